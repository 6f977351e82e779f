/* Static responses: gravity error symmetry, compliance against an
 * independent LU solve, point-mass limit, worst direction. */
#include "dm_test.h"

#include <lapacke.h>
#include <stdlib.h>

#include "dm_analysis.h"
#include "dm_reference.h"

static void run(dm_robot *rb, const double *P, dm_analysis **an, dm_pose_result *res)
{
    *an = dm_analysis_alloc(rb, 2, 2, 1, DM_EIGEN_PARTIAL, NULL);
    assert_non_null(*an);
    assert_int_equal(dm_analysis_run(*an, P ? P : rb->home_m, 1, res, NULL), 0);
}

static void gravity_error_is_vertical_at_centre(void **state)
{
    (void)state;
    const char *names[] = {"chen2018", "zheng2017", "han2011"};
    for (int r = 0; r < 3; r++) {
        dm_robot rb;
        dm_analysis *an;
        dm_pose_result res;
        assert_int_equal(dm_robot_load(names[r], &rb, NULL), 0);
        run(&rb, NULL, &an, &res);
        double dz = fabs(res.static_error[2]);
        assert_true(res.static_error[2] < 0); /* sags under gravity */
        for (int k = 0; k < 6; k++)
            if (k != 2)
                assert_abs(res.static_error[k], 0.0, 1e-9 * dz, "%s component %d", names[r], k);
        dm_analysis_free(an);
    }
}

/* The compliance (6 x 6 block of K^-1 at the platform, from the block-arrow
 * Cholesky factor) against an LU solve (dgesv) of the dense K: each within
 * LAPACK's bound for a backward-stable solve of K (LUG §4.4, with the
 * scaling each factorization does not see: dm_reference.h), ours for
 * Cholesky, dgesv's for LU with partial pivoting. (Formerly 1e-9 of the
 * diagonal entry, a constant set on one CPU.) */
static void compliance_matches_lu_solve(void **state)
{
    (void)state;
    dm_robot rb;
    dm_analysis *an;
    dm_pose_result res;
    const double P[3] = {0.07, -0.04, -0.42};
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    run(&rb, P, &an, &res);
    int n = an->model->n, p = an->model->platform_dof;
    double *A = malloc(sizeof(double) * n * n), *B = calloc((size_t)n * 6, sizeof(double));
    lapack_int *piv = malloc(sizeof(lapack_int) * n);
    dm_model_dense(an->model, A, NULL);
    dm_solve_bound chol, lu;
    assert_int_equal(dm_solve_bound_init(A, n, 1, &chol), 0);
    assert_int_equal(dm_solve_bound_init(A, n, 0, &lu), 0);
    for (int j = 0; j < 6; j++)
        B[(size_t)j * n + p + j] = 1.0;
    assert_int_equal(LAPACKE_dgesv(LAPACK_COL_MAJOR, n, 6, A, n, piv, B, n), 0);
    for (int j = 0; j < 6; j++)
        for (int r = 0; r < 6; r++) {
            const double *x = B + (size_t)j * n;
            double bound = dm_solve_bound_at(&chol, x, p + r) + dm_solve_bound_at(&lu, x, p + r);
            assert_abs(res.compliance[6 * j + r], x[p + r], bound, "C(%d,%d) vs LU", r, j);
            assert_rel(res.compliance[6 * j + r], res.compliance[6 * r + j], 1e-12, "C symmetric");
        }
    /* worst direction: the largest eigenvalue bounds every diagonal entry */
    for (int k = 0; k < 3; k++)
        assert_true(res.compliance_max_m_per_n >= res.compliance[7 * k] * (1 - 1e-12));
    const double *d = res.compliance_dir;
    assert_rel(d[0] * d[0] + d[1] * d[1] + d[2] * d[2], 1.0, 1e-12, "unit direction");
    dm_solve_bound_free(&chol);
    dm_solve_bound_free(&lu);
    free(A);
    free(B);
    free(piv);
    dm_analysis_free(an);
}

/* With massless links the gravity error is the compliance times the
 * platform weight. */
static void massless_links_give_compliance_times_weight(void **state)
{
    (void)state;
    dm_robot rb;
    dm_analysis *an;
    dm_pose_result res;
    const double P[3] = {0.1, 0.05, -0.55};
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    rb.arm.density_kgm3 *= 1e-8; /* links 1e-8 of their mass: eigen solve stays sane */
    rb.rod.density_kgm3 *= 1e-8;
    run(&rb, P, &an, &res);
    double W = rb.platform_mass_kg * rb.gravity_ms2[2];
    for (int r = 0; r < 6; r++)
        assert_rel(res.static_error[r], res.compliance[6 * 2 + r] * W, 1e-6, "component %d", r);
    dm_analysis_free(an);
}

/* Superposition and scaling: the static error is linear in gravity. */
static void error_is_linear_in_gravity(void **state)
{
    (void)state;
    dm_robot rb;
    dm_analysis *an;
    dm_pose_result rz, rx, rxz, r3;
    const double P[3] = {-0.05, 0.1, 0.9};
    assert_int_equal(dm_robot_load("han2011", &rb, NULL), 0);
    run(&rb, P, &an, &rz);
    dm_analysis_free(an);
    rb.gravity_ms2[0] = 4.9;
    run(&rb, P, &an, &rxz);
    dm_analysis_free(an);
    rb.gravity_ms2[2] = 0;
    run(&rb, P, &an, &rx);
    dm_analysis_free(an);
    rb.gravity_ms2[0] = 0;
    rb.gravity_ms2[2] = -3 * 9.80665;
    run(&rb, P, &an, &r3);
    dm_analysis_free(an);
    double scale = fabs(rz.static_error[2]);
    for (int k = 0; k < 6; k++) {
        assert_abs(rxz.static_error[k], rx.static_error[k] + rz.static_error[k], 1e-12 * scale,
                   "superposition, comp %d", k);
        assert_abs(r3.static_error[k], 3.0 * rz.static_error[k], 1e-12 * scale,
                   "scaling, comp %d", k);
    }
    assert_true(fabs(rx.static_error[0]) > 0.1 * scale); /* sideways gravity moves it sideways */
}

/* The worst direction of a compliance whose translational block is
 * Q diag(1, 3, 2) Q' (rotational rows and columns anything): the largest
 * value 3 within 4 eps, its direction Q's second column within 1e-14,
 * signed so that its largest component is positive; the rotational part
 * is not read. */
static void worst_compliance_direction(void **state)
{
    (void)state;
    double c = cos(0.3), s = sin(0.3), c2 = cos(1.1), s2 = sin(1.1);
    /* Q = Rz(0.3) Rx(1.1), columns */
    double Q[3][3] = {{c, s, 0}, {-s * c2, c * c2, s2}, {s * s2, -c * s2, c2}};
    double lam[3] = {1, 3, 2}, C[36];
    for (int i = 0; i < 36; i++)
        C[i] = 7.0 + i; /* rotational and coupling entries: not read */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double v = 0;
            for (int k = 0; k < 3; k++)
                v += Q[k][i] * lam[k] * Q[k][j];
            C[i + 6 * j] = v;
        }
    double m, dir[3];
    assert_int_equal(dm_compliance_worst(C, &m, dir), 0);
    assert_true(fabs(m - 3) <= 4 * 3 * 2.3e-16);
    double sign = fabs(Q[1][1]) >= fabs(Q[1][0]) && fabs(Q[1][1]) >= fabs(Q[1][2])
                      ? (Q[1][1] > 0 ? 1 : -1)
                      : (fabs(Q[1][0]) >= fabs(Q[1][2]) ? (Q[1][0] > 0 ? 1 : -1)
                                                         : (Q[1][2] > 0 ? 1 : -1));
    for (int k = 0; k < 3; k++)
        assert_true(fabs(dir[k] - sign * Q[1][k]) <= 1e-14);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(gravity_error_is_vertical_at_centre),
        cmocka_unit_test(compliance_matches_lu_solve),
        cmocka_unit_test(massless_links_give_compliance_times_weight),
        cmocka_unit_test(error_is_linear_in_gravity),
        cmocka_unit_test(worst_compliance_direction),
    };
    return cmocka_run_group_tests_name("static", tests, NULL, NULL);
}
