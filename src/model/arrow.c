/* Symmetric block-arrow matrices (see dm_arrow.h). */
#include "dm_arrow.h"

#include <assert.h>
#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "arrow_impl.h"

#define NP DM_ARROW_BORDER
#define NB DM_ARROW_BLOCKS

const dm_arrow_kernels *dm_arrow_kernels_of(dm_isa isa)
{
    assert(dm_isa_available(isa));
    return DM_ISA_SELECT(dm_arrow_kernels_, isa);
}

/* The kernels of the process's path (chosen once: dm_isa_active). */
static const dm_arrow_kernels *kernels(void)
{
    return dm_arrow_kernels_of(dm_isa_active());
}

void dm_arrow_layout_make(dm_arrow_layout *lay, const int nb[NB], const int kd[NB])
{
    int next = 0;
    for (int c = 0; c < NB; c++) {
        assert(nb[c] >= 1);
        lay->nb[c] = nb[c];
        lay->kd[c] = kd[c] < nb[c] - 1 ? (kd[c] > 0 ? kd[c] : 0) : nb[c] - 1;
        lay->off[c] = next;
        next += nb[c];
    }
    lay->border = next;
    lay->n = next + NP;
}

static size_t band_len(const dm_arrow_layout *lay, int c)
{
    return (size_t)(lay->kd[c] + 1) * lay->nb[c];
}

int dm_arrow_init(dm_arrow *a, const dm_arrow_layout *lay, dm_error *err)
{
    memset(a, 0, sizeof *a);
    a->lay = *lay;
    int ok = 1;
    for (int c = 0; c < NB; c++) {
        a->band[c] = calloc(band_len(lay, c), sizeof(double));
        a->cpl[c] = calloc((size_t)lay->nb[c] * NP, sizeof(double));
        ok &= a->band[c] && a->cpl[c];
    }
    if (!ok) {
        dm_arrow_release(a);
        return dm_fail(err, DM_ENOMEM, "out of memory for a %d-DOF block-arrow matrix", lay->n);
    }
    return DM_OK;
}

static void stop_recording(dm_arrow *a)
{
    for (int c = 0; c < NB; c++) {
        free(a->touched[c]);
        free(a->touched_cpl[c]);
        a->touched[c] = a->touched_cpl[c] = NULL;
    }
}

void dm_arrow_release(dm_arrow *a)
{
    stop_recording(a);
    for (int c = 0; c < NB; c++) {
        free(a->band[c]);
        free(a->cpl[c]);
        a->band[c] = a->cpl[c] = NULL;
    }
}

int dm_arrow_record(dm_arrow *a, dm_error *err)
{
    stop_recording(a); /* a recording an earlier (failed) build left */
    for (int c = 0; c < NB; c++) {
        a->touched[c] = calloc(band_len(&a->lay, c), 1);
        a->touched_cpl[c] = calloc((size_t)a->lay.nb[c] * NP, 1);
        if (!a->touched[c] || !a->touched_cpl[c]) {
            stop_recording(a);
            return dm_fail(err, DM_ENOMEM, "out of memory for a sparsity pattern");
        }
    }
    return DM_OK;
}

void dm_arrow_pattern_release(dm_arrow_pattern *p)
{
    for (int c = 0; c < NB; c++) {
        free(p->colptr[c]);
        free(p->rows[c]);
        free(p->colend[c]);
        free(p->cpl[c]);
        p->colptr[c] = p->rows[c] = p->colend[c] = p->cpl[c] = NULL;
    }
}

int dm_arrow_pattern_make(dm_arrow_pattern *p, dm_arrow *a, dm_arrow *b, dm_error *err)
{
    const dm_arrow_layout *lay = &a->lay;
    memset(p, 0, sizeof *p);
    int rc = DM_OK;
    for (int c = 0; c < NB && !rc; c++) {
        int nb = lay->nb[c], kd = lay->kd[c], ld = kd + 1, nz = 0;
        const unsigned char *ta = a->touched[c], *tb = b->touched[c];
        assert(ta && tb);
        p->colptr[c] = malloc(sizeof(int) * (nb + 1));
        p->rows[c] = malloc(sizeof(int) * band_len(lay, c));
        p->colend[c] = malloc(sizeof(int) * nb);
        p->cpl[c] = malloc(sizeof(int) * nb * NP);
        int *first = malloc(sizeof(int) * nb); /* each row's first non-zero column */
        if (!p->colptr[c] || !p->rows[c] || !p->colend[c] || !p->cpl[c] || !first) {
            free(first);
            rc = dm_fail(err, DM_ENOMEM, "out of memory for a sparsity pattern");
            break;
        }
        for (int i = 0; i < nb; i++)
            first[i] = i;
        for (int j = 0; j < nb; j++) {
            p->colptr[c][j] = nz;
            for (int i = j + 1; i <= j + kd && i < nb; i++)
                if (ta[(i - j) + (size_t)j * ld] || tb[(i - j) + (size_t)j * ld]) {
                    p->rows[c][nz++] = i;
                    if (j < first[i])
                        first[i] = j;
                }
        }
        p->colptr[c][nb] = nz;
        /* profile: column j holds the rows i >= j whose first column is <= j
         * (the envelope need not be monotone) */
        for (int j = 0; j < nb; j++)
            p->colend[c][j] = j;
        for (int i = 0; i < nb; i++)
            for (int j = first[i]; j < i; j++)
                p->colend[c][j] = i > p->colend[c][j] ? i : p->colend[c][j];
        free(first);
        p->ncpl[c] = 0;
        for (int k = 0; k < nb * NP; k++) {
            if (k % nb == 0)
                p->cpl_start[c][k / nb] = p->ncpl[c];
            if (a->touched_cpl[c][k] || b->touched_cpl[c][k])
                p->cpl[c][p->ncpl[c]++] = k;
        }
        p->cpl_start[c][NP] = p->ncpl[c];
    }
    stop_recording(a);
    stop_recording(b);
    if (rc)
        dm_arrow_pattern_release(p);
    return rc;
}

void dm_arrow_zero(dm_arrow *a)
{
    for (int c = 0; c < NB; c++) {
        memset(a->band[c], 0, band_len(&a->lay, c) * sizeof(double));
        memset(a->cpl[c], 0, (size_t)a->lay.nb[c] * NP * sizeof(double));
    }
    memset(a->pp, 0, sizeof a->pp);
}

/* Block of unknown i (0..2), or NB for the border. */
static int block_of(const dm_arrow_layout *lay, int i)
{
    assert(i >= 0 && i < lay->n);
    if (i >= lay->border)
        return NB;
    int c = 0;
    while (c + 1 < NB && i >= lay->off[c + 1])
        c++;
    return c;
}

/* Where entry (i, j) of the full matrix is stored, or NULL for the
 * half that is not (the upper triangle of a band, (border, block)). */
static double *slot(const dm_arrow *a, int i, int j)
{
    const dm_arrow_layout *lay = &a->lay;
    int bi = block_of(lay, i), bj = block_of(lay, j);
    if (bi == NB && bj == NB)
        return (double *)&a->pp[(j - lay->border) * NP + (i - lay->border)];
    if (bi == NB)
        return NULL;
    if (bj == NB)
        return &a->cpl[bi][(i - lay->off[bi]) + (size_t)(j - lay->border) * lay->nb[bi]];
    assert(bi == bj); /* blocks are coupled only through the border */
    int li = i - lay->off[bi], lj = j - lay->off[bi];
    if (li < lj)
        return NULL;
    assert(li - lj <= lay->kd[bi]);
    return &a->band[bi][(li - lj) + (size_t)lj * (lay->kd[bi] + 1)];
}

/* Mark a stored entry as structurally non-zero. */
static void mark(dm_arrow *a, const double *s)
{
    for (int c = 0; c < NB; c++) {
        if (s >= a->band[c] && s < a->band[c] + band_len(&a->lay, c))
            a->touched[c][s - a->band[c]] = 1;
        if (s >= a->cpl[c] && s < a->cpl[c] + (size_t)a->lay.nb[c] * NP)
            a->touched_cpl[c][s - a->cpl[c]] = 1;
    }
}

void dm_arrow_add(dm_arrow *a, int i, int j, double v)
{
    double *s = slot(a, i, j);
    if (!s)
        return;
    *s += v;
    if (a->touched[0])
        mark(a, s);
}

/* A plan's places: which array (bands 0-2, couplings 3-5, the border 6)
 * in the bits above PLACE_SHIFT, the offset in it below. */
#define PLACE_SHIFT 24
#define PLACE_BORDER (2 * NB)

static int place(int array, size_t offset)
{
    assert(offset < (1u << PLACE_SHIFT));
    return (array << PLACE_SHIFT) | (int)offset;
}

void dm_arrow_plan_make(const dm_arrow_layout *lay, const int *idx, int m, dm_arrow_plan *p)
{
    int bo = lay->border, blk[DM_ARROW_PLAN_DOFS], loc[DM_ARROW_PLAN_DOFS];
    assert(m <= DM_ARROW_PLAN_DOFS);
    for (int r = 0; r < m; r++) { /* block and local index of each DOF */
        blk[r] = block_of(lay, idx[r]);
        loc[r] = idx[r] - (blk[r] == NB ? bo : lay->off[blk[r]]);
    }
    p->count = 0;
    for (int c = 0; c < m; c++)
        for (int r = 0; r < m; r++) {
            int to;
            if (blk[c] == NB)
                to = blk[r] == NB ? place(PLACE_BORDER, (size_t)loc[c] * NP + loc[r])
                                  : place(NB + blk[r], loc[r] + (size_t)loc[c] * lay->nb[blk[r]]);
            else if (blk[r] == blk[c] && loc[r] >= loc[c]) {
                assert(loc[r] - loc[c] <= lay->kd[blk[r]]);
                to = place(blk[r], (loc[r] - loc[c]) + (size_t)loc[c] * (lay->kd[blk[r]] + 1));
            } else {
                assert(blk[r] == NB || blk[r] == blk[c]); /* blocks meet only at the border */
                continue; /* the half that is not stored */
            }
            p->from[p->count] = (short)(c * m + r);
            p->to[p->count++] = to;
        }
}

void dm_arrow_add_planned(dm_arrow *a, const dm_arrow_plan *p, const double *E)
{
    double *base[2 * NB + 1];
    for (int c = 0; c < NB; c++)
        base[c] = a->band[c], base[NB + c] = a->cpl[c];
    base[PLACE_BORDER] = a->pp;
    const int mask = (1 << PLACE_SHIFT) - 1;
    for (int k = 0; k < p->count; k++)
        base[p->to[k] >> PLACE_SHIFT][p->to[k] & mask] += E[p->from[k]];
    if (a->touched[0])
        for (int k = 0; k < p->count; k++)
            mark(a, base[p->to[k] >> PLACE_SHIFT] + (p->to[k] & mask));
}

double dm_arrow_get(const dm_arrow *a, int i, int j)
{
    const dm_arrow_layout *lay = &a->lay;
    int bi = block_of(lay, i), bj = block_of(lay, j);
    if (bi != NB && bj != NB && bi != bj)
        return 0.0;
    if (bi == NB && bj != NB)
        return dm_arrow_get(a, j, i);
    if (bi == bj && bi != NB) {
        int li = i - lay->off[bi], lj = j - lay->off[bi];
        if (li < lj)
            return dm_arrow_get(a, j, i);
        if (li - lj > lay->kd[bi])
            return 0.0;
    }
    return *slot(a, i, j);
}

void dm_arrow_mult(const dm_arrow *a, const double *X, int q, double *Y)
{
    assert(q >= 1 && X != Y);
    kernels()->mult(a, X, q, Y);
}

void dm_arrow_axpby(dm_arrow *dst, const dm_arrow *a, double sigma, const dm_arrow *b)
{
    const dm_arrow_layout *lay = &a->lay;
    assert(dst->lay.n == lay->n && b->lay.n == lay->n);
    for (int c = 0; c < NB; c++) {
        size_t nband = band_len(lay, c), ncpl = (size_t)lay->nb[c] * NP;
        for (size_t i = 0; i < nband; i++)
            dst->band[c][i] = a->band[c][i] - sigma * b->band[c][i];
        for (size_t i = 0; i < ncpl; i++)
            dst->cpl[c][i] = a->cpl[c][i] - sigma * b->cpl[c][i];
    }
    for (int i = 0; i < NP * NP; i++)
        dst->pp[i] = a->pp[i] - sigma * b->pp[i];
}

void dm_arrow_to_dense(const dm_arrow *a, double *D)
{
    const dm_arrow_layout *lay = &a->lay;
    int n = lay->n, bo = lay->border;
    memset(D, 0, sizeof(double) * n * n);
    for (int c = 0; c < NB; c++) {
        int nb = lay->nb[c], kd = lay->kd[c], off = lay->off[c];
        for (int j = 0; j < nb; j++)
            for (int i = j; i <= j + kd && i < nb; i++) {
                double v = a->band[c][(i - j) + (size_t)j * (kd + 1)];
                D[(size_t)(off + j) * n + off + i] = D[(size_t)(off + i) * n + off + j] = v;
            }
        for (int m = 0; m < NP; m++)
            for (int i = 0; i < nb; i++) {
                double v = a->cpl[c][i + (size_t)m * nb];
                D[(size_t)(bo + m) * n + off + i] = D[(size_t)(off + i) * n + bo + m] = v;
            }
    }
    for (int m = 0; m < NP; m++)
        for (int l = 0; l < NP; l++)
            D[(size_t)(bo + m) * n + bo + l] = a->pp[m * NP + l];
}

/* ---- Cholesky ----------------------------------------------------------- */

int dm_arrow_chol_init(dm_arrow_chol *f, const dm_arrow_layout *lay, dm_error *err)
{
    memset(f, 0, sizeof *f);
    f->lay = *lay;
    int ok = 1;
    for (int c = 0; c < NB; c++) {
        f->band[c] = malloc(band_len(lay, c) * sizeof(double));
        f->W[c] = malloc((size_t)lay->nb[c] * NP * sizeof(double));
        f->Z[c] = malloc((size_t)lay->nb[c] * NP * sizeof(double));
        ok &= f->band[c] && f->W[c] && f->Z[c];
    }
    if (!ok) {
        dm_arrow_chol_release(f);
        return dm_fail(err, DM_ENOMEM, "out of memory for a %d-DOF factorization", lay->n);
    }
    return DM_OK;
}

void dm_arrow_chol_release(dm_arrow_chol *f)
{
    for (int c = 0; c < NB; c++) {
        free(f->band[c]);
        free(f->W[c]);
        free(f->Z[c]);
        f->band[c] = f->W[c] = f->Z[c] = NULL;
    }
}


int dm_arrow_chol_factor(dm_arrow_chol *f, const dm_arrow *a, dm_error *err)
{
    const dm_arrow_layout *lay = &a->lay;
    assert(f->lay.n == lay->n);
    f->pattern = a->pattern;
    memcpy(f->S, a->pp, sizeof f->S);
    for (int c = 0; c < NB; c++) {
        int nb = lay->nb[c], kd = lay->kd[c];
        const int *colend = a->pattern ? a->pattern->colend[c] : NULL;
        memcpy(f->band[c], a->band[c], band_len(lay, c) * sizeof(double));
        int info = kernels()->band_chol(f->band[c], nb, kd, colend);
        if (info)
            return dm_fail(err, DM_ENUMERIC,
                           "stiffness matrix is not positive definite (chain %d, pivot %d)", c,
                           info);
        f->w_first[c] = kernels()->border_of_factor(f->band[c], nb, kd, colend, a->cpl[c], f->Z[c],
                                         f->W[c], f->S);
    }
    for (int j = 0; j < NP; j++) /* exactly symmetric */
        for (int i = j + 1; i < NP; i++)
            f->S[j * NP + i] = f->S[i * NP + j] = 0.5 * (f->S[j * NP + i] + f->S[i * NP + j]);
    memcpy(f->LS, f->S, sizeof f->LS);
    lapack_int info = LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'L', NP, f->LS, NP);
    if (info)
        return dm_fail(err, DM_ENUMERIC,
                       "stiffness matrix is not positive definite (platform block, pivot %d)",
                       (int)info);
    return DM_OK;
}

void dm_arrow_chol_solve(const dm_arrow_chol *f, double *X, int q)
{
    assert(q >= 1);
    kernels()->chol_solve(f, X, q);
}


/* X = L^-1 X for the n columns of X (n x n interleaved) whose column j is
 * zero outside j's own chain and the border (the columns of a block-arrow
 * matrix, and the rows of L^-1 of one: [L_c^-1 0] on a chain): a chain's
 * solve visits its own columns and the border's, not all n. The same bits
 * as dm_arrow_chol_forward(f, X, n). */
static void forward_by_chain(const dm_arrow_chol *f, double *X)
{
    const dm_arrow_layout *lay = &f->lay;
    const dm_arrow_kernels *k = kernels();
    for (int c = 0; c < NB; c++)
        k->chains_forward(f, c, c + 1, X, lay->n, lay->off[c], lay->off[c] + lay->nb[c]);
    k->chains_forward(f, 0, NB, X, lay->n, lay->border, lay->n);
}

void dm_arrow_chol_forward(const dm_arrow_chol *f, double *X, int q)
{
    assert(q >= 1);
    kernels()->chol_forward(f, X, q);
}

void dm_arrow_chol_backward(const dm_arrow_chol *f, double *X, int q)
{
    assert(q >= 1);
    kernels()->chol_backward(f, X, q);
}

void dm_arrow_chol_reduce(const dm_arrow_chol *f, const dm_arrow *a, double *C, double *scratch)
{
    int n = f->lay.n;
    assert(a->lay.n == n);
    dm_arrow_to_dense(a, scratch); /* symmetric: its rows are its columns */
    forward_by_chain(f, scratch);
    for (int i = 0; i < n; i++) /* (L^-1 A)' as n interleaved vectors */
        for (int j = 0; j < n; j++)
            C[(size_t)i * n + j] = scratch[(size_t)j * n + i];
    forward_by_chain(f, C);
}

int dm_arrow_chol_border_inverse(const dm_arrow_chol *f, double Sinv[36])
{
    memcpy(Sinv, f->LS, sizeof f->LS);
    if (LAPACKE_dpotri_work(LAPACK_COL_MAJOR, 'L', NP, Sinv, NP))
        return DM_ENUMERIC;
    for (int j = 0; j < NP; j++)
        for (int i = 0; i < j; i++)
            Sinv[j * NP + i] = Sinv[i * NP + j];
    return DM_OK;
}

double dm_arrow_chol_logdet(const dm_arrow_chol *f)
{
    double s = 0;
    for (int c = 0; c < NB; c++)
        for (int j = 0; j < f->lay.nb[c]; j++)
            s += log(f->band[c][(size_t)j * (f->lay.kd[c] + 1)]);
    for (int j = 0; j < NP; j++)
        s += log(f->LS[j * NP + j]);
    return 2 * s;
}

/* ---- inertia ---------------------------------------------------------- */

int dm_arrow_ldl_init(dm_arrow_ldl *w, const dm_arrow_layout *lay, dm_error *err)
{
    memset(w, 0, sizeof *w);
    int rc = dm_arrow_init(&w->shifted, lay, err);
    for (int c = 0; c < NB && !rc; c++)
        if (!(w->Z[c] = malloc((size_t)lay->nb[c] * NP * sizeof(double))))
            rc = dm_fail(err, DM_ENOMEM, "out of memory for a Sturm count");
    if (rc)
        dm_arrow_ldl_release(w);
    return rc;
}

void dm_arrow_ldl_release(dm_arrow_ldl *w)
{
    dm_arrow_release(&w->shifted);
    for (int c = 0; c < NB; c++) {
        free(w->Z[c]);
        w->Z[c] = NULL;
    }
}


int dm_arrow_count_below(dm_arrow_ldl *w, const dm_arrow *A, const dm_arrow *B, double sigma,
                         int *count)
{
    const dm_arrow_layout *lay = &A->lay;
    dm_arrow *s = &w->shifted;
    dm_arrow_axpby(s, A, sigma, B);
    double S[NP * NP], ev[NP], work[3 * NP * NP];
    memcpy(S, s->pp, sizeof S);
    int total = 0;
    for (int c = 0; c < NB; c++) {
        int nb = lay->nb[c], kd = lay->kd[c];
        int neg = kernels()->band_ldl(s->band[c], nb, kd, A->pattern ? A->pattern->colend[c] : NULL);
        if (neg < 0)
            return DM_ENUMERIC;
        total += neg;
        kernels()->border_schur(s->band[c], nb, kd, A->pattern ? A->pattern->colend[c] : NULL, s->cpl[c],
                     w->Z[c], S);
    }
    if (LAPACKE_dsyev_work(LAPACK_COL_MAJOR, 'N', 'L', NP, S, NP, ev, work, 3 * NP * NP))
        return DM_ENUMERIC;
    double big = fmax(fabs(ev[0]), fabs(ev[NP - 1]));
    for (int k = 0; k < NP; k++) {
        if (fabs(ev[k]) <= 1e-12 * big)
            return DM_ENUMERIC; /* sigma on an eigenvalue of the border */
        total += ev[k] < 0;
    }
    *count = total;
    return DM_OK;
}
