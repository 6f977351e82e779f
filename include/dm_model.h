/* dm_model — the frozen-configuration finite-element model (docs/model.md §2).
 *
 * Arms (na elements) and rods (nb elements each, two per chain) are 3-D
 * beams; short bars and the platform are rigid. Each beam node's six global
 * displacements are a linear map ("node map") of a few reduced DOFs U:
 *   free node      -> its own 6 DOFs
 *   arm root       -> nothing (clamped)
 *   upper rod end  -> elbow's 6 DOFs via the short bar + 2 own bending rotations
 *   lower rod end  -> platform's 6 DOFs via the platform + 2 own bending rotations
 * and M = sum (T_e S_e)' M_e (T_e S_e), likewise K (Chen eq. 13–21).
 *
 * Order of U: chain 0, 1, 2 (arm-root DOFs when the model extensions give
 * it any; arm nodes 1..na; the upper ends of rods +d and -d; the two rods'
 * interior nodes interleaved, node k of +d then node k of -d; the two
 * lower ends), then the 6 platform DOFs (dx, dy, dz, ex, ey, ez) last.
 * Chains touch each other only through the platform, so M and K are
 * block-arrow matrices (dm_arrow): a banded block per chain (half-bandwidth
 * 17 at any mesh with nb >= 2) and the platform as the border.
 *
 * Model extensions (docs/model.md §6, robot [effects]): actuator springs and
 * compliant bases add arm-root DOFs and springs to ground; joint springs
 * give each rod end its own translations tied to its short-bar point;
 * payload and elbow masses add mass and weight; geometric stiffness adds
 * K_G from the axial forces of a linear static gravity solve. A dm_model
 * is one thread's workspace; the robot it points to is read-only. */
#ifndef DM_MODEL_H
#define DM_MODEL_H

#include "dm_arrow.h"
#include "dm_beam.h"
#include "dm_error.h"
#include "dm_kinematics.h"
#include "dm_robot.h"

#define DM_NODEMAP_MAX 8

/* u_node[r] = sum_j c[r][j] * U[idx[j]], r over (u, v, w, tx, ty, tz) global. */
typedef struct dm_nodemap {
    int m;
    int idx[DM_NODEMAP_MAX];
    double c[6][DM_NODEMAP_MAX];
} dm_nodemap;

typedef enum { DM_MEMBER_ARM = 0, DM_MEMBER_ROD = 1 } dm_member_kind;

typedef struct dm_element {
    dm_member_kind member;
    int chain;
    double x1[3], x2[3];    /* node positions, m */
    double s1, s2;          /* node positions as fractions of the member (0 at its top) */
    double length_m;
    double lambda[9];       /* local axes (rows) */
    dm_nodemap node[2];
} dm_element;

typedef struct dm_model {
    const dm_robot *robot;
    int na, nb;
    int root_dofs[3];       /* per arm root: 3 base translations and/or 1 actuator rotation */
    int end_dofs;           /* per rod end: 2 rotations (+3 translations with joint springs) */
    int n;                  /* reduced DOFs */
    int platform_dof;       /* first of the 6 platform DOFs (== n - 6) */
    int chain_dof[3];       /* first DOF of each chain's block */
    int elbow_dof[3];       /* first DOF (translations) of each elbow node */
    int nelem;
    dm_element *elem;
    dm_arrow_plan *plan;    /* nelem: where each element's entries go in M and K */
    dm_beam_props props[2]; /* arm, rod */
    double platform_mass[36]; /* 6x6 rigid mass of platform (+ payload) */
    dm_pose pose;
    dm_arrow_layout layout; /* of M and K */
    dm_arrow M, K;          /* block-arrow (K includes K_G when enabled) */
    dm_arrow_pattern pattern; /* their structural non-zeros (after the first build) */
    int have_pattern;
    double *F_gravity;      /* n: consistent gravity load */
    dm_arrow_chol *gs_factor; /* geometric stiffness: factor of the elastic K */
    double *u_static;       /* n: its static gravity displacement */
} dm_model;

/* Number of reduced DOFs for this robot (with its [effects]) and mesh. */
int dm_model_dofs(const dm_robot *robot, int na, int nb);

/* Number the DOFs for this robot and mesh and allocate the matrices. */
dm_model *dm_model_alloc(const dm_robot *robot, int na, int nb, dm_error *err);
void dm_model_free(dm_model *model);

/* Build M, K and the gravity load at a pose (from dm_kin_inverse). */
int dm_model_build(dm_model *model, const dm_pose *pose, dm_error *err);

/* Add to F the consistent loads of one element whose nodes have global
 * accelerations a12 (translation, rotation per node), F += (T S)' M_e T a,
 * for q loads at once: a12 holds q sets of 12 accelerations, F q columns
 * of length n (the element's map and mass computed once). Inertial loads
 * (dm_loads); the build's gravity load is the same sum. */
void dm_model_add_element_loads(const dm_model *model, const dm_element *e, int q,
                                const double *a12, double *F);

/* The full n x n matrices, column-major (either may be NULL): the dense
 * oracle for tests, and the input of the dense eigen solvers. */
void dm_model_dense(const dm_model *model, double *K, double *M);

/* Y = M X and Y = K X for a block of q vectors, interleaved (the q values
 * of DOF i at X[i q ...]; q = 1: one plain vector). X and Y must differ. */
void dm_model_mult_M(const dm_model *model, const double *X, int q, double *Y);
void dm_model_mult_K(const dm_model *model, const double *X, int q, double *Y);

/* The rigid platform with its payload (robot [effects]): MP its 6 x 6
 * mass about P (column-major), F6 += its weight as a load on the
 * platform's six DOFs (the assembly's own numbers). */
void dm_model_platform(const dm_robot *robot, double MP[36], double F6[6]);

/* Where rod s (0: +d, 1: -d) of chain i runs at a pose: its ends (the
 * short-bar points at the elbow and at the platform) and the rigid offsets
 * that carry them, bar from the elbow and plat_arm from the platform
 * centre (the assembly's own numbers, for modules that rebuild the
 * members' frames without assembling). */
void dm_model_rod_ends(const dm_robot *robot, const dm_pose *pose, int i, int s, double top[3],
                       double bottom[3], double bar[3], double plat_arm[3]);

/* Global 6-vector of a node given reduced DOFs U. */
void dm_model_nodemap_apply(const dm_nodemap *map, const double *U, double out[6]);

#endif
