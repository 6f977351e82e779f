/* Sweeps: values equal the single-pose analysis, unreachable
 * points masked, thread-count independence, resume and refusal. */
#include "dm_test.h"

#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include "dm_coupling.h"
#include "dm_store.h"
#include "dm_sweep.h"
#include "../src/maps/sweep_impl.h" /* the array table, walked */

static char *tmpdir(void)
{
    static char dirs[8][64]; /* a test holds up to 8 at once */
    static int next;
    char *d = dirs[next++ % 8];
    snprintf(d, 64, "/tmp/dm_sweep_XXXXXX");
    assert_non_null(mkdtemp(d));
    return d;
}

static void rmtree(const char *d)
{
    char cmd[200];
    snprintf(cmd, sizeof cmd, "rm -rf %s", d);
    assert_int_equal(system(cmd), 0);
}

static volatile sig_atomic_t no_stop;

static void run_sweep_into(const dm_robot *rb, const char *spec, dm_sweep_opts *o,
                           const char *out, dm_sweep_stats *st)
{
    dm_grid g;
    dm_error err;
    assert_int_equal(dm_grid_parse(spec, &g, NULL), 0);
    int rc = dm_sweep_run(rb, &g, o, out, &no_stop, st, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
}

static long run_sweep_stats(const dm_robot *rb, const char *spec, dm_sweep_opts *o,
                            const char *out)
{
    dm_sweep_stats st;
    run_sweep_into(rb, spec, o, out, &st);
    return st.points_full_model;
}

static void run_sweep(const dm_robot *rb, const char *spec, dm_sweep_opts *o, const char *out)
{
    run_sweep_stats(rb, spec, o, out);
}

static void read_all(const char *dir, const char *name, void *out, size_t elem_bytes)
{
    dm_store st;
    assert_int_equal(dm_store_read_metadata(dir, &st, NULL), 0);
    int a = 0;
    while (strcmp(st.arr[a].name, name))
        a++;
    const dm_array_spec *s = &st.arr[a];
    size_t E = s->ndim > 3 ? (size_t)s->shape[3] : 1, ce = dm_store_chunk_elems(&st, a);
    unsigned char *buf = malloc(ce * elem_bytes);
    for (int64_t c0 = 0; c0 * s->chunk[0] < s->shape[0]; c0++)
        for (int64_t c1 = 0; c1 * s->chunk[1] < s->shape[1]; c1++)
            for (int64_t c2 = 0; c2 * s->chunk[2] < s->shape[2]; c2++) {
                int64_t c[4] = {c0, c1, c2, 0};
                int missing;
                assert_int_equal(dm_store_read_chunk(&st, a, c, buf, &missing, NULL), 0);
                for (int i = 0; i < s->chunk[0]; i++)
                    for (int j = 0; j < s->chunk[1]; j++)
                        for (int k = 0; k < s->chunk[2]; k++) {
                            int64_t g[3] = {c0 * s->chunk[0] + i, c1 * s->chunk[1] + j, c2 * s->chunk[2] + k};
                            if (g[0] >= s->shape[0] || g[1] >= s->shape[1] || g[2] >= s->shape[2])
                                continue;
                            size_t src = (((size_t)i * s->chunk[1] + j) * s->chunk[2] + k) * E;
                            size_t dst = (((size_t)g[0] * s->shape[1] + g[1]) * s->shape[2] + g[2]) * E;
                            memcpy((unsigned char *)out + dst * elem_bytes, buf + src * elem_bytes,
                                   E * elem_bytes);
                        }
            }
    free(buf);
    dm_store_release(&st);
}

/* The named float64 arrays of stores a and b (at most count values each)
 * are the same bits: the values a point gets do not depend on how it was
 * swept. */
static void same_arrays(const char *a, const char *b, const char *const *names, size_t count)
{
    double *x = calloc(count, sizeof(double)), *y = calloc(count, sizeof(double));
    for (const char *const *n = names; *n; n++) {
        memset(x, 0, sizeof(double) * count); /* a shorter array leaves the rest equal */
        memset(y, 0, sizeof(double) * count);
        read_all(a, *n, x, 8);
        read_all(b, *n, y, 8);
        assert_memory_equal(x, y, sizeof(double) * count);
    }
    free(x);
    free(y);
}

static const char *const SAME_ARRAYS[] = {"frequencies_hz", "frequencies_tracked_hz",
                                          "move_peak_m", NULL};

/* Default options but the mesh (na = nb), modes and tile (t0 x t1 x 1). */
static void sweep_options(dm_sweep_opts *o, int mesh, int k, int t0, int t1)
{
    dm_sweep_opts_default(o);
    o->na = o->nb = mesh;
    o->k = k;
    o->tile[0] = t0, o->tile[1] = t1, o->tile[2] = 1;
}

/* 7 x 5 x 2 grid that runs past the workspace edge at one end */
#define SPEC "x=-0.3:1.2:7,y=-0.2:0.2:5,z=-0.6:-0.45:2"
#define NPTS (7 * 5 * 2)

/* A sweep's 6 frequencies (f), tracked families (tr) and static error
 * (e) at point p against the one-pose analysis res there (10 modes). Both
 * converge on residuals far below what 1e-9 needs (the sweep started from
 * its anchor, the analysis from its own start): two converged solves
 * differ by the rounding of their projections and what their residuals
 * leave, ~1e-11 here on any BLAS kernels (test_modal.c's ritz_error).
 * Each tracked value is one of the point's frequencies. */
static void point_equals_analysis(const double *f, const double *tr, const double *e, int p,
                                  const dm_pose_result *res)
{
    for (int j = 0; j < 6; j++) {
        assert_rel(f[6 * p + j], res->modes->freq_hz[j], 1e-9, "point %d f%d", p, j + 1);
        assert_abs(e[6 * p + j], res->static_error[j], 1e-9 * fabs(res->static_error[2]),
                   "point %d error %d", p, j);
        int found = 0;
        for (int i = 0; i < 10; i++)
            found |= fabs(tr[6 * p + j] - res->modes->freq_hz[i]) < 1e-8 * res->modes->freq_hz[i];
        assert_true(found);
    }
}

static void values_equal_single_pose_analysis(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    dm_sweep_opts o;
    sweep_options(&o, 2, 6, 3, 2); /* edge tiles are partial */
    o.members = DM_SWEEP_FULL_MODEL; /* the members' sweep: member_engine_sweeps */
    char *dir = tmpdir();
    run_sweep(&rb, SPEC, &o, dir);
    static double f[NPTS * 6], e[NPTS * 6], cm[NPTS], tr[NPTS * 6];
    static unsigned char status[NPTS];
    read_all(dir, "frequencies_hz", f, 8);
    read_all(dir, "frequencies_tracked_hz", tr, 8);
    read_all(dir, "static_error", e, 8);
    read_all(dir, "compliance_max", cm, 8);
    read_all(dir, "status", status, 1);
    dm_grid g;
    assert_int_equal(dm_grid_parse(SPEC, &g, NULL), 0);
    /* 10 modes: the 6 reported and the 4 extra candidates of mode tracking */
    dm_analysis *an = dm_analysis_alloc(&rb, 2, 2, 10, DM_EIGEN_PARTIAL, NULL);
    int unreachable = 0;
    for (int p = 0; p < NPTS; p++) {
        int idx[3] = {p / 10, (p / 2) % 5, p % 2};
        double P[3];
        dm_pose_result res;
        dm_grid_position(&g, idx, P);
        int rc = dm_analysis_run(an, P, 10, &res, NULL);
        if (rc == DM_EUNREACHABLE) {
            unreachable++;
            assert_int_equal(status[p], DM_POINT_UNREACHABLE);
            assert_true(isnan(f[6 * p]) && isnan(cm[p]) && isnan(e[6 * p + 2]));
            continue;
        }
        assert_int_equal(rc, 0);
        assert_int_equal(status[p], res.near_singular ? DM_POINT_NEAR_SINGULAR : DM_POINT_OK);
        point_equals_analysis(f, tr, e, p, &res);
        assert_rel(cm[p], res.compliance_max_m_per_n, 1e-10, "point %d compliance", p);
    }
    assert_true(unreachable > 0 && unreachable < NPTS);
    dm_analysis_free(an);
    rmtree(dir);
}

static int same_tree(const char *a, const char *b)
{
    char cmd[300];
    snprintf(cmd, sizeof cmd, "diff -r %s %s > /dev/null", a, b);
    return system(cmd) == 0;
}

/* A line of 40 points has 16 anchors: the points between them start
 * between their seeds (dm_sweep_anchors_toward). Their values equal the
 * single-pose analysis to 1e-9, and a point's numbers depend on the grid
 * only: tiles of 16 and of 7 points (cutting the anchors' intervals
 * elsewhere) give the same values, bit for bit. */
#define LINE "x=-0.2:0.2:40,y=0.01,z=-0.45"
static void points_between_anchors(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("han2011", &rb, NULL), 0);
    dm_sweep_opts o;
    sweep_options(&o, 2, 6, 16, 1);
    o.members = DM_SWEEP_FULL_MODEL; /* the members start from the anchor's seed as it is */
    o.threads = 2;
    char *a = tmpdir(), *b = tmpdir();
    run_sweep(&rb, LINE, &o, a);
    o.tile[0] = 7;
    run_sweep(&rb, LINE, &o, b);
    same_arrays(a, b, SAME_ARRAYS, 40 * 6);
    static double f[40 * 6];
    read_all(a, "frequencies_hz", f, 8);
    dm_grid g;
    assert_int_equal(dm_grid_parse(LINE, &g, NULL), 0);
    dm_analysis *an = dm_analysis_alloc(&rb, 2, 2, 10, DM_EIGEN_PARTIAL, NULL);
    for (int p = 0; p < 40; p++) {
        int idx[3] = {p, 0, 0};
        double P[3];
        dm_pose_result res;
        dm_grid_position(&g, idx, P);
        assert_int_equal(dm_analysis_run(an, P, 10, &res, NULL), 0);
        for (int j = 0; j < 6; j++)
            assert_rel(f[6 * p + j], res.modes->freq_hz[j], 1e-9, "point %d f%d", p, j + 1);
    }
    dm_analysis_free(an);
    rmtree(a);
    rmtree(b);
}

static void threads_resume_and_refusal_with(int engine)
{
    dm_robot rb;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    dm_sweep_opts o;
    sweep_options(&o, 1, 5, 2, 2);
    o.members = engine;
    char *one = tmpdir(), *two = tmpdir();
    o.threads = 1;
    run_sweep(&rb, SPEC, &o, one);
    o.threads = 2;
    run_sweep(&rb, SPEC, &o, two);
    assert_true(same_tree(one, two)); /* bit-identical for 1 and 2 threads */
    /* delete a tile's chunk and corrupt another's: both are recomputed */
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm %s/frequencies_hz/c/1/1/0/0 && printf X | dd of=%s/status/c/2/0/1 bs=1 seek=1 conv=notrunc 2>/dev/null", two, two);
    assert_int_equal(system(cmd), 0);
    assert_false(same_tree(one, two));
    dm_grid g;
    dm_sweep_stats st;
    dm_error err;
    assert_int_equal(dm_grid_parse(SPEC, &g, NULL), 0);
    assert_int_equal(dm_sweep_run(&rb, &g, &o, two, &no_stop, &st, &err), 0);
    assert_int_equal(st.tiles_computed, 2);
    assert_true(same_tree(one, two));
    /* another grid or robot is refused; replace overwrites it */
    assert_int_equal(dm_grid_parse("x=-0.3:1.2:8,y=-0.2:0.2:5,z=-0.6:-0.45:2", &g, NULL), 0);
    assert_int_equal(dm_sweep_run(&rb, &g, &o, two, &no_stop, &st, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "another grid"));
    dm_robot other = rb;
    assert_int_equal(dm_robot_set(&other, "platform.mass=2", NULL), 0);
    assert_int_equal(dm_grid_parse(SPEC, &g, NULL), 0);
    assert_int_equal(dm_sweep_run(&other, &g, &o, two, &no_stop, &st, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "another robot"));
    o.replace = 1;
    assert_int_equal(dm_sweep_run(&other, &g, &o, two, &no_stop, &st, &err), 0);
    assert_int_equal(st.tiles_present, 0);
    /* a stop request before any tile: nothing computed, DM_EINTERRUPT */
    volatile sig_atomic_t stop = 1;
    char *three = tmpdir();
    o.replace = 0;
    assert_int_equal(dm_sweep_run(&rb, &g, &o, three, &stop, &st, &err), DM_EINTERRUPT);
    assert_non_null(strstr(err.msg, "resume"));
    rmtree(one);
    rmtree(two);
    rmtree(three);
}

/* Either engine's store: the same on 1 and 2 threads, damaged tiles
 * recomputed, another sweep's store refused unless replaced, a stop. */
static void threads_resume_and_refusal(void **state)
{
    (void)state;
    threads_resume_and_refusal_with(DM_SWEEP_FULL_MODEL);
    threads_resume_and_refusal_with(DM_SWEEP_MEMBERS);
}

/* --method members: the store bit-identical on 1 and 2 threads and its
 * values on other tiles; every point's values those of the member
 * analysis at its pose (to 1e-9, as the full sweep's are the full
 * analysis's) and within 1e-9 of the full model's frequencies; the
 * standard moves' peaks (on the reduced model: dm_standard_moves_reduced)
 * within 1e-7 of the full sweep's (their inputs differ by ~1e-10 in
 * frequency, which the peak's phase over the window, omega t ~ 100,
 * multiplies; the further Ritz vectors are the reduced pair's,
 * test_integrate: 1.3e-10 measured); a robot the members cannot
 * serve is refused, and so is resuming a store of the full model. */
static void member_engine_sweeps(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    dm_sweep_opts o;
    sweep_options(&o, 2, 6, 3, 2);
    o.members = DM_SWEEP_MEMBERS;
    char *one = tmpdir(), *two = tmpdir(), *other = tmpdir(), *full = tmpdir();
    dm_sweep_stats s1, s2, sf;
    o.threads = 1;
    run_sweep_into(&rb, SPEC, &o, one, &s1);
    assert_int_equal(s1.points_full_model, 0); /* the members served every point */
    o.threads = 2;
    run_sweep_into(&rb, SPEC, &o, two, &s2);
    assert_true(same_tree(one, two));
    /* the reduced solves' work is counted, and is the same on any thread
     * count (each point starts from its anchor's seed): at least one
     * application a point, at most the filter's largest degree (12) and
     * a few more rounds' */
    long reached = s1.points_ok + s1.points_near_singular;
    assert_true(reached > 0);
    assert_true(s1.members_applications >= reached && s1.members_applications <= 40 * reached);
    assert_int_equal(s2.members_applications, s1.members_applications);
    o.tile[0] = 7, o.tile[1] = 5;
    run_sweep(&rb, SPEC, &o, other);
    o.members = DM_SWEEP_FULL_MODEL;
    o.tile[0] = 3, o.tile[1] = 2;
    run_sweep_into(&rb, SPEC, &o, full, &sf);
    assert_int_equal(sf.members_applications, 0);
    same_arrays(one, other, SAME_ARRAYS, NPTS * 6);
    static double f[NPTS * 6], ff[NPTS * 6], tr[NPTS * 6], mp[NPTS * 3], mpf[NPTS * 3];
    static double e[NPTS * 6];
    static unsigned char status[NPTS];
    read_all(one, "frequencies_hz", f, 8);
    read_all(full, "frequencies_hz", ff, 8);
    read_all(one, "frequencies_tracked_hz", tr, 8);
    read_all(one, "move_peak_m", mp, 8);
    read_all(full, "move_peak_m", mpf, 8);
    read_all(one, "static_error", e, 8);
    read_all(one, "status", status, 1);
    dm_grid g;
    assert_int_equal(dm_grid_parse(SPEC, &g, NULL), 0);
    dm_members *ms = dm_analysis_members(&rb, 2, 2, 10, NULL);
    dm_analysis *an = dm_analysis_alloc(&rb, 2, 2, 10, DM_EIGEN_PARTIAL, NULL);
    assert_int_equal(dm_analysis_use_members(an, ms, NULL), 0);
    int served = 0;
    for (int p = 0; p < NPTS; p++) {
        int idx[3] = {p / 10, (p / 2) % 5, p % 2};
        double P[3];
        dm_pose_result res;
        dm_grid_position(&g, idx, P);
        if (dm_analysis_run(an, P, 10, &res, NULL) == DM_EUNREACHABLE) {
            assert_int_equal(status[p], DM_POINT_UNREACHABLE);
            continue;
        }
        served += res.engine == DM_ENGINE_MEMBERS;
        assert_int_equal(res.engine, DM_ENGINE_MEMBERS);
        point_equals_analysis(f, tr, e, p, &res);
        for (int j = 0; j < 6; j++)
            assert_rel(f[6 * p + j], ff[6 * p + j], 1e-9, "point %d f%d (full)", p, j + 1);
        for (int d = 0; d < 3; d++)
            assert_rel(mp[3 * p + d], mpf[3 * p + d], 1e-7, "point %d move %d", p, d);
    }
    assert_true(served > 0);
    dm_analysis_free(an);
    dm_members_free(ms);
    /* resuming the full model's store with the members: another sweep */
    dm_sweep_stats st;
    dm_error err;
    o.members = DM_SWEEP_MEMBERS;
    assert_int_equal(dm_sweep_run(&rb, &g, &o, full, &no_stop, &st, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "another --method"));
    /* geometric stiffness: the members cannot serve, said before any work */
    char *none = tmpdir();
    assert_int_equal(dm_robot_set(&rb, "effects.geometric_stiffness=on", NULL), 0);
    assert_int_equal(dm_sweep_run(&rb, &g, &o, none, &no_stop, &st, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "geometric stiffness"));
    /* as many modes (with tracking's 4) as the bases' reduced model:
     * refused before the store is made */
    assert_int_equal(dm_robot_set(&rb, "effects.geometric_stiffness=off", NULL), 0);
    char *big = tmpdir();
    rmtree(big);
    sweep_options(&o, 1, 44, 3, 2); /* 48 of 48 at mesh 1,1 */
    o.members = DM_SWEEP_MEMBERS;
    assert_int_equal(dm_sweep_run(&rb, &g, &o, big, &no_stop, &st, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "reduced model"));
    struct stat sb;
    assert_int_not_equal(stat(big, &sb), 0);
    /* 47 of the 48: the filter does not converge at some poses, which the
     * full model serves (counted; their families untracked: their vectors
     * are not the anchors' kind); the store the same on 1 and 2 threads */
#define FB_GRID "x=-0.1:0.1:9,y=-0.1:0.1:9,z=-0.5"
    sweep_options(&o, 1, 43, 3, 2);
    o.members = DM_SWEEP_MEMBERS;
    o.threads = 1;
    char *fb1 = tmpdir(), *fb2 = tmpdir();
    long nfull = run_sweep_stats(&rb, FB_GRID, &o, fb1);
    o.threads = 2;
    assert_int_equal(run_sweep_stats(&rb, FB_GRID, &o, fb2), nfull);
    assert_true(same_tree(fb1, fb2));
    assert_true(nfull > 0);
    static double trk[81 * 43];
    read_all(fb1, "frequencies_tracked_hz", trk, 8);
    long untracked = 0;
    for (int p = 0; p < 81; p++)
        untracked += isnan(trk[43 * p]);
    assert_true(untracked >= nfull);
    rmtree(fb1);
    rmtree(fb2);
    rmtree(one);
    rmtree(two);
    rmtree(other);
    rmtree(full);
    rmtree(none);
}

/* Near the workspace's rim, where f1 falls to ~1 Hz, an anchor's start
 * can lead the reduced solve astray (here 3 of 180 points before
 * 2026-12-07: served by the full model, their families untracked); the
 * members then try once more, cold, and serve every point: each
 * frequency within 1e-9 of a cold members analysis at the point (a warm
 * solve and a cold one differ by their residuals' rounding, as in
 * point_equals_analysis), every family tracked, the store the same on 1
 * and 2 threads. */
#define RIM "r=0.38:0.46:5,phi=0:350:36,z=-0.4"
static void astray_start_retried_cold(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    dm_sweep_opts o;
    sweep_options(&o, 4, 6, 16, 16);
    o.members = DM_SWEEP_MEMBERS;
    o.dynamic = 0;
    char *one = tmpdir(), *two = tmpdir();
    dm_sweep_stats st;
    o.threads = 1;
    run_sweep_into(&rb, RIM, &o, one, &st);
    assert_int_equal(st.points_full_model, 0);
    assert_int_equal(st.points_ok + st.points_near_singular, 180);
    o.threads = 2;
    run_sweep_into(&rb, RIM, &o, two, &st);
    assert_true(same_tree(one, two));
    static double f[180 * 6], tr[180 * 6];
    read_all(one, "frequencies_hz", f, 8);
    read_all(one, "frequencies_tracked_hz", tr, 8);
    dm_grid g;
    assert_int_equal(dm_grid_parse(RIM, &g, NULL), 0);
    dm_members *ms = dm_analysis_members(&rb, 4, 4, 10, NULL);
    dm_analysis *an = dm_analysis_alloc(&rb, 4, 4, 10, DM_EIGEN_PARTIAL, NULL);
    assert_int_equal(dm_analysis_use_members(an, ms, NULL), 0);
    for (int p = 0; p < 180; p++) {
        int idx[3] = {p / 36, p % 36, 0};
        double P[3];
        dm_pose_result res;
        dm_grid_position(&g, idx, P);
        dm_analysis_forget(an);
        assert_int_equal(dm_analysis_run(an, P, 10, &res, NULL), 0);
        assert_int_equal(res.engine, DM_ENGINE_MEMBERS);
        for (int j = 0; j < 6; j++) {
            assert_rel(f[6 * p + j], res.modes->freq_hz[j], 1e-9, "point %d f%d", p, j + 1);
            assert_true(isfinite(tr[6 * p + j]));
        }
    }
    dm_analysis_free(an);
    dm_members_free(ms);
    rmtree(one);
    rmtree(two);
}

/* DM_SWEEP_AUTO, the default: a new store gets the members (the very
 * store DM_SWEEP_MEMBERS makes); a store of this sweep is resumed with
 * the engine it was made with (nothing recomputed; for the full model
 * the reason is given); another sweep's store, replaced, does not pass
 * its engine on; a robot, or a number of modes, the members cannot serve
 * runs on the full model, and the reason is given. */
static void auto_engine_choice(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    dm_sweep_opts o;
    sweep_options(&o, 1, 5, 2, 2);
    assert_int_equal(o.members, DM_SWEEP_AUTO);
    char *a = tmpdir(), *m = tmpdir(), *f = tmpdir(), *g = tmpdir(), *big = tmpdir();
    dm_sweep_stats st;
    run_sweep_into(&rb, SPEC, &o, a, &st);
    assert_int_equal(st.members, DM_SWEEP_MEMBERS);
    assert_string_equal(st.engine_why, "");
    o.members = DM_SWEEP_MEMBERS;
    run_sweep_into(&rb, SPEC, &o, m, &st);
    assert_true(same_tree(a, m));
    o.members = DM_SWEEP_FULL_MODEL;
    run_sweep_into(&rb, SPEC, &o, f, &st);
    assert_int_equal(st.members, DM_SWEEP_FULL_MODEL);
    assert_false(same_tree(a, f));
    o.members = DM_SWEEP_AUTO;
    run_sweep_into(&rb, SPEC, &o, f, &st);
    assert_int_equal(st.members, DM_SWEEP_FULL_MODEL);
    assert_int_equal(st.tiles_computed, 0);
    assert_int_equal(st.tiles_present, st.tiles_total);
    assert_non_null(strstr(st.engine_why, "resumed"));
    run_sweep_into(&rb, SPEC, &o, m, &st);
    assert_int_equal(st.members, DM_SWEEP_MEMBERS);
    assert_int_equal(st.tiles_computed, 0);
    o.replace = 1;
    run_sweep_into(&rb, "x=-0.3:1.2:8,y=-0.2:0.2:5,z=-0.6:-0.45:2", &o, f, &st);
    assert_int_equal(st.members, DM_SWEEP_MEMBERS);
    assert_int_equal(st.tiles_present, 0);
    o.replace = 0;
    dm_robot stiff = rb;
    assert_int_equal(dm_robot_set(&stiff, "effects.geometric_stiffness=on", NULL), 0);
    run_sweep_into(&stiff, SPEC, &o, g, &st);
    assert_int_equal(st.members, DM_SWEEP_FULL_MODEL);
    assert_non_null(strstr(st.engine_why, "geometric stiffness"));
    sweep_options(&o, 1, 44, 3, 2); /* with tracking's 4, 48 of 48 at mesh 1,1 */
    run_sweep_into(&rb, SPEC, &o, big, &st);
    assert_int_equal(st.members, DM_SWEEP_FULL_MODEL);
    assert_non_null(strstr(st.engine_why, "reduced model"));
    rmtree(a);
    rmtree(m);
    rmtree(f);
    rmtree(g);
    rmtree(big);
}

/* Three shards run one after the other into one store make the store of
 * one process, each computing only its tiles; a finished shard's rerun
 * computes nothing; a shard that does not exist is refused. */
static void shards_with(int engine)
{
    dm_robot rb;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    dm_sweep_opts o;
    sweep_options(&o, 1, 5, 2, 2);
    o.members = engine;
    o.threads = 1;
    char *one = tmpdir(), *parts = tmpdir();
    run_sweep(&rb, SPEC, &o, one);
    dm_grid g;
    dm_sweep_stats st;
    dm_error err;
    assert_int_equal(dm_grid_parse(SPEC, &g, NULL), 0);
    long mine = 0;
    o.shards = 3;
    for (o.shard = 2; o.shard >= 0; o.shard--) {
        assert_int_equal(dm_sweep_run(&rb, &g, &o, parts, &no_stop, &st, &err), 0);
        assert_int_equal(st.tiles_computed, st.tiles_mine);
        assert_int_equal(st.tiles_present, 0);
        assert_true(st.tiles_mine < st.tiles_total);
        mine += st.tiles_mine;
        if (o.shard)
            assert_false(same_tree(one, parts));
    }
    assert_int_equal(mine, st.tiles_total);
    assert_true(same_tree(one, parts));
    o.shard = 1;
    assert_int_equal(dm_sweep_run(&rb, &g, &o, parts, &no_stop, &st, &err), 0);
    assert_int_equal(st.tiles_computed, 0);
    assert_int_equal(st.tiles_present, st.tiles_mine);
    o.shard = 3;
    assert_int_equal(dm_sweep_run(&rb, &g, &o, parts, &no_stop, &st, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "no shard 3 of 3"));
    assert_true(same_tree(one, parts));
    rmtree(one);
    rmtree(parts);
}

static void shards_make_the_same_store(void **state)
{
    (void)state;
    shards_with(DM_SWEEP_FULL_MODEL);
    shards_with(DM_SWEEP_MEMBERS);
}

/* dm_sweep_opts.on_repair: each file it is told of */
typedef struct {
    int n;
    char files[8][300];
} repairs;

static void note_repair(void *user, const char *file, const char *problem, int repaired)
{
    repairs *r = user;
    (void)problem;
    assert_true(repaired);
    if (r->n < 8)
        snprintf(r->files[r->n], sizeof r->files[0], "%s", file);
    r->n++;
}

/* The files a resume derives from the command are checked, not only
 * parsed: an array's metadata with its units replaced and a coordinate
 * chunk with a byte changed are rewritten, reported, and the store is the
 * undamaged one again; the info check (dm_sweep_check_open) finds both
 * before and nothing after. */
static void resume_repairs_derived_files(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    dm_sweep_opts o;
    sweep_options(&o, 1, 5, 2, 2);
    o.threads = 2;
    char *one = tmpdir(), *two = tmpdir();
    run_sweep(&rb, SPEC, &o, one);
    run_sweep(&rb, SPEC, &o, two);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "sed -i 's/\"units\": \"m, rad\"/\"units\": \"mm\"/' %s/static_error/zarr.json && "
             "grep -q '\"mm\"' %s/static_error/zarr.json && "
             "printf X | dd of=%s/y/c/0 bs=1 seek=2 conv=notrunc 2>/dev/null", two, two, two);
    assert_int_equal(system(cmd), 0);
    assert_false(same_tree(one, two));
    dm_sweep_check chk;
    dm_error err;
    assert_int_equal(dm_sweep_check_open(two, 0, NULL, NULL, &chk, &err), DM_OK);
    assert_true(chk.verified);
    assert_int_equal(chk.problems, 2);
    assert_int_equal(chk.chunk_problems, 1);
    dm_sweep_check_close(&chk);
    repairs r = {0};
    o.on_repair = note_repair;
    o.repair_user = &r;
    run_sweep(&rb, SPEC, &o, two);
    assert_int_equal(r.n, 2);
    assert_non_null(strstr(r.files[0], "/static_error/zarr.json"));
    assert_non_null(strstr(r.files[1], "/y/c/0"));
    assert_true(same_tree(one, two));
    assert_int_equal(dm_sweep_check_open(two, 0, NULL, NULL, &chk, &err), DM_OK);
    assert_int_equal(chk.problems, 0);
    dm_sweep_check_close(&chk);
    rmtree(one);
    rmtree(two);
}

/* ---- the array table (sweep_impl.h) ------------------------------------------- */

static size_t elem_size(const dm_sweep_array *d)
{
    return d->dtype == DM_DTYPE_FLOAT64 ? sizeof(double) : sizeof(int);
}

/* The table against dm_point_result: each row's field holds its array's
 * values at a point (DM_MAX_MODES for the mode dimension), the fields
 * tile the struct with nothing but alignment between them (a field no
 * row stores would show as a gap), status comes first and the groups in
 * order, so a sweep's arrays are a prefix. */
static void array_table_matches_point_result(void **state)
{
    (void)state;
    int n = dm_sweep_narrays, order[64];
    assert_true(n > 0 && n <= 64);
    assert_string_equal(dm_sweep_arrays[0].name, "status");
    assert_int_equal(dm_sweep_arrays[0].dtype, DM_DTYPE_UINT8);
    for (int a = 0; a < n; a++) {
        const dm_sweep_array *d = &dm_sweep_arrays[a];
        assert_int_equal(d->size, dm_sweep_extra_len(d->extra, DM_MAX_MODES) * elem_size(d));
        assert_true(d->dtype == DM_DTYPE_FLOAT64 ? isnan(d->fill) : d->fill == (int)d->fill);
        if (a)
            assert_true(d->group >= dm_sweep_arrays[a - 1].group);
        for (int b = 0; b < a; b++)
            assert_string_not_equal(d->name, dm_sweep_arrays[b].name);
        order[a] = a;
    }
    for (int i = 1; i < n; i++) /* rows by their field's offset */
        for (int j = i; j > 0 && dm_sweep_arrays[order[j]].offset < dm_sweep_arrays[order[j - 1]].offset; j--) {
            int t = order[j];
            order[j] = order[j - 1], order[j - 1] = t;
        }
    size_t end = 0;
    for (int i = 0; i < n; i++) {
        const dm_sweep_array *d = &dm_sweep_arrays[order[i]];
        size_t align = elem_size(d), aligned = (end + align - 1) / align * align;
        if (d->offset != aligned)
            fail_msg("%s at offset %zu: a field without an array, or an overlap, before it (from %zu)",
                     d->name, d->offset, end);
        end = d->offset + d->size;
    }
    assert_int_equal((end + sizeof(double) - 1) / sizeof(double) * sizeof(double), sizeof(dm_point_result));
    int core = dm_sweep_ndata(0, 0), tol = dm_sweep_ndata(1, 0);
    assert_true(core > 0 && core < tol && tol < n && dm_sweep_ndata(1, 1e-5) == n);
    assert_int_equal(dm_sweep_ndata(0, 1e-5), core); /* a spec without the Monte Carlo: none */
    for (int a = 0; a < n; a++)
        assert_int_equal(dm_sweep_arrays[a].group, a < core ? G_CORE : a < tol ? G_TOLERANCE : G_SPEC);
}

/* What an array should hold at a point, from the single-pose functions. */
typedef struct {
    const char *name;
    double v[DM_MAX_MODES + EXTRA_MODES];
    int n;       /* values (any_of: candidates) */
    double tol;  /* relative to the largest |v|; 0: exactly */
    int any_of;  /* each stored value is one of v (mode families) */
} expected_array;

#define WK 4 /* modes of the walk's sweep */

/* Every array's values at reachable pose P: the analysis, the standard
 * moves, the nominal robot's coupling index and the tolerance Monte Carlo
 * run on their own. Returns how many. */
static int expect_at(const dm_robot *rb, const dm_sweep_opts *o, const double P[3],
                     expected_array *e)
{
    dm_analysis *an = dm_analysis_alloc(rb, 1, 1, WK + EXTRA_MODES, DM_EIGEN_PARTIAL, NULL);
    dm_pose_result r;
    assert_int_equal(dm_analysis_run(an, P, WK + EXTRA_MODES, &r, NULL), 0);
    static const double xyz[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    dm_move_result mv[3];
    dm_move_ws *ws = dm_move_alloc(dm_model_dofs(rb, 1, 1), WK, NULL);
    assert_int_equal(dm_standard_moves(ws, an->model, r.modes, WK, an->statics, xyz, 3, &o->move, mv, NULL), 0);
    dm_coupling *nominal = dm_coupling_alloc(rb, 1, 1, NULL);
    double nominal_log10;
    assert_int_equal(dm_coupling_nominal_log10(nominal, P, &nominal_log10, NULL), 0);
    dm_tolerance_spec ts = o->tolerance_spec;
    ts.na = ts.nb = ts.flexibility = 1; /* the sweep's mesh, flexible */
    dm_tolerance_result t;
    assert_int_equal(dm_tolerance_pose(rb, &ts, P, 1, &t, NULL), 0);
    /* tolerances (relative to the array's largest |value|): modal values
     * 1e-9, two converged solves (the sweep's from an anchor's seed) agree
     * to ~1e-11 (values_equal_single_pose_analysis; 4e-13 seen here); the
     * moves' maxima and settling times 1e-8, each found to 1e-9 relative
     * (dm_move_result) from those modes (2e-12 seen); the statics 1e-12,
     * the same direct solve at the same pose (2e-16 seen); the Monte Carlo
     * exactly, as `deltamap tolerance --at` (store_tests.sh) */
    expected_array list[] = {
        {"status", {r.near_singular ? DM_POINT_NEAR_SINGULAR : DM_POINT_OK}, 1, 0, 0},
        {"frequencies_hz", {0}, WK, 1e-9, 0},
        {"frequencies_tracked_hz", {0}, WK + EXTRA_MODES, 1e-9, 1},
        {"static_error", {0}, 6, 1e-12, 0},
        {"compliance_max", {r.compliance_max_m_per_n}, 1, 1e-12, 0},
        {"compliance_direction", {r.compliance_dir[0], r.compliance_dir[1], r.compliance_dir[2]}, 3, 1e-12, 0},
        {"stiffness_min", {r.stiffness_min_n_per_m}, 1, 1e-12, 0},
        {"singularity", {r.pose.cond}, 1, 1e-12, 0},
        {"move_peak_m", {mv[0].peak_m, mv[1].peak_m, mv[2].peak_m}, 3, 1e-8, 0},
        {"move_residual_m", {mv[0].residual_m, mv[1].residual_m, mv[2].residual_m}, 3, 1e-8, 0},
        {"move_settling_s", {mv[0].settling_s, mv[1].settling_s, mv[2].settling_s}, 3, 1e-8, 0},
        {"coupling_index_log10", {r.coupling_index_log10}, 1, 1e-12, 0},
        {"coupling_index_change_log10", {r.coupling_index_log10 - nominal_log10}, 1, 1e-12, 0},
        {"error_mean_m", {t.mean_error_m}, 1, 0, 0},
        {"error_p95_m", {t.p95_error_m}, 1, 0, 0},
        {"error_max_m", {t.max_error_m}, 1, 0, 0},
        {"dominant_source", {t.dominant}, 1, 0, 0},
        {"p_exceed_spec", {t.p_exceed_spec}, 1, 0, 0},
    };
    int n = sizeof list / sizeof list[0];
    for (int j = 0; j < WK + EXTRA_MODES; j++)
        list[1].v[j] = list[2].v[j] = r.modes->freq_hz[j];
    memcpy(list[3].v, r.static_error, sizeof r.static_error);
    memcpy(e, list, sizeof list);
    dm_coupling_free(nominal);
    dm_move_free(ws);
    dm_analysis_free(an);
    return n;
}

/* Stored array a's values at every point, as doubles (E per point). */
static double *read_as_double(const char *dir, const dm_store *st, int a, size_t npts, size_t E)
{
    size_t n = npts * E, bytes = dm_dtype_size(st->arr[a].dtype);
    unsigned char *raw = malloc(n * bytes);
    double *v = malloc(n * sizeof *v);
    read_all(dir, st->arr[a].name, raw, bytes);
    for (size_t i = 0; i < n; i++)
        v[i] = st->arr[a].dtype == DM_DTYPE_UINT8   ? raw[i]
               : st->arr[a].dtype == DM_DTYPE_INT32 ? ((int32_t *)raw)[i]
                                                    : ((double *)raw)[i];
    free(raw);
    return v;
}

static void check_against(const dm_sweep_array *d, const double *got, size_t E, const expected_array *e)
{
    double scale = 0;
    for (int j = 0; j < e->n; j++)
        scale = fmax(scale, isfinite(e->v[j]) ? fabs(e->v[j]) : 0);
    if (!e->any_of)
        assert_int_equal(E, e->n);
    for (size_t j = 0; j < E; j++) {
        int found = 0;
        for (int i = e->any_of ? 0 : (int)j; i < (e->any_of ? e->n : (int)j + 1) && !found; i++)
            found = got[j] == e->v[i] || fabs(got[j] - e->v[i]) <= e->tol * scale;
        if (!found)
            fail_msg("%s[%zu] = %.17g: not %.17g (within %.3g of %.3g)", d->name, j, got[j],
                     e->v[e->any_of ? 0 : j], e->tol, scale);
    }
}

/* A sweep with every array (standard moves, effects, the tolerance Monte
 * Carlo with a spec) at a reachable and an unreachable point: each array
 * of the table is in the store at its row, with its dimensions, type and
 * units, and reads back what the single-pose functions give at the
 * reachable point and the array's fill at the other. An array added to
 * the table without a check here fails. */
static void every_array_written_and_read_back(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    assert_int_equal(dm_robot_set(&rb, "effects.error_rod_length=1e-4,0,-5e-5", NULL), 0);
    assert_int_equal(dm_robot_set(&rb, "effects.actuator_stiffness=2e4", NULL), 0);
    assert_int_equal(dm_robot_set(&rb, "damping.alpha=30", NULL), 0); /* moves that settle */
    dm_sweep_opts o;
    sweep_options(&o, 1, WK, 2, 1);
    o.tolerance = 1;
    o.tolerance_spec.samples = 30;
    o.tolerance_spec.seed = 7;
    o.tolerance_spec.spec_m = 8.5e-4; /* |error| spreads over 0.8-0.9 mm there */
    o.tolerance_spec.tol[DM_TOL_ROD_LENGTH] = 5e-5;
    o.tolerance_spec.tol[DM_TOL_THETA] = 3e-4;
    const char *spec = "x=0:1.2:2,y=0,z=-0.5"; /* x = 1.2 m is out of reach */
    char *dir = tmpdir();
    run_sweep(&rb, spec, &o, dir);
    const double P[3] = {0, 0, -0.5};
    expected_array e[32];
    int ne = expect_at(&rb, &o, P, e);
    dm_store st;
    assert_int_equal(dm_store_read_metadata(dir, &st, NULL), 0);
    assert_int_equal(st.narr, dm_sweep_narrays + N_AXES_LABELS);
    for (int a = 0; a < dm_sweep_narrays; a++) {
        const dm_sweep_array *d = &dm_sweep_arrays[a];
        const dm_array_spec *s = &st.arr[a];
        assert_string_equal(s->name, d->name);
        assert_int_equal(s->dtype, d->dtype);
        assert_int_equal(s->ndim, 3 + (d->extra != X_NONE));
        assert_string_equal(json_string_value(json_object_get(s->attributes, "units")), d->units);
        size_t E = (size_t)dm_sweep_extra_len(d->extra, WK);
        assert_int_equal(s->ndim > 3 ? s->shape[3] : 1, E);
        int i = 0;
        while (i < ne && strcmp(e[i].name, d->name))
            i++;
        if (i == ne)
            fail_msg("array %s has no check in every_array_written_and_read_back", d->name);
        double *v = read_as_double(dir, &st, a, 2, E);
        check_against(d, v, E, &e[i]);
        for (size_t j = 0; j < E; j++) { /* the unreachable point: the fill */
            double want = a == 0 ? DM_POINT_UNREACHABLE : d->fill;
            assert_true(isnan(want) ? isnan(v[E + j]) : v[E + j] == want);
        }
        free(v);
    }
    dm_store_release(&st);
    rmtree(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(values_equal_single_pose_analysis),
        cmocka_unit_test(points_between_anchors),
        cmocka_unit_test(threads_resume_and_refusal),
        cmocka_unit_test(member_engine_sweeps),
        cmocka_unit_test(auto_engine_choice),
        cmocka_unit_test(astray_start_retried_cold),
        cmocka_unit_test(shards_make_the_same_store),
        cmocka_unit_test(resume_repairs_derived_files),
        cmocka_unit_test(array_table_matches_point_result),
        cmocka_unit_test(every_array_written_and_read_back),
    };
    return cmocka_run_group_tests_name("sweep", tests, NULL, NULL);
}
