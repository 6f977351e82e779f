/* dm_measure — measured data (docs/measured-data.md) and what the
 * model predicts for it.
 *
 * Kinds: modal surveys (frequency of mode rank j at a pose), static
 * deflection surveys (platform deflection under an added force at P) and
 * tracker trajectories (measured minus commanded platform position along a
 * path). Files are CSV with a header row, '#' comments anywhere, SI units,
 * columns found by name; a bad cell is an error naming file, line and
 * column. A dataset is a plain value owned by its caller. */
#ifndef DM_MEASURE_H
#define DM_MEASURE_H

#include <stdint.h>
#include <stdio.h>

#include "dm_error.h"
#include "dm_robot.h"

typedef enum { DM_DATA_MODAL = 0, DM_DATA_STATIC = 1, DM_DATA_TRACKER = 2 } dm_data_kind;

/* One measured number (a frequency, or one component of a deflection or a
 * tracker error) with its pose and its standard deviation. */
typedef struct dm_sample {
    double P[3];      /* pose (m); for tracker data: the commanded position */
    double value;     /* measured: Hz, or m */
    double sigma;     /* standard deviation; 0 = not given */
    double force[3];  /* static: added force at P (N) */
    double t;         /* tracker: time (s) */
    int mode;         /* modal: rank, 1 = lowest */
    int comp;         /* static/tracker: 0, 1, 2 = x, y, z */
    int pose_id;      /* samples of one pose (or one tracker time) share it */
    int line;         /* line in the file */
} dm_sample;

typedef struct dm_dataset {
    dm_data_kind kind;
    char source[512];
    char robot[256];   /* "# robot: NAME" header, or "" */
    int n, cap, npose;
    dm_sample *s;
} dm_dataset;

const char *dm_data_kind_name(dm_data_kind kind);
int dm_data_kind_parse(const char *name, dm_data_kind *kind);

/* Read a file; the kind is recognised from its columns. */
int dm_dataset_read(const char *path, dm_dataset *data, dm_error *err);

/* The same for a measurement template (as `deltamap plan` writes): the
 * measured values (freq_hz, dx..dz, x_meas..z_meas) may be empty and read
 * as 0; poses, modes, forces, times and sigma are as in a data file. */
int dm_dataset_read_template(const char *path, dm_dataset *data, dm_error *err);
int dm_dataset_write(const dm_dataset *data, FILE *out);
/* Append one sample (the array grows as needed); DM_ENOMEM names the
 * dataset. */
int dm_dataset_push(dm_dataset *d, const dm_sample *s, dm_error *err);
void dm_dataset_free(dm_dataset *data);

/* Model predictions for every sample (same order), with the robot's mesh
 * (or na, nb when > 0). Unreachable poses and mode ranks beyond the model
 * are errors naming the sample's line. One run of a dm_predictor made for
 * it. */
int dm_predict(const dm_robot *robot, const dm_dataset *data, int na, int nb, double *pred,
               dm_error *err);

/* A prediction workspace: the predictions of one dataset for many robots
 * (a fit's every evaluation), with the model, eigen and static workspaces
 * (tracker data: the commanded path) made once and reused. The dataset
 * must outlive it and not change; the mesh is that of `robot` (or na, nb
 * when > 0) for every run. One per thread. */
typedef struct dm_predictor dm_predictor;

dm_predictor *dm_predictor_new(const dm_robot *robot, const dm_dataset *data, int na, int nb,
                               dm_error *err);

/* Predictions with this robot: bit for bit those of dm_predict (every run
 * starts the eigen solver cold). The robot may differ from run to run in
 * any value; when its effects change the model's DOFs (a compliant base,
 * joint springs) the workspace is made again for the new size. */
int dm_predictor_run(dm_predictor *p, const dm_robot *robot, double *pred, dm_error *err);

/* Predict only the first n samples (whole poses, or whole tracker times)
 * from now on; the dataset's n restores all. A tracker run's first part is
 * predicted as dm_predict predicts a file cut there: along the path
 * through its own commanded samples. */
void dm_predictor_window(dm_predictor *p, int n);

void dm_predictor_free(dm_predictor *p);

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

/* What a command implies, judged before any work: refused beyond
 * DM_MAX_WORK_S of estimated wall time or DM_MAX_BYTES of memory unless
 * forced (the CLI's --force-long). Estimates come from the costs measured
 * on this project's development machine (2 cores, x86-64): a modal pose or
 * a tracker step about 2.5 ms and a static pose (with and without the
 * force) 5 ms at 210 DOF, 15 % of it fixed and the rest growing as n^2
 * (0.4 ms per tracker step at 48 DOF). */
#define DM_MAX_WORK_S (4 * 3600.0)
#define DM_MAX_BYTES 2e9

/* Seconds on one thread of predicting `count` poses (tracker: integration
 * steps) of data of this kind with this mesh (0: the robot's). */
double dm_predict_cost_s(const dm_robot *robot, dm_data_kind kind, double count, int na, int nb);

/* The same for one dm_predict of `data` (tracker: its duration at the
 * step dm_predict takes), and the bytes that prediction holds. */
double dm_predict_estimate_s(const dm_robot *robot, const dm_dataset *data, int na, int nb,
                             double *bytes);

/* DM_EINVAL "WHAT: about H hours of work [and G GB of memory] (the limit
 * is ...): HINT, or force it" when est_s or bytes exceed the limits and
 * !force; DM_OK otherwise. */
int dm_check_size(const char *what, double est_s, double bytes, const char *hint, int force,
                  dm_error *err);

/* Is err such a refusal? (The CLI then names its option that forces.) */
int dm_size_refused(const dm_error *err);

/* splitmix64-based generator: uniform in [0,1) and standard normal. */
typedef struct dm_rng {
    uint64_t state;
} dm_rng;
double dm_rng_uniform(dm_rng *rng);
double dm_rng_normal(dm_rng *rng);

#endif
