/* dm_diagnose — what the model gets wrong about measured data, and why.
 *
 * Residuals r = measured - predicted, normalised by each sample's sigma.
 * For every candidate effect of docs/model.md §6 (the rows of the effect
 * table, dm_effects.h, that the data's kind can see) the effect's parameters are
 * fitted by nonlinear least squares (cminpack lmdif, parameters in log10;
 * geometry errors as they are, by the chord method) on a training part of
 * the data and scored on the held-out rest: poses whose index is 2 mod 3
 * (modal, static) or the last third of the time (tracker). For tracker data
 * the union of the six geometry families (18 parameters) is a candidate too,
 * fitted in the combinations the data can see (truncated SVD).
 *
 * Score: held-out chi-square (without sigma: N ln(chi2/N)) plus a BIC-like
 * penalty p ln N (p: parameters fitted); scores within DM_DIAG_TIE tie. An
 * effect is found when it lowers the score by more than 9 + ln N; a second
 * one joins it (forward selection) when that lowers the score by as much
 * again. The simpler of two nested or look-alike candidates wins unless the
 * other scores better by DM_DIAG_CLEAR: a global effect against its
 * per-chain variants, one geometry family against their union.
 *
 * Found is not explained: the verdict names a cause only when the found
 * fit's held-out residual is consistent with the noise (dm_noise_test).
 * Gain (%) = 100 (1 - sqrt(e_after / e_before)) on the held-out samples, with
 * e = max(chi2/N - 1, 0) the misfit beyond the noise: the share of the
 * model's error amplitude that the effect removes (without sigma: 100 (1 -
 * RMS_after / RMS_before)).
 *
 * Nor is compensated explained: on a tracker run with nuisances, a model
 * that fits only because its nuisances moved far from the baseline's is
 * never the verdict (dm_nuisance_shift); the verdict reports it set aside. */
#ifndef DM_DIAGNOSE_H
#define DM_DIAGNOSE_H

#include "dm_effects.h"
#include "dm_measure.h"
#include "dm_modal.h"
#include "dm_nuisance.h"
#include "dm_pairing.h"
#include "dm_progress.h"
#include "dm_robot.h"

#define DM_DIAG_MAXV DM_EFFECTS_MAXV /* parameters of one effect (dm_effects.h) */
#define DM_DIAG_MAXP 18    /* free parameters of a fit */
#define DM_DIAG_MAXCAND DM_EFFECTS_MAXROWS /* candidate effects: rows of the effect table */
#define DM_DIAG_TIE 2.0    /* score difference below which two effects tie */
#define DM_DIAG_CLEAR 6.0  /* "strong" evidence (Kass & Raftery, on the BIC scale): what a
                              per-chain variant must gain over its global effect */
#define DM_DIAG_BAND 0.001 /* the noise test rejects an exact model at most this often: the
                              test suite diagnoses ~100 exact models, and at 1 % two of its
                              48 survey cases were called unexplained by pure noise */
#define DM_DIAG_DETERMINED 0.1 /* a combination is determined when its 1-sigma is at most
                                  this (relative, or in units of the candidate's scale) */

/* How far a model's tracker nuisances (dm_nuisance.h) moved from where
 * the baseline put them, both fitted on the training samples, and
 * whether the model therefore compensates rather than explains. The move
 * delta shifts the fitted positions by N delta (N: the nuisances'
 * design); rms_m is that over the training samples, and `sigmas` the
 * move's Mahalanobis distance in the baseline's nuisance covariance (its
 * reported 1-sigma, scaled by its misfit). The statistical distance
 * cannot decide: a genuine effect with a rigid part (a clearance's
 * steady offset, the common part of arm-length errors) moves the
 * nuisances by hundreds of these sigma, because the baseline's nuisances
 * took that part. A model compensates when rms_m exceeds
 * dm_diagnosis.compensating_m (DM_DIAG_NUISANCE_MOVE_M, or the baseline's
 * whole misfit before any nuisance if larger) and, with its nuisances
 * held where the baseline put them, it fits the training samples no
 * better than the baseline (at_baseline_chi2 = |r + N delta|^2 >= the
 * baseline's, r its weighted residual): its effect is better only
 * because the frame, reflector or clock moved. Such a model is never the
 * verdict. */
#define DM_DIAG_NUISANCE_MOVE_M 5e-4 /* five times the geometry errors' scale (0.1 mm,
                                        dm_effects_param_scale): beyond the rigid offsets
                                        that errors at assembly tolerance give a Delta
                                        (docs/diagnosis.md, "How the diagnosis decides") */
typedef struct dm_nuisance_shift {
    int n;                       /* nuisances compared (0: none fitted) */
    double delta[DM_NUISANCE_MAX]; /* the model's nuisances minus the baseline's */
    double sigmas;               /* the move in the baseline's 1-sigma (Mahalanobis) */
    double rms_m;                /* |N delta|, RMS over the training samples (m) */
    double at_baseline_chi2;     /* training chi2 with the nuisances held at the baseline's */
    int compensating;
} dm_nuisance_shift;

typedef struct dm_fit {
    int ncand;                   /* 1 or 2 effects */
    const dm_effect *cand[2];
    double value[2][DM_DIAG_MAXV], sigma[2][DM_DIAG_MAXV]; /* fitted values, 1-sigma */
    double train_chi2, held_chi2, held_rms, gain_percent, score;
    int nfree;                   /* parameters fitted (geometry_errors: combinations seen) */
    int ok;                      /* 0 when the fit failed (reported, never fatal) */
    dm_nuisance_shift shift;     /* a tracker run with nuisances, in dm_diagnose (n 0 otherwise) */
} dm_fit;

/* Is the held-out residual of a fit consistent with the noise? A held-out
 * residual is noise plus what the error of the fitted parameters makes of
 * it, and the training data give that error's covariance: the statistic is
 * the prediction chi-square r' C^-1 r, C = I + J_h (J_t'J_t)^-1 J_h'
 * (weighted residuals r, Jacobians J of the held-out and training
 * samples), which is chi2_N for an exact model (linearised). Consistent:
 * it is <= the 1 - DM_DIAG_BAND/2 quantile of chi2_N (the upper end of its
 * central 99.9 % band), and every mode or axis group's chi2 <= its 1 -
 * DM_DIAG_BAND/(2G) quantile (Bonferroni over G groups), so that the whole
 * test rejects an exact model at most DM_DIAG_BAND of the time. Quantiles by
 * Wilson-Hilferty (at most 2.5 % above the exact ones from 3 samples up). */
#define DM_DIAG_MAXGROUP DM_MAX_MODES /* mode ranks (or 3 axes) */
typedef struct dm_noise_test {
    int n;                       /* held-out samples */
    double chi2, limit;          /* their prediction chi-square and its limit */
    double sigmas;               /* (chi2 - n) / sqrt(2 n): the excess in standard deviations */
    int ngroup;
    struct {
        int group;               /* mode rank (1 = lowest) or axis (0, 1, 2 = x, y, z) */
        int n;
        double chi2, limit;
    } group[DM_DIAG_MAXGROUP];
    int consistent;
    /* where the excess sits: the held-out poses (tracker: times) that carry
     * half of it, and their bounding box */
    int nregion, nposes;
    double lo[3], hi[3];         /* m */
    double t_lo, t_hi;           /* tracker: s */
} dm_noise_test;

/* What the data determine of a fit with several parameters: the singular
 * value decomposition of its Jacobian (parameters in scaled units, see
 * dm_effects_param_scale). Combination k (unit vector weight[k] over the
 * fit's parameters, effect by effect) has 1-sigma sigma[k], ascending; it
 * is determined when sigma[k] <= DM_DIAG_DETERMINED. */
typedef struct dm_ident {
    int n, ndetermined;
    double sigma[DM_DIAG_MAXP];
    double weight[DM_DIAG_MAXP][DM_DIAG_MAXP];
} dm_ident;

typedef struct dm_diagnosis {
    int n_train, n_held, sigma_known;
    double base_train_chi2, base_held_chi2, base_held_rms, base_score;
    int significant;             /* baseline misfit beyond the noise */
    int nrank;
    dm_fit rank[DM_DIAG_MAXCAND]; /* single effects, best first */
    dm_fit best;                 /* the verdict: one or two effects */
    int found;                   /* best beats the noise */
    int explained;               /* found, sigma known and best consistent with the noise:
                                    best is the cause; otherwise it explains only part */
    int ntie, tie[DM_DIAG_MAXCAND]; /* ranks whose score is within DM_DIAG_TIE of best's:
                                    effects these data cannot tell apart */
    int has_simpler_choice;      /* best was preferred to `passed_over`, which scored better
                                    but by less than DM_DIAG_CLEAR (or its nesting need) */
    dm_fit passed_over;
    dm_noise_test noise;         /* of best, when found */
    dm_ident ident;              /* of best, when found */
    /* a tracker run's nuisances (dm_nuisance.h), fitted with every model
     * (the baseline's figures above are after them); never a cause */
    int nnuisance;               /* 0: none fitted */
    dm_nuisance_fit nuisance;    /* of best when found, else of the baseline */
    double raw_held_chi2, raw_held_rms; /* the baseline without nuisances, held out */
    double raw_train_rms;        /* the same on the training samples (m) */
    double compensating_m;       /* a nuisance move beyond this compensates (dm_nuisance_shift) */
    int nset_aside;              /* models that would have been the verdict but compensate: */
    dm_fit set_aside[2];         /* a single effect, then a pair, as the search met them */
    double nuisance_gain_percent; /* the nuisances' gain against that baseline */
    /* a modal survey with shapes or directions (dm_pairing.h): its modes
     * paired with the given robot's, then diagnosed as a plain survey of
     * the paired ones (unpaired ones left out); pairing.pair NULL
     * otherwise. The caller frees it: dm_pairing_free(&dg.pairing). */
    dm_pairing pairing;
} dm_diagnosis;

typedef struct dm_diagnose_opts {
    int na, nb;                  /* mesh (0: the robot's) */
    /* The mesh of the coarse scan that starts a lone log parameter's fit
     * (its 13 or 25 predictions; the fit itself, from the scan's best
     * point, is at na, nb). 0: half the mesh, rounded up, but at least 2
     * (and at most the mesh): 4,4 scans at 2,2, whose first six
     * frequencies are within 0.4 % of the converged ones (docs/
     * validation.md), far finer than the scan's steps of the parameter. */
    int scan_na, scan_nb;
    int pairs;                   /* try a second effect (default 1) */
    int threads;                 /* fits run in parallel (0: OpenMP's default); the
                                    result does not depend on it */
    int force_long;              /* run even when estimated beyond DM_WORK_LIMIT
                                    (else refused before any fit, dm_work_check) */
    /* dm_diagnose's progress (dm_progress.h), NULL: none. Units: fits
     * (a fit is 7 to 100 predictions of the data; the count is reported
     * again after each prediction, so the clock moves), in the stages
     * "single effects", "geometry union" (when the families are fitted
     * together), "second effect screen", "pair fits", "pair with the
     * global effect" (when a per-chain effect must beat its global one),
     * then "verdict checks" (predictions: one per parameter of the
     * verdict and one more). */
    dm_progress_fn progress;
    void *progress_user;
} dm_diagnose_opts;

int dm_diagnose(const dm_robot *robot, const dm_dataset *data, const dm_diagnose_opts *opts,
                dm_diagnosis *out, dm_error *err);

/* Fit effects names[0..n-1] (n = 1 or 2) jointly on all of the data (no
 * hold-out; held-out figures of `fit` stay 0), as dm_diagnose fits them:
 * values, 1-sigma uncertainties, train_chi2. start: the values to start
 * from (NULL: a scan for one log parameter, mid-range otherwise). For
 * experiment planning and its checks. */
int dm_fit_effects(const dm_robot *robot, const dm_dataset *data, const char *const *names,
                   int n, const double start[][DM_DIAG_MAXV], const dm_diagnose_opts *opts,
                   dm_fit *fit, dm_error *err);

/* The robot with the fitted effects of `fit` applied. */
int dm_fit_apply(const dm_robot *robot, const dm_fit *fit, dm_robot *out, dm_error *err);

#endif
