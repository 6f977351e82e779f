/* Workspace sweeps into the map store (see dm_sweep.h, docs/store.md). */
#define _XOPEN_SOURCE 700 /* nftw */
#include "dm_sweep.h"

#include <cblas.h>
#include <dirent.h>
#include <ftw.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

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
    dm_store store;
    /* anchors for mode tracking (read-only once built) */
    int nanchor;
    double (*anchor_P)[3];
    int *anchor_ok;
    double *anchor_phi;  /* nanchor x (n x k) */
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

static int remove_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)flag, (void)ftw;
    return remove(path);
}

static int remove_temporaries(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)ftw;
    if (flag == FTW_F && strstr(path, ".tmp."))
        remove(path); /* left by a killed writer: never a finished file */
    return 0;
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

/* Does directory `dir` hold nothing but zarr.json (or its temporary)? */
static int only_zarr_json(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    struct dirent *e;
    int ok = 1;
    while (ok && (e = readdir(d)))
        ok = !strcmp(e->d_name, ".") || !strcmp(e->d_name, "..") ||
             !strcmp(e->d_name, "zarr.json") || !strncmp(e->d_name, "zarr.json.tmp.", 14);
    closedir(d);
    return ok;
}

/* What a sweep stopped while writing its metadata leaves (no group
 * zarr.json yet, it is written last): only this layout's array
 * directories, each with nothing but its zarr.json. A rerun takes it up. */
static int unfinished_metadata(const sweep_ctx *c, const char *path)
{
    DIR *d = opendir(path);
    if (!d)
        return 0;
    struct dirent *e;
    int ok = 1;
    while (ok && (e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        int known = 0;
        for (int a = 0; a < c->store.narr && !known; a++)
            known = !strcmp(e->d_name, c->store.arr[a].name);
        char sub[1100];
        snprintf(sub, sizeof sub, "%s/%s", path, e->d_name);
        ok = known && only_zarr_json(sub);
    }
    closedir(d);
    return ok;
}

/* Existing store: same fingerprint resumes; another is refused unless force. */
static int prepare_store(sweep_ctx *c, const char *path, dm_error *err)
{
    char file[1100];
    snprintf(file, sizeof file, "%s/zarr.json", path);
    if (access(file, F_OK) == 0) {
        dm_store old;
        int rc = dm_store_read_metadata(path, &old, err);
        if (rc == DM_ENOMEM)
            return rc; /* not a verdict on the store */
        json_t *ofp = rc ? NULL : json_object_get(json_object_get(old.group_attributes, "deltamap"), "fingerprint");
        json_t *nfp = json_object_get(json_object_get(c->store.group_attributes, "deltamap"), "fingerprint");
        int same = ofp && json_equal(ofp, nfp);
        const char *what = !ofp ? "an unreadable store"
                           : !json_equal(json_object_get(ofp, "robot_ini"), json_object_get(nfp, "robot_ini")) ? "another robot"
                           : !json_equal(json_object_get(ofp, "grid"), json_object_get(nfp, "grid")) ? "another grid"
                           : "other options (modes, mesh, tile, move or version)";
        if (!rc)
            dm_store_release(&old);
        if (!same && !c->o.force)
            return dm_fail(err, DM_EINVAL,
                           "%s holds a sweep of %s; use --force to overwrite it or choose another --out",
                           path, what);
        if (!same && nftw(path, remove_entry, 16, FTW_DEPTH | FTW_PHYS))
            return dm_fail(err, DM_EIO, "%s: cannot remove the old store", path);
        if (same)
            nftw(path, remove_temporaries, 16, FTW_PHYS);
    } else if (!dir_is_empty(path)) {
        if (!unfinished_metadata(c, path))
            return dm_fail(err, DM_EINVAL,
                           "%s exists and is not a map store; choose another --out", path);
        nftw(path, remove_temporaries, 16, FTW_PHYS);
    }
    int rc = dm_store_write_metadata(&c->store, err);
    return rc ? rc : write_coordinates(c, err);
}

/* ---- per-thread work -------------------------------------------------------- */

typedef struct {
    dm_analysis *an;
    dm_move_ws *move;
    double *mac_work, *mac;
    int *assign;
    double *prev;       /* families' shapes at the previous point (n x k) */
    int have_prev;
    void *buf[N_DATA];
} worker;

static void worker_free(worker *w)
{
    dm_analysis_free(w->an);
    dm_move_free(w->move);
    free(w->mac_work);
    free(w->mac);
    free(w->assign);
    free(w->prev);
    for (int a = 0; a < N_DATA; a++)
        free(w->buf[a]);
}

static int worker_alloc(const sweep_ctx *c, worker *w, dm_error *err)
{
    memset(w, 0, sizeof *w);
    w->an = dm_analysis_alloc(c->rb, c->na, c->nb, c->kc, DM_EIGEN_PARTIAL, err);
    if (!w->an)
        return err->code;
    w->move = dm_move_alloc(c->n, c->k, err);
    w->mac_work = malloc(sizeof(double) * (2 * (size_t)c->n * c->k + (size_t)c->k * c->kc));
    w->mac = malloc(sizeof(double) * c->k);
    w->assign = malloc(sizeof(int) * c->k);
    w->prev = malloc(sizeof(double) * c->n * c->k);
    int ok = w->move && w->mac_work && w->mac && w->assign && w->prev;
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

/* Match the k families with shapes `ref` to the current modes by MAC
 * (w->assign) and store the matched shapes in dst (may be ref itself). */
static void match_families(const sweep_ctx *c, worker *w, const double *ref,
                           const dm_modes *modes, double *dst)
{
    dm_modal_mac_match(ref, c->k, modes, c->kc, w->an->model, w->assign, w->mac, w->mac_work);
    for (int f = 0; f < c->k; f++)
        memcpy(dst + (size_t)f * c->n, modes->phi + (size_t)w->assign[f] * c->n,
               sizeof(double) * c->n);
}

/* Families at anchor `to`, continued from anchor `from` by MAC. */
static int follow(sweep_ctx *c, worker *w, int from, int to)
{
    size_t block = (size_t)c->n * c->k;
    dm_pose_result res;
    if (dm_analysis_run(w->an, c->anchor_P[to], c->kc, &res, NULL))
        return 0;
    match_families(c, w, c->anchor_phi + from * block, res.modes, c->anchor_phi + to * block);
    c->anchor_ok[to] = 1;
    return 1;
}

/* A coarse lattice (at most 16 per axis) of reference poses. Families are
 * the k lowest modes at the root (the anchor nearest the robot's home),
 * followed to every other reachable anchor by MAC, serially:
 * the result is fixed before any tile runs. Memory: at most 4096 anchors. */
static int build_anchors(sweep_ctx *c, worker *w, dm_error *err)
{
    int m[3], n = c->n, k = c->k;
    for (int d = 0; d < 3; d++)
        m[d] = c->grid->axis[d].count < ANCHORS_PER_AXIS ? c->grid->axis[d].count : ANCHORS_PER_AXIS;
    c->nanchor = m[0] * m[1] * m[2];
    c->anchor_P = calloc((size_t)c->nanchor, sizeof *c->anchor_P);
    c->anchor_ok = calloc((size_t)c->nanchor, sizeof *c->anchor_ok);
    c->anchor_phi = calloc((size_t)c->nanchor * n * k, sizeof(double));
    int *queue = malloc(sizeof(int) * c->nanchor), *reach = calloc((size_t)c->nanchor, sizeof(int));
    if (!c->anchor_P || !c->anchor_ok || !c->anchor_phi || !queue || !reach) {
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
    if (root >= 0) {
        dm_pose_result res;
        if (!dm_analysis_run(w->an, c->anchor_P[root], c->kc, &res, NULL)) {
            memcpy(c->anchor_phi + (size_t)root * n * k, res.modes->phi, sizeof(double) * n * k);
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
    int rc = dm_analysis_run(w->an, P, c->kc, &res, NULL);
    if (rc) {
        w->have_prev = 0; /* the path is broken: restart from an anchor */
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
    /* families: continue from the previous point of this tile's path, or
     * start from the nearest anchor */
    const double *ref = w->have_prev ? w->prev : NULL;
    int an = ref ? -1 : nearest_anchor(c, P);
    if (an >= 0)
        ref = c->anchor_phi + (size_t)an * c->n * c->k;
    if (ref) {
        match_families(c, w, ref, res.modes, w->prev);
        for (int f = 0; f < c->k; f++)
            r->tracked_hz[f] = res.modes->freq_hz[w->assign[f]];
        w->have_prev = 1;
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

/* Every data chunk of the tile present and checksum-valid. */
static int tile_complete(const sweep_ctx *c, worker *w, long t)
{
    int64_t tc[4];
    tile_coords(c, t, tc);
    for (int a = 0; a < N_DATA; a++) {
        int missing;
        if (dm_store_read_chunk(&c->store, a, tc, w->buf[a], &missing, NULL))
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
    w->have_prev = 0;
    dm_modal_forget(w->an->modal); /* a tile's values do not depend on the thread's last tile */
    /* serpentine path through the tile, so each point follows a neighbour */
    for (int i0 = 0; i0 < c->tile[0]; i0++)
        for (int j1 = 0; j1 < c->tile[1]; j1++)
            for (int j2 = 0; j2 < c->tile[2]; j2++) {
                int i1 = i0 % 2 ? c->tile[1] - 1 - j1 : j1;
                int i2 = (i0 * c->tile[1] + j1) % 2 ? c->tile[2] - 1 - j2 : j2;
                int idx[3] = {(int)tc[0] * c->tile[0] + i0, (int)tc[1] * c->tile[1] + i1,
                              (int)tc[2] * c->tile[2] + i2};
                if (idx[0] >= c->grid->axis[0].count || idx[1] >= c->grid->axis[1].count ||
                    idx[2] >= c->grid->axis[2].count) {
                    w->have_prev = 0; /* padding of an edge tile: stays fill value */
                    continue;
                }
                double P[3];
                dm_point_result r;
                dm_grid_position(c->grid, idx, P);
                compute_point(c, w, P, &r);
                store_point(c, w, ((size_t)i0 * c->tile[1] + i1) * c->tile[2] + i2, &r);
                counts[r.status == DM_POINT_NOT_COMPUTED ? 3 : r.status]++;
            }
    /* status last: a reader sees a tile's status only once its data is there */
    for (int a = N_DATA - 1; a >= 0; a--) {
        int rc = dm_store_write_chunk(&c->store, a, tc, w->buf[a], err);
        if (rc)
            return rc;
    }
    return DM_OK;
}

/* ---- progress --------------------------------------------------------------- */

typedef struct {
    int mode;
    long total, done;
    double t0, last;
    long points_per_tile;
} progress;

static void progress_show(progress *p, int final)
{
    double now = omp_get_wtime(), el = now - p->t0;
    if (!p->mode || (!final && now - p->last < (p->mode == 1 ? 0.25 : 10.0)))
        return;
    p->last = now;
    double rate = el > 0 ? p->done * p->points_per_tile / el : 0;
    double eta = p->done ? el * (p->total - p->done) / p->done : 0;
    int pct = p->total ? (int)(100 * p->done / p->total) : 100;
    if (p->mode == 1) {
        char bar[31];
        int fill = pct * 30 / 100;
        for (int i = 0; i < 30; i++)
            bar[i] = i < fill ? '#' : '.';
        bar[30] = '\0';
        fprintf(stderr, "\r[%s] %3d%%  %ld/%ld tiles  %.0f points/s  ETA %.0fs   %s", bar, pct,
                p->done, p->total, rate, eta, final ? "\n" : "");
    } else {
        fprintf(stderr, "sweep: %ld/%ld tiles (%d%%), %.0f points/s, ETA %.0f s\n", p->done,
                p->total, pct, rate, eta);
    }
    fflush(stderr);
}

/* ---- the run ----------------------------------------------------------------- */

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
    c->k = o->k;
    c->kc = c->k + EXTRA_MODES < c->n ? c->k + EXTRA_MODES : c->n;
    auto_tile(g, o->tile, c->tile);
    for (int d = 0; d < 3; d++)
        c->ntiles[d] = (g->axis[d].count + c->tile[d] - 1) / c->tile[d];
    define_store(c, out);
    return prepare_store(c, out, err);
}

static void teardown(sweep_ctx *c)
{
    free(c->anchor_P);
    free(c->anchor_ok);
    free(c->anchor_phi);
    for (int a = 0; a < c->store.narr; a++)
        json_decref(c->store.arr[a].attributes);
    json_decref(c->store.group_attributes);
}

int dm_sweep_run(const dm_robot *rb, const dm_grid *g, const dm_sweep_opts *o, const char *out,
                 volatile sig_atomic_t *stop, dm_sweep_stats *stats, dm_error *err)
{
    sweep_ctx c;
    memset(stats, 0, sizeof *stats);
    int rc = setup(&c, rb, g, o, out, err);
    long ntiles = (long)c.ntiles[0] * c.ntiles[1] * c.ntiles[2];
    char *pending = rc ? NULL : calloc((size_t)ntiles, 1);
    if (!rc && !pending)
        rc = dm_fail(err, DM_ENOMEM, "out of memory");
    worker w0;
    if (!rc && !(rc = worker_alloc(&c, &w0, err))) {
        rc = build_anchors(&c, &w0, err);
        worker_free(&w0);
    }
    /* BLAS runs single-threaded inside our threads; threads over tiles. */
    int nthreads = o->threads > 0 ? o->threads : omp_get_max_threads();
    openblas_set_num_threads(1);
    omp_set_num_threads(nthreads);
    double t0 = omp_get_wtime();
    long present = 0, counts[4] = {0};
    int first_err = DM_OK;
    dm_error shared_err = {0};
    progress pg = {o->progress, 0, 0, t0, 0, (long)c.tile[0] * c.tile[1] * c.tile[2]};
    if (!rc) {
#pragma omp parallel
        {
            worker w;
            dm_error werr = {0};
            int wrc = worker_alloc(&c, &w, &werr);
#pragma omp for schedule(static)
            for (long t = 0; t < ntiles; t++) /* which tiles are already done */
                if (!wrc) {
                    pending[t] = !tile_complete(&c, &w, t);
                    if (!pending[t]) {
#pragma omp atomic
                        present++;
                    }
                }
#pragma omp single
            pg.total = ntiles - present; /* after the loop's barrier: every tile checked */
            long local[4] = {0};
#pragma omp for schedule(dynamic, 1)
            for (long t = 0; t < ntiles; t++) {
                if (wrc || !pending[t] || *stop)
                    continue;
                int failed;
#pragma omp atomic read
                failed = first_err;
                if (failed)
                    continue;
                int trc = compute_tile(&c, &w, t, local, &werr);
#pragma omp critical(dm_sweep_progress)
                {
                    if (trc && !first_err) {
                        first_err = trc;
                        shared_err = werr;
                    }
                    if (!trc) {
                        pending[t] = 0;
                        pg.done++;
                        progress_show(&pg, 0);
                    }
                }
            }
#pragma omp critical(dm_sweep_progress)
            {
                for (int s = 0; s < 4; s++)
                    counts[s] += local[s];
                if (wrc && !first_err) {
                    first_err = wrc;
                    shared_err = werr;
                }
            }
            worker_free(&w);
        }
        progress_show(&pg, 1);
    }
    if (!rc && first_err) {
        rc = first_err;
        if (err)
            *err = shared_err;
    }
    stats->tiles_total = ntiles;
    stats->tiles_present = present;
    stats->tiles_computed = pg.done;
    stats->points_total = dm_grid_points(g);
    stats->points_ok = counts[0];
    stats->points_unreachable = counts[1];
    stats->points_near_singular = counts[2];
    stats->points_failed = counts[3];
    stats->seconds = omp_get_wtime() - t0;
    if (!rc && present + pg.done < ntiles) {
        stats->interrupted = 1;
        rc = dm_fail(err, DM_EINTERRUPT,
                     "interrupted: %ld of %ld tiles are done and kept in %s; run the same "
                     "command again to resume",
                     present + pg.done, ntiles, out);
    }
    free(pending);
    teardown(&c);
    return rc;
}
