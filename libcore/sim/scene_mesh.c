/* Scenes against a mesh: completion (pf_scene_resolve), the faces and elements a region selects
 * (boxes, planes, and the mesh's groups: Gmsh physical groups), the per-element materials, and
 * the obstacles' paths and surfaces. */
#include <pf/sim.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "scene_values.h"

pf_vec3 pf_scene_path_at(int32_t n_keys, const double *key_time, const pf_vec3 *key_translation,
                         double t)
{
    if (n_keys == 0)
        return pf_v3(0, 0, 0);
    if (t <= key_time[0])
        return key_translation[0];
    for (int32_t k = 1; k < n_keys; ++k)
        if (t < key_time[k]) {
            double s = (t - key_time[k - 1]) / (key_time[k] - key_time[k - 1]);
            return pf_v3_add(pf_v3_scale(key_translation[k - 1], 1 - s),
                             pf_v3_scale(key_translation[k], s));
        }
    return key_translation[n_keys - 1];
}

pf_vec3 pf_obstacle_translation(const pf_obstacle *o, double t)
{
    return pf_scene_path_at(o->n_keys, o->key_time, o->key_translation, t);
}

pf_status pf_scene_set_obstacle_surface(pf_scene *s, int32_t i, pf_surface *surface, pf_error *err)
{
    PF_CHECK(i >= 0 && i < s->n_obstacles && s->obstacles[i].kind == PF_OBSTACLE_MESH, err,
             PF_ERR_INVALID, "obstacles[%d]: not a mesh obstacle", (int)i);
    pf_obstacle *o = &s->obstacles[i];
    PF_CHECK(surface->n_tris > 0, err, PF_ERR_INVALID, "obstacles[%d].mesh: %s: no triangles",
             (int)i, o->file);
    pf_surface_release(&o->surface);
    o->surface = *surface;
    memset(surface, 0, sizeof *surface);
    return PF_OK;
}

/* ---- completion against a mesh, regions ------------------------------------------------------ */

void pf_scene_resolve(pf_scene *s, pf_vec3 lo, pf_vec3 hi)
{
    if (s->ground_auto) {
        /* The bounding box's extent along the normal from its 8 corners; the plane sits 5 % of
         * that extent below the lowest corner, so the body starts just above the ground. */
        pf_vec3 n = s->ground_normal;
        double smin = INFINITY, smax = -INFINITY;
        for (int c = 0; c < 8; ++c) {
            pf_vec3 corner = pf_v3(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z);
            double d = pf_v3_dot(n, corner);
            smin = fmin(smin, d);
            smax = fmax(smax, d);
        }
        s->ground_point = pf_v3_scale(n, smin - 0.05 * (smax - smin));
    }
    double tol = 1e-6 * pf_v3_dist(lo, hi);
    for (int32_t i = 0; i < s->n_fixed; ++i)
        if (s->fixed[i].region.kind == PF_REGION_PLANE && s->fixed[i].region.tol < 0)
            s->fixed[i].region.tol = tol;
    for (int32_t i = 0; i < s->n_loads; ++i)
        if (s->loads[i].region.kind == PF_REGION_PLANE && s->loads[i].region.tol < 0)
            s->loads[i].region.tol = tol;
}

bool pf_region_contains(const pf_region *r, pf_vec3 p)
{
    if (r->kind != PF_REGION_BOX && r->kind != PF_REGION_PLANE)
        return false;
    if (r->kind == PF_REGION_BOX)
        return p.x >= r->lo.x && p.x <= r->hi.x && p.y >= r->lo.y && p.y <= r->hi.y &&
               p.z >= r->lo.z && p.z <= r->hi.z;
    return fabs(pf_plane_signed_distance(r->plane, p)) <= r->tol;
}

/* The group region r names among m's groups of dimension dim, or NULL. */
static const pf_mesh_group *find_group(const pf_region *r, const pf_mesh *m, int32_t dim)
{
    return r->group_name[0] ? pf_mesh_find_group(m, dim, r->group_name, 0)
                            : pf_mesh_find_group(m, dim, NULL, r->group);
}

/* ---- lists of nodes and elements ------------------------------------------------------------ */

static bool is_list(const pf_region *r)
{
    return r->kind == PF_REGION_NODES || r->kind == PF_REGION_ELEMENTS;
}

pf_status pf_region_set_list(pf_region *r, const pf_mesh *m, const int32_t *indices, int32_t n,
                             pf_error *err)
{
    PF_CHECK(is_list(r), err, PF_ERR_INVALID, "not a region of nodes_file or elements_file");
    bool nodes = r->kind == PF_REGION_NODES;
    int32_t count = nodes ? m->n_nodes : m->n_elems;
    for (int32_t k = 0; k < n; ++k)
        PF_CHECK(indices[k] >= 0 && indices[k] < count, err, PF_ERR_INVALID,
                 "%s: %s %d out of range: the mesh has %d", r->file ? r->file : "list",
                 nodes ? "node" : "element", (int)indices[k], (int)count);
    uint8_t *listed = pf_calloc((size_t)count + 1, 1);
    PF_CHECK(listed, err, PF_ERR_NOMEM, "cannot allocate %d list flags", (int)count);
    for (int32_t k = 0; k < n; ++k)
        listed[indices[k]] = 1;
    pf_free(r->listed);
    r->listed = listed;
    r->n_listed = count;
    r->list_mesh = m->id;
    return PF_OK;
}

/* Whether the node list of r names node i. */
static bool node_listed(const pf_region *r, uint32_t i)
{
    return i < (uint32_t)r->n_listed && r->listed[i];
}

/* Whether the element list of r names element e (-1: none). */
static bool elem_listed(const pf_region *r, int32_t e)
{
    return e >= 0 && e < r->n_listed && r->listed[e];
}

/* Whether the node list of r names every node of face f. */
static bool face_nodes_listed(const pf_region *r, const pf_mesh *m, int32_t f)
{
    for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q)
        if (!node_listed(r, m->face_nodes[q]))
            return false;
    return true;
}

/* Whether list region r selects element e of m: named, or all its nodes named. */
static bool list_selects_elem(const pf_region *r, const pf_mesh *m, int32_t e)
{
    if (r->kind == PF_REGION_ELEMENTS)
        return elem_listed(r, e);
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k)
        if (!face_nodes_listed(r, m, PF_FACE_INDEX(m->elem_faces[k])))
            return false;
    return true;
}

/* A list region must have been handed over for this very mesh: its indices mean nothing on
 * another one (a simulator carries its own copy of the lists through mesh changes,
 * pf_scene_carry_lists in sim_change.h). */
static pf_status check_list(const pf_region *r, const pf_mesh *m, const char *what, int32_t k,
                            pf_error *err)
{
    if (!is_list(r))
        return PF_OK;
    const char *key = r->kind == PF_REGION_NODES ? "nodes_file" : "elements_file";
    PF_CHECK(r->listed, err, PF_ERR_INVALID,
             "%s[%d].%s: %s: the list was not handed over (pf_region_set_list)", what, (int)k, key,
             r->file ? r->file : "");
    PF_CHECK(r->list_mesh == m->id &&
                 r->n_listed == (r->kind == PF_REGION_NODES ? m->n_nodes : m->n_elems),
             err, PF_ERR_INVALID, "%s[%d].%s: %s: the list numbers mesh %llu, not mesh %llu", what,
             (int)k, key, r->file ? r->file : "", (unsigned long long)r->list_mesh,
             (unsigned long long)m->id);
    return PF_OK;
}

bool pf_region_selects_face(const pf_region *r, const pf_mesh *m, int32_t f, pf_vec3 c)
{
    if (r->kind == PF_REGION_NODES)
        return face_nodes_listed(r, m, f);
    if (r->kind == PF_REGION_ELEMENTS)
        return elem_listed(r, m->face_elems[2 * f]) || elem_listed(r, m->face_elems[2 * f + 1]);
    if (r->kind != PF_REGION_GROUP)
        return pf_region_contains(r, c);
    const pf_mesh_group *g = m->face_group ? find_group(r, m, 2) : NULL;
    return g && m->face_group[f] == g->number;
}

/* "fixed[1].group: the mesh has no group 'top' of faces (its groups: 1 'left' of faces, ...)". */
static pf_status check_group(const pf_region *r, const pf_mesh *m, int32_t dim, const char *what,
                             int32_t k, pf_error *err)
{
    if (r->kind != PF_REGION_GROUP || (m->elem_group && find_group(r, m, dim)))
        return PF_OK;
    char list[PF_ERROR_MSG_MAX / 2] = "none";
    size_t used = 0;
    for (int32_t g = 0; g < m->n_groups && used < sizeof list; ++g) {
        int n = snprintf(list + used, sizeof list - used, "%s%d '%s' of %s", g ? ", " : "",
                         (int)m->groups[g].number, m->groups[g].name,
                         m->groups[g].dim == 3 ? "elements" : "faces");
        used += n > 0 ? (size_t)n : 0;
    }
    char name[PF_GROUP_NAME_MAX + 2];
    if (r->group_name[0])
        snprintf(name, sizeof name, "'%s'", r->group_name);
    else
        snprintf(name, sizeof name, "%d", (int)r->group);
    return pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                        "%s[%d].group: the mesh has no group %s of %s (its groups: %s)", what,
                        (int)k, name, dim == 3 ? "elements" : "faces", list);
}

/* The mean of element e's faces' vertices (each vertex once per face using it). */
static pf_vec3 elem_centre(const pf_mesh *m, int32_t e)
{
    pf_vec3 sum = {0, 0, 0};
    int64_t count = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q, ++count)
            sum = pf_v3_add(sum, pf_v3_load(m->x + 3 * (size_t)m->face_nodes[q]));
    }
    return pf_v3_scale(sum, count ? 1.0 / (double)count : 0);
}

pf_status pf_scene_materials(const pf_scene *s, const pf_mesh *m, pf_material **table, int32_t *n,
                             int32_t **elem, pf_error *err)
{
    *table = NULL;
    *elem = NULL;
    *n = 0;
    for (int32_t k = 0; k < s->n_fixed; ++k) {
        PF_TRY(check_group(&s->fixed[k].region, m, 2, "fixed", k, err));
        PF_TRY(check_list(&s->fixed[k].region, m, "fixed", k, err));
    }
    for (int32_t k = 0; k < s->n_loads; ++k) {
        PF_TRY(check_group(&s->loads[k].region, m, 2, "loads", k, err));
        PF_TRY(check_list(&s->loads[k].region, m, "loads", k, err));
    }
    for (int32_t k = 0; k < s->n_materials; ++k) {
        PF_TRY(check_group(&s->materials[k].region, m, 3, "materials", k, err));
        PF_TRY(check_list(&s->materials[k].region, m, "materials", k, err));
    }
    *table = pf_alloc_array((size_t)s->n_materials + 1, sizeof **table);
    *elem = pf_calloc((size_t)m->n_elems + 1, sizeof **elem);
    if (!*table || !*elem) {
        pf_free(*table);
        pf_free(*elem);
        *table = NULL;
        *elem = NULL;
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the materials of %d elements", (int)m->n_elems);
    }
    (*table)[0] = pf_material_make(s->E, s->nu, s->density);
    for (int32_t k = 0; k < s->n_materials; ++k) {
        const pf_material_region *mr = &s->materials[k];
        (*table)[k + 1] = pf_material_make(mr->E, mr->nu, mr->density);
    }
    *n = s->n_materials + 1;
    for (int32_t e = 0; e < m->n_elems && s->n_materials > 0; ++e) {
        pf_vec3 c = elem_centre(m, e);
        for (int32_t k = 0; k < s->n_materials; ++k) {
            const pf_region *r = &s->materials[k].region;
            const pf_mesh_group *g = r->kind == PF_REGION_GROUP ? find_group(r, m, 3) : NULL;
            bool in = is_list(r) ? list_selects_elem(r, m, e)
                      : g        ? m->elem_group[e] == g->number
                                 : pf_region_contains(r, c);
            if (in) {
                (*elem)[e] = k + 1;
                break;
            }
        }
    }
    return PF_OK;
}
