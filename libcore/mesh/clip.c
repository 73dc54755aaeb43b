/* Clipping a mesh by a closed surface (pf/cut.h, pf_mesh_clip_surface): DG paper sec. 9.4 and
 * fig. 10, a bunny cut out of a cube.
 *
 * The slicer's idea turned around (slice.c): there the solid the surface bounds is cut by the
 * planes of a grid; here by the planes of the elements. The solid is one closed polyhedron (the
 * surface's triangles; for the outside, a box around everything with the surface reversed inside
 * it), split with pf_poly_split. A kd tree over the elements' boxes bisects it along axis planes
 * so that each element meets a small piece: an element lying wholly on one side of a node's plane
 * goes down that side, the others are clipped at the node. Clipping an element is splitting its
 * piece by the element's box planes, then by the planes of its faces (the element is convex),
 * keeping what lies inside. A piece with no surface left in it is the element itself (kept whole),
 * an empty one means the element is dropped.
 *
 * The parts of neighbouring elements come from different sequences of splits, so their shared
 * faces are rebuilt on welded nodes (clip_faces.c) before they are glued by node sets as in the
 * slicer; then slivers are merged by the slicer's rule. A face on an element face that is used
 * only once although both neighbours have a part on it is reported, never left as a crack. */
#include <pf/cut.h>
#include <pf/refine.h>
#include <pf/split.h>

#include "clip_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { OUTSIDE = PF_CLIP_DROPPED, WHOLE = PF_CLIP_WHOLE, CLIPPED = PF_CLIP_CLIPPED };

/* A piece of the solid and, for each face, the triangle of the surface it is part of (-1: a cap
 * made by a split, or a face of the outer box). */
typedef struct cpiece {
    piece p;
    int32_t *origin; /* [p.n_faces] */
} cpiece;

typedef struct clipper {
    const pf_mesh *m;
    double tol;
    pf_split_params sp;
    int32_t *remap; /* [cap_remap] all -1 between uses */
    int32_t cap_remap;
    double *box;               /* [6 n_elems] lo, hi of every element */
    uint8_t *state;            /* [n_elems] OUTSIDE, WHOLE, CLIPPED */
    pf_clip_elem_parts *parts; /* [n_elems] */
    double *tri_normal;        /* [3 n_tris] outward normal of the solid's faces from the surface */
    pf_weld weld;
    int64_t splits;
} clipper;

static void cpiece_release(cpiece *c)
{
    pf_piece_release(&c->p);
    pf_free(c->origin);
    c->origin = NULL;
}

static pf_status cpiece_copy(const cpiece *c, cpiece *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    const piece *p = &c->p;
    int64_t n_idx = p->face_offsets ? p->face_offsets[p->n_faces] : 0;
    out->p = *p;
    out->p.x = pf_alloc_array(3 * (size_t)p->n_nodes + 1, sizeof(double));
    out->p.face_offsets = pf_alloc_array((size_t)p->n_faces + 1, sizeof(int64_t));
    out->p.face_nodes = pf_alloc_array((size_t)n_idx + 1, sizeof(uint32_t));
    out->origin = pf_alloc_array((size_t)p->n_faces + 1, sizeof(int32_t));
    if (!out->p.x || !out->p.face_offsets || !out->p.face_nodes || !out->origin) {
        cpiece_release(out);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    }
    memcpy(out->p.x, p->x, 3 * (size_t)p->n_nodes * sizeof(double));
    if (p->face_offsets)
        memcpy(out->p.face_offsets, p->face_offsets, ((size_t)p->n_faces + 1) * sizeof(int64_t));
    else
        out->p.face_offsets[0] = 0;
    memcpy(out->p.face_nodes, p->face_nodes, (size_t)n_idx * sizeof(uint32_t));
    memcpy(out->origin, c->origin, (size_t)p->n_faces * sizeof(int32_t));
    return PF_OK;
}

static bool has_surface(const cpiece *c)
{
    for (int32_t f = 0; f < c->p.n_faces; ++f)
        if (c->origin[f] >= 0)
            return true;
    return false;
}

/* The pieces of a split on one side, as one piece (several shells when there are several). */
static pf_status extract_side(clipper *cl, const pf_split *s, const int32_t *in_origin, int side,
                              cpiece *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    int32_t nf = 0;
    int64_t n_idx = 0;
    for (int32_t k = 0; k < s->n_pieces; ++k)
        if (s->piece_side[k] == side) {
            nf += (int32_t)(s->piece_faces[k + 1] - s->piece_faces[k]);
            n_idx += s->face_offsets[s->piece_faces[k + 1]] - s->face_offsets[s->piece_faces[k]];
        }
    piece *p = &out->p;
    p->face_offsets = pf_alloc_array((size_t)nf + 1, sizeof *p->face_offsets);
    p->face_nodes = pf_alloc_array((size_t)n_idx + 1, sizeof *p->face_nodes);
    p->x = pf_alloc_array(3 * (size_t)n_idx + 1, sizeof *p->x);
    out->origin = pf_alloc_array((size_t)nf + 1, sizeof *out->origin);
    if (!p->face_offsets || !p->face_nodes || !p->x || !out->origin) {
        cpiece_release(out);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    }
    p->face_offsets[0] = 0;
    for (int32_t k = 0; k < s->n_pieces; ++k) {
        if (s->piece_side[k] != side)
            continue;
        for (int64_t f = s->piece_faces[k]; f < s->piece_faces[k + 1]; ++f) {
            int64_t at = p->face_offsets[p->n_faces];
            for (int64_t q = s->face_offsets[f]; q < s->face_offsets[f + 1]; ++q) {
                uint32_t node = s->face_nodes[q];
                if (cl->remap[node] < 0) {
                    cl->remap[node] = p->n_nodes;
                    memcpy(p->x + 3 * (size_t)p->n_nodes, s->x + 3 * (size_t)node,
                           3 * sizeof(double));
                    p->n_nodes++;
                }
                p->face_nodes[at++] = (uint32_t)cl->remap[node];
            }
            out->origin[p->n_faces] = s->face_source[f] >= 0 ? in_origin[s->face_source[f]] : -1;
            p->face_offsets[++p->n_faces] = at;
        }
    }
    for (int64_t q = 0; q < s->face_offsets[s->n_faces]; ++q)
        cl->remap[s->face_nodes[q]] = -1;
    pf_update_bounds(p);
    return PF_OK;
}

/* The parts of c below and above pl (either output may be NULL: not wanted). */
static pf_status split_piece(clipper *cl, const cpiece *c, pf_plane pl, cpiece *below,
                             cpiece *above, pf_error *err)
{
    if (below)
        memset(below, 0, sizeof *below);
    if (above)
        memset(above, 0, sizeof *above);
    if (c->p.n_faces == 0)
        return PF_OK;
    double lo = INFINITY, hi = -INFINITY;
    for (int32_t i = 0; i < c->p.n_nodes; ++i) {
        const double *x = c->p.x + 3 * (size_t)i;
        double d = pf_plane_signed_distance(pl, pf_v3(x[0], x[1], x[2]));
        lo = d < lo ? d : lo;
        hi = d > hi ? d : hi;
    }
    if (hi <= cl->tol)
        return below ? cpiece_copy(c, below, err) : PF_OK;
    if (lo >= -cl->tol)
        return above ? cpiece_copy(c, above, err) : PF_OK;
    pf_polyhedron view = pf_piece_view(&c->p);
    pf_split s;
    PF_TRY(pf_poly_split(&view, c->p.n_nodes, &pl, &cl->sp, &s, err));
    cl->splits++;
    pf_status st = pf_remap_reserve(&cl->remap, &cl->cap_remap, s.n_nodes, err);
    if (st >= 0 && below)
        st = extract_side(cl, &s, c->origin, -1, below, err);
    if (st >= 0 && above)
        st = extract_side(cl, &s, c->origin, 1, above, err);
    pf_split_release(&s);
    return st;
}

/* ---- one element --------------------------------------------------------------------------------
 */

static pf_vec3 node_of(const double *x, uint32_t i)
{
    return pf_v3(x[3 * (size_t)i], x[3 * (size_t)i + 1], x[3 * (size_t)i + 2]);
}

/* The outward plane of the element's face used by entry (the mesh face's plane, negated when the
 * element uses it reversed: both neighbours have the same plane to the bit). */
static pf_plane face_plane(const pf_mesh *m, uint32_t entry)
{
    int32_t f = PF_FACE_INDEX(entry);
    const uint32_t *idx = m->face_nodes + m->face_offsets[f];
    int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
    pf_plane pl = pf_plane_from_point_normal(pf_polygon_centroid(m->x, idx, n),
                                             pf_polygon_area_vector(m->x, idx, n));
    if (entry & PF_FACE_REVERSED)
        pl.n = pf_v3_scale(pl.n, -1), pl.d = -pl.d;
    return pl;
}

/* Crossed elements must be convex, with no node inside a straight edge of a face. */
static pf_status check_convex(const clipper *cl, int32_t e, const pf_plane *planes, int32_t nk,
                              pf_error *err)
{
    const pf_mesh *m = cl->m;
    for (int32_t k = 0; k < nk; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[m->elem_offsets[e] + k]);
        int64_t a = m->face_offsets[f], n = m->face_offsets[f + 1] - a;
        for (int64_t q = 0; q < n; ++q) {
            uint32_t u = m->face_nodes[a + (q + n - 1) % n], v = m->face_nodes[a + q],
                     w = m->face_nodes[a + (q + 1) % n];
            pf_vec3 d = pf_v3_sub(node_of(m->x, w), node_of(m->x, u));
            pf_vec3 r = pf_v3_sub(node_of(m->x, v), node_of(m->x, u));
            PF_CHECK(pf_v3_norm(pf_v3_cross(r, d)) > cl->tol * pf_v3_norm(d), err,
                     PF_ERR_UNSUPPORTED,
                     "element %d: node %u lies inside a straight edge of face %d; clipping by a "
                     "surface supports convex elements without such nodes (tets, hexes, convex "
                     "polyhedra)",
                     (int)e, (unsigned)v, (int)f);
            for (int32_t j = 0; j < nk; ++j)
                PF_CHECK(pf_plane_signed_distance(planes[j], node_of(m->x, v)) <= cl->tol, err,
                         PF_ERR_UNSUPPORTED,
                         "element %d is not convex (node %u lies outside the plane of its face "
                         "%d); clipping by a surface supports convex elements (tets, hexes, "
                         "convex polyhedra)",
                         (int)e, (unsigned)v,
                         (int)PF_FACE_INDEX(m->elem_faces[m->elem_offsets[e] + j]));
        }
    }
    return PF_OK;
}

static int32_t find(int32_t *parent, int32_t i)
{
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

typedef struct edge_ref {
    uint32_t lo, hi;
    int32_t face;
} edge_ref;

static int compare_edge_ref(const void *pa, const void *pb)
{
    const edge_ref *a = pa, *b = pb;
    if (a->lo != b->lo)
        return a->lo < b->lo ? -1 : 1;
    if (a->hi != b->hi)
        return a->hi < b->hi ? -1 : 1;
    return (a->face > b->face) - (a->face < b->face);
}

/* comp[f]: the connected part (faces joined by edges) of every face of p, numbered from 0 in
 * order of first face; *n_comp their number. */
static pf_status components(const piece *p, int32_t *comp, int32_t *n_comp, pf_error *err)
{
    int64_t n_idx = p->face_offsets[p->n_faces];
    edge_ref *er = pf_alloc_array((size_t)n_idx + 1, sizeof *er);
    int32_t *parent = pf_alloc_array((size_t)p->n_faces + 1, sizeof *parent);
    if (!er || !parent) {
        pf_free(er), pf_free(parent);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    }
    int64_t n = 0;
    for (int32_t f = 0; f < p->n_faces; ++f) {
        parent[f] = f;
        int64_t a = p->face_offsets[f], len = p->face_offsets[f + 1] - a;
        for (int64_t q = 0; q < len; ++q) {
            uint32_t u = p->face_nodes[a + q], v = p->face_nodes[a + (q + 1) % len];
            er[n++] = (edge_ref){u < v ? u : v, u < v ? v : u, f};
        }
    }
    qsort(er, (size_t)n, sizeof *er, compare_edge_ref);
    for (int64_t i = 1; i < n; ++i)
        if (er[i].lo == er[i - 1].lo && er[i].hi == er[i - 1].hi) {
            int32_t a = find(parent, er[i].face), b = find(parent, er[i - 1].face);
            if (a != b)
                parent[a > b ? a : b] = a < b ? a : b;
        }
    *n_comp = 0;
    for (int32_t f = 0; f < p->n_faces; ++f) {
        int32_t r = find(parent, f);
        comp[f] = r == f ? (*n_comp)++ : comp[r];
    }
    pf_free(er), pf_free(parent);
    return PF_OK;
}

/* The faces of component c of p as a piece of its own, and their keys. */
static pf_status component_piece(clipper *cl, const piece *p, const int32_t *key,
                                 const int32_t *comp, int32_t c, piece *out, int32_t *out_key,
                                 pf_error *err)
{
    memset(out, 0, sizeof *out);
    int32_t nf = 0;
    int64_t n_idx = 0;
    for (int32_t f = 0; f < p->n_faces; ++f)
        if (comp[f] == c)
            ++nf, n_idx += p->face_offsets[f + 1] - p->face_offsets[f];
    out->face_offsets = pf_alloc_array((size_t)nf + 1, sizeof *out->face_offsets);
    out->face_nodes = pf_alloc_array((size_t)n_idx + 1, sizeof *out->face_nodes);
    out->x = pf_alloc_array(3 * (size_t)n_idx + 1, sizeof *out->x);
    if (!out->face_offsets || !out->face_nodes || !out->x) {
        pf_piece_release(out);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    }
    PF_TRY(pf_remap_reserve(&cl->remap, &cl->cap_remap, p->n_nodes, err));
    out->face_offsets[0] = 0;
    for (int32_t f = 0; f < p->n_faces; ++f) {
        if (comp[f] != c)
            continue;
        int64_t at = out->face_offsets[out->n_faces];
        for (int64_t q = p->face_offsets[f]; q < p->face_offsets[f + 1]; ++q) {
            uint32_t node = p->face_nodes[q];
            if (cl->remap[node] < 0) {
                cl->remap[node] = out->n_nodes;
                memcpy(out->x + 3 * (size_t)out->n_nodes, p->x + 3 * (size_t)node,
                       3 * sizeof(double));
                out->n_nodes++;
            }
            out->face_nodes[at++] = (uint32_t)cl->remap[node];
        }
        out_key[out->n_faces] = key[f];
        out->face_offsets[++out->n_faces] = at;
    }
    for (int64_t q = 0; q < p->face_offsets[p->n_faces]; ++q)
        cl->remap[p->face_nodes[q]] = -1;
    return PF_OK;
}

static double part_volume(const pf_weld *w, const pf_part_faces *f)
{
    pf_polyhedron v = {w->x, f->n_faces, f->offsets, f->nodes};
    return pf_polyhedron_volume(&v);
}

/* The element's part(s) of the clipped piece p: keys of its faces, connected parts, faces
 * rebuilt. */
static pf_status element_parts(clipper *cl, int32_t e, const piece *p, const int32_t *key,
                               const int32_t *face_ref, const uint8_t *face_rev, pf_error *err)
{
    int32_t *comp = pf_alloc_array((size_t)p->n_faces + 1, sizeof *comp);
    int32_t *sub_key = pf_alloc_array((size_t)p->n_faces + 1, sizeof *sub_key);
    int32_t nc = 0;
    pf_status st = comp && sub_key ? components(p, comp, &nc, err)
                                   : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                                  "out of memory clipping");
    pf_clip_elem_parts *ep = &cl->parts[e];
    if (st >= 0 && !(ep->part = pf_calloc((size_t)nc + 1, sizeof *ep->part)))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    for (int32_t c = 0; st >= 0 && c < nc; ++c) {
        piece sub;
        st = component_piece(cl, p, key, comp, c, &sub, sub_key, err);
        pf_part_faces *pf = &ep->part[ep->n];
        if (st >= 0)
            st = pf_clip_rebuild_part(&cl->weld, &sub, sub_key, cl->m, face_ref, face_rev,
                                      cl->tri_normal, pf, err);
        pf_piece_release(&sub);
        if (st < 0)
            break;
        double v = part_volume(&cl->weld, pf);
        if (pf->n_faces == 0 || v == 0) {
            pf_part_faces_release(pf);
            continue;
        }
        if (v < 0) {
            pf_part_faces_release(pf);
            st = pf_error_set(err, PF_ERR_UNSUPPORTED, __FILE__, __LINE__,
                              "element %d would hold a whole shell of the surface inside it (a "
                              "cavity, volume %g): use a finer mesh",
                              (int)e, -v);
            break;
        }
        ep->n++;
    }
    pf_free(comp), pf_free(sub_key);
    return st;
}

/* Clips element e out of the piece c of its kd node. */
static pf_status clip_element(clipper *cl, const cpiece *c, int32_t e, pf_error *err)
{
    const pf_mesh *m = cl->m;
    int64_t e0 = m->elem_offsets[e];
    int32_t nk = (int32_t)(m->elem_offsets[e + 1] - e0);
    pf_plane *planes = pf_alloc_array((size_t)nk + 6, sizeof *planes);
    int32_t *face_ref = pf_alloc_array((size_t)nk, sizeof *face_ref);
    uint8_t *face_rev = pf_alloc_array((size_t)nk, sizeof *face_rev);
    if (!planes || !face_ref || !face_rev) {
        pf_free(planes), pf_free(face_ref), pf_free(face_rev);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    }
    const double *box = cl->box + 6 * (size_t)e;
    for (int a = 0; a < 3; ++a) {
        pf_vec3 n = pf_v3(a == 0, a == 1, a == 2);
        planes[2 * a] = (pf_plane){pf_v3_scale(n, -1), -box[a]};
        planes[2 * a + 1] = (pf_plane){n, box[3 + a]};
    }
    for (int32_t k = 0; k < nk; ++k) {
        planes[6 + k] = face_plane(m, m->elem_faces[e0 + k]);
        face_ref[k] = PF_FACE_INDEX(m->elem_faces[e0 + k]);
        face_rev[k] = (m->elem_faces[e0 + k] & PF_FACE_REVERSED) != 0;
    }
    cpiece cur;
    pf_status st = cpiece_copy(c, &cur, err);
    for (int32_t k = 0; st >= 0 && k < nk + 6 && cur.p.n_faces > 0; ++k) {
        cpiece next;
        st = split_piece(cl, &cur, planes[k], &next, NULL, err);
        cpiece_release(&cur);
        cur = next;
    }
    int32_t *key = NULL;
    if (st >= 0 && cur.p.n_faces > 0 && !(key = pf_alloc_array((size_t)cur.p.n_faces, sizeof *key)))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    bool surface = false;
    double on = 1.01 * cl->tol;
    for (int32_t f = 0; st >= 0 && f < cur.p.n_faces; ++f) {
        int32_t on_face = -1;
        for (int32_t k = 0; k < nk && on_face < 0; ++k) {
            bool all = true;
            for (int64_t q = cur.p.face_offsets[f]; all && q < cur.p.face_offsets[f + 1]; ++q)
                all = fabs(pf_plane_signed_distance(planes[6 + k],
                                                    node_of(cur.p.x, cur.p.face_nodes[q]))) <= on;
            on_face = all ? k : -1;
        }
        key[f] = on_face >= 0 ? -on_face - 1 : cur.origin[f];
        if (on_face < 0 && cur.origin[f] < 0)
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "element %d: a face of its part lies neither on the surface nor on "
                              "a face of the element (geometry too degenerate at tolerance %g)",
                              (int)e, cl->tol);
        surface |= on_face < 0;
    }
    if (st >= 0 && cur.p.n_faces > 0)
        cl->state[e] = surface ? CLIPPED : WHOLE;
    if (st >= 0 && surface)
        st = check_convex(cl, e, planes + 6, nk, err);
    if (st >= 0 && surface)
        st = element_parts(cl, e, &cur.p, key, face_ref, face_rev, err);
    cpiece_release(&cur);
    pf_free(key), pf_free(planes), pf_free(face_ref), pf_free(face_rev);
    return st;
}

/* ---- the kd tree over the elements' boxes ------------------------------------------------------
 */

typedef struct axis_key {
    double c;
    int32_t e;
} axis_key;

static int compare_axis_key(const void *pa, const void *pb)
{
    const axis_key *a = pa, *b = pb;
    if (a->c != b->c)
        return a->c < b->c ? -1 : 1;
    return (a->e > b->e) - (a->e < b->e);
}

/* Elements wholly below the plane x[a] = cut, wholly above, and the others. */
static void classify_elements(const clipper *cl, const int32_t *el, int32_t n, int a, double cut,
                              int32_t *low, int32_t *n_low, int32_t *high, int32_t *n_high,
                              int32_t *across, int32_t *n_across)
{
    *n_low = *n_high = *n_across = 0;
    for (int32_t i = 0; i < n; ++i) {
        const double *b = cl->box + 6 * (size_t)el[i];
        if (b[3 + a] <= cut + cl->tol)
            low[(*n_low)++] = el[i];
        else if (b[a] >= cut - cl->tol)
            high[(*n_high)++] = el[i];
        else
            across[(*n_across)++] = el[i];
    }
}

/* The elements el[n] lie in the region of this node, whose part of the solid is c. */
static pf_status kd_node(clipper *cl, const cpiece *c, const int32_t *el, int32_t n, int depth,
                         pf_error *err)
{
    if (c->p.n_faces == 0)
        return PF_OK;      /* nothing of the solid here: all dropped */
    if (!has_surface(c)) { /* bounded by split planes only: the whole region is solid */
        for (int32_t i = 0; i < n; ++i)
            cl->state[el[i]] = WHOLE;
        return PF_OK;
    }
    pf_status st = PF_OK;
    int32_t *low = NULL, *high = NULL, *across = NULL, n_low = 0, n_high = 0, n_across = n;
    axis_key *k = NULL;
    int a = 0;
    double cut = 0;
    if (n > 2 && depth < 48) {
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int32_t i = 0; i < n; ++i)
            for (int q = 0; q < 3; ++q) {
                const double *b = cl->box + 6 * (size_t)el[i];
                lo[q] = fmin(lo[q], b[q]);
                hi[q] = fmax(hi[q], b[3 + q]);
            }
        for (int q = 1; q < 3; ++q)
            if (hi[q] - lo[q] > hi[a] - lo[a])
                a = q;
        k = pf_alloc_array((size_t)n, sizeof *k);
        low = pf_alloc_array((size_t)n, sizeof *low);
        high = pf_alloc_array((size_t)n, sizeof *high);
        across = pf_alloc_array((size_t)n, sizeof *across);
        if (!k || !low || !high || !across) {
            pf_free(k), pf_free(low), pf_free(high), pf_free(across);
            return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
        }
        for (int32_t i = 0; i < n; ++i) {
            const double *b = cl->box + 6 * (size_t)el[i];
            k[i] = (axis_key){0.5 * (b[a] + b[3 + a]), el[i]};
        }
        qsort(k, (size_t)n, sizeof *k, compare_axis_key);
        /* the top of the median element's box, else the bottom of the next: on a grid a plane
         * between cells, which no element crosses */
        cut = cl->box[6 * (size_t)k[n / 2 - 1].e + 3 + a];
        classify_elements(cl, el, n, a, cut, low, &n_low, high, &n_high, across, &n_across);
        if (n_low == 0 || n_high == 0) {
            cut = cl->box[6 * (size_t)k[n / 2].e + a];
            classify_elements(cl, el, n, a, cut, low, &n_low, high, &n_high, across, &n_across);
        }
    }
    if (n_low == 0 || n_high == 0) { /* a leaf */
        for (int32_t i = 0; st >= 0 && i < n; ++i)
            st = clip_element(cl, c, el[i], err);
    } else {
        for (int32_t i = 0; st >= 0 && i < n_across; ++i)
            st = clip_element(cl, c, across[i], err);
        cpiece below, above;
        pf_plane pl = {pf_v3(a == 0, a == 1, a == 2), cut};
        if (st >= 0)
            st = split_piece(cl, c, pl, &below, &above, err);
        if (st >= 0) {
            st = kd_node(cl, &below, low, n_low, depth + 1, err);
            cpiece_release(&below);
            if (st >= 0)
                st = kd_node(cl, &above, high, n_high, depth + 1, err);
            cpiece_release(&above);
        }
    }
    pf_free(k), pf_free(low), pf_free(high), pf_free(across);
    return st;
}

/* ---- entry point -------------------------------------------------------------------------------
 */

/* The solid as one closed polyhedron: the surface's triangles (inside), or a box around
 * everything with the surface reversed in it (outside). */
static pf_status make_solid(clipper *cl, const pf_surface *s, pf_clip_keep keep, pf_vec3 lo,
                            pf_vec3 hi, cpiece *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    bool outside = keep == PF_CLIP_OUTSIDE;
    int32_t nv = s->n_verts + (outside ? 8 : 0), nt = s->n_tris + (outside ? 12 : 0);
    piece *p = &out->p;
    p->x = pf_alloc_array(3 * (size_t)nv, sizeof *p->x);
    p->face_offsets = pf_alloc_array((size_t)nt + 1, sizeof *p->face_offsets);
    p->face_nodes = pf_alloc_array(3 * (size_t)nt, sizeof *p->face_nodes);
    out->origin = pf_alloc_array((size_t)nt, sizeof *out->origin);
    cl->tri_normal = pf_alloc_array(3 * (size_t)s->n_tris + 1, sizeof *cl->tri_normal);
    if (!p->x || !p->face_offsets || !p->face_nodes || !out->origin || !cl->tri_normal) {
        cpiece_release(out);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory clipping");
    }
    memcpy(p->x, s->x, 3 * (size_t)s->n_verts * sizeof *p->x);
    p->n_nodes = nv;
    p->n_faces = nt;
    for (int32_t t = 0; t < s->n_tris; ++t) {
        const uint32_t *v = s->tri + 3 * (size_t)t;
        uint32_t *f = p->face_nodes + 3 * (size_t)t;
        f[0] = v[0], f[1] = outside ? v[2] : v[1], f[2] = outside ? v[1] : v[2];
        out->origin[t] = t;
        pf_vec3 a = node_of(s->x, f[0]), b = node_of(s->x, f[1]), c = node_of(s->x, f[2]);
        pf_vec3 n = pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(c, a));
        memcpy(cl->tri_normal + 3 * (size_t)t, &(double[3]){n.x, n.y, n.z}, 3 * sizeof(double));
    }
    if (outside) {
        for (int i = 0; i < 8; ++i) {
            double *x = p->x + 3 * ((size_t)s->n_verts + (size_t)i);
            x[0] = i & 1 ? hi.x : lo.x, x[1] = i & 2 ? hi.y : lo.y, x[2] = i & 4 ? hi.z : lo.z;
        }
        /* the box's faces, outward: -x, +x, -y, +y, -z, +z as two triangles each */
        static const uint8_t quad[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                           {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
        for (int q = 0; q < 6; ++q)
            for (int h = 0; h < 2; ++h) {
                int32_t t = s->n_tris + 2 * q + h;
                uint32_t *f = p->face_nodes + 3 * (size_t)t;
                uint32_t base = (uint32_t)s->n_verts;
                f[0] = base + quad[q][0];
                f[1] = base + quad[q][1 + h];
                f[2] = base + quad[q][2 + h];
                out->origin[t] = -1;
            }
    }
    for (int32_t t = 0; t <= nt; ++t)
        p->face_offsets[t] = 3 * (int64_t)t;
    pf_update_bounds(p);
    return PF_OK;
}

static void clipper_release(clipper *cl)
{
    if (cl->parts)
        for (int32_t e = 0; e < cl->m->n_elems; ++e) {
            for (int32_t q = 0; q < cl->parts[e].n; ++q)
                pf_part_faces_release(&cl->parts[e].part[q]);
            pf_free(cl->parts[e].part);
        }
    pf_free(cl->parts);
    pf_free(cl->remap);
    pf_free(cl->box);
    pf_free(cl->state);
    pf_free(cl->tri_normal);
    pf_weld_release(&cl->weld);
}

/* Sets up cl for src: element boxes, the src nodes welded first (two at one place refused). */
static pf_status clipper_init(clipper *cl, const pf_mesh *src, double tol, pf_error *err)
{
    int32_t ne = src->n_elems;
    cl->m = src;
    cl->tol = tol;
    cl->sp.tol = tol;
    cl->sp.assume_closed = true; /* the surface is checked; pieces of splits are closed */
    cl->weld.tol = tol;
    cl->box = pf_alloc_array(6 * (size_t)ne + 1, sizeof *cl->box);
    cl->state = pf_calloc((size_t)ne + 1, sizeof *cl->state);
    cl->parts = pf_calloc((size_t)ne + 1, sizeof *cl->parts);
    PF_CHECK(cl->box && cl->state && cl->parts, err, PF_ERR_NOMEM, "out of memory clipping");
    for (int32_t e = 0; e < ne; ++e) {
        double *b = cl->box + 6 * (size_t)e;
        b[0] = b[1] = b[2] = INFINITY;
        b[3] = b[4] = b[5] = -INFINITY;
        for (int64_t k = src->elem_offsets[e]; k < src->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(src->elem_faces[k]);
            for (int64_t q = src->face_offsets[f]; q < src->face_offsets[f + 1]; ++q)
                for (int c = 0; c < 3; ++c) {
                    double v = src->x[3 * (size_t)src->face_nodes[q] + c];
                    b[c] = fmin(b[c], v);
                    b[3 + c] = fmax(b[3 + c], v);
                }
        }
    }
    for (int32_t i = 0; i < src->n_nodes; ++i) {
        int32_t id;
        PF_TRY(pf_weld_point(&cl->weld, src->x + 3 * (size_t)i, &id, err));
        PF_CHECK(id == i, err, PF_ERR_UNSUPPORTED,
                 "nodes %d and %d of the mesh lie at one place (within %g): a mesh that was "
                 "already cut cannot be clipped; clip first, then cut",
                 (int)id, (int)i, tol);
    }
    cl->weld.n_fixed = src->n_nodes;
    return PF_OK;
}

static pf_status check_surface(const pf_surface *s, pf_vec3 *lo, pf_vec3 *hi, pf_error *err)
{
    pf_surface_stats ss;
    PF_TRY(pf_surface_compute_stats(s, &ss, err));
    PF_CHECK(ss.n_tris > 0 && ss.closed && ss.manifold && ss.volume > 0, err, PF_ERR_INVALID,
             "clipping needs a closed, manifold, outward-oriented surface (%lld open edges, %lld "
             "non-manifold, %lld flipped, volume %g)",
             (long long)ss.n_boundary_edges, (long long)ss.n_nonmanifold_edges,
             (long long)ss.n_flipped_edges, ss.volume);
    *lo = ss.lo, *hi = ss.hi;
    return PF_OK;
}

pf_status pf_mesh_clip_surface(const pf_mesh *src, const pf_surface *s,
                               const pf_clip_params *params, pf_mesh *dst, pf_clip_stats *stats,
                               pf_error *err)
{
    memset(dst, 0, sizeof *dst);
    pf_clip_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    double t0 = pf_time_seconds();
    pf_clip_params p = params ? *params : (pf_clip_params){0};
    if (!(p.min_fraction > 0))
        p.min_fraction = PF_REFINE_MIN_FRACTION;
    PF_CHECK(p.keep == PF_CLIP_INSIDE || p.keep == PF_CLIP_OUTSIDE, err, PF_ERR_INVALID,
             "keep must be inside or outside, got %d", (int)p.keep);
    PF_CHECK(p.min_fraction < 1, err, PF_ERR_INVALID, "min_fraction must be below 1, got %g",
             p.min_fraction);
    PF_CHECK(src->face_elems, err, PF_ERR_INVALID, "clipping needs a derived mesh");
    pf_vec3 slo = {0}, shi = {0}, mlo, mhi;
    PF_TRY(check_surface(s, &slo, &shi, err));
    pf_mesh_bounds(src, &mlo, &mhi);
    pf_vec3 lo = pf_v3(fmin(slo.x, mlo.x), fmin(slo.y, mlo.y), fmin(slo.z, mlo.z));
    pf_vec3 hi = pf_v3(fmax(shi.x, mhi.x), fmax(shi.y, mhi.y), fmax(shi.z, mhi.z));
    double diag = pf_v3_norm(pf_v3_sub(hi, lo));
    /* the outer box of the outside's solid: beyond everything by a tenth of the diagonal */
    pf_vec3 pad = pf_v3(0.1 * diag, 0.1 * diag, 0.1 * diag);
    clipper cl = {0};
    cpiece solid = {0};
    int32_t *all = pf_alloc_array((size_t)src->n_elems + 1, sizeof *all);
    pf_status st = all ? clipper_init(&cl, src, 1e-10 * diag, err)
                       : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    if (st >= 0)
        st = make_solid(&cl, s, p.keep, pf_v3_sub(lo, pad), pf_v3_add(hi, pad), &solid, err);
    for (int32_t e = 0; st >= 0 && e < src->n_elems; ++e)
        all[e] = e;
    if (st >= 0)
        st = kd_node(&cl, &solid, all, src->n_elems, 0, err);
    cpiece_release(&solid);
    pf_free(all);
    if (st >= 0)
        st = pf_clip_assemble(src, cl.state, cl.parts, &cl.weld, p.min_fraction, dst,
                              &stats->n_merged, &stats->n_isolated, err);
    for (int32_t e = 0; e < src->n_elems && st >= 0; ++e) {
        stats->n_kept += cl.state[e] == WHOLE;
        stats->n_dropped += cl.state[e] == OUTSIDE;
        stats->n_clipped += cl.state[e] == CLIPPED;
        stats->n_parts += cl.state[e] == CLIPPED ? cl.parts[e].n : 0;
    }
    stats->n_splits = cl.splits;
    clipper_release(&cl);
    if (st >= 0)
        st = pf_mesh_validate(dst, NULL, err);
    if (st < 0) {
        pf_mesh_release(dst);
        return st;
    }
    dst->id = src->id + 1;
    stats->volume += pf_mesh_volume(dst);
    stats->seconds = pf_time_seconds() - t0;
    return PF_OK;
}
