/* Chen's parameter studies: a trajectory run per combination of robot-key
 * values, in parallel. */
#include "dm_study.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "dm_threads.h"
#include "dm_trajectory.h"

int dm_study_axis_parse(const char *s, dm_study_axis *a)
{
    const char *eq = strchr(s, '=');
    if (!eq || eq - s >= (long)sizeof a->key)
        return -1;
    snprintf(a->key, sizeof a->key, "%.*s", (int)(eq - s), s);
    char tail;
    if (sscanf(eq + 1, "%lf:%lf:%d%c", &a->from, &a->to, &a->count, &tail) != 3 ||
        a->count < 1 || a->count > 1000 || !isfinite(a->from) || !isfinite(a->to))
        return -1;
    return 0;
}

double dm_study_value(const dm_study_axis *a, int i)
{
    return a->count == 1 ? a->from : a->from + (a->to - a->from) * i / (a->count - 1);
}

int dm_study_cells(const dm_study *s)
{
    return s->axis[0].count * (s->naxis > 1 ? s->axis[1].count : 1);
}

/* Progress: the runs' time steps, counted by each run's sink and reported
 * through one meter for the cells' threads. A cell's share is the steps of
 * the path with the given robot (1 when that path cannot be made); a run
 * that ends early, or fails, has its share completed when it ends. */
typedef struct {
    dm_progress_meter *pm;
    long counted, share;
} cell_progress;

/* The run's sink: every sample after the start ends a step. */
static int count_step(void *user, const dm_integ_sample *s)
{
    cell_progress *c = user;
    if (s->t_s > 0 && c->counted < c->share) {
        c->counted++;
        dm_progress_add(c->pm, 1);
    }
    return 0;
}

static void run_cell(const dm_study *s, const dm_robot *base, int i, int j, dm_study_cell *out,
                     cell_progress *cp)
{
    dm_robot rb = *base;
    dm_trajectory tr;
    dm_integ_summary sum;
    dm_error err = {0};
    char assign[128];
    int rc = DM_OK;
    for (int a = 0; a < s->naxis && !rc; a++) {
        snprintf(assign, sizeof assign, "%s=%.17g", s->axis[a].key,
                 dm_study_value(&s->axis[a], a ? j : i));
        rc = dm_robot_set(&rb, assign, &err);
    }
    if (!rc)
        rc = dm_traj_make(s->path, &rb, &tr, &err);
    if (!rc) {
        int steps = cp->pm->fn && cp->share > 1; /* counted by steps */
        rc = dm_integrate_trajectory(&rb, &tr, &s->opts, steps ? count_step : NULL, cp, &sum,
                                     &err);
        dm_traj_free(&tr);
    }
    dm_progress_add(cp->pm, cp->share - cp->counted);
    out->status = rc;
    snprintf(out->msg, sizeof out->msg, "%.255s", rc ? err.msg : "ok");
    out->mean_error_m = rc ? NAN : sum.mean_error_m;
    out->peak_error_m = rc ? NAN : sum.peak_error_m;
}

int dm_study_run(const dm_robot *rb, const dm_study *s, dm_study_cell *cells, dm_error *err)
{
    if (s->naxis < 1 || s->naxis > DM_STUDY_MAXAXIS)
        return dm_fail(err, DM_EINVAL, "study: 1 or 2 parameters, got %d", s->naxis);
    for (int a = 0; a < s->naxis; a++) { /* each key once, before any run */
        dm_robot probe = *rb;
        char assign[128];
        snprintf(assign, sizeof assign, "%s=%.17g", s->axis[a].key, s->axis[a].from);
        int rc = dm_robot_set(&probe, assign, err);
        if (rc)
            return rc;
    }
    int n2 = s->naxis > 1 ? s->axis[1].count : 1, n = dm_study_cells(s);
    dm_progress_meter pm;
    dm_progress_meter_init(&pm, s->progress, s->progress_user);
    long share = 1;
    dm_trajectory tr;
    if (pm.fn && !dm_traj_make(s->path, rb, &tr, NULL)) { /* its steps, as the runs take them */
        /* (a run of more than 1e9 steps is refused as hours of work: its share is done then) */
        share = (long)fmin(1e9, fmax(1.0, ceil(tr.duration_s / s->opts.dt_s - 1e-9)));
        dm_traj_free(&tr);
    }
    dm_progress_begin(&pm, "trajectory runs", share > 1 ? "steps" : "combinations", share * n);
#pragma omp parallel for schedule(dynamic) num_threads(dm_threads_count(s->threads))
    for (int c = 0; c < n; c++) {
        cell_progress cp = {&pm, 0, share};
        run_cell(s, rb, c / n2, c % n2, &cells[c], &cp);
    }
    dm_progress_end(&pm);
    return DM_OK;
}
