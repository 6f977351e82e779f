/* dm_members — the model cut into its members, each in its own frame,
 * computed once per robot, mesh and effect set (issue 39; docs/model-choices.md
 * "Member bases").
 *
 * Every pose dependence of the frozen-configuration M and K enters through
 * the nine members' orientations (three arms, six rods) and the rigid
 * offsets that tie the rods' ends to the elbows and the platform: in its
 * own frame a member's matrices are the same at every pose. So the n DOFs
 * of dm_model split into
 *   the boundary: each elbow's 6 DOFs, each compliant base's 3
 *                 translations, the platform's 6 (model order, global axes);
 *   each member's interior: the rest of its DOFs, in the member's frame
 *                 (arm: nodes 1..na-1 and the actuator rotation; rod: its
 *                 interior nodes, its ends' two own rotations, and with
 *                 joint springs its ends' own translations).
 * A member meets the boundary through its own boundary DOFs, in its frame:
 * an arm through its tip (the elbow's 6) and its root's translations on a
 * compliant base (3); a rod through the two short-bar points its ends ride
 * on (3 + 3 translations). Per pose, member boundary = C(pose) x boundary,
 * C holding the rotations and the rigid offsets (dm_members_coupling); the
 * model DOFs and (boundary, interiors) are related by an orthogonal map Q
 * (rotations of node triads), so K_model = Q K Q' exactly and det K is the
 * same.
 *
 * For each member the cache holds its K, M and unit-acceleration loads,
 * the Cholesky factor of K_ii (the member clamped at its boundary) and
 * ln det K_ii, the constraint modes Psi = -K_ii^-1 K_ib with the condensed
 * stiffness Khat = K_bb + K_bi Psi and load, and its fixed-interface modes
 * (all of them, M_ii-orthonormal) with the basis the rule keeps: the modes
 * with eigenvalue <= lambda_cut and the residual (static) vectors of the
 * modes dropped, one per boundary DOF (docs/model-choices.md).
 *
 * A dm_members is built once and then only read: any number of threads
 * may share it. It cannot serve a model whose member matrices change with
 * the pose: geometric stiffness (K_G follows the axial forces) is refused
 * at build, and dm_members_at refuses a pose whose member lengths differ
 * from the cached ones (joint clearance: a rod's effective length flips
 * with its load). Callers then use the full model. */
#ifndef DM_MEMBERS_H
#define DM_MEMBERS_H

#include "dm_error.h"
#include "dm_kinematics.h"
#include "dm_model.h"
#include "dm_robot.h"

#define DM_MEMBERS_N 9       /* chain i: arm 3i, rods 3i + 1 (+d), 3i + 2 (-d) */
#define DM_MEMBERS_MAX_BOUND 33 /* 3 elbows, 3 bases, the platform */
#define DM_MEMBERS_LOADS 9   /* unit load cases per member (dm_member_basis.G) */

/* A run of a member's interior DOFs that sits in the model's U: `count`
 * DOFs from model_dof, either the same numbers (rotate 0: own rotations,
 * the actuator) or node triads turned by the member's frame (rotate 1:
 * local = lambda * global). */
typedef struct dm_members_run {
    int interior, model_dof, count, rotate;
} dm_members_run;

typedef struct dm_member_basis {
    dm_member_kind kind;
    int chain, side;        /* side: the rod's 0 (+d) or 1 (-d); arms 0 */
    int nel;                /* elements */
    double element_m;       /* its elements' length at the build (the model's number) */
    int nb, ni, nm;         /* boundary DOFs (6 or 9), interior, nb + ni */
    double *K, *M;          /* nm x nm, column-major, boundary DOFs first */
    double *G;              /* nm x DM_MEMBERS_LOADS: consistent loads (M times the nodal
                             * accelerations) of unit accelerations in the member's frame:
                             * columns 0-2 along local x, y, z at every node (gravity);
                             * 3-5 the same growing from 0 at the first node to 1 at the
                             * last (the affine field of dm_loads along a link); 6-8 about
                             * local x, y, z at every node's rotations */
    double *Lii;            /* ni x ni: Cholesky factor of K_ii (lower) */
    double logdet_ii;       /* ln det K_ii */
    double *Psi;            /* ni x nb: constraint modes -K_ii^-1 K_ib */
    double *Khat;           /* nb x nb: K_bb + K_bi Psi */
    double *Ghat;           /* nb x DM_MEMBERS_LOADS: G_b + Psi' G_i */
    double *Gq;             /* (nkeep + nres) x DM_MEMBERS_LOADS: [Phi_kept, R]' G_i */
    double *Ui;             /* ni x 3: K_ii^-1 G_i (clamped member under unit acceleration) */
    double *lambda;         /* ni: fixed-interface eigenvalues, ascending, rad^2/s^2 */
    double *Phi;            /* ni x ni: their modes, M_ii-orthonormal */
    int nkeep;              /* modes the rule keeps (lambda <= lambda_cut) */
    int nres;               /* residual vectors (<= nb + 1: an arm's own rotation) */
    double *R;              /* ni x nres: M_ii-orthonormal, M_ii-orthogonal to the kept modes */
    double *Mhat;           /* nb x nb: [I; Psi]' M [I; Psi], the inertia of the constraint modes */
    double *Gam;            /* ni x nb: Phi' F, F = M_ib + M_ii Psi (every mode's coupling) */
    double *GamR;           /* nres x nb: R' F */
    double *kres;           /* nres: R' K_ii R, diagonal (R is K_ii-orthogonal), ascending */
    int nrun;
    dm_members_run *run;     /* where the interior sits in the model's U */
} dm_member_basis;

typedef struct dm_members {
    const dm_robot *robot;
    int na, nb, n;          /* the mesh and the model's DOF count */
    double lambda_cut;      /* the basis rule's cut, rad^2/s^2 */
    int nbound;             /* boundary DOFs */
    int bdof[DM_MEMBERS_MAX_BOUND]; /* their model DOFs, ascending */
    int belbow[3], bbase[3], bplat; /* first boundary index of each group (bbase -1: rigid base) */
    int interior0[DM_MEMBERS_N];    /* first index of each member's interior in (boundary, interiors) */
    dm_member_basis member[DM_MEMBERS_N];
    double *Kb, *Mb;        /* nbound x nbound: what acts on the boundary alone (base springs;
                             * platform, payload and elbow masses), global axes */
    double Fb[DM_MEMBERS_MAX_BOUND]; /* their weight */
} dm_members;

/* A pose as the members see it: each member's frame, the offsets of the
 * rods' ends from the elbow (bar) and from the platform centre. */
typedef struct dm_members_pose {
    double lambda[DM_MEMBERS_N][9];
    double bar[DM_MEMBERS_N][3], plat_arm[DM_MEMBERS_N][3];
    double gravity[3];
} dm_members_pose;

/* Build the cache from a model assembled at any pose (dm_model_build: its
 * DOF numbering and member lengths), keeping fixed-interface modes with
 * eigenvalue <= lambda_cut (rad^2/s^2). DM_EINVAL when the model's member
 * matrices depend on the pose (dm_members_serves): the caller keeps the
 * full model. */
dm_members *dm_members_build(const dm_model *model, double lambda_cut, dm_error *err);
void dm_members_free(dm_members *members);

/* The reduced problem's size on these bases: boundary DOFs + each
 * member's kept modes and residual vectors (dm_boundary_reduced_size). */
int dm_members_reduced_size(const dm_members *members);

/* Can the cache serve this robot's models at all (else the reason)? */
int dm_members_serves(const dm_robot *robot, dm_error *err);

/* The members' frames at a pose; DM_EINVAL when a member's length differs
 * from the cached one by more than 1e-12 relative (another geometry). */
int dm_members_at(const dm_members *members, const dm_pose *pose, dm_members_pose *mp,
                  dm_error *err);

/* C (nb x nbound, column-major): member m's boundary DOFs (its frame) from
 * the boundary DOFs (global) at the pose. */
void dm_members_coupling(const dm_members *members, const dm_members_pose *mp, int m, double *C);

/* The boundary DOFs member m reaches (C's structurally non-zero columns):
 * its elbow, and its base (arm on a compliant base) or the platform (rod).
 * Returns their count (6, 9 or 12). */
int dm_members_columns(const dm_members *members, int m, int cols[12]);

/* z (n) = Q' U: the model's DOFs U as (boundary, member interiors), and
 * back, U = Q z. */
void dm_members_gather(const dm_members *members, const dm_members_pose *mp, const double *U,
                       double *z);
void dm_members_scatter(const dm_members *members, const dm_members_pose *mp, const double *z,
                        double *U);
/* dm_members_scatter for k vectors at once (z and U: n x k,
 * column-major): the shapes of a trajectory's every step. */
void dm_members_scatter_many(const dm_members *members, const dm_members_pose *mp, const double *z,
                             int k, double *U);

/* y = K z or y = M z (which 'K' or 'M') assembled from the members at the
 * pose, in (boundary, interiors) coordinates: Q' K_model Q. The check of
 * the cache against the model; not a fast path (it allocates: DM_ENOMEM). */
int dm_members_mult(const dm_members *members, const dm_members_pose *mp, char which,
                    const double *z, double *y);

#endif
