/* The visibility rule of the MLS embedding after a cut (the visibility criterion of meshless
 * methods for cracks, Belytschko et al. 1996): a node is not in a vertex's support when the
 * segment from the vertex to the node crosses a blocking face. A crossing is strict: both end
 * points lie farther than the face's tolerance (1e-10 of its diameter) from its plane, on
 * opposite sides, and the segment meets the plane inside the face's polygon or within the
 * tolerance of its edges (so a segment through the edge shared by two blocking faces is blocked).
 *
 * A vertex on the cut is seen from nudged 1e-6 of the nearest face's diameter into its side
 * (pf_embed_params.vertex_side); a segment from it that leaves the cut through the cut's outer
 * edge meets the plane just outside the face, so an end point within 1e-5 of the diameter of the
 * plane is tested itself too.
 *
 * The two copies of a node on a cut sit at the same point, a corner of blocking faces, where
 * every segment only touches the faces. Such a node belongs to the side its faces' elements are
 * on: it is hidden from every point farther than the tolerance behind it, against the sum of the
 * inward normals of the blocking faces it is a corner of (so also from a vertex whose segment
 * runs along the cut's outer edge, just outside the faces). At the crack front a node is a
 * corner of both copies of a face, the normals cancel and the node, shared by both sides, is
 * seen from both.
 *
 * Line of sight alone does not keep a vertex to its piece: a segment from a vertex near the rim
 * of a cut may leave the material and reach a node of the piece across the cut through the air
 * around the cut's outer edge, without crossing a cut face. So a vertex also sees only the nodes
 * of its own body, the connected group of elements (through shared faces) holding it. */
#include "embed_internal.h"

#include <string.h>

#define VIS_TOL   1e-10 /* crossing tolerance, fraction of a face's diameter */
#define VIS_NUDGE 1e-6  /* nudge of a vertex, fraction of a face's diameter */
#define VIS_NEAR                                                                                   \
    1e5 /* an end point within VIS_NEAR tolerances (1e-5 of the diameter) of a                     \
           face's plane is on the cut */

void pf_visibility_release(visibility *v)
{
    pf_free(v->face);
    pf_free(v->plane);
    pf_free(v->tol);
    pf_free(v->axes);
    pf_free(v->uv_offsets);
    pf_free(v->uv);
    pf_free(v->box);
    pf_free(v->node_dir);
    pf_free(v->node_tol);
    pf_free(v->stamp);
    pf_free(v->cand);
    pf_free(v->elem_body);
    pf_free(v->node_body);
    pf_bucket_grid_release(&v->grid);
    memset(v, 0, sizeof *v);
}

/* The element side of each blocking face: +1 when its element uses it as stored (the stored
 * normal points out of the element), -1 when reversed. */
static void face_orientation(const pf_mesh *m, const uint8_t *blocking, int8_t *orient)
{
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            if (blocking[f] && orient[f] == 0)
                orient[f] = (m->elem_faces[k] & PF_FACE_REVERSED) ? -1 : 1;
        }
}

static void axes_of(pf_vec3 n, uint8_t ax[2])
{
    double an[3] = {fabs(n.x), fabs(n.y), fabs(n.z)};
    int k = an[0] >= an[1] && an[0] >= an[2] ? 0 : an[1] >= an[2] ? 1 : 2;
    ax[0] = (uint8_t)((k + 1) % 3);
    ax[1] = (uint8_t)((k + 2) % 3);
}

/* The connected groups of elements through shared faces (union-find over the faces' first
 * users), numbered in order of their first element, and each node's group. */
static pf_status label_bodies(visibility *v, const pf_mesh *m, pf_error *err)
{
    int32_t *first = NULL, *parent = NULL;
    if (!PF_ALLOC_N(v->elem_body, (size_t)m->n_elems + 1) ||
        !PF_ALLOC_N(v->node_body, (size_t)m->n_nodes + 1) ||
        !PF_ALLOC_N(first, (size_t)m->n_faces + 1) || !PF_ALLOC_N(parent, (size_t)m->n_elems + 1)) {
        pf_free(first);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for the bodies of %d elements", (int)m->n_elems);
    }
    for (int32_t f = 0; f < m->n_faces; ++f)
        first[f] = -1;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        parent[e] = e;
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            if (first[f] < 0) {
                first[f] = e;
                continue;
            }
            int32_t a = first[f], b = e;
            while (parent[a] != a)
                a = parent[a] = parent[parent[a]];
            while (parent[b] != b)
                b = parent[b] = parent[parent[b]];
            parent[a > b ? a : b] = a < b ? a : b;
        }
    }
    int32_t n = 0;
    for (int32_t e = 0; e < m->n_elems; ++e) { /* roots are the lowest element of their group */
        int32_t r = e;
        while (parent[r] != r)
            r = parent[r];
        v->elem_body[e] = r == e ? n++ : v->elem_body[r];
    }
    for (int32_t i = 0; i < m->n_nodes; ++i)
        v->node_body[i] = -1;
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
                int32_t *b = &v->node_body[m->face_nodes[j]];
                *b = *b == -1 || *b == v->elem_body[e] ? v->elem_body[e] : -2;
            }
        }
    pf_free(first);
    pf_free(parent);
    return PF_OK;
}

pf_status pf_visibility_build(visibility *v, const pf_mesh *m, const uint8_t *blocking,
                              pf_error *err)
{
    memset(v, 0, sizeof *v);
    int32_t nb = 0;
    int64_t n_uv = 0;
    for (int32_t f = 0; f < m->n_faces; ++f)
        if (blocking[f]) {
            nb++;
            n_uv += m->face_offsets[f + 1] - m->face_offsets[f];
        }
    v->n_faces = nb;
    v->n_nodes = m->n_nodes;
    int8_t *orient = NULL;
    int ok = PF_ALLOC_N(orient, (size_t)m->n_faces) &&
             PF_ALLOC_N(v->node_dir, 3 * (size_t)m->n_nodes) &&
             PF_ALLOC_N(v->node_tol, (size_t)m->n_nodes);
    if (ok && nb > 0)
        ok = PF_ALLOC_N(v->face, (size_t)nb) && PF_ALLOC_N(v->plane, (size_t)nb) &&
             PF_ALLOC_N(v->tol, (size_t)nb) && PF_ALLOC_N(v->axes, 2 * (size_t)nb) &&
             PF_ALLOC_N(v->uv_offsets, (size_t)nb + 1) && PF_ALLOC_N(v->uv, 2 * (size_t)n_uv) &&
             PF_ALLOC_N(v->box, 6 * (size_t)nb) && PF_ALLOC_N(v->stamp, (size_t)nb) &&
             PF_ALLOC_N(v->cand, (size_t)nb);
    if (!ok) {
        pf_free(orient);
        pf_visibility_release(v);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for %d blocking faces", (int)nb);
    }
    pf_status sb = label_bodies(v, m, err);
    if (sb < 0) {
        pf_free(orient);
        pf_visibility_release(v);
        return sb;
    }
    memset(orient, 0, (size_t)m->n_faces);
    face_orientation(m, blocking, orient);
    double *dir = v->node_dir; /* first the sum of inward normals, then its direction */
    memset(dir, 0, 3 * (size_t)m->n_nodes * sizeof *dir);
    for (int32_t i = 0; i < m->n_nodes; ++i)
        v->node_tol[i] = INFINITY;
    int32_t b = 0;
    if (nb > 0)
        v->uv_offsets[0] = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        if (!blocking[f])
            continue;
        int64_t o = m->face_offsets[f], n = m->face_offsets[f + 1] - o;
        const uint32_t *fn = m->face_nodes + o;
        pf_vec3 area = pf_polygon_area_vector(m->x, fn, n);
        pf_vec3 c = pf_polygon_centroid(m->x, fn, n);
        double diam = pf_polygon_diameter(m->x, fn, n);
        pf_plane pl = pf_plane_from_point_normal(c, area);
        v->face[b] = f;
        v->plane[b] = pl;
        v->tol[b] = VIS_TOL * diam;
        axes_of(pl.n, v->axes + 2 * b);
        int64_t u0 = v->uv_offsets[b];
        pf_vec3 lo = pf_v3_load(m->x + 3 * (size_t)fn[0]), hi = lo;
        for (int64_t k = 0; k < n; ++k) {
            pf_vec3 p = pf_v3_load(m->x + 3 * (size_t)fn[k]);
            lo = pf_v3_min(lo, p);
            hi = pf_v3_max(hi, p);
            v->uv[2 * (u0 + k)] = pf_v3_get(p, v->axes[2 * b]);
            v->uv[2 * (u0 + k) + 1] = pf_v3_get(p, v->axes[2 * b + 1]);
            /* inward: against the normal pointing out of the face's element */
            pf_vec3 in = pf_v3_scale(pl.n, orient[f] < 0 ? 1.0 : -1.0);
            for (int a = 0; a < 3; ++a)
                dir[3 * (size_t)fn[k] + a] += pf_v3_get(in, a);
            v->node_tol[fn[k]] = fmin(v->node_tol[fn[k]], VIS_TOL * diam);
        }
        v->uv_offsets[b + 1] = u0 + n;
        pf_vec3 pad = pf_v3(v->tol[b], v->tol[b], v->tol[b]);
        pf_v3_store(pf_v3_sub(lo, pad), v->box + 6 * (size_t)b);
        pf_v3_store(pf_v3_add(hi, pad), v->box + 6 * (size_t)b + 3);
        v->min_diam = b == 0 ? diam : fmin(v->min_diam, diam);
        b++;
    }
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        pf_vec3 d = pf_v3_load(dir + 3 * (size_t)i);
        double len = pf_v3_norm(d);
        /* a corner of faces of one side; < 0.5: cancelled at the crack front */
        pf_v3_store(len > 0.5 ? pf_v3_scale(d, 1.0 / len) : pf_v3(0, 0, 0), dir + 3 * (size_t)i);
    }
    pf_free(orient);
    if (nb == 0)
        return PF_OK;
    memset(v->stamp, 0, (size_t)nb * sizeof *v->stamp);
    double mean = 0;
    for (int32_t k = 0; k < nb; ++k)
        mean += v->box[6 * (size_t)k + 3] - v->box[6 * (size_t)k] + v->box[6 * (size_t)k + 4] -
                v->box[6 * (size_t)k + 1] + v->box[6 * (size_t)k + 5] - v->box[6 * (size_t)k + 2];
    pf_status st = pf_bucket_grid_build(&v->grid, v->box, nb, mean / (3.0 * nb), err);
    if (st < 0)
        pf_visibility_release(v);
    return st;
}

static bool box_overlap(const double *a, const double *b)
{
    for (int k = 0; k < 3; ++k)
        if (a[k] > b[3 + k] || b[k] > a[3 + k])
            return false;
    return true;
}

typedef struct face_query {
    visibility *v;
    double box[6];
} face_query;

/* A face of the grid's cells, a candidate once when its box overlaps the query's. */
static int take_face(void *ctx, int32_t b)
{
    face_query *q = ctx;
    visibility *v = q->v;
    if (v->stamp[b] != v->now) {
        v->stamp[b] = v->now;
        if (box_overlap(v->box + 6 * (size_t)b, q->box))
            v->cand[v->n_cand++] = b;
    }
    return 0;
}

int32_t pf_visibility_gather(visibility *v, pf_vec3 x, double reach)
{
    v->n_cand = 0;
    if (v->n_faces == 0)
        return 0;
    if (++v->now == 0) {
        memset(v->stamp, 0, (size_t)v->n_faces * sizeof *v->stamp);
        v->now = 1;
    }
    face_query q = {v, {x.x - reach, x.y - reach, x.z - reach, x.x + reach, x.y + reach,
                        x.z + reach}};
    pf_bucket_grid_visit(&v->grid, x, reach, take_face, &q);
    /* candidates in face order, whatever the grid's cell order */
    for (int32_t a = 1; a < v->n_cand; ++a)
        for (int32_t c = a; c > 0 && v->cand[c - 1] > v->cand[c]; --c) {
            int32_t t = v->cand[c];
            v->cand[c] = v->cand[c - 1];
            v->cand[c - 1] = t;
        }
    return v->n_cand;
}

/* Squared distance from (px, py) to the 2D segment a-b. */
static double seg_dist2(double px, double py, const double *a, const double *b)
{
    double ex = b[0] - a[0], ey = b[1] - a[1], wx = px - a[0], wy = py - a[1];
    double ee = ex * ex + ey * ey, t = ee > 0 ? (wx * ex + wy * ey) / ee : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double dx = wx - t * ex, dy = wy - t * ey;
    return dx * dx + dy * dy;
}

bool pf_polygon2_contains(const double *uv, int64_t n, double px, double py, double tol)
{
    bool inside = false;
    for (int64_t k = 0, j = n - 1; k < n; j = k++) {
        const double *a = uv + 2 * j, *b = uv + 2 * k;
        if ((a[1] > py) != (b[1] > py) && px < a[0] + (py - a[1]) * (b[0] - a[0]) / (b[1] - a[1]))
            inside = !inside;
    }
    if (inside)
        return true;
    for (int64_t k = 0, j = n - 1; k < n; j = k++)
        if (seg_dist2(px, py, uv + 2 * j, uv + 2 * k) <= tol * tol)
            return true;
    return false;
}

bool pf_visibility_blocked(const visibility *v, pf_vec3 a, int32_t node, pf_vec3 b)
{
    pf_vec3 dir = pf_v3_load(v->node_dir + 3 * (size_t)node);
    if ((dir.x != 0 || dir.y != 0 || dir.z != 0) &&
        pf_v3_dot(pf_v3_sub(a, b), dir) < -v->node_tol[node])
        return true;
    double sb[6];
    pf_v3_store(pf_v3_min(a, b), sb);
    pf_v3_store(pf_v3_max(a, b), sb + 3);
    for (int32_t c = 0; c < v->n_cand; ++c) {
        int32_t f = v->cand[c];
        if (!box_overlap(v->box + 6 * (size_t)f, sb))
            continue;
        double da = pf_plane_signed_distance(v->plane[f], a);
        double db = pf_plane_signed_distance(v->plane[f], b);
        double tol = v->tol[f];
        if (!((da > tol && db < -tol) || (da < -tol && db > tol)))
            continue;
        pf_vec3 x = pf_v3_add(a, pf_v3_scale(pf_v3_sub(b, a), da / (da - db)));
        int64_t o = v->uv_offsets[f], n = v->uv_offsets[f + 1] - o;
        const uint8_t *ax = v->axes + 2 * f;
        if (pf_polygon2_contains(v->uv + 2 * o, n, pf_v3_get(x, ax[0]), pf_v3_get(x, ax[1]), tol))
            return true;
        /* an end point on the cut (a vertex nudged off it): where the segment leaves the cut
         * through its outer edge, the crossing point lies just outside the face; the end point
         * itself decides */
        pf_vec3 near = fabs(da) < fabs(db) ? a : b;
        if (fmin(fabs(da), fabs(db)) <= VIS_NEAR * tol &&
            pf_polygon2_contains(v->uv + 2 * o, n, pf_v3_get(near, ax[0]), pf_v3_get(near, ax[1]),
                                 tol))
            return true;
    }
    return false;
}

pf_vec3 pf_visibility_nudge(const visibility *v, pf_vec3 x, pf_vec3 dir)
{
    double len = pf_v3_norm(dir);
    if (!(len > 0) || v->n_cand == 0)
        return x;
    double d = INFINITY;
    for (int32_t c = 0; c < v->n_cand; ++c) {
        int32_t f = v->cand[c];
        d = fmin(d, v->tol[f] / VIS_TOL);
    }
    return pf_v3_add(x, pf_v3_scale(dir, VIS_NUDGE * d / len));
}
