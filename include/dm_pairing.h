/* dm_pairing — measured modes paired with the model's (docs/measured-data.md,
 * "Mode shapes and pairing"): by MAC of the mode shapes at the sensors
 * where a survey gives shapes, by frequency and dominant direction where it
 * gives only directions; never by rank alone.
 *
 * At each pose the measured modes are assigned to the model's lowest K
 * modes (K = min(2 L + 2, DM_MAX_MODES, DOFs), L the highest measured
 * label) by an optimal assignment (Hungarian method) of least total cost
 * among the admissible pairs, a measured mode left unpaired costing
 * DM_PAIR_UNPAIRED, more than any admissible pair: the assignment pairs as
 * many measured modes as it can, then the cheapest way. A measured mode
 * with no admissible partner is reported unpaired, never forced; a model
 * mode no measured mode pairs with is skipped.
 *
 * By MAC: admissible when MAC >= DM_PAIR_MAC_MIN and the frequencies
 * differ by at most DM_PAIR_FREQ_TOL_MAC (relative to the model's); cost
 * (1 - MAC) + |f_meas - f_model| / f_model. By direction: admissible when
 * the dominant directions are the same and the frequencies differ by at
 * most DM_PAIR_FREQ_TOL; cost |f_meas - f_model| / f_model. A mode's
 * dominant direction is that of the six platform DOFs (x, y, z, rx, ry, rz)
 * holding the largest share of its modal kinetic energy (dm_modes'
 * direction); the measured one is the survey's `dir` column. */
#ifndef DM_PAIRING_H
#define DM_PAIRING_H

#include <stdint.h>

#include "dm_error.h"
#include "dm_measure.h"
#include "dm_rng.h"
#include "dm_robot.h"

#define DM_PAIR_MAC_MIN 0.7       /* below: the shapes are not the same mode */
#define DM_PAIR_FREQ_TOL_MAC 0.3  /* relative frequency window of a MAC pair */
#define DM_PAIR_FREQ_TOL 0.25     /* relative frequency window of a direction pair */
#define DM_PAIR_UNPAIRED 10.0     /* cost of leaving a measured mode unpaired */

typedef struct dm_pair {
    int sample;       /* index in the dataset read */
    int line;         /* its line in the file */
    int pose_id;
    int label;        /* the file's `mode`: rank among the measured modes */
    int model_mode;   /* paired model rank (1 = lowest); 0: unpaired */
    double freq_meas, freq_model; /* freq_model: 0 when unpaired */
    double mac;       /* by MAC: the pair's MAC (unpaired: the best one); else -1 */
    int dir_meas, dir_model;      /* dm_direction; -1: not given */
} dm_pair;

typedef struct dm_pairing {
    int n, npaired, npose, by_mac;
    dm_pair *pair;            /* n: one per measured mode, in the file's order */
    uint64_t *skipped;        /* npose: model ranks (bit r-1) below the pose's highest
                                 paired one that no measured mode pairs with */
} dm_pairing;

/* The pairing of data's modes (data->pair set) with those of `robot` (mesh
 * na, nb; 0: the robot's). Errors name the pose's line. */
int dm_pairing_make(const dm_robot *robot, const dm_dataset *data, int na, int nb,
                    dm_pairing *pairing, dm_error *err);
void dm_pairing_free(dm_pairing *pairing);

/* The paired samples as a plain survey: each paired sample with `mode` its
 * model rank, unpaired ones left out, no shapes; pose ids renumbered. */
int dm_pairing_apply(const dm_dataset *data, const dm_pairing *pairing, dm_dataset *out,
                     dm_error *err);

/* The model's k lowest modes at P: frequencies (Hz), dominant directions
 * and, for data's sensors, the shapes' values there (k x nsensor,
 * row-major; NULL: none wanted). */
int dm_pairing_model_modes(const dm_robot *robot, const dm_dataset *data, const double P[3],
                           int k, int na, int nb, double *freq, int *dir, double *shape,
                           dm_error *err);

/* The modal assurance criterion of two shapes of n values. */
double dm_pairing_mac(const double *a, const double *b, int n);

/* A synthetic survey made into one a modal test gives (dm_synth): at each
 * pose model mode `drop` (0: none) left out, a local mode the model lacks
 * added at extra_hz (0: none) with direction extra_dir, the modes
 * relabelled by measured rank, each given its dominant direction and, with
 * sensors, its shape at dm_pairing_default_sensors (exact, unit largest
 * value; the extra one orthogonal to the modes written). */
int dm_pairing_survey(const dm_robot *robot, int sensors, int drop, double extra_hz,
                      int extra_dir, int na, int nb, dm_rng *rng, dm_dataset *data,
                      dm_error *err);

/* Put the default sensor set on data (19 sensors: the platform centre x, y,
 * z, a point on the platform's rim along y, each elbow x, y, z and each
 * chain's first rod at mid-length along x and y). */
void dm_pairing_default_sensors(const dm_robot *robot, dm_dataset *data);

#endif
