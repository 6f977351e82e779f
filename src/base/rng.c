/* Random numbers for synthetic data and random designs (see dm_rng.h). */
#include "dm_rng.h"

#include <math.h>

static uint64_t splitmix64(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

double dm_rng_uniform(dm_rng *r) { return (splitmix64(&r->state) >> 11) * 0x1.0p-53; }

double dm_rng_normal(dm_rng *r)
{
    double u1 = dm_rng_uniform(r), u2 = dm_rng_uniform(r);
    return sqrt(-2.0 * log(1.0 - u1)) * cos(2 * M_PI * u2);
}
