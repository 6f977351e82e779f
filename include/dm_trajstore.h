/* dm_trajstore — a trajectory run's store (`deltamap trajectory --out
 * NAME.zarr`): its layout in the map store's format (dm_store), defined
 * once for the writer and for the check of a store against it.
 *
 * The run is written once, whole (no resume): one array per quantity along
 * time, chunked by DM_TRAJSTORE_CHUNK samples. The group's attributes
 * record the robot, the path, the number of samples and of frequencies,
 * from which every array's metadata follows. */
#ifndef DM_TRAJSTORE_H
#define DM_TRAJSTORE_H

#include "dm_integrate.h"
#include "dm_store.h"
#include "dm_sweep.h"

#define DM_TRAJSTORE_TITLE "deltamap trajectory run"
#define DM_TRAJSTORE_CHUNK 4096
#define DM_TRAJSTORE_NARR 8

/* The layout of a run of n >= 1 samples with nfreq frequencies each (0..64)
 * of robot `robot` along path `traj`, at path: arrays time, position,
 * error, error_norm, tool_error, frequencies_hz, coupling_index_log10,
 * coupling_index_change_log10, in that order. Release with
 * dm_store_release. */
void dm_trajstore_define(dm_store *store, const char *path, const char *robot, const char *traj,
                         long n, int nfreq);

/* The group attributes are a trajectory run's (their title). */
int dm_trajstore_is(json_t *group_attributes);

/* Check the trajectory store at path whose group attributes are attrs:
 * the group's and every array's metadata byte for byte against the layout
 * its attributes record (with repair, the arrays' metadata that differ
 * are rewritten; the group's never), every chunk of every array against
 * its checksum; each damaged file reported. A store of another version
 * (or whose attributes record no layout) is read as its metadata says,
 * its chunks checked. Fills check (dm_sweep.h) as dm_sweep_check_open
 * does. */
int dm_trajstore_check(const char *path, json_t *attrs, int repair, dm_sweep_damage_fn report,
                       void *user, dm_sweep_check *check, dm_error *err);

/* A run's samples, kept as they come for its store (zero-initialise). */
typedef struct dm_trajstore_samples {
    long n, cap;
    dm_integ_sample *s;
    double *change; /* per sample: the coupling index's change against the nominal robot */
} dm_trajstore_samples;

/* Keep one sample and its coupling change: non-zero when out of memory. */
int dm_trajstore_keep(dm_trajstore_samples *samples, const dm_integ_sample *s, double change);
void dm_trajstore_samples_free(dm_trajstore_samples *samples);

/* Write the run of robot `robot` along path `traj` as the store at path,
 * whole or not at all: built as PATH.tmp.PID and renamed over PATH,
 * replacing an earlier run's store (a directory whose zarr.json is a
 * deltamap trajectory run) but nothing else (DM_EINVAL naming it). */
int dm_trajstore_write(const char *path, const char *robot, const char *traj,
                       const dm_trajstore_samples *samples, dm_error *err);

#endif
