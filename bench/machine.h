/* What a benchmark ran on, for the comment line that heads its CSV: results from different machines
 * or a busy one must be told apart when they are compared. */
#ifndef PF_BENCH_MACHINE_H
#define PF_BENCH_MACHINE_H

#include <stddef.h>

/* "cpu: MODEL, N cores online, load average L at start; compiler: VERSION" into out[n]. */
void bench_describe_machine(char *out, size_t n);

#endif
