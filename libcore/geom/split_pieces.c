/* Pieces of pf_poly_split (step 5 of split.c): connected components of each side's polygons
 * over shared edges; at an edge shared by more than two polygons of one side, they are paired
 * around the edge across the solid between them. */
#include "split_internal.h"

#include <math.h>
#include <stdlib.h>

/* ---- pieces ---------------------------------------------------------------------------------- */

static int32_t find_root(int32_t *parent, int32_t i)
{
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

static void unite(int32_t *parent, int32_t a, int32_t b)
{
    a = find_root(parent, a);
    b = find_root(parent, b);
    if (a != b)
        parent[a > b ? a : b] = a < b ? a : b;
}

typedef struct around {
    double angle;
    int32_t poly;
    int solid_ccw;
} around;

static int compare_around(const void *a, const void *b)
{
    const around *x = a, *y = b;
    if (x->angle != y->angle)
        return (x->angle > y->angle) - (x->angle < y->angle);
    return (x->poly > y->poly) - (x->poly < y->poly);
}

/* Faces of one side around edge lo-hi, sorted by angle about it; each face is joined to the
 * neighbour across the solid on its inner side. */
static pf_status pair_around_edge(const work *w, const pedge *g, int64_t k, int32_t *parent,
                                  pf_error *err)
{
    uint32_t lo = (uint32_t)(g[0].key >> 32), hi = (uint32_t)(g[0].key & 0xffffffffu);
    pf_vec3 t = pf_v3_normalize(
        pf_v3_sub(pf_v3_load(w->x + 3 * (size_t)hi), pf_v3_load(w->x + 3 * (size_t)lo)));
    pf_vec3 helper = fabs(t.x) <= fabs(t.y) && fabs(t.x) <= fabs(t.z) ? pf_v3(1, 0, 0)
                     : fabs(t.y) <= fabs(t.z)                         ? pf_v3(0, 1, 0)
                                                                      : pf_v3(0, 0, 1);
    pf_vec3 e1 = pf_v3_normalize(pf_v3_cross(helper, t)), e2 = pf_v3_cross(t, e1);
    around *a = pf_alloc_array((size_t)k, sizeof *a);
    PF_CHECK(a, err, PF_ERR_NOMEM, "split: cannot allocate edge fan");
    const uint32_t *nodes = BUF(w->out.nodes, uint32_t);
    for (int64_t i = 0; i < k; ++i) {
        int32_t pi = g[i].poly;
        int64_t b = poly_begin(&w->out, pi), end = BUF(w->out.end, int64_t)[pi];
        pf_vec3 nrm = pf_polygon_area_vector(w->x, nodes + b, end - b);
        pf_vec3 dir = g[i].dir > 0 ? t : pf_v3_scale(t, -1);
        pf_vec3 in_face = pf_v3_cross(nrm, dir);
        a[i].angle = atan2(pf_v3_dot(in_face, e2), pf_v3_dot(in_face, e1));
        a[i].poly = pi;
        a[i].solid_ccw = pf_v3_dot(nrm, pf_v3_cross(t, in_face)) < 0;
    }
    qsort(a, (size_t)k, sizeof *a, compare_around);
    for (int64_t i = 0; i < k; ++i)
        if (a[i].solid_ccw)
            unite(parent, a[i].poly, a[(i + 1) % k].poly);
    pf_free(a);
    return PF_OK;
}

/* Reorders the edges so that those of one side along one edge (equal side and key) are adjacent:
 * a counting sort by the lower node, then each node's bucket (a handful of edges) by insertion in
 * compare_pedge order. Linear in edges plus nodes, where a full sort was n log n per split. The
 * pieces do not depend on the order of the groups, nor on the order within one (pair_around_edge
 * sorts its own). */
static pf_status group_edges(pedge **edges, int64_t n, int32_t n_nodes, pf_error *err)
{
    pedge *e = *edges;
    int64_t *end = pf_calloc((size_t)n_nodes + 1, sizeof *end);
    pedge *g = pf_alloc_array((size_t)n + 1, sizeof *g);
    if (!end || !g) {
        pf_free(end), pf_free(g);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "split: cannot allocate %lld edges", (long long)n);
    }
    for (int64_t i = 0; i < n; ++i)
        end[(e[i].key >> 32) + 1]++;
    for (int32_t v = 0; v < n_nodes; ++v)
        end[v + 1] += end[v];
    for (int64_t i = 0; i < n; ++i)
        g[end[e[i].key >> 32]++] = e[i]; /* end[v]: now the end of node v's bucket */
    for (int64_t v = 0, begin = 0; v < n_nodes; begin = end[v++])
        for (int64_t i = begin + 1; i < end[v]; ++i) {
            pedge x = g[i];
            int64_t j = i;
            for (; j > begin && compare_pedge(&g[j - 1], &x) > 0; --j)
                g[j] = g[j - 1];
            g[j] = x;
        }
    pf_free(end);
    pf_free(e);
    *edges = g;
    return PF_OK;
}

pf_status pf_split_find_pieces(const work *w, int32_t *piece_of, int32_t *n_pieces, pf_error *err)
{
    int32_t np = w->out.n;
    pedge *e = NULL;
    int64_t n = 0;
    PF_TRY(pf_split_collect_edges(w, 0, &e, &n, err));
    pf_status s = group_edges(&e, n, w->n_total, err);
    int32_t *parent = s == PF_OK ? pf_alloc_array((size_t)np, sizeof *parent) : NULL;
    if (s == PF_OK && !parent)
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                         "split: cannot allocate components");
    for (int32_t i = 0; i < np && s == PF_OK; ++i)
        parent[i] = i;
    for (int64_t i = 0; i < n && s == PF_OK;) {
        int64_t j = i, net = 0;
        while (j < n && e[j].key == e[i].key && e[j].side == e[i].side)
            net += e[j++].dir;
        if (net != 0)
            s = pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                             "split: a piece is not closed at edge %u-%u",
                             (unsigned)(e[i].key >> 32), (unsigned)(e[i].key & 0xffffffffu));
        else if (j - i == 2)
            unite(parent, e[i].poly, e[i + 1].poly);
        else
            s = pair_around_edge(w, e + i, j - i, parent, err);
        i = j;
    }
    if (s == PF_OK) {
        const int8_t *side = BUF(w->out.side, int8_t);
        for (int32_t i = 0; i < np; ++i)
            piece_of[i] = -1;
        int32_t count = 0;
        int32_t *id = pf_alloc_array((size_t)np, sizeof *id);
        if (!id)
            s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "split: out of memory");
        for (int32_t i = 0; i < np && id; ++i)
            id[i] = -1;
        for (int sd = -1; sd <= 1 && id; sd += 2)
            for (int32_t i = 0; i < np; ++i) {
                if (side[i] != sd)
                    continue;
                int32_t r = find_root(parent, i);
                if (id[r] < 0)
                    id[r] = count++;
                piece_of[i] = id[r];
            }
        pf_free(id);
        *n_pieces = count;
    }
    pf_free(parent);
    pf_free(e);
    return s;
}
