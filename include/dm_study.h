/* dm_study — a parameter study (Chen et al. 2018, figures 5-7): the same
 * trajectory run for every value, or pair of values, of one or two robot
 * keys, giving Chen's mean error (eq. 27) and the peak error of each.
 *
 * The combinations run in parallel, each on its own copy of the robot (its
 * keys set with dm_robot_set, the path made for that robot): the results
 * do not depend on the thread count. A combination that fails (a value the
 * robot refuses, an unreachable path) keeps its status and message and NaN
 * errors; the others stand. */
#ifndef DM_STUDY_H
#define DM_STUDY_H

#include "dm_error.h"
#include "dm_integrate.h"
#include "dm_progress.h"
#include "dm_robot.h"

/* N evenly spaced values of a robot key ("arm.side", SI units) from
 * `from` to `to` (N = 1: `from` alone). */
typedef struct dm_study_axis {
    char key[64];
    double from, to;
    int count; /* 1..1000 */
} dm_study_axis;

#define DM_STUDY_MAXAXIS 2

typedef struct dm_study {
    int naxis;                             /* 1 or 2 */
    dm_study_axis axis[DM_STUDY_MAXAXIS];
    const char *path;                      /* a trajectory spec (dm_traj_make) */
    dm_integ_opts opts;                    /* each run's */
    int threads;                           /* parallel runs (dm_threads_count) */
    /* progress (dm_progress.h), NULL: none. One stage, "trajectory runs",
     * counting the runs' time steps (combinations when the path cannot be
     * made with the given robot). */
    dm_progress_fn progress;
    void *progress_user;
} dm_study;

typedef struct dm_study_cell {
    double mean_error_m, peak_error_m; /* NaN when status != DM_OK */
    int status;
    char msg[256];                     /* "ok" or the run's error */
} dm_study_cell;

/* "SECTION.KEY=FROM:TO:N" into *axis: -1 when it is not one. */
int dm_study_axis_parse(const char *spec, dm_study_axis *axis);

/* The i-th value of an axis. */
double dm_study_value(const dm_study_axis *axis, int i);

/* Combinations of the study: axis[0].count * axis[1].count (or the first's). */
int dm_study_cells(const dm_study *study);

/* Every combination, row-major (the first axis's index i, the second's j:
 * cells[i * n2 + j]). DM_EINVAL before any run when a key is not one the
 * robot has (naming it); the runs' own failures are the cells'. */
int dm_study_run(const dm_robot *robot, const dm_study *study, dm_study_cell *cells,
                 dm_error *err);

#endif
