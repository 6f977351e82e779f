/* Fuzz target: measured-data CSV files (dm_dataset_read; the formats of
 * MEASURED.md): the input is written to a temporary file and read.
 * Properties: errors name the file; a dataset that is read has samples
 * with finite values, and what dm_dataset_write makes of it reads back
 * with the same kind and number of samples (surveys; tracker times are
 * written with 9 digits, enough for sampling at 1 ms, so a fuzzed record
 * whose times differ in the 10th digit does not read back). */
#include "fuzz.h"

#include <math.h>

#include "dm_measure.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[300], back[300];
    snprintf(path, sizeof path, "%s/measured.csv", fuzz_tmpdir());
    snprintf(back, sizeof back, "%s/written.csv", fuzz_tmpdir());
    fuzz_write_file(path, data, size);
    dm_dataset d, again;
    dm_error err;
    int rc = dm_dataset_read(path, &d, &err);
    FUZZ_CHECK(rc == DM_OK || (rc == DM_EINVAL && strstr(err.msg, path)),
               "status %d, message without the file name: %s", rc, err.msg);
    if (rc == DM_OK) {
        FUZZ_CHECK(d.n > 0 && d.npose > 0 && d.npose <= d.n, "n %d npose %d", d.n, d.npose);
        for (int i = 0; i < d.n; i++)
            FUZZ_CHECK(isfinite(d.s[i].value) && isfinite(d.s[i].sigma) && d.s[i].sigma >= 0 &&
                           d.s[i].pose_id >= 0 && d.s[i].pose_id < d.npose,
                       "sample %d (line %d)", i, d.s[i].line);
        FILE *f = d.kind == DM_DATA_TRACKER ? NULL : fopen(back, "w");
        if (!f) {
            dm_dataset_free(&d);
            remove(path);
            return 0;
        }
        FUZZ_CHECK(dm_dataset_write(&d, f) == DM_OK && !fclose(f), "writing %s", back);
        rc = dm_dataset_read(back, &again, &err);
        FUZZ_CHECK(rc == DM_OK, "written data do not read back: %s", err.msg);
        FUZZ_CHECK(again.kind == d.kind && again.n == d.n, "read back: kind %d n %d, was %d %d",
                   again.kind, again.n, d.kind, d.n);
        dm_dataset_free(&again);
        dm_dataset_free(&d);
        remove(back);
    }
    remove(path);
    return 0;
}
