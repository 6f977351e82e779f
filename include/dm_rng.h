/* dm_rng — a small seeded random number generator (splitmix64): uniform
 * in [0, 1) and standard normal. The state is a plain value owned by its
 * caller (one per thread or per draw sequence), so results depend on the
 * seed alone. */
#ifndef DM_RNG_H
#define DM_RNG_H

#include <stdint.h>

typedef struct dm_rng {
    uint64_t state;
} dm_rng;

double dm_rng_uniform(dm_rng *rng);
double dm_rng_normal(dm_rng *rng);

#endif
