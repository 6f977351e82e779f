/* The per-pose pipeline: kinematics, assembly, one factorization of K,
 * statics, eigen solve. */
#include "dm_analysis.h"

#include <math.h>

#include "dm_coupling.h"
#include <stdlib.h>

dm_analysis *dm_analysis_alloc(const dm_robot *robot, int na, int nb, int kmax,
                               dm_eigen_method method, dm_error *err)
{
    dm_analysis *an = calloc(1, sizeof *an);
    if (!an) {
        dm_fail(err, DM_ENOMEM, "out of memory");
        return NULL;
    }
    an->robot = robot;
    an->model = dm_model_alloc(robot, na, nb, err);
    if (an->model) {
        if (kmax > an->model->n)
            kmax = an->model->n;
        an->kmax = kmax;
        an->modal = dm_modal_alloc(an->model, kmax, method, err);
        if (an->modal)
            an->statics = dm_static_alloc(an->model, err);
    }
    if (!an->statics) {
        dm_analysis_free(an);
        return NULL;
    }
    return an;
}

void dm_analysis_free(dm_analysis *an)
{
    if (!an)
        return;
    dm_static_free(an->statics);
    dm_modal_free(an->modal);
    dm_model_free(an->model);
    free(an);
}

int dm_analysis_run(dm_analysis *an, const double P[3], int k, dm_pose_result *res,
                    dm_error *err)
{
    int rc = dm_kin_pose(an->robot, P, &res->pose, err);
    if (!rc)
        rc = dm_model_build(an->model, &res->pose, err);
    /* one factorization of K: statics, then the eigen solve on it */
    if (!rc)
        rc = dm_static_factor(an->statics, an->model, err);
    if (!rc)
        rc = dm_static_platform_error(an->statics, an->model, an->model->F_gravity,
                                      res->static_error, err);
    if (!rc)
        res->coupling_index_log10 = dm_coupling_index_log10(an->statics);
    if (!rc)
        rc = dm_static_compliance(an->statics, an->model, res->compliance, err);
    if (!rc)
        rc = dm_modal_solve(an->modal, an->model, an->statics, k, &res->modes, err);
    if (rc)
        return rc;
    dm_modal_platform_share(an->modal, an->model);
    if (dm_compliance_worst(res->compliance, &res->compliance_max_m_per_n, res->compliance_dir))
        return dm_fail(err, DM_ENUMERIC, "eigen decomposition of the 3x3 compliance failed");
    res->stiffness_min_n_per_m = 1.0 / res->compliance_max_m_per_n;
    res->near_singular = !(res->pose.cond <= an->robot->singular_cond);
    return DM_OK;
}
