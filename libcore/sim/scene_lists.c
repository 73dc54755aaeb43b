/* Node and element lists through mesh changes (sim_change.h): a list numbers the nodes and
 * elements of one mesh, so a simulator whose mesh changes keeps its own copy of the scene whose
 * lists number its current mesh. An element's children inherit its membership; an old node
 * keeps its own; a new node is named when it lies on an old face all of whose nodes the list
 * named, so the faces a split makes of a listed face are listed faces again. */
#include <math.h>
#include <string.h>

#include "sim_change.h"

static bool is_list(const pf_region *r)
{
    return r->kind == PF_REGION_NODES || r->kind == PF_REGION_ELEMENTS;
}

static bool scene_has_lists(const pf_scene *s)
{
    for (int32_t k = 0; k < s->n_fixed; ++k)
        if (is_list(&s->fixed[k].region))
            return true;
    for (int32_t k = 0; k < s->n_loads; ++k)
        if (is_list(&s->loads[k].region))
            return true;
    for (int32_t k = 0; k < s->n_materials; ++k)
        if (is_list(&s->materials[k].region))
            return true;
    return false;
}

/* Whether every node of face f of m is named by the node list flags listed. */
static bool face_listed(const uint8_t *listed, const pf_mesh *m, int32_t f)
{
    for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q)
        if (!listed[m->face_nodes[q]])
            return false;
    return true;
}

/* Whether x lies on face f of m: within 1e-9 of the face's diameter from its plane and inside
 * every edge (the faces of pf meshes and their splits are convex polygons). */
static bool on_face(const pf_mesh *m, int32_t f, pf_vec3 x)
{
    const uint32_t *idx = m->face_nodes + m->face_offsets[f];
    int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
    pf_vec3 a = pf_polygon_area_vector(m->x, idx, n);
    double area = pf_v3_norm(a);
    if (!(area > 0))
        return false;
    pf_vec3 normal = pf_v3_scale(a, 1 / area);
    double tol = 1e-9 * pf_polygon_diameter(m->x, idx, n);
    pf_vec3 c = pf_polygon_centroid(m->x, idx, n);
    if (fabs(pf_v3_dot(normal, pf_v3_sub(x, c))) > tol)
        return false;
    for (int64_t k = 0; k < n; ++k) {
        pf_vec3 p = pf_v3_load(m->x + 3 * (size_t)idx[k]);
        pf_vec3 q = pf_v3_load(m->x + 3 * (size_t)idx[(k + 1) % n]);
        pf_vec3 e = pf_v3_sub(q, p);
        if (pf_v3_dot(pf_v3_cross(e, pf_v3_sub(x, p)), normal) < -tol * pf_v3_norm(e))
            return false;
    }
    return true;
}

/* Whether new node i of m lies on a listed face of the parent of one of m's elements using it
 * (old: the list's flags on the old mesh). */
static bool new_node_listed(const uint8_t *old, const pf_mesh *old_mesh, const pf_mesh *m,
                            const int32_t *parent, const int32_t *users, int64_t n_users, int32_t i)
{
    pf_vec3 x = pf_v3_load(m->x + 3 * (size_t)i);
    for (int64_t u = 0; u < n_users; ++u) {
        int32_t p = parent[users[u]];
        for (int64_t k = old_mesh->elem_offsets[p]; k < old_mesh->elem_offsets[p + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(old_mesh->elem_faces[k]);
            if (face_listed(old, old_mesh, f) && on_face(old_mesh, f, x))
                return true;
        }
    }
    return false;
}

/* The elements of m using each node, as CSR: offsets [n_nodes + 1], elems. */
static pf_status node_users(const pf_mesh *m, int64_t **offsets, int32_t **elems, pf_error *err)
{
    int64_t *off = pf_calloc((size_t)m->n_nodes + 2, sizeof *off);
    PF_CHECK(off, err, PF_ERR_NOMEM, "cannot allocate %d node offsets", (int)m->n_nodes);
    int64_t total = 0;
    for (int pass = 0; pass < 2; ++pass) {
        for (int32_t e = 0; e < m->n_elems; ++e)
            for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
                int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
                for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q)
                    if (pass == 0)
                        off[m->face_nodes[q] + 1]++;
                    else
                        (*elems)[off[m->face_nodes[q]]++] = e;
            }
        if (pass == 0) {
            for (int32_t i = 0; i < m->n_nodes; ++i)
                off[i + 1] += off[i];
            total = off[m->n_nodes];
            *elems = pf_alloc_array((size_t)total + 1, sizeof **elems);
            if (!*elems) {
                pf_free(off);
                return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                    "cannot allocate %lld node uses", (long long)total);
            }
        }
    }
    for (int32_t i = m->n_nodes; i > 0; --i) /* the fill moved every start to the next one's */
        off[i] = off[i - 1];
    off[0] = 0;
    *offsets = off;
    return PF_OK;
}

/* What carrying a list needs: the meshes, the change, and the elements of m using each node. */
typedef struct region_carry {
    const pf_mesh *old_mesh, *m;
    const pf_mesh_change *change;
    int64_t *use_off; /* [m->n_nodes + 1] */
    int32_t *users;
} region_carry;

/* Region r's list on the new mesh from old, its flags on the old mesh (nothing for a region
 * that is not a list). */
static pf_status carry_region(const region_carry *c, pf_region *r, const uint8_t *old,
                              pf_error *err)
{
    if (!is_list(r))
        return PF_OK;
    const pf_mesh *old_mesh = c->old_mesh, *m = c->m;
    const pf_mesh_change *change = c->change;
    bool nodes = r->kind == PF_REGION_NODES;
    int32_t count = nodes ? m->n_nodes : m->n_elems;
    uint8_t *listed = pf_calloc((size_t)count + 1, 1);
    PF_CHECK(listed, err, PF_ERR_NOMEM, "cannot allocate %d list flags", (int)count);
    if (!nodes) {
        for (int32_t e = 0; e < m->n_elems; ++e)
            listed[e] = old[change->parent[e]];
    } else {
        uint8_t *from_old = pf_calloc((size_t)count + 1, 1);
        if (!from_old) {
            pf_free(listed);
            return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "no node flags");
        }
        for (int32_t i = 0; i < old_mesh->n_nodes; ++i) {
            int32_t j = change->node_map ? change->node_map[i] : i;
            if (j >= 0 && j < count) {
                listed[j] = old[i];
                from_old[j] = 1;
            }
        }
        for (int32_t i = 0; i < count; ++i)
            if (!from_old[i])
                listed[i] =
                    new_node_listed(old, old_mesh, m, change->parent, c->users + c->use_off[i],
                                    c->use_off[i + 1] - c->use_off[i], i);
        pf_free(from_old);
    }
    r->listed = listed;
    r->n_listed = count;
    r->list_mesh = m->id;
    return PF_OK;
}

/* A copy of the array of n items of size bytes at src (NULL for none). */
static void *copy_array(const void *src, int32_t n, size_t size)
{
    void *dst = pf_alloc_array((size_t)n + 1, size);
    if (dst && n > 0)
        memcpy(dst, src, (size_t)n * size);
    return dst;
}

pf_status pf_scene_carry_lists(const pf_scene *src, const pf_mesh *old_mesh, const pf_mesh *m,
                               const pf_mesh_change *change, pf_scene **out, pf_error *err)
{
    *out = NULL;
    if (!scene_has_lists(src))
        return PF_OK;
    pf_scene *s = pf_calloc(1, sizeof *s);
    PF_CHECK(s, err, PF_ERR_NOMEM, "cannot allocate the scene on the new mesh");
    *s = *src;
    s->fixed = copy_array(src->fixed, src->n_fixed, sizeof *s->fixed);
    s->loads = copy_array(src->loads, src->n_loads, sizeof *s->loads);
    s->materials = copy_array(src->materials, src->n_materials, sizeof *s->materials);
    if (!s->fixed || !s->loads || !s->materials) {
        pf_scene_free_lists(&s);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "no region copies");
    }
    /* the copy's flags are its own: none until carried */
    for (int32_t k = 0; k < s->n_fixed; ++k)
        s->fixed[k].region.listed = NULL;
    for (int32_t k = 0; k < s->n_loads; ++k)
        s->loads[k].region.listed = NULL;
    for (int32_t k = 0; k < s->n_materials; ++k)
        s->materials[k].region.listed = NULL;
    region_carry c = {.old_mesh = old_mesh, .m = m, .change = change};
    pf_status st = node_users(m, &c.use_off, &c.users, err);
    for (int32_t k = 0; st >= 0 && k < s->n_fixed; ++k)
        st = carry_region(&c, &s->fixed[k].region, src->fixed[k].region.listed, err);
    for (int32_t k = 0; st >= 0 && k < s->n_loads; ++k)
        st = carry_region(&c, &s->loads[k].region, src->loads[k].region.listed, err);
    for (int32_t k = 0; st >= 0 && k < s->n_materials; ++k)
        st = carry_region(&c, &s->materials[k].region, src->materials[k].region.listed, err);
    pf_free(c.use_off);
    pf_free(c.users);
    *out = s;
    if (st < 0)
        pf_scene_free_lists(out);
    return st;
}

void pf_scene_free_lists(pf_scene **sp)
{
    pf_scene *s = *sp;
    if (!s)
        return;
    for (int32_t k = 0; s->fixed && k < s->n_fixed; ++k)
        pf_free(s->fixed[k].region.listed);
    for (int32_t k = 0; s->loads && k < s->n_loads; ++k)
        pf_free(s->loads[k].region.listed);
    for (int32_t k = 0; s->materials && k < s->n_materials; ++k)
        pf_free(s->materials[k].region.listed);
    pf_free(s->fixed);
    pf_free(s->loads);
    pf_free(s->materials);
    pf_free(s);
    *sp = NULL;
}
