/* dm_loads — load vectors of the frozen model (docs/model.md §3), in the
 * reduced DOFs of a dm_model (N and N*m).
 *
 * Gravity is built with the model (dm_model.F_gravity). This module adds
 * the inertial loads of the nominal rigid motion, G_e = -M_e * a_e, with
 * a_e the element's rigid-body nodal accelerations (translational and
 * angular) from the arm rates, and -mp*aP at the platform (which does not
 * rotate), plus an optional external wrench at P. */
#ifndef DM_LOADS_H
#define DM_LOADS_H

#include "dm_model.h"

/* Nominal rigid motion of the mechanism at one instant. */
typedef struct dm_rigid_motion {
    double alpha_dot[3];   /* arm rates, rad/s (0 for a start from rest) */
    double alpha_ddot[3];  /* arm accelerations, rad/s^2 */
    double aP[3];          /* platform acceleration, m/s^2 */
} dm_rigid_motion;

/* F += inertial load of `motion` on the frozen geometry of `model`.
 * Velocity (centripetal) terms enter through alpha_dot. */
void dm_loads_add_inertial(const dm_model *model, const dm_rigid_motion *motion, double *F);

/* The same for q motions (1..8) at once: F holds q columns of length n,
 * F[:, l] += inertial load of motion[l] (one pass over the elements). */
void dm_loads_add_inertial_many(const dm_model *model, const dm_rigid_motion *motion, int q,
                                double *F);

/* F += external force (N) and torque (N*m) at the platform centre P. */
void dm_loads_add_platform_wrench(const dm_model *model, const double force[3],
                                  const double torque[3], double *F);

#endif
