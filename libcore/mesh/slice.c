/* Hexahedral slicing (DG paper sec. 9.2): the solid bounded by a closed surface intersected with
 * a grid of cubes. Interior cells come out as hexes, cells the surface crosses as the exact
 * polyhedra of the solid inside them (one element per connected piece).
 *
 * The solid itself is cut: the closed surface is one polyhedron (its triangles are the faces),
 * split by the grid planes with pf_poly_split, halving the range of planes at every level (x,
 * then y, then z), so every piece is cut only by the planes that cross it and the total work
 * grows like n log(cells). Four properties make the result conforming:
 *   - the planes are applied in one global bisection order (see slice_range);
 *   - one absolute tolerance for the whole model, so a node is classified alike in every piece;
 *   - a new node depends only on the two end points of the edge it splits (pf_poly_split), and a
 *     shared face has the same edges in both pieces, so both compute bit-identical nodes;
 *   - the caps on the two sides of a cut are the same polygons.
 * Pieces are then glued by exact node coordinates and faces by their node sets. Pieces smaller
 * than a fraction of a cell are merged into the neighbour with which they share the most face
 * area (DG paper sec. 9.4); the merged element may be non-convex. */
#include <pf/mesh.h>
#include <pf/split.h>

#include "mesh_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- a piece: one closed polyhedron with its own nodes ------------------------------------ */


void pf_piece_release(piece *p)
{
    pf_free(p->x);
    pf_free(p->face_offsets);
    pf_free(p->face_nodes);
    memset(p, 0, sizeof *p);
}

pf_polyhedron pf_piece_view(const piece *p)
{
    return (pf_polyhedron){p->x, p->n_faces, p->face_offsets, p->face_nodes};
}

/* The bounding box, kept with the piece: every level of the cut asks for it. */
void pf_update_bounds(piece *p)
{
    for (int c = 0; c < 3; ++c)
        p->lo[c] = p->hi[c] = p->n_nodes ? p->x[c] : 0;
    for (int32_t i = 1; i < p->n_nodes; ++i)
        for (int c = 0; c < 3; ++c) {
            double v = p->x[3 * (size_t)i + c];
            if (v < p->lo[c])
                p->lo[c] = v;
            if (v > p->hi[c])
                p->hi[c] = v;
        }
}

/* Piece k of a split, with only the nodes its faces use. */
pf_status pf_extract_piece(const pf_split *s, int32_t k, int32_t *remap, piece *out,
                               pf_error *err)
{
    memset(out, 0, sizeof *out);
    int64_t f0 = s->piece_faces[k], f1 = s->piece_faces[k + 1];
    int64_t n_idx = s->face_offsets[f1] - s->face_offsets[f0];
    out->n_faces = (int32_t)(f1 - f0);
    out->face_offsets = pf_alloc_array((size_t)out->n_faces + 1, sizeof *out->face_offsets);
    out->face_nodes = pf_alloc_array((size_t)n_idx, sizeof *out->face_nodes);
    out->x = pf_alloc_array(3 * (size_t)n_idx, sizeof *out->x);
    if (!out->face_offsets || !out->face_nodes || !out->x) {
        pf_piece_release(out);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory slicing");
    }
    out->face_offsets[0] = 0;
    for (int64_t f = f0; f < f1; ++f) {
        for (int64_t q = s->face_offsets[f]; q < s->face_offsets[f + 1]; ++q) {
            uint32_t node = s->face_nodes[q];
            if (remap[node] < 0) {
                remap[node] = out->n_nodes;
                memcpy(out->x + 3 * (size_t)out->n_nodes, s->x + 3 * (size_t)node, 3 * sizeof(double));
                out->n_nodes++;
            }
            out->face_nodes[out->face_offsets[f - f0] + (q - s->face_offsets[f])] =
                (uint32_t)remap[node];
        }
        out->face_offsets[f - f0 + 1] = s->face_offsets[f + 1] - s->face_offsets[f0];
    }
    for (int64_t q = s->face_offsets[f0]; q < s->face_offsets[f1]; ++q)
        remap[s->face_nodes[q]] = -1;
    pf_update_bounds(out);
    return PF_OK;
}

/* ---- gluing: nodes by exact coordinates, faces by node sets ------------------------------- */


uint64_t pf_hash_mix(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    return h ^ (h >> 33);
}

uint64_t pf_hash_point(const double *p)
{
    uint64_t h = 0;
    for (int c = 0; c < 3; ++c) {
        double v = p[c] == 0 ? 0 : p[c]; /* -0 and +0 are the same point */
        uint64_t bits;
        memcpy(&bits, &v, sizeof bits);
        h = pf_hash_mix(h ^ bits);
    }
    return h;
}

static bool grow_table(int32_t **table, int64_t *slots, int64_t needed)
{
    if (needed * 2 < *slots)
        return true;
    pf_free(*table);
    int64_t n = *slots ? *slots : 1024;
    while (n < needed * 4)
        n *= 2;
    *table = pf_alloc_array((size_t)n, sizeof **table);
    if (!*table)
        return false;
    for (int64_t k = 0; k < n; ++k)
        (*table)[k] = -1;
    *slots = n;
    return true;
}

static void insert_node_slot(glue *g, int32_t id)
{
    uint64_t mask = (uint64_t)g->node_slots - 1;
    for (uint64_t s = pf_hash_point(g->x + 3 * (size_t)id) & mask;; s = (s + 1) & mask)
        if (g->node_table[s] < 0) {
            g->node_table[s] = id;
            return;
        }
}

static pf_status glue_node(glue *g, const double *p, int32_t *id, pf_error *err)
{
    if (g->node_slots == 0 || (int64_t)g->n_nodes * 2 >= g->node_slots) {
        PF_CHECK(grow_table(&g->node_table, &g->node_slots, g->n_nodes + 1), err, PF_ERR_NOMEM,
                 "out of memory slicing");
        for (int32_t k = 0; k < g->n_nodes; ++k)
            insert_node_slot(g, k);
    }
    uint64_t mask = (uint64_t)g->node_slots - 1;
    uint64_t s = pf_hash_point(p) & mask;
    for (; g->node_table[s] >= 0; s = (s + 1) & mask) {
        const double *q = g->x + 3 * (size_t)g->node_table[s];
        if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) {
            *id = g->node_table[s];
            return PF_OK;
        }
    }
    if (g->n_nodes == g->cap_nodes) {
        int32_t cap = g->cap_nodes ? 2 * g->cap_nodes : 4096;
        double *x = pf_realloc_array(g->x, 3 * (size_t)cap, sizeof *x);
        PF_CHECK(x, err, PF_ERR_NOMEM, "out of memory slicing");
        g->x = x;
        g->cap_nodes = cap;
    }
    memcpy(g->x + 3 * (size_t)g->n_nodes, p, 3 * sizeof *p);
    g->node_table[s] = g->n_nodes;
    *id = g->n_nodes++;
    return PF_OK;
}

static int compare_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* Faces mostly have a handful of nodes, where qsort's call overhead dominates: insertion sort
 * for those, qsort for long ones (caps of coarse grids). */
static void sort_u32(uint32_t *v, int64_t n)
{
    if (n > 32) {
        qsort(v, (size_t)n, sizeof *v, compare_u32);
        return;
    }
    for (int64_t i = 1; i < n; ++i) {
        uint32_t x = v[i];
        int64_t j = i;
        for (; j > 0 && v[j - 1] > x; --j)
            v[j] = v[j - 1];
        v[j] = x;
    }
}

/* Hash of a face's node set (sorted copy in key). */
static uint64_t hash_face(uint32_t *key, int64_t n)
{
    sort_u32(key, n);
    uint64_t h = pf_hash_mix((uint64_t)n);
    for (int64_t k = 0; k < n; ++k)
        h = pf_hash_mix(h ^ key[k]);
    return h;
}

static const uint32_t *glue_face_nodes(const glue *g, int32_t f, int64_t *n)
{
    *n = g->face_offsets[f + 1] - g->face_offsets[f];
    return (const uint32_t *)g->face_nodes.data + g->face_offsets[f];
}

static bool same_node_set(const glue *g, int32_t f, const uint32_t *sorted, int64_t n,
                          uint32_t *scratch)
{
    int64_t m;
    const uint32_t *nodes = glue_face_nodes(g, f, &m);
    if (m != n)
        return false;
    memcpy(scratch, nodes, (size_t)n * sizeof *scratch);
    sort_u32(scratch, n);
    return memcmp(scratch, sorted, (size_t)n * sizeof *scratch) == 0;
}

static void insert_face_slot(glue *g, int32_t f, uint32_t *scratch)
{
    int64_t n;
    const uint32_t *nodes = glue_face_nodes(g, f, &n);
    memcpy(scratch, nodes, (size_t)n * sizeof *scratch);
    uint64_t mask = (uint64_t)g->face_slots - 1;
    for (uint64_t s = hash_face(scratch, n) & mask;; s = (s + 1) & mask)
        if (g->face_table[s] < 0) {
            g->face_table[s] = f;
            return;
        }
}

/* The glued face with these nodes (in this piece's outward order): an existing face when another
 * element already has it (then used reversed), else a new one. */
static pf_status glue_face(glue *g, const uint32_t *nodes, int64_t n, uint32_t *entry,
                           uint32_t *scratch, pf_error *err)
{
    if (g->face_slots == 0 || (int64_t)g->n_faces * 2 >= g->face_slots) {
        PF_CHECK(grow_table(&g->face_table, &g->face_slots, g->n_faces + 1), err, PF_ERR_NOMEM,
                 "out of memory slicing");
        for (int32_t f = 0; f < g->n_faces; ++f)
            insert_face_slot(g, f, scratch);
    }
    uint32_t *sorted = scratch + n;
    memcpy(sorted, nodes, (size_t)n * sizeof *sorted);
    uint64_t mask = (uint64_t)g->face_slots - 1;
    uint64_t s = hash_face(sorted, n) & mask;
    for (; g->face_table[s] >= 0; s = (s + 1) & mask) {
        int32_t f = g->face_table[s];
        if (same_node_set(g, f, sorted, n, scratch)) {
            PF_CHECK(g->face_uses[f] == 1, err, PF_ERR_NUMERIC,
                     "slicing produced a face used by more than two pieces");
            g->face_uses[f]++;
            *entry = (uint32_t)f | PF_FACE_REVERSED;
            return PF_OK;
        }
    }
    if (g->n_faces == g->cap_faces) {
        int32_t cap = g->cap_faces ? 2 * g->cap_faces : 4096;
        int64_t *fo = pf_realloc_array(g->face_offsets, (size_t)cap + 1, sizeof *fo);
        if (fo)
            g->face_offsets = fo;
        int32_t *uses = pf_realloc_array(g->face_uses, (size_t)cap, sizeof *uses);
        if (uses)
            g->face_uses = uses;
        PF_CHECK(fo && uses, err, PF_ERR_NOMEM, "out of memory slicing");
        if (g->cap_faces == 0)
            g->face_offsets[0] = 0;
        g->cap_faces = cap;
    }
    PF_TRY(pf_buffer_append(&g->face_nodes, nodes, (size_t)n * sizeof *nodes, err));
    int32_t f = g->n_faces++;
    g->face_offsets[f + 1] = g->face_offsets[f] + n;
    g->face_uses[f] = 1;
    g->face_table[s] = f;
    *entry = (uint32_t)f;
    return PF_OK;
}

void pf_glue_release(glue *g)
{
    pf_free(g->x);
    pf_free(g->node_table);
    pf_free(g->face_offsets);
    pf_buffer_release(&g->face_nodes);
    pf_free(g->face_table);
    pf_free(g->face_uses);
    pf_buffer_release(&g->elem_faces);
    pf_buffer_release(&g->elem_offsets);
    pf_free(g->scratch);
    memset(g, 0, sizeof *g);
}

/* Room for faces of n nodes in the scratch buffer (rehashing may meet any glued face). */
static pf_status ensure_scratch(glue *g, int64_t n, pf_error *err)
{
    if (n <= g->longest_face && g->scratch)
        return PF_OK;
    if (n < g->longest_face)
        n = g->longest_face;
    uint32_t *s = pf_realloc_array(g->scratch, 3 * (size_t)n, sizeof *s);
    PF_CHECK(s, err, PF_ERR_NOMEM, "out of memory slicing");
    g->scratch = s;
    g->longest_face = n;
    return PF_OK;
}

/* Adds a finished piece as one element. */
pf_status pf_glue_piece(glue *g, const piece *p, pf_error *err)
{
    int64_t longest = 0;
    for (int32_t f = 0; f < p->n_faces; ++f)
        if (p->face_offsets[f + 1] - p->face_offsets[f] > longest)
            longest = p->face_offsets[f + 1] - p->face_offsets[f];
    PF_TRY(ensure_scratch(g, longest, err));
    int32_t *ids = pf_alloc_array((size_t)p->n_nodes, sizeof *ids);
    PF_CHECK(ids, err, PF_ERR_NOMEM, "out of memory slicing");
    pf_status st = PF_OK;
    for (int32_t i = 0; st >= 0 && i < p->n_nodes; ++i)
        st = glue_node(g, p->x + 3 * (size_t)i, &ids[i], err);
    if (st >= 0 && g->n_elems == 0) {
        int64_t zero = 0;
        st = pf_buffer_append(&g->elem_offsets, &zero, sizeof zero, err);
    }
    uint32_t *nodes = g->scratch, *rest = g->scratch + g->longest_face;
    for (int32_t f = 0; st >= 0 && f < p->n_faces; ++f) {
        int64_t n = p->face_offsets[f + 1] - p->face_offsets[f];
        for (int64_t q = 0; q < n; ++q)
            nodes[q] = (uint32_t)ids[p->face_nodes[p->face_offsets[f] + q]];
        uint32_t entry;
        st = glue_face(g, nodes, n, &entry, rest, err);
        if (st >= 0)
            st = pf_buffer_append(&g->elem_faces, &entry, sizeof entry, err);
    }
    if (st >= 0) {
        int64_t end = (int64_t)(g->elem_faces.size / sizeof(uint32_t));
        st = pf_buffer_append(&g->elem_offsets, &end, sizeof end, err);
        g->n_elems++;
    }
    pf_free(ids);
    return st;
}

/* ---- the recursive cut ----------------------------------------------------------------------- */

typedef struct slicer {
    const pf_grid *grid;
    pf_split_params params; /* one absolute tolerance for the whole model */
    int32_t *remap;         /* [cap_remap] -1 */
    int32_t cap_remap;
    glue glue;
    int64_t splits;
    pf_progress_fn progress; /* the caller's, with its context */
    void *progress_ctx;
} slicer;

static double plane_coordinate(const pf_grid *g, int axis, int32_t index)
{
    const double o[3] = {g->origin.x, g->origin.y, g->origin.z};
    return o[axis] + g->h * index;
}

pf_status pf_remap_reserve(int32_t **remap, int32_t *cap, int32_t n, pf_error *err)
{
    if (n <= *cap)
        return PF_OK;
    int32_t c = *cap ? *cap : 1024;
    while (c < n)
        c *= 2;
    int32_t *r = pf_realloc_array(*remap, (size_t)c, sizeof *r);
    PF_CHECK(r, err, PF_ERR_NOMEM, "out of memory for %d node slots", (int)c);
    for (int32_t k = *cap; k < c; ++k)
        r[k] = -1;
    *remap = r;
    *cap = c;
    return PF_OK;
}

static pf_status slice_axis(slicer *sl, piece *p, int axis, int32_t lo, int32_t hi, pf_error *err);

/* Cuts along one axis with the planes of the whole grid, bisected in one global order: every
 * piece meets the planes in the same sequence (a piece skips those it lies beside), so an edge
 * shared by two pieces is split at the same planes, in the same order, from the same end points,
 * into bit-identical nodes. (Narrowing the range to each piece's extent would change the order
 * from piece to piece, and with it the rounding of the nodes.) */
static pf_status slice_range(slicer *sl, piece *p, int axis, pf_error *err)
{
    return slice_axis(sl, p, axis, 0, sl->grid->n[axis], err);
}

/* A piece whose cell range along every axis is one cell: an element. */
static pf_status finish_piece(slicer *sl, piece *p, int axis, pf_error *err)
{
    if (axis < 2)
        return slice_range(sl, p, axis + 1, err);
    pf_status st = pf_glue_piece(&sl->glue, p, err);
    pf_piece_release(p);
    return st;
}

static pf_status slice_axis(slicer *sl, piece *p, int axis, int32_t lo, int32_t hi, pf_error *err)
{
    if (hi - lo <= 1) {
        pf_status st = finish_piece(sl, p, axis, err);
        if (axis == 0 && sl->progress) /* slabs along x are finished in increasing order */
            sl->progress(sl->progress_ctx, hi, sl->grid->n[0]);
        return st;
    }
    int32_t mid = lo + (hi - lo) / 2;
    double c = plane_coordinate(sl->grid, axis, mid);
    if (p->hi[axis] <= c + sl->params.tol) /* wholly below (touching at most): no cut */
        return slice_axis(sl, p, axis, lo, mid, err);
    if (p->lo[axis] >= c - sl->params.tol)
        return slice_axis(sl, p, axis, mid, hi, err);

    pf_plane plane = {{axis == 0, axis == 1, axis == 2}, c};
    pf_polyhedron view = pf_piece_view(p);
    pf_split split;
    pf_status st = pf_poly_split(&view, p->n_nodes, &plane, &sl->params, &split, err);
    pf_piece_release(p);
    sl->splits++;
    if (st >= 0)
        st = pf_remap_reserve(&sl->remap, &sl->cap_remap, split.n_nodes, err);
    for (int32_t k = 0; st >= 0 && k < split.n_pieces; ++k) {
        piece sub;
        st = pf_extract_piece(&split, k, sl->remap, &sub, err);
        if (st >= 0)
            st = split.piece_side[k] < 0 ? slice_axis(sl, &sub, axis, lo, mid, err)
                                         : slice_axis(sl, &sub, axis, mid, hi, err);
    }
    pf_split_release(&split);
    return st;
}

/* ---- the glued mesh and sliver merging ------------------------------------------------------- */

/* The glued arrays copied into m, nothing derived. */
static pf_status glue_copy(const glue *g, pf_mesh *m, pf_error *err)
{
    int64_t n_face_nodes = g->face_offsets ? g->face_offsets[g->n_faces] : 0;
    int64_t n_elem_faces = (int64_t)(g->elem_faces.size / sizeof(uint32_t));
    PF_TRY(pf_mesh_alloc(m, g->n_nodes, g->n_faces, n_face_nodes, g->n_elems, n_elem_faces, err));
    memcpy(m->x, g->x, 3 * (size_t)g->n_nodes * sizeof *m->x);
    memcpy(m->face_offsets, g->face_offsets, ((size_t)g->n_faces + 1) * sizeof *m->face_offsets);
    memcpy(m->face_nodes, g->face_nodes.data, (size_t)n_face_nodes * sizeof *m->face_nodes);
    memcpy(m->elem_offsets, g->elem_offsets.data, ((size_t)g->n_elems + 1) * sizeof(int64_t));
    memcpy(m->elem_faces, g->elem_faces.data, (size_t)n_elem_faces * sizeof(uint32_t));
    return PF_OK;
}

pf_status pf_glue_to_mesh(const glue *g, pf_mesh *m, pf_error *err)
{
    PF_TRY(glue_copy(g, m, err));
    return pf_mesh_derive(m, err);
}

/* The glued mesh with only the adjacency sliver merging needs (face_elems as pf_mesh_derive
 * computes it: glue_face made every face's first use outward, its second reversed); the kinds
 * of the pieces are never asked for, only those of the merged mesh. */
static pf_status glue_to_unmerged(const glue *g, pf_mesh *m, pf_error *err)
{
    PF_TRY(glue_copy(g, m, err));
    m->face_elems = pf_alloc_array(2 * (size_t)g->n_faces + 1, sizeof *m->face_elems);
    PF_CHECK(m->face_elems, err, PF_ERR_NOMEM, "out of memory slicing");
    for (int64_t i = 0; i < 2 * (int64_t)g->n_faces; ++i)
        m->face_elems[i] = -1;
    for (int32_t e = 0; e < g->n_elems; ++e)
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k)
            m->face_elems[2 * PF_FACE_INDEX(m->elem_faces[k]) +
                          ((m->elem_faces[k] & PF_FACE_REVERSED) ? 1 : 0)] = e;
    return PF_OK;
}

static int32_t find_root(int32_t *parent, int32_t e)
{
    while (parent[e] != e) {
        parent[e] = parent[parent[e]];
        e = parent[e];
    }
    return e;
}

static double face_area(const pf_mesh *m, int32_t f)
{
    return pf_polygon_area(m->x, m->face_nodes + m->face_offsets[f],
                           m->face_offsets[f + 1] - m->face_offsets[f]);
}

/* The neighbouring group sharing the most face area with group r (members linked by next), or -1
 * when it touches no other element. */
static int32_t best_neighbour(const pf_mesh *m, int32_t *parent, const int32_t *next, int32_t r,
                              int32_t *cand, double *area, int32_t cap)
{
    int32_t n = 0;
    for (int32_t e = r; e >= 0; e = next[e])
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
            int32_t other = a == e ? b : a;
            if (other < 0)
                continue;
            int32_t ro = find_root(parent, other);
            if (ro == r)
                continue;
            int32_t i = 0;
            while (i < n && cand[i] != ro)
                ++i;
            if (i == n) {
                if (n == cap)
                    continue; /* more neighbours than a cell can have: ignore the rest */
                cand[n] = ro, area[n] = 0, ++n;
            }
            area[i] += face_area(m, f);
        }
    int32_t best = -1;
    for (int32_t i = 0; i < n; ++i)
        if (best < 0 || area[i] > area[best])
            best = i;
    return best < 0 ? -1 : cand[best];
}

/* Merges every group of volume below min_volume into its best neighbour (DG paper sec. 9.4, which
 * merges slivers into neighbours without prescribing an order): groups in index order, sweeps
 * repeated until no group below min_volume has a neighbour left, so the result is deterministic. */
pf_status pf_merge_slivers(const pf_mesh *m, double min_volume, const double *elem_min,
                           int32_t *parent, int32_t *merged, int32_t *isolated, pf_error *err)
{
    int32_t ne = m->n_elems;
    int32_t *next = pf_alloc_array((size_t)ne, sizeof *next);
    int32_t *last = pf_alloc_array((size_t)ne, sizeof *last);
    double *volume = pf_alloc_array((size_t)ne, sizeof *volume);
    enum { CAP = 256 };
    int32_t cand[CAP];
    double area[CAP];
    if (!next || !last || !volume) {
        pf_free(next), pf_free(last), pf_free(volume);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory merging");
    }
    for (int32_t e = 0; e < ne; ++e) {
        parent[e] = e, next[e] = -1, last[e] = e;
        volume[e] = pf_mesh_elem_volume(m, e);
    }
    *merged = *isolated = 0;
    for (bool changed = true; changed;) {
        changed = false;
        for (int32_t e = 0; e < ne; ++e) {
            if (parent[e] != e || volume[e] >= (elem_min ? elem_min[e] : min_volume))
                continue;
            int32_t into = best_neighbour(m, parent, next, e, cand, area, CAP);
            if (into < 0)
                continue;
            parent[e] = into;
            next[last[into]] = e; /* append e's members to into's list */
            last[into] = last[e];
            volume[into] += volume[e];
            ++*merged;
            changed = true;
        }
    }
    for (int32_t e = 0; e < ne; ++e)
        if (parent[e] == e && volume[e] < (elem_min ? elem_min[e] : min_volume))
            ++*isolated;
    pf_free(next), pf_free(last), pf_free(volume);
    return PF_OK;
}

/* The mesh with every group one element: faces inside a group dropped, nodes compacted. */
pf_status pf_rebuild_merged(const pf_mesh *m, int32_t *parent, pf_mesh *out, pf_error *err)
{
    int32_t ne = m->n_elems, nf = m->n_faces;
    int32_t *elem_id = pf_alloc_array((size_t)ne, sizeof *elem_id);
    int32_t *face_id = pf_alloc_array((size_t)nf, sizeof *face_id);
    int32_t *node_id = pf_alloc_array((size_t)m->n_nodes, sizeof *node_id);
    pf_status st = PF_OK;
    if (!elem_id || !face_id || !node_id) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory merging");
        goto done;
    }
    int32_t n_elems = 0, n_faces = 0, n_nodes = 0;
    int64_t n_face_nodes = 0, n_elem_faces = 0;
    for (int32_t e = 0; e < ne; ++e)
        elem_id[e] = find_root(parent, e) == e ? n_elems++ : -1;
    for (int32_t i = 0; i < m->n_nodes; ++i)
        node_id[i] = -1;
    for (int32_t f = 0; f < nf; ++f) {
        int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
        bool inside = a >= 0 && b >= 0 && find_root(parent, a) == find_root(parent, b);
        face_id[f] = inside ? -1 : n_faces++;
        if (inside)
            continue;
        n_face_nodes += m->face_offsets[f + 1] - m->face_offsets[f];
        n_elem_faces += (a >= 0) + (b >= 0);
        for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q)
            if (node_id[m->face_nodes[q]] < 0)
                node_id[m->face_nodes[q]] = n_nodes++;
    }
    st = pf_mesh_alloc(out, n_nodes, n_faces, n_face_nodes, n_elems, n_elem_faces, err);
    if (st < 0)
        goto done;
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (node_id[i] >= 0)
            memcpy(out->x + 3 * (size_t)node_id[i], m->x + 3 * (size_t)i, 3 * sizeof(double));
    for (int32_t f = 0; f < nf; ++f) {
        if (face_id[f] < 0)
            continue;
        int64_t at = out->face_offsets[face_id[f]];
        for (int64_t q = m->face_offsets[f]; q < m->face_offsets[f + 1]; ++q)
            out->face_nodes[at++] = (uint32_t)node_id[m->face_nodes[q]];
        out->face_offsets[face_id[f] + 1] = at;
    }
    /* elements in root order, each with its members' surviving faces: members bucketed by their
     * new element (a counting sort), so the pass is linear */
    int32_t *start = pf_calloc((size_t)n_elems + 1, sizeof *start);
    int32_t *members = pf_alloc_array((size_t)ne, sizeof *members);
    if (!start || !members) {
        pf_free(start), pf_free(members);
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory merging");
        goto done;
    }
    for (int32_t e = 0; e < ne; ++e)
        start[elem_id[find_root(parent, e)] + 1]++;
    for (int32_t k = 0; k < n_elems; ++k)
        start[k + 1] += start[k];
    for (int32_t e = 0; e < ne; ++e)
        members[start[elem_id[find_root(parent, e)]]++] = e;
    int64_t at = 0;
    for (int32_t k = 0, first = 0; k < n_elems; first = start[k], ++k) {
        for (int32_t q = first; q < start[k]; ++q) {
            int32_t e = members[q];
            for (int64_t j = m->elem_offsets[e]; j < m->elem_offsets[e + 1]; ++j) {
                uint32_t entry = m->elem_faces[j];
                int32_t f = PF_FACE_INDEX(entry);
                if (face_id[f] >= 0)
                    out->elem_faces[at++] = (uint32_t)face_id[f] | (entry & PF_FACE_REVERSED);
            }
        }
        out->elem_offsets[k + 1] = at;
    }
    pf_free(start), pf_free(members);
    st = pf_mesh_derive(out, err);
done:
    pf_free(elem_id), pf_free(face_id), pf_free(node_id);
    return st;
}

/* ---- entry point ----------------------------------------------------------------------------- */

pf_slice_params pf_slice_params_default(void)
{
    return (pf_slice_params){
        .grid = pf_voxelize_params_default(), .merge = 0.05, .robust = true, .contour_refine = 2};
}

pf_status pf_surface_piece(const pf_surface *s, piece *p, pf_error *err)
{
    memset(p, 0, sizeof *p);
    p->n_nodes = s->n_verts;
    p->n_faces = s->n_tris;
    p->x = pf_alloc_array(3 * (size_t)s->n_verts, sizeof *p->x);
    p->face_offsets = pf_alloc_array((size_t)s->n_tris + 1, sizeof *p->face_offsets);
    p->face_nodes = pf_alloc_array(3 * (size_t)s->n_tris, sizeof *p->face_nodes);
    if (!p->x || !p->face_offsets || !p->face_nodes) {
        pf_piece_release(p);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory slicing");
    }
    memcpy(p->x, s->x, 3 * (size_t)s->n_verts * sizeof *p->x);
    memcpy(p->face_nodes, s->tri, 3 * (size_t)s->n_tris * sizeof *p->face_nodes);
    for (int32_t t = 0; t <= s->n_tris; ++t)
        p->face_offsets[t] = 3 * (int64_t)t;
    pf_update_bounds(p);
    return PF_OK;
}

/* Slices the closed, manifold, outward surface s with the grid in stats->grid. */
static pf_status slice_clean(pf_mesh *m, const pf_surface *s, const pf_slice_params *p,
                             double tol, pf_slice_stats *stats, pf_error *err)
{
    slicer sl = {.grid = &stats->grid, .progress = p->progress, .progress_ctx = p->progress_ctx};
    sl.params.tol = tol;
    sl.params.assume_closed = true; /* the surface is checked above; pieces of splits are closed */
    piece whole;
    pf_mesh glued = {0};
    int32_t *parent = NULL;
    pf_status st = pf_surface_piece(s, &whole, err);
    if (st >= 0)
        st = slice_range(&sl, &whole, 0, err);
    if (st >= 0)
        st = glue_to_unmerged(&sl.glue, &glued, err);
    stats->splits = sl.splits;
    stats->pieces = sl.glue.n_elems;
    pf_glue_release(&sl.glue);
    pf_free(sl.remap);
    if (st >= 0) {
        parent = pf_alloc_array((size_t)glued.n_elems, sizeof *parent);
        st = parent ? PF_OK
                    : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory merging");
    }
    double h = stats->grid.h;
    if (st >= 0)
        st = pf_merge_slivers(&glued, p->merge * h * h * h, NULL, parent, &stats->merged,
                              &stats->isolated_slivers, err);
    if (st >= 0)
        st = pf_rebuild_merged(&glued, parent, m, err);
    pf_free(parent);
    pf_mesh_release(&glued);
    return st;
}

pf_status pf_slice_winding_surface(const pf_surface *s, const pf_grid *grid, int32_t refine,
                                   pf_surface *out, pf_surface_fix_report *orient,
                                   pf_winding_contour_stats *contour, bool *contoured,
                                   pf_error *err)
{
    memset(out, 0, sizeof *out);
    memset(contour, 0, sizeof *contour);
    PF_CHECK(refine >= 1 && refine <= 8, err, PF_ERR_INVALID,
             "contour refinement must be in 1 .. 8, got %d", (int)refine);
    pf_surface oriented;
    PF_TRY(pf_surface_alloc(&oriented, s->n_verts, s->n_tris, err));
    memcpy(oriented.x, s->x, 3 * (size_t)s->n_verts * sizeof *s->x);
    memcpy(oriented.tri, s->tri, 3 * (size_t)s->n_tris * sizeof *s->tri);
    oriented.id = s->id;
    pf_status st = pf_surface_orient(&oriented, orient, err);
    pf_surface_stats ss;
    if (st >= 0)
        st = pf_surface_compute_stats(&oriented, &ss, err);
    *contoured = false;
    bool overlap = true;
    if (st >= 0 && ss.closed && ss.manifold && ss.volume > 0)
        st = pf_surface_parts_overlap(&oriented, &overlap, err);
    if (st >= 0 && !overlap) {
        *out = oriented; /* orienting was enough: sliced as it is */
        return PF_OK;
    }
    *contoured = true;
    /* Lattice nodes at half-integer multiples of h / refine from the grid planes: never on one.
     * One node beyond the grid on every side, the outer layer counted outside. */
    double hl = grid->h / refine;
    int32_t n[3];
    for (int a = 0; a < 3; ++a)
        n[a] = grid->n[a] * refine + 2;
    pf_vec3 origin = pf_v3_sub(grid->origin, pf_v3(0.5 * hl, 0.5 * hl, 0.5 * hl));
    if (st >= 0)
        st = pf_surface_winding_contour(&oriented, origin, hl, n, out, contour, err);
    pf_surface_release(&oriented);
    return st;
}

pf_status pf_mesh_slice(pf_mesh *m, const pf_surface *s, const pf_slice_params *params,
                        pf_slice_stats *stats, pf_error *err)
{
    memset(m, 0, sizeof *m);
    pf_slice_params p = params ? *params : pf_slice_params_default();
    pf_slice_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    double t0 = pf_time_seconds();
    pf_surface_stats ss;
    PF_TRY(pf_surface_compute_stats(s, &ss, err));
    bool clean = ss.closed && ss.manifold && ss.volume > 0;
    if (clean && p.robust) {
        bool overlap;
        PF_TRY(pf_surface_parts_overlap(s, &overlap, err));
        clean = !overlap;
    }
    PF_CHECK(clean || p.robust, err, PF_ERR_INVALID,
             "slicing needs a closed, manifold, outward-oriented surface (%lld open edges, %lld "
             "non-manifold, %lld flipped, volume %g); the robust mode slices the winding-number "
             "solid of any surface",
             (long long)ss.n_boundary_edges, (long long)ss.n_nonmanifold_edges,
             (long long)ss.n_flipped_edges, ss.volume);
    PF_CHECK(p.merge >= 0 && p.merge < 1, err, PF_ERR_INVALID,
             "merge fraction must be in [0, 1), got %g", p.merge);
    PF_TRY(pf_grid_fit(ss.lo, ss.hi, &p.grid, &stats->grid, err));
    double tol = 1e-10 * pf_v3_norm(pf_v3_sub(ss.hi, ss.lo));
    pf_status st;
    if (clean) {
        st = slice_clean(m, s, &p, tol, stats, err);
    } else {
        pf_surface contour;
        stats->robust_used = true;
        st = pf_slice_winding_surface(s, &stats->grid, p.contour_refine, &contour,
                                      &stats->orient, &stats->contour, &stats->contoured, err);
        if (st >= 0)
            st = slice_clean(m, &contour, &p, tol, stats, err);
        pf_surface_release(&contour);
    }
    if (st < 0) {
        pf_mesh_release(m);
        return st;
    }
    for (int32_t e = 0; e < m->n_elems; ++e)
        stats->kinds[m->elem_kind[e]]++;
    stats->seconds = pf_time_seconds() - t0;
    return PF_OK;
}
