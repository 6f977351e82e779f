/* dm_symeig.h — small symmetric eigenproblems by cyclic Jacobi: the
 * eigenpairs of the standard moves' Ritz problems, at most 4 x 4 a
 * direction (dm_integrate.h, the load-dependent Ritz vectors), and the
 * singular values of the pose's 3 x 3 Jacobian. LAPACK's dsyev
 * spends its time there in set-up (dlamch, the scaling checks, the
 * workspace): 9 200 instructions a 3 x 3 call, 2 % of a chen2018 sweep's
 * time; Jacobi's rotations need some 2 000 (docs/model-choices.md,
 * "Standard moves: the Ritz modes' small problems"). */
#ifndef DM_SYMEIG_H
#define DM_SYMEIG_H

/* A (n x n, column-major, lda; its upper triangle read, the whole matrix
 * overwritten) = V diag(w) V': w ascending, V (n x n, ldv) orthogonal,
 * its column j w[j]'s eigenvector. Cyclic Jacobi with Rutishauser's
 * updates, each off-diagonal entry rotated away until every one is below
 * half an ulp of the geometric mean of its diagonal pair (so the
 * eigenvalues carry an error of a few n eps |A|, eigenvectors a few n eps
 * over their gaps, as dsyev's). Returns 0, or -1 for a non-finite entry
 * or no convergence in 50 sweeps (quadratic convergence takes 4-6). */
int dm_symeig(int n, double *A, int lda, double *w, double *V, int ldv);

/* The singular values s (n, descending) of A (m x n, m >= n, lda;
 * overwritten): the square roots of A'A's eigenvalues, by the same
 * rotations applied to A's columns alone (one-sided Jacobi: A'A is never
 * formed, so a small singular value keeps its accuracy instead of
 * drowning in A'A's rounding), each column pair rotated until its
 * cosine is below m ulps (the singular values then within a few m eps of
 * their own size). What the pose's Jacobian condition number needs
 * (dm_kinematics.h): LAPACK's dgesvd took 14 000 instructions a 3 x 3
 * call (this 2 000), 1.5 % of a sweep's time. -1 for a non-finite entry or no
 * convergence in 50 sweeps. */
int dm_symeig_singular_values(int m, int n, double *A, int lda, double *s);

#endif
