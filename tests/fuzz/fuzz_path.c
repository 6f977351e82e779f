/* Fuzz target: trajectory path specs (dm_traj_make: presets, circle:,
 * p2p:, pick:). Only the spec is built and evaluated, never integrated
 * (integration time grows with the duration by design; its limits are
 * checked where the steps are counted).
 * Properties: a path that is made has a finite duration > 0 and finite
 * position, velocity and acceleration at its start, middle and end. */
#include "fuzz.h"

#include <math.h>

#include "dm_trajectory.h"

static dm_robot robot;
static int have_robot;

static void check_path(const dm_trajectory *tr, const char *spec)
{
    FUZZ_CHECK(isfinite(tr->duration_s) && tr->duration_s > 0, "'%s': duration %g", spec,
               tr->duration_s);
    const double ts[3] = {0, tr->duration_s / 2, tr->duration_s};
    for (int i = 0; i < 3; i++) {
        double P[3], v[3], a[3];
        dm_traj_eval(tr, ts[i], P, v, a);
        for (int k = 0; k < 3; k++)
            FUZZ_CHECK(isfinite(P[k]) && isfinite(v[k]) && isfinite(a[k]),
                       "'%s' at t = %g: P %g v %g a %g", spec, ts[i], P[k], v[k], a[k]);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!have_robot) {
        dm_error err;
        FUZZ_CHECK(dm_robot_load("chen2018", &robot, &err) == DM_OK, "%s", err.msg);
        have_robot = 1;
    }
    char *spec = fuzz_cstring(data, size);
    if (!spec)
        return 0;
    size_t n = strlen(spec);
    if (n >= 4 && !strcmp(spec + n - 4, ".csv")) { /* a file name: fuzz_path_csv's job */
        free(spec);
        return 0;
    }
    for (int with_robot = 0; with_robot < 2; with_robot++) {
        dm_trajectory tr;
        dm_error err;
        int rc = dm_traj_make(spec, with_robot ? &robot : NULL, &tr, &err);
        FUZZ_CHECK(rc == DM_OK || rc == DM_EINVAL, "unexpected status %d: %s", rc, err.msg);
        if (rc == DM_OK) {
            check_path(&tr, spec);
            dm_traj_free(&tr);
        }
    }
    free(spec);
    return 0;
}
