/* Predictions: a prediction workspace reused for many robots gives bit
 * for bit what a fresh dm_predict gives for each, whether the robots'
 * effects keep the model's size or change it (a compliant base adds DOFs),
 * a window predicts a tracker run's first part as the cut file would be
 * predicted, and tracker predictions are smooth in the parameters to the
 * accuracy the fits' finite differences assume. */
#include "dm_test.h"

#include <math.h>
#include <stdlib.h>

#include "dm_predict.h"
#include "dm_synth.h"

/* zheng2017 with one effect set through the typed API (v: 1 or 3 numbers). */
static void robot_with(dm_robot *rb, const char *section, const char *key, const double *v)
{
    assert_int_equal(dm_robot_load("zheng2017", rb, NULL), 0);
    if (key)
        assert_int_equal(dm_robot_set_number(rb, section, key, v, NULL), 0);
}

/* Runs of one workspace over robots[0..n-1] against fresh predictions,
 * compared to the bit. */
static void assert_reuse_is_fresh(const dm_dataset *d, const dm_robot *robots, int n, int na,
                                  int nb)
{
    double *fresh = malloc(sizeof(double) * d->n), *reused = malloc(sizeof(double) * d->n);
    dm_predictor *p = dm_predictor_new(&robots[0], d, na, nb, NULL);
    assert_non_null(p);
    for (int r = 0; r < n; r++) {
        assert_int_equal(dm_predict(&robots[r], d, na, nb, fresh, NULL), 0);
        assert_int_equal(dm_predictor_run(p, &robots[r], reused, NULL), 0);
        if (memcmp(fresh, reused, sizeof(double) * d->n))
            print_error("robot %d of %d: the reused workspace differs\n", r, n);
        assert_memory_equal(fresh, reused, sizeof(double) * d->n);
    }
    dm_predictor_free(p);
    free(fresh);
    free(reused);
}

/* Modal data at mesh 2,2 (102 DOF: the subspace solver, which warm-starts
 * within a run), robots whose effects keep and change the DOF count. */
static void reuse_equals_fresh_on_modal_data(void **state)
{
    (void)state;
    dm_robot rb[5];
    const double payload = 0.8, base3[3] = {3e6, 3e6, 3e6}, actuator = 4e4;
    robot_with(&rb[0], NULL, NULL, NULL);
    robot_with(&rb[1], "effects", "payload_mass", &payload);
    robot_with(&rb[2], "effects", "base_stiffness_1", base3);    /* + 3 DOF */
    robot_with(&rb[3], "effects", "actuator_stiffness", &actuator); /* + 1 a chain */
    rb[4] = rb[0];                                                /* back to the first size */
    dm_synth_opts o = {.kind = DM_DATA_MODAL, .npose = 4, .modes = 6, .seed = 5, .na = 2, .nb = 2};
    dm_dataset d;
    assert_int_equal(dm_synthesize(&rb[0], &o, &d, NULL), 0);
    assert_reuse_is_fresh(&d, rb, 5, 2, 2);
    dm_dataset_free(&d);
}

/* Static data with and without clearance (a loaded pose per sample). */
static void reuse_equals_fresh_on_static_data(void **state)
{
    (void)state;
    dm_robot rb[3];
    const double clearance = 2e-5, joint = 5e6;
    robot_with(&rb[0], NULL, NULL, NULL);
    robot_with(&rb[1], "effects", "clearance", &clearance);
    robot_with(&rb[2], "effects", "joint_stiffness", &joint); /* rod ends get DOFs */
    dm_synth_opts o = {.kind = DM_DATA_STATIC, .npose = 4, .seed = 6, .na = 1, .nb = 1};
    dm_dataset d;
    assert_int_equal(dm_synthesize(&rb[0], &o, &d, NULL), 0);
    assert_reuse_is_fresh(&d, rb, 3, 1, 1);
    dm_dataset_free(&d);
}

/* Tracker data: whole runs, and a window on the first part predicted as
 * that part alone would be. */
static void tracker_runs_and_windows(void **state)
{
    (void)state;
    dm_robot rb[5];
    const double beta = 1e-3, alpha = 20, payload = 0.3;
    robot_with(&rb[0], NULL, NULL, NULL);
    robot_with(&rb[1], "damping", "beta", &beta);
    rb[2] = rb[1]; /* damping only, again: the kept modal history replayed */
    assert_int_equal(dm_robot_set_number(&rb[2], "damping", "alpha", &alpha, NULL), 0);
    rb[3] = rb[2]; /* a new model: the history must not be replayed */
    assert_int_equal(dm_robot_set_number(&rb[3], "effects", "payload_mass", &payload, NULL), 0);
    rb[4] = rb[1];
    dm_synth_opts o = {.kind = DM_DATA_TRACKER, .seed = 2, .na = 1, .nb = 1,
                       .path = "circle:centre=0,0,-0.4;radius=0.03;rate=6.283;duration=0.04"};
    dm_dataset d;
    assert_int_equal(dm_synthesize(&rb[0], &o, &d, NULL), 0);
    assert_int_equal(d.npose, 41);
    assert_reuse_is_fresh(&d, rb, 5, 1, 1);

    dm_dataset part = d; /* the first 20 times, as a file cut there */
    part.n = 3 * 20;
    part.npose = 20;
    double *fresh = malloc(sizeof(double) * d.n), *reused = malloc(sizeof(double) * d.n);
    dm_predictor *p = dm_predictor_new(&rb[0], &d, 1, 1, NULL);
    assert_non_null(p);
    for (int r = 0; r < 2; r++) {
        dm_predictor_window(p, part.n);
        assert_int_equal(dm_predict(&rb[r], &part, 1, 1, fresh, NULL), 0);
        assert_int_equal(dm_predictor_run(p, &rb[r], reused, NULL), 0);
        assert_memory_equal(fresh, reused, sizeof(double) * part.n);
        dm_predictor_window(p, d.n); /* and all of it again */
        assert_int_equal(dm_predict(&rb[r], &d, 1, 1, fresh, NULL), 0);
        assert_int_equal(dm_predictor_run(p, &rb[r], reused, NULL), 0);
        assert_memory_equal(fresh, reused, sizeof(double) * d.n);
    }
    dm_predictor_free(p);
    free(fresh);
    free(reused);
    dm_dataset_free(&d);
}

/* A failed run (a mode beyond the model) names the file and leaves the
 * workspace usable. */
static void errors_leave_the_workspace_usable(void **state)
{
    (void)state;
    dm_robot rb;
    robot_with(&rb, NULL, NULL, NULL);
    dm_synth_opts o = {.kind = DM_DATA_MODAL, .npose = 2, .modes = 2, .seed = 1, .na = 1, .nb = 1};
    dm_dataset d;
    assert_int_equal(dm_synthesize(&rb, &o, &d, NULL), 0);
    double pred[4], again[4];
    dm_predictor *p = dm_predictor_new(&rb, &d, 1, 1, NULL);
    assert_non_null(p);
    assert_int_equal(dm_predictor_run(p, &rb, pred, NULL), 0);
    dm_robot far = rb; /* every pose out of reach: arms far too short */
    far.arm_length_m = 0.01;
    far.rod_length_m = 0.01;
    dm_error err;
    assert_int_equal(dm_predictor_run(p, &far, again, &err), DM_EUNREACHABLE);
    assert_non_null(strstr(err.msg, "synthetic modal data:"));
    assert_int_equal(dm_predictor_run(p, &rb, again, NULL), 0);
    assert_memory_equal(pred, again, sizeof pred);
    dm_predictor_free(p);
    dm_dataset_free(&d);
}

/* Tracker predictions at the default mesh are smooth in a parameter to
 * 1e-10 of their largest value: the second difference of the predictions
 * at payload masses m (1 - h), m, m (1 + h) for steps h so small that the
 * curvature is below round-off shows only the noise of the eigen solves
 * and the stepping. The fits' forward differences (diagnose.c,
 * PREDICTION_EPS) and the plan's information assume this accuracy: the
 * bound is that requirement, not a comparison with LAPACK; a solver that
 * stops closer to its residual tolerance carries 1e-9 and fails here. The
 * noise depends on the BLAS kernels: under the 14 OpenBLAS kernel sets of
 * an x86-64 machine (OPENBLAS_CORETYPE) it was 1e-12 to 3.4e-11, in steps
 * of 1.7e-11 (one or two roundings of one quantity), against 3e-12 to
 * 8e-12 once measured on one CPU. The runs (100 steps) take their modes
 * from member bases (integrate_trajectory.c MEMBER_MIN_STEPS), whose
 * eigenvalue bound alone left the vectors noisier: 1.3e-10 here, 6e-12
 * since they converge to the full model's residual as well
 * (dm_analysis_residual_target). */
static void tracker_predictions_are_smooth(void **state)
{
    (void)state;
    dm_robot rb;
    robot_with(&rb, NULL, NULL, NULL);
    dm_synth_opts o = {.kind = DM_DATA_TRACKER, .noise = 2e-6, .seed = 9,
                       .path = "p2p:from=-0.03,-0.02,-0.41;to=0.03,0.02,-0.39;duration=0.05;"
                               "law=bangbang;dwell=0.05"};
    dm_dataset d;
    assert_int_equal(dm_synthesize(&rb, &o, &d, NULL), 0);
    double *f[3];
    for (int i = 0; i < 3; i++)
        assert_non_null(f[i] = malloc(sizeof(double) * d.n));
    const double m0 = 0.2;
    const double steps[] = {1e-10, 1e-8, 1e-6};
    for (int s = 0; s < 3; s++) {
        for (int i = 0; i < 3; i++) {
            double m = m0 * (1 + (i - 1) * steps[s]);
            dm_robot r = rb;
            assert_int_equal(dm_robot_set_number(&r, "effects", "payload_mass", &m, NULL), 0);
            assert_int_equal(dm_predict(&r, &d, 0, 0, f[i], NULL), 0);
        }
        double scale = 0, second = 0;
        for (int j = 0; j < d.n; j++) {
            scale = fmax(scale, fabs(f[1][j]));
            second = fmax(second, fabs(f[0][j] - 2 * f[1][j] + f[2][j]));
        }
        print_message("payload step %g: second difference %.2e of the largest prediction\n",
                      steps[s], second / scale);
        assert_true(second <= 1e-10 * scale);
    }
    for (int i = 0; i < 3; i++)
        free(f[i]);
    dm_dataset_free(&d);
}

/* A tracker run's offsets (dm_predictor_offsets) are the part of its
 * predictions that geometry errors and clearance move: a robot with them,
 * less its offsets, predicts what the robot without them predicts, but
 * for how the elastic error changes with the geometry (the deflection's
 * relative change with a pose moved by the errors, about the errors over
 * the arm's length). Without them the offsets are zero, as the
 * predictions add none; a window's are the first of the whole run's. */
static void offsets_are_what_geometry_errors_move(void **state)
{
    (void)state;
    dm_robot rb[2];
    const double arm[3] = {1e-4, -5e-5, 2e-5}, clearance = 2e-5;
    robot_with(&rb[0], NULL, NULL, NULL);
    robot_with(&rb[1], "effects", "error_arm_length", arm);
    assert_int_equal(dm_robot_set_number(&rb[1], "effects", "clearance", &clearance, NULL), 0);
    dm_synth_opts o = {.kind = DM_DATA_TRACKER, .seed = 2, .na = 2, .nb = 2,
                       .path = "circle:centre=0,0,-0.4;radius=0.04;rate=12.566;duration=0.1"};
    dm_dataset d;
    assert_int_equal(dm_synthesize(&rb[0], &o, &d, NULL), 0);
    double *pred[2], *off[2], *part = malloc(sizeof(double) * d.n);
    dm_predictor *p = dm_predictor_new(&rb[0], &d, 2, 2, NULL);
    assert_non_null(p);
    for (int r = 0; r < 2; r++) {
        assert_non_null(pred[r] = malloc(sizeof(double) * d.n));
        assert_non_null(off[r] = malloc(sizeof(double) * d.n));
        assert_int_equal(dm_predictor_run(p, &rb[r], pred[r], NULL), 0);
        assert_int_equal(dm_predictor_offsets(p, &rb[r], off[r], NULL), 0);
    }
    double moved = 0, elastic = 0, rest = 0;
    for (int i = 0; i < d.n; i++) {
        assert_true(off[0][i] == 0.0);
        moved = fmax(moved, fabs(off[1][i]));
        elastic = fmax(elastic, fabs(pred[0][i]));
        rest = fmax(rest, fabs(pred[1][i] - off[1][i] - pred[0][i]));
    }
    print_message("offsets up to %.3g m, elastic error %.3g m; what is left %.3g m\n", moved,
                  elastic, rest);
    assert_true(moved > 1e-5);
    /* left: the elastic error's change, about 3.6e-5 m x (1e-4 + 2e-5) m /
     * 0.2 m = 2e-8 m (measured 3.2e-8 m, 1.6e-4 of the offsets) */
    assert_true(rest <= 1e-3 * moved);
    dm_dataset cut = d; /* a window's offsets: those of the file cut there */
    cut.n = 3 * 10;
    cut.npose = 10;
    dm_predictor *c = dm_predictor_new(&rb[0], &cut, 2, 2, NULL);
    assert_non_null(c);
    assert_int_equal(dm_predictor_offsets(c, &rb[1], off[0], NULL), 0);
    dm_predictor_window(p, cut.n);
    assert_int_equal(dm_predictor_offsets(p, &rb[1], part, NULL), 0);
    assert_memory_equal(part, off[0], sizeof(double) * cut.n);
    dm_predictor_free(c);
    dm_predictor_free(p);
    for (int r = 0; r < 2; r++)
        free(pred[r]), free(off[r]);
    free(part);
    dm_dataset_free(&d);
}

int main(int argc, char **argv)
{
    if (argc > 1)
        cmocka_set_test_filter(argv[1]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(reuse_equals_fresh_on_modal_data),
        cmocka_unit_test(reuse_equals_fresh_on_static_data),
        cmocka_unit_test(tracker_runs_and_windows),
        cmocka_unit_test(errors_leave_the_workspace_usable),
        cmocka_unit_test(tracker_predictions_are_smooth),
        cmocka_unit_test(offsets_are_what_geometry_errors_move),
    };
    return cmocka_run_group_tests_name("predict", tests, NULL, NULL);
}
