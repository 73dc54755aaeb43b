/* The strict JSON reader of scenes: key paths for messages, typed values with their ranges
 * (scene_values.c), keyframe paths. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene_reader.h"

/* The shortest of %.15g / %.17g that reads back as v: "0.5", not "0.50000000000000000". */
void pf_scene_format_number(double v, char buf[32])
{
    snprintf(buf, 32, "%.15g", v);
    if (strtod(buf, NULL) != v)
        snprintf(buf, 32, "%.17g", v);
}

/* ---- the JSON reader ------------------------------------------------------------------------- */

/* After snprintf wrote n characters at path[len]: the new length, clamped to the truncation. */
static void advance(reader *r, int n)
{
    if (n > 0)
        r->len = r->len + (size_t)n < sizeof r->path ? r->len + (size_t)n : sizeof r->path - 1;
}

size_t pf_scene_push_key(reader *r, const char *key)
{
    size_t mark = r->len;
    advance(r, snprintf(r->path + r->len, sizeof r->path - r->len, "%s%s", r->len ? "." : "", key));
    return mark;
}

size_t pf_scene_push_index(reader *r, int i)
{
    size_t mark = r->len;
    advance(r, snprintf(r->path + r->len, sizeof r->path - r->len, "[%d]", i));
    return mark;
}

void pf_scene_pop(reader *r, size_t mark)
{
    r->len = mark;
    r->path[mark] = '\0';
}

/* "name: path: reason" as PF_ERR_INVALID. */
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
pf_status
pf_scene_fail(reader *r, const char *fmt, ...)
{
    char reason[PF_ERROR_MSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(reason, sizeof reason, fmt, ap);
    va_end(ap);
    return pf_error_set(r->err, PF_ERR_INVALID, __FILE__, __LINE__, "%s: %s: %s", r->name,
                        r->len ? r->path : "top level", reason);
}

/* A short description of a JSON value for "got ..." in messages. */
void pf_scene_describe(const cJSON *v, char buf[64])
{
    if (cJSON_IsNumber(v))
        pf_scene_format_number(v->valuedouble, buf);
    else if (cJSON_IsString(v))
        snprintf(buf, 64, "string \"%.40s\"", v->valuestring);
    else if (cJSON_IsTrue(v))
        snprintf(buf, 64, "true");
    else if (cJSON_IsFalse(v))
        snprintf(buf, 64, "false");
    else if (cJSON_IsNull(v))
        snprintf(buf, 64, "null");
    else if (cJSON_IsArray(v))
        snprintf(buf, 64, "an array of %d", cJSON_GetArraySize(v));
    else if (cJSON_IsObject(v))
        snprintf(buf, 64, "an object");
    else
        snprintf(buf, 64, "an invalid value");
}

pf_status pf_scene_fail_type(reader *r, const cJSON *v, const char *expected)
{
    char got[64];
    pf_scene_describe(v, got);
    return pf_scene_fail(r, "must be %s, got %s", expected, got);
}

/* Checks that v is an object whose keys are all in keys[] (NULL-terminated) and unique. */
pf_status pf_scene_begin_object(reader *r, const cJSON *v, const char *const *keys)
{
    if (!cJSON_IsObject(v))
        return pf_scene_fail_type(r, v, "an object");
    for (const cJSON *it = v->child; it; it = it->next) {
        bool known = false;
        for (const char *const *k = keys; *k && !known; ++k)
            known = strcmp(*k, it->string) == 0;
        if (!known) {
            char expected[PF_ERROR_MSG_MAX / 2] = "";
            size_t used = 0;
            for (const char *const *k = keys; *k && used < sizeof expected; ++k) {
                int n = snprintf(expected + used, sizeof expected - used, "%s%s",
                                 k == keys ? "" : ", ", *k);
                used += n > 0 ? (size_t)n : 0;
            }
            pf_scene_push_key(r, it->string);
            return pf_scene_fail(r, "unknown key (expected one of: %s)", expected);
        }
        for (const cJSON *prev = v->child; prev != it; prev = prev->next)
            if (strcmp(prev->string, it->string) == 0) {
                pf_scene_push_key(r, it->string);
                return pf_scene_fail(r, "duplicate key");
            }
    }
    return PF_OK;
}

pf_status pf_scene_read_number(reader *r, const cJSON *v, scene_range rg, double *out)
{
    if (!cJSON_IsNumber(v))
        return pf_scene_fail_type(r, v, pf_scene_range_is_integer(rg) ? "an integer" : "a number");
    /* cJSON turns a literal beyond the double range (1e999) into an infinity. */
    if (!isfinite(v->valuedouble))
        return pf_scene_fail(r, "must be finite (the number overflows a double)");
    if (!pf_scene_in_range(rg, v->valuedouble)) {
        char got[32];
        pf_scene_format_number(v->valuedouble, got);
        return pf_scene_fail(r, "%s, got %s", pf_scene_range_text(rg), got);
    }
    *out = v->valuedouble;
    return PF_OK;
}

pf_status pf_scene_read_int(reader *r, const cJSON *v, scene_range rg, int32_t *out)
{
    double d = 0;
    PF_TRY(pf_scene_read_number(r, v, rg, &d));
    *out = (int32_t)d;
    return PF_OK;
}

pf_status pf_scene_read_bool(reader *r, const cJSON *v, bool *out)
{
    if (!cJSON_IsBool(v))
        return pf_scene_fail_type(r, v, "true or false");
    *out = cJSON_IsTrue(v);
    return PF_OK;
}

pf_status pf_scene_read_vec3(reader *r, const cJSON *v, pf_vec3 *out)
{
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 3)
        return pf_scene_fail_type(r, v, "an array of 3 numbers");
    double c[3];
    int i = 0;
    for (const cJSON *it = v->child; it; it = it->next, ++i) {
        size_t mark = pf_scene_push_index(r, i);
        PF_TRY(pf_scene_read_number(r, it, RANGE_FINITE, &c[i]));
        pf_scene_pop(r, mark);
    }
    *out = pf_v3_load(c);
    return PF_OK;
}

/* A direction: non-zero, returned as a unit vector (pf_scene_unit_direction). */
pf_status pf_scene_read_normal(reader *r, const cJSON *v, pf_vec3 *out)
{
    pf_vec3 n;
    PF_TRY(pf_scene_read_vec3(r, v, &n));
    if (!pf_scene_unit_direction(n, out))
        return pf_scene_fail(r, "must be a non-zero vector");
    return PF_OK;
}

/* [{"time": t, "translation": [...]}, ...]: at least one key, times strictly increasing. */
pf_status pf_scene_read_path(reader *r, const cJSON *v, int32_t *n_keys, double **key_time,
                             pf_vec3 **key_translation)
{
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) == 0)
        return pf_scene_fail_type(r, v, "a non-empty array of {\"time\", \"translation\"} keys");
    int n = cJSON_GetArraySize(v);
    (*key_time) = pf_alloc_array((size_t)n, sizeof *(*key_time));
    (*key_translation) = pf_alloc_array((size_t)n, sizeof *(*key_translation));
    PF_CHECK((*key_time) && (*key_translation), r->err, PF_ERR_NOMEM, "%s: %s: out of memory",
             r->name, r->path);
    static const char *const keys[] = {"time", "translation", NULL};
    int i = 0;
    for (const cJSON *it = v->child; it; it = it->next, ++i) {
        size_t mark = pf_scene_push_index(r, i);
        PF_TRY(pf_scene_begin_object(r, it, keys));
        bool has_time = false, has_translation = false;
        for (const cJSON *k = it->child; k; k = k->next) {
            if (!strcmp(k->string, "time")) {
                READ_KEY(r, k, pf_scene_read_number(r, k, RANGE_FINITE, &(*key_time)[i]));
                has_time = true;
            } else {
                READ_KEY(r, k, pf_scene_read_vec3(r, k, &(*key_translation)[i]));
                has_translation = true;
            }
        }
        if (!has_time || !has_translation)
            return pf_scene_fail(r, "missing key \"%s\"", has_time ? "translation" : "time");
        if (i > 0 && !((*key_time)[i] > (*key_time)[i - 1])) {
            pf_scene_push_key(r, "time");
            return pf_scene_fail(r, "times must increase strictly along the path");
        }
        pf_scene_pop(r, mark);
        *n_keys = i + 1;
    }
    return PF_OK;
}
