/* Zheng's coupling index from the Cholesky factor of K (dm_coupling.h). */
#include "dm_coupling.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_model.h"
#include "dm_kinematics.h"

struct dm_coupling {
    dm_robot nominal; /* the model points here: the workspace must not move it */
    dm_model *model;
    dm_static *statics;
};

double dm_coupling_index_log10(const dm_static *factored)
{
    return dm_coupling_index_from_logdet(dm_static_logdet(factored));
}

double dm_coupling_index_from_logdet(double logdet_K) { return logdet_K / M_LN10; }

dm_coupling *dm_coupling_alloc(const dm_robot *robot, int na, int nb, dm_error *err)
{
    dm_coupling *ws = calloc(1, sizeof *ws);
    if (!ws) {
        dm_fail(err, DM_ENOMEM, "out of memory");
        return NULL;
    }
    ws->nominal = *robot;
    memset(&ws->nominal.effects, 0, sizeof ws->nominal.effects);
    ws->model = dm_model_alloc(&ws->nominal, na, nb, err);
    ws->statics = ws->model ? dm_static_alloc(ws->model, err) : NULL;
    if (!ws->statics) {
        dm_coupling_free(ws);
        return NULL;
    }
    return ws;
}

void dm_coupling_free(dm_coupling *ws)
{
    if (!ws)
        return;
    dm_static_free(ws->statics);
    dm_model_free(ws->model);
    free(ws);
}

int dm_coupling_nominal_log10(dm_coupling *ws, const double P[3], double *log10_index,
                              dm_error *err)
{
    dm_pose pose;
    int rc = dm_kin_inverse(&ws->nominal, P, &pose, err);
    if (!rc)
        rc = dm_model_build(ws->model, &pose, err);
    if (!rc)
        rc = dm_static_factor(ws->statics, ws->model, err);
    if (!rc)
        *log10_index = dm_coupling_index_log10(ws->statics);
    return rc;
}
