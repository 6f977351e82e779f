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
#include "dm_loads.h"
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

/* Wittrick-Williams: the number of the model's eigenvalues below sigma
 * (rad^2/s^2) at the last solve's pose, exactly: the members' own
 * fixed-interface eigenvalues below sigma plus the negative eigenvalues
 * of the boundary's dynamic stiffness
 *   D(sigma) = S - sigma M_BB - sigma^2 sum_m C' Gam' (Lambda - sigma)^-1 Gam C
 * (every fixed-interface mode, so D is the members' exact condensation).
 * DM_ENUMERIC when sigma is an eigenvalue of a member or of D. */
int dm_boundary_count(dm_boundary *bw, double sigma, int *count, dm_error *err);

/* The k lowest eigenvalues of the reduced problem on the member bases
 * (boundary DOFs, each member's kept fixed-interface modes and residual
 * vectors) at the last solve's pose. Upper bounds of the model's
 * (Rayleigh-Ritz on a subspace). */
int dm_boundary_reduced_modes(dm_boundary *bw, int k, double *lambda, dm_error *err);

/* The reduced problem's k lowest modes by a warm-started iteration
 * (src/solve/boundary_eig.c; docs/model-choices.md "Member bases"): in the
 * reduced coordinates K = diag(S, d) is block diagonal (d: the kept
 * fixed-interface eigenvalues and the residual vectors' stiffness, which
 * the bases make K_ii-orthogonal) and M = [M_BB, B'; B, I] couples only
 * through the boundary, so A = K^-1 M is S^-1 and a division after two
 * nv x nB products. Chebyshev-filtered subspace iteration: the block
 * (k + guard vectors) is multiplied by a Chebyshev polynomial in A that
 * stays within 1 on the unwanted part of the spectrum (up to the block's
 * top Ritz value) and grows on the wanted one, with a Cholesky QR when its
 * columns drift apart, then projected once (Rayleigh-Ritz). Warm from the
 * previous solve's Ritz vectors (the neighbour pose: the coordinates are
 * the members' own and the boundary's global ones, continuous in the
 * pose) with the degree the previous solves needed, cold from random
 * vectors (projected first, the degree chosen from their residuals).
 * Stopped when for every wanted Ritz value theta_j the quadratic residual
 * bound in the standard form mu = 1/lambda (Kato-Temple, for a cluster of
 * Ritz values its block form |mu_i - rho_i| <= ||R||^2 / delta),
 *   |lambda_j - theta_j| / theta_j <= e / (rho_j - e),
 *   e = sum_{i in cluster} r_i' K^-1 r_i / theta_i^3 / delta,
 * with delta the gap in mu from the cluster to the other Ritz values, is
 * below DM_BOUNDARY_EIG_TOL, judged on products made afresh. Then a
 * Wittrick-Williams count of the reduced problem at 1e-9 above the k-th
 * mode's cluster must equal the Ritz values below it (each is an upper
 * bound of its eigenvalue), else a mode was missed: the guard vectors are
 * replaced by random ones and the iteration resumed. The modes then
 * serve dm_boundary_mode_shapes like dm_boundary_reduced_modes'. */
#define DM_BOUNDARY_EIG_TOL 1e-12
typedef struct dm_boundary_eig dm_boundary_eig;

typedef struct dm_boundary_eig_info {
    int iterations;   /* Rayleigh-Ritz projections after the start's */
    int applications; /* of K^-1 M, in the filters */
    int restarts;   /* modes found missing by the count, and recovered */
    int cold;       /* 1: started from random vectors */
    int block;      /* the block's columns (wanted and guard) at the end */
} dm_boundary_eig_info;

/* A solver of k modes for bw's reduced problem (block of k + guard
 * vectors); one thread's, like bw. */
dm_boundary_eig *dm_boundary_eig_alloc(dm_boundary *bw, int k, dm_error *err);
void dm_boundary_eig_free(dm_boundary_eig *e);

/* The k lowest eigenvalues of the reduced problem at bw's last solve's
 * pose, and (estimate, may be NULL) each one's relative error bound as
 * above. DM_ENUMERIC when the iteration does not converge or a count
 * contradicts it (the caller uses dm_boundary_reduced_modes). */
int dm_boundary_eig_solve(dm_boundary_eig *e, dm_boundary *bw, double *lambda, double *estimate,
                          dm_boundary_eig_info *info, dm_error *err);

/* Start the next solve from these ncol reduced vectors (nred each,
 * column-major, the coordinates of dm_boundary_reduced_vectors), or cold
 * (ncol 0); more than k columns (up to k + 24) become the block. */
void dm_boundary_eig_start(dm_boundary_eig *e, const double *Y, int ncol);

/* Seeds, as dm_modal's: after a successful solve, save what the next warm
 * solve would start from (returns 0 when there is nothing: no solve yet,
 * or the last one failed); load one before a solve to start from it. A
 * solve from a seed gives the same bits whatever the solver did before
 * (a sweep starts each point from its anchor's seed, so results do not
 * depend on threads or tiles). seed_size bytes, fixed per solver. */
size_t dm_boundary_eig_seed_size(const dm_boundary_eig *e);
int dm_boundary_eig_seed_save(const dm_boundary_eig *e, void *seed);
void dm_boundary_eig_seed_load(dm_boundary_eig *e, const void *seed);

/* Poses come along a smooth path at equal steps (a trajectory's): each
 * warm solve starts from the wanted subspaces of the last three solves
 * extrapolated (quadratic in the step), as dm_modal_follow_path's, and
 * needs fewer applications; the results converge to the same bounds
 * either way. Calling it again (on or off) starts a new path: do so where
 * the steps stop being equal (a pause, a jump). */
void dm_boundary_eig_follow_path(dm_boundary_eig *e, int on);

/* Each wanted pair also converges to this relative residual,
 * ||x - theta K^-1 M x||_K / sqrt(theta) (0, the default: the eigenvalue
 * bound alone), unless round-off stalls it. The bound of 1e-12 leaves
 * the vectors within about 1e-6 rad; a residual of 1e-8 (dm_modal's own)
 * within 1e-8, so that results are as smooth in the robot's parameters
 * as the full model's (a fit's forward differences need 1e-10:
 * trajectories set it, dm_integrate.h). */
void dm_boundary_eig_residual_target(dm_boundary_eig *e, double residual);

/* Forget what the solves before taught (block, filter plan, guard
 * generator): the next solve is cold and its bits depend on the pose
 * alone, as after dm_boundary_eig_alloc. */
void dm_boundary_eig_forget(dm_boundary_eig *e);

/* The last successful solve's completeness count: its shift sigma (just
 * above the k-th mode's cluster), the reduced problem's eigenvalues below
 * it (count), and the whole model's there (whole, dm_boundary_count; -1
 * when sigma is singular for it), which the solve makes first: where it
 * equals the Ritz values below sigma it proves count equal too, and the
 * reduced problem is not counted. A whole count larger than count means
 * the member bases miss a mode there. */
void dm_boundary_eig_count_point(const dm_boundary_eig *e, double *sigma, int *count, int *whole);

/* The reduced problem's eigenvalues below sigma at the last solve's pose,
 * by the Wittrick-Williams count the solver certifies itself with
 * (interior coordinates below sigma plus the negative eigenvalues of the
 * boundary's dynamic stiffness); DM_ENUMERIC when sigma is an interior
 * coordinate's eigenvalue or the boundary matrix is singular there. */
int dm_boundary_eig_count(dm_boundary_eig *e, dm_boundary *bw, double sigma, int *count,
                          dm_error *err);

/* MY = M_red Y for any ncol reduced vectors (nred each, the coordinates
 * of dm_boundary_reduced_vectors) with the reduced mass at the last
 * solve's pose: M-products of the model's shapes in reduced coordinates
 * (phi_a' M phi_b = y_a' M_red y_b exactly, the reduction being a
 * projection). */
void dm_boundary_eig_mult_M(const dm_boundary_eig *e, const double *Y, int ncol, double *MY);

/* C (na x nb, leading dimension na) = A'B for na and nb reduced vectors
 * (nred each, leading dimension nred): their products through the
 * path's kernels, each entry's sum in order (the same bits on every
 * path; OpenBLAS's dgemm packed both operands at every call: mode
 * tracking's MACs). work: nred na doubles. */
void dm_boundary_eig_products(const dm_boundary_eig *e, const double *A, int na, const double *B,
                              int nb, double *C, double *work);

/* M_red times the last dm_boundary_eig_solve's Ritz vectors of the
 * wanted clusters (nred x at least k, leading dimension nred: the first k
 * columns M_red times dm_boundary_reduced_vectors' k), made with the
 * residuals of its last projection; valid until e's next solve. */
const double *dm_boundary_eig_mass_vectors(const dm_boundary_eig *e);

/* KY = K_red Y, and Y = K_red^-1 Y in place (any ncol), in the same
 * coordinates at bw's last solve's pose (K_red =
 * diag(S, the kept modes' eigenvalues, each member's R' K_ii R); the
 * solve through S's Cholesky factor): the standard moves' operators on
 * the reduced model (dm_standard_moves_reduced). */
void dm_boundary_eig_mult_K(const dm_boundary_eig *e, const dm_boundary *bw, const double *Y, int ncol,
                            double *KY);
void dm_boundary_eig_solve_K(const dm_boundary_eig *e, const dm_boundary *bw, double *Y, int ncol);

/* The last dm_boundary_reduced_modes' or dm_boundary_eig_solve's first k
 * reduced eigenvectors (nred x k, column-major, M-normalised); after
 * dm_boundary_eig_solve, k at most its block (dm_boundary_eig_info.block:
 * the Ritz vectors of all its columns). */
void dm_boundary_reduced_vectors(const dm_boundary *bw, int k, double *Y);

/* The last dm_boundary_reduced_modes' first k mode shapes in the model's
 * DOFs (phi: n x k, column-major), M-normalised (the reduced problem is
 * the model's projection on the member bases, so its normalisation
 * carries over). */
void dm_boundary_mode_shapes(dm_boundary *bw, int k, double *phi);

/* M phi (n x k) for the last dm_boundary_mode_shapes' first k shapes, M
 * the model's mass at the last solve's pose, made member by member from
 * the cache (dm_members_mult's assembly, Q' M Q, in the members' frames;
 * never the assembled model): a trajectory's transfer between steps,
 * Phi_j' M_j Phi_{j-1}, without the model. */
void dm_boundary_mass_shapes(dm_boundary *bw, int k, double *mphi);

/* The reduced problem's size: boundary DOFs + kept modes + residual vectors. */
int dm_boundary_reduced_size(const dm_boundary *bw);

/* The platform's first reduced coordinate: its 6 DOFs (translations,
 * rotations; model axes) are reduced coordinates as they are. */
int dm_boundary_platform_row(const dm_boundary *bw);

/* The reduced pair at the last solve's pose, dense (nred x nred each,
 * column-major, both triangles): the check of the solvers against an
 * independent one. Overwrites dm_boundary_reduced_modes' vectors. */
void dm_boundary_reduced_pair(dm_boundary *bw, double *K, double *M);

/* Certified per-mode error bounds of reduced eigenvalues lambda. Modes
 * whose values lie within 1e-9 of each other (a degenerate pair) form a
 * cluster a..b, bracketed together: for the smallest tau in
 * 1e-9 x 10^(i/2) with at most a of the model's eigenvalues below
 * lambda[a] (1 - tau) and at least b + 1 below lambda[b] (1 + tau)
 * (dm_boundary_count), every model eigenvalue lambda_j of the cluster is
 * between the two (counts are monotone): bound[j] is the farther end's
 * distance from lambda[j] (tau lambda[j] for a single mode). So no mode
 * below is missed and none is off by more (the Ritz values are upper
 * bounds too, but only up to the reduced solve's rounding). Two counts a
 * cluster, not a mode: at a symmetric pose, where the platform's modes
 * come in pairs, about half. The counts resolve about 1e-11 of an
 * eigenvalue at mesh 4,4, 1e-10 at 8,8 and less with soft springs
 * (docs/model-choices.md), so no bound is below 1e-9: the bound
 * certifies 1e-9, the eigenvalues are better (1e-10, measured).
 * DM_ENUMERIC when some mode cannot be bracketed within half its value (a
 * mode missed: use the full solver). */
int dm_boundary_bounds(dm_boundary *bw, int k, const double *lambda, double *bound,
                       dm_error *err);

/* The basis rule: member bases for k modes keep the fixed-interface modes
 * with eigenvalue <= DM_BOUNDARY_CUT x the model's k-th eigenvalue (found
 * once, by the model's own solver at the pose it is built at), with
 * their residual vectors. NULL (err says why) when the members cannot
 * serve the robot. */
#define DM_BOUNDARY_CUT 100.0
dm_members *dm_boundary_members_for_modes(const dm_model *model, int k, dm_error *err);

/* T' G in the reduced coordinates (dm_boundary_reduced_vectors'; nred x q,
 * column-major) for the inertial loads G of q rigid motions at `pose`,
 * the last solve's (dm_loads: G_e = -M_e a_e along every link, the
 * platform's and the elbows' masses), T the member bases: each member's
 * accelerations in its frame are a combination of its unit loads, so its
 * share is a few products with what the cache holds (dm_member_basis.G,
 * Ghat, Gq), never the model's n-vector. The boundary rows are the exact
 * condensation of G: S^-1 of them is the model's static response's
 * boundary part. */
void dm_boundary_inertial_loads(dm_boundary *bw, const dm_pose *pose,
                                const dm_rigid_motion *motion, int q, double *G);

/* T' F_gravity (nred) at the last solve's pose, as dm_boundary_inertial_loads
 * makes the inertial loads: the model's consistent gravity load (the
 * members' weight in their frames, the boundary's own: platform, payload,
 * elbow masses) in the reduced coordinates; its boundary rows are the
 * condensed load whose S^-1 is the static error. */
void dm_boundary_gravity_loads(dm_boundary *bw, double *G);

/* The last solve's whole static displacement in the model's DOFs (n). */
void dm_boundary_displacement(dm_boundary *bw, double *U);

/* The statics through the members when they serve the pose (bw non-NULL
 * and dm_boundary_solve succeeds), else through the full model (md built
 * at the pose, st factored): res->full says which served. */
int dm_boundary_statics_or_full(dm_boundary *bw, dm_model *md, dm_static *st,
                                const dm_pose *pose, dm_boundary_statics *res, dm_error *err);

#endif
