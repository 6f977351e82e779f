/* The parameter study: each combination is exactly the trajectory run of
 * the robot with those key values (an independent dm_integrate_trajectory
 * of a robot set by hand, bitwise); the same cells on 1 and 3 threads; a
 * key the robot lacks refused before any run; a value the robot refuses
 * fails that combination alone. */
#include "dm_test.h"

#include <math.h>

#include "dm_study.h"
#include "dm_trajectory.h"

#define PATH "p2p:from=0,0,-0.5;to=0.04,0,-0.5;duration=0.02"

static void make_study(dm_study *s, int threads)
{
    memset(s, 0, sizeof *s);
    s->naxis = 2;
    assert_int_equal(dm_study_axis_parse("arm.side=0.02:0.03:3", &s->axis[0]), 0);
    assert_int_equal(dm_study_axis_parse("rod.side=0.006:0.01:2", &s->axis[1]), 0);
    s->path = PATH;
    dm_integ_opts_default(&s->opts);
    s->opts.reference = 0;
    s->opts.na = s->opts.nb = 1;
    s->opts.k = 6;
    s->threads = threads;
}

/* The run of combination (i, j), made by hand. */
static dm_integ_summary direct_run(const dm_robot *base, const dm_study *s, int i, int j)
{
    dm_robot rb = *base;
    char a[128];
    snprintf(a, sizeof a, "arm.side=%.17g", dm_study_value(&s->axis[0], i));
    assert_int_equal(dm_robot_set(&rb, a, NULL), 0);
    snprintf(a, sizeof a, "rod.side=%.17g", dm_study_value(&s->axis[1], j));
    assert_int_equal(dm_robot_set(&rb, a, NULL), 0);
    dm_trajectory tr;
    dm_integ_summary sum;
    assert_int_equal(dm_traj_make(s->path, &rb, &tr, NULL), 0);
    assert_int_equal(dm_integrate_trajectory(&rb, &tr, &s->opts, NULL, NULL, &sum, NULL), 0);
    dm_traj_free(&tr);
    return sum;
}

static void cells_are_the_runs_on_any_threads(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    dm_study s;
    dm_study_cell one[6], three[6];
    make_study(&s, 1);
    assert_int_equal(dm_study_cells(&s), 6);
    assert_int_equal(dm_study_run(&rb, &s, one, NULL), 0);
    s.threads = 3;
    assert_int_equal(dm_study_run(&rb, &s, three, NULL), 0);
    assert_true(fabs(dm_study_value(&s.axis[0], 2) - 0.03) < 1e-15);
    for (int c = 0; c < 6; c++) {
        assert_int_equal(one[c].status, DM_OK);
        assert_string_equal(one[c].msg, "ok");
        dm_integ_summary d = direct_run(&rb, &s, c / 2, c % 2);
        assert_true(one[c].mean_error_m > 0 && one[c].mean_error_m == d.mean_error_m);
        assert_true(one[c].peak_error_m == d.peak_error_m);
        assert_true(three[c].mean_error_m == one[c].mean_error_m);
        assert_true(three[c].peak_error_m == one[c].peak_error_m);
    }
    /* thicker arms (rows) deflect less: Chen's trend, a check the table is
     * not transposed */
    assert_true(one[4].mean_error_m < one[0].mean_error_m);
}

static void bad_keys_and_values(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    dm_study s;
    dm_study_cell cells[6];
    dm_error err;
    make_study(&s, 2);
    assert_int_equal(dm_study_axis_parse("arm.colour=1:2:3", &s.axis[1]), 0);
    assert_int_equal(dm_study_run(&rb, &s, cells, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "colour"));
    /* side -0.01..0.01: the first value is refused by the robot, the others run */
    make_study(&s, 2);
    s.naxis = 1;
    assert_int_equal(dm_study_axis_parse("arm.side=0.03:-0.01:3", &s.axis[0]), 0);
    assert_int_equal(dm_study_run(&rb, &s, cells, &err), 0);
    assert_int_equal(cells[0].status, DM_OK);
    assert_int_equal(cells[2].status, DM_EINVAL);
    assert_true(isnan(cells[2].mean_error_m) && strstr(cells[2].msg, "side"));
    assert_int_equal(dm_study_axis_parse("arm.side=1:2", &s.axis[0]), -1);
    assert_int_equal(dm_study_axis_parse("arm.side=1:2:0", &s.axis[0]), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(cells_are_the_runs_on_any_threads),
        cmocka_unit_test(bad_keys_and_values),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
