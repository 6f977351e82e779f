/* Zheng's error budget along a path (dm_budget): each source alone, sum,
 * combined, coupling. Exact identities where a source is missing, and the
 * order of the coupling terms where they are all there. */
#include "dm_test.h"

#include <stdlib.h>

#include "dm_budget.h"
#include "dm_coupling.h"

#define MAXS 64
#define PATH "circle:centre=0,0,-0.4;radius=0.05;rate=6.283185307179586;duration=0.04"

typedef struct {
    int n;
    dm_budget_sample s[MAXS];
} record;

static int keep(void *user, const dm_budget_sample *s)
{
    record *r = user;
    if (r->n == MAXS)
        return 1;
    r->s[r->n++] = *s;
    return 0;
}

typedef struct {
    int n;
    double e[MAXS][3];
} plain;

static int keep_plain(void *user, const dm_integ_sample *s)
{
    plain *p = user;
    if (p->n == MAXS)
        return 1;
    memcpy(p->e[p->n++], s->error, sizeof p->e[0]);
    return 0;
}

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

static void opts(dm_integ_opts *o)
{
    dm_integ_opts_default(o);
    o->na = o->nb = 1;
    o->reference = 0;
    o->dt_s = 2e-3;
}

static void budget(const dm_robot *rb, int flex, record *r, dm_budget_summary *sum)
{
    dm_trajectory tr;
    dm_integ_opts o;
    dm_error err;
    opts(&o);
    assert_int_equal(dm_traj_make(PATH, rb, &tr, NULL), 0);
    r->n = 0;
    int rc = dm_budget_trajectory(rb, &tr, &o, flex, keep, r, sum, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    assert_int_equal(r->n, 21);
    dm_traj_free(&tr);
}

static double norm(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

/* No geometry errors, no clearance: the kinematic sources are exactly zero
 * and the combined model is the baseline run, bit for bit. */
static void zero_errors_give_the_baseline_exactly(void **state)
{
    (void)state;
    const char *const sets[] = {"effects.base_stiffness=3e7,3e7,5e7", NULL}; /* kept: flexibility */
    dm_robot rb;
    robot_with(sets, &rb);
    static record r;
    dm_budget_summary sum;
    budget(&rb, 1, &r, &sum);
    dm_trajectory tr;
    dm_integ_opts o;
    dm_integ_summary is;
    static plain p;
    opts(&o);
    p.n = 0;
    assert_int_equal(dm_traj_make(PATH, &rb, &tr, NULL), 0);
    assert_int_equal(dm_integrate_trajectory(&rb, &tr, &o, keep_plain, &p, &is, NULL), 0);
    dm_traj_free(&tr);
    assert_int_equal(p.n, r.n);
    for (int i = 0; i < r.n; i++) {
        const dm_budget_sample *s = &r.s[i];
        for (int k = 0; k < 3; k++) {
            assert_true(s->alone_m[DM_BUDGET_GEOMETRY][k] == 0.0);
            assert_true(s->alone_m[DM_BUDGET_CLEARANCE][k] == 0.0);
            assert_true(s->combined_m[k] == p.e[i][k]);
            assert_true(s->alone_m[DM_BUDGET_FLEXIBILITY][k] == p.e[i][k]);
            assert_true(s->coupling_m[k] == 0.0);
        }
    }
    assert_true(norm(r.s[r.n - 1].combined_m) > 1e-7); /* the baseline is there */
    assert_true(sum.mean_combined_m == is.mean_error_m);
}

/* One kinematic source and no flexible model: combined == that source
 * alone (1e-12 of its size), the other sources zero. */
static void one_source_alone_is_the_combined_error(void **state)
{
    (void)state;
    const char *const geo[] = {"effects.error_arm_length=1e-4,-5e-5,2e-5",
                               "effects.error_theta_deg=0.05,0,-0.03",
                               "effects.error_platform_radius=0,3e-5,0", NULL};
    const char *const clr[] = {"effects.clearance=1e-5", "effects.actuator_clearance_radial=2e-5",
                               "effects.actuator_clearance_axial=1e-5", NULL};
    const char *const *cases[2] = {geo, clr};
    for (int c = 0; c < 2; c++) {
        dm_robot rb;
        robot_with(cases[c], &rb);
        static record r;
        dm_budget_summary sum;
        budget(&rb, 0, &r, &sum);
        int on = c == 0 ? DM_BUDGET_GEOMETRY : DM_BUDGET_CLEARANCE;
        for (int i = 0; i < r.n; i++) {
            const dm_budget_sample *s = &r.s[i];
            double mag = norm(s->alone_m[on]);
            assert_true(mag > 1e-6);
            for (int k = 0; k < 3; k++) {
                assert_abs(s->combined_m[k], s->alone_m[on][k], 1e-12 * mag, "case %d sample %d", c, i);
                assert_true(s->alone_m[1 - on][k] == 0.0 && s->alone_m[DM_BUDGET_FLEXIBILITY][k] == 0.0);
            }
        }
        assert_rel(sum.mean_combined_m, sum.mean_alone_m[on], 1e-12, "case %d mean", c);
    }
}

/* Everything on. The coupling is the elastic error's change from the
 * nominal to the real configuration plus the closure's cross terms: first
 * order in the geometry errors times the elastic error. Halving the
 * errors halves it (to 1 %, measured 0.04 %: the O(e^2) remainder is 1e-4 of the first-order
 * term for 1e-4 m errors on 0.2 m links, the rest is round-off in a
 * difference of 1e-4 against 1e-8); it stays far below the sum. */
static void coupling_is_first_order_in_the_errors(void **state)
{
    (void)state;
    double cpl[2];
    for (int h = 0; h < 2; h++) {
        double f = h ? 0.5 : 1.0;
        char a[96], b[96];
        snprintf(a, sizeof a, "effects.error_arm_length=%g,%g,%g", 1e-4 * f, -5e-5 * f, 2e-5 * f);
        snprintf(b, sizeof b, "effects.error_base_radius=%g,0,%g", 8e-5 * f, -4e-5 * f);
        const char *const sets[] = {a, b, NULL};
        dm_robot rb;
        robot_with(sets, &rb);
        static record r;
        dm_budget_summary sum;
        budget(&rb, 1, &r, &sum);
        cpl[h] = sum.mean_coupling_m;
        assert_true(sum.mean_coupling_m > 0 && sum.mean_coupling_m < 1e-3 * sum.mean_sum_m);
        for (int i = 0; i < r.n; i++)
            for (int k = 0; k < 3; k++)
                assert_abs(r.s[i].sum_m[k] + r.s[i].coupling_m[k], r.s[i].combined_m[k],
                           1e-15, "(b) + ((c) - (b)) == (c)");
    }
    print_message("first-order coupling %.6g %.6g ratio %.6f\n", cpl[0], cpl[1], cpl[0] / cpl[1]);
    assert_rel(cpl[0] / cpl[1], 2.0, 0.01, "coupling halves with the errors");
}

/* Rigid, geometry errors and clearance together: the closure is nonlinear
 * only at second order, so their coupling is the cross term, quadratic in
 * the amplitude: halving both quarters it (to 1 %, measured 0.09 %: third-order terms). */
static void kinematic_coupling_is_second_order(void **state)
{
    (void)state;
    double cpl[2];
    for (int h = 0; h < 2; h++) {
        double f = h ? 0.5 : 1.0;
        char a[96], b[96], c[96];
        snprintf(a, sizeof a, "effects.error_arm_length=%g,%g,%g", 2e-4 * f, -1e-4 * f, 5e-5 * f);
        snprintf(b, sizeof b, "effects.error_theta_deg=%g,0,0", 0.1 * f);
        snprintf(c, sizeof c, "effects.actuator_clearance_radial=%g", 5e-5 * f);
        const char *const sets[] = {a, b, c, NULL};
        dm_robot rb;
        robot_with(sets, &rb);
        static record r;
        dm_budget_summary sum;
        budget(&rb, 0, &r, &sum);
        cpl[h] = sum.mean_coupling_m;
        assert_true(cpl[h] > 0 && cpl[h] < 1e-2 * sum.mean_sum_m);
    }
    print_message("second-order coupling %.6g %.6g ratio %.6f\n", cpl[0], cpl[1], cpl[0] / cpl[1]);
    assert_rel(cpl[0] / cpl[1], 4.0, 0.01, "kinematic coupling quarters with the errors");
}

/* The coupling index's change against the nominal robot along a run:
 * exactly zero for a robot without effects; with errors and clearance its
 * time mean is the run's mean index minus the nominal robot's, evaluated
 * here where each step is frozen (the commanded position at its start). */
typedef struct {
    dm_coupling_change cc;
    int n;
    double change[MAXS];
} change_rec;

static int track(void *user, const dm_integ_sample *s)
{
    change_rec *r = user;
    if (r->n == MAXS)
        return 1;
    if (dm_coupling_change_next(&r->cc, s, &r->change[r->n], NULL))
        return 1;
    r->n++;
    return 0;
}

static void coupling_change_against_nominal(void **state)
{
    (void)state;
    static const char *const ERRS[] = {"effects.error_rod_length=1e-4,0,-5e-5",
                                       "effects.clearance=1e-5", NULL};
    dm_trajectory tr;
    dm_integ_opts o;
    dm_integ_summary sum;
    dm_error err;
    opts(&o);
    for (int with = 0; with < 2; with++) {
        dm_robot rb;
        robot_with(with ? ERRS : NULL, &rb);
        assert_int_equal(dm_traj_make(PATH, &rb, &tr, NULL), 0);
        change_rec r = {.n = 0};
        assert_int_equal(dm_coupling_change_init(&r.cc, &rb, o.na, o.nb, &err), 0);
        assert_int_equal(dm_integrate_trajectory(&rb, &tr, &o, track, &r, &sum, &err), 0);
        assert_int_equal(r.n, 21);
        double mean, lo, hi;
        dm_coupling_change_summary(&r.cc, &mean, &lo, &hi);
        if (!with) {
            for (int i = 0; i < r.n; i++)
                assert_true(r.change[i] == 0.0);
            assert_true(mean == 0.0 && lo == 0.0 && hi == 0.0);
        } else {
            double nominal_mean = 0, T = tr.duration_s;
            long steps = (long)ceil(T / o.dt_s - 1e-9);
            for (long j = 0; j < steps; j++) {
                double t0 = j * o.dt_s, t1 = j + 1 == steps ? T : (j + 1) * o.dt_s, P[3], v[3], a[3];
                double nominal;
                dm_traj_eval(&tr, t0, P, v, a);
                dm_coupling *cw = dm_coupling_alloc(&rb, o.na, o.nb, NULL);
                assert_non_null(cw);
                assert_int_equal(dm_coupling_nominal_log10(cw, P, &nominal, NULL), 0);
                dm_coupling_free(cw);
                nominal_mean += (t1 - t0) * nominal / T;
            }
            assert_abs(mean, sum.coupling_mean_log10 - nominal_mean, 1e-11,
                       "mean change = mean index - mean nominal index");
            assert_true(fabs(mean) > 1e-6 && lo <= mean && mean <= hi);
            for (int i = 0; i < r.n; i++)
                assert_true(isfinite(r.change[i]));
        }
        dm_coupling_change_free(&r.cc);
        dm_traj_free(&tr);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(zero_errors_give_the_baseline_exactly),
        cmocka_unit_test(one_source_alone_is_the_combined_error),
        cmocka_unit_test(coupling_is_first_order_in_the_errors),
        cmocka_unit_test(kinematic_coupling_is_second_order),
        cmocka_unit_test(coupling_change_against_nominal),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
