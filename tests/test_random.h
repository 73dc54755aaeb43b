/* Deterministic random numbers for the tests: xorshift64, seeded by the caller, so that every
 * run draws the same cases; and random rotations. */
#ifndef PF_TEST_RANDOM_H
#define PF_TEST_RANDOM_H

#include <math.h>
#include <stdint.h>

#include <pf/geom.h>

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

/* A rotation from a random unit quaternion (uniform over rotations: the quaternion is drawn
 * uniformly in the unit ball, then normalised), independent of the library's code. */
static inline pf_mat3 random_rotation(rng *r)
{
    double w, x, y, z, n;
    do {
        w = uniform(r), x = uniform(r), y = uniform(r), z = uniform(r);
        n = sqrt(w * w + x * x + y * y + z * z);
    } while (n < 0.1 || n > 1);
    w /= n, x /= n, y /= n, z /= n;
    return (pf_mat3){{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                      {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                      {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
}

#endif
