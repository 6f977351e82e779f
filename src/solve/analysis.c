/* The per-pose pipeline: kinematics, assembly, one factorization of K,
 * statics, eigen solve. */
#include "dm_analysis.h"

#include <assert.h>
#include <cblas.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_coupling.h"

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

/* The member engine's parts, released (a failed dm_analysis_use_members
 * leaves the analysis as it found it). */
static void drop_members(dm_analysis *an)
{
    dm_boundary_eig_free(an->eig);
    dm_boundary_free(an->boundary);
    dm_modes *mo = &an->member_modes;
    void *p[] = {mo->omega_rad_s, mo->freq_hz, mo->platform_share, mo->direction,
                 an->reduced,     an->lambda,  an->shapes};
    for (size_t i = 0; i < sizeof p / sizeof *p; i++)
        free(p[i]);
    memset(mo, 0, sizeof *mo);
    an->eig = NULL, an->boundary = NULL, an->reduced = an->lambda = an->shapes = NULL;
    an->members = NULL, an->last_members = 0;
}

void dm_analysis_free(dm_analysis *an)
{
    if (!an)
        return;
    drop_members(an);
    dm_static_free(an->statics);
    dm_modal_free(an->modal);
    dm_model_free(an->model);
    free(an);
}

/* The statics of the factored full model into res. */
static int full_statics(dm_analysis *an, dm_pose_result *res, dm_error *err)
{
    int rc = dm_static_platform_error(an->statics, an->model, an->model->F_gravity,
                                      res->static_error, err);
    if (!rc)
        res->coupling_index_log10 = dm_coupling_index_log10(an->statics);
    if (!rc)
        rc = dm_static_compliance(an->statics, an->model, res->compliance, err);
    return rc;
}

/* The pose on the full model: assembly, one factorization of K for the
 * statics, then the eigen solve on it. */
static int run_full(dm_analysis *an, int k, dm_pose_result *res, dm_error *err)
{
    int rc = dm_model_build(an->model, &res->pose, err);
    if (!rc)
        rc = dm_static_factor(an->statics, an->model, err);
    if (!rc)
        rc = full_statics(an, res, err);
    if (!rc)
        rc = dm_modal_solve(an->modal, an->model, an->statics, k, &res->modes, err);
    if (!rc)
        dm_modal_platform_share(an->modal, an->model);
    res->engine = DM_ENGINE_FULL;
    return rc;
}

/* Each mode's share of its kinetic energy in the platform, and the
 * direction with the most, from the reduced vectors' platform rows: the
 * platform is part of the boundary, in the model's axes, and the
 * boundary's mass holds the platform's. */
static void member_platform_share(dm_analysis *an, int k)
{
    const dm_members *ms = an->members;
    int nr = dm_boundary_reduced_size(an->boundary), p = ms->bplat;
    dm_modes *mo = &an->member_modes;
    for (int j = 0; j < k; j++)
        dm_modal_mode_platform_share(ms->Mb + (size_t)p * ms->nbound + p, ms->nbound,
                                     an->reduced + (size_t)j * nr + p, &mo->platform_share[j],
                                     &mo->direction[j]);
}

/* The pose from the members: the boundary's statics, the reduced modes
 * and the whole model's count at the reduced solve's shift, which must
 * find no more modes below it than the reduced problem has (the reduced
 * values are upper bounds of the model's: more means a mode the bases
 * miss). */
/* The reduced problem's kmax lowest pairs, proven complete by the count of
 * the whole model (Wittrick-Williams on the boundary) at the solver's
 * own count point. */
static int reduced_modes(dm_analysis *an, dm_error *err)
{
    double sigma;
    int reduced_count, whole_count;
    int rc = dm_boundary_eig_solve(an->eig, an->boundary, an->lambda, NULL, &an->member_info, err);
    if (!rc) {
        dm_boundary_eig_count_point(an->eig, &sigma, &reduced_count, &whole_count);
        if (whole_count < 0) /* singular there: the count's own error */
            rc = dm_boundary_count(an->boundary, sigma, &whole_count, err);
    }
    if (!rc && whole_count != reduced_count)
        rc = dm_fail(err, DM_ENUMERIC,
                     "member bases: the model has %d modes below %.6g Hz, the bases %d",
                     whole_count, sqrt(sigma) / (2 * M_PI), reduced_count);
    return rc;
}

static int run_members(dm_analysis *an, int k, dm_pose_result *res, dm_error *err)
{
    dm_boundary_statics bs;
    dm_modes *mo = &an->member_modes;
    int rc = dm_boundary_solve(an->boundary, &res->pose, &bs, err);
    if (rc)
        return rc;
    memcpy(res->static_error, bs.static_error, sizeof bs.static_error);
    memcpy(res->compliance, bs.compliance, sizeof bs.compliance);
    res->coupling_index_log10 = dm_coupling_index_from_logdet(bs.logdet_K);
    double *lambda = an->lambda;
    rc = reduced_modes(an, err);
    if (rc && !an->member_info.cold) { /* a neighbour's start that led astray: once more, cold */
        int spent = an->member_info.applications;
        dm_boundary_eig_forget(an->eig);
        rc = reduced_modes(an, err);
        an->member_info.applications += spent;
    }
    if (rc) {
        dm_boundary_eig_forget(an->eig);
        return rc;
    }
    for (int j = 0; j < an->kmax; j++) {
        mo->omega_rad_s[j] = sqrt(lambda[j]);
        mo->freq_hz[j] = mo->omega_rad_s[j] / (2 * M_PI);
    }
    dm_boundary_reduced_vectors(an->boundary, an->kmax, an->reduced);
    member_platform_share(an, an->kmax);
    mo->k = k;
    mo->phi = an->want_shapes ? an->shapes : NULL;
    if (an->want_shapes)
        dm_boundary_mode_shapes(an->boundary, an->kmax, mo->phi);
    if (an->want_model) {
        rc = dm_model_build(an->model, &res->pose, err);
        if (!rc)
            rc = dm_static_factor(an->statics, an->model, err);
    }
    res->modes = mo;
    res->engine = DM_ENGINE_MEMBERS;
    return rc;
}

/* Everything at res->pose. */
static int run_at(dm_analysis *an, int k, dm_pose_result *res, dm_error *err)
{
    int rc;
    if (an->members) {
        rc = run_members(an, k, res, &an->member_error);
        an->last_members = !rc;
        if (rc) { /* the full model serves, cold: its bits depend on the pose alone */
            dm_modal_forget(an->modal);
            rc = run_full(an, k, res, err);
        }
    } else
        rc = run_full(an, k, res, err);
    if (rc)
        return rc;
    if (dm_compliance_worst(res->compliance, &res->compliance_max_m_per_n, res->compliance_dir))
        return dm_fail(err, DM_ENUMERIC, "eigen decomposition of the 3x3 compliance failed");
    res->stiffness_min_n_per_m = 1.0 / res->compliance_max_m_per_n;
    res->near_singular = !(res->pose.cond <= an->robot->singular_cond);
    return DM_OK;
}

/* Nothing of a previous run stands for this one. */
static int begin_run(dm_analysis *an, int k, dm_error *err)
{
    an->last_members = 0;
    dm_error_clear(&an->member_error);
    if (k < 1 || k > an->kmax)
        return dm_fail(err, DM_EINVAL, "%d modes asked of an analysis made for 1 to %d", k,
                       an->kmax);
    return DM_OK;
}

int dm_analysis_run(dm_analysis *an, const double P[3], int k, dm_pose_result *res,
                    dm_error *err)
{
    int rc = begin_run(an, k, err);
    if (!rc)
        rc = dm_kin_pose(an->robot, P, &res->pose, err);
    return rc ? rc : run_at(an, k, res, err);
}

int dm_analysis_run_pose(dm_analysis *an, const dm_pose *pose, int k, dm_pose_result *res,
                         dm_error *err)
{
    int rc = begin_run(an, k, err);
    res->pose = *pose;
    return rc ? rc : run_at(an, k, res, err);
}

dm_members *dm_analysis_members(const dm_robot *robot, int na, int nb, int kmax, dm_error *err)
{
    if (dm_members_serves(robot, err))
        return NULL;
    dm_model *md = dm_model_alloc(robot, na, nb, err);
    dm_pose home;
    dm_members *ms = NULL;
    if (md && !dm_kin_pose(robot, robot->home_m, &home, err) && !dm_model_build(md, &home, err))
        ms = dm_boundary_members_for_modes(md, kmax < md->n ? kmax : md->n - 1, err);
    dm_model_free(md);
    return ms;
}

int dm_analysis_use_members(dm_analysis *an, const dm_members *members, dm_error *err)
{
    assert(!an->members && members->n == an->model->n);
    int k = an->kmax, rc = DM_OK;
    an->boundary = dm_boundary_alloc(members, err);
    if (!an->boundary)
        return err ? err->code : DM_ENOMEM;
    int nr = dm_boundary_reduced_size(an->boundary);
    if (k >= nr)
        rc = dm_fail(err, DM_EINVAL, "member bases: %d modes asked of a %d-DOF reduced model",
                     k, nr);
    if (!rc && !(an->eig = dm_boundary_eig_alloc(an->boundary, k, err)))
        rc = err ? err->code : DM_ENOMEM;
    dm_modes *mo = &an->member_modes;
    if (!rc) {
        mo->n = an->model->n, mo->k = k;
        mo->omega_rad_s = malloc(sizeof(double) * k);
        mo->freq_hz = malloc(sizeof(double) * k);
        an->shapes = malloc(sizeof(double) * (size_t)mo->n * k);
        mo->platform_share = malloc(sizeof(double) * k);
        mo->direction = malloc(sizeof(int) * k);
        an->reduced = malloc(sizeof(double) * (size_t)nr * k);
        an->lambda = malloc(sizeof(double) * k);
        if (!an->lambda || !mo->omega_rad_s || !mo->freq_hz || !an->shapes ||
            !mo->platform_share || !mo->direction || !an->reduced)
            rc = dm_fail(err, DM_ENOMEM, "out of memory for the member engine");
    }
    if (rc) {
        drop_members(an);
        return rc;
    }
    an->want_shapes = 1;
    an->members = members;
    return DM_OK;
}

/* A member seed: whether the solve left one, then the solver's. */
size_t dm_analysis_seed_size(const dm_analysis *an)
{
    return an->members ? sizeof(double) + dm_boundary_eig_seed_size(an->eig)
                       : dm_modal_seed_size(an->modal);
}

int dm_analysis_seed_save(const dm_analysis *an, void *seed)
{
    if (!an->members)
        return dm_modal_seed_save(an->modal, seed);
    /* none where the full model served the last run: the solver's state is
     * an older pose's */
    double has = an->last_members && dm_boundary_eig_seed_save(an->eig, (char *)seed + sizeof(double));
    memcpy(seed, &has, sizeof has);
    return has != 0;
}

void dm_analysis_seed_load(dm_analysis *an, const void *seed)
{
    if (!an->members) {
        dm_modal_seed_load(an->modal, seed);
        return;
    }
    double has;
    memcpy(&has, seed, sizeof has);
    if (has != 0)
        dm_boundary_eig_seed_load(an->eig, (const char *)seed + sizeof(double));
    else
        dm_boundary_eig_forget(an->eig);
}

void dm_analysis_forget(dm_analysis *an)
{
    dm_modal_forget(an->modal);
    if (an->members)
        dm_boundary_eig_forget(an->eig);
}

void dm_analysis_residual_target(dm_analysis *an, double residual)
{
    if (an->members)
        dm_boundary_eig_residual_target(an->eig, residual);
}

void dm_analysis_follow_path(dm_analysis *an, int on)
{
    dm_modal_follow_path(an->modal, on);
    if (an->members)
        dm_boundary_eig_follow_path(an->eig, on);
}

int dm_analysis_bounds(dm_analysis *an, int k, double *bound, dm_error *err)
{
    if (!an->last_members)
        return dm_fail(err, DM_EINVAL, "certified bounds: the full model served the last pose");
    assert(k >= 1 && k <= an->kmax);
    return dm_boundary_bounds(an->boundary, k, an->lambda, bound, err);
}

int dm_analysis_track_dim(const dm_analysis *an)
{
    return an->members ? dm_boundary_reduced_size(an->boundary) : an->model->n;
}

const double *dm_analysis_track_vectors(const dm_analysis *an, const dm_pose_result *res)
{
    if (!an->members)
        return res->modes->phi;
    return an->last_members ? an->reduced : NULL;
}

int dm_analysis_track(dm_analysis *an, const dm_pose_result *res, const double *ref, int kr,
                      int kc, int *assign, double *mac, double *shapes, double *work)
{
    assert(kr <= kc && kc <= an->kmax && kc <= DM_TRACK_MAX);
    if (!an->members) {
        dm_modal_track(ref, kr, res->modes, kc, an->model, assign, mac, shapes, work);
        return 0;
    }
    if (!an->last_members) {
        for (int f = 0; f < kr; f++)
            assign[f] = -1, mac[f] = 0;
        return -1;
    }
    int nr = dm_boundary_reduced_size(an->boundary);
    double *MR = work, *t = MR + (size_t)nr * kr, *a = t + (size_t)nr * kc, norms2[DM_TRACK_MAX];
    dm_boundary_eig_mult_M(an->eig, ref, kr, MR);
    dm_boundary_eig_products(an->eig, an->reduced, kc, MR, kr, a, t);
    for (int f = 0; f < kr; f++)
        norms2[f] = cblas_ddot(nr, ref + (size_t)f * nr, 1, MR + (size_t)f * nr, 1);
    dm_modal_track_products(a, norms2, kr, res->modes->freq_hz, kc, an->reduced, nr, assign, mac,
                            shapes);
    return 0;
}
