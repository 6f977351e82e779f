/* The kernels' instruction-set path (see dm_isa.h). */
#include "dm_isa.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/utsname.h>

static const char *const NAME[DM_ISA_COUNT] = {"default", "avx2", "avx512"};

const char *dm_isa_name(dm_isa isa)
{
    return isa >= 0 && isa < DM_ISA_COUNT ? NAME[isa] : "?";
}

const char *dm_isa_describe(dm_isa isa)
{
    switch (isa) {
#if defined(__aarch64__)
    case DM_ISA_DEFAULT: return "NEON, 2 doubles";
#elif defined(__x86_64__)
    case DM_ISA_DEFAULT: return "SSE2, 2 doubles";
#else
    case DM_ISA_DEFAULT: return "portable C, 2 doubles";
#endif
    case DM_ISA_AVX2: return "AVX2, 4 doubles";
    case DM_ISA_AVX512: return "AVX-512F, 8 doubles";
    default: return "?";
    }
}

int dm_isa_available(dm_isa isa)
{
    switch (isa) {
    case DM_ISA_DEFAULT: return 1;
#if defined(__x86_64__) && defined(__GNUC__)
    /* libgcc's check includes the OS's (XGETBV): the registers are saved */
    case DM_ISA_AVX2: return __builtin_cpu_supports("avx2");
    case DM_ISA_AVX512: return __builtin_cpu_supports("avx512f");
#endif
    default: return 0;
    }
}

dm_isa dm_isa_best(void)
{
    dm_isa best = DM_ISA_DEFAULT;
    for (int i = 0; i < DM_ISA_COUNT; i++)
        if (dm_isa_available((dm_isa)i))
            best = (dm_isa)i;
    return best;
}

/* "default, avx2" */
static void list_available(char *buf, size_t size)
{
    buf[0] = 0;
    for (int i = 0; i < DM_ISA_COUNT; i++)
        if (dm_isa_available((dm_isa)i))
            snprintf(buf + strlen(buf), size - strlen(buf), "%s%s", buf[0] ? ", " : "", NAME[i]);
}

int dm_isa_from_env(dm_isa *isa, dm_error *err)
{
    const char *want = getenv("DELTAMAP_ISA");
    *isa = dm_isa_best();
    if (!want || !*want)
        return DM_OK;
    char have[64];
    list_available(have, sizeof have);
    for (int i = 0; i < DM_ISA_COUNT; i++) {
        if (strcmp(want, NAME[i]))
            continue;
        if (!dm_isa_available((dm_isa)i))
            return dm_fail(err, DM_EINVAL,
                           "DELTAMAP_ISA=%s: this CPU or build has no %s path (available: %s)",
                           want, NAME[i], have);
        *isa = (dm_isa)i;
        return DM_OK;
    }
    return dm_fail(err, DM_EINVAL,
                   "DELTAMAP_ISA=%s: unknown path (default, avx2 or avx512; available here: %s)",
                   want, have);
}

/* Chosen once per process (pthread_once: the first kernel call may come
 * from any thread), read-only after. */
static pthread_once_t chosen_once = PTHREAD_ONCE_INIT;
static dm_isa chosen;

static void choose(void)
{
    if (dm_isa_from_env(&chosen, NULL))
        chosen = dm_isa_best();
}

dm_isa dm_isa_active(void)
{
    pthread_once(&chosen_once, choose);
    return chosen;
}

void dm_isa_cpu_model(char *buf, size_t size)
{
    struct utsname u;
    snprintf(buf, size, "%s", uname(&u) ? "unknown CPU" : u.machine);
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[256];
    while (fgets(line, sizeof line, f)) {
        char *colon = strchr(line, ':');
        if (strncmp(line, "model name", 10) || !colon)
            continue;
        colon += 1 + strspn(colon + 1, " \t");
        colon[strcspn(colon, "\n")] = 0;
        snprintf(buf, size, "%s", colon);
        break;
    }
    fclose(f);
}
