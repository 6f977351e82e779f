/* dm_predict — what the model predicts for measured data (docs/
 * measured-data.md), a workspace that predicts one dataset for many robots
 * (the fits' every evaluation), and what predictions cost (the estimates
 * the measurement commands give dm_work_check before any work). */
#ifndef DM_PREDICT_H
#define DM_PREDICT_H

#include "dm_error.h"
#include "dm_measure.h"
#include "dm_robot.h"

/* Model predictions for every sample (same order), with the robot's mesh
 * (or na, nb when > 0). Unreachable poses and mode ranks beyond the model
 * are errors naming the sample's line. One run of a dm_predictor made for
 * it. A survey with mode shapes or directions (data->pair) is refused:
 * its ranks are the measured ones; predict dm_pairing_apply's survey. */
int dm_predict(const dm_robot *robot, const dm_dataset *data, int na, int nb, double *pred,
               dm_error *err);

/* A prediction workspace: the predictions of one dataset for many robots
 * (a fit's every evaluation), with the model, eigen and static workspaces
 * (tracker data: the commanded path) made once and reused. The dataset
 * must outlive it and not change; the mesh is that of `robot` (or na, nb
 * when > 0) for every run. One per thread. */
typedef struct dm_predictor dm_predictor;

dm_predictor *dm_predictor_new(const dm_robot *robot, const dm_dataset *data, int na, int nb,
                               dm_error *err);

/* Predictions with this robot: bit for bit those of dm_predict (every run
 * starts the eigen solver cold). The robot may differ from run to run in
 * any value; when its effects change the model's DOFs (a compliant base,
 * joint springs) the workspace is made again for the new size. Tracker
 * data: the run keeps its modal history (dm_integ_history), and a next
 * run whose robot differs only in Rayleigh damping replays it instead of
 * solving every step again. */
int dm_predictor_run(dm_predictor *p, const dm_robot *robot, double *pred, dm_error *err);

/* A tracker run's integration step: this, or the samples' spacing where
 * shorter (the closed-form modal transition with the quasi-static
 * correction, 10 modes, loads linear between the steps' ends). */
#define DM_PREDICT_STEP_S 1e-3

/* Integrate this predictor's tracker runs at steps of at most step_s
 * instead of DM_PREDICT_STEP_S (a coarse search's cheaper predictions:
 * they differ from dm_predict's). */
void dm_predictor_step(dm_predictor *p, double step_s);

/* Predict only the first n samples (whole poses, or whole tracker times)
 * from now on; the dataset's n restores all. A tracker run's first part is
 * predicted as dm_predict predicts a file cut there: along the path
 * through its own commanded samples. */
void dm_predictor_window(dm_predictor *p, int n);

/* Tracker data: the part of a run's predictions that geometry errors
 * move at first order, alone: at each sample of the window, where the
 * robot's geometry errors (with its clearance) put the real platform
 * relative to the commanded one, as dm_predictor_run adds it to the
 * elastic error (and 0 where it adds none), without that error. Costs a
 * few kinematic solves a sample, against a run's model and modes every
 * step. */
int dm_predictor_offsets(dm_predictor *p, const dm_robot *robot, double *pred, dm_error *err);
void dm_predictor_free(dm_predictor *p);

/* Call tick(user) after each pose analysed (modal and static data) or
 * each integration step (tracker data, replays included) of this
 * predictor's runs, from the thread running them: units of work, for a
 * caller's progress. NULL: none. Changes no prediction. */
void dm_predictor_on_work(dm_predictor *p, void (*tick)(void *user), void *user);

/* What a command implies, judged before any work by dm_work_check against
 * DM_WORK_LIMIT (dm_work.h). Estimates come from the costs measured on
 * this project's development machine (2 cores, x86-64): a modal pose or a
 * tracker step about 2.5 ms and a static pose (with and without the force)
 * 5 ms at 210 DOF, 15 % of it fixed and the rest growing as n^2 (0.4 ms
 * per tracker step at 48 DOF). */

/* Seconds on one thread of predicting `count` poses (tracker: integration
 * steps) of data of this kind with this mesh (0: the robot's). */
double dm_predict_cost_s(const dm_robot *robot, dm_data_kind kind, double count, int na, int nb);

/* The same for one dm_predict of `data` (tracker: its duration at the
 * step dm_predict takes), and the bytes that prediction holds. */
double dm_predict_estimate_s(const dm_robot *robot, const dm_dataset *data, int na, int nb,
                             double *bytes);

#endif
