/* Status names and the error context. */
#include <pf/base.h>

#include <stdio.h>
#include <string.h>

const char *pf_status_name(pf_status s)
{
    switch (s) {
    case PF_OK: return "ok";
    case PF_WARN: return "warning";
    case PF_ERR_NOMEM: return "out of memory";
    case PF_ERR_IO: return "i/o error";
    case PF_ERR_FORMAT: return "format error";
    case PF_ERR_INVALID: return "invalid input";
    case PF_ERR_NUMERIC: return "numerical failure";
    case PF_ERR_TOO_LARGE: return "too large";
    case PF_ERR_UNSUPPORTED: return "unsupported";
    }
    return "unknown status";
}

pf_status pf_error_set(pf_error *err, pf_status s, const char *src_file, int src_line,
                       const char *fmt, ...)
{
    if (!err)
        return s;
    err->status = s;
    err->src_file = src_file;
    err->src_line = src_line;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    va_end(ap);
    return s;
}

void pf_error_prefix(pf_error *err, const char *fmt, ...)
{
    if (!err)
        return;
    char prefix[PF_ERROR_MSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap);
    va_end(ap);
    /* Room for both; the result is cut to the message size, as any message is. */
    char joined[2 * PF_ERROR_MSG_MAX + 2];
    snprintf(joined, sizeof joined, "%s: %s", prefix, err->msg);
    memcpy(err->msg, joined, PF_ERROR_MSG_MAX - 1);
    err->msg[PF_ERROR_MSG_MAX - 1] = '\0';
}
