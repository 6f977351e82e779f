/* Nominal motions: circles and straight-line moves against their analytic
 * positions, velocities and accelerations; the motion laws' ends, middles
 * and derivatives; sampled paths (a spline through samples on a line is
 * that line); the presets; and bad specs and files, whose errors name the
 * spec or the file, line and column. */
#include "dm_test.h"

#include <stdlib.h>
#include <unistd.h>

#include "dm_trajectory.h"

static const char *write_file(char *path, const char *text)
{
    strcpy(path, "/tmp/dm_traj_XXXXXX.csv");
    int fd = mkstemps(path, 4);
    assert_true(fd >= 0);
    FILE *f = fdopen(fd, "w");
    fputs(text, f);
    fclose(f);
    return path;
}

static void assert_vec(const double got[3], const double want[3], double tol, const char *what,
                       double t)
{
    for (int k = 0; k < 3; k++)
        assert_abs(got[k], want[k], tol, "%s[%d] at t = %g s", what, k, t);
}

/* The spec fails with DM_EINVAL and a message holding `part`. */
static void assert_refused(const char *spec, const char *part)
{
    dm_trajectory tr;
    dm_error err;
    int rc = dm_traj_make(spec, NULL, &tr, &err);
    if (rc != DM_EINVAL || !strstr(err.msg, part))
        print_error("'%s': rc %d, '%s' (want '%s')\n", spec, rc, rc ? err.msg : "", part);
    assert_int_equal(rc, DM_EINVAL);
    assert_non_null(strstr(err.msg, part));
}

/* P = c + R (cos phi u + sin phi w), phi = phase + w t, in each plane. */
static void circles_are_analytic(void **state)
{
    (void)state;
    static const struct {
        const char *plane;
        int u, w; /* the axes cos and sin run along */
    } planes[] = {{"xy", 0, 1}, {"yz", 2, 1}, {"xz", 0, 2}};
    const double c[3] = {0.01, -0.02, -0.4}, R = 0.05, rate = 6.0, T = 1.5;
    const double phase = 30 * M_PI / 180;
    for (int p = 0; p < 3; p++) {
        char spec[160];
        snprintf(spec, sizeof spec,
                 "circle:centre=0.01,-0.02,-0.4;radius=0.05;rate=6;duration=1.5;plane=%s;phase=30",
                 planes[p].plane);
        dm_trajectory tr;
        assert_int_equal(dm_traj_make(spec, NULL, &tr, NULL), 0);
        assert_int_equal(tr.kind, DM_PATH_CIRCLE);
        assert_abs(tr.duration_s, T, 0, "duration");
        for (double t = 0; t <= T; t += 0.1) {
            double P[3], v[3], a[3], Pw[3] = {c[0], c[1], c[2]}, vw[3] = {0}, aw[3] = {0};
            double phi = phase + rate * t;
            Pw[planes[p].u] += R * cos(phi);
            Pw[planes[p].w] += R * sin(phi);
            vw[planes[p].u] = -R * rate * sin(phi);
            vw[planes[p].w] = R * rate * cos(phi);
            aw[planes[p].u] = -R * rate * rate * cos(phi);
            aw[planes[p].w] = -R * rate * rate * sin(phi);
            dm_traj_eval(&tr, t, P, v, a);
            assert_vec(P, Pw, 1e-15, "P", t);
            assert_vec(v, vw, 1e-14, "v", t);
            assert_vec(a, aw, 1e-13, "a", t);
        }
        double P1[3], P2[3], v[3], a[3]; /* times beyond the ends are clamped */
        dm_traj_eval(&tr, T + 1, P1, v, a);
        dm_traj_eval(&tr, T, P2, v, a);
        assert_memory_equal(P1, P2, sizeof P1);
        dm_traj_eval(&tr, -1, P1, v, a);
        dm_traj_eval(&tr, 0, P2, v, a);
        assert_memory_equal(P1, P2, sizeof P1);
        dm_traj_free(&tr);
    }
}

/* Each law: s(0) = 0, s(1) = 1, at rest at both ends, symmetric about the
 * middle (s(1/2) = 1/2), and ds, dds the derivatives of s. */
static void motion_laws(void **state)
{
    (void)state;
    const double mid_speed[4] = {2.0, 1.5, 2.1875, 2.0}; /* ds(1/2) of each law */
    for (int law = 0; law < 4; law++) {
        double s, ds, dds;
        dm_motion_law_eval(law, 0, &s, &ds, &dds);
        assert_abs(s, 0, 1e-15, "law %d: s(0)", law);
        assert_abs(ds, 0, 1e-15, "law %d: ds(0)", law);
        dm_motion_law_eval(law, 1, &s, &ds, &dds);
        assert_abs(s, 1, 1e-15, "law %d: s(1)", law);
        assert_abs(ds, 0, 1e-14, "law %d: ds(1)", law);
        dm_motion_law_eval(law, 0.5, &s, &ds, &dds);
        assert_abs(s, 0.5, 1e-15, "law %d: s(1/2)", law);
        assert_abs(ds, mid_speed[law], 1e-14, "law %d: ds(1/2)", law);
        for (double x = 0.05; x < 1; x += 0.1) { /* central differences, off the kinks */
            const double h = 1e-6;
            double sp, sm, dsp, dsm, unused;
            dm_motion_law_eval(law, x, &s, &ds, &dds);
            dm_motion_law_eval(law, x + h, &sp, &dsp, &unused);
            dm_motion_law_eval(law, x - h, &sm, &dsm, &unused);
            assert_abs((sp - sm) / (2 * h), ds, 1e-7, "law %d: ds at %g", law, x);
            assert_abs((dsp - dsm) / (2 * h), dds, 1e-5, "law %d: dds at %g", law, x);
        }
    }
}

/* A straight line from A to B: P = A + s(t/T) (B - A), v = s' (B - A)/T,
 * a = s'' (B - A)/T^2, then at rest at B through the dwell. */
static void straight_lines_are_analytic(void **state)
{
    (void)state;
    static const char *const laws[4] = {"cycloidal", "trapezoidal", "poly7", "bangbang"};
    const double A[3] = {-0.03, -0.02, -0.41}, B[3] = {0.03, 0.02, -0.39}, T = 0.05, dwell = 0.02;
    for (int law = 0; law < 4; law++) {
        char spec[160];
        snprintf(spec, sizeof spec,
                 "p2p:from=-0.03,-0.02,-0.41;to=0.03,0.02,-0.39;duration=0.05;law=%s;dwell=0.02",
                 laws[law]);
        dm_trajectory tr;
        assert_int_equal(dm_traj_make(spec, NULL, &tr, NULL), 0);
        assert_int_equal(tr.kind, DM_PATH_SEGMENTS);
        assert_int_equal(tr.nseg, 2);
        assert_abs(tr.duration_s, T + dwell, 1e-15, "duration");
        for (double t = 0; t <= T + dwell + 1e-12; t += 0.0025) {
            double P[3], v[3], a[3], Pw[3], vw[3], aw[3], s, ds, dds;
            dm_motion_law_eval(law, t / T, &s, &ds, &dds);
            if (t >= T) /* the dwell */
                s = 1, ds = dds = 0;
            for (int k = 0; k < 3; k++) {
                Pw[k] = A[k] + s * (B[k] - A[k]);
                vw[k] = ds * (B[k] - A[k]) / T;
                aw[k] = dds * (B[k] - A[k]) / (T * T);
            }
            dm_traj_eval(&tr, t, P, v, a);
            assert_vec(P, Pw, 1e-15, "P", t);
            assert_vec(v, vw, 1e-13, "v", t);
            if (fabs(t - T / 3) > 1e-9 && fabs(t - T / 2) > 1e-9 && fabs(t - 2 * T / 3) > 1e-9)
                assert_vec(a, aw, 1e-10, "a", t); /* (off the laws' jumps in acceleration) */
        }
        double P[3], v[3], a[3], mid[3] = {0, 0, -0.4};
        dm_traj_eval(&tr, T / 2, P, v, a);
        assert_vec(P, mid, 1e-15, "the middle", T / 2);
        dm_traj_free(&tr);
    }
    /* "jerk-limited" names poly7; no law: cycloidal */
    dm_trajectory a, b;
    assert_int_equal(dm_traj_make("p2p:from=0,0,-0.4;to=0.1,0,-0.4;duration=0.2;law=jerk-limited",
                                  NULL, &a, NULL), 0);
    assert_int_equal(a.seg[0].law, DM_LAW_POLY7);
    assert_int_equal(dm_traj_make("p2p:from=0,0,-0.4;to=0.1,0,-0.4;duration=0.2", NULL, &b, NULL),
                     0);
    assert_int_equal(b.seg[0].law, DM_LAW_CYCLOIDAL);
    assert_int_equal(b.nseg, 1);
    dm_traj_free(&a);
    dm_traj_free(&b);
}

/* The pick cycle: 25 mm up, 305 mm across, 25 mm down in the given time,
 * each segment with the same peak acceleration (times ~ sqrt(length)). */
static void pick_cycle(void **state)
{
    (void)state;
    dm_trajectory tr;
    assert_int_equal(dm_traj_make("pick:start=-0.15,0,-0.45;duration=0.6;axis=y", NULL, &tr, NULL),
                     0);
    assert_int_equal(tr.nseg, 3);
    assert_abs(tr.duration_s, 0.6, 1e-15, "duration");
    double P[3], v[3], a[3], end[3] = {-0.15, 0.305, -0.45}, top[3] = {-0.15, 0, -0.425};
    dm_traj_eval(&tr, tr.seg[1].t0_s, P, v, a);
    assert_vec(P, top, 1e-15, "the top of the lift", tr.seg[1].t0_s);
    dm_traj_eval(&tr, 0.6, P, v, a);
    assert_vec(P, end, 1e-15, "the end", 0.6);
    double peak[3];
    for (int j = 0; j < 3; j++) {
        const dm_segment *s = &tr.seg[j];
        double D = 0;
        for (int k = 0; k < 3; k++)
            D += (s->to_m[k] - s->from_m[k]) * (s->to_m[k] - s->from_m[k]);
        peak[j] = 2 * M_PI * sqrt(D) / (s->duration_s * s->duration_s); /* cycloidal */
    }
    assert_rel(peak[1], peak[0], 1e-12, "peak acceleration across vs up");
    assert_rel(peak[2], peak[0], 1e-12, "peak acceleration down vs up");
    dm_traj_free(&tr);
    dm_robot rb; /* without a start: 152.5 mm before home */
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    assert_int_equal(dm_traj_make("pick", &rb, &tr, NULL), 0);
    assert_abs(tr.seg[0].from_m[0], rb.home_m[0] - 0.1525, 1e-15, "default start");
    assert_abs(tr.duration_s, 0.5, 0, "default duration");
    dm_traj_free(&tr);
}

/* The papers' trajectories by name (docs/model.md §7). */
static void presets(void **state)
{
    (void)state;
    dm_trajectory tr;
    assert_int_equal(dm_traj_make("zheng2017", NULL, &tr, NULL), 0);
    assert_int_equal(tr.kind, DM_PATH_CIRCLE);
    assert_abs(tr.radius_m, 0.05, 0, "radius");
    assert_abs(tr.centre_m[2], -0.4, 0, "centre z");
    assert_abs(tr.duration_s, 1.0, 0, "duration");
    double P[3], v[3], a[3], start[3] = {0.05, 0, -0.4};
    dm_traj_eval(&tr, 1.0, P, v, a); /* one turn */
    assert_vec(P, start, 1e-15, "after one turn", 1.0);
    dm_traj_free(&tr);
    assert_int_equal(dm_traj_make("han2011-vertical", NULL, &tr, NULL), 0);
    assert_true(tr.u[2] == 1 && tr.w[1] == 1); /* cos on z, sin on y */
    dm_traj_free(&tr);
}

/* Samples at uneven times on a line at constant velocity: the natural
 * spline through them is that line (zero second derivatives solve its
 * equations), so positions, velocity and acceleration are exact between
 * samples; columns are found by name. */
static void sampled_line(void **state)
{
    (void)state;
    const double P0[3] = {0.01, -0.02, -0.4}, V[3] = {0.2, -0.1, 0.05};
    const double ts[6] = {0, 0.01, 0.025, 0.03, 0.05, 0.08};
    char text[1024], path[64];
    int len = snprintf(text, sizeof text, "# a line\nz, t, y ,x\n");
    for (int i = 0; i < 6; i++)
        len += snprintf(text + len, sizeof text - len, "%.17g,%.17g,%.17g,%.17g\n",
                        P0[2] + V[2] * ts[i], ts[i], P0[1] + V[1] * ts[i], P0[0] + V[0] * ts[i]);
    dm_trajectory tr, tr2;
    assert_int_equal(dm_traj_make(write_file(path, text), NULL, &tr, NULL), 0);
    unlink(path);
    assert_int_equal(tr.kind, DM_PATH_SAMPLES);
    assert_int_equal(tr.nsamp, 6);
    assert_abs(tr.duration_s, 0.08, 0, "duration");
    double xyz[18];
    for (int i = 0; i < 6; i++)
        for (int k = 0; k < 3; k++)
            xyz[3 * i + k] = P0[k] + V[k] * ts[i];
    assert_int_equal(dm_traj_from_samples(ts, xyz, 6, "line", &tr2, NULL), 0);
    for (double t = 0; t <= 0.08; t += 0.0035) {
        double P[3], v[3], a[3], Pw[3], zero[3] = {0, 0, 0};
        for (int k = 0; k < 3; k++)
            Pw[k] = P0[k] + V[k] * t;
        for (int which = 0; which < 2; which++) {
            dm_traj_eval(which ? &tr2 : &tr, t, P, v, a);
            assert_vec(P, Pw, 1e-15, which ? "P (from samples)" : "P (file)", t);
            assert_vec(v, V, 1e-12, "v", t);
            assert_vec(a, zero, 1e-9, "a", t);
        }
    }
    dm_traj_free(&tr);
    dm_traj_free(&tr2);
}

/* A spec's mistakes name the spec and the field. */
static void bad_specs(void **state)
{
    (void)state;
    assert_refused("circle:centre=0,0,-0.4;rate=6;duration=1",
                   "path 'circle:centre=0,0,-0.4;rate=6;duration=1': missing radius=");
    assert_refused("circle:centre=0,0;radius=0.1;rate=6;duration=1", "centre needs 3 numbers");
    assert_refused("circle:centre=0,0,-0.4;radius=-0.1;rate=6;duration=1",
                   "radius must be > 0");
    assert_refused("circle:centre=0,0,-0.4;radius=0.1;rate=6;duration=1;plane=xx",
                   "plane is xy, yz or xz");
    assert_refused("circle:centre=0,0,-0.4;radius=0.1;rate=6;duration=1;speed=2",
                   "unknown or empty field 'speed'");
    assert_refused("circle:centre=0,0,-0.4;radius=1e300;rate=1e10;duration=1", "overflows");
    assert_refused("p2p:from=0,0,-0.4;to=0.1,0,-0.4;duration=0", "duration must be > 0");
    assert_refused("p2p:from=0,0,-0.4;to=0.1,0,-0.4;duration=0.1;law=smooth",
                   "law 'smooth' is not cycloidal");
    assert_refused("p2p:from=0,0,-0.4;to=0.1,0,-0.4;duration=0.1;dwell=-1",
                   "dwell must be >= 0 s");
    assert_refused("p2p:from=0,0,-0.4;to=1e308,0,-0.4;duration=1e-10", "segment 1");
    assert_refused("pick:duration=0.5", "missing start="); /* no robot: no home */
    assert_refused("pick:start=0,0,-0.4;duration=0.5;axis=z", "axis is x or y");
    assert_refused("square:side=1", "is not a preset");
}

/* A file's mistakes name the file, the line and the column. */
static void bad_files(void **state)
{
    (void)state;
    static const struct {
        const char *text, *msg; /* msg after "PATH" */
    } cases[] = {
        {"t,x,y,z\n0,0,0,-0.4\n0.01,0,0,-0.4\n0.01,0,0,-0.4\n",
         ":4: column 1 (t): times must increase strictly"},
        {"t,x,y\n0,0,0\n", ":1: header lacks column 'z' (need t,x,y,z)"},
        {"t,x,y,z\n0,0,0,-0.4\n0.01,0,abc,-0.4\n", ":3: column 3 (y): 'abc' is not a number"},
        {"t,x,y,z\n0,0,0,-0.4\n0.01,0,,-0.4\n", ":3: column 3 (y): empty"},
        {"t,x,y,z\n0,0,0,-0.4\n0.01,0,0\n", ":3: row has 3 columns, too few for t,x,y,z"},
        {"t,x,y,z\n0,0,0,-0.4\n0.01,0,0,-0.4\n", ": needs a header t,x,y,z and at least 3 samples"},
        {"t,x,y,z\n0.5,0,0,-0.4\n1,0,0,-0.4\n2,0,0,-0.4\n", ": the first sample must be at t = 0"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char path[64], want[160];
        dm_trajectory tr;
        dm_error err;
        write_file(path, cases[i].text);
        int rc = dm_traj_make(path, NULL, &tr, &err);
        unlink(path);
        snprintf(want, sizeof want, "%s%s", path, cases[i].msg);
        if (rc != DM_EINVAL || strncmp(err.msg, want, strlen(want)))
            print_error("case %zu: rc %d, '%s' (want '%s')\n", i, rc, rc ? err.msg : "", want);
        assert_int_equal(rc, DM_EINVAL);
        assert_true(!strncmp(err.msg, want, strlen(want)));
    }
    dm_trajectory tr;
    dm_error err;
    assert_int_equal(dm_traj_make("/nonexistent/path.csv", NULL, &tr, &err), DM_EIO);
    assert_non_null(strstr(err.msg, "/nonexistent/path.csv"));
    const double t[3] = {0, 0.01, 0.01}, xyz[9] = {0};
    assert_int_equal(dm_traj_from_samples(t, xyz, 3, "run", &tr, &err), DM_EINVAL);
    assert_string_equal(err.msg, "run: times must increase strictly");
    assert_int_equal(dm_traj_from_samples(t + 1, xyz, 2, "run", &tr, &err), DM_EINVAL);
    assert_string_equal(err.msg, "run: needs at least 3 samples starting at t = 0");
}

/* Reachability along a path: the first unreachable time and pose. */
static void reachability(void **state)
{
    (void)state;
    dm_robot rb;
    dm_trajectory tr;
    dm_error err;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    assert_int_equal(dm_traj_make("zheng2017", &rb, &tr, NULL), 0);
    assert_int_equal(dm_traj_check_reachable(&tr, &rb, 1e-2, &err), 0);
    assert_int_equal(dm_traj_make("p2p:from=0,0,-0.4;to=0,0,-5;duration=1", &rb, &tr, NULL), 0);
    assert_int_equal(dm_traj_check_reachable(&tr, &rb, 1e-2, &err), DM_EUNREACHABLE);
    assert_non_null(
        strstr(err.msg, "leaves the workspace of zheng2017: first unreachable at t = "));
    dm_traj_free(&tr);
}

int main(int argc, char **argv)
{
    if (argc > 1)
        cmocka_set_test_filter(argv[1]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(circles_are_analytic),
        cmocka_unit_test(motion_laws),
        cmocka_unit_test(straight_lines_are_analytic),
        cmocka_unit_test(pick_cycle),
        cmocka_unit_test(presets),
        cmocka_unit_test(sampled_line),
        cmocka_unit_test(bad_specs),
        cmocka_unit_test(bad_files),
        cmocka_unit_test(reachability),
    };
    return cmocka_run_group_tests_name("trajectory", tests, NULL, NULL);
}
