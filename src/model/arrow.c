/* Symmetric block-arrow matrices (see dm_arrow.h). */
#include "dm_arrow.h"

#include <assert.h>
#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_clones.h"

#define NP DM_ARROW_BORDER
#define NB DM_ARROW_BLOCKS

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

void dm_arrow_copy(dm_arrow *dst, const dm_arrow *src)
{
    assert(dst->lay.n == src->lay.n);
    for (int c = 0; c < NB; c++) {
        memcpy(dst->band[c], src->band[c], band_len(&src->lay, c) * sizeof(double));
        memcpy(dst->cpl[c], src->cpl[c], (size_t)src->lay.nb[c] * NP * sizeof(double));
    }
    memcpy(dst->pp, src->pp, sizeof dst->pp);
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

/* Multi-vector blocks are interleaved: the q values of unknown i are
 * X[i q .. i q + q - 1], so every band entry updates q contiguous values
 * (vectorised), and one vector (q = 1) is an ordinary array. */

/* The kernels below run over blocks of q values; where the CPU has
 * AVX-512 or AVX2 a clone built for it is chosen when the program loads
 * (dm_clones.h: the baseline x86-64 build has only SSE2, a quarter and
 * half the width; every clone gives the same bits). AVX-512 over AVX2,
 * measured at the default mesh: eigen solves 13-20 % faster, the pose
 * 8-12 %. */

/* Each kernel walks the matrix once per slice of the q columns, a slice
 * being 24, 20, 16, 12, 8, 4, 3, 2 or 1 columns wide (at most two
 * slices up to q = 28): with the width a
 * compile-time constant the compiler unrolls the inner loops completely
 * and keeps a row's slice in registers across a column's entries
 * (measured at the default mesh: M products 1.3x faster at q = 20, 2x at
 * q = 3; solves 1.2x at q = 20, 2.8x at q = 1). Every value undergoes
 * the same operations in the same order as without slices: the results
 * are bit for bit those of a plain loop over q. */
#define INLINE static inline __attribute__((always_inline))

/* Width of the next slice of the q - o columns left. */
static inline int slice_width(int left)
{
    if (left >= 4) /* a multiple of 4 (AVX2's width), then at most 3 */
        return left >= 24 ? 24 : left & ~3;
    return left;
}

/* Run KERNEL(w) with w the constant equal to `width`. */
#define BY_WIDTH(width, KERNEL)                                                                    \
    switch (width) {                                                                               \
    case 24: KERNEL(24); break;                                                                    \
    case 20: KERNEL(20); break;                                                                    \
    case 16: KERNEL(16); break;                                                                    \
    case 12: KERNEL(12); break;                                                                    \
    case 8: KERNEL(8); break;                                                                      \
    case 4: KERNEL(4); break;                                                                      \
    case 3: KERNEL(3); break;                                                                      \
    case 2: KERNEL(2); break;                                                                      \
    default: KERNEL(1); break;                                                                     \
    }

/* Run KERNEL(W) on each slice of q columns: o, the slice's first column,
 * and W, its width, in scope. */
#define FOR_SLICES(q, KERNEL)                                                                      \
    for (int o = 0, w; o < (q); o += w) {                                                          \
        w = slice_width((q) - o);                                                                  \
        BY_WIDTH(w, KERNEL)                                                                        \
    }

/* A slice of w <= 24 values (w a multiple of 4) held in vector
 * registers: w / 8 vectors of eight, then one of four if w % 8 == 4. GCC
 * lowers each vector to the clone's widest registers (two AVX2 halves, four
 * SSE2 quarters). Without them the compiler kept the accumulating slices in
 * memory, every entry's update waiting on the store of the one before (at
 * q = 20 and the default mesh: M products 9.9 -> 8.2 us, solves 12.9 ->
 * 10.9). The loads and stores accept any alignment. */
typedef double vec8 __attribute__((vector_size(64), aligned(8), may_alias));
typedef double vec4 __attribute__((vector_size(32), aligned(8), may_alias));
#define V8(p) (*(vec8 *)(p))
#define V4(p) (*(vec4 *)(p))

typedef struct {
    vec8 e[3];
    vec4 f;
} slice;

/* w is a compile-time constant wherever these are inlined: the loops
 * unroll completely and a slice lives in registers. */
#define BY8(w, v) _Pragma("GCC unroll 3") for (int v = 0; v < (w) / 8; v++)
#define HAS4(w) ((w) % 8 == 4)

INLINE slice slice_load(const double *x, int w)
{
    slice s = {0};
    BY8(w, v) s.e[v] = V8(x + 8 * v);
    if (HAS4(w))
        s.f = V4(x + w - 4);
    return s;
}

INLINE void slice_store(double *y, const slice *s, int w)
{
    BY8(w, v) V8(y + 8 * v) = s->e[v];
    if (HAS4(w))
        V4(y + w - 4) = s->f;
}

/* s += a x (x in memory) */
INLINE void slice_axpy(slice *s, double a, const double *x, int w)
{
    BY8(w, v) s->e[v] += a * V8(x + 8 * v);
    if (HAS4(w))
        s->f += a * V4(x + w - 4);
}

/* y += a s (y in memory) */
INLINE void slice_axpy_to(double *y, double a, const slice *s, int w)
{
    BY8(w, v) V8(y + 8 * v) += a * s->e[v];
    if (HAS4(w))
        V4(y + w - 4) += a * s->f;
}

INLINE void slice_scale(slice *s, double a, int w)
{
    BY8(w, v) s->e[v] *= a;
    if (HAS4(w))
        s->f *= a;
}

/* Whether a slice of w values goes through registers (else plain loops). */
#define IN_REGISTERS(w) ((w) % 4 == 0 && (w) <= 24)

/* y_i += a x_j over w values */
INLINE void axpy_w(double *restrict y, double a, const double *restrict x, int w)
{
    if (IN_REGISTERS(w)) {
        slice s = slice_load(x, w);
        slice_axpy_to(y, a, &s, w);
        return;
    }
#pragma omp simd
    for (int r = 0; r < w; r++)
        y[r] += a * x[r];
}

/* Y_c += A_c X_c over the w columns of a slice (rows q apart), the
 * pattern's entries: row j's slice accumulates in registers. */
INLINE void band_mult_slice(const double *ab, int n, int ld, const int *colptr, const int *rows,
                            const double *X, double *Y, int q, int w)
{
    if (IN_REGISTERS(w)) {
        for (int j = 0; j < n; j++) {
            const double *col = ab + (size_t)j * ld;
            double *yj = Y + (size_t)j * q;
            slice xj = slice_load(X + (size_t)j * q, w), acc = slice_load(yj, w);
            slice_axpy(&acc, col[0], X + (size_t)j * q, w);
            for (int p = colptr[j]; p < colptr[j + 1]; p++) {
                int i = rows[p];
                double a = col[i - j];
                slice_axpy_to(Y + (size_t)i * q, a, &xj, w);
                slice_axpy(&acc, a, X + (size_t)i * q, w);
            }
            slice_store(yj, &acc, w);
        }
        return;
    }
    for (int j = 0; j < n; j++) {
        const double *col = ab + (size_t)j * ld, *xj = X + (size_t)j * q;
        double *yj = Y + (size_t)j * q, acc[24];
#pragma omp simd
        for (int r = 0; r < w; r++)
            acc[r] = yj[r] + col[0] * xj[r];
        for (int p = colptr[j]; p < colptr[j + 1]; p++) {
            int i = rows[p];
            double a = col[i - j], *yi = Y + (size_t)i * q;
            const double *xi = X + (size_t)i * q;
#pragma omp simd
            for (int r = 0; r < w; r++) {
                yi[r] += a * xj[r];
                acc[r] += a * xi[r];
            }
        }
#pragma omp simd
        for (int r = 0; r < w; r++)
            yj[r] = acc[r];
    }
}

/* The same over every non-zero of the band (no pattern recorded). */
INLINE void band_mult_full(const double *ab, int n, int kd, const double *X, double *Y, int q,
                           int w)
{
    int ld = kd + 1;
    for (int j = 0; j < n; j++) {
        const double *col = ab + (size_t)j * ld, *xj = X + (size_t)j * q;
        double *yj = Y + (size_t)j * q;
        axpy_w(yj, col[0], xj, w);
        int top = j + kd < n - 1 ? j + kd : n - 1;
        for (int i = j + 1; i <= top; i++) {
            double a = col[i - j];
            if (a == 0)
                continue;
            axpy_w(Y + (size_t)i * q, a, xj, w);
            axpy_w(yj, a, X + (size_t)i * q, w);
        }
    }
}

/* Y_c += A_c X_c for one banded block (symmetric, lower band storage):
 * the pattern's entries, or every non-zero of the band. */
DM_VECTOR_CLONES static void band_mult(const double *ab, int n, int kd, const dm_arrow_pattern *pat,
                                       int c, const double *X, double *Y, int q)
{
#define KERNEL(W)                                                                                  \
    if (pat)                                                                                       \
        band_mult_slice(ab, n, kd + 1, pat->colptr[c], pat->rows[c], X + o, Y + o, q, W);         \
    else                                                                                           \
        band_mult_full(ab, n, kd, X + o, Y + o, q, W)
    FOR_SLICES(q, KERNEL)
#undef KERNEL
}

/* Y_c += C_c X_P and Y_P += C_c' X_c over a slice: C_c's entries k (row
 * k - m nb of column m) from `index`, those of column m from start[m] on;
 * or every non-zero of C_c. */
INLINE void coupling_slice(const double *cpl, int nb, const int *index, const int *start,
                           const double *xc, const double *xp, double *yc, double *yp, int q,
                           int w)
{
    for (int m = 0; m < NP; m++) {
        const double *xm = xp + (size_t)m * q, *cm = cpl + (size_t)m * nb;
        double *ym = yp + (size_t)m * q;
        if (index && IN_REGISTERS(w)) { /* y_m's slice accumulates in registers */
            slice x = slice_load(xm, w), acc = slice_load(ym, w);
            for (int e = start[m]; e < start[m + 1]; e++) {
                int i = index[e] - m * nb;
                slice_axpy_to(yc + (size_t)i * q, cm[i], &x, w);
                slice_axpy(&acc, cm[i], xc + (size_t)i * q, w);
            }
            slice_store(ym, &acc, w);
        } else if (index) {
            for (int e = start[m]; e < start[m + 1]; e++) {
                int i = index[e] - m * nb;
                axpy_w(yc + (size_t)i * q, cm[i], xm, w);
                axpy_w(ym, cm[i], xc + (size_t)i * q, w);
            }
        } else {
            for (int i = 0; i < nb; i++)
                if (cm[i] != 0) {
                    axpy_w(yc + (size_t)i * q, cm[i], xm, w);
                    axpy_w(ym, cm[i], xc + (size_t)i * q, w);
                }
        }
    }
}

/* Y_c += C_c X_P and Y_P += C_c' X_c */
DM_VECTOR_CLONES static void coupling_mult(const dm_arrow *a, int c, const double *X, double *Y,
                                           int q)
{
    const dm_arrow_layout *lay = &a->lay;
    int nb = lay->nb[c];
    const double *xc = X + (size_t)lay->off[c] * q, *xp = X + (size_t)lay->border * q;
    double *yc = Y + (size_t)lay->off[c] * q, *yp = Y + (size_t)lay->border * q;
    const int *index = a->pattern ? a->pattern->cpl[c] : NULL;
    const int *start = a->pattern ? a->pattern->cpl_start[c] : NULL;
#define KERNEL(W) coupling_slice(a->cpl[c], nb, index, start, xc + o, xp + o, yc + o, yp + o, q, W)
    FOR_SLICES(q, KERNEL)
#undef KERNEL
}

void dm_arrow_mult(const dm_arrow *a, const double *X, int q, double *Y)
{
    const dm_arrow_layout *lay = &a->lay;
    assert(q >= 1 && X != Y);
    memset(Y, 0, sizeof(double) * lay->n * q);
    const double *xp = X + (size_t)lay->border * q;
    double *yp = Y + (size_t)lay->border * q;
    for (int c = 0; c < NB; c++) {
        int off = lay->off[c];
        band_mult(a->band[c], lay->nb[c], lay->kd[c], a->pattern, c, X + (size_t)off * q,
                  Y + (size_t)off * q, q);
        coupling_mult(a, c, X, Y, q);
    }
    for (int m = 0; m < NP; m++)
        for (int l = 0; l < NP; l++)
            axpy_w(yp + (size_t)m * q, a->pp[l * NP + m], xp + (size_t)l * q, q);
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

/* Last row of column j that a factor can fill: the profile's, or the band's. */
static int column_end(const int *colend, int j, int n, int kd)
{
    return colend ? colend[j] : (j + kd < n - 1 ? j + kd : n - 1);
}

/* In-place Cholesky of a banded block (right-looking, over the profile:
 * the fill of column j stays within it, see dm_arrow_pattern_make). 0, or
 * the failed column + 1 when a pivot is not positive. */
DM_VECTOR_CLONES static int band_chol(double *ab, int n, int kd, const int *colend)
{
    int ld = kd + 1;
    for (int j = 0; j < n; j++) {
        double *col = ab + (size_t)j * ld;
        if (!(col[0] > 0))
            return j + 1;
        double d = sqrt(col[0]), inv = 1.0 / d;
        int top = column_end(colend, j, n, kd);
        col[0] = d;
        for (int i = j + 1; i <= top; i++)
            col[i - j] *= inv;
        for (int i = j + 1; i <= top; i++) {
            double lij = col[i - j], *ci = ab + (size_t)i * ld;
            if (lij == 0)
                continue;
#pragma omp simd /* column i and column j do not overlap */
            for (int m = i; m <= top; m++)
                ci[m - i] -= lij * col[m - j];
        }
    }
    return 0;
}

/* W = L^-1 C (C's NP columns, nb apart) for the factor in ab, and S -=
 * W' W: Z holds W interleaved (the NP values of row i together) while the
 * solve updates whole rows, from C's first non-zero row on (W is zero
 * above: the border reaches a chain at its lower rod ends, numbered last). */
DM_VECTOR_CLONES static int border_of_factor(const double *ab, int nb, int kd, const int *colend,
                                             const double *C, double *Z, double *W,
                                             double S[NP * NP])
{
    int ld = kd + 1, first = nb;
    for (int i = 0; i < nb; i++)
        for (int m = 0; m < NP; m++) {
            Z[(size_t)i * NP + m] = C[i + (size_t)m * nb];
            if (Z[(size_t)i * NP + m] != 0 && i < first)
                first = i;
        }
    double acc[NP * NP] = {0};
    for (int j = first; j < nb; j++) {
        const double *col = ab + (size_t)j * ld;
        double *zj = Z + (size_t)j * NP, inv = 1.0 / col[0];
        int top = column_end(colend, j, nb, kd);
#pragma omp simd
        for (int m = 0; m < NP; m++)
            zj[m] *= inv;
        for (int i = j + 1; i <= top; i++)
            if (col[i - j] != 0)
                axpy_w(Z + (size_t)i * NP, -col[i - j], zj, NP);
        for (int a = 0; a < NP; a++) {
#pragma omp simd
            for (int b = 0; b < NP; b++)
                acc[a * NP + b] += zj[a] * zj[b];
        }
    }
    for (int i = 0; i < nb; i++)
        for (int m = 0; m < NP; m++)
            W[i + (size_t)m * nb] = i < first ? 0 : Z[(size_t)i * NP + m];
    for (int a = 0; a < NP * NP; a++)
        S[a] -= acc[a];
    return first;
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
        int info = band_chol(f->band[c], nb, kd, colend);
        if (info)
            return dm_fail(err, DM_ENUMERIC,
                           "stiffness matrix is not positive definite (chain %d, pivot %d)", c,
                           info);
        f->w_first[c] = border_of_factor(f->band[c], nb, kd, colend, a->cpl[c], f->Z[c],
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

/* X_c = L_c^-1 X_c (lower band, forward) over a slice: row j's values,
 * once final, stay in registers while they update the rows below. */
INLINE void band_forward(const double *L, int n, int kd, const int *colend, double *X, int q, int w)
{
    int ld = kd + 1;
    for (int j = 0; j < n; j++) {
        const double *col = L + (size_t)j * ld;
        double *xj = X + (size_t)j * q, inv = 1.0 / col[0];
        int top = column_end(colend, j, n, kd);
        if (IN_REGISTERS(w)) {
            slice xr = slice_load(xj, w);
            slice_scale(&xr, inv, w);
            slice_store(xj, &xr, w);
            for (int i = j + 1; i <= top; i++)
                if (col[i - j] != 0)
                    slice_axpy_to(X + (size_t)i * q, -col[i - j], &xr, w);
            continue;
        }
        double xr[24];
#pragma omp simd
        for (int r = 0; r < w; r++)
            xj[r] = xr[r] = xj[r] * inv;
        for (int i = j + 1; i <= top; i++)
            if (col[i - j] != 0)
                axpy_w(X + (size_t)i * q, -col[i - j], xr, w);
    }
}

/* X_c = L_c^-T X_c (backward) over a slice: row j accumulates in registers */
INLINE void band_backward(const double *L, int n, int kd, const int *colend, double *X, int q,
                          int w)
{
    int ld = kd + 1;
    for (int j = n - 1; j >= 0; j--) {
        const double *col = L + (size_t)j * ld;
        double *xj = X + (size_t)j * q, inv = 1.0 / col[0];
        int top = column_end(colend, j, n, kd);
        if (IN_REGISTERS(w)) {
            slice acc = slice_load(xj, w);
            for (int i = j + 1; i <= top; i++)
                if (col[i - j] != 0)
                    slice_axpy(&acc, -col[i - j], X + (size_t)i * q, w);
            slice_scale(&acc, inv, w);
            slice_store(xj, &acc, w);
            continue;
        }
        double acc[24];
#pragma omp simd
        for (int r = 0; r < w; r++)
            acc[r] = xj[r];
        for (int i = j + 1; i <= top; i++)
            if (col[i - j] != 0)
                axpy_w(acc, -col[i - j], X + (size_t)i * q, w);
#pragma omp simd
        for (int r = 0; r < w; r++)
            xj[r] = acc[r] * inv;
    }
}

/* x_P = LS^-1 x_P and x_P = LS^-T x_P: the border's two triangular solves */
INLINE void border_forward_solve(const double *LS, double *xp, int q, int w)
{
    for (int j = 0; j < NP; j++) {
        double *xj = xp + (size_t)j * q, inv = 1.0 / LS[j * NP + j];
        for (int l = 0; l < j; l++)
            axpy_w(xj, -LS[l * NP + j], xp + (size_t)l * q, w);
#pragma omp simd
        for (int r = 0; r < w; r++)
            xj[r] *= inv;
    }
}

INLINE void border_backward_solve(const double *LS, double *xp, int q, int w)
{
    for (int j = NP - 1; j >= 0; j--) {
        double *xj = xp + (size_t)j * q, inv = 1.0 / LS[j * NP + j];
        for (int l = j + 1; l < NP; l++)
            axpy_w(xj, -LS[j * NP + l], xp + (size_t)l * q, w);
#pragma omp simd
        for (int r = 0; r < w; r++)
            xj[r] *= inv;
    }
}

/* x_P -= W_c' y_c: each border row's slice accumulates in registers */
INLINE void border_forward(const double *W, int nb, int first, const double *xc, double *xp,
                           int q, int w)
{
    for (int m = 0; m < NP; m++) {
        const double *wm = W + (size_t)m * nb;
        double *xm = xp + (size_t)m * q;
        if (IN_REGISTERS(w)) {
            slice acc = slice_load(xm, w);
            for (int i = first; i < nb; i++)
                if (wm[i] != 0)
                    slice_axpy(&acc, -wm[i], xc + (size_t)i * q, w);
            slice_store(xm, &acc, w);
            continue;
        }
        double acc[24];
#pragma omp simd
        for (int r = 0; r < w; r++)
            acc[r] = xm[r];
        for (int i = first; i < nb; i++)
            if (wm[i] != 0)
                axpy_w(acc, -wm[i], xc + (size_t)i * q, w);
#pragma omp simd
        for (int r = 0; r < w; r++)
            xm[r] = acc[r];
    }
}

/* x_c -= W_c x_P */
INLINE void border_backward(const double *W, int nb, int first, const double *xp, double *xc,
                            int q, int w)
{
    for (int m = 0; m < NP; m++)
        for (int i = first; i < nb; i++)
            if (W[i + (size_t)m * nb] != 0)
                axpy_w(xc + (size_t)i * q, -W[i + (size_t)m * nb], xp + (size_t)m * q, w);
}

/* X = L^-1 X (forward: y_c = L_c^-1 x_c, x_P -= W_c' y_c, x_P = LS^-1 x_P)
 * and X = L^-T X (backward: x_P = LS^-T x_P, x_c = L_c^-T (y_c - W_c x_P))
 * for the w columns of a slice (columns are independent). */
INLINE void chains_forward_slice(const dm_arrow_chol *f, int c0, int c1, double *X, int q, int w)
{
    const dm_arrow_layout *lay = &f->lay;
    double *xp = X + (size_t)lay->border * q;
    for (int c = c0; c < c1; c++) {
        double *xc = X + (size_t)lay->off[c] * q;
        const int *colend = f->pattern ? f->pattern->colend[c] : NULL;
        band_forward(f->band[c], lay->nb[c], lay->kd[c], colend, xc, q, w);
        border_forward(f->W[c], lay->nb[c], f->w_first[c], xc, xp, q, w);
    }
    border_forward_solve(f->LS, xp, q, w);
}

INLINE void chol_forward_slice(const dm_arrow_chol *f, double *X, int q, int w)
{
    chains_forward_slice(f, 0, NB, X, q, w);
}

INLINE void chol_backward_slice(const dm_arrow_chol *f, double *X, int q, int w)
{
    const dm_arrow_layout *lay = &f->lay;
    double *xp = X + (size_t)lay->border * q;
    border_backward_solve(f->LS, xp, q, w);
    for (int c = 0; c < NB; c++) {
        double *xc = X + (size_t)lay->off[c] * q;
        const int *colend = f->pattern ? f->pattern->colend[c] : NULL;
        border_backward(f->W[c], lay->nb[c], f->w_first[c], xp, xc, q, w);
        band_backward(f->band[c], lay->nb[c], lay->kd[c], colend, xc, q, w);
    }
}

/* The whole solve, X = L^-T L^-1 X. */
INLINE void chol_solve_slice(const dm_arrow_chol *f, double *X, int q, int w)
{
    chol_forward_slice(f, X, q, w);
    chol_backward_slice(f, X, q, w);
}

DM_VECTOR_CLONES static void chol_solve(const dm_arrow_chol *f, double *X, int q)
{
#define KERNEL(W) chol_solve_slice(f, X + o, q, W)
    FOR_SLICES(q, KERNEL)
#undef KERNEL
}

void dm_arrow_chol_solve(const dm_arrow_chol *f, double *X, int q)
{
    assert(q >= 1);
    chol_solve(f, X, q);
}

DM_VECTOR_CLONES static void chol_forward(const dm_arrow_chol *f, double *X, int q)
{
#define KERNEL(W) chol_forward_slice(f, X + o, q, W)
    FOR_SLICES(q, KERNEL)
#undef KERNEL
}

DM_VECTOR_CLONES static void chol_backward(const dm_arrow_chol *f, double *X, int q)
{
#define KERNEL(W) chol_backward_slice(f, X + o, q, W)
    FOR_SLICES(q, KERNEL)
#undef KERNEL
}

/* The forward solve of columns o0 .. o1-1 of X (rows q apart) that are
 * zero on every chain but c0 .. c1-1: the others' solves would leave them
 * zero and add nothing to the border. */
DM_VECTOR_CLONES static void chains_forward(const dm_arrow_chol *f, int c0, int c1, double *X,
                                            int q, int o0, int o1)
{
#define KERNEL(W) chains_forward_slice(f, c0, c1, X + o0 + o, q, W)
    FOR_SLICES(o1 - o0, KERNEL)
#undef KERNEL
}

/* X = L^-1 X for the n columns of X (n x n interleaved) whose column j is
 * zero outside j's own chain and the border (the columns of a block-arrow
 * matrix, and the rows of L^-1 of one: [L_c^-1 0] on a chain): a chain's
 * solve visits its own columns and the border's, not all n. The same bits
 * as dm_arrow_chol_forward(f, X, n). */
static void forward_by_chain(const dm_arrow_chol *f, double *X)
{
    const dm_arrow_layout *lay = &f->lay;
    for (int c = 0; c < NB; c++)
        chains_forward(f, c, c + 1, X, lay->n, lay->off[c], lay->off[c] + lay->nb[c]);
    chains_forward(f, 0, NB, X, lay->n, lay->border, lay->n);
}

void dm_arrow_chol_forward(const dm_arrow_chol *f, double *X, int q)
{
    assert(q >= 1);
    chol_forward(f, X, q);
}

void dm_arrow_chol_backward(const dm_arrow_chol *f, double *X, int q)
{
    assert(q >= 1);
    chol_backward(f, X, q);
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

/* Largest growth |L||D||L'| / |A| on the diagonal we accept: beyond it the
 * computed factor is not that of a matrix near A - sigma B. */
#define LDL_MAX_GROWTH 1e8

/* In-place LDL' of a banded block without pivoting (right-looking): D on
 * the diagonal, L (unit) below it. Returns the number of negative pivots,
 * or -1 when a pivot's growth says the count cannot be trusted. */
DM_VECTOR_CLONES static int band_ldl(double *ab, int n, int kd, const int *colend)
{
    int ld = kd + 1, neg = 0;
    for (int j = 0; j < n; j++) {
        double *col = ab + (size_t)j * ld, d = col[0];
        int top = column_end(colend, j, n, kd);
        double big = 0;
        for (int i = j + 1; i <= top; i++)
            big = fmax(big, fabs(col[i - j]));
        if (d == 0 || fabs(d) * LDL_MAX_GROWTH < big) /* |l_ij| up to big / |d| */
            return -1;
        neg += d < 0;
        for (int i = j + 1; i <= top; i++) { /* trailing update with the unscaled column */
            double lij = col[i - j] / d, *ci = ab + (size_t)i * ld;
#pragma omp simd /* column i and column j do not overlap */
            for (int m = i; m <= top; m++)
                ci[m - i] -= lij * col[m - j];
        }
        for (int i = j + 1; i <= top; i++)
            col[i - j] /= d;
    }
    return neg;
}

/* S -= Z' D^-1 Z with Z = L^-1 C, for the unit L and the D of band_ldl
 * in ab: Z interleaved (the 6 values of row i together) so the solve
 * updates whole rows, from C's first non-zero row on (Z is zero above). */
DM_VECTOR_CLONES static void border_schur(const double *ab, int nb, int kd, const int *colend,
                                          const double *C, double *Z, double S[NP * NP])
{
    int ld = kd + 1, first = nb;
    for (int i = 0; i < nb; i++)
        for (int m = 0; m < NP; m++) {
            Z[(size_t)i * NP + m] = C[i + (size_t)m * nb];
            if (Z[(size_t)i * NP + m] != 0 && i < first)
                first = i;
        }
    for (int j = first; j < nb; j++) {
        const double *col = ab + (size_t)j * ld, *zj = Z + (size_t)j * NP;
        int top = column_end(colend, j, nb, kd);
        for (int i = j + 1; i <= top; i++)
            if (col[i - j] != 0)
                axpy_w(Z + (size_t)i * NP, -col[i - j], zj, NP);
    }
    double acc[NP * NP] = {0};
    for (int i = first; i < nb; i++) {
        const double *zi = Z + (size_t)i * NP;
        double dinv = 1 / ab[(size_t)i * ld];
        for (int a = 0; a < NP; a++) {
            double za = zi[a] * dinv;
#pragma omp simd
            for (int b = 0; b < NP; b++)
                acc[a * NP + b] += za * zi[b];
        }
    }
    for (int a = 0; a < NP; a++) /* exactly symmetric */
        for (int b = 0; b <= a; b++) {
            double v = 0.5 * (acc[a * NP + b] + acc[b * NP + a]);
            S[b * NP + a] -= v;
            if (a != b)
                S[a * NP + b] -= v;
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
        int neg = band_ldl(s->band[c], nb, kd, A->pattern ? A->pattern->colend[c] : NULL);
        if (neg < 0)
            return DM_ENUMERIC;
        total += neg;
        border_schur(s->band[c], nb, kd, A->pattern ? A->pattern->colend[c] : NULL, s->cpl[c],
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
