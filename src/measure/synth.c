/* Synthetic measured data (see dm_synth.h). */
#include "dm_synth.h"

#include <assert.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_kinematics.h"
#include "dm_pairing.h"
#include "dm_plan.h"
#include "dm_predict.h"
#include "dm_trajectory.h"
#include "dm_work.h"

int dm_synth_draw_pose(const dm_robot *rb, dm_rng *rng, double P[3])
{
    double h = rb->arm_length_m;
    for (int tries = 0; tries < 1000; tries++) {
        dm_pose pose;
        P[0] = rb->home_m[0] + 0.3 * h * (2 * dm_rng_uniform(rng) - 1);
        P[1] = rb->home_m[1] + 0.3 * h * (2 * dm_rng_uniform(rng) - 1);
        P[2] = rb->home_m[2] + 0.15 * h * (2 * dm_rng_uniform(rng) - 1);
        if (!dm_kin_inverse(rb, P, &pose, NULL) && pose.cond <= rb->singular_cond)
            return DM_OK;
    }
    return DM_EUNREACHABLE;
}

int dm_synth_path_samples(const dm_trajectory *tr, int n, double sigma, dm_dataset *d,
                          dm_error *err)
{
    assert(n >= 0);
    int rc = DM_OK;
    for (int i = 0; i < n && !rc; i++) {
        dm_sample s = {0};
        double v[3], a[3];
        s.t = i * 1e-3;
        dm_traj_eval(tr, s.t, s.P, v, a);
        s.pose_id = d->npose++;
        s.sigma = sigma;
        for (int k = 0; k < 3 && !rc; k++) {
            s.comp = k;
            rc = dm_dataset_push(d, &s, err);
        }
    }
    return rc;
}

int dm_synth_pose_samples(dm_dataset *d, const double P[3], int pose_id, double sigma, int modes,
                          double force_n, const double *u, dm_error *err)
{
    assert(d->kind == DM_DATA_MODAL || u);
    dm_sample s = {0};
    int rc = DM_OK;
    memcpy(s.P, P, sizeof s.P);
    s.pose_id = pose_id;
    s.sigma = sigma;
    if (d->kind == DM_DATA_MODAL) {
        for (int j = 1; j <= (modes > 0 ? modes : 6) && !rc; j++) {
            s.mode = j;
            rc = dm_dataset_push(d, &s, err);
        }
        return rc;
    }
    double nu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int k = 0; k < 3; k++)
        s.force[k] = (force_n > 0 ? force_n : 50.0) * u[k] / nu;
    for (int k = 0; k < 3 && !rc; k++) {
        s.comp = k;
        rc = dm_dataset_push(d, &s, err);
    }
    return rc;
}

int dm_synthesize(const dm_robot *rb, const dm_synth_opts *o, dm_dataset *d, dm_error *err)
{
    dm_rng rng = {o->seed * 0x2545F4914F6CDD1Dull + 1};
    memset(d, 0, sizeof *d);
    d->kind = o->kind;
    snprintf(d->source, sizeof d->source, "synthetic %s data", dm_data_kind_name(o->kind));
    snprintf(d->robot, sizeof d->robot, "%s", rb->name);
    int rc = DM_OK;
    if (o->kind == DM_DATA_TRACKER) {
        char spec[256];
        dm_trajectory tr;
        const double *h = rb->home_m;
        if (o->path)
            snprintf(spec, sizeof spec, "%s", o->path);
        else
            snprintf(spec, sizeof spec, "circle:centre=%.9g,%.9g,%.9g;radius=%.9g;rate=%.9g;duration=0.5",
                     h[0], h[1], h[2], 0.2 * rb->arm_length_m, 4 * M_PI);
        if ((rc = dm_traj_make(spec, rb, &tr, err)))
            return rc;
        double steps = floor(tr.duration_s / 1e-3 + 1e-9) + 1;
        char what[320];
        snprintf(what, sizeof what, "synth: %s: %.4g s sampled every 1 ms", tr.name,
                 tr.duration_s);
        dm_work need = {dm_predict_cost_s(rb, o->kind, steps, o->na, o->nb),
                        steps * (3 * (sizeof(dm_sample) + sizeof(double)) + 4 * sizeof(double)),
                        0};
        rc = dm_work_check(what, need, DM_WORK_LIMIT, "a shorter path", o->force_long, err);
        if (!rc && steps > INT_MAX / 3) /* the samples are counted in int */
            rc = dm_fail(err, DM_EINVAL, "%s: %.3g samples, at most %d", what, 3 * steps,
                         INT_MAX);
        if (rc) {
            dm_traj_free(&tr);
            return rc;
        }
        rc = dm_synth_path_samples(&tr, (int)steps, o->noise, d, err);
        dm_traj_free(&tr);
    } else {
        double np = o->npose > 0 ? o->npose : 16;
        double per = o->kind == DM_DATA_MODAL ? (o->modes > 0 ? o->modes : 6) : 3;
        char what[96];
        snprintf(what, sizeof what, "synth: %.0f poses", np);
        dm_work need = {dm_predict_cost_s(rb, o->kind, np, o->na, o->nb),
                        np * per * (sizeof(dm_sample) + sizeof(double)), 0};
        if ((rc = dm_work_check(what, need, DM_WORK_LIMIT, "fewer poses", o->force_long, err)))
            return rc;
        if (np * per > INT_MAX) /* the samples are counted in int */
            return dm_fail(err, DM_EINVAL, "%s: %.3g samples, at most %d", what, np * per,
                           INT_MAX);
        for (int p = 0; p < (o->npose > 0 ? o->npose : 16) && !rc; p++) {
            double P[3], u[3];
            if (dm_synth_draw_pose(rb, &rng, P)) {
                rc = dm_fail(err, DM_EUNREACHABLE, "no reachable pose found near home");
                break;
            }
            if (o->kind == DM_DATA_STATIC)
                for (int k = 0; k < 3; k++)
                    u[k] = dm_rng_normal(&rng);
            rc = dm_synth_pose_samples(d, P, d->npose++, o->noise, o->modes, o->force_n,
                                       o->kind == DM_DATA_STATIC ? u : NULL, err);
        }
    }
    double *pred = rc ? NULL : malloc(sizeof(double) * d->n);
    if (!rc && !pred)
        rc = dm_fail(err, DM_ENOMEM, "out of memory");
    if (!rc)
        rc = dm_predict(rb, d, o->na, o->nb, pred, err);
    for (int i = 0; i < d->n && !rc; i++)
        d->s[i].value = pred[i] + o->noise * dm_rng_normal(&rng);
    free(pred);
    if (!rc && o->kind == DM_DATA_MODAL && o->pairing)
        rc = dm_pairing_survey(rb, o->sensors, o->drop_mode, o->extra_hz, o->extra_dir, o->na,
                               o->nb, &rng, d, err);
    if (rc)
        dm_dataset_free(d);
    return rc;
}

int dm_synth_at(const dm_robot *rb, const dm_dataset *tmpl, const dm_synth_opts *o,
                dm_dataset *d, dm_error *err)
{
    dm_work need = {0};
    need.seconds = dm_predict_estimate_s(rb, tmpl, o->na, o->nb, &need.bytes);
    char what[sizeof tmpl->source + 64];
    snprintf(what, sizeof what, "synth: %s: %d samples", tmpl->source, tmpl->n);
    int rc = dm_work_check(what, need, DM_WORK_LIMIT, "a smaller template", o->force_long, err);
    return rc ? rc : dm_plan_observe(rb, tmpl, o->noise, o->seed, o->na, o->nb, d, err);
}
