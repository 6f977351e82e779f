/* Member bases (dm_members, issue 39): the members' matrices, built once
 * in their own frames, rebuild the model's M and K at random poses; a
 * robot whose member matrices follow the pose (geometric stiffness, joint
 * clearance) is refused; the fixed-interface modes and residual vectors
 * are what they claim, the lowest against the simply supported beam. */
#include "dm_test.h"

#include <stdlib.h>

#include "dm_members.h"
#include "dm_members_fixtures.h"

/* max_r |y1 - y2|_r / (|X| |U|)_r: X U from the model against Q (X from
 * the members) Q' U, relative to each row's sum of absolute products. */
static double rebuild_error(const dm_model *md, const dm_members *ms, const dm_members_pose *mp,
                            char which, const double *U)
{
    int n = md->n;
    double *y1 = malloc(sizeof(double) * n), *y2 = malloc(sizeof(double) * n);
    double *z = malloc(sizeof(double) * n), *w = malloc(sizeof(double) * n);
    double *X = malloc(sizeof(double) * n * n), worst = 0;
    assert_true(y1 && y2 && z && w && X);
    dm_model_dense(md, which == 'K' ? X : NULL, which == 'M' ? X : NULL);
    (which == 'K' ? dm_model_mult_K : dm_model_mult_M)(md, U, 1, y1);
    dm_members_gather(ms, mp, U, z);
    assert_int_equal(dm_members_mult(ms, mp, which, z, w), 0);
    dm_members_scatter(ms, mp, w, y2);
    for (int r = 0; r < n; r++) {
        double scale = 0;
        for (int c = 0; c < n; c++)
            scale += fabs(X[(size_t)c * n + r] * U[c]);
        double e = fabs(y1[r] - y2[r]) / scale;
        worst = e > worst ? e : worst;
    }
    free(y1);
    free(y2);
    free(z);
    free(w);
    free(X);
    return worst;
}

/* The cache is built at home; at random poses the model's K and M (each
 * rebuilt from its elements) equal the members' matrices turned to the
 * pose, to 1e-14 of each row's |X| |U| (the rotations and sums add a few
 * ulps; 1e-14 is 90 of them, and a member matrix that moved with the pose
 * by 1e-6, as under geometric stiffness, fails it by eight decades). The
 * gather and scatter are each other's inverse (Q orthogonal). */
static void members_rebuild_the_model_at_random_poses(void **state)
{
    (void)state;
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    const int meshes[3][2] = {{1, 1}, {4, 4}, {8, 8}};
    dm_rng rng = {12345};
    double worst = 0;
    for (int r = 0; r < 3; r++)
        for (int me = 0; me < 3; me++)
            for (int fx = 0; fx < 2; fx++) {
                dm_robot rb;
                dm_pose pose;
                dm_members_pose mp;
                load(&rb, presets[r], fx ? ALL_EFFECTS : NULL);
                dm_model *md = dm_model_alloc(&rb, meshes[me][0], meshes[me][1], NULL);
                assert_non_null(md);
                assert_int_equal(dm_kin_pose(&rb, rb.home_m, &pose, NULL), 0);
                assert_int_equal(dm_model_build(md, &pose, NULL), 0);
                dm_members *ms = dm_members_build(md, 1e8, NULL);
                assert_non_null(ms);
                int n = md->n;
                double *U = malloc(sizeof(double) * n), *z = malloc(sizeof(double) * n);
                double *V = malloc(sizeof(double) * n);
                for (int t = 0; t < 4; t++) {
                    random_pose(&rb, &rng, &pose);
                    assert_int_equal(dm_model_build(md, &pose, NULL), 0);
                    assert_int_equal(dm_members_at(ms, &pose, &mp, NULL), 0);
                    for (int k = 0; k < n; k++)
                        U[k] = dm_rng_normal(&rng);
                    double eK = rebuild_error(md, ms, &mp, 'K', U);
                    double eM = rebuild_error(md, ms, &mp, 'M', U);
                    if (eK > 1e-14 || eM > 1e-14)
                        print_error("%s mesh %d,%d effects %d: K %.2e M %.2e\n", presets[r],
                                    meshes[me][0], meshes[me][1], fx, eK, eM);
                    assert_true(eK <= 1e-14 && eM <= 1e-14);
                    worst = fmax(worst, fmax(eK, eM));
                    dm_members_gather(ms, &mp, U, z);
                    dm_members_scatter(ms, &mp, z, V);
                    for (int k = 0; k < n; k++)
                        assert_abs(V[k], U[k], 1e-15 * (1 + fabs(U[k])), "Q Q' U");
                }
                free(U);
                free(z);
                free(V);
                dm_members_free(ms);
                dm_model_free(md);
            }
    print_message("K, M rebuilt from the members: worst %.2e of |X| |U|\n", worst);
}

/* Geometric stiffness: the members' K follows the pose's axial forces, so
 * the cache refuses the robot (with the reason), and the refusal is real:
 * a cache of the same robot without K_G misses the model's K at a pose by
 * far more than the 1e-14 it holds otherwise. */
static void geometric_stiffness_is_refused(void **state)
{
    (void)state;
    const char *on[] = {"effects.geometric_stiffness=on", NULL};
    dm_robot rb, off;
    dm_pose pose;
    dm_error err;
    dm_members_pose mp;
    dm_rng rng = {7};
    load(&rb, "zheng2017", on);
    load(&off, "zheng2017", NULL);
    dm_model *md = dm_model_alloc(&rb, 4, 4, NULL), *mo = dm_model_alloc(&off, 4, 4, NULL);
    assert_true(md && mo);
    random_pose(&rb, &rng, &pose);
    assert_int_equal(dm_model_build(md, &pose, NULL), 0);
    assert_int_equal(dm_model_build(mo, &pose, NULL), 0);
    assert_int_equal(dm_members_serves(&rb, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "geometric stiffness"));
    assert_null(dm_members_build(md, 1e8, &err));
    assert_int_equal(err.code, DM_EINVAL);
    dm_members *ms = dm_members_build(mo, 1e8, NULL);
    assert_non_null(ms);
    assert_int_equal(dm_members_at(ms, &pose, &mp, NULL), 0);
    double *U = malloc(sizeof(double) * md->n);
    for (int k = 0; k < md->n; k++)
        U[k] = dm_rng_normal(&rng);
    double e = rebuild_error(md, ms, &mp, 'K', U);
    print_message("geometric stiffness: K from the K_G-free members off by %.2e\n", e);
    assert_true(e > 1e-10);
    assert_true(rebuild_error(mo, ms, &mp, 'K', U) <= 1e-14);
    free(U);
    dm_members_free(ms);
    dm_model_free(md);
    dm_model_free(mo);
}

/* A rod whose length is not the cache's (joint clearance flips a rod's
 * effective length with the sign of its force; here the pose is edited
 * by 0.1 mm, 2e-4 of the rod): dm_members_at refuses and names it. */
static void changed_length_is_refused(void **state)
{
    (void)state;
    const char *play[] = {"effects.clearance=0.0005", NULL};
    dm_robot rb;
    dm_pose pose;
    dm_error err;
    dm_members_pose mp;
    load(&rb, "chen2018", play);
    dm_model *md = dm_model_alloc(&rb, 2, 2, NULL);
    assert_non_null(md);
    assert_int_equal(dm_kin_pose(&rb, rb.home_m, &pose, NULL), 0);
    assert_int_equal(dm_model_build(md, &pose, NULL), 0);
    dm_members *ms = dm_members_build(md, 1e8, NULL);
    assert_non_null(ms);
    pose.C[1][2] += 1e-4; /* chain 1's platform joint 0.1 mm off: its rods' lengths change */
    assert_int_equal(dm_members_at(ms, &pose, &mp, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "chain 1's rod"));
    dm_members_free(ms);
    dm_model_free(md);
}

/* Phi' M_ii Phi = I and Phi' K_ii Phi = Lambda (LAPACK's dsygvd: 1e-12 of
 * the largest entry), the residual vectors M_ii-orthonormal, M_ii-orthogonal
 * to the kept modes and K_ii-orthogonal among themselves (kres, ascending),
 * nkeep and nres as the rule says. */
static void check_basis(const dm_member_basis *mb, double cut)
{
    int ni = mb->ni, nb = mb->nb, nm = mb->nm;
    const double *Mii = mb->M + (size_t)nb * nm + nb, *Kii = mb->K + (size_t)nb * nm + nb;
    int ntot = ni + mb->nres;
    for (int a = 0; a < ntot; a++)
        for (int b = 0; b <= a; b++) {
            const double *x = a < ni ? mb->Phi + (size_t)a * ni : mb->R + (size_t)(a - ni) * ni;
            const double *y = b < ni ? mb->Phi + (size_t)b * ni : mb->R + (size_t)(b - ni) * ni;
            if (a >= ni && b < ni && b >= mb->nkeep)
                continue; /* residual vectors live in the dropped modes' span */
            double m = 0, k = 0;
            for (int r = 0; r < ni; r++)
                for (int c = 0; c < ni; c++) {
                    m += x[r] * Mii[(size_t)c * nm + r] * y[c];
                    k += x[r] * Kii[(size_t)c * nm + r] * y[c];
                }
            assert_abs(m, a == b, 1e-12, "x' M y, (%d, %d)", a, b);
            if (a < ni)
                assert_abs(k, a == b ? mb->lambda[a] : 0, 1e-12 * mb->lambda[ni - 1], "x' K y");
            else if (b >= ni) /* K_ii-orthogonal among themselves, kres their stiffness */
                assert_abs(k, a == b ? mb->kres[a - ni] : 0, 1e-12 * mb->lambda[ni - 1],
                           "r' K r, (%d, %d)", a - ni, b - ni);
        }
    for (int j = 0; j < ni; j++)
        assert_true((j < mb->nkeep) == (mb->lambda[j] <= cut));
    for (int j = 1; j < mb->nres; j++)
        assert_true(mb->kres[j - 1] <= mb->kres[j]);
    /* one per boundary DOF at most, and an arm's own rotation */
    int most = nb + (mb->kind == DM_MEMBER_ARM);
    assert_true(mb->nres <= most && (mb->nkeep == ni) == (mb->nres == 0));
}

/* A rod clamped at its boundary (its ends' translations) with its ends
 * free to turn about its local y and z is simply supported in bending:
 * lambda_1 = (pi/L)^4 EI_min / rhoA (Euler-Bernoulli; the element has no
 * rotary inertia either). Hermite elements with consistent mass converge
 * from above as h^4: the error at nb = 8 is below 1e-4 and at least 12
 * times smaller than at nb = 4 (16 in the limit). */
static void fixed_interface_modes(void **state)
{
    (void)state;
    double err[2];
    for (int k = 0; k < 2; k++) {
        dm_robot rb;
        dm_pose pose;
        int nb = 4 << k;
        load(&rb, "chen2018", NULL);
        dm_model *md = dm_model_alloc(&rb, 4, nb, NULL);
        assert_non_null(md);
        assert_int_equal(dm_kin_pose(&rb, rb.home_m, &pose, NULL), 0);
        assert_int_equal(dm_model_build(md, &pose, NULL), 0);
        const double cut = 1e7;
        dm_members *ms = dm_members_build(md, cut, NULL);
        assert_non_null(ms);
        for (int m = 0; m < DM_MEMBERS_N; m++)
            check_basis(&ms->member[m], cut);
        const dm_member_basis *rod = &ms->member[1];
        const dm_beam_props *p = &md->props[DM_MEMBER_ROD];
        double L = rod->element_m * rod->nel, EI = p->EIy < p->EIz ? p->EIy : p->EIz;
        double exact = pow(M_PI / L, 4) * EI / p->rhoA;
        err[k] = (rod->lambda[0] - exact) / exact;
        print_message("rod nb=%d: lambda_1 %.12g, simply supported %.12g, rel err %.2e\n", nb,
                      rod->lambda[0], exact, err[k]);
        assert_true(err[k] > -1e-12);
        dm_members_free(ms);
        dm_model_free(md);
    }
    assert_true(err[1] < 1e-4 && err[1] * 12 < err[0]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(members_rebuild_the_model_at_random_poses),
        cmocka_unit_test(geometric_stiffness_is_refused),
        cmocka_unit_test(changed_length_is_refused),
        cmocka_unit_test(fixed_interface_modes),
    };
    return cmocka_run_group_tests_name("members", tests, NULL, NULL);
}
