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
 * platform's velocity as the model has it (3-point differences, second
 * order at the ends too, of the commanded samples plus the model's
 * predicted elastic error). The terms are linear in the nuisances, so each
 * model's nuisances are the weighted least squares on its training samples
 * (variable projection: the same optimum as fitting them jointly with the
 * effect), applied unchanged to the held-out ones, in the combinations the
 * data determine (dm_nuisance_seen: a straight path cannot show a rotation
 * about itself, a plane circle cannot tell the rotation about its axis
 * from the clock offset); the others are left at zero and what the data
 * determine of them is reported as combinations. Neglected: the
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

/* Whether a combination of the nuisances is determined (fitted) by m
 * samples: eig, its eigenvalue of the noise-weighted normal matrix with
 * unit diagonal (columns scaled to unit norm), eig_max the largest. It is
 * when its 1-sigma moves each nuisance's own term by less than the noise
 * RMS over the samples (eig m > 1), and eig is above round-off. The fit
 * (dm_nuisance_apply), the verdict's prediction check and plan use it. */
int dm_nuisance_seen(double eig, double eig_max, int m);

/* A combination of nuisances that the data determine although its parts
 * are not: value = x_ref + sum_{k != ref} coef[k] x_k, in the unit of
 * nuisance ref (coef[ref] = 1). */
typedef struct dm_nuisance_combination {
    int ref;
    double coef[DM_NUISANCE_MAX], value, sigma;
} dm_nuisance_combination;

/* A fit of the nuisances: values, 1-sigma (INFINITY: not determined, left
 * at zero), how many combinations the data see, and the determined
 * combinations of the undetermined nuisances (on a plane circle: the clock
 * offset with the rotation about the circle's axis). */
typedef struct dm_nuisance_fit {
    int n, nseen, ncombination;
    double value[DM_NUISANCE_MAX], sigma[DM_NUISANCE_MAX];
    dm_nuisance_combination combination[DM_NUISANCE_MAX];
} dm_nuisance_fit;

/* Every 1-sigma of fit (nuisances and combinations) times factor. */
void dm_nuisance_fit_scale(dm_nuisance_fit *fit, double factor);

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

/* The reader's placement of a '# frame: tracker' run redone on the
 * samples not held out (held: per sample, whole times): value[i], for
 * every sample, is measured - commanded with the rigid transform that
 * takes the training positions closest to the commanded ones (Kabsch).
 * The reader places the frame on every sample, the held-out ones too, so
 * a baseline without nuisances judged on it has seen the data it is
 * judged on; this one has not. Returns 1 when placed; 0 (value[i] the
 * sample's value unchanged) for runs not in a tracker frame or whose
 * training part lies on a line. */
int dm_nuisance_place_on(const dm_dataset *data, const char *held, double *value);

#endif
