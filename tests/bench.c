/* make bench: speed, memory and accuracy of deltamap, as figures and as
 * ratios against bare LAPACK calls on the same matrices in the same run.
 *   1. the sweep's per-pose pipeline (kinematics, assembly, statics, eigen
 *      solve of k + 4 modes, three standard moves, mode tracking, tile I/O)
 *      along a tile's serpentine path, for the three presets at meshes
 *      1,1, 4,4 and 8,8, each part against bare dsygvx (10 modes) and
 *      dsygvd (all) of the same M and K; the moves and dsygvx again as
 *      the min of 5 runs per pose (robust to a shared machine's load);
 *   2. eigenvalue error against an extended-precision reference;
 *   3. sweep throughput on 1 and 2 threads and what it implies for 1e6
 *      poses, a sweep's pose on one thread against bare dsygvx at poses of
 *      its map, and on 2 threads over a 256 x 256 grid (a large map's anchor
 *      lattice); trajectories; tracker diagnoses; one fit's evaluations with
 *      the prediction workspace reused against one made per evaluation;
 *   4. peak memory (max RSS) of two sweeps whose grids differ 10x;
 *   5. the member-basis engine (issue 39, dm_members + dm_boundary) beside
 *      today's statics: the cache's one-off build, and per pose the
 *      boundary solve (statics, compliance, ln det K) against today's
 *      assembly + arrow factor + the same outputs, both against bare
 *      dsygvx(10) at the same poses, min of 5 timings per pose; the 14
 *      lowest modes from the rule's bases (reduced eigenproblem, certified
 *      bounds) beside today's eigen solve; then the whole engine in
 *      sweeps of each preset's map at meshes 4,4 and 8,8 against the full
 *      model, bare dsygvx(10) and dsygvd, on every kernel path.
 * Section 1's rows, section 3's per-pose sweep line and tracker
 * diagnoses and section 5's sweeps are measured on every kernel path the
 * CPU has (include/dm_isa.h), each in a child
 * process of its own (a process runs one path) with DELTAMAP_ISA set;
 * the rest runs on the path in use (the best, or DELTAMAP_ISA's), which
 * the header names with the CPU. Nothing is asserted: timings are not
 * tests. */
#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "dm_analysis.h"
#include "dm_boundary.h"
#include "dm_diagnose.h"
#include "dm_integrate.h"
#include "dm_isa.h"
#include "dm_predict.h"
#include "dm_synth.h"
#include "dm_reference.h"
#include "dm_spectrum.h"
#include "dm_store.h"
#include "dm_sweep.h"
#include "dm_trajectory.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* A tile's serpentine path: 8 x 6 poses 0.04 la apart around home. */
#define PATH_X 8
#define PATH_Y 6
#define NPOSE (PATH_X * PATH_Y)

static void pose_at(const dm_robot *rb, int j, double P[3])
{
    int row = j / PATH_X, col = row % 2 ? PATH_X - 1 - j % PATH_X : j % PATH_X;
    double h = 0.04 * rb->arm_length_m;
    P[0] = rb->home_m[0] + h * (col - 0.5 * (PATH_X - 1));
    P[1] = rb->home_m[1] + h * (row - 0.5 * (PATH_Y - 1));
    P[2] = rb->home_m[2];
}

enum { T_KIN, T_ASM, T_STATIC, T_EIGEN, T_MOVES, T_MAC, T_IO, NPART };
static const char *const PART[NPART] = {"kin", "asm", "static", "eigen", "moves", "mac", "io"};

typedef struct {
    double t[NPART], dsygvx, dsygvd;
    double moves_min, dsygvx_min; /* per pose, min of MIN_REPS back-to-back runs (a shared
                                     machine's load spoils single timings) */
    double applications, rounds, fallbacks;
    int n;
} pose_costs;

/* Bare dsygvx for the 10 lowest pairs on a dense copy of the model's
 * matrices (the copy is not timed); seconds. */
static double bare_dsygvx(const dm_model *md, double *A, double *B, double *w, double *Z,
                          lapack_int *ifail)
{
    int n = md->n;
    lapack_int m;
    dm_model_dense(md, A, B);
    double t0 = now_s();
    LAPACKE_dsygvx(LAPACK_COL_MAJOR, 1, 'V', 'I', 'U', n, A, n, B, n, 0, 0, 1, 10, 0.0, &m, w,
                   Z, n, ifail);
    return now_s() - t0;
}

/* Bare LAPACK on dense copies of the same matrices: dsygvx for the 10
 * lowest pairs and dsygvd for all (the copies are not timed). */
static void bare_lapack(const dm_model *md, double *A, double *B, double *w, double *Z,
                        lapack_int *ifail, double *tx, double *td)
{
    int n = md->n;
    *tx += bare_dsygvx(md, A, B, w, Z, ifail);
    dm_model_dense(md, A, B);
    double t0 = now_s();
    LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'V', 'U', n, A, n, B, n, w);
    *td += now_s() - t0;
}

/* A 16 x 16 tile of every data array, written once per 256 poses. */
static void tile_io(dm_store *st, const double *tile, double *t)
{
    const int64_t c0[4] = {0, 0, 0, 0};
    double ti = now_s();
    if (!dm_store_write_metadata(st, NULL))
        for (int a = 0; a < st->narr; a++)
            dm_store_write_chunk(st, a, c0, tile, NULL);
    *t += (now_s() - ti) / 256.0;
}

static void tile_store(dm_store *st, char *dir, int k)
{
    memset(st, 0, sizeof *st);
    snprintf(st->path, sizeof st->path, "%s", dir);
    const int extra[11] = {1, k, k, 6, 1, 3, 1, 1, 3, 3, 3};
    for (int a = 0; a < 11; a++) {
        dm_array_spec *s = &st->arr[st->narr++];
        snprintf(s->name, sizeof s->name, "a%d", a);
        s->dtype = DM_DTYPE_FLOAT64;
        s->ndim = 4;
        s->shape[0] = s->shape[1] = s->chunk[0] = s->chunk[1] = 16;
        s->shape[2] = s->chunk[2] = 1;
        s->shape[3] = s->chunk[3] = extra[a];
    }
}

/* The moves and bare dsygvx(10) timed again per pose, best of MIN_REPS. */
#define MIN_REPS 5
static void min_timings(dm_move_ws *mw, dm_analysis *an, const dm_modes *modes, int k,
                        const dm_move_opts *mo, double *A, double *B, double *w, double *Z,
                        lapack_int *ifail, pose_costs *pc)
{
    static const double xyz[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    double tm = INFINITY, tx = INFINITY;
    for (int r = 0; r < MIN_REPS; r++) {
        dm_move_result res[3];
        double t0 = now_s();
        dm_standard_moves(mw, an->model, modes, k, an->statics, xyz, 3, mo, res, NULL);
        tm = fmin(tm, now_s() - t0);
        tx = fmin(tx, bare_dsygvx(an->model, A, B, w, Z, ifail));
    }
    pc->moves_min += tm;
    pc->dsygvx_min += tx;
}

static void per_pose(const char *preset, int mesh, int k, pose_costs *pc)
{
    dm_robot rb;
    dm_robot_load(preset, &rb, NULL);
    int kc = k + 4;
    dm_analysis *an = dm_analysis_alloc(&rb, mesh, mesh, kc, DM_EIGEN_PARTIAL, NULL);
    int n = an->model->n;
    dm_move_ws *mw = dm_move_alloc(n, k, NULL);
    dm_move_opts mo;
    dm_move_opts_default(&mo);
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *w = malloc(sizeof(double) * n), *Z = malloc(sizeof(double) * n * 10);
    double *work = malloc(sizeof(double) * (2 * n * k + k * kc)), *prev = malloc(sizeof(double) * n * k);
    double *tile = calloc(16 * 16 * 64, sizeof(double)), mac[64];
    lapack_int *ifail = malloc(sizeof(lapack_int) * n);
    int assign[64], reps = mesh <= 1 ? 4 : 1;
    char dir[] = "/tmp/dm_bench_XXXXXX";
    dm_store st;
    if (!mkdtemp(dir))
        return;
    tile_store(&st, dir, k);
    memset(pc, 0, sizeof *pc);
    pc->n = n;
    static const double xyz[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int r = 0; r < reps; r++) {
        dm_modal_forget(an->modal); /* a tile starts cold */
        for (int j = 0; j < NPOSE; j++) {
            double P[3], u6[6], C[36];
            dm_pose pose;
            const dm_modes *modes;
            dm_move_result res[3];
            dm_modal_stats ms;
            pose_at(&rb, j, P);
            double t0 = now_s();
            dm_kin_inverse(&rb, P, &pose, NULL);
            double t1 = now_s();
            dm_model_build(an->model, &pose, NULL);
            double t2 = now_s();
            dm_static_factor(an->statics, an->model, NULL);
            dm_static_platform_error(an->statics, an->model, an->model->F_gravity, u6, NULL);
            dm_static_compliance(an->statics, an->model, C, NULL);
            double t3 = now_s();
            dm_modal_solve(an->modal, an->model, an->statics, kc, &modes, NULL);
            double t4 = now_s();
            dm_standard_moves(mw, an->model, modes, k, an->statics, xyz, 3, &mo, res, NULL);
            double t5 = now_s();
            if (j)
                dm_modal_track(prev, k, modes, kc, an->model, assign, mac, prev, work);
            else
                memcpy(prev, modes->phi, sizeof(double) * n * k);
            double t6 = now_s();
            if (j % 16 == 0) /* every 16th pose writes 1/256 of a tile's time, x 16 below */
                tile_io(&st, tile, &pc->t[T_IO]);
            pc->t[T_KIN] += t1 - t0, pc->t[T_ASM] += t2 - t1, pc->t[T_STATIC] += t3 - t2;
            pc->t[T_EIGEN] += t4 - t3, pc->t[T_MOVES] += t5 - t4, pc->t[T_MAC] += t6 - t5;
            dm_modal_last_stats(an->modal, &ms);
            if (j) {
                pc->applications += ms.iterations;
                pc->rounds += ms.rounds;
                pc->fallbacks += ms.fallback;
            }
            bare_lapack(an->model, A, B, w, Z, ifail, &pc->dsygvx, &pc->dsygvd);
            if (r == 0)
                min_timings(mw, an, modes, k, &mo, A, B, w, Z, ifail, pc);
        }
    }
    double np = (double)reps * NPOSE;
    pc->t[T_IO] *= 16;
    for (int i = 0; i < NPART; i++)
        pc->t[i] /= np;
    pc->dsygvx /= np;
    pc->dsygvd /= np;
    pc->moves_min /= NPOSE;
    pc->dsygvx_min /= NPOSE;
    pc->applications /= reps * (NPOSE - 1);
    pc->rounds /= reps * (NPOSE - 1);
    char cmd[64];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd)) {}
    free(A), free(B), free(w), free(Z), free(work), free(prev), free(tile), free(ifail);
    dm_move_free(mw);
    dm_analysis_free(an);
}

static void print_pose_costs(const char *preset, int mesh, const pose_costs *pc)
{
    double total = 0, us = 1e6;
    for (int i = 0; i < NPART; i++)
        total += pc->t[i];
    printf("%-9s %d,%d n=%3d %-7s| total %6.0f us = %5.3f x dsygvx(10), %5.3f x dsygvd |",
           preset, mesh, mesh, pc->n, dm_isa_name(dm_isa_active()), total * us,
           total / pc->dsygvx, total / pc->dsygvd);
    for (int i = 0; i < NPART; i++)
        printf(" %s %.0f", PART[i], pc->t[i] * us);
    printf(" | eigen/dsygvx %5.3f | bare dsygvx %5.0f dsygvd %6.0f us | %.1f A-products, %.1f "
           "projections per pose | moves %.0f us = %.4f x dsygvx(10) %.0f us, min of %d\n",
           pc->t[T_EIGEN] / pc->dsygvx, pc->dsygvx * us, pc->dsygvd * us, pc->applications,
           pc->rounds, pc->moves_min * us, pc->moves_min / pc->dsygvx_min, pc->dsygvx_min * us,
           MIN_REPS);
}

/* Largest relative eigenvalue error of the 14 lowest, against the long
 * double reference, of the subspace solver, dsygvd and dsygvx. */
static void accuracy(const char *preset, int mesh)
{
    dm_robot rb;
    dm_robot_load(preset, &rb, NULL);
    const int k = 14;
    dm_analysis *an = dm_analysis_alloc(&rb, mesh, mesh, k, DM_EIGEN_SUBSPACE, NULL);
    int n = an->model->n;
    double *K = malloc(sizeof(double) * n * n), *M = malloc(sizeof(double) * n * n);
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *w = malloc(sizeof(double) * n), *Z = malloc(sizeof(double) * n * k);
    lapack_int *ifail = malloc(sizeof(lapack_int) * n), m;
    double err[3] = {0, 0, 0};
    for (int j = 0; j < NPOSE; j += 16) {
        double P[3];
        dm_pose_result r;
        ldbl lam[14];
        pose_at(&rb, j, P);
        dm_modal_forget(an->modal);
        if (dm_analysis_run(an, P, k, &r, NULL))
            continue;
        dm_model_dense(an->model, K, M);
        dm_reference_eigen(K, M, n, k, lam, NULL);
        memcpy(A, K, sizeof(double) * n * n), memcpy(B, M, sizeof(double) * n * n);
        LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'N', 'U', n, A, n, B, n, w);
        for (int i = 0; i < k; i++) {
            double om = r.modes->omega_rad_s[i];
            err[0] = fmax(err[0], fabs((double)((om * om - lam[i]) / lam[i])));
            err[1] = fmax(err[1], fabs((double)((w[i] - lam[i]) / lam[i])));
        }
        memcpy(A, K, sizeof(double) * n * n), memcpy(B, M, sizeof(double) * n * n);
        LAPACKE_dsygvx(LAPACK_COL_MAJOR, 1, 'N', 'I', 'U', n, A, n, B, n, 0, 0, 1, k, 0.0, &m, w,
                       Z, n, ifail);
        for (int i = 0; i < k; i++)
            err[2] = fmax(err[2], fabs((double)((w[i] - lam[i]) / lam[i])));
    }
    printf("%-9s %d,%d n=%3d | largest relative eigenvalue error (14 modes, 3 poses): subspace "
           "%.1e  dsygvd %.1e  dsygvx %.1e\n",
           preset, mesh, mesh, n, err[0], err[1], err[2]);
    free(K), free(M), free(A), free(B), free(w), free(Z), free(ifail);
    dm_analysis_free(an);
}

static volatile sig_atomic_t never;

/* poses/s of a sweep of the preset: the full model or the members, with
 * or without the standard moves; *apps (may be NULL): the members'
 * reduced solves' applications of K^-1 M a point they served. */
static double sweep_rate_with(const char *preset, const char *grid_spec, int mesh, int threads,
                              int members, int dynamic, long *points, double *apps)
{
    dm_robot rb;
    dm_grid g;
    dm_sweep_opts o;
    dm_sweep_stats st;
    dm_error err;
    char dir[] = "/tmp/dm_bench_XXXXXX", cmd[64];
    dm_robot_load(preset, &rb, NULL);
    dm_grid_parse(grid_spec, &g, NULL);
    dm_sweep_opts_default(&o);
    o.na = o.nb = mesh;
    o.threads = threads;
    o.members = members;
    o.dynamic = dynamic;
    if (!mkdtemp(dir))
        return 0;
    double t0 = now_s();
    if (dm_sweep_run(&rb, &g, &o, dir, &never, &st, &err))
        fprintf(stderr, "bench: %s\n", err.msg);
    double dt = now_s() - t0;
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd)) {}
    *points = st.points_total;
    if (apps) {
        long served = st.points_ok + st.points_near_singular - st.points_full_model;
        *apps = served > 0 ? (double)st.members_applications / served : 0;
    }
    return st.points_total / dt;
}

/* ... with the default engine (DM_SWEEP_AUTO: the members, for chen2018) */
static double sweep_rate(const char *grid_spec, int mesh, int threads, long *points)
{
    return sweep_rate_with("chen2018", grid_spec, mesh, threads, DM_SWEEP_AUTO, 1, points, NULL);
}


/* Bare dsygvx(10) and dsygvd (seconds, the means) at poses of a sweep's
 * map: the model built at 8 of its grid points spread over it (4 along
 * x, 2 along y), as section 1 times them along a tile's path; three times
 * each (a single call's time scatters by 10-40 % on a shared machine). */
static double bare_lapack_on_grid(const char *preset, const char *grid_spec, int mesh,
                                  double *dsygvd)
{
    dm_robot rb;
    dm_grid g;
    dm_robot_load(preset, &rb, NULL);
    dm_grid_parse(grid_spec, &g, NULL);
    dm_model *md = dm_model_alloc(&rb, mesh, mesh, NULL);
    int n = md->n, count = 0;
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *w = malloc(sizeof(double) * n), *Z = malloc(sizeof(double) * n * 10);
    lapack_int *ifail = malloc(sizeof(lapack_int) * n);
    double tx = 0, td = 0;
    for (int j = 0; j < 8; j++) {
        int idx[3] = {(g.axis[0].count - 1) * (j % 4) / 3,
                      (g.axis[1].count - 1) * (1 + 2 * (j / 4)) / 4, (g.axis[2].count - 1) / 2};
        double P[3];
        dm_pose pose;
        dm_grid_position(&g, idx, P);
        if (dm_kin_inverse(&rb, P, &pose, NULL) || dm_model_build(md, &pose, NULL))
            continue;
        for (int r = 0; r < 3; r++, count++)
            bare_lapack(md, A, B, w, Z, ifail, &tx, &td);
    }
    free(A), free(B), free(w), free(Z), free(ifail);
    dm_model_free(md);
    if (dsygvd)
        *dsygvd = count ? td / count : 0;
    return count ? tx / count : 0;
}

static int discard(void *user, const dm_integ_sample *s)
{
    (void)user, (void)s;
    return 0;
}

/* A paper trajectory's run on |threads| threads: with the all-modes
 * reference (the default run) for threads > 0, without it for < 0, the
 * best of 3 (a run without the reference takes 0.2-0.8 s, where a
 * virtual machine's single runs scatter by 10-20 %); each step's modes
 * from the full model where full_model, else from the member bases where
 * they serve (the default). Returns seconds. */
static double trajectory_time(const char *preset, int threads, int full_model)
{
    dm_robot rb;
    dm_trajectory tr;
    dm_integ_opts o;
    dm_integ_summary sum;
    dm_robot_load(preset, &rb, NULL);
    dm_traj_make(preset, &rb, &tr, NULL);
    dm_integ_opts_default(&o);
    o.reference = threads > 0;
    o.threads = abs(threads);
    o.full_model = full_model;
    double dt = INFINITY;
    int rc = 0;
    for (int rep = 0; rep < 3 && !rc; rep++) {
        double t0 = now_s();
        rc = dm_integrate_trajectory(&rb, &tr, &o, discard, NULL, &sum, NULL);
        dt = fmin(dt, now_s() - t0);
    }
    if (threads > 0)
        printf("   %-9s paper trajectory, default run (all-modes reference), %d thread%s: %6.2f s "
               "(%4.0f us per step, best of 3)%s\n",
               preset, threads, threads > 1 ? "s" : " ", dt, 1e6 * dt / (rc ? 1 : sum.steps),
               rc ? " FAILED" : "");
    else
        printf("   %-9s paper trajectory, %ld steps of 1 ms, 10 modes, CVODE, %d thread%s, %-12s: "
               "%6.2f s (%4.0f us per step, best of 3)%s\n",
               preset, sum.steps, -threads, threads < -1 ? "s" : " ",
               rc ? "" : sum.member_steps == sum.steps ? "member bases" : "full model", dt,
               1e6 * dt / (rc ? 1 : sum.steps), rc ? " FAILED" : "");
    dm_traj_free(&tr);
    return dt;
}

/* The papers' trajectories without the reference on 1 and 2 threads,
 * each on both engines in turn. */
static void paper_trajectories(void)
{
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    for (int p = 0; p < 3; p++)
        for (int t = 1; t <= 2; t++)
            for (int full = 0; full < 2; full++)
                trajectory_time(presets[p], -t, full);
}

/* The all-modes reference's solve at a pose (every mode, kept factored:
 * dm_spectrum) against DM_EIGEN_ALL_ARROW (every mode formed) and bare
 * dsygvd on the same matrices; best of 10. */
static void reference_solve_time(const char *preset, int mesh)
{
    dm_robot rb;
    dm_pose pose;
    dm_robot_load(preset, &rb, NULL);
    dm_model *md = dm_model_alloc(&rb, mesh, mesh, NULL);
    if (!md || dm_kin_pose(&rb, rb.home_m, &pose, NULL) || dm_model_build(md, &pose, NULL))
        return;
    int n = md->n;
    dm_spectrum *sp = dm_spectrum_alloc(md, NULL);
    dm_spectrum_solver *sv = dm_spectrum_solver_alloc(md, NULL);
    dm_modal *all = dm_modal_alloc(md, n, DM_EIGEN_ALL_ARROW, NULL);
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *w = malloc(sizeof(double) * n);
    double ts = INFINITY, ta = INFINITY, td = INFINITY;
    const dm_modes *mo;
    for (int r = 0; r < 10 && sp && sv && all && A && B && w; r++) {
        double t0 = now_s();
        dm_spectrum_solve(sp, md, sv, NULL);
        ts = fmin(ts, now_s() - t0);
        t0 = now_s();
        dm_modal_solve(all, md, NULL, n, &mo, NULL);
        ta = fmin(ta, now_s() - t0);
        dm_model_dense(md, A, B);
        t0 = now_s();
        LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'V', 'U', n, A, n, B, n, w);
        td = fmin(td, now_s() - t0);
    }
    printf("   %-9s %d,%d n=%3d all-modes reference per pose: spectrum %6.0f us = %.2f x dsygvd, "
           "every mode formed %6.0f us = %.2f x, bare dsygvd %6.0f us\n",
           preset, mesh, mesh, n, ts * 1e6, ts / td, ta * 1e6, ta / td, td * 1e6);
    free(A), free(B), free(w);
    dm_modal_free(all);
    dm_spectrum_solver_free(sv);
    dm_spectrum_free(sp);
    dm_model_free(md);
}

/* The diagnosis docs' tracker case (a 0.05 s bang-bang move and 0.05 s of
 * ring-down, beta off) at the default mesh; and a 1 s record sampled at
 * 250 Hz (every 4th sample of a 1 kHz run). */
static void diagnosis_time(int decimate, const char *path)
{
    dm_robot rb, truth;
    dm_dataset d;
    dm_diagnosis dg;
    dm_synth_opts so = {.kind = DM_DATA_TRACKER, .noise = 2e-6, .seed = 9, .path = path};
    dm_diagnose_opts o = {.pairs = 1, .threads = 2};
    const double beta = 1.2e-3;
    dm_robot_load("zheng2017", &rb, NULL);
    truth = rb;
    dm_effects_apply(&truth, "damping_beta", &beta, NULL);
    if (dm_synthesize(&truth, &so, &d, NULL))
        return;
    int m = 0;
    for (int i = 0; i < d.n; i++) /* keep every decimate-th time (3 samples each) */
        if ((d.s[i].pose_id % decimate) == 0) {
            d.s[m] = d.s[i];
            d.s[m].pose_id = d.s[i].pose_id / decimate;
            m++;
        }
    d.n = m;
    d.npose = m / 3;
    double t0 = now_s();
    int rc = dm_diagnose(&rb, &d, &o, &dg, NULL);
    double dt = now_s() - t0;
    printf("   tracker diagnosis, %4d times (%s, %g kHz), default mesh, 2 threads, path %-7s: "
           "%6.1f s%s\n",
           d.npose, path, 1.0 / decimate, dm_isa_name(dm_isa_active()), dt,
           rc ? " FAILED" : dg.found ? "" : " (no cause found)");
    dm_dataset_free(&d);
}

/* One fit's evaluations on a modal survey (16 poses, 6 modes): the
 * payload mass stepped through 25 values, as a fit's searches step it,
 * each predicted with one workspace reused by every evaluation and with
 * one allocated for it (dm_predict), in evaluations per second. The two
 * alternate, so that both see the same load on a shared machine. */
static void fit_evaluation_rate(int mesh)
{
    dm_robot rb, at;
    dm_dataset d;
    dm_synth_opts so = {.kind = DM_DATA_MODAL, .npose = 16, .modes = 6, .noise = 0.02, .seed = 7,
                        .na = mesh, .nb = mesh};
    dm_robot_load("zheng2017", &rb, NULL);
    if (dm_synthesize(&rb, &so, &d, NULL))
        return;
    enum { NEVAL = 25 };
    double *pred = malloc(sizeof(double) * d.n), t[2] = {0, 0};
    dm_predictor *p = dm_predictor_new(&rb, &d, mesh, mesh, NULL);
    int rc = !pred || !p;
    for (int e = 0; e < NEVAL && !rc; e++) {
        const double kg = 0.1 * pow(30.0, e / (NEVAL - 1.0));
        at = rb;
        rc = dm_effects_apply(&at, "payload_mass", &kg, NULL);
        for (int reuse = 0; reuse < 2 && !rc; reuse++) {
            double t0 = now_s();
            rc = reuse ? dm_predictor_run(p, &at, pred, NULL)
                       : dm_predict(&at, &d, mesh, mesh, pred, NULL);
            t[reuse] += now_s() - t0;
        }
    }
    printf("   one fit's evaluations, modal survey of 16 poses, mesh %d,%d: %6.1f/s with the "
           "workspace reused, %6.1f/s allocated per evaluation (ratio %.2f)%s\n",
           mesh, mesh, NEVAL / t[1], NEVAL / t[0], t[0] / t[1], rc ? " FAILED" : "");
    dm_predictor_free(p);
    free(pred);
    dm_dataset_free(&d);
}

/* Max RSS (MB) of the deltamap command running one sweep (fork + exec:
 * forking this OpenMP process and carrying on in the child is not safe). */
static double sweep_rss_mb(const char *grid_spec)
{
    const char *dm = getenv("DELTAMAP") ? getenv("DELTAMAP") : "build/deltamap";
    char dir[] = "/tmp/dm_bench_XXXXXX", cmd[64];
    if (!mkdtemp(dir))
        return 0;
    pid_t pid = fork();
    if (pid == 0) {
        if (!freopen("/dev/null", "w", stdout))
            _exit(127);
        execl(dm, dm, "sweep", "--robot", "chen2018", "--grid", grid_spec, "--threads", "2",
              "--progress", "none", "--out", dir, (char *)NULL);
        _exit(127);
    }
    int status = 0;
    struct rusage ru;
    memset(&ru, 0, sizeof ru);
    wait4(pid, &status, 0, &ru);
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd)) {}
    if (!WIFEXITED(status) || WEXITSTATUS(status))
        fprintf(stderr, "bench: %s sweep failed\n", dm);
    return ru.ru_maxrss / 1024.0;
}

/* Start `deltamap sweep ... --out dir [--shard k/n] --threads th` (fork +
 * exec: forking this OpenMP process and carrying on in the child is not
 * safe); its pid. */
static pid_t start_sweep(const char *grid_spec, const char *dir, int th, int k, int n)
{
    const char *dm = getenv("DELTAMAP") ? getenv("DELTAMAP") : "build/deltamap";
    char threads[16], shard[32];
    snprintf(threads, sizeof threads, "%d", th);
    snprintf(shard, sizeof shard, "%d/%d", k, n);
    pid_t pid = fork();
    if (pid == 0) {
        if (!freopen("/dev/null", "w", stdout))
            _exit(127);
        if (n > 1)
            execl(dm, dm, "sweep", "--robot", "chen2018", "--grid", grid_spec, "--threads",
                  threads, "--progress", "none", "--shard", shard, "--out", dir, (char *)NULL);
        else
            execl(dm, dm, "sweep", "--robot", "chen2018", "--grid", grid_spec, "--threads",
                  threads, "--progress", "none", "--out", dir, (char *)NULL);
        _exit(127);
    }
    return pid;
}

/* Wall seconds of one process on 2 threads against 2 shards of 1 thread
 * each, at once, into one store (docs/cluster.md). */
static void shard_throughput(const char *grid_spec, long points)
{
    double wall[2];
    for (int v = 0; v < 2; v++) {
        char dir[] = "/tmp/dm_bench_XXXXXX", cmd[64];
        if (!mkdtemp(dir))
            return;
        rmdir(dir); /* the sweep creates it */
        double t0 = now_s();
        pid_t p[2] = {start_sweep(grid_spec, dir, v ? 1 : 2, 0, v ? 2 : 1),
                      v ? start_sweep(grid_spec, dir, 1, 1, 2) : 0};
        int bad = 0;
        for (int i = 0; i < 1 + v; i++) {
            int status = 0;
            waitpid(p[i], &status, 0);
            bad |= !WIFEXITED(status) || WEXITSTATUS(status);
        }
        wall[v] = now_s() - t0;
        snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
        if (system(cmd)) {}
        if (bad)
            fprintf(stderr, "bench: a sweep process failed\n");
    }
    printf("   sweep chen2018 default mesh, %ld points: 1 process x 2 threads %.2f s, "
           "2 shards x 1 thread %.2f s (%.1f / %.1f poses/s; shards / threads %.2f)\n",
           points, wall[0], wall[1], points / wall[0], points / wall[1], wall[0] / wall[1]);
}

/* Section 1's row for one preset and mesh. */
static void pose_row(const char *preset, int mesh)
{
    pose_costs pc;
    per_pose(preset, mesh, 10, &pc);
    print_pose_costs(preset, mesh, &pc);
}

#define SWEEP_GRID "x=-0.3:0.3:64,y=-0.3:0.3:64,z=-0.5"

/* The sweep on one thread and its pose against bare dsygvx(10) at poses
 * of its map; poses/s. */
static double sweep_one_thread(void)
{
    long pts;
    /* 16 tiles of 16 x 16: with 9 (a 48 x 48 grid, used before) two
     * threads share them 5 : 4, which caps their ratio at 1.8 whatever
     * the code; a map of 1e6 poses has ~4000 tiles */
    double r = sweep_rate(SWEEP_GRID, 4, 1, &pts);
    double x = bare_lapack_on_grid("chen2018", SWEEP_GRID, 4, NULL);
    const char *isa = dm_isa_name(dm_isa_active());
    printf("   sweep chen2018 mesh 4,4, default engine: %ld points in 16 tiles, 1 thread , path "
           "%-7s: %7.1f poses/s (1e6 poses: %.1f min)\n",
           pts, isa, r, 1e6 / r / 60);
    printf("   a sweep's pose on one thread (anchors and tile I/O included), path %-7s: %.0f us = "
           "%.3f x bare dsygvx(10) at its poses (%.0f us)\n",
           isa, 1e6 / r, 1 / r / x, 1e6 * x);
    return r;
}

/* JOB ("row PRESET MESH", "members PRESET MESH" or "sweep") on kernel
 * path isa, in a child process with DELTAMAP_ISA set (the path is chosen
 * once a process). */
static void on_path(dm_isa isa, const char *job)
{
    fflush(stdout);
    pid_t pid = fork();
    if (pid == 0) {
        setenv("DELTAMAP_ISA", dm_isa_name(isa), 1);
        setenv("DM_BENCH_JOB", job, 1);
        execl("/proc/self/exe", "bench", (char *)NULL);
        _exit(127);
    }
    int status;
    if (pid < 0 || waitpid(pid, &status, 0) < 0 || !WIFEXITED(status) || WEXITSTATUS(status))
        fprintf(stderr, "bench: %s on path %s failed\n", job, dm_isa_name(isa));
}

static void members_sweep_rows(const char *preset, int mesh);

/* A child's job (DM_BENCH_JOB): 0 when there was none. */
static int run_job(const char *job)
{
    char preset[32];
    int mesh;
    if (!job || !*job)
        return 0;
    if (sscanf(job, "row %31s %d", preset, &mesh) == 2)
        pose_row(preset, mesh);
    else if (sscanf(job, "members %31s %d", preset, &mesh) == 2)
        members_sweep_rows(preset, mesh);
    else if (!strcmp(job, "sweep"))
        sweep_one_thread();
    else if (!strcmp(job, "trajectories")) /* section 3's paper trajectories alone */
        paper_trajectories();
    else if (!strcmp(job, "diagnosis p2p")) /* the diagnosis docs' case */
        diagnosis_time(1, "p2p:from=-0.03,-0.02,-0.41;to=0.03,0.02,-0.39;duration=0.05;"
                          "law=bangbang;dwell=0.05");
    else if (!strcmp(job, "diagnosis circle"))
        diagnosis_time(4, "circle:centre=0,0,-0.4;radius=0.04;rate=12.566;duration=1");
    return 1;
}

/* JOB on every path this CPU has: in this process on the path in use,
 * in a child on each other. */
static void on_every_path(const char *job)
{
    for (int i = 0; i < DM_ISA_COUNT; i++) {
        if (!dm_isa_available((dm_isa)i))
            continue;
        if ((dm_isa)i == dm_isa_active())
            run_job(job);
        else
            on_path((dm_isa)i, job);
    }
}

/* Section 5's whole engine on each preset's map: 64 x 64 points around
 * home, every one reachable (chen2018's is section 3's). */
static const char *members_map(const char *preset)
{
    if (!strcmp(preset, "zheng2017"))
        return "x=-0.15:0.15:64,y=-0.15:0.15:64,z=-0.4";
    if (!strcmp(preset, "han2011"))
        return "x=-0.2:0.2:64,y=-0.2:0.2:64,z=0.96";
    return SWEEP_GRID;
}

/* Section 5's whole engine: a sweep (anchors, tile I/O, tracking
 * included) with the members against the full model in the same run, per
 * pose on one thread against bare dsygvx(10) and dsygvd at the map's
 * poses, and poses/s on 1 and 2 threads, with and without the standard
 * moves; on the path in use (a child process runs it on each other). */
static void members_sweep_rows(const char *preset, int mesh)
{
    long pts;
    const char *grid = members_map(preset);
    double d, x = bare_lapack_on_grid(preset, grid, mesh, &d);
    for (int dynamic = 1; dynamic >= 0; dynamic--) {
        double r[2][2], apps[2];
        for (int members = 0; members < 2; members++)
            for (int t = 1; t <= 2; t++)
                r[members][t - 1] = sweep_rate_with(preset, grid, mesh, t, members, dynamic, &pts,
                                                    members ? &apps[t - 1] : NULL);
        printf("   sweep %-9s %d,%d, %ld points, %s, path %-7s: full model %6.0f us a pose = "
               "%.3f x dsygvx(10), %5.0f poses/s on 2 threads | members %6.0f us = %.3f x "
               "dsygvx(10) = %.4f x dsygvd, %5.0f poses/s on 2 threads (%.2f x one; 1e6 poses "
               "%.1f min), %.2f x faster | bare dsygvx(10) %.0f us, dsygvd %.0f us\n",
               preset, mesh, mesh, pts, dynamic ? "standard moves" : "--no-dynamic  ",
               dm_isa_name(dm_isa_active()), 1e6 / r[0][0], 1 / r[0][0] / x, r[0][1],
               1e6 / r[1][0], 1 / r[1][0] / x, 1 / r[1][0] / d, r[1][1], r[1][1] / r[1][0],
               1e6 / r[1][1] / 60, r[1][1] / r[0][1], 1e6 * x, 1e6 * d);
        printf("      members' reduced solves: %.2f applications of K^-1 M a point (a count: "
               "robust to this machine's load)%s\n",
               apps[0], apps[0] == apps[1] ? "" : " -- NOT the same on 2 threads");
    }
}

/* Section 5: along a tile's path, per pose the minimum of REPS timings
 * of each part run REPS times in a row (warm caches; the machine is
 * shared: the minimum is the figure least disturbed by other load),
 * summed over the path. */
static void members_row(const char *preset, int mesh)
{
    enum { REPS = 5 };
    dm_robot rb;
    dm_pose pose;
    dm_robot_load(preset, &rb, NULL);
    dm_model *md = dm_model_alloc(&rb, mesh, mesh, NULL);
    dm_static *st = dm_static_alloc(md, NULL);
    int n = md->n;
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *w = malloc(sizeof(double) * n), *Z = malloc(sizeof(double) * n * 10);
    lapack_int *ifail = malloc(sizeof(lapack_int) * n);
    dm_kin_inverse(&rb, rb.home_m, &pose, NULL);
    dm_model_build(md, &pose, NULL);
    double t0 = now_s();
    dm_members *ms = dm_members_build(md, 0, NULL);
    double tbuild = now_s() - t0, t[11] = {0};
    dm_boundary *bw = dm_boundary_alloc(ms, NULL);
    t0 = now_s();
    dm_members *mr = dm_boundary_members_for_modes(md, 14, NULL);
    double trule = now_s() - t0, lam[14], bound[14];
    dm_boundary *br = dm_boundary_alloc(mr, NULL);
    dm_modal *mo = dm_modal_alloc(md, 14, DM_EIGEN_PARTIAL, NULL);
    dm_boundary *be = dm_boundary_alloc(mr, NULL);
    dm_boundary_eig *eig = dm_boundary_eig_alloc(be, 14, NULL);
    int nred = dm_boundary_reduced_size(be), steps = 0, apps = 0;
    double *Y = malloc(sizeof(double) * nred * 14), est[14];
    void *eseed = malloc(dm_boundary_eig_seed_size(eig));
    const dm_modes *modes;
    void *seed = malloc(dm_modal_seed_size(mo));
    static const double XYZ[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    dm_move_ws *mw = dm_move_alloc(n, 10, NULL);
    dm_move_opts mopt;
    dm_move_opts_default(&mopt);
    for (int j = 0; j < NPOSE; j++) {
        double P[3], u6[6], C[36], best[4] = {INFINITY, INFINITY, INFINITY, INFINITY};
        dm_boundary_statics bs;
        pose_at(&rb, j, P);
        for (int r = 0; r < REPS; r++) { /* each part REPS times in a row: warm caches */
            double a = now_s();
            dm_kin_inverse(&rb, P, &pose, NULL);
            best[0] = fmin(best[0], now_s() - a);
        }
        for (int r = 0; r < REPS; r++) {
            double b = now_s();
            dm_model_build(md, &pose, NULL);
            dm_static_factor(st, md, NULL);
            dm_static_platform_error(st, md, md->F_gravity, u6, NULL);
            dm_static_compliance(st, md, C, NULL);
            best[1] = fmin(best[1], now_s() - b);
        }
        for (int r = 0; r < REPS; r++) {
            double c = now_s();
            dm_boundary_solve(bw, &pose, &bs, NULL);
            best[2] = fmin(best[2], now_s() - c);
        }
        for (int r = 0; r < REPS; r++)
            best[3] = fmin(best[3], bare_dsygvx(md, A, B, w, Z, ifail));
        /* today's eigen solve, warm from the previous pose's seed (loaded
         * again before each timing, as the sweep loads an anchor's; the
         * first pose cold), min of REPS like the members' parts */
        dm_model_build(md, &pose, NULL);
        dm_static_factor(st, md, NULL);
        double best4 = INFINITY;
        for (int r = 0; r < REPS; r++) {
            if (j)
                dm_modal_seed_load(mo, seed);
            double e0 = now_s();
            dm_modal_solve(mo, md, st, 14, &modes, NULL);
            best4 = fmin(best4, now_s() - e0);
        }
        dm_modal_seed_save(mo, seed);
        t[4] += best4 / NPOSE;
        double best2[3] = {INFINITY, INFINITY, INFINITY};
        for (int r = 0; r < REPS; r++) {
            double a = now_s();
            dm_boundary_solve(br, &pose, &bs, NULL);
            double b = now_s();
            dm_boundary_reduced_modes(br, 14, lam, NULL);
            double c = now_s();
            dm_boundary_bounds(br, 14, lam, bound, NULL);
            double d = now_s(), part[3] = {b - a, c - b, d - c};
            for (int k = 0; k < 3; k++)
                best2[k] = fmin(best2[k], part[k]);
        }
        for (int k = 0; k < 3; k++)
            t[5 + k] += best2[k] / NPOSE;
        /* the iteration, warm from the previous pose's seed (loaded again
         * before each timing, as a sweep's point loads its anchor's: the
         * block and filter that solve chose; the first pose cold) */
        double best3 = INFINITY;
        for (int r = 0; r < REPS; r++) {
            dm_boundary_eig_info info;
            double a = now_s();
            if (j)
                dm_boundary_eig_seed_load(eig, eseed);
            dm_boundary_solve(be, &pose, &bs, NULL);
            if (dm_boundary_eig_solve(eig, be, lam, est, &info, NULL))
                printf("   (%s %d,%d pose %d: the reduced solve failed)\n", preset, mesh, mesh, j);
            best3 = fmin(best3, now_s() - a);
            if (!r)
                steps += info.iterations, apps += info.applications;
        }
        dm_boundary_eig_seed_save(eig, eseed);
        dm_boundary_reduced_vectors(be, 14, Y);
        t[8] += best3 / NPOSE;
        /* the standard moves (10 modes, X Y Z) on the reduced model and on
         * the full model, the same pose and modes count */
        double om[14], best5[2] = {INFINITY, INFINITY};
        for (int j = 0; j < 14; j++)
            om[j] = sqrt(lam[j]);
        for (int r = 0; r < REPS; r++) {
            dm_move_result mv[3];
            double a = now_s();
            dm_standard_moves_reduced(mw, be, eig, &rb, &pose, Y, dm_boundary_eig_mass_vectors(eig),
                                      om, 10, XYZ, 3, &mopt, mv, NULL);
            double b = now_s();
            dm_standard_moves(mw, md, modes, 10, st, XYZ, 3, &mopt, mv, NULL);
            double c = now_s();
            best5[0] = fmin(best5[0], b - a), best5[1] = fmin(best5[1], c - b);
        }
        t[9] += best5[0] / NPOSE, t[10] += best5[1] / NPOSE;
        for (int k = 0; k < 4; k++)
            t[k] += best[k] / NPOSE;
    }
    double us = 1e6;
    printf("%-9s %d,%d n=%3d nbound=%2d | cache %6.1f ms once | per pose: kin %4.1f us | today "
           "asm+statics %6.1f us = %6.4f x dsygvx(10) | members' statics %5.1f us = %6.4f x "
           "dsygvx(10), %5.1fx faster | bare dsygvx(10) %6.0f us\n",
           preset, mesh, mesh, n, ms->nbound, tbuild * 1e3, t[0] * us, t[1] * us, t[1] / t[3],
           t[2] * us, t[2] / t[3], t[1] / t[2], t[3] * us);
    printf("          modes (14): rule's bases %d reduced DOFs, cache %.1f ms once | today's "
           "eigen solve (warm from the last pose's seed) %7.1f us = %6.4f x dsygvx(10) | members: reduced "
           "eigenproblem %6.1f us = %6.4f x, certified bounds %6.1f us = %6.4f x dsygvx(10)\n",
           dm_boundary_reduced_size(br), trule * 1e3, t[4] * us, t[4] / t[3], t[6] * us,
           t[6] / t[3], t[7] * us, t[7] / t[3]);
    printf("          reduced modes by warm iteration (boundary statics + Chebyshev-filtered "
           "subspace iteration, bound <= %.0e, count): %6.1f us = %6.4f x dsygvx(10), %.2f "
           "projections and %.2f applications of K^-1 M a pose\n",
           DM_BOUNDARY_EIG_TOL, t[8] * us, t[8] / t[3], (double)steps / NPOSE,
           (double)apps / NPOSE);
    printf("          standard moves (10 modes, X Y Z): on the reduced model %6.1f us = %6.4f x "
           "dsygvx(10) | on the full model %6.1f us = %6.4f x\n",
           t[9] * us, t[9] / t[3], t[10] * us, t[10] / t[3]);
    dm_move_free(mw);
    free(Y), free(eseed);
    free(seed);
    dm_boundary_eig_free(eig);
    dm_boundary_free(be);
    free(A), free(B), free(w), free(Z), free(ifail);
    dm_modal_free(mo);
    dm_boundary_free(br);
    dm_members_free(mr);
    dm_boundary_free(bw);
    dm_members_free(ms);
    dm_static_free(st);
    dm_model_free(md);
}

static int wanted(int argc, char **argv, const char *what);

/* JOB "KIND PRESET MESH" (run_job's) for each mesh given and each preset
 * wanted, on every kernel path, mesh by mesh. */
static void jobs_on_every_path(int argc, char **argv, const char *kind, const int *meshes,
                               int nmesh)
{
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    for (int m = 0; m < nmesh; m++)
        for (int p = 0; p < 3; p++) {
            if (!wanted(argc, argv, presets[p]))
                continue;
            char job[64];
            snprintf(job, sizeof job, "%s %s %d", kind, presets[p], meshes[m]);
            on_every_path(job);
        }
}

/* `bench` runs every section; `bench 1 3` only those, and in section 1
 * `bench 1 chen2018` only that preset (to iterate on one figure). */
static int wanted(int argc, char **argv, const char *what)
{
    int any = 0;
    for (int i = 1; i < argc; i++) {
        int is_section = argv[i][0] >= '1' && argv[i][0] <= '5' && !argv[i][1];
        if (is_section == (what[0] >= '1' && what[0] <= '5' && !what[1])) {
            any = 1;
            if (!strcmp(argv[i], what))
                return 1;
        }
    }
    return !any;
}

int main(int argc, char **argv)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    openblas_set_num_threads(1); /* as the serial commands do */
    if (run_job(getenv("DM_BENCH_JOB")))
        return 0;
    dm_isa isa;
    dm_error err;
    if (dm_isa_from_env(&isa, &err)) {
        fprintf(stderr, "bench: %s\n", err.msg);
        return 2;
    }
    char cpu[128];
    dm_isa_cpu_model(cpu, sizeof cpu);
    printf("deltamap bench on %d cores of %s (one BLAS thread per worker); kernels: %s, paths on "
           "this CPU:",
           omp_get_num_procs(), cpu, dm_isa_name(isa));
    for (int i = 0; i < DM_ISA_COUNT; i++)
        if (dm_isa_available((dm_isa)i))
            printf(" %s", dm_isa_name((dm_isa)i));
    printf(" (section 1's rows, the sweep's per-pose line, the diagnoses and section 5's sweeps "
           "on each)\n\n");
    if (wanted(argc, argv, "1"))
        printf("1. per pose, one thread: the sweep's pipeline along a tile's path (10 modes + 4 "
               "for tracking, 3 moves), parts in us, on each kernel path\n");
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    const int meshes[] = {1, 4, 8};
    if (wanted(argc, argv, "1"))
        jobs_on_every_path(argc, argv, "row", meshes, 3);
    if (wanted(argc, argv, "2"))
        printf("\n2. accuracy against an extended-precision reference (tests/dm_reference.h)\n");
    for (int m = 1; m < 3 && wanted(argc, argv, "2"); m++)
        for (int p = 0; p < 3; p++)
            accuracy(presets[p], meshes[m]);
    if (wanted(argc, argv, "3")) {
        printf("\n3. throughput (the serial commands first: a sweep leaves OpenMP at its threads)\n");
        paper_trajectories();
        for (int p = 0; p < 3; p++)
            reference_solve_time(presets[p], 4);
        reference_solve_time("chen2018", 8);
        double tr1 = trajectory_time("zheng2017", 1, 0), tr2 = trajectory_time("zheng2017", 2, 0);
        printf("   2 threads / 1 thread: %.2f\n", tr1 / tr2);
        on_every_path("diagnosis p2p");
        on_every_path("diagnosis circle");
        fit_evaluation_rate(1);
        fit_evaluation_rate(4);
        long pts;
        for (int i = 0; i < DM_ISA_COUNT; i++) /* the other paths first, then this one's */
            if (dm_isa_available((dm_isa)i) && (dm_isa)i != dm_isa_active())
                on_path((dm_isa)i, "sweep");
        double r1 = sweep_one_thread(), r2 = sweep_rate(SWEEP_GRID, 4, 2, &pts);
        printf("   sweep chen2018 mesh 4,4, default engine: %ld points in 16 tiles, 2 threads, "
               "path %-7s: %7.1f poses/s (1e6 poses: %.1f min)\n",
               pts, dm_isa_name(dm_isa_active()), r2, 1e6 / r2 / 60);
        printf("   2 threads / 1 thread: %.2f\n", r2 / r1);
        /* a large map's anchors: 32 per axis, 8 grid points apart (the
         * 64 x 64 grid above has 16, 4 apart, and 1/16 of its poses) */
        double rl = sweep_rate("x=-0.3:0.3:256,y=-0.3:0.3:256,z=-0.5", 4, 2, &pts);
        printf("   sweep chen2018 mesh 4,4, default engine: %ld points (a large map's anchor "
               "lattice), 2 threads: %7.1f poses/s (1e6 poses: %.1f min)\n",
               pts, rl, 1e6 / rl / 60);
        shard_throughput("x=-0.3:0.3:32,y=-0.3:0.3:32,z=-0.5", 32 * 32);
    }
    if (wanted(argc, argv, "4")) {
        printf("\n4. peak memory of a sweep (default mesh, 2 threads)\n");
        double m1 = sweep_rss_mb("x=-0.3:0.3:16,y=-0.3:0.3:16,z=-0.5");
        double m2 = sweep_rss_mb("x=-0.3:0.3:51,y=-0.3:0.3:51,z=-0.5");
        printf("   %5d points: %6.1f MB max RSS\n", 16 * 16, m1);
        printf("   %5d points: %6.1f MB max RSS   (10x the grid: ratio %.2f)\n", 51 * 51, m2, m2 / m1);
    }
    if (wanted(argc, argv, "5"))
        printf("\n5. member bases (issue 39), one thread, path %s: the statics of a pose from the "
               "members against today's, along a tile's path, min of 5 back-to-back timings per "
               "part and pose; then the whole engine in sweeps, on each path\n",
               dm_isa_name(dm_isa_active()));
    for (int m = 0; m < 3 && wanted(argc, argv, "5"); m++)
        for (int p = 0; p < 3; p++)
            if (wanted(argc, argv, presets[p]))
                members_row(presets[p], meshes[m]);
    if (wanted(argc, argv, "5"))
        jobs_on_every_path(argc, argv, "members", meshes + 1, 2);
    return 0;
}
