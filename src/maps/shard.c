/* The tile partition of dm_shard.h. */
#include "dm_shard.h"

#include <stdint.h>

/* 2^64 / phi: the fractional part of g * phi, in 64-bit fixed point, is
 * g * PHI64 modulo 2^64. */
#define PHI64 0x9E3779B97F4A7C15ull

long dm_shard_of(long tile, long count)
{
    if (count <= 1 || tile < 0)
        return 0;
    uint64_t run = (uint64_t)tile / (uint64_t)count;
    uint64_t frac32 = (run * PHI64) >> 32;                   /* frac(run phi) * 2^32 */
    uint64_t offset = (frac32 * (uint64_t)count) >> 32;      /* in 0..count-1 */
    return (long)(((uint64_t)tile % (uint64_t)count + offset) % (uint64_t)count);
}
