/* dm_progress — how far a long call is. Libraries never print: a call that
 * runs for seconds to hours (a diagnosis, a plan, a tolerance Monte Carlo)
 * takes a callback in its options and reports to it; the caller shows it
 * (the CLI's --progress). The sweep has its own, richer record
 * (dm_sweep_progress).
 *
 * A call's work comes in stages (a diagnosis fits single effects, then
 * pairs, then checks the verdict). Each stage is reported first with done
 * 0, then as its units get done, and last with `final` set and done ==
 * total; a stage with no work is not reported. Units are the stage's own
 * (fits, pose analyses, samples, steps) and of about equal cost within it,
 * so that elapsed * (total - done) / done estimates the rest of the stage
 * from the work done so far. Reports come from one thread at a time (the
 * callback needs no lock of its own), cost nothing when no callback is
 * given, and change no result: no number, thread count or allocation of
 * the work depends on them.
 *
 * dm_progress_meter is what the reporting side keeps: one per call, shared
 * by the call's threads. */
#ifndef DM_PROGRESS_H
#define DM_PROGRESS_H

#include <omp.h>

typedef struct dm_progress {
    int index;           /* the stage's number in the call, from 0 (stages may share a name) */
    const char *stage;   /* what is being done: "single effects", "samples" */
    const char *unit;    /* what done and total count: "fits", "pose analyses" */
    long done, total;    /* of this stage; 0 <= done <= total, total >= 1 */
    double seconds;      /* since the call started */
    int final;           /* the stage is over */
} dm_progress;

typedef void (*dm_progress_fn)(void *user, const dm_progress *p);

typedef struct dm_progress_meter {
    dm_progress_fn fn;   /* NULL: nothing is counted or reported */
    void *user;
    double t0;           /* omp_get_wtime() at the call's start */
    dm_progress p;       /* the stage under way */
} dm_progress_meter;

static inline void dm_progress_meter_init(dm_progress_meter *m, dm_progress_fn fn, void *user)
{
    m->fn = fn;
    m->user = user;
    m->t0 = fn ? omp_get_wtime() : 0;
    m->p = (dm_progress){-1, "", "", 0, 0, 0, 1};
}

/* Report under the meter's lock (one report at a time, whatever thread). */
static inline void dm_progress_send_(dm_progress_meter *m)
{
    m->p.seconds = omp_get_wtime() - m->t0;
    m->fn(m->user, &m->p);
}

/* A stage of `total` units begins (reported with done 0); total < 1: the
 * stage has no work and nothing is reported until the next one. */
static inline void dm_progress_begin(dm_progress_meter *m, const char *stage, const char *unit,
                                     long total)
{
    if (!m->fn)
        return;
#pragma omp critical(dm_progress)
    {
        m->p = (dm_progress){m->p.index + 1, stage, unit, 0, total, 0, total < 1};
        if (total >= 1)
            dm_progress_send_(m);
    }
}

/* n more units of the stage done, from any thread (n = 0: the same count,
 * reported again as time passes); never beyond the total. */
static inline void dm_progress_add(dm_progress_meter *m, long n)
{
    if (!m->fn)
        return;
#pragma omp critical(dm_progress)
    if (!m->p.final) {
        m->p.done = m->p.done + n < m->p.total ? m->p.done + n : m->p.total;
        dm_progress_send_(m);
    }
}

/* The stage is over: every unit done (work found unnecessary counts as
 * done), reported with `final`. */
static inline void dm_progress_end(dm_progress_meter *m)
{
    if (!m->fn)
        return;
#pragma omp critical(dm_progress)
    if (!m->p.final) {
        m->p.done = m->p.total;
        m->p.final = 1;
        dm_progress_send_(m);
    }
}

#endif
