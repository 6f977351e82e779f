/* dm_boundary's workspace, shared by its files (boundary.c: statics;
 * boundary_modes.c: the Wittrick-Williams count and the reduced modes). */
#ifndef DM_BOUNDARY_IMPL_H
#define DM_BOUNDARY_IMPL_H

#include <lapacke.h>

#include "dm_boundary.h"
#include "dm_isa.h"

struct dm_boundary {
    const dm_members *ms;
    dm_members_pose mp; /* the last solve's pose */
    int nB;
    double *S;      /* nB x nB: K's Schur complement S on the boundary, assembled in
                       the lower triangle; then its Cholesky factor U (upper, U'U = S,
                       by the path's kernels: boundary_kernels.c) */
    double *Sk;     /* nB x nB: S, both triangles */
    double *D;      /* nB x nB: the boundary's dynamic stiffness at a shift */
    double *F;      /* nB: condensed gravity load, then x_B */
    double *X6;     /* nB x 6: S^-1 on the platform's unit loads */
    /* each member's coupling at the pose on the boundary columns it
     * reaches (C's non-zero columns: Cc nb x nc, cols), and M_BB
     * (dm_boundary_mass), made once a pose */
    double Cc[DM_MEMBERS_N][9 * 12];
    double Cct[DM_MEMBERS_N][12 * 9]; /* Cc' (nc x nb), for the congruences' products */
    int cols[DM_MEMBERS_N][12], nc[DM_MEMBERS_N];
    double *Mbb;
    int have_mbb;
    double *z;      /* n: (boundary, interiors) */
    double gl[DM_MEMBERS_N][3]; /* gravity in each member's frame */
    int nred;       /* reduced DOFs: boundary + each member's kept modes and residual vectors */
    double *Kr, *Mr, *wr; /* the reduced problem, then its eigenvectors (Kr) and values */
    double *work;         /* dsygvd's workspace */
    double *wcount;       /* a count's 1 / (lambda_j - sigma) for the largest member
                             interior (ni), then room for diag(w) Gam and Gam' (ni x nb,
                             nb <= 9, each) */
    double *shW, *shZt, *shZ; /* the shapes' scratch: a member's coefficients
                               * (ncoef x nred), its interior transposed
                               * (nred x ni), the modes in (boundary, interiors) (n x nred) */
    double *shM;    /* M times the shapes in (boundary, interiors) (n x nred), then a
                       member's [C x_B; x_i] and its M times them (nm x nred each) */
    int lwork, liwork;
    lapack_int *iwork;    /* dsygvd's integer workspace (liwork) */
};

/* The boundary's mass through the clamped members, M_b + sum C' Mhat C,
 * into T (leading dimension ld); made once a pose. */
void dm_boundary_mass(dm_boundary *bw, double *T, int ld);

/* V (nc x nc, leading dimension nc) = Cc' X Cc for member m at the pose,
 * X nb x nb: through the path's kernels, each entry's sums in order
 * (the same bits as the loops over r before them). */
void dm_boundary_congruence(const dm_boundary *bw, int m, const double *X, double *V);

/* Member m's boundary displacements x_b = C y from the boundary vector y
 * (nB). */
void dm_boundary_member_dofs(dm_boundary *bw, int m, const double *y, double *xb);

/* Its transpose: F (nB) += C' f for member m's boundary forces f (nb),
 * each entry's sum over f first. */
void dm_boundary_member_add_forces(const dm_boundary *bw, int m, const double *f, double *F);

/* Negative eigenvalues of the symmetric n x n D (lower triangle,
 * destroyed; n <= nB) by Sylvester's inertia; -1 if singular. */
int dm_boundary_negatives(double *D, int n);

/* The reduced solve's dense products (boundary_kernels.c), built once
 * per instruction-set path; every path gives the same bits. Column-major
 * operands, read where they lie (nothing packed, nothing allocated). */
typedef struct dm_boundary_kernels {
    /* Y = (add ? Y : 0) + A X: Y m x n, A m x k, X k x n; each entry's
     * products added in r order. Y overlaps neither A nor X. */
    void (*mult)(int m, int n, int k, const double *A, int lda, const double *X, int ldx,
                 int add, double *Y, int ldy);
    /* Y = Y U in place: Y m x n, U n x n upper triangular (what lies below
     * its diagonal is not read). */
    void (*mult_upper_in_place)(int m, int n, double *Y, int ldy, const double *U, int ldu);
    /* mult's entries i <= j with add 0 (m = n; some entries below the
     * diagonal are written too): the upper triangle of a product known
     * to be symmetric, or whose lower one is not read. */
    void (*mult_upper)(int m, int n, int k, const double *A, int lda, const double *X, int ldx,
                       double *Y, int ldy);
    /* Y[i + j ldy] = v[i] X[i + j ldx] (m x n; Y apart from X) */
    void (*scale_rows)(int m, int n, const double *v, const double *X, int ldx, double *Y,
                       int ldy);
    /* G's upper triangle (p x p, ld; symmetric positive definite) becomes
     * U, U'U = G, U upper triangular (below the diagonal is neither read
     * nor written). -1 when G is not positive definite. */
    int (*cholesky_upper)(int p, double *G, int ld);
    /* U (upper triangular, ld) = U^-1 in place; below the diagonal is
     * neither read nor written */
    void (*inverse_upper)(int p, double *U, int ld);
    /* X = (U'U)^-1 X for U from cholesky_upper, ncol columns (ldx) */
    void (*cholesky_solve)(int p, const double *U, int ld, double *X, int ldx, int ncol);
    /* A (n x n, lda; symmetric, its upper triangle read) = Q T Q': T's
     * diagonal d (n) and subdiagonal e (n - 1), Q (n x n, ldq) orthogonal,
     * as dsytrd and dorgtr give them to dsteqr; A's lower triangle is
     * overwritten */
    void (*tridiagonalise)(int n, double *A, int lda, double *d, double *e, double *Q, int ldq);
    /* The tridiagonal (d, e) of order n = W Lambda W': d becomes Lambda
     * ascending, Z (nz rows, ldz; n columns) Z W, e is destroyed; dsteqr's
     * algorithm ('V'). -1 when it does not converge (or for NaN). */
    int (*tridiagonal_eigen)(int n, double *d, double *e, double *Z, int ldz, int nz);
    /* The negative eigenvalues of the symmetric A (n x n, lda; lower
     * triangle read and destroyed) by its Bunch-Kaufman factor (dsytf2's
     * pivoting); -1 when a pivot column vanishes (singular) or is NaN. */
    int (*negatives)(int n, double *A, int lda);
    /* Yn = 2/c (Yn - c Y) - Yp over n entries; with Yp NULL, 1/c (Yn - c Y) */
    void (*chebyshev_step)(size_t n, double c, const double *Y, const double *Yp, double *Yn);
} dm_boundary_kernels;

DM_ISA_DECLARE(dm_boundary_kernels, dm_boundary_kernels_);

/* The table of a path this build and CPU have. */
const dm_boundary_kernels *dm_boundary_kernels_of(dm_isa isa);

/* The table of the process's path (chosen once: dm_isa_active). */
static inline const dm_boundary_kernels *boundary_kernels(void)
{
    return dm_boundary_kernels_of(dm_isa_active());
}

#endif
