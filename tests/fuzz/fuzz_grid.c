/* Fuzz target: sweep grid specs (dm_grid_parse).
 * Properties: a grid that parses has at most DM_GRID_MAX_POINTS points,
 * finite coordinates, and its canonical text (dm_grid_format) parses back
 * to the same grid. */
#include "fuzz.h"

#include <math.h>

#include "dm_sweep.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *spec = fuzz_cstring(data, size);
    if (!spec)
        return 0;
    dm_grid g, again;
    dm_error err;
    int rc = dm_grid_parse(spec, &g, &err);
    FUZZ_CHECK(rc == DM_OK || rc == DM_EINVAL, "unexpected status %d: %s", rc, err.msg);
    if (rc == DM_OK) {
        long n = dm_grid_points(&g);
        FUZZ_CHECK(n >= 1 && n <= DM_GRID_MAX_POINTS, "%ld points", n);
        for (int a = 0; a < 3; a++) {
            FUZZ_CHECK(g.axis[a].count >= 1, "axis %d count %d", a, g.axis[a].count);
            int ends[2] = {0, g.axis[a].count - 1};
            for (int e = 0; e < 2; e++)
                FUZZ_CHECK(isfinite(dm_grid_value(&g.axis[a], ends[e])), "axis %d value", a);
        }
        char text[512];
        dm_grid_format(&g, text, sizeof text);
        rc = dm_grid_parse(text, &again, &err);
        FUZZ_CHECK(rc == DM_OK, "canonical text '%s' of '%s' does not parse: %s", text, spec,
                   err.msg);
        FUZZ_CHECK(!memcmp(&g, &again, sizeof g), "'%s' -> '%s' is another grid", spec, text);
    }
    free(spec);
    return 0;
}
