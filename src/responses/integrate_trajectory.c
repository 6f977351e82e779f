/* Integration along a trajectory: frozen configuration per step, state
 * carried by projection, optional all-modes reference (docs/model.md §4). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_integrate.h"
#include "dm_coupling.h"
#include "dm_kinematics.h"
#include "dm_loads.h"
#include "dm_static.h"
#include "dm_vec3.h"

void dm_integ_opts_default(dm_integ_opts *o)
{
    memset(o, 0, sizeof *o);
    o->k = 10;
    o->dt_s = 1e-3;
    o->method = DM_ODE_CVODE;
    o->rtol = 1e-8;
    o->atol = 1e-14;
    o->reference = 1;
    o->quasi_static = 1;
    o->nfreq = 3;
}

typedef struct {
    const dm_robot *rb;
    const dm_trajectory *tr;
    dm_integ_opts o;
    int n, k, ksolve; /* ksolve: modes solved per step (retained or reported) */
    dm_model *md;
    dm_modal *modal, *modal_all;
    dm_static *statics;
    dm_stepper *stepper, *ref_stepper;
    /* an undamped robot's truncation figure: k modes and all modes, both
     * with DM_TRUNCATION_BETA (the figure run; NULL when the robot has
     * damping and the main run serves) */
    dm_stepper *fig_stepper;
    double fig_beta;
    double *x, *xd, *xr, *xrd, *xf, *xfd, *F0, *F1, *xout, *xfout;
    /* the pose the model, modes and factor were last made for: a step at
     * the very same pose (a robot standing still) reuses them */
    dm_pose frozen;
    int have_frozen;
    double coupling_log10; /* of the frozen K */
    const dm_modes *mo, *mo_all;
} run_ws;

static void free_ws(run_ws *w)
{
    dm_model_free(w->md);
    dm_modal_free(w->modal);
    dm_modal_free(w->modal_all);
    dm_static_free(w->statics);
    dm_stepper_free(w->stepper);
    dm_stepper_free(w->ref_stepper);
    dm_stepper_free(w->fig_stepper);
    free(w->x);
    free(w->xd);
    free(w->xr);
    free(w->xrd);
    free(w->xf);
    free(w->xfd);
    free(w->xfout);
    free(w->F0);
    free(w->F1);
    free(w->xout);
}

static int alloc_ws(run_ws *w, dm_error *err)
{
    const dm_integ_opts *o = &w->o;
    w->md = dm_model_alloc(w->rb, o->na ? o->na : w->rb->na, o->nb ? o->nb : w->rb->nb, err);
    if (!w->md)
        return err ? err->code : DM_ENOMEM;
    int n = w->n = w->md->n;
    w->k = (o->k <= 0 || o->k > n) ? n : o->k;
    w->ksolve = w->k > o->nfreq ? w->k : (o->nfreq < n ? o->nfreq : n);
    w->modal = dm_modal_alloc(w->md, w->ksolve, DM_EIGEN_PARTIAL, err);
    if (w->modal) /* the steps' poses: equally spaced in time along the path */
        dm_modal_follow_path(w->modal, 1);
    w->statics = w->modal ? dm_static_alloc(w->md, err) : NULL;
    w->stepper = w->statics ? dm_stepper_alloc(n, w->k, o->method, o->rtol, o->atol, err) : NULL;
    if (!w->stepper)
        return err ? err->code : DM_ENOMEM;
    if (o->reference) {
        w->modal_all = dm_modal_alloc(w->md, n, DM_EIGEN_ALL, err);
        w->ref_stepper = w->modal_all ? dm_stepper_alloc(n, n, DM_ODE_CLOSED_FORM, 0, 0, err) : NULL;
        if (!w->ref_stepper)
            return err ? err->code : DM_ENOMEM;
        if (w->rb->rayleigh_alpha == 0 && w->rb->rayleigh_beta == 0 && w->k < n) {
            w->fig_beta = DM_TRUNCATION_BETA;
            w->fig_stepper = dm_stepper_alloc(n, w->k, o->method, o->rtol, o->atol, err);
            if (!w->fig_stepper)
                return err ? err->code : DM_ENOMEM;
            dm_stepper_set_damping(w->ref_stepper, 0, w->fig_beta);
            dm_stepper_set_damping(w->fig_stepper, 0, w->fig_beta);
        }
    }
    size_t sz = sizeof(double) * n;
    w->x = calloc(1, sz);
    w->xd = calloc(1, sz);
    w->xr = calloc(1, sz);
    w->xrd = calloc(1, sz);
    w->xf = calloc(1, sz);
    w->xfd = calloc(1, sz);
    w->xfout = malloc(sz);
    w->F0 = malloc(sz);
    w->F1 = malloc(sz);
    w->xout = malloc(sz);
    if (!w->x || !w->xd || !w->xr || !w->xrd || !w->xf || !w->xfd || !w->xfout || !w->F0 ||
        !w->F1 || !w->xout)
        return dm_fail(err, DM_ENOMEM, "out of memory for the trajectory run");
    return DM_OK;
}

/* The real configuration commanded to P while accelerating at a: the
 * platform's net force m (g - a) sets which way joint clearances open. */
static int pose_at(const run_ws *w, const double P[3], const double a[3], dm_pose *pose,
                   dm_error *err)
{
    double W[3];
    dm_kin_platform_force(w->rb, a, w->o.force_n, W);
    return dm_kin_pose_loaded(w->rb, P, W, pose, err);
}

/* Load at time t on the model frozen at the current step's pose: gravity +
 * inertia of the nominal motion at t (rates from the kinematics at P(t)). */
static int load_at(const run_ws *w, double t, double *F, dm_error *err)
{
    double P[3], v[3], a[3];
    dm_pose pose;
    dm_rigid_motion mo;
    dm_traj_eval(w->tr, t, P, v, a);
    int rc = pose_at(w, P, a, &pose, err);
    if (!rc)
        rc = dm_kin_rates(w->rb, &pose, v, mo.alpha_dot, err);
    if (!rc)
        rc = dm_kin_accelerations(w->rb, &pose, v, a, mo.alpha_ddot, err);
    if (rc)
        return rc;
    dm_copy3(a, mo.aP);
    memcpy(F, w->md->F_gravity, sizeof(double) * w->n);
    dm_loads_add_inertial(w->md, &mo, F);
    const double no_torque[3] = {0, 0, 0};
    dm_loads_add_platform_wrench(w->md, w->o.force_n, no_torque, F);
    return DM_OK;
}

/* Output displacement: the state x, plus with quasi_static the static part
 * of the dropped modes, K^-1 F - sum_j phi_j phi_j' F / omega_j^2, with the
 * factor of K made with the step's model, into out. */
static int output_state(run_ws *w, const dm_modes *mo, const double *F, const double *x,
                        double *xout, dm_error *err)
{
    int n = w->n;
    memcpy(xout, x, sizeof(double) * n);
    if (!w->o.quasi_static || w->k == n)
        return DM_OK;
    double *s = w->F0 == F ? w->F1 : w->F0; /* scratch that is not F */
    memcpy(s, F, sizeof(double) * n);
    int rc = dm_static_solve(w->statics, s, 1, err); /* factored with the step's model */
    if (rc)
        return rc;
    for (int j = 0; j < w->k; j++) {
        const double *ph = mo->phi + (size_t)j * n;
        double f = 0, w2 = mo->omega_rad_s[j] * mo->omega_rad_s[j];
        for (int i = 0; i < n; i++)
            f += ph[i] * F[i];
        for (int i = 0; i < n; i++)
            s[i] -= ph[i] * f / w2;
    }
    for (int i = 0; i < n; i++)
        xout[i] += s[i];
    return DM_OK;
}

static void fill_sample(const run_ws *w, double t, const double *x, const dm_modes *mo,
                        dm_integ_sample *s)
{
    double v[3], a[3], exr[3];
    const double *u = x + w->md->platform_dof;
    s->t_s = t;
    dm_traj_eval(w->tr, t, s->P_m, v, a);
    memcpy(s->error, u, 6 * sizeof(double));
    dm_pose real;
    if (dm_effects_geometry_errors(&w->rb->effects) && !pose_at(w, s->P_m, a, &real, NULL))
        for (int k = 0; k < 3; k++) /* geometry errors: where the real platform is at t */
            s->error[k] += real.offset[k];
    dm_cross3(u + 3, w->o.tool_m, exr);
    for (int k = 0; k < 3; k++)
        s->tool_error_m[k] = u[k] + exr[k];
    s->nfreq = w->o.nfreq < mo->k ? w->o.nfreq : mo->k;
    if (s->nfreq > DM_INTEG_MAXFREQ)
        s->nfreq = DM_INTEG_MAXFREQ;
    for (int j = 0; j < s->nfreq; j++)
        s->freq_hz[j] = mo->freq_hz[j];
    s->coupling_index_log10 = w->coupling_log10;
}

static double platform_diff(const run_ws *w, const double *a, const double *b)
{
    const double *pa = a + w->md->platform_dof, *pb = b + w->md->platform_dof;
    double d[3] = {pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]};
    return dm_norm3(d);
}

static int initial_state(run_ws *w, dm_error *err)
{
    if (w->o.from_rest)
        return DM_OK;
    const double no_torque[3] = {0, 0, 0};
    memcpy(w->x, w->md->F_gravity, sizeof(double) * w->n);
    dm_loads_add_platform_wrench(w->md, w->o.force_n, no_torque, w->x);
    int rc = dm_static_solve(w->statics, w->x, 1, err); /* factored with the step's model */
    memcpy(w->xr, w->x, sizeof(double) * w->n);
    memcpy(w->xf, w->x, sizeof(double) * w->n);
    return rc;
}

typedef struct {
    double mean, peak, ref_mean, ref_sq, diff_sq; /* time integrals and maxima */
    double coupling_mean, coupling_min, coupling_max;
    double axes[DM_INTEG_MAXAXES][3];
} run_stats;

static int step(run_ws *w, long j, long nsteps, dm_integ_sink sink, void *user, run_stats *rs,
                dm_error *err)
{
    const dm_trajectory *tr = w->tr;
    double t0 = j * w->o.dt_s, t1 = j + 1 == nsteps ? tr->duration_s : (j + 1) * w->o.dt_s;
    double h = t1 - t0, P[3], v[3], a[3];
    dm_pose pose;
    dm_integ_sample s;
    dm_traj_eval(tr, t0, P, v, a);
    memset(&pose, 0, sizeof pose); /* compared bytewise below */
    int rc = pose_at(w, P, a, &pose, err);
    /* the same pose bit for bit gives the same model, modes and factor */
    int fresh = !w->have_frozen || memcmp(&pose, &w->frozen, sizeof pose);
    if (!fresh) /* a pause: the steps after it start a new path */
        dm_modal_follow_path(w->modal, 1);
    if (!rc && fresh) {
        w->have_frozen = 0;
        rc = dm_model_build(w->md, &pose, err);
        if (!rc) rc = dm_static_factor(w->statics, w->md, err);
        if (!rc) w->coupling_log10 = dm_coupling_index_log10(w->statics);
        if (!rc) rc = dm_modal_solve(w->modal, w->md, w->statics, w->ksolve, &w->mo, err);
        if (!rc && w->ref_stepper)
            rc = dm_modal_solve(w->modal_all, w->md, NULL, w->n, &w->mo_all, err);
        w->frozen = pose;
        w->have_frozen = !rc;
    }
    const dm_modes *mo = w->mo;
    if (!rc && j == 0) {
        rc = initial_state(w, err);
        if (!rc) {
            fill_sample(w, 0.0, w->x, mo, &s);
            rc = sink && sink(user, &s) ? DM_EINTERRUPT : DM_OK;
            rs->peak = dm_norm3(w->x + w->md->platform_dof);
        }
    }
    if (!rc) rc = load_at(w, t0, w->F0, err);
    if (!rc) rc = load_at(w, t1, w->F1, err);
    if (!rc && w->ref_stepper)
        rc = dm_stepper_advance(w->ref_stepper, w->md, w->mo_all, w->n, w->F0, w->F1, h, w->xr,
                                w->xrd, err);
    if (!rc) rc = dm_stepper_advance(w->stepper, w->md, mo, w->k, w->F0, w->F1, h, w->x, w->xd, err);
    if (!rc && w->fig_stepper)
        rc = dm_stepper_advance(w->fig_stepper, w->md, mo, w->k, w->F0, w->F1, h, w->xf, w->xfd, err);
    /* outputs last: they use F0 as scratch */
    if (!rc) rc = output_state(w, mo, w->F1, w->x, w->xout, err);
    if (!rc && w->fig_stepper)
        rc = output_state(w, mo, w->F1, w->xf, w->xfout, err);
    if (rc)
        return rc;
    fill_sample(w, t1, w->xout, mo, &s);
    double e = dm_norm3(s.error);
    rs->mean += h * e;
    rs->coupling_mean += h * w->coupling_log10;
    for (int a = 0; a < w->o.naxes && a < DM_INTEG_MAXAXES; a++) {
        double b = w->o.axes_rotation_rad[a], c = cos(b), sn = sin(b);
        rs->axes[a][0] += h * fabs(c * s.error[0] + sn * s.error[1]);
        rs->axes[a][1] += h * fabs(-sn * s.error[0] + c * s.error[1]);
        rs->axes[a][2] += h * fabs(s.error[2]);
    }
    rs->coupling_min = j == 0 ? w->coupling_log10 : fmin(rs->coupling_min, w->coupling_log10);
    rs->coupling_max = j == 0 ? w->coupling_log10 : fmax(rs->coupling_max, w->coupling_log10);
    rs->peak = fmax(rs->peak, e);
    if (w->ref_stepper) {
        double er = dm_norm3(w->xr + w->md->platform_dof);
        double d = platform_diff(w, w->fig_stepper ? w->xfout : w->xout, w->xr);
        rs->ref_mean += h * er;
        rs->ref_sq += h * er * er;
        rs->diff_sq += h * d * d;
    }
    return sink && sink(user, &s) ? DM_EINTERRUPT : DM_OK;
}

double dm_integ_estimate_s(long steps, int n, int k, int reference)
{
    double s = n / 210.0, per_step = 2e-3 * s * s * fmax(1.0, k / 10.0);
    if (reference)
        per_step += 5e-3 * s * s * s;
    return steps * per_step;
}

int dm_integrate_trajectory(const dm_robot *rb, const dm_trajectory *tr, const dm_integ_opts *o,
                            dm_integ_sink sink, void *user, dm_integ_summary *sum, dm_error *err)
{
    if (!(o->dt_s > 0) || !(tr->duration_s > 0))
        return dm_fail(err, DM_EINVAL, "time step and duration must be > 0");
    double steps_d = ceil(tr->duration_s / o->dt_s - 1e-9);
    int n = dm_model_dofs(rb, o->na ? o->na : rb->na, o->nb ? o->nb : rb->nb);
    int k = o->k <= 0 || o->k > n ? n : o->k;
    double est = steps_d > 1e15 ? INFINITY : dm_integ_estimate_s((long)steps_d, n, k, o->reference);
    if (est > DM_INTEG_MAX_SECONDS && !o->force)
        return dm_fail(err, DM_EINVAL,
                       "%s: %.6g s at a step of %g s is %.3g steps, about %.3g hours of work "
                       "for a %d-DOF model (the limit is %g hours; a larger step, a shorter "
                       "path or no all-modes reference would do, or force it)",
                       tr->name, tr->duration_s, o->dt_s, steps_d, est / 3600, n,
                       DM_INTEG_MAX_SECONDS / 3600);
    int rc = dm_traj_check_reachable(tr, rb, o->dt_s, err);
    if (rc)
        return rc;
    run_ws w = {.rb = rb, .tr = tr, .o = *o};
    run_stats rs = {0};
    long nsteps = (long)ceil(tr->duration_s / o->dt_s - 1e-9);
    rc = alloc_ws(&w, err);
    for (long j = 0; !rc && j < nsteps; j++)
        rc = step(&w, j, nsteps, sink, user, &rs, err);
    if (!rc) {
        memset(sum, 0, sizeof *sum);
        sum->n = w.n;
        sum->k = w.k;
        sum->steps = nsteps;
        sum->duration_s = tr->duration_s;
        sum->mean_error_m = rs.mean / tr->duration_s;
        sum->peak_error_m = rs.peak;
        sum->truncation_error = o->reference ? sqrt(rs.diff_sq / rs.ref_sq) : NAN;
        sum->reference_mean_error_m = o->reference ? rs.ref_mean / tr->duration_s : NAN;
        sum->truncation_beta_s = w.fig_beta;
        int undamped = rb->rayleigh_alpha == 0 && rb->rayleigh_beta == 0;
        sum->aliasing_risk = undamped && o->dt_s > 1.25e-4 && w.k > 20;
        sum->coupling_mean_log10 = rs.coupling_mean / tr->duration_s;
        sum->coupling_min_log10 = rs.coupling_min;
        sum->coupling_max_log10 = rs.coupling_max;
        for (int a = 0; a < o->naxes && a < DM_INTEG_MAXAXES; a++)
            for (int k = 0; k < 3; k++)
                sum->mean_axes_m[a][k] = rs.axes[a][k] / tr->duration_s;
    }
    free_ws(&w);
    return rc;
}
