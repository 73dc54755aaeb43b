/* Barycentric embedding: each vertex weighted by the shape functions of its element (linear on
 * tets, trilinear on hexes, mean value coordinates or the CG method's harmonic functions on other
 * polyhedra). */
#include "embed_internal.h"

#include <pf/basis.h>

#include <string.h>

/* ---- 3D mean value coordinates ---------------------------------------------------------------
 * Floater, Kos, Reimers 2005 and Ju, Schaefer, Warren 2005: w_k is the integral over the unit
 * sphere around p of the piecewise-linear hat of node k projected onto it, divided by |x_k - p|.
 * Per triangle, with u_i the unit vectors from p to its corners, the integral of the outward unit
 * normal over its spherical triangle is the mean vector
 *     m = 1/2 sum_i beta_i n_i,   beta_i the arc u_{i+1} u_{i+2}, n_i = unit(u_{i+1} x u_{i+2}),
 * and the hats' integrals lambda solve [u_0 u_1 u_2] lambda = m; w_i += lambda_i / d_i. This
 * vector form loses digits only as 1e-16 / (distance to the triangle's plane), where the
 * half-perimeter form loses them as its square. Within NEAR_TOL of the model size from a triangle
 * the weights are its linear functions at the projection (an O(distance) approximation), so
 * the worst error is about 1e-8 of the weights. A last minimal correction (below) makes the
 * partition of unity and linear reproduction exact to round-off. */

#define NEAR_TOL 1e-8

static int32_t local_index(const uint32_t *nodes, int32_t n, uint32_t v)
{
    for (int32_t k = 0; k < n; ++k)
        if (nodes[k] == v)
            return k;
    return -1;
}

/* Linear interpolation weights of the projection of p onto the triangle's plane. */
static void triangle_weights(pf_vec3 p, const pf_vec3 c[3], double wt[3])
{
    pf_vec3 n = pf_v3_cross(pf_v3_sub(c[1], c[0]), pf_v3_sub(c[2], c[0]));
    double nn = pf_v3_dot(n, n);
    for (int i = 0; i < 3; ++i)
        wt[i] =
            pf_v3_dot(n, pf_v3_cross(pf_v3_sub(c[(i + 1) % 3], p), pf_v3_sub(c[(i + 2) % 3], p))) /
            nn;
}

/* Solves the symmetric positive 4 x 4 system a y = b by Gaussian elimination with pivoting. */
static int solve4(double a[4][4], double b[4])
{
    for (int c = 0; c < 4; ++c) {
        int piv = c;
        for (int r = c + 1; r < 4; ++r)
            if (fabs(a[r][c]) > fabs(a[piv][c]))
                piv = r;
        if (!(fabs(a[piv][c]) > 0))
            return 0;
        for (int k = 0; k < 4; ++k) {
            double t = a[c][k];
            a[c][k] = a[piv][k], a[piv][k] = t;
        }
        double t = b[c];
        b[c] = b[piv], b[piv] = t;
        for (int r = c + 1; r < 4; ++r) {
            double f = a[r][c] / a[c][c];
            for (int k = c; k < 4; ++k)
                a[r][k] -= f * a[c][k];
            b[r] -= f * b[c];
        }
    }
    for (int c = 3; c >= 0; --c) {
        for (int k = c + 1; k < 4; ++k)
            b[c] -= a[c][k] * b[k];
        b[c] /= a[c][c];
    }
    return 1;
}

/* The smallest change of w (least squares) after which sum w = 1 and sum w_k (x_k - p) = 0:
 * w += P (P^T P)^-1 (e_0 - P^T w), P the rows (1, (x_k - p) / size). It removes round-off and the
 * near-face approximation's defect from the identities, and is a smooth function of w and p. */
static void restore_affine(const double *x, const uint32_t *nodes, int32_t n, pf_vec3 p,
                           double size, double *w)
{
    double a[4][4] = {{0}}, r[4] = {1, 0, 0, 0};
    for (int32_t k = 0; k < n; ++k) {
        pf_vec3 e = pf_v3_scale(pf_v3_sub(pf_v3_load(x + 3 * (size_t)nodes[k]), p), 1 / size);
        double row[4] = {1, e.x, e.y, e.z};
        for (int i = 0; i < 4; ++i) {
            r[i] -= row[i] * w[k];
            for (int j = 0; j < 4; ++j)
                a[i][j] += row[i] * row[j];
        }
    }
    if (!solve4(a, r))
        return;
    for (int32_t k = 0; k < n; ++k) {
        pf_vec3 e = pf_v3_scale(pf_v3_sub(pf_v3_load(x + 3 * (size_t)nodes[k]), p), 1 / size);
        w[k] += r[0] + e.x * r[1] + e.y * r[2] + e.z * r[3];
    }
}

pf_status pf_embed_mean_value(const double *x, const uint32_t *tri, int32_t nt,
                              const uint32_t *nodes, int32_t n, pf_vec3 p, double *w, pf_error *err)
{
    double size = 0;
    for (int32_t k = 0; k < n; ++k) {
        w[k] = 0;
        size = fmax(size, pf_v3_dist(p, pf_v3_load(x + 3 * (size_t)nodes[k])));
    }
    PF_CHECK(size > 0, err, PF_ERR_NUMERIC, "mean value coordinates of a degenerate element");
    int near = 0;
    for (int32_t t = 0; t < nt && !near; ++t) {
        int32_t loc[3];
        double d[3], wt[3];
        pf_vec3 u[3], c[3];
        for (int i = 0; i < 3; ++i) {
            loc[i] = local_index(nodes, n, tri[3 * t + i]);
            PF_CHECK(loc[i] >= 0, err, PF_ERR_INVALID,
                     "triangle %d corner %u is not among the %d nodes", (int)t, tri[3 * t + i],
                     (int)n);
            c[i] = pf_v3_load(x + 3 * (size_t)tri[3 * t + i]);
        }
        if (pf_point_triangle_distance(p, c[0], c[1], c[2]) <= NEAR_TOL * size) {
            for (int32_t k = 0; k < n; ++k)
                w[k] = 0;
            triangle_weights(p, c, wt);
            for (int i = 0; i < 3; ++i)
                w[loc[i]] = wt[i];
            near = 1;
            break;
        }
        for (int i = 0; i < 3; ++i) {
            pf_vec3 e = pf_v3_sub(c[i], p);
            d[i] = pf_v3_norm(e);
            u[i] = pf_v3_scale(e, 1.0 / d[i]);
        }
        pf_vec3 m = pf_v3(0, 0, 0);
        for (int i = 0; i < 3; ++i) {
            pf_vec3 a = u[(i + 1) % 3], b = u[(i + 2) % 3];
            double beta = 2 * asin(fmin(1.0, pf_v3_dist(a, b) / 2));
            m = pf_v3_add(m, pf_v3_scale(pf_v3_normalize(pf_v3_cross(a, b)), beta / 2));
        }
        pf_mat3 um = {
            {{u[0].x, u[1].x, u[2].x}, {u[0].y, u[1].y, u[2].y}, {u[0].z, u[1].z, u[2].z}}};
        double det;
        pf_mat3 inv = pf_m3_inverse(um, &det);
        if (fabs(det) <= 1e-14) /* p in the plane, outside the triangle: it spans no solid angle */
            continue;
        pf_vec3 lambda = pf_m3_mulv(inv, m);
        w[loc[0]] += lambda.x / d[0];
        w[loc[1]] += lambda.y / d[1];
        w[loc[2]] += lambda.z / d[2];
    }
    double total = 0, mass = 0;
    for (int32_t k = 0; k < n; ++k)
        total += w[k], mass += fabs(w[k]);
    PF_CHECK(isfinite(total) && fabs(total) > 1e-8 * mass, err, PF_ERR_NUMERIC,
             "mean value coordinates at (%g, %g, %g) do not sum to a usable total", p.x, p.y, p.z);
    for (int32_t k = 0; k < n; ++k)
        w[k] /= total;
    restore_affine(x, nodes, n, p, size, w);
    return PF_OK;
}

/* ---- tets and hexes ------------------------------------------------------------------------- */

/* Barycentric coordinates of p in the tet of the four nodes: p - x0 = T (l1, l2, l3). */
static int tet_weights(const double *x, const uint32_t *nodes, pf_vec3 p, double *w)
{
    pf_vec3 x0 = pf_v3_load(x + 3 * (size_t)nodes[0]);
    pf_mat3 t;
    for (int c = 0; c < 3; ++c) {
        pf_vec3 e = pf_v3_sub(pf_v3_load(x + 3 * (size_t)nodes[c + 1]), x0);
        t.m[0][c] = e.x, t.m[1][c] = e.y, t.m[2][c] = e.z;
    }
    double det;
    pf_mat3 inv = pf_m3_inverse(t, &det);
    if (det == 0 || !isfinite(det))
        return 0;
    pf_vec3 l = pf_m3_mulv(inv, pf_v3_sub(p, x0));
    w[0] = 1 - l.x - l.y - l.z;
    w[1] = l.x, w[2] = l.y, w[3] = l.z;
    return 1;
}

static int contains(const uint32_t *v, int n, uint32_t x)
{
    for (int k = 0; k < n; ++k)
        if (v[k] == x)
            return 1;
    return 0;
}

/* The eight corners of hex e in VTK order (bottom 0-1-2-3 counter-clockwise seen from above, 4-7
 * above them) from its faces: the first face, outward, is the bottom; each bottom corner's top
 * partner is its one edge neighbour off the bottom. False when the faces do not form a hex. */
static int hex_corners(const pf_mesh *m, int32_t e, uint32_t corner[8])
{
    if (m->elem_offsets[e + 1] - m->elem_offsets[e] != 6)
        return 0;
    uint32_t first = m->elem_faces[m->elem_offsets[e]];
    int32_t f0 = PF_FACE_INDEX(first);
    int64_t o = m->face_offsets[f0];
    if (m->face_offsets[f0 + 1] - o != 4)
        return 0;
    uint32_t out[4];
    for (int k = 0; k < 4; ++k)
        out[k] = m->face_nodes[o + ((first & PF_FACE_REVERSED) ? 3 - k : k)];
    corner[0] = out[0], corner[1] = out[3], corner[2] = out[2], corner[3] = out[1];
    for (int b = 0; b < 4; ++b) {
        int found = 0;
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            int64_t fo = m->face_offsets[f], n = m->face_offsets[f + 1] - fo;
            for (int64_t j = 0; j < n; ++j) {
                uint32_t a = m->face_nodes[fo + j], c = m->face_nodes[fo + (j + 1) % n];
                uint32_t other = a == corner[b] ? c : c == corner[b] ? a : UINT32_MAX;
                if (other == UINT32_MAX || contains(corner, 4, other))
                    continue;
                if (found && corner[4 + b] != other)
                    return 0;
                corner[4 + b] = other;
                found = 1;
            }
        }
        if (!found || contains(corner, 4 + b, corner[4 + b]))
            return 0;
    }
    return 1;
}

/* Trilinear shape functions on [0,1]^3, corners in VTK order, and their derivatives. */
static void trilinear(pf_vec3 xi, double n[8], double dn[8][3])
{
    static const int bits[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                   {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    double t[3] = {xi.x, xi.y, xi.z};
    for (int a = 0; a < 8; ++a) {
        double f[3], df[3];
        for (int k = 0; k < 3; ++k) {
            f[k] = bits[a][k] ? t[k] : 1 - t[k];
            df[k] = bits[a][k] ? 1 : -1;
        }
        n[a] = f[0] * f[1] * f[2];
        dn[a][0] = df[0] * f[1] * f[2];
        dn[a][1] = f[0] * df[1] * f[2];
        dn[a][2] = f[0] * f[1] * df[2];
    }
}

/* Inverts the trilinear map by Newton's method from the centre; the weights are the shape
 * functions at the solution (affine fields reproduced to the residual). False when it does not
 * converge to 1e-13 of the hex's size. */
static int hex_weights(const double *x, const uint32_t corner[8], pf_vec3 p, double *w)
{
    pf_vec3 c[8];
    pf_vec3 lo, hi;
    for (int a = 0; a < 8; ++a) {
        c[a] = pf_v3_load(x + 3 * (size_t)corner[a]);
        lo = a ? pf_v3_min(lo, c[a]) : c[a];
        hi = a ? pf_v3_max(hi, c[a]) : c[a];
    }
    double size = pf_v3_dist(lo, hi);
    pf_vec3 xi = pf_v3(0.5, 0.5, 0.5);
    double n[8], dn[8][3];
    for (int it = 0; it < 50; ++it) {
        trilinear(xi, n, dn);
        pf_vec3 r = p;
        pf_mat3 j = {{{0}}};
        for (int a = 0; a < 8; ++a) {
            r = pf_v3_sub(r, pf_v3_scale(c[a], n[a]));
            for (int k = 0; k < 3; ++k) {
                j.m[0][k] += c[a].x * dn[a][k];
                j.m[1][k] += c[a].y * dn[a][k];
                j.m[2][k] += c[a].z * dn[a][k];
            }
        }
        if (pf_v3_norm(r) <= 1e-13 * size) {
            memcpy(w, n, sizeof n);
            return 1;
        }
        double det;
        pf_mat3 inv = pf_m3_inverse(j, &det);
        if (!(fabs(det) > 1e-14 * size * size * size))
            return 0;
        xi = pf_v3_add(xi, pf_m3_mulv(inv, r));
        if (!pf_v3_isfinite(xi) || pf_v3_max_abs(xi) > 1e6)
            return 0;
    }
    return 0;
}

/* ---- per vertex ------------------------------------------------------------------------------ */

/* The affine least-squares fit to the element's nodes (equal weights): the fallback where the
 * element's own functions cannot be evaluated (far outside a distorted hex or polyhedron). */
static int affine_fallback(const double *x, const uint32_t *nodes, int32_t n, pf_vec3 p, double *d,
                           double *ones, double *w)
{
    double size = 0;
    for (int32_t k = 0; k < n; ++k)
        size = fmax(size, pf_v3_dist(p, pf_v3_load(x + 3 * (size_t)nodes[k])));
    for (int32_t k = 0; k < n; ++k) {
        pf_vec3 e = pf_v3_scale(pf_v3_sub(pf_v3_load(x + 3 * (size_t)nodes[k]), p), 1.0 / size);
        pf_v3_store(e, d + 3 * (size_t)k);
        ones[k] = 1;
    }
    return pf_affine_fit_weights(d, ones, n, 1e-12, w);
}

/* Which shape functions weight a vertex in element e: the closed forms where the element is a tet
 * or a hex with identifiable corners (corner[8] then holds them), else the general ones. */
typedef enum elem_form { FORM_TET, FORM_HEX, FORM_GENERAL } elem_form;

static elem_form form_of(const pf_mesh *m, const locator *L, int32_t e, uint32_t corner[8])
{
    int64_t n = L->geo.node_offsets[e + 1] - L->geo.node_offsets[e];
    pf_elem_kind kind = (pf_elem_kind)L->geo.kind[e];
    if (kind == PF_ELEM_TET && n == 4)
        return FORM_TET;
    if (kind == PF_ELEM_HEX && hex_corners(m, e, corner))
        return FORM_HEX;
    return FORM_GENERAL;
}

/* The harmonic functions of the general polyhedra that hold a vertex, on a sub-mesh of them
 * (the same nodes, so their node indices are the mesh's). */
typedef struct harmonic_set {
    pf_basis basis;
    int32_t *sub_of; /* [n_elems]: the element's index in basis, -1 when it has no functions */
} harmonic_set;

static void harmonic_release(harmonic_set *h)
{
    pf_basis_release(&h->basis);
    PF_FREE(h->sub_of);
}

static pf_status harmonic_build(const pf_mesh *m, const locator *L, const int32_t *elem_of,
                                int32_t n_verts, harmonic_set *h, pf_embed_stats *stats,
                                pf_error *err)
{
    double t0 = pf_time_seconds();
    memset(h, 0, sizeof *h);
    uint8_t *keep = NULL;
    int32_t *map = NULL;
    pf_mesh sub = {0};
    pf_status st = PF_OK;
    if (!PF_ALLOC_N(keep, m->n_elems) || !PF_ALLOC_N(map, m->n_elems) ||
        !PF_ALLOC_N(h->sub_of, m->n_elems))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for weights");
    if (st >= 0) {
        memset(keep, 0, (size_t)m->n_elems);
        uint32_t corner[8];
        for (int32_t v = 0; v < n_verts; ++v)
            keep[elem_of[v]] = 1;
        for (int32_t e = 0; e < m->n_elems; ++e) {
            keep[e] = keep[e] && form_of(m, L, e, corner) == FORM_GENERAL;
            h->sub_of[e] = -1;
        }
        st = pf_mesh_select_elements(&sub, m, keep, map, err);
    }
    if (st >= 0) {
        /* Uniform: the sub-mesh's boundary is not the mesh's, so its surface patches would be
         * wrong (docs/basis.md). */
        pf_basis_params bp = pf_basis_params_uniform();
        st = pf_basis_create(&h->basis, &sub, &bp, err);
        if (st < 0)
            pf_error_prefix(err,
                            "harmonic weights of the %d polyhedra holding surface vertices "
                            "(numbered among them)",
                            (int)sub.n_elems);
    }
    if (st >= 0) {
        for (int32_t k = 0; k < sub.n_elems; ++k)
            h->sub_of[map[k]] = k;
        stats->n_harmonic = sub.n_elems;
    }
    pf_mesh_release(&sub);
    pf_free(keep);
    pf_free(map);
    if (st < 0)
        harmonic_release(h);
    stats->basis_seconds = pf_time_seconds() - t0;
    return st;
}

/* Harmonic functions are meaningful inside the element and, extended, a little outside: the
 * kernels sit xi = 0.1 element diameters out, so up to half of that a vertex still gets them. */
#define HARMONIC_REACH 0.05

static int harmonic_weights(const harmonic_set *h, const locator *L, int32_t e, pf_vec3 p,
                            double dist, uint32_t *col, double *w, int32_t *n)
{
    const double *box = L->geo.box + 6 * (size_t)e;
    double diameter = pf_v3_dist(pf_v3_load(box), pf_v3_load(box + 3));
    int32_t k = h->sub_of[e];
    if (k < 0 || dist > HARMONIC_REACH * diameter)
        return 0;
    const int32_t *nodes;
    *n = pf_basis_elem_nodes(&h->basis, k, &nodes);
    for (int32_t i = 0; i < *n; ++i)
        col[i] = (uint32_t)nodes[i];
    pf_basis_eval(&h->basis, k, p, w, NULL);
    for (int32_t i = 0; i < *n; ++i)
        if (!isfinite(w[i]))
            return 0;
    return 1;
}

/* The closed forms of a tet or a hex, or the mean value coordinates of a general polyhedron;
 * 0 when they cannot be evaluated (col then holds the element's distinct nodes, *n of them). */
static int shape_weights(const pf_mesh *m, const locator *L, int32_t e, pf_vec3 p, uint32_t *col,
                         double *val, int32_t *n)
{
    const uint32_t *nodes = L->geo.nodes + L->geo.node_offsets[e];
    *n = (int32_t)(L->geo.node_offsets[e + 1] - L->geo.node_offsets[e]);
    elem_form form = form_of(m, L, e, col);
    if (form == FORM_TET) {
        memcpy(col, nodes, 4 * sizeof *col);
        return tet_weights(m->x, nodes, p, val);
    }
    if (form == FORM_HEX) {
        *n = 8;
        if (hex_weights(m->x, col, p, val))
            return 1;
        memcpy(col, nodes, 8 * sizeof *col);
        return 0;
    }
    memcpy(col, nodes, (size_t)*n * sizeof *col);
    int64_t t0 = L->geo.tri_offsets[e];
    pf_error ignored = {0};
    return pf_embed_mean_value(m->x, L->geo.tri + 3 * t0, (int32_t)(L->geo.tri_offsets[e + 1] - t0),
                               nodes, *n, p, val, &ignored) >= 0;
}

int pf_embed_elem_weights(const pf_mesh *m, const locator *L, int32_t e, pf_vec3 p, uint32_t *col,
                          double *val, double *scratch, int32_t *n, bool *fallback)
{
    *fallback = false;
    if (shape_weights(m, L, e, p, col, val, n))
        return 1;
    *fallback = true;
    return affine_fallback(m->x, col, *n, p, scratch, scratch + 3 * (size_t)*n, val);
}

/* A vertex with a side (on a cut, where the elements of both sides hold it) is located nudged
 * into its side by 1e-6 of its first element's size. */
static void locate_all(locator *L, const pf_surface *s, const double *side, int32_t *elem_of,
                       double *dist)
{
    for (int32_t v = 0; v < s->n_verts; ++v) {
        pf_vec3 p = pf_v3_load(s->x + 3 * (size_t)v);
        elem_of[v] = pf_locator_find(L, p, &dist[v]);
        pf_vec3 dir = side ? pf_v3_load(side + 3 * (size_t)v) : pf_v3(0, 0, 0);
        double len = pf_v3_norm(dir);
        if (len > 0) {
            const double *box = L->geo.box + 6 * (size_t)elem_of[v];
            double h = fmax(box[3] - box[0], fmax(box[4] - box[1], box[5] - box[2]));
            elem_of[v] =
                pf_locator_find(L, pf_v3_add(p, pf_v3_scale(dir, 1e-6 * h / len)), &dist[v]);
        }
    }
}

pf_status pf_embed_bary(const pf_mesh *m, const pf_surface *s, const double *vertex_side,
                        locator *L, bool harmonic, row_builder *b, pf_embed_stats *stats,
                        pf_error *err)
{
    int32_t cap = L->geo.max_nodes > 8 ? L->geo.max_nodes : 8;
    uint32_t *col = NULL;
    double *val = NULL, *d = NULL, *ones = NULL, *dist = NULL;
    int32_t *elem_of = NULL;
    harmonic_set h = {0};
    pf_status st = PF_OK;
    if (!PF_ALLOC_N(col, (size_t)cap) || !PF_ALLOC_N(val, (size_t)cap) ||
        !PF_ALLOC_N(d, 4 * (size_t)cap) || !PF_ALLOC_N(ones, (size_t)cap) ||
        !PF_ALLOC_N(elem_of, s->n_verts) || !PF_ALLOC_N(dist, s->n_verts))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory for weights");
    if (st >= 0)
        locate_all(L, s, vertex_side, elem_of, dist);
    if (st >= 0 && harmonic)
        st = harmonic_build(m, L, elem_of, s->n_verts, &h, stats, err);
    for (int32_t v = 0; v < s->n_verts && st >= 0; ++v) {
        pf_vec3 p = pf_v3_load(s->x + 3 * (size_t)v);
        int32_t e = elem_of[v];
        if (dist[v] > L->tol) {
            stats->n_outside++;
            stats->max_outside = fmax(stats->max_outside, dist[v]);
        }
        const uint32_t *nodes = L->geo.nodes + L->geo.node_offsets[e];
        int32_t n = (int32_t)(L->geo.node_offsets[e + 1] - L->geo.node_offsets[e]);
        stats->n_by_kind[L->geo.kind[e]]++;
        int ok = 0;
        bool fallback = false;
        if (harmonic && form_of(m, L, e, col) == FORM_GENERAL) {
            ok = harmonic_weights(&h, L, e, p, dist[v], col, val, &n);
            if (!ok) {
                n = (int32_t)(L->geo.node_offsets[e + 1] - L->geo.node_offsets[e]);
                memcpy(col, nodes, (size_t)n * sizeof *col);
                fallback = true;
                ok = affine_fallback(m->x, col, n, p, d, ones, val);
            }
        } else {
            ok = pf_embed_elem_weights(m, L, e, p, col, val, d, &n, &fallback);
        }
        stats->n_fallback += fallback;
        if (!ok)
            st = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                              "surface vertex %d: no usable weights in element %d", (int)v, (int)e);
        else
            st = pf_row_builder_add(b, v, col, val, n, err);
    }
    harmonic_release(&h);
    pf_free(col);
    pf_free(val);
    pf_free(d);
    pf_free(ones);
    pf_free(elem_of);
    pf_free(dist);
    return st;
}
