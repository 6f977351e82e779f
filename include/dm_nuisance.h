/* dm_nuisance — what a laser-tracker run measures besides the robot.
 *
 * A tracker measures a reflector on the platform, in its own frame, on its
 * own clock. With '# frame:' in the file (docs/measured-data.md) every
 * model the diagnosis compares — the baseline too — is fitted together
 * with these nuisances, linearised about the file's nominal frame and
 * reflector offset:
 *
 *   measured - commanded = prediction + t + phi x (P - Pc) + v(t) (tau + rho t)
 *
 * t: the frame's translation plus the reflector's offset error (a Delta's
 * platform does not turn, so the two are one constant vector: only their
 * sum is determined, and it is reported as such); phi: the frame's small
 * rotation (rad) about the run's centroid Pc; tau: the tracker clock's
 * offset (s: a sample stamped t shows the robot at t + tau); rho: its rate
 * error (only with '# clock: rate'). P is the commanded position, v the
 * platform's velocity as the model has it (central differences of the
 * commanded samples plus the model's predicted elastic error). The terms are
 * linear in the nuisances, so each model's nuisances are the weighted least
 * squares on its training samples (variable projection: the same optimum
 * as fitting them jointly with the effect), in the combinations the data
 * see (a straight path cannot show a rotation about itself). Neglected: the
 * platform's elastic rotation times the reflector offset (about 1e-4 rad x
 * the offset), and the acceleration's tau^2/2 term (|a| tau^2 / 2: 4e-7 m
 * for tau = 0.3 ms on a 0.05 m circle at 2 Hz). */
#ifndef DM_NUISANCE_H
#define DM_NUISANCE_H

#include "dm_error.h"
#include "dm_measure.h"

#define DM_NUISANCE_MAX 8

/* Nuisance parameters of a dataset: 0 (none), 7 or 8 (with the clock rate). */
int dm_nuisance_count(const dm_dataset *data);

/* Name and unit of nuisance k ("frame_translation_x", "m"). */
const char *dm_nuisance_name(int k);
const char *dm_nuisance_unit(int k);

/* A fit of the nuisances: values, 1-sigma (INFINITY: a combination the
 * data do not see), and how many combinations the data see. */
typedef struct dm_nuisance_fit {
    int n, nseen;
    double value[DM_NUISANCE_MAX], sigma[DM_NUISANCE_MAX];
} dm_nuisance_fit;

/* Fit the nuisances to the residuals of pred (weights w) on the samples
 * i < n that are not held out, and add their contribution to pred[i] for
 * every i < n (held-out samples too: the model's prediction). covscale
 * multiplies the covariance (the reduced chi-square when the fit
 * misfits). fit may be NULL. Returns DM_ENOMEM or DM_OK; without
 * nuisances pred is unchanged. */
int dm_nuisance_apply(const dm_dataset *data, int n, const char *held, const double *w,
                      double *pred, double covscale, dm_nuisance_fit *fit);

/* The nuisances fitted to the residuals of pred on every sample (weights
 * 1/sigma, 1 without), their contribution added to pred; the 1-sigma
 * scaled by max(1, chi2/dof) with sigma known, chi2/dof without (as a
 * diagnosis scales its fits). For residuals after the nuisances (compare).
 * DM_EINVAL (naming the file) for data without nuisances, DM_ENOMEM. */
int dm_nuisance_fit_all(const dm_dataset *data, double *pred, dm_nuisance_fit *fit,
                        dm_error *err);

/* The nuisances' design at samples i < n: N (n x dm_nuisance_count,
 * column-major), d(measured - commanded)/d(nuisance k) at sample i, about
 * the model's prediction pred. */
void dm_nuisance_design(const dm_dataset *data, int n, const double *pred, double *N);

/* On reading: the '# frame: tracker' alignment (the rigid transform that
 * takes the measured positions to the commanded ones plus the nominal
 * reflector offset, least squares, Kabsch) applied to every sample, and
 * the nominal offset subtracted. Refuses a commanded path on a line (the
 * rotation about it is not determined). */
int dm_nuisance_prepare(dm_dataset *data, dm_error *err);

#endif
