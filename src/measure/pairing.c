/* Measured modes paired with the model's (see dm_pairing.h). */
#include "dm_pairing.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_analysis.h"
#include "dm_modal.h"
#include "dm_shape.h"

/* ---- the model's modes at the sensors ---------------------------------------- */

/* Translation of node k of d (6 per node) into t. */
static void node_translation(const double *d, int k, double t[3])
{
    memcpy(t, d + 6 * k, 3 * sizeof(double));
}

/* Displacement at a sensor: members interpolated linearly between their
 * nodes (a sensor at a node reads that node), the platform moved rigidly. */
static double sensor_value(const dm_shape_mesh *mesh, const double *d, const dm_sensor *sn)
{
    double u[3];
    if (sn->body == DM_BODY_PLATFORM) {
        const double *p = d + 6 * dm_shape_platform_node(mesh), *r = sn->at;
        u[0] = p[0] + p[4] * r[2] - p[5] * r[1];
        u[1] = p[1] + p[5] * r[0] - p[3] * r[2];
        u[2] = p[2] + p[3] * r[1] - p[4] * r[0];
    } else {
        int arm = sn->body < 3, nel = arm ? mesh->na : mesh->nb;
        double x = sn->at[0] * nel;
        int k = (int)floor(x) < nel ? (int)floor(x) : nel - 1;
        int i = arm ? sn->body : (sn->body - 3) / 2, s = (sn->body - 3) % 2;
        int n0 = arm ? dm_shape_arm_node(mesh, i, k) : dm_shape_rod_node(mesh, i, s, k);
        int n1 = arm ? dm_shape_arm_node(mesh, i, k + 1) : dm_shape_rod_node(mesh, i, s, k + 1);
        double a[3], b[3], w = x - k;
        node_translation(d, n0, a);
        node_translation(d, n1, b);
        for (int r = 0; r < 3; r++)
            u[r] = (1 - w) * a[r] + w * b[r];
    }
    return u[0] * sn->dir[0] + u[1] * sn->dir[1] + u[2] * sn->dir[2];
}

int dm_pairing_model_modes(const dm_robot *rb, const dm_dataset *data, const double P[3], int k,
                           int na, int nb, double *freq, int *dir, double *shape, dm_error *err)
{
    na = na > 0 ? na : rb->na;
    nb = nb > 0 ? nb : rb->nb;
    dm_analysis *an = dm_analysis_alloc(rb, na, nb, k, DM_EIGEN_PARTIAL, err);
    if (!an)
        return err ? err->code : DM_ENOMEM;
    dm_pose_result res;
    int rc = dm_analysis_run(an, P, k, &res, err);
    dm_shape_mesh *mesh = rc || !data->nsensor || !shape ? NULL : dm_shape_mesh_alloc(an->model, err);
    double *d = mesh ? malloc(sizeof(double) * 6 * mesh->nnodes) : NULL;
    if (mesh && !d)
        rc = dm_fail(err, DM_ENOMEM, "out of memory");
    for (int j = 0; j < k && !rc; j++) {
        freq[j] = res.modes->freq_hz[j];
        dir[j] = res.modes->direction[j];
        if (!d)
            continue;
        dm_shape_displace(mesh, res.modes->phi + (size_t)j * res.modes->n, d);
        for (int s = 0; s < data->nsensor; s++)
            shape[j * data->nsensor + s] = sensor_value(mesh, d, &data->sensor[s]);
    }
    free(d);
    dm_shape_mesh_free(mesh);
    dm_analysis_free(an);
    return rc;
}

double dm_pairing_mac(const double *a, const double *b, int n)
{
    double ab = 0, aa = 0, bb = 0;
    for (int i = 0; i < n; i++)
        ab += a[i] * b[i], aa += a[i] * a[i], bb += b[i] * b[i];
    return aa > 0 && bb > 0 ? ab * ab / (aa * bb) : 0;
}

/* ---- the assignment ---------------------------------------------------------- */

/* Rows 0..n-1 assigned to distinct columns 0..m-1 (n <= m) at least total
 * cost c (n x m, row-major): the Hungarian method with potentials,
 * O(n^2 m). */
static int hungarian(const double *c, int n, int m, int *row_col)
{
    assert(n <= m);
    double *u = calloc(n + 1, sizeof *u), *v = calloc(m + 1, sizeof *v);
    double *minv = malloc(sizeof(double) * (m + 1));
    int *p = calloc(m + 1, sizeof *p), *way = calloc(m + 1, sizeof *way);
    char *used = malloc(m + 1);
    int ok = u && v && minv && p && way && used;
    for (int i = 1; i <= n && ok; i++) {
        p[0] = i;
        int j0 = 0;
        for (int j = 0; j <= m; j++)
            minv[j] = DBL_MAX, used[j] = 0;
        do {
            used[j0] = 1;
            int i0 = p[j0], j1 = 0;
            double delta = DBL_MAX;
            for (int j = 1; j <= m; j++) {
                if (used[j])
                    continue;
                double cur = c[(i0 - 1) * m + j - 1] - u[i0] - v[j];
                if (cur < minv[j])
                    minv[j] = cur, way[j] = j0;
                if (minv[j] < delta)
                    delta = minv[j], j1 = j;
            }
            for (int j = 0; j <= m; j++)
                if (used[j])
                    u[p[j]] += delta, v[j] -= delta;
                else
                    minv[j] -= delta;
            j0 = j1;
        } while (p[j0]);
        do {
            int j1 = way[j0];
            p[j0] = p[j1];
            j0 = j1;
        } while (j0);
    }
    for (int j = 1; j <= m && ok; j++)
        if (p[j])
            row_col[p[j] - 1] = j - 1;
    free(u), free(v), free(minv), free(p), free(way), free(used);
    return ok ? DM_OK : DM_ENOMEM;
}

#define INADMISSIBLE 1e6

/* The cost of pairing measured sample i with model mode j (0-based). */
static double pair_cost(const dm_dataset *d, int i, double f, int dir, const double *shape,
                        double *mac)
{
    const dm_sample *s = &d->s[i];
    double df = fabs(s->value - f) / f;
    if (d->nsensor) {
        *mac = dm_pairing_mac(d->shape + (size_t)i * d->nsensor, shape, d->nsensor);
        return *mac >= DM_PAIR_MAC_MIN && df <= DM_PAIR_FREQ_TOL_MAC ? 1 - *mac + df
                                                                      : INADMISSIBLE;
    }
    *mac = -1;
    return s->dir == dir + 1 && df <= DM_PAIR_FREQ_TOL ? df : INADMISSIBLE;
}

/* The pairs of one pose: samples first..end-1, K model modes. */
static int pair_pose(const dm_robot *rb, const dm_dataset *d, int first, int end, int na, int nb,
                     dm_pairing *pg, dm_error *err)
{
    int nm = end - first, label = 1, dofs = dm_model_dofs(rb, na > 0 ? na : rb->na,
                                                           nb > 0 ? nb : rb->nb);
    for (int i = first; i < end; i++)
        label = d->s[i].mode > label ? d->s[i].mode : label;
    int K = 2 * label + 2;
    K = K < DM_MAX_MODES ? K : DM_MAX_MODES;
    K = K < dofs ? K : dofs;
    int cols = K + nm, ns = d->nsensor ? d->nsensor : 1;
    double *freq = malloc(sizeof(double) * K), *shape = malloc(sizeof(double) * K * ns);
    double *cost = malloc(sizeof(double) * nm * cols), *mac = malloc(sizeof(double) * nm * K);
    int *dir = malloc(sizeof(int) * K), *col = malloc(sizeof(int) * nm);
    int rc = freq && shape && cost && mac && dir && col ? DM_OK
                                                        : dm_fail(err, DM_ENOMEM, "out of memory");
    dm_error merr;
    if (!rc && (rc = dm_pairing_model_modes(rb, d, d->s[first].P, K, na, nb, freq, dir,
                                            d->nsensor ? shape : NULL, &merr)))
        rc = dm_fail(err, rc, "%s:%d: %s", d->source, d->s[first].line, merr.msg);
    for (int a = 0; a < nm && !rc; a++)
        for (int b = 0; b < cols; b++)
            cost[a * cols + b] = b < K ? pair_cost(d, first + a, freq[b], dir[b], shape + b * ns,
                                                   &mac[a * K + b])
                                       : b - K == a ? DM_PAIR_UNPAIRED : 2 * INADMISSIBLE;
    if (!rc && hungarian(cost, nm, cols, col))
        rc = dm_fail(err, DM_ENOMEM, "out of memory");
    for (int a = 0; a < nm && !rc; a++) {
        dm_pair *p = &pg->pair[first + a];
        int j = col[a] < K && cost[a * cols + col[a]] < INADMISSIBLE ? col[a] : -1;
        *p = (dm_pair){.sample = first + a, .line = d->s[first + a].line, .pose_id = d->s[first].pose_id,
                       .label = d->s[first + a].mode, .freq_meas = d->s[first + a].value,
                       .mac = -1, .dir_meas = d->s[first + a].dir - 1, .dir_model = -1};
        for (int b = 0; b < K && d->nsensor; b++) /* unpaired: its best MAC */
            p->mac = fmax(p->mac, mac[a * K + b]);
        if (j >= 0) {
            p->model_mode = j + 1, p->freq_model = freq[j], p->dir_model = dir[j];
            p->mac = d->nsensor ? mac[a * K + j] : -1;
            pg->npaired++;
        }
    }
    free(freq), free(shape), free(cost), free(mac), free(dir), free(col);
    return rc;
}

static void mark_skipped(dm_pairing *pg, int first, int end, int pose)
{
    uint64_t paired = 0;
    int top = 0;
    for (int i = first; i < end; i++)
        if (pg->pair[i].model_mode) {
            paired |= (uint64_t)1 << (pg->pair[i].model_mode - 1);
            top = pg->pair[i].model_mode > top ? pg->pair[i].model_mode : top;
        }
    uint64_t below = top ? (top == 64 ? ~(uint64_t)0 : ((uint64_t)1 << top) - 1) : 0;
    pg->skipped[pose] = below & ~paired;
}

int dm_pairing_make(const dm_robot *rb, const dm_dataset *d, int na, int nb, dm_pairing *pg,
                    dm_error *err)
{
    assert(d->kind == DM_DATA_MODAL && d->pair);
    memset(pg, 0, sizeof *pg);
    pg->n = d->n;
    pg->npose = d->npose;
    pg->by_mac = d->nsensor > 0;
    pg->pair = calloc(d->n ? d->n : 1, sizeof *pg->pair);
    pg->skipped = calloc(d->npose ? d->npose : 1, sizeof *pg->skipped);
    int rc = pg->pair && pg->skipped ? DM_OK : dm_fail(err, DM_ENOMEM, "out of memory");
    for (int first = 0, end; first < d->n && !rc; first = end) {
        for (end = first; end < d->n && d->s[end].pose_id == d->s[first].pose_id; end++)
            ;
        rc = pair_pose(rb, d, first, end, na, nb, pg, err);
        if (!rc)
            mark_skipped(pg, first, end, d->s[first].pose_id);
    }
    if (rc)
        dm_pairing_free(pg);
    return rc;
}

void dm_pairing_free(dm_pairing *pg)
{
    free(pg->pair);
    free(pg->skipped);
    memset(pg, 0, sizeof *pg);
}

int dm_pairing_apply(const dm_dataset *d, const dm_pairing *pg, dm_dataset *out, dm_error *err)
{
    assert(pg->n == d->n);
    memset(out, 0, sizeof *out);
    out->kind = DM_DATA_MODAL;
    memcpy(out->source, d->source, sizeof out->source);
    memcpy(out->robot, d->robot, sizeof out->robot);
    int rc = DM_OK, last = -1;
    for (int i = 0; i < d->n && !rc; i++) {
        if (!pg->pair[i].model_mode)
            continue;
        dm_sample s = d->s[i];
        if (s.pose_id != last)
            out->npose++;
        last = s.pose_id;
        s.mode = pg->pair[i].model_mode;
        s.pose_id = out->npose - 1;
        rc = dm_dataset_push(out, &s, err);
    }
    if (!rc && !out->n)
        rc = dm_fail(err, DM_EINVAL, "%s: no measured mode pairs with a mode of the model "
                     "(docs/measured-data.md, 'Mode shapes and pairing')", d->source);
    if (rc)
        dm_dataset_free(out);
    return rc;
}

/* ---- synthetic surveys as a modal test gives them ----------------------------- */

void dm_pairing_default_sensors(const dm_robot *rb, dm_dataset *d)
{
    static const double axis[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    d->nsensor = 0;
    for (int a = 0; a < 4; a++) { /* the centre x, y, z; the rim along y */
        dm_sensor *s = &d->sensor[d->nsensor++];
        *s = (dm_sensor){.body = DM_BODY_PLATFORM};
        snprintf(s->name, sizeof s->name, a < 3 ? "p%c" : "rim", "xyz"[a % 3]);
        s->at[0] = a < 3 ? 0 : rb->platform_radius_m;
        memcpy(s->dir, axis[a < 3 ? a : 1], sizeof s->dir);
    }
    for (int i = 0; i < 3; i++)
        for (int a = 0; a < 5; a++) {
            dm_sensor *s = &d->sensor[d->nsensor++];
            *s = (dm_sensor){.body = a < 3 ? i : 3 + 2 * i, .at = {a < 3 ? 1.0 : 0.5}};
            snprintf(s->name, sizeof s->name, a < 3 ? "e%d%c" : "r%d%c", i + 1, "xyzxy"[a]);
            memcpy(s->dir, axis[a % 3], sizeof s->dir);
        }
    assert(d->nsensor <= DM_MAX_SENSORS);
}

/* v made orthogonal to the k rows of `basis` (n values each), then scaled
 * to unit largest value. */
static void orthogonal_to(double *v, const double *basis, int k, int n)
{
    for (int pass = 0; pass < 2; pass++) /* twice: Gram-Schmidt loses little then */
        for (int j = 0; j < k; j++) {
            const double *b = basis + (size_t)j * n;
            double vb = 0, bb = 0;
            for (int i = 0; i < n; i++)
                vb += v[i] * b[i], bb += b[i] * b[i];
            for (int i = 0; i < n && bb > 0; i++)
                v[i] -= vb / bb * b[i];
        }
    double m = 0;
    for (int i = 0; i < n; i++)
        m = fmax(m, fabs(v[i]));
    for (int i = 0; i < n && m > 0; i++)
        v[i] /= m;
}

static void unit_largest(double *v, int n) { orthogonal_to(v, NULL, 0, n); }

/* One pose's measured modes (samples first..end-1 of d, ranks 1..M) into
 * out: mode `drop` left out, the extra one added, relabelled by frequency. */
static int survey_pose(const dm_robot *rb, const dm_dataset *d, int first, int end, int drop,
                       double extra_hz, int extra_dir, int na, int nb, dm_rng *rng,
                       dm_dataset *out, dm_error *err)
{
    int M = end - first, ns = out->nsensor, m = 0;
    double freq[DM_MAX_MODES], shape[(DM_MAX_MODES + 1) * DM_MAX_SENSORS], f[DM_MAX_MODES + 1];
    int dir[DM_MAX_MODES], keep[DM_MAX_MODES + 1], order[DM_MAX_MODES + 1];
    assert(M <= DM_MAX_MODES);
    int rc = dm_pairing_model_modes(rb, out, d->s[first].P, M, na, nb, freq, dir, shape, err);
    for (int j = 0; j < M && !rc; j++)
        if (j + 1 != drop) {
            keep[m] = j, f[m] = d->s[first + j].value;
            memmove(shape + m * ns, shape + j * ns, sizeof(double) * ns);
            unit_largest(shape + m * ns, ns);
            m++;
        }
    if (!rc && extra_hz > 0) {
        for (int i = 0; i < ns; i++)
            shape[m * ns + i] = dm_rng_normal(rng);
        orthogonal_to(shape + m * ns, shape, m, ns);
        keep[m] = -1, f[m++] = extra_hz;
    }
    for (int a = 0; a < m; a++) { /* by measured frequency */
        order[a] = a;
        for (int b = a; b > 0 && f[order[b - 1]] > f[order[b]]; b--) {
            int t = order[b];
            order[b] = order[b - 1], order[b - 1] = t;
        }
    }
    for (int a = 0; a < m && !rc; a++) {
        int q = order[a];
        dm_sample s = d->s[first];
        s.mode = a + 1, s.value = f[q];
        s.dir = (keep[q] >= 0 ? dir[keep[q]] : extra_dir) + 1;
        s.pose_id = out->npose - 1;
        if (!(rc = dm_dataset_push(out, &s, err)) && ns) {
            double *g = realloc(out->shape, sizeof(double) * out->n * ns);
            if (!g)
                return dm_fail(err, DM_ENOMEM, "out of memory");
            out->shape = g, out->shape_cap = out->n * ns;
            memcpy(g + (size_t)(out->n - 1) * ns, shape + q * ns, sizeof(double) * ns);
        }
    }
    return rc;
}

int dm_pairing_survey(const dm_robot *rb, int sensors, int drop, double extra_hz, int extra_dir,
                      int na, int nb, dm_rng *rng, dm_dataset *d, dm_error *err)
{
    assert(d->kind == DM_DATA_MODAL);
    dm_dataset out = {.kind = DM_DATA_MODAL, .pair = 1};
    memcpy(out.source, d->source, sizeof out.source);
    memcpy(out.robot, d->robot, sizeof out.robot);
    if (sensors)
        dm_pairing_default_sensors(rb, &out);
    int rc = DM_OK;
    for (int first = 0, end; first < d->n && !rc; first = end) {
        for (end = first; end < d->n && d->s[end].pose_id == d->s[first].pose_id; end++)
            ;
        if (drop > end - first) {
            rc = dm_fail(err, DM_EINVAL, "mode %d to leave out is beyond the %d modes made",
                         drop, end - first);
            break;
        }
        out.npose++;
        rc = survey_pose(rb, d, first, end, drop, extra_hz, extra_dir, na, nb, rng, &out, err);
    }
    dm_dataset_free(d);
    if (rc)
        dm_dataset_free(&out);
    *d = out;
    return rc;
}
