/* What a map store holds: which tiles are complete and valid, the points'
 * statuses (see dm_sweep.h). Read-only; safe beside running sweeps. */
#include <stdlib.h>
#include <string.h>

#include "sweep_impl.h"

/* Read and verify every chunk of tile t; count its point statuses. */
static int census_tile(const dm_store *st, int status, long t, dm_sweep_census *tc, void *buf,
                       void (*on_corrupt)(void *, const char *), void *user)
{
    const dm_array_spec *sa = &st->arr[status];
    int64_t c[4] = {t / (tc->nt[1] * tc->nt[2]), (t / tc->nt[2]) % tc->nt[1], t % tc->nt[2], 0};
    int ok = 1;
    dm_error err;
    for (int a = 0; a < st->narr; a++) {
        if (st->arr[a].ndim < 3)
            continue; /* coordinates */
        int missing;
        if (dm_store_read_chunk(st, a, c, buf, &missing, &err)) {
            ok = 0;
            missing ? tc->missing_chunks++ : tc->corrupt++;
            if (!missing && on_corrupt)
                on_corrupt(user, err.msg);
            continue;
        }
        if (a != status)
            continue;
        const unsigned char *s = buf;
        for (int i0 = 0; i0 < sa->chunk[0]; i0++)
            for (int i1 = 0; i1 < sa->chunk[1]; i1++)
                for (int i2 = 0; i2 < sa->chunk[2]; i2++)
                    if (c[0] * sa->chunk[0] + i0 < sa->shape[0] &&
                        c[1] * sa->chunk[1] + i1 < sa->shape[1] &&
                        c[2] * sa->chunk[2] + i2 < sa->shape[2])
                        tc->counts[s[((size_t)i0 * sa->chunk[1] + i1) * sa->chunk[2] + i2]]++;
    }
    return ok;
}

static int status_array(const dm_store *st)
{
    for (int a = 0; a < st->narr; a++)
        if (!strcmp(st->arr[a].name, "status"))
            return st->arr[a].ndim >= 3 && st->arr[a].dtype == DM_DTYPE_UINT8 ? a : -1;
    return -1;
}

int dm_sweep_census_take(const dm_store *st, dm_sweep_census *tc,
                         void (*on_corrupt)(void *user, const char *msg), void *user,
                         dm_error *err)
{
    memset(tc, 0, sizeof *tc);
    int status = status_array(st);
    if (status < 0)
        return dm_fail(err, DM_EINVAL, "%s: no status array (uint8, x, y, z): not a map store",
                       st->path);
    /* tiles: the status array's chunk grid (the data arrays share it) */
    const dm_array_spec *sa = &st->arr[status];
    tc->tiles = 1;
    for (int d = 0; d < 3; d++) {
        tc->nt[d] = (sa->shape[d] + sa->chunk[d] - 1) / sa->chunk[d];
        tc->tiles *= tc->nt[d];
    }
    size_t maxbytes = 0;
    for (int a = 0; a < st->narr; a++)
        if (dm_store_chunk_elems(st, a) * dm_dtype_size(st->arr[a].dtype) > maxbytes)
            maxbytes = dm_store_chunk_elems(st, a) * dm_dtype_size(st->arr[a].dtype);
    unsigned char *buf = malloc(maxbytes);
    tc->done = calloc((size_t)tc->tiles, 1);
    if (!buf || !tc->done) {
        free(buf);
        dm_sweep_census_free(tc);
        return dm_fail(err, DM_ENOMEM, "out of memory");
    }
    for (long t = 0; t < tc->tiles; t++) {
        tc->done[t] = (char)census_tile(st, status, t, tc, buf, on_corrupt, user);
        tc->complete += tc->done[t];
    }
    free(buf);
    return DM_OK;
}

void dm_sweep_census_free(dm_sweep_census *tc)
{
    free(tc->done);
    tc->done = NULL;
}
