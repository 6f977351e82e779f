/* dm_coupling — Zheng & Zhang's coupling index (2017, eq. 33): the product
 * of the singular values of the stiffness matrix K of the combined model,
 * lambda_s = prod_k sigma_k(K).
 *
 * K is symmetric positive definite, so its singular values are its
 * eigenvalues and lambda_s = det K. For any real model that overflows a
 * double (mesh 4,4: about 10^1500), so deltamap reports log10 lambda_s =
 * ln det K / ln 10, with ln det K = 2 sum ln diag L from the Cholesky factor
 * K = L L' that the statics already make (no overflow, no extra solve).
 *
 * The number depends on the discretisation (more elements: more
 * eigenvalues in the product) and on the units of the DOFs (translations
 * in m and rotations in rad enter K with different scales): compare it only
 * at the same mesh and DOF set. Its change against the nominal robot (all
 * [effects] off) at the same commanded pose and mesh,
 *   change = log10 lambda_s(robot) - log10 lambda_s(nominal),
 * is what a user can compare across poses and designs (when the effects
 * add DOFs, e.g. joint springs, those DOFs' spring stiffnesses are part of
 * the change). */
#ifndef DM_COUPLING_H
#define DM_COUPLING_H

#include "dm_error.h"
#include "dm_robot.h"
#include "dm_static.h"

/* log10 lambda_s of the model whose K `factored` holds (dm_static_factor). */
double dm_coupling_index_log10(const dm_static *factored);

/* The same from ln det K however it was found (dm_boundary_statics). */
double dm_coupling_index_from_logdet(double logdet_K);

/* Workspace for the nominal robot's index (per thread; it owns a copy of
 * the robot with every effect off, its model and factor). */
typedef struct dm_coupling dm_coupling;

dm_coupling *dm_coupling_alloc(const dm_robot *robot, int na, int nb, dm_error *err);
void dm_coupling_free(dm_coupling *ws);

/* log10 lambda_s of the nominal robot (all effects off) at the commanded
 * platform position P (m). DM_EUNREACHABLE outside its workspace. */
int dm_coupling_nominal_log10(dm_coupling *ws, const double P[3], double *log10_index,
                              dm_error *err);

#endif
