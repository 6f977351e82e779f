/* Assembly: DOF counts, symmetry and definiteness, slaving through the
 * short bars, invariance under rotation of the whole robot, and the
 * consistent gravity load. */
#include "dm_test.h"

#include <lapacke.h>
#include <stdlib.h>

#include "dm_analysis.h"
#include "dm_reference.h"
#include "dm_vec3.h"

static dm_model *built(dm_robot *rb, const char *preset, int na, int nb)
{
    dm_pose pose;
    assert_int_equal(dm_robot_load(preset, rb, NULL), 0);
    dm_model *md = dm_model_alloc(rb, na, nb, NULL);
    assert_non_null(md);
    assert_int_equal(dm_kin_inverse(rb, rb->home_m, &pose, NULL), 0);
    assert_int_equal(dm_model_build(md, &pose, NULL), 0);
    return md;
}

static void dof_counts(void **state)
{
    (void)state;
    dm_robot rb;
    for (int na = 1; na <= 5; na += 2)
        for (int nb = 1; nb <= 4; nb++) {
            dm_model *md = built(&rb, "chen2018", na, nb);
            /* per chain: 6 per arm node, per rod 2+2 end rotations + 6 per interior node */
            assert_int_equal(md->n, 3 * (6 * na + 2 * (4 + 6 * (nb - 1))) + 6);
            assert_int_equal(md->platform_dof, md->n - 6);
            dm_model_free(md);
        }
    dm_model *md = built(&rb, "chen2018", 1, 1);
    assert_int_equal(md->n, 48); /* Chen's model */
    dm_model_free(md);
}

static void matrices_symmetric_positive_definite(void **state)
{
    (void)state;
    dm_robot rb;
    dm_model *md = built(&rb, "han2011", 3, 2);
    int n = md->n;
    double kmax = 0, mmax = 0;
    double *K = malloc(sizeof(double) * n * n), *M = malloc(sizeof(double) * n * n);
    dm_model_dense(md, K, M);
    for (size_t i = 0; i < (size_t)n * n; i++) {
        kmax = fmax(kmax, fabs(K[i]));
        mmax = fmax(mmax, fabs(M[i]));
    }
    for (int a = 0; a < n; a++)
        for (int b = 0; b < a; b++) {
            assert_abs(K[a * n + b], K[b * n + a], 1e-14 * kmax, "K symmetric");
            assert_abs(M[a * n + b], M[b * n + a], 1e-14 * mmax, "M symmetric");
        }
    assert_int_equal(LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', n, K, n), 0);
    assert_int_equal(LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', n, M, n), 0);
    free(K);
    free(M);
    dm_model_free(md);
}

/* An elbow rotation theta moves the upper rod ends by theta x (+-d t_i) and
 * leaves their own rotations alone; a platform rotation moves the lower
 * ends by eps x (r e_i +- d t_i). */
static void short_bars_slave_rod_ends(void **state)
{
    (void)state;
    dm_robot rb;
    dm_model *md = built(&rb, "zheng2017", 2, 3);
    double *U = calloc((size_t)md->n, sizeof *U), u[6];
    const double th[3] = {1e-3, -2e-3, 3e-3};
    for (int e = 0; e < md->nelem; e++) {
        const dm_element *el = &md->elem[e];
        if (el->member != DM_MEMBER_ROD)
            continue;
        int i = el->chain;
        for (int nd = 0; nd < 2; nd++) {
            if (el->node[nd].m != 8)
                continue;
            int ref = el->node[nd].idx[0];
            memset(U, 0, sizeof(double) * md->n);
            for (int k = 0; k < 3; k++)
                U[ref + 3 + k] = th[k];
            dm_model_nodemap_apply(&el->node[nd], U, u);
            const double *x = nd == 0 ? el->x1 : el->x2;
            double s[3], expect[3];
            dm_sub3(x, ref == md->platform_dof ? md->pose.P : md->pose.B[i], s);
            dm_cross3(th, s, expect);
            for (int k = 0; k < 3; k++) {
                assert_abs(u[k], expect[k], 1e-15, "rod end translation");
                assert_abs(u[3 + k], 0.0, 0.0, "rod end rotation independent of its body");
            }
        }
    }
    free(U);
    dm_model_free(md);
}

/* The 8 lowest eigenvalues omega^2 (dsygvd) and LAPACK's bound on each
 * (EERRBD, LUG §4.10: dm_reference.h). */
static void eigenvalues(dm_robot *rb, double lam[8], double bound[8])
{
    dm_analysis *an = dm_analysis_alloc(rb, 2, 2, 8, DM_EIGEN_ALL, NULL);
    dm_pose_result res;
    assert_int_equal(dm_analysis_run(an, rb->home_m, 8, &res, NULL), 0);
    int n = an->model->n;
    double *K = malloc(sizeof(double) * n * n), *M = malloc(sizeof(double) * n * n);
    dm_sygv_bound eb;
    dm_model_dense(an->model, K, M);
    assert_int_equal(dm_sygv_bound_init(K, M, n, &eb), 0);
    for (int j = 0; j < 8; j++) {
        lam[j] = res.modes->omega_rad_s[j] * res.modes->omega_rad_s[j];
        bound[j] = dm_sygv_eerrbd(&eb, lam[j]) + 2 * DBL_EPSILON * lam[j]; /* (omega^2 again) */
    }
    free(K), free(M);
    dm_analysis_free(an);
}

/* Rotated, the model is the same up to the rounding of its assembly (each
 * element matrix transformed by other rotations: a few eps of its
 * entries, the kind of perturbation LAPACK's EERRBD allows for in K and
 * M): each eigenvalue within the two solves' bounds and as much again for
 * the two assemblies (formerly 1e-9 relative in f: a constant set on one
 * CPU, below this bound by 3-25x, so it held by that CPU's rounding). */
static void rotating_the_robot_changes_nothing(void **state)
{
    (void)state;
    dm_robot rb;
    double l0[8], l1[8], b0[8], b1[8];
    assert_int_equal(dm_robot_load("han2011", &rb, NULL), 0);
    eigenvalues(&rb, l0, b0);
    rb.theta0_rad = 0.6457;
    eigenvalues(&rb, l1, b1);
    for (int j = 0; j < 8; j++)
        assert_abs(l1[j], l0[j], 2 * (b0[j] + b1[j]), "mode %d after rotating the robot about Z",
                   j + 1);
}

/* Hermite elements with consistent loads solve uniformly loaded frames
 * exactly at the nodes: the static gravity error is mesh independent. */
static void gravity_error_mesh_independent(void **state)
{
    (void)state;
    const char *names[] = {"chen2018", "zheng2017", "han2011"};
    for (int r = 0; r < 3; r++) {
        double dz[3];
        const int mesh[3] = {1, 3, 8};
        for (int m = 0; m < 3; m++) {
            dm_robot rb;
            assert_int_equal(dm_robot_load(names[r], &rb, NULL), 0);
            dm_analysis *an = dm_analysis_alloc(&rb, mesh[m], mesh[m], 1, DM_EIGEN_PARTIAL, NULL);
            dm_pose_result res;
            const double P[3] = {0.03, -0.02, rb.home_m[2]};
            assert_int_equal(dm_analysis_run(an, P, 1, &res, NULL), 0);
            dz[m] = res.static_error[2];
            dm_analysis_free(an);
        }
        assert_rel(dz[1], dz[0], 1e-9, "%s dz at mesh 3,3 vs 1,1", names[r]);
        assert_rel(dz[2], dz[0], 1e-9, "%s dz at mesh 8,8 vs 1,1", names[r]);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(dof_counts),
        cmocka_unit_test(matrices_symmetric_positive_definite),
        cmocka_unit_test(short_bars_slave_rod_ends),
        cmocka_unit_test(rotating_the_robot_changes_nothing),
        cmocka_unit_test(gravity_error_mesh_independent),
    };
    return cmocka_run_group_tests_name("model", tests, NULL, NULL);
}
