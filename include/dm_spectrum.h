/* dm_spectrum — every mode of a pose, kept factored: the all-modes
 * reference of a trajectory (docs/model.md §4), whose steps need the modes
 * only on a few vectors (Phi' M x, Phi' F, Phi q).
 *
 * With M = L L' (the block-arrow Cholesky factor, dm_arrow_chol), the
 * standard form C = L^-1 K L^-T is reduced to a tridiagonal T = Q' C Q
 * (dsytrd) and T = Z Lambda Z' (divide and conquer, dstedc), so
 *
 *     Phi = L^-T Q Z,   Phi' M Phi = Z' Q' Q Z = I,   ascending.
 *
 * Phi itself is never formed: Q applied to the n columns of Z and n
 * back-substitutions were a third of a solve at 210 DOF (what dsyevd and
 * DM_EIGEN_ALL_ARROW do), while Phi' V or Phi Y for a few vectors cost
 * O(n^2) each: one solve with L, Q's reflectors and a product with Z. */
#ifndef DM_SPECTRUM_H
#define DM_SPECTRUM_H

#include "dm_error.h"
#include "dm_model.h"

/* Most vectors dm_spectrum_project and dm_spectrum_expand take at once. */
#define DM_SPECTRUM_QMAX 4

typedef struct dm_spectrum dm_spectrum;
/* A solve's scratch (about n^2 doubles): one per thread, shared by the
 * spectra it solves. */
typedef struct dm_spectrum_solver dm_spectrum_solver;

/* Room for every mode of models of `model`'s size and structure. */
dm_spectrum *dm_spectrum_alloc(const dm_model *model, dm_error *err);
void dm_spectrum_free(dm_spectrum *sp);
dm_spectrum_solver *dm_spectrum_solver_alloc(const dm_model *model, dm_error *err);
void dm_spectrum_solver_free(dm_spectrum_solver *sv);

/* Every mode of the model as it is built. DM_ENUMERIC when M is not
 * positive definite, the tridiagonal solve does not converge, or an
 * eigenvalue is not positive (a mechanism). The spectrum keeps a pointer
 * to the model's sparsity pattern (fixed at its first build): the model
 * must outlive the spectrum's use, as a model rebuilt at other poses
 * does. */
int dm_spectrum_solve(dm_spectrum *sp, const dm_model *model, dm_spectrum_solver *sv,
                      dm_error *err);

/* n, and the circular frequencies, ascending (n). */
int dm_spectrum_size(const dm_spectrum *sp);
const double *dm_spectrum_omega(const dm_spectrum *sp);

/* Y = Phi' V and X = Phi Y for q <= DM_SPECTRUM_QMAX vectors of length n
 * (column-major n x q; the input may be the output). A spectrum keeps the
 * scratch they use: one thread at a time. */
void dm_spectrum_project(dm_spectrum *sp, const double *V, int q, double *Y);
void dm_spectrum_expand(dm_spectrum *sp, const double *Y, int q, double *X);

#endif
