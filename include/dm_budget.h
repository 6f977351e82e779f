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

/* ---- the coupling index against the nominal robot along a run ---------
 * Zheng's index log10 lambda_s depends on the mesh and the DOF units
 * (dm_coupling.h); its change against the nominal robot (all [effects]
 * off) at the same commanded pose and mesh is what compares across poses
 * and designs. A run's step is frozen at the commanded position of its
 * start, which is the previous sample's (the first sample: its own), so
 * the tracker fed every sample of a run in order gives
 *   change = sample.coupling_index_log10 - nominal at that position,
 * NaN where the sample has no index (a rigid run) or the nominal robot
 * cannot be built there (outside its workspace), and over the steps the
 * time mean (each step weighted by its length, as the run's own index),
 * minimum and maximum of the finite changes. */
typedef struct dm_coupling_change {
    struct dm_coupling *nominal;  /* dm_coupling.h's workspace (NULL: no effects, change 0) */
    long samples;
    double t_prev, P_prev[3];
    double integral_s, weight_s, min, max;
} dm_coupling_change;

/* For runs of `robot` at mesh na, nb (0: the robot file's). */
int dm_coupling_change_init(dm_coupling_change *cc, const dm_robot *robot, int na, int nb,
                            dm_error *err);
void dm_coupling_change_free(dm_coupling_change *cc);
/* The change of the run's next sample into *change (NaN when there is
 * none: a rigid run, a position outside the nominal robot's workspace or
 * singular for it). Other failures of the nominal model (out of memory)
 * are returned. */
int dm_coupling_change_next(dm_coupling_change *cc, const dm_integ_sample *sample,
                            double *change, dm_error *err);
/* Time mean, minimum and maximum over the steps so far (NaN: none). */
void dm_coupling_change_summary(const dm_coupling_change *cc, double *mean, double *min,
                                double *max);

#endif
