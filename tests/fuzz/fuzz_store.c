/* Fuzz target: what `deltamap info` and a sweep's resume read from disk —
 * a store's metadata (dm_store_read_metadata: the group's and each
 * array's zarr.json) and its chunk files (dm_store_read_chunk) — by
 * running `deltamap info` (dm_cli_info) on a store made from the input.
 *
 * Input: an archive of files, each introduced by a line "%%% RELPATH"
 * (the bytes up to the next such line are its content; RELPATH made of
 * [A-Za-z0-9_./-] without "..", e.g. "zarr.json", "status/zarr.json",
 * "status/c/0/0/0/0"), written below a private directory. The seeds are
 * small stores written by `deltamap sweep` (tests/fuzz/store/).
 * Properties: info returns 0 (store whole), 5 (i/o: unreadable or
 * corrupt) or 2 (not a deltamap store), never anything else; and
 * dm_store_read_metadata agrees with it about the metadata. */
#define _GNU_SOURCE /* memmem */
#include "fuzz.h"

#include <sys/stat.h>

#include "cli_impl.h"
#include "dm_store.h"

static int safe_path(const char *p, size_t n)
{
    if (n == 0 || n > 200 || p[0] == '/')
        return 0;
    for (size_t i = 0; i < n; i++) {
        char c = p[i];
        int ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                 c == '_' || c == '.' || c == '/' || c == '-';
        if (!ok || (c == '.' && i + 1 < n && p[i + 1] == '.'))
            return 0;
    }
    return p[n - 1] != '/';
}

static void make_parents(char *path)
{
    for (char *s = strchr(path + 1, '/'); s; s = strchr(s + 1, '/')) {
        *s = '\0';
        mkdir(path, 0777);
        *s = '/';
    }
}

/* Write the archive below dir; returns the number of files written. */
static int unpack(const uint8_t *data, size_t size, const char *dir)
{
    static const char mark[] = "%%% ";
    const char *p = (const char *)data, *end = p + size;
    int files = 0;
    while (p < end) {
        if ((size_t)(end - p) < 4 || memcmp(p, mark, 4)) { /* skip to the next marker */
            const char *nl = memchr(p, '\n', (size_t)(end - p));
            p = nl ? nl + 1 : end;
            continue;
        }
        const char *name = p + 4, *nl = memchr(name, '\n', (size_t)(end - name));
        if (!nl)
            break;
        /* content runs to the next "\n%%% " (or the end, less a final newline) */
        const char *body = nl + 1;
        const char *next = memmem(body, (size_t)(end - body), "\n%%% ", 5);
        if (!next)
            next = end > body && end[-1] == '\n' ? end - 1 : end;
        size_t nlen = (size_t)(nl - name);
        if (safe_path(name, nlen)) {
            char path[512];
            snprintf(path, sizeof path, "%s/%.*s", dir, (int)nlen, name);
            make_parents(path);
            /* a path through a file, or onto a directory, is skipped */
            FILE *f = fopen(path, "wb");
            if (f) {
                size_t n = (size_t)(next - body);
                if (fwrite(body, 1, n, f) != n)
                    abort();
                fclose(f);
                files++;
            }
        }
        p = next < end ? next + 1 : end;
    }
    return files;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int quiet;
    if (!quiet) { /* info prints its report: not wanted while fuzzing */
        if (!freopen("/dev/null", "w", stdout))
            abort();
        quiet = 1;
    }
    char dir[300];
    snprintf(dir, sizeof dir, "%s/store", fuzz_tmpdir());
    mkdir(dir, 0777);
    fuzz_clear_dir(dir);
    unpack(data, size, dir);

    dm_store st;
    dm_error err;
    int meta = dm_store_read_metadata(dir, &st, &err);
    FUZZ_CHECK(meta == DM_OK || meta == DM_EIO || meta == DM_EINVAL,
               "metadata status %d: %s", meta, err.msg);
    long chunks = 0; /* info reads every chunk the metadata declares: its time is
                        proportional to that by design, so large ones are not run */
    if (meta == DM_OK) {
        for (int a = 0; a < st.narr; a++) {
            long n = 1;
            for (int d = 0; d < st.arr[a].ndim && n <= 4096; d++)
                n *= (long)((st.arr[a].shape[d] + st.arr[a].chunk[d] - 1) / st.arr[a].chunk[d]);
            chunks += n;
        }
        for (int a = 0; a < st.narr; a++) { /* what a resume does with a chunk */
            const dm_array_spec *s = &st.arr[a];
            FUZZ_CHECK(s->ndim >= 1 && s->ndim <= DM_STORE_MAXDIM, "ndim %d", s->ndim);
            size_t bytes = dm_store_chunk_elems(&st, a) * dm_dtype_size(s->dtype);
            void *buf = malloc(bytes ? bytes : 1);
            FUZZ_CHECK(buf, "chunk of %zu bytes", bytes);
            int64_t c[DM_STORE_MAXDIM] = {0};
            int missing;
            int rc = dm_store_read_chunk(&st, a, c, buf, &missing, &err);
            FUZZ_CHECK(rc == DM_OK || rc == DM_EIO, "chunk status %d", rc);
            free(buf);
        }
        dm_store_release(&st);
    }
    if (chunks > 4096)
        return 0;
    char *argv[] = {"info", dir, NULL};
    int rc = dm_cli_info(2, argv);
    FUZZ_CHECK(rc == 0 || rc == DM_EIO || rc == DM_EINVAL, "info exit %d", rc);
    FUZZ_CHECK(meta == DM_OK || rc != 0, "info accepts what the metadata reader refuses");
    fflush(stdout);
    return 0;
}
