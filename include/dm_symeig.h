/* dm_symeig.h — the eigenpairs of a small symmetric matrix by cyclic
 * Jacobi: the standard moves' Ritz problems, at most 4 x 4 a direction
 * (dm_integrate.h, the load-dependent Ritz vectors). LAPACK's dsyev
 * spends its time there in set-up (dlamch, the scaling checks, the
 * workspace): 9 200 instructions a 3 x 3 call, 2 % of a chen2018 sweep's
 * time; Jacobi's rotations need some 600 (docs/model-choices.md,
 * "Standard moves: the Ritz modes' eigenproblems"). */
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

#endif
