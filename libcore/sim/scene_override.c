/* Command-line overrides of common scene keys (pf_scene_override, pf/sim.h), by the same value
 * rules as the file (scene_values.h). */
#include <pf/sim.h>

#include <errno.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene_values.h"

#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
static pf_status
override_fail(pf_error *err, const char *key, const char *value, const char *fmt, ...)
{
    char reason[PF_ERROR_MSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(reason, sizeof reason, fmt, ap);
    va_end(ap);
    return pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__, "%s: %s, got '%.64s'", key, reason,
                        value ? value : "");
}

/* The whole of value as a number in scene_range rg (strtod: decimal or hexadecimal floating point).
 */
static pf_status override_number(const char *key, const char *value, scene_range rg, double *out,
                                 pf_error *err)
{
    const char *what = pf_scene_range_is_integer(rg) ? "an integer" : "a number";
    if (!value || !*value || strchr(" \t\r\n\f\v", value[0]))
        return override_fail(err, key, value, "must be %s", what);
    /* Overflow gives an infinity and underflow a tiny or zero value: pf_scene_in_range judges both. */
    char *end = NULL;
    double v = strtod(value, &end);
    if (*end != '\0')
        return override_fail(err, key, value, "must be %s", what);
    if (!pf_scene_in_range(rg, v))
        return override_fail(err, key, value, "%s", pf_scene_range_text(rg));
    *out = v;
    return PF_OK;
}

/* The whole of value as a decimal integer in scene_range rg (strtol, no fractional part). */
static pf_status override_int(const char *key, const char *value, scene_range rg, int32_t *out,
                              pf_error *err)
{
    if (!value || !*value || strchr(" \t\r\n\f\v", value[0]))
        return override_fail(err, key, value, "must be an integer");
    char *end = NULL;
    errno = 0;
    long v = strtol(value, &end, 10);
    if (*end != '\0')
        return override_fail(err, key, value, "must be an integer");
    if (errno == ERANGE || v < INT32_MIN || v > INT32_MAX || !pf_scene_in_range(rg, (double)v))
        return override_fail(err, key, value, "%s", pf_scene_range_text(rg));
    *out = (int32_t)v;
    return PF_OK;
}

/* true / false; NULL or empty means true (a bare --static). */
static pf_status override_bool(const char *key, const char *value, bool *out, pf_error *err)
{
    if (!value || !*value || !strcmp(value, "true"))
        *out = true;
    else if (!strcmp(value, "false"))
        *out = false;
    else
        return override_fail(err, key, value, "must be true or false");
    return PF_OK;
}

pf_status pf_scene_override(pf_scene *s, const char *key, const char *value, pf_error *err)
{
    PF_CHECK(key, err, PF_ERR_INVALID, "override without a key");
    if (!strcmp(key, "method")) {
        if (!value || !pf_scene_parse_method_name(value, &s->method))
            return override_fail(err, key, value, "must be dg or cg");
        return PF_OK;
    }
    if (!strcmp(key, "flux")) {
        if (!value || !pf_scene_parse_flux_name(value, &s->flux))
            return override_fail(err, key, value, "must be ip or bz");
        return PF_OK;
    }
    if (!strcmp(key, "mass")) {
        if (!value || !pf_scene_parse_mass_name(value, &s->mass))
            return override_fail(err, key, value, "must be consistent or lumped");
        return PF_OK;
    }
    if (!strcmp(key, "solver")) {
        if (!value || !pf_scene_parse_solver_name(value, &s->solver.method))
            return override_fail(err, key, value, "must be auto, direct, pcg or petsc");
        return PF_OK;
    }
    if (!strcmp(key, "tolerance"))
        return override_number(key, value, RANGE_OPEN_UNIT, &s->solver.tolerance, err);
    if (!strcmp(key, "degree"))
        return override_int(key, value, RANGE_DEGREE, &s->degree, err);
    if (!strcmp(key, "edge_samples"))
        return override_int(key, value, RANGE_EDGE_SAMPLES, &s->edge_samples, err);
    if (!strcmp(key, "frames"))
        return override_int(key, value, RANGE_INT_NONNEG, &s->frames, err);
    if (!strcmp(key, "substeps"))
        return override_int(key, value, RANGE_INT_POS, &s->substeps, err);
    if (!strcmp(key, "dt"))
        return override_number(key, value, RANGE_POSITIVE, &s->dt, err);
    if (!strcmp(key, "E"))
        return override_number(key, value, RANGE_POSITIVE, &s->E, err);
    if (!strcmp(key, "nu"))
        return override_number(key, value, RANGE_POISSON, &s->nu, err);
    if (!strcmp(key, "density"))
        return override_number(key, value, RANGE_POSITIVE, &s->density, err);
    if (!strcmp(key, "penalty"))
        return override_number(key, value, RANGE_NONNEG, &s->penalty, err);
    if (!strcmp(key, "corotation"))
        return override_bool(key, value, &s->corotation, err);
    if (!strcmp(key, "static")) {
        PF_TRY(override_bool(key, value, &s->is_static, err));
        pf_scene_apply_static_ground_rule(s);
        return PF_OK;
    }
    return pf_error_set(
        err, PF_ERR_INVALID, __FILE__, __LINE__,
        "%.64s: unknown scene option (expected one of: method, degree, flux, "
        "mass, edge_samples, frames, dt, static, E, nu, density, penalty, substeps, corotation, "
        "solver, tolerance)",
        key);
}
