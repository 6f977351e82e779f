/* The reduced problem's small dense products, Cholesky factors and
 * tridiagonal forms (boundary_eig.c, boundary.c), compiled
 * once per instruction-set path as the block-arrow kernels are (dm_isa.h,
 * src/model/arrow_kernels.c): the path's table is
 * dm_boundary_kernels_PATH.
 *
 * Why not BLAS: the reduced solve's products are tiny (24 x 24 by 20
 * columns, B's runs of 6 columns by 33 or 90 rows, 123 x 20 blocks) and
 * many, and OpenBLAS packs both operands into buffers at every call
 * before its kernel runs; on an AMD EPYC (Zen 3, AVX2) its copies took a
 * third of the products' time and the products a quarter of a members
 * sweep's pose. Here nothing is packed: every operand is read where it
 * lies, the accumulators stay in registers.
 *
 * The same bits on every path: no build contracts a multiply and an add
 * (no FMA; C11 mode keeps contraction off), and every entry's sum runs in
 * a fixed order whatever the vector width: each entry's k products are
 * added in order, the vectors holding neighbouring rows. */
#include <assert.h>
#include <float.h>
#include <math.h>

#include "boundary_impl.h"

#if defined(__AVX512F__)
#define VW 8
#elif defined(__AVX2__)
#define VW 4
#else
#define VW 2 /* SSE2, NEON */
#endif

#define INLINE static inline __attribute__((always_inline))

/* Vectors of 8, 4, 2 and 1 doubles at any alignment; only those no wider
 * than the path's registers are used (wider ones GCC lowers through
 * memory). */
typedef double vec __attribute__((vector_size(8 * VW), aligned(8), may_alias));
#if VW == 8
typedef double vec4 __attribute__((vector_size(32), aligned(8), may_alias));
#endif
typedef double vec2 __attribute__((vector_size(16), aligned(8), may_alias)); /* vec where VW = 2 */
typedef double vec1 __attribute__((aligned(8), may_alias));

#define UNROLL _Pragma("GCC unroll 8")

/* Y[i + c ldy] (rows i0 .. i0 + NV L - 1, columns j0 .. j0 + NC - 1) =
 * (add ? Y : 0) + sum over r < k of A[i + r lda] X[r + c ldx], in r order;
 * T a vector of L doubles, NV of them a column. With TRI the sum of
 * column j0 + c stops at r = j0 + c (X upper triangular: the products
 * below its diagonal are not made). */
#define BLOCK(T, L, NV, NC, TRI)                                                                   \
    do {                                                                                           \
        T acc[NV][NC];                                                                             \
        UNROLL for (int c = 0; c < NC; c++) UNROLL for (int v = 0; v < NV; v++) acc[v][c] =       \
            add ? *(const T *)(Y + i0 + v * L + (size_t)(j0 + c) * ldy) : (T){0};                  \
        int kfull = TRI ? j0 : k;                                                                  \
        for (int r = 0; r < kfull; r++) {                                                          \
            T a[NV];                                                                               \
            UNROLL for (int v = 0; v < NV; v++) a[v] = *(const T *)(A + i0 + v * L + (size_t)r * lda); \
            UNROLL for (int c = 0; c < NC; c++)                                                    \
            {                                                                                      \
                double x = X[r + (size_t)(j0 + c) * ldx];                                          \
                UNROLL for (int v = 0; v < NV; v++) acc[v][c] += a[v] * x;                         \
            }                                                                                      \
        }                                                                                          \
        if (TRI)                                                                                   \
            UNROLL for (int t = 0; t < NC; t++)                                                    \
            {                                                                                      \
                int r = j0 + t;                                                                    \
                T a[NV];                                                                           \
                UNROLL for (int v = 0; v < NV; v++) a[v] = *(const T *)(A + i0 + v * L + (size_t)r * lda); \
                UNROLL for (int c = t; c < NC; c++)                                                \
                {                                                                                  \
                    double x = X[r + (size_t)(j0 + c) * ldx];                                      \
                    UNROLL for (int v = 0; v < NV; v++) acc[v][c] += a[v] * x;                     \
                }                                                                                  \
            }                                                                                      \
        UNROLL for (int c = 0; c < NC; c++) UNROLL for (int v = 0; v < NV; v++)                   \
            *(T *)(Y + i0 + v * L + (size_t)(j0 + c) * ldy) = acc[v][c];                           \
    } while (0)

/* Columns j0 upward in groups of NC, then of four, three, two or one
 * (rows i0 .. i0 + NV L - 1), from the block's first row's diagonal
 * when upper. */
#define COLUMNS_UP(T, L, NV, NC)                                                                   \
    do {                                                                                           \
        int j0 = upper ? i0 : 0;                                                                   \
        for (; j0 + NC <= n; j0 += NC)                                                             \
            BLOCK(T, L, NV, NC, 0);                                                                \
        if (NC > 4 && j0 + 4 <= n) {                                                               \
            BLOCK(T, L, NV, 4, 0);                                                                 \
            j0 += 4;                                                                               \
        }                                                                                          \
        switch (n - j0) {                                                                          \
        case 3: BLOCK(T, L, NV, 3, 0); break;                                                      \
        case 2: BLOCK(T, L, NV, 2, 0); break;                                                      \
        case 1: BLOCK(T, L, NV, 1, 0); break;                                                      \
        default: break;                                                                            \
        }                                                                                          \
    } while (0)

/* Y U's columns from the last down, in groups of four (the first group
 * the n % 4 at the top): a group reads only the columns up to its own,
 * which no group before it has overwritten. */
#define COLUMNS_DOWN(T, L, NV)                                                                     \
    do {                                                                                           \
        int j0 = n - n % 4;                                                                        \
        switch (n % 4) {                                                                           \
        case 3: BLOCK(T, L, NV, 3, 1); break;                                                      \
        case 2: BLOCK(T, L, NV, 2, 1); break;                                                      \
        case 1: BLOCK(T, L, NV, 1, 1); break;                                                      \
        default: break;                                                                            \
        }                                                                                          \
        for (j0 -= 4; j0 >= 0; j0 -= 4)                                                            \
            BLOCK(T, L, NV, 4, 1);                                                                 \
    } while (0)

/* Every row: blocks of two vectors by four columns, then of one vector
 * (and narrower, for the last rows) by eight: a narrow block's eight
 * columns are eight independent sums, enough to hide an addition's
 * latency (four left B's runs of six rows waiting on it). */
#define ROWS(COLUMNS_2, COLUMNS_1)                                                                 \
    do {                                                                                           \
        int i0 = 0;                                                                                \
        for (; i0 + 2 * VW <= m; i0 += 2 * VW)                                                     \
            COLUMNS_2(vec, VW, 2);                                                                 \
        if (i0 + VW <= m) {                                                                        \
            COLUMNS_1(vec, VW, 1);                                                                 \
            i0 += VW;                                                                              \
        }                                                                                          \
        ROWS_NARROW(COLUMNS_1);                                                                    \
        if (i0 < m)                                                                                \
            COLUMNS_1(vec1, 1, 1);                                                                 \
    } while (0)

#if VW == 8
#define ROWS_NARROW(COLUMNS_1)                                                                     \
    if (i0 + 4 <= m) {                                                                             \
        COLUMNS_1(vec4, 4, 1);                                                                     \
        i0 += 4;                                                                                   \
    }                                                                                              \
    if (i0 + 2 <= m) {                                                                             \
        COLUMNS_1(vec2, 2, 1);                                                                     \
        i0 += 2;                                                                                   \
    }
#elif VW == 4
#define ROWS_NARROW(COLUMNS_1)                                                                     \
    if (i0 + 2 <= m) {                                                                             \
        COLUMNS_1(vec2, 2, 1);                                                                     \
        i0 += 2;                                                                                   \
    }
#else
#define ROWS_NARROW(COLUMNS_1)
#endif

#define UP_BY_4(T, L, NV) COLUMNS_UP(T, L, NV, 4)
#define UP_BY_8(T, L, NV) COLUMNS_UP(T, L, NV, 8)

static void mult(int m, int n, int k, const double *A, int lda, const double *X, int ldx,
                 int add, double *Y, int ldy)
{
    assert(m >= 0 && n >= 0 && k >= 0 && lda >= m && ldy >= m && ldx >= k);
    int upper = 0;
    ROWS(UP_BY_4, UP_BY_8);
}

/* mult's entries i <= j (and some below the diagonal, in the blocks that
 * cross it) of a product known to be symmetric, or whose lower triangle
 * is not read. */
static void mult_upper(int m, int n, int k, const double *A, int lda, const double *X, int ldx,
                       double *Y, int ldy)
{
    assert(m >= 0 && n >= 0 && k >= 0 && lda >= m && ldy >= m && ldx >= k);
    int upper = 1, add = 0;
    ROWS(UP_BY_4, UP_BY_8);
}

/* Y = Y U in place, U n x n upper triangular: column j of the product
 * reads Y's columns up to j only (COLUMNS_DOWN); a block's columns are
 * read whole into registers before they are stored. */
static void mult_upper_in_place(int m, int n, double *Y, int ldy, const double *U, int ldu)
{
    assert(m >= 0 && n >= 0 && ldy >= m && ldu >= n);
    const double *A = Y, *X = U;
    int lda = ldy, ldx = ldu, add = 0, k = n, upper = 0;
    (void)upper;
    (void)k;
    ROWS(COLUMNS_DOWN, COLUMNS_DOWN);
}

/* Y[i + j ldy] = v[i] X[i + j ldx]: one product an entry. */
static void scale_rows(int m, int n, const double *v, const double *X, int ldx, double *Y,
                       int ldy)
{
    for (int j = 0; j < n; j++) {
        const double *restrict x = X + (size_t)j * ldx;
        double *restrict y = Y + (size_t)j * ldy;
#pragma omp simd
        for (int i = 0; i < m; i++)
            y[i] = v[i] * x[i];
    }
}

/* The filter's three-term step on n entries, each as written:
 * Yn = s (Yn - c Y) - Yp, s = 2 / c (the first step: s = 1 / c, no Yp). */
static void chebyshev_step(size_t n, double c, const double *Y, const double *Yp, double *Yn)
{
    const double *restrict y = Y, *restrict yp = Yp;
    double *restrict yn = Yn;
    if (Yp) {
        double s = 2 / c;
#pragma omp simd
        for (size_t a = 0; a < n; a++)
            yn[a] = s * (yn[a] - c * y[a]) - yp[a];
    } else {
        double s = 1 / c;
#pragma omp simd
        for (size_t a = 0; a < n; a++)
            yn[a] = s * (yn[a] - c * y[a]);
    }
}

/* a'b over n, in four partial sums (k mod 4, two pairs of lanes) added as
 * (s0 + s1) + (s2 + s3): the chain of additions a quarter as long, the
 * order fixed. */
INLINE double dot_in_order(int n, const double *a, const double *b)
{
    vec2 lo = {0, 0}, hi = {0, 0}; /* two doubles: a register on every path */
    int k = 0;
    for (; k + 4 <= n; k += 4) {
        lo += *(const vec2 *)(a + k) * *(const vec2 *)(b + k);
        hi += *(const vec2 *)(a + k + 2) * *(const vec2 *)(b + k + 2);
    }
    double s[4] = {lo[0], lo[1], hi[0], hi[1]};
    for (; k < n; k++)
        s[k & 3] += a[k] * b[k];
    return (s[0] + s[1]) + (s[2] + s[3]);
}

/* x[0:n] += t a[0:n], entry by entry (the path's vectors, then one at a
 * time). */
INLINE void axpy_in_order(int n, double t, const double *a, double *x)
{
    int i = 0;
    for (; i + VW <= n; i += VW)
        *(vec *)(x + i) += t * *(const vec *)(a + i);
    for (; i < n; i++)
        x[i] += t * a[i];
}

/* The Cholesky factor and its uses, at the orders of the reduced problem
 * (20-40) and the boundary (24): LAPACK's unblocked algorithms, which
 * dpotrf, dtrtri, dpotri and dpotrs run there too, through OpenBLAS's
 * level-2 and dtrsm calls. Counted on a chen2018 sweep (callgrind,
 * instructions a call): the factor at 20 12 600 (dpotrf 13 200: the
 * short dot products cost what OpenBLAS's calls did), the inverse 8 300
 * (dtrtri 19 600), S^-1 at 24 with its product 18 000 (dpotri 46 000),
 * a solve of 3 columns 6 100 (dpotrs 9 300). The same operations in a
 * fixed order on every path.
 *
 * G's upper triangle = U'U (dpotf2 'U': each entry from its column's dot
 * products, each pivot's reciprocal taken once, as dpotf2 scales by it:
 * a column's entries wait on a product, not a division). -1 when a pivot
 * is not positive (or NaN): G is not positive definite. */
static int cholesky_upper(int p, double *G, int ld)
{
    assert(p >= 0 && ld >= p);
    double rd[p > 0 ? p : 1]; /* 1 / u_ii */
    for (int j = 0; j < p; j++) {
        double *uj = G + (size_t)j * ld;
        for (int i = 0; i < j; i++)
            uj[i] = (uj[i] - dot_in_order(i, G + (size_t)i * ld, uj)) * rd[i];
        double d = uj[j] - dot_in_order(j, uj, uj);
        if (!(d > 0))
            return -1;
        uj[j] = sqrt(d);
        rd[j] = 1 / uj[j];
    }
    return 0;
}

/* U (upper) = U^-1 in place (dtrti2: column j is the inverted leading
 * block times U's column, then times -1 / u_jj). */
static void inverse_upper(int p, double *U, int ld)
{
    assert(p >= 0 && ld >= p);
    for (int j = 0; j < p; j++) {
        double *x = U + (size_t)j * ld;
        x[j] = 1 / x[j];
        for (int k = 0; k < j; k++) { /* x = U^-1(0:j, 0:j) x, column by column */
            const double *a = U + (size_t)k * ld;
            double t = x[k];
            axpy_in_order(k, t, a, x);
            x[k] = t * a[k];
        }
        double ajj = -x[j];
        for (int i = 0; i < j; i++)
            x[i] *= ajj;
    }
}

/* X = (U'U)^-1 X, ncol columns (ldx): U'y = x by dot products down U's
 * columns, then U x = y by columns from the last (dpotrs's two
 * triangular solves, each pivot's reciprocal taken once a call). */
static void cholesky_solve(int p, const double *U, int ld, double *X, int ldx, int ncol)
{
    assert(p >= 0 && ld >= p && ldx >= p);
    double rd[p > 0 ? p : 1];
    for (int i = 0; i < p; i++)
        rd[i] = 1 / U[i + (size_t)i * ld];
    for (int c = 0; c < ncol; c++) {
        double *x = X + (size_t)c * ldx;
        for (int i = 0; i < p; i++)
            x[i] = (x[i] - dot_in_order(i, U + (size_t)i * ld, x)) * rd[i];
        for (int k = p - 1; k >= 0; k--) {
            x[k] *= rd[k];
            axpy_in_order(k, -x[k], U + (size_t)k * ld, x);
        }
    }
}

/* x[0:n] = x - v a - w b (entry by entry: the path's vectors, then one at
 * a time; each entry's two products subtracted in that order). */
INLINE void rank2_in_order(int n, const double *v, double a, const double *w, double b, double *x)
{
    int i = 0;
    for (; i + VW <= n; i += VW)
        *(vec *)(x + i) = *(vec *)(x + i) - *(const vec *)(v + i) * a - *(const vec *)(w + i) * b;
    for (; i < n; i++)
        x[i] = x[i] - v[i] * a - w[i] * b;
}

/* The symmetric A (n x n, lda; its upper triangle read) = Q T Q', T
 * tridiagonal (diagonal d, subdiagonal e, n - 1) and Q orthogonal (n x n,
 * ldq), as dsyev ('U') gives them to dsteqr: LAPACK's dsytd2 (Householder
 * reflectors H_i = I - tau v v', each applied to the trailing block from
 * both sides by a product and a rank-2 update) and dorg2r's backward
 * accumulation of Q = H_0 ... H_(n-2), which dsytrd and dorgtr run below
 * their block size (32) — through OpenBLAS's level-2 calls there (dsymv,
 * dsyr2, dlarf's dgemv and dger: 91 000 and 46 000 instructions at n =
 * 20, 40 % of dsyev's; here 60 000 for both). 'U' reduces from the last
 * column: here the lower form's reduction of P A P (P reversing the
 * order), reversed back. That order matters: the QL iteration
 * (tridiagonal_eigen, dsteqr's algorithm) then chases the same
 * tridiagonal as dsyev's (from the first column instead, dsteqr's sweeps
 * took 18 % more instructions on the projected problems). The same
 * operations in a fixed order on every path. A's lower triangle holds the
 * reflectors afterwards. No scaling: the reduced problem's standard
 * forms are far from under- and overflow. */
static void tridiagonalise(int n, double *A, int lda, double *d, double *e, double *Q, int ldq)
{
    assert(n >= 1 && lda >= n && ldq >= n);
    double tau[n], w[n];
    /* B = P A P (P reverses the order) into A's lower triangle, from A's
     * upper: B's reduction from the first column is A's from the last */
    for (int c = 0; c < n; c++)
        w[c] = A[(n - 1 - c) + (size_t)(n - 1 - c) * lda];
    for (int c = 0; c < n; c++) {
        A[c + (size_t)c * lda] = w[c];
        for (int r = c + 1; r < n; r++)
            A[r + (size_t)c * lda] = A[(n - 1 - r) + (size_t)(n - 1 - c) * lda];
    }
    for (int i = 0; i + 1 < n; i++) {
        int m = n - i - 1;
        double *x = A + (i + 1) + (size_t)i * lda, alpha = x[0];
        double xnorm2 = dot_in_order(m - 1, x + 1, x + 1);
        tau[i] = 0;
        e[i] = alpha;
        if (xnorm2 > 0) { /* dlarfg: H (alpha, x) = (beta, 0) */
            double beta = -copysign(sqrt(alpha * alpha + xnorm2), alpha);
            tau[i] = (beta - alpha) / beta;
            double scale = 1 / (alpha - beta);
            for (int k = 1; k < m; k++)
                x[k] *= scale;
            e[i] = beta;
            x[0] = 1; /* x is v now */
            double *A22 = A + (i + 1) + (size_t)(i + 1) * lda;
            /* w = tau A22 v (A22's lower triangle, by columns) */
            for (int k = 0; k < m; k++)
                w[k] = 0;
            for (int c = 0; c < m; c++) {
                const double *a = A22 + (size_t)c * lda;
                w[c] += a[c] * x[c] + dot_in_order(m - c - 1, a + c + 1, x + c + 1);
                axpy_in_order(m - c - 1, x[c], a + c + 1, w + c + 1);
            }
            for (int k = 0; k < m; k++)
                w[k] *= tau[i];
            double half = -0.5 * tau[i] * dot_in_order(m, w, x);
            axpy_in_order(m, half, x, w);
            for (int c = 0; c < m; c++) /* A22 -= v w' + w v' (lower) */
                rank2_in_order(m - c, x + c, w[c], w + c, x[c], A22 + c + (size_t)c * lda);
            x[0] = e[i];
        }
        d[i] = A[i + (size_t)i * lda];
    }
    d[n - 1] = A[(n - 1) + (size_t)(n - 1) * lda];
    for (int c = 0; c < n; c++) /* Q = I, then H_i applied from the last */
        for (int r = 0; r < n; r++)
            Q[r + (size_t)c * ldq] = r == c;
    for (int i = n - 2; i >= 0; i--) {
        if (tau[i] == 0)
            continue;
        int m = n - i - 1;
        double *v = A + (i + 1) + (size_t)i * lda, keep = v[0];
        v[0] = 1;
        for (int c = i + 1; c < n; c++) {
            double *q = Q + (i + 1) + (size_t)c * ldq;
            axpy_in_order(m, -tau[i] * dot_in_order(m, v, q), v, q);
        }
        v[0] = keep;
    }
    /* back to A's order: T's and Q's indices reversed */
    for (int k = 0; k < n / 2; k++) {
        double t = d[k];
        d[k] = d[n - 1 - k], d[n - 1 - k] = t;
    }
    for (int k = 0; k < (n - 1) / 2; k++) {
        double t = e[k];
        e[k] = e[n - 2 - k], e[n - 2 - k] = t;
    }
    for (int c = 0; c < n; c++)
        for (int r = 0; r < n; r++) {
            size_t a = r + (size_t)c * ldq, b = (n - 1 - r) + (size_t)(n - 1 - c) * ldq;
            if (a < b) {
                double t = Q[a];
                Q[a] = Q[b], Q[b] = t;
            }
        }
}

/* sqrt(a^2 + b^2), squared directly where no square can over- or
 * underflow (all the reduced problem's numbers), else scaled */
INLINE double pythag(double a, double b)
{
    double m = fmax(fabs(a), fabs(b));
    if (m > 1e-150 && m < 1e150)
        return sqrt(a * a + b * b);
    if (!(m > 0) || isinf(m))
        return m;
    a /= m, b /= m;
    return m * sqrt(a * a + b * b);
}

/* A plane rotation [c s; -s c] (f, g)' = (r, 0)': c >= 0, r with f's sign */
INLINE void rotation(double f, double g, double *c, double *s, double *r)
{
    if (g == 0) {
        *c = 1, *s = 0, *r = f;
    } else if (f == 0) {
        *c = 0, *s = copysign(1, g), *r = fabs(g);
    } else {
        double h = pythag(f, g);
        *c = fabs(f) / h, *r = copysign(h, f), *s = g / *r;
    }
}

/* Columns x, y (n entries) = (c x - s y, s x + c y): each entry as
 * written, the path's vectors then one at a time. */
INLINE void rotate_columns(int n, double c, double s, double *x, double *y)
{
    int i = 0;
    vec cv = (vec){0} + c, sv = (vec){0} + s;
    for (; i + VW <= n; i += VW) {
        vec a = *(vec *)(x + i), b = *(vec *)(y + i);
        *(vec *)(x + i) = cv * a - sv * b;
        *(vec *)(y + i) = sv * a + cv * b;
    }
    for (; i < n; i++) {
        double a = x[i], b = y[i];
        x[i] = c * a - s * b;
        y[i] = s * a + c * b;
    }
}

/* The eigenpairs of the symmetric 2 x 2 [a b; b c]: rt1 (the larger in
 * magnitude) with unit eigenvector (cs, sn), and rt2; rt2 from rt1 and
 * the determinant, where the sum would cancel (dlaev2's way). */
static void eigen2(double a, double b, double c, double *rt1, double *rt2, double *cs, double *sn)
{
    double sm = a + c, df = a - c, tb = 2 * b, rt = pythag(df, tb);
    double big = fabs(a) > fabs(c) ? a : c, small = fabs(a) > fabs(c) ? c : a;
    int sgn1 = sm < 0 ? -1 : 1, sgn2 = df >= 0 ? 1 : -1;
    if (sm != 0) {
        *rt1 = 0.5 * (sm + sgn1 * rt);
        *rt2 = (big / *rt1) * small - (b / *rt1) * b;
    } else {
        *rt1 = 0.5 * rt, *rt2 = -0.5 * rt;
    }
    double v = df + sgn2 * rt; /* the eigenvector (v, -tb) of rt1 up to scale */
    if (fabs(v) > fabs(tb)) {
        double ct = -tb / v;
        *sn = 1 / sqrt(1 + ct * ct), *cs = ct * *sn;
    } else if (tb == 0) {
        *cs = 1, *sn = 0;
    } else {
        double tn = -v / tb;
        *cs = 1 / sqrt(1 + tn * tn), *sn = tn * *cs;
    }
    if (sgn1 == sgn2) { /* the other root's vector came out: turn it */
        double t = *cs;
        *cs = -*sn, *sn = t;
    }
}

/* One unreduced block of tridiagonal_eigen by implicit QL with
 * Wilkinson's shift, walked in the direction dir from its first row l
 * (dir -1: QR on the block below l, as QL on the block read backwards).
 * Logical row k is row l + dir k; the coupling of logical rows k and
 * k + 1 is E(k); Z's column of logical row k is ZC(k). *iter counts the
 * sweeps (at most maxit: -1). */
static int ql_block(int len, int l, int dir, double *d, double *e, double *Z, int ldz, int nz,
                    int *iter, int maxit)
{
#define D(k) d[l + dir * (k)]
#define E(k) e[dir > 0 ? l + (k) : l - (k) - 1]
#define ZC(k) (Z + (size_t)(l + dir * (k)) * ldz)
    const double eps2 = 0.25 * DBL_EPSILON * DBL_EPSILON, safmin = DBL_MIN;
    for (int lo = 0; lo < len;) {
        int m = lo;
        for (; m + 1 < len; m++) { /* a negligible coupling splits the block */
            double t = E(m) * E(m);
            if (t <= eps2 * fabs(D(m)) * fabs(D(m + 1)) + safmin)
                break;
        }
        if (m + 1 < len)
            E(m) = 0;
        if (m == lo) { /* converged */
            lo++;
            continue;
        }
        if (m == lo + 1) { /* a 2 x 2 block: directly */
            double rt1, rt2, c, s;
            eigen2(D(lo), E(lo), D(lo + 1), &rt1, &rt2, &c, &s);
            /* rt1's vector c z0 + s z1 into z0, rt2's c z1 - s z0 into z1 */
            rotate_columns(nz, c, s, ZC(lo + 1), ZC(lo));
            D(lo) = rt1, D(lo + 1) = rt2;
            E(lo) = 0;
            lo += 2;
            continue;
        }
        if ((*iter)++ == maxit)
            return -1;
        double p = D(lo), g = (D(lo + 1) - p) / (2 * E(lo)), r = pythag(g, 1);
        g = D(m) - p + E(lo) / (g + copysign(r, g));
        double s = 1, c = 1;
        p = 0;
        for (int i = m - 1; i >= lo; i--) {
            double f = s * E(i), b = c * E(i);
            rotation(g, f, &c, &s, &r);
            if (i != m - 1)
                E(i + 1) = r;
            g = D(i + 1) - p;
            r = (D(i) - g) * s + 2 * c * b;
            p = s * r;
            D(i + 1) = g + p;
            g = c * r - b;
            rotate_columns(nz, c, s, ZC(i), ZC(i + 1)); /* (c zi - s zi1, s zi + c zi1) */
        }
        D(lo) -= p;
        E(lo) = g;
    }
    return 0;
#undef D
#undef E
#undef ZC
}

/* The symmetric tridiagonal T (diagonal d, subdiagonal e; n) = W Lambda
 * W': d becomes Lambda ascending, Z (nz rows, ldz) becomes Z W, e is
 * destroyed. What dsteqr ('V') computes, by its algorithm: the matrix
 * split where a coupling is negligible, each block by implicit QL or QR
 * with Wilkinson's shift (QR where the block's last diagonal is the
 * smaller), 2 x 2 blocks directly, a selection sort at the end. Own code
 * for its rotations of Z: dsteqr applies them through dlasr, scalar in
 * Debian's OpenBLAS 0.3.21 (with dlartg and dsteqr itself 6.6 % of a
 * chen2018 sweep's time, AVX2); here each is the path's vectors down two
 * columns, every entry as written (the same bits on every path). -1 after
 * 30 n sweeps without convergence, or for a block out of the range dsteqr
 * would rescale (never a reduced problem's). */
static int tridiagonal_eigen(int n, double *d, double *e, double *Z, int ldz, int nz)
{
    assert(n >= 0 && ldz >= nz);
    const double ssfmax = sqrt(1 / DBL_MIN) / 3;
    const double ssfmin = sqrt(DBL_MIN) / (0.25 * DBL_EPSILON * DBL_EPSILON);
    const double eps = 0.5 * DBL_EPSILON;
    int iter = 0, maxit = 30 * n;
    for (int l = 0; l < n;) {
        if (l > 0)
            e[l - 1] = 0;
        int m = l;
        for (; m + 1 < n; m++) {
            double t = fabs(e[m]);
            if (t == 0)
                break;
            if (t <= sqrt(fabs(d[m])) * sqrt(fabs(d[m + 1])) * eps) {
                e[m] = 0;
                break;
            }
        }
        int len = m - l + 1, first = l;
        l = m + 1;
        if (len == 1)
            continue;
        double anorm = 0;
        for (int i = first; i <= m; i++) {
            double ei = i < m ? e[i] : 0;
            if (!isfinite(d[i]) || !isfinite(ei))
                return -1;
            anorm = fmax(anorm, fmax(fabs(d[i]), fabs(ei)));
        }
        if (anorm == 0)
            continue;
        if (!(anorm >= ssfmin && anorm <= ssfmax))
            return -1;
        int rev = fabs(d[m]) < fabs(d[first]);
        if (ql_block(len, rev ? m : first, rev ? -1 : 1, d, e, Z, ldz, nz, &iter, maxit))
            return -1;
    }
    for (int i = 0; i + 1 < n; i++) { /* ascending: selection sort, columns swapped */
        int k = i;
        for (int j = i + 1; j < n; j++)
            if (d[j] < d[k])
                k = j;
        if (k != i) {
            double t = d[k];
            d[k] = d[i], d[i] = t;
            double *a = Z + (size_t)i * ldz, *b = Z + (size_t)k * ldz;
            for (int r = 0; r < nz; r++) {
                double u = a[r];
                a[r] = b[r], b[r] = u;
            }
        }
    }
    return 0;
}

/* The largest |x_i| over n entries and its index (the first of equals,
 * as idamax; a NaN is passed over here and stops the factor at a later
 * pivot, which it reaches through the updates). */
INLINE double abs_max(int n, const double *x, int *at)
{
    double m = 0;
    *at = 0;
    for (int i = 0; i < n; i++)
        if (fabs(x[i]) > m)
            m = fabs(x[i]), *at = i;
    return m;
}

/* The largest |A(r, j)| for k <= j < r (row r of the lower triangle left
 * of the diagonal, lda apart). */
INLINE double abs_max_row(int k, int r, const double *A, int lda)
{
    double m = 0;
    for (int j = k; j < r; j++)
        m = fmax(m, fabs(A[r + (size_t)j * lda]));
    return m;
}

/* Rows and columns a < b of the trailing symmetric matrix from column k
 * (lower triangle, ld; order n) swapped, as dsytf2 ('L') swaps them. */
static void swap_symmetric(int n, double *A, int ld, int k, int a, int b)
{
#define AT(i, j) A[(i) + (size_t)(j) * ld]
    for (int i = b + 1; i < n; i++) {
        double t = AT(i, a);
        AT(i, a) = AT(i, b), AT(i, b) = t;
    }
    for (int j = a + 1; j < b; j++) {
        double t = AT(j, a);
        AT(j, a) = AT(b, j), AT(b, j) = t;
    }
    double t = AT(a, a);
    AT(a, a) = AT(b, b), AT(b, b) = t;
    if (a > k) { /* a 2 x 2 pivot's off-diagonal entry */
        t = AT(a, k);
        AT(a, k) = AT(b, k), AT(b, k) = t;
    }
#undef AT
}

/* The number of negative eigenvalues of the symmetric A (n x n, lda; its
 * lower triangle read and destroyed) by Sylvester's law of inertia from
 * its Bunch-Kaufman factor P A P' = L D L': LAPACK's dsytf2 ('L'; the
 * pivot choice with alpha = (1 + sqrt 17) / 8, 1 x 1 and 2 x 2 blocks),
 * without L's multipliers, which a count does not read. -1 where a pivot
 * column is zero (A singular) or a pivot NaN (an entry was). The Sturm counts
 * run it twice a pose at order 24, where OpenBLAS's dsytrf made a level-2
 * call a column (28 000 instructions a call, 2 % of a chen2018 sweep's). */
static int negatives(int n, double *A, int lda)
{
    assert(n >= 0 && lda >= n);
    const double alpha = (1 + sqrt(17.0)) / 8;
    double w[2][n > 0 ? n : 1];
    int neg = 0;
#define AT(i, j) A[(i) + (size_t)(j) * lda]
    for (int k = 0; k < n;) {
        int imax = k, step = 1, kp = k, at;
        double absakk = fabs(AT(k, k)), colmax = 0;
        if (k + 1 < n) {
            colmax = abs_max(n - k - 1, &AT(k + 1, k), &at);
            imax = k + 1 + at;
        }
        if (!(fmax(absakk, colmax) > 0) || isnan(absakk))
            return -1;
        if (absakk < alpha * colmax) {
            /* the largest off-diagonal in row and column imax */
            double rowmax = abs_max_row(k, imax, A, lda);
            if (imax + 1 < n)
                rowmax = fmax(rowmax, abs_max(n - imax - 1, &AT(imax + 1, imax), &at));
            if (absakk >= alpha * colmax * (colmax / rowmax))
                kp = k;
            else if (fabs(AT(imax, imax)) >= alpha * rowmax)
                kp = imax;
            else
                kp = imax, step = 2;
        }
        int kk = k + step - 1;
        if (kp != kk)
            swap_symmetric(n, A, lda, k, kk, kp);
        int m = n - k - step; /* the trailing block's order */
        double *x = &AT(k + step, k);
        if (step == 1) { /* A22 -= x x' / d */
            double d = AT(k, k), rd = 1 / d;
            if (isnan(d))
                return -1;
            neg += d < 0;
            for (int j = 0; j < m; j++)
                axpy_in_order(m - j, -(rd * x[j]), x + j, &AT(k + 1 + j, k + 1 + j));
        } else { /* A22 -= [x y] D^-1 [x y]' (dsytf2's form of it) */
            double a = AT(k, k), b = AT(k + 1, k), c = AT(k + 1, k + 1), det = a * c - b * b;
            if (isnan(det) || isnan(a + c))
                return -1;
            /* (the pivot rule makes det < 0: a 2 x 2 pivot is indefinite) */
            neg += det < 0 ? 1 : (a + c < 0 ? 2 : 0);
            double *y = &AT(k + 2, k + 1), d11 = c / b, d22 = a / b, t = 1 / (d11 * d22 - 1);
            double d21 = t / b;
            for (int j = 0; j < m; j++) {
                w[0][j] = d21 * (d11 * x[j] - y[j]);
                w[1][j] = d21 * (d22 * y[j] - x[j]);
            }
            for (int j = 0; j < m; j++)
                rank2_in_order(m - j, x + j, w[0][j], y + j, w[1][j], &AT(k + 2 + j, k + 2 + j));
        }
        k += step;
    }
#undef AT
    return neg;
}

const dm_boundary_kernels DM_ISA_TABLE(dm_boundary_kernels_) = {
    .cholesky_upper = cholesky_upper,
    .inverse_upper = inverse_upper,
    .cholesky_solve = cholesky_solve,
    .tridiagonalise = tridiagonalise,
    .tridiagonal_eigen = tridiagonal_eigen,
    .negatives = negatives,
    .scale_rows = scale_rows,
    .chebyshev_step = chebyshev_step,
    .mult = mult,
    .mult_upper_in_place = mult_upper_in_place,
    .mult_upper = mult_upper,
};
