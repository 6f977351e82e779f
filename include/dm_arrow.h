/* dm_arrow — symmetric block-arrow matrices, the shape of the robot's M and
 * K (dm_model): three diagonal blocks, one per chain, banded inside, and
 * coupled to nothing but a small dense border (the platform's 6 DOFs):
 *
 *       [ A0          C0 ]
 *   A = [     A1      C1 ]      A_c: banded, half-bandwidth kd[c]
 *       [         A2  C2 ]      C_c: nb[c] x 6, dense
 *       [ C0' C1' C2' P  ]      P: 6 x 6
 *
 * Storage: A_c in LAPACK's lower band format (entry (i, j), 0 <= i-j <= kd,
 * at band[(i-j) + j (kd+1)]), C_c and P column-major. The unknowns are
 * numbered block 0, 1, 2, then the border, so a vector of length n is
 * used as it is: no permutation anywhere.
 *
 * What this gives (n = 210 at the default mesh, blocks of 68, kd 17):
 * products in O(n kd), a Cholesky factor with no fill outside the bands
 * and the border (dm_arrow_chol), whose border block is the Schur
 * complement S, so (A^-1)_PP = S^-1 needs no extra solve, and the inertia
 * of A - sigma B from one LDL' (Sylvester's law and Haynsworth's inertia
 * additivity: inertia(A) = sum inertia(A_c) + inertia(S)). */
#ifndef DM_ARROW_H
#define DM_ARROW_H

#include "dm_error.h"

#define DM_ARROW_BLOCKS 3
#define DM_ARROW_BORDER 6

typedef struct dm_arrow_layout {
    int n;                     /* sum of nb + DM_ARROW_BORDER */
    int nb[DM_ARROW_BLOCKS];   /* size of each diagonal block */
    int off[DM_ARROW_BLOCKS];  /* its first unknown */
    int kd[DM_ARROW_BLOCKS];   /* its half-bandwidth (0 <= kd < nb) */
    int border;                /* first border unknown (n - 6) */
} dm_arrow_layout;

/* Layout from block sizes and half-bandwidths (kd clipped to nb - 1). */
void dm_arrow_layout_make(dm_arrow_layout *lay, const int nb[DM_ARROW_BLOCKS],
                          const int kd[DM_ARROW_BLOCKS]);

/* The structural non-zeros of a family of matrices (M and K of one model):
 * recorded from the entries an assembly adds, whatever their values, so an
 * entry that is zero by accident at one pose (a symmetric one) is kept.
 * Products visit only these; a Cholesky factor's fill stays inside the
 * profile (each row from its first non-zero to the diagonal), so solves
 * visit column j from j to colend[j]. */
typedef struct dm_arrow_pattern {
    int *colptr[DM_ARROW_BLOCKS]; /* nb + 1: rows below the diagonal of column j */
    int *rows[DM_ARROW_BLOCKS];   /* at rows[colptr[j] .. colptr[j+1]) */
    int *colend[DM_ARROW_BLOCKS]; /* last row of the profile in column j */
    int *cpl[DM_ARROW_BLOCKS];    /* non-zeros of C_c: (row i, column m) as i + m nb */
    int ncpl[DM_ARROW_BLOCKS];
    int cpl_start[DM_ARROW_BLOCKS][DM_ARROW_BORDER + 1]; /* cpl's entries of border column m
                                                            from cpl_start[m] on */
} dm_arrow_pattern;

typedef struct dm_arrow {
    dm_arrow_layout lay;
    double *band[DM_ARROW_BLOCKS];
    double *cpl[DM_ARROW_BLOCKS];  /* C_c: (off + i, border + j) at cpl[c][i + j nb] */
    double pp[DM_ARROW_BORDER * DM_ARROW_BORDER]; /* P, both triangles */
    const dm_arrow_pattern *pattern; /* NULL: every entry of the bands */
    unsigned char *touched[DM_ARROW_BLOCKS], *touched_cpl[DM_ARROW_BLOCKS]; /* recording */
} dm_arrow;

int dm_arrow_init(dm_arrow *a, const dm_arrow_layout *lay, dm_error *err);
void dm_arrow_release(dm_arrow *a);
void dm_arrow_zero(dm_arrow *a);

/* Record which entries dm_arrow_add touches (until dm_arrow_pattern_make). */
int dm_arrow_record(dm_arrow *a, dm_error *err);

/* The pattern of the entries recorded in a and b (same layout); stops
 * their recording. Release with dm_arrow_pattern_release. */
int dm_arrow_pattern_make(dm_arrow_pattern *p, dm_arrow *a, dm_arrow *b, dm_error *err);
void dm_arrow_pattern_release(dm_arrow_pattern *p);

/* A(i, j) += v, called for every (i, j) of the full symmetric matrix (both
 * (i, j) and (j, i) of an off-diagonal pair): the call keeps the stored
 * half. An entry between two blocks, or outside a band, is a bug
 * (asserted). */
void dm_arrow_add(dm_arrow *a, int i, int j, double v);

/* Where an element's m x m contribution E goes (m <= DM_ARROW_PLAN_DOFS,
 * its DOFs idx): for each entry of the stored half, its index in E and
 * its place in any matrix of the layout. An assembly adds the same
 * elements at every pose, so it works its plans out once. */
#define DM_ARROW_PLAN_DOFS 16
typedef struct dm_arrow_plan {
    int count;
    short from[DM_ARROW_PLAN_DOFS * DM_ARROW_PLAN_DOFS];
    int to[DM_ARROW_PLAN_DOFS * DM_ARROW_PLAN_DOFS];
} dm_arrow_plan;

void dm_arrow_plan_make(const dm_arrow_layout *lay, const int *idx, int m, dm_arrow_plan *p);

/* A(idx[r], idx[c]) += E[c m + r] through a plan made for idx (entries
 * of the half that A does not store are not read). */
void dm_arrow_add_planned(dm_arrow *a, const dm_arrow_plan *p, const double *E);

/* A(i, j) of the full matrix (0 outside the pattern). */
double dm_arrow_get(const dm_arrow *a, int i, int j);

/* Blocks of q vectors are interleaved: the q values of unknown i are
 * X[i q .. i q + q - 1] (row-major n x q), so every matrix entry updates q
 * contiguous values; one vector (q = 1) is an ordinary array. */

/* Y = A X for an interleaved block of q vectors (X and Y must differ). */
void dm_arrow_mult(const dm_arrow *a, const double *X, int q, double *Y);

/* dst = a - sigma b (same layout). */
void dm_arrow_axpby(dm_arrow *dst, const dm_arrow *a, double sigma, const dm_arrow *b);

/* The full n x n matrix, column-major (the dense oracle). */
void dm_arrow_to_dense(const dm_arrow *a, double *D);

/* ---- Cholesky: A = L L', L = [L_c 0; W_c' L_S], S = P - sum W_c' W_c ---- */

typedef struct dm_arrow_chol {
    dm_arrow_layout lay;
    double *band[DM_ARROW_BLOCKS]; /* L_c, lower band */
    const dm_arrow_pattern *pattern; /* of the matrix factored (NULL: full bands) */
    double *W[DM_ARROW_BLOCKS];    /* L_c^-1 C_c, nb x 6 */
    int w_first[DM_ARROW_BLOCKS];  /* W_c's first non-zero row */
    double *Z[DM_ARROW_BLOCKS];    /* scratch: W_c with each row's 6 values together */
    double LS[DM_ARROW_BORDER * DM_ARROW_BORDER]; /* Cholesky factor of S (lower) */
    double S[DM_ARROW_BORDER * DM_ARROW_BORDER];  /* S itself (both triangles) */
} dm_arrow_chol;

int dm_arrow_chol_init(dm_arrow_chol *f, const dm_arrow_layout *lay, dm_error *err);
void dm_arrow_chol_release(dm_arrow_chol *f);

/* Factor a symmetric positive definite A; DM_ENUMERIC (with the block that
 * failed) when it is not. */
int dm_arrow_chol_factor(dm_arrow_chol *f, const dm_arrow *a, dm_error *err);

/* X = A^-1 X in place for an interleaved block of q vectors. */
void dm_arrow_chol_solve(const dm_arrow_chol *f, double *X, int q);

/* Its two halves: X = L^-1 X and X = L^-T X (a reduction to standard
 * form, L^-1 K L^-T, with the factor of M). */
void dm_arrow_chol_forward(const dm_arrow_chol *f, double *X, int q);
void dm_arrow_chol_backward(const dm_arrow_chol *f, double *X, int q);

/* C = L^-1 A L^-T (n x n, dense, both triangles: symmetric, so row- and
 * column-major alike), with f the factor of another matrix B = L L' of
 * the same layout: the generalized problem A x = lambda B x in standard
 * form. scratch: n x n. */
void dm_arrow_chol_reduce(const dm_arrow_chol *f, const dm_arrow *a, double *C, double *scratch);

/* (A^-1) restricted to the border: S^-1 (6 x 6, column-major, symmetric). */
int dm_arrow_chol_border_inverse(const dm_arrow_chol *f, double Sinv[36]);

/* ln det A = 2 sum ln diag(L). */
double dm_arrow_chol_logdet(const dm_arrow_chol *f);

/* ---- inertia --------------------------------------------------------- */

typedef struct dm_arrow_ldl {
    dm_arrow shifted;              /* A - sigma B */
    double *Z[DM_ARROW_BLOCKS];    /* L_c^-1 C_c, interleaved (nb x 6, row-major) */
} dm_arrow_ldl;

int dm_arrow_ldl_init(dm_arrow_ldl *w, const dm_arrow_layout *lay, dm_error *err);
void dm_arrow_ldl_release(dm_arrow_ldl *w);

/* Number of eigenvalues of the pencil (A, B), B positive definite, below
 * sigma: the negative eigenvalues of A - sigma B, counted from an LDL'
 * without pivoting of each block and the eigenvalues of the border's Schur
 * complement. DM_ENUMERIC when a pivot is so small against its column
 * that the count could be wrong (sigma sits on an eigenvalue of a block):
 * the caller moves sigma a little and asks again. */
int dm_arrow_count_below(dm_arrow_ldl *w, const dm_arrow *A, const dm_arrow *B, double sigma,
                         int *count);

#endif
