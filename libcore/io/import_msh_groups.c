/* Gmsh physical groups carried into the mesh (declared in import_msh_groups.h).
 *
 * A volume's physical group tags the elements of its cells; a surface's tags the mesh faces whose
 * corners are its triangles' or quadrangles' corners, found by looking up the sorted corner
 * list among the sorted corner lists of every triangular and quadrilateral mesh face. */
#include "import_msh_groups.h"

#include <stdlib.h>
#include <string.h>

typedef struct msh_entity {
    int64_t dim, tag, physical;
} msh_entity;

typedef struct msh_face {
    int64_t node[4];
    int64_t group, elem, line;
    int32_t n;
} msh_face;

/* A face's corners, sorted, padded with UINT32_MAX, and the face they belong to. */
typedef struct face_key {
    uint32_t node[4];
    int32_t face;
} face_key;

#define BUFFER_COUNT(b, type) ((b).size / sizeof(type))
#define BUFFER_AT(b, type)    ((type *)(void *)(b).data)

pf_status pf_msh_groups_add_name(msh_groups *g, int32_t dim, int32_t number, const char *name,
                                 size_t len, pf_error *err)
{
    pf_mesh_group p = {.number = number, .dim = dim, .name = pf_alloc(len + 1)};
    PF_CHECK(p.name, err, PF_ERR_NOMEM, "out of memory reading physical names");
    memcpy(p.name, name, len);
    p.name[len] = '\0';
    pf_status st = pf_buffer_append(&g->names, &p, sizeof p, err);
    if (st < 0)
        pf_free(p.name);
    return st;
}

pf_status pf_msh_groups_add_entity(msh_groups *g, int dim, int64_t tag, int64_t physical,
                                   pf_error *err)
{
    msh_entity e = {dim, tag, physical};
    return pf_buffer_append(&g->entities, &e, sizeof e, err);
}

int64_t pf_msh_groups_entity_physical(const msh_groups *g, int64_t dim, int64_t tag)
{
    const msh_entity *e = BUFFER_AT(g->entities, const msh_entity);
    for (size_t i = 0; i < BUFFER_COUNT(g->entities, msh_entity); ++i)
        if (e[i].dim == dim && e[i].tag == tag)
            return e[i].physical;
    return 0;
}

pf_status pf_msh_groups_add_cell(msh_groups *g, int64_t group, pf_error *err)
{
    int32_t v = (int32_t)group;
    return pf_buffer_append(&g->cell_group, &v, sizeof v, err);
}

pf_status pf_msh_groups_add_face(msh_groups *g, const int64_t *corners, int n, int64_t group,
                                 int64_t elem, int64_t line, pf_error *err)
{
    msh_face f = {.group = group, .elem = elem, .line = line, .n = n};
    memcpy(f.node, corners, (size_t)n * sizeof *corners);
    return pf_buffer_append(&g->faces, &f, sizeof f, err);
}

static void sort_key(uint32_t k[4])
{
    for (int a = 1; a < 4; ++a)
        for (int b = a; b > 0 && k[b - 1] > k[b]; --b) {
            uint32_t t = k[b];
            k[b] = k[b - 1];
            k[b - 1] = t;
        }
}

static int compare_nodes(const uint32_t *a, const uint32_t *b);

static int compare_keys(const void *pa, const void *pb)
{
    const face_key *a = pa, *b = pb;
    int c = compare_nodes(a->node, b->node);
    return c ? c : (a->face > b->face) - (a->face < b->face);
}

/* Adds group (dim, number) to the list unless it is there: unnamed groups used by elements. */
static pf_status note_group(msh_groups *list, int32_t dim, int64_t number, pf_error *err)
{
    const pf_mesh_group *p = BUFFER_AT(list->names, const pf_mesh_group);
    for (size_t i = 0; i < BUFFER_COUNT(list->names, pf_mesh_group); ++i)
        if (p[i].dim == dim && p[i].number == number)
            return PF_OK;
    return pf_msh_groups_add_name(list, dim, (int32_t)number, "", 0, err);
}

/* The mesh faces of 3 or 4 corners as sorted keys. */
static face_key *face_keys(const pf_mesh *m, int32_t *n_keys, pf_error *err)
{
    face_key *keys = pf_alloc_array((size_t)m->n_faces + 1, sizeof *keys);
    if (!keys) {
        pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                     "out of memory matching physical surfaces");
        return NULL;
    }
    int32_t n = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int64_t a = m->face_offsets[f], len = m->face_offsets[f + 1] - a;
        if (len < 3 || len > 4)
            continue;
        face_key k = {{UINT32_MAX, UINT32_MAX, UINT32_MAX, UINT32_MAX}, f};
        memcpy(k.node, m->face_nodes + a, (size_t)len * sizeof *k.node);
        sort_key(k.node);
        keys[n++] = k;
    }
    qsort(keys, (size_t)n, sizeof *keys, compare_keys);
    *n_keys = n;
    return keys;
}

static int compare_nodes(const uint32_t *a, const uint32_t *b)
{
    for (int i = 0; i < 4; ++i)
        if (a[i] != b[i])
            return a[i] < b[i] ? -1 : 1;
    return 0;
}

static int32_t find_face(const face_key *keys, int32_t n, const face_key *k)
{
    int32_t lo = 0, hi = n;
    while (lo < hi) {
        int32_t mid = lo + (hi - lo) / 2;
        int c = compare_nodes(keys[mid].node, k->node);
        if (c == 0)
            return keys[mid].face;
        if (c < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return -1;
}

static pf_status tag_faces(const msh_groups *g, const int32_t *node_map, pf_mesh *m, pf_error *err)
{
    int32_t n_keys = 0;
    face_key *keys = face_keys(m, &n_keys, err);
    if (!keys)
        return PF_ERR_NOMEM;
    const msh_face *faces = BUFFER_AT(g->faces, const msh_face);
    pf_status st = PF_OK;
    for (size_t i = 0; st == PF_OK && i < BUFFER_COUNT(g->faces, msh_face); ++i) {
        const msh_face *f = &faces[i];
        face_key k = {{UINT32_MAX, UINT32_MAX, UINT32_MAX, UINT32_MAX}, 0};
        bool on_mesh = true;
        for (int c = 0; c < f->n; ++c) {
            on_mesh = on_mesh && node_map[f->node[c]] >= 0;
            k.node[c] = on_mesh ? (uint32_t)node_map[f->node[c]] : 0;
        }
        sort_key(k.node);
        int32_t face = on_mesh ? find_face(keys, n_keys, &k) : -1;
        if (face < 0)
            st = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                              "line %lld: element %lld of physical group %lld matches no face "
                              "of the volume mesh",
                              (long long)f->line, (long long)f->elem, (long long)f->group);
        else if (m->face_group[face] == 0) /* the first group listing a face keeps it */
            m->face_group[face] = (int32_t)f->group;
    }
    pf_free(keys);
    return st;
}

pf_status pf_msh_groups_apply(const msh_groups *g, const int32_t *node_map, pf_mesh *m,
                              pf_error *err)
{
    const int32_t *cell_group = BUFFER_AT(g->cell_group, const int32_t);
    const msh_face *faces = BUFFER_AT(g->faces, const msh_face);
    size_t n_faces = BUFFER_COUNT(g->faces, msh_face);
    /* the groups: the named ones in file order, then unnamed ones in order of first use */
    msh_groups list = {0};
    pf_status st = PF_OK;
    const pf_mesh_group *named = BUFFER_AT(g->names, const pf_mesh_group);
    for (size_t i = 0; st == PF_OK && i < BUFFER_COUNT(g->names, pf_mesh_group); ++i)
        if (named[i].dim >= 2) /* points and curves select nothing pf simulates */
            st = pf_msh_groups_add_name(&list, named[i].dim, named[i].number, named[i].name,
                                        strlen(named[i].name), err);
    for (int32_t e = 0; st == PF_OK && e < m->n_elems; ++e)
        if (cell_group[e] > 0)
            st = note_group(&list, 3, cell_group[e], err);
    for (size_t i = 0; st == PF_OK && i < n_faces; ++i)
        st = note_group(&list, 2, faces[i].group, err);
    int32_t n_groups = (int32_t)BUFFER_COUNT(list.names, pf_mesh_group);
    if (st == PF_OK && n_groups > 0)
        st = pf_mesh_groups_alloc(m, n_groups, err);
    if (st == PF_OK && n_groups > 0) {
        /* the names move from the list to the mesh */
        memcpy(m->groups, list.names.data, (size_t)n_groups * sizeof *m->groups);
        list.names.size = 0;
        for (int32_t e = 0; e < m->n_elems; ++e)
            m->elem_group[e] = cell_group[e];
        st = tag_faces(g, node_map, m, err);
    }
    pf_msh_groups_release(&list);
    return st;
}

void pf_msh_groups_release(msh_groups *g)
{
    pf_mesh_group *p = BUFFER_AT(g->names, pf_mesh_group);
    for (size_t i = 0; i < BUFFER_COUNT(g->names, pf_mesh_group); ++i)
        pf_free(p[i].name);
    pf_buffer_release(&g->names);
    pf_buffer_release(&g->entities);
    pf_buffer_release(&g->cell_group);
    pf_buffer_release(&g->faces);
}
