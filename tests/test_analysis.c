/* The per-pose pipeline served by the member bases (dm_analysis with
 * dm_analysis_use_members, issue 39) against the same pipeline on the full
 * model and against the extended-precision eigenvalues of the full model:
 * along a sweep-like path (warm solves), three presets, meshes 1,1 and
 * 4,4 (and 8,8 for one), without and with every pose-free effect; the
 * fallback to the full model where the members cannot serve; seeds. */
#include "dm_test.h"

#include <cblas.h>
#include <lapacke.h>
#include <stdlib.h>

#include "dm_analysis.h"
#include "dm_members_fixtures.h"
#include "dm_reference.h"

enum { K14 = 14, STEPS = 5 };

/* The platform share summed over each run of modes closer than 1e-3 in
 * frequency: a degenerate pair's own split depends on its basis. */
static double cluster_share(const dm_modes *mo, int j)
{
    double s = 0;
    int a = j, b = j;
    while (a > 0 && mo->freq_hz[a] <= mo->freq_hz[a - 1] * (1 + 1e-3))
        a--;
    while (b + 1 < K14 && mo->freq_hz[b + 1] <= mo->freq_hz[b] * (1 + 1e-3))
        b++;
    for (int i = a; i <= b; i++)
        s += mo->platform_share[i];
    return s;
}

/* The MAC of each member shape with the whole model's invariant
 * subspace around it (the dense solve's modes within 2e-3 in eigenvalue,
 * two beyond the 14 included: a pair split by the k-th mode stays whole),
 * and what the shape's own residual allows (Davis-Kahan): with
 * r = K phi - lambda M phi (phi M-normalised, lambda its Rayleigh
 * quotient) and delta the distance from lambda to the model's
 * eigenvalues outside the cluster, sin of the M-angle to the cluster's
 * subspace <= ||r||_{M^-1} / delta, so 1 - MAC <= (that)^2. */
static void cluster_macs(const dm_model *md, const double *phi, double *mac, double *allowed)
{
    int n = md->n, q = K14 + 2;
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *K = malloc(sizeof(double) * n * n), *L = malloc(sizeof(double) * n * n);
    double *w = malloc(sizeof(double) * n), *MZ = malloc(sizeof(double) * n * q);
    double *Kp = malloc(sizeof(double) * n), *Mp = malloc(sizeof(double) * n);
    dm_model_dense(md, A, B);
    memcpy(K, A, sizeof(double) * n * n);
    memcpy(L, B, sizeof(double) * n * n);
    assert_int_equal(LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'L', n, L, n), 0); /* M = L L' */
    assert_int_equal(LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'V', 'L', n, A, n, B, n, w), 0);
    dm_model_dense(md, NULL, B);
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, n, q, n, 1, B, n, A, n, 0, MZ, n);
    for (int j = 0; j < K14; j++) {
        const double *p = phi + (size_t)j * n;
        double delta = INFINITY;
        mac[j] = 0;
        for (int i = 0; i < n; i++)
            if (fabs(w[i] - w[j]) <= 2e-3 * w[j]) {
                if (i < q) {
                    double a = cblas_ddot(n, MZ + (size_t)i * n, 1, p, 1);
                    mac[j] += a * a;
                }
            } else
                delta = fmin(delta, fabs(w[i] - w[j]));
        cblas_dsymv(CblasColMajor, CblasLower, n, 1, K, n, p, 1, 0, Kp, 1);
        cblas_dsymv(CblasColMajor, CblasLower, n, 1, B, n, p, 1, 0, Mp, 1);
        double rq = cblas_ddot(n, p, 1, Kp, 1) / cblas_ddot(n, p, 1, Mp, 1);
        for (int r = 0; r < n; r++)
            Kp[r] -= rq * Mp[r];
        cblas_dtrsv(CblasColMajor, CblasLower, CblasNoTrans, CblasNonUnit, n, L, n, Kp, 1);
        double sin_bound = cblas_dnrm2(n, Kp, 1) / delta; /* ||r||_{M^-1} = ||L^-1 r|| */
        allowed[j] = sin_bound * sin_bound;
    }
    free(A), free(B), free(K), free(L), free(w), free(MZ), free(Kp), free(Mp);
}

/* LAPACK's bound on the platform rows of K^-1 [F_gravity, e_platform]
 * (dm_solve_bound: 6 for the static error, then 36 for the compliance). */
static void statics_bounds(const dm_model *md, double *bnd)
{
    int n = md->n, p = md->platform_dof;
    double *K = malloc(sizeof(double) * n * n), *L = malloc(sizeof(double) * n * n);
    double *X = calloc((size_t)n * 7, sizeof(double));
    dm_model_dense(md, K, NULL);
    memcpy(L, K, sizeof(double) * n * n);
    memcpy(X, md->F_gravity, sizeof(double) * n);
    for (int c = 0; c < 6; c++)
        X[(size_t)(c + 1) * n + p + c] = 1;
    assert_int_equal(LAPACKE_dposv(LAPACK_COL_MAJOR, 'L', n, 7, L, n, X, n), 0);
    dm_solve_bound sb;
    assert_int_equal(dm_solve_bound_init(K, n, 1, &sb), 0);
    for (int c = 0; c < 7; c++)
        for (int i = 0; i < 6; i++)
            bnd[6 * c + i] = dm_solve_bound_at(&sb, X + (size_t)c * n, p + i);
    dm_solve_bound_free(&sb);
    free(K), free(L), free(X);
}

/* One pose: members against full and against the reference. */
static void check_pose(dm_analysis *mem, dm_analysis *full, const double P[3], int reference)
{
    dm_pose_result rm, rf;
    assert_int_equal(dm_analysis_run(mem, P, K14, &rm, NULL), 0);
    assert_int_equal(rm.engine, DM_ENGINE_MEMBERS);
    double bound[K14], freq[K14], share[K14];
    assert_int_equal(dm_analysis_bounds(mem, K14, bound, NULL), 0);
    memcpy(freq, rm.modes->freq_hz, sizeof freq);
    for (int j = 0; j < K14; j++)
        share[j] = cluster_share(rm.modes, j);
    int n = full->model->n;
    double *phi = malloc(sizeof(double) * n * K14);
    memcpy(phi, rm.modes->phi, sizeof(double) * n * K14);
    assert_int_equal(dm_analysis_run(full, P, K14, &rf, NULL), 0);
    assert_int_equal(rf.engine, DM_ENGINE_FULL);
    /* statics: the members' are exact through the boundary (test_boundary:
     * 1e-11 of the extended-precision solve); the full solve's own rounding
     * is LAPACK's bound for the condition of K (soft springs make it
     * large). So |members - full| <= 1e-10 of each component's energy
     * scale (the rotations of a Delta's platform are near zero: their
     * scale is the translation's, through the compliances) + that bound. */
    double bnd[42];
    statics_bounds(full->model, bnd);
    const double *C = rf.compliance;
    double W = 0;
    for (int t = 0; t < 3; t++)
        W = fmax(W, fabs(rf.static_error[t]) / sqrt(C[7 * t]));
    for (int j = 0; j < 6; j++) {
        assert_true(fabs(rm.static_error[j] - rf.static_error[j]) <=
                    1e-10 * sqrt(C[7 * j]) * W + bnd[j]);
        for (int i = 0; i < 6; i++)
            assert_true(fabs(rm.compliance[6 * j + i] - C[6 * j + i]) <=
                        1e-10 * sqrt(C[7 * j] * C[7 * i]) + bnd[6 + 6 * j + i]);
    }
    assert_true(fabs(rm.coupling_index_log10 - rf.coupling_index_log10) <=
                1e-10 * fabs(rf.coupling_index_log10) + 1e-12);
    double mac[K14], allowed[K14], share_full[K14];
    cluster_macs(full->model, phi, mac, allowed);
    for (int j = 0; j < K14; j++)
        share_full[j] = cluster_share(rf.modes, j);
    for (int j = 0; j < K14; j++) {
        /* both within 1e-9 of the model's (each is certified so:
         * dm_boundary.h, dm_modal.h) */
        assert_true(fabs(freq[j] - rf.modes->freq_hz[j]) <= 1e-9 * rf.modes->freq_hz[j]);
        /* the shape: as its residual allows (plus the rounding of the
         * MAC's products, 1e-13), and issue 39's 1 - 1e-8 */
        if (!(1 - mac[j] <= allowed[j] + 1e-13 && mac[j] > 1 - 1e-8))
            print_error("mode %d (%.6g Hz): cluster MAC 1 - %.3g, residual allows %.3g\n", j,
                        freq[j], 1 - mac[j], allowed[j]);
        assert_true(1 - mac[j] <= allowed[j] + 1e-13);
        assert_true(mac[j] > 1 - 1e-8);
    }
    for (int j = 0; j < K14; j++) {
        /* a cluster's platform share: phi' P phi with 0 <= P <= M, so two
         * M-unit vectors at M-angle theta differ by at most 2 sin theta;
         * summed over the cluster's modes, each at the angle its MAC
         * gives (1 - MAC known to the 1e-13 of its products' rounding) */
        double allow = 1e-12;
        for (int i = 0; i < K14; i++)
            if (fabs(freq[i] - freq[j]) <= 1e-3 * freq[j])
                allow += 2 * sqrt(fmax(1 - mac[i], 0) + 1e-13);
        if (!(fabs(share[j] - share_full[j]) <= allow))
            print_error("mode %d (%.9g Hz): share %.3g vs %.3g, allowed %.3g\n", j, freq[j], share[j], share_full[j], allow);
        assert_true(fabs(share[j] - share_full[j]) <= allow);
    }
    if (reference) { /* each certified bound covers the true error */
        double *K = malloc(sizeof(double) * n * n), *M = malloc(sizeof(double) * n * n);
        ldbl ref[K14];
        dm_model_dense(full->model, K, M);
        assert_int_equal(dm_reference_eigen(K, M, n, K14, ref, NULL), 0);
        for (int j = 0; j < K14; j++) {
            double lam = pow(2 * M_PI * freq[j], 2), e = fabs(lam - (double)ref[j]);
            if (!(e <= bound[j]))
                print_error("mode %d: error %.3g above its bound %.3g\n", j, e / lam, bound[j] / lam);
            assert_true(e <= bound[j] * (1 + 1e-6));
            assert_true(e <= 1e-9 * lam);
        }
        free(K);
        free(M);
    }
    free(phi);
}

static void along_path(const char *preset, const char *const *sets, int mesh, int reference)
{
    dm_robot rb;
    load(&rb, preset, sets);
    dm_error err;
    dm_members *ms = dm_analysis_members(&rb, mesh, mesh, K14, &err);
    if (!ms)
        print_error("%s: %s\n", preset, err.msg);
    assert_non_null(ms);
    dm_analysis *mem = dm_analysis_alloc(&rb, mesh, mesh, K14, DM_EIGEN_PARTIAL, NULL);
    dm_analysis *full = dm_analysis_alloc(&rb, mesh, mesh, K14, DM_EIGEN_PARTIAL, NULL);
    assert_int_equal(dm_analysis_use_members(mem, ms, NULL), 0);
    for (int s = 0; s < STEPS; s++) { /* 5 mm steps from home, as a sweep's tile */
        double P[3] = {rb.home_m[0] + 0.005 * s, rb.home_m[1] - 0.003 * s, rb.home_m[2] + 0.002 * s};
        check_pose(mem, full, P, reference && (s == 0 || s == STEPS - 1));
    }
    dm_analysis_free(mem);
    dm_analysis_free(full);
    dm_members_free(ms);
}

static void members_serve_the_pipeline(void **state)
{
    (void)state;
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    for (int p = 0; p < 3; p++)
        for (int mesh = 1; mesh <= 4; mesh += 3) {
            along_path(presets[p], NULL, mesh, 1);
            along_path(presets[p], ALL_EFFECTS, mesh, mesh == 1);
        }
    along_path("zheng2017", ALL_EFFECTS, 8, 0);
}

/* Members built for another geometry cannot serve the pose (their arm
 * length differs): the full model serves it, cold, with the same values
 * as an analysis that never had members. Geometric stiffness: no members. */
static void fallback_to_the_full_model(void **state)
{
    (void)state;
    dm_robot rb, other;
    static const char *const longer[] = {"effects.error_arm_length=0.002,0,0", NULL};
    load(&rb, "chen2018", NULL);
    load(&other, "chen2018", longer);
    dm_members *ms = dm_analysis_members(&other, 4, 4, K14, NULL);
    assert_non_null(ms);
    dm_analysis *mem = dm_analysis_alloc(&rb, 4, 4, K14, DM_EIGEN_PARTIAL, NULL);
    dm_analysis *full = dm_analysis_alloc(&rb, 4, 4, K14, DM_EIGEN_PARTIAL, NULL);
    assert_int_equal(dm_analysis_use_members(mem, ms, NULL), 0);
    dm_pose_result rm, rf;
    assert_int_equal(dm_analysis_run(mem, rb.home_m, K14, &rm, NULL), 0);
    assert_int_equal(rm.engine, DM_ENGINE_FULL);
    double bound[K14];
    assert_int_equal(dm_analysis_bounds(mem, K14, bound, NULL), DM_EINVAL);
    double freq[K14];
    memcpy(freq, rm.modes->freq_hz, sizeof freq);
    assert_int_equal(dm_analysis_run(full, rb.home_m, K14, &rf, NULL), 0);
    assert_memory_equal(freq, rf.modes->freq_hz, sizeof freq);
    assert_memory_equal(rm.static_error, rf.static_error, sizeof rm.static_error);
    dm_analysis_free(mem);
    dm_analysis_free(full);
    dm_members_free(ms);

    /* a solve the members fail at: 47 modes of their 48-DOF reduced model
     * (the filter has no room), served by the full model with the reason
     * kept, no bounds, no seed; an unreachable pose after a served one
     * leaves nothing of it standing; k beyond kmax is refused */
    ms = dm_analysis_members(&rb, 1, 1, 47, NULL);
    assert_non_null(ms);
    mem = dm_analysis_alloc(&rb, 1, 1, 47, DM_EIGEN_PARTIAL, NULL);
    full = dm_analysis_alloc(&rb, 1, 1, 47, DM_EIGEN_PARTIAL, NULL);
    assert_int_equal(dm_analysis_use_members(mem, ms, NULL), 0);
    assert_int_equal(dm_analysis_run(mem, rb.home_m, 47, &rm, NULL), 0);
    assert_int_equal(rm.engine, DM_ENGINE_FULL);
    assert_int_not_equal(mem->member_error.code, 0);
    assert_int_equal(dm_analysis_bounds(mem, 47, bound, NULL), DM_EINVAL);
    unsigned char *seed = malloc(dm_analysis_seed_size(mem));
    assert_int_equal(dm_analysis_seed_save(mem, seed), 0);
    double f47[47];
    memcpy(f47, rm.modes->freq_hz, sizeof f47);
    assert_int_equal(dm_analysis_run(full, rb.home_m, 47, &rf, NULL), 0);
    assert_memory_equal(f47, rf.modes->freq_hz, sizeof f47);
    free(seed);
    dm_analysis_free(mem);
    dm_members_free(ms);
    ms = dm_analysis_members(&rb, 1, 1, K14, NULL);
    mem = dm_analysis_alloc(&rb, 1, 1, K14, DM_EIGEN_PARTIAL, NULL);
    assert_int_equal(dm_analysis_use_members(mem, ms, NULL), 0);
    assert_int_equal(dm_analysis_run(mem, rb.home_m, K14, &rm, NULL), 0);
    assert_int_equal(rm.engine, DM_ENGINE_MEMBERS);
    const double away[3] = {0, 0, -2};
    assert_int_equal(dm_analysis_run(mem, away, K14, &rm, NULL), DM_EUNREACHABLE);
    assert_int_equal(dm_analysis_bounds(mem, K14, bound, NULL), DM_EINVAL);
    assert_null(dm_analysis_track_vectors(mem, &rm));
    assert_int_equal(dm_analysis_run(mem, rb.home_m, K14 + 1, &rm, NULL), DM_EINVAL);
    dm_analysis_free(mem);
    dm_analysis_free(full);
    dm_members_free(ms);

    dm_error err;
    static const char *const geometric[] = {"effects.geometric_stiffness=on", NULL};
    load(&rb, "chen2018", geometric);
    assert_null(dm_analysis_members(&rb, 4, 4, K14, &err));
    assert_true(strstr(err.msg, "geometric") != NULL);
}

/* A run from a seed gives the same bits whatever the analysis ran before
 * (the sweep starts each point from its anchor's seed). */
static void seeds_decide_the_bits(void **state)
{
    (void)state;
    dm_robot rb;
    load(&rb, "zheng2017", NULL);
    dm_members *ms = dm_analysis_members(&rb, 4, 4, K14, NULL);
    dm_analysis *an = dm_analysis_alloc(&rb, 4, 4, K14, DM_EIGEN_PARTIAL, NULL);
    assert_int_equal(dm_analysis_use_members(an, ms, NULL), 0);
    size_t len = dm_analysis_seed_size(an);
    unsigned char *seed = malloc(len);
    dm_pose_result r;
    double P[3] = {rb.home_m[0] + 0.01, rb.home_m[1], rb.home_m[2]}, first[K14];
    double far[3] = {rb.home_m[0] - 0.05, rb.home_m[1] + 0.04, rb.home_m[2] - 0.02};
    assert_int_equal(dm_analysis_run(an, rb.home_m, K14, &r, NULL), 0);
    assert_int_equal(dm_analysis_seed_save(an, seed), 1);
    for (int history = 0; history < 3; history++) {
        if (history == 1)
            assert_int_equal(dm_analysis_run(an, far, K14, &r, NULL), 0);
        if (history == 2)
            dm_analysis_forget(an);
        dm_analysis_seed_load(an, seed);
        assert_int_equal(dm_analysis_run(an, P, K14, &r, NULL), 0);
        assert_int_equal(r.engine, DM_ENGINE_MEMBERS);
        if (!history)
            memcpy(first, r.modes->freq_hz, sizeof first);
        else
            assert_memory_equal(first, r.modes->freq_hz, sizeof first);
    }
    /* and a cold run's bits depend on its pose alone */
    dm_analysis_forget(an);
    assert_int_equal(dm_analysis_run(an, P, K14, &r, NULL), 0);
    memcpy(first, r.modes->freq_hz, sizeof first);
    assert_int_equal(dm_analysis_run(an, far, K14, &r, NULL), 0);
    dm_analysis_forget(an);
    assert_int_equal(dm_analysis_run(an, P, K14, &r, NULL), 0);
    assert_memory_equal(first, r.modes->freq_hz, sizeof first);
    free(seed);
    dm_analysis_free(an);
    dm_members_free(ms);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(members_serve_the_pipeline),
        cmocka_unit_test(fallback_to_the_full_model),
        cmocka_unit_test(seeds_decide_the_bits),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
