/* dm_work — what a run implies, judged before any of it.
 *
 * Every command that can run for hours or fill memory or a file system
 * estimates its work first (the estimates are the modules': dm_predict,
 * dm_integ, dm_tolerance, the sweep) and asks dm_work_check, which refuses
 * it with DM_ETOOBIG beyond the caller's limits unless forced (the CLI's
 * one spelling of that, on every command: --force-long). The CLI
 * recognises the refusal by its status, not by its message. */
#ifndef DM_WORK_H
#define DM_WORK_H

#include "dm_error.h"

/* An amount of work, or the most accepted of it. A limit's field that is
 * 0 judges nothing of that kind. */
typedef struct dm_work {
    double seconds; /* estimated wall time (on the run's threads) */
    double bytes;   /* memory held at once */
    double files;   /* files written */
} dm_work;

/* The measurement commands' and a trajectory's limits (4 hours, 2 GB); a
 * tolerance Monte Carlo's is 1 hour on one thread, a sweep's 24 hours and
 * 2e6 chunk files (dm_tolerance.h, dm_sweep.h). */
#define DM_WORK_MAX_SECONDS (4 * 3600.0)
#define DM_WORK_MAX_BYTES 2e9
#define DM_WORK_LIMIT ((dm_work){DM_WORK_MAX_SECONDS, DM_WORK_MAX_BYTES, 0})

/* DM_OK when force_long or `need` is within `limit` in every judged kind
 * (a NaN estimate is never within it); else DM_ETOOBIG with "WHAT: about
 * H hours of work (the limit is L)[ and G GB of memory (the limit is
 * M)][ and F files (the limit is N)]: HINT, or force it", naming each kind
 * exceeded (the hours, the gigabytes or the files alone when only that
 * one is). */
int dm_work_check(const char *what, dm_work need, dm_work limit, const char *hint,
                  int force_long, dm_error *err);

#endif
