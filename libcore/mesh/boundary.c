/* The boundary of a polyhedral mesh: faces used by one element, each triangulated in its plane
 * (pf_polygon_triangulate), oriented outward. Drawn by the renderer, written by the exporters. */
#include <pf/mesh.h>

#include <string.h>

void pf_boundary_release(pf_boundary *b)
{
    pf_free(b->face);
    pf_free(b->elem);
    pf_free(b->reversed);
    pf_free(b->tri_offsets);
    pf_free(b->tri_edges);
    pf_free(b->tri);
    memset(b, 0, sizeof *b);
}

/* Counts the uses of every face and remembers the (last) element using each and how. */
static pf_status count_uses(const pf_mesh *m, uint8_t *uses, int32_t *elem, uint8_t *reversed,
                            pf_error *err)
{
    for (int32_t e = 0; e < m->n_elems; ++e) {
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            PF_CHECK(f < m->n_faces, err, PF_ERR_INVALID, "element %d refers to face %d of %d",
                     (int)e, (int)f, (int)m->n_faces);
            if (uses[f] < 255)
                uses[f]++;
            elem[f] = e;
            reversed[f] = (m->elem_faces[k] & PF_FACE_REVERSED) != 0;
        }
    }
    return PF_OK;
}

static pf_status check_face(const pf_mesh *m, int32_t f, pf_error *err)
{
    int64_t d = m->face_offsets[f + 1] - m->face_offsets[f];
    PF_CHECK(d >= 3 && d <= INT32_MAX, err, PF_ERR_INVALID, "face %d has %lld nodes", (int)f,
             (long long)d);
    for (int64_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; ++k)
        PF_CHECK(m->face_nodes[k] < (uint32_t)m->n_nodes, err, PF_ERR_INVALID,
                 "face %d refers to node %u of %d", (int)f, (unsigned)m->face_nodes[k],
                 (int)m->n_nodes);
    return PF_OK;
}

/* The boundary faces in mesh order, their triangle counts, and the largest face degree. */
static pf_status select_faces(const pf_mesh *m, const uint8_t *uses, const int32_t *elem,
                              const uint8_t *reversed, pf_boundary *b, int64_t *max_degree,
                              pf_error *err)
{
    int32_t nb = 0;
    for (int32_t f = 0; f < m->n_faces; ++f)
        nb += uses[f] == 1;
    if (!PF_ALLOC_N(b->face, nb) || !PF_ALLOC_N(b->elem, nb) || !PF_ALLOC_N(b->reversed, nb) ||
        !PF_ALLOC_N(b->tri_offsets, nb + 1))
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the boundary (%d faces)", (int)nb);
    b->n_faces = nb;
    b->tri_offsets[0] = 0;
    *max_degree = 3;
    for (int32_t f = 0, i = 0; f < m->n_faces; ++f) {
        if (uses[f] != 1)
            continue;
        PF_TRY(check_face(m, f, err));
        int64_t d = m->face_offsets[f + 1] - m->face_offsets[f];
        b->face[i] = f;
        b->elem[i] = elem[f];
        b->reversed[i] = reversed[f];
        b->tri_offsets[i + 1] = b->tri_offsets[i] + d - 2;
        if (d > *max_degree)
            *max_degree = d;
        ++i;
    }
    return PF_OK;
}

/* Triangulates every boundary face in its outward orientation and maps corners to mesh nodes. */
static pf_status triangulate_faces(const pf_mesh *m, pf_boundary *b, int64_t max_degree,
                                   pf_error *err)
{
    int64_t nt = b->tri_offsets[b->n_faces];
    if (!PF_ALLOC_N(b->tri, 3 * nt) || !PF_ALLOC_N(b->tri_edges, nt))
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate %lld boundary triangles", (long long)nt);
    pf_arena arena = {0};
    PF_TRY(pf_arena_init(&arena, (size_t)max_degree * 64 + 256, err));
    uint32_t *ring = pf_arena_push(&arena, (size_t)max_degree, sizeof *ring);
    pf_status s = PF_OK;
    for (int32_t i = 0; i < b->n_faces && s == PF_OK; ++i) {
        int32_t f = b->face[i];
        int64_t off = m->face_offsets[f];
        int32_t d = (int32_t)(m->face_offsets[f + 1] - off);
        for (int32_t c = 0; c < d; ++c)
            ring[c] = m->face_nodes[off + (b->reversed[i] ? d - 1 - c : c)];
        uint32_t *t = b->tri + 3 * b->tri_offsets[i];
        s = pf_polygon_triangulate(m->x, ring, d, &arena, t, b->tri_edges + b->tri_offsets[i], err);
        for (int32_t k = 0; k < 3 * (d - 2); ++k)
            t[k] = ring[t[k]];
    }
    pf_arena_release(&arena);
    return s;
}

pf_status pf_boundary_extract(const pf_mesh *m, pf_boundary *b, pf_error *err)
{
    memset(b, 0, sizeof *b);
    uint8_t *uses = pf_calloc((size_t)m->n_faces + 1, 1);
    uint8_t *reversed = pf_calloc((size_t)m->n_faces + 1, 1);
    int32_t *elem = pf_alloc_array((size_t)m->n_faces + 1, sizeof *elem);
    pf_status s = PF_OK;
    int64_t max_degree = 3;
    if (!uses || !reversed || !elem)
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                         "cannot allocate face uses for %d faces", (int)m->n_faces);
    if (s == PF_OK)
        s = count_uses(m, uses, elem, reversed, err);
    if (s == PF_OK)
        s = select_faces(m, uses, elem, reversed, b, &max_degree, err);
    if (s == PF_OK)
        s = triangulate_faces(m, b, max_degree, err);
    pf_free(uses);
    pf_free(reversed);
    pf_free(elem);
    if (s != PF_OK)
        pf_boundary_release(b);
    return s;
}
