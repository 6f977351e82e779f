/* dm_budget — Zheng & Zhang's (2017, §5, eq. 30–31) error budget along a
 * path: the platform error of each source alone, their simple sum, the
 * combined model and the coupling (combined − sum).
 *
 * The three sources and what each "alone" means (translations of the
 * platform centre, m, real − commanded, base frame):
 *   geometry     the robot with its geometry errors (table 1: lengths,
 *                radii, mounting angle, actuator offset) and no clearance,
 *                rigid: the offset of the real closure (dm_kin_pose_loaded)
 *   clearance    the robot with its clearances (rod-end balls, actuator
 *                joints) and no geometry errors, rigid: the offset of the
 *                dead bands opened by the platform's net force m (g − a) + F
 *   flexibility  the robot with neither (its other effects — springs,
 *                masses, stress stiffening — kept): the elastic error of
 *                the normal-coordinate run (dm_integrate_trajectory)
 *   sum          (b) = the three vectors added
 *   combined     (c) = the run of the robot with everything on: the flexible
 *                model is built at the real configuration (real lengths and
 *                radii, the arms where the clearances put them), loaded by
 *                gravity and the inertia of the real motion there, and the
 *                offset of the real closure with geometry errors and
 *                clearance together is added to its elastic error
 *   coupling     (c) − (b): the elastic error's change from the nominal to
 *                the real configuration, plus the kinematic cross terms of
 *                geometry errors and clearance in the closure.
 * With `flexibility` off no model is integrated: flexibility alone is zero
 * and combined is the rigid closure with everything on. */
#ifndef DM_BUDGET_H
#define DM_BUDGET_H

#include "dm_integrate.h"

enum { DM_BUDGET_GEOMETRY = 0, DM_BUDGET_CLEARANCE, DM_BUDGET_FLEXIBILITY, DM_BUDGET_NSRC };

/* "geometry", "clearance", "flexibility" */
const char *dm_budget_source_name(int source);

typedef struct dm_budget_sample {
    dm_integ_sample run;          /* the combined run's sample (frequencies, 6-D error, ...;
                                     nfreq 0 and coupling index NaN when rigid) */
    double alone_m[DM_BUDGET_NSRC][3];
    double sum_m[3], combined_m[3], coupling_m[3];
} dm_budget_sample;

typedef struct dm_budget_summary {
    dm_integ_summary run;         /* of the combined run (zeros when rigid) */
    int flexibility;
    /* Chen eq. 27 means (1/T) sum dt |e| and peaks max |e| of each series */
    double mean_alone_m[DM_BUDGET_NSRC], peak_alone_m[DM_BUDGET_NSRC];
    double mean_sum_m, peak_sum_m, mean_combined_m, peak_combined_m;
    double mean_coupling_m, peak_coupling_m;
} dm_budget_summary;

typedef int (*dm_budget_sink)(void *user, const dm_budget_sample *sample);

/* The budget of `robot` along `traj`: opts as for dm_integrate_trajectory
 * (the flexibility-alone run skips the all-modes reference); flexibility 0:
 * rigid (kinematics only). The sink sees t = 0 and the end of every step. */
int dm_budget_trajectory(const dm_robot *robot, const dm_trajectory *traj,
                         const dm_integ_opts *opts, int flexibility, dm_budget_sink sink,
                         void *user, dm_budget_summary *summary, dm_error *err);

#endif
