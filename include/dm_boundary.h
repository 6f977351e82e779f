/* dm_boundary — the statics of a pose from the member bases (issue 39,
 * step 2; dm_members.h): per pose only the boundary problem is built and
 * factored, the members' clamped parts being the cache's.
 *
 * With the model's DOFs as (boundary x_B, member interiors) (dm_members),
 * K's Schur complement onto the boundary is
 *   S = K_b + sum_m C_m' Khat_m C_m,
 * C_m the member's rotation and rigid offsets at the pose, Khat_m its
 * condensed stiffness; the gravity load condenses the same way,
 *   F = F_b + sum_m C_m' Ghat_m (lambda_m g),
 * so a Cholesky factor of S (24 x 24 without compliant bases, up to 33)
 * gives exactly what the full factor gives: the platform's static error
 * (x_B at the platform), its compliance (S^-1's platform block: the
 * platform is part of the boundary, so no further condensation) and
 * ln det K = sum_m ln det K_ii,m + ln det S (Q is orthogonal). The whole
 * displacement follows member by member, u_i = Ui (lambda g) + Psi C x_B.
 *
 * A dm_boundary is one thread's workspace; the dm_members it reads may be
 * shared. It never allocates per pose. */
#ifndef DM_BOUNDARY_H
#define DM_BOUNDARY_H

#include "dm_error.h"
#include "dm_kinematics.h"
#include "dm_members.h"
#include "dm_model.h"
#include "dm_static.h"

typedef struct dm_boundary dm_boundary;

typedef struct dm_boundary_statics {
    double static_error[6]; /* platform displacement under gravity: dx, dy, dz (m), ex, ey, ez (rad) */
    double compliance[36];  /* 6 x 6 at the platform, column-major */
    double logdet_K;        /* ln det K of the whole model */
    int full;               /* 1: the full model served (the members could not) */
} dm_boundary_statics;

dm_boundary *dm_boundary_alloc(const dm_members *members, dm_error *err);
void dm_boundary_free(dm_boundary *bw);

/* The statics at a pose from the members. DM_EINVAL when the members
 * cannot serve the pose (dm_members_at), DM_ENUMERIC when S is not
 * positive definite (a singular pose). */
int dm_boundary_solve(dm_boundary *bw, const dm_pose *pose, dm_boundary_statics *res,
                      dm_error *err);

/* The last solve's whole static displacement in the model's DOFs (n). */
void dm_boundary_displacement(dm_boundary *bw, double *U);

/* The statics through the members when they serve the pose (bw non-NULL
 * and dm_boundary_solve succeeds), else through the full model (md built
 * at the pose, st factored): res->full says which served. */
int dm_boundary_statics_or_full(dm_boundary *bw, dm_model *md, dm_static *st,
                                const dm_pose *pose, dm_boundary_statics *res, dm_error *err);

#endif
