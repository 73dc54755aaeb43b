/* The polyhedral mesh: storage, derived adjacency, element kinds, per-element views. */
#include <pf/mesh.h>

#include <string.h>

pf_status pf_mesh_alloc(pf_mesh *m, int32_t n_nodes, int32_t n_faces, int64_t n_face_nodes,
                        int32_t n_elems, int64_t n_elem_faces, pf_error *err)
{
    memset(m, 0, sizeof *m);
    PF_CHECK(n_nodes >= 0 && n_faces >= 0 && n_elems >= 0 && n_face_nodes >= 0 &&
                 n_elem_faces >= 0,
             err, PF_ERR_INVALID, "mesh counts must be non-negative");
    m->n_nodes = n_nodes;
    m->n_faces = n_faces;
    m->n_elems = n_elems;
    m->x = pf_alloc_array(3 * (size_t)n_nodes, sizeof *m->x);
    m->face_offsets = pf_alloc_array((size_t)n_faces + 1, sizeof *m->face_offsets);
    m->face_nodes = pf_alloc_array((size_t)n_face_nodes, sizeof *m->face_nodes);
    m->elem_offsets = pf_alloc_array((size_t)n_elems + 1, sizeof *m->elem_offsets);
    m->elem_faces = pf_alloc_array((size_t)n_elem_faces, sizeof *m->elem_faces);
    if ((!m->x && n_nodes) || !m->face_offsets || (!m->face_nodes && n_face_nodes) ||
        !m->elem_offsets || (!m->elem_faces && n_elem_faces)) {
        pf_mesh_release(m);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate a mesh of %d nodes, %d faces, %d elements",
                            (int)n_nodes, (int)n_faces, (int)n_elems);
    }
    m->face_offsets[0] = 0;
    m->elem_offsets[0] = 0;
    return PF_OK;
}

void pf_mesh_release(pf_mesh *m)
{
    pf_free(m->x);
    pf_free(m->face_offsets);
    pf_free(m->face_nodes);
    pf_free(m->elem_offsets);
    pf_free(m->elem_faces);
    pf_free(m->face_elems);
    pf_free(m->elem_kind);
    pf_mesh_groups_release(m);
    memset(m, 0, sizeof *m);
}

pf_status pf_mesh_copy(pf_mesh *dst, const pf_mesh *src, pf_error *err)
{
    int64_t nfn = src->face_offsets[src->n_faces];
    int64_t nef = src->elem_offsets[src->n_elems];
    PF_TRY(pf_mesh_alloc(dst, src->n_nodes, src->n_faces, nfn, src->n_elems, nef, err));
    dst->id = src->id;
    memcpy(dst->x, src->x, 3 * (size_t)src->n_nodes * sizeof *dst->x);
    memcpy(dst->face_offsets, src->face_offsets, ((size_t)src->n_faces + 1) * sizeof(int64_t));
    memcpy(dst->face_nodes, src->face_nodes, (size_t)nfn * sizeof(uint32_t));
    memcpy(dst->elem_offsets, src->elem_offsets, ((size_t)src->n_elems + 1) * sizeof(int64_t));
    memcpy(dst->elem_faces, src->elem_faces, (size_t)nef * sizeof(uint32_t));
    PF_TRY(pf_mesh_groups_copy(dst, src, err));
    if (src->face_elems || src->elem_kind)
        return pf_mesh_derive(dst, err);
    return PF_OK;
}

const char *pf_elem_kind_name(pf_elem_kind k)
{
    switch (k) {
    case PF_ELEM_TET: return "tet";
    case PF_ELEM_HEX: return "hex";
    case PF_ELEM_POLY: return "polyhedron";
    case PF_ELEM_KIND_COUNT: break;
    }
    return "unknown";
}

/* Distinct nodes of element e, at most `cap`, in first-seen order; returns the count or cap + 1
 * when there are more. */
static int elem_distinct_nodes(const pf_mesh *m, int32_t e, uint32_t *nodes, int cap)
{
    int n = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
            uint32_t v = m->face_nodes[j];
            int seen = 0;
            for (int i = 0; i < n && !seen; ++i)
                seen = nodes[i] == v;
            if (seen)
                continue;
            if (n == cap)
                return cap + 1;
            nodes[n++] = v;
        }
    }
    return n;
}

static int elem_faces_all_of_size(const pf_mesh *m, int32_t e, int64_t size)
{
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        if (m->face_offsets[f + 1] - m->face_offsets[f] != size)
            return 0;
    }
    return 1;
}

pf_elem_kind pf_mesh_classify_elem(const pf_mesh *m, int32_t e)
{
    int64_t n_faces = m->elem_offsets[e + 1] - m->elem_offsets[e];
    uint32_t nodes[9];
    if (n_faces == 4 && elem_faces_all_of_size(m, e, 3) && elem_distinct_nodes(m, e, nodes, 8) == 4)
        return PF_ELEM_TET;
    if (n_faces != 6 || !elem_faces_all_of_size(m, e, 4) || elem_distinct_nodes(m, e, nodes, 8) != 8)
        return PF_ELEM_POLY;
    /* A hexahedron's graph: every one of its 8 corners lies on exactly 3 of its 6 quads. */
    for (int i = 0; i < 8; ++i) {
        int uses = 0;
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j)
                uses += m->face_nodes[j] == nodes[i];
        }
        if (uses != 3)
            return PF_ELEM_POLY;
    }
    return PF_ELEM_HEX;
}

pf_status pf_mesh_derive(pf_mesh *m, pf_error *err)
{
    pf_free(m->face_elems);
    pf_free(m->elem_kind);
    m->face_elems = pf_alloc_array(2 * (size_t)m->n_faces, sizeof *m->face_elems);
    m->elem_kind = pf_alloc_array((size_t)m->n_elems, sizeof *m->elem_kind);
    if ((!m->face_elems && m->n_faces) || (!m->elem_kind && m->n_elems)) {
        PF_FREE(m->face_elems);
        PF_FREE(m->elem_kind);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate adjacency");
    }
    for (int64_t i = 0; i < 2 * (int64_t)m->n_faces; ++i)
        m->face_elems[i] = -1;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            int side = (m->elem_faces[k] & PF_FACE_REVERSED) ? 1 : 0;
            if (f >= m->n_faces || m->face_elems[2 * f + side] >= 0) {
                if (f >= m->n_faces)
                    pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                                 "element %d uses face %d of %d", (int)e, (int)f,
                                 (int)m->n_faces);
                else
                    pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                                 "face %d is used twice with the same orientation (by elements "
                                 "%d and %d)",
                                 (int)f, (int)m->face_elems[2 * f + side], (int)e);
                PF_FREE(m->face_elems);
                PF_FREE(m->elem_kind);
                return PF_ERR_INVALID;
            }
            m->face_elems[2 * f + side] = e;
        }
        m->elem_kind[e] = (uint8_t)pf_mesh_classify_elem(m, e);
    }
    return PF_OK;
}

pf_status pf_mesh_elem_polyhedron(const pf_mesh *m, int32_t e, pf_arena *scratch,
                                  pf_polyhedron *out, pf_error *err)
{
    int64_t k0 = m->elem_offsets[e], k1 = m->elem_offsets[e + 1];
    int64_t n_nodes = 0;
    for (int64_t k = k0; k < k1; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        n_nodes += m->face_offsets[f + 1] - m->face_offsets[f];
    }
    int64_t *offsets = pf_arena_push(scratch, (size_t)(k1 - k0 + 1), sizeof *offsets);
    uint32_t *nodes = pf_arena_push(scratch, (size_t)n_nodes, sizeof *nodes);
    PF_CHECK(offsets && (nodes || n_nodes == 0), err, PF_ERR_NOMEM,
             "scratch arena too small for element %d", (int)e);
    offsets[0] = 0;
    for (int64_t k = k0; k < k1; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        int64_t a = m->face_offsets[f], n = m->face_offsets[f + 1] - a;
        uint32_t *dst = nodes + offsets[k - k0];
        if (m->elem_faces[k] & PF_FACE_REVERSED)
            for (int64_t j = 0; j < n; ++j)
                dst[j] = m->face_nodes[a + n - 1 - j];
        else
            memcpy(dst, m->face_nodes + a, (size_t)n * sizeof *dst);
        offsets[k - k0 + 1] = offsets[k - k0] + n;
    }
    out->x = m->x;
    out->n_faces = (int32_t)(k1 - k0);
    out->face_offsets = offsets;
    out->face_nodes = nodes;
    return PF_OK;
}

static bool on_boundary(const pf_mesh *m, int32_t f)
{
    return m->face_elems[2 * f] < 0 || m->face_elems[2 * f + 1] < 0;
}

bool pf_mesh_elem_same(const pf_mesh *a, int32_t ea, const pf_mesh *b, int32_t eb,
                       const int32_t *node_map)
{
    int64_t qa = a->elem_offsets[ea], qb = b->elem_offsets[eb];
    int64_t nf = a->elem_offsets[ea + 1] - qa;
    if (nf != b->elem_offsets[eb + 1] - qb)
        return false;
    for (int64_t k = 0; k < nf; ++k) {
        uint32_t fa = a->elem_faces[qa + k], fb = b->elem_faces[qb + k];
        int32_t ia = PF_FACE_INDEX(fa), ib = PF_FACE_INDEX(fb);
        int64_t n = a->face_offsets[ia + 1] - a->face_offsets[ia];
        if ((fa & PF_FACE_REVERSED) != (fb & PF_FACE_REVERSED) ||
            n != b->face_offsets[ib + 1] - b->face_offsets[ib] ||
            on_boundary(a, ia) != on_boundary(b, ib))
            return false;
        const uint32_t *na = a->face_nodes + a->face_offsets[ia];
        const uint32_t *nb = b->face_nodes + b->face_offsets[ib];
        for (int64_t j = 0; j < n; ++j) {
            int64_t mapped = node_map ? node_map[na[j]] : (int64_t)na[j];
            if (mapped != (int64_t)nb[j] ||
                memcmp(a->x + 3 * (size_t)na[j], b->x + 3 * (size_t)nb[j], 3 * sizeof *a->x))
                return false;
        }
    }
    if (!node_map)
        return true;
    /* the order of the element's node indices: every pair of face-node entries */
    int64_t total = 0;
    for (int64_t k = 0; k < nf; ++k) {
        int32_t f = PF_FACE_INDEX(a->elem_faces[qa + k]);
        total += a->face_offsets[f + 1] - a->face_offsets[f];
    }
    for (int64_t s = 0, ks = 0, js = 0; s < total; ++s) {
        int32_t fs = PF_FACE_INDEX(a->elem_faces[qa + ks]);
        uint32_t xs = a->face_nodes[a->face_offsets[fs] + js];
        for (int64_t kt = ks, jt = js; kt < nf;) {
            int32_t ft = PF_FACE_INDEX(a->elem_faces[qa + kt]);
            uint32_t xt = a->face_nodes[a->face_offsets[ft] + jt];
            if ((xs < xt) != (node_map[xs] < node_map[xt]))
                return false;
            if (++jt == a->face_offsets[ft + 1] - a->face_offsets[ft])
                jt = 0, ++kt;
        }
        if (++js == a->face_offsets[fs + 1] - a->face_offsets[fs])
            js = 0, ++ks;
    }
    return true;
}

double pf_mesh_elem_volume(const pf_mesh *m, int32_t e)
{
    /* Divergence theorem: V = 1/3 sum_f (x_f - r) . N_f, with N_f the Newell area vector (exact
     * for planar faces) and r a reference point on the element, which keeps the terms small at
     * large coordinate offsets. */
    int64_t k0 = m->elem_offsets[e];
    if (k0 == m->elem_offsets[e + 1])
        return 0;
    int32_t f0 = PF_FACE_INDEX(m->elem_faces[k0]);
    pf_vec3 r = pf_v3_load(m->x + 3 * (size_t)m->face_nodes[m->face_offsets[f0]]);
    double volume = 0;
    for (int64_t k = k0; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        const uint32_t *idx = m->face_nodes + m->face_offsets[f];
        int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
        pf_vec3 area = pf_polygon_area_vector(m->x, idx, n);
        pf_vec3 p = pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)idx[0]), r);
        double cone = pf_v3_dot(area, p) / 3.0;
        volume += (m->elem_faces[k] & PF_FACE_REVERSED) ? -cone : cone;
    }
    return volume;
}

double pf_mesh_volume(const pf_mesh *m)
{
    double volume = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        volume += pf_mesh_elem_volume(m, e);
    return volume;
}

void pf_mesh_bounds(const pf_mesh *m, pf_vec3 *lo, pf_vec3 *hi)
{
    *lo = *hi = pf_v3(0, 0, 0);
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        pf_vec3 p = pf_v3_load(m->x + 3 * (size_t)i);
        *lo = i ? pf_v3_min(*lo, p) : p;
        *hi = i ? pf_v3_max(*hi, p) : p;
    }
}

/* ---- groups ---------------------------------------------------------------------------------- */

pf_status pf_mesh_groups_alloc(pf_mesh *m, int32_t n_groups, pf_error *err)
{
    m->elem_group = pf_calloc((size_t)m->n_elems + 1, sizeof *m->elem_group);
    m->face_group = pf_calloc((size_t)m->n_faces + 1, sizeof *m->face_group);
    m->groups = pf_calloc((size_t)n_groups + 1, sizeof *m->groups);
    if (!m->elem_group || !m->face_group || !m->groups) {
        pf_mesh_groups_release(m);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the groups of a mesh of %d elements", (int)m->n_elems);
    }
    m->n_groups = n_groups;
    return PF_OK;
}

void pf_mesh_groups_release(pf_mesh *m)
{
    for (int32_t g = 0; m->groups && g < m->n_groups; ++g)
        pf_free(m->groups[g].name);
    pf_free(m->groups);
    pf_free(m->elem_group);
    pf_free(m->face_group);
    m->groups = NULL;
    m->elem_group = m->face_group = NULL;
    m->n_groups = 0;
}

pf_status pf_mesh_groups_copy(pf_mesh *dst, const pf_mesh *src, pf_error *err)
{
    if (!src->elem_group)
        return PF_OK;
    PF_TRY(pf_mesh_groups_alloc(dst, src->n_groups, err));
    if (dst->n_elems == src->n_elems && dst->n_faces == src->n_faces) {
        memcpy(dst->elem_group, src->elem_group, (size_t)src->n_elems * sizeof *dst->elem_group);
        memcpy(dst->face_group, src->face_group, (size_t)src->n_faces * sizeof *dst->face_group);
    }
    for (int32_t g = 0; g < src->n_groups; ++g) {
        const char *name = src->groups[g].name ? src->groups[g].name : "";
        size_t n = strlen(name);
        dst->groups[g] = src->groups[g];
        dst->groups[g].name = pf_alloc(n + 1);
        if (!dst->groups[g].name) {
            pf_mesh_groups_release(dst);
            return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                "cannot copy the group names of a mesh");
        }
        memcpy(dst->groups[g].name, name, n + 1);
    }
    return PF_OK;
}

const pf_mesh_group *pf_mesh_find_group(const pf_mesh *m, int32_t dim, const char *name,
                                        int32_t number)
{
    for (int32_t g = 0; g < m->n_groups; ++g) {
        const pf_mesh_group *p = &m->groups[g];
        if (p->dim == dim && (name ? p->name && strcmp(p->name, name) == 0 : p->number == number))
            return p;
    }
    return NULL;
}
