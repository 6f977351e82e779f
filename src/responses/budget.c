/* Zheng's error budget along a path (dm_budget.h): two integrated runs
 * (nominal geometry, everything on) and the rigid closures of each
 * kinematic source alone at the same times. */
#include "dm_budget.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_coupling.h"
#include "dm_kinematics.h"
#include "dm_vec3.h"

const char *dm_budget_source_name(int s)
{
    static const char *const names[] = {"geometry", "clearance", "flexibility"};
    return s >= 0 && s < DM_BUDGET_NSRC ? names[s] : "?";
}

static void no_clearance(dm_effects *e)
{
    e->clearance_m = e->actuator_clearance_axial_m = e->actuator_clearance_radial_m = 0;
}

static void no_geometry_errors(dm_effects *e)
{
    memset(e->err_arm_length_m, 0, sizeof e->err_arm_length_m);
    memset(e->err_rod_length_m, 0, sizeof e->err_rod_length_m);
    memset(e->err_base_radius_m, 0, sizeof e->err_base_radius_m);
    memset(e->err_platform_radius_m, 0, sizeof e->err_platform_radius_m);
    memset(e->err_theta_rad, 0, sizeof e->err_theta_rad);
    memset(e->err_alpha0_rad, 0, sizeof e->err_alpha0_rad);
}

typedef struct {
    const dm_robot *full;
    dm_robot geometry, clearance; /* each kinematic source alone */
    const dm_trajectory *tr;
    const dm_integ_opts *o;
    double *flex;                 /* 3 per sample: the flexibility-alone run */
    long nflex, cap, i;
    double t_prev;
    dm_budget_sink sink;
    void *user;
    dm_budget_summary *sum;
    dm_error *err;
    int failed;                   /* a status of ours (not the user's sink) */
} budget_ws;

static int keep_flex(void *user, const dm_integ_sample *s)
{
    budget_ws *b = user;
    if (b->nflex == b->cap) {
        long cap = b->cap ? 2 * b->cap : 1024;
        double *g = realloc(b->flex, sizeof(double) * 3 * cap);
        if (!g) {
            b->failed = dm_fail(b->err, DM_ENOMEM, "out of memory for the error budget");
            return 1;
        }
        b->flex = g;
        b->cap = cap;
    }
    memcpy(b->flex + 3 * b->nflex++, s->error, 3 * sizeof(double));
    return 0;
}

/* real - commanded platform position of a rigid robot commanded to P(t) */
static int offset_at(const budget_ws *b, const dm_robot *rb, double t, double off[3])
{
    double P[3], v[3], a[3], W[3];
    dm_pose pose;
    dm_traj_eval(b->tr, t, P, v, a);
    dm_kin_platform_force(rb, a, b->o->force_n, W);
    int rc = dm_kin_pose_loaded(rb, P, W, &pose, b->err);
    if (!rc)
        dm_copy3(pose.offset, off);
    return rc;
}

static void account(double *mean, double *peak, double h, const double e[3])
{
    double n = dm_norm3(e);
    *mean += h * n;
    *peak = fmax(*peak, n);
}

/* One sample of the combined run (or of the rigid loop). */
static int combine(void *user, const dm_integ_sample *s)
{
    budget_ws *b = user;
    dm_budget_summary *sum = b->sum;
    dm_budget_sample bs;
    memset(&bs, 0, sizeof bs);
    bs.run = *s;
    if (sum->flexibility) {
        if (b->i >= b->nflex) {
            b->failed = dm_fail(b->err, DM_ENUMERIC, "error budget: the two runs differ in length");
            return 1;
        }
        memcpy(bs.alone_m[DM_BUDGET_FLEXIBILITY], b->flex + 3 * b->i, 3 * sizeof(double));
    }
    if ((b->failed = offset_at(b, &b->geometry, s->t_s, bs.alone_m[DM_BUDGET_GEOMETRY])) ||
        (b->failed = offset_at(b, &b->clearance, s->t_s, bs.alone_m[DM_BUDGET_CLEARANCE])))
        return 1;
    dm_copy3(s->error, bs.combined_m);
    for (int k = 0; k < 3; k++) {
        bs.sum_m[k] = bs.alone_m[0][k] + bs.alone_m[1][k] + bs.alone_m[2][k];
        bs.coupling_m[k] = bs.combined_m[k] - bs.sum_m[k];
    }
    double h = b->i ? s->t_s - b->t_prev : 0.0;
    for (int src = 0; src < DM_BUDGET_NSRC; src++)
        account(&sum->mean_alone_m[src], &sum->peak_alone_m[src], h, bs.alone_m[src]);
    account(&sum->mean_sum_m, &sum->peak_sum_m, h, bs.sum_m);
    account(&sum->mean_combined_m, &sum->peak_combined_m, h, bs.combined_m);
    account(&sum->mean_coupling_m, &sum->peak_coupling_m, h, bs.coupling_m);
    b->t_prev = s->t_s;
    b->i++;
    return b->sink && b->sink(b->user, &bs) ? 1 : 0;
}

/* Flexibility off: the rigid closure of the full robot at the times the
 * integrator would sample. */
static int rigid_run(budget_ws *b)
{
    const dm_trajectory *tr = b->tr;
    double dt = b->o->dt_s;
    long nsteps = (long)ceil(tr->duration_s / dt - 1e-9);
    for (long j = 0; j <= nsteps; j++) {
        dm_integ_sample s;
        double v[3], a[3];
        memset(&s, 0, sizeof s);
        s.t_s = j == 0 ? 0.0 : j == nsteps ? tr->duration_s : j * dt;
        dm_traj_eval(tr, s.t_s, s.P_m, v, a);
        s.coupling_index_log10 = NAN;
        int rc = offset_at(b, b->full, s.t_s, s.error);
        if (rc)
            return rc;
        dm_copy3(s.error, s.tool_error_m);
        if (combine(b, &s))
            return b->failed ? b->failed : DM_EINTERRUPT;
    }
    return DM_OK;
}

int dm_budget_trajectory(const dm_robot *rb, const dm_trajectory *tr, const dm_integ_opts *o,
                         int flexibility, dm_budget_sink sink, void *user,
                         dm_budget_summary *sum, dm_error *err)
{
    if (!(o->dt_s > 0) || !(tr->duration_s > 0))
        return dm_fail(err, DM_EINVAL, "time step and duration must be > 0");
    budget_ws b = {.full = rb, .geometry = *rb, .clearance = *rb, .tr = tr, .o = o,
                   .sink = sink, .user = user, .sum = sum, .err = err};
    no_clearance(&b.geometry.effects);
    no_geometry_errors(&b.clearance.effects);
    memset(sum, 0, sizeof *sum);
    sum->flexibility = flexibility;
    int rc;
    if (!flexibility) {
        rc = dm_traj_check_reachable(tr, rb, o->dt_s, err);
        if (!rc)
            rc = rigid_run(&b);
    } else {
        dm_robot nominal = *rb; /* flexibility alone: no geometry errors, no clearance */
        no_clearance(&nominal.effects);
        no_geometry_errors(&nominal.effects);
        dm_integ_opts of = *o;
        of.reference = 0;
        dm_integ_summary fs;
        rc = dm_integrate_trajectory(&nominal, tr, &of, keep_flex, &b, &fs, err);
        if (!rc)
            rc = dm_integrate_trajectory(rb, tr, o, combine, &b, &sum->run, err);
        if (rc == DM_EINTERRUPT && b.failed)
            rc = b.failed;
        else if (!rc && b.i != b.nflex)
            rc = dm_fail(err, DM_ENUMERIC, "error budget: the two runs differ in length");
    }
    if (rc == DM_EINTERRUPT && b.failed)
        rc = b.failed;
    free(b.flex);
    if (rc)
        return rc;
    double T = tr->duration_s;
    for (int s = 0; s < DM_BUDGET_NSRC; s++)
        sum->mean_alone_m[s] /= T;
    sum->mean_sum_m /= T;
    sum->mean_combined_m /= T;
    sum->mean_coupling_m /= T;
    return DM_OK;
}

/* ---- the coupling index against the nominal robot ------------------------ */

int dm_coupling_change_init(dm_coupling_change *cc, const dm_robot *rb, int na, int nb,
                            dm_error *err)
{
    memset(cc, 0, sizeof *cc);
    cc->min = cc->max = NAN;
    if (!dm_effects_any(&rb->effects)) /* the nominal robot is the robot: the change is 0 */
        return DM_OK;
    cc->nominal = dm_coupling_alloc(rb, na > 0 ? na : rb->na, nb > 0 ? nb : rb->nb, err);
    return cc->nominal ? DM_OK : (err ? err->code : DM_ENOMEM);
}

void dm_coupling_change_free(dm_coupling_change *cc)
{
    dm_coupling_free(cc->nominal);
    cc->nominal = NULL;
}

int dm_coupling_change_next(dm_coupling_change *cc, const dm_integ_sample *s, double *out,
                            dm_error *err)
{
    /* the step that ends at this sample was frozen where the last one was */
    const double *P = cc->samples ? cc->P_prev : s->P_m;
    double nominal, change = NAN, h = cc->samples ? s->t_s - cc->t_prev : 0.0;
    if (!isnan(s->coupling_index_log10) && !cc->nominal) {
        change = 0;
    } else if (!isnan(s->coupling_index_log10)) {
        dm_error e;
        int rc = dm_coupling_nominal_log10(cc->nominal, P, &nominal, &e);
        if (!rc)
            change = s->coupling_index_log10 - nominal;
        else if (rc != DM_EUNREACHABLE && rc != DM_ENUMERIC) { /* no pose of its own: NaN */
            if (err)
                *err = e;
            return rc;
        }
    }
    *out = change;
    if (cc->samples && isfinite(change)) {
        cc->integral_s += h * change;
        cc->weight_s += h;
        cc->min = isnan(cc->min) ? change : fmin(cc->min, change);
        cc->max = isnan(cc->max) ? change : fmax(cc->max, change);
    }
    dm_copy3(s->P_m, cc->P_prev);
    cc->t_prev = s->t_s;
    cc->samples++;
    return DM_OK;
}

void dm_coupling_change_summary(const dm_coupling_change *cc, double *mean, double *min,
                                double *max)
{
    *mean = cc->weight_s > 0 ? cc->integral_s / cc->weight_s : NAN;
    *min = cc->min;
    *max = cc->max;
}
