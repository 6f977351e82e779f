/* dm_synth — synthetic measured data: what the model (with any effects)
 * predicts at drawn poses or along a path, plus seeded Gaussian noise. */
#ifndef DM_SYNTH_H
#define DM_SYNTH_H

#include <stdint.h>

#include "dm_error.h"
#include "dm_measure.h"
#include "dm_rng.h"
#include "dm_robot.h"
#include "dm_trajectory.h"

/* Synthetic data from `robot` (with any effects already applied): npose
 * poses drawn in the workspace around home (modal, static), or the path
 * `path` sampled every 1 ms (tracker), plus Gaussian noise of standard
 * deviation `noise` (Hz or m). Deterministic for a seed. */
typedef struct dm_synth_opts {
    dm_data_kind kind;
    int npose;          /* modal/static poses (default 16) */
    int modes;          /* modal: ranks 1..modes (default 6) */
    double noise;       /* Hz or m */
    uint64_t seed;
    double force_n;     /* static: magnitude of the added force (default 50 N) */
    const char *path;   /* tracker: trajectory spec (default: a circle about home) */
    int na, nb;
    int force_long;     /* run even beyond DM_WORK_LIMIT (dm_work_check) */
    /* modal: a survey as a modal test gives it (dm_pairing_survey): each
     * mode's dominant direction (`dir`), with `sensors` its shape at the
     * default sensors, mode rank `drop_mode` missed, a local mode at
     * extra_hz (direction extra_dir) added; `modes` counts the model's
     * modes before the drop */
    int pairing, sensors, drop_mode, extra_dir;
    double extra_hz;
} dm_synth_opts;

int dm_synthesize(const dm_robot *robot, const dm_synth_opts *opts, dm_dataset *data,
                  dm_error *err);

/* The same at a template's samples (docs/measured-data.md: e.g. a plan's
 * poses, forces and sigmas; the data have its kind, opts.kind is not
 * read): its predictions plus noise (dm_plan_observe), refused first
 * beyond DM_WORK_LIMIT unless opts.force_long. */
int dm_synth_at(const dm_robot *robot, const dm_dataset *tmpl, const dm_synth_opts *opts,
                dm_dataset *data, dm_error *err);

/* The parts synth and plan's designs share. */

/* A pose drawn uniformly from the box about home where synthetic surveys
 * lie (+-0.3 arm lengths across, +-0.15 in height), reachable with
 * cond(J) <= the robot's singular_cond; DM_EUNREACHABLE after 1000 draws. */
int dm_synth_draw_pose(const dm_robot *robot, dm_rng *rng, double P[3]);

/* Append the samples of one pose of a survey of d's kind: modal, mode
 * ranks 1..modes (0: 6); static, the three components of the deflection
 * under force_n newtons (0: 50) along u (any length; may be NULL for
 * modal). Measured values 0 (to be filled), this standard deviation. */
int dm_synth_pose_samples(dm_dataset *d, const double P[3], int pose_id, double sigma, int modes,
                          double force_n, const double *u, dm_error *err);

/* Append the tracker samples of n times 1 ms apart from t = 0 along the
 * path: the commanded positions, measured values 0 (to be filled), this
 * standard deviation; each time its own pose id. */
int dm_synth_path_samples(const dm_trajectory *traj, int n, double sigma, dm_dataset *data,
                          dm_error *err);

#endif
