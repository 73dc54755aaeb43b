/* Progress of named phases (pf/base.h): the one place a computation hands its progress on. */
#include <pf/base.h>

void pf_progress_post(const pf_progress_hook *h, const char *phase, int64_t done, int64_t total)
{
    if (!h || !h->fn)
        return;
    pf_progress_event ev = {.phase = phase, .done = done, .total = total};
    h->fn(h->user, &ev);
}
