/* dm_analysis — the whole frozen-configuration analysis at one pose:
 * pose -> model (M, K, F) -> modes -> static responses. This is the
 * per-point pipeline shared by `deltamap modes` and workspace sweeps.
 *
 * A dm_analysis owns every workspace it needs (one per thread); the robot
 * is read-only and may be shared. */
#ifndef DM_ANALYSIS_H
#define DM_ANALYSIS_H

#include "dm_model.h"
#include "dm_kinematics.h"
#include "dm_modal.h"
#include "dm_robot.h"
#include "dm_static.h"

typedef struct dm_analysis {
    const dm_robot *robot;
    int kmax;
    dm_model *model;
    dm_modal *modal;
    dm_static *statics;
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
} dm_pose_result;

dm_analysis *dm_analysis_alloc(const dm_robot *robot, int na, int nb, int kmax,
                               dm_eigen_method method, dm_error *err);
void dm_analysis_free(dm_analysis *an);

/* Everything at platform position P with k modes (k <= kmax). Returns
 * DM_EUNREACHABLE for poses outside the workspace, DM_ENUMERIC when the
 * structure is singular there. */
int dm_analysis_run(dm_analysis *an, const double P[3], int k, dm_pose_result *res,
                    dm_error *err);

#endif
