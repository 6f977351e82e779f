/* Modal analysis: mass normalisation, the two eigen methods agree, the
 * independent check values of MODEL.md §8, symmetry pairs, mesh
 * convergence. */
#include "dm_test.h"

#include <stdlib.h>

#include "dm_analysis.h"

typedef struct {
    const char *preset;
    int mesh, dof;
    double f[6], dz;
} check_row;

/* MODEL.md §8, from an independent implementation of the contract. */
static const check_row CHECKS[] = {
    {"chen2018", 1, 48, {27.9643, 32.5073, 32.5073, 44.1040, 46.7423, 46.7423}, -4.10144e-4},
    {"chen2018", 4, 210, {27.7747, 32.2985, 32.2985, 43.0844, 46.0175, 46.0175}, -4.10144e-4},
    {"zheng2017", 1, 48, {84.3861, 84.3861, 157.2553, 187.9854, 188.2113, 188.2113}, -1.38612e-6},
    {"zheng2017", 4, 210, {84.1938, 84.1938, 149.5315, 169.5698, 169.7193, 169.7193}, -1.38612e-6},
    {"han2011", 1, 48, {15.8274, 15.8274, 25.2644, 36.3228, 36.3228, 44.8890}, -4.12602e-4},
    {"han2011", 4, 210, {15.8261, 15.8261, 25.2618, 36.2972, 36.2972, 44.8045}, -4.12602e-4},
};

static void run_at(const char *preset, int na, int nb, const double *P, int k,
                   dm_eigen_method method, dm_robot *rb, dm_analysis **an, dm_pose_result *res)
{
    assert_int_equal(dm_robot_load(preset, rb, NULL), 0);
    *an = dm_analysis_alloc(rb, na, nb, k, method, NULL);
    assert_non_null(*an);
    dm_error err;
    int rc = dm_analysis_run(*an, P ? P : rb->home_m, k, res, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
}

static void check_values_of_the_contract(void **state)
{
    (void)state;
    for (size_t c = 0; c < sizeof CHECKS / sizeof CHECKS[0]; c++) {
        const check_row *row = &CHECKS[c];
        dm_robot rb;
        dm_analysis *an;
        dm_pose_result res;
        run_at(row->preset, row->mesh, row->mesh, NULL, 6, DM_EIGEN_PARTIAL, &rb, &an, &res);
        assert_int_equal(an->model->n, row->dof);
        /* printed to 4 decimals (Hz) and 6 digits (m): half a unit of the last digit */
        for (int j = 0; j < 6; j++)
            assert_abs(res.modes->freq_hz[j], row->f[j], 0.5e-4 + 1e-9, "%s mesh %d f%d (Hz)",
                       row->preset, row->mesh, j + 1);
        assert_abs(res.static_error[2], row->dz, 0.5e-5 * fabs(row->dz), "%s mesh %d dz (m)",
                   row->preset, row->mesh);
        dm_analysis_free(an);
    }
}

static void modes_are_mass_normalised(void **state)
{
    (void)state;
    dm_robot rb;
    dm_analysis *an;
    dm_pose_result res;
    const double P[3] = {0.05, 0.08, -0.45};
    run_at("chen2018", 2, 3, P, 12, DM_EIGEN_PARTIAL, &rb, &an, &res);
    const dm_modes *mo = res.modes;
    int n = mo->n;
    double *M = malloc(sizeof(double) * n * n), *K = malloc(sizeof(double) * n * n);
    dm_model_dense(an->model, K, M);
    for (int a = 0; a < mo->k; a++)
        for (int b = 0; b < mo->k; b++) {
            double m = 0, k = 0;
            for (int r = 0; r < n; r++)
                for (int c = 0; c < n; c++) {
                    double pa = mo->phi[(size_t)a * n + r], pb = mo->phi[(size_t)b * n + c];
                    m += pa * M[(size_t)c * n + r] * pb;
                    k += pa * K[(size_t)c * n + r] * pb;
                }
            double w2 = mo->omega_rad_s[a] * mo->omega_rad_s[a];
            assert_abs(m, a == b, 1e-10, "Phi' M Phi (%d,%d)", a, b);
            assert_abs(k, a == b ? w2 : 0.0, 1e-9 * w2, "Phi' K Phi (%d,%d)", a, b);
        }
    free(M);
    free(K);
    for (int j = 0; j < mo->k; j++) {
        assert_true(mo->platform_share[j] >= 0 && mo->platform_share[j] <= 1.0 + 1e-12);
        if (j)
            assert_true(mo->freq_hz[j] >= mo->freq_hz[j - 1]);
    }
    dm_analysis_free(an);
}

/* The partial solver (dsyevr for the k lowest; below 96 DOF all
 * eigenvalues by dsterf and k vectors by dstein) against dsygvd: the same
 * eigenvalues, and the same invariant subspaces (MAC of each mode with the
 * reference's, summed over a degenerate pair, = 1). Off-centre and at the
 * centre, where x/y pairs are degenerate. */
static void compare_solvers(const char *preset, int mesh, const double *P, int k)
{
    dm_robot rb;
    dm_analysis *a1, *a2;
    dm_pose_result r1, r2;
    run_at(preset, mesh, mesh, P, k, DM_EIGEN_PARTIAL, &rb, &a1, &r1);
    run_at(preset, mesh, mesh, P, k, DM_EIGEN_ALL, &rb, &a2, &r2);
    int n = a1->model->n;
    double *M = malloc(sizeof(double) * n * n);
    dm_model_dense(a1->model, NULL, M);
    /* eigenvalues agree to ~eps * lambda_max; lambda_max / lambda_1 ~ 1e6 here,
     * so f1 agrees to ~1e-10 relative: allow 1e-8 */
    for (int j = 0; j < k; j++)
        assert_rel(r1.modes->freq_hz[j], r2.modes->freq_hz[j], 1e-8, "%s mesh %d mode %d",
                   preset, mesh, j + 1);
    for (int j = 0; j < k - 1; j++) { /* the last may be half of a pair cut by k */
        const double *a = r1.modes->phi + (size_t)j * n;
        double sum = 0;
        for (int i = 0; i < k; i++) {
            const double *b = r2.modes->phi + (size_t)i * n;
            if (fabs(r2.modes->freq_hz[i] / r1.modes->freq_hz[j] - 1) > 1e-6)
                continue;
            double ab = 0;
            for (int r = 0; r < n; r++)
                for (int c = 0; c < n; c++)
                    ab += a[r] * M[(size_t)c * n + r] * b[c];
            sum += ab * ab; /* both M-normalised */
        }
        assert_rel(sum, 1.0, 1e-8, "%s mesh %d mode %d lies in the reference's eigenspace",
                   preset, mesh, j + 1);
    }
    free(M);
    dm_analysis_free(a1);
    dm_analysis_free(a2);
}

static void partial_and_full_solvers_agree(void **state)
{
    (void)state;
    const double P[3] = {-0.1, 0.2, 0.9}, Pz[3] = {0.05, -0.08, -0.42};
    compare_solvers("han2011", 3, P, 15);    /* n > 96: dsyevr */
    compare_solvers("han2011", 1, P, 15);    /* n = 48: dsterf + dstein */
    compare_solvers("zheng2017", 1, Pz, 10);
    compare_solvers("zheng2017", 1, NULL, 10); /* centre: degenerate pairs */
    compare_solvers("chen2018", 1, NULL, 12);
}

/* At the workspace centre the 120-degree symmetry makes pairs of modes
 * degenerate (x/y bending families): equal to round-off. */
static void symmetric_pairs_at_centre(void **state)
{
    (void)state;
    const char *names[] = {"chen2018", "zheng2017", "han2011"};
    for (int r = 0; r < 3; r++) {
        dm_robot rb;
        dm_analysis *an;
        dm_pose_result res;
        run_at(names[r], 4, 4, NULL, 12, DM_EIGEN_PARTIAL, &rb, &an, &res);
        const double *f = res.modes->freq_hz;
        int pairs = 0;
        for (int j = 0; j + 1 < 12; j++)
            if (fabs(f[j + 1] - f[j]) < 1e-6 * f[j]) {
                assert_rel(f[j + 1], f[j], 1e-8, "%s modes %d and %d", names[r], j + 1, j + 2);
                pairs++;
                j++;
            }
        assert_true(pairs >= 2);
        dm_analysis_free(an);
    }
}

static void mesh_convergence(void **state)
{
    (void)state;
    const char *names[] = {"chen2018", "zheng2017", "han2011"};
    for (int r = 0; r < 3; r++) {
        double f[4][6];
        const int mesh[4] = {1, 2, 4, 8};
        for (int m = 0; m < 4; m++) {
            dm_robot rb;
            dm_analysis *an;
            dm_pose_result res;
            run_at(names[r], mesh[m], mesh[m], NULL, 6, DM_EIGEN_PARTIAL, &rb, &an, &res);
            memcpy(f[m], res.modes->freq_hz, sizeof f[m]);
            dm_analysis_free(an);
        }
        /* consistent mass: frequencies fall towards the limit as the mesh refines */
        for (int m = 1; m < 4; m++)
            assert_true(f[m][0] <= f[m - 1][0] * (1 + 1e-12));
        assert_rel(f[2][0], f[3][0], 5e-3, "%s f1 between the two finest meshes", names[r]);
        for (int j = 0; j < 6; j++) /* the default mesh 4,4 converges f1..f6 to 0.1 % */
            assert_rel(f[2][j], f[3][j], 1e-3, "%s f%d at mesh 4,4 vs 8,8", names[r], j + 1);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(check_values_of_the_contract),
        cmocka_unit_test(modes_are_mass_normalised),
        cmocka_unit_test(partial_and_full_solvers_agree),
        cmocka_unit_test(symmetric_pairs_at_centre),
        cmocka_unit_test(mesh_convergence),
    };
    return cmocka_run_group_tests_name("modal", tests, NULL, NULL);
}
