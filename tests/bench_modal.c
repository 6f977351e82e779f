/* make bench: per-pose cost of the frozen-configuration analysis, split by
 * stage, against a bare LAPACK eigen solve (dsygvd, all pairs) of the same
 * matrices in the same run. Prints figures and ratios; asserts nothing. */
#include <lapacke.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "dm_analysis.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

#define NPOSE 64

static void pose_at(const dm_robot *rb, int j, double P[3])
{
    double a = 6.283185307179586 * j / NPOSE, rad = 0.1 * rb->arm_length_m;
    P[0] = rb->home_m[0] + rad * cos(a);
    P[1] = rb->home_m[1] + rad * sin(3 * a);
    P[2] = rb->home_m[2] + 0.05 * rb->arm_length_m * sin(a);
}

static void bench(const char *preset, int mesh, int k)
{
    dm_robot rb;
    dm_error err;
    if (dm_robot_load(preset, &rb, &err)) {
        fprintf(stderr, "%s\n", err.msg);
        exit(1);
    }
    dm_analysis *an = dm_analysis_alloc(&rb, mesh, mesh, k, DM_EIGEN_PARTIAL, &err);
    dm_analysis *full = dm_analysis_alloc(&rb, mesh, mesh, k, DM_EIGEN_ALL, &err);
    int n = an->model->n;
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *w = malloc(sizeof(double) * n);
    double t_kin = 0, t_asm = 0, t_eig = 0, t_eig_all = 0, t_static = 0, t_bare = 0;
    int reps = mesh <= 2 ? 8 : 2;
    for (int r = 0; r < reps; r++)
        for (int j = 0; j < NPOSE; j++) {
            double P[3];
            dm_pose pose;
            const dm_modes *modes;
            double u6[6], C[36];
            pose_at(&rb, j, P);
            double t0 = now_s();
            dm_kin_inverse(&rb, P, &pose, NULL);
            double t1 = now_s();
            dm_model_build(an->model, &pose, NULL);
            double t2 = now_s();
            dm_modal_solve(an->modal, an->model->K, an->model->M, k, &modes, NULL);
            double t3 = now_s();
            dm_static_factor(an->statics, an->model->K, NULL);
            dm_static_platform_error(an->statics, an->model, an->model->F_gravity, u6, NULL);
            dm_static_compliance(an->statics, an->model, C, NULL);
            double t4 = now_s();
            dm_modal_solve(full->modal, an->model->K, an->model->M, k, &modes, NULL);
            double t5 = now_s();
            memcpy(A, an->model->K, sizeof(double) * n * n);
            memcpy(B, an->model->M, sizeof(double) * n * n);
            double t6 = now_s();
            LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'V', 'U', n, A, n, B, n, w);
            double t7 = now_s();
            t_kin += t1 - t0;
            t_asm += t2 - t1;
            t_eig += t3 - t2;
            t_static += t4 - t3;
            t_eig_all += t5 - t4;
            t_bare += t7 - t6;
        }
    double np = reps * NPOSE, total = t_kin + t_asm + t_eig + t_static;
    printf("%-10s mesh %d,%d  n=%3d  k=%2d | per pose: total %8.1f us = kin %5.1f + assembly "
           "%7.1f + eigen %8.1f + static %7.1f | bare dsygvd %8.1f us | eigen(all) %8.1f | "
           "ratio total/bare %.2f, eigen/bare %.2f | %.0f poses/s\n",
           preset, mesh, mesh, n, k, 1e6 * total / np, 1e6 * t_kin / np, 1e6 * t_asm / np,
           1e6 * t_eig / np, 1e6 * t_static / np, 1e6 * t_bare / np, 1e6 * t_eig_all / np,
           total / t_bare, t_eig / t_bare, np / total);
    free(A);
    free(B);
    free(w);
    dm_analysis_free(an);
    dm_analysis_free(full);
}

int main(void)
{
    printf("deltamap bench: one thread, OPENBLAS_NUM_THREADS=%s\n",
           getenv("OPENBLAS_NUM_THREADS") ? getenv("OPENBLAS_NUM_THREADS") : "(unset)");
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    for (int r = 0; r < 3; r++) {
        bench(presets[r], 1, 10);
        bench(presets[r], 4, 10);
    }
    bench("chen2018", 8, 10);
    return 0;
}
