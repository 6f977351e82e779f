/* dm_isa — which instruction-set path the kernels run: the block-arrow
 * products and solves (src/model/arrow_kernels.c) are built once per path
 * the compiler's target has, each with vectors of its own registers' width
 * (SSE2 and NEON 2 doubles, AVX2 4, AVX-512 8), and one of them is used for
 * the whole process.
 *
 * Every path gives the same bits: no path contracts a multiply and an add
 * (none is built with FMA, and C11 mode turns contraction off), every
 * column of a block undergoes the same operations in the same order
 * whatever the vector width, and no kernel reorders a sum. A sweep's store
 * is byte-identical across paths (tests/cli_tests.sh); only speed differs.
 *
 * The path is the best the CPU has, unless DELTAMAP_ISA names another
 * (default, avx2, avx512): measurement and tests run one machine's every
 * path that way. It is chosen once, at the first kernel call, and never
 * changes after: a run's results cannot depend on when a path was chosen. */
#ifndef DM_ISA_H
#define DM_ISA_H

#include <stddef.h>

#include "dm_error.h"

typedef enum dm_isa {
    DM_ISA_DEFAULT, /* the target's baseline: SSE2 on x86-64, NEON on aarch64 */
    DM_ISA_AVX2,
    DM_ISA_AVX512,
    DM_ISA_COUNT
} dm_isa;

/* "default", "avx2", "avx512" */
const char *dm_isa_name(dm_isa isa);

/* What the path's vectors are, for people: "SSE2, 2 doubles", ... */
const char *dm_isa_describe(dm_isa isa);

/* Whether this build has the path and this CPU can run it. */
int dm_isa_available(dm_isa isa);

/* The fastest available path. */
dm_isa dm_isa_best(void);

/* The path DELTAMAP_ISA asks for (the best when unset or empty); an
 * unknown name, or a path this build or CPU lacks, is an error that says
 * which paths there are. */
int dm_isa_from_env(dm_isa *isa, dm_error *err);

/* The path in use, chosen once per process from DELTAMAP_ISA (the best
 * when that is unset or not usable: programs that honour the variable
 * check it first with dm_isa_from_env and refuse a bad one). */
dm_isa dm_isa_active(void);

/* In a *_kernels.c, the name of its table for the path it is built for:
 * DM_ISA_TABLE(dm_arrow_kernels_) is dm_arrow_kernels_avx2 in the build
 * with -DDM_ISA_PATH=avx2 (the Makefile's), ..._default without it. */
#ifndef DM_ISA_PATH
#define DM_ISA_PATH default
#endif
#define DM_ISA_PASTE_(prefix, path) prefix##path
#define DM_ISA_NAME_(prefix, path) DM_ISA_PASTE_(prefix, path)
#define DM_ISA_TABLE(prefix) DM_ISA_NAME_(prefix, DM_ISA_PATH)

/* A module's tables, one a path this build has (in its private header):
 * DM_ISA_DECLARE(dm_arrow_kernels, dm_arrow_kernels_) declares
 * dm_arrow_kernels_default and, on x86-64, ..._avx2 and ..._avx512; and
 * DM_ISA_SELECT(dm_arrow_kernels_, isa) is the address of path isa's
 * (isa one dm_isa_available admits). */
#if defined(__x86_64__)
#define DM_ISA_DECLARE(type, prefix)                                                              \
    extern const type prefix##default, prefix##avx2, prefix##avx512
#define DM_ISA_SELECT(prefix, isa)                                                                \
    ((isa) == DM_ISA_AVX512 ? &prefix##avx512 : (isa) == DM_ISA_AVX2 ? &prefix##avx2              \
                                                                     : &prefix##default)
#else
#define DM_ISA_DECLARE(type, prefix) extern const type prefix##default
#define DM_ISA_SELECT(prefix, isa) ((void)(isa), &prefix##default)
#endif

/* The CPU's model name ("AMD EPYC 9R14", ...), or the architecture when the
 * system does not say; into buf, always terminated. */
void dm_isa_cpu_model(char *buf, size_t size);

#endif
