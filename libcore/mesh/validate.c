/* pf_mesh_validate: the first offending entity of a mesh, or PF_OK. */
#include <pf/mesh.h>

#include <stdlib.h>
#include <string.h>

pf_mesh_validate_params pf_mesh_validate_params_default(void)
{
    return (pf_mesh_validate_params){.planarity_tol = 1e-9, .duplicate_tol = 1e-12};
}

static pf_status check_shapes(const pf_mesh *m, pf_error *err)
{
    PF_CHECK(m->n_nodes >= 0 && m->n_faces >= 0 && m->n_elems >= 0, err, PF_ERR_INVALID,
             "negative mesh counts");
    PF_CHECK(m->face_offsets && m->elem_offsets && (m->x || m->n_nodes == 0), err, PF_ERR_INVALID,
             "mesh arrays missing");
    PF_CHECK(m->face_offsets[0] == 0 && m->elem_offsets[0] == 0, err, PF_ERR_INVALID,
             "offsets must start at 0");
    for (int32_t f = 0; f < m->n_faces; ++f) {
        PF_CHECK(m->face_offsets[f + 1] > m->face_offsets[f], err, PF_ERR_INVALID,
                 "face %d has no nodes (offsets not increasing)", (int)f);
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j)
            PF_CHECK(m->face_nodes[j] < (uint32_t)m->n_nodes, err, PF_ERR_INVALID,
                     "face %d references node %u of %d", (int)f, m->face_nodes[j],
                     (int)m->n_nodes);
    }
    for (int32_t e = 0; e < m->n_elems; ++e) {
        PF_CHECK(m->elem_offsets[e + 1] > m->elem_offsets[e], err, PF_ERR_INVALID,
                 "element %d has no faces (offsets not increasing)", (int)e);
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k)
            PF_CHECK(PF_FACE_INDEX(m->elem_faces[k]) < m->n_faces, err, PF_ERR_INVALID,
                     "element %d references face %d of %d", (int)e,
                     (int)PF_FACE_INDEX(m->elem_faces[k]), (int)m->n_faces);
    }
    return PF_OK;
}

static pf_status check_finite(const pf_mesh *m, pf_error *err)
{
    for (int32_t i = 0; i < m->n_nodes; ++i)
        PF_CHECK(pf_v3_isfinite(pf_v3_load(m->x + 3 * (size_t)i)), err, PF_ERR_INVALID,
                 "node %d has a non-finite coordinate", (int)i);
    return PF_OK;
}

static pf_status check_face(const pf_mesh *m, int32_t f, const pf_mesh_validate_params *p,
                            pf_error *err)
{
    const uint32_t *idx = m->face_nodes + m->face_offsets[f];
    int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
    double diameter = pf_polygon_diameter(m->x, idx, n);
    double dup = p->duplicate_tol * diameter;
    int64_t distinct = 0;
    for (int64_t i = 0; i < n; ++i) {
        pf_vec3 a = pf_v3_load(m->x + 3 * (size_t)idx[i]);
        int repeated = 0;
        for (int64_t j = 0; j < i && !repeated; ++j)
            repeated = idx[j] == idx[i] || pf_v3_dist(a, pf_v3_load(m->x + 3 * (size_t)idx[j])) <= dup;
        distinct += !repeated;
    }
    PF_CHECK(distinct >= 3, err, PF_ERR_INVALID, "face %d has %lld distinct nodes (needs 3)",
             (int)f, (long long)distinct);
    double planarity = pf_polygon_planarity_error(m->x, idx, n);
    PF_CHECK(planarity <= p->planarity_tol * diameter, err, PF_ERR_INVALID,
             "face %d is not planar: a node lies %.3g from its plane (%.3g of the face size)",
             (int)f, planarity, planarity / diameter);
    return PF_OK;
}

static pf_status check_face_uses(const pf_mesh *m, pf_error *err)
{
    uint8_t *uses = pf_calloc((size_t)m->n_faces, 1); /* bit 0: as stored, bit 1: reversed */
    PF_CHECK(uses || m->n_faces == 0, err, PF_ERR_NOMEM, "cannot allocate face use flags");
    pf_status s = PF_OK;
    for (int32_t e = 0; e < m->n_elems && s == PF_OK; ++e) {
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1] && s == PF_OK; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            uint8_t bit = (m->elem_faces[k] & PF_FACE_REVERSED) ? 2 : 1;
            if (uses[f] & bit)
                s = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                                 "face %d is used twice with the same orientation (again by "
                                 "element %d): used by more than two elements or inconsistently "
                                 "oriented",
                                 (int)f, (int)e);
            uses[f] |= bit;
        }
    }
    for (int32_t f = 0; f < m->n_faces && s == PF_OK; ++f)
        if (!uses[f])
            s = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                             "face %d is used by no element", (int)f);
    pf_free(uses);
    return s;
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static int64_t count_key(const uint64_t *sorted, int64_t n, uint64_t key)
{
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (sorted[mid] < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    int64_t c = 0;
    while (lo + c < n && sorted[lo + c] == key)
        ++c;
    return c;
}

/* Closed and consistently oriented: with every face turned outward, each directed edge a->b is
 * matched by as many b->a (a surface without boundary, orientations agreeing across edges). */
static pf_status check_closed(const pf_mesh *m, int32_t e, uint64_t *edges, pf_error *err)
{
    int64_t n = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        int reversed = (m->elem_faces[k] & PF_FACE_REVERSED) != 0;
        int64_t a = m->face_offsets[f], len = m->face_offsets[f + 1] - a;
        for (int64_t j = 0; j < len; ++j) {
            uint64_t u = m->face_nodes[a + j], v = m->face_nodes[a + (j + 1) % len];
            if (u == v)
                continue;
            edges[n++] = reversed ? (v << 32 | u) : (u << 32 | v);
        }
    }
    qsort(edges, (size_t)n, sizeof *edges, compare_u64);
    for (int64_t i = 0; i < n; ++i) {
        uint64_t key = edges[i], twin = (key << 32) | (key >> 32);
        if (i > 0 && edges[i - 1] == key)
            continue;
        int64_t forward = count_key(edges + i, n - i, key);
        int64_t backward = count_key(edges, n, twin);
        /* An odd number of uses of the undirected edge: a hole; even but unbalanced: a face
         * turned the wrong way. */
        PF_CHECK(forward == backward, err, PF_ERR_INVALID,
                 "element %d is %s at edge %u-%u", (int)e,
                 (forward + backward) % 2 ? "not closed" : "not consistently oriented",
                 (unsigned)(key >> 32), (unsigned)(key & 0xffffffffu));
    }
    return PF_OK;
}

static pf_status check_elements(const pf_mesh *m, pf_error *err)
{
    int64_t max_edges = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        int64_t n = 0;
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            n += m->face_offsets[f + 1] - m->face_offsets[f];
        }
        max_edges = n > max_edges ? n : max_edges;
    }
    uint64_t *edges = pf_alloc_array((size_t)max_edges, sizeof *edges);
    PF_CHECK(edges || max_edges == 0, err, PF_ERR_NOMEM, "cannot allocate edge scratch");
    pf_status s = PF_OK;
    for (int32_t e = 0; e < m->n_elems && s == PF_OK; ++e) {
        s = check_closed(m, e, edges, err);
        if (s == PF_OK) {
            double v = pf_mesh_elem_volume(m, e);
            if (!(v > 0))
                s = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                                 "element %d has non-positive volume %.6g", (int)e, v);
        }
    }
    pf_free(edges);
    return s;
}

pf_status pf_mesh_validate(const pf_mesh *m, const pf_mesh_validate_params *params, pf_error *err)
{
    pf_mesh_validate_params p = params ? *params : pf_mesh_validate_params_default();
    PF_TRY(check_shapes(m, err));
    PF_TRY(check_finite(m, err));
    for (int32_t f = 0; f < m->n_faces; ++f)
        PF_TRY(check_face(m, f, &p, err));
    PF_TRY(check_face_uses(m, err));
    PF_TRY(check_elements(m, err));
    return PF_OK;
}
