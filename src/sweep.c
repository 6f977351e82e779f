/* Workspace sweeps into the map store (see dm_sweep.h, docs/store.md). */
#include "dm_sweep.h"

#include <cblas.h>
#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "dm_shard.h"
#include "dm_store.h"
#include "dm_version.h"
#include "dm_vec3.h"

#define DM_SWEEP_VERSION "deltamap " DM_VERSION
#define EXTRA_MODES 4   /* candidates beyond k for mode tracking */
#define ANCHORS_PER_AXIS 16

void dm_sweep_opts_default(dm_sweep_opts *o)
{
    memset(o, 0, sizeof *o);
    o->k = 10;
    o->dynamic = 1;
    dm_move_opts_default(&o->move);
}

/* ---- the arrays ------------------------------------------------------------ */

enum {
    A_STATUS, A_FREQ, A_TRACKED, A_STATIC, A_CMAX, A_CDIR, A_KMIN, A_COND, A_PEAK, A_RESID,
    A_SETTLE, N_DATA, A_C0 = N_DATA, A_C1, A_C2, A_MODE, A_COMPONENT, A_AXIS, A_MOVE, N_ARRAYS
};

typedef struct {
    const char *name;
    dm_dtype dtype;
    int extra;          /* 0: none, else index into the extra-dimension table */
    const char *units, *long_name;
} array_def;

enum { X_NONE, X_MODE, X_COMPONENT, X_AXIS, X_MOVE };
static const char *const EXTRA_DIM[] = {"", "mode", "component", "axis", "move"};

static const array_def DATA[N_DATA] = {
    {"status", DM_DTYPE_UINT8, X_NONE, "1", "0 ok, 1 unreachable, 2 near-singular, 3 solver failure, 255 not computed"},
    {"frequencies_hz", DM_DTYPE_FLOAT64, X_MODE, "Hz", "natural frequencies, ascending"},
    {"frequencies_tracked_hz", DM_DTYPE_FLOAT64, X_MODE, "Hz", "frequencies of mode families followed by MAC"},
    {"static_error", DM_DTYPE_FLOAT64, X_COMPONENT, "m, rad", "platform error under gravity: dx, dy, dz (m), ex, ey, ez (rad)"},
    {"compliance_max", DM_DTYPE_FLOAT64, X_NONE, "m/N", "largest translational compliance at P"},
    {"compliance_direction", DM_DTYPE_FLOAT64, X_AXIS, "1", "direction of the largest compliance"},
    {"stiffness_min", DM_DTYPE_FLOAT64, X_NONE, "N/m", "smallest translational stiffness at P (1/compliance_max)"},
    {"singularity", DM_DTYPE_FLOAT64, X_NONE, "1", "condition number of the kinematic Jacobian"},
    {"move_peak_m", DM_DTYPE_FLOAT64, X_MOVE, "m", "standard move: peak |Delta - Delta_static| during the move"},
    {"move_residual_m", DM_DTYPE_FLOAT64, X_MOVE, "m", "standard move: residual vibration amplitude after it"},
    {"move_settling_s", DM_DTYPE_FLOAT64, X_MOVE, "s", "standard move: settling time after it (inf: never)"},
};

static int extra_len(int x, int k)
{
    return x == X_MODE ? k : x == X_COMPONENT ? 6 : x == X_AXIS ? 3 : x == X_MOVE ? 3 : 1;
}

/* ---- set-up --------------------------------------------------------------- */

typedef struct {
    const dm_robot *rb;
    const dm_grid *grid;
    dm_sweep_opts o;
    int na, nb, n, k, kc;
    int tile[3], ntiles[3];
    int nthreads;       /* over tiles */
    dm_store store;
    /* anchors (read-only once built): each point starts its eigen solve
     * from its nearest anchor's seed and is tracked against that anchor's
     * families, so a point depends on nothing computed before it */
    int nanchor;
    double (*anchor_P)[3];
    int *anchor_ok;
    double *anchor_phi;  /* nanchor x (n x k): the families' shapes */
    unsigned char *anchor_seed; /* nanchor x seed_len: the solver's start */
    size_t seed_len;
    double t0;           /* when the sweep started */
} sweep_ctx;

static void auto_tile(const dm_grid *g, const int req[3], int tile[3])
{
    for (int d = 0; d < 3; d++) {
        int c = g->axis[d].count;
        tile[d] = req[d] > 0 ? (req[d] < c ? req[d] : c) : (c < 16 ? c : 16);
    }
    if (!req[2] && g->axis[0].count > 1 && g->axis[1].count > 1)
        tile[2] = 1; /* 3-D grids: 16 x 16 x 1 slices */
}

static json_t *attrs(const char *units, const char *long_name)
{
    return json_pack("{s:s, s:s}", "units", units, "long_name", long_name);
}

static void add_array(dm_store *st, const char *name, dm_dtype t, int ndim, const int64_t *shape,
                      const int *chunk, const char *const *dims, json_t *attributes)
{
    dm_array_spec *a = &st->arr[st->narr++];
    memset(a, 0, sizeof *a);
    snprintf(a->name, sizeof a->name, "%s", name);
    a->dtype = t;
    a->ndim = ndim;
    for (int d = 0; d < ndim; d++) {
        a->shape[d] = shape[d];
        a->chunk[d] = chunk[d];
        snprintf(a->dims[d], sizeof a->dims[d], "%s", dims[d]);
    }
    a->attributes = attributes;
}

static json_t *fingerprint(const sweep_ctx *c)
{
    char *ini = NULL, grid[512];
    size_t len = 0;
    FILE *mem = open_memstream(&ini, &len);
    dm_robot_write(c->rb, mem);
    fclose(mem);
    dm_grid_format(c->grid, grid, sizeof grid);
    const dm_move_opts *m = &c->o.move;
    json_t *f = json_pack("{s:s, s:s, s:s, s:i, s:[ii], s:[iii], s:b, s:{s:f, s:f, s:f, s:f, s:b}}",
                          "version", DM_SWEEP_VERSION, "robot_ini", ini, "grid", grid, "modes",
                          c->k, "mesh", c->na, c->nb, "tile", c->tile[0], c->tile[1], c->tile[2],
                          "dynamic", c->o.dynamic, "move", "amax_ms2", m->amax_ms2, "tau_s",
                          m->tau_s, "tol_m", m->tol_m, "window_s", m->window_s, "quasi_static",
                          m->quasi_static);
    free(ini);
    return f;
}

static void define_store(sweep_ctx *c, const char *path)
{
    dm_store *st = &c->store;
    const dm_grid *g = c->grid;
    memset(st, 0, sizeof *st);
    snprintf(st->path, sizeof st->path, "%s", path);
    const char *dims[4] = {g->axis[0].name, g->axis[1].name, g->axis[2].name, ""};
    for (int a = 0; a < N_DATA; a++) {
        const array_def *d = &DATA[a];
        int64_t shape[4];
        int chunk[4], nd = 3 + (d->extra != X_NONE);
        for (int i = 0; i < 3; i++) {
            shape[i] = g->axis[i].count;
            chunk[i] = c->tile[i];
        }
        shape[3] = chunk[3] = extra_len(d->extra, c->k);
        dims[3] = EXTRA_DIM[d->extra];
        json_t *at = attrs(d->units, d->long_name);
        if (a == A_STATUS)
            json_object_set_new(at, "flag_meanings",
                                json_string("ok unreachable near_singular solver_failure"));
        add_array(st, d->name, d->dtype, nd, shape, chunk, dims, at);
    }
    static const char *const unit_of[2][3] = {{"m", "m", "m"}, {"m", "degree", "m"}};
    for (int i = 0; i < 3; i++) {
        int64_t shape[1] = {g->axis[i].count};
        int chunk[1] = {g->axis[i].count};
        const char *dn[1] = {g->axis[i].name};
        add_array(st, g->axis[i].name, DM_DTYPE_FLOAT64, 1, shape, chunk, dn,
                  attrs(unit_of[g->kind][i], "grid coordinate"));
    }
    static const char *const xnames[4] = {"mode", "component", "axis", "move"};
    const int xlen[4] = {c->k, 6, 3, 3};
    static const char *const labels[4] = {"mode rank, 1 = lowest", "dx dy dz ex ey ez",
                                          "x y z", "X Y Z"};
    for (int i = 0; i < 4; i++) {
        int64_t shape[1] = {xlen[i]};
        int chunk[1] = {xlen[i]};
        const char *dn[1] = {xnames[i]};
        json_t *at = attrs("1", labels[i]);
        add_array(st, xnames[i], DM_DTYPE_INT32, 1, shape, chunk, dn, at);
    }
    json_t *names = json_array();
    for (int a = 0; a < st->narr; a++)
        json_array_append_new(names, json_string(st->arr[a].name));
    char grid[512];
    dm_grid_format(g, grid, sizeof grid);
    json_t *dm = json_pack("{s:s, s:s, s:s, s:s, s:o, s:o}", "tool", DM_SWEEP_VERSION, "robot",
                           c->rb->name, "grid", grid, "grid_kind",
                           g->kind ? "cylindrical" : "cartesian", "arrays", names, "fingerprint",
                           fingerprint(c));
    st->group_attributes = json_pack("{s:s, s:o}", "title", "deltamap workspace maps", "deltamap", dm);
}

static int write_coordinates(sweep_ctx *c, dm_error *err)
{
    const int64_t zero[1] = {0};
    int rc = DM_OK;
    for (int i = 0; i < 3 && !rc; i++) {
        const dm_grid_axis *ax = &c->grid->axis[i];
        double *v = malloc(sizeof(double) * ax->count);
        if (!v)
            return dm_fail(err, DM_ENOMEM, "out of memory");
        for (int j = 0; j < ax->count; j++)
            v[j] = dm_grid_value(ax, j);
        rc = dm_store_write_chunk(&c->store, A_C0 + i, zero, v, err);
        free(v);
    }
    int32_t idx[64];
    for (int j = 0; j < 64; j++)
        idx[j] = j;
    for (int a = A_MODE; a <= A_MOVE && !rc; a++) {
        if (a == A_MODE)
            for (int j = 0; j < 64; j++)
                idx[j] = j + 1;
        rc = dm_store_write_chunk(&c->store, a, zero, idx, err);
        for (int j = 0; j < 64; j++)
            idx[j] = j;
    }
    return rc;
}

/* ---- opening or creating the store ------------------------------------------
 * Any number of processes, on any hosts, may open or create one store at
 * once. A store is created whole: its metadata and coordinates are written
 * under a temporary name beside it and renamed into place, so the others
 * see no store or a complete one, never a half-made directory. Whoever
 * renames first owns it; the others find its fingerprint and join it, or
 * are refused and touch nothing. */

enum { STORE_ABSENT = -1, STORE_RETRY = -2 };
#define PREPARE_PATIENCE_S 60.0 /* NFS's default longest attribute cache time */

static json_t *fingerprint_of(json_t *group_attributes)
{
    return json_object_get(json_object_get(group_attributes, "deltamap"), "fingerprint");
}

/* What differs between the store's fingerprint and ours, in words. */
static const char *difference(json_t *ofp, json_t *nfp)
{
    if (!ofp)
        return "an unreadable store";
    if (!json_equal(json_object_get(ofp, "robot_ini"), json_object_get(nfp, "robot_ini")))
        return "another robot";
    if (!json_equal(json_object_get(ofp, "grid"), json_object_get(nfp, "grid")))
        return "another grid";
    return "other options (modes, mesh, tile, move or version)";
}

/* "maps/xy" -> parent "maps", base "xy" ("." for a bare name). */
static const char *split_path(const char *path, char *parent, size_t len)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(parent, len, ".");
    else
        snprintf(parent, len, "%.*s", slash == path ? 1 : (int)(slash - path), path);
    return slash ? slash + 1 : path;
}

static int dir_is_empty(const char *path)
{
    DIR *d = opendir(path);
    if (!d)
        return 1; /* absent: created later */
    struct dirent *e;
    int n = 0;
    while ((e = readdir(d)))
        n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    return n == 0;
}

static int same_dir(const struct stat *a, const struct stat *b)
{
    return a->st_dev == b->st_dev && a->st_ino == b->st_ino;
}

/* What dead runs left of the store's skeleton: staging directories beside
 * it, metadata and coordinate temporaries inside (data chunks' ones are
 * cleaned tile by tile, by the shard that recomputes the tile). */
static void clean_skeleton(const sweep_ctx *c, const char *path)
{
    char parent[1024], dir[1200];
    dm_remove_stale_temporaries(parent, split_path(path, parent, sizeof parent));
    dm_remove_stale_temporaries(path, "zarr.json");
    for (int a = 0; a < c->store.narr; a++) {
        snprintf(dir, sizeof dir, "%s/%s", path, c->store.arr[a].name);
        dm_remove_stale_temporaries(dir, "zarr.json");
        snprintf(dir, sizeof dir, "%s/%s/c", path, c->store.arr[a].name);
        if (a >= N_DATA)
            dm_remove_stale_temporaries(dir, "0");
    }
}

/* An existing store's array metadata and coordinates: rewritten (the same
 * bytes) if any file is missing or has the wrong size. */
static int repair_skeleton(sweep_ctx *c, dm_error *err)
{
    char file[1200];
    const int64_t zero[1] = {0};
    struct stat sb;
    int whole = 1;
    for (int a = 0; a < c->store.narr && whole; a++) {
        snprintf(file, sizeof file, "%s/%s/zarr.json", c->store.path, c->store.arr[a].name);
        whole = stat(file, &sb) == 0;
        if (whole && a >= N_DATA) {
            dm_store_chunk_path(&c->store, a, zero, file, sizeof file);
            size_t bytes = dm_store_chunk_elems(&c->store, a) * dm_dtype_size(c->store.arr[a].dtype);
            whole = stat(file, &sb) == 0 && (size_t)sb.st_size == bytes + 4;
        }
    }
    if (whole)
        return DM_OK;
    int rc = dm_store_write_metadata(&c->store, err);
    return rc ? rc : write_coordinates(c, err);
}

/* --force on a store of another sweep: rename it aside, check that it was
 * the store judged (a concurrent process may have replaced it already:
 * then put that one back and look again), remove it. */
static int move_aside(const char *path, const struct stat *judged, dm_error *err)
{
    char aside[1200];
    struct stat sb;
    dm_temp_name(path, aside, sizeof aside);
    dm_remove_tree(aside);
    if (rename(path, aside))
        return errno == ENOENT ? STORE_RETRY
                               : dm_fail(err, DM_EIO, "%s: cannot replace the store: %s", path,
                                         strerror(errno));
    if (stat(aside, &sb) || !same_dir(&sb, judged)) {
        if (rename(aside, path))
            return dm_fail(err, DM_EIO,
                           "%s: another process replaced the store at the same moment; the "
                           "store it made is now %s",
                           path, aside);
        return STORE_RETRY;
    }
    if (dm_remove_tree(aside))
        return dm_fail(err, DM_EIO, "%s: cannot remove the old store (moved to %s): %s", path,
                       aside, strerror(errno));
    return STORE_ABSENT;
}

/* The store at path: DM_OK when it holds this sweep, STORE_ABSENT when
 * there is none (or --force moved another sweep's away), STORE_RETRY when
 * it changed while we looked. `racing`: we just lost a creation race, so a
 * directory without metadata may be a store not yet visible to this host. */
static int open_existing(sweep_ctx *c, const char *path, int racing, dm_error *err)
{
    char file[1100];
    struct stat dir, again;
    snprintf(file, sizeof file, "%s/zarr.json", path);
    if (stat(path, &dir))
        return STORE_ABSENT;
    int has_group = access(file, F_OK) == 0;
    if (!S_ISDIR(dir.st_mode) || (!has_group && !dir_is_empty(path)))
        return racing ? STORE_RETRY
                      : dm_fail(err, DM_EINVAL,
                                "%s exists and is not a map store; choose another --out", path);
    if (!has_group)
        return STORE_ABSENT; /* an empty directory */
    dm_store old;
    dm_error rerr;
    int rc = dm_store_read_metadata(path, &old, &rerr);
    if (rc == DM_ENOMEM)
        return dm_fail(err, rc, "%s", rerr.msg); /* no verdict on the store */
    json_t *ofp = rc ? NULL : fingerprint_of(old.group_attributes);
    json_t *nfp = fingerprint_of(c->store.group_attributes);
    int same = ofp && json_equal(ofp, nfp);
    const char *what = difference(ofp, nfp);
    if (!rc)
        dm_store_release(&old);
    if (stat(path, &again) || !same_dir(&dir, &again))
        return STORE_RETRY; /* replaced while we read it */
    if (same) {
        clean_skeleton(c, path);
        return repair_skeleton(c, err);
    }
    if (!c->o.force)
        return dm_fail(err, DM_EINVAL,
                       "%s holds a sweep of %s; use --force to overwrite it or choose another --out",
                       path, what);
    return move_aside(path, &dir, err);
}

/* Build the store under PATH.tmp.HOST.PID, rename it to PATH. STORE_RETRY:
 * another process created it first (the rename found PATH not empty). */
static int create_store(sweep_ctx *c, const char *path, dm_error *err)
{
    char parent[1024], stage[1024], keep[sizeof c->store.path];
    const char *base = split_path(path, parent, sizeof parent);
    int rc = dm_mkdirs(parent, err);
    if (rc)
        return rc;
    dm_remove_stale_temporaries(parent, base);
    dm_temp_name(path, stage, sizeof stage);
    dm_remove_tree(stage); /* left by an earlier process with our PID */
    memcpy(keep, c->store.path, sizeof keep);
    snprintf(c->store.path, sizeof c->store.path, "%s", stage);
    rc = dm_store_write_metadata(&c->store, err);
    if (!rc)
        rc = write_coordinates(c, err);
    memcpy(c->store.path, keep, sizeof keep);
    if (!rc && !rename(stage, path))
        return DM_OK;
    int e = errno;
    dm_remove_tree(stage);
    if (rc)
        return rc;
    if (e == ENOTEMPTY || e == EEXIST)
        return STORE_RETRY;
    return dm_fail(err, DM_EIO, "%s: cannot create the store: %s", path, strerror(e));
}

/* Open the store if it holds this sweep, or create it; another sweep's is
 * refused unless force (which replaces only a store of another sweep, so
 * any number of processes may be given it). A lost race is retried: at
 * once, as a rule, but a network filesystem may show the winner's store to
 * this host only after its attribute cache expires. */
static int prepare_store(sweep_ctx *c, const char *path, dm_error *err)
{
    double t0 = omp_get_wtime();
    int rc;
    for (int attempt = 0;; attempt++) {
        double waited = omp_get_wtime() - t0;
        rc = open_existing(c, path, attempt > 0 && waited < PREPARE_PATIENCE_S, err);
        if (rc == STORE_ABSENT)
            rc = create_store(c, path, err);
        if (rc != STORE_RETRY || waited >= PREPARE_PATIENCE_S)
            break;
        long ms = attempt < 50 ? 10 * (attempt + 1) : 500;
        struct timespec pause = {ms / 1000, 1000000L * (ms % 1000)};
        nanosleep(&pause, NULL);
    }
    if (rc == STORE_RETRY)
        rc = dm_fail(err, DM_EIO, "%s: the store kept changing while this process opened it", path);
    return rc;
}

/* ---- per-thread work -------------------------------------------------------- */

typedef struct {
    dm_analysis *an;
    dm_move_ws *move;
    double *mac_work, *mac;
    int *assign;
    double *shapes;     /* families' shapes at the point (n x k) */
    void *buf[N_DATA];
} worker;

static void worker_free(worker *w)
{
    dm_analysis_free(w->an);
    dm_move_free(w->move);
    free(w->mac_work);
    free(w->mac);
    free(w->assign);
    free(w->shapes);
    for (int a = 0; a < N_DATA; a++)
        free(w->buf[a]);
}

static int worker_alloc(const sweep_ctx *c, worker *w, dm_error *err)
{
    memset(w, 0, sizeof *w);
    w->an = dm_analysis_alloc(c->rb, c->na, c->nb, c->kc, DM_EIGEN_PARTIAL, err);
    if (!w->an)
        return err ? err->code : DM_ENOMEM;
    w->move = dm_move_alloc(c->n, c->k, err);
    w->mac_work = malloc(sizeof(double) * (2 * (size_t)c->n * c->k + (size_t)c->k * c->kc));
    w->mac = malloc(sizeof(double) * c->k);
    w->assign = malloc(sizeof(int) * c->k);
    w->shapes = malloc(sizeof(double) * c->n * c->k);
    int ok = w->move && w->mac_work && w->mac && w->assign && w->shapes;
    for (int a = 0; a < N_DATA && ok; a++)
        ok = (w->buf[a] = malloc(dm_store_chunk_elems(&c->store, a) * dm_dtype_size(DATA[a].dtype))) != NULL;
    if (!ok) {
        worker_free(w);
        memset(w, 0, sizeof *w); /* the caller frees a failed worker again */
        return dm_fail(err, DM_ENOMEM, "out of memory for a sweep worker");
    }
    return DM_OK;
}

/* ---- mode-tracking anchors ------------------------------------------------ */

static int anchor_index(const sweep_ctx *c, const int m[3], const int a[3])
{
    (void)c;
    return (a[0] * m[1] + a[1]) * m[2] + a[2];
}

/* Match the k families with shapes `ref` to the current modes by MAC,
 * clusters as subspaces (w->assign), and store the families' next shapes
 * in dst (may be ref itself). */
static void match_families(const sweep_ctx *c, worker *w, const double *ref,
                           const dm_modes *modes, double *dst)
{
    dm_modal_track(ref, c->k, modes, c->kc, w->an->model, w->assign, w->mac, dst, w->mac_work);
}

static unsigned char *seed_of(const sweep_ctx *c, int a)
{
    return c->anchor_seed + (size_t)a * c->seed_len;
}

static void anchor_progress(const sweep_ctx *c, long done, long total, int final)
{
    if (!c->o.progress)
        return;
    dm_sweep_progress p = {DM_SWEEP_ANCHORS, done, total, 0, omp_get_wtime() - c->t0, final};
    c->o.progress(c->o.progress_user, &p);
}

/* Families at anchor `to`, continued from anchor `from` by MAC; the solve
 * starts from `from`'s seed and leaves `to`'s. */
static int follow(sweep_ctx *c, worker *w, int from, int to)
{
    size_t block = (size_t)c->n * c->k;
    dm_pose_result res;
    if (c->seed_len)
        dm_modal_seed_load(w->an->modal, seed_of(c, from));
    if (dm_analysis_run(w->an, c->anchor_P[to], c->kc, &res, NULL))
        return 0;
    match_families(c, w, c->anchor_phi + from * block, res.modes, c->anchor_phi + to * block);
    if (c->seed_len)
        dm_modal_seed_save(w->an->modal, seed_of(c, to));
    c->anchor_ok[to] = 1;
    return 1;
}

/* Anchors per axis: at most ANCHORS_PER_AXIS, fewer (the largest axis
 * first) while the lattice's shapes and seeds would exceed ANCHOR_BYTES. */
#define ANCHOR_BYTES (128u << 20)
static void anchor_lattice(const sweep_ctx *c, int m[3])
{
    size_t per = (size_t)c->n * c->k * sizeof(double) + c->seed_len + 64;
    for (int d = 0; d < 3; d++)
        m[d] = c->grid->axis[d].count < ANCHORS_PER_AXIS ? c->grid->axis[d].count : ANCHORS_PER_AXIS;
    while ((size_t)m[0] * m[1] * m[2] * per > ANCHOR_BYTES) {
        int big = m[0] >= m[1] && m[0] >= m[2] ? 0 : m[1] >= m[2] ? 1 : 2;
        m[big]--;
    }
}

/* A coarse lattice (at most 16 per axis) of reference poses. Families are
 * the k lowest modes at the root (the anchor nearest the robot's home),
 * followed to every other reachable anchor by MAC, serially:
 * the result is fixed before any tile runs. Memory: at most 4096 anchors. */
static int build_anchors(sweep_ctx *c, worker *w, dm_error *err)
{
    int m[3], n = c->n, k = c->k;
    c->seed_len = dm_modal_seed_size(w->an->modal);
    anchor_lattice(c, m);
    c->nanchor = m[0] * m[1] * m[2];
    c->anchor_P = calloc((size_t)c->nanchor, sizeof *c->anchor_P);
    c->anchor_ok = calloc((size_t)c->nanchor, sizeof *c->anchor_ok);
    c->anchor_phi = calloc((size_t)c->nanchor * n * k, sizeof(double));
    c->anchor_seed = c->seed_len ? calloc((size_t)c->nanchor, c->seed_len) : NULL;
    int *queue = malloc(sizeof(int) * c->nanchor), *reach = calloc((size_t)c->nanchor, sizeof(int));
    if (!c->anchor_P || !c->anchor_ok || !c->anchor_phi || !queue || !reach ||
        (c->seed_len && !c->anchor_seed)) {
        free(queue);
        free(reach);
        return dm_fail(err, DM_ENOMEM, "out of memory for mode tracking");
    }
    int root = -1;
    double best = INFINITY;
    for (int a0 = 0; a0 < m[0]; a0++)
        for (int a1 = 0; a1 < m[1]; a1++)
            for (int a2 = 0; a2 < m[2]; a2++) {
                int a[3] = {a0, a1, a2}, idx[3];
                for (int d = 0; d < 3; d++)
                    idx[d] = m[d] == 1 ? 0 : (int)lround((double)a[d] * (c->grid->axis[d].count - 1) / (m[d] - 1));
                int id = anchor_index(c, m, a);
                dm_pose pose;
                dm_grid_position(c->grid, idx, c->anchor_P[id]);
                reach[id] = dm_kin_inverse(c->rb, c->anchor_P[id], &pose, NULL) == DM_OK;
                double dd[3];
                dm_sub3(c->anchor_P[id], c->rb->home_m, dd);
                if (reach[id] && dm_norm3(dd) < best) {
                    best = dm_norm3(dd);
                    root = id;
                }
            }
    /* Continuation tree: up and down the root's column first (one height
     * step at a time), then breadth first within each horizontal layer from
     * that column, so families cross between heights in one place only. */
    int head = 0, tail = 0;
    long reachable = 0;
    for (int i = 0; i < c->nanchor; i++)
        reachable += reach[i];
    if (root >= 0) {
        dm_pose_result res;
        dm_modal_forget(w->an->modal); /* the root starts cold */
        if (!dm_analysis_run(w->an, c->anchor_P[root], c->kc, &res, NULL)) {
            memcpy(c->anchor_phi + (size_t)root * n * k, res.modes->phi, sizeof(double) * n * k);
            if (c->seed_len)
                dm_modal_seed_save(w->an->modal, seed_of(c, root));
            c->anchor_ok[root] = 1;
            queue[tail++] = root;
        }
    }
    int r0 = root / (m[1] * m[2]), r1 = (root / m[2]) % m[1], r2 = root % m[2];
    for (int dir = -1; dir <= 1 && root >= 0; dir += 2)
        for (int a2 = r2 + dir, from = root; a2 >= 0 && a2 < m[2]; a2 += dir) {
            int b[3] = {r0, r1, a2}, nb = anchor_index(c, m, b);
            if (!reach[nb] || !follow(c, w, from, nb))
                break;
            queue[tail++] = nb;
            from = nb;
        }
    while (head < tail) {
        anchor_progress(c, tail, reachable, 0);
        int id = queue[head++], a[3] = {id / (m[1] * m[2]), (id / m[2]) % m[1], id % m[2]};
        for (int d = 0; d < 2; d++)
            for (int s = -1; s <= 1; s += 2) {
                int b[3] = {a[0], a[1], a[2]};
                b[d] += s;
                if (b[d] < 0 || b[d] >= m[d])
                    continue;
                int nb = anchor_index(c, m, b);
                if (reach[nb] && !c->anchor_ok[nb] && follow(c, w, id, nb))
                    queue[tail++] = nb;
            }
    }
    anchor_progress(c, tail, reachable, 1);
    free(queue);
    free(reach);
    return DM_OK;
}

static int nearest_anchor(const sweep_ctx *c, const double P[3])
{
    int best = -1;
    double bd = INFINITY;
    for (int i = 0; i < c->nanchor; i++) {
        if (!c->anchor_ok[i])
            continue;
        double d[3];
        dm_sub3(c->anchor_P[i], P, d);
        if (dm_norm3(d) < bd) {
            bd = dm_norm3(d);
            best = i;
        }
    }
    return best;
}

/* ---- one point --------------------------------------------------------------- */

static void point_nan(dm_point_result *r, int status)
{
    double nan = NAN;
    r->status = status;
    for (int j = 0; j < 64; j++)
        r->freq_hz[j] = r->tracked_hz[j] = nan;
    for (int j = 0; j < 6; j++)
        r->static_error[j] = nan;
    r->compliance_max = r->stiffness_min = r->singularity = nan;
    for (int j = 0; j < 3; j++)
        r->compliance_dir[j] = r->move_peak[j] = r->move_residual[j] = r->move_settling[j] = nan;
}

static void compute_point(const sweep_ctx *c, worker *w, const double P[3], dm_point_result *r)
{
    dm_pose_result res;
    point_nan(r, DM_POINT_OK);
    int an = nearest_anchor(c, P);
    if (an >= 0 && c->seed_len)
        dm_modal_seed_load(w->an->modal, seed_of(c, an));
    else
        dm_modal_forget(w->an->modal); /* no anchor reached: cold */
    int rc = dm_analysis_run(w->an, P, c->kc, &res, NULL);
    if (rc) {
        int unreachable = rc == DM_EUNREACHABLE;
        point_nan(r, unreachable ? DM_POINT_UNREACHABLE : DM_POINT_FAILED);
        if (!unreachable)
            r->singularity = res.pose.cond;
        return;
    }
    r->status = res.near_singular ? DM_POINT_NEAR_SINGULAR : DM_POINT_OK;
    memcpy(r->freq_hz, res.modes->freq_hz, sizeof(double) * c->k);
    memcpy(r->static_error, res.static_error, sizeof r->static_error);
    r->compliance_max = res.compliance_max_m_per_n;
    memcpy(r->compliance_dir, res.compliance_dir, sizeof r->compliance_dir);
    r->stiffness_min = res.stiffness_min_n_per_m;
    r->singularity = res.pose.cond;
    /* families: matched against the nearest anchor's */
    if (an >= 0) {
        match_families(c, w, c->anchor_phi + (size_t)an * c->n * c->k, res.modes, w->shapes);
        for (int f = 0; f < c->k; f++)
            r->tracked_hz[f] = w->assign[f] < 0 ? NAN : res.modes->freq_hz[w->assign[f]];
    }
    if (c->o.dynamic) {
        static const double xyz[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        dm_move_result mv[3];
        if (dm_standard_moves(w->move, w->an->model, res.modes, c->k, w->an->statics, xyz, 3,
                              &c->o.move, mv, NULL)) {
            r->status = DM_POINT_FAILED;
            return;
        }
        for (int d = 0; d < 3; d++) {
            r->move_peak[d] = mv[d].peak_m;
            r->move_residual[d] = mv[d].residual_m;
            r->move_settling[d] = mv[d].settling_s;
        }
    }
}

/* ---- tiles ------------------------------------------------------------------ */

static void tile_coords(const sweep_ctx *c, long t, int64_t tc[4])
{
    tc[2] = t % c->ntiles[2];
    tc[1] = (t / c->ntiles[2]) % c->ntiles[1];
    tc[0] = t / ((long)c->ntiles[2] * c->ntiles[1]);
    tc[3] = 0;
}

/* Every data chunk of the tile present and checksum-valid (read into
 * scratch, which holds the largest chunk). */
static int tile_complete(const sweep_ctx *c, void *scratch, long t)
{
    int64_t tc[4];
    tile_coords(c, t, tc);
    for (int a = 0; a < N_DATA; a++) {
        int missing;
        if (dm_store_read_chunk(&c->store, a, tc, scratch, &missing, NULL))
            return 0;
    }
    return 1;
}

static void fill_buffers(const sweep_ctx *c, worker *w)
{
    for (int a = 0; a < N_DATA; a++) {
        size_t n = dm_store_chunk_elems(&c->store, a);
        if (DATA[a].dtype == DM_DTYPE_UINT8)
            memset(w->buf[a], DM_POINT_NOT_COMPUTED, n);
        else
            for (size_t i = 0; i < n; i++)
                ((double *)w->buf[a])[i] = NAN;
    }
}

static void store_point(const sweep_ctx *c, worker *w, size_t off, const dm_point_result *r)
{
    ((unsigned char *)w->buf[A_STATUS])[off] = (unsigned char)r->status;
    double *b;
#define PUT(a, src, len)                                                                   \
    b = (double *)w->buf[a] + off * (len);                                                 \
    memcpy(b, src, sizeof(double) * (len))
    PUT(A_FREQ, r->freq_hz, c->k);
    PUT(A_TRACKED, r->tracked_hz, c->k);
    PUT(A_STATIC, r->static_error, 6);
    PUT(A_CMAX, &r->compliance_max, 1);
    PUT(A_CDIR, r->compliance_dir, 3);
    PUT(A_KMIN, &r->stiffness_min, 1);
    PUT(A_COND, &r->singularity, 1);
    PUT(A_PEAK, r->move_peak, 3);
    PUT(A_RESID, r->move_residual, 3);
    PUT(A_SETTLE, r->move_settling, 3);
#undef PUT
}

static int compute_tile(const sweep_ctx *c, worker *w, long t, long counts[4], dm_error *err)
{
    int64_t tc[4];
    tile_coords(c, t, tc);
    fill_buffers(c, w);
    /* serpentine path through the tile (each point starts from an anchor's
     * seed: the order changes nothing but memory locality) */
    for (int i0 = 0; i0 < c->tile[0]; i0++)
        for (int j1 = 0; j1 < c->tile[1]; j1++)
            for (int j2 = 0; j2 < c->tile[2]; j2++) {
                int i1 = i0 % 2 ? c->tile[1] - 1 - j1 : j1;
                int i2 = (i0 * c->tile[1] + j1) % 2 ? c->tile[2] - 1 - j2 : j2;
                int idx[3] = {(int)tc[0] * c->tile[0] + i0, (int)tc[1] * c->tile[1] + i1,
                              (int)tc[2] * c->tile[2] + i2};
                if (idx[0] >= c->grid->axis[0].count || idx[1] >= c->grid->axis[1].count ||
                    idx[2] >= c->grid->axis[2].count)
                    continue; /* padding of an edge tile: stays fill value */
                double P[3];
                dm_point_result r;
                dm_grid_position(c->grid, idx, P);
                compute_point(c, w, P, &r);
                store_point(c, w, ((size_t)i0 * c->tile[1] + i1) * c->tile[2] + i2, &r);
                counts[r.status == DM_POINT_NOT_COMPUTED ? 3 : r.status]++;
            }
    /* status last: a reader sees a tile's status only once its data is there */
    for (int a = N_DATA - 1; a >= 0; a--) {
        dm_store_clean_chunk(&c->store, a, tc); /* what a killed run left of it */
        int rc = dm_store_write_chunk(&c->store, a, tc, w->buf[a], err);
        if (rc)
            return rc;
    }
    return DM_OK;
}

/* ---- progress --------------------------------------------------------------- */

static void tile_progress(const sweep_ctx *c, long done, long total, int final)
{
    if (!c->o.progress)
        return;
    dm_sweep_progress p = {DM_SWEEP_TILES, done, total,
                           (long)c->tile[0] * c->tile[1] * c->tile[2],
                           omp_get_wtime() - c->t0, final};
    c->o.progress(c->o.progress_user, &p);
}

/* ---- the run ----------------------------------------------------------------- */

/* What the sweep implies, before any work: time on its threads, files. */
static int check_size(const sweep_ctx *c, dm_error *err)
{
    long tiles = (long)c->ntiles[0] * c->ntiles[1] * c->ntiles[2];
    double files = (double)tiles * N_ARRAYS, s = c->n / 210.0;
    double points = (double)dm_grid_points(c->grid) / (c->o.shards > 1 ? c->o.shards : 1);
    int threads = c->o.threads > 0 ? c->o.threads : omp_get_max_threads();
    double est = points * 2.5e-3 * s * s * (c->o.dynamic ? 1.0 : 0.6) / threads;
    if (c->o.force_long)
        return DM_OK;
    if (files > DM_SWEEP_MAX_FILES)
        return dm_fail(err, DM_EINVAL,
                       "sweep: %ld tiles of %d x %d x %d points make %.3g chunk files, more "
                       "than %ld: use larger tiles (or shards into several stores), or force it",
                       tiles, c->tile[0], c->tile[1], c->tile[2], files, DM_SWEEP_MAX_FILES);
    if (est > DM_SWEEP_MAX_SECONDS)
        return dm_fail(err, DM_EINVAL,
                       "sweep: %.3g points at %d DOF on %d thread%s is about %.3g hours of work "
                       "(the limit is %g hours): use shards, a coarser grid or mesh, or force it",
                       points, c->n, threads, threads > 1 ? "s" : "", est / 3600,
                       DM_SWEEP_MAX_SECONDS / 3600);
    return DM_OK;
}

static int setup(sweep_ctx *c, const dm_robot *rb, const dm_grid *g, const dm_sweep_opts *o,
                 const char *out, dm_error *err)
{
    memset(c, 0, sizeof *c);
    c->rb = rb;
    c->grid = g;
    c->o = *o;
    c->na = o->na ? o->na : rb->na;
    c->nb = o->nb ? o->nb : rb->nb;
    c->n = dm_model_dofs(rb, c->na, c->nb);
    if (o->k < 1 || o->k > 64 || o->k > c->n)
        return dm_fail(err, DM_EINVAL, "sweep: --modes must be 1..64 (and at most %d DOF)", c->n);
    if (o->shards < 0 || o->shard < 0 || (o->shards > 1 ? o->shard >= o->shards : o->shard > 0))
        return dm_fail(err, DM_EINVAL, "sweep: there is no shard %d of %d (0 <= K < N)", o->shard,
                       o->shards);
    c->k = o->k;
    c->kc = c->k + EXTRA_MODES < c->n ? c->k + EXTRA_MODES : c->n;
    auto_tile(g, o->tile, c->tile);
    for (int d = 0; d < 3; d++)
        c->ntiles[d] = (g->axis[d].count + c->tile[d] - 1) / c->tile[d];
    int rc = check_size(c, err);
    if (rc)
        return rc;
    /* no trailing '/': the store's name is also the stem of its staging
     * name; a symbolic link stands for the directory it names (a store is
     * created by renaming onto that) */
    char path[sizeof c->store.path], real[PATH_MAX];
    struct stat sb;
    snprintf(path, sizeof path, "%s", out);
    for (size_t n = strlen(path); n > 1 && path[n - 1] == '/'; n--)
        path[n - 1] = '\0';
    if (!lstat(path, &sb) && S_ISLNK(sb.st_mode) && realpath(path, real) &&
        strlen(real) < sizeof path)
        memcpy(path, real, strlen(real) + 1);
    define_store(c, path);
    return prepare_store(c, path, err);
}

static void teardown(sweep_ctx *c)
{
    free(c->anchor_P);
    free(c->anchor_ok);
    free(c->anchor_phi);
    free(c->anchor_seed);
    for (int a = 0; a < c->store.narr; a++)
        json_decref(c->store.arr[a].attributes);
    json_decref(c->store.group_attributes);
}

/* The tiles of this process: its shard's (all of them without shards). */
typedef struct {
    long total, mine, present;
    char *pending; /* per tile: this shard's and not complete */
} tile_plan;

/* Which of this shard's tiles still need computing: each check reads and
 * verifies a tile's chunks, so the checks run in parallel. */
static int plan_tiles(const sweep_ctx *c, tile_plan *p, dm_error *err)
{
    p->total = (long)c->ntiles[0] * c->ntiles[1] * c->ntiles[2];
    p->mine = p->present = 0;
    p->pending = calloc((size_t)p->total, 1);
    size_t scratch = 0;
    for (int a = 0; a < N_DATA; a++) {
        size_t b = dm_store_chunk_elems(&c->store, a) * dm_dtype_size(DATA[a].dtype);
        scratch = b > scratch ? b : scratch;
    }
    if (!p->pending)
        return dm_fail(err, DM_ENOMEM, "out of memory");
    int nomem = 0;
    long mine = 0, present = 0;
#pragma omp parallel num_threads(c->nthreads) reduction(+ : mine, present) reduction(| : nomem)
    {
        void *buf = malloc(scratch);
        nomem = !buf;
#pragma omp for schedule(static)
        for (long t = 0; t < p->total; t++) {
            if (!buf || dm_shard_of(t, c->o.shards) != c->o.shard)
                continue;
            mine++;
            p->pending[t] = !tile_complete(c, buf, t);
            present += !p->pending[t];
        }
        free(buf);
    }
    p->mine = mine;
    p->present = present;
    return nomem ? dm_fail(err, DM_ENOMEM, "out of memory") : DM_OK;
}

typedef struct {
    long done, counts[4];
    int rc;
    dm_error err;
} tile_result;

/* Compute the pending tiles, in parallel, one tile per thread at a time. */
static void run_tiles(const sweep_ctx *c, tile_plan *p, volatile sig_atomic_t *stop,
                      tile_result *res)
{
    long done = 0, total = p->mine - p->present;
    tile_progress(c, 0, total, 0);
#pragma omp parallel num_threads(c->nthreads)
    {
        worker w;
        dm_error werr = {0};
        int wrc = worker_alloc(c, &w, &werr);
        long local[4] = {0};
#pragma omp for schedule(dynamic, 1)
        for (long t = 0; t < p->total; t++) {
            if (wrc || !p->pending[t] || *stop)
                continue;
            int failed;
#pragma omp atomic read
            failed = res->rc;
            if (failed)
                continue;
            int trc = compute_tile(c, &w, t, local, &werr);
#pragma omp critical(dm_sweep_progress)
            {
                if (trc && !res->rc) {
                    res->rc = trc;
                    res->err = werr;
                }
                if (!trc) {
                    p->pending[t] = 0;
                    tile_progress(c, ++done, total, 0);
                }
            }
        }
#pragma omp critical(dm_sweep_progress)
        {
            for (int s = 0; s < 4; s++)
                res->counts[s] += local[s];
            if (wrc && !res->rc) {
                res->rc = wrc;
                res->err = werr;
            }
        }
        if (!wrc)
            worker_free(&w);
    }
    tile_progress(c, done, total, 1);
    res->done = done;
}

static void fill_stats(const tile_plan *p, const tile_result *r, const dm_grid *g,
                       dm_sweep_stats *stats)
{
    stats->tiles_total = p->total;
    stats->tiles_mine = p->mine;
    stats->tiles_present = p->present;
    stats->tiles_computed = r->done;
    stats->points_total = dm_grid_points(g);
    stats->points_ok = r->counts[0];
    stats->points_unreachable = r->counts[1];
    stats->points_near_singular = r->counts[2];
    stats->points_failed = r->counts[3];
}

int dm_sweep_run(const dm_robot *rb, const dm_grid *g, const dm_sweep_opts *o, const char *out,
                 volatile sig_atomic_t *stop, dm_sweep_stats *stats, dm_error *err)
{
    sweep_ctx c;
    tile_plan plan = {0};
    tile_result res = {0};
    memset(stats, 0, sizeof *stats);
    /* Threads over tiles, BLAS single-threaded everywhere: inside them, and
     * in the serial anchors too, as OpenBLAS's OpenMP build takes its
     * thread count from OpenMP's outside parallel regions (two BLAS threads
     * on 210 x 210 matrices spin more than they compute). */
    int outer = omp_get_max_threads();
    openblas_set_num_threads(1);
    omp_set_num_threads(1);
    double t0 = omp_get_wtime();
    int rc = setup(&c, rb, g, o, out, err);
    c.t0 = t0;
    c.nthreads = o->threads > 0 ? o->threads : outer;
    if (!rc)
        rc = plan_tiles(&c, &plan, err);
    /* anchors only when there is work: a finished shard costs nothing */
    worker w0;
    if (!rc && plan.present < plan.mine && !*stop && !(rc = worker_alloc(&c, &w0, err))) {
        rc = build_anchors(&c, &w0, err);
        worker_free(&w0);
    }
    if (!rc) {
        run_tiles(&c, &plan, stop, &res);
        rc = res.rc;
        if (rc && err)
            *err = res.err;
    }
    fill_stats(&plan, &res, g, stats);
    stats->seconds = omp_get_wtime() - t0;
    if (!rc && plan.present + res.done < plan.mine) {
        stats->interrupted = 1;
        rc = dm_fail(err, DM_EINTERRUPT,
                     "interrupted: %ld of %ld tiles are done and kept in %s; run the same "
                     "command again to resume",
                     plan.present + res.done, plan.mine, out);
    }
    free(plan.pending);
    teardown(&c);
    omp_set_num_threads(outer);
    return rc;
}
