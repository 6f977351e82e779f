/* Monte Carlo over tolerances and clearance states (dm_tolerance): seeds,
 * the zero-width limit, the linearised prediction, an analytic
 * sensitivity, the statistics, thread independence, bad input. */
#include "dm_test.h"

#include <stdlib.h>

#include "dm_kinematics.h"
#include "dm_tolerance.h"
#include "dm_vec3.h"

static void robot_with(const char *const *sets, dm_robot *rb)
{
    dm_error err;
    assert_int_equal(dm_robot_load("zheng2017", rb, NULL), 0);
    for (int i = 0; sets && sets[i]; i++) {
        int rc = dm_robot_set(rb, sets[i], &err);
        if (rc)
            print_error("%s\n", err.msg);
        assert_int_equal(rc, 0);
    }
}

static void run(const dm_robot *rb, const dm_tolerance_spec *sp, const double *P, int threads,
                dm_tolerance_result *r)
{
    dm_error err;
    int rc = dm_tolerance_pose(rb, sp, P, threads, r, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
}

static const char *const CLEAR[] = {"effects.clearance=1e-5", "effects.actuator_clearance_radial=2e-5",
                                    "effects.actuator_clearance_axial=1e-5", NULL};

static void spec_small(dm_tolerance_spec *sp, long n)
{
    dm_tolerance_spec_default(sp);
    sp->tol[DM_TOL_ARM_LENGTH] = 5e-5;
    sp->tol[DM_TOL_ROD_LENGTH] = 3e-5;
    sp->tol[DM_TOL_BASE_RADIUS] = 2e-5;
    sp->tol[DM_TOL_PLATFORM_RADIUS] = 2e-5;
    sp->tol[DM_TOL_THETA] = 0.01 * M_PI / 180;
    sp->tol[DM_TOL_ALPHA0] = 0.005 * M_PI / 180;
    sp->samples = n;
    sp->flexibility = 0;
}

/* Two seeds estimate the same mean |e|: within 3 combined standard errors. */
static void two_seeds_agree(void **state)
{
    (void)state;
    dm_robot rb;
    robot_with(CLEAR, &rb);
    dm_tolerance_spec sp;
    dm_tolerance_result a, b;
    const double P[3] = {0.05, -0.03, -0.42};
    spec_small(&sp, 4000);
    sp.seed = 11;
    run(&rb, &sp, P, 2, &a);
    sp.seed = 12;
    run(&rb, &sp, P, 2, &b);
    assert_true(a.mean_error_m != b.mean_error_m); /* different draws */
    double se = sqrt(a.stderr_mean_m * a.stderr_mean_m + b.stderr_mean_m * b.stderr_mean_m);
    assert_abs(a.mean_error_m, b.mean_error_m, 3 * se, "mean |e| of seeds 11 and 12");
    assert_true(se < 0.05 * a.mean_error_m);
}

/* No tolerance and no clearance: every sample is the deterministic error
 * (the file's geometry errors, flexible model on), so the distribution has
 * zero width and sits there exactly. */
static void zero_tolerances_give_zero_width(void **state)
{
    (void)state;
    const char *const geo[] = {"effects.error_arm_length=1e-4,0,-5e-5", "effects.error_theta_deg=0,0.05,0", NULL};
    const char *const *cases[2] = {NULL, geo};
    for (int c = 0; c < 2; c++) {
        dm_robot rb;
        robot_with(cases[c], &rb);
        dm_tolerance_spec sp;
        dm_tolerance_result r;
        dm_tolerance_spec_default(&sp);
        sp.samples = 50;
        sp.na = sp.nb = 1;
        sp.spec_m = 1e-3;
        run(&rb, &sp, rb.home_m, 2, &r);
        assert_true(r.std_error_m == 0.0 && r.std_m[0] == 0.0 && r.std_m[1] == 0.0 && r.std_m[2] == 0.0);
        assert_true(r.mean_error_m == r.deterministic_error_m);
        assert_true(r.p95_error_m == r.deterministic_error_m && r.max_error_m == r.deterministic_error_m);
        assert_true(r.p_exceed_spec == 0.0);
        assert_true(r.dominant == -1);
        assert_true(r.deterministic_error_m > 1e-6); /* the sag (and the errors) are there */
    }
}

/* Small tolerances: the error is linear in the draws, and the sample
 * standard deviation of each component equals the linearised prediction
 * sqrt(sum_p S_p^2 var p) within 5 % (the figure; the sampling
 * error of a standard deviation from 20 000 samples is about 0.5 %), for
 * both laws; and with the flexible model (mesh 1,1, 6 000 samples: sampling
 * error about 1 %; measured deviations 0.2-1.2 %). */
static void small_tolerances_follow_the_linearisation(void **state)
{
    (void)state;
    dm_robot rb;
    robot_with(CLEAR, &rb);
    const double P[3] = {0.06, 0.02, -0.43};
    for (int c = 0; c < 3; c++) {
        dm_tolerance_spec sp;
        dm_tolerance_result r;
        spec_small(&sp, c == 2 ? 6000 : 20000);
        sp.dist = c == 1 ? DM_TOL_NORMAL : DM_TOL_UNIFORM;
        sp.seed = 5 + c;
        if (c == 2) {
            sp.flexibility = 1;
            sp.na = sp.nb = 1;
        }
        run(&rb, &sp, P, 2, &r);
        for (int k = 0; k < 3; k++) {
            print_message("case %d axis %d: std %.5e predicted %.5e (%.2f %%)\n", c, k, r.std_m[k],
                          r.predicted_std_m[k], 100 * (r.std_m[k] / r.predicted_std_m[k] - 1));
            assert_rel(r.std_m[k], r.predicted_std_m[k], 0.05, "case %d component %d", c, k);
            assert_abs(r.mean_m[k], r.deterministic_m[k], 4 * r.predicted_std_m[k] / sqrt(sp.samples),
                       "case %d mean component %d", c, k);
        }
    }
}

/* Rod-length tolerance alone, rigid, at the centre: the first-order closure
 * u_i . dP = d_i (u_i the unit rod direction) gives dP = U^-1 d, so the rms
 * error per unit of tolerance (uniform: var 1/3) is ||U^-1||_F / sqrt 3,
 * computed here from the inverse kinematics alone. Tolerance 1e-6: the
 * central differences (h = 1 um on 0.5 m rods). */
static void rod_length_sensitivity_is_analytic(void **state)
{
    (void)state;
    dm_robot rb;
    robot_with(NULL, &rb);
    const double P[3] = {0.04, -0.05, -0.41};
    dm_pose pose;
    assert_int_equal(dm_kin_inverse(&rb, P, &pose, NULL), 0);
    double U[9], inv[9];
    for (int i = 0; i < 3; i++) {
        double u[3];
        dm_sub3(pose.C[i], pose.B[i], u);
        dm_scale3(1.0 / dm_norm3(u), u, u);
        for (int k = 0; k < 3; k++)
            U[3 * i + k] = u[k];
    }
    double det = U[0] * (U[4] * U[8] - U[5] * U[7]) - U[1] * (U[3] * U[8] - U[5] * U[6]) +
                 U[2] * (U[3] * U[7] - U[4] * U[6]);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) { /* inverse by cofactors */
            int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
            inv[3 * r + c] = (U[3 * r1 + c1] * U[3 * r2 + c2] - U[3 * r1 + c2] * U[3 * r2 + c1]) / det;
        }
    double fro = 0;
    for (int k = 0; k < 9; k++)
        fro += inv[k] * inv[k];
    dm_tolerance_spec sp;
    dm_tolerance_result r;
    dm_tolerance_spec_default(&sp);
    sp.tol[DM_TOL_ROD_LENGTH] = 1e-5;
    sp.flexibility = 0;
    sp.samples = 10;
    run(&rb, &sp, P, 1, &r);
    assert_rel(r.sensitivity[DM_TOL_ROD_LENGTH], sqrt(fro / 3), 1e-6, "rod length: ||U^-1||_F / sqrt 3");
    assert_rel(r.std_contribution_m[DM_TOL_ROD_LENGTH], 1e-5 * sqrt(fro / 3), 1e-6, "its std");
    assert_int_equal(r.dominant, DM_TOL_ROD_LENGTH);
    for (int c = 0; c < DM_TOL_NCLASS; c++)
        if (c != DM_TOL_ROD_LENGTH)
            assert_true(r.std_contribution_m[c] == 0.0);
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The statistics are those of the samples (recomputed here from
 * dm_tolerance_samples: mean, P95 by linear interpolation, max, exceedance,
 * exactly), a sub-range of samples is the same numbers (counter-based
 * draws), and 1, 2 and 3 threads give the same bits. */
static void statistics_and_threads(void **state)
{
    (void)state;
    enum { N = 997 };
    dm_robot rb;
    robot_with(CLEAR, &rb);
    dm_tolerance_spec sp;
    spec_small(&sp, N);
    sp.flexibility = 1;
    sp.na = sp.nb = 1;
    sp.seed = 99;
    sp.spec_m = 6e-5;
    const double P[3] = {0.02, 0.05, -0.4};
    dm_tolerance_result r1, r2, r3;
    run(&rb, &sp, P, 1, &r1);
    run(&rb, &sp, P, 2, &r2);
    run(&rb, &sp, P, 3, &r3);
    assert_memory_equal(&r1, &r2, sizeof r1);
    assert_memory_equal(&r1, &r3, sizeof r1);
    static double e[3 * N], part[3 * 100], nrm[N];
    assert_int_equal(dm_tolerance_samples(&rb, &sp, P, 0, N, e, NULL), 0);
    assert_int_equal(dm_tolerance_samples(&rb, &sp, P, 500, 100, part, NULL), 0);
    assert_memory_equal(part, e + 3 * 500, sizeof part);
    double s = 0;
    long over = 0;
    for (int i = 0; i < N; i++) {
        nrm[i] = dm_norm3(e + 3 * i);
        s += nrm[i];
        over += nrm[i] > sp.spec_m;
    }
    qsort(nrm, N, sizeof *nrm, cmp);
    double pos = 0.95 * (N - 1);
    int lo = (int)pos;
    assert_rel(r1.mean_error_m, s / N, 1e-13, "mean |e|");
    assert_rel(r1.p95_error_m, nrm[lo] + (pos - lo) * (nrm[lo + 1] - nrm[lo]), 1e-15, "P95");
    assert_true(r1.max_error_m == nrm[N - 1]);
    assert_true(r1.p_exceed_spec == (double)over / N && over > 0 && over < N);
}

/* Each pose has its own streams, keyed by the pose to 1 nm: a pose typed
 * with fewer digits than a grid computed it, or -0.0 for 0.0, draws the
 * same states; another pose, or another seed, other ones. */
static void pose_seeds(void **state)
{
    (void)state;
    const double a[3] = {0.05, 0.0, -0.4}, b[3] = {0.05000000000000002, -0.0, -0.4000000000000001},
                 c[3] = {0.05, 1e-9, -0.4};
    assert_true(dm_tolerance_pose_seed(7, a) == dm_tolerance_pose_seed(7, b));
    assert_true(dm_tolerance_pose_seed(7, a) != dm_tolerance_pose_seed(7, c));
    assert_true(dm_tolerance_pose_seed(7, a) != dm_tolerance_pose_seed(8, a));
    dm_robot rb;
    robot_with(CLEAR, &rb);
    dm_tolerance_spec sp;
    spec_small(&sp, 4);
    double ea[12], eb[12], ec[12];
    assert_int_equal(dm_tolerance_samples(&rb, &sp, a, 0, 4, ea, NULL), 0);
    assert_int_equal(dm_tolerance_samples(&rb, &sp, b, 0, 4, eb, NULL), 0);
    assert_int_equal(dm_tolerance_samples(&rb, &sp, c, 0, 4, ec, NULL), 0);
    /* the same draws: errors equal to far below the draws' spread (1e-5) */
    for (int i = 0; i < 12; i++)
        assert_abs(ea[i], eb[i], 1e-12, "same states at a pose typed two ways");
    int differ = 0;
    for (int i = 0; i < 12; i++)
        differ += fabs(ea[i] - ec[i]) > 1e-7;
    assert_true(differ > 6);
}

/* Bad input is refused before any work, naming the field. */
static void bad_input(void **state)
{
    (void)state;
    dm_robot rb;
    robot_with(NULL, &rb);
    dm_tolerance_spec sp;
    dm_tolerance_result r;
    dm_error err;
    struct { const char *what; const char *msg; } cases[] = {
        {"negative tolerance", "tolerance rod_length: must be >= 0"},
        {"zero samples", "samples: must be >= 1"},
        {"negative spec", "spec: must be > 0"},
        {"hours", "hours of work"},
    };
    for (int c = 0; c < 4; c++) {
        dm_tolerance_spec_default(&sp);
        if (c == 0) sp.tol[DM_TOL_ROD_LENGTH] = -1e-5;
        if (c == 1) sp.samples = 0;
        if (c == 2) sp.spec_m = -1e-4;
        if (c == 3) sp.samples = 9000000; /* flexible, mesh 8,8: about 1.8 hours */
        if (c == 3) sp.na = sp.nb = 8;
        assert_int_equal(dm_tolerance_pose(&rb, &sp, rb.home_m, 1, &r, &err),
                         c == 3 ? DM_ETOOBIG : DM_EINVAL);
        if (!strstr(err.msg, cases[c].msg))
            print_error("%s: %s\n", cases[c].what, err.msg);
        assert_non_null(strstr(err.msg, cases[c].msg));
    }
    sp.force_long = 1; /* forced, the same count passes the check */
    assert_int_equal(dm_tolerance_check(&rb, &sp, NULL), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(two_seeds_agree),
        cmocka_unit_test(zero_tolerances_give_zero_width),
        cmocka_unit_test(small_tolerances_follow_the_linearisation),
        cmocka_unit_test(rod_length_sensitivity_is_analytic),
        cmocka_unit_test(statistics_and_threads),
        cmocka_unit_test(pose_seeds),
        cmocka_unit_test(bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
