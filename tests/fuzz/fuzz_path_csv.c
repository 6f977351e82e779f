/* Fuzz target: trajectory sample files t,x,y,z (dm_traj_make on FILE.csv):
 * the input is written to a temporary .csv file and read back.
 * Properties: errors name the file; a path that is made has a finite
 * duration > 0 and finite motion at its start, middle and end. */
#include "fuzz.h"

#include <math.h>

#include "dm_trajectory.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[300];
    snprintf(path, sizeof path, "%s/path.csv", fuzz_tmpdir());
    fuzz_write_file(path, data, size);
    dm_trajectory tr;
    dm_error err;
    int rc = dm_traj_make(path, NULL, &tr, &err);
    FUZZ_CHECK(rc == DM_OK || ((rc == DM_EINVAL || rc == DM_ENUMERIC) && strstr(err.msg, path)),
               "status %d, message without the file name: %s", rc, err.msg);
    if (rc == DM_OK) {
        FUZZ_CHECK(isfinite(tr.duration_s) && tr.duration_s > 0, "duration %g", tr.duration_s);
        const double ts[3] = {0, tr.duration_s / 2, tr.duration_s};
        for (int i = 0; i < 3; i++) {
            double P[3], v[3], a[3];
            dm_traj_eval(&tr, ts[i], P, v, a);
            for (int k = 0; k < 3; k++)
                FUZZ_CHECK(isfinite(P[k]) && isfinite(v[k]) && isfinite(a[k]),
                           "t = %g: P %g v %g a %g", ts[i], P[k], v[k], a[k]);
        }
        dm_traj_free(&tr);
    }
    remove(path);
    return 0;
}
