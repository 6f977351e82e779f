/* Shared by the fuzz targets (tests/fuzz/fuzz_*.c).
 *
 * Each target defines LLVMFuzzerTestOneInput. `make fuzz` links it with
 * libFuzzer (clang, -fsanitize=fuzzer,address,undefined); `make test`
 * links the same file with replay.c (any C compiler, no libFuzzer) and
 * runs it over every file of the target's corpus, tests/fuzz/TARGET/.
 *
 * A target fails (abort(), which libFuzzer and the replay driver report
 * with the input) when the library crashes, when a sanitizer objects, or
 * when a property the library promises does not hold: FUZZ_CHECK. */
#ifndef DM_FUZZ_H
#define DM_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define FUZZ_CHECK(cond, ...)                                                         \
    do {                                                                              \
        if (!(cond)) {                                                                \
            fprintf(stderr, "fuzz property failed at %s:%d: %s\n  ", __FILE__,        \
                    __LINE__, #cond);                                                 \
            fprintf(stderr, __VA_ARGS__);                                             \
            fputc('\n', stderr);                                                      \
            abort();                                                                  \
        }                                                                             \
    } while (0)

/* The input as a NUL-terminated string (NULL when it holds a NUL byte:
 * the callers take C strings, which cannot). Free with free(). */
static inline char *fuzz_cstring(const uint8_t *data, size_t size)
{
    if (memchr(data, '\0', size))
        return NULL;
    char *s = malloc(size + 1);
    if (!s)
        abort();
    memcpy(s, data, size);
    s[size] = '\0';
    return s;
}

/* A private directory for the files a target writes (made once). */
const char *fuzz_tmpdir(void);

/* Write bytes to a file (abort on failure: the machine, not the input). */
void fuzz_write_file(const char *path, const void *data, size_t size);

/* Remove everything below dir (dir itself stays). */
void fuzz_clear_dir(const char *dir);

#endif
