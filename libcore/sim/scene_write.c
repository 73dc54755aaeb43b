/* The scene as simulated, written back as a scene file: every key explicit, the command-line
 * overrides applied, so the SCEN chunk of a stream says exactly how its frames were made and
 * reads back into the same scene. Numbers are printed with 17 significant digits (round trip). */
#include <pf/sim.h>

#include <stdio.h>
#include <string.h>

#include <cjson/cJSON.h>

#include "scene_json.h"

/* A number printed with %.17g as a raw item: cJSON's own printing keeps 15 digits whenever they
 * read back within an ulp, so a written scene did not read back into the same numbers (a ground
 * normal (5, 1, 0) normalised changed its last bit on every write and read). Scene values are
 * finite (checked on input). */
static cJSON *number(double v)
{
    char text[32];
    snprintf(text, sizeof text, "%.17g", v);
    return cJSON_CreateRaw(text);
}

static void add_number(cJSON *o, const char *key, double v)
{
    cJSON_AddItemToObject(o, key, number(v));
}

static cJSON *vector(pf_vec3 v)
{
    cJSON *a = cJSON_CreateArray();
    cJSON_AddItemToArray(a, number(v.x));
    cJSON_AddItemToArray(a, number(v.y));
    cJSON_AddItemToArray(a, number(v.z));
    return a;
}

/* The plane's point: the one the scene gave when it is on the plane (n . point = d, as read), so
 * that the plane reads back into the same bits; n d for a region made in code without one. */
static pf_vec3 plane_point(const pf_region *r)
{
    if (pf_v3_dot(r->plane.n, r->point) == r->plane.d)
        return r->point;
    return pf_v3_scale(r->plane.n, r->plane.d);
}

static cJSON *region(const pf_region *r)
{
    cJSON *o = cJSON_CreateObject();
    if (r->kind == PF_REGION_GROUP) {
        if (r->group_name[0])
            cJSON_AddStringToObject(o, "group", r->group_name);
        else
            add_number(o, "group", r->group);
    } else if (r->kind == PF_REGION_NODES || r->kind == PF_REGION_ELEMENTS) {
        /* the file as resolved, as an obstacle's mesh file */
        cJSON_AddStringToObject(o, r->kind == PF_REGION_NODES ? "nodes_file" : "elements_file",
                                r->file ? r->file : "");
    } else if (r->kind == PF_REGION_BOX) {
        cJSON *box = cJSON_AddArrayToObject(o, "box");
        cJSON_AddItemToArray(box, vector(r->lo));
        cJSON_AddItemToArray(box, vector(r->hi));
    } else {
        cJSON *plane = cJSON_AddObjectToObject(o, "plane");
        pf_vec3 point = plane_point(r);
        cJSON_AddItemToObject(plane, "point", vector(point));
        cJSON_AddItemToObject(plane, "normal", vector(r->plane.n));
        if (r->tol >= 0)
            add_number(plane, "tol", r->tol);
    }
    return o;
}

/* "path": [{"time", "translation"}, ...] of an obstacle or a blade. */
static void add_path(cJSON *j, int32_t n_keys, const double *key_time,
                     const pf_vec3 *key_translation)
{
    cJSON *path = cJSON_AddArrayToObject(j, "path");
    for (int32_t k = 0; k < n_keys; ++k) {
        cJSON *key = cJSON_CreateObject();
        add_number(key, "time", key_time[k]);
        cJSON_AddItemToObject(key, "translation", vector(key_translation[k]));
        cJSON_AddItemToArray(path, key);
    }
}

/* The mesh file as resolved (relative to the working directory, or absolute), so the SCEN chunk
 * names a file a tool reading the stream from the same directory finds. */
static cJSON *obstacle(const pf_obstacle *o)
{
    cJSON *j = cJSON_CreateObject();
    if (o->kind == PF_OBSTACLE_PLANE) {
        cJSON *plane = cJSON_AddObjectToObject(j, "plane");
        cJSON_AddItemToObject(plane, "point", vector(o->point));
        cJSON_AddItemToObject(plane, "normal", vector(o->normal));
    } else if (o->kind == PF_OBSTACLE_SPHERE) {
        cJSON *sphere = cJSON_AddObjectToObject(j, "sphere");
        cJSON_AddItemToObject(sphere, "centre", vector(o->centre));
        add_number(sphere, "radius", o->radius);
    } else if (o->kind == PF_OBSTACLE_BOX) {
        cJSON *box = cJSON_AddArrayToObject(j, "box");
        cJSON_AddItemToArray(box, vector(o->lo));
        cJSON_AddItemToArray(box, vector(o->hi));
    } else {
        cJSON *mesh = cJSON_AddObjectToObject(j, "mesh");
        cJSON_AddStringToObject(mesh, "file", o->file ? o->file : "");
        add_number(mesh, "depth", o->depth);
        cJSON_AddStringToObject(mesh, "up", pf_up_axis_name(o->up));
        add_number(mesh, "scale", o->scale > 0 ? o->scale : 1);
    }
    add_number(j, "stiffness", o->stiffness);
    if (o->n_keys > 0)
        add_path(j, o->n_keys, o->key_time, o->key_translation);
    return j;
}

static cJSON *blade(const pf_blade *b)
{
    cJSON *j = cJSON_CreateObject();
    if (b->kind == PF_BLADE_PLANE) {
        cJSON *plane = cJSON_AddObjectToObject(j, "plane");
        cJSON_AddItemToObject(plane, "point", vector(b->point));
        cJSON_AddItemToObject(plane, "normal", vector(b->normal));
        add_number(j, "time", b->time);
        return j;
    }
    cJSON *segment = cJSON_AddArrayToObject(j, "blade");
    cJSON_AddItemToArray(segment, vector(b->a));
    cJSON_AddItemToArray(segment, vector(b->b));
    add_path(j, b->n_keys, b->key_time, b->key_translation);
    return j;
}

static cJSON *scene_object(const pf_scene *s)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *material = cJSON_AddObjectToObject(root, "material");
    add_number(material, "E", s->E);
    add_number(material, "nu", s->nu);
    add_number(material, "density", s->density);

    cJSON *method = cJSON_AddObjectToObject(root, "method");
    cJSON_AddStringToObject(method, "name", s->method == PF_METHOD_CG ? "cg" : "dg");
    if (s->method == PF_METHOD_DG) {
        add_number(method, "degree", s->degree);
        cJSON_AddStringToObject(method, "flux", s->flux == PF_FLUX_BZ ? "bz" : "ip");
        add_number(method, "penalty", s->penalty);
    } else {
        cJSON_AddStringToObject(method, "mass",
                                s->mass == PF_MASS_LUMPED ? "lumped" : "consistent");
        add_number(method, "edge_samples", s->edge_samples);
    }
    cJSON_AddBoolToObject(method, "corotation", s->corotation);

    cJSON_AddItemToObject(root, "gravity", vector(s->gravity));
    cJSON_AddItemToObject(root, "body_force", vector(s->body_force));
    cJSON *solver = cJSON_AddObjectToObject(root, "solver");
    cJSON_AddStringToObject(solver, "method", pf_solver_method_name(s->solver.method));
    cJSON_AddNumberToObject(solver, "tolerance", s->solver.tolerance);
    cJSON_AddNumberToObject(solver, "max_iterations", s->solver.max_iterations);
    if (s->refine.enabled) {
        cJSON *refine = cJSON_AddObjectToObject(root, "refine");
        add_number(refine, "threshold", s->refine.threshold);
        cJSON_AddStringToObject(refine, "split",
                                s->refine.split == PF_SPLIT_HALVES ? "halves" : "octs");
        add_number(refine, "max_level", s->refine.max_level);
        add_number(refine, "max_elements", s->refine.max_elements);
        add_number(refine, "min_size", s->refine.min_size);
        add_number(refine, "coarsen_fraction", s->refine.coarsen_fraction);
        add_number(refine, "coarsen_after", s->refine.coarsen_after);
        cJSON_AddBoolToObject(refine, "rebuild", s->refine.rebuild);
    }
    cJSON *damping = cJSON_AddObjectToObject(root, "damping");
    add_number(damping, "alpha", s->damping_alpha);
    add_number(damping, "beta", s->damping_beta);

    if (s->n_materials > 0) {
        cJSON *materials = cJSON_AddArrayToObject(root, "materials");
        for (int32_t k = 0; k < s->n_materials; ++k) {
            cJSON *m = region(&s->materials[k].region);
            add_number(m, "E", s->materials[k].E);
            add_number(m, "nu", s->materials[k].nu);
            add_number(m, "density", s->materials[k].density);
            cJSON_AddItemToArray(materials, m);
        }
    }
    cJSON *fixed = cJSON_AddArrayToObject(root, "fixed");
    for (int32_t k = 0; k < s->n_fixed; ++k) {
        cJSON *f = region(&s->fixed[k].region);
        cJSON_AddItemToObject(f, "displacement", vector(s->fixed[k].displacement));
        cJSON_AddItemToArray(fixed, f);
    }
    cJSON *loads = cJSON_AddArrayToObject(root, "loads");
    for (int32_t k = 0; k < s->n_loads; ++k) {
        cJSON *l = region(&s->loads[k].region);
        cJSON_AddItemToObject(l, "traction", vector(s->loads[k].traction));
        cJSON_AddItemToArray(loads, l);
    }

    if (!s->ground) {
        cJSON_AddBoolToObject(root, "ground", false);
    } else {
        cJSON *ground = cJSON_AddObjectToObject(root, "ground");
        if (!s->ground_auto) /* an automatic ground is placed again under the same mesh */
            cJSON_AddItemToObject(ground, "point", vector(s->ground_point));
        cJSON_AddItemToObject(ground, "normal", vector(s->ground_normal));
        add_number(ground, "stiffness", s->ground_stiffness);
    }

    cJSON *obstacles = cJSON_AddArrayToObject(root, "obstacles");
    for (int32_t k = 0; k < s->n_obstacles; ++k)
        cJSON_AddItemToArray(obstacles, obstacle(&s->obstacles[k]));
    if (s->n_cuts > 0) {
        cJSON *cuts = cJSON_AddArrayToObject(root, "cuts");
        for (int32_t k = 0; k < s->n_cuts; ++k)
            cJSON_AddItemToArray(cuts, blade(&s->cuts[k]));
    }

    cJSON *time = cJSON_AddObjectToObject(root, "time");
    add_number(time, "dt", s->dt);
    add_number(time, "frames", s->frames);
    add_number(time, "substeps", s->substeps);
    cJSON_AddBoolToObject(root, "static", s->is_static);
    return root;
}

pf_status pf_sim_json_print(cJSON *root, const char *what, char **json, pf_error *err)
{
    *json = NULL;
    char *text = root ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    PF_CHECK(text, err, PF_ERR_NOMEM, "cannot write %s as JSON", what);
    size_t n = strlen(text);
    *json = pf_alloc(n + 1);
    if (*json)
        memcpy(*json, text, n + 1);
    cJSON_free(text);
    PF_CHECK(*json, err, PF_ERR_NOMEM, "cannot write %s as JSON", what);
    return PF_OK;
}

pf_status pf_scene_to_json(const pf_scene *s, char **json, pf_error *err)
{
    return pf_sim_json_print(scene_object(s), "the scene", json, err);
}
