/* dm_synth — synthetic measured data: what the model (with any effects)
 * predicts at drawn poses or along a path, plus seeded Gaussian noise. */
#ifndef DM_SYNTH_H
#define DM_SYNTH_H

#include <stdint.h>

#include "dm_error.h"
#include "dm_measure.h"
#include "dm_rng.h"
#include "dm_robot.h"

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
    int force_long;     /* run even beyond DM_MAX_WORK_S or DM_MAX_BYTES (dm_check_size) */
} dm_synth_opts;

int dm_synthesize(const dm_robot *robot, const dm_synth_opts *opts, dm_dataset *data,
                  dm_error *err);

#endif
