/* dm_clones — one function built for several instruction sets, the one the
 * CPU has chosen when the program loads (GCC's target_clones; elsewhere a
 * plain function). None of the targets enables FMA, so no clone contracts
 * a multiply and an add: every clone gives the same bits (a sweep's store
 * measured byte-identical with the AVX2 and the AVX-512 clone). For the
 * small fixed-width loops of the block kernels (src/model/arrow.c) and the
 * standard moves (src/responses/standard_move.c). */
#ifndef DM_CLONES_H
#define DM_CLONES_H

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DM_VECTOR_CLONES __attribute__((target_clones("default", "avx2", "avx512f")))
#else
#define DM_VECTOR_CLONES
#endif

#endif
