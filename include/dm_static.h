/* dm_static — static responses of the frozen model (MODEL.md §5):
 * elastic error of the platform under a load (uP = SP K^-1 F, six
 * components: dx, dy, dz in m, ex, ey, ez in rad) and the 6x6 compliance at
 * P (CP = SP K^-1 SP', m/N, rad/(N*m) ...), its worst translational
 * direction and the stiffness there.
 *
 * Workspace per thread: factor K once per pose, then solve many loads. */
#ifndef DM_STATIC_H
#define DM_STATIC_H

#include "dm_assembly.h"
#include "dm_error.h"

typedef struct dm_static dm_static;

dm_static *dm_static_alloc(int n, dm_error *err);
void dm_static_free(dm_static *ws);

/* Cholesky factor of K; DM_ENUMERIC if K is not positive definite. */
int dm_static_factor(dm_static *ws, const double *K, dm_error *err);

/* Solve K X = F in place for nrhs column-major right-hand sides. */
int dm_static_solve(const dm_static *ws, double *F, int nrhs, dm_error *err);

/* Platform displacement (6) under load F (length n; not modified). */
int dm_static_platform_error(const dm_static *ws, const dm_model *model, const double *F,
                             double u6[6], dm_error *err);

/* 6x6 compliance at P (column-major, symmetric). */
int dm_static_compliance(const dm_static *ws, const dm_model *model, double C[36],
                         dm_error *err);

/* Largest eigenvalue of the translational 3x3 block of C (m/N) and its unit
 * direction (sign fixed so the largest component is positive). */
int dm_compliance_worst(const double C[36], double *max_m_per_n, double dir[3]);

#endif
