/* pf_poly_split: a closed polyhedron cut by a plane into closed pieces.
 *
 * 1. Every node is classified once (-1, 0, +1) against the plane with tolerance tol.
 * 2. Every input edge with ends of classes (-1, +1) gets one new node (class 0).
 * 3. Faces with no node below go above whole, faces with no node above go below whole; faces
 *    lying on the plane go to the side of their element (opposite to their outward normal).
 *    A face with nodes on both sides is cut along the line where it meets the plane: with the
 *    new nodes inserted, every edge of the face lies on one side (an edge between two on-plane
 *    nodes goes to the side the face's interior is on, to its left). Along the line, with u the
 *    direction whose left is below, the part below is bounded by chords directed +u between
 *    consecutive on-plane nodes; how many chords cover each gap follows from the balance of
 *    incoming and outgoing boundary edges at each on-plane node taken in order along u (0 or
 *    1 for a simple face, anything else is reported). The part above is the mirror image.
 *    Where a chord and a face edge meet at a node touched by the face from one side, the chord
 *    continues into the face edge, so parts touching at a vertex are separate polygons.
 *    Everything so far uses the classes and the order along u only.
 * 4. Caps: over all faces below, on-plane edges used a -> b more often than b -> a bound the region
 *    of the plane with solid on both sides; the cap below is that region with those edges
 *    reversed, the cap above its mirror image. (Both sides use the same edges: the faces of both
 *    sides together are the input's edges, split at the new nodes, plus every chord both ways.)
 *    An input edge on the plane whose two faces leave it into the same half-space at a reflex
 *    dihedral angle lies inside the cap region, with the solid on that side split along it into
 *    two parts touching at the edge: the cap is cut along it (unless it dangles into the region).
 * 5. Pieces are connected components of each side's faces over shared edges; at an edge shared
 *    by more than two faces of one side, faces are paired around the edge across the solid
 *    between them.
 */
#include <pf/split.h>

#include "split_internal.h"

#include <stdlib.h>
#include <string.h>

pf_split_params pf_split_params_default(void)
{
    return (pf_split_params){.tol = 0, .rel_tol = 1e-10};
}

void pf_split_release(pf_split *s)
{
    pf_free(s->x);
    pf_free(s->node_class);
    pf_free(s->new_edge);
    pf_free(s->new_t);
    pf_free(s->piece_side);
    pf_free(s->piece_faces);
    pf_free(s->face_offsets);
    pf_free(s->face_nodes);
    pf_free(s->face_source);
    memset(s, 0, sizeof *s);
}

/* pf_buffer_append with the common case, room left, inline: polygons are built a node at a time. */
static inline pf_status push(pf_buffer *b, const void *bytes, size_t n, pf_error *err)
{
    if (b->capacity - b->size < n)
        return pf_buffer_append(b, bytes, n, err);
    memcpy(b->data + b->size, bytes, n);
    b->size += n;
    return PF_OK;
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static uint64_t edge_key(uint32_t a, uint32_t b)
{
    return a < b ? ((uint64_t)a << 32 | b) : ((uint64_t)b << 32 | a);
}

static int64_t lower_bound_u64(const uint64_t *s, int64_t n, uint64_t key)
{
    int64_t lo = 0, hi = n;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (s[mid] < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

static int64_t count_u64(const uint64_t *s, int64_t n, uint64_t key)
{
    int64_t i = lower_bound_u64(s, n, key), c = 0;
    while (i + c < n && s[i + c] == key)
        ++c;
    return c;
}

/* ---- input checks ---------------------------------------------------------------------------- */

static pf_status check_input(const pf_polyhedron *p, int32_t n_nodes, const pf_plane *pl,
                             pf_error *err)
{
    PF_CHECK(p && pl, err, PF_ERR_INVALID, "split: polyhedron or plane missing");
    PF_CHECK(p->n_faces > 0 && n_nodes > 0 && p->x && p->face_offsets && p->face_nodes, err,
             PF_ERR_INVALID, "split: empty polyhedron (%d faces, %d nodes)", (int)p->n_faces,
             (int)n_nodes);
    double nn = pf_v3_norm(pl->n);
    PF_CHECK(pf_v3_isfinite(pl->n) && isfinite(pl->d) && fabs(nn - 1) < 1e-6, err, PF_ERR_INVALID,
             "split: the plane needs a finite unit normal and offset (|n| = %g)", nn);
    for (int32_t f = 0; f < p->n_faces; ++f) {
        int64_t k0 = p->face_offsets[f], k1 = p->face_offsets[f + 1];
        PF_CHECK(k1 - k0 >= 3, err, PF_ERR_INVALID, "split: face %d has %lld nodes (needs 3)",
                 (int)f, (long long)(k1 - k0));
        for (int64_t k = k0; k < k1; ++k) {
            uint32_t a = p->face_nodes[k], b = p->face_nodes[k + 1 < k1 ? k + 1 : k0];
            PF_CHECK(a < (uint32_t)n_nodes, err, PF_ERR_INVALID,
                     "split: face %d references node %u of %d", (int)f, a, (int)n_nodes);
            PF_CHECK(a != b, err, PF_ERR_INVALID, "split: face %d repeats node %u", (int)f, a);
            PF_CHECK(pf_v3_isfinite(pf_v3_load(p->x + 3 * (size_t)a)), err, PF_ERR_INVALID,
                     "split: node %u has a non-finite coordinate", a);
        }
    }
    return PF_OK;
}

/* Closed: every directed edge a -> b is matched by as many b -> a. */
static pf_status check_closed(const pf_polyhedron *p, pf_error *err)
{
    int64_t n = p->face_offsets[p->n_faces] - p->face_offsets[0];
    uint64_t *e = pf_alloc_array((size_t)n, sizeof *e);
    PF_CHECK(e, err, PF_ERR_NOMEM, "split: cannot allocate %lld edges", (long long)n);
    int64_t m = 0;
    for (int32_t f = 0; f < p->n_faces; ++f) {
        int64_t k0 = p->face_offsets[f], k1 = p->face_offsets[f + 1];
        for (int64_t k = k0; k < k1; ++k)
            e[m++] = (uint64_t)p->face_nodes[k] << 32 | p->face_nodes[k + 1 < k1 ? k + 1 : k0];
    }
    qsort(e, (size_t)m, sizeof *e, compare_u64);
    pf_status s = PF_OK;
    for (int64_t i = 0; i < m && s == PF_OK; ++i) {
        if (i > 0 && e[i] == e[i - 1])
            continue;
        uint64_t twin = e[i] << 32 | e[i] >> 32;
        if (count_u64(e + i, m - i, e[i]) != count_u64(e, m, twin))
            s = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                             "split: the polyhedron is not closed at edge %u-%u",
                             (unsigned)(e[i] >> 32), (unsigned)(e[i] & 0xffffffffu));
    }
    pf_free(e);
    return s;
}

/* ---- classification and new nodes ------------------------------------------------------------ */

static int lex_less(const double *a, const double *b)
{
    if (a[0] != b[0])
        return a[0] < b[0];
    if (a[1] != b[1])
        return a[1] < b[1];
    return a[2] < b[2];
}

/* The crossing point of edge (a, b) from its end points in lexicographic order, so that every
 * cell sharing the edge computes the same bits: t = d_a / (d_a - d_b) with |d_a|, |d_b| > tol,
 * hence 0 < t < 1; each coordinate is clamped into the edge's range against rounding. */
static void crossing_point(work *w, uint32_t a, uint32_t b, uint32_t *first, uint32_t *second,
                           double *t_out, double *out)
{
    const double *xa = w->x + 3 * (size_t)a, *xb = w->x + 3 * (size_t)b;
    if (lex_less(xb, xa)) {
        uint32_t t = a;
        a = b, b = t;
        const double *q = xa;
        xa = xb, xb = q;
    }
    double da = pf_plane_signed_distance(w->pl, pf_v3_load(xa));
    double db = pf_plane_signed_distance(w->pl, pf_v3_load(xb));
    double t = da / (da - db);
    for (int i = 0; i < 3; ++i) {
        double v = xa[i] + t * (xb[i] - xa[i]);
        double lo = fmin(xa[i], xb[i]), hi = fmax(xa[i], xb[i]);
        out[i] = fmin(fmax(v, lo), hi);
    }
    *first = a;
    *second = b;
    *t_out = t;
}

static pf_status classify(work *w, pf_error *err)
{
    const pf_polyhedron *p = w->p;
    PF_CHECK(PF_ALLOC_N(w->dist, w->n_in) && PF_ALLOC_N(w->cls, w->n_in), err, PF_ERR_NOMEM,
             "split: cannot allocate node classes");
    memset(w->dist, 0, (size_t)w->n_in * sizeof *w->dist);
    memset(w->cls, 0, (size_t)w->n_in);
    int below = 0, above = 0;
    for (int64_t k = p->face_offsets[0]; k < p->face_offsets[p->n_faces]; ++k) {
        uint32_t a = p->face_nodes[k];
        double d = pf_plane_signed_distance(w->pl, pf_v3_load(p->x + 3 * (size_t)a));
        w->dist[a] = d;
        w->cls[a] = (int8_t)(d > w->tol ? 1 : d < -w->tol ? -1 : 0);
        below |= w->cls[a] < 0;
        above |= w->cls[a] > 0;
    }
    PF_CHECK(below || above, err, PF_ERR_INVALID,
             "split: the polyhedron lies in the plane (every node within %g of it)", w->tol);
    return PF_OK;
}

static pf_status make_new_nodes(work *w, pf_split *out, pf_error *err)
{
    const pf_polyhedron *p = w->p;
    int64_t m = 0, total = p->face_offsets[p->n_faces] - p->face_offsets[0];
    PF_CHECK(PF_ALLOC_N(w->cross, total), err, PF_ERR_NOMEM, "split: cannot allocate edges");
    for (int32_t f = 0; f < p->n_faces; ++f) {
        int64_t k0 = p->face_offsets[f], k1 = p->face_offsets[f + 1];
        for (int64_t k = k0; k < k1; ++k) {
            uint32_t a = p->face_nodes[k], b = p->face_nodes[k + 1 < k1 ? k + 1 : k0];
            if (w->cls[a] * w->cls[b] < 0)
                w->cross[m++] = edge_key(a, b);
        }
    }
    qsort(w->cross, (size_t)m, sizeof *w->cross, compare_u64);
    int64_t n_new = 0;
    for (int64_t i = 0; i < m; ++i)
        if (i == 0 || w->cross[i] != w->cross[i - 1])
            w->cross[n_new++] = w->cross[i];
    PF_CHECK(n_new <= INT32_MAX - w->n_in, err, PF_ERR_TOO_LARGE, "split: too many nodes");
    w->n_new = n_new;
    w->n_total = w->n_in + (int32_t)n_new;
    double *x = pf_alloc_array(3 * (size_t)w->n_total, sizeof *x);
    int8_t *cls = pf_realloc_array(w->cls, (size_t)w->n_total, 1);
    if (cls)
        w->cls = cls;
    out->new_edge = pf_alloc_array(2 * (size_t)n_new + 1, sizeof *out->new_edge);
    out->new_t = pf_alloc_array((size_t)n_new + 1, sizeof *out->new_t);
    w->x = x;
    PF_CHECK(x && cls && out->new_edge && out->new_t, err, PF_ERR_NOMEM,
             "split: cannot allocate %lld new nodes", (long long)n_new);
    memcpy(x, p->x, 3 * (size_t)w->n_in * sizeof *x);
    for (int64_t i = 0; i < n_new; ++i) {
        uint32_t a = (uint32_t)(w->cross[i] >> 32), b = (uint32_t)(w->cross[i] & 0xffffffffu);
        crossing_point(w, a, b, &out->new_edge[2 * i], &out->new_edge[2 * i + 1], &out->new_t[i],
                       x + 3 * (size_t)(w->n_in + i));
        w->cls[w->n_in + i] = 0;
    }
    return PF_OK;
}

static uint32_t new_node_on(const work *w, uint32_t a, uint32_t b)
{
    return (uint32_t)(w->n_in + lower_bound_u64(w->cross, w->n_new, edge_key(a, b)));
}

/* ---- polygons -------------------------------------------------------------------------------- */

static pf_status emit(polys *o, const uint32_t *nodes, int64_t n, int32_t source, int side,
                      int flat, int reversed, pf_error *err)
{
    PF_TRY(pf_buffer_reserve(&o->nodes, o->nodes.size + (size_t)n * sizeof *nodes, err));
    uint32_t *to = (uint32_t *)(void *)(o->nodes.data + o->nodes.size);
    for (int64_t i = 0; i < n; ++i)
        /* reversed about the same first node: a fan from it gives the same triangles on both
         * sides even when the on-plane nodes (within tol) make a cap slightly non-planar, so
         * the caps' volume contributions cancel exactly */
        to[i] = nodes[reversed ? (n - i) % n : i];
    o->nodes.size += (size_t)n * sizeof *nodes;
    int64_t end = (int64_t)(o->nodes.size / sizeof(uint32_t));
    int8_t s = (int8_t)side;
    uint8_t fl = (uint8_t)flat;
    PF_TRY(push(&o->end, &end, sizeof end, err));
    PF_TRY(push(&o->source, &source, sizeof source, err));
    PF_TRY(push(&o->side, &s, sizeof s, err));
    PF_TRY(push(&o->flat, &fl, sizeof fl, err));
    o->n++;
    return PF_OK;
}

static void polys_release(polys *o)
{
    pf_buffer_release(&o->end);
    pf_buffer_release(&o->nodes);
    pf_buffer_release(&o->source);
    pf_buffer_release(&o->side);
    pf_buffer_release(&o->flat);
    memset(o, 0, sizeof *o);
}

/* ---- cutting one face ------------------------------------------------------------------------ */

/* On-plane positions in the order the chords of one side run: increasing s = dot(x, u) below,
 * decreasing above (ties by position, for determinism). Insertion sort: faces are short. */
static void sort_zero_nodes(int32_t *zp, int32_t nz, const double *as, int side)
{
    for (int32_t i = 1; i < nz; ++i) {
        int32_t v = zp[i], j = i;
        double kv = side < 0 ? as[v] : -as[v];
        while (j > 0) {
            double kj = side < 0 ? as[zp[j - 1]] : -as[zp[j - 1]];
            if (kj < kv || (kj == kv && zp[j - 1] < v))
                break;
            zp[j] = zp[j - 1];
            --j;
        }
        zp[j] = v;
    }
}

/* Boundary of the face's part on one side: its face edges plus chords, traced into polygons. */
static pf_status trace_side(work *w, int32_t f, int32_t m, int32_t nz, int side, pf_error *err)
{
    int32_t *zp = w->zp;
    sort_zero_nodes(zp, nz, w->as, side);
    int flow = 0;
    for (int32_t i = 0; i < nz; ++i) {
        int32_t z = zp[i];
        int fin = w->es[(z + m - 1) % m] == side, fout = w->es[z] == side;
        w->zin[z] = (uint8_t)flow;
        flow += fin - fout;
        PF_CHECK(flow == 0 || flow == 1, err, PF_ERR_NUMERIC,
                 "split: face %d crosses the plane inconsistently (nodes within the tolerance "
                 "%g of the plane do not lie along one line)",
                 (int)f, w->tol);
        w->zout[z] = (uint8_t)flow;
        w->zto[z] = i + 1 < nz ? zp[i + 1] : -1;
        PF_CHECK(!flow || i + 1 < nz, err, PF_ERR_NUMERIC,
                 "split: face %d crosses the plane inconsistently", (int)f);
    }
    memset(w->visited, 0, (size_t)m);
    for (int32_t k = 0; k < m; ++k) {
        if (w->es[k] != side || w->visited[k])
            continue;
        int64_t start = (int64_t)(w->out.nodes.size / sizeof(uint32_t));
        int32_t cur = k, chord = 0, steps = 0;
        do {
            PF_CHECK(++steps <= m + nz + 1, err, PF_ERR_NUMERIC,
                     "split: face %d: the part on one side does not close", (int)f);
            PF_TRY(push(&w->out.nodes, &w->av[cur], sizeof(uint32_t), err));
            int32_t v;
            if (!chord) {
                w->visited[cur] = 1;
                v = (cur + 1) % m;
                if (w->ac[v] != 0)
                    chord = 0;
                else
                    chord = !(w->es[v] == side && !w->zin[v]);
            } else {
                v = w->zto[cur];
                chord = w->es[v] != side;
            }
            PF_CHECK(v >= 0 && (chord ? w->zout[v] == 1 : w->es[v] == side), err, PF_ERR_NUMERIC,
                     "split: face %d: the part on one side does not close", (int)f);
            cur = v;
        } while (chord || cur != k);
        /* emit the nodes just appended */
        int64_t end = (int64_t)(w->out.nodes.size / sizeof(uint32_t));
        int8_t s8 = (int8_t)side;
        uint8_t flat = 0;
        PF_CHECK(end - start >= 3, err, PF_ERR_NUMERIC, "split: face %d: a part has %lld nodes",
                 (int)f, (long long)(end - start));
        PF_TRY(push(&w->out.end, &end, sizeof end, err));
        PF_TRY(push(&w->out.source, &f, sizeof f, err));
        PF_TRY(push(&w->out.side, &s8, sizeof s8, err));
        PF_TRY(push(&w->out.flat, &flat, sizeof flat, err));
        w->out.n++;
    }
    return PF_OK;
}

static pf_status cut_face(work *w, int32_t f, pf_error *err)
{
    const pf_polyhedron *p = w->p;
    int64_t k0 = p->face_offsets[f], k1 = p->face_offsets[f + 1];
    int32_t n = (int32_t)(k1 - k0), m = 0, nz = 0;
    const uint32_t *fn = p->face_nodes + k0;
    pf_vec3 normal = pf_polygon_area_vector(p->x, fn, n);
    pf_vec3 u = pf_v3_cross(normal, w->pl.n); /* its left (normal x u) points below */
    for (int32_t i = 0; i < n; ++i) {
        uint32_t a = fn[i], b = fn[(i + 1) % n];
        w->av[m] = a;
        w->ac[m++] = w->cls[a];
        if (w->cls[a] * w->cls[b] < 0) {
            w->av[m] = new_node_on(w, a, b);
            w->ac[m++] = 0;
        }
    }
    for (int32_t k = 0; k < m; ++k) {
        if (w->ac[k] == 0) {
            w->as[k] = pf_v3_dot(u, pf_v3_load(w->x + 3 * (size_t)w->av[k]));
            w->zp[nz++] = k;
        }
    }
    for (int32_t k = 0; k < m; ++k) {
        int32_t k2 = (k + 1) % m;
        int sum = w->ac[k] + w->ac[k2];
        w->es[k] = (int8_t)(sum < 0 ? -1 : sum > 0 ? 1 : w->as[k2] > w->as[k] ? -1 : 1);
    }
    PF_TRY(trace_side(w, f, m, nz, -1, err));
    PF_TRY(trace_side(w, f, m, nz, 1, err));
    return PF_OK;
}

static pf_status split_faces(work *w, pf_error *err)
{
    const pf_polyhedron *p = w->p;
    int64_t max_n = 0;
    for (int32_t f = 0; f < p->n_faces; ++f)
        if (p->face_offsets[f + 1] - p->face_offsets[f] > max_n)
            max_n = p->face_offsets[f + 1] - p->face_offsets[f];
    int64_t m = 2 * max_n;
    PF_CHECK(PF_ALLOC_N(w->av, m) && PF_ALLOC_N(w->ac, m) && PF_ALLOC_N(w->es, m) &&
                 PF_ALLOC_N(w->as, m) && PF_ALLOC_N(w->zp, m) && PF_ALLOC_N(w->zin, m) &&
                 PF_ALLOC_N(w->zout, m) && PF_ALLOC_N(w->visited, m) && PF_ALLOC_N(w->zto, m),
             err, PF_ERR_NOMEM, "split: cannot allocate face scratch");
    for (int32_t f = 0; f < p->n_faces; ++f) {
        int64_t k0 = p->face_offsets[f], k1 = p->face_offsets[f + 1];
        int below = 0, above = 0;
        for (int64_t k = k0; k < k1; ++k) {
            below |= w->cls[p->face_nodes[k]] < 0;
            above |= w->cls[p->face_nodes[k]] > 0;
        }
        if (below && above) {
            PF_TRY(cut_face(w, f, err));
        } else if (below || above) {
            PF_TRY(emit(&w->out, p->face_nodes + k0, k1 - k0, f, above ? 1 : -1, 0, 0, err));
        } else {
            /* on the plane: the element lies opposite to the outward normal */
            pf_vec3 a = pf_polygon_area_vector(p->x, p->face_nodes + k0, k1 - k0);
            int side = pf_v3_dot(a, w->pl.n) > 0 ? -1 : 1;
            PF_TRY(emit(&w->out, p->face_nodes + k0, k1 - k0, f, side, 1, 0, err));
        }
    }
    return PF_OK;
}

/* ---- caps ------------------------------------------------------------------------------------ */

static int compare_pedge_key(const void *a, const void *b)
{
    const pedge *x = a, *y = b;
    if (x->key != y->key)
        return (x->key > y->key) - (x->key < y->key);
    if (x->side != y->side)
        return x->side - y->side;
    return (x->poly > y->poly) - (x->poly < y->poly);
}

pf_status pf_split_collect_edges(const work *w, int zero_only, pedge **out, int64_t *n_out,
                              pf_error *err)
{
    const uint32_t *nodes = BUF(w->out.nodes, uint32_t);
    const int8_t *side = BUF(w->out.side, int8_t);
    int64_t total = (int64_t)(w->out.nodes.size / sizeof(uint32_t)), n = 0;
    pedge *e = pf_alloc_array((size_t)total + 1, sizeof *e);
    PF_CHECK(e, err, PF_ERR_NOMEM, "split: cannot allocate %lld edges", (long long)total);
    for (int32_t i = 0; i < w->out.n; ++i) {
        int64_t b = poly_begin(&w->out, i), end = BUF(w->out.end, int64_t)[i];
        for (int64_t k = b; k < end; ++k) {
            uint32_t a = nodes[k], c = nodes[k + 1 < end ? k + 1 : b];
            if (zero_only && (w->cls[a] != 0 || w->cls[c] != 0))
                continue;
            e[n++] = (pedge){
                .key = edge_key(a, c), .poly = i, .dir = (int8_t)(a < c ? 1 : -1), .side = side[i]};
        }
    }
    *out = e;
    *n_out = n;
    return PF_OK;
}

/* Dihedral angle at the on-plane edge lo -> hi of input face f1, shared with face f2, both
 * leaving it into the half-space `side`: reflex when f2's farthest node off the plane lies on
 * the outer side of f1's plane. */
static int reflex_edge(const work *w, int32_t f1, int32_t f2, uint32_t a, int side)
{
    const pf_polyhedron *p = w->p;
    int64_t k0 = p->face_offsets[f1], k1 = p->face_offsets[f1 + 1];
    pf_vec3 n1 = pf_polygon_area_vector(p->x, p->face_nodes + k0, k1 - k0);
    int64_t best = -1;
    for (int64_t k = p->face_offsets[f2]; k < p->face_offsets[f2 + 1]; ++k) {
        uint32_t v = p->face_nodes[k];
        if (w->cls[v] == side &&
            (best < 0 || fabs(w->dist[v]) > fabs(w->dist[p->face_nodes[best]])))
            best = k;
    }
    if (best < 0)
        return 0;
    pf_vec3 d = pf_v3_sub(pf_v3_load(w->x + 3 * (size_t)p->face_nodes[best]),
                          pf_v3_load(w->x + 3 * (size_t)a));
    return pf_v3_dot(n1, d) > 0;
}

static pf_status append_edge(pf_buffer *b, uint32_t a, uint32_t c, pf_error *err)
{
    uint32_t e[2] = {a, c};
    return push(b, e, sizeof e, err);
}

static pf_status make_caps(work *w, pf_error *err)
{
    pedge *e = NULL;
    int64_t n = 0;
    PF_TRY(pf_split_collect_edges(w, 1, &e, &n, err));
    qsort(e, (size_t)n, sizeof *e, compare_pedge_key);
    const uint8_t *flat = BUF(w->out.flat, uint8_t);
    const int32_t *source = BUF(w->out.source, int32_t);
    pf_buffer edges = {0};       /* boundary edges of the cap below, uint32 pairs */
    pf_buffer constraints = {0}; /* interior edges, uint32 pairs (one direction) */
    int32_t *deg = pf_calloc((size_t)w->n_total, sizeof *deg);
    pf_status s = deg ? PF_OK
                      : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                     "split: cannot allocate node degrees");
    for (int64_t i = 0; i < n && s == PF_OK;) {
        int64_t j = i, net = 0;
        while (j < n && e[j].key == e[i].key) {
            if (e[j].side < 0)
                net += e[j].dir;
            ++j;
        }
        uint32_t lo = (uint32_t)(e[i].key >> 32), hi = (uint32_t)(e[i].key & 0xffffffffu);
        /* unmatched lo -> hi below: the cap below runs hi -> lo there */
        for (int64_t c = 0; c < (net < 0 ? -net : net) && s == PF_OK; ++c) {
            s = net > 0 ? append_edge(&edges, hi, lo, err) : append_edge(&edges, lo, hi, err);
            deg[lo]++, deg[hi]++;
        }
        if (j - i == 2 && e[i].side == e[i + 1].side && e[i].dir != e[i + 1].dir &&
            !flat[e[i].poly] && !flat[e[i + 1].poly] &&
            source[e[i].poly] != source[e[i + 1].poly]) {
            int32_t f1 = source[e[i].dir > 0 ? e[i].poly : e[i + 1].poly];
            int32_t f2 = source[e[i].dir > 0 ? e[i + 1].poly : e[i].poly];
            if (s == PF_OK && reflex_edge(w, f1, f2, lo, e[i].side)) {
                s = append_edge(&constraints, lo, hi, err);
                deg[lo]++, deg[hi]++;
            }
        }
        i = j;
    }
    /* an interior edge ending inside the region cuts nothing: drop dangling ones */
    uint32_t *cons = BUF(constraints, uint32_t);
    int64_t nc = (int64_t)(constraints.size / (2 * sizeof(uint32_t)));
    for (int changed = 1; changed && s == PF_OK;) {
        changed = 0;
        for (int64_t c = 0; c < nc; ++c) {
            uint32_t a = cons[2 * c], b = cons[2 * c + 1];
            if (a != b && (deg[a] == 1 || deg[b] == 1)) {
                deg[a]--, deg[b]--;
                cons[2 * c] = cons[2 * c + 1] = a; /* removed */
                changed = 1;
            }
        }
    }
    for (int64_t c = 0; c < nc && s == PF_OK; ++c)
        if (cons[2 * c] != cons[2 * c + 1]) {
            s = append_edge(&edges, cons[2 * c], cons[2 * c + 1], err);
            if (s == PF_OK)
                s = append_edge(&edges, cons[2 * c + 1], cons[2 * c], err);
        }
    int64_t *off = NULL;
    uint32_t *nodes = NULL;
    int32_t np = 0;
    if (s == PF_OK)
        s = pf_split_cap_polygons(w->x, w->pl.n, BUF(edges, uint32_t),
                                  (int64_t)(edges.size / (2 * sizeof(uint32_t))), &off, &nodes, &np,
                                  err);
    for (int side = -1; side <= 1 && s == PF_OK; side += 2)
        for (int32_t i = 0; i < np && s == PF_OK; ++i)
            s = emit(&w->out, nodes + off[i], off[i + 1] - off[i], -1, side, 0, side > 0, err);
    pf_free(off);
    pf_free(nodes);
    pf_free(deg);
    pf_free(e);
    pf_buffer_release(&edges);
    pf_buffer_release(&constraints);
    return s;
}

/* ---- result ---------------------------------------------------------------------------------- */

static pf_status fill_result(work *w, const int32_t *piece_of, int32_t n_pieces, pf_split *out,
                             pf_error *err)
{
    int32_t np = w->out.n;
    int64_t nn = (int64_t)(w->out.nodes.size / sizeof(uint32_t));
    out->n_pieces = n_pieces;
    out->n_faces = np;
    out->piece_side = pf_alloc_array((size_t)n_pieces + 1, 1);
    out->piece_faces = pf_calloc((size_t)n_pieces + 1, sizeof *out->piece_faces);
    out->face_offsets = pf_alloc_array((size_t)np + 1, sizeof *out->face_offsets);
    out->face_nodes = pf_alloc_array((size_t)nn + 1, sizeof *out->face_nodes);
    out->face_source = pf_alloc_array((size_t)np + 1, sizeof *out->face_source);
    int64_t *fill = pf_alloc_array((size_t)n_pieces + 1, sizeof *fill);
    int32_t *order = pf_alloc_array((size_t)np + 1, sizeof *order);
    if (!out->piece_side || !out->piece_faces || !out->face_offsets || !out->face_nodes ||
        !out->face_source || !fill || !order) {
        pf_free(fill), pf_free(order);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "split: cannot allocate the "
                            "result");
    }
    const int8_t *side = BUF(w->out.side, int8_t);
    for (int32_t i = 0; i < np; ++i) {
        out->piece_faces[piece_of[i] + 1]++;
        out->piece_side[piece_of[i]] = side[i];
    }
    for (int32_t k = 0; k < n_pieces; ++k)
        out->piece_faces[k + 1] += out->piece_faces[k];
    memcpy(fill, out->piece_faces, (size_t)n_pieces * sizeof *fill);
    for (int32_t i = 0; i < np; ++i)
        order[fill[piece_of[i]]++] = i;
    const uint32_t *nodes = BUF(w->out.nodes, uint32_t);
    const int32_t *source = BUF(w->out.source, int32_t);
    out->face_offsets[0] = 0;
    for (int32_t f = 0; f < np; ++f) {
        int32_t i = order[f];
        int64_t b = poly_begin(&w->out, i), end = BUF(w->out.end, int64_t)[i];
        memcpy(out->face_nodes + out->face_offsets[f], nodes + b,
               (size_t)(end - b) * sizeof *nodes);
        out->face_offsets[f + 1] = out->face_offsets[f] + (end - b);
        out->face_source[f] = source[i];
    }
    pf_free(fill);
    pf_free(order);
    out->x = w->x;
    w->x = NULL;
    out->node_class = w->cls;
    w->cls = NULL;
    out->n_nodes = w->n_total;
    out->n_input_nodes = w->n_in;
    out->tol = w->tol;
    return PF_OK;
}

static void work_release(work *w)
{
    pf_free(w->x);
    pf_free(w->dist);
    pf_free(w->cls);
    pf_free(w->cross);
    pf_free(w->av);
    pf_free(w->ac);
    pf_free(w->es);
    pf_free(w->as);
    pf_free(w->zp);
    pf_free(w->zin);
    pf_free(w->zout);
    pf_free(w->visited);
    pf_free(w->zto);
    polys_release(&w->out);
}

static pf_status run(work *w, bool assume_closed, pf_split *out, pf_error *err)
{
    if (!assume_closed)
        PF_TRY(check_closed(w->p, err));
    PF_TRY(classify(w, err));
    PF_TRY(make_new_nodes(w, out, err));
    PF_TRY(split_faces(w, err));
    PF_TRY(make_caps(w, err));
    int32_t *piece_of = pf_alloc_array((size_t)w->out.n + 1, sizeof *piece_of);
    PF_CHECK(piece_of, err, PF_ERR_NOMEM, "split: out of memory");
    int32_t n_pieces = 0;
    pf_status s = pf_split_find_pieces(w, piece_of, &n_pieces, err);
    if (s == PF_OK)
        s = fill_result(w, piece_of, n_pieces, out, err);
    pf_free(piece_of);
    return s;
}

/* The diagonal of the bounding box of the nodes the faces use (coordinates checked finite, so
 * plain comparisons give what fmin / fmax would). */
static double node_extent(const pf_polyhedron *p)
{
    int64_t k0 = p->face_offsets[0], k1 = p->face_offsets[p->n_faces];
    const double *first = p->x + 3 * (size_t)p->face_nodes[k0];
    double lo[3] = {first[0], first[1], first[2]}, hi[3] = {first[0], first[1], first[2]};
    for (int64_t k = k0 + 1; k < k1; ++k) {
        const double *q = p->x + 3 * (size_t)p->face_nodes[k];
        for (int c = 0; c < 3; ++c) {
            lo[c] = q[c] < lo[c] ? q[c] : lo[c];
            hi[c] = q[c] > hi[c] ? q[c] : hi[c];
        }
    }
    return pf_v3_dist(pf_v3_load(lo), pf_v3_load(hi));
}

/* Whether every node the faces use is at the same point (the bounding box has no extent). */
static bool all_nodes_equal(const pf_polyhedron *p)
{
    int64_t k0 = p->face_offsets[0], k1 = p->face_offsets[p->n_faces];
    const double *first = p->x + 3 * (size_t)p->face_nodes[k0];
    for (int64_t k = k0 + 1; k < k1; ++k) {
        const double *q = p->x + 3 * (size_t)p->face_nodes[k];
        if (q[0] != first[0] || q[1] != first[1] || q[2] != first[2])
            return false;
    }
    return true;
}

pf_status pf_poly_split(const pf_polyhedron *p, int32_t n_nodes, const pf_plane *plane,
                        const pf_split_params *params, pf_split *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    PF_TRY(check_input(p, n_nodes, plane, err));
    pf_split_params prm = params ? *params : pf_split_params_default();
    /* the extent sets a relative tolerance; with an absolute one, only its existence matters */
    double diag = prm.tol > 0 ? 0 : node_extent(p);
    bool extent = prm.tol > 0 ? !all_nodes_equal(p) : diag > 0;
    double rel = prm.rel_tol > 0 ? prm.rel_tol : 1e-10;
    work w = {.p = p, .n_in = n_nodes, .pl = *plane, .tol = prm.tol > 0 ? prm.tol : rel * diag};
    PF_CHECK(extent && isfinite(w.tol), err, PF_ERR_INVALID, "split: the polyhedron has no extent");
    pf_status s = run(&w, prm.assume_closed, out, err);
    work_release(&w);
    if (s != PF_OK)
        pf_split_release(out);
    return s;
}
