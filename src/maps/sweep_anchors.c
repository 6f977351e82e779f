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

#define ANCHORS_PER_AXIS 16


static int anchor_index(const sweep_ctx *c, const int m[3], const int a[3])
{
    (void)c;
    return (a[0] * m[1] + a[1]) * m[2] + a[2];
}

void dm_sweep_anchors_track(const sweep_ctx *c, sweep_worker *w, const double *ref,
                            const dm_modes *modes, double *dst)
{
    dm_modal_track(ref, c->k, modes, c->kc, w->an->model, w->assign, w->mac, dst, w->mac_work);
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
    size_t block = (size_t)c->n * c->k;
    dm_pose_result res;
    if (c->seed_len)
        dm_modal_seed_load(w->an->modal, dm_sweep_anchors_seed(c, from));
    if (dm_analysis_run(w->an, c->anchor_P[to], c->kc, &res, NULL))
        return 0;
    dm_sweep_anchors_track(c, w, c->anchor_phi + from * block, res.modes, c->anchor_phi + to * block);
    if (c->seed_len)
        dm_modal_seed_save(w->an->modal, dm_sweep_anchors_seed(c, to));
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
 * followed to every other reachable anchor by MAC, before any tile runs.
 * The breadth-first search goes one wave at a time: the anchors a wave
 * reaches are claimed serially, each by the first anchor of the wave next
 * to it (the order of a serial search), then computed in parallel, each
 * from its claimant's seed: the lattice, bit for bit, does not depend on
 * the number of threads (one that fails may be reached again by the next
 * wave). Memory: at most 4096 anchors. */
int dm_sweep_anchors_build(sweep_ctx *c, sweep_worker *w, int nw, dm_error *err)
{
    int m[3], n = c->n, k = c->k, rc = DM_OK;
    assert(nw >= 1);
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
                dm_modal_seed_save(w->an->modal, dm_sweep_anchors_seed(c, root));
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
    int *parent = malloc(sizeof(int) * c->nanchor), *child = malloc(sizeof(int) * c->nanchor);
    unsigned char *claimed = calloc((size_t)c->nanchor, 1), *done = malloc((size_t)c->nanchor);
    if (!parent || !child || !claimed || !done)
        rc = dm_fail(err, DM_ENOMEM, "out of memory for mode tracking");
    while (!rc && head < tail) {
        anchor_progress(c, tail, reachable, 0);
        int wave = tail, nclaim = 0;
        for (; head < wave; head++) { /* claims in the serial search's order */
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
            claimed[child[j]] = done[j]; /* a failed one may be reached again */
        }
    }
    free(parent);
    free(child);
    free(claimed);
    free(done);
    anchor_progress(c, tail, reachable, 1);
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
