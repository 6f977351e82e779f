/* The block-arrow kernels (dm_arrow.h): products, the factor's parts and
 * its solves, the LDL' of the Sturm count. This file is compiled once per
 * instruction-set path of the target (the Makefile: DM_ISA_PATH default,
 * and on x86-64 also avx2 with -mavx2 and avx512 with -mavx512f), each
 * build holding a block's slices in vectors of its own registers' width,
 * and defines that path's table, dm_arrow_kernels_PATH (arrow_impl.h);
 * dm_isa chooses one for the process.
 *
 * Why not one source with GCC's target_clones: a clone is compiled from
 * the same preprocessed text, so its vectors had one width for all
 * targets; 8-double vectors are native on AVX-512 only, and GCC lowered
 * them through the stack on AVX2 and SSE2 (every slice stored 8 bytes at
 * a time and reloaded whole: the AVX2 clone ran no faster than SSE2,
 * issue 34). Here each path's vectors are its registers.
 *
 * The same bits on every path: no build enables FMA (and C11 mode keeps
 * contraction off), and every value undergoes the same operations in the
 * same order whatever the vector width (the slices split the q columns,
 * which never mix). */
#include <assert.h>
#include <math.h>
#include <string.h>

#include "arrow_impl.h"


#define NP DM_ARROW_BORDER
#define NB DM_ARROW_BLOCKS

/* Multi-vector blocks are interleaved: the q values of unknown i are
 * X[i q .. i q + q - 1], so every band entry updates q contiguous values
 * (vectorised), and one vector (q = 1) is an ordinary array. */

/* VW, doubles in the path's vector registers, and SLICE_MAX, the widest
 * slice, chosen so that the two slices a kernel holds (a row's values and
 * an accumulator) and a broadcast fit the registers: 32 of 8 on AVX-512
 * (6 for two slices of 24), 16 of 4 on AVX2 (12), 16 of 2 on SSE2 (two
 * slices of 12 would take 24: 8 leaves room), 32 of 2 on NEON (16). */
#if defined(__AVX512F__)
#define VW 8
#define SLICE_WIDEST 24
#elif defined(__AVX2__)
#define VW 4
#define SLICE_WIDEST 24
#elif defined(__aarch64__)
#define VW 2
#define SLICE_WIDEST 16
#else
#define VW 2
#define SLICE_WIDEST 12
#endif
#ifndef SLICE_MAX /* (another, for measurements) */
#define SLICE_MAX SLICE_WIDEST
#endif

/* Each kernel walks the matrix once per slice of the q columns, a slice
 * being a multiple of 4 columns up to SLICE_MAX, or the last 3, 2 or 1:
 * with the width a compile-time constant the compiler unrolls the inner
 * loops completely and keeps a row's slice in registers across a column's
 * entries (measured at the default mesh on AVX-512: M products 1.3x faster
 * at q = 20, 2x at q = 3; solves 1.2x at q = 20, 2.8x at q = 1). */
#define INLINE static inline __attribute__((always_inline))

/* Width of the next slice of the q - o columns left. */
static inline int slice_width(int left)
{
    if (left >= 4) /* a multiple of 4 (AVX2's width), then at most 3 */
        return left >= SLICE_MAX ? SLICE_MAX : left & ~3;
    return left;
}

/* Run KERNEL(w) with w the constant equal to `width` (the cases above
 * SLICE_MAX are never taken on the paths that have a smaller one). */
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

/* A slice of w <= SLICE_MAX values (w a multiple of 4) held in vector
 * registers: w / VW vectors, and on AVX-512 one of four more when w % 8 ==
 * 4. Without them the compiler kept the accumulating slices in memory,
 * every entry's update waiting on the store of the one before (at q = 20
 * and the default mesh: M products 9.9 -> 8.2 us, solves 12.9 -> 10.9).
 * The loads and stores accept any alignment. */
typedef double vec __attribute__((vector_size(8 * VW), aligned(8), may_alias));
#define VEC(p) (*(vec *)(p))

#if VW == 8
typedef double vec4 __attribute__((vector_size(32), aligned(8), may_alias));
#define V4(p) (*(vec4 *)(p))
#define TAIL4(w, stmt)                                                                             \
    if ((w) % 8 == 4) {                                                                            \
        stmt;                                                                                      \
    }
#else
#define TAIL4(w, stmt)
#endif

typedef struct {
    vec e[SLICE_MAX / VW];
#if VW == 8
    vec4 f;
#endif
} slice;


/* w is a compile-time constant wherever these are inlined: the loops
 * unroll completely and a slice lives in registers. */
#define BYV(w, v) _Pragma("GCC unroll 12") for (int v = 0; v < (w) / VW; v++)

INLINE slice slice_load(const double *x, int w)
{
    slice s = {0};
    BYV(w, v) s.e[v] = VEC(x + VW * v);
    TAIL4(w, s.f = V4(x + w - 4))
    return s;
}

INLINE void slice_store(double *y, const slice *s, int w)
{
    BYV(w, v) VEC(y + VW * v) = s->e[v];
    TAIL4(w, V4(y + w - 4) = s->f)
}

/* s += a x (x in memory) */
INLINE void slice_axpy(slice *s, double a, const double *x, int w)
{
    BYV(w, v) s->e[v] += a * VEC(x + VW * v);
    TAIL4(w, s->f += a * V4(x + w - 4))
}

/* y += a s (y in memory) */
INLINE void slice_axpy_to(double *y, double a, const slice *s, int w)
{
    BYV(w, v) VEC(y + VW * v) += a * s->e[v];
    TAIL4(w, V4(y + w - 4) += a * s->f)
}

INLINE void slice_scale(slice *s, double a, int w)
{
    BYV(w, v) s->e[v] *= a;
    TAIL4(w, s->f *= a)
}

/* Whether a slice of w values goes through registers (else plain loops). */
#define IN_REGISTERS(w) ((w) % 4 == 0 && (w) <= SLICE_MAX)

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
static void band_mult(const double *ab, int n, int kd, const dm_arrow_pattern *pat,
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
static void coupling_mult(const dm_arrow *a, int c, const double *X, double *Y,
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

static void mult(const dm_arrow *a, const double *X, int q, double *Y)
{
    const dm_arrow_layout *lay = &a->lay;
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

/* Last row of column j that a factor can fill: the profile's, or the band's. */
static int column_end(const int *colend, int j, int n, int kd)
{
    return colend ? colend[j] : (j + kd < n - 1 ? j + kd : n - 1);
}

/* In-place Cholesky of a banded block (right-looking, over the profile:
 * the fill of column j stays within it, see dm_arrow_pattern_make). 0, or
 * the failed column + 1 when a pivot is not positive. */
static int band_chol(double *ab, int n, int kd, const int *colend)
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
static int border_of_factor(const double *ab, int nb, int kd, const int *colend,
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

static void chol_solve(const dm_arrow_chol *f, double *X, int q)
{
#define KERNEL(W) chol_solve_slice(f, X + o, q, W)
    FOR_SLICES(q, KERNEL)
#undef KERNEL
}

static void chol_forward(const dm_arrow_chol *f, double *X, int q)
{
#define KERNEL(W) chol_forward_slice(f, X + o, q, W)
    FOR_SLICES(q, KERNEL)
#undef KERNEL
}

static void chol_backward(const dm_arrow_chol *f, double *X, int q)
{
#define KERNEL(W) chol_backward_slice(f, X + o, q, W)
    FOR_SLICES(q, KERNEL)
#undef KERNEL
}

/* The forward solve of columns o0 .. o1-1 of X (rows q apart) that are
 * zero on every chain but c0 .. c1-1: the others' solves would leave them
 * zero and add nothing to the border. */
static void chains_forward(const dm_arrow_chol *f, int c0, int c1, double *X,
                                            int q, int o0, int o1)
{
#define KERNEL(W) chains_forward_slice(f, c0, c1, X + o0 + o, q, W)
    FOR_SLICES(o1 - o0, KERNEL)
#undef KERNEL
}

/* Largest growth |L||D||L'| / |A| on the diagonal we accept: beyond it the
 * computed factor is not that of a matrix near A - sigma B. */
#define LDL_MAX_GROWTH 1e8

/* In-place LDL' of a banded block without pivoting (right-looking): D on
 * the diagonal, L (unit) below it. Returns the number of negative pivots,
 * or -1 when a pivot's growth says the count cannot be trusted. */
static int band_ldl(double *ab, int n, int kd, const int *colend)
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
static void border_schur(const double *ab, int nb, int kd, const int *colend,
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

const dm_arrow_kernels DM_ISA_TABLE(dm_arrow_kernels_) = {
    .mult = mult,
    .band_chol = band_chol,
    .border_of_factor = border_of_factor,
    .chol_solve = chol_solve,
    .chol_forward = chol_forward,
    .chol_backward = chol_backward,
    .chains_forward = chains_forward,
    .band_ldl = band_ldl,
    .border_schur = border_schur,
    .slice_max = SLICE_MAX,
};
