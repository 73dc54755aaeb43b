/* pf_mesh_refine: elements split into children on a working copy of the mesh that every request
 * edits in turn, so that the mesh stays conforming after each one (harmonic paper sec. 8: no
 * hanging nodes; DG paper sec. 9.3: only faces the cut touches change).
 *
 * The working mesh keeps faces and element face lists as ranges of two pools (an edited list is
 * rewritten at the pool's end), each face's two users, and node -> face incidences as linked
 * lists, so a request costs time in the faces around its element only. A split element's children
 * come from refine_split.c in local numbering; here they get mesh nodes (merged by exact
 * coordinates with the nodes of earlier requests), their faces are matched (caps between two
 * children, the parts of each element face), the neighbour across a cut face takes the parts
 * reversed, and the nodes made on each element edge are inserted into every other face along
 * that edge. */
#include <pf/refine.h>

#include "mesh_internal.h"
#include "refine_internal.h"

#include <math.h>
#include <string.h>

enum { FACE_ALIVE = 1, FACE_EDITED = 2 };

typedef struct work {
    const pf_mesh *src;
    /* nodes */
    int32_t n_nodes;
    int64_t cap_nodes;
    double *x;          /* [3 cap_nodes] */
    int32_t *adj_head;  /* [cap_nodes] first incidence of the node, -1 none */
    int32_t *local_of;  /* [cap_nodes] index in the element being split, -1 otherwise */
    int64_t node_slots; /* hash of the nodes made by this call, by exact coordinates */
    int32_t *node_table;
    int32_t n_made;
    /* node -> face incidences */
    int64_t n_adj, cap_adj;
    int32_t *adj_face, *adj_next;
    /* faces */
    int32_t n_faces;
    int64_t cap_faces;
    int64_t *face_start; /* [cap_faces] into fpool */
    int32_t *face_len;
    int32_t *face_user;  /* [2 cap_faces] element using the face as stored, then reversed; -1 */
    uint8_t *face_flags; /* FACE_ALIVE | FACE_EDITED (nodes differ from src's) */
    int64_t n_fpool, cap_fpool;
    uint32_t *fpool;
    /* elements: the first src->n_elems are src's, children appended */
    int32_t n_elems;
    int64_t cap_elems;
    int64_t *elem_start; /* into epool */
    int32_t *elem_len;
    uint8_t *elem_changed;
    int64_t n_epool, cap_epool;
    uint32_t *epool;
    int32_t *child_first, *child_count; /* [src->n_elems] */
    /* per split scratch */
    refine_local L;
    pf_buffer edges;   /* int32 (a, b, first, count) per element edge that got nodes */
    pf_buffer mids;    /* int32 the nodes on those edges, from a to b */
    pf_buffer scratch; /* uint32 */
    pf_buffer entries; /* uint32 the children's face entries */
} work;

/* Same capacity for several parallel arrays. */
#define GROW_WITH(ptr, old_cap, new_cap, err)                                                      \
    do {                                                                                           \
        int64_t c_ = (old_cap);                                                                    \
        PF_TRY(pf_refine_grow(&(ptr), &c_, (new_cap), sizeof *(ptr), (err)));                      \
    } while (0)

static void work_release(work *w)
{
    void *arrays[] = {w->x,           w->adj_head,   w->local_of, w->node_table,   w->adj_face,
                      w->adj_next,    w->face_start, w->face_len, w->face_user,    w->face_flags,
                      w->fpool,       w->elem_start, w->elem_len, w->elem_changed, w->epool,
                      w->child_first, w->child_count};
    for (size_t i = 0; i < sizeof arrays / sizeof *arrays; ++i)
        pf_free(arrays[i]);
    pf_refine_local_release(&w->L);
    pf_buffer_release(&w->edges);
    pf_buffer_release(&w->mids);
    pf_buffer_release(&w->scratch);
    pf_buffer_release(&w->entries);
    memset(w, 0, sizeof *w);
}

/* ---- nodes --------------------------------------------------------------------------------- */

static pf_status reserve_nodes(work *w, int64_t n, pf_error *err)
{
    if (n <= w->cap_nodes)
        return PF_OK;
    int64_t cap = w->cap_nodes;
    PF_TRY(pf_refine_grow(&w->adj_head, &cap, n, sizeof *w->adj_head, err));
    GROW_WITH(w->local_of, w->cap_nodes, cap, err);
    GROW_WITH(w->x, 3 * w->cap_nodes, 3 * cap, err);
    w->cap_nodes = cap;
    return PF_OK;
}

static void hash_insert(work *w, int32_t id)
{
    uint64_t mask = (uint64_t)w->node_slots - 1;
    for (uint64_t s = pf_hash_point(w->x + 3 * (size_t)id) & mask;; s = (s + 1) & mask)
        if (w->node_table[s] < 0) {
            w->node_table[s] = id;
            return;
        }
}

/* The mesh node at p among those this call made, or a new one. */
static pf_status made_node(work *w, const double *p, int32_t *id, pf_error *err)
{
    if (2 * ((int64_t)w->n_made + 1) > w->node_slots) {
        int64_t slots = w->node_slots ? 2 * w->node_slots : 256;
        pf_free(w->node_table);
        w->node_table = pf_alloc_array((size_t)slots, sizeof *w->node_table);
        PF_CHECK(w->node_table, err, PF_ERR_NOMEM, "refine: out of memory");
        w->node_slots = slots;
        for (int64_t s = 0; s < slots; ++s)
            w->node_table[s] = -1;
        for (int32_t i = w->src->n_nodes; i < w->n_nodes; ++i)
            hash_insert(w, i);
    }
    uint64_t mask = (uint64_t)w->node_slots - 1;
    for (uint64_t s = pf_hash_point(p) & mask; w->node_table[s] >= 0; s = (s + 1) & mask) {
        const double *q = w->x + 3 * (size_t)w->node_table[s];
        if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) {
            *id = w->node_table[s];
            return PF_OK;
        }
    }
    PF_CHECK(w->n_nodes < INT32_MAX - 1, err, PF_ERR_TOO_LARGE, "refine: more than 2^31 nodes");
    PF_TRY(reserve_nodes(w, (int64_t)w->n_nodes + 1, err));
    int32_t n = w->n_nodes++;
    memcpy(w->x + 3 * (size_t)n, p, 3 * sizeof *p);
    w->adj_head[n] = -1;
    w->local_of[n] = -1;
    w->n_made++;
    hash_insert(w, n);
    *id = n;
    return PF_OK;
}

static pf_status add_incidence(work *w, int32_t node, int32_t face, pf_error *err)
{
    PF_CHECK(w->n_adj < INT32_MAX, err, PF_ERR_TOO_LARGE, "refine: more than 2^31 face nodes");
    if (w->n_adj + 1 > w->cap_adj) {
        int64_t cap = w->cap_adj;
        PF_TRY(pf_refine_grow(&w->adj_face, &cap, w->n_adj + 1, sizeof *w->adj_face, err));
        GROW_WITH(w->adj_next, w->cap_adj, cap, err);
        w->cap_adj = cap;
    }
    w->adj_face[w->n_adj] = face;
    w->adj_next[w->n_adj] = w->adj_head[node];
    w->adj_head[node] = (int32_t)w->n_adj++;
    return PF_OK;
}

/* ---- faces and elements -------------------------------------------------------------------- */

static const uint32_t *face_nodes(const work *w, int32_t f)
{
    return w->fpool + w->face_start[f];
}

/* A new face with these nodes, users (stored, reversed), alive, its incidences recorded. */
static pf_status new_face(work *w, const uint32_t *nodes, int64_t n, int32_t user0, int32_t user1,
                          int32_t *id, pf_error *err)
{
    PF_CHECK(w->n_faces < INT32_MAX - 1, err, PF_ERR_TOO_LARGE, "refine: more than 2^31 faces");
    if ((int64_t)w->n_faces + 1 > w->cap_faces) {
        int64_t cap = w->cap_faces;
        PF_TRY(pf_refine_grow(&w->face_start, &cap, (int64_t)w->n_faces + 1, sizeof *w->face_start,
                              err));
        GROW_WITH(w->face_len, w->cap_faces, cap, err);
        GROW_WITH(w->face_flags, w->cap_faces, cap, err);
        GROW_WITH(w->face_user, 2 * w->cap_faces, 2 * cap, err);
        w->cap_faces = cap;
    }
    PF_TRY(pf_refine_grow(&w->fpool, &w->cap_fpool, w->n_fpool + n, sizeof *w->fpool, err));
    int32_t f = w->n_faces++;
    memcpy(w->fpool + w->n_fpool, nodes, (size_t)n * sizeof *nodes);
    w->face_start[f] = w->n_fpool;
    w->face_len[f] = (int32_t)n;
    w->n_fpool += n;
    w->face_user[2 * f] = user0;
    w->face_user[2 * f + 1] = user1;
    w->face_flags[f] = FACE_ALIVE | FACE_EDITED;
    for (int64_t k = 0; k < n; ++k)
        PF_TRY(add_incidence(w, (int32_t)nodes[k], f, err));
    *id = f;
    return PF_OK;
}

/* Element e's face list becomes entries[n] (written at the end of the pool). */
static pf_status set_elem_faces(work *w, int32_t e, const uint32_t *entries, int64_t n,
                                pf_error *err)
{
    PF_TRY(pf_refine_grow(&w->epool, &w->cap_epool, w->n_epool + n, sizeof *w->epool, err));
    memcpy(w->epool + w->n_epool, entries, (size_t)n * sizeof *entries);
    w->elem_start[e] = w->n_epool;
    w->elem_len[e] = (int32_t)n;
    w->n_epool += n;
    return PF_OK;
}

static pf_status new_elem(work *w, int32_t *id, pf_error *err)
{
    PF_CHECK(w->n_elems < INT32_MAX - 1, err, PF_ERR_TOO_LARGE, "refine: more than 2^31 elements");
    if ((int64_t)w->n_elems + 1 > w->cap_elems) {
        int64_t cap = w->cap_elems;
        PF_TRY(pf_refine_grow(&w->elem_start, &cap, (int64_t)w->n_elems + 1, sizeof *w->elem_start,
                              err));
        GROW_WITH(w->elem_len, w->cap_elems, cap, err);
        GROW_WITH(w->elem_changed, w->cap_elems, cap, err);
        w->cap_elems = cap;
    }
    *id = w->n_elems++;
    w->elem_len[*id] = 0;
    w->elem_start[*id] = w->n_epool;
    w->elem_changed[*id] = 1;
    return PF_OK;
}

/* ---- the working copy of src ------------------------------------------------------------------
 */

static pf_status work_init(work *w, const pf_mesh *src, pf_error *err)
{
    memset(w, 0, sizeof *w);
    w->src = src;
    PF_CHECK(src->n_nodes >= 0 && src->n_faces >= 0 && src->n_elems >= 0 && src->face_offsets &&
                 src->elem_offsets && (src->x || src->n_nodes == 0),
             err, PF_ERR_INVALID, "refine: the mesh has negative counts or missing arrays");
    int64_t nfn = src->face_offsets[src->n_faces], nef = src->elem_offsets[src->n_elems];
    PF_TRY(reserve_nodes(w, (int64_t)src->n_nodes + 64, err));
    w->n_nodes = src->n_nodes;
    memcpy(w->x, src->x, 3 * (size_t)src->n_nodes * sizeof *w->x);
    for (int32_t i = 0; i < src->n_nodes; ++i) {
        w->adj_head[i] = -1;
        w->local_of[i] = -1;
        for (int c = 0; c < 3; ++c)
            PF_CHECK(isfinite(src->x[3 * (size_t)i + c]), err, PF_ERR_INVALID,
                     "refine: node %d has a non-finite coordinate", (int)i);
    }
    /* faces */
    int64_t cap = 0;
    PF_TRY(pf_refine_grow(&w->face_start, &cap, (int64_t)src->n_faces + 16, sizeof *w->face_start,
                          err));
    GROW_WITH(w->face_len, 0, cap, err);
    GROW_WITH(w->face_flags, 0, cap, err);
    GROW_WITH(w->face_user, 0, 2 * cap, err);
    w->cap_faces = cap;
    PF_TRY(pf_refine_grow(&w->fpool, &w->cap_fpool, nfn + 64, sizeof *w->fpool, err));
    PF_TRY(pf_refine_grow(&w->adj_face, &w->cap_adj, nfn + 64, sizeof *w->adj_face, err));
    GROW_WITH(w->adj_next, 0, w->cap_adj, err);
    for (int32_t f = 0; f < src->n_faces; ++f) {
        int64_t k0 = src->face_offsets[f], k1 = src->face_offsets[f + 1];
        PF_CHECK(k0 >= 0 && k1 - k0 >= 3 && k1 <= nfn, err, PF_ERR_INVALID,
                 "refine: face %d has bad offsets or fewer than 3 nodes", (int)f);
        w->face_start[f] = k0;
        w->face_len[f] = (int32_t)(k1 - k0);
        w->face_flags[f] = FACE_ALIVE;
        w->face_user[2 * f] = w->face_user[2 * f + 1] = -1;
        for (int64_t k = k0; k < k1; ++k) {
            uint32_t v = src->face_nodes[k];
            PF_CHECK(v < (uint32_t)src->n_nodes, err, PF_ERR_INVALID,
                     "refine: face %d: node index %u out of range", (int)f, v);
            PF_TRY(add_incidence(w, (int32_t)v, f, err));
        }
    }
    memcpy(w->fpool, src->face_nodes, (size_t)nfn * sizeof *w->fpool);
    w->n_fpool = nfn;
    w->n_faces = src->n_faces;
    /* elements */
    cap = 0;
    PF_TRY(pf_refine_grow(&w->elem_start, &cap, (int64_t)src->n_elems + 16, sizeof *w->elem_start,
                          err));
    GROW_WITH(w->elem_len, 0, cap, err);
    GROW_WITH(w->elem_changed, 0, cap, err);
    w->cap_elems = cap;
    PF_TRY(pf_refine_grow(&w->epool, &w->cap_epool, nef + 64, sizeof *w->epool, err));
    memcpy(w->epool, src->elem_faces, (size_t)nef * sizeof *w->epool);
    w->n_epool = nef;
    w->n_elems = src->n_elems;
    PF_CHECK(PF_ALLOC_N(w->child_first, src->n_elems) && PF_ALLOC_N(w->child_count, src->n_elems),
             err, PF_ERR_NOMEM, "refine: out of memory");
    for (int32_t e = 0; e < src->n_elems; ++e) {
        int64_t k0 = src->elem_offsets[e], k1 = src->elem_offsets[e + 1];
        PF_CHECK(k0 >= 0 && k1 - k0 >= 4 && k1 <= nef, err, PF_ERR_INVALID,
                 "refine: element %d has bad offsets or fewer than 4 faces", (int)e);
        w->elem_start[e] = k0;
        w->elem_len[e] = (int32_t)(k1 - k0);
        w->elem_changed[e] = 0;
        w->child_first[e] = -1;
        w->child_count[e] = 0;
        for (int64_t k = k0; k < k1; ++k) {
            int32_t f = PF_FACE_INDEX(src->elem_faces[k]);
            int side = (src->elem_faces[k] & PF_FACE_REVERSED) ? 1 : 0;
            PF_CHECK(f < src->n_faces, err, PF_ERR_INVALID,
                     "refine: element %d: face index %d out of range", (int)e, (int)f);
            PF_CHECK(w->face_user[2 * f + side] < 0, err, PF_ERR_INVALID,
                     "refine: face %d is used the same way round by elements %d and %d", (int)f,
                     (int)w->face_user[2 * f + side], (int)e);
            w->face_user[2 * f + side] = e;
        }
    }
    return PF_OK;
}

/* ---- one split ---------------------------------------------------------------------------- */

/* Element e's polyhedron in local numbering as the single piece of w->L.cur: face j is entry j
 * of its list, outward. */
static pf_status load_element(work *w, int32_t e, pf_error *err)
{
    refine_local *L = &w->L;
    for (int32_t i = 0; i < L->n; ++i)
        if (L->glob[i] >= 0)
            w->local_of[L->glob[i]] = -1;
    L->n = L->n_orig = 0;
    pf_refine_pieces_clear(&L->cur);
    PF_TRY(pf_refine_pieces_begin(&L->cur, err));
    const uint32_t *entries = w->epool + w->elem_start[e];
    for (int32_t j = 0; j < w->elem_len[e]; ++j) {
        int32_t f = PF_FACE_INDEX(entries[j]);
        bool rev = (entries[j] & PF_FACE_REVERSED) != 0;
        int32_t n = w->face_len[f];
        const uint32_t *nodes = face_nodes(w, f);
        w->scratch.size = 0;
        PF_TRY(pf_buffer_reserve(&w->scratch, (size_t)n * sizeof(uint32_t), err));
        uint32_t *local = (uint32_t *)w->scratch.data;
        for (int32_t k = 0; k < n; ++k) {
            int32_t g = (int32_t)nodes[rev ? n - 1 - k : k];
            if (w->local_of[g] < 0) {
                PF_TRY(pf_refine_local_reserve(L, (int64_t)L->n + 1, err));
                memcpy(L->x + 3 * (size_t)L->n, w->x + 3 * (size_t)g, 3 * sizeof(double));
                L->glob[L->n] = g;
                w->local_of[g] = L->n++;
            }
            local[k] = (uint32_t)w->local_of[g];
        }
        PF_TRY(pf_refine_pieces_face(&L->cur, local, n, j, err));
    }
    L->n_orig = L->n;
    return PF_OK;
}

/* Position of the directed edge (a, b) in the face, or -1. */
static int32_t find_edge(const uint32_t *nodes, int32_t n, uint32_t a, uint32_t b)
{
    for (int32_t k = 0; k < n; ++k)
        if (nodes[k] == a && nodes[(k + 1) % n] == b)
            return k;
    return -1;
}

/* poly[n] equals face[n] as a cycle (same direction, any first node). */
static bool same_cycle(const uint32_t *poly, const uint32_t *face, int32_t n)
{
    for (int32_t s = 0; s < n; ++s)
        if (face[s] == poly[0]) {
            for (int32_t k = 1; k < n; ++k)
                if (face[(s + k) % n] != poly[k])
                    return false;
            return true;
        }
    return false;
}

/* The children's faces with origin j (element face j, outward nodes fo[nf]): the nodes they put
 * on each edge (a, b) of it with a < b, appended to w->edges / w->mids. The union of the parts is
 * face j; its boundary, the parts' directed edges not matched by a reversed one, runs from a to b
 * through exactly the nodes on that edge. */
static pf_status edge_nodes(work *w, const uint32_t *gl, const int64_t *list, int32_t n_list,
                            const uint32_t *fo, int32_t nf, pf_error *err)
{
    const refine_pieces *ps = &w->L.cur;
    /* directed boundary edges */
    int64_t n_edges = 0;
    for (int32_t i = 0; i < n_list; ++i)
        n_edges += ps->off[list[i] + 1] - ps->off[list[i]];
    w->scratch.size = 0;
    PF_TRY(pf_buffer_reserve(&w->scratch, 2 * (size_t)n_edges * sizeof(uint32_t), err));
    uint32_t *ed = (uint32_t *)w->scratch.data;
    int64_t m = 0;
    for (int32_t i = 0; i < n_list; ++i) {
        int64_t k0 = ps->off[list[i]], n = ps->off[list[i] + 1] - k0;
        for (int64_t k = 0; k < n; ++k) {
            ed[2 * m] = gl[ps->nodes[k0 + k]];
            ed[2 * m + 1] = gl[ps->nodes[k0 + (k + 1) % n]];
            ++m;
        }
    }
    /* inner edges are marked first (by a node value no edge has), then dropped */
    for (int64_t i = 0; i < m; ++i)
        for (int64_t k = i + 1; k < m; ++k)
            if (ed[2 * k] == ed[2 * i + 1] && ed[2 * k + 1] == ed[2 * i] &&
                ed[2 * i] != UINT32_MAX) {
                ed[2 * i] = ed[2 * k] = UINT32_MAX;
                break;
            }
    int64_t kept = 0;
    for (int64_t i = 0; i < m; ++i)
        if (ed[2 * i] != UINT32_MAX) {
            ed[2 * kept] = ed[2 * i];
            ed[2 * kept + 1] = ed[2 * i + 1];
            ++kept;
        }
    for (int32_t k = 0; k < nf; ++k) {
        uint32_t a = fo[k], b = fo[(k + 1) % nf];
        if (a > b)
            continue;
        int32_t first = (int32_t)(w->mids.size / sizeof(int32_t)), count = 0;
        uint32_t at = a;
        for (int64_t steps = 0; at != b; ++steps) {
            int64_t i = 0;
            while (i < kept && ed[2 * i] != at)
                ++i;
            PF_CHECK(i < kept && steps < kept, err, PF_ERR_NUMERIC,
                     "the children's faces do not cover the edge %u-%u", a, b);
            at = ed[2 * i + 1];
            if (at != b) {
                int32_t v = (int32_t)at;
                PF_TRY(pf_buffer_append(&w->mids, &v, sizeof v, err));
                ++count;
            }
        }
        if (count > 0) {
            int32_t rec[4] = {(int32_t)a, (int32_t)b, first, count};
            PF_TRY(pf_buffer_append(&w->edges, rec, sizeof rec, err));
        }
    }
    return PF_OK;
}

/* Inserts the nodes of every recorded edge into every live face that has the edge. */
static pf_status insert_edge_nodes(work *w, pf_error *err)
{
    const int32_t *rec = (const int32_t *)w->edges.data;
    int64_t n_rec = (int64_t)(w->edges.size / (4 * sizeof(int32_t)));
    for (int64_t r = 0; r < n_rec; ++r) {
        uint32_t a = (uint32_t)rec[4 * r], b = (uint32_t)rec[4 * r + 1];
        int32_t count = rec[4 * r + 3];
        for (int32_t q = w->adj_head[a]; q >= 0; q = w->adj_next[q]) {
            int32_t f = w->adj_face[q];
            if (!(w->face_flags[f] & FACE_ALIVE))
                continue;
            int32_t n = w->face_len[f];
            const int32_t *mids = (const int32_t *)w->mids.data + rec[4 * r + 2];
            bool forward = true;
            int32_t at = find_edge(face_nodes(w, f), n, a, b);
            if (at < 0) {
                forward = false;
                at = find_edge(face_nodes(w, f), n, b, a);
            }
            if (at < 0)
                continue;
            PF_TRY(pf_refine_grow(&w->fpool, &w->cap_fpool, w->n_fpool + n + count,
                                  sizeof *w->fpool, err));
            const uint32_t *old = face_nodes(w, f);
            uint32_t *nw = w->fpool + w->n_fpool;
            memcpy(nw, old, (size_t)(at + 1) * sizeof *nw);
            for (int32_t i = 0; i < count; ++i)
                nw[at + 1 + i] = (uint32_t)mids[forward ? i : count - 1 - i];
            memcpy(nw + at + 1 + count, old + at + 1, (size_t)(n - at - 1) * sizeof *nw);
            w->face_start[f] = w->n_fpool;
            w->face_len[f] = n + count;
            w->n_fpool += n + count;
            w->face_flags[f] |= FACE_EDITED;
            for (int s = 0; s < 2; ++s)
                if (w->face_user[2 * f + s] >= 0)
                    w->elem_changed[w->face_user[2 * f + s]] = 1;
            for (int32_t i = 0; i < count; ++i)
                PF_TRY(add_incidence(w, mids[i], f, err));
        }
    }
    return PF_OK;
}

/* Replaces face f in element e's list by the entries rep[n]. */
static pf_status replace_in_elem(work *w, int32_t e, int32_t f, const uint32_t *rep, int64_t n,
                                 pf_error *err)
{
    int32_t len = w->elem_len[e];
    PF_TRY(pf_refine_grow(&w->epool, &w->cap_epool, w->n_epool + len + n, sizeof *w->epool, err));
    const uint32_t *old = w->epool + w->elem_start[e];
    uint32_t *nw = w->epool + w->n_epool;
    int64_t m = 0;
    for (int32_t k = 0; k < len; ++k)
        if (PF_FACE_INDEX(old[k]) == f) {
            memcpy(nw + m, rep, (size_t)n * sizeof *rep);
            m += n;
        } else {
            nw[m++] = old[k];
        }
    w->elem_start[e] = w->n_epool;
    w->elem_len[e] = (int32_t)m;
    w->n_epool += m;
    w->elem_changed[e] = 1;
    return PF_OK;
}

/* Puts the children in w->L.cur into the mesh in place of element e. */
static pf_status commit_children(work *w, int32_t e, pf_error *err)
{
    refine_local *L = &w->L;
    const refine_pieces *ps = &L->cur;
    int32_t nf = ps->n_faces, nfe = w->elem_len[e];
    int64_t nfn = ps->off[nf];
    w->edges.size = w->mids.size = 0;
    /* Mesh nodes for the nodes the planes made, in the order the children use them. */
    for (int64_t k = 0; k < nfn; ++k) {
        uint32_t l = ps->nodes[k];
        if (L->glob[l] < 0)
            PF_TRY(made_node(w, L->x + 3 * (size_t)l, &L->glob[l], err));
    }
    int32_t longest = 0;
    for (int32_t i = 0; i < nf; ++i)
        if (ps->off[i + 1] - ps->off[i] > longest)
            longest = (int32_t)(ps->off[i + 1] - ps->off[i]);
    for (int32_t j = 0; j < nfe; ++j)
        if (w->face_len[PF_FACE_INDEX(w->epool[w->elem_start[e] + j])] > longest)
            longest = w->face_len[PF_FACE_INDEX(w->epool[w->elem_start[e] + j])];
    uint32_t *gn = pf_alloc_array((size_t)nfn + 1, sizeof *gn);
    uint32_t *entry_of = pf_alloc_array((size_t)nf + 1, sizeof *entry_of);
    uint32_t *rep = pf_alloc_array((size_t)nf + 1, sizeof *rep);
    uint32_t *eent = pf_alloc_array((size_t)nfe + 1, sizeof *eent);
    uint32_t *tmp = pf_alloc_array((size_t)longest + 1, sizeof *tmp);
    int32_t *child = pf_alloc_array((size_t)nf + 1, sizeof *child);
    int64_t *order = pf_alloc_array((size_t)nf + 1, sizeof *order);
    int64_t *start = pf_calloc((size_t)nfe + 3, sizeof *start);
    pf_status st = PF_OK;
    if (!gn || !entry_of || !rep || !eent || !tmp || !child || !order || !start) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
        goto done;
    }
    for (int64_t k = 0; k < nfn; ++k)
        gn[k] = (uint32_t)L->glob[ps->nodes[k]];
    memcpy(eent, w->epool + w->elem_start[e], (size_t)nfe * sizeof *eent);
    int32_t c0 = w->n_elems;
    for (int32_t k = 0; k < ps->n && st >= 0; ++k) {
        int32_t id = -1;
        st = new_elem(w, &id, err);
        for (int64_t i = ps->first_face[k]; i < ps->first_face[k + 1]; ++i)
            child[i] = id;
    }
    /* The children's faces grouped by origin (caps first), each group in face order. */
    for (int32_t i = 0; i < nf; ++i)
        start[ps->origin[i] + 2]++;
    for (int32_t j = 0; j <= nfe; ++j)
        start[j + 1] += start[j];
    for (int32_t i = 0; i < nf; ++i)
        order[start[ps->origin[i] + 1]++] = i;
    /* now group j (origin j - 1) is order[start[j - 1] .. start[j]), start[-1] = 0 */
    for (int32_t j = 0; j < nfe && st >= 0; ++j) {
        int32_t f = PF_FACE_INDEX(eent[j]);
        int side = (eent[j] & PF_FACE_REVERSED) ? 1 : 0;
        int32_t n = w->face_len[f];
        for (int32_t k = 0; k < n; ++k)
            tmp[k] = face_nodes(w, f)[side ? n - 1 - k : k];
        const int64_t *list = order + start[j];
        int32_t n_list = (int32_t)(start[j + 1] - start[j]);
        if (n_list == 0) {
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "face %d of the element is in no child", (int)f);
            break;
        }
        int64_t i0 = list[0];
        if (n_list == 1 && ps->off[i0 + 1] - ps->off[i0] == n &&
            same_cycle(gn + ps->off[i0], tmp, n)) {
            /* Not cut: the face stays as it is, now the child's. */
            entry_of[i0] = eent[j];
            w->face_user[2 * f + side] = child[i0];
            continue;
        }
        st = edge_nodes(w, (const uint32_t *)L->glob, list, n_list, tmp, n, err);
        int32_t other = w->face_user[2 * f + 1 - side];
        for (int32_t i = 0; i < n_list && st >= 0; ++i) {
            int64_t q = list[i];
            int32_t g;
            st =
                new_face(w, gn + ps->off[q], ps->off[q + 1] - ps->off[q], child[q], other, &g, err);
            entry_of[q] = (uint32_t)g;
            rep[i] = (uint32_t)g | PF_FACE_REVERSED;
        }
        w->face_flags[f] &= (uint8_t)~FACE_ALIVE;
        if (st >= 0 && other >= 0)
            st = replace_in_elem(w, other, f, rep, n_list, err);
    }
    /* Caps: each shared by two children, one's polygon the other's reversed. */
    int64_t c_end = start[0];
    for (int64_t a = 0; a < c_end && st >= 0; ++a) {
        int64_t p = order[a];
        if (child[p] < 0)
            continue;
        int64_t np = ps->off[p + 1] - ps->off[p];
        int64_t b = a + 1;
        for (; b < c_end; ++b) {
            int64_t q = order[b];
            if (child[q] < 0 || child[q] == child[p] || ps->off[q + 1] - ps->off[q] != np)
                continue;
            for (int64_t k = 0; k < np; ++k)
                tmp[k] = gn[ps->off[q] + np - 1 - k];
            if (same_cycle(gn + ps->off[p], tmp, (int32_t)np))
                break;
        }
        if (b == c_end) {
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "a face inside the element belongs to one child only");
            break;
        }
        int64_t q = order[b];
        int32_t g;
        st = new_face(w, gn + ps->off[p], np, child[p], child[q], &g, err);
        entry_of[p] = (uint32_t)g;
        entry_of[q] = (uint32_t)g | PF_FACE_REVERSED;
        child[q] = -1 - child[q]; /* matched */
    }
    for (int64_t a = 0; a < c_end; ++a)
        if (child[order[a]] < 0)
            child[order[a]] = -1 - child[order[a]];
    for (int32_t k = 0; k < ps->n && st >= 0; ++k)
        st = set_elem_faces(w, c0 + k, entry_of + ps->first_face[k],
                            ps->first_face[k + 1] - ps->first_face[k], err);
    if (st >= 0) {
        w->child_first[e] = c0;
        w->child_count[e] = ps->n;
        w->elem_len[e] = 0;
        st = insert_edge_nodes(w, err);
    }
done:
    pf_free(gn);
    pf_free(entry_of);
    pf_free(rep);
    pf_free(eent);
    pf_free(tmp);
    pf_free(child);
    pf_free(order);
    pf_free(start);
    return st;
}

/* ---- the result ------------------------------------------------------------------------------ */

static pf_status build_output(work *w, pf_mesh *dst, pf_refine_result *res, pf_error *err)
{
    const pf_mesh *src = w->src;
    int32_t *face_map = pf_alloc_array((size_t)w->n_faces + 1, sizeof *face_map);
    PF_CHECK(face_map, err, PF_ERR_NOMEM, "refine: out of memory");
    int32_t n_faces = 0;
    int64_t nfn = 0, nef = 0, n_elems = 0;
    for (int32_t f = 0; f < w->n_faces; ++f) {
        face_map[f] = (w->face_flags[f] & FACE_ALIVE) ? n_faces++ : -1;
        if (face_map[f] >= 0)
            nfn += w->face_len[f];
    }
    for (int32_t e = 0; e < src->n_elems; ++e) {
        int32_t c0 = w->child_count[e] ? w->child_first[e] : e;
        int32_t nc = w->child_count[e] ? w->child_count[e] : 1;
        n_elems += nc;
        for (int32_t c = c0; c < c0 + nc; ++c)
            nef += w->elem_len[c];
    }
    pf_status st = n_elems < INT32_MAX ? PF_OK
                                       : pf_error_set(err, PF_ERR_TOO_LARGE, __FILE__, __LINE__,
                                                      "refine: more than 2^31 elements");
    if (st >= 0)
        st = pf_mesh_alloc(dst, w->n_nodes, n_faces, nfn, (int32_t)n_elems, nef, err);
    if (st >= 0 && (!PF_ALLOC_N(res->parent, n_elems) || !PF_ALLOC_N(res->changed, n_elems) ||
                    !PF_ALLOC_N(res->face_src, n_faces)))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "refine: out of memory");
    if (st < 0) {
        pf_free(face_map);
        return st;
    }
    dst->id = src->id + 1;
    memcpy(dst->x, w->x, 3 * (size_t)w->n_nodes * sizeof *dst->x);
    for (int32_t f = 0; f < w->n_faces; ++f) {
        int32_t g = face_map[f];
        if (g < 0)
            continue;
        int64_t at = dst->face_offsets[g];
        memcpy(dst->face_nodes + at, face_nodes(w, f), (size_t)w->face_len[f] * sizeof(uint32_t));
        dst->face_offsets[g + 1] = at + w->face_len[f];
        res->face_src[g] = (f < src->n_faces && !(w->face_flags[f] & FACE_EDITED)) ? f : -1;
    }
    int32_t d = 0;
    for (int32_t e = 0; e < src->n_elems; ++e) {
        int32_t c0 = w->child_count[e] ? w->child_first[e] : e;
        int32_t nc = w->child_count[e] ? w->child_count[e] : 1;
        for (int32_t c = c0; c < c0 + nc; ++c, ++d) {
            int64_t at = dst->elem_offsets[d];
            const uint32_t *entries = w->epool + w->elem_start[c];
            for (int32_t k = 0; k < w->elem_len[c]; ++k)
                dst->elem_faces[at + k] =
                    (uint32_t)face_map[PF_FACE_INDEX(entries[k])] | (entries[k] & PF_FACE_REVERSED);
            dst->elem_offsets[d + 1] = at + w->elem_len[c];
            res->parent[d] = e;
            res->changed[d] = w->elem_changed[c];
            if (w->child_count[e])
                res->n_children++;
            else if (w->elem_changed[c])
                res->n_neighbours_changed++;
        }
    }
    pf_free(face_map);
    return pf_mesh_derive(dst, err);
}

void pf_refine_result_release(pf_refine_result *r)
{
    pf_free(r->parent);
    pf_free(r->changed);
    pf_free(r->face_src);
    memset(r, 0, sizeof *r);
}

static pf_status check_requests(const pf_mesh *src, const pf_refine_request *req, int32_t n_req,
                                pf_error *err)
{
    uint8_t *seen = pf_calloc((size_t)src->n_elems + 1, 1);
    PF_CHECK(seen, err, PF_ERR_NOMEM, "refine: out of memory");
    pf_status st = PF_OK;
    for (int32_t r = 0; r < n_req && st >= 0; ++r) {
        int32_t e = req[r].elem;
        pf_vec3 n = req[r].normal;
        if (e < 0 || e >= src->n_elems)
            st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                              "refine: request %d names element %d of %d", (int)r, (int)e,
                              (int)src->n_elems);
        else if (seen[e])
            st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                              "refine: request %d names element %d a second time", (int)r, (int)e);
        else if (req[r].kind != PF_SPLIT_OCTS && req[r].kind != PF_SPLIT_HALVES &&
                 req[r].kind != PF_SPLIT_PLANE)
            st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                              "refine: request %d (element %d): unknown split kind %d", (int)r,
                              (int)e, (int)req[r].kind);
        else if (req[r].kind != PF_SPLIT_OCTS &&
                 !(isfinite(n.x) && isfinite(n.y) && isfinite(n.z) && pf_v3_norm(n) > 0))
            st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                              "refine: request %d (element %d): the plane normal (%g, %g, %g) is "
                              "zero or not finite",
                              (int)r, (int)e, n.x, n.y, n.z);
        else if (req[r].kind == PF_SPLIT_PLANE &&
                 !(isfinite(req[r].point.x) && isfinite(req[r].point.y) &&
                   isfinite(req[r].point.z)))
            st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                              "refine: request %d (element %d): the plane's point is not finite",
                              (int)r, (int)e);
        else
            seen[e] = 1;
    }
    pf_free(seen);
    return st;
}

static pf_status refine(work *w, const pf_refine_request *req, int32_t n_req, pf_refine_result *res,
                        pf_error *err)
{
    for (int32_t r = 0; r < n_req; ++r) {
        int32_t e = req[r].elem;
        double vol;
        pf_vec3 centroid, axes[3];
        int32_t applied = 0, skipped = 0;
        pf_status st = load_element(w, e, err);
        if (st >= 0) {
            pf_polyhedron view = pf_refine_piece_view(&w->L, &w->L.cur, 0);
            st = pf_refine_element_axes(&view, &vol, &centroid, axes, err);
        }
        if (st >= 0)
            st =
                pf_refine_split_local(&w->L, &req[r], vol, centroid, axes, &applied, &skipped, err);
        if (st >= 0 && applied > 0)
            st = commit_children(w, e, err);
        if (st < 0) {
            pf_error_prefix(err, "refine: request %d (element %d)", (int)r, (int)e);
            return st;
        }
        res->n_planes_skipped += skipped;
        if (applied > 0)
            res->n_split++;
        else
            res->n_skipped++;
    }
    return PF_OK;
}

pf_status pf_mesh_refine(const pf_mesh *src, const pf_refine_request *req, int32_t n_req,
                         pf_mesh *dst, pf_refine_result *res, pf_error *err)
{
    PF_CHECK(src && dst && res && n_req >= 0 && (req || n_req == 0), err, PF_ERR_INVALID,
             "refine: NULL argument or negative request count");
    memset(dst, 0, sizeof *dst);
    memset(res, 0, sizeof *res);
    work w;
    pf_status st = check_requests(src, req, n_req, err);
    if (st >= 0)
        st = work_init(&w, src, err);
    else
        memset(&w, 0, sizeof w);
    if (st >= 0)
        st = refine(&w, req, n_req, res, err);
    if (st >= 0)
        st = build_output(&w, dst, res, err);
    work_release(&w);
    if (st < 0) {
        pf_mesh_release(dst);
        pf_refine_result_release(res);
    }
    return st;
}
