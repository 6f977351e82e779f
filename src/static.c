/* Static gravity error and compliance at the platform (MODEL.md §5). */
#include "dm_static.h"

#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct dm_static {
    int n;
    double *L;     /* Cholesky factor of K */
    double *rhs;   /* n x 6 scratch */
};

dm_static *dm_static_alloc(int n, dm_error *err)
{
    dm_static *ws = calloc(1, sizeof *ws);
    if (ws) {
        ws->n = n;
        ws->L = malloc((size_t)n * n * sizeof(double));
        ws->rhs = malloc((size_t)n * 6 * sizeof(double));
    }
    if (!ws || !ws->L || !ws->rhs) {
        dm_static_free(ws);
        dm_fail(err, DM_ENOMEM, "out of memory for a %d-DOF static workspace", n);
        return NULL;
    }
    return ws;
}

void dm_static_free(dm_static *ws)
{
    if (!ws)
        return;
    free(ws->L);
    free(ws->rhs);
    free(ws);
}

int dm_static_factor(dm_static *ws, const double *K, dm_error *err)
{
    memcpy(ws->L, K, (size_t)ws->n * ws->n * sizeof *K);
    lapack_int info = LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'L', ws->n, ws->L, ws->n);
    if (info)
        return dm_fail(err, DM_ENUMERIC,
                       "stiffness matrix is singular or not positive definite (dpotrf info %d)",
                       (int)info);
    return DM_OK;
}

int dm_static_solve(const dm_static *ws, double *F, int nrhs, dm_error *err)
{
    lapack_int info = LAPACKE_dpotrs_work(LAPACK_COL_MAJOR, 'L', ws->n, nrhs, ws->L, ws->n, F,
                                          ws->n);
    if (info)
        return dm_fail(err, DM_ENUMERIC, "static solve failed (dpotrs info %d)", (int)info);
    return DM_OK;
}

int dm_static_platform_error(const dm_static *ws, const dm_model *md, const double *F,
                             double u6[6], dm_error *err)
{
    memcpy(ws->rhs, F, (size_t)ws->n * sizeof *F);
    int rc = dm_static_solve(ws, ws->rhs, 1, err);
    if (rc)
        return rc;
    memcpy(u6, ws->rhs + md->platform_dof, 6 * sizeof *u6);
    return DM_OK;
}

int dm_static_compliance(const dm_static *ws, const dm_model *md, double C[36], dm_error *err)
{
    int n = ws->n, p = md->platform_dof;
    memset(ws->rhs, 0, (size_t)n * 6 * sizeof *ws->rhs);
    for (int j = 0; j < 6; j++)
        ws->rhs[(size_t)j * n + p + j] = 1.0;
    int rc = dm_static_solve(ws, ws->rhs, 6, err);
    if (rc)
        return rc;
    for (int j = 0; j < 6; j++)
        for (int r = 0; r < 6; r++)
            C[6 * j + r] = 0.5 * (ws->rhs[(size_t)j * n + p + r] + ws->rhs[(size_t)r * n + p + j]);
    return DM_OK;
}

int dm_compliance_worst(const double C[36], double *max_m_per_n, double dir[3])
{
    double a[9], w[3], work[64];
    for (int j = 0; j < 3; j++)
        for (int r = 0; r < 3; r++)
            a[3 * j + r] = C[6 * j + r];
    lapack_int info = LAPACKE_dsyev_work(LAPACK_COL_MAJOR, 'V', 'U', 3, a, 3, w, work, 64);
    if (info)
        return DM_ENUMERIC;
    *max_m_per_n = w[2];
    int big = 0;
    for (int k = 1; k < 3; k++)
        if (fabs(a[6 + k]) > fabs(a[6 + big]))
            big = k;
    double s = a[6 + big] < 0 ? -1.0 : 1.0;
    for (int k = 0; k < 3; k++)
        dir[k] = s * a[6 + k];
    return DM_OK;
}
