/* sweep_impl.h — the sweep's internals, shared by its files; not part of
 * the public API (dm_sweep.h). Sections by the file that defines them:
 *   sweep.c          the run: workers, points, tiles, scheduling
 *   sweep_schema.c   the stored arrays, the fingerprint, the coordinates
 *   sweep_store.c    opening, creating or joining the store
 *   sweep_anchors.c  mode tracking's reference poses */
#ifndef DM_SWEEP_IMPL_H
#define DM_SWEEP_IMPL_H

#include "dm_store.h"
#include "dm_sweep.h"
#include "dm_version.h"

#define DM_SWEEP_VERSION "deltamap " DM_VERSION
#define EXTRA_MODES 4   /* candidates beyond k for mode tracking */

/* ---- sweep.c: what one point of the map holds ------------------------------ */

/* The values a map stores at a point, flat and of fixed size, NaN where
 * not computed. Not dm_pose_result (dm_analysis.h), which is one pose's
 * analysis and points into the workspace that made it (modes, statics),
 * valid until the next pose; nor dm_integ_sample (dm_integrate.h), one
 * time step of a trajectory. This one adds the tracked families and the
 * standard moves, and outlives the workspace until its tile is written.
 * Each field holds one stored array's values at the point (its row of
 * dm_sweep_arrays names it by offset): an array is added as a field here,
 * a row there and the line of analyse_point that computes it. */
typedef struct dm_point_result {
    int status;
    double freq_hz[DM_MAX_MODES], tracked_hz[DM_MAX_MODES];
    double static_error[6];
    double compliance_max, compliance_dir[3], stiffness_min, singularity;
    double move_peak[3], move_residual[3], move_settling[3];
    double coupling_index_log10, coupling_change_log10;
    /* the tolerance Monte Carlo (NaN, dominant -1: not run or failed) */
    double error_mean_m, error_p95_m, error_max_m, p_exceed_spec;
    int dominant_source;
} dm_point_result;

/* ---- sweep_schema.c: the arrays of a map store ----------------------------- */

/* Which sweeps store an array: every one, those with the tolerance Monte
 * Carlo, those with it and a spec. The table holds the groups in this
 * order, so a store's data arrays are the table's first dm_sweep_ndata()
 * rows and an array's index in the store is its row. After them come the
 * coordinates (c->ndata + 0..2) and the labels of the extra dimensions
 * (c->ndata + 3..6). */
enum { G_CORE, G_TOLERANCE, G_SPEC };
#define N_AXES_LABELS 7 /* coordinate and label arrays */

/* An array's fourth dimension, after x, y, z: none, or the one it names. */
enum { X_NONE, X_MODE, X_COMPONENT, X_AXIS, X_MOVE };

/* One stored (data) array. */
typedef struct {
    const char *name;
    dm_dtype dtype;     /* FLOAT64: its field is double[], UINT8 and INT32: int[] */
    int extra;          /* X_*: its fourth dimension */
    int group;          /* G_*: the sweeps that store it */
    const char *units, *long_name;
    /* CF attributes beyond units and long_name (flag_values, ...); NULL: none */
    void (*cf_attributes)(json_t *attributes);
    size_t offset, size; /* its field in dm_point_result */
    double fill;        /* its value where not computed: in a point, in a chunk's padding */
} dm_sweep_array;

/* The data arrays: status first (written last, so that a reader sees a
 * tile's status only once its data is there), then the groups in order. */
extern const dm_sweep_array dm_sweep_arrays[];
extern const int dm_sweep_narrays;

/* How many of the table's first rows a sweep stores, with or without the
 * tolerance Monte Carlo and a spec (> 0). */
int dm_sweep_ndata(int tolerance, double spec_m);
/* The length of an array's fourth dimension (1 without one) at k modes. */
int dm_sweep_extra_len(int extra, int k);

/* ---- sweep.c: the run's context and its workers ----------------------------- */

typedef struct sweep_ctx {
    const dm_robot *rb;
    const dm_grid *grid;
    dm_sweep_opts o;
    int na, nb, n, k, kc;
    struct dm_members *members; /* with the members: the bases every worker shares */
    int dim;            /* the length of the vectors families are tracked by */
    int tile[3], ntiles[3];
    int ndata;          /* data arrays in the store: dm_sweep_arrays' first */
    dm_tolerance_spec tol; /* the Monte Carlo's, at the sweep's mesh (o.tolerance) */
    int nthreads;       /* over tiles */
    dm_store store;
    /* anchors (read-only once built): each point starts its eigen solve
     * from its nearest anchor's seed, moved toward the next anchors along
     * the lattice's axes, and is tracked against that anchor's families,
     * so a point depends on nothing computed before it */
    int nanchor;
    int anchor_m[3];     /* the lattice: anchors per axis */
    double (*anchor_P)[3];
    int *anchor_ok;
    double *anchor_phi;  /* nanchor x (dim x k): the families' vectors (shapes,
                          * or the members' reduced vectors) */
    unsigned char *anchor_seed; /* nanchor x seed_len: the solver's start */
    size_t seed_len;
    double t0;           /* when the sweep started */
    int store_refused;   /* the store at out is of another sweep */
    char engine_why[200]; /* DM_SWEEP_AUTO: why the full model runs ("" otherwise) */
} sweep_ctx;

typedef struct sweep_worker {
    dm_analysis *an;
    dm_move_ws *move;
    double *mac_work, *mac;
    int *assign;
    double *shapes;     /* families' vectors at the point (dim x k) */
    int served_full;    /* the last point: the full model served it, the members
                         * (o.members) could not */
    int applications;   /* the last point: K^-1 M applications of its members' solve */
    struct dm_coupling *nominal; /* the robot without effects (NULL: it has none) */
    int nbuf;
    void **buf;         /* a chunk of each of the store's data arrays (nbuf) */
} sweep_worker;

/* ---- sweep_schema.c --------------------------------------------------------- */

/* The store's layout (arrays, attributes, fingerprint) at path. */
void dm_sweep_schema_define(sweep_ctx *c, const char *path);
/* The coordinate and label arrays' chunks. */
int dm_sweep_schema_write_coordinates(const sweep_ctx *c, dm_error *err);
/* Coordinate or label array a's chunk alone. */
int dm_sweep_schema_write_coordinates_one(const sweep_ctx *c, int a, dm_error *err);
/* The values of coordinate or label array a (c->ndata and after): the
 * grid's positions, or an extra dimension's indices. */
void dm_sweep_schema_coordinate(const sweep_ctx *c, int a, void *out);

/* ---- sweep_verify.c: the store against the sweep it records ------------------ */


/* Every array's metadata and the coordinate and label chunks against the
 * bytes this sweep writes (they are derived from its command, so nothing
 * is lost by rewriting them); with repair each that differs is rewritten.
 * *found: files that differed; *repaired and *chunks (may be NULL): of
 * them, those rewritten and the chunk files left as they were. Fails
 * only when a rewrite does (or memory). */
int dm_sweep_schema_check(const sweep_ctx *c, int repair, dm_sweep_damage_fn report, void *user,
                          long *found, long *repaired, long *chunks, dm_error *err);
/* The group's metadata against this sweep's: why[0] is '\0' when the
 * same, else what differs (it is never rewritten: it names the sweep). */
int dm_sweep_schema_check_group(const sweep_ctx *c, char *why, size_t len, dm_error *err);

/* ---- sweep_store.c ---------------------------------------------------------- */

/* Join the sweep's store at c->store.path, or create it (atomically);
 * refuse a store of another sweep unless c->o.replace. */
int dm_sweep_store_prepare(sweep_ctx *c, const char *path, dm_error *err);
/* The engine of the store at path when it records this sweep but perhaps
 * for its engine (c's schema defined at path, either engine):
 * DM_SWEEP_MEMBERS or DM_SWEEP_FULL_MODEL; -1 when there is no readable
 * store of this sweep. */
int dm_sweep_store_engine(const sweep_ctx *c, const char *path);

/* ---- sweep_anchors.c -------------------------------------------------------- */

/* Build the lattice of anchors with the nw workers w[0 .. nw-1] (one per
 * thread): the same lattice for any nw. */
int dm_sweep_anchors_build(sweep_ctx *c, sweep_worker *w, int nw, dm_error *err);
/* The nearest anchor whose families are known, or -1. */
int dm_sweep_anchors_nearest(const sweep_ctx *c, const double P[3]);
/* Anchor a's solver seed (c->seed_len bytes). */
unsigned char *dm_sweep_anchors_seed(const sweep_ctx *c, int a);
/* The seeds that the start of the point at grid index idx, nearest anchor
 * a, moves toward: along each axis on which the point lies between a and
 * the next anchor (solved), that one's seed and how far along; returns
 * how many (0..3). */
int dm_sweep_anchors_toward(const sweep_ctx *c, int a, const int idx[3], const void *toward[3],
                            double frac[3]);
/* Match the k families with vectors ref (c->dim each) to the modes of
 * the worker's last run res by MAC, clusters as subspaces (w->assign),
 * their next vectors into dst (may be ref). -1 (nothing assigned) where
 * the run's vectors are not the anchors' kind (dm_analysis_track). */
int dm_sweep_anchors_track(const sweep_ctx *c, sweep_worker *w, const double *ref,
                           const dm_pose_result *res, double *dst);

#endif
