/* An extended-precision reference for the lowest eigenpairs of (K, M),
 * independent of deltamap's solvers: dsygvd's vectors, refined in long
 * double (64-bit mantissa on x86) by block inverse iteration with a long
 * double Cholesky factor of K and a Rayleigh-Ritz step in long double
 * after each application (cyclic Jacobi on the projected problem).
 * Each step reduces the error of mode j by lambda_j / lambda_{q+1}; with
 * q = k + 12 and three steps from dsygvd's vectors (off by ~1e-8) the
 * eigenvalues are good to far below 1e-14. Dense and O(n^3): for tests. */
#ifndef DM_REFERENCE_H
#define DM_REFERENCE_H

#include <float.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef long double ldbl;

/* In-place lower Cholesky of the n x n column-major A (long double). */
static inline int ref_cholesky(ldbl *A, int n)
{
    for (int j = 0; j < n; j++) {
        ldbl d = A[(size_t)j * n + j];
        for (int k = 0; k < j; k++)
            d -= A[(size_t)k * n + j] * A[(size_t)k * n + j];
        if (!(d > 0))
            return -1;
        d = sqrtl(d);
        A[(size_t)j * n + j] = d;
        for (int i = j + 1; i < n; i++) {
            ldbl s = A[(size_t)j * n + i];
            for (int k = 0; k < j; k++)
                s -= A[(size_t)k * n + i] * A[(size_t)k * n + j];
            A[(size_t)j * n + i] = s / d;
        }
    }
    return 0;
}

/* x = (L L')^-1 x */
static inline void ref_chol_solve(const ldbl *L, int n, ldbl *x)
{
    for (int i = 0; i < n; i++) {
        ldbl s = x[i];
        for (int k = 0; k < i; k++)
            s -= L[(size_t)k * n + i] * x[k];
        x[i] = s / L[(size_t)i * n + i];
    }
    for (int i = n - 1; i >= 0; i--) {
        ldbl s = x[i];
        for (int k = i + 1; k < n; k++)
            s -= L[(size_t)i * n + k] * x[k];
        x[i] = s / L[(size_t)i * n + i];
    }
}

/* Symmetric eigenproblem of the q x q column-major C by cyclic Jacobi:
 * eigenvalues in w, eigenvectors in the columns of Z. */
static inline void ref_jacobi(ldbl *C, int q, ldbl *w, ldbl *Z)
{
    for (int i = 0; i < q * q; i++)
        Z[i] = 0;
    for (int i = 0; i < q; i++)
        Z[i * q + i] = 1;
    for (int sweep = 0; sweep < 60; sweep++) {
        ldbl off = 0, diag = 0;
        for (int j = 0; j < q; j++)
            for (int i = 0; i < q; i++) {
                ldbl c2 = C[j * q + i] * C[j * q + i];
                if (i == j)
                    diag += c2;
                else
                    off += c2;
            }
        if (off <= 1e-38L * diag)
            break;
        for (int p = 0; p < q; p++)
            for (int r = p + 1; r < q; r++) {
                ldbl apr = C[r * q + p];
                if (apr == 0)
                    continue;
                ldbl theta = (C[r * q + r] - C[p * q + p]) / (2 * apr);
                ldbl t = (theta >= 0 ? 1 : -1) / (fabsl(theta) + sqrtl(theta * theta + 1));
                ldbl c = 1 / sqrtl(t * t + 1), s = t * c;
                for (int k = 0; k < q; k++) { /* columns p, r */
                    ldbl a = C[p * q + k], b = C[r * q + k];
                    C[p * q + k] = c * a - s * b;
                    C[r * q + k] = s * a + c * b;
                }
                for (int k = 0; k < q; k++) { /* rows p, r */
                    ldbl a = C[k * q + p], b = C[k * q + r];
                    C[k * q + p] = c * a - s * b;
                    C[k * q + r] = s * a + c * b;
                }
                for (int k = 0; k < q; k++) {
                    ldbl a = Z[p * q + k], b = Z[r * q + k];
                    Z[p * q + k] = c * a - s * b;
                    Z[r * q + k] = s * a + c * b;
                }
            }
    }
    for (int i = 0; i < q; i++)
        w[i] = C[i * q + i];
}

/* Rayleigh-Ritz of (K, M) on the q columns of X (n x q, long double):
 * X becomes M-orthonormal Ritz vectors, ascending values in w. */
static inline void ref_rayleigh_ritz(const double *K, const double *M, int n, ldbl *X, int q, ldbl *w)
{
    ldbl *KX = malloc(sizeof(ldbl) * n * q), *MX = malloc(sizeof(ldbl) * n * q);
    ldbl *Kt = malloc(sizeof(ldbl) * q * q), *Mt = malloc(sizeof(ldbl) * q * q);
    ldbl *C = malloc(sizeof(ldbl) * q * q), *Z = malloc(sizeof(ldbl) * q * q);
    ldbl *Q = malloc(sizeof(ldbl) * q * q), *Y = malloc(sizeof(ldbl) * n * q);
    for (int j = 0; j < q; j++)
        for (int i = 0; i < n; i++) {
            ldbl sk = 0, sm = 0;
            for (int l = 0; l < n; l++) {
                sk += (ldbl)K[(size_t)l * n + i] * X[(size_t)j * n + l];
                sm += (ldbl)M[(size_t)l * n + i] * X[(size_t)j * n + l];
            }
            KX[(size_t)j * n + i] = sk;
            MX[(size_t)j * n + i] = sm;
        }
    for (int a = 0; a < q; a++)
        for (int b = 0; b < q; b++) {
            ldbl sk = 0, sm = 0;
            for (int i = 0; i < n; i++) {
                sk += X[(size_t)a * n + i] * KX[(size_t)b * n + i];
                sm += X[(size_t)a * n + i] * MX[(size_t)b * n + i];
            }
            Kt[b * q + a] = sk;
            Mt[b * q + a] = sm;
        }
    for (int a = 0; a < q; a++) /* symmetric */
        for (int b = 0; b < a; b++) {
            Kt[b * q + a] = Kt[a * q + b] = (Kt[b * q + a] + Kt[a * q + b]) / 2;
            Mt[b * q + a] = Mt[a * q + b] = (Mt[b * q + a] + Mt[a * q + b]) / 2;
        }
    ref_cholesky(Mt, q); /* Mt = R R', C = R^-1 Kt R^-T */
    for (int j = 0; j < q; j++) /* C = R^-1 Kt (lower solve on columns) */
        for (int i = 0; i < q; i++) {
            ldbl s = Kt[j * q + i];
            for (int l = 0; l < i; l++)
                s -= Mt[l * q + i] * C[j * q + l];
            C[j * q + i] = s / Mt[i * q + i];
        }
    for (int i = 0; i < q; i++) /* C = C R^-T (solve on rows) */
        for (int j = 0; j < q; j++) {
            ldbl s = C[j * q + i];
            for (int l = 0; l < j; l++)
                s -= C[l * q + i] * Mt[l * q + j];
            C[j * q + i] = s / Mt[j * q + j];
        }
    ref_jacobi(C, q, w, Z);
    for (int j = 0; j < q; j++) /* Q = R^-T Z */
        for (int i = q - 1; i >= 0; i--) {
            ldbl s = Z[j * q + i];
            for (int l = i + 1; l < q; l++)
                s -= Mt[i * q + l] * Q[j * q + l];
            Q[j * q + i] = s / Mt[i * q + i];
        }
    for (int a = 0; a < q; a++) /* ascending */
        for (int b = a + 1; b < q; b++)
            if (w[b] < w[a]) {
                ldbl t = w[a];
                w[a] = w[b];
                w[b] = t;
                for (int i = 0; i < q; i++) {
                    t = Q[a * q + i];
                    Q[a * q + i] = Q[b * q + i];
                    Q[b * q + i] = t;
                }
            }
    for (int j = 0; j < q; j++)
        for (int i = 0; i < n; i++) {
            ldbl s = 0;
            for (int l = 0; l < q; l++)
                s += X[(size_t)l * n + i] * Q[j * q + l];
            Y[(size_t)j * n + i] = s;
        }
    memcpy(X, Y, sizeof(ldbl) * n * q);
    free(KX), free(MX), free(Kt), free(Mt), free(C), free(Z), free(Q), free(Y);
}

/* X = K^-1 B for nrhs columns (n x nrhs, column-major), solved in long
 * double; returns -1 if K is not positive definite. */
static inline int dm_reference_solve(const double *K, int n, const double *B, int nrhs, ldbl *X)
{
    ldbl *L = malloc(sizeof(ldbl) * n * n);
    for (size_t i = 0; i < (size_t)n * n; i++)
        L[i] = K[i];
    int rc = ref_cholesky(L, n);
    for (int j = 0; j < nrhs && rc == 0; j++) {
        for (int i = 0; i < n; i++)
            X[(size_t)j * n + i] = B[(size_t)j * n + i];
        ref_chol_solve(L, n, X + (size_t)j * n);
    }
    free(L);
    return rc;
}

/* The k lowest eigenvalues (lam, long double) and M-normalised vectors
 * (phi, n x k, double; may be NULL) of the dense pair (K, M). Returns 0,
 * or -1 if K is not positive definite. */
static inline int dm_reference_eigen(const double *K, const double *M, int n, int k, ldbl *lam,
                              double *phi)
{
    int q = k + 12 < n ? k + 12 : n;
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *w = malloc(sizeof(double) * n);
    ldbl *L = malloc(sizeof(ldbl) * n * n), *X = malloc(sizeof(ldbl) * n * q);
    ldbl *wq = malloc(sizeof(ldbl) * q), *v = malloc(sizeof(ldbl) * n);
    memcpy(A, K, sizeof(double) * n * n);
    memcpy(B, M, sizeof(double) * n * n);
    LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'V', 'U', n, A, n, B, n, w);
    for (size_t i = 0; i < (size_t)n * n; i++)
        L[i] = K[i];
    int rc = ref_cholesky(L, n);
    for (size_t i = 0; i < (size_t)n * q; i++)
        X[i] = A[i];
    for (int step = 0; rc == 0 && step < 3; step++) {
        for (int j = 0; j < q; j++) { /* X = K^-1 M X */
            for (int i = 0; i < n; i++) {
                ldbl s = 0;
                for (int l = 0; l < n; l++)
                    s += (ldbl)M[(size_t)l * n + i] * X[(size_t)j * n + l];
                v[i] = s;
            }
            ref_chol_solve(L, n, v);
            memcpy(X + (size_t)j * n, v, sizeof(ldbl) * n);
        }
        ref_rayleigh_ritz(K, M, n, X, q, wq);
    }
    for (int j = 0; j < k && rc == 0; j++) {
        lam[j] = wq[j];
        for (int i = 0; phi && i < n; i++)
            phi[(size_t)j * n + i] = (double)X[(size_t)j * n + i];
    }
    free(A), free(B), free(w), free(L), free(X), free(wq), free(v);
    return rc;
}

/* ---- LAPACK's own error bounds ------------------------------------------
 *
 * Where a test compares deltamap's results with LAPACK's (or LAPACK's with
 * the reference above), it allows what LAPACK guarantees for the matrices
 * at hand, never a value measured on one machine: the rounding of a dense
 * solve depends on the BLAS kernels of the CPU it runs on (OpenBLAS picks
 * them at run time), so a constant measured on one CPU fails on another.
 * The bounds are those of the LAPACK Users' Guide, 3rd ed. (LUG), evaluated
 * as its code fragments do: 1-norms (dlansy), LAPACK's condition estimates
 * (dtrcon, dpocon, dgecon), and its "modestly growing function" p(n) taken
 * as 1. They are bounds of the error's size, not estimates of it: under
 * the 14 OpenBLAS kernel sets this x86-64 machine runs (OPENBLAS_CORETYPE,
 * Prescott to SkylakeX) the errors stay below 1/10 of them. */

/* LUG §4.10 (generalized symmetric definite eigenproblem K z = lambda M z,
 * solved as dsygv/dsygvd/dsygvx do: a Cholesky factor of M, the reduction
 * to standard form, a symmetric eigensolver; every dense solver of the
 * project takes the same three steps):
 *   |lambda^_i - lambda_i| <~ p(n) eps (||M^-1|| ||K|| + kappa(M) |lambda^_i|)
 *                                                                  = EERRBD(i),
 *   angle(z^_i, z_i) <~ p(n) eps (||M^-1|| ||K|| kappa(M)^1/2 + kappa(M) |lambda^_i|)
 *                       / gap_i                                    = ZERRBD(i),
 * gap_i the distance from lambda_i to the rest of the spectrum (to the rest
 * outside its cluster, for the cluster's invariant subspace). §4.10.1: the
 * bounds hold with (K, M) replaced by (D K D, D M D), D diagonal, and
 * D = diag(M)^-1/2 tightens them "when the diagonal entries of M differ
 * widely in magnitude" -- here translational masses and rotational
 * inertias: kappa(M) ~ 1e6-1e7, kappa(D M D) ~ 1e2-1e3. */
typedef struct {
    double kappa; /* kappa_1(D M D) = 1 / rcond^2, rcond of its Cholesky factor */
    double ratio; /* ||D K D||_1 / ||D M D||_1 */
} dm_sygv_bound;

/* From the dense column-major K and M (n x n, both triangles). 0, or
 * LAPACK's info if D M D is not positive definite. */
static inline int dm_sygv_bound_init(const double *K, const double *M, int n, dm_sygv_bound *b)
{
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *d = malloc(sizeof(double) * n), rcond = 0;
    for (int i = 0; i < n; i++)
        d[i] = 1 / sqrt(M[(size_t)i * n + i]);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            A[(size_t)j * n + i] = d[i] * K[(size_t)j * n + i] * d[j];
            B[(size_t)j * n + i] = d[i] * M[(size_t)j * n + i] * d[j];
        }
    double an = LAPACKE_dlansy(LAPACK_COL_MAJOR, '1', 'U', n, A, n);
    double bn = LAPACKE_dlansy(LAPACK_COL_MAJOR, '1', 'U', n, B, n);
    int rc = LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', n, B, n);
    if (!rc)
        rc = LAPACKE_dtrcon(LAPACK_COL_MAJOR, '1', 'U', 'N', n, B, n, &rcond);
    rcond = fmax(rcond, DBL_EPSILON); /* as the LUG fragment: no overflow */
    b->kappa = 1 / (rcond * rcond);
    b->ratio = an / bn;
    free(A), free(B), free(d);
    return rc;
}

static inline double dm_sygv_eerrbd(const dm_sygv_bound *b, double lambda)
{
    return DBL_EPSILON * b->kappa * (b->ratio + fabs(lambda));
}

static inline double dm_sygv_zerrbd(const dm_sygv_bound *b, double lambda, double gap)
{
    return DBL_EPSILON * b->kappa * (b->ratio * sqrt(b->kappa) + fabs(lambda)) / gap;
}

/* LUG §4.4 (a linear system A x = b solved by dposv or dgesv, both
 * backward stable): ||x^ - x||_inf <~ p(n) eps kappa_inf(A) ||x^||_inf
 * (ERRBD = EPSMCH / RCOND). Neither factorization sees a diagonal scaling
 * S: Cholesky of S A S is S times that of A, and LU with partial pivoting
 * of A S picks the same pivots (each is chosen within a column), up to the
 * rounding of the scale (none for powers of 2). So the bound holds for
 * y = S^-1 x with the condition of the scaled matrix, the equilibration of
 * LUG §4.4.1 (xPOSVX, xGESVX), and for each component
 *   |x^_i - x_i| <~ eps kappa_inf(scaled A) s_i max_j |x^_j| / s_j.
 * symmetric: S A S, s_i = a_ii^-1/2 (Cholesky); else A S with
 * s_j = 1 / max_i |a_ij| (LU). */
typedef struct {
    int n;
    double errbd; /* eps kappa_inf of the scaled matrix */
    double *s;    /* the scale (n) */
} dm_solve_bound;

static inline int dm_solve_bound_init(const double *A, int n, int symmetric, dm_solve_bound *b)
{
    double *H = malloc(sizeof(double) * n * n), rcond = 0;
    lapack_int *piv = malloc(sizeof(lapack_int) * n);
    int rc;
    b->n = n;
    b->s = malloc(sizeof(double) * n);
    for (int j = 0; j < n; j++) {
        double c = 0;
        for (int i = 0; i < n; i++)
            c = fmax(c, fabs(A[(size_t)j * n + i]));
        b->s[j] = symmetric ? 1 / sqrt(A[(size_t)j * n + j]) : 1 / c;
    }
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++)
            H[(size_t)j * n + i] = (symmetric ? b->s[i] : 1.0) * A[(size_t)j * n + i] * b->s[j];
    double hn = LAPACKE_dlange(LAPACK_COL_MAJOR, 'I', n, n, H, n);
    if (symmetric) {
        rc = LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', n, H, n);
        if (!rc) /* ||H||_1 = ||H||_inf */
            rc = LAPACKE_dpocon(LAPACK_COL_MAJOR, 'U', n, H, n, hn, &rcond);
    } else {
        rc = LAPACKE_dgetrf(LAPACK_COL_MAJOR, n, n, H, n, piv);
        if (!rc)
            rc = LAPACKE_dgecon(LAPACK_COL_MAJOR, 'I', n, H, n, hn, &rcond);
    }
    b->errbd = DBL_EPSILON / fmax(rcond, DBL_EPSILON);
    free(H), free(piv);
    return rc;
}

/* The bound on component i of the computed solution x^ (n). */
static inline double dm_solve_bound_at(const dm_solve_bound *b, const double *x, int i)
{
    double y = 0;
    for (int j = 0; j < b->n; j++)
        y = fmax(y, fabs(x[j]) / b->s[j]);
    return b->errbd * b->s[i] * y;
}

static inline void dm_solve_bound_free(dm_solve_bound *b) { free(b->s); }

#endif
