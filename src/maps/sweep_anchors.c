/* Mode tracking's anchors: a coarse lattice of reference poses whose mode
 * families and solver seeds every point of the sweep starts from, so that
 * a point's values depend on the grid alone (see sweep_impl.h). */
#include <assert.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "dm_vec3.h"
#include "sweep_impl.h"

/* Anchors per axis: one per POINTS_PER_ANCHOR grid points, at least
 * ANCHORS_MIN (every point of a smaller axis), at most ANCHORS_MAX, and
 * fewer while the lattice would exceed ANCHOR_BYTES. A point starts
 * between the seeds of the anchors around it, whose error falls with the
 * square of their spacing. chen2018 over +-0.3 m, 2 threads, the anchors'
 * own solves included: on 256 x 256 points 32 per axis (19 mm apart)
 * instead of 16 made the sweep 8.7 % faster; on 512 x 512, the cap's ~54
 * (11 mm) instead of 32, 9.2 % (99.2 instead of 109.3 s; peak memory 120
 * instead of 49 MB). Every shard of a cluster job builds the whole
 * lattice (docs/cluster.md). */
#define ANCHORS_MIN 16
#define ANCHORS_MAX 64
#define POINTS_PER_ANCHOR 8


static int anchor_index(const sweep_ctx *c, const int m[3], const int a[3])
{
    (void)c;
    return (a[0] * m[1] + a[1]) * m[2] + a[2];
}

int dm_sweep_anchors_track(const sweep_ctx *c, sweep_worker *w, const double *ref,
                           const dm_pose_result *res, double *dst)
{
    return dm_analysis_track(w->an, res, ref, c->k, c->kc, w->assign, w->mac, dst, w->mac_work);
}

unsigned char *dm_sweep_anchors_seed(const sweep_ctx *c, int a)
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
static int follow(sweep_ctx *c, sweep_worker *w, int from, int to)
{
    size_t block = (size_t)c->dim * c->k;
    dm_pose_result res;
    if (c->seed_len)
        dm_analysis_seed_load(w->an, dm_sweep_anchors_seed(c, from));
    if (dm_analysis_run(w->an, c->anchor_P[to], c->kc, &res, NULL) ||
        dm_sweep_anchors_track(c, w, c->anchor_phi + from * block, &res,
                               c->anchor_phi + to * block))
        return 0;
    if (c->seed_len)
        dm_analysis_seed_save(w->an, dm_sweep_anchors_seed(c, to));
    c->anchor_ok[to] = 1;
    return 1;
}

/* Anchors per axis (see ANCHORS_MIN), fewer (the largest axis first) while
 * the lattice's shapes and seeds would exceed ANCHOR_BYTES. */
#define ANCHOR_BYTES (128u << 20)
static void anchor_lattice(const sweep_ctx *c, int m[3])
{
    size_t per = (size_t)c->dim * c->k * sizeof(double) + c->seed_len + 64;
    for (int d = 0; d < 3; d++) {
        int count = c->grid->axis[d].count, want = count / POINTS_PER_ANCHOR;
        want = want < ANCHORS_MIN ? ANCHORS_MIN : want > ANCHORS_MAX ? ANCHORS_MAX : want;
        m[d] = count < want ? count : want;
    }
    while ((size_t)m[0] * m[1] * m[2] * per > ANCHOR_BYTES) {
        int big = m[0] >= m[1] && m[0] >= m[2] ? 0 : m[1] >= m[2] ? 1 : 2;
        m[big]--;
    }
}

/* The grid index of lattice position a along axis d (m per axis). */
static int anchor_grid_index(const sweep_ctx *c, const int m[3], const int a[3], int d)
{
    return m[d] == 1 ? 0 : (int)lround((double)a[d] * (c->grid->axis[d].count - 1) / (m[d] - 1));
}

int dm_sweep_anchors_toward(const sweep_ctx *c, int an, const int idx[3], const void *toward[3],
                            double frac[3])
{
    const int *m = c->anchor_m;
    int a[3] = {an / (m[1] * m[2]), (an / m[2]) % m[1], an % m[2]}, count = 0;
    for (int d = 0; d < 3; d++) {
        int at = anchor_grid_index(c, m, a, d);
        if (idx[d] == at)
            continue;
        int b[3] = {a[0], a[1], a[2]};
        b[d] += idx[d] > at ? 1 : -1;
        if (b[d] < 0 || b[d] >= m[d])
            continue;
        int nb = anchor_index(c, m, b), to = anchor_grid_index(c, m, b, d);
        double f = (double)(idx[d] - at) / (to - at);
        if (!c->anchor_ok[nb] || !(f > 0 && f <= 1))
            continue;
        toward[count] = dm_sweep_anchors_seed(c, nb);
        frac[count++] = f;
    }
    return count;
}

/* Place the anchors on the grid: reach[id] says which are reachable;
 * returns the reachable one nearest the robot's home (-1: none). */
static int place_anchors(sweep_ctx *c, const int m[3], int *reach)
{
    int root = -1;
    double best = INFINITY;
    for (int a0 = 0; a0 < m[0]; a0++)
        for (int a1 = 0; a1 < m[1]; a1++)
            for (int a2 = 0; a2 < m[2]; a2++) {
                int a[3] = {a0, a1, a2}, idx[3];
                for (int d = 0; d < 3; d++)
                    idx[d] = anchor_grid_index(c, m, a, d);
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
    return root;
}

/* The root (cold) and, one height step at a time, its column up and down,
 * serially: into the queue, whose new tail is returned. */
static int root_column(sweep_ctx *c, sweep_worker *w, const int m[3], const int *reach, int root,
                       int *queue)
{
    int tail = 0;
    size_t block = (size_t)c->dim * c->k;
    dm_pose_result res;
    dm_analysis_forget(w->an); /* the root starts cold */
    if (dm_analysis_run(w->an, c->anchor_P[root], c->kc, &res, NULL) ||
        !dm_analysis_track_vectors(w->an, &res))
        return 0;
    memcpy(c->anchor_phi + root * block, dm_analysis_track_vectors(w->an, &res),
           sizeof(double) * block);
    if (c->seed_len)
        dm_analysis_seed_save(w->an, dm_sweep_anchors_seed(c, root));
    c->anchor_ok[root] = 1;
    queue[tail++] = root;
    int r0 = root / (m[1] * m[2]), r1 = (root / m[2]) % m[1], r2 = root % m[2];
    for (int dir = -1; dir <= 1; dir += 2)
        for (int a2 = r2 + dir, from = root; a2 >= 0 && a2 < m[2]; a2 += dir) {
            int b[3] = {r0, r1, a2}, nb = anchor_index(c, m, b);
            if (!reach[nb] || !follow(c, w, from, nb))
                break;
            queue[tail++] = nb;
            from = nb;
        }
    return tail;
}

/* Breadth first within each horizontal layer from the queued anchors, one
 * wave at a time: the anchors a wave reaches are claimed serially, each by
 * the first anchor of the wave next to it (the order of a serial search),
 * then computed in parallel on the nw workers, each from its claimant's
 * seed; one that fails may be reached again by the next wave. */
static int grow_layers(sweep_ctx *c, sweep_worker *w, int nw, const int m[3], const int *reach,
                       int *queue, int tail, long reachable, dm_error *err)
{
    int *parent = malloc(sizeof(int) * c->nanchor), *child = malloc(sizeof(int) * c->nanchor);
    unsigned char *claimed = calloc((size_t)c->nanchor, 1), *done = malloc((size_t)c->nanchor);
    int rc = parent && child && claimed && done
                 ? DM_OK
                 : dm_fail(err, DM_ENOMEM, "out of memory for mode tracking");
    for (int head = 0; !rc && head < tail;) {
        anchor_progress(c, tail, reachable, 0);
        int wave = tail, nclaim = 0;
        for (; head < wave; head++) {
            int id = queue[head], a[3] = {id / (m[1] * m[2]), (id / m[2]) % m[1], id % m[2]};
            for (int d = 0; d < 2; d++)
                for (int s = -1; s <= 1; s += 2) {
                    int b[3] = {a[0], a[1], a[2]};
                    b[d] += s;
                    if (b[d] < 0 || b[d] >= m[d])
                        continue;
                    int nb = anchor_index(c, m, b);
                    if (reach[nb] && !c->anchor_ok[nb] && !claimed[nb]) {
                        claimed[nb] = 1;
                        parent[nclaim] = id;
                        child[nclaim++] = nb;
                    }
                }
        }
#pragma omp parallel for schedule(dynamic, 1) num_threads(nw)
        for (int j = 0; j < nclaim; j++)
            done[j] = (unsigned char)follow(c, &w[omp_get_thread_num()], parent[j], child[j]);
        for (int j = 0; j < nclaim; j++) {
            if (done[j])
                queue[tail++] = child[j];
            claimed[child[j]] = done[j];
        }
    }
    free(parent);
    free(child);
    free(claimed);
    free(done);
    anchor_progress(c, tail, reachable, 1);
    return rc;
}

/* A coarse lattice (16 to 64 per axis, see ANCHORS_MIN) of reference poses. Families are
 * the k lowest modes at the root (the anchor nearest the robot's home),
 * followed to every other reachable anchor by MAC, before any tile runs:
 * up and down the root's column first (one height step at a time), then
 * breadth first within each horizontal layer from that column, so
 * families cross between heights in one place only. The lattice, bit for
 * bit, does not depend on the number of workers (grow_layers). Memory: at
 * most 4096 anchors. */
int dm_sweep_anchors_build(sweep_ctx *c, sweep_worker *w, int nw, dm_error *err)
{
    int m[3];
    assert(nw >= 1);
    c->seed_len = dm_analysis_seed_size(w->an);
    anchor_lattice(c, m);
    memcpy(c->anchor_m, m, sizeof m);
    c->nanchor = m[0] * m[1] * m[2];
    c->anchor_P = calloc((size_t)c->nanchor, sizeof *c->anchor_P);
    c->anchor_ok = calloc((size_t)c->nanchor, sizeof *c->anchor_ok);
    c->anchor_phi = calloc((size_t)c->nanchor * c->dim * c->k, sizeof(double));
    c->anchor_seed = c->seed_len ? calloc((size_t)c->nanchor, c->seed_len) : NULL;
    int *queue = malloc(sizeof(int) * c->nanchor), *reach = calloc((size_t)c->nanchor, sizeof(int));
    int rc = DM_OK;
    if (!c->anchor_P || !c->anchor_ok || !c->anchor_phi || !queue || !reach ||
        (c->seed_len && !c->anchor_seed))
        rc = dm_fail(err, DM_ENOMEM, "out of memory for mode tracking");
    int root = rc ? -1 : place_anchors(c, m, reach);
    long reachable = 0;
    for (int i = 0; !rc && i < c->nanchor; i++)
        reachable += reach[i];
    int tail = root >= 0 ? root_column(c, w, m, reach, root, queue) : 0;
    if (!rc)
        rc = grow_layers(c, w, nw, m, reach, queue, tail, reachable, err);
    free(queue);
    free(reach);
    return rc;
}

int dm_sweep_anchors_nearest(const sweep_ctx *c, const double P[3])
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
