/* Model extensions (docs/model.md §6), each against its own physics: very stiff
 * springs recover the clamped baseline, masses lower every frequency and
 * add their weight exactly, geometric stiffness follows Euler buckling. */
#include "dm_test.h"

#include <lapacke.h>
#include <stdlib.h>
#include <unistd.h>

#include "dm_analysis.h"
#include "dm_beam.h"
#include "dm_effects.h"
#include "dm_sweep.h"

#define K10 10

typedef struct {
    double f[K10], err[6], C[36];
    int n;
} outputs;

static void analyse(const char *preset, const char *const *sets, const double *P, outputs *o)
{
    dm_robot rb;
    dm_error err;
    dm_pose_result res;
    assert_int_equal(dm_robot_load(preset, &rb, NULL), 0);
    for (int i = 0; sets && sets[i]; i++) {
        int rc = dm_robot_set(&rb, sets[i], &err);
        if (rc)
            print_error("%s\n", err.msg);
        assert_int_equal(rc, 0);
    }
    dm_analysis *an = dm_analysis_alloc(&rb, 2, 2, K10, DM_EIGEN_PARTIAL, NULL);
    assert_non_null(an);
    int rc = dm_analysis_run(an, P ? P : rb.home_m, K10, &res, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    memcpy(o->f, res.modes->freq_hz, sizeof o->f);
    memcpy(o->err, res.static_error, sizeof o->err);
    memcpy(o->C, res.compliance, sizeof o->C);
    o->n = an->model->n;
    dm_analysis_free(an);
}

static const double POSE[3] = {0.06, -0.04, -0.52};

static void stiff_springs_recover_the_baseline(void **state)
{
    (void)state;
    outputs base, o;
    analyse("chen2018", NULL, POSE, &base);
    /* Springs 1e5-1e6 times the structure's own stiffness; much stiffer ones
     * only add round-off: an eigen solve is accurate to eps * lambda_max and
     * a stiff spring on a light DOF makes lambda_max huge. */
    const char *act[] = {"effects.actuator_stiffness=1e10", NULL};
    const char *bas[] = {"effects.base_stiffness=1e13,1e13,1e13", NULL};
    const char *joi[] = {"effects.joint_stiffness=1e13", NULL};
    const char *const *cases[] = {act, bas, joi};
    const int extra[] = {3, 9, 36}; /* DOFs each extension adds */
    for (int c = 0; c < 3; c++) {
        analyse("chen2018", cases[c], POSE, &o);
        assert_int_equal(o.n, base.n + extra[c]);
        /* series springs: relative change ~ structure stiffness / spring ~ 1e-5 */
        for (int j = 0; j < K10; j++) /* round-off here is ~1e-6 (eps * lambda_max) */
            assert_rel(o.f[j], base.f[j], 1e-5, "%s: f%d", cases[c][0], j + 1);
        for (int k = 0; k < 3; k++)
            assert_abs(o.err[k], base.err[k], 1e-5 * fabs(base.err[2]), "%s: error %d", cases[c][0], k);
    }
}

static void soft_springs_lower_frequencies(void **state)
{
    (void)state;
    outputs base, o;
    analyse("chen2018", NULL, POSE, &base);
    const char *act[] = {"effects.actuator_stiffness=2000", NULL};
    const char *bas[] = {"effects.base_stiffness=2e5,2e5,5e5", NULL};
    const char *joi[] = {"effects.joint_stiffness=1e6", NULL};
    const char *const *cases[] = {act, bas, joi};
    for (int c = 0; c < 3; c++) {
        analyse("chen2018", cases[c], POSE, &o);
        for (int j = 0; j < K10; j++) /* adding compliance can only lower them */
            assert_true(o.f[j] <= base.f[j] * (1 + 1e-12));
        assert_true(o.f[0] < 0.99 * base.f[0]);
        assert_true(fabs(o.err[2]) > fabs(base.err[2]));
    }
}

/* One softer base under chain 0 breaks the 120-degree symmetry: the x/y mode
 * pair at the centre splits (Zheng's larger errors along one axis). */
static void per_chain_base_breaks_symmetry(void **state)
{
    (void)state;
    outputs sym, asym;
    const char *s1[] = {"effects.base_stiffness=1e6,1e6,1e6", NULL};
    const char *s2[] = {"effects.base_stiffness=1e6,1e6,1e6", "effects.base_stiffness_0=3e5,3e5,3e5", NULL};
    analyse("chen2018", s1, NULL, &sym);
    analyse("chen2018", s2, NULL, &asym);
    assert_rel(sym.f[2], sym.f[1], 1e-8, "symmetric base keeps the pair");
    assert_true(fabs(asym.f[2] - asym.f[1]) > 1e-3 * asym.f[1]);
    assert_true(fabs(asym.err[0]) + fabs(asym.err[1]) > 1e-3 * fabs(asym.err[2]));
}

/* A point payload adds exactly its weight (and its moment about P) through
 * the unchanged compliance, and lowers every frequency. */
static void payload_weight_and_frequencies(void **state)
{
    (void)state;
    outputs base, o, off;
    analyse("zheng2017", NULL, POSE, &base);
    const char *p[] = {"effects.payload_mass=2.0", NULL};
    const char *po[] = {"effects.payload_mass=2.0", "effects.payload_offset=0.03,-0.02,-0.05", NULL};
    analyse("zheng2017", p, POSE, &o);
    analyse("zheng2017", po, POSE, &off);
    double W[6] = {0, 0, 2.0 * -9.80665, 0, 0, 0}, Wo[6];
    const double r[3] = {0.03, -0.02, -0.05};
    memcpy(Wo, W, sizeof W);
    Wo[3] = r[1] * W[2] - r[2] * W[1]; /* r x F */
    Wo[4] = r[2] * W[0] - r[0] * W[2];
    Wo[5] = r[0] * W[1] - r[1] * W[0];
    for (int k = 0; k < 6; k++) {
        double d = 0, dof = 0;
        for (int j = 0; j < 6; j++) {
            d += base.C[6 * j + k] * W[j];
            dof += base.C[6 * j + k] * Wo[j];
        }
        assert_abs(o.err[k] - base.err[k], d, 1e-9 * fabs(d) + 1e-15, "payload at P, comp %d", k);
        assert_abs(off.err[k] - base.err[k], dof, 1e-9 * fabs(dof) + 1e-15, "offset payload, comp %d", k);
    }
    for (int j = 0; j < K10; j++)
        assert_true(o.f[j] < base.f[j]);
}

static void elbow_mass_is_linear_and_lowers_frequencies(void **state)
{
    (void)state;
    outputs base, m1, m2;
    const char *a[] = {"effects.elbow_mass=0.3", NULL};
    const char *b[] = {"effects.elbow_mass=0.6", NULL};
    analyse("han2011", NULL, NULL, &base);
    analyse("han2011", a, NULL, &m1);
    analyse("han2011", b, NULL, &m2);
    for (int k = 0; k < 3; k++)
        assert_abs(m2.err[k] - base.err[k], 2 * (m1.err[k] - base.err[k]), 1e-9 * fabs(base.err[2]),
                   "weight linear in the mass, comp %d", k);
    /* Rayleigh: added mass never raises a frequency. A mode in which the
     * elbows stand still (han2011's mode 10 at the centre, a rod mode) keeps
     * its frequency, equal to round-off: never higher by more than 1e-11,
     * above what two subspace solves may differ by (the rounding of their
     * projections, n eps theta_q / lambda_10 ~ 1e-13 relative, as in
     * test_modal.c's ritz_error; 4e-16 on every OpenBLAS kernel set), and
     * every mode whose elbows move is strictly lower. */
    int lowered = 0;
    for (int j = 0; j < K10; j++) {
        assert_true(m1.f[j] <= base.f[j] * (1 + 1e-11) && m2.f[j] <= m1.f[j] * (1 + 1e-11));
        lowered += m1.f[j] < base.f[j] * (1 - 1e-6) && m2.f[j] < m1.f[j] * (1 - 1e-6);
    }
    assert_true(lowered >= K10 - 1);
    /* a hanging robot sags more (Han's, platform above the base, rises
     * slightly: the loaded elbows push its rods up) */
    analyse("chen2018", NULL, NULL, &base);
    analyse("chen2018", a, NULL, &m1);
    assert_true(m1.err[2] < base.err[2]);
}

/* Pinned-pinned beam, 8 elements: omega^2(N) = omega_0^2 (1 + N/N_cr) for
 * the first bending mode, and K + K_G(-N_cr) is singular (Euler). */
#define NE 8
#define ND (6 * (NE + 1))

static void assemble_beam(const dm_beam_props *p, double L, double N, double *K, double *M)
{
    double Ke[144], Me[144], Ge[144], h = L / NE;
    memset(K, 0, sizeof(double) * ND * ND);
    memset(M, 0, sizeof(double) * ND * ND);
    dm_beam_stiffness(p, h, Ke);
    dm_beam_mass(p, h, Me);
    dm_beam_geometric(p, N, h, Ge);
    for (int e = 0; e < NE; e++)
        for (int a = 0; a < 12; a++)
            for (int b = 0; b < 12; b++) {
                int ga = 6 * e + a, gb = 6 * e + b;
                K[gb * ND + ga] += Ke[a * 12 + b] + Ge[a * 12 + b];
                M[gb * ND + ga] += Me[a * 12 + b];
            }
}

/* Keep DOFs that are free: pins fix u, v, w, theta_x at node 0 and v, w at
 * the last node. Returns the reduced size. */
static int reduce(const double *A, double *R)
{
    int keep[ND], m = 0;
    for (int d = 0; d < ND; d++) {
        int node = d / 6, c = d % 6;
        int fixed = (node == 0 && c <= 3) || (node == NE && (c == 1 || c == 2));
        if (!fixed)
            keep[m++] = d;
    }
    for (int a = 0; a < m; a++)
        for (int b = 0; b < m; b++)
            R[b * m + a] = A[keep[b] * ND + keep[a]];
    return m;
}

static double lowest(const dm_beam_props *p, double L, double N)
{
    static double K[ND * ND], M[ND * ND], Kr[ND * ND], Mr[ND * ND];
    double w[ND];
    assemble_beam(p, L, N, K, M);
    int m = reduce(K, Kr);
    reduce(M, Mr);
    assert_int_equal(LAPACKE_dsygv(LAPACK_COL_MAJOR, 1, 'N', 'U', m, Kr, m, Mr, m, w), 0);
    return w[0];
}

static void geometric_stiffness_follows_euler(void **state)
{
    (void)state;
    dm_member mem = {0};
    mem.shape = DM_SECTION_RECT;
    mem.b_m = 0.01;  /* bends first about z (Iz smallest) */
    mem.h_m = 0.02;
    mem.youngs_pa = 210e9;
    mem.shear_pa = 80e9;
    mem.density_kgm3 = 7850;
    assert_int_equal(dm_section_compute(&mem, &mem.section, NULL), 0);
    dm_beam_props p;
    dm_beam_props_of(&mem, &p);
    double L = 1.0, Ncr = M_PI * M_PI * p.EIz / (L * L), w0 = lowest(&p, L, 0.0);
    for (int s = -1; s <= 1; s += 2) {
        double N = 0.5 * s * Ncr;
        /* 1 % at 8 elements: consistent K_G is accurate to O(h^2) */
        assert_rel(lowest(&p, L, N) / w0, 1.0 + N / Ncr, 1e-2, "omega^2 ratio at N = %+.1f Ncr", N / Ncr);
    }
    assert_true(lowest(&p, L, 0.5 * Ncr) > w0);  /* tension stiffens */
    assert_true(lowest(&p, L, -0.5 * Ncr) < w0); /* compression softens */
    /* buckling: the lowest eigenvalue crosses zero within 0.5 % of Euler's load */
    assert_true(lowest(&p, L, -0.995 * Ncr) > 0);
    assert_true(lowest(&p, L, -1.005 * Ncr) < 0);
}

/* Hanging robots (chen2018) pull their rods: stress stiffening raises the
 * rod-bending frequencies. Han's platform sits above the base and pushes
 * its rods: they soften. */
static void geometric_stiffness_on_robots(void **state)
{
    (void)state;
    const char *on[] = {"effects.geometric_stiffness=on", NULL};
    outputs base, o;
    double up = 0, down = 0;
    analyse("chen2018", NULL, NULL, &base);
    analyse("chen2018", on, NULL, &o);
    for (int j = 0; j < K10; j++)
        up += o.f[j] - base.f[j];
    assert_true(up > 0);
    analyse("han2011", NULL, NULL, &base);
    analyse("han2011", on, NULL, &o);
    for (int j = 0; j < K10; j++)
        down += o.f[j] - base.f[j];
    assert_true(down < 0);
}

/* ---- the effect table, walked row by row --------------------------------------
 *
 * Every row with a robot-file key set to a non-zero value (its typical
 * magnitude; a per-chain key a different one on each chain, signed where
 * the key takes signs, so that a chain or sign mix-up shows) must survive
 * the robot file's round trip, come out the same from the text and the
 * typed setter, and change a sweep's fingerprint. A row that the writer,
 * a setter or dm_effects_any missed fails here. */

/* The row's numbers (degrees for degree keys, as both setters take them)
 * and their text. */
static int row_value(const dm_effect *e, double v[3], char *text, size_t n)
{
    if (e->value == DM_EFFECTS_ONOFF) {
        v[0] = 1;
        snprintf(text, n, "on");
        return 1;
    }
    static const double each[3] = {1.0, -1.5, 2.0};
    int three = e->value >= DM_EFFECTS_VEC3;
    for (int k = 0; k < 3; k++)
        v[k] = e->typical * (e->value == DM_EFFECTS_VEC3 || e->value == DM_EFFECTS_VEC3_DEG
                                 ? each[k]
                                 : fabs(each[k]));
    if (three)
        snprintf(text, n, "%.17g,%.17g,%.17g", v[0], v[1], v[2]);
    else
        snprintf(text, n, "%.17g", v[0]);
    return three ? 3 : 1;
}

/* The robot with one row set by the text setter. */
static void set_row_text(dm_robot *rb, const dm_effect *e)
{
    double v[3];
    char text[200], assign[300];
    dm_error err;
    row_value(e, v, text, sizeof text);
    snprintf(assign, sizeof assign, "%s.%s=%s", e->section, e->key, text);
    int rc = dm_robot_set(rb, assign, &err);
    if (rc)
        print_error("%s: %s\n", assign, err.msg);
    assert_int_equal(rc, 0);
}

static void round_trip(const dm_robot *rb, const char *what)
{
    char *text = NULL;
    size_t len = 0;
    FILE *mem = open_memstream(&text, &len);
    assert_non_null(mem);
    assert_int_equal(dm_robot_write(rb, mem), 0);
    assert_int_equal(fclose(mem), 0);
    dm_robot back;
    dm_error err;
    int rc = dm_robot_parse_string(text, rb->source, &back, &err);
    if (rc)
        print_error("%s: %s\n%s", what, err.msg, text);
    assert_int_equal(rc, 0);
    free(text);
    if (memcmp(&back, rb, sizeof back)) {
        print_error("%s: the robot file does not read back the robot\n", what);
        fail();
    }
}

static int same_robot(dm_robot a, dm_robot b) /* the source text aside */
{
    memset(a.source, 0, sizeof a.source);
    memset(b.source, 0, sizeof b.source);
    return !memcmp(&a, &b, sizeof a);
}

static void every_row_round_trips_and_setters_agree(void **state)
{
    (void)state;
    int n, nkeys = 0;
    const dm_effect *tab = dm_effects_table(&n);
    dm_robot base, all;
    assert_int_equal(dm_robot_load("zheng2017", &base, NULL), 0);
    assert_false(dm_effects_any(&base.effects));
    all = base;
    for (int i = 0; i < n; i++) {
        const dm_effect *e = &tab[i];
        if (!e->section)
            continue;
        nkeys++;
        dm_robot text = base, typed = base;
        double v[3];
        char buf[200];
        row_value(e, v, buf, sizeof buf);
        set_row_text(&text, e);
        assert_int_equal(dm_robot_set_number(&typed, e->section, e->key, v, NULL), 0);
        if (!same_robot(text, typed)) {
            print_error("%s: the text and typed setters differ\n", e->name);
            fail();
        }
        assert_false(same_robot(text, base)); /* the row changed something */
        if (!strcmp(e->section, "effects")) {
            assert_true(dm_effects_is_set(&text.effects, e));
            assert_true(dm_effects_any(&text.effects));
        }
        round_trip(&text, e->name);
        set_row_text(&all, e);
    }
    assert_int_equal(nkeys, n - 1); /* every row but geometry_errors has a key */
    for (int i = 0; i < n; i++) /* all rows at once: each still set after the round trip */
        if (tab[i].section && !strcmp(tab[i].section, "effects"))
            assert_true(dm_effects_is_set(&all.effects, &tab[i]));
    round_trip(&all, "every row");
}

/* The base_stiffness rule (dm_effects.h): in a file the global key fills
 * the chains without their own; an assignment sets all three chains, by
 * either setter. */
static void base_stiffness_rule(void **state)
{
    (void)state;
    dm_robot rb, text, typed;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    assert_int_equal(dm_robot_set(&rb, "effects.base_stiffness_1=4e6,5e6,6e6", NULL), 0);
    text = typed = rb;
    const double k[3] = {1e6, 2e6, 3e6};
    assert_int_equal(dm_robot_set(&text, "effects.base_stiffness=1e6,2e6,3e6", NULL), 0);
    assert_int_equal(dm_robot_set_number(&typed, "effects", "base_stiffness", k, NULL), 0);
    assert_true(same_robot(text, typed));
    for (int c = 0; c < 3; c++)
        assert_memory_equal(text.effects.base_stiffness_n_per_m[c], k, sizeof k);
    const char *file = "[robot]\nname = t\n[geometry]\nbase_radius = 0.15\n"
                       "platform_radius = 0.085\narm_length = 0.2\nrod_length = 0.5\n"
                       "rod_half_spacing = 0.03\n[arm]\nshape = square\nside = 0.02\n"
                       "youngs_modulus = 7e10\npoisson_ratio = 0.3\ndensity = 2700\n"
                       "[rod]\nshape = circle\ndiameter = 0.008\nyoungs_modulus = 7e10\n"
                       "poisson_ratio = 0.3\ndensity = 2700\n[platform]\nmass = 0.5\n"
                       "[effects]\nbase_stiffness_1 = 4e6, 5e6, 6e6\n"
                       "base_stiffness = 1e6, 2e6, 3e6\n";
    dm_robot parsed;
    dm_error err;
    int rc = dm_robot_parse_string(file, "rule.ini", &parsed, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    const double own[3] = {4e6, 5e6, 6e6};
    assert_memory_equal(parsed.effects.base_stiffness_n_per_m[0], k, sizeof k);
    assert_memory_equal(parsed.effects.base_stiffness_n_per_m[1], own, sizeof own);
    assert_memory_equal(parsed.effects.base_stiffness_n_per_m[2], k, sizeof k);
}

/* Each row changes the sweep's fingerprint: a store of the baseline
 * refuses to be resumed by the robot with that row set. */
static void every_row_changes_the_sweep_fingerprint(void **state)
{
    (void)state;
    char dir[] = "/tmp/dm_effects_XXXXXX";
    assert_non_null(mkdtemp(dir));
    dm_robot base;
    assert_int_equal(dm_robot_load("zheng2017", &base, NULL), 0);
    dm_grid g;
    assert_int_equal(dm_grid_parse("x=0,y=0,z=-0.4", &g, NULL), 0);
    dm_sweep_opts o;
    dm_sweep_opts_default(&o);
    o.na = o.nb = 1, o.k = 2, o.dynamic = 0, o.threads = 1;
    static volatile sig_atomic_t no_stop;
    dm_sweep_stats st;
    dm_error err;
    assert_int_equal(dm_sweep_run(&base, &g, &o, dir, &no_stop, &st, &err), 0);
    assert_int_equal(dm_sweep_run(&base, &g, &o, dir, &no_stop, &st, &err), 0); /* resumed */
    int n;
    const dm_effect *tab = dm_effects_table(&n);
    for (int i = 0; i < n; i++) {
        if (!tab[i].section)
            continue;
        dm_robot rb = base;
        set_row_text(&rb, &tab[i]);
        int rc = dm_sweep_run(&rb, &g, &o, dir, &no_stop, &st, &err);
        if (rc != DM_EINVAL || !strstr(err.msg, "another robot")) {
            print_error("%s: the baseline's store was not refused (rc %d: %s)\n", tab[i].name,
                        rc, rc ? err.msg : "");
            fail();
        }
    }
    char cmd[64];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(stiff_springs_recover_the_baseline),
        cmocka_unit_test(soft_springs_lower_frequencies),
        cmocka_unit_test(per_chain_base_breaks_symmetry),
        cmocka_unit_test(payload_weight_and_frequencies),
        cmocka_unit_test(elbow_mass_is_linear_and_lowers_frequencies),
        cmocka_unit_test(geometric_stiffness_follows_euler),
        cmocka_unit_test(geometric_stiffness_on_robots),
        cmocka_unit_test(every_row_round_trips_and_setters_agree),
        cmocka_unit_test(base_stiffness_rule),
        cmocka_unit_test(every_row_changes_the_sweep_fingerprint),
    };
    return cmocka_run_group_tests_name("effects", tests, NULL, NULL);
}
