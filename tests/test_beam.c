/* The beam element against Euler–Bernoulli theory (cantilever), statics to
 * round-off, and rigid-body modes of a free element. */
#include "dm_test.h"

#include <lapacke.h>
#include <stdlib.h>

#include "dm_beam.h"
#include "dm_reference.h"

#define NEL 8
#define NDOF (6 * NEL) /* node 0 clamped */

typedef struct {
    dm_member member;
    dm_beam_props p;
    double L;
} cantilever;

static void make_cantilever(cantilever *c)
{
    memset(c, 0, sizeof *c);
    c->member.shape = DM_SECTION_RECT;
    c->member.b_m = 0.02; /* local y */
    c->member.h_m = 0.03; /* local z: Iy != Iz separates the two planes */
    c->member.youngs_pa = 210e9;
    c->member.shear_pa = 210e9 / 2.6;
    c->member.density_kgm3 = 7850;
    assert_int_equal(dm_section_compute(&c->member, &c->member.section, NULL), 0);
    dm_beam_props_of(&c->member, &c->p);
    c->L = 1.0;
}

/* Assemble K, M (column-major, NDOF x NDOF) of NEL elements along x. */
static void assemble(const cantilever *c, double *K, double *M)
{
    double Ke[144], Me[144], h = c->L / NEL;
    memset(K, 0, sizeof(double) * NDOF * NDOF);
    memset(M, 0, sizeof(double) * NDOF * NDOF);
    dm_beam_stiffness(&c->p, h, Ke);
    dm_beam_mass(&c->p, h, Me);
    for (int e = 0; e < NEL; e++)
        for (int a = 0; a < 12; a++)
            for (int b = 0; b < 12; b++) {
                int ga = 6 * e + a - 6, gb = 6 * e + b - 6; /* drop node 0 */
                if (ga < 0 || gb < 0)
                    continue;
                K[gb * NDOF + ga] += Ke[a * 12 + b];
                M[gb * NDOF + ga] += Me[a * 12 + b];
            }
}

/* Family of a mode: which local DOF group holds most of its M-energy:
 * 0 axial (u), 1 x-y bending (v, tz), 2 x-z bending (w, ty), 3 torsion. */
static int family_of(const double *phi, const double *M)
{
    static const int group[6] = {0, 1, 2, 3, 2, 1};
    double e[4] = {0};
    for (int a = 0; a < NDOF; a++) {
        double Mphi = 0;
        for (int b = 0; b < NDOF; b++)
            Mphi += M[b * NDOF + a] * phi[b];
        e[group[a % 6]] += phi[a] * Mphi;
    }
    int best = 0;
    for (int g = 1; g < 4; g++)
        if (e[g] > e[best])
            best = g;
    return best;
}

static void cantilever_frequencies(void **state)
{
    (void)state;
    cantilever c;
    make_cantilever(&c);
    double *K = malloc(sizeof(double) * NDOF * NDOF), *M = malloc(sizeof(double) * NDOF * NDOF);
    double *Mcopy = malloc(sizeof(double) * NDOF * NDOF), w[NDOF];
    assemble(&c, K, M);
    memcpy(Mcopy, M, sizeof(double) * NDOF * NDOF);
    assert_int_equal(LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'V', 'U', NDOF, K, NDOF, Mcopy, NDOF, w), 0);

    const double beta[3] = {1.8751040687, 4.6940911330, 7.8547574382};
    double L = c.L, found[4][3];
    int count[4] = {0};
    assemble(&c, Mcopy, M); /* fresh M for the energy split */
    for (int j = 0; j < NDOF; j++) {
        int f = family_of(K + (size_t)j * NDOF, M);
        if (count[f] < 3)
            found[f][count[f]++] = sqrt(w[j]) / (2 * M_PI);
    }
    /* Bending: f = (beta L)^2 / (2 pi L^2) sqrt(EI / rho A); 0.5 % at 8 elements. */
    for (int k = 0; k < 3; k++) {
        double fz = beta[k] * beta[k] / (2 * M_PI * L * L) * sqrt(c.p.EIz / c.p.rhoA);
        double fy = beta[k] * beta[k] / (2 * M_PI * L * L) * sqrt(c.p.EIy / c.p.rhoA);
        assert_rel(found[1][k], fz, 5e-3, "x-y bending mode %d vs Euler-Bernoulli", k + 1);
        assert_rel(found[2][k], fy, 5e-3, "x-z bending mode %d vs Euler-Bernoulli", k + 1);
    }
    /* Axial and torsion, fixed-free rod: f1 = 1/(4L) sqrt(EA/rhoA), sqrt(GJ/rhoIp).
     * Linear elements with consistent mass overestimate by ~(kh)^2/24 = 0.16 %. */
    assert_rel(found[0][0], sqrt(c.p.EA / c.p.rhoA) / (4 * L), 5e-3, "first axial mode");
    assert_rel(found[3][0], sqrt(c.p.GJ / c.p.rhoIp) / (4 * L), 5e-3, "first torsional mode");
    /* Consistent mass overestimates frequencies: the FE value is an upper bound. */
    assert_true(found[1][0] > beta[0] * beta[0] / (2 * M_PI) * sqrt(c.p.EIz / c.p.rhoA));
    free(K);
    free(M);
    free(Mcopy);
}

static void cantilever_static_tip(void **state)
{
    (void)state;
    cantilever c;
    make_cantilever(&c);
    double *K = malloc(sizeof(double) * NDOF * NDOF), *M = malloc(sizeof(double) * NDOF * NDOF);
    double F[NDOF * 4] = {0};
    assemble(&c, K, M);
    dm_solve_bound sb;
    assert_int_equal(dm_solve_bound_init(K, NDOF, 1, &sb), 0);
    int tip = NDOF - 6;
    const double P = 1000.0, T = 50.0;
    F[0 * NDOF + tip + 1] = P; /* tip force along y: bends with EIz */
    F[1 * NDOF + tip + 2] = P; /* along z: EIy */
    F[2 * NDOF + tip + 0] = P; /* axial */
    F[3 * NDOF + tip + 3] = T; /* torque */
    assert_int_equal(LAPACKE_dposv(LAPACK_COL_MAJOR, 'U', NDOF, 4, K, NDOF, F, NDOF), 0);
    double L3 = c.L * c.L * c.L;
    /* Hermite beams are exact for end loads: round-off only, dposv's (LUG
     * §4.4, equilibrated: dm_reference.h) and a few eps of the formula's
     * own (formerly 1e-10 relative, a constant). */
#define TIP(col, dof, expect, what)                                                        \
    assert_abs(F[(col) * NDOF + tip + (dof)], (expect),                                     \
               dm_solve_bound_at(&sb, F + (col) * NDOF, tip + (dof)) +                      \
                   4 * DBL_EPSILON * fabs(expect),                                          \
               what)
    TIP(0, 1, P * L3 / (3 * c.p.EIz), "tip deflection v = PL^3/3EIz");
    TIP(1, 2, P * L3 / (3 * c.p.EIy), "tip deflection w = PL^3/3EIy");
    TIP(0, 5, P * c.L * c.L / (2 * c.p.EIz), "tip slope PL^2/2EI");
    TIP(2, 0, P * c.L / c.p.EA, "axial PL/EA");
    TIP(3, 3, T * c.L / c.p.GJ, "twist TL/GJ");
#undef TIP
    dm_solve_bound_free(&sb);
    free(K);
    free(M);
}

/* T' K T for an arbitrary frame, and rigid motions u = a + w x x give no force. */
static void free_element_rigid_modes(void **state)
{
    (void)state;
    cantilever c;
    make_cantilever(&c);
    double Kl[144], lam[9], Kg[144] = {0}, w[12];
    const double axis[3] = {0.3, -0.5, 0.8}, hint[3] = {-1.0, 0.2, 0.1};
    double L = sqrt(0.09 + 0.25 + 0.64);
    dm_beam_stiffness(&c.p, L, Kl);
    assert_int_equal(dm_beam_frame(axis, hint, lam), 0);
    for (int a = 0; a < 12; a++) /* Kg = T' Kl T, T = blockdiag(lam) */
        for (int b = 0; b < 12; b++) {
            double s = 0;
            for (int p = 0; p < 3; p++)
                for (int q = 0; q < 3; q++)
                    s += lam[3 * p + a % 3] * Kl[(3 * (a / 3) + p) * 12 + 3 * (b / 3) + q] *
                         lam[3 * q + b % 3];
            Kg[a * 12 + b] = s;
        }
    const double x1[3] = {0.1, 0.2, 0.3}, tr[3] = {1e-3, -2e-3, 5e-4}, om[3] = {2e-3, 1e-3, -3e-3};
    double u[12];
    for (int nd = 0; nd < 2; nd++) {
        double x[3];
        for (int k = 0; k < 3; k++)
            x[k] = x1[k] + nd * axis[k];
        double oxx[3] = {om[1] * x[2] - om[2] * x[1], om[2] * x[0] - om[0] * x[2],
                         om[0] * x[1] - om[1] * x[0]};
        for (int k = 0; k < 3; k++) {
            u[6 * nd + k] = tr[k] + oxx[k];
            u[6 * nd + 3 + k] = om[k];
        }
    }
    double kmax = 0;
    for (int a = 0; a < 144; a++)
        kmax = fmax(kmax, fabs(Kg[a]));
    for (int a = 0; a < 12; a++) {
        double f = 0;
        for (int b = 0; b < 12; b++)
            f += Kg[a * 12 + b] * u[b];
        assert_abs(f, 0.0, 1e-12 * kmax, "force from rigid motion, row %d", a);
    }
    assert_int_equal(LAPACKE_dsyev(LAPACK_COL_MAJOR, 'N', 'U', 12, Kg, 12, w), 0);
    int zeros = 0;
    for (int j = 0; j < 12; j++)
        zeros += fabs(w[j]) < 1e-10 * w[11];
    assert_int_equal(zeros, 6);
    assert_true(w[6] > 1e-6 * w[11]);
}

static void element_matrices_symmetric_and_mass_total(void **state)
{
    (void)state;
    cantilever c;
    make_cantilever(&c);
    double K[144], M[144], G[144], L = 0.37;
    dm_beam_stiffness(&c.p, L, K);
    dm_beam_mass(&c.p, L, M);
    dm_beam_geometric(&c.p, 1234.0, L, G);
    for (int a = 0; a < 12; a++)
        for (int b = 0; b < 12; b++) {
            assert_abs(K[a * 12 + b], K[b * 12 + a], 0, "K symmetric");
            assert_abs(M[a * 12 + b], M[b * 12 + a], 0, "M symmetric");
            assert_abs(G[a * 12 + b], G[b * 12 + a], 0, "KG symmetric");
        }
    /* A rigid translation along each axis carries the whole mass rho*A*L. */
    for (int d = 0; d < 3; d++) {
        double total = 0;
        for (int a = 0; a < 12; a++)
            total += M[a * 12 + d] + M[a * 12 + 6 + d];
        assert_rel(total, c.p.rhoA * L, 1e-14, "translational mass along %d", d);
    }
}

static void sections_match_formulas(void **state)
{
    (void)state;
    dm_member m = {0};
    dm_section s;
    m.shape = DM_SECTION_TUBE;
    m.diameter_m = 0.016;
    m.inner_diameter_m = 0.014;
    assert_int_equal(dm_section_compute(&m, &s, NULL), 0);
    assert_rel(s.area_m2, M_PI * (0.016 * 0.016 - 0.014 * 0.014) / 4, 1e-14, "tube area");
    assert_rel(s.j_m4, s.ip_m4, 1e-14, "tube J == Ip");
    m.shape = DM_SECTION_RECT;
    m.b_m = 0.045;
    m.h_m = 0.060;
    assert_int_equal(dm_section_compute(&m, &s, NULL), 0);
    assert_rel(s.iy_m4, 0.045 * pow(0.060, 3) / 12, 1e-14, "Iy = b h^3/12 (h along z)");
    assert_rel(s.iz_m4, 0.060 * pow(0.045, 3) / 12, 1e-14, "Iz = h b^3/12");
    double q = 0.045 / 0.060;
    assert_rel(s.j_m4, 0.060 * pow(0.045, 3) * (1.0 / 3 - 0.21 * q * (1 - pow(q, 4) / 12)), 1e-14,
               "rect torsion constant (long side s, short side t)");
    m.shape = DM_SECTION_SQUARE;
    m.diameter_m = 0.02;
    assert_int_equal(dm_section_compute(&m, &s, NULL), 0);
    assert_rel(s.j_m4, pow(0.02, 4) * (1.0 / 3 - 0.21 * (1 - 1.0 / 12)), 1e-14, "square J = 0.1406 a^4");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(cantilever_frequencies),
        cmocka_unit_test(cantilever_static_tip),
        cmocka_unit_test(free_element_rigid_modes),
        cmocka_unit_test(element_matrices_symmetric_and_mass_total),
        cmocka_unit_test(sections_match_formulas),
    };
    return cmocka_run_group_tests_name("beam", tests, NULL, NULL);
}
