/* Deterministic random numbers for the tests: xorshift64, seeded by the caller, so that every
 * run draws the same cases. */
#ifndef PF_TEST_RANDOM_H
#define PF_TEST_RANDOM_H

#include <stdint.h>

typedef struct rng {
    uint64_t s; /* non-zero */
} rng;

/* Uniform in [0, 1). */
static inline double uniform01(rng *r)
{
    r->s ^= r->s << 13;
    r->s ^= r->s >> 7;
    r->s ^= r->s << 17;
    return (double)(r->s >> 11) * (1.0 / 9007199254740992.0);
}

/* Uniform in [-1, 1). */
static inline double uniform(rng *r)
{
    return 2 * uniform01(r) - 1;
}

#endif
