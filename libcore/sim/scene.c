/* Scenes: defaults, the JSON reader (docs/scene.md is the reference of every key), completion
 * against a mesh's bounding box, and region tests. The JSON syntax is checked in scene_json.c;
 * cJSON builds the tree read here; the value rules it shares with the command-line overrides
 * (scene_override.c) are in scene_values.c.
 *
 * The reader is strict on purpose: an unknown key, a duplicate key, a wrong type or a value out
 * of range is an error naming the key's full path, so that a typo in a scene never silently
 * leaves a default in place. The same range rules serve the file and the overrides. */
#include <pf/sim.h>

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene_json.h"
#include "scene_reader.h"
#include "scene_values.h"

static void release_obstacles(pf_scene *s);
static pf_status resolve_file(reader *r, const char *file, char **out);

static void release_region(pf_region *r)
{
    pf_free(r->file);
    pf_free(r->listed);
    r->file = NULL;
    r->listed = NULL;
}

void pf_scene_release(pf_scene *s)
{
    if (!s)
        return;
    for (int32_t k = 0; k < s->n_fixed && s->fixed; ++k)
        release_region(&s->fixed[k].region);
    for (int32_t k = 0; k < s->n_loads && s->loads; ++k)
        release_region(&s->loads[k].region);
    for (int32_t k = 0; k < s->n_materials && s->materials; ++k)
        release_region(&s->materials[k].region);
    pf_free(s->fixed);
    pf_free(s->loads);
    pf_free(s->materials);
    release_obstacles(s);
    pf_scene_release_cuts(s);
    pf_free(s->json);
    memset(s, 0, sizeof *s);
}

static pf_status read_material(reader *r, const cJSON *v, pf_scene *s)
{
    static const char *const keys[] = {"E", "nu", "density", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "E"))
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_POSITIVE, &s->E));
        else if (!strcmp(it->string, "nu"))
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_POISSON, &s->nu));
        else
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_POSITIVE, &s->density));
    }
    return PF_OK;
}

static pf_status read_mass(reader *r, const cJSON *v, pf_mass *out)
{
    if (!cJSON_IsString(v) || !pf_scene_parse_mass_name(v->valuestring, out))
        return pf_scene_fail_type(r, v, "\"consistent\" or \"lumped\"");
    return PF_OK;
}

static pf_status read_method_name(reader *r, const cJSON *v, pf_method *out)
{
    if (!cJSON_IsString(v) || !pf_scene_parse_method_name(v->valuestring, out))
        return pf_scene_fail_type(r, v, "\"dg\" or \"cg\"");
    return PF_OK;
}

static pf_status read_flux(reader *r, const cJSON *v, pf_flux *out)
{
    if (!cJSON_IsString(v) || !pf_scene_parse_flux_name(v->valuestring, out))
        return pf_scene_fail_type(r, v, "\"ip\" or \"bz\"");
    return PF_OK;
}

static pf_status read_corotation(reader *r, const cJSON *v, pf_scene *s)
{
    if (r->corotation_seen)
        return pf_scene_fail(
            r, "corotation is given both at the top level and in method: give it once");
    r->corotation_seen = true;
    return pf_scene_read_bool(r, v, &s->corotation);
}

static pf_status read_method(reader *r, const cJSON *v, pf_scene *s)
{
    if (cJSON_IsString(v))
        return read_method_name(r, v, &s->method);
    if (!cJSON_IsObject(v))
        return pf_scene_fail_type(r, v, "\"dg\", \"cg\" or an object");
    static const char *const keys[] = {"name",       "degree", "flux",         "penalty",
                                       "corotation", "mass",   "edge_samples", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "name"))
            READ_KEY(r, it, read_method_name(r, it, &s->method));
        else if (!strcmp(it->string, "degree"))
            READ_KEY(r, it, pf_scene_read_int(r, it, RANGE_DEGREE, &s->degree));
        else if (!strcmp(it->string, "flux"))
            READ_KEY(r, it, read_flux(r, it, &s->flux));
        else if (!strcmp(it->string, "penalty"))
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_NONNEG, &s->penalty));
        else if (!strcmp(it->string, "mass"))
            READ_KEY(r, it, read_mass(r, it, &s->mass));
        else if (!strcmp(it->string, "edge_samples"))
            READ_KEY(r, it, pf_scene_read_int(r, it, RANGE_EDGE_SAMPLES, &s->edge_samples));
        else
            READ_KEY(r, it, read_corotation(r, it, s));
    }
    return PF_OK;
}

static pf_status read_solver_name(reader *r, const cJSON *v, pf_solver_method *out)
{
    if (!cJSON_IsString(v) || !pf_scene_parse_solver_name(v->valuestring, out))
        return pf_scene_fail_type(r, v, "\"auto\", \"direct\", \"pcg\" or \"petsc\"");
    return PF_OK;
}

static pf_status read_solver(reader *r, const cJSON *v, pf_solver_params *p)
{
    if (cJSON_IsString(v))
        return read_solver_name(r, v, &p->method);
    if (!cJSON_IsObject(v))
        return pf_scene_fail_type(r, v, "\"auto\", \"direct\", \"pcg\", \"petsc\" or an object");
    static const char *const keys[] = {"method", "tolerance", "max_iterations", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "method"))
            READ_KEY(r, it, read_solver_name(r, it, &p->method));
        else if (!strcmp(it->string, "tolerance"))
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_OPEN_UNIT, &p->tolerance));
        else
            READ_KEY(r, it, pf_scene_read_int(r, it, RANGE_INT_POS, &p->max_iterations));
    }
    return PF_OK;
}

static pf_status read_split(reader *r, const cJSON *v, pf_split_kind *out)
{
    if (!cJSON_IsString(v) || !pf_scene_parse_split_name(v->valuestring, out))
        return pf_scene_fail_type(r, v, "\"octs\" or \"halves\"");
    return PF_OK;
}

static pf_status read_refine(reader *r, const cJSON *v, pf_refine_params *p)
{
    static const char *const keys[] = {"threshold",     "split",    "max_level",
                                       "max_elements",  "min_size", "coarsen_fraction",
                                       "coarsen_after", "rebuild",  NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    bool threshold = false;
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "threshold")) {
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_POSITIVE, &p->threshold));
            threshold = true;
        } else if (!strcmp(it->string, "split"))
            READ_KEY(r, it, read_split(r, it, &p->split));
        else if (!strcmp(it->string, "max_level"))
            READ_KEY(r, it, pf_scene_read_int(r, it, RANGE_INT_NONNEG, &p->max_level));
        else if (!strcmp(it->string, "max_elements"))
            READ_KEY(r, it, pf_scene_read_int(r, it, RANGE_INT_POS, &p->max_elements));
        else if (!strcmp(it->string, "coarsen_fraction"))
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_UNIT_INTERVAL, &p->coarsen_fraction));
        else if (!strcmp(it->string, "coarsen_after"))
            READ_KEY(r, it, pf_scene_read_int(r, it, RANGE_INT_POS, &p->coarsen_after));
        else if (!strcmp(it->string, "rebuild"))
            READ_KEY(r, it, pf_scene_read_bool(r, it, &p->rebuild));
        else
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_NONNEG, &p->min_size));
    }
    if (!threshold)
        return pf_scene_fail(r, "needs a threshold (stress units)");
    p->enabled = true;
    return PF_OK;
}

static pf_status read_damping(reader *r, const cJSON *v, pf_scene *s)
{
    static const char *const keys[] = {"alpha", "beta", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "alpha"))
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_NONNEG, &s->damping_alpha));
        else
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_NONNEG, &s->damping_beta));
    }
    return PF_OK;
}

static pf_status read_time(reader *r, const cJSON *v, pf_scene *s)
{
    static const char *const keys[] = {"dt", "frames", "substeps", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "dt"))
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_POSITIVE, &s->dt));
        else if (!strcmp(it->string, "frames"))
            READ_KEY(r, it, pf_scene_read_int(r, it, RANGE_INT_NONNEG, &s->frames));
        else
            READ_KEY(r, it, pf_scene_read_int(r, it, RANGE_INT_POS, &s->substeps));
    }
    return PF_OK;
}

/* [[xlo, ylo, zlo], [xhi, yhi, zhi]] with lo <= hi componentwise. */
static pf_status read_box(reader *r, const cJSON *v, pf_region *out)
{
    if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 2)
        return pf_scene_fail_type(r, v, "[[xlo, ylo, zlo], [xhi, yhi, zhi]]");
    size_t mark = pf_scene_push_index(r, 0);
    PF_TRY(pf_scene_read_vec3(r, v->child, &out->lo));
    pf_scene_pop(r, mark);
    pf_scene_push_index(r, 1);
    PF_TRY(pf_scene_read_vec3(r, v->child->next, &out->hi));
    pf_scene_pop(r, mark);
    for (int i = 0; i < 3; ++i) {
        double lo = pf_v3_get(out->lo, i), hi = pf_v3_get(out->hi, i);
        if (lo > hi) {
            char a[32], b[32];
            pf_scene_format_number(lo, a);
            pf_scene_format_number(hi, b);
            return pf_scene_fail(r, "lower corner above upper corner along %c (%s > %s)", "xyz"[i],
                                 a, b);
        }
    }
    out->kind = PF_REGION_BOX;
    return PF_OK;
}

/* {"point": [...], "normal": [...], "tol": t}: point and normal required, tol -1 when absent. */
static pf_status read_plane(reader *r, const cJSON *v, pf_region *out)
{
    static const char *const keys[] = {"point", "normal", "tol", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    pf_vec3 point = {0, 0, 0}, normal = {0, 0, 0};
    bool has_point = false, has_normal = false;
    out->tol = -1;
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "point")) {
            READ_KEY(r, it, pf_scene_read_vec3(r, it, &point));
            has_point = true;
        } else if (!strcmp(it->string, "normal")) {
            READ_KEY(r, it, pf_scene_read_normal(r, it, &normal));
            has_normal = true;
        } else {
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_NONNEG, &out->tol));
        }
    }
    if (!has_point || !has_normal)
        return pf_scene_fail(r, "missing key \"%s\"", has_point ? "normal" : "point");
    out->kind = PF_REGION_PLANE;
    out->plane = (pf_plane){.n = normal, .d = pf_v3_dot(normal, point)}; /* normal: unit */
    out->point = point;
    return PF_OK;
}

/* "name" (a mesh group's name) or a positive integer (its number). */
static pf_status read_group(reader *r, const cJSON *v, pf_region *out)
{
    out->kind = PF_REGION_GROUP;
    if (cJSON_IsString(v)) {
        size_t n = strlen(v->valuestring);
        if (n == 0 || n >= PF_GROUP_NAME_MAX)
            return pf_scene_fail(r, "a group name has 1 to %d bytes, got %zu",
                                 PF_GROUP_NAME_MAX - 1, n);
        memcpy(out->group_name, v->valuestring, n + 1);
        return PF_OK;
    }
    if (!cJSON_IsNumber(v))
        return pf_scene_fail_type(r, v, "a group name or number");
    double d = 0;
    PF_TRY(pf_scene_read_number(r, v, RANGE_INT_POS, &d));
    out->group = (int32_t)d;
    return PF_OK;
}

/* "nodes_file" or "elements_file": a non-empty file name, resolved as an obstacle's mesh file;
 * the caller reads the indices (pf_region_set_list). */
static pf_status read_list_file(reader *r, const cJSON *v, pf_region_kind kind, pf_region *out)
{
    if (!cJSON_IsString(v) || !v->valuestring[0])
        return pf_scene_fail_type(r, v, "a non-empty file name");
    pf_free(out->file);
    out->file = NULL;
    out->kind = kind;
    return resolve_file(r, v->valuestring, &out->file);
}

/* A region key of an entry of "fixed", "loads" or "materials" (box, plane where allowed, group,
 * nodes_file, elements_file) into region; false for another key. */
static bool read_region_key(reader *r, const cJSON *it, bool plane, pf_region *region,
                            pf_status *st)
{
    const char *k = it->string;
    size_t mark = pf_scene_push_key(r, k);
    if (!strcmp(k, "box"))
        *st = read_box(r, it, region);
    else if (plane && !strcmp(k, "plane"))
        *st = read_plane(r, it, region);
    else if (!strcmp(k, "group"))
        *st = read_group(r, it, region);
    else if (!strcmp(k, "nodes_file"))
        *st = read_list_file(r, it, PF_REGION_NODES, region);
    else if (!strcmp(k, "elements_file"))
        *st = read_list_file(r, it, PF_REGION_ELEMENTS, region);
    else {
        pf_scene_pop(r, mark);
        return false;
    }
    if (*st >= 0)
        pf_scene_pop(r, mark);
    return true;
}

/* One entry of "fixed" or "loads": exactly one of box / plane / group / nodes_file /
 * elements_file, plus the entry's vector key (displacement, optional; traction, required). */
static pf_status read_region_entry(reader *r, const cJSON *v, const char *vector_key,
                                   bool vector_required, pf_region *region, pf_vec3 *vector)
{
    const char *const keys[] = {"box",           "plane",    "group", "nodes_file",
                                "elements_file", vector_key, NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    int n_regions = 0;
    bool has_vector = false;
    for (const cJSON *it = v->child; it; it = it->next) {
        pf_status st = PF_OK;
        if (read_region_key(r, it, true, region, &st)) {
            PF_TRY(st);
            ++n_regions;
        } else {
            READ_KEY(r, it, pf_scene_read_vec3(r, it, vector));
            has_vector = true;
        }
    }
    if (n_regions != 1)
        return pf_scene_fail(r, n_regions ? "give one region, \"box\", \"plane\", \"group\", "
                                            "\"nodes_file\" or \"elements_file\", not several"
                                          : "missing region: give \"box\", \"plane\", \"group\", "
                                            "\"nodes_file\" or \"elements_file\"");
    if (vector_required && !has_vector)
        return pf_scene_fail(r, "missing key \"%s\"", vector_key);
    return PF_OK;
}

static pf_status read_fixed(reader *r, const cJSON *v, pf_scene *s)
{
    if (!cJSON_IsArray(v))
        return pf_scene_fail_type(r, v, "an array");
    int n = cJSON_GetArraySize(v);
    pf_free(s->fixed);
    s->n_fixed = 0;
    s->fixed = pf_calloc((size_t)n, sizeof *s->fixed);
    PF_CHECK(s->fixed || n == 0, r->err, PF_ERR_NOMEM, "%s: fixed: out of memory", r->name);
    s->n_fixed = n;
    int i = 0;
    for (const cJSON *it = v->child; it; it = it->next, ++i) {
        size_t mark = pf_scene_push_index(r, i);
        PF_TRY(read_region_entry(r, it, "displacement", false, &s->fixed[i].region,
                                 &s->fixed[i].displacement));
        pf_scene_pop(r, mark);
    }
    return PF_OK;
}

static pf_status read_loads(reader *r, const cJSON *v, pf_scene *s)
{
    if (!cJSON_IsArray(v))
        return pf_scene_fail_type(r, v, "an array");
    int n = cJSON_GetArraySize(v);
    pf_free(s->loads);
    s->n_loads = 0;
    s->loads = pf_calloc((size_t)n, sizeof *s->loads);
    PF_CHECK(s->loads || n == 0, r->err, PF_ERR_NOMEM, "%s: loads: out of memory", r->name);
    s->n_loads = n;
    int i = 0;
    for (const cJSON *it = v->child; it; it = it->next, ++i) {
        size_t mark = pf_scene_push_index(r, i);
        PF_TRY(
            read_region_entry(r, it, "traction", true, &s->loads[i].region, &s->loads[i].traction));
        pf_scene_pop(r, mark);
    }
    return PF_OK;
}

/* One entry of "materials": exactly one of box / group, and any of E, nu, density (NAN until
 * read_scene fills in the scene's material). */
static pf_status read_material_entry(reader *r, const cJSON *v, pf_material_region *m)
{
    static const char *const keys[] = {"box", "group", "nodes_file", "elements_file",
                                       "E",   "nu",    "density",    NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    m->E = m->nu = m->density = NAN;
    int n_regions = 0;
    for (const cJSON *it = v->child; it; it = it->next) {
        pf_status st = PF_OK;
        if (read_region_key(r, it, false, &m->region, &st)) {
            PF_TRY(st);
            ++n_regions;
        } else if (!strcmp(it->string, "E")) {
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_POSITIVE, &m->E));
        } else if (!strcmp(it->string, "nu")) {
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_POISSON, &m->nu));
        } else {
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_POSITIVE, &m->density));
        }
    }
    if (n_regions != 1)
        return pf_scene_fail(r, n_regions ? "give one region, \"box\", \"group\", \"nodes_file\" "
                                            "or \"elements_file\", not several"
                                          : "missing region: give \"box\", \"group\", "
                                            "\"nodes_file\" or \"elements_file\"");
    return PF_OK;
}

static pf_status read_materials(reader *r, const cJSON *v, pf_scene *s)
{
    if (!cJSON_IsArray(v))
        return pf_scene_fail_type(r, v, "an array");
    int n = cJSON_GetArraySize(v);
    pf_free(s->materials);
    s->n_materials = 0;
    s->materials = pf_calloc((size_t)n + 1, sizeof *s->materials);
    PF_CHECK(s->materials, r->err, PF_ERR_NOMEM, "%s: materials: out of memory", r->name);
    s->n_materials = n;
    int i = 0;
    for (const cJSON *it = v->child; it; it = it->next, ++i) {
        size_t mark = pf_scene_push_index(r, i);
        PF_TRY(read_material_entry(r, it, &s->materials[i]));
        pf_scene_pop(r, mark);
    }
    return PF_OK;
}

static pf_status read_ground(reader *r, const cJSON *v, pf_scene *s)
{
    s->ground_given = true;
    if (cJSON_IsBool(v)) {
        s->ground = cJSON_IsTrue(v);
        s->ground_auto = true;
        return PF_OK;
    }
    if (!cJSON_IsObject(v))
        return pf_scene_fail_type(r, v, "true, false or an object");
    static const char *const keys[] = {"point", "normal", "stiffness", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    s->ground = true;
    s->ground_auto = true;
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "point")) {
            READ_KEY(r, it, pf_scene_read_vec3(r, it, &s->ground_point));
            s->ground_auto = false;
        } else if (!strcmp(it->string, "normal")) {
            READ_KEY(r, it, pf_scene_read_normal(r, it, &s->ground_normal));
        } else {
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_NONNEG, &s->ground_stiffness));
        }
    }
    return PF_OK;
}

/* ---- obstacles ------------------------------------------------------------------------------- */

static void release_obstacle(pf_obstacle *o)
{
    pf_free(o->file);
    pf_free(o->key_time);
    pf_free(o->key_translation);
    pf_surface_release(&o->surface);
    memset(o, 0, sizeof *o);
}

static void release_obstacles(pf_scene *s)
{
    for (int32_t i = 0; i < s->n_obstacles; ++i)
        release_obstacle(&s->obstacles[i]);
    pf_free(s->obstacles);
    s->obstacles = NULL;
    s->n_obstacles = 0;
}

/* {"point": [...], "normal": [...]}, both required. */
static pf_status read_obstacle_plane(reader *r, const cJSON *v, pf_obstacle *o)
{
    static const char *const keys[] = {"point", "normal", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    bool has_point = false, has_normal = false;
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "point")) {
            READ_KEY(r, it, pf_scene_read_vec3(r, it, &o->point));
            has_point = true;
        } else {
            READ_KEY(r, it, pf_scene_read_normal(r, it, &o->normal));
            has_normal = true;
        }
    }
    if (!has_point || !has_normal)
        return pf_scene_fail(r, "missing key \"%s\"", has_point ? "normal" : "point");
    o->kind = PF_OBSTACLE_PLANE;
    return PF_OK;
}

/* {"centre": [...], "radius": r > 0}, both required. */
static pf_status read_obstacle_sphere(reader *r, const cJSON *v, pf_obstacle *o)
{
    static const char *const keys[] = {"centre", "radius", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    bool has_centre = false, has_radius = false;
    for (const cJSON *it = v->child; it; it = it->next) {
        if (!strcmp(it->string, "centre")) {
            READ_KEY(r, it, pf_scene_read_vec3(r, it, &o->centre));
            has_centre = true;
        } else {
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_POSITIVE, &o->radius));
            has_radius = true;
        }
    }
    if (!has_centre || !has_radius)
        return pf_scene_fail(r, "missing key \"%s\"", has_centre ? "radius" : "centre");
    o->kind = PF_OBSTACLE_SPHERE;
    return PF_OK;
}

/* [[lo], [hi]] with lo < hi: a solid box of positive volume. */
static pf_status read_obstacle_box(reader *r, const cJSON *v, pf_obstacle *o)
{
    pf_region box;
    PF_TRY(read_box(r, v, &box));
    for (int i = 0; i < 3; ++i)
        if (pf_v3_get(box.lo, i) == pf_v3_get(box.hi, i))
            return pf_scene_fail(r, "the box is flat along %c: an obstacle box needs lo < hi",
                                 "xyz"[i]);
    o->kind = PF_OBSTACLE_BOX;
    o->lo = box.lo;
    o->hi = box.hi;
    return PF_OK;
}

/* The file relative to the directory of the scene file (r->name up to its last '/'), unless it is
 * absolute or the name has no directory. */
static pf_status resolve_file(reader *r, const char *file, char **out)
{
    const char *slash = strrchr(r->name, '/');
    size_t dir = file[0] != '/' && slash ? (size_t)(slash - r->name) + 1 : 0;
    size_t n = strlen(file);
    *out = pf_alloc(dir + n + 1);
    PF_CHECK(*out, r->err, PF_ERR_NOMEM, "%s: %s: out of memory", r->name, r->path);
    memcpy(*out, r->name, dir);
    memcpy(*out + dir, file, n + 1);
    return PF_OK;
}

/* {"file": "name", "depth": d >= 0, "up": axis, "scale": s > 0}: file required. */
static pf_status read_obstacle_mesh(reader *r, const cJSON *v, pf_obstacle *o)
{
    static const char *const keys[] = {"file", "depth", "up", "scale", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    o->up = PF_UP_AUTO;
    o->scale = 1;
    for (const cJSON *it = v->child; it; it = it->next) {
        size_t mark = pf_scene_push_key(r, it->string);
        if (!strcmp(it->string, "file")) {
            if (!cJSON_IsString(it) || !it->valuestring[0])
                return pf_scene_fail_type(r, it, "a non-empty file name");
            PF_TRY(resolve_file(r, it->valuestring, &o->file));
        } else if (!strcmp(it->string, "up")) {
            if (!cJSON_IsString(it) || !pf_up_axis_parse(it->valuestring, &o->up))
                return pf_scene_fail_type(
                    r, it, "\"x\", \"y\", \"z\", \"-x\", \"-y\", \"-z\" or \"auto\"");
        } else if (!strcmp(it->string, "scale")) {
            PF_TRY(pf_scene_read_number(r, it, RANGE_POSITIVE, &o->scale));
        } else {
            PF_TRY(pf_scene_read_number(r, it, RANGE_NONNEG, &o->depth));
        }
        pf_scene_pop(r, mark);
    }
    if (!o->file)
        return pf_scene_fail(r, "missing key \"file\"");
    o->kind = PF_OBSTACLE_MESH;
    return PF_OK;
}

/* One obstacle: exactly one of plane / sphere / box / mesh, optional stiffness and path. */
static pf_status read_obstacle(reader *r, const cJSON *v, pf_obstacle *o)
{
    static const char *const keys[] = {"plane", "sphere", "box", "mesh", "stiffness", "path", NULL};
    PF_TRY(pf_scene_begin_object(r, v, keys));
    int n_shapes = 0;
    for (const cJSON *it = v->child; it; it = it->next) {
        const char *k = it->string;
        if (!strcmp(k, "stiffness")) {
            READ_KEY(r, it, pf_scene_read_number(r, it, RANGE_NONNEG, &o->stiffness));
            continue;
        }
        if (!strcmp(k, "path")) {
            READ_KEY(r, it,
                     pf_scene_read_path(r, it, &o->n_keys, &o->key_time, &o->key_translation));
            continue;
        }
        if (n_shapes++)
            return pf_scene_fail(r,
                                 "give one shape, \"plane\", \"sphere\", \"box\" or \"mesh\", not "
                                 "several");
        if (!strcmp(k, "plane"))
            READ_KEY(r, it, read_obstacle_plane(r, it, o));
        else if (!strcmp(k, "sphere"))
            READ_KEY(r, it, read_obstacle_sphere(r, it, o));
        else if (!strcmp(k, "box"))
            READ_KEY(r, it, read_obstacle_box(r, it, o));
        else
            READ_KEY(r, it, read_obstacle_mesh(r, it, o));
    }
    if (n_shapes == 0)
        return pf_scene_fail(r, "missing shape: give \"plane\", \"sphere\", \"box\" or \"mesh\"");
    return PF_OK;
}

static pf_status read_obstacles(reader *r, const cJSON *v, pf_scene *s)
{
    if (!cJSON_IsArray(v))
        return pf_scene_fail_type(r, v, "an array");
    int n = cJSON_GetArraySize(v);
    release_obstacles(s);
    s->obstacles = pf_calloc((size_t)n, sizeof *s->obstacles);
    PF_CHECK(s->obstacles || n == 0, r->err, PF_ERR_NOMEM, "%s: obstacles: out of memory", r->name);
    s->n_obstacles = n;
    int i = 0;
    for (const cJSON *it = v->child; it; it = it->next, ++i) {
        size_t mark = pf_scene_push_index(r, i);
        PF_TRY(read_obstacle(r, it, &s->obstacles[i]));
        pf_scene_pop(r, mark);
    }
    return PF_OK;
}

static pf_status read_scene(reader *r, const cJSON *root, pf_scene *s)
{
    if (!cJSON_IsObject(root)) {
        char got[64];
        pf_scene_describe(root, got);
        return pf_error_set(r->err, PF_ERR_INVALID, __FILE__, __LINE__,
                            "%s: the scene must be a JSON object, got %s", r->name, got);
    }
    static const char *const keys[] = {"material",   "materials", "method", "corotation", "gravity",
                                       "body_force", "damping",   "fixed",  "loads",      "ground",
                                       "obstacles",  "time",      "static", "solver",     "refine",
                                       "cuts",       NULL};
    PF_TRY(pf_scene_begin_object(r, root, keys));
    for (const cJSON *it = root->child; it; it = it->next) {
        const char *k = it->string;
        if (!strcmp(k, "material"))
            READ_KEY(r, it, read_material(r, it, s));
        else if (!strcmp(k, "materials"))
            READ_KEY(r, it, read_materials(r, it, s));
        else if (!strcmp(k, "method"))
            READ_KEY(r, it, read_method(r, it, s));
        else if (!strcmp(k, "corotation"))
            READ_KEY(r, it, read_corotation(r, it, s));
        else if (!strcmp(k, "gravity"))
            READ_KEY(r, it, pf_scene_read_vec3(r, it, &s->gravity));
        else if (!strcmp(k, "body_force"))
            READ_KEY(r, it, pf_scene_read_vec3(r, it, &s->body_force));
        else if (!strcmp(k, "damping"))
            READ_KEY(r, it, read_damping(r, it, s));
        else if (!strcmp(k, "fixed"))
            READ_KEY(r, it, read_fixed(r, it, s));
        else if (!strcmp(k, "loads"))
            READ_KEY(r, it, read_loads(r, it, s));
        else if (!strcmp(k, "ground"))
            READ_KEY(r, it, read_ground(r, it, s));
        else if (!strcmp(k, "obstacles"))
            READ_KEY(r, it, read_obstacles(r, it, s));
        else if (!strcmp(k, "time"))
            READ_KEY(r, it, read_time(r, it, s));
        else if (!strcmp(k, "solver"))
            READ_KEY(r, it, read_solver(r, it, &s->solver));
        else if (!strcmp(k, "cuts"))
            READ_KEY(r, it, pf_scene_read_cuts(r, it, s));
        else if (!strcmp(k, "refine"))
            READ_KEY(r, it, read_refine(r, it, &s->refine));
        else
            READ_KEY(r, it, pf_scene_read_bool(r, it, &s->is_static));
    }
    pf_scene_apply_static_ground_rule(s);
    for (int32_t k = 0; k < s->n_materials; ++k) { /* what an entry did not give */
        pf_material_region *m = &s->materials[k];
        m->E = isnan(m->E) ? s->E : m->E;
        m->nu = isnan(m->nu) ? s->nu : m->nu;
        m->density = isnan(m->density) ? s->density : m->density;
    }
    return PF_OK;
}

/* ---- parse and load -------------------------------------------------------------------------- */

pf_status pf_scene_parse(pf_scene *s, const char *text, size_t len, const char *name, pf_error *err)
{
    memset(s, 0, sizeof *s);
    pf_scene_default(s);
    if (!name)
        name = "scene";
    PF_CHECK(text || len == 0, err, PF_ERR_INVALID, "%s: no text", name);
    PF_CHECK(len < SIZE_MAX, err, PF_ERR_TOO_LARGE, "%s: text too large", name);
    s->json = pf_alloc(len + 1);
    PF_CHECK(s->json, err, PF_ERR_NOMEM, "%s: out of memory copying %zu bytes", name, len);
    if (len)
        memcpy(s->json, text, len);
    s->json[len] = '\0';

    size_t start = 0;
    PF_TRY(pf_scene_json_check(s->json, len, name, &start, err));
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithOpts(s->json + start, &end, 1);
    if (!root) {
        /* The check accepted the text, so cJSON ran out of memory (or disagrees on the grammar:
         * then its stopping point is the best position there is). */
        bool inside = end && end >= s->json && end <= s->json + len;
        size_t pos = inside ? (size_t)(end - s->json) : start;
        return pf_scene_json_error_at(s->json, len, pos, name, NULL, err);
    }
    reader r = {.name = name, .err = err};
    pf_status st = read_scene(&r, root, s);
    cJSON_Delete(root);
    return st;
}
