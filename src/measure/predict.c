/* What the model predicts for measured data, the workspace that does it
 * for many robots, and what predictions cost (see dm_predict.h). */
#include "dm_predict.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_analysis.h"
#include "dm_integrate.h"
#include "dm_kinematics.h"
#include "dm_trajectory.h"

/* ---- the prediction workspace ------------------------------------------------ */

/* What the model's workspaces are sized by, beyond the mesh: the DOF
 * layout (arm-root, rod-end DOFs), the factor geometric stiffness keeps,
 * the members' sections, and which entries of M and K the assembly adds
 * to (recorded once, at the first build). Runs whose robots agree on
 * these share one analysis workspace. */
typedef struct {
    int root[3], joint_springs, actuator_spring, geometric_stiffness, elbow_masses;
    dm_member arm, rod;
} layout_key;

static void key_of(const dm_robot *rb, layout_key *k)
{
    const dm_effects *fx = &rb->effects;
    memset(k, 0, sizeof *k); /* padding too: keys are compared with memcmp */
    for (int i = 0; i < 3; i++)
        k->root[i] = dm_effects_base_compliant(fx, i);
    k->joint_springs = fx->joint_stiffness_n_per_m > 0;
    k->actuator_spring = fx->actuator_stiffness_nm_per_rad > 0;
    k->geometric_stiffness = fx->geometric_stiffness != 0;
    k->elbow_masses = fx->elbow_mass_kg > 0;
    k->arm = rb->arm;
    k->rod = rb->rod;
}

typedef struct {
    int n, cap;
    double *t, *e; /* e: 3 per sample */
    void (*tick)(void *user); /* dm_predictor_on_work's, per step */
    void *tick_user;
} track;

struct dm_predictor {
    dm_dataset data;   /* the caller's samples (borrowed); n: those predicted */
    int nall;          /* samples in the dataset */
    int na, nb, kmax;
    double step_s;     /* a tracker run's longest integration step */
    /* the robot of the current run: the analysis points to this copy, so
     * a run may pass any robot and the workspace still reads the right one */
    dm_robot robot;
    dm_analysis *an;   /* modal/static data: sized for `key` (NULL: not yet) */
    layout_key key;
    /* tracker data: the commanded times and positions of all samples, the
     * path through those predicted (tr_npose of them; 0: none yet) and the
     * integrated error */
    double *t, *xyz;
    dm_trajectory tr;
    int tr_npose;
    track tk;
    /* the last tracker run's modal history (NULL: none kept), for
     * hist_robot: that run's robot with its damping zeroed */
    dm_integ_history *hist;
    dm_robot hist_robot;
    void (*tick)(void *user); /* dm_predictor_on_work */
    void *tick_user;
};

/* Most bytes a kept modal history may hold (dm_integ_history_bytes: about
 * 2 KB per step at 10 modes, so 35 s of record at 1 ms steps). */
#define HISTORY_MAX_BYTES ((size_t)64 << 20)

static int max_mode(const dm_dataset *d)
{
    int m = 1;
    for (int i = 0; i < d->n; i++)
        if (d->s[i].mode > m)
            m = d->s[i].mode;
    return m;
}

dm_predictor *dm_predictor_new(const dm_robot *rb, const dm_dataset *d, int na, int nb,
                               dm_error *err)
{
    if (d->kind == DM_DATA_MODAL && d->pair) { /* its ranks are the measured ones */
        dm_fail(err, DM_EINVAL, "%s: a survey with mode shapes or directions is paired with "
                "the model's modes first (dm_pairing_apply)", d->source);
        return NULL;
    }
    dm_predictor *p = calloc(1, sizeof *p);
    if (!p) {
        dm_fail(err, DM_ENOMEM, "out of memory");
        return NULL;
    }
    p->data = *d;
    p->nall = d->n;
    p->na = na > 0 ? na : rb->na;
    p->nb = nb > 0 ? nb : rb->nb;
    p->kmax = d->kind == DM_DATA_MODAL ? max_mode(d) : 1;
    p->step_s = DM_PREDICT_STEP_S;
    if (d->kind == DM_DATA_TRACKER) {
        int m = d->npose;
        p->t = malloc(sizeof(double) * (m ? m : 1));
        p->xyz = malloc(3 * sizeof(double) * (m ? m : 1));
        if (!p->t || !p->xyz) {
            dm_predictor_free(p);
            dm_fail(err, DM_ENOMEM, "out of memory");
            return NULL;
        }
        for (int i = 0; i < m; i++) {
            p->t[i] = d->s[3 * i].t;
            memcpy(p->xyz + 3 * i, d->s[3 * i].P, 3 * sizeof(double));
        }
    }
    return p;
}

void dm_predictor_free(dm_predictor *p)
{
    if (!p)
        return;
    dm_analysis_free(p->an);
    dm_integ_history_free(p->hist);
    if (p->tr_npose)
        dm_traj_free(&p->tr);
    free(p->t);
    free(p->xyz);
    free(p->tk.t);
    free(p->tk.e);
    free(p);
}

void dm_predictor_on_work(dm_predictor *p, void (*tick)(void *user), void *user)
{
    p->tick = tick;
    p->tick_user = user;
    p->tk.tick = tick;
    p->tk.tick_user = user;
}

void dm_predictor_window(dm_predictor *p, int n)
{
    assert(n >= 0 && n <= p->nall);
    p->data.n = n;
    p->data.npose = n > 0 ? p->data.s[n - 1].pose_id + 1 : 0;
}

/* The analysis workspace for the current robot: kept while the layout is
 * the same, allocated afresh when an effect changes it. */
static int pose_workspace(dm_predictor *p, dm_error *err)
{
    layout_key key;
    key_of(&p->robot, &key);
    if (p->an && !memcmp(&key, &p->key, sizeof key)) {
        /* cold, as a fresh workspace would start: a run's results must not
         * depend on the runs before it */
        dm_modal_forget(p->an->modal);
        return DM_OK;
    }
    dm_analysis_free(p->an);
    dm_error aerr; /* err may be NULL */
    p->an = dm_analysis_alloc(&p->robot, p->na, p->nb, p->kmax, DM_EIGEN_PARTIAL, &aerr);
    if (!p->an)
        return dm_fail(err, aerr.code, "%s", aerr.msg);
    p->key = key;
    return DM_OK;
}

static int predict_poses(dm_predictor *p, double *pred, dm_error *err)
{
    const dm_robot *rb = &p->robot;
    const dm_dataset *d = &p->data;
    assert(d->kind != DM_DATA_TRACKER && d->n <= p->nall && p->kmax >= 1);
    int kmax = p->kmax, n = dm_model_dofs(rb, p->na, p->nb);
    if (kmax > n)
        return dm_fail(err, DM_EINVAL, "%s: mode %d is beyond the model's %d modes", d->source,
                       kmax, n);
    int rc = pose_workspace(p, err);
    if (rc)
        return rc;
    dm_pose_result res;
    dm_pose loaded;
    int last = -1;
    int clearance = d->kind == DM_DATA_STATIC && dm_effects_clearance(&rb->effects);
    for (int i = 0; i < d->n && !rc; i++) {
        const dm_sample *s = &d->s[i];
        if (s->pose_id != last) {
            dm_error perr;
            rc = dm_analysis_run(p->an, s->P, kmax, &res, &perr);
            if (!rc && clearance) { /* the added force may open clearances the other way */
                double W[3];
                dm_kin_platform_force(rb, NULL, s->force, W);
                rc = dm_kin_pose_loaded(rb, s->P, W, &loaded, &perr);
            }
            if (rc)
                rc = dm_fail(err, rc, "%s:%d: %s", d->source, s->line, perr.msg);
            else if (p->tick)
                p->tick(p->tick_user);
            last = s->pose_id;
        }
        if (rc)
            break;
        if (d->kind == DM_DATA_MODAL) {
            pred[i] = res.modes->freq_hz[s->mode - 1];
        } else {
            double v = 0;
            for (int j = 0; j < 3; j++)
                v += res.compliance[6 * j + s->comp] * s->force[j];
            if (clearance)
                v += loaded.offset[s->comp] - res.pose.offset[s->comp];
            pred[i] = v;
        }
    }
    return rc;
}

static int keep(void *user, const dm_integ_sample *s)
{
    track *tk = user;
    if (tk->n == tk->cap) {
        int cap = tk->cap ? 2 * tk->cap : 1024;
        double *t = realloc(tk->t, sizeof(double) * cap), *e;
        if (t)
            tk->t = t;
        e = t ? realloc(tk->e, 3 * sizeof(double) * cap) : NULL;
        if (!e)
            return 1;
        tk->e = e;
        tk->cap = cap;
    }
    tk->t[tk->n] = s->t_s;
    memcpy(tk->e + 3 * tk->n, s->error, 3 * sizeof(double));
    if (tk->tick && tk->n > 0) /* the first sample is the start, not a step */
        tk->tick(tk->tick_user);
    tk->n++;
    return 0;
}

static void forget_history(dm_predictor *p)
{
    dm_integ_history_free(p->hist);
    p->hist = NULL;
}

/* The modal history of the current robot along the current path: kept
 * from the last run when the robots differ at most in damping (a fit of
 * the damping then replays it), made afresh otherwise; none when it would
 * be too large (the run is then streamed, with the same numbers). The
 * robots are compared byte for byte: equal bytes are equal robots (a
 * difference in padding alone only makes the history again). */
static int history_for(dm_predictor *p, const dm_integ_opts *o, dm_error *err)
{
    dm_robot undamped = p->robot;
    undamped.rayleigh_alpha = undamped.rayleigh_beta = 0;
    if (p->hist && !memcmp(&undamped, &p->hist_robot, sizeof undamped))
        return DM_OK;
    forget_history(p);
    if (dm_integ_history_bytes(&p->tr, o, o->k) > HISTORY_MAX_BYTES)
        return DM_OK;
    int rc = dm_integ_history_make(&p->robot, &p->tr, o, &p->hist, err);
    if (!rc)
        p->hist_robot = undamped;
    return rc;
}

void dm_predictor_step(dm_predictor *p, double step_s)
{
    assert(step_s > 0);
    forget_history(p); /* made with the old step */
    p->step_s = step_s;
}

/* The commanded path through the window's samples, made when the window
 * changed. */
static int window_path(dm_predictor *p, dm_error *err)
{
    int m = p->data.npose;
    if (p->tr_npose == m)
        return DM_OK;
    forget_history(p);
    if (p->tr_npose)
        dm_traj_free(&p->tr);
    p->tr_npose = 0;
    int rc = dm_traj_from_samples(p->t, p->xyz, m, p->data.source, &p->tr, err);
    if (!rc)
        p->tr_npose = m;
    return rc;
}

/* Tracker: the elastic error (static + dynamic) along the commanded path,
 * 10 modes with the quasi-static correction, linear between steps. The
 * path is the spline through the samples predicted, made once per window;
 * the integrator sizes its own workspace for each run. */
static int predict_tracker(dm_predictor *p, double *pred, dm_error *err)
{
    const dm_dataset *d = &p->data;
    int m = d->npose, rc = DM_OK;
    assert(d->n == 3 * m && d->n <= p->nall); /* three samples a time */
    const double *t = p->t;
    if ((rc = window_path(p, err)))
        return rc;
    track *tk = &p->tk;
    tk->n = 0;
    dm_integ_opts o;
    dm_integ_summary sum;
    dm_integ_opts_default(&o);
    o.method = DM_ODE_CLOSED_FORM;
    o.quasi_static = 1;
    o.reference = 0;
    o.na = p->na;
    o.nb = p->nb;
    o.dt_s = fmin(p->step_s, t[m - 1] / (m - 1));
    o.force_long = 1; /* the work of the whole command is judged before it (dm_work_check) */
    rc = history_for(p, &o, err);
    if (!rc)
        rc = p->hist ? dm_integ_history_replay(p->hist, p->robot.rayleigh_alpha,
                                               p->robot.rayleigh_beta, keep, tk, &sum, err)
                     : dm_integrate_trajectory(&p->robot, &p->tr, &o, keep, tk, &sum, err);
    assert(rc || tk->n >= 2); /* the start and every step's end */
    for (int i = 0, j = 0; i < m && !rc; i++) {
        while (j + 2 < tk->n && tk->t[j + 1] < t[i])
            j++;
        double w = tk->n > 1 ? (t[i] - tk->t[j]) / (tk->t[j + 1] - tk->t[j]) : 0;
        w = fmin(1, fmax(0, w));
        for (int k = 0; k < 3; k++)
            pred[3 * i + k] = (1 - w) * tk->e[3 * j + k] + w * tk->e[3 * (j + 1) + k];
    }
    return rc;
}

int dm_predictor_run(dm_predictor *p, const dm_robot *robot, double *pred, dm_error *err)
{
    p->robot = *robot;
    return p->data.kind == DM_DATA_TRACKER ? predict_tracker(p, pred, err)
                                           : predict_poses(p, pred, err);
}

int dm_predictor_offsets(dm_predictor *p, const dm_robot *robot, double *pred, dm_error *err)
{
    const dm_dataset *d = &p->data;
    assert(d->kind == DM_DATA_TRACKER && d->n == 3 * d->npose && d->n <= p->nall);
    int rc = window_path(p, err);
    if (rc)
        return rc;
    dm_integ_opts o;
    dm_integ_opts_default(&o); /* the external force predict_tracker's runs see */
    for (int i = 0; i < d->npose; i++) { /* as the integrator's samples add it */
        double P[3], v[3], a[3];
        dm_traj_eval(&p->tr, p->t[i], P, v, a);
        dm_kin_real_offset(robot, P, a, o.force_n, pred + 3 * i);
    }
    return DM_OK;
}

int dm_predict(const dm_robot *rb, const dm_dataset *d, int na, int nb, double *pred, dm_error *err)
{
    dm_error local; /* err may be NULL */
    dm_predictor *p = dm_predictor_new(rb, d, na, nb, err ? err : &local);
    if (!p)
        return (err ? err : &local)->code;
    int rc = dm_predictor_run(p, rb, pred, err);
    dm_predictor_free(p);
    return rc;
}

/* ---- what predictions cost -------------------------------------------------- */

double dm_predict_cost_s(const dm_robot *rb, dm_data_kind kind, double count, int na, int nb)
{
    double s = dm_model_dofs(rb, na > 0 ? na : rb->na, nb > 0 ? nb : rb->nb) / 210.0;
    double per = (kind == DM_DATA_STATIC ? 5e-3 : 2.5e-3) * (0.15 + 0.85 * s * s);
    return count * per;
}

double dm_predict_estimate_s(const dm_robot *rb, const dm_dataset *d, int na, int nb,
                             double *bytes)
{
    double count = d->npose, per_count = 0;
    if (d->kind == DM_DATA_TRACKER && d->n > 0) { /* dm_predict's step: at most 1 ms */
        double T = d->s[d->n - 1].t - d->s[0].t;
        count = fmax(T / DM_PREDICT_STEP_S, d->npose);
        per_count = 4 * sizeof(double); /* the integrated error kept per step */
    }
    if (bytes)
        *bytes = count * per_count + (double)d->n * 2 * sizeof(double);
    return dm_predict_cost_s(rb, d->kind, count, na, nb);
}
