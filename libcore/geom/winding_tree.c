/* The generalised winding number of a triangle soup, accelerated by a bounding-volume tree whose
 * far clusters are replaced by their dipole (Barill, Dickson, Schmidt, Levin, Jacobson, "Fast
 * Winding Numbers for Soups and Clouds", SIGGRAPH 2018, sec. 3: first-order expansion).
 *
 * A cluster of triangles with area vectors a_t (half the cross product of two edges, along the
 * right-handed normal) seen from p far away subtends the solid angle
 *     Omega ~ sum_t a_t . (c - p) / |c - p|^3 = A . (c - p) / |c - p|^3,
 * c the area-weighted centroid of the cluster, A = sum_t a_t: the leading term of the expansion
 * about c. The next term (the first moments sum_t a_t (x_t - c)^T, which Barill et al. keep at
 * second order) is dropped, so the error is O(r / d) of the cluster's own contribution, r its
 * radius and d the distance. A cluster is expanded when d > beta r, beta = 4 (2.5 left errors of
 * 4e-2 of a turn, 4 leaves 1.4e-2 on spheres and tori: tests/test_robust.c); nearer clusters are
 * opened and leaves summed exactly (Van Oosterom-Strackee, as pf_winding_number). */
#include <pf/geom.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { LEAF_SIZE = 8, STACK = 128 };
static const double BETA = 4;

typedef struct node {
    int32_t begin, end; /* triangles order[begin .. end) */
    int32_t child[2];   /* -1 for a leaf */
    pf_vec3 c;          /* area-weighted centroid */
    pf_vec3 a;          /* sum of area vectors */
    double r;           /* radius around c enclosing every corner */
} node;

struct pf_winding_tree {
    const double *x; /* borrowed */
    const uint32_t *tri;
    int32_t nt;
    int32_t *order;  /* [nt] triangle indices grouped by node */
    pf_vec3 *centre; /* [nt] triangle centroids, for the splits */
    node *nodes;
    int32_t n_nodes, cap_nodes;
};

static pf_vec3 corner(const pf_winding_tree *wt, int32_t t, int q)
{
    return pf_v3_load(wt->x + 3 * (size_t)wt->tri[3 * (size_t)t + q]);
}

static pf_vec3 area_vector(const pf_winding_tree *wt, int32_t t)
{
    pf_vec3 a = corner(wt, t, 0), b = corner(wt, t, 1), c = corner(wt, t, 2);
    return pf_v3_scale(pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(c, a)), 0.5);
}

/* Quickselect on centroids along axis: order[begin .. end) partitioned around mid. */
static void partition(pf_winding_tree *wt, int32_t begin, int32_t end, int32_t mid, int axis)
{
    int32_t *o = wt->order;
    while (end - begin > 1) {
        double pivot = pf_v3_get(wt->centre[o[begin + (end - begin) / 2]], axis);
        int32_t i = begin, j = end - 1;
        while (i <= j) {
            while (pf_v3_get(wt->centre[o[i]], axis) < pivot)
                ++i;
            while (pf_v3_get(wt->centre[o[j]], axis) > pivot)
                --j;
            if (i <= j) {
                int32_t tmp = o[i];
                o[i++] = o[j];
                o[j--] = tmp;
            }
        }
        if (mid <= j)
            end = j + 1;
        else if (mid >= i)
            begin = i;
        else
            return;
    }
}

static int32_t build(pf_winding_tree *wt, int32_t begin, int32_t end)
{
    int32_t id = wt->n_nodes++;
    node n = {.begin = begin, .end = end, .child = {-1, -1}};
    double area = 0;
    pf_vec3 lo = pf_v3(INFINITY, INFINITY, INFINITY), hi = pf_v3_scale(lo, -1);
    pf_vec3 weighted = pf_v3(0, 0, 0);
    for (int32_t k = begin; k < end; ++k) {
        int32_t t = wt->order[k];
        pf_vec3 av = area_vector(wt, t);
        double at = pf_v3_norm(av);
        n.a = pf_v3_add(n.a, av);
        area += at;
        weighted = pf_v3_add(weighted, pf_v3_scale(wt->centre[t], at));
        lo = pf_v3_min(lo, wt->centre[t]);
        hi = pf_v3_max(hi, wt->centre[t]);
    }
    n.c = area > 0 ? pf_v3_scale(weighted, 1 / area) : pf_v3_scale(pf_v3_add(lo, hi), 0.5);
    for (int32_t k = begin; k < end; ++k)
        for (int q = 0; q < 3; ++q)
            n.r = fmax(n.r, pf_v3_dist(n.c, corner(wt, wt->order[k], q)));
    wt->nodes[id] = n;
    if (end - begin > LEAF_SIZE) {
        pf_vec3 e = pf_v3_sub(hi, lo);
        int axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
        int32_t mid = begin + (end - begin) / 2;
        partition(wt, begin, end, mid, axis);
        int32_t left = build(wt, begin, mid);
        int32_t right = build(wt, mid, end);
        wt->nodes[id].child[0] = left;
        wt->nodes[id].child[1] = right;
    }
    return id;
}

pf_status pf_winding_tree_create(pf_winding_tree **out, const double *x, int32_t nv,
                                 const uint32_t *tri, int32_t nt, pf_error *err)
{
    *out = NULL;
    PF_CHECK(nt > 0 && nv > 0, err, PF_ERR_INVALID, "winding number of an empty surface");
    for (int64_t i = 0; i < 3 * (int64_t)nt; ++i)
        PF_CHECK(tri[i] < (uint32_t)nv, err, PF_ERR_INVALID,
                 "triangle %lld has vertex %u out of range (%d vertices)", (long long)(i / 3),
                 tri[i], (int)nv);
    pf_winding_tree *wt = pf_calloc(1, sizeof *wt);
    PF_CHECK(wt, err, PF_ERR_NOMEM, "out of memory for a winding-number tree");
    wt->x = x, wt->tri = tri, wt->nt = nt;
    /* a binary tree with leaves of LEAF_SIZE / 2 .. LEAF_SIZE triangles has < 2 nt / 4 + 1 nodes */
    wt->cap_nodes = 2 * (nt / (LEAF_SIZE / 2) + 1);
    wt->order = pf_alloc_array((size_t)nt, sizeof *wt->order);
    wt->centre = pf_alloc_array((size_t)nt, sizeof *wt->centre);
    wt->nodes = pf_alloc_array((size_t)wt->cap_nodes, sizeof *wt->nodes);
    if (!wt->order || !wt->centre || !wt->nodes) {
        pf_winding_tree_destroy(&wt);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "out of memory for a winding-number tree of %d triangles", (int)nt);
    }
    for (int32_t t = 0; t < nt; ++t) {
        wt->order[t] = t;
        wt->centre[t] = pf_v3_scale(
            pf_v3_add(corner(wt, t, 0), pf_v3_add(corner(wt, t, 1), corner(wt, t, 2))), 1.0 / 3);
    }
    build(wt, 0, nt);
    *out = wt;
    return PF_OK;
}

void pf_winding_tree_destroy(pf_winding_tree **wt)
{
    if (!*wt)
        return;
    pf_free((*wt)->order);
    pf_free((*wt)->centre);
    pf_free((*wt)->nodes);
    pf_free(*wt);
    *wt = NULL;
}

/* Solid angle of triangle t seen from p (Van Oosterom-Strackee, as pf_winding_number). */
static double solid_angle(const pf_winding_tree *wt, int32_t t, pf_vec3 p)
{
    pf_vec3 a = pf_v3_sub(corner(wt, t, 0), p);
    pf_vec3 b = pf_v3_sub(corner(wt, t, 1), p);
    pf_vec3 c = pf_v3_sub(corner(wt, t, 2), p);
    double la = pf_v3_norm(a), lb = pf_v3_norm(b), lc = pf_v3_norm(c);
    double num = pf_v3_dot(a, pf_v3_cross(b, c));
    double den = la * lb * lc + pf_v3_dot(a, b) * lc + pf_v3_dot(a, c) * lb + pf_v3_dot(b, c) * la;
    return 2 * atan2(num, den);
}

double pf_winding_tree_eval(const pf_winding_tree *wt, pf_vec3 p)
{
    double sum = 0;
    int32_t stack[STACK];
    int n = 0;
    stack[n++] = 0;
    while (n > 0) {
        const node *nd = &wt->nodes[stack[--n]];
        pf_vec3 d = pf_v3_sub(nd->c, p);
        double dist = pf_v3_norm(d);
        if (dist > BETA * nd->r) {
            sum += pf_v3_dot(nd->a, d) / (dist * dist * dist);
        } else if (nd->child[0] < 0 || n + 2 > STACK) {
            for (int32_t k = nd->begin; k < nd->end; ++k)
                sum += solid_angle(wt, wt->order[k], p);
        } else {
            stack[n++] = nd->child[0];
            stack[n++] = nd->child[1];
        }
    }
    return sum / (4 * 3.14159265358979323846);
}
