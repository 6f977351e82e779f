/* Workspace sweeps into the map store: the run — workers, points, tiles,
 * scheduling (see dm_sweep.h, sweep_impl.h, docs/store.md). */
#include "sweep_impl.h"

#include <assert.h>
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "dm_coupling.h"
#include "dm_shard.h"
#include "dm_threads.h"
#include "dm_work.h"


void dm_sweep_opts_default(dm_sweep_opts *o)
{
    memset(o, 0, sizeof *o);
    o->k = 10;
    o->dynamic = 1;
    o->members = DM_SWEEP_AUTO;
    dm_move_opts_default(&o->move);
    dm_tolerance_spec_default(&o->tolerance_spec);
}

/* ---- set-up --------------------------------------------------------------- */

static void auto_tile(const dm_grid *g, const int req[3], int tile[3])
{
    for (int d = 0; d < 3; d++) {
        int c = g->axis[d].count;
        tile[d] = req[d] > 0 ? (req[d] < c ? req[d] : c) : (c < 16 ? c : 16);
    }
    if (!req[2] && g->axis[0].count > 1 && g->axis[1].count > 1)
        tile[2] = 1; /* 3-D grids: 16 x 16 x 1 slices */
}

/* ---- per-thread work -------------------------------------------------------- */

static void worker_free(sweep_worker *w)
{
    dm_analysis_free(w->an);
    dm_coupling_free(w->nominal);
    dm_move_free(w->move);
    free(w->mac_work);
    free(w->mac);
    free(w->assign);
    free(w->shapes);
    for (int a = 0; a < w->nbuf; a++)
        free(w->buf[a]);
    free(w->buf);
}

static int worker_alloc(const sweep_ctx *c, sweep_worker *w, dm_error *err)
{
    memset(w, 0, sizeof *w);
    w->an = dm_analysis_alloc(c->rb, c->na, c->nb, c->kc, DM_EIGEN_PARTIAL, err);
    if (!w->an)
        return err ? err->code : DM_ENOMEM;
    if (c->members) { /* the moves run on the reduced model: no shapes, no model */
        int rc = dm_analysis_use_members(w->an, c->members, err);
        if (rc) {
            worker_free(w);
            memset(w, 0, sizeof *w);
            return rc;
        }
        w->an->want_model = w->an->want_shapes = 0;
    }
    if (dm_effects_any(&c->rb->effects) && /* else the change is 0 */
        !(w->nominal = dm_coupling_alloc(c->rb, c->na, c->nb, err))) {
        worker_free(w);
        memset(w, 0, sizeof *w);
        return err ? err->code : DM_ENOMEM;
    }
    w->move = dm_move_alloc(c->n, c->k, err);
    w->mac_work = malloc(sizeof(double) * ((size_t)c->n * (c->k + c->kc) + (size_t)c->k * c->kc));
    w->mac = malloc(sizeof(double) * c->k);
    w->assign = malloc(sizeof(int) * c->k);
    w->shapes = malloc(sizeof(double) * c->n * c->k);
    w->buf = calloc((size_t)c->ndata, sizeof *w->buf);
    w->nbuf = w->buf ? c->ndata : 0;
    int ok = w->move && w->mac_work && w->mac && w->assign && w->shapes && w->buf;
    for (int a = 0; a < w->nbuf && ok; a++)
        ok = (w->buf[a] = malloc(dm_store_chunk_elems(&c->store, a) * dm_dtype_size(dm_sweep_arrays[a].dtype))) != NULL;
    if (!ok) {
        worker_free(w);
        memset(w, 0, sizeof *w); /* the caller frees a failed worker again */
        return dm_fail(err, DM_ENOMEM, "out of memory for a sweep worker");
    }
    return DM_OK;
}

/* ---- one point --------------------------------------------------------------- */

/* Every field at its array's fill (NaN, -1: not computed), the status given. */
static void point_nan(dm_point_result *r, int status)
{
    for (int a = 0; a < dm_sweep_narrays; a++) {
        const dm_sweep_array *d = &dm_sweep_arrays[a];
        char *field = (char *)r + d->offset;
        if (d->dtype == DM_DTYPE_FLOAT64)
            for (size_t j = 0; j < d->size / sizeof(double); j++)
                ((double *)field)[j] = d->fill;
        else
            for (size_t j = 0; j < d->size / sizeof(int); j++)
                ((int *)field)[j] = (int)d->fill;
    }
    r->status = status;
}

static void analyse_point(const sweep_ctx *c, sweep_worker *w, const int idx[3], const double P[3],
                          dm_point_result *r)
{
    dm_pose_result res;
    point_nan(r, DM_POINT_OK);
    int an = dm_sweep_anchors_nearest(c, P);
    if (c->members) { /* the anchor's seed as it is: the filter needs no nudge */
        if (an >= 0)
            dm_analysis_seed_load(w->an, dm_sweep_anchors_seed(c, an));
        else
            dm_analysis_forget(w->an);
    } else if (an >= 0 && c->seed_len) {
        const void *toward[3];
        double frac[3];
        int nt = dm_sweep_anchors_toward(c, an, idx, toward, frac);
        dm_modal_seed_load_toward(w->an->modal, dm_sweep_anchors_seed(c, an), toward, frac, nt);
    } else
        dm_modal_forget(w->an->modal); /* no anchor reached: cold */
    int rc = dm_analysis_run(w->an, P, c->kc, &res, NULL);
    w->served_full = c->members && !rc && res.engine != DM_ENGINE_MEMBERS;
    w->applications = c->members && !rc && res.engine == DM_ENGINE_MEMBERS
                          ? w->an->member_info.applications
                          : 0;
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
    r->coupling_index_log10 = res.coupling_index_log10;
    r->coupling_change_log10 = 0;
    double nominal;
    if (w->nominal) /* NaN where the nominal robot fails there */
        r->coupling_change_log10 = dm_coupling_nominal_log10(w->nominal, P, &nominal, NULL)
                                       ? NAN
                                       : res.coupling_index_log10 - nominal;
    /* families: matched against the nearest anchor's */
    if (an >= 0) {
        dm_sweep_anchors_track(c, w, c->anchor_phi + (size_t)an * c->dim * c->k, &res, w->shapes);
        for (int f = 0; f < c->k; f++)
            r->tracked_hz[f] = w->assign[f] < 0 ? NAN : res.modes->freq_hz[w->assign[f]];
    }
    if (c->o.dynamic) {
        static const double xyz[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        dm_move_result mv[3];
        dm_analysis *a = w->an;
        int rc = a->last_members
                     ? dm_standard_moves_reduced(w->move, a->boundary, a->eig, c->rb, &res.pose,
                                                 a->reduced, dm_boundary_eig_mass_vectors(a->eig),
                                                 res.modes->omega_rad_s, c->k, xyz, 3, &c->o.move,
                                                 mv, NULL)
                     : dm_standard_moves(w->move, a->model, res.modes, c->k, a->statics, xyz, 3,
                                         &c->o.move, mv, NULL);
        if (rc) {
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

/* The tolerance Monte Carlo at a point the analysis reached: what
 * dm_tolerance_pose gives at P. A pose where it fails (a sampled robot's
 * chains do not close near the workspace's edge, a singular structure)
 * keeps NaN and -1: the rest of the point stands. */
static void tolerance_point(const sweep_ctx *c, const double P[3], dm_point_result *r)
{
    if (r->status != DM_POINT_OK && r->status != DM_POINT_NEAR_SINGULAR)
        return;
    dm_tolerance_result t;
    if (dm_tolerance_pose(c->rb, &c->tol, P, 1, &t, NULL))
        return;
    r->error_mean_m = t.mean_error_m;
    r->error_p95_m = t.p95_error_m;
    r->error_max_m = t.max_error_m;
    r->p_exceed_spec = t.p_exceed_spec;
    r->dominant_source = t.dominant;
}

static void compute_point(const sweep_ctx *c, sweep_worker *w, const int idx[3], const double P[3],
                          dm_point_result *r)
{
    analyse_point(c, w, idx, P, r);
    if (c->o.tolerance)
        tolerance_point(c, P, r);
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
    for (int a = 0; a < c->ndata; a++) {
        int missing;
        if (dm_store_read_chunk(&c->store, a, tc, scratch, &missing, NULL))
            return 0;
    }
    return 1;
}

/* Every point of the tile's chunks at its array's fill (the padding of an
 * edge tile stays so). */
static void fill_buffers(const sweep_ctx *c, sweep_worker *w)
{
    for (int a = 0; a < c->ndata; a++) {
        double fill = dm_sweep_arrays[a].fill;
        size_t n = dm_store_chunk_elems(&c->store, a);
        for (size_t i = 0; i < n; i++)
            switch (dm_sweep_arrays[a].dtype) {
            case DM_DTYPE_UINT8: ((unsigned char *)w->buf[a])[i] = (unsigned char)fill; break;
            case DM_DTYPE_INT32: ((int32_t *)w->buf[a])[i] = (int32_t)fill; break;
            case DM_DTYPE_FLOAT64: ((double *)w->buf[a])[i] = fill; break;
            }
    }
}

/* The point's values into each chunk at point offset off. */
static void store_point(const sweep_ctx *c, sweep_worker *w, size_t off, const dm_point_result *r)
{
    for (int a = 0; a < c->ndata; a++) {
        const dm_sweep_array *d = &dm_sweep_arrays[a];
        const char *field = (const char *)r + d->offset;
        size_t len = (size_t)dm_sweep_extra_len(d->extra, c->k);
        assert(len * (d->dtype == DM_DTYPE_FLOAT64 ? sizeof(double) : sizeof(int)) <= d->size);
        switch (d->dtype) {
        case DM_DTYPE_UINT8:
            for (size_t j = 0; j < len; j++)
                ((unsigned char *)w->buf[a])[off * len + j] = (unsigned char)((const int *)field)[j];
            break;
        case DM_DTYPE_INT32:
            for (size_t j = 0; j < len; j++)
                ((int32_t *)w->buf[a])[off * len + j] = ((const int *)field)[j];
            break;
        case DM_DTYPE_FLOAT64:
            memcpy((double *)w->buf[a] + off * len, field, sizeof(double) * len);
            break;
        }
    }
}

/* A run's counts: points by status (dm_point_status: ok, unreachable,
 * near-singular, failed), then with o.members the points the full model
 * served and the applications of K^-1 M of those the members served. */
enum { COUNT_FULL_MODEL = DM_POINT_FAILED + 1, COUNT_APPLICATIONS, NCOUNTS };

static int compute_tile(const sweep_ctx *c, sweep_worker *w, long t, long counts[NCOUNTS],
                        dm_error *err)
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
                compute_point(c, w, idx, P, &r);
                store_point(c, w, ((size_t)i0 * c->tile[1] + i1) * c->tile[2] + i2, &r);
                counts[r.status == DM_POINT_NOT_COMPUTED ? DM_POINT_FAILED : r.status]++;
                counts[COUNT_FULL_MODEL] += w->served_full;
                counts[COUNT_APPLICATIONS] += w->applications;
            }
    /* status last: a reader sees a tile's status only once its data is there */
    assert(!strcmp(dm_sweep_arrays[0].name, "status"));
    for (int a = c->ndata - 1; a >= 0; a--) {
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
    double files = (double)tiles * (c->ndata + N_AXES_LABELS), s = c->n / 210.0;
    double points = (double)dm_grid_points(c->grid) / (c->o.shards > 1 ? c->o.shards : 1);
    int threads = c->nthreads;
    double per_point = 2.5e-3 * s * s * (c->o.dynamic ? 1.0 : 0.6);
    if (c->o.tolerance)
        per_point += dm_tolerance_estimate_s(c->rb, &c->tol);
    dm_work need = {points * per_point / threads, 0, files},
            limit = {DM_SWEEP_MAX_SECONDS, 0, DM_SWEEP_MAX_FILES};
    char what[256], hint[160];
    snprintf(what, sizeof what, "sweep: %.3g points at %d DOF%s on %d thread%s, in %ld tiles of "
             "%d x %d x %d points (a chunk file per array and tile)", points, c->n,
             c->o.tolerance ? " with the tolerance Monte Carlo" : "", threads,
             threads > 1 ? "s" : "", tiles, c->tile[0], c->tile[1], c->tile[2]);
    int slow = !(need.seconds <= limit.seconds), many = !(need.files <= limit.files);
    snprintf(hint, sizeof hint, "%s%s%s%s", slow ? "shards, a coarser grid or mesh" : "",
             slow && c->o.tolerance ? ", fewer tolerance samples" : "", slow && many ? "; " : "",
             many ? "larger tiles (or shards into several stores)" : "");
    return dm_work_check(what, need, limit, hint, c->o.force_long, err);
}

/* The member bases for the sweep's robot, mesh and modes (c->members and
 * the reduced size in c->dim), or why not: DM_EINVAL when the bases are
 * too small for the modes, another code when they cannot be built. */
static int build_members(sweep_ctx *c, dm_error *err)
{
    if (!(c->members = dm_analysis_members(c->rb, c->na, c->nb, c->kc, err)))
        return err->code ? err->code : DM_EINVAL;
    int dim = dm_members_reduced_size(c->members);
    if (c->kc < dim) {
        c->dim = dim;
        return DM_OK;
    }
    dm_members_free(c->members);
    c->members = NULL;
    return dm_fail(err, DM_EINVAL,
                   "member bases: %d modes (%d and %d more for mode tracking) need a reduced "
                   "model larger than the bases' %d DOF at this mesh",
                   c->kc, c->k, c->kc - c->k, dim);
}

/* The engine (see dm_sweep_opts.members) into c->o.members, with the
 * members built where they run. Decided before the store is opened: the
 * engine is part of its fingerprint. */
static int choose_engine(sweep_ctx *c, const char *path, dm_error *err)
{
    int want = c->o.members;
    dm_error why = {0};
    c->o.members = DM_SWEEP_FULL_MODEL;
    if (want == DM_SWEEP_FULL_MODEL)
        return DM_OK;
    if (want == DM_SWEEP_AUTO) { /* a store of this sweep keeps its engine */
        dm_sweep_schema_define(c, path);
        int kept = dm_sweep_store_engine(c, path);
        dm_store_release(&c->store);
        if (kept == DM_SWEEP_FULL_MODEL) {
            snprintf(c->engine_why, sizeof c->engine_why,
                     "the store being resumed was made with it");
            return DM_OK;
        }
    }
    int rc = build_members(c, &why);
    if (!rc) {
        c->o.members = DM_SWEEP_MEMBERS;
        return DM_OK;
    }
    if (want == DM_SWEEP_MEMBERS || rc == DM_ENOMEM)
        return dm_fail(err, rc, "sweep --method members: %s%s", why.msg,
                       rc == DM_EINVAL ? "; use fewer modes or --method partial" : "");
    snprintf(c->engine_why, sizeof c->engine_why, "%.190s", why.msg);
    return DM_OK;
}

static int setup(sweep_ctx *c, const dm_robot *rb, const dm_grid *g, const dm_sweep_opts *o,
                 int nthreads, const char *out, dm_error *err)
{
    memset(c, 0, sizeof *c);
    c->nthreads = nthreads;
    c->rb = rb;
    c->grid = g;
    c->o = *o;
    c->na = o->na ? o->na : rb->na;
    c->nb = o->nb ? o->nb : rb->nb;
    c->n = dm_model_dofs(rb, c->na, c->nb);
    if (o->k < 1 || o->k > DM_MAX_MODES || o->k > c->n)
        return dm_fail(err, DM_EINVAL, "sweep: the number of modes must be 1..%d (and at most %d DOF)",
                       DM_MAX_MODES, c->n);
    if (o->shards < 0 || o->shard < 0 || (o->shards > 1 ? o->shard >= o->shards : o->shard > 0))
        return dm_fail(err, DM_EINVAL, "sweep: there is no shard %d of %d (0 <= K < N)", o->shard,
                       o->shards);
    c->k = o->k;
    c->kc = c->k + EXTRA_MODES < c->n ? c->k + EXTRA_MODES : c->n;
    c->dim = c->n;
    c->ndata = dm_sweep_ndata(o->tolerance, o->tolerance_spec.spec_m);
    if (o->tolerance) {
        c->tol = o->tolerance_spec;
        c->tol.na = c->na;
        c->tol.nb = c->nb;
        c->tol.flexibility = 1;
        c->tol.force_long = o->force_long;
        c->tol.progress = NULL; /* its points run on many threads: the sweep reports tiles */
        c->tol.progress_user = NULL;
        dm_error terr;
        if (dm_tolerance_check(rb, &c->tol, &terr))
            return dm_fail(err, terr.code, "sweep: tolerance %s", terr.msg);
    }
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
    if ((rc = choose_engine(c, path, err)))
        return rc;
    dm_sweep_schema_define(c, path);
    return dm_sweep_store_prepare(c, path, err);
}

static void teardown(sweep_ctx *c)
{
    dm_members_free(c->members);
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
    for (int a = 0; a < c->ndata; a++) {
        size_t b = dm_store_chunk_elems(&c->store, a) * dm_dtype_size(dm_sweep_arrays[a].dtype);
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
    long done, counts[NCOUNTS];
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
        sweep_worker w;
        dm_error werr = {0};
        int wrc = worker_alloc(c, &w, &werr);
        long local[NCOUNTS] = {0};
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
            for (int s = 0; s < NCOUNTS; s++)
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

/* The anchors, with a worker per thread. */
static int build_anchors(sweep_ctx *c, dm_error *err)
{
    int nw = c->nthreads, rc = DM_OK, made = 0;
    sweep_worker *w = calloc((size_t)nw, sizeof *w);
    if (!w)
        return dm_fail(err, DM_ENOMEM, "out of memory for sweep workers");
    while (made < nw && !(rc = worker_alloc(c, &w[made], err)))
        made++;
    if (!rc)
        rc = dm_sweep_anchors_build(c, w, nw, err);
    for (int i = 0; i < made; i++)
        worker_free(&w[i]);
    free(w);
    return rc;
}

static void fill_stats(const tile_plan *p, const tile_result *r, const dm_grid *g,
                       dm_sweep_stats *stats)
{
    stats->tiles_total = p->total;
    stats->tiles_mine = p->mine;
    stats->tiles_present = p->present;
    stats->tiles_computed = r->done;
    stats->points_total = dm_grid_points(g);
    stats->points_ok = r->counts[DM_POINT_OK];
    stats->points_unreachable = r->counts[DM_POINT_UNREACHABLE];
    stats->points_near_singular = r->counts[DM_POINT_NEAR_SINGULAR];
    stats->points_failed = r->counts[DM_POINT_FAILED];
    stats->points_full_model = r->counts[COUNT_FULL_MODEL];
    stats->members_applications = r->counts[COUNT_APPLICATIONS];
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
    int outer = dm_threads_count(o->threads);
    dm_threads_saved saved = dm_threads_serial_blas();
    double t0 = omp_get_wtime();
    int rc = setup(&c, rb, g, o, outer, out, err);
    c.t0 = t0;
    if (!rc)
        rc = plan_tiles(&c, &plan, err);
    /* anchors only when there is work: a finished shard costs nothing */
    if (!rc && plan.present < plan.mine && !*stop)
        rc = build_anchors(&c, err);
    if (!rc) {
        run_tiles(&c, &plan, stop, &res);
        rc = res.rc;
        if (rc && err)
            *err = res.err;
    }
    fill_stats(&plan, &res, g, stats);
    stats->members = c.o.members == DM_SWEEP_MEMBERS ? DM_SWEEP_MEMBERS : DM_SWEEP_FULL_MODEL;
    snprintf(stats->engine_why, sizeof stats->engine_why, "%s", c.engine_why);
    stats->store_refused = c.store_refused;
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
    dm_threads_restore(saved);
    return rc;
}
