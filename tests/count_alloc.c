/* An LD_PRELOAD shim that counts every heap allocation of a process, in
 * every library (OpenBLAS, LAPACKE, SUNDIALS, libgomp, libc's stdio), for
 * tests/alloc_tests.sh. At exit it writes the count to the file named by
 * DM_ALLOC_REPORT. It forwards to glibc's own entry points, so it needs no
 * dlsym (which allocates) and cannot be combined with a sanitizer's
 * allocator. */
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>

void *__libc_malloc(size_t n);
void *__libc_calloc(size_t m, size_t n);
void *__libc_realloc(void *p, size_t n);
void *__libc_memalign(size_t align, size_t n);

static atomic_long count;

void *malloc(size_t n)
{
    atomic_fetch_add(&count, 1);
    return __libc_malloc(n);
}

void *calloc(size_t m, size_t n)
{
    atomic_fetch_add(&count, 1);
    return __libc_calloc(m, n);
}

void *realloc(void *p, size_t n)
{
    atomic_fetch_add(&count, 1);
    return __libc_realloc(p, n);
}

int posix_memalign(void **p, size_t align, size_t n)
{
    atomic_fetch_add(&count, 1);
    *p = __libc_memalign(align, n);
    return *p ? 0 : 12; /* ENOMEM */
}

__attribute__((destructor)) static void report(void)
{
    const char *path = getenv("DM_ALLOC_REPORT");
    FILE *f = path ? fopen(path, "w") : NULL;
    if (f) {
        fprintf(f, "%ld\n", (long)atomic_load(&count));
        fclose(f);
    }
}
