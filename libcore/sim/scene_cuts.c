/* The scene's "cuts" (docs/scene.md): blades, a segment moved along a path or a plane applied at
 * a time. Read here; written back in scene_write.c; applied between frames in sim_cut.c. */
#include <math.h>
#include <string.h>

#include "scene_reader.h"

void pf_blade_at(const pf_blade *b, double t, pf_vec3 *a, pf_vec3 *bb)
{
    pf_vec3 shift = pf_scene_path_at(b->n_keys, b->key_time, b->key_translation, t);
    *a = pf_v3_add(b->a, shift);
    *bb = pf_v3_add(b->b, shift);
}

bool pf_scene_changes_mesh(const pf_scene *s)
{
    return s->refine.enabled || s->n_cuts > 0;
}

bool pf_scene_has_contact(const pf_scene *s)
{
    return !s->is_static && (s->ground || s->n_obstacles > 0);
}

void pf_scene_release_cuts(pf_scene *s)
{
    for (int32_t i = 0; i < s->n_cuts; ++i) {
        pf_free(s->cuts[i].key_time);
        pf_free(s->cuts[i].key_translation);
    }
    pf_free(s->cuts);
    s->cuts = NULL;
    s->n_cuts = 0;
}

/* "blade": [[x, y, z], [x, y, z]], two distinct points. */
static pf_status read_segment(reader *r, const cJSON *v, pf_blade *b)
{
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 2)
        return pf_scene_fail_type(r, v, "an array of 2 points");
    size_t mark = pf_scene_push_index(r, 0);
    PF_TRY(pf_scene_read_vec3(r, v->child, &b->a));
    pf_scene_pop(r, mark);
    mark = pf_scene_push_index(r, 1);
    PF_TRY(pf_scene_read_vec3(r, v->child->next, &b->b));
    pf_scene_pop(r, mark);
    if (pf_v3_dist(b->a, b->b) == 0)
        return pf_scene_fail(r, "the blade's two end points must differ");
    b->kind = PF_BLADE_SEGMENT;
    return PF_OK;
}

/* "plane": {"point": vector, "normal": vector}. */
static pf_status read_plane(reader *r, const cJSON *v, pf_blade *b)
{
    static const char *const keys[] = {"point", "normal", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    bool has_point = false, has_normal = false;
    for (const cJSON *it = v->child; it; it = it->next)
        if (!strcmp(it->string, "point")) {
            READ_KEY(r, it, pf_scene_read_vec3(r, it, &b->point));
            has_point = true;
        } else {
            READ_KEY(r, it, pf_scene_read_normal(r, it, &b->normal));
            has_normal = true;
        }
    if (!has_point || !has_normal)
        return pf_scene_fail(r, "missing key \"%s\"", has_point ? "normal" : "point");
    b->kind = PF_BLADE_PLANE;
    return PF_OK;
}

/* One blade: a "blade" segment with a "path", or a "plane" with an optional "time". */
static pf_status read_blade(reader *r, const cJSON *v, pf_blade *b)
{
    static const char *const keys[] = {"blade", "path", "plane", "time", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    bool segment = false, plane = false, path = false, time = false;
    for (const cJSON *it = v->child; it; it = it->next) {
        const char *k = it->string;
        if (!strcmp(k, "blade")) {
            READ_KEY(r, it, read_segment(r, it, b));
            segment = true;
        } else if (!strcmp(k, "plane")) {
            READ_KEY(r, it, read_plane(r, it, b));
            plane = true;
        } else if (!strcmp(k, "path")) {
            READ_KEY(r, it,
                     pf_scene_read_path(r, it, &b->n_keys, &b->key_time, &b->key_translation));
            path = true;
        } else {
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_FINITE, &b->time));
            time = true;
        }
    }
    if (segment == plane)
        return pf_scene_fail(r, "give one of \"blade\" (a moving segment) or \"plane\"");
    b->kind = segment ? PF_BLADE_SEGMENT : PF_BLADE_PLANE;
    if (segment && time)
        return pf_scene_fail(r, "\"time\" is for a plane; a blade cuts along its \"path\"");
    if (plane && path)
        return pf_scene_fail(r, "\"path\" is for a blade; a plane cuts once, at its \"time\"");
    if (segment && b->n_keys < 2)
        return pf_scene_fail(r, "a blade needs a \"path\" of at least two keys: it cuts where "
                                "it moves");
    return PF_OK;
}

pf_status pf_scene_read_cuts(reader *r, const cJSON *v, pf_scene *s)
{
    if (!cJSON_IsArray(v))
        return pf_scene_fail_type(r, v, "an array");
    int n = cJSON_GetArraySize(v);
    pf_scene_release_cuts(s);
    s->cuts = pf_calloc((size_t)n + 1, sizeof *s->cuts);
    PF_CHECK(s->cuts, r->err, PF_ERR_NOMEM, "%s: cuts: out of memory", r->name);
    s->n_cuts = n;
    int i = 0;
    for (const cJSON *it = v->child; it; it = it->next, ++i) {
        size_t mark = pf_scene_push_index(r, i);
        PF_TRY(read_blade(r, it, &s->cuts[i]));
        pf_scene_pop(r, mark);
    }
    return PF_OK;
}
