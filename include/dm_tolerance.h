/* dm_tolerance — Monte Carlo of the platform error over manufacturing
 * errors drawn from tolerance bands and random joint-clearance states
 * (Zheng & Zhang 2017), at one commanded pose, with the first-order
 * sensitivity of the error to each tolerance.
 *
 * One sample: every geometry error of the robot file (per chain: arm and
 * rod length, base and platform radius, mounting angle, actuator offset)
 * plus a draw within +- its tolerance (uniform in [-tol, tol], or normal
 * with sigma = tol/3 truncated at +-tol); and a clearance state drawn in
 * each joint's dead band, as Zheng models it: a revolute (actuator) joint
 * takes a radial offset in the plane normal to its axis, of normal
 * magnitude |N(0, c_r/3)| truncated at c_r, in a uniform direction, and an
 * axial offset uniform in [0, v] along its axis (the robot file's
 * actuator_clearance_radial c_r and _axial v); a rod-end ball joint of
 * radial clearance c takes an offset of the same normal magnitude law on c
 * in a uniform direction in space, of which its rod's length sees the
 * component along the rod (uniform in [-1, 1] times the magnitude); each
 * chain's effective rod length changes by the mean over its two rods of
 * the sum over their two ends. The platform goes where the real chains
 * close (dm_kin_pose_play); with `flexibility` the static elastic error
 * under gravity of the model built at that real configuration is added.
 * The error of a sample is the translation of the platform centre, real -
 * commanded (m), and its norm.
 *
 * Random numbers are counter-based: sample i's draws come from a stream
 * seeded by (dm_tolerance_pose_seed(seed, P), i) alone, so results are
 * bit-identical for any number of threads and any order of the samples,
 * and a sweep's point is the same run as the one at its pose (each pose
 * has its own draws: a map's noise is independent from pose to pose).
 *
 * The linearised model: the error at the mean state (the file's errors,
 * the mean clearance state: axial v/2, the rest 0), and its derivative
 * S_p with respect to each drawn parameter p by central differences; the
 * predicted covariance of the error is sum_p S_p S_p' var(p). */
#ifndef DM_TOLERANCE_H
#define DM_TOLERANCE_H

#include <stdint.h>

#include "dm_error.h"
#include "dm_progress.h"
#include "dm_robot.h"

typedef enum { DM_TOL_UNIFORM = 0, DM_TOL_NORMAL = 1 } dm_tol_dist;

/* The tolerance classes (the geometry errors of dm_effects, then the three
 * clearances, whose size is the robot file's). */
enum {
    DM_TOL_ARM_LENGTH = 0, DM_TOL_ROD_LENGTH, DM_TOL_BASE_RADIUS, DM_TOL_PLATFORM_RADIUS,
    DM_TOL_THETA, DM_TOL_ALPHA0, DM_TOL_CLEARANCE, DM_TOL_ACT_AXIAL, DM_TOL_ACT_RADIAL,
    DM_TOL_NCLASS
};
#define DM_TOL_NGEOM 6

/* "arm_length", ..., "theta_deg", "alpha0_deg", "clearance", ... */
const char *dm_tolerance_class_name(int cls);

typedef struct dm_tolerance_spec {
    double tol[DM_TOL_NGEOM]; /* +- band of each geometry error, m or rad, >= 0, same per chain */
    dm_tol_dist dist;
    long samples;             /* >= 1 */
    uint64_t seed;
    double spec_m;            /* accuracy spec, > 0; 0: none */
    int flexibility;          /* add the static elastic error under gravity */
    int na, nb;               /* mesh of the flexible model (0: the robot's) */
    int force_long;           /* run even when estimated beyond DM_TOLERANCE_MAX_SECONDS */
    /* dm_tolerance_pose's progress (dm_progress.h), NULL: none. Stages:
     * "linearisation" (its 61 model evaluations), then "Monte Carlo" (its
     * samples). Not a setting of the result, nor of a sweep's store (a
     * sweep's points report nothing). */
    dm_progress_fn progress;
    void *progress_user;
} dm_tolerance_spec;

void dm_tolerance_spec_default(dm_tolerance_spec *spec);

/* Estimated single-thread seconds of a run (calibrated on this project's
 * development machine), and the limit above which it is refused
 * (dm_work_check, DM_ETOOBIG) unless spec.force_long. */
#define DM_TOLERANCE_MAX_SECONDS 3600.0
double dm_tolerance_estimate_s(const dm_robot *robot, const dm_tolerance_spec *spec);

/* The seed of the sample streams at commanded position P (m): a function
 * of the seed and of P rounded to 1 nm, so a pose typed with fewer digits
 * than a grid computed it (0.05 for 0.05000000000000002) draws the same
 * states. What dm_tolerance_pose and dm_tolerance_samples use. */
uint64_t dm_tolerance_pose_seed(uint64_t seed, const double P[3]);

/* Check the spec before any work: DM_EINVAL naming the field. */
int dm_tolerance_check(const dm_robot *robot, const dm_tolerance_spec *spec, dm_error *err);

typedef struct dm_tolerance_result {
    long samples;
    double mean_error_m, std_error_m, stderr_mean_m; /* of |e| */
    double p95_error_m, max_error_m;                 /* P95: linear between order statistics */
    double p_exceed_spec;                            /* share of samples with |e| > spec (NaN: no spec) */
    double mean_m[3], std_m[3];                      /* of the components */
    double deterministic_m[3], deterministic_error_m;/* at the mean state */
    double predicted_std_m[3];                       /* linearised, per component */
    double predicted_std_error_m;                    /* of |e|, linearised along e_det (NaN if e_det = 0) */
    /* per class: d|e| per unit of tolerance (rms over its parameters and
     * the draw's law, m per m or per rad) and the standard deviation it
     * contributes (m) */
    double sensitivity[DM_TOL_NCLASS], std_contribution_m[DM_TOL_NCLASS];
    int dominant;                                    /* the class contributing most; -1: none */
} dm_tolerance_result;

/* The Monte Carlo at commanded position P (m) on `threads` OpenMP threads
 * (1 inside a caller's own parallel region, e.g. a sweep's point). */
int dm_tolerance_pose(const dm_robot *robot, const dm_tolerance_spec *spec, const double P[3],
                      int threads, dm_tolerance_result *res, dm_error *err);

/* The errors of samples [first, first + count) (3 per sample, m) on one
 * thread: what dm_tolerance_pose aggregates (tests, other statistics). */
int dm_tolerance_samples(const dm_robot *robot, const dm_tolerance_spec *spec, const double P[3],
                         long first, long count, double *e, dm_error *err);

#endif
