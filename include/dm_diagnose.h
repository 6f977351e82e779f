/* dm_diagnose — what the model gets wrong about measured data, and why.
 *
 * Residuals r = measured - predicted, normalised by each sample's sigma.
 * For every candidate effect of MODEL.md §6 the effect's parameters are
 * fitted by nonlinear least squares (cminpack lmdif, parameters in log10)
 * on a training part of the data and scored on the held-out rest: poses
 * whose index is 2 mod 3 (modal, static) or the last third of the time
 * (tracker). Score: held-out chi-square (without sigma: N ln(chi2/N))
 * plus a BIC-like penalty p ln N; scores within DM_DIAG_TIE tie.
 * Gain (%) = share of the held-out excess chi-square (over the noise, N)
 * that the effect removes; without sigma, the share of the held-out mean
 * square. An effect is found when it lowers the score by more than
 * 9 + ln N. It may be joined by a second (forward selection: every other
 * candidate is screened on top of it, the two best screened are refitted
 * jointly) when that lowers the score by as much again. */
#ifndef DM_DIAGNOSE_H
#define DM_DIAGNOSE_H

#include "dm_measure.h"
#include "dm_robot.h"

#define DM_DIAG_MAXP 6     /* free parameters of a fit (two effects of three) */
#define DM_DIAG_MAXCAND 24 /* candidate effects */
#define DM_DIAG_TIE 2.0    /* score difference below which two effects tie */

typedef struct dm_candidate {
    const char *name;        /* effect name, as in the robot file's [effects] */
    const char *unit;
    double lo, hi;           /* log10 search range (lo == hi: a switch) */
    unsigned kinds;          /* bit per dm_data_kind that can see it */
    int nparam;              /* 0 (a switch), 1, or 3 (one per chain) */
    int linear;              /* parameters fitted as they are (may be negative), from 0 */
} dm_candidate;

const dm_candidate *dm_candidates(int *count);
const dm_candidate *dm_candidate_find(const char *name);

/* Apply effect `name` with its parameter values v[nparam] (ignored for
 * switches) to a robot. A name that is not a candidate is set as the robot
 * file's [effects] key of that name with the value v[0] (so every effect
 * can be synthesised); the robot-file parser refuses unknown keys. */
int dm_effect_apply(dm_robot *robot, const char *name, const double *v, dm_error *err);

typedef struct dm_fit {
    int ncand;                   /* 1 or 2 effects */
    const dm_candidate *cand[2];
    double value[2][3], sigma[2][3]; /* per effect: fitted values, 1-sigma uncertainties */
    double train_chi2, held_chi2, held_rms, gain_percent, score;
    int ok;                      /* 0 when the fit failed (reported, never fatal) */
} dm_fit;

typedef struct dm_diagnosis {
    int n_train, n_held, sigma_known;
    double base_train_chi2, base_held_chi2, base_held_rms, base_score;
    int significant;             /* baseline misfit beyond the noise */
    int nrank;
    dm_fit rank[DM_DIAG_MAXCAND]; /* single effects, best first */
    dm_fit best;                 /* the verdict: one or two effects */
    int found;                   /* best beats the noise */
    int ntie, tie[DM_DIAG_MAXCAND]; /* ranks (>0) whose score is within DM_DIAG_TIE of
                                    rank 0: effects these data cannot tell apart */
} dm_diagnosis;

typedef struct dm_diagnose_opts {
    int na, nb;                  /* mesh (0: the robot's) */
    int pairs;                   /* try a second effect (default 1) */
    int threads;                 /* fits run in parallel (0: OpenMP's default); the
                                    result does not depend on it */
} dm_diagnose_opts;

int dm_diagnose(const dm_robot *robot, const dm_dataset *data, const dm_diagnose_opts *opts,
                dm_diagnosis *out, dm_error *err);

/* The robot with the fitted effects of `fit` applied. */
int dm_fit_apply(const dm_robot *robot, const dm_fit *fit, dm_robot *out, dm_error *err);

#endif
