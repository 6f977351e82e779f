/* Static gravity error and compliance at the platform (docs/model.md §5). */
#include "dm_static.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_symeig.h"

struct dm_static {
    int n;
    dm_arrow_chol chol; /* K = L L' */
    double *rhs;        /* n scratch */
};

dm_static *dm_static_alloc(const dm_model *md, dm_error *err)
{
    dm_static *ws = calloc(1, sizeof *ws);
    int rc = ws ? dm_arrow_chol_init(&ws->chol, &md->layout, NULL) : DM_ENOMEM;
    if (!rc) {
        ws->n = md->n;
        ws->rhs = malloc((size_t)md->n * sizeof(double));
        rc = ws->rhs ? DM_OK : DM_ENOMEM;
    }
    if (rc) {
        dm_static_free(ws);
        dm_fail(err, DM_ENOMEM, "out of memory for a %d-DOF static workspace", md->n);
        return NULL;
    }
    return ws;
}

void dm_static_free(dm_static *ws)
{
    if (!ws)
        return;
    dm_arrow_chol_release(&ws->chol);
    free(ws->rhs);
    free(ws);
}

int dm_static_factor(dm_static *ws, const dm_model *md, dm_error *err)
{
    assert(md->n == ws->n);
    return dm_arrow_chol_factor(&ws->chol, &md->K, err);
}

int dm_static_solve(const dm_static *ws, double *F, int nrhs, dm_error *err)
{
    (void)err; /* a factor that exists always solves */
    for (int j = 0; j < nrhs; j++)
        dm_arrow_chol_solve(&ws->chol, F + (size_t)j * ws->n, 1);
    return DM_OK;
}

const dm_arrow_chol *dm_static_chol(const dm_static *ws) { return &ws->chol; }

double dm_static_logdet(const dm_static *ws) { return dm_arrow_chol_logdet(&ws->chol); }

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
    (void)md;
    if (dm_arrow_chol_border_inverse(&ws->chol, C))
        return dm_fail(err, DM_ENUMERIC, "platform compliance: inverse of the Schur complement failed");
    return DM_OK;
}

int dm_compliance_worst(const double C[36], double *max_m_per_n, double dir[3])
{
    double c[9], a[9], w[3];
    for (int j = 0; j < 3; j++)
        for (int r = 0; r < 3; r++)
            c[3 * j + r] = C[6 * j + r];
    if (dm_symeig(3, c, 3, w, a, 3)) /* (dsyev took 9 400 instructions a pose) */
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
