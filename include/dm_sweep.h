/* dm_sweep — workspace maps: the frozen-configuration analysis (and the
 * standard move) on a grid of poses, in parallel, into a dm_store.
 *
 * The grid is a dm_grid (dm_grid.h). Tiles are chunks of the spatial grid; each
 * tile is computed by one thread with its own workspaces, so results do
 * not depend on the number of threads. An interrupted sweep keeps every
 * finished tile and resumes where it stopped.
 *
 * Several processes (on one host or many) may sweep into one store, each
 * computing one shard of the tiles (dm_shard.h): the store they make is
 * byte-identical to one process's, because a tile's values depend on the
 * grid alone (mode-tracking anchors are computed, the same, by every
 * process; each tile starts afresh). Store creation is atomic, so the
 * processes may start in any order or all at once. */
#ifndef DM_SWEEP_H
#define DM_SWEEP_H

#include <signal.h>

#include "dm_analysis.h"
#include "dm_grid.h"
#include "dm_integrate.h"
#include "dm_robot.h"
#include "dm_store.h"
#include "dm_tolerance.h"

enum dm_point_status {
    DM_POINT_OK = 0,
    DM_POINT_UNREACHABLE = 1,
    DM_POINT_NEAR_SINGULAR = 2, /* computed; cond(J) above the robot's threshold */
    DM_POINT_FAILED = 3,        /* singular structure or solver failure */
    DM_POINT_NOT_COMPUTED = 255
};

/* Where a running sweep is. */
typedef struct dm_sweep_progress {
    int phase;          /* DM_SWEEP_ANCHORS (mode tracking's references), then
                           DM_SWEEP_TILES */
    long done, total;   /* anchors or tiles of this run */
    long points_per_tile;
    double seconds;     /* since the sweep started */
    int final;          /* the phase is over */
} dm_sweep_progress;

enum { DM_SWEEP_ANCHORS = 0, DM_SWEEP_TILES = 1 };

enum { DM_SWEEP_FULL_MODEL = 0, DM_SWEEP_MEMBERS = 1, DM_SWEEP_AUTO = 2 };

typedef struct dm_sweep_opts {
    int k;              /* frequencies per point (default 10) */
    int na, nb;         /* mesh (0: the robot's) */
    int tile[3];        /* tile shape (0: automatic) */
    int threads;        /* 0: OpenMP default */
    int dynamic;        /* standard moves along X, Y, Z (default 1) */
    /* The eigen engine, part of the fingerprint. DM_SWEEP_MEMBERS: every
     * point served by the member bases (dm_analysis_use_members, built
     * once and shared by the threads; a pose they cannot serve by the full
     * model, and its families untracked); refused for a robot they cannot
     * serve at all. DM_SWEEP_FULL_MODEL: the full model at every point, as
     * `deltamap modes`. DM_SWEEP_AUTO (the default): a store of this very
     * sweep being resumed keeps the engine it was made with; otherwise the
     * members where they serve the robot at the sweep's mesh and modes
     * (faster at every preset and mesh measured: make bench section 5),
     * else the full model. dm_sweep_stats says which ran, and why. */
    int members;
    dm_move_opts move;
    int replace;        /* replace a store of another robot/grid/options */
    int force_long;     /* run even beyond DM_SWEEP_MAX_SECONDS or DM_SWEEP_MAX_FILES */
    int shard, shards;  /* compute only shard `shard` of `shards` (0: all) */
    /* The tolerance Monte Carlo at every computed point (dm_tolerance_pose
     * at the sweep's mesh, flexible model, one thread per point): maps of
     * the mean, P95 and maximum |error|, P(|error| > spec) when
     * tolerance_spec.spec_m > 0, and the dominant source. Each point's result is
     * that of dm_tolerance_pose at its pose (its own streams,
     * dm_tolerance_pose_seed): the same for any threads, tiles and shards.
     * The spec's samples, seed, spec, bands and law are part of the
     * store's fingerprint; its na, nb, flexibility and force_long are the
     * sweep's (its mesh, 1, force_long). */
    int tolerance;
    dm_tolerance_spec tolerance_spec;
    /* progress: called (from one thread at a time) as the anchors and the
     * tiles get done; NULL: none. The caller draws it. */
    void (*progress)(void *user, const struct dm_sweep_progress *p);
    void *progress_user;
    /* on_repair: called for each file of an existing store of this sweep
     * that was not what the sweep writes (an array's metadata, a
     * coordinate or label chunk) and was rewritten: its path and what was
     * wrong (repaired is 1); NULL: none. */
    void (*on_repair)(void *user, const char *file, const char *problem, int repaired);
    void *repair_user;
} dm_sweep_opts;

void dm_sweep_opts_default(dm_sweep_opts *opts);

/* Refused before any work (dm_work_check, DM_ETOOBIG) unless
 * opts.force_long: a sweep whose share of points is estimated at more
 * than DM_SWEEP_MAX_SECONDS of wall time on its threads (from the per-point cost measured on this project's
 * development machine, 2.5 ms at 210 DOF with the standard moves, growing
 * as n^2, plus the tolerance Monte Carlo's dm_tolerance_estimate_s), or
 * one point's Monte Carlo beyond DM_TOLERANCE_MAX_SECONDS, or whose store
 * would hold more than DM_SWEEP_MAX_FILES chunk files (larger tiles, or
 * several stores, keep a file system usable). */
#define DM_SWEEP_MAX_SECONDS (24 * 3600.0)
#define DM_SWEEP_MAX_FILES 2000000L

typedef struct dm_sweep_stats {
    long tiles_total;                  /* in the whole grid */
    long tiles_mine;                   /* this shard's (all without shards) */
    long tiles_present, tiles_computed; /* of this shard's */
    long points_total, points_ok, points_unreachable, points_near_singular, points_failed;
    long points_full_model; /* with the members: points they could not serve (the full
                               model did; their families untracked) */
    long members_applications; /* with the members: applications of K^-1 M the reduced solves
                                  of the points the members served took, in all (a
                                  count, unlike the time: make bench) */
    int members;        /* the engine that ran: DM_SWEEP_MEMBERS or DM_SWEEP_FULL_MODEL */
    char engine_why[200]; /* DM_SWEEP_AUTO: why it is the full model ("" otherwise) */
    double seconds;
    int interrupted;
    int store_refused;  /* out holds another sweep's store (opts.force replaces it) */
} dm_sweep_stats;

/* Run (or resume) a sweep into the store at `out`. `stop` is polled
 * between tiles: when it becomes non-zero the tiles in flight finish and
 * DM_EINTERRUPT is returned. */
int dm_sweep_run(const dm_robot *robot, const dm_grid *grid, const dm_sweep_opts *opts,
                 const char *out, volatile sig_atomic_t *stop, dm_sweep_stats *stats,
                 dm_error *err);

/* ---- a store against the sweep it records (sweep_verify.c) ---- */

/* A file of a store that is not what its sweep writes: its path, what is
 * wrong, and whether it was rewritten. */
typedef void (*dm_sweep_damage_fn)(void *user, const char *file, const char *problem,
                                   int repaired);

typedef struct dm_sweep_check {
    dm_store store;      /* the layout to read the chunks by (dm_sweep_census_take) */
    int verified;        /* the metadata and coordinates were compared with the bytes this
                            version writes for the sweep the store records */
    char made_by[64];    /* the tool the store records ("deltamap 0.4.0"; "" none) */
    int other_version;   /* made by another version: read as its metadata says */
    long problems;       /* files found not to be what the sweep writes */
    long repaired;       /* of them, rewritten */
    long chunk_problems; /* of them, chunk files left as they were */
    int trajectory;      /* a trajectory run's store (dm_trajstore.h): no tiles */
} dm_sweep_check;

/* Open the store at path for deltamap info: rebuild the sweep its
 * group's fingerprint records (robot, grid, options) and compare every
 * file that sweep derives — the group's and arrays' metadata, the
 * coordinate and label chunks — with what it writes, reporting each that
 * differs; with repair, those that can be derived are rewritten (never the
 * group's, which names the sweep). A store of another version, or whose
 * sweep cannot be rebuilt, is read as its metadata says, its coordinate
 * chunks checked by their checksums. Errors: the group's metadata missing
 * or not JSON (DM_EIO), the fallback's (dm_store_read_metadata), a failed
 * rewrite. Close with dm_sweep_check_close. */
int dm_sweep_check_open(const char *path, int repair, dm_sweep_damage_fn report, void *user,
                        dm_sweep_check *check, dm_error *err);
void dm_sweep_check_close(dm_sweep_check *check);

/* ---- what a store holds (sweep_census.c) ---- */

/* The scan of a map store's tiles: every chunk read and its checksum
 * verified. */
typedef struct dm_sweep_census {
    long nt[3], tiles;         /* the tile grid */
    long complete;             /* tiles whose every chunk is present and valid */
    long corrupt, missing_chunks;
    long counts[256];          /* points by status (enum dm_point_status) */
    char *done;                /* per tile (C order): complete */
} dm_sweep_census;

/* Scan store (from dm_store_read_metadata); on_corrupt (may be NULL) gets
 * each corrupt chunk's message. DM_EINVAL: not a map store (no uint8
 * status array over x, y, z). Free with dm_sweep_census_free. */
int dm_sweep_census_take(const dm_store *store, dm_sweep_census *census,
                         void (*on_corrupt)(void *user, const char *msg), void *user,
                         dm_error *err);
void dm_sweep_census_free(dm_sweep_census *census);

#endif
