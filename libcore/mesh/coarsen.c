/* pf_mesh_coarsen: groups of elements merged into one element each, the inverse of
 * pf_mesh_refine. The faces between two elements of a group go; what the merge leaves over is
 * cleaned: pieces of one polygon that a refinement cut apart (coplanar faces between the same two
 * elements that meet along an edge of a face the merge removed) become that polygon again, and
 * the nodes that no face needs any more (used by none, or lying on a straight part of the
 * boundary of every face that has them) are dropped from every face.
 *
 * Everything but the final copy works on the groups, their faces and the faces around the nodes
 * they touch: a face that changes gets its own polygon in a pool (an overlay on src's), a face
 * that goes is marked dead, and element face lists are src's with the dead faces skipped. */
#include "coarsen_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void coarsen_release(coarsen *c)
{
    void *arrays[] = {c->group_off, c->group_elem, c->elem_group, c->face_user, c->face_state,
                      c->own_start, c->own_len,    c->pool,       c->dead,      c->edge_table,
                      c->candidate, c->node_map,   c->touched};
    for (size_t i = 0; i < sizeof arrays / sizeof *arrays; ++i)
        pf_free(arrays[i]);
    pf_buffer_release(&c->cands);
    memset(c, 0, sizeof *c);
}

#define NOMEM(err) pf_error_set((err), PF_ERR_NOMEM, __FILE__, __LINE__, "coarsen: out of memory")

pf_status pf_coarsen_set_poly(coarsen *c, int32_t f, const uint32_t *nodes, int32_t n,
                              pf_error *err)
{
    if (c->n_pool + n > c->cap_pool) {
        int64_t cap = c->cap_pool ? 2 * c->cap_pool : 1024;
        while (cap < c->n_pool + n)
            cap *= 2;
        uint32_t *q = pf_realloc_array(c->pool, (size_t)cap, sizeof *q);
        PF_CHECK(q, err, PF_ERR_NOMEM, "coarsen: out of memory");
        c->pool = q;
        c->cap_pool = cap;
    }
    memmove(c->pool + c->n_pool, nodes, (size_t)n * sizeof *nodes);
    c->own_start[f] = c->n_pool;
    c->own_len[f] = n;
    c->n_pool += n;
    c->face_state[f] = FACE_OWN;
    return PF_OK;
}

pf_status pf_coarsen_add_candidate(coarsen *c, uint32_t v, pf_error *err)
{
    if (c->candidate[v])
        return PF_OK;
    c->candidate[v] = 1;
    int32_t id = (int32_t)v;
    return pf_buffer_append(&c->cands, &id, sizeof id, err);
}

/* ---- input --------------------------------------------------------------------------------- */

/* Shapes and index ranges of src, and face_user. */
static pf_status read_mesh(coarsen *c, pf_error *err)
{
    const pf_mesh *m = c->src;
    PF_CHECK(m->n_nodes >= 0 && m->n_faces >= 0 && m->n_elems >= 0 && m->face_offsets &&
                 m->elem_offsets && (m->x || m->n_nodes == 0),
             err, PF_ERR_INVALID, "coarsen: the mesh has negative counts or missing arrays");
    int64_t nfn = m->face_offsets[m->n_faces], nef = m->elem_offsets[m->n_elems];
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int64_t k0 = m->face_offsets[f], k1 = m->face_offsets[f + 1];
        PF_CHECK(k0 >= 0 && k1 - k0 >= 3 && k1 <= nfn, err, PF_ERR_INVALID,
                 "coarsen: face %d has bad offsets or fewer than 3 nodes", (int)f);
        for (int64_t k = k0; k < k1; ++k)
            PF_CHECK(m->face_nodes[k] < (uint32_t)m->n_nodes, err, PF_ERR_INVALID,
                     "coarsen: face %d: node index %u out of range", (int)f, m->face_nodes[k]);
    }
    PF_CHECK(PF_ALLOC_N(c->face_user, 2 * (int64_t)m->n_faces) &&
                 PF_ALLOC_N(c->face_state, m->n_faces) && PF_ALLOC_N(c->own_start, m->n_faces) &&
                 PF_ALLOC_N(c->own_len, m->n_faces),
             err, PF_ERR_NOMEM, "coarsen: out of memory");
    for (int64_t i = 0; i < 2 * (int64_t)m->n_faces; ++i)
        c->face_user[i] = -1;
    memset(c->face_state, FACE_SRC, (size_t)m->n_faces);
    for (int32_t e = 0; e < m->n_elems; ++e) {
        int64_t k0 = m->elem_offsets[e], k1 = m->elem_offsets[e + 1];
        PF_CHECK(k0 >= 0 && k1 - k0 >= 4 && k1 <= nef, err, PF_ERR_INVALID,
                 "coarsen: element %d has bad offsets or fewer than 4 faces", (int)e);
        for (int64_t k = k0; k < k1; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            int side = (m->elem_faces[k] & PF_FACE_REVERSED) ? 1 : 0;
            PF_CHECK(f < m->n_faces, err, PF_ERR_INVALID,
                     "coarsen: element %d: face index %d out of range", (int)e, (int)f);
            PF_CHECK(c->face_user[2 * f + side] < 0, err, PF_ERR_INVALID,
                     "coarsen: face %d is used the same way round by elements %d and %d", (int)f,
                     (int)c->face_user[2 * f + side], (int)e);
            c->face_user[2 * f + side] = e;
        }
    }
    return PF_OK;
}

/* Groups numbered in the order of their first element (a hash of the caller's ids). */
static pf_status read_groups(coarsen *c, const int32_t *group, pf_error *err)
{
    const pf_mesh *m = c->src;
    int32_t n_in = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        PF_CHECK(group[e] >= -1, err, PF_ERR_INVALID, "coarsen: element %d has group %d (< -1)",
                 (int)e, (int)group[e]);
        n_in += group[e] >= 0;
    }
    int64_t slots = pow2_at_least(2 * (int64_t)n_in);
    int32_t *key = pf_alloc_array((size_t)slots, sizeof *key);
    int32_t *val = pf_alloc_array((size_t)slots, sizeof *val);
    int32_t *count = pf_alloc_array((size_t)n_in + 1, sizeof *count);
    pf_status st = PF_OK;
    if (!key || !val || !count || !PF_ALLOC_N(c->elem_group, m->n_elems)) {
        st = NOMEM(err);
        goto done;
    }
    for (int64_t s = 0; s < slots; ++s)
        key[s] = -1;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        c->elem_group[e] = -1;
        if (group[e] < 0)
            continue;
        uint64_t mask = (uint64_t)slots - 1, s = mix((uint64_t)group[e]) & mask;
        while (key[s] >= 0 && key[s] != group[e])
            s = (s + 1) & mask;
        if (key[s] < 0) {
            key[s] = group[e];
            val[s] = c->n_groups;
            count[c->n_groups++] = 0;
        }
        c->elem_group[e] = val[s];
        count[val[s]]++;
    }
    if (!PF_ALLOC_N(c->group_off, (int64_t)c->n_groups + 1) || !PF_ALLOC_N(c->group_elem, n_in)) {
        st = NOMEM(err);
        goto done;
    }
    c->group_off[0] = 0;
    for (int32_t g = 0; g < c->n_groups; ++g) {
        c->group_off[g + 1] = c->group_off[g] + count[g];
        count[g] = c->group_off[g];
    }
    for (int32_t e = 0; e < m->n_elems; ++e)
        if (c->elem_group[e] >= 0)
            c->group_elem[count[c->elem_group[e]]++] = e;
done:
    pf_free(key);
    pf_free(val);
    pf_free(count);
    return st;
}

/* Index of element e in its group's element list (sorted). */
static int32_t local_index(const coarsen *c, int32_t g, int32_t e)
{
    const int32_t *list = c->group_elem + c->group_off[g];
    int32_t lo = 0, hi = c->group_off[g + 1] - c->group_off[g] - 1;
    while (lo < hi) {
        int32_t mid = (lo + hi) / 2;
        if (list[mid] < e)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* Marks the faces inside each group dead and refuses a group that is not face-connected. */
static pf_status find_inner_faces(coarsen *c, const int32_t *group, pf_error *err)
{
    const pf_mesh *m = c->src;
    int32_t largest = 0;
    int64_t n_dead = 0;
    for (int32_t g = 0; g < c->n_groups; ++g)
        if (c->group_off[g + 1] - c->group_off[g] > largest)
            largest = c->group_off[g + 1] - c->group_off[g];
    int32_t *parent = pf_alloc_array((size_t)largest + 1, sizeof *parent);
    PF_CHECK(parent, err, PF_ERR_NOMEM, "coarsen: out of memory");
    pf_status st = PF_OK;
    for (int32_t g = 0; g < c->n_groups && st >= 0; ++g) {
        int32_t n = c->group_off[g + 1] - c->group_off[g];
        if (n < 2)
            continue;
        for (int32_t i = 0; i < n; ++i)
            parent[i] = i;
        for (int32_t i = 0; i < n; ++i) {
            int32_t e = c->group_elem[c->group_off[g] + i];
            for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
                int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
                int32_t a = c->face_user[2 * f], b = c->face_user[2 * f + 1];
                if (a < 0 || b < 0 || c->elem_group[a] != g || c->elem_group[b] != g)
                    continue;
                pf_uf_union(parent, local_index(c, g, a), local_index(c, g, b));
                if (e == a && c->face_state[f] != FACE_DEAD) {
                    c->face_state[f] = FACE_DEAD;
                    n_dead++;
                }
            }
        }
        for (int32_t i = 1; i < n && st >= 0; ++i)
            if (pf_uf_find(parent, i) != 0)
                st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                                  "coarsen: group %d is not face-connected: element %d shares no "
                                  "chain of faces with element %d",
                                  (int)group[c->group_elem[c->group_off[g]]],
                                  (int)c->group_elem[c->group_off[g] + i],
                                  (int)c->group_elem[c->group_off[g]]);
    }
    pf_free(parent);
    PF_TRY(st);
    PF_CHECK(PF_ALLOC_N(c->dead, n_dead), err, PF_ERR_NOMEM, "coarsen: out of memory");
    for (int32_t g = 0; g < c->n_groups; ++g)
        for (int32_t i = c->group_off[g]; i < c->group_off[g + 1]; ++i) {
            int32_t e = c->group_elem[i];
            for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
                int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
                if (c->face_state[f] == FACE_DEAD && c->face_user[2 * f] == e)
                    c->dead[c->n_dead++] = f;
            }
        }
    return PF_OK;
}

/* ---- the result ------------------------------------------------------------------------------ */

/* Whether dst element d has the faces of src element e node for node through node_map. */
static bool same_faces(const coarsen *c, int32_t e, const pf_mesh *dst, int32_t d)
{
    const pf_mesh *m = c->src;
    int64_t n = m->elem_offsets[e + 1] - m->elem_offsets[e];
    if (dst->elem_offsets[d + 1] - dst->elem_offsets[d] != n)
        return false;
    for (int64_t k = 0; k < n; ++k) {
        uint32_t es = m->elem_faces[m->elem_offsets[e] + k];
        uint32_t ed = dst->elem_faces[dst->elem_offsets[d] + k];
        if ((es & PF_FACE_REVERSED) != (ed & PF_FACE_REVERSED))
            return false;
        int32_t fs = PF_FACE_INDEX(es), fd = PF_FACE_INDEX(ed);
        int64_t len = m->face_offsets[fs + 1] - m->face_offsets[fs];
        if (dst->face_offsets[fd + 1] - dst->face_offsets[fd] != len)
            return false;
        for (int64_t j = 0; j < len; ++j)
            if ((uint32_t)c->node_map[m->face_nodes[m->face_offsets[fs] + j]] !=
                dst->face_nodes[dst->face_offsets[fd] + j])
                return false;
    }
    return true;
}

/* Appends element e's live face entries to dst's element list at *at. */
static void put_entries(const coarsen *c, int32_t e, const int32_t *face_map, pf_mesh *dst,
                        int64_t *at)
{
    const pf_mesh *m = c->src;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        if (c->face_state[f] != FACE_DEAD)
            dst->elem_faces[(*at)++] =
                (uint32_t)face_map[f] | (m->elem_faces[k] & PF_FACE_REVERSED);
    }
}

static pf_status build_output(coarsen *c, pf_mesh *dst, pf_coarsen_result *res, pf_error *err)
{
    const pf_mesh *m = c->src;
    int32_t n_nodes = 0, n_faces = 0, n_elems = 0;
    for (int32_t v = 0; v < m->n_nodes; ++v)
        c->node_map[v] = c->candidate[v] == 2 ? -1 : n_nodes++;
    int32_t *face_map = pf_alloc_array((size_t)m->n_faces + 1, sizeof *face_map);
    PF_CHECK(face_map, err, PF_ERR_NOMEM, "coarsen: out of memory");
    int64_t nfn = 0, nef = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int32_t n = 0;
        face_map[f] = c->face_state[f] == FACE_DEAD ? -1 : n_faces++;
        if (face_map[f] >= 0)
            poly(c, f, &n);
        nfn += n;
    }
    for (int32_t e = 0; e < m->n_elems; ++e) {
        int32_t g = c->elem_group[e];
        if (g >= 0 && c->group_elem[c->group_off[g]] != e)
            continue;
        n_elems++;
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k)
            nef += c->face_state[PF_FACE_INDEX(m->elem_faces[k])] != FACE_DEAD;
        for (int32_t i = g >= 0 ? c->group_off[g] + 1 : 0; g >= 0 && i < c->group_off[g + 1]; ++i) {
            int32_t o = c->group_elem[i];
            for (int64_t k = m->elem_offsets[o]; k < m->elem_offsets[o + 1]; ++k)
                nef += c->face_state[PF_FACE_INDEX(m->elem_faces[k])] != FACE_DEAD;
        }
    }
    pf_status st = pf_mesh_alloc(dst, n_nodes, n_faces, nfn, n_elems, nef, err);
    if (st >= 0 && (!PF_ALLOC_N(res->parent, n_elems) || !PF_ALLOC_N(res->changed, n_elems) ||
                    !PF_ALLOC_N(res->node_map, m->n_nodes) || !PF_ALLOC_N(res->face_src, n_faces)))
        st = NOMEM(err);
    if (st < 0) {
        pf_free(face_map);
        return st;
    }
    dst->id = m->id + 1;
    for (int32_t v = 0; v < m->n_nodes; ++v)
        if (c->node_map[v] >= 0)
            memcpy(dst->x + 3 * (size_t)c->node_map[v], m->x + 3 * (size_t)v, 3 * sizeof(double));
    memcpy(res->node_map, c->node_map, (size_t)m->n_nodes * sizeof *res->node_map);
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int32_t g = face_map[f], n;
        if (g < 0)
            continue;
        const uint32_t *p = poly(c, f, &n);
        int64_t at = dst->face_offsets[g];
        for (int32_t k = 0; k < n; ++k)
            dst->face_nodes[at + k] = (uint32_t)c->node_map[p[k]];
        dst->face_offsets[g + 1] = at + n;
        res->face_src[g] = c->face_state[f] == FACE_SRC ? f : -1;
    }
    int32_t d = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        int32_t g = c->elem_group[e];
        if (g >= 0 && c->group_elem[c->group_off[g]] != e)
            continue;
        int64_t at = dst->elem_offsets[d];
        int32_t n = g >= 0 ? c->group_off[g + 1] - c->group_off[g] : 1;
        for (int32_t i = 0; i < n; ++i)
            put_entries(c, g >= 0 ? c->group_elem[c->group_off[g] + i] : e, face_map, dst, &at);
        dst->elem_offsets[d + 1] = at;
        res->parent[d] = e;
        if (n >= 2)
            res->n_merged++;
        d++;
    }
    for (d = 0; d < n_elems; ++d) {
        int32_t e = res->parent[d], g = c->elem_group[e];
        bool merged = g >= 0 && c->group_off[g + 1] - c->group_off[g] >= 2;
        res->changed[d] = merged || (c->touched[e] && !same_faces(c, e, dst, d));
    }
    pf_free(face_map);
    return pf_mesh_derive(dst, err);
}

void pf_coarsen_result_release(pf_coarsen_result *r)
{
    pf_free(r->parent);
    pf_free(r->node_map);
    pf_free(r->changed);
    pf_free(r->face_src);
    memset(r, 0, sizeof *r);
}

pf_status pf_mesh_coarsen(const pf_mesh *src, const int32_t *group, pf_mesh *dst,
                          pf_coarsen_result *res, pf_error *err)
{
    PF_CHECK(src && dst && res && (group || src->n_elems == 0), err, PF_ERR_INVALID,
             "coarsen: NULL argument");
    memset(dst, 0, sizeof *dst);
    memset(res, 0, sizeof *res);
    coarsen c;
    memset(&c, 0, sizeof c);
    c.src = src;
    pf_status st = read_mesh(&c, err);
    if (st >= 0)
        st = read_groups(&c, group, err);
    if (st >= 0)
        st = find_inner_faces(&c, group, err);
    if (st >= 0 && (!(c.candidate = pf_calloc((size_t)src->n_nodes + 1, 1)) ||
                    !(c.touched = pf_calloc((size_t)src->n_elems + 1, 1)) ||
                    !PF_ALLOC_N(c.node_map, src->n_nodes)))
        st = NOMEM(err);
    for (int64_t i = 0; i < c.n_dead && st >= 0; ++i) {
        int32_t n;
        const uint32_t *p = poly(&c, c.dead[i], &n);
        for (int32_t k = 0; k < n && st >= 0; ++k)
            st = pf_coarsen_add_candidate(&c, p[k], err);
    }
    if (st >= 0)
        st = pf_coarsen_cut_edges(&c, err);
    if (st >= 0)
        st = pf_coarsen_unite(&c, err);
    int32_t n_removed = 0;
    if (st >= 0)
        st = pf_coarsen_remove_nodes(&c, &n_removed, err);
    if (st >= 0)
        st = build_output(&c, dst, res, err);
    res->n_removed_nodes = n_removed;
    coarsen_release(&c);
    if (st < 0) {
        pf_mesh_release(dst);
        pf_coarsen_result_release(res);
    }
    return st;
}
