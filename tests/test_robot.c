/* Robot files: presets load, write/parse round trip, and every error path
 * of the parser names the file, the line and the key. */
#include "dm_test.h"

#include <stdlib.h>
#include <unistd.h>

#include "dm_robot.h"

/* A valid file; line numbers below refer to it. */
static const char BASE[] =
    "[robot]\n"                    /* 1 */
    "name = test\n"                /* 2 */
    "[geometry]\n"                 /* 3 */
    "base_radius = 0.1\n"          /* 4 */
    "platform_radius = 0.05\n"     /* 5 */
    "arm_length = 0.5\n"           /* 6 */
    "rod_length = 0.6\n"           /* 7 */
    "rod_half_spacing = 0.025\n"   /* 8 */
    "[arm]\n"                      /* 9 */
    "shape = square\n"             /* 10 */
    "side = 0.02\n"                /* 11 */
    "youngs_modulus = 210e9\n"     /* 12 */
    "poisson_ratio = 0.3\n"        /* 13 */
    "density = 7850\n"             /* 14 */
    "[rod]\n"                      /* 15 */
    "shape = tube\n"               /* 16 */
    "diameter = 0.016\n"           /* 17 */
    "inner_diameter = 0.014\n"     /* 18 */
    "youngs_modulus = 70e9\n"      /* 19 */
    "shear_modulus = 26.5e9\n"     /* 20 */
    "density = 2700\n"             /* 21 */
    "[platform]\n"                 /* 22 */
    "mass = 0.2\n";                /* 23 */

/* BASE with line `line` replaced by `repl` (NULL: deleted); `extra` appended. */
static char *edited(int line, const char *repl, const char *extra)
{
    static char buf[4096];
    buf[0] = '\0';
    const char *p = BASE;
    for (int n = 1; *p; n++) {
        const char *nl = strchr(p, '\n');
        size_t len = (size_t)(nl - p) + 1;
        if (n != line)
            strncat(buf, p, len);
        else if (repl) {
            strcat(buf, repl);
            strcat(buf, "\n");
        }
        p += len;
    }
    if (extra)
        strcat(buf, extra);
    return buf;
}

static void expect_error(const char *text, const char *where, const char *what)
{
    dm_robot rb;
    dm_error err;
    int rc = dm_robot_parse_string(text, "bad.ini", &rb, &err);
    if (rc != DM_EINVAL || !strstr(err.msg, where) || (what && !strstr(err.msg, what))) {
        print_error("expected error containing '%s' and '%s', got rc %d: %s\n", where,
                    what ? what : "", rc, err.msg);
        fail();
    }
}

static void base_text_is_valid(void **state)
{
    (void)state;
    dm_robot rb;
    dm_error err;
    assert_int_equal(dm_robot_parse_string(BASE, "ok.ini", &rb, &err), 0);
    assert_string_equal(rb.name, "test");
    assert_int_equal(rb.na, 4); /* documented default mesh */
    assert_int_equal(rb.nb, 4);
    assert_rel(rb.gravity_ms2[2], -9.80665, 0, "default gravity");
    assert_rel(rb.arm.shear_pa, 210e9 / 2.6, 1e-15, "G from nu");
    assert_rel(rb.platform_inertia_kgm2[2], 0.2 * 0.05 * 0.05 / 2, 1e-15, "thin-disc Izz");
}

static void presets_load_and_round_trip(void **state)
{
    (void)state;
    for (const char *const *n = dm_robot_preset_names(); *n; n++) {
        dm_robot rb, back;
        dm_error err;
        assert_int_equal(dm_robot_load(*n, &rb, &err), 0);
        assert_string_equal(rb.name, *n);
        char path[] = "/tmp/dm_robot_XXXXXX";
        int fd = mkstemp(path);
        assert_true(fd >= 0);
        FILE *f = fdopen(fd, "w");
        assert_int_equal(dm_robot_write(&rb, f), 0);
        fclose(f);
        assert_int_equal(dm_robot_parse_file(path, &back, &err), 0);
        unlink(path);
        assert_memory_equal(&rb.arm, &back.arm, sizeof rb.arm);
        assert_memory_equal(&rb.rod, &back.rod, sizeof rb.rod);
        assert_rel(back.rod_length_m, rb.rod_length_m, 0, "rod length round trip");
        assert_rel(back.platform_inertia_kgm2[0], rb.platform_inertia_kgm2[0], 0, "inertia");
        assert_memory_equal(rb.home_m, back.home_m, sizeof rb.home_m);
    }
    assert_int_equal(dm_robot_preset_names()[3], NULL);
}

static void unknown_section_and_key(void **state)
{
    (void)state;
    expect_error(edited(0, NULL, "[gearbox]\nratio = 3\n"), "bad.ini:25: [gearbox] ratio",
                 "unknown section");
    expect_error(edited(5, "platform_radiuss = 0.05", NULL), "bad.ini:5: [geometry] platform_radiuss",
                 "unknown key");
    expect_error(edited(0, NULL, "[effects]\nwobble = 1\n"), "bad.ini:25: [effects] wobble",
                 "model extension");
}

static void missing_required_keys(void **state)
{
    (void)state;
    expect_error(edited(7, NULL, NULL), "[geometry] rod_length", "required key missing");
    expect_error(edited(23, NULL, NULL), "[platform] mass", "required key missing");
    expect_error(edited(16, NULL, NULL), "[rod] shape", "required key missing");
    expect_error(edited(14, NULL, NULL), "[arm] density", "required key missing");
    expect_error(edited(11, NULL, NULL), "bad.ini:10: [arm] side", "missing");
    expect_error(edited(13, NULL, NULL), "[arm] poisson_ratio", "shear_modulus");
}

static void non_physical_values(void **state)
{
    (void)state;
    expect_error(edited(6, "arm_length = -0.5", NULL), "bad.ini:6: [geometry] arm_length", "> 0");
    expect_error(edited(6, "arm_length = 0", NULL), "bad.ini:6: [geometry] arm_length", "> 0");
    expect_error(edited(6, "arm_length = fast", NULL), "bad.ini:6: [geometry] arm_length",
                 "not a number");
    expect_error(edited(6, "arm_length = 0.5 m", NULL), "bad.ini:6:", "not a number");
    expect_error(edited(6, "arm_length = nan", NULL), "bad.ini:6:", "not a number");
    expect_error(edited(13, "poisson_ratio = 0.7", NULL), "bad.ini:13: [arm] poisson_ratio",
                 "(-1, 0.5)");
    expect_error(edited(18, "inner_diameter = 0.02", NULL), "bad.ini:18: [rod] inner_diameter",
                 "smaller than diameter");
    expect_error(edited(23, "mass = -1", NULL), "bad.ini:23: [platform] mass", "> 0");
    /* |R - r| beyond la + lb: the robot can reach nothing */
    expect_error(edited(4, "base_radius = 2.0", NULL), "bad.ini:7: [geometry] rod_length",
                 "reach nothing");
}

static void malformed_values(void **state)
{
    (void)state;
    expect_error(edited(10, "shape = hexagon", NULL), "bad.ini:10: [arm] shape",
                 "not a section shape");
    expect_error(edited(0, NULL, "[mesh]\nna = 0\n"), "bad.ini:25: [mesh] na", "whole number");
    expect_error(edited(0, NULL, "[mesh]\nnb = 2.5\n"), "bad.ini:25: [mesh] nb", "whole number");
    expect_error(edited(0, NULL, "[environment]\ngravity = 0, -9.8\n"),
                 "bad.ini:25: [environment] gravity", "three numbers");
    expect_error(edited(0, NULL, "[platform]\ninertia = 1, -1, 1\n"), "[platform] inertia",
                 "negative");
    expect_error(edited(0, NULL, "[geometry]\nelbow = sideways\n"), "[geometry] elbow",
                 "elbow branch");
    expect_error(edited(0, NULL, "[damping]\nbeta = -1e-4\n"), "[damping] beta", ">= 0");
    expect_error(edited(2, "name = ", NULL), "bad.ini:2: [robot] name", "1 to 63");
}

static void inconsistent_keys(void **state)
{
    (void)state;
    expect_error(edited(0, NULL, "[arm]\nside = 0.03\n"), "bad.ini:25: [arm] side",
                 "given twice (first on line 11)");
    expect_error(edited(11, "diameter = 0.02", NULL), "bad.ini:11: [arm] diameter",
                 "does not apply");
    expect_error(edited(20, "poisson_ratio = 0.33", "[rod]\nshear_modulus = 26e9\n"),
                 "[rod] poisson_ratio", "not both");
}

static void effects_keys(void **state)
{
    (void)state;
    dm_robot rb;
    dm_error err;
    const char *good = "[effects]\nactuator_stiffness = 5e3\npayload_mass = 1.5\n"
                       "payload_offset = 0, 0, -0.05\nbase_stiffness = 1e6, 1e6, 2e6\n"
                       "base_stiffness_1 = 5e5, 5e5, 5e5\ngeometric_stiffness = on\n";
    assert_int_equal(dm_robot_parse_string(edited(0, NULL, good), "fx.ini", &rb, &err), 0);
    assert_rel(rb.effects.base_stiffness_n_per_m[0][2], 2e6, 0, "global base spring");
    assert_rel(rb.effects.base_stiffness_n_per_m[1][0], 5e5, 0, "per-chain override");
    assert_int_equal(rb.effects.geometric_stiffness, 1);
    expect_error(edited(0, NULL, "[effects]\nbase_stiffness = 1e6, 0, 1e6\n"),
                 "bad.ini:25: [effects] base_stiffness", "no spring along Y");
    expect_error(edited(0, NULL, "[effects]\ngeometric_stiffness = yes\n"),
                 "bad.ini:25: [effects] geometric_stiffness", "on or off");
    expect_error(edited(0, NULL, "[effects]\njoint_stiffness = -1\n"),
                 "bad.ini:25: [effects] joint_stiffness", "> 0");
    expect_error(edited(0, NULL, "[effects]\npayload_offset = 1, 2\n"), "[effects] payload_offset",
                 "three numbers");
}

static void syntax_and_files(void **state)
{
    (void)state;
    expect_error(edited(8, "rod_half_spacing 0.025", NULL), "bad.ini:8", "not an INI line");
    dm_robot rb;
    dm_error err;
    assert_int_equal(dm_robot_load("/nonexistent/robot.ini", &rb, &err), DM_EIO);
    assert_non_null(strstr(err.msg, "/nonexistent/robot.ini"));
    assert_int_equal(dm_robot_load("chen2019", &rb, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "neither a preset"));
    assert_non_null(strstr(err.msg, "chen2018"));
    /* comments and inline comments are fine */
    assert_int_equal(dm_robot_parse_string(edited(6, "# c\narm_length = 0.5 ; la", NULL), "c.ini",
                                           &rb, &err), 0);
    assert_rel(rb.arm_length_m, 0.5, 0, "inline comment");
}

static void overrides_are_validated(void **state)
{
    (void)state;
    dm_robot rb, before;
    dm_error err;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    double A0 = rb.arm.section.area_m2;
    assert_int_equal(dm_robot_set(&rb, "arm.side=0.025", &err), 0);
    assert_rel(rb.arm.section.area_m2, 0.025 * 0.025, 1e-15, "section follows the override");
    assert_true(rb.arm.section.area_m2 > A0);
    assert_string_equal(rb.source, "robots/chen2018.ini (built-in preset)");
    assert_int_equal(dm_robot_set(&rb, "rod.poisson_ratio=0.25", &err), 0);
    assert_rel(rb.rod.shear_pa, 210e9 / 2.5, 1e-15, "G from the new nu");
    assert_int_equal(dm_robot_set(&rb, "damping.beta=1e-4", &err), 0);
    assert_rel(rb.rayleigh_beta, 1e-4, 0, "new section key");
    before = rb;
    assert_int_equal(dm_robot_set(&rb, "arm.side=-1", &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "[arm] side: must be > 0"));
    assert_non_null(strstr(err.msg, "with arm.side=-1"));
    assert_memory_equal(&rb, &before, sizeof rb);
    assert_int_equal(dm_robot_set(&rb, "arm.sidee=1", &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "unknown key"));
    assert_int_equal(dm_robot_set(&rb, "arm.diameter=0.02", &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "does not apply"));
    assert_int_equal(dm_robot_set(&rb, "nonsense", &err), DM_EINVAL);
    assert_memory_equal(&rb, &before, sizeof rb);
}

/* The typed setter leaves the robot exactly as the text one (the robot
 * file written and read again) for every settable key; refuses what the
 * reader refuses, and keys other values derive from. */
static void typed_values_equal_text_ones(void **state)
{
    (void)state;
    static const struct {
        const char *section, *key, *text;
        double v[3];
    } cases[] = {
        {"effects", "actuator_stiffness", "2.5e4", {2.5e4}},
        {"effects", "joint_stiffness", "3e6", {3e6}},
        {"effects", "payload_mass", "0.35", {0.35}},
        {"effects", "payload_offset", "0.01,-0.02,0.003", {0.01, -0.02, 0.003}},
        {"effects", "elbow_mass", "0.07", {0.07}},
        {"effects", "base_stiffness", "1e6,2e6,3e6", {1e6, 2e6, 3e6}},
        {"effects", "base_stiffness_1", "4e6,5e6,6e6", {4e6, 5e6, 6e6}},
        {"effects", "geometric_stiffness", "on", {1}},
        {"effects", "clearance", "1.5e-5", {1.5e-5}},
        {"effects", "actuator_clearance_axial", "2e-5", {2e-5}},
        {"effects", "error_arm_length", "1e-4,-2e-4,3e-5", {1e-4, -2e-4, 3e-5}},
        {"effects", "error_theta_deg", "0.05,-0.1,0.02", {0.05, -0.1, 0.02}},
        {"effects", "error_alpha0_deg", "0.3,0,-0.2", {0.3, 0, -0.2}},
        {"damping", "alpha", "12.5", {12.5}},
        {"damping", "beta", "2e-5", {2e-5}},
    };
    dm_robot base;
    assert_int_equal(dm_robot_load("zheng2017", &base, NULL), 0);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        dm_robot typed = base, text = base;
        char assign[128];
        snprintf(assign, sizeof assign, "%s.%s=%s", cases[c].section, cases[c].key, cases[c].text);
        assert_int_equal(dm_robot_set(&text, assign, NULL), 0);
        assert_int_equal(dm_robot_set_number(&typed, cases[c].section, cases[c].key, cases[c].v,
                                             NULL), 0);
        /* the same text of the source; the bytes after it do not count */
        assert_string_equal(typed.source, text.source);
        memset(typed.source, 0, sizeof typed.source);
        memset(text.source, 0, sizeof text.source);
        if (memcmp(&typed, &text, sizeof typed)) {
            print_error("%s: the typed setter differs from the text one\n", assign);
            fail();
        }
    }
    dm_robot rb = base;
    dm_error err;
    const double minus[3] = {-1, 0, 0}, nan3[3] = {NAN, 0, 0}, half[3] = {1e6, 0, 1e6};
    assert_int_equal(dm_robot_set_number(&rb, "effects", "payload_mass", minus, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "[effects] payload_mass: must be > 0"));
    assert_int_equal(dm_robot_set_number(&rb, "damping", "beta", nan3, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "not a number"));
    assert_int_equal(dm_robot_set_number(&rb, "effects", "base_stiffness_2", half, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "chain 2 has no spring along Y"));
    assert_int_equal(dm_robot_set_number(&rb, "rod", "youngs_modulus", half, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "dm_robot_set"));
    assert_int_equal(dm_robot_set_number(&rb, "effects", "bogus", half, &err), DM_EINVAL);
    assert_memory_equal(&rb, &base, sizeof rb);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(base_text_is_valid),
        cmocka_unit_test(presets_load_and_round_trip),
        cmocka_unit_test(unknown_section_and_key),
        cmocka_unit_test(missing_required_keys),
        cmocka_unit_test(non_physical_values),
        cmocka_unit_test(malformed_values),
        cmocka_unit_test(inconsistent_keys),
        cmocka_unit_test(effects_keys),
        cmocka_unit_test(syntax_and_files),
        cmocka_unit_test(overrides_are_validated),
        cmocka_unit_test(typed_values_equal_text_ones),
    };
    return cmocka_run_group_tests_name("robot", tests, NULL, NULL);
}
