/* deltamap with a failing allocator: the test-only hook of fault_tests.sh.
 *
 * Linked with -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc, so every
 * allocation the library and the command line make goes through the
 * counters below (jansson's too, via json_set_alloc_funcs); the library
 * itself is unchanged. Environment:
 *   DM_FAIL_ALLOC=N     the N-th allocation (1 = the first) and every later
 *                       one fail, as when memory is exhausted (0 or unset:
 *                       none fails)
 *   DM_FAIL_REPORT=F    at exit, write "ALLOCATIONS INJECTED" to file F:
 *                       how many allocations were asked for, and 1 if
 *                       one was refused
 * Allocations made inside other shared libraries (libc's stdio, OpenBLAS,
 * SUNDIALS, libgomp) are not counted. */
#include <jansson.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>

#include "dm_cli.h"

void *__real_malloc(size_t n);
void *__real_calloc(size_t m, size_t n);
void *__real_realloc(void *p, size_t n);

static long fail_at;
static atomic_long count;
static atomic_int injected;

static int refuse(void)
{
    long c = atomic_fetch_add(&count, 1) + 1;
    if (fail_at > 0 && c >= fail_at) {
        atomic_store(&injected, 1);
        return 1;
    }
    return 0;
}

void *__wrap_malloc(size_t n) { return refuse() ? NULL : __real_malloc(n); }
void *__wrap_calloc(size_t m, size_t n) { return refuse() ? NULL : __real_calloc(m, n); }
void *__wrap_realloc(void *p, size_t n) { return refuse() ? NULL : __real_realloc(p, n); }

static void *json_alloc(size_t n) { return __wrap_malloc(n); }

static void report(void)
{
    const char *path = getenv("DM_FAIL_REPORT");
    FILE *f = path ? fopen(path, "w") : NULL;
    if (f) {
        fprintf(f, "%ld %d\n", (long)atomic_load(&count), atomic_load(&injected));
        fclose(f);
    }
}

int main(int argc, char **argv)
{
    const char *n = getenv("DM_FAIL_ALLOC");
    fail_at = n ? atol(n) : 0;
    json_set_alloc_funcs(json_alloc, free);
    atexit(report);
    int rc = dm_cli_main(argc, argv);
    fflush(stdout);
    return rc;
}
