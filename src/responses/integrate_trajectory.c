/* Integration along a trajectory: frozen configuration per step, state
 * carried by projection, optional all-modes reference (docs/model.md §4). */
#include <assert.h>
#include <cblas.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dm_integrate.h"
#include "dm_analysis.h"
#include "dm_boundary.h"
#include "dm_coupling.h"
#include "dm_effects.h"
#include "dm_kinematics.h"
#include "dm_loads.h"
#include "dm_static.h"
#include "dm_threads.h"
#include "dm_vec3.h"
#include "dm_work.h"

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
    dm_modal *modal;
    /* the member engine (NULL: the full model's dm_modal serves every
     * step): the bases, built for the run, and an analysis on them */
    dm_members *members;
    dm_analysis *an;
    long member_steps; /* the steps whose modes it gave */
    int members_off;   /* it failed a pose: the full model serves the rest */
    int threads;         /* of the all-modes reference's solves */
    struct ref_ahead *ahead; /* the reference's modes, solved ahead */
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
    const dm_modes *mo;
    dm_spectrum *all;     /* the reference's modes at the step's pose */
    /* closed-form runs in modal coordinates (see "histories"): the last
     * step's modes, and Phi_prev and M Phi_prev interleaved (dm_arrow.h;
     * a member step: M Phi in Yi, n x k) */
    double *phi_prev, *Xi, *Yi;
    double *Gred; /* a member step's loads in the reduced coordinates: nred x 3 */
    /* what a step takes from its pose (see "frames"): three, so that one
     * thread can solve the next step's modes while another runs this step
     * and builds the model of the step after */
    struct frame {
        dm_pose pose;
        dm_model *md;
        dm_static *statics;
        double coupling_log10;
        dm_modes mo;   /* copies of the modes: omega, freq, phi */
        double *buf;
        dm_modal_count count; /* the Sturm count made ahead for its solve */
        int counted;
        int rc;
        dm_error err;
    } fr[3];
    int pipelined; /* a thread of its own makes the frames */
    /* each solve's own Sturm shift, by step (NAN: no solve of its own),
     * and the workspace of the counts made ahead with the frames */
    double shift[4];
    dm_arrow_ldl ldl;
} run_ws;

struct ref_ahead;
static struct ref_ahead *ahead_alloc(const run_ws *w, dm_error *err);
static void ahead_free(struct ref_ahead *ra);

static void free_ws(run_ws *w)
{
    dm_model_free(w->md);
    dm_modal_free(w->modal);
    dm_analysis_free(w->an);
    dm_members_free(w->members);
    ahead_free(w->ahead);
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
    free(w->F0); /* and F1 */
    free(w->xout);
    free(w->phi_prev);
    free(w->Xi);
    free(w->Yi);
    free(w->Gred);
    for (int i = 0; i < 3; i++) {
        if (i > 0) { /* frame 0's are w->md and w->statics */
            dm_model_free(w->fr[i].md);
            dm_static_free(w->fr[i].statics);
        }
        free(w->fr[i].buf);
    }
    dm_arrow_ldl_release(&w->ldl);
}

/* Runs of this many steps or more take their modes from member bases.
 * Building them costs 1.0-1.3 ms at mesh 2,2, 2.7-3.0 ms at 4,4 and
 * 6.2-7.6 ms at 8,8 (the model's own solver finds the basis rule's k-th
 * eigenvalue), which a closed-form run of 25 steps repays on every
 * preset and mesh measured (a 1 s circle, AVX2: members 0-45 % faster;
 * 10-15 steps, 0.1 s apart, were not, the warm starts too far apart);
 * docs/model-choices.md "Member bases along a trajectory". */
#define MEMBER_MIN_STEPS 25

/* The member engine for a run it serves and repays: not with joint
 * clearance (each step's load opens it and changes the rods' effective
 * lengths, which the bases fix) nor geometric stiffness
 * (dm_members_serves), nor for every mode, nor when asked not to. Where
 * the bases cannot be made, the full model serves. */
static void use_members(run_ws *w, long nsteps)
{
    const dm_robot *rb = w->rb;
    int na = w->md->na, nb = w->md->nb;
    if (w->o.full_model || nsteps < MEMBER_MIN_STEPS || w->k == w->n ||
        dm_effects_clearance(&rb->effects))
        return;
    w->members = dm_analysis_members(rb, na, nb, w->ksolve, NULL);
    if (w->members)
        w->an = dm_analysis_alloc(rb, na, nb, w->ksolve, DM_EIGEN_PARTIAL, NULL);
    if (!w->an || dm_analysis_use_members(w->an, w->members, NULL)) {
        dm_analysis_free(w->an);
        dm_members_free(w->members);
        w->an = NULL, w->members = NULL;
    } else { /* the steps' poses: equally spaced in time along the path */
        dm_analysis_follow_path(w->an, 1);
        /* the full model's residual: predictions as smooth in the robot's
         * parameters as its own, which a fit's forward differences need
         * (test_predict tracker_predictions_are_smooth) */
        dm_analysis_residual_target(w->an, DM_MODAL_CONVERGED);
    }
}

/* The run's workspaces for nsteps steps (the member engine where it
 * serves them: use_members). */
static int alloc_ws(run_ws *w, long nsteps, dm_error *err)
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
        w->ahead = ahead_alloc(w, err);
        w->ref_stepper = w->ahead ? dm_stepper_alloc(n, n, DM_ODE_CLOSED_FORM, 0, 0, err) : NULL;
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
    w->F0 = malloc(2 * sz); /* F1 = F0 + n: loads_at fills both in one pass */
    w->F1 = w->F0 ? w->F0 + n : NULL;
    w->xout = malloc(sz);
    if (!w->x || !w->xd || !w->xr || !w->xrd || !w->xf || !w->xfd || !w->xfout || !w->F0 ||
        !w->F1 || !w->xout)
        return dm_fail(err, DM_ENOMEM, "out of memory for the trajectory run");
    use_members(w, nsteps);
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

/* The nominal motion at time t, on the model frozen at the current
 * step's pose (rates from the kinematics at P(t)). */
static int motion_at(const run_ws *w, double t, dm_rigid_motion *mo, dm_error *err)
{
    double P[3], v[3], a[3];
    dm_pose pose;
    dm_traj_eval(w->tr, t, P, v, a);
    int rc = pose_at(w, P, a, &pose, err);
    if (!rc)
        rc = dm_kin_rates(w->rb, &pose, v, mo->alpha_dot, err);
    if (!rc)
        rc = dm_kin_accelerations(w->rb, &pose, v, a, mo->alpha_ddot, err);
    dm_copy3(a, mo->aP);
    return rc;
}

/* The nominal motion at the step's ends t0 and t1 (motion_at). */
static int step_motions(const run_ws *w, double t0, double t1, dm_rigid_motion mo[2],
                        dm_error *err)
{
    int rc = motion_at(w, t0, &mo[0], err);
    return rc ? rc : motion_at(w, t1, &mo[1], err);
}

/* Loads at the step's ends t0 and t1 into F0 and F1 (= F0 + n): gravity
 * + inertia of the nominal motion, both in one pass over the elements. */
static int loads_at(const run_ws *w, double t0, double t1, dm_error *err)
{
    dm_rigid_motion mo[2];
    int rc = step_motions(w, t0, t1, mo, err);
    if (rc)
        return rc;
    const double no_torque[3] = {0, 0, 0};
    for (int l = 0; l < 2; l++)
        memcpy(w->F0 + (size_t)l * w->n, w->md->F_gravity, sizeof(double) * w->n);
    dm_loads_add_inertial_many(w->md, mo, 2, w->F0);
    dm_loads_add_platform_wrench(w->md, w->o.force_n, no_torque, w->F0);
    dm_loads_add_platform_wrench(w->md, w->o.force_n, no_torque, w->F1);
    return DM_OK;
}

/* The static part of the dropped modes under F,
 * K^-1 F - sum_j phi_j phi_j' F / omega_j^2, with the factor of K made
 * with the step's model, into s (which must not be F). */
static int static_remainder(run_ws *w, const dm_modes *mo, const double *F, double *s,
                            dm_error *err)
{
    int n = w->n;
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
    return DM_OK;
}

/* Output displacement: the state x, plus with quasi_static the static part
 * of the dropped modes, into xout. */
static int output_state(run_ws *w, const dm_modes *mo, const double *F, const double *x,
                        double *xout, dm_error *err)
{
    int n = w->n;
    memcpy(xout, x, sizeof(double) * n);
    if (!w->o.quasi_static || w->k == n)
        return DM_OK;
    double *s = w->F0 == F ? w->F1 : w->F0; /* scratch that is not F */
    int rc = static_remainder(w, mo, F, s, err);
    if (rc)
        return rc;
    for (int i = 0; i < n; i++)
        xout[i] += s[i];
    return DM_OK;
}

/* A sample at t but its errors; offset: where geometry errors put the real
 * platform at t (NULL: not wanted), *has_offset whether it was found. */
static void sample_base(const run_ws *w, double t, const dm_modes *mo, dm_integ_sample *s,
                        double offset[3], int *has_offset)
{
    double v[3], a[3];
    memset(s, 0, sizeof *s);
    s->t_s = t;
    dm_traj_eval(w->tr, t, s->P_m, v, a);
    *has_offset = dm_kin_real_offset(w->rb, s->P_m, a, w->o.force_n, offset);
    s->nfreq = w->o.nfreq < mo->k ? w->o.nfreq : mo->k;
    if (s->nfreq > DM_INTEG_MAXFREQ)
        s->nfreq = DM_INTEG_MAXFREQ;
    for (int j = 0; j < s->nfreq; j++)
        s->freq_hz[j] = mo->freq_hz[j];
    s->coupling_index_log10 = w->coupling_log10;
}

/* The sample's errors from the platform displacement u (6). */
static void sample_errors(dm_integ_sample *s, const double u[6], const double offset[3],
                          int has_offset, const double tool[3])
{
    double exr[3];
    memcpy(s->error, u, 6 * sizeof(double));
    for (int k = 0; has_offset && k < 3; k++) /* geometry errors: where the real platform is */
        s->error[k] += offset[k];
    dm_cross3(u + 3, tool, exr);
    for (int k = 0; k < 3; k++)
        s->tool_error_m[k] = u[k] + exr[k];
}

static void fill_sample(const run_ws *w, double t, const double *x, const dm_modes *mo,
                        dm_integ_sample *s)
{
    double offset[3];
    int has_offset;
    sample_base(w, t, mo, s, offset, &has_offset);
    sample_errors(s, x + w->md->platform_dof, offset, has_offset, w->o.tool_m);
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

/* The pose commanded at t0, its padding zeroed (poses are compared
 * bytewise: the same pose bit for bit gives the same model and modes). */
static int step_pose(const run_ws *w, double t0, dm_pose *pose, dm_error *err)
{
    double P[3], v[3], a[3];
    dm_traj_eval(w->tr, t0, P, v, a);
    memset(pose, 0, sizeof *pose);
    return pose_at(w, P, a, pose, err);
}

/* Whether the pose differs from the last one frozen; where it does not (a
 * pause), the steps after it start a new path. */
static int fresh_pose(run_ws *w, const dm_pose *pose)
{
    int fresh = !w->have_frozen || memcmp(pose, &w->frozen, sizeof *pose);
    if (!fresh)
        dm_modal_follow_path(w->modal, 1);
    if (!fresh && w->an)
        dm_analysis_follow_path(w->an, 1);
    return fresh;
}

/* The model at a pose, the factor of its K and Zheng's coupling index. */
static int build_at(const dm_pose *pose, dm_model *md, dm_static *st, double *coupling_log10,
                    dm_error *err)
{
    int rc = dm_model_build(md, pose, err);
    if (!rc) rc = dm_static_factor(st, md, err);
    if (!rc) *coupling_log10 = dm_coupling_index_log10(st);
    return rc;
}

/* Whether the full model's solver serves the run's next solve. */
static int full_model_solves(const run_ws *w) { return !w->an || w->members_off; }

/* The modes at a pose whose model and factor are built: from the member
 * bases while they serve the run, else from the full model, warm from the
 * steps before. The first pose the bases cannot serve (the analysis
 * solves it on the full model, cold) hands the rest of the run to the
 * full model's solver: bases that fail once are likely to again, and
 * each such solve would start cold. */
static int solve_modes(run_ws *w, const dm_pose *pose, const dm_model *md, const dm_static *st,
                       const dm_modes **mo, dm_error *err)
{
    if (full_model_solves(w))
        return dm_modal_solve(w->modal, md, st, w->ksolve, mo, err);
    dm_pose_result res;
    int rc = dm_analysis_run_pose(w->an, pose, w->ksolve, &res, err);
    if (rc)
        return rc;
    *mo = res.modes;
    if (res.engine == DM_ENGINE_MEMBERS)
        w->member_steps++;
    else
        w->members_off = 1;
    return DM_OK;
}

/* The model, factor and modes at the pose commanded at t0 (a step at the
 * very same pose as the last one keeps them). */
static int freeze(run_ws *w, double t0, dm_error *err)
{
    dm_pose pose;
    int rc = step_pose(w, t0, &pose, err);
    if (fresh_pose(w, &pose) && !rc) {
        rc = build_at(&pose, w->md, w->statics, &w->coupling_log10, err);
        if (!rc) rc = solve_modes(w, &pose, w->md, w->statics, &w->mo, err);
        w->frozen = pose;
        w->have_frozen = !rc;
    }
    return rc;
}

/* A step's sample into the run's integrals and maxima. */
static void account(const dm_integ_opts *o, run_stats *rs, long j, double h, double coupling,
                    const dm_integ_sample *s)
{
    double e = dm_norm3(s->error);
    rs->mean += h * e;
    rs->coupling_mean += h * coupling;
    for (int a = 0; a < o->naxes && a < DM_INTEG_MAXAXES; a++) {
        double b = o->axes_rotation_rad[a], c = cos(b), sn = sin(b);
        rs->axes[a][0] += h * fabs(c * s->error[0] + sn * s->error[1]);
        rs->axes[a][1] += h * fabs(-sn * s->error[0] + c * s->error[1]);
        rs->axes[a][2] += h * fabs(s->error[2]);
    }
    rs->coupling_min = j == 0 ? coupling : fmin(rs->coupling_min, coupling);
    rs->coupling_max = j == 0 ? coupling : fmax(rs->coupling_max, coupling);
    rs->peak = fmax(rs->peak, e);
}

static void step_times(const run_ws *w, long j, long nsteps, double *t0, double *t1)
{
    *t0 = j * w->o.dt_s;
    *t1 = j + 1 == nsteps ? w->tr->duration_s : (j + 1) * w->o.dt_s;
}

/* ---- the all-modes reference, solved ahead on the run's threads ----------
 *
 * The reference's dense eigen solve (every mode, O(n^3), kept factored:
 * dm_spectrum; 1.5-1.9 ms of a 2.1-2.5 ms step at 210 DOF) depends on the step's
 * pose alone, not on the state carried from step to step. So
 * while one thread runs a batch of steps, the others solve the next
 * batch's poses into a second buffer, each with a model and a dense
 * workspace of its own. A solve is the same call on the same matrices
 * whichever thread makes it, so the results do not depend on the thread
 * count (tested bitwise). */

#define AHEAD_PER_THREAD 4         /* steps per batch and thread: balances the batch's
                                      main steps (one thread) against its solves */
#define AHEAD_BYTES (64.0 * 1024 * 1024) /* both buffers at most (4 steps at 1 000 DOF) */

typedef struct {
    dm_spectrum *sp; /* every mode of the step's pose */
    int same;     /* the step before is at the same pose: its modes */
    int rc;       /* of the solve */
    dm_error err;
} ref_slot;

typedef struct ref_ahead {
    int nt, cap;         /* threads; steps per batch */
    ref_slot *buf[2];    /* batches b and b + 1, cap each */
    dm_model **md;       /* nt each */
    dm_spectrum_solver **solver;
} ref_ahead;

static void ahead_free(ref_ahead *ra)
{
    if (!ra)
        return;
    for (int t = 0; ra->md && t < ra->nt; t++)
        dm_model_free(ra->md[t]);
    for (int t = 0; ra->solver && t < ra->nt; t++)
        dm_spectrum_solver_free(ra->solver[t]);
    for (int i = 0; ra->buf[0] && i < 2 * ra->cap; i++)
        dm_spectrum_free(ra->buf[0][i].sp);
    free(ra->md), free(ra->solver), free(ra->buf[0]);
    free(ra);
}

static int ahead_cap(int nt, int n)
{
    double slot = sizeof(double) * (2.0 * n * n + 5.0 * n); /* a spectrum */
    double cap = fmin(AHEAD_PER_THREAD * nt, fmax(1.0, floor(AHEAD_BYTES / (2 * slot))));
    return (int)cap;
}

static ref_ahead *ahead_alloc(const run_ws *w, dm_error *err)
{
    int n = w->n;
    ref_ahead *ra = calloc(1, sizeof *ra);
    int ok = ra != NULL;
    if (ok) {
        ra->nt = w->threads > 0 ? w->threads : 1;
        ra->cap = ahead_cap(ra->nt, n);
        ra->md = calloc((size_t)ra->nt, sizeof *ra->md);
        ra->solver = calloc((size_t)ra->nt, sizeof *ra->solver);
        ra->buf[0] = calloc(2 * (size_t)ra->cap, sizeof(ref_slot));
        ok = ra->md && ra->solver && ra->buf[0];
    }
    if (!ok) {
        ahead_free(ra);
        dm_fail(err, DM_ENOMEM, "out of memory for the all-modes reference");
        return NULL;
    }
    for (int t = 0; ok && t < ra->nt; t++) {
        ra->md[t] = dm_model_alloc(w->rb, w->md->na, w->md->nb, err);
        ra->solver[t] = ra->md[t] ? dm_spectrum_solver_alloc(ra->md[t], err) : NULL;
        ok = ra->solver[t] != NULL;
    }
    for (int i = 0; ok && i < 2 * ra->cap; i++)
        ok = (ra->buf[0][i].sp = dm_spectrum_alloc(w->md, err)) != NULL;
    if (!ok) {
        ahead_free(ra);
        return NULL;
    }
    ra->buf[1] = ra->buf[0] + ra->cap;
    return ra;
}

/* Step j's modes into its slot (batch j / cap), on thread t. */
static void ahead_solve(const run_ws *w, ref_ahead *ra, int t, long j, long nsteps)
{
    ref_slot *s = &ra->buf[j / ra->cap % 2][j % ra->cap];
    double t0, t1, tp;
    dm_pose pose, prev;
    step_times(w, j, nsteps, &t0, &t1);
    dm_error_clear(&s->err);
    s->rc = step_pose(w, t0, &pose, &s->err);
    s->same = 0;
    if (!s->rc && j % ra->cap > 0) { /* a batch's first step always solves */
        step_times(w, j - 1, nsteps, &tp, &t1);
        s->same = !step_pose(w, tp, &prev, NULL) && !memcmp(&pose, &prev, sizeof pose);
    }
    if (s->rc || s->same)
        return;
    s->rc = dm_model_build(ra->md[t], &pose, &s->err);
    if (!s->rc)
        s->rc = dm_spectrum_solve(s->sp, ra->md[t], ra->solver[t], &s->err);
}

/* Step j's modes, solved ahead. */
static int ahead_take(run_ws *w, long j, dm_error *err)
{
    ref_ahead *ra = w->ahead;
    ref_slot *b = ra->buf[j / ra->cap % 2];
    long i = j % ra->cap;
    while (b[i].same)
        i--;
    assert(i >= 0);
    if (b[i].rc) {
        if (err)
            *err = b[i].err;
        return b[i].rc;
    }
    w->all = b[i].sp;
    return DM_OK;
}

/* ---- frames: what a step takes from its pose ---------------------------
 *
 * A step's model, the factor of its K and Zheng's coupling index depend on
 * its pose alone; its modes on its pose and, through the warm start, on
 * the modes of the steps before: none of it on the state integrated from
 * step to step. So on two threads (run_pipelined) one solves step j + 1's
 * modes while the other integrates step j and then builds step j + 2's
 * model: the same calls in the same order as one thread makes them, so
 * the same numbers. A step at the very same pose as the one before
 * rebuilds the model and the factor (the same bits) and copies the modes:
 * the modes it would have kept. */

#define NFRAMES 3

static int frames_alloc(run_ws *w, dm_error *err)
{
    int n = w->n, k = w->ksolve;
    for (int i = 0; i < 4; i++)
        w->shift[i] = NAN;
    int rc = dm_arrow_ldl_init(&w->ldl, &w->md->layout, err);
    if (rc)
        return rc;
    w->fr[0].md = w->md;
    w->fr[0].statics = w->statics;
    for (int i = 0; i < NFRAMES; i++) {
        struct frame *f = &w->fr[i];
        if (i > 0) {
            f->md = dm_model_alloc(w->rb, w->md->na, w->md->nb, err);
            f->statics = f->md ? dm_static_alloc(f->md, err) : NULL;
            if (!f->statics)
                return err ? err->code : DM_ENOMEM;
        }
        if (!(f->buf = malloc(sizeof(double) * ((size_t)n * k + 2 * (size_t)k))))
            return dm_fail(err, DM_ENOMEM, "out of memory for the trajectory run");
        f->mo.n = n, f->mo.k = k;
        f->mo.omega_rad_s = f->buf, f->mo.freq_hz = f->buf + k, f->mo.phi = f->buf + 2 * k;
    }
    return DM_OK;
}

static void copy_modes(dm_modes *dst, const dm_modes *src, int n, int k)
{
    memcpy(dst->omega_rad_s, src->omega_rad_s, sizeof(double) * k);
    memcpy(dst->freq_hz, src->freq_hz, sizeof(double) * k);
    memcpy(dst->phi, src->phi, sizeof(double) * n * k);
}

/* Step j's pose, model, factor and coupling index into its frame, and,
 * where `ahead` asks, the Sturm count that will likely prove its modes
 * (dm_modal_count_ahead), at a shift predicted from the solves of steps
 * j - 2 to j - 4 (done when the frame is built on two threads, step
 * j - 1's under way, as on one). The solve decides as it would without
 * it (dm_modal_offer_count): the modes are the same whichever thread
 * counts, and run_pipelined moves the count to the thread with time to
 * spare. Returns the seconds the count took (0: none made). */
static double build_frame(run_ws *w, long j, long nsteps, int ahead)
{
    struct frame *f = &w->fr[j % NFRAMES];
    double t0, t1;
    step_times(w, j, nsteps, &t0, &t1);
    dm_error_clear(&f->err);
    f->counted = 0;
    f->rc = step_pose(w, t0, &f->pose, &f->err);
    if (!f->rc)
        f->rc = build_at(&f->pose, f->md, f->statics, &f->coupling_log10, &f->err);
    if (f->rc || j < 4 || !ahead || w->an) /* (the members count their own) */
        return 0;
    double before[3] = {w->shift[(j - 2) % 4], w->shift[(j - 3) % 4], w->shift[(j - 4) % 4]};
    double c0 = omp_get_wtime();
    f->counted = dm_modal_count_ahead(&w->ldl, f->md, before, &f->count) == DM_OK;
    return omp_get_wtime() - c0;
}

/* Step j's modes into its frame (built): solved, warm from the steps
 * before, or step j - 1's copied where the pose is the same. */
static void solve_frame(run_ws *w, long j)
{
    struct frame *f = &w->fr[j % NFRAMES];
    const dm_modes *mo = &w->fr[(j + NFRAMES - 1) % NFRAMES].mo;
    int fresh = fresh_pose(w, &f->pose);
    w->shift[j % 4] = NAN;
    if (!f->rc && fresh) {
        int full = full_model_solves(w);
        if (f->counted && full)
            dm_modal_offer_count(w->modal, &f->count);
        f->rc = solve_modes(w, &f->pose, f->md, f->statics, &mo, &f->err);
        dm_modal_stats st;
        if (!f->rc && full) {
            dm_modal_last_stats(w->modal, &st);
            if (st.shift > 0)
                w->shift[j % 4] = st.shift;
        }
    }
    if (!f->rc)
        copy_modes(&f->mo, mo, w->n, w->ksolve);
    w->frozen = f->pose;
    w->have_frozen = !f->rc;
}

/* Step j's frame becomes the run's model, factor and modes. */
static int take_frame(run_ws *w, long j, dm_error *err)
{
    const struct frame *f = &w->fr[j % NFRAMES];
    if (f->rc) {
        if (err)
            *err = f->err;
        return f->rc;
    }
    w->md = f->md;
    w->statics = f->statics;
    w->coupling_log10 = f->coupling_log10;
    w->mo = &f->mo;
    return DM_OK;
}

static int step(run_ws *w, long j, long nsteps, dm_integ_sink sink, void *user, run_stats *rs,
                dm_error *err)
{
    double t0, t1;
    step_times(w, j, nsteps, &t0, &t1);
    double h = t1 - t0;
    dm_integ_sample s;
    if (!w->pipelined) {
        build_frame(w, j, nsteps, 0);
        solve_frame(w, j);
    }
    int rc = take_frame(w, j, err);
    if (!rc && w->ahead)
        rc = ahead_take(w, j, err);
    const dm_modes *mo = w->mo;
    if (!rc && j == 0) {
        rc = initial_state(w, err);
        if (!rc) {
            fill_sample(w, 0.0, w->x, mo, &s);
            s.model = w->md;
            s.x = w->x;
            rc = sink && sink(user, &s) ? DM_EINTERRUPT : DM_OK;
            rs->peak = dm_norm3(w->x + w->md->platform_dof);
        }
    }
    if (!rc) rc = loads_at(w, t0, t1, err);
    if (!rc && w->ref_stepper)
        rc = dm_stepper_advance_all(w->ref_stepper, w->md, w->all, w->F0, w->F1, h, w->xr,
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
    s.model = w->md;
    s.x = w->xout;
    account(&w->o, rs, j, h, w->coupling_log10, &s);
    if (w->ref_stepper) {
        double er = dm_norm3(w->xr + w->md->platform_dof);
        double d = platform_diff(w, w->fig_stepper ? w->xfout : w->xout, w->xr);
        rs->ref_mean += h * er;
        rs->ref_sq += h * er * er;
        rs->diff_sq += h * d * d;
    }
    return sink && sink(user, &s) ? DM_EINTERRUPT : DM_OK;
}

/* ---- histories: closed-form runs in modal coordinates ----------------------
 *
 * Without the all-modes reference, a closed-form run carries only the k
 * modal coordinates from step to step: after step j-1 the state is
 * x = Phi_{j-1} q, so step j's projection Phi_j' M_j x is T_j q with
 * T_j = Phi_j' M_j Phi_{j-1} (k x k; the initial equilibrium x0, which
 * is not in any modal span, is projected once). Each step then needs from
 * its frozen model only the frequencies, T_j, the modal loads at its ends,
 * the platform rows of Phi_j and the static part of the dropped modes on
 * the platform: none of it depends on the damping. A history keeps these
 * records, and replays the run for another Rayleigh damping at O(k^2)
 * per step (a fit of the damping evaluates many) instead of a model, a
 * factorization and an eigen solve per step. A streamed run makes one
 * record at a time and applies it by the same code as a replay: both give
 * the same numbers, bit for bit. */

struct dm_integ_history {
    int n, k;
    dm_integ_opts o;
    double duration_s;
    long nsteps, nrec;     /* steps of the run; records held (1: streamed) */
    long member_steps;     /* steps whose modes the member bases gave */
    size_t len;            /* doubles per record */
    dm_integ_sample first; /* t = 0 */
    double peak0;          /* |platform translation| at t = 0 */
    double *q0;            /* k: the initial state on step 0's modes */
    double *rec;           /* nrec x len */
    dm_integ_sample *base; /* nrec: each step's end sample but its errors */
    double *q, *qd, *tmp;  /* k each: a replay's state */
};

/* A record: h, omega (k), f0 (k), f1 (k), T (k x k), platform rows of Phi
 * (6 x k, column-major), static remainder on the platform (6), geometry
 * offset (3) and whether it was found (1). */
typedef struct {
    double h;
    double *omega, *f0, *f1, *T, *phiP, *sP, *offset;
    int has_offset;
} step_record;

static size_t record_len(int k) { return 1 + 3 * (size_t)k + (size_t)k * k + 6 * (size_t)k + 10; }

static void record_view(const dm_integ_history *h, long slot, step_record *r)
{
    int k = h->k;
    double *p = h->rec + (size_t)slot * h->len;
    r->h = p[0];
    r->omega = p + 1, r->f0 = r->omega + k, r->f1 = r->f0 + k, r->T = r->f1 + k;
    r->phiP = r->T + (size_t)k * k, r->sP = r->phiP + 6 * k, r->offset = r->sP + 6;
    r->has_offset = r->offset[3] != 0;
}

void dm_integ_history_free(dm_integ_history *h)
{
    if (!h)
        return;
    free(h->q0), free(h->rec), free(h->base), free(h->q), free(h->qd), free(h->tmp);
    free(h);
}

static dm_integ_history *history_alloc(const run_ws *w, long nsteps, long nrec, dm_error *err)
{
    dm_integ_history *h = calloc(1, sizeof *h);
    if (h) {
        h->n = w->n, h->k = w->k, h->o = w->o, h->nsteps = nsteps, h->nrec = nrec;
        h->duration_s = w->tr->duration_s;
        h->len = record_len(w->k);
        h->q0 = malloc(sizeof(double) * w->k);
        h->q = malloc(sizeof(double) * w->k);
        h->qd = malloc(sizeof(double) * w->k);
        h->tmp = malloc(sizeof(double) * w->k);
        h->rec = malloc(sizeof(double) * h->len * nrec);
        h->base = malloc(sizeof *h->base * nrec);
    }
    if (!h || !h->q0 || !h->q || !h->qd || !h->tmp || !h->rec || !h->base) {
        dm_integ_history_free(h);
        dm_fail(err, DM_ENOMEM, "out of memory for the trajectory's modal history");
        return NULL;
    }
    return h;
}

/* Workspace of the records: the last modes, and M times them. */
static int alloc_record_ws(run_ws *w, dm_error *err)
{
    size_t sz = sizeof(double) * w->n * w->k;
    w->phi_prev = malloc(sz), w->Xi = malloc(sz), w->Yi = malloc(sz);
    if (w->an) /* (the full model serving the run needs none) */
        w->Gred = malloc(sizeof(double) * 3 * dm_boundary_reduced_size(w->an->boundary));
    if (!w->phi_prev || !w->Xi || !w->Yi || (w->an && !w->Gred))
        return dm_fail(err, DM_ENOMEM, "out of memory for the trajectory run");
    return DM_OK;
}

/* T = Phi' M Phi_prev (k x k, column-major). */
static void transfer(run_ws *w, const double *Phi, double *T)
{
    int n = w->n, k = w->k;
    for (int i = 0; i < n; i++) /* Phi_prev interleaved: row i holds its k values */
        for (int c = 0; c < k; c++)
            w->Xi[(size_t)i * k + c] = w->phi_prev[(size_t)c * n + i];
    dm_model_mult_M(w->md, w->Xi, k, w->Yi);
    /* Yi read column-major is (M Phi_prev)', k x n */
    cblas_dgemm(CblasColMajor, CblasTrans, CblasTrans, k, k, n, 1.0, Phi, n, w->Yi, k, 0.0, T, k);
}

/* ---- a member step without the full model ------------------------------
 *
 * After the first step (whose equilibrium is solved on the model), a step
 * the member bases serve takes all of its record from them: the modes
 * from their solve, the loads at the step's ends in the reduced
 * coordinates (dm_boundary_inertial_loads, dm_boundary_gravity_loads:
 * T' F of the model's own loads), so the modal loads are y' T' F and the
 * static response's platform part S^-1 of their boundary rows exactly,
 * and the transfer Phi_j' M_j Phi_{j-1} from the members' M times the
 * shapes (dm_boundary_mass_shapes). The model is neither built nor
 * factored; all of it equals the model's to rounding (test_boundary
 * loads_and_mass_equal_the_model). */

/* Step t0's pose frozen from the members alone: their solve there; where
 * they fail it (the analysis solved it on its own full model), the model
 * is built and factored too and serves the rest of the run. *served:
 * whether the step's record comes from the members. */
static int freeze_members(run_ws *w, double t0, int *served, dm_error *err)
{
    dm_pose pose;
    dm_pose_result res;
    int rc = step_pose(w, t0, &pose, err);
    *served = 1;
    if (rc || !fresh_pose(w, &pose)) /* (the same pose: the last solve stands) */
        return rc;
    rc = dm_analysis_run_pose(w->an, &pose, w->ksolve, &res, err);
    if (!rc && res.engine == DM_ENGINE_MEMBERS) {
        w->member_steps++;
        w->coupling_log10 = res.coupling_index_log10;
    } else if (!rc) {
        w->members_off = 1, *served = 0;
        rc = build_at(&pose, w->md, w->statics, &w->coupling_log10, err);
    }
    if (!rc)
        w->mo = res.modes;
    w->frozen = pose;
    w->have_frozen = !rc;
    return rc;
}

/* The step's loads in the reduced coordinates at the frozen pose (G:
 * nred x 2, at t0 and t1): gravity, the nominal motion's inertia and the
 * platform's force, what loads_at puts on the model. */
static int reduced_loads(run_ws *w, double t0, double t1, double *G, dm_error *err)
{
    dm_boundary *bw = w->an->boundary;
    int nr = dm_boundary_reduced_size(bw), p = dm_boundary_platform_row(bw);
    dm_rigid_motion mo[2];
    int rc = step_motions(w, t0, t1, mo, err);
    if (rc)
        return rc;
    double *g = G + 2 * (size_t)nr;
    dm_boundary_inertial_loads(bw, &w->frozen, mo, 2, G);
    dm_boundary_gravity_loads(bw, g);
    for (int l = 0; l < 2; l++) {
        double *c = G + (size_t)l * nr;
        for (int i = 0; i < nr; i++)
            c[i] += g[i];
        for (int i = 0; i < 3; i++)
            c[p + i] += w->o.force_n[i];
    }
    return DM_OK;
}

/* A member step's loads, transfer and static remainder into its record. */
static int record_from_members(run_ws *w, step_record *r, double t0, double t1, dm_error *err)
{
    dm_boundary *bw = w->an->boundary;
    int n = w->n, k = w->k, nr = dm_boundary_reduced_size(bw), p = dm_boundary_platform_row(bw);
    const double *Y = w->an->reduced; /* the modes' reduced vectors, nr x kmax */
    double *G = w->Gred;
    int rc = reduced_loads(w, t0, t1, G, err);
    if (rc)
        return rc;
    cblas_dgemv(CblasColMajor, CblasTrans, nr, k, 1.0, Y, nr, G, 1, 0.0, r->f0, 1);
    cblas_dgemv(CblasColMajor, CblasTrans, nr, k, 1.0, Y, nr, G + nr, 1, 0.0, r->f1, 1);
    memset(r->sP, 0, 6 * sizeof(double));
    if (w->o.quasi_static && k < n) { /* K^-1 F1 on the platform, less the kept modes' part */
        dm_boundary_eig_solve_K(w->an->eig, bw, G + nr, 1);
        for (int i = 0; i < 6; i++) {
            double v = G[nr + p + i];
            for (int m = 0; m < k; m++)
                v -= r->phiP[6 * m + i] * r->f1[m] / (r->omega[m] * r->omega[m]);
            r->sP[i] = v;
        }
    }
    dm_boundary_mass_shapes(bw, k, w->Yi); /* M_j Phi_j, n x k */
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, k, k, n, 1.0, w->Yi, n, w->phi_prev, n,
                0.0, r->T, k);
    return DM_OK;
}

/* Step j's record into slot `slot` of h (step 0 also sets the start). */
static int record_step(run_ws *w, dm_integ_history *h, long j, long slot, dm_error *err)
{
    int n = w->n, k = w->k, pd, members = 0;
    double t0, t1;
    step_times(w, j, h->nsteps, &t0, &t1);
    int rc = j > 0 && !full_model_solves(w) ? freeze_members(w, t0, &members, err)
                                              : freeze(w, t0, err);
    if (rc)
        return rc;
    const dm_modes *mo = w->mo;
    const double *Phi = mo->phi;
    pd = w->md->platform_dof;
    step_record r;
    record_view(h, slot, &r);
    h->rec[(size_t)slot * h->len] = t1 - t0;
    if (j == 0) { /* the start: equilibrium (or rest), projected as a stepper does */
        if ((rc = initial_state(w, err)))
            return rc;
        fill_sample(w, 0.0, w->x, mo, &h->first);
        h->peak0 = dm_norm3(w->x + pd);
        dm_model_mult_M(w->md, w->x, 1, w->xd);
        cblas_dgemv(CblasColMajor, CblasTrans, n, k, 1.0, Phi, n, w->xd, 1, 0.0, h->q0, 1);
        memset(r.T, 0, sizeof(double) * k * k);
    }
    memcpy(r.omega, mo->omega_rad_s, sizeof(double) * k);
    for (int c = 0; c < k; c++)
        memcpy(r.phiP + 6 * c, Phi + (size_t)c * n + pd, 6 * sizeof(double));
    if (members) {
        if ((rc = record_from_members(w, &r, t0, t1, err)))
            return rc;
    } else {
        if (j > 0)
            transfer(w, Phi, r.T);
        if ((rc = loads_at(w, t0, t1, err)))
            return rc;
        cblas_dgemv(CblasColMajor, CblasTrans, n, k, 1.0, Phi, n, w->F0, 1, 0.0, r.f0, 1);
        cblas_dgemv(CblasColMajor, CblasTrans, n, k, 1.0, Phi, n, w->F1, 1, 0.0, r.f1, 1);
        memset(r.sP, 0, 6 * sizeof(double));
        if (w->o.quasi_static && k < n) {
            if ((rc = static_remainder(w, mo, w->F1, w->F0, err)))
                return rc;
            memcpy(r.sP, w->F0 + pd, 6 * sizeof(double));
        }
    }
    int has_offset;
    sample_base(w, t1, mo, &h->base[slot], r.offset, &has_offset);
    r.offset[3] = has_offset;
    memcpy(w->phi_prev, Phi, sizeof(double) * n * k);
    return DM_OK;
}

/* Apply step j's record (slot) to the replay's state, with damping
 * (alpha, beta): the sample at the step's end. */
static void replay_step(dm_integ_history *h, long j, long slot, double alpha, double beta,
                        dm_integ_sample *s)
{
    int k = h->k;
    step_record r;
    record_view(h, slot, &r);
    if (j == 0) {
        memcpy(h->q, h->q0, sizeof(double) * k);
        memset(h->qd, 0, sizeof(double) * k); /* from rest or equilibrium */
    } else {
        cblas_dgemv(CblasColMajor, CblasNoTrans, k, k, 1.0, r.T, k, h->q, 1, 0.0, h->tmp, 1);
        memcpy(h->q, h->tmp, sizeof(double) * k);
        cblas_dgemv(CblasColMajor, CblasNoTrans, k, k, 1.0, r.T, k, h->qd, 1, 0.0, h->tmp, 1);
        memcpy(h->qd, h->tmp, sizeof(double) * k);
    }
    for (int m = 0; m < k; m++) {
        double om = r.omega[m], zeta = dm_rayleigh_zeta(alpha, beta, om);
        dm_sdof_step(om, zeta, r.f0[m], r.f1[m], r.h, &h->q[m], &h->qd[m]);
    }
    double u[6];
    for (int i = 0; i < 6; i++) {
        double v = r.sP[i];
        for (int m = 0; m < k; m++)
            v += r.phiP[6 * m + i] * h->q[m];
        u[i] = v;
    }
    *s = h->base[slot];
    sample_errors(s, u, r.offset, r.has_offset, h->o.tool_m);
}

/* A run's summary from its integrals and maxima (no reference: the
 * truncation figures NaN, set by the caller that ran one). */
static void summarise(const dm_integ_opts *o, int n, int k, long nsteps, double duration_s,
                      const run_stats *rs, double alpha, double beta, dm_integ_summary *sum)
{
    memset(sum, 0, sizeof *sum);
    sum->n = n;
    sum->k = k;
    sum->steps = nsteps;
    sum->duration_s = duration_s;
    sum->mean_error_m = rs->mean / duration_s;
    sum->peak_error_m = rs->peak;
    sum->truncation_error = NAN;
    sum->reference_mean_error_m = NAN;
    sum->aliasing_risk = alpha == 0 && beta == 0 && o->dt_s > 1.25e-4 && k > 20;
    sum->coupling_mean_log10 = rs->coupling_mean / duration_s;
    sum->coupling_min_log10 = rs->coupling_min;
    sum->coupling_max_log10 = rs->coupling_max;
    for (int a = 0; a < o->naxes && a < DM_INTEG_MAXAXES; a++)
        for (int c = 0; c < 3; c++)
            sum->mean_axes_m[a][c] = rs->axes[a][c] / duration_s;
}

static void summarise_history(const dm_integ_history *h, const run_stats *rs, double alpha,
                              double beta, dm_integ_summary *sum)
{
    summarise(&h->o, h->n, h->k, h->nsteps, h->duration_s, rs, alpha, beta, sum);
    sum->member_steps = h->member_steps;
}

/* Emit step j's sample (slot) after applying it; non-zero: the sink stopped the run. */
static int replay_one(dm_integ_history *h, long j, long slot, double alpha, double beta,
                      run_stats *rs, dm_integ_sink sink, void *user)
{
    dm_integ_sample s;
    if (j == 0) {
        rs->peak = h->peak0;
        if (sink && sink(user, &h->first))
            return DM_EINTERRUPT;
    }
    replay_step(h, j, slot, alpha, beta, &s);
    step_record r;
    record_view(h, slot, &r);
    account(&h->o, rs, j, r.h, s.coupling_index_log10, &s);
    return sink && sink(user, &s) ? DM_EINTERRUPT : DM_OK;
}

int dm_integ_history_replay(dm_integ_history *h, double alpha, double beta, dm_integ_sink sink,
                            void *user, dm_integ_summary *sum, dm_error *err)
{
    if (h->nrec != h->nsteps)
        return dm_fail(err, DM_EINVAL, "a streamed run's history cannot be replayed");
    run_stats rs = {0};
    int rc = DM_OK;
    for (long j = 0; !rc && j < h->nsteps; j++)
        rc = replay_one(h, j, j, alpha, beta, &rs, sink, user);
    if (!rc)
        summarise_history(h, &rs, alpha, beta, sum);
    return rc;
}

/* A closed-form run without the reference: its records made (all kept
 * into *out, or one at a time and applied as they come when out is NULL). */
static int run_modal(const dm_robot *rb, const dm_trajectory *tr, const dm_integ_opts *o,
                     long nsteps, dm_integ_sink sink, void *user, dm_integ_summary *sum,
                     dm_integ_history **out, dm_error *err)
{
    run_ws w = {.rb = rb, .tr = tr, .o = *o};
    dm_integ_history *h = NULL;
    run_stats rs = {0};
    int rc = alloc_ws(&w, nsteps, err);
    if (!rc) rc = alloc_record_ws(&w, err);
    if (!rc && !(h = history_alloc(&w, nsteps, out ? nsteps : 1, err)))
        rc = err ? err->code : DM_ENOMEM;
    for (long j = 0; !rc && j < nsteps; j++) {
        rc = record_step(&w, h, j, out ? j : 0, err);
        h->member_steps = w.member_steps;
        if (!rc && !out)
            rc = replay_one(h, j, 0, rb->rayleigh_alpha, rb->rayleigh_beta, &rs, sink, user);
    }
    if (!rc && !out)
        summarise_history(h, &rs, rb->rayleigh_alpha, rb->rayleigh_beta, sum);
    free_ws(&w);
    if (!rc && out)
        *out = h;
    else
        dm_integ_history_free(h);
    return rc;
}

/* One core's time a step, measured at 210 DOF (make bench) and rounded
 * up: 0.3-0.8 ms without the reference (10 modes, CVODE), growing with
 * the modes kept; the reference's spectrum and projections 1.6 ms, O(n^3). */
double dm_integ_estimate_s(long steps, int n, int k, int reference)
{
    double s = n / 210.0, per_step = 1e-3 * s * s * fmax(1.0, k / 10.0);
    if (reference)
        per_step += 2e-3 * s * s * s;
    return steps * per_step;
}

/* The run's step count, after refusing what it cannot or should not do. */
static int check_run(const dm_robot *rb, const dm_trajectory *tr, const dm_integ_opts *o,
                     long *nsteps, dm_error *err)
{
    if (!(o->dt_s > 0) || !(tr->duration_s > 0))
        return dm_fail(err, DM_EINVAL, "time step and duration must be > 0");
    double steps_d = ceil(tr->duration_s / o->dt_s - 1e-9);
    int n = dm_model_dofs(rb, o->na ? o->na : rb->na, o->nb ? o->nb : rb->nb);
    int k = o->k <= 0 || o->k > n ? n : o->k;
    double est = steps_d > 1e15 ? INFINITY : dm_integ_estimate_s((long)steps_d, n, k, o->reference);
    char what[sizeof tr->name + 128];
    snprintf(what, sizeof what, "%s: %.6g s at a step of %g s is %.3g steps for a %d-DOF model",
             tr->name, tr->duration_s, o->dt_s, steps_d, n);
    int rc = dm_work_check(what, (dm_work){est, 0, 0}, (dm_work){DM_WORK_MAX_SECONDS, 0, 0},
                           "a larger step, a shorter path or no all-modes reference",
                           o->force_long, err);
    if (rc)
        return rc;
    *nsteps = (long)ceil(tr->duration_s / o->dt_s - 1e-9);
    return dm_traj_check_reachable(tr, rb, o->dt_s, err);
}

int dm_integ_history_make(const dm_robot *rb, const dm_trajectory *tr, const dm_integ_opts *o,
                          dm_integ_history **out, dm_error *err)
{
    long nsteps;
    *out = NULL;
    if (o->method != DM_ODE_CLOSED_FORM || o->reference)
        return dm_fail(err, DM_EINVAL, "a modal history needs the closed form without reference");
    int rc = check_run(rb, tr, o, &nsteps, err);
    if (rc)
        return rc;
    dm_threads_saved saved = dm_threads_serial_blas(); /* see integrate() */
    rc = run_modal(rb, tr, o, nsteps, NULL, NULL, NULL, out, err);
    dm_threads_restore(saved);
    return rc;
}

size_t dm_integ_history_bytes(const dm_trajectory *tr, const dm_integ_opts *o, int k)
{
    double steps = ceil(tr->duration_s / o->dt_s - 1e-9);
    return (size_t)fmin(steps * (sizeof(double) * record_len(k) + sizeof(dm_integ_sample)), 1e18);
}

static int integrate(const dm_robot *rb, const dm_trajectory *tr, const dm_integ_opts *o,
                     int threads, dm_integ_sink sink, void *user, dm_integ_summary *sum,
                     dm_error *err);

/* BLAS on one thread for the run (dm_threads.h): its matrices have 48-430
 * rows, where BLAS threads spin more than they compute (chen2018's
 * truncation figure at mesh 1,1: 65 s with two, 37 s with one). */
int dm_integrate_trajectory(const dm_robot *rb, const dm_trajectory *tr, const dm_integ_opts *o,
                            dm_integ_sink sink, void *user, dm_integ_summary *sum, dm_error *err)
{
    /* (counted before BLAS and OpenMP's default go to one thread; inside
     * another stage's parallel region the run has one) */
    int threads = omp_in_parallel() ? 1 : dm_threads_count(o->threads);
    dm_threads_saved saved = dm_threads_serial_blas();
    int rc = integrate(rb, tr, o, threads, sink, user, sum, err);
    dm_threads_restore(saved);
    return rc;
}

/* The steps in batches of the reference's: batch b's steps on one thread
 * while the others (and that one, once done) solve batch b + 1's modes;
 * b = -1 solves the first batch alone. */
static int run_ahead(run_ws *w, long nsteps, dm_integ_sink sink, void *user, run_stats *rs,
                     dm_error *err)
{
    ref_ahead *ra = w->ahead;
    long cap = ra->cap;
    int rc = DM_OK;
    for (long b = -1; !rc && b * cap < nsteps; b++) {
        long j0 = b < 0 ? 0 : b * cap, j1 = b < 0 ? 0 : (j0 + cap < nsteps ? j0 + cap : nsteps);
        long s0 = (b + 1) * cap, s1 = s0 + cap < nsteps ? s0 + cap : nsteps;
        long items = 1 + (s1 > s0 ? s1 - s0 : 0);
#pragma omp parallel for schedule(dynamic, 1) num_threads(ra->nt)
        for (long i = 0; i < items; i++) {
            if (i == 0) /* (rc is this item's alone until the loop ends) */
                for (long j = j0; !rc && j < j1; j++)
                    rc = step(w, j, nsteps, sink, user, rs, err);
            else
                ahead_solve(w, ra, omp_get_thread_num(), s0 + i - 1, nsteps);
        }
    }
    return rc;
}

/* Seconds a pipelined step's two threads spend (moving averages), and the
 * count's: where the Sturm count goes. */
typedef struct {
    double solve, frame, count; /* solve without the count, frame without it */
    int have_count;
} pipe_balance;

/* After a step: the solving thread spent `solve` s (with the count unless
 * the frame it solved had one made ahead), the frame thread `frame` (with
 * the count it made ahead, count_s). The count goes ahead next time when
 * the slower of the two threads is then faster than it would be with the
 * count in the solve. Only the time changes: the modes do not depend on
 * where the count is made (build_frame). */
static int count_goes_ahead(pipe_balance *b, double solve, int solved_with_count, double frame,
                            double count_s)
{
    const double a = 0.125; /* averages over ~8 steps */
    if (count_s > 0) {
        b->count = b->have_count ? b->count + a * (count_s - b->count) : count_s;
        b->have_count = 1;
    }
    if (!b->have_count) /* make one to know what it costs */
        return 1;
    double s = solved_with_count ? solve - b->count : solve, f = frame - count_s;
    b->solve += a * (s - b->solve);
    b->frame += a * (f - b->frame);
    return fmax(b->solve, b->frame + b->count) < fmax(b->solve + b->count, b->frame);
}

/* Without the reference, on two threads: the first solves step j + 1's
 * modes while the other integrates step j and builds step j + 2's model,
 * and makes step j + 2's Sturm count where that balances the two threads
 * better. With member bases the solve is the shorter part (chen2018: the
 * modes 110 us, the step and the next model 230 us), so the first thread
 * builds step j + 1's model itself before solving it, and the other only
 * integrates. fail[] and solve_s[] alternate so that a thread reading step
 * j's after the barrier never sees step j + 1's being written. */
static int run_pipelined(run_ws *w, long nsteps, dm_integ_sink sink, void *user, run_stats *rs,
                         dm_error *err)
{
    int fail[2] = {DM_OK, DM_OK}, solved_with_count[2] = {1, 1}, ahead = 1;
    double solve_s[2] = {0, 0};
    pipe_balance bal = {0};
    int solver_builds = w->an != NULL;
    w->pipelined = 1;
    build_frame(w, 0, nsteps, 0);
    solve_frame(w, 0);
    if (nsteps > 1 && !solver_builds)
        build_frame(w, 1, nsteps, 0);
#pragma omp parallel num_threads(2)
    {
        int t = omp_get_thread_num(), last = omp_get_num_threads() - 1;
        for (long j = 0; j < nsteps; j++) {
            if (t == 0 && j + 1 < nsteps) {
                double t0 = omp_get_wtime();
                if (solver_builds)
                    build_frame(w, j + 1, nsteps, 0);
                solved_with_count[j % 2] = !w->fr[(j + 1) % NFRAMES].counted;
                solve_frame(w, j + 1);
                solve_s[j % 2] = omp_get_wtime() - t0;
            }
            double frame_s = 0, count_s = 0;
            if (t == last) {
                double t0 = omp_get_wtime();
                fail[j % 2] = step(w, j, nsteps, sink, user, rs, err);
                if (j + 2 < nsteps && !solver_builds)
                    count_s = build_frame(w, j + 2, nsteps, ahead);
                frame_s = omp_get_wtime() - t0;
            }
#pragma omp barrier
            if (t == last && last > 0) /* (ahead is the frame thread's alone) */
                ahead = count_goes_ahead(&bal, solve_s[j % 2], solved_with_count[j % 2], frame_s,
                                         count_s);
            if (fail[j % 2])
                break;
        }
    }
    w->pipelined = 0;
    return fail[0] ? fail[0] : fail[1];
}

static int integrate(const dm_robot *rb, const dm_trajectory *tr, const dm_integ_opts *o,
                     int threads, dm_integ_sink sink, void *user, dm_integ_summary *sum,
                     dm_error *err)
{
    long nsteps;
    int rc = check_run(rb, tr, o, &nsteps, err);
    if (rc)
        return rc;
    if (o->method == DM_ODE_CLOSED_FORM && !o->reference)
        return run_modal(rb, tr, o, nsteps, sink, user, sum, NULL, err);
    run_ws w = {.rb = rb, .tr = tr, .o = *o, .threads = threads};
    run_stats rs = {0};
    rc = alloc_ws(&w, nsteps, err);
    if (!rc)
        rc = frames_alloc(&w, err);
    if (!rc && w.ahead)
        rc = run_ahead(&w, nsteps, sink, user, &rs, err);
    else if (!rc && threads > 1)
        rc = run_pipelined(&w, nsteps, sink, user, &rs, err);
    for (long j = 0; !rc && !w.ahead && threads < 2 && j < nsteps; j++)
        rc = step(&w, j, nsteps, sink, user, &rs, err);
    if (w.fr[0].md) { /* frame 0's are the run's own (free_ws) */
        w.md = w.fr[0].md;
        w.statics = w.fr[0].statics;
    }
    if (!rc) {
        summarise(o, w.n, w.k, nsteps, tr->duration_s, &rs, rb->rayleigh_alpha,
                  rb->rayleigh_beta, sum);
        if (o->reference) {
            sum->truncation_error = sqrt(rs.diff_sq / rs.ref_sq);
            sum->reference_mean_error_m = rs.ref_mean / tr->duration_s;
        }
        sum->truncation_beta_s = w.fig_beta;
        sum->member_steps = w.member_steps;
    }
    free_ws(&w);
    return rc;
}
