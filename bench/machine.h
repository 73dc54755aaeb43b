/* What a benchmark ran on, for the comment line that heads its CSV: results from different machines
 * or a busy one must be told apart when they are compared. */
#ifndef PF_BENCH_MACHINE_H
#define PF_BENCH_MACHINE_H

#include <stddef.h>

/* "cpu: MODEL, N cores online, load average L at start; compiler: VERSION" into out[n]. */
void bench_describe_machine(char *out, size_t n);

/* CPU seconds this process has used (all threads), from a monotonic per-process clock: on a
 * machine other jobs keep busy, the difference over a single-threaded call is far closer to its
 * cost on an idle machine than the wall clock (which also counts the time the call waited for a
 * core). */
double bench_cpu_seconds(void);

#endif
