/* Adaptive octree meshing (harmonic paper sec. 7, fig. 4): cells refined toward the surface, coarse
 * inside, meeting without hanging nodes.
 *
 * Everything is addressed on the integer lattice of the finest level: a cell of depth k has edge
 * 2^(depth-k) lattice units and its lowest corner at lattice coordinates that are multiples of
 * that. Every position on a lattice plane is computed by the one formula coord(a, i) = origin_a +
 * i h, so equal lattice points are equal doubles wherever they are made.
 *
 * Faces: the face of a leaf toward a neighbour region is tiled by the faces of the leaves on the
 * other side where those are smaller (found by descending the neighbour's subtree), by its own
 * square otherwise; each square tile then lists, along its edges, every node lying on them (the
 * nodes are indexed per lattice line), so no node sits inside an edge of a face it is not part of.
 *
 * With slice, the solid is cut top-down by the octree's mid planes (x, y, z at every subdivided
 * cell) with pf_poly_split, as pf_mesh_slice does with its grid, following the pieces only into
 * the cells the surface comes near. Two leaves of full depth facing each other across a plane had
 * that plane applied once, in their lowest common ancestor, and every later plane both met came
 * in the same order (the two sides of a cell face span the same range along the other axes), so
 * their faces on the plane are the same polygons with the same nodes (see slice.c for why). A cell
 * the surface stays away from holds either its whole cube or nothing, so it is a lattice cube,
 * inside exactly when it received pieces; its face toward a cut leaf is tiled by that leaf's
 * polygons. Cut nodes within the cutting tolerance of a lattice plane are snapped onto it, so they
 * are the same doubles as lattice points and as each other. Slivers are merged as in pf-slice. */
#include <pf/mesh.h>
#include <pf/split.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "mesh_internal.h"
#include "octree_internal.h"

pf_octree_params pf_octree_params_default(void)
{
    return (pf_octree_params){.depth = 5, .min_depth = 2, .slice = false, .merge = 0.05,
                              .robust = true, .contour_refine = 2};
}

/* ---- the tree (types: octree_internal.h) ------------------------------------------------ */

static uint64_t leaf_key(int level, int32_t i, int32_t j, int32_t k)
{
    return (uint64_t)level << 48 | (uint64_t)i << 32 | (uint64_t)j << 16 | (uint64_t)k;
}

static void map_put(octree *oc, uint64_t key, int32_t val)
{
    uint64_t mask = (uint64_t)oc->slots - 1;
    for (uint64_t s = pf_hash_mix(key) & mask;; s = (s + 1) & mask)
        if (oc->keys[s] == UINT64_MAX) {
            oc->keys[s] = key;
            oc->vals[s] = val;
            return;
        }
}

static int32_t map_get(const octree *oc, uint64_t key)
{
    uint64_t mask = (uint64_t)oc->slots - 1;
    for (uint64_t s = pf_hash_mix(key) & mask; oc->keys[s] != UINT64_MAX; s = (s + 1) & mask)
        if (oc->keys[s] == key)
            return oc->vals[s];
    return -1;
}

static pf_status add_leaf(octree *oc, const int32_t c[3], int level, bool crossing, int inside,
                          pf_error *err)
{
    PF_CHECK(oc->n_leaves < INT32_MAX / 16, err, PF_ERR_TOO_LARGE,
             "octree of more than %d leaves: use a smaller depth", (int)(INT32_MAX / 16));
    if (oc->n_leaves == oc->cap_leaves) {
        int32_t cap = oc->cap_leaves ? 2 * oc->cap_leaves : 1024;
        leaf *l = pf_realloc_array(oc->leaves, (size_t)cap, sizeof *l);
        PF_CHECK(l, err, PF_ERR_NOMEM, "out of memory for %d octree leaves", (int)cap);
        oc->leaves = l;
        oc->cap_leaves = cap;
    }
    if ((int64_t)oc->n_leaves * 2 >= oc->slots) {
        int64_t slots = oc->slots ? 2 * oc->slots : 4096;
        uint64_t *keys = pf_alloc_array((size_t)slots, sizeof *keys);
        int32_t *vals = pf_alloc_array((size_t)slots, sizeof *vals);
        if (!keys || !vals) {
            pf_free(keys), pf_free(vals);
            return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                "out of memory for the octree map");
        }
        pf_free(oc->keys), pf_free(oc->vals);
        oc->keys = keys, oc->vals = vals, oc->slots = slots;
        memset(keys, 0xff, (size_t)slots * sizeof *keys);
        for (int32_t q = 0; q < oc->n_leaves; ++q) {
            const leaf *l = &oc->leaves[q];
            map_put(oc, leaf_key(l->level, l->c[0], l->c[1], l->c[2]), q);
        }
    }
    leaf *l = &oc->leaves[oc->n_leaves];
    *l = (leaf){.c = {c[0], c[1], c[2]},
                .level = (int8_t)level,
                .crossing = crossing,
                .inside = inside > 0,
                .first_piece = oc->n_pieces};
    map_put(oc, leaf_key(level, c[0], c[1], c[2]), oc->n_leaves);
    oc->n_leaves++;
    return PF_OK;
}

static pf_status push_tri(octree *oc, int32_t t, pf_error *err)
{
    if (oc->n_tris == oc->cap_tris) {
        int64_t cap = oc->cap_tris ? 2 * oc->cap_tris : 4096;
        int32_t *tris = pf_realloc_array(oc->tris, (size_t)cap, sizeof *tris);
        PF_CHECK(tris, err, PF_ERR_NOMEM, "out of memory for octree triangle lists");
        oc->tris = tris;
        oc->cap_tris = cap;
    }
    oc->tris[oc->n_tris++] = t;
    return PF_OK;
}

/* Pushes the triangles of list [b, e) that come within margin of the cell's closed box. */
static pf_status filter_tris(octree *oc, const int32_t c[3], int level, int64_t b, int64_t e,
                             pf_error *err)
{
    int32_t sz = cell_size(oc, level);
    pf_vec3 centre = pf_v3(0.5 * (coord(oc, 0, c[0]) + coord(oc, 0, c[0] + sz)),
                           0.5 * (coord(oc, 1, c[1]) + coord(oc, 1, c[1] + sz)),
                           0.5 * (coord(oc, 2, c[2]) + coord(oc, 2, c[2] + sz)));
    double half = 0.5 * sz * oc->h + oc->margin;
    const pf_surface *s = oc->s;
    for (int64_t q = b; q < e; ++q) {
        int32_t t = oc->tris[q];
        pf_vec3 p0 = pf_v3_load(s->x + 3 * (size_t)s->tri[3 * (size_t)t]);
        pf_vec3 p1 = pf_v3_load(s->x + 3 * (size_t)s->tri[3 * (size_t)t + 1]);
        pf_vec3 p2 = pf_v3_load(s->x + 3 * (size_t)s->tri[3 * (size_t)t + 2]);
        if (pf_triangle_overlaps_box(p0, p1, p2, centre, half))
            PF_TRY(push_tri(oc, t, err));
    }
    return PF_OK;
}

/* ---- cutting pieces (slice) ------------------------------------------------------------------ */

static void list_release(piece_list *l)
{
    for (int32_t k = 0; k < l->n; ++k)
        pf_piece_release(&l->p[k]);
    pf_free(l->p);
    memset(l, 0, sizeof *l);
}

/* Moves *p into l (p is zeroed). */
static pf_status list_push(piece_list *l, piece *p, pf_error *err)
{
    if (l->n == l->cap) {
        int32_t cap = l->cap ? 2 * l->cap : 4;
        piece *q = pf_realloc_array(l->p, (size_t)cap, sizeof *q);
        if (!q) {
            pf_piece_release(p);
            return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory cutting");
        }
        l->p = q;
        l->cap = cap;
    }
    l->p[l->n++] = *p;
    memset(p, 0, sizeof *p);
    return PF_OK;
}

/* Splits every piece of in (emptied) at the plane x_axis = c into below and above. */
static pf_status cut_list(octree *oc, piece_list *in, int axis, double c, piece_list *below,
                          piece_list *above, pf_error *err)
{
    pf_status st = PF_OK;
    for (int32_t k = 0; st >= 0 && k < in->n; ++k) {
        piece *p = &in->p[k];
        if (p->hi[axis] <= c + oc->tol) { /* wholly below, touching at most: no cut */
            st = list_push(below, p, err);
            continue;
        }
        if (p->lo[axis] >= c - oc->tol) {
            st = list_push(above, p, err);
            continue;
        }
        pf_plane plane = {{axis == 0, axis == 1, axis == 2}, c};
        pf_polyhedron view = pf_piece_view(p);
        pf_split split;
        st = pf_poly_split(&view, p->n_nodes, &plane, &oc->split, &split, err);
        pf_piece_release(p);
        oc->splits++;
        if (st >= 0)
            st = pf_remap_reserve(&oc->remap, &oc->cap_remap, split.n_nodes, err);
        for (int32_t q = 0; st >= 0 && q < split.n_pieces; ++q) {
            piece sub;
            st = pf_extract_piece(&split, q, oc->remap, &sub, err);
            if (st >= 0)
                st = list_push(split.piece_side[q] < 0 ? below : above, &sub, err);
        }
        pf_split_release(&split);
    }
    list_release(in);
    return st;
}

/* Cuts the pieces of cell (c, level) by its three mid planes, x first, into its octants:
 * out[bits], bit a set for the upper half along axis a. */
static pf_status cut_octants(octree *oc, const int32_t c[3], int level, piece_list *in, int axis,
                             int bits, piece_list out[8], pf_error *err)
{
    if (axis == 3) {
        out[bits] = *in;
        memset(in, 0, sizeof *in);
        return PF_OK;
    }
    int32_t half = cell_size(oc, level) / 2;
    piece_list below = {0}, above = {0};
    pf_status st = cut_list(oc, in, axis, coord(oc, axis, c[axis] + half), &below, &above, err);
    if (st >= 0)
        st = cut_octants(oc, c, level, &below, axis + 1, bits, out, err);
    if (st >= 0)
        st = cut_octants(oc, c, level, &above, axis + 1, bits | 1 << axis, out, err);
    list_release(&below);
    list_release(&above);
    return st;
}

/* Snaps every coordinate within tol of a lattice plane onto the plane's formula value. */
static void snap_piece(const octree *oc, piece *p)
{
    for (int32_t i = 0; i < p->n_nodes; ++i)
        for (int a = 0; a < 3; ++a) {
            double *v = &p->x[3 * (size_t)i + a];
            double r = nearbyint((*v - oc->o[a]) / oc->h);
            if (r >= 0 && r <= oc->n && fabs(*v - coord(oc, a, (int64_t)r)) <= oc->tol)
                *v = coord(oc, a, (int64_t)r);
        }
    pf_update_bounds(p);
}

/* Keeps the pieces of a crossing leaf (moved out of l). */
static pf_status keep_pieces(octree *oc, piece_list *l, pf_error *err)
{
    if (oc->n_pieces + l->n > oc->cap_pieces) {
        int32_t cap = oc->cap_pieces ? oc->cap_pieces : 256;
        while (cap < oc->n_pieces + l->n)
            cap *= 2;
        piece *q = pf_realloc_array(oc->pieces, (size_t)cap, sizeof *q);
        PF_CHECK(q, err, PF_ERR_NOMEM, "out of memory for %d pieces", (int)cap);
        oc->pieces = q;
        oc->cap_pieces = cap;
    }
    for (int32_t k = 0; k < l->n; ++k) {
        snap_piece(oc, &l->p[k]);
        oc->pieces[oc->n_pieces++] = l->p[k];
    }
    l->n = 0;
    list_release(l);
    return PF_OK;
}

/* A cell the surface stays away from holds its whole cube or nothing. */
static pf_status check_whole(const octree *oc, const piece_list *l, const int32_t c[3], int level,
                             pf_error *err)
{
    double volume = 0, edge = cell_size(oc, level) * oc->h;
    for (int32_t k = 0; k < l->n; ++k) {
        pf_polyhedron v = pf_piece_view(&l->p[k]);
        volume += pf_polyhedron_volume(&v);
    }
    /* the cube's volume to rounding of the cut nodes (a few ulp of the coordinates) */
    PF_CHECK(l->n == 0 || fabs(volume - edge * edge * edge) <= 1e-9 * edge * edge * edge, err,
             PF_ERR_NUMERIC,
             "octree cell at lattice (%d, %d, %d), depth %d: the surface stays away from it but "
             "the cut left %.17g of its volume %.17g",
             (int)c[0], (int)c[1], (int)c[2], level, volume, edge * edge * edge);
    return PF_OK;
}

/* ---- refinement ------------------------------------------------------------------------------ */

/* Cell (c, level) with the triangles [b, e) near it and, with slice, its pieces (consumed).
 * inside: -1 unknown, else whether a cell away from the surface is in the solid. */
static pf_status build(octree *oc, const int32_t c[3], int level, int64_t b, int64_t e,
                       piece_list *pieces, int inside, pf_error *err)
{
    bool crossing = e > b;
    bool refine = level < oc->p.depth && (crossing || level < oc->p.min_depth);
    if (!refine) {
        PF_TRY(add_leaf(oc, c, level, crossing, inside, err));
        if (crossing && pieces) {
            PF_TRY(keep_pieces(oc, pieces, err));
            oc->leaves[oc->n_leaves - 1].n_pieces =
                oc->n_pieces - oc->leaves[oc->n_leaves - 1].first_piece;
        }
        if (oc->p.progress) { /* a leaf at level holds 8^-level of the root cube */
            oc->volume_done += ldexp(1.0, -3 * level);
            oc->p.progress(oc->p.progress_ctx, oc->volume_done, 1.0);
        }
        return PF_OK;
    }
    piece_list octant[8];
    memset(octant, 0, sizeof octant);
    pf_status st = PF_OK;
    if (crossing && pieces)
        st = cut_octants(oc, c, level, pieces, 0, 0, octant, err);
    int32_t half = cell_size(oc, level) / 2;
    for (int q = 0; st >= 0 && q < 8; ++q) {
        int32_t cc[3] = {c[0] + (q & 1 ? half : 0), c[1] + (q & 2 ? half : 0),
                         c[2] + (q & 4 ? half : 0)};
        int64_t start = oc->n_tris;
        st = filter_tris(oc, cc, level + 1, b, e, err);
        if (st < 0)
            break;
        int child_inside = inside;
        piece_list *child_pieces = NULL;
        if (crossing && pieces) {
            if (oc->n_tris > start) {
                child_pieces = &octant[q];
            } else {
                st = check_whole(oc, &octant[q], cc, level + 1, err);
                child_inside = octant[q].n > 0;
                list_release(&octant[q]);
            }
        }
        if (st >= 0)
            st = build(oc, cc, level + 1, start, oc->n_tris, child_pieces, child_inside, err);
        oc->n_tris = start;
    }
    for (int q = 0; q < 8; ++q)
        list_release(&octant[q]);
    return st;
}

/* ---- face tiling ------------------------------------------------------------------------------
 */

/* A whole-cell element: a leaf that is inside and, with slice, away from the surface. */
static bool is_cube(const octree *oc, const leaf *l)
{
    return l->inside && !(oc->p.slice && l->crossing);
}

/* Leaves of the subtree of the subdivided cell (c, level) touching its face on side (axis, low
 * when toward_low) appended to out. */
static pf_status descend(const octree *oc, const int32_t c[3], int level, int axis, bool toward_low,
                         pf_buffer *out, pf_error *err)
{
    PF_CHECK(level < oc->p.depth, err, PF_ERR_NUMERIC, "octree: a cell below the full depth");
    int32_t half = cell_size(oc, level) / 2;
    for (int q = 0; q < 8; ++q) {
        if (((q >> axis) & 1) != (toward_low ? 0 : 1))
            continue;
        int32_t cc[3] = {c[0] + (q & 1 ? half : 0), c[1] + (q & 2 ? half : 0),
                         c[2] + (q & 4 ? half : 0)};
        int32_t found = map_get(oc, leaf_key(level + 1, cc[0], cc[1], cc[2]));
        if (found >= 0)
            PF_TRY(pf_buffer_append(out, &found, sizeof found, err));
        else
            PF_TRY(descend(oc, cc, level + 1, axis, toward_low, out, err));
    }
    return PF_OK;
}

/* The tiles of side (axis, dir) of leaf li, appended to out as leaf indices: the leaf whose face
 * square the tile is (li itself when the other side is no smaller, or the root boundary). */
static pf_status face_tiles(const octree *oc, int32_t li, int axis, int dir, pf_buffer *out,
                            pf_error *err)
{
    const leaf *l = &oc->leaves[li];
    int32_t sz = cell_size(oc, l->level);
    int32_t nb[3] = {l->c[0], l->c[1], l->c[2]};
    nb[axis] += dir > 0 ? sz : -sz;
    if (nb[axis] < 0 || nb[axis] >= oc->n)
        return pf_buffer_append(out, &li, sizeof li, err);
    for (int level = l->level; level >= 0; --level) {
        int32_t m = ~(cell_size(oc, level) - 1);
        int32_t found = map_get(oc, leaf_key(level, nb[0] & m, nb[1] & m, nb[2] & m));
        if (found >= 0) {
            /* a neighbour as large or larger: l's own square, or the cut leaf's polygons */
            int32_t tile =
                level == l->level && oc->p.slice && oc->leaves[found].crossing ? found : li;
            return pf_buffer_append(out, &tile, sizeof tile, err);
        }
    }
    return descend(oc, nb, l->level, axis, dir > 0, out, err);
}

/* Side of the cell of crossing leaf l that face f of piece p lies on (0 .. 5: 2 axis + (high)),
 * or -1. Snapped nodes on a lattice plane carry its exact value. */
static int piece_face_side(const octree *oc, const leaf *l, const piece *p, int32_t f)
{
    for (int side = 0; side < 6; ++side) {
        int a = side / 2;
        double v = coord(oc, a, l->c[a] + (side & 1));
        bool on = true;
        for (int64_t q = p->face_offsets[f]; on && q < p->face_offsets[f + 1]; ++q)
            on = p->x[3 * (size_t)p->face_nodes[q] + a] == v;
        if (on)
            return side;
    }
    return -1;
}

/* ---- nodes on lattice lines ------------------------------------------------------------------ */

typedef struct line_node {
    uint64_t line; /* axis << 32 | (index along the next axis) << 16 | index along the one after */
    double pos;    /* coordinate along the axis */
} line_node;

static int compare_line_node(const void *pa, const void *pb)
{
    const line_node *a = pa, *b = pb;
    if (a->line != b->line)
        return a->line < b->line ? -1 : 1;
    return (a->pos > b->pos) - (a->pos < b->pos);
}

static uint64_t line_id(int axis, int64_t ib, int64_t ic)
{
    return (uint64_t)axis << 32 | (uint64_t)ib << 16 | (uint64_t)ic;
}

/* Lattice index of coordinate v on axis a, or -1 when v is not a lattice plane's value. */
static int64_t lattice_index(const octree *oc, int a, double v)
{
    double r = nearbyint((v - oc->o[a]) / oc->h);
    return r >= 0 && r <= oc->n && coord(oc, a, (int64_t)r) == v ? (int64_t)r : -1;
}

static pf_status add_point_lines(const octree *oc, const double *x, pf_buffer *lines, pf_error *err)
{
    int64_t idx[3];
    for (int a = 0; a < 3; ++a)
        idx[a] = lattice_index(oc, a, x[a]);
    for (int a = 0; a < 3; ++a) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        if (idx[b] < 0 || idx[c] < 0)
            continue;
        line_node ln = {line_id(a, idx[b], idx[c]), x[a]};
        PF_TRY(pf_buffer_append(lines, &ln, sizeof ln, err));
    }
    return PF_OK;
}

/* Inserts key into the open-addressing set (UINT64_MAX empty); false when it was there. */
static bool point_set_insert(uint64_t *set, int64_t slots, uint64_t key)
{
    uint64_t mask = (uint64_t)slots - 1;
    uint64_t s = pf_hash_mix(key) & mask;
    for (; set[s] != UINT64_MAX; s = (s + 1) & mask)
        if (set[s] == key)
            return false;
    set[s] = key;
    return true;
}

/* Doubles the set (at least 4096 slots), reinserting its keys. */
static pf_status grow_point_set(uint64_t **set, int64_t *slots, pf_error *err)
{
    int64_t n = *slots ? 2 * *slots : 4096;
    uint64_t *grown = pf_alloc_array((size_t)n, sizeof *grown);
    PF_CHECK(grown, err, PF_ERR_NOMEM, "out of memory for octree nodes");
    memset(grown, 0xff, (size_t)n * sizeof *grown);
    for (int64_t k = 0; k < *slots; ++k)
        if ((*set)[k] != UINT64_MAX)
            point_set_insert(grown, n, (*set)[k]);
    pf_free(*set);
    *set = grown;
    *slots = n;
    return PF_OK;
}

/* ---- elements ------------------------------------------------------------------------------- */

/* Scratch for one element: nodes appended per face (glue merges equal coordinates). */
typedef struct builder {
    pf_buffer x;            /* double */
    pf_buffer face_offsets; /* int64 */
    pf_buffer face_nodes;   /* uint32 */
    int32_t n_nodes, n_faces;
} builder;

static void builder_reset(builder *b)
{
    b->x.size = b->face_offsets.size = b->face_nodes.size = 0;
    b->n_nodes = b->n_faces = 0;
}

static pf_status builder_node(builder *b, const double *p, pf_error *err)
{
    PF_TRY(pf_buffer_append(&b->x, p, 3 * sizeof *p, err));
    uint32_t id = (uint32_t)b->n_nodes++;
    return pf_buffer_append(&b->face_nodes, &id, sizeof id, err);
}

static pf_status builder_end_face(builder *b, pf_error *err)
{
    if (b->n_faces == 0) {
        int64_t zero = 0;
        PF_TRY(pf_buffer_append(&b->face_offsets, &zero, sizeof zero, err));
    }
    int64_t end = (int64_t)(b->face_nodes.size / sizeof(uint32_t));
    b->n_faces++;
    return pf_buffer_append(&b->face_offsets, &end, sizeof end, err);
}

static piece builder_piece(const builder *b)
{
    return (piece){.n_nodes = b->n_nodes,
                   .x = (double *)b->x.data,
                   .n_faces = b->n_faces,
                   .face_offsets = (int64_t *)b->face_offsets.data,
                   .face_nodes = (uint32_t *)b->face_nodes.data};
}

typedef struct lines {
    const line_node *v;
    int64_t n;
    int64_t n_cut; /* cut pieces (0 without slice): their nodes may lie inside finest edges */
} lines;

/* Appends the lattice point p (lattice units) and then every node strictly inside the segment
 * from p to the next corner along axis a (d lattice units, signed), in the order met. */
static pf_status square_edge(const octree *oc, const lines *ln, const int64_t p[3], int a,
                             int64_t d, builder *b, pf_error *err)
{
    double x[3] = {coord(oc, 0, p[0]), coord(oc, 1, p[1]), coord(oc, 2, p[2])};
    PF_TRY(builder_node(b, x, err));
    if (ln->n_cut == 0 && (d == 1 || d == -1))
        return PF_OK; /* a finest edge holds no lattice point inside, and there are no cut nodes */
    int bb = (a + 1) % 3, cc = (a + 2) % 3;
    uint64_t id = line_id(a, p[bb], p[cc]);
    double lo = coord(oc, a, d > 0 ? p[a] : p[a] + d), hi = coord(oc, a, d > 0 ? p[a] + d : p[a]);
    /* first entry of the line with pos > lo */
    int64_t l = 0, r = ln->n;
    while (l < r) {
        int64_t m = l + (r - l) / 2;
        const line_node *e = &ln->v[m];
        if (e->line < id || (e->line == id && e->pos <= lo))
            l = m + 1;
        else
            r = m;
    }
    int64_t end = l;
    while (end < ln->n && ln->v[end].line == id && ln->v[end].pos < hi)
        ++end;
    for (int64_t k = 0; k < end - l; ++k) {
        x[a] = ln->v[d > 0 ? l + k : end - 1 - k].pos;
        PF_TRY(builder_node(b, x, err));
    }
    return PF_OK;
}

/* The square of leaf t's face on the plane of side (axis, dir) of leaf li (t is li or a smaller
 * leaf across it), counter-clockwise about li's outward normal, with the nodes on its edges. */
static pf_status square_tile(const octree *oc, const lines *ln, int32_t li, int32_t t, int axis,
                             int dir, builder *b, pf_error *err)
{
    const leaf *l = &oc->leaves[li], *s = &oc->leaves[t];
    int bb = (axis + 1) % 3, cc = (axis + 2) % 3;
    int32_t sz = cell_size(oc, s->level);
    int64_t plane = dir > 0 ? l->c[axis] + cell_size(oc, l->level) : l->c[axis];
    /* corners in (bb, cc): e_bb x e_cc = e_axis, so (0,0) (1,0) (1,1) (0,1) is counter-clockwise
     * about +e_axis, its reverse about -e_axis */
    static const int ccw[2][4][2] = {{{0, 0}, {0, 1}, {1, 1}, {1, 0}},
                                     {{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
    const int(*corner)[2] = ccw[dir > 0];
    for (int k = 0; k < 4; ++k) {
        const int *q = corner[k], *q1 = corner[(k + 1) % 4];
        int64_t p[3];
        p[axis] = plane;
        p[bb] = s->c[bb] + q[0] * sz;
        p[cc] = s->c[cc] + q[1] * sz;
        int moving = q[0] != q1[0] ? bb : cc;
        int64_t d = (int64_t)(moving == bb ? q1[0] - q[0] : q1[1] - q[1]) * sz;
        PF_TRY(square_edge(oc, ln, p, moving, d, b, err));
    }
    return builder_end_face(b, err);
}

/* The faces of crossing leaf t's pieces on its side `side`, reversed (outward for the cube on
 * the other side). Returns the number of faces added in *count. */
static pf_status polygon_tiles(const octree *oc, int32_t t, int side, builder *b, int32_t *count,
                               pf_error *err)
{
    const leaf *l = &oc->leaves[t];
    *count = 0;
    for (int32_t k = l->first_piece; k < l->first_piece + l->n_pieces; ++k) {
        const piece *p = &oc->pieces[k];
        for (int32_t f = 0; f < p->n_faces; ++f) {
            if (piece_face_side(oc, l, p, f) != side)
                continue;
            for (int64_t q = p->face_offsets[f + 1] - 1; q >= p->face_offsets[f]; --q)
                PF_TRY(builder_node(b, p->x + 3 * (size_t)p->face_nodes[q], err));
            PF_TRY(builder_end_face(b, err));
            ++*count;
        }
    }
    return PF_OK;
}

static void octree_release(octree *oc)
{
    pf_free(oc->leaves);
    pf_free(oc->keys);
    pf_free(oc->vals);
    pf_free(oc->tris);
    for (int32_t k = 0; k < oc->n_pieces; ++k)
        pf_piece_release(&oc->pieces[k]);
    pf_free(oc->pieces);
    pf_free(oc->remap);
    memset(oc, 0, sizeof *oc);
}

/* Tiles of every side of every cube (CSR over 6 sides per cube in leaf order) and the nodes on
 * lattice lines, then every element glued. */
static pf_status emit(octree *oc, glue *g, pf_octree_stats *stats, pf_error *err)
{
    pf_buffer tiles = {0}, side_end = {0}, lines_buf = {0};
    builder b = {0};
    pf_status st = PF_OK;
    /* lattice corners of square tiles, each put on its lines once: a set of packed points */
    uint64_t *seen = NULL;
    int64_t seen_slots = 0, n_seen = 0;
    /* pass 1: tiles, and the nodes their squares and the pieces put on lattice lines */
    for (int32_t li = 0; st >= 0 && li < oc->n_leaves; ++li) {
        const leaf *l = &oc->leaves[li];
        if (!is_cube(oc, l))
            continue;
        for (int side = 0; st >= 0 && side < 6; ++side) {
            size_t before = tiles.size;
            st = face_tiles(oc, li, side / 2, side & 1 ? 1 : -1, &tiles, err);
            int64_t end = (int64_t)(tiles.size / sizeof(int32_t));
            if (st >= 0)
                st = pf_buffer_append(&side_end, &end, sizeof end, err);
            if (st >= 0 && tiles.size - before > sizeof(int32_t))
                stats->split_faces++;
            for (size_t q = before; st >= 0 && q < tiles.size; q += sizeof(int32_t)) {
                int32_t t;
                memcpy(&t, tiles.data + q, sizeof t);
                const leaf *s = &oc->leaves[t];
                if (oc->p.slice && s->crossing)
                    continue; /* its nodes come with the pieces */
                int a = side / 2, bb = (a + 1) % 3, cc = (a + 2) % 3;
                int32_t sz = cell_size(oc, s->level);
                for (int k = 0; st >= 0 && k < 4; ++k) {
                    int64_t p[3];
                    p[a] = side & 1 ? l->c[a] + cell_size(oc, l->level) : l->c[a];
                    p[bb] = s->c[bb] + (k & 1) * sz;
                    p[cc] = s->c[cc] + (k >> 1) * sz;
                    if (2 * (n_seen + 1) > seen_slots) {
                        st = grow_point_set(&seen, &seen_slots, err);
                        if (st < 0)
                            break;
                    }
                    if (!point_set_insert(seen, seen_slots,
                                          leaf_key(0, (int32_t)p[0], (int32_t)p[1], (int32_t)p[2])))
                        continue;
                    ++n_seen;
                    double x[3] = {coord(oc, 0, p[0]), coord(oc, 1, p[1]), coord(oc, 2, p[2])};
                    st = add_point_lines(oc, x, &lines_buf, err);
                }
            }
        }
    }
    for (int32_t k = 0; st >= 0 && k < oc->n_pieces; ++k)
        for (int32_t i = 0; st >= 0 && i < oc->pieces[k].n_nodes; ++i)
            st = add_point_lines(oc, oc->pieces[k].x + 3 * (size_t)i, &lines_buf, err);
    lines ln = {(const line_node *)lines_buf.data, (int64_t)(lines_buf.size / sizeof(line_node)),
                oc->n_pieces};
    if (st >= 0) {
        line_node *v = (line_node *)lines_buf.data;
        qsort(v, (size_t)ln.n, sizeof *v, compare_line_node);
        int64_t u = 0;
        for (int64_t k = 0; k < ln.n; ++k)
            if (u == 0 || v[k].line != v[u - 1].line || v[k].pos != v[u - 1].pos)
                v[u++] = v[k];
        ln.n = u;
    }
    /* pass 2: the elements in leaf order */
    const int32_t *tile = (const int32_t *)tiles.data;
    const int64_t *ends = (const int64_t *)side_end.data;
    int64_t side_at = 0;
    for (int32_t li = 0; st >= 0 && li < oc->n_leaves; ++li) {
        const leaf *l = &oc->leaves[li];
        if (oc->p.slice && l->crossing) {
            for (int32_t k = l->first_piece; st >= 0 && k < l->first_piece + l->n_pieces; ++k)
                st = pf_glue_piece(g, &oc->pieces[k], err);
            continue;
        }
        if (!l->inside)
            continue;
        builder_reset(&b);
        for (int side = 0; st >= 0 && side < 6; ++side, ++side_at) {
            int64_t t0 = side_at ? ends[side_at - 1] : 0, t1 = ends[side_at];
            for (int64_t q = t0; st >= 0 && q < t1; ++q) {
                const leaf *s = &oc->leaves[tile[q]];
                if (oc->p.slice && s->crossing) {
                    int32_t count;
                    st = polygon_tiles(oc, tile[q], side ^ 1, &b, &count, err);
                    if (st >= 0 && count == 0)
                        st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                                          "octree: the cut cell at lattice (%d, %d, %d) has no "
                                          "face toward the cell inside it touches",
                                          (int)s->c[0], (int)s->c[1], (int)s->c[2]);
                } else {
                    st = square_tile(oc, &ln, li, tile[q], side / 2, side & 1 ? 1 : -1, &b, err);
                }
            }
        }
        if (st >= 0) {
            piece view = builder_piece(&b);
            st = pf_glue_piece(g, &view, err);
            stats->cells_by_depth[l->level]++;
        }
    }
    pf_free(seen);
    pf_buffer_release(&tiles);
    pf_buffer_release(&side_end);
    pf_buffer_release(&lines_buf);
    pf_buffer_release(&b.x);
    pf_buffer_release(&b.face_offsets);
    pf_buffer_release(&b.face_nodes);
    return st;
}

/* ---- entry point ----------------------------------------------------------------------------- */

pf_status pf_octree_mesh(pf_mesh *m, const pf_surface *s, const pf_octree_params *params,
                             pf_vec3 lo, pf_vec3 hi, bool closed, pf_octree_stats *stats,
                             pf_error *err)
{
    pf_octree_params p = *params;
    double t0 = pf_time_seconds();
    pf_surface_stats ss = {.lo = lo, .hi = hi, .closed = closed};
    pf_vec3 extent = pf_v3_sub(ss.hi, ss.lo);
    double size = pf_v3_max_abs(extent);
    PF_CHECK(size > 0 && isfinite(size), err, PF_ERR_INVALID,
             "the surface has an empty or non-finite bounding box");

    octree oc = {.s = s, .p = p, .n = 1 << p.depth};
    for (int a = 0; a < 3; ++a)
        oc.o[a] = 0.5 * (pf_v3_get(ss.lo, a) + pf_v3_get(ss.hi, a)) - 0.5 * size;
    oc.h = size / oc.n;
    oc.tol = 1e-10 * pf_v3_norm(extent);
    oc.margin = 4 * oc.tol;
    oc.split.tol = oc.tol;
    oc.split.assume_closed = true; /* the surface is checked above; pieces of splits are closed */
    stats->origin = pf_v3(oc.o[0], oc.o[1], oc.o[2]);
    stats->size = size;
    stats->h = oc.h;

    pf_status st = PF_OK;
    for (int32_t t = 0; st >= 0 && t < s->n_tris; ++t)
        st = push_tri(&oc, t, err);
    int64_t root_end = oc.n_tris;
    piece_list root = {0};
    if (st >= 0 && p.slice) {
        piece whole;
        st = pf_surface_piece(s, &whole, err);
        if (st >= 0)
            st = list_push(&root, &whole, err);
    }
    static const int32_t origin[3] = {0, 0, 0};
    if (st >= 0)
        st = filter_tris(&oc, origin, 0, 0, root_end, err);
    if (st >= 0)
        st = build(&oc, origin, 0, root_end, oc.n_tris, p.slice ? &root : NULL, -1, err);
    list_release(&root);
    stats->leaves = oc.n_leaves;
    for (int32_t q = 0; q < oc.n_leaves; ++q)
        stats->surface_leaves += oc.leaves[q].crossing;
    if (st >= 0 && !p.slice) {
        if (ss.closed) {
            stats->method = PF_INSIDE_RAYS;
            st = pf_octree_classify_by_rays(&oc, err);
        } else {
            stats->method = PF_INSIDE_WINDING;
            pf_octree_classify_by_winding(&oc);
        }
    }
    glue g = {0};
    pf_mesh glued = {0};
    if (st >= 0)
        st = emit(&oc, &g, stats, err);
    stats->splits = oc.splits;
    octree_release(&oc);
    if (st >= 0)
        st = g.n_elems > 0 ? PF_OK
                           : pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                                          "no octree cell is inside the surface at depth %d: use "
                                          "a larger depth or check that the surface is closed",
                                          (int)p.depth);
    if (st >= 0)
        st = pf_glue_to_mesh(&g, p.slice ? &glued : m, err);
    stats->pieces = g.n_elems;
    pf_glue_release(&g);
    if (st >= 0 && p.slice) {
        int32_t *parent = pf_alloc_array((size_t)glued.n_elems, sizeof *parent);
        st = parent ? PF_OK
                    : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory merging");
        if (st >= 0)
            st = pf_merge_slivers(&glued, p.merge * stats->h * stats->h * stats->h, NULL, parent,
                                  &stats->merged, &stats->isolated_slivers, err);
        if (st >= 0)
            st = pf_rebuild_merged(&glued, parent, m, err);
        pf_free(parent);
    }
    pf_mesh_release(&glued);
    if (st < 0) {
        pf_mesh_release(m);
        return st;
    }
    for (int32_t e = 0; e < m->n_elems; ++e)
        stats->kinds[m->elem_kind[e]]++;
    stats->seconds = pf_time_seconds() - t0;
    return PF_OK;
}
