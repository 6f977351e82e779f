/* make bench: speed and memory of deltamap, as figures and ratios.
 *   1. per-pose cost split (kinematics, assembly, eigen, statics, standard
 *      moves, mode tracking, tile I/O) against a bare LAPACK dsygvd of the
 *      same matrices in the same run (the lower bound to match, then beat);
 *   2. sweep throughput in poses/s on all cores, default and finer mesh;
 *   3. peak memory (max RSS) of two sweeps whose grids differ 10x.
 * Nothing is asserted: timings are not tests. */
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
#include "dm_integrate.h"
#include "dm_store.h"
#include "dm_sweep.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

#define NPOSE 48

static void pose_at(const dm_robot *rb, int j, double P[3])
{
    double a = 6.283185307179586 * j / NPOSE, rad = 0.1 * rb->arm_length_m;
    P[0] = rb->home_m[0] + rad * cos(a);
    P[1] = rb->home_m[1] + rad * sin(3 * a);
    P[2] = rb->home_m[2] + 0.05 * rb->arm_length_m * sin(a);
}

static void per_pose(const char *preset, int mesh, int k)
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
    double *w = malloc(sizeof(double) * n), *work = malloc(sizeof(double) * (n * kc + k * kc));
    double *prev = malloc(sizeof(double) * n * k), mac[64];
    int assign[64];
    double t[8] = {0}; /* kin, asm, eig, static, moves, mac, io, bare */
    int reps = mesh <= 2 ? 4 : 1;
    /* tile I/O: a 16x16 tile of every data array, timed per point */
    char dir[] = "/tmp/dm_bench_XXXXXX";
    mkdtemp(dir);
    dm_store st;
    memset(&st, 0, sizeof st);
    snprintf(st.path, sizeof st.path, "%s", dir);
    const int extra[11] = {1, k, k, 6, 1, 3, 1, 1, 3, 3, 3};
    for (int a = 0; a < 11; a++) {
        dm_array_spec *s = &st.arr[st.narr++];
        snprintf(s->name, sizeof s->name, "a%d", a);
        s->dtype = DM_DTYPE_FLOAT64;
        s->ndim = 4;
        s->shape[0] = s->shape[1] = 16;
        s->shape[2] = 1;
        s->shape[3] = extra[a];
        s->chunk[0] = s->chunk[1] = 16;
        s->chunk[2] = 1;
        s->chunk[3] = extra[a];
    }
    double *tile = calloc(16 * 16 * 64, sizeof(double));
    const int64_t c0[4] = {0, 0, 0, 0};
    for (int r = 0; r < reps; r++)
        for (int j = 0; j < NPOSE; j++) {
            double P[3], u6[6], C[36];
            dm_pose pose;
            const dm_modes *modes;
            dm_move_result res;
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
            for (int d = 0; d < 3; d++) {
                double dirv[3] = {d == 0, d == 1, d == 2};
                dm_standard_move(mw, an->model, modes, k, an->statics, dirv, &mo, &res, NULL);
            }
            double t5 = now_s();
            if (j)
                dm_modal_mac_match(prev, k, modes, kc, an->model, assign, mac, work);
            memcpy(prev, modes->phi, sizeof(double) * n * k);
            double t6 = now_s();
            if (j % 16 == 0) { /* one tile per 256 points: charge 1/256 each */
                double ti = now_s();
                if (!dm_store_write_metadata(&st, NULL))
                    for (int a = 0; a < 11; a++)
                        dm_store_write_chunk(&st, a, c0, tile, NULL);
                t[6] += 16.0 * (now_s() - ti) / 256.0;
            }
            dm_model_dense(an->model, A, B);
            double t7 = now_s();
            LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'V', 'U', n, A, n, B, n, w);
            double t8 = now_s();
            t[0] += t1 - t0, t[1] += t2 - t1, t[2] += t4 - t3, t[3] += t3 - t2;
            t[4] += t5 - t4, t[5] += t6 - t5, t[7] += t8 - t7;
        }
    double np = reps * NPOSE, us = 1e6 / np, total = 0;
    for (int i = 0; i < 7; i++)
        total += t[i];
    printf("%-9s mesh %d,%d n=%3d k=%d | per pose %7.0f us: kin %4.0f asm %5.0f eigen %6.0f "
           "static %5.0f moves %5.0f mac %4.0f io %4.0f | bare dsygvd %6.0f us | "
           "eigen/bare %.2f  total/bare %.2f\n",
           preset, mesh, mesh, n, k, total * us, t[0] * us, t[1] * us, t[2] * us, t[3] * us,
           t[4] * us, t[5] * us, t[6] * us, t[7] * us, t[2] / t[7], total / t[7]);
    char cmd[64];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd)) {}
    free(A), free(B), free(w), free(work), free(prev), free(tile);
    dm_move_free(mw);
    dm_analysis_free(an);
}

static volatile sig_atomic_t never;

static double sweep_rate(const char *grid_spec, int mesh, int threads, long *points)
{
    dm_robot rb;
    dm_grid g;
    dm_sweep_opts o;
    dm_sweep_stats st;
    dm_error err;
    char dir[] = "/tmp/dm_bench_XXXXXX", cmd[64];
    dm_robot_load("chen2018", &rb, NULL);
    dm_grid_parse(grid_spec, &g, NULL);
    dm_sweep_opts_default(&o);
    o.na = o.nb = mesh;
    o.threads = threads;
    mkdtemp(dir);
    double t0 = now_s();
    if (dm_sweep_run(&rb, &g, &o, dir, &never, &st, &err))
        fprintf(stderr, "bench: %s\n", err.msg);
    double dt = now_s() - t0;
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd)) {}
    *points = st.points_total;
    return st.points_total / dt;
}

/* Max RSS (MB) of the deltamap command running one sweep (fork + exec:
 * forking this OpenMP process and carrying on in the child is not safe). */
static double sweep_rss_mb(const char *grid_spec)
{
    const char *dm = getenv("DELTAMAP") ? getenv("DELTAMAP") : "build/deltamap";
    char dir[] = "/tmp/dm_bench_XXXXXX", cmd[64];
    mkdtemp(dir);
    pid_t pid = fork();
    if (pid == 0) {
        execl(dm, dm, "sweep", "--robot", "chen2018", "--grid", grid_spec, "--mesh", "2,2",
              "--threads", "2", "--progress", "none", "--out", dir, (char *)NULL);
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

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    printf("deltamap bench on %d cores (one BLAS thread per worker)\n\n", omp_get_num_procs());
    printf("1. per pose, one thread (the sweep's pipeline: k modes + 4 for tracking, 3 moves)\n");
    per_pose("chen2018", 1, 10);
    per_pose("chen2018", 2, 10);
    per_pose("chen2018", 4, 10);
    per_pose("zheng2017", 4, 10);
    per_pose("han2011", 4, 10);
    per_pose("chen2018", 8, 10);
    printf("\n2. sweep throughput (chen2018, whole pipeline incl. store)\n");
    long pts;
    for (int th = 1; th <= omp_get_num_procs() && th <= 2; th++) {
        double r4 = sweep_rate("x=-0.3:0.3:24,y=-0.3:0.3:24,z=-0.5", 4, th, &pts);
        printf("   mesh 4,4 (default): %ld points, %d thread%s: %7.1f poses/s\n", pts, th,
               th > 1 ? "s" : " ", r4);
    }
    double r8 = sweep_rate("x=-0.3:0.3:12,y=-0.3:0.3:12,z=-0.5", 8, 0, &pts);
    printf("   mesh 8,8 (finer):   %ld points, all threads: %7.1f poses/s\n", pts, r8);
    printf("\n3. peak memory of a sweep (mesh 2,2, 2 threads)\n");
    double m1 = sweep_rss_mb("x=-0.3:0.3:16,y=-0.3:0.3:16,z=-0.5");
    double m2 = sweep_rss_mb("x=-0.3:0.3:51,y=-0.3:0.3:51,z=-0.5");
    printf("   %5d points: %6.1f MB max RSS\n", 16 * 16, m1);
    printf("   %5d points: %6.1f MB max RSS   (10x the grid: ratio %.2f)\n", 51 * 51, m2, m2 / m1);
    return 0;
}
