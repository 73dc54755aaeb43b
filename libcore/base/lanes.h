/* Four lanes of doubles (GCC's vector extensions) for the kernels that run a clone built for AVX2
 * where the machine has it. The order of every sum is the source's whatever the machine's vector
 * width, so the bits are the same on any x86-64 (no FMA: -ffp-contract=off). Internal header. */
#ifndef PF_BASE_LANES_H
#define PF_BASE_LANES_H

/* The lanes live in registers of static functions, never in a call across objects: GCC's note on
 * the ABI of 32-byte vectors without AVX does not apply. */
#pragma GCC diagnostic ignored "-Wpsabi"
typedef double lanes_d __attribute__((vector_size(32)));

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) &&                             \
    !defined(__SANITIZE_ADDRESS__)
#define PF_KERNEL_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define PF_KERNEL_CLONES
#endif

#endif
