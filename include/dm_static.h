/* dm_static — static responses of the frozen model (docs/model.md §5):
 * elastic error of the platform under a load (uP = SP K^-1 F, six
 * components: dx, dy, dz in m, ex, ey, ez in rad) and the 6x6 compliance at
 * P (CP = SP K^-1 SP', m/N, rad/(N*m) ...), its worst translational
 * direction and the stiffness there.
 *
 * One factorization per pose: the block-arrow Cholesky of K (dm_arrow),
 * whose platform block is the Schur complement S of K onto the platform's
 * six DOFs, so CP = S^-1 needs no further solve. The same factor serves
 * the eigen solver (dm_modal), the quasi-static corrections and any
 * number of load cases. Workspace per thread. */
#ifndef DM_STATIC_H
#define DM_STATIC_H

#include "dm_arrow.h"
#include "dm_model.h"
#include "dm_error.h"

typedef struct dm_static dm_static;

/* Workspace for models of `model`'s layout (its robot, mesh, effects). */
dm_static *dm_static_alloc(const dm_model *model, dm_error *err);
void dm_static_free(dm_static *ws);

/* Cholesky factor of the model's K; DM_ENUMERIC if K is not positive
 * definite (a mechanism, a singular pose). */
int dm_static_factor(dm_static *ws, const dm_model *model, dm_error *err);

/* Solve K X = F in place for nrhs column-major right-hand sides (leading
 * dimension n). */
int dm_static_solve(const dm_static *ws, double *F, int nrhs, dm_error *err);

/* The factor itself (for solvers that use it). */
const dm_arrow_chol *dm_static_chol(const dm_static *ws);

/* Platform displacement (6) under load F (length n; not modified). */
int dm_static_platform_error(const dm_static *ws, const dm_model *model, const double *F,
                             double u6[6], dm_error *err);

/* 6x6 compliance at P (column-major, symmetric): S^-1. */
int dm_static_compliance(const dm_static *ws, const dm_model *model, double C[36],
                         dm_error *err);

/* ln det K from the factor (2 sum ln diag L). */
double dm_static_logdet(const dm_static *ws);

/* Largest eigenvalue of the translational 3x3 block of C (m/N) and its unit
 * direction (sign fixed so the largest component is positive). */
int dm_compliance_worst(const double C[36], double *max_m_per_n, double dir[3]);

#endif
