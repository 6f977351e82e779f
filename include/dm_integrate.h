/* dm_integrate — time response of the robot in normal coordinates
 * (docs/model.md §4, Han eq. 10–13).
 *
 * Along a trajectory the configuration is frozen per step: at each step
 * start M, K and the k lowest modes Phi are rebuilt at the new pose, the
 * physical state is carried across by projection q = Phi' M x,
 * q_dot = Phi' M x_dot, and the decoupled modal equations
 *   q_j'' + 2 zeta_j omega_j q_j' + omega_j^2 q_j = phi_j' F(t)
 * are integrated over the step with the load F linear in time between its
 * values at the step ends (gravity + inertia of the nominal rigid motion).
 * Rayleigh damping: zeta_j = alpha/(2 omega_j) + beta omega_j / 2.
 *
 * Integrators: CVODE (SUNDIALS, BDF with a banded Jacobian; default), the
 * exact closed-form solution of each mode for a linear load (cross-check),
 * or the full model M x'' + C x' + K x = F integrated directly with CVODE
 * (validation: equals the modal model with all modes retained).
 *
 * Errors are total (static + dynamic) platform displacements: dx, dy, dz
 * (m), ex, ey, ez (rad). Units SI throughout.
 *
 * One header for three files, its sections marked by file (as GSL does):
 * integrate.c (a frozen step), standard_move.c (the sweep's standard move),
 * integrate_trajectory.c (a whole trajectory). */
#ifndef DM_INTEGRATE_H
#define DM_INTEGRATE_H

#include "dm_boundary.h"
#include "dm_model.h"
#include "dm_modal.h"
#include "dm_robot.h"
#include "dm_spectrum.h"
#include "dm_static.h"
#include "dm_trajectory.h"

typedef enum {
    DM_ODE_CVODE = 0,       /* modal equations with SUNDIALS CVODE */
    DM_ODE_CLOSED_FORM = 1, /* modal equations, exact per step */
    DM_ODE_FULL = 2         /* full model with CVODE (validation) */
} dm_ode_method;

/* ---- integrate.c: one frozen step (trajectories and the standard move) --- */

typedef struct dm_stepper dm_stepper;

dm_stepper *dm_stepper_alloc(int n, int kmax, dm_ode_method method, double rtol,
                             double atol, dm_error *err);
void dm_stepper_free(dm_stepper *st);

/* Damping for this stepper instead of the robot's (the truncation figure
 * of an undamped robot). */
void dm_stepper_set_damping(dm_stepper *st, double alpha, double beta);

/* Advance the physical state (x, xd: length n, in the model's DOFs) over
 * h seconds with the model frozen, its first k modes (ignored by
 * DM_ODE_FULL) and the load varying linearly from F0 to F1. */
int dm_stepper_advance(dm_stepper *st, const dm_model *model, const dm_modes *modes, int k,
                       const double *F0, const double *F1, double h, double *x, double *xd,
                       dm_error *err);

/* The same with every mode of a spectrum, never formed (the all-modes
 * reference): a stepper of kmax >= n modes, not DM_ODE_FULL. */
int dm_stepper_advance_all(dm_stepper *st, const dm_model *model, dm_spectrum *spectrum,
                           const double *F0, const double *F1, double h, double *x, double *xd,
                           dm_error *err);

/* One degree of freedom, exact: q'' + 2 z w q' + w^2 q = f0 + (f1 - f0) t/h,
 * advanced from (q, qd) over h. Any damping ratio z >= 0. */
void dm_sdof_step(double omega, double zeta, double f0, double f1, double h, double *q,
                  double *qd);

/* The damping ratio of a mode at omega [rad/s] under Rayleigh damping
 * C = alpha M + beta K (docs/model.md, "Damping"): alpha / (2 omega) + beta omega / 2. */
double dm_rayleigh_zeta(double alpha, double beta, double omega);

/* ---- standard_move.c: the standard move (docs/model.md §5) ------------------- */

/* A rest-to-rest bang-bang move starting at the pose: +amax for tau/2, then
 * -amax for tau/2, configuration frozen at the start pose, load = inertia of
 * the nominal accelerations at zero velocity, starting from the static
 * equilibrium. Outputs use |Delta - Delta_static| (platform translation). */
typedef struct dm_move_opts {
    double amax_ms2;     /* 50 */
    double tau_s;        /* 0.05 */
    double tol_m;        /* settling band, 10e-6 */
    double window_s;     /* residual window after the move, 1.0 */
    int quasi_static;    /* the dropped modes' response: static correction and
                            Ritz vectors (default on) */
    int ritz_vectors;    /* load-dependent Ritz vectors per direction carried
                            dynamically (default DM_MOVE_RITZ; 0: static only) */
} dm_move_opts;

#define DM_MOVE_RITZ 3

void dm_move_opts_default(dm_move_opts *opts);

typedef struct dm_move_result {
    double peak_m;       /* max over 0 <= t <= tau (of the continuous response,
                            to 1e-9 relative) */
    double residual_m;   /* max over tau < t <= tau + window (likewise) */
    double peak_t_s;     /* when the peak occurs (from the move's start) */
    double residual_t_s; /* when the residual's maximum occurs (after tau) */
    double settling_s;   /* time after tau until within tol for good; INFINITY when
                            undamped or not settled within the window */
} dm_move_result;

typedef struct dm_move_ws dm_move_ws;

dm_move_ws *dm_move_alloc(int n, int kmax, dm_error *err);
void dm_move_free(dm_move_ws *ws);

/* The move along unit direction dir with the model built at the pose, its
 * first k modes and the Cholesky factor of K in `statics`. */
int dm_standard_move(dm_move_ws *ws, const dm_model *model, const dm_modes *modes, int k,
                     const dm_static *statics, const double dir[3],
                     const dm_move_opts *opts, dm_move_result *res, dm_error *err);

/* The same along ndir (1..3) directions: res[d] for dir[d]. Maxima and the
 * settling time are those of the continuous response (each mode advanced
 * exactly; bounds on what lies between samples decide where to look
 * closer). A damped robot's ringing is followed only until its envelope
 * is below both the residual found and the settling band: the results are
 * those of the whole window. */
int dm_standard_moves(dm_move_ws *ws, const dm_model *model, const dm_modes *modes, int k,
                      const dm_static *statics, const double (*dir)[3], int ndir,
                      const dm_move_opts *opts, dm_move_result *res, dm_error *err);

/* The same on the member engine's reduced model (dm_boundary, issue 39):
 * the k retained modes are the reduced eigenvectors Y (nred x k,
 * dm_boundary_reduced_vectors' coordinates, M_red-normalised; MY =
 * M_red Y beside them, leading dimension nred, or NULL to make it) with
 * circular frequencies omega, at bw's last solve's pose (`pose`; eig the
 * solver that served it, whose M_red and K_red products and K_red solves
 * the preparation uses). The loads are T' G (dm_boundary_inertial_loads)
 * and the platform's rows are reduced coordinates, so the retained modes'
 * forces and platform shapes are the model's (phi = T y) and the static
 * remainder's platform part is exact (K_red^-1's boundary block is S^-1,
 * the exact condensation); the Ritz vectors are those of the reduced pair,
 * a Rayleigh-Ritz of the model's (docs/model-choices.md). No n-vector of
 * the model is formed. */
int dm_standard_moves_reduced(dm_move_ws *ws, dm_boundary *bw, dm_boundary_eig *eig,
                              const dm_robot *robot, const dm_pose *pose, const double *Y,
                              const double *MY, const double *omega, int k, const double (*dir)[3], int ndir,
                              const dm_move_opts *opts, dm_move_result *res, dm_error *err);

/* ---- integrate_trajectory.c: trajectories --------------------------------- */

#define DM_INTEG_MAXFREQ 8

typedef struct dm_integ_opts {
    int k;               /* retained modes; 0 = all */
    double dt_s;         /* frozen-step length */
    dm_ode_method method;
    double rtol, atol;   /* CVODE tolerances (atol in modal units, sqrt(kg)*m) */
    int quasi_static;    /* add the static part of the dropped modes to outputs
                            (default on) */
    int from_rest;       /* start undeformed instead of in static equilibrium */
    int reference;       /* also run all modes (closed form) for the truncation error */
    int threads;         /* 0: OpenMP's default (all cores). The reference's
                            eigen solves run ahead on this many threads;
                            without the reference, with 2 or more each step's
                            modes are solved beside the integration of the
                            step before. The results do not depend on it */
    int na, nb;          /* mesh (0: the robot's) */
    double tool_m[3];    /* tool point offset from P, platform axes */
    double force_n[3];   /* constant external force at P (part of the initial
                            static equilibrium as well) */
    int nfreq;           /* frequencies reported per sample (<= DM_INTEG_MAXFREQ) */
    int full_model;      /* 1: every step's modes from the full model; 0: from
                            member bases (dm_boundary.h) where they serve the
                            robot and the run is long enough to repay them
                            (src/responses/integrate_trajectory.c,
                            use_members), the two equal to their accuracy */
    int force_long;      /* run even beyond DM_WORK_MAX_SECONDS of estimated work */
    /* Zheng fig. 15: also report the mean |error component| along base axes
     * rotated about z by each of these angles (rad) */
    int naxes;           /* <= DM_INTEG_MAXAXES */
    double axes_rotation_rad[8];
} dm_integ_opts;
#define DM_INTEG_MAXAXES 8

/* The estimated seconds of a run (steps, model size, reference): from the
 * step count and the model size, calibrated on this project's development
 * machine (2 ms per step at 210 DOF and 10 modes, 5 ms more for the
 * all-modes reference, which grows as n^3). A run estimated beyond
 * DM_WORK_MAX_SECONDS (dm_work.h) is refused before it starts, with
 * DM_ETOOBIG, unless opts.force_long. */
double dm_integ_estimate_s(long steps, int n, int k, int reference);

void dm_integ_opts_default(dm_integ_opts *opts);

typedef struct dm_integ_sample {
    double t_s;
    double P_m[3];
    double error[6];        /* total platform error */
    double tool_error_m[3]; /* error + eps x tool */
    double freq_hz[DM_INTEG_MAXFREQ];
    int nfreq;
    double coupling_index_log10; /* of the step's frozen K (dm_coupling.h) */
    /* The whole robot, valid during the sink's call only: the step's frozen
     * model and its displacement (n reduced DOFs, the output's: with the
     * quasi-static part), NULL where a run keeps none (a closed-form run
     * without the reference carries modal coordinates only) */
    const struct dm_model *model;
    const double *x;
} dm_integ_sample;

typedef struct dm_integ_summary {
    int n, k;
    long steps;
    double duration_s;
    double mean_error_m;     /* Chen eq. 27: (1/T) sum dt |Delta(t)| */
    double peak_error_m;     /* max |Delta(t)| */
    double truncation_error; /* RMS_t |Delta_k - Delta_all| / RMS_t |Delta_all| (NaN: not run) */
    double reference_mean_error_m; /* of the all-modes run */
    double truncation_beta_s;  /* > 0: the robot is undamped, and both runs of the
                                  truncation figure had Rayleigh beta = this */
    int aliasing_risk;       /* undamped, > 20 modes, dt > 1.25e-4 s (docs/model.md §4) */
    long member_steps;       /* steps whose modes the member bases gave (the
                                rest the full model's; dm_integ_opts.full_model) */
    /* Zheng's coupling index log10 det K over the frozen steps: time mean
     * (each step's value weighted by its length), minimum, maximum */
    double coupling_mean_log10, coupling_min_log10, coupling_max_log10;
    /* per opts.axes_rotation_rad[a]: (1/T) sum dt |e . x'|, |e . y'|, |e . z|
     * with x' = (cos b, sin b, 0), y' = (-sin b, cos b, 0), e the total error */
    double mean_axes_m[DM_INTEG_MAXAXES][3];
} dm_integ_summary;

/* An undamped robot's truncation figure is measured with this light
 * stiffness-proportional damping in both the k-mode and the all-modes run:
 * undamped, the all-modes run is not converged in dt (step-boundary
 * projections alias into the stiff modes and the persistent free vibration
 * drifts in phase by O(dt)), and the figure would say more about dt than
 * about truncation (chen2018: 8.9 % at 1 ms, 1.8 % at 0.125 ms; with this,
 * 0.06 % at either). */
#define DM_TRUNCATION_BETA 1e-4

/* Called for t = 0 and the end of every step; a non-zero return stops the run. */
typedef int (*dm_integ_sink)(void *user, const dm_integ_sample *sample);

int dm_integrate_trajectory(const dm_robot *robot, const dm_trajectory *traj,
                            const dm_integ_opts *opts, dm_integ_sink sink, void *user,
                            dm_integ_summary *summary, dm_error *err);

/* A closed-form run without the reference carries only the modal
 * coordinates from step to step, and what each step takes from its frozen
 * model (frequencies, the projection between consecutive steps' modes,
 * modal loads, the platform rows of the modes, the static part of the
 * dropped modes) does not depend on Rayleigh damping. A history keeps
 * that for every step, so the run can be replayed for another damping at
 * O(k^2) per step: a fit of the damping evaluates many. A replay gives
 * bit for bit what dm_integrate_trajectory gives for a robot that differs
 * only in its damping (rayleigh_alpha, rayleigh_beta).
 * dm_integ_history_make: opts must ask for DM_ODE_CLOSED_FORM and no
 * reference (DM_EINVAL otherwise); dm_integ_history_bytes: what it holds
 * for k modes. */
typedef struct dm_integ_history dm_integ_history;
int dm_integ_history_make(const dm_robot *robot, const dm_trajectory *traj,
                          const dm_integ_opts *opts, dm_integ_history **history, dm_error *err);
int dm_integ_history_replay(dm_integ_history *history, double alpha, double beta,
                            dm_integ_sink sink, void *user, dm_integ_summary *summary,
                            dm_error *err);
size_t dm_integ_history_bytes(const dm_trajectory *traj, const dm_integ_opts *opts, int k);
void dm_integ_history_free(dm_integ_history *history);

#endif
