/* Experiment design: on synthetic data drawn at the planned poses, the
 * fitted parameters scatter (standard deviation over 20 noise seeds) at
 * most 0.7 times as much as on the same number of random reachable poses,
 * and within 20 % of the 1-sigma the plan predicted; the plan is
 * deterministic and independent of the thread count; bad input is refused
 * with a message. Mesh 1,1: the statistics, not the mesh, are checked.
 *
 * Tolerances: with 20 seeds a sample standard deviation has a relative
 * standard error of 1/sqrt(38) = 16 %, so the 20 % band holds with about
 * 80 % probability per parameter for an exact prediction; the seeds are
 * fixed (dm_plan_observe's noise streams, seed * 977 + 13 as in
 * test_diagnose), so the test is deterministic, and it fails when the
 * predicted uncertainty is off by a few tens of percent (a wrong noise
 * scale, a Jacobian in the wrong units). The fits start at the truth: the
 * scatter of the estimator is checked, not the search (test_diagnose
 * checks that). */
#include "dm_test.h"

#include <stdlib.h>

#include "dm_plan.h"

#define SEEDS 20

/* Data at the poses of `design`: the truth's predictions plus noise. */
static void observe(const dm_robot *truth, const dm_dataset *design, double noise, uint64_t seed,
                    dm_dataset *d)
{
    assert_int_equal(dm_plan_observe(truth, design, noise, seed, 1, 1, d, NULL), 0);
}

/* Standard deviation of the fitted parameters of `names` over SEEDS noise
 * draws, on the planned design (random == 0) or on a new random design per
 * seed. start: the truth (a Monte Carlo study of the estimator, not of
 * the search). */
static void scatter(const dm_robot *base, const dm_robot *truth, const dm_plan_result *plan,
                    const dm_plan_opts *po, const char *const *names, int n,
                    const double start[][DM_DIAG_MAXV], int random, double *sd)
{
    double sum[2] = {0}, sq[2] = {0};
    dm_diagnose_opts o = {.na = 1, .nb = 1, .pairs = 0, .threads = 2};
    for (uint64_t seed = 1; seed <= SEEDS; seed++) {
        dm_dataset design, d;
        dm_fit f;
        dm_error err;
        if (random)
            assert_int_equal(dm_plan_random(base, po, 1000 + seed, &design, NULL), 0);
        observe(truth, random ? &design : &plan->design, plan->noise, seed, &d);
        int rc = dm_fit_effects(base, &d, names, n, start, &o, &f, &err);
        if (rc)
            print_error("%s\n", err.msg);
        assert_int_equal(rc, 0);
        for (int i = 0; i < n; i++) {
            sum[i] += f.value[i][0];
            sq[i] += f.value[i][0] * f.value[i][0];
        }
        dm_dataset_free(&d);
        if (random)
            dm_dataset_free(&design);
    }
    for (int i = 0; i < n; i++)
        sd[i] = sqrt((sq[i] - sum[i] * sum[i] / SEEDS) / (SEEDS - 1));
}

/* The plan for `spec` on `kind` data, its predicted 1-sigma checked
 * against the scatter of fits on its design and on random ones. */
static void check_plan(const char *robot, dm_data_kind kind, const char *spec, int npose)
{
    dm_robot base, truth;
    dm_plan_effect eff[DM_PLAN_MAXEFF];
    dm_plan_result plan;
    dm_error err;
    int n;
    assert_int_equal(dm_robot_load(robot, &base, NULL), 0);
    assert_int_equal(dm_plan_parse_effects(spec, kind, eff, &n, &err), 0);
    dm_plan_opts po = {.kind = kind, .npose = npose, .seed = 1, .na = 1, .nb = 1, .threads = 2};
    int rc = dm_plan(&base, eff, n, &po, &plan, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    truth = base;
    const char *names[2];
    double start[2][DM_DIAG_MAXV];
    for (int i = 0; i < n; i++) {
        names[i] = eff[i].cand->name;
        memcpy(start[i], eff[i].value, sizeof start[i]);
        assert_int_equal(dm_effects_apply(&truth, names[i], eff[i].value, NULL), 0);
    }
    double sd_plan[2], sd_random[2];
    scatter(&base, &truth, &plan, &po, names, n, (const double(*)[DM_DIAG_MAXV])start, 0, sd_plan);
    scatter(&base, &truth, &plan, &po, names, n, (const double(*)[DM_DIAG_MAXV])start, 1,
            sd_random);
    for (int i = 0; i < n; i++) {
        print_message("%s %s: sd planned %.3g (predicted %.3g, ratio %.2f), random %.3g: "
                      "planned / random %.2f\n",
                      dm_data_kind_name(kind), names[i], sd_plan[i], plan.sigma[i],
                      sd_plan[i] / plan.sigma[i], sd_random[i], sd_plan[i] / sd_random[i]);
        assert_true(sd_plan[i] <= 0.7 * sd_random[i]);
        assert_rel(sd_plan[i], plan.sigma[i], 0.20, "%s: scatter against the plan's 1-sigma",
                   names[i]);
    }
    dm_plan_free(&plan);
}

/* Actuator and base stiffness soften a deflection survey alike; the plan
 * picks poses and force directions that tell them apart. */
static void planned_static_survey_beats_random_poses(void **state)
{
    (void)state;
    check_plan("zheng2017", DM_DATA_STATIC, "actuator_stiffness=2e4,base_stiffness=2e6", 12);
}

/* A payload shows only in how the robot rings: the plan picks the move
 * of the family that excites it most. */
static void planned_tracker_run_beats_random_paths(void **state)
{
    (void)state;
    check_plan("zheng2017", DM_DATA_TRACKER, "payload_mass=0.5", 60);
}

/* Same seed, one or two threads: the same design, bit for bit. */
static void plan_is_deterministic(void **state)
{
    (void)state;
    dm_robot rb;
    dm_plan_effect eff[DM_PLAN_MAXEFF];
    dm_plan_result a, b;
    int n;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    assert_int_equal(dm_plan_parse_effects("payload_mass,actuator_stiffness", DM_DATA_MODAL, eff,
                                           &n, NULL),
                     0);
    dm_plan_opts o = {.kind = DM_DATA_MODAL, .npose = 6, .seed = 3, .na = 1, .nb = 1,
                      .ncandidates = 40, .threads = 1};
    assert_int_equal(dm_plan(&rb, eff, n, &o, &a, NULL), 0);
    o.threads = 2;
    assert_int_equal(dm_plan(&rb, eff, n, &o, &b, NULL), 0);
    assert_int_equal(a.design.n, b.design.n);
    assert_memory_equal(a.design.s, b.design.s, sizeof(dm_sample) * a.design.n);
    assert_memory_equal(a.sigma, b.sigma, sizeof a.sigma);
    assert_memory_equal(&a.logdet, &b.logdet, sizeof a.logdet);
    assert_true(a.logdet >= a.logdet_random); /* the plan is no worse than chance */
    dm_plan_free(&a);
    dm_plan_free(&b);
}

/* Base and platform radius errors enter the kinematics only as R - r:
 * no path separates them, and the plan says so. */
static void look_alikes_are_reported(void **state)
{
    (void)state;
    dm_robot rb;
    dm_plan_effect eff[DM_PLAN_MAXEFF];
    dm_plan_result r;
    int n;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    assert_int_equal(dm_plan_parse_effects("error_base_radius,error_platform_radius",
                                           DM_DATA_TRACKER, eff, &n, NULL),
                     0);
    dm_plan_opts o = {.kind = DM_DATA_TRACKER, .npose = 40, .seed = 1, .na = 1, .nb = 1};
    assert_int_equal(dm_plan(&rb, eff, n, &o, &r, NULL), 0);
    assert_int_equal(r.npair, 1);
    assert_true(r.pair[0].alike);
    assert_true(r.pair[0].angle_deg < 1.0);
    /* the random paths' 1-sigma is their median: typical paths determine
     * each radius to about what the plan does, within 30x, although some
     * of them barely determine it at all (an rms over the paths gave 1e4
     * to 1e5 times the plan's, set by their round-off) */
    for (int j = 0; j < r.nparam; j++) {
        print_message("%d: planned %.3g random %.3g\n", j, r.sigma[j], r.sigma_random[j]);
        assert_true(r.sigma_random[j] < 30 * r.sigma[j]);
    }
    dm_plan_free(&r);
}

/* A tracker run as a lab records it (dm_nuisance.h): the frame, the
 * reflector offset and the clock offset are fitted with every model. An
 * arm-length error on a planar circle is then mostly a rigid motion of the
 * frame (at 5 um over 0.4 s its weakest combination, alone determined to
 * 0.0055 of the scale, is left at 0.15 > DM_DIAG_DETERMINED), and the plan
 * says so; from its family it picks a run that
 * separates them (the pick cycle's heights and reach), and a diagnosis of a
 * synthetic run of that path, nuisances in it, reports the uncertainty the
 * plan predicted.
 *
 * Tolerance 10 %: both are the inverse Fisher information of the arm
 * lengths after the nuisances are marginalised (the plan: the Schur
 * complement; the fit: variable projection, its Jacobian of residuals with
 * the nuisances fitted), from the same design. They differ by the points
 * of linearisation (the assumed against the fitted lengths, a few um on
 * 0.2 mm: the Jacobian changes by far less than 1 %), the finite
 * differences, and the fit's misfit scale max(1, chi2/dof): with 3 x 400
 * samples chi2/dof has a standard deviation sqrt(2/1200) = 4 %, its square
 * root 2 %, so even 3 sd stay at 6 %. A plan that ignored the nuisances
 * predicts several times less (at least 2x: the check below), which fails it. */
#define NUIS_SAMPLES 400
#define NUIS_NOISE 5e-6 /* m: a laser tracker over a metre */
#define PLANAR_CIRCLE "circle:centre=0,0,-0.4;radius=0.05;rate=12.566;duration=0.399"

static void nuisance_plan(const dm_robot *rb, const char *spec, const char *path, int nuisance,
                          dm_plan_result *r)
{
    dm_plan_effect eff[DM_PLAN_MAXEFF];
    dm_error err;
    int n;
    assert_int_equal(dm_plan_parse_effects(spec, DM_DATA_TRACKER, eff, &n, NULL), 0);
    dm_plan_opts o = {.kind = DM_DATA_TRACKER, .npose = NUIS_SAMPLES, .seed = 1, .na = 1,
                      .nb = 1, .threads = 2, .nuisance = nuisance, .path = path,
                      .noise = NUIS_NOISE};
    int rc = dm_plan(rb, eff, n, &o, r, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
}

static void planned_run_separates_effects_from_nuisances(void **state)
{
    (void)state;
    static const char *const names[1] = {"error_arm_length"};
    /* two rows: dm_fit_effects reads a start for up to two effects */
    static const double truth_v[2][DM_DIAG_MAXV] = {{2e-4, -1.5e-4, 2.5e-4}};
    const char *spec = "error_arm_length=2e-4,-1.5e-4,2.5e-4";
    dm_robot rb, truth;
    dm_plan_result circle, plain, plan;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    /* the planar circle: an arm-length combination the frame takes */
    nuisance_plan(&rb, spec, PLANAR_CIRCLE, 1, &circle);
    assert_int_equal(circle.nnuisance, 7);
    assert_int_equal(circle.nconfound, 1);
    const dm_plan_confound *c = &circle.confound[0];
    print_message("circle: least determined %.3g alone, %.3g beyond the nuisances\n",
                  c->sigma_alone, c->sigma);
    assert_true(c->alike);
    assert_true(c->sigma > DM_DIAG_DETERMINED && c->sigma_alone < 0.1 * DM_DIAG_DETERMINED);
    double frame = 0; /* the frame (translation, rotation) mimics it */
    for (int k = 0; k < 6; k++)
        frame = fmax(frame, fabs(c->like[k]));
    assert_true(frame >= 0.3);
    /* the plan: a path of the family that separates them */
    nuisance_plan(&rb, spec, NULL, 1, &plan);
    print_message("planned %s: least determined %.3g beyond the nuisances\n", plan.path,
                  plan.confound[0].sigma);
    assert_int_equal(plan.ncandidates, 24);
    assert_false(plan.confound[0].alike);
    assert_true(plan.confound[0].sigma <= DM_DIAG_DETERMINED);
    assert_true(strncmp(plan.path, "circle", 6)); /* no circle in one plane */
    assert_true(plan.design.nuisance.on);
    /* the same path without the nuisances determines far more */
    nuisance_plan(&rb, spec, plan.path, 0, &plain);
    assert_int_equal(plain.nnuisance, 0);
    /* a synthetic run of that path with a frame translation and the robot's
     * arm-length errors, diagnosed with the nuisances */
    truth = rb;
    assert_int_equal(dm_effects_apply(&truth, names[0], truth_v[0], NULL), 0);
    dm_dataset d;
    dm_fit f;
    dm_error err;
    assert_int_equal(dm_plan_observe(&truth, &plan.design, plan.noise, 7, 1, 1, &d, NULL), 0);
    assert_true(d.nuisance.on);
    static const double shift[3] = {3e-5, -2e-5, 4e-5};
    for (int i = 0; i < d.n; i++)
        d.s[i].value += shift[d.s[i].comp];
    dm_diagnose_opts o = {.na = 1, .nb = 1, .pairs = 0, .threads = 2};
    int rc = dm_fit_effects(&rb, &d, names, 1, truth_v, &o, &f, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    for (int k = 0; k < 3; k++) {
        double s = f.sigma[0][k];
        print_message("arm %d: fitted %.4g +- %.3g (true %.4g); planned 1-sigma %.3g, without "
                      "nuisances %.3g\n", k, f.value[0][k], s, truth_v[0][k], plan.sigma[k],
                      plain.sigma[k]);
        assert_rel(s, plan.sigma[k], 0.10, "arm %d: reported against planned 1-sigma", k);
        assert_true(fabs(f.value[0][k] - truth_v[0][k]) <= 4 * s);
        assert_true(plain.sigma[k] < 0.5 * plan.sigma[k]);
    }
    dm_dataset_free(&d);
    dm_plan_free(&plain);
    dm_plan_free(&plan);
    dm_plan_free(&circle);
}

static void bad_input_is_refused(void **state)
{
    (void)state;
    dm_robot rb;
    dm_plan_effect eff[DM_PLAN_MAXEFF];
    dm_plan_result r;
    dm_error err;
    int n;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    assert_int_equal(dm_plan_parse_effects("bogus_mass", DM_DATA_MODAL, eff, &n, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "'bogus_mass' is not a candidate effect"));
    assert_int_equal(dm_plan_parse_effects("payload_mass", DM_DATA_STATIC, eff, &n, &err),
                     DM_EINVAL);
    assert_non_null(strstr(err.msg, "static data cannot see payload_mass"));
    assert_int_equal(dm_plan_parse_effects("error_arm_length=1e-4,2e-4", DM_DATA_TRACKER, eff, &n,
                                           &err),
                     DM_EINVAL);
    assert_int_equal(dm_plan_parse_effects("actuator_stiffness,error_arm_length", DM_DATA_TRACKER,
                                           eff, &n, &err),
                     0);
    dm_plan_opts o = {.kind = DM_DATA_TRACKER, .npose = 3, .na = 1, .nb = 1};
    assert_int_equal(dm_plan(&rb, eff, n, &o, &r, &err), DM_EINVAL); /* 4 parameters */
    assert_non_null(strstr(err.msg, "fewer than the 4 parameters"));
    assert_int_equal(dm_plan_parse_effects("base_stiffness", DM_DATA_STATIC, eff, &n, &err), 0);
    o = (dm_plan_opts){.kind = DM_DATA_STATIC, .npose = 4, .na = 1, .nb = 1,
                       .region = "x=1:2:3,y=0,z=-0.4"};
    assert_int_equal(dm_plan(&rb, eff, n, &o, &r, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "no reachable pose"));
    o.nuisance = 1; /* the tracker's nuisances on a static survey */
    assert_int_equal(dm_plan(&rb, eff, n, &o, &r, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "are for tracker runs"));
}

int main(int argc, char **argv)
{
    if (argc > 1)
        cmocka_set_test_filter(argv[1]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(bad_input_is_refused),
        cmocka_unit_test(plan_is_deterministic),
        cmocka_unit_test(look_alikes_are_reported),
        cmocka_unit_test(planned_static_survey_beats_random_poses),
        cmocka_unit_test(planned_tracker_run_beats_random_paths),
        cmocka_unit_test(planned_run_separates_effects_from_nuisances),
    };
    return cmocka_run_group_tests_name("plan", tests, NULL, NULL);
}
