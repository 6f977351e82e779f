/* Zheng's coupling index (dm_coupling): log10 prod sigma_k(K) from the
 * Cholesky factor against a dense SVD, its exact scaling with the
 * stiffness, its change against the nominal robot, and independence of
 * the thread count. */
#include "dm_test.h"

#include <cblas.h>
#include <float.h>
#include <lapacke.h>
#include <omp.h>
#include <stdlib.h>

#include "dm_analysis.h"
#include "dm_coupling.h"
#include "dm_reference.h"

static void load(const char *preset, const char *const *sets, dm_robot *rb)
{
    dm_error err;
    assert_int_equal(dm_robot_load(preset, rb, NULL), 0);
    for (int i = 0; sets && sets[i]; i++) {
        int rc = dm_robot_set(rb, sets[i], &err);
        if (rc)
            print_error("%s\n", err.msg);
        assert_int_equal(rc, 0);
    }
}

static double index_at(const dm_robot *rb, int na, int nb, const double *P, dm_analysis **keep)
{
    dm_pose_result res;
    dm_error err;
    dm_analysis *an = dm_analysis_alloc(rb, na, nb, 1, DM_EIGEN_DENSE, NULL);
    assert_non_null(an);
    int rc = dm_analysis_run(an, P, 1, &res, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    if (keep)
        *keep = an;
    else
        dm_analysis_free(an);
    return res.coupling_index_log10;
}

/* Sum of log10 of the singular values of the dense K (LAPACKE_dgesvd):
 * Zheng's definition taken literally, by a route that shares nothing with
 * the block-arrow Cholesky but the assembled matrix. *bound: how far each
 * route may be from the exact sum, from LAPACK's own error bounds. dgesvd:
 * |sigma^_k - sigma_k| <~ p(n) eps sigma_1 (LUG §4.9, SERRBD), which
 * moves log10 sigma_k by up to eps sigma_1 / (sigma_k ln 10). The Cholesky
 * factor: R'R = K + E with |E| <= gamma |R'| |R| (Higham, Thm 10.3), which
 * does not see the diagonal scaling D = diag(K)^-1/2: as a perturbation of
 * H = D K D of norm ~eps ||H||, it moves log det by up to
 * sum_k eps ||H||_2 / lambda_k(H) (Weyl, each eigenvalue; log det H =
 * log det K + 2 sum log d_k exactly but for the rounding of the d_k, a
 * few eps each). p(n) = 1, as in LUG's fragments. */
static double svd_log10(const dm_model *md, double *bound)
{
    int n = md->n;
    double *K = malloc(sizeof(double) * n * n), *s = malloc(sizeof(double) * n),
           *sup = malloc(sizeof(double) * n), *H = malloc(sizeof(double) * n * n);
    dm_model_dense(md, K, NULL);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++)
            H[(size_t)j * n + i] =
                K[(size_t)j * n + i] / sqrt(K[(size_t)i * n + i] * K[(size_t)j * n + j]);
    assert_int_equal(LAPACKE_dgesvd(LAPACK_COL_MAJOR, 'N', 'N', n, n, K, n, s, NULL, 1, NULL, 1, sup),
                     0);
    double sum = 0, err = 0;
    for (int k = 0; k < n; k++) {
        assert_true(s[k] > 0);
        sum += log10(s[k]);
        err += DBL_EPSILON * s[0] / s[k];
    }
    assert_int_equal(LAPACKE_dsyev(LAPACK_COL_MAJOR, 'N', 'U', n, H, n, s), 0); /* ascending */
    for (int k = 0; k < n; k++) {
        assert_true(s[k] > 0);
        err += DBL_EPSILON * s[n - 1] / s[k] + 4 * DBL_EPSILON;
    }
    *bound = err / log(10.0);
    free(K);
    free(s);
    free(sup);
    free(H);
    return sum;
}

/* log10 det K from a long double Cholesky factor (dm_reference.h): no
 * LAPACK rounding, and 2^11 times less of its own. */
static double ld_log10(const dm_model *md)
{
    int n = md->n;
    double *K = malloc(sizeof(double) * n * n);
    ldbl *L = malloc(sizeof(ldbl) * n * n), sum = 0;
    dm_model_dense(md, K, NULL);
    for (size_t i = 0; i < (size_t)n * n; i++)
        L[i] = K[i];
    assert_int_equal(ref_cholesky(L, n), 0);
    for (int k = 0; k < n; k++)
        sum += 2 * log10l(L[(size_t)k * n + k]);
    free(K), free(L);
    return (double)sum;
}

/* 1e-10 in log10 lambda_s (2.3e-10 relative in lambda_s), the issue's
 * figure, against the long double factor. Against the dense SVD, a route
 * that involves LAPACK's rounding, the two routes' bounds from LAPACK's
 * (svd_log10: 4e-10 to 6e-9 here); the 1e-10 held there on one
 * CPU's kernels only (the difference varies 5x between OpenBLAS kernel
 * sets, and exceeded 1e-10 with OPENBLAS_CORETYPE=Atom: 1.06e-10). */
static void equals_dense_svd_at_mesh_1_1(void **state)
{
    (void)state;
    static const char *const none[] = {NULL};
    static const char *const ext[] = {"effects.joint_stiffness=2e7", "effects.actuator_stiffness=5e4",
                                      "effects.base_stiffness=1e7,2e7,3e7", "effects.payload_mass=0.5",
                                      "effects.error_arm_length=1e-4,-2e-4,0",
                                      "effects.clearance=2e-5", "effects.geometric_stiffness=on", NULL};
    const struct { const char *preset; const char *const *sets; double P[3]; } cases[] = {
        {"chen2018", none, {0, 0, -0.5}},       {"chen2018", none, {0.12, -0.07, -0.55}},
        {"zheng2017", none, {0, 0, -0.4}},      {"zheng2017", ext, {0.05, 0.03, -0.42}},
        {"han2011", none, {0.1, 0.2, 0.9}},     {"han2011", ext, {0, 0, 0.96}},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        dm_robot rb;
        dm_analysis *an;
        load(cases[c].preset, cases[c].sets, &rb);
        double li = index_at(&rb, 1, 1, cases[c].P, &an), bound;
        double ref = svd_log10(an->model, &bound);
        assert_abs(li, ld_log10(an->model), 1e-10,
                   "%s case %zu: log10 lambda_s vs long double Cholesky (n = %d)",
                   cases[c].preset, c, an->model->n);
        assert_abs(li, ref, bound, "%s case %zu: log10 lambda_s vs dense SVD (n = %d)",
                   cases[c].preset, c, an->model->n);
        assert_true(isfinite(li) && li > 0);
        dm_analysis_free(an);
    }
}

/* K is linear in the elastic moduli: scaling E and G of arms and rods by s
 * scales every entry of the baseline K, so log10 det K grows by exactly
 * n log10 s (analytic; tolerance 1e-9 of log10 lambda_s ~ 1e3, round-off
 * of the n pivots). */
static void scales_with_stiffness_as_n_log10_s(void **state)
{
    (void)state;
    const double P[3] = {0.03, -0.02, -0.45}, s = 3.7;
    dm_robot rb, stiff;
    load("chen2018", NULL, &rb);
    stiff = rb;
    dm_member *m[2] = {&stiff.arm, &stiff.rod};
    for (int i = 0; i < 2; i++) {
        m[i]->youngs_pa *= s;
        m[i]->shear_pa *= s;
    }
    dm_analysis *an;
    double l0 = index_at(&rb, 4, 4, P, &an), l1 = index_at(&stiff, 4, 4, P, NULL);
    int n = an->model->n;
    assert_abs(l1 - l0, n * log10(s), 1e-9 * fabs(l0), "log10 det(sK) - log10 det K = n log10 s");
    dm_analysis_free(an);
}

/* The nominal robot's index at the same commanded pose: the robot itself
 * when it has no effects (change exactly 0), and with a compliant base the
 * change is below zero (softer) and scales with the springs as the
 * analytic limit says: nine extra DOFs tied to ground by k, so for stiff
 * springs the change tends to 9 log10 k + const; doubling k adds 9 log10 2
 * (to 1e-3: the base springs are 1e5x stiffer than what they hold). */
static void change_against_nominal(void **state)
{
    (void)state;
    const double P[3] = {0.04, 0.01, -0.45};
    dm_robot rb;
    dm_error err;
    load("zheng2017", NULL, &rb);
    dm_coupling *cw = dm_coupling_alloc(&rb, 2, 2, &err);
    assert_non_null(cw);
    double nominal, li = index_at(&rb, 2, 2, P, NULL);
    assert_int_equal(dm_coupling_nominal_log10(cw, P, &nominal, &err), 0);
    assert_true(li - nominal == 0.0);
    dm_coupling_free(cw);

    double ch[2];
    for (int j = 0; j < 2; j++) {
        char kv[64];
        snprintf(kv, sizeof kv, "effects.base_stiffness=%g,%g,%g", 1e13 * (1 + j), 1e13 * (1 + j), 1e13 * (1 + j));
        const char *const sets[] = {kv, NULL};
        load("zheng2017", sets, &rb);
        cw = dm_coupling_alloc(&rb, 2, 2, &err);
        assert_non_null(cw);
        li = index_at(&rb, 2, 2, P, NULL);
        assert_int_equal(dm_coupling_nominal_log10(cw, P, &nominal, &err), 0);
        ch[j] = li - nominal;
        dm_coupling_free(cw);
    }
    assert_abs(ch[1] - ch[0], 9 * log10(2.0), 1e-3, "stiff base: change grows by 9 log10 2");
}

/* The same poses on one thread and on two (each thread its own workspace),
 * and with 1 or 2 BLAS threads: the same bits. */
static void independent_of_thread_count(void **state)
{
    (void)state;
    enum { NP = 6 };
    dm_robot rb;
    load("han2011", NULL, &rb);
    double serial[NP], par[NP], blas2[NP];
    for (int p = 0; p < NP; p++) {
        const double P[3] = {0.05 * p, -0.03 * p, 0.9};
        serial[p] = index_at(&rb, 4, 4, P, NULL);
    }
#pragma omp parallel for num_threads(2) schedule(static, 1)
    for (int p = 0; p < NP; p++) {
        const double P[3] = {0.05 * p, -0.03 * p, 0.9};
        par[p] = index_at(&rb, 4, 4, P, NULL);
    }
    openblas_set_num_threads(2);
    for (int p = 0; p < NP; p++) {
        const double P[3] = {0.05 * p, -0.03 * p, 0.9};
        blas2[p] = index_at(&rb, 4, 4, P, NULL);
    }
    openblas_set_num_threads(1);
    for (int p = 0; p < NP; p++) {
        assert_memory_equal(&serial[p], &par[p], sizeof(double));
        assert_memory_equal(&serial[p], &blas2[p], sizeof(double));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(equals_dense_svd_at_mesh_1_1),
        cmocka_unit_test(scales_with_stiffness_as_n_log10_s),
        cmocka_unit_test(change_against_nominal),
        cmocka_unit_test(independent_of_thread_count),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
