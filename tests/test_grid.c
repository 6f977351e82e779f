/* Grids of poses: specs parsed and written back, positions, errors that
 * name what is wrong. */
#include "dm_test.h"

#include "dm_grid.h"

static void expect_grid_error(const char *spec, const char *what)
{
    dm_grid g;
    dm_error err;
    int rc = dm_grid_parse(spec, &g, &err);
    if (rc != DM_EINVAL || !strstr(err.msg, what)) {
        print_error("grid '%s': expected an error with '%s', got %d: %s\n", spec, what, rc, err.msg);
        fail();
    }
}

static void grid_specs(void **state)
{
    (void)state;
    dm_grid g, back;
    char text[512];
    assert_int_equal(dm_grid_parse("x=-0.3:0.3:61,y=-0.2:0.2:5,z=-0.5", &g, NULL), 0);
    assert_int_equal(g.kind, DM_GRID_CARTESIAN);
    assert_int_equal(dm_grid_points(&g), 61 * 5);
    assert_rel(dm_grid_value(&g.axis[0], 30), 0.0 + 1e-300, 1, "centre of x");
    dm_grid_format(&g, text, sizeof text);
    assert_string_equal(text, "x=-0.3:0.3:61,y=-0.2:0.2:5,z=-0.5");
    assert_int_equal(dm_grid_parse(text, &back, NULL), 0);
    assert_memory_equal(&g, &back, sizeof g);
    assert_int_equal(dm_grid_parse("z=-0.6:-0.4:3,phi=0:90:4,r=0.1", &g, NULL), 0);
    assert_int_equal(g.kind, DM_GRID_CYLINDRICAL);
    int idx[3] = {0, 3, 2};
    double P[3];
    dm_grid_position(&g, idx, P);
    assert_abs(P[0], 0.0, 1e-15, "r cos 90");
    assert_rel(P[1], 0.1, 1e-15, "r sin 90");
    assert_rel(P[2], -0.4, 1e-15, "z");
    expect_grid_error("x=-0.3:0.3:61,y=0", "axis z missing");
    expect_grid_error("x=1,y=2,z=3,x=4", "more than three");
    expect_grid_error("x=1,x=2,z=3", "given twice");
    expect_grid_error("x=-0.3:0.3:0,y=0,z=0", "N must be");
    expect_grid_error("x=-0.3:0.3:2.5,y=0,z=0", "N must be");
    expect_grid_error("x=0:0:5,y=0,z=0", "empty range");
    expect_grid_error("x=0:1,y=0,z=0", "not A:B:N");
    expect_grid_error("x=a:b:3,y=0,z=0", "not A:B:N");
    expect_grid_error("r=-0.1:0.2:3,phi=0,z=0", "r must be >= 0");
    expect_grid_error("x=0,phi=0,z=0", "does not belong");
    expect_grid_error("w=0,q=0,z=0", "give x=,y=,z=");
    expect_grid_error("x=0:1:100000,y=0:1:100000,z=0:1:100", "more than");
}

/* Every value of an axis lies on the line from A to B, both ends exact;
 * the canonical text of odd values reads back to the same bits. */
static void grid_values_and_round_trip(void **state)
{
    (void)state;
    dm_grid g, back;
    char text[512];
    assert_int_equal(dm_grid_parse("x=-0.123456789:0.3:7,y=0.1:0.2:2,z=-0.7:-0.4:3", &g, NULL), 0);
    assert_true(dm_grid_value(&g.axis[0], 0) == -0.123456789);
    assert_true(dm_grid_value(&g.axis[0], 6) == 0.3);
    for (int i = 0; i < 7; i++)
        assert_abs(dm_grid_value(&g.axis[0], i), -0.123456789 + i * (0.3 + 0.123456789) / 6,
                   1e-16, "x[%d]", i);
    int idx[3] = {6, 1, 2};
    double P[3];
    dm_grid_position(&g, idx, P);
    assert_true(P[0] == 0.3 && P[1] == 0.2 && P[2] == -0.4);
    dm_grid_format(&g, text, sizeof text);
    assert_int_equal(dm_grid_parse(text, &back, NULL), 0);
    assert_memory_equal(&g, &back, sizeof g);
    assert_int_equal(dm_grid_points(&g), 7 * 2 * 3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(grid_specs),
        cmocka_unit_test(grid_values_and_round_trip),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
