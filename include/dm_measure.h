/* dm_measure — measured data (docs/measured-data.md): kinds, samples,
 * datasets read, validated and written. What the model predicts for them
 * is dm_predict.h; synthetic data, dm_synth.h.
 *
 * Kinds: modal surveys (frequency of mode rank j at a pose), static
 * deflection surveys (platform deflection under an added force at P) and
 * tracker trajectories (measured minus commanded platform position along a
 * path). Files are CSV with a header row, '#' comments anywhere, SI units,
 * columns found by name; a bad cell is an error naming file, line and
 * column. A dataset is a plain value owned by its caller. */
#ifndef DM_MEASURE_H
#define DM_MEASURE_H

#include <stdio.h>

#include "dm_error.h"

typedef enum { DM_DATA_MODAL = 0, DM_DATA_STATIC = 1, DM_DATA_TRACKER = 2 } dm_data_kind;

/* One measured number (a frequency, or one component of a deflection or a
 * tracker error) with its pose and its standard deviation. */
typedef struct dm_sample {
    double P[3];      /* pose (m); for tracker data: the commanded position */
    double value;     /* measured: Hz, or m */
    double sigma;     /* standard deviation; 0 = not given */
    double force[3];  /* static: added force at P (N) */
    double t;         /* tracker: time (s) */
    int mode;         /* modal: rank, 1 = lowest (with pairing data: among the measured) */
    int dir;          /* modal: dominant direction + 1 (dm_direction), 0 = not given */
    int comp;         /* static/tracker: 0, 1, 2 = x, y, z */
    int pose_id;      /* samples of one pose (or one tracker time) share it */
    int line;         /* line in the file */
} dm_sample;

/* A tracker run's nuisances (docs/measured-data.md, dm_nuisance.h): what
 * its header lines say. Without '# frame:' none is fitted (the file's
 * positions are the platform centre's, in the base frame, on the robot's
 * clock). */
typedef struct dm_nuisance_spec {
    int on;              /* '# frame:' given: fit the nuisances with every model */
    int tracker_frame;   /* '# frame: tracker': measured positions were in the tracker's
                            frame, placed in the base frame on reading (R, d) */
    int clock_rate;      /* '# clock: rate': fit a clock-rate error too */
    int line;            /* the '# frame:' line */
    double reflector[3]; /* '# reflector: X, Y, Z': nominal reflector offset from the
                            platform centre (m, platform axes = base axes), subtracted */
    double R[9], d[3];   /* tracker frame: base = R m + d (row-major R), from reading */
    double align_rms;    /* that alignment's RMS misfit (m) */
} dm_nuisance_spec;

/* A modal survey's sensor ('# sensor:' line): where on the robot, which
 * way. Bodies: 0..2 arm i + 1 (at: fraction from its root to its elbow),
 * 3 + 2 i + s rod s (0 = a, 1 = b) of chain i + 1 (at: fraction from its
 * upper end), DM_BODY_PLATFORM (at: offset from the centre, m). */
#define DM_MAX_SENSORS 24
#define DM_BODY_PLATFORM 9
typedef struct dm_sensor {
    char name[32];
    int body;
    double at[3];
    double dir[3];     /* unit vector, base axes */
    int line;
} dm_sensor;

typedef struct dm_dataset {
    dm_data_kind kind;
    char source[512];
    char robot[256];   /* "# robot: NAME" header, or "" */
    int n, cap, npose;
    dm_sample *s;
    dm_nuisance_spec nuisance; /* tracker runs only */
    /* modal surveys with a `dir` or `shape_NAME` column: pair the measured
     * modes with the model's (dm_pairing.h) instead of taking `mode` as
     * the model's rank */
    int pair;
    int nsensor;
    dm_sensor sensor[DM_MAX_SENSORS];
    double *shape;     /* nsensor values per sample (the shape at each sensor), or NULL */
    int shape_cap;
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

#endif
