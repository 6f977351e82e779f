/* The tracker's nuisances (see dm_nuisance.h). */
#include "dm_nuisance.h"

#include <assert.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *const NAMES[DM_NUISANCE_MAX] = {
    "frame_translation_x", "frame_translation_y", "frame_translation_z", "frame_rotation_x",
    "frame_rotation_y",    "frame_rotation_z",    "clock_offset",        "clock_rate"};
static const char *const UNITS[DM_NUISANCE_MAX] = {"m", "m", "m", "rad", "rad", "rad", "s", "1"};

/* A combination is seen when its eigenvalue of the (column-scaled) normal
 * matrix is above this share of the largest: a singular value above 1e-6
 * of the largest, far above the round-off of an exact degeneracy. */
#define SEEN_EIG 1e-12

int dm_nuisance_count(const dm_dataset *d)
{
    if (d->kind != DM_DATA_TRACKER || !d->nuisance.on)
        return 0;
    return d->nuisance.clock_rate ? 8 : 7;
}

const char *dm_nuisance_name(int k)
{
    assert(k >= 0 && k < DM_NUISANCE_MAX);
    return NAMES[k];
}

const char *dm_nuisance_unit(int k)
{
    assert(k >= 0 && k < DM_NUISANCE_MAX);
    return UNITS[k];
}

/* Mean commanded position of the run. */
static void centroid(const dm_dataset *d, double c[3])
{
    c[0] = c[1] = c[2] = 0;
    for (int i = 0; i < d->n; i++)
        c[d->s[i].comp] += d->s[i].P[d->s[i].comp] / (d->n / 3);
}

/* The platform's velocity at sample i's time, as the model has it: the
 * commanded one plus the predicted elastic error's, central differences
 * of the samples i < n (one-sided at the ends). Tracker samples come three
 * per time (x, y, z), as the reader makes them. */
static double velocity(const dm_dataset *d, int n, const double *pred, int i)
{
    int j = i / 3, c = d->s[i].comp, nt = n / 3, all = d->n / 3;
    assert(d->s[i].comp == i % 3 && all >= 2);
    if (nt < 2) { /* a window of one time: the commanded velocity alone */
        const dm_sample *s0 = &d->s[c], *s1 = &d->s[3 + c];
        return (s1->P[c] - s0->P[c]) / (s1->t - s0->t);
    }
    int a = j > 0 ? j - 1 : 0, b = j < nt - 1 ? j + 1 : nt - 1;
    const dm_sample *sa = &d->s[3 * a + c], *sb = &d->s[3 * b + c];
    return (sb->P[c] + pred[3 * b + c] - sa->P[c] - pred[3 * a + c]) / (sb->t - sa->t);
}

/* Row of the nuisance design for sample i (pred: the model's prediction
 * of samples < n, without nuisances). */
static void basis_row(const dm_dataset *d, int n, const double *pred, int i, const double Pc[3],
                      int q, double *row)
{
    const dm_sample *s = &d->s[i];
    int c = s->comp;
    double p[3] = {s->P[0] - Pc[0], s->P[1] - Pc[1], s->P[2] - Pc[2]};
    for (int k = 0; k < 3; k++)
        row[k] = k == c;
    /* (e_k x p)_c: the rotation phi_k about axis k moves p by e_k x p */
    row[3] = c == 1 ? -p[2] : c == 2 ? p[1] : 0;
    row[4] = c == 0 ? p[2] : c == 2 ? -p[0] : 0;
    row[5] = c == 0 ? -p[1] : c == 1 ? p[0] : 0;
    double v = velocity(d, n, pred, i);
    row[6] = v;
    if (q > 7)
        row[7] = v * s->t;
}

void dm_nuisance_design(const dm_dataset *d, int n, const double *pred, double *N)
{
    int q = dm_nuisance_count(d);
    double Pc[3], row[DM_NUISANCE_MAX];
    centroid(d, Pc);
    for (int i = 0; i < n; i++) {
        basis_row(d, n, pred, i, Pc, q, row);
        for (int k = 0; k < q; k++)
            N[(size_t)k * n + i] = row[k];
    }
}

int dm_nuisance_apply(const dm_dataset *d, int n, const char *held, const double *w, double *pred,
                      double covscale, dm_nuisance_fit *fit)
{
    int q = dm_nuisance_count(d);
    if (fit)
        memset(fit, 0, sizeof *fit), fit->n = q;
    if (!q)
        return DM_OK;
    assert(n >= 0 && n <= d->n && q <= DM_NUISANCE_MAX);
    double Pc[3], A[DM_NUISANCE_MAX * DM_NUISANCE_MAX] = {0}, b[DM_NUISANCE_MAX] = {0};
    double norm[DM_NUISANCE_MAX] = {0}, row[DM_NUISANCE_MAX];
    centroid(d, Pc);
    for (int i = 0; i < n; i++) /* column norms: the normal matrix scaled to unit diagonal */
        if (!held[i]) {
            basis_row(d, n, pred, i, Pc, q, row);
            for (int k = 0; k < q; k++)
                norm[k] += row[k] * row[k] * w[i] * w[i];
        }
    for (int k = 0; k < q; k++)
        norm[k] = norm[k] > 0 ? sqrt(norm[k]) : 1;
    for (int i = 0; i < n; i++)
        if (!held[i]) {
            basis_row(d, n, pred, i, Pc, q, row);
            double r = (d->s[i].value - pred[i]) * w[i];
            for (int k = 0; k < q; k++) {
                double ak = row[k] * w[i] / norm[k];
                b[k] += ak * r;
                for (int l = 0; l < q; l++)
                    A[k * q + l] += ak * row[l] * w[i] / norm[l];
            }
        }
    double eig[DM_NUISANCE_MAX];
    if (LAPACKE_dsyev(LAPACK_COL_MAJOR, 'V', 'U', q, A, q, eig))
        return DM_ENOMEM; /* dsyev fails only without workspace */
    /* x = V diag(1/eig) V' b over the combinations seen (eig ascending) */
    double x[DM_NUISANCE_MAX] = {0}, unseen[DM_NUISANCE_MAX] = {0}, var[DM_NUISANCE_MAX] = {0};
    int seen = 0;
    for (int e = 0; e < q; e++) {
        const double *v = &A[e * q];
        int ok = eig[e] > SEEN_EIG * eig[q - 1];
        double vb = 0;
        for (int k = 0; k < q; k++)
            vb += v[k] * b[k];
        for (int k = 0; k < q; k++) {
            if (ok) {
                x[k] += v[k] * vb / eig[e];
                var[k] += v[k] * v[k] / eig[e];
            } else {
                unseen[k] += v[k] * v[k];
            }
        }
        seen += ok;
    }
    for (int k = 0; k < q; k++)
        x[k] /= norm[k];
    double *add = malloc(sizeof(double) * (n ? n : 1)); /* rows read the raw prediction */
    if (!add)
        return DM_ENOMEM;
    for (int i = 0; i < n; i++) {
        basis_row(d, n, pred, i, Pc, q, row);
        add[i] = 0;
        for (int k = 0; k < q; k++)
            add[i] += row[k] * x[k];
    }
    for (int i = 0; i < n; i++)
        pred[i] += add[i];
    free(add);
    if (fit) {
        fit->nseen = seen;
        for (int k = 0; k < q; k++) {
            fit->value[k] = x[k];
            fit->sigma[k] = unseen[k] > 1e-6 ? INFINITY : sqrt(covscale * var[k]) / norm[k];
        }
    }
    return DM_OK;
}

int dm_nuisance_fit_all(const dm_dataset *d, double *pred, dm_nuisance_fit *fit, dm_error *err)
{
    assert(fit);
    if (!dm_nuisance_count(d))
        return dm_fail(err, DM_EINVAL, "%s: no nuisances to fit (a tracker run with a '# frame:' "
                       "header line, docs/measured-data.md)", d->source);
    char *held = calloc(d->n, 1);
    double *w = malloc(sizeof(double) * d->n);
    int rc = !held || !w ? DM_ENOMEM : DM_OK, known = 1;
    for (int i = 0; !rc && i < d->n; i++) {
        known &= d->s[i].sigma > 0;
        w[i] = d->s[i].sigma > 0 ? 1 / d->s[i].sigma : 1;
    }
    if (!rc)
        rc = dm_nuisance_apply(d, d->n, held, w, pred, 1.0, fit);
    double ss = 0;
    for (int i = 0; !rc && i < d->n; i++)
        ss += (d->s[i].value - pred[i]) * (d->s[i].value - pred[i]) * w[i] * w[i];
    double reduced = ss / (d->n > fit->nseen ? d->n - fit->nseen : 1);
    double scale = sqrt(known ? fmax(1.0, reduced) : reduced);
    for (int k = 0; !rc && k < fit->n; k++)
        fit->sigma[k] *= scale;
    free(held), free(w);
    return rc ? dm_fail(err, rc, "out of memory") : DM_OK;
}

/* ---- reading ------------------------------------------------------------------- */

/* The rigid transform base = R m + d that takes the measured points m_j
 * (value + commanded, in the tracker's frame) closest to the commanded
 * points plus the nominal reflector offset (Kabsch: the SVD of the 3 x 3
 * cross-covariance, a reflection refused). */
static int align(dm_dataset *d, dm_error *err)
{
    dm_nuisance_spec *ns = &d->nuisance;
    int nt = d->n / 3;
    double cm[3] = {0}, cb[3] = {0}, H[9] = {0};
    for (int i = 0; i < d->n; i++) {
        const dm_sample *s = &d->s[i];
        cm[s->comp] += (s->value + s->P[s->comp]) / nt;
        cb[s->comp] += (s->P[s->comp] + ns->reflector[s->comp]) / nt;
    }
    for (int j = 0; j < nt; j++)
        for (int a = 0; a < 3; a++)
            for (int c = 0; c < 3; c++) { /* H = sum (m - cm)(b - cb)' */
                const dm_sample *sa = &d->s[3 * j + a], *sc = &d->s[3 * j + c];
                H[a * 3 + c] += (sa->value + sa->P[a] - cm[a]) *
                                (sc->P[c] + ns->reflector[c] - cb[c]);
            }
    double S[3], U[9], VT[9], superb[2];
    if (LAPACKE_dgesvd(LAPACK_ROW_MAJOR, 'A', 'A', 3, 3, H, 3, S, U, 3, VT, 3, superb))
        return dm_fail(err, DM_ENUMERIC, "%s: the tracker frame's alignment failed", d->source);
    if (!(S[1] > 1e-9 * S[0]))
        return dm_fail(err, DM_EINVAL,
                       "%s:%d: '# frame: tracker': the commanded path lies on a line, which "
                       "cannot place the tracker's frame (give the positions in the base frame: "
                       "'# frame: base')", d->source, ns->line);
    /* R = V diag(1, 1, det) U' */
    double det = 0, V[9], R[9];
    for (int a = 0; a < 3; a++)
        for (int c = 0; c < 3; c++)
            V[a * 3 + c] = VT[c * 3 + a];
    for (int pass = 0; pass < 2; pass++) {
        for (int a = 0; a < 3; a++)
            for (int c = 0; c < 3; c++) {
                R[a * 3 + c] = 0;
                for (int k = 0; k < 3; k++)
                    R[a * 3 + c] += V[a * 3 + k] * (k == 2 && pass ? det : 1) * U[c * 3 + k];
            }
        det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
              R[2] * (R[3] * R[7] - R[4] * R[6]);
        if (det > 0)
            break;
    }
    memcpy(ns->R, R, sizeof R);
    for (int a = 0; a < 3; a++)
        ns->d[a] = cb[a] - (R[a * 3] * cm[0] + R[a * 3 + 1] * cm[1] + R[a * 3 + 2] * cm[2]);
    return DM_OK;
}

int dm_nuisance_prepare(dm_dataset *d, dm_error *err)
{
    dm_nuisance_spec *ns = &d->nuisance;
    if (!ns->on)
        return DM_OK;
    assert(d->kind == DM_DATA_TRACKER && d->n % 3 == 0);
    int rc = ns->tracker_frame ? align(d, err) : DM_OK;
    double ss = 0;
    for (int j = 0; !rc && j < d->n / 3; j++) {
        dm_sample *s = &d->s[3 * j];
        double m[3], base[3];
        for (int c = 0; c < 3; c++)
            m[c] = s[c].value + s[c].P[c];
        for (int a = 0; a < 3; a++)
            base[a] = ns->tracker_frame
                          ? ns->R[a * 3] * m[0] + ns->R[a * 3 + 1] * m[1] + ns->R[a * 3 + 2] * m[2] +
                                ns->d[a]
                          : m[a];
        for (int c = 0; c < 3; c++) {
            s[c].value = base[c] - ns->reflector[c] - s[c].P[c];
            ss += s[c].value * s[c].value;
        }
    }
    if (!rc && ns->tracker_frame)
        ns->align_rms = sqrt(ss / d->n);
    return rc;
}
