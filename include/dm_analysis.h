/* dm_analysis — the whole frozen-configuration analysis at one pose:
 * pose -> model (M, K, F) -> modes -> static responses. This is the
 * per-point pipeline shared by `deltamap modes` and workspace sweeps.
 *
 * A dm_analysis owns every workspace it needs (one per thread); the robot
 * is read-only and may be shared. */
#ifndef DM_ANALYSIS_H
#define DM_ANALYSIS_H

#include "dm_boundary.h"
#include "dm_model.h"
#include "dm_kinematics.h"
#include "dm_modal.h"
#include "dm_robot.h"
#include "dm_static.h"

/* Which model serves a pose: the full FE model (dm_modal, dm_static), or
 * the member bases (dm_members, dm_boundary: statics exact through the
 * boundary, the modes of the reduced problem, proven complete by a count
 * of the whole model; docs/model-choices.md "Member bases"). */
typedef enum dm_engine { DM_ENGINE_FULL = 0, DM_ENGINE_MEMBERS = 1 } dm_engine;

typedef struct dm_analysis {
    const dm_robot *robot;
    int kmax;
    dm_model *model;
    dm_modal *modal;
    dm_static *statics;
    /* the member engine (dm_analysis_use_members; members NULL: none) */
    const dm_members *members; /* shared, read-only */
    dm_boundary *boundary;
    dm_boundary_eig *eig;
    dm_modes member_modes;    /* the member engine's modes (its buffers) */
    double *reduced;          /* nred x kmax: their reduced vectors */
    double *lambda, *shapes;  /* kmax: their eigenvalues; n x kmax: their shapes */
    int last_members;         /* the members served the last run */
    dm_boundary_eig_info member_info; /* and how its reduced solve went */
    dm_error member_error;    /* else why not (code 0: they were not asked) */
    int want_model;           /* the member engine also builds and factors the
                                 full model (for consumers of the model's DOFs:
                                 `modes`' shape outputs, a CVODE reference; the
                                 standard moves need it not: dm_standard_moves_reduced) */
    int want_shapes;          /* and recovers the shapes in the model's DOFs
                                 (default 1; 0: member_modes.phi is NULL) */
} dm_analysis;

typedef struct dm_pose_result {
    dm_pose pose;
    const dm_modes *modes;       /* points into the workspace */
    double static_error[6];      /* dx, dy, dz (m), ex, ey, ez (rad) */
    double compliance[36];       /* 6x6 column-major */
    double compliance_max_m_per_n;
    double compliance_dir[3];
    double stiffness_min_n_per_m;/* 1 / compliance_max */
    int near_singular;           /* pose.cond > robot->singular_cond */
    double coupling_index_log10; /* log10 det K, Zheng eq. 33 (dm_coupling.h) */
    dm_engine engine;            /* which served the pose (the full model where
                                    the members could not) */
} dm_pose_result;

dm_analysis *dm_analysis_alloc(const dm_robot *robot, int na, int nb, int kmax,
                               dm_eigen_method method, dm_error *err);
void dm_analysis_free(dm_analysis *an);

/* Everything at platform position P with k modes (k <= kmax). Returns
 * DM_EUNREACHABLE for poses outside the workspace, DM_ENUMERIC when the
 * structure is singular there. */
int dm_analysis_run(dm_analysis *an, const double P[3], int k, dm_pose_result *res,
                    dm_error *err);

/* The same at a pose already solved (a loaded pose, dm_kin_pose_loaded:
 * a trajectory's steps). */
int dm_analysis_run_pose(dm_analysis *an, const dm_pose *pose, int k, dm_pose_result *res,
                         dm_error *err);

/* Member bases for analyses of `robot` at mesh (na, nb) with up to kmax
 * modes (the rule of dm_boundary_members_for_modes, at the robot's home):
 * built once, shared read-only by every thread's dm_analysis. NULL, err
 * saying why, when the members cannot serve the robot (geometric
 * stiffness, joint clearance: dm_members_serves); callers keep the full
 * model. */
dm_members *dm_analysis_members(const dm_robot *robot, int na, int nb, int kmax,
                                dm_error *err);

/* Serve the poses from `members` (built for this robot, mesh and at least
 * this kmax) from now on; a pose they cannot serve (a member solve that
 * fails, a count of the whole model that finds a mode the bases miss,
 * from a warm start and then once more from a cold one) falls back to
 * the full model, cold, and says so in res->engine. */
int dm_analysis_use_members(dm_analysis *an, const dm_members *members, dm_error *err);

/* Warm starts, as dm_modal's seeds, for whichever engine is in use: a run
 * after seed_load gives the same bits whatever ran before; forget makes
 * the next run cold. */
size_t dm_analysis_seed_size(const dm_analysis *an);
int dm_analysis_seed_save(const dm_analysis *an, void *seed);
void dm_analysis_seed_load(dm_analysis *an, const void *seed);
void dm_analysis_forget(dm_analysis *an);

/* Poses along a smooth path at equal steps, for whichever engine is in
 * use (dm_modal_follow_path, dm_boundary_eig_follow_path); calling it
 * again starts a new path. */
void dm_analysis_follow_path(dm_analysis *an, int on);

/* The member engine's pairs (after dm_analysis_use_members) also converge
 * to this relative residual (dm_boundary_eig_residual_target; the full
 * model's is always DM_MODAL_CONVERGED): set to that, results are as
 * smooth in the robot's parameters on either engine. */
void dm_analysis_residual_target(dm_analysis *an, double residual);

/* Mode tracking for whichever engine is in use (dm_modal_track): the
 * vectors families are followed by are the shapes (n) on the full model,
 * the reduced vectors (nred: the same M-products, dm_boundary_eig_mult_M)
 * on the members. track_dim: their length; track_vectors: the last run's
 * (kmax of them), NULL where the full model served a member analysis (its
 * vectors are not in the members' coordinates). dm_analysis_track
 * matches families ref (track_dim x kr) against the last run's kc modes;
 * -1 (nothing assigned) where track_vectors is NULL. work: track_dim
 * (kr + kc) + kr kc doubles. */
int dm_analysis_track_dim(const dm_analysis *an);
const double *dm_analysis_track_vectors(const dm_analysis *an, const dm_pose_result *res);
int dm_analysis_track(dm_analysis *an, const dm_pose_result *res, const double *ref, int kr,
                      int kc, int *assign, double *mac, double *shapes, double *work);

/* Certified error bounds (rad^2/s^2) of the k lowest eigenvalues of the
 * last run, which the members served (dm_boundary_bounds: the whole
 * model's eigenvalue within bound[j] of omega_j^2). DM_EINVAL when the
 * full model served it (its accuracy is dense LAPACK's, dm_modal.h). */
int dm_analysis_bounds(dm_analysis *an, int k, double *bound, dm_error *err);

#endif
