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

/* Below this share of the largest eigenvalue a combination is round-off
 * of an exact degeneracy, whatever the number of samples. */
#define ROUNDOFF_EIG 1e-12

/* A nuisance is reported not determined (1-sigma INFINITY) when the
 * undetermined directions hold more than this share of its unit vector
 * (a component above 0.1): left at zero, its value is then mostly what
 * the seen combinations imply, not its own. */
#define UNSEEN_SHARE 1e-2

int dm_nuisance_seen(double eig, double eig_max, int m)
{
    return eig > ROUNDOFF_EIG * eig_max && eig * m > 1;
}

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
 * commanded position plus the predicted elastic error, differentiated by
 * the 3-point Lagrange stencil of the samples i < n through time j (its
 * neighbours; the first or last three at the window's ends). The stencil
 * is second order everywhere: a one-sided first-order difference at the
 * ends is wrong by |a| dt / 2 (0.8 % of v on a 2 Hz circle at 5 ms), which
 * on a plane circle is what separated the clock offset from the rotation
 * about the circle's axis at the run's last sample. Tracker samples come
 * three per time (x, y, z), as the reader makes them. */
static double velocity(const dm_dataset *d, int n, const double *pred, int i)
{
    int j = i / 3, c = d->s[i].comp, nt = n / 3, all = d->n / 3;
    assert(d->s[i].comp == i % 3 && all >= 2);
    if (nt < 2) { /* a window of one time: the commanded velocity alone */
        const dm_sample *s0 = &d->s[c], *s1 = &d->s[3 + c];
        return (s1->P[c] - s0->P[c]) / (s1->t - s0->t);
    }
    if (nt == 2) {
        const dm_sample *s0 = &d->s[c], *s1 = &d->s[3 + c];
        return (s1->P[c] + pred[3 + c] - s0->P[c] - pred[c]) / (s1->t - s0->t);
    }
    int a = j < 1 ? 0 : j > nt - 2 ? nt - 3 : j - 1; /* stencil a, a + 1, a + 2 */
    double t = d->s[i].t, v = 0;
    for (int k = 0; k < 3; k++) { /* v = sum f_k l_k'(t), l_k the Lagrange basis */
        const dm_sample *sk = &d->s[3 * (a + k) + c];
        double dl = 0;
        for (int m = 0; m < 3; m++) {
            if (m == k)
                continue;
            const dm_sample *sm = &d->s[3 * (a + m) + c];
            double term = 1 / (sk->t - sm->t);
            for (int l = 0; l < 3; l++)
                if (l != k && l != m)
                    term *= (t - d->s[3 * (a + l) + c].t) / (sk->t - d->s[3 * (a + l) + c].t);
            dl += term;
        }
        v += (sk->P[c] + pred[3 * (a + k) + c]) * dl;
    }
    return v;
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

/* The weighted normal matrix of the training samples i < n, its columns
 * scaled to unit norm (norm), and the right-hand side b; m: the samples,
 * rr: their weighted residual sum of squares. */
static void normal_equations(const dm_dataset *d, int n, const char *held, const double *w,
                             const double *pred, int q, double *A, double *b, double *norm,
                             int *m, double *rr)
{
    double Pc[3], row[DM_NUISANCE_MAX];
    centroid(d, Pc);
    *m = 0, *rr = 0;
    for (int i = 0; i < n; i++) /* column norms: the normal matrix scaled to unit diagonal */
        if (!held[i]) {
            basis_row(d, n, pred, i, Pc, q, row);
            for (int k = 0; k < q; k++)
                norm[k] += row[k] * row[k] * w[i] * w[i];
            ++*m;
        }
    for (int k = 0; k < q; k++)
        norm[k] = norm[k] > 0 ? sqrt(norm[k]) : 1;
    for (int i = 0; i < n; i++)
        if (!held[i]) {
            basis_row(d, n, pred, i, Pc, q, row);
            double r = (d->s[i].value - pred[i]) * w[i];
            *rr += r * r;
            for (int k = 0; k < q; k++) {
                double ak = row[k] * w[i] / norm[k];
                b[k] += ak * r;
                for (int l = 0; l < q; l++)
                    A[k * q + l] += ak * row[l] * w[i] / norm[l];
            }
        }
}

/* The combinations of the nuisances left undetermined (touched[k]) that
 * the data do determine: scaled coefficient vectors c supported on the
 * touched nuisances and orthogonal to every unseen eigenvector (V, eig
 * ascending, column-major), each with its value and 1-sigma from the
 * seen part; in physical units, with the reference's coefficient 1 (of
 * the nuisances with a scaled coefficient at least half the largest, the
 * last: a clock offset reads more plainly than a turn). */
static void determined_combinations(int q, const double *V, const double *eig, const int *seen,
                                    const double *y, const double *norm, const double *touched,
                                    dm_nuisance_fit *fit)
{
    int idx[DM_NUISANCE_MAX], nt = 0;
    for (int k = 0; k < q; k++)
        if (touched[k] > UNSEEN_SHARE)
            idx[nt++] = k;
    /* P = sum over unseen u of u_T u_T': its null space is the touched
     * combinations that no unseen direction moves */
    double P[DM_NUISANCE_MAX * DM_NUISANCE_MAX] = {0}, lam[DM_NUISANCE_MAX];
    for (int e = 0; e < q; e++)
        for (int a = 0; a < nt && !seen[e]; a++)
            for (int c = 0; c < nt; c++)
                P[a * nt + c] += V[e * q + idx[a]] * V[e * q + idx[c]];
    if (nt < 2 || LAPACKE_dsyev(LAPACK_COL_MAJOR, 'V', 'U', nt, P, nt, lam))
        return;
    for (int g = 0; g < nt && lam[g] < 1e-6; g++) {
        double c[DM_NUISANCE_MAX] = {0}, val = 0, var = 0, big = 0;
        int ref = idx[0];
        for (int a = 0; a < nt; a++)
            big = fmax(big, fabs(c[idx[a]] = P[g * nt + a]));
        for (int a = 0; a < nt; a++) /* the last of the leading ones: the clock before a turn */
            ref = fabs(c[idx[a]]) >= 0.5 * big ? idx[a] : ref;
        for (int k = 0; k < q; k++)
            val += c[k] * y[k];
        for (int e = 0; e < q; e++) {
            double cv = 0;
            for (int k = 0; k < q; k++)
                cv += c[k] * V[e * q + k];
            var += seen[e] ? cv * cv / eig[e] : 0;
        }
        dm_nuisance_combination *cb = &fit->combination[fit->ncombination++];
        double unit = c[ref] / norm[ref]; /* c . y = unit (x_ref + sum_k coef_k x_k) */
        cb->ref = ref;
        for (int k = 0; k < q; k++)
            cb->coef[k] = c[k] * norm[k] / (c[ref] * norm[ref]);
        cb->value = val / (unit * norm[ref] * norm[ref]);
        cb->sigma = sqrt(var) / fabs(unit * norm[ref] * norm[ref]);
    }
}

/* Which combinations (eigenvectors V of the normal matrix, eig ascending)
 * are determined (dm_nuisance_seen) and which are fitted: the determined
 * ones, and an undetermined one whose fit lowers the training chi-square
 * (by (v'b)^2 / eig) more than 9 times the residual's reduced chi-square
 * (at least 1, the noise): the data hold it at 3 sigma, and left out it
 * would misfit them. Under noise alone such a combination stays at zero. */
static void choose_fitted(int q, const double *V, const double *eig, const double *b, int m,
                          double rr, int *determined, int *fitted)
{
    double red[DM_NUISANCE_MAX], left = rr;
    int k_all = 0;
    for (int e = 0; e < q; e++) {
        double vb = 0;
        for (int k = 0; k < q; k++)
            vb += V[e * q + k] * b[k];
        int roundoff = !(eig[e] > ROUNDOFF_EIG * eig[q - 1]);
        red[e] = roundoff ? 0 : vb * vb / eig[e];
        left -= red[e];
        k_all += !roundoff;
        determined[e] = dm_nuisance_seen(eig[e], eig[q - 1], m);
    }
    double scatter = fmax(1.0, m > k_all ? left / (m - k_all) : 1.0);
    for (int e = 0; e < q; e++)
        fitted[e] = determined[e] || red[e] > 9 * scatter;
}

/* Nuisances are properties of the run: fitted on the training samples,
 * they are applied unchanged to the held-out ones. A combination is
 * determined when its 1-sigma moves each nuisance's own term by less than
 * the noise, RMS over the samples fitted (dm_nuisance_seen). One that is
 * not is seen only through terms that cancel on the samples fitted (on a
 * plane circle the rotation about its axis and the clock offset,
 * phi_z = -omega tau): fitted to noise or to the model's error its value
 * is amplified, and it does not cancel elsewhere. It is left at zero —
 * the frame as the reader placed it, the nominal reflector offset,
 * synchronised clocks — unless the data hold it at 3 sigma
 * (choose_fitted); either way the nuisances it involves are reported not
 * determined, and what the data do determine of them as combinations. */
int dm_nuisance_apply(const dm_dataset *d, int n, const char *held, const double *w, double *pred,
                      double covscale, dm_nuisance_fit *fit)
{
    int q = dm_nuisance_count(d), m;
    if (fit)
        memset(fit, 0, sizeof *fit), fit->n = q;
    if (!q)
        return DM_OK;
    assert(n >= 0 && n <= d->n && q <= DM_NUISANCE_MAX);
    double A[DM_NUISANCE_MAX * DM_NUISANCE_MAX] = {0}, b[DM_NUISANCE_MAX] = {0}, rr;
    double norm[DM_NUISANCE_MAX] = {0}, eig[DM_NUISANCE_MAX], Pc[3], row[DM_NUISANCE_MAX];
    normal_equations(d, n, held, w, pred, q, A, b, norm, &m, &rr);
    if (LAPACKE_dsyev(LAPACK_COL_MAJOR, 'V', 'U', q, A, q, eig))
        return DM_ENOMEM; /* dsyev fails only without workspace */
    int determined[DM_NUISANCE_MAX], fitted[DM_NUISANCE_MAX], nfit = 0;
    choose_fitted(q, A, eig, b, m, rr, determined, fitted);
    /* y = V diag(1/eig) V' b over the combinations fitted (eig ascending) */
    double y[DM_NUISANCE_MAX] = {0}, unseen[DM_NUISANCE_MAX] = {0}, var[DM_NUISANCE_MAX] = {0};
    for (int e = 0; e < q; e++) {
        const double *v = &A[e * q];
        double vb = 0;
        for (int k = 0; k < q; k++)
            vb += v[k] * b[k];
        for (int k = 0; k < q; k++) {
            y[k] += fitted[e] ? v[k] * vb / eig[e] : 0;
            var[k] += determined[e] ? v[k] * v[k] / eig[e] : 0;
            unseen[k] += determined[e] ? 0 : v[k] * v[k];
        }
        nfit += fitted[e];
    }
    double *add = malloc(sizeof(double) * (n ? n : 1)); /* rows read the raw prediction */
    if (!add)
        return DM_ENOMEM;
    centroid(d, Pc);
    for (int i = 0; i < n; i++) {
        basis_row(d, n, pred, i, Pc, q, row);
        add[i] = 0;
        for (int k = 0; k < q; k++)
            add[i] += row[k] * y[k] / norm[k];
    }
    for (int i = 0; i < n; i++)
        pred[i] += add[i];
    free(add);
    if (fit) {
        fit->nseen = nfit;
        for (int k = 0; k < q; k++) {
            fit->value[k] = y[k] / norm[k];
            fit->sigma[k] = unseen[k] > UNSEEN_SHARE ? INFINITY : sqrt(var[k]) / norm[k];
        }
        determined_combinations(q, A, eig, determined, y, norm, unseen, fit);
        dm_nuisance_fit_scale(fit, sqrt(covscale));
    }
    return DM_OK;
}

void dm_nuisance_fit_scale(dm_nuisance_fit *fit, double factor)
{
    for (int k = 0; k < fit->n; k++)
        fit->sigma[k] *= factor;
    for (int c = 0; c < fit->ncombination; c++)
        fit->combination[c].sigma *= factor;
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
    if (!rc)
        dm_nuisance_fit_scale(fit, sqrt(known ? fmax(1.0, reduced) : reduced));
    free(held), free(w);
    return rc ? dm_fail(err, rc, "out of memory") : DM_OK;
}

/* ---- reading ------------------------------------------------------------------- */

/* The rigid transform base = R m + D that takes the measured points m_j
 * (value + commanded) of the times not skipped closest to the commanded
 * points plus the reflector offset refl (Kabsch: the SVD of the 3 x 3
 * cross-covariance, a reflection refused). DM_EINVAL: the points lie on a
 * line; DM_ENUMERIC: the SVD failed. */
static int rigid_fit(const dm_dataset *d, const char *skip, const double refl[3], double R[9],
                     double D[3])
{
    int nt = 0;
    double cm[3] = {0}, cb[3] = {0}, H[9] = {0};
    for (int j = 0; j < d->n / 3; j++)
        nt += !skip || !skip[3 * j];
    for (int i = 0; i < d->n; i++) {
        const dm_sample *s = &d->s[i];
        if (skip && skip[i - s->comp])
            continue;
        cm[s->comp] += (s->value + s->P[s->comp]) / nt;
        cb[s->comp] += (s->P[s->comp] + refl[s->comp]) / nt;
    }
    for (int j = 0; j < d->n / 3; j++)
        for (int a = 0; a < 3 && (!skip || !skip[3 * j]); a++)
            for (int c = 0; c < 3; c++) { /* H = sum (m - cm)(b - cb)' */
                const dm_sample *sa = &d->s[3 * j + a], *sc = &d->s[3 * j + c];
                H[a * 3 + c] += (sa->value + sa->P[a] - cm[a]) * (sc->P[c] + refl[c] - cb[c]);
            }
    double S[3], U[9], VT[9], superb[2];
    if (LAPACKE_dgesvd(LAPACK_ROW_MAJOR, 'A', 'A', 3, 3, H, 3, S, U, 3, VT, 3, superb))
        return DM_ENUMERIC;
    if (!(S[1] > 1e-9 * S[0]))
        return DM_EINVAL;
    /* R = V diag(1, 1, det) U' */
    double det = 0, V[9];
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
    for (int a = 0; a < 3; a++)
        D[a] = cb[a] - (R[a * 3] * cm[0] + R[a * 3 + 1] * cm[1] + R[a * 3 + 2] * cm[2]);
    return DM_OK;
}

/* The reader's alignment of a '# frame: tracker' run, on every sample. */
static int align(dm_dataset *d, dm_error *err)
{
    dm_nuisance_spec *ns = &d->nuisance;
    int rc = rigid_fit(d, NULL, ns->reflector, ns->R, ns->d);
    if (rc == DM_ENUMERIC)
        return dm_fail(err, DM_ENUMERIC, "%s: the tracker frame's alignment failed", d->source);
    if (rc)
        return dm_fail(err, DM_EINVAL,
                       "%s:%d: '# frame: tracker': the commanded path lies on a line, which "
                       "cannot place the tracker's frame (give the positions in the base frame: "
                       "'# frame: base')", d->source, ns->line);
    return DM_OK;
}

int dm_nuisance_place_on(const dm_dataset *d, const char *held, double *value)
{
    double R[9], D[3], zero[3] = {0};
    int placed = d->kind == DM_DATA_TRACKER && d->nuisance.on && d->nuisance.tracker_frame &&
                 rigid_fit(d, held, zero, R, D) == DM_OK;
    for (int i = 0; i < d->n; i++)
        value[i] = d->s[i].value;
    for (int j = 0; placed && j < d->n / 3; j++) {
        const dm_sample *s = &d->s[3 * j];
        assert(s[0].comp == 0 && s[1].comp == 1 && s[2].comp == 2);
        double m[3] = {s[0].value + s[0].P[0], s[1].value + s[1].P[1], s[2].value + s[2].P[2]};
        for (int a = 0; a < 3; a++)
            value[3 * j + a] = R[a * 3] * m[0] + R[a * 3 + 1] * m[1] + R[a * 3 + 2] * m[2] + D[a] -
                               s[a].P[a];
    }
    return placed;
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
