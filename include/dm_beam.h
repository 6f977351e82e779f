/* dm_beam — the 2-node 3-D Euler–Bernoulli beam element (docs/model.md §2).
 *
 * Local DOF order per node: u, v, w (m), theta_x, theta_y, theta_z (rad);
 * node 1 then node 2 (12 DOF). Local x runs from node 1 to node 2; v and
 * theta_z bend in the x-y plane (EIz), w and theta_y in the x-z plane (EIy).
 * Matrices are 12x12, symmetric, stored column-major (== row-major). */
#ifndef DM_BEAM_H
#define DM_BEAM_H

#include "dm_robot.h"

/* Rigidities and inertias per unit length of one member. */
typedef struct dm_beam_props {
    double EA, EIy, EIz, GJ;   /* N, N*m^2, N*m^2, N*m^2 */
    double rhoA, rhoIp;        /* kg/m, kg*m */
    double A, Ip;              /* m^2, m^4 (for the geometric stiffness) */
} dm_beam_props;

void dm_beam_props_of(const dm_member *member, dm_beam_props *props);

/* Elastic stiffness: EA, EIy, EIz, GJ. */
void dm_beam_stiffness(const dm_beam_props *p, double L, double K[144]);

/* Consistent mass: linear axial, cubic Hermite transverse, torsional rho*Ip;
 * no bending rotary inertia. */
void dm_beam_mass(const dm_beam_props *p, double L, double M[144]);

/* Geometric (stress) stiffness for axial force N (N, tension > 0):
 * transverse 6/(5L), 1/10, 2L/15, -L/30 in both planes, torsion N*Ip/(A*L). */
void dm_beam_geometric(const dm_beam_props *p, double N, double L, double KG[144]);

/* Local frame: x along `axis`, y = part of `y_hint` orthogonal to x
 * (normalised), z = x cross y. Writes the rotation lambda (row-major 3x3,
 * rows = local axes in global coordinates: u_local = lambda * u_global). */
int dm_beam_frame(const double axis[3], const double y_hint[3], double lambda[9]);

#endif
