/* MLS embedding (DG paper sec. 7, eq. 31-32): per surface vertex, the weights of the affine
 * moving-least-squares fit to the nodes in its support. */
#include "mls_internal.h"

#include <string.h>

pf_status pf_embed_mls_radii(const pf_mesh *m, const pf_embed_params *params, double *radius,
                             pf_error *err)
{
    pf_embed_params p;
    PF_TRY(pf_embed_resolve_params(params, &p, err));
    for (int32_t i = 0; i < m->n_nodes; ++i)
        radius[i] = 0;
    double longest = 0;
    /* every edge of every face: the node spacing is the longest edge at the node (one ring) */
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int64_t o = m->face_offsets[f], n = m->face_offsets[f + 1] - o;
        for (int64_t k = 0; k < n; ++k) {
            uint32_t a = m->face_nodes[o + k], b = m->face_nodes[o + (k + 1) % n];
            double len = pf_v3_dist(pf_v3_load(m->x + 3 * (size_t)a),
                                    pf_v3_load(m->x + 3 * (size_t)b));
            radius[a] = fmax(radius[a], len);
            radius[b] = fmax(radius[b], len);
            longest = fmax(longest, len);
        }
    }
    PF_CHECK(longest > 0, err, PF_ERR_INVALID, "the mesh has no edge of positive length");
    for (int32_t i = 0; i < m->n_nodes; ++i)
        radius[i] = p.support * (radius[i] > 0 ? radius[i] : longest);
    return PF_OK;
}

/* The kernel at q^2 = (|x - x_i| / R_i)^2 < 1: the Gaussian exp(-s q^2) minus its first-order
 * expansion in q^2 about q = 1, so value and slope vanish at the radius (C1 truncation), divided
 * by its value at 0. */
static double kernel(double q2, double s)
{
    double es = exp(-s);
    return (exp(-s * q2) - es * (1 + s * (1 - q2))) / (1 - es * (1 + s));
}

static void support_release(mls_support *s)
{
    pf_free(s->col);
    pf_free(s->d);
    pf_free(s->theta);
    pf_free(s->val);
    memset(s, 0, sizeof *s);
}

static pf_status support_push(mls_support *s, uint32_t node, pf_vec3 d, double theta, pf_error *err)
{
    if (s->n == s->cap) {
        int32_t cap = s->cap ? 2 * s->cap : 128;
        uint32_t *c = pf_realloc_array(s->col, (size_t)cap, sizeof *c);
        if (c)
            s->col = c;
        double *dd = c ? pf_realloc_array(s->d, 3 * (size_t)cap, sizeof *dd) : NULL;
        if (dd)
            s->d = dd;
        double *t = dd ? pf_realloc_array(s->theta, (size_t)cap, sizeof *t) : NULL;
        if (t)
            s->theta = t;
        double *v = t ? pf_realloc_array(s->val, (size_t)cap, sizeof *v) : NULL;
        if (v)
            s->val = v;
        PF_CHECK(v, err, PF_ERR_NOMEM, "out of memory for an MLS support of %d nodes", (int)cap);
        s->cap = cap;
    }
    s->col[s->n] = node;
    pf_v3_store(d, s->d + 3 * (size_t)s->n);
    s->theta[s->n] = theta;
    s->n++;
    return PF_OK;
}

/* Near a cut, the visible support of a vertex may be truncated to a few nodes on one side of
 * it; the affine fit then still reproduces affine fields but extrapolates: sum |W_i| grows, and
 * with it the error on any non-affine motion (a bent or separating body) and on the DG
 * displacement's jumps. Element shape functions have sum |W_i| = 1 inside a convex element;
 * uncut MLS rows (support 2) stay well below 2: the sliced bunny's surface (pf-slice --res 8,
 * vertices on the mesh's boundary) has median 1.08 and largest 1.45, a sphere inside a hex grid
 * 1.00. A truncated fit with more than twice the amplification of an interpolation is not
 * used: the vertex takes its host element's own weights. */
#define MLS_MAX_AMPLIFICATION 2.0

static pf_status consider(mls_context *c, int32_t node, pf_vec3 x, double scale, pf_error *err)
{
    pf_vec3 xi = pf_v3_load(c->m->x + 3 * (size_t)node);
    pf_vec3 d = pf_v3_sub(xi, x);
    double r = scale * c->radius[node];
    double q2 = pf_v3_dot(d, d) / (r * r);
    if (q2 >= 1)
        return PF_OK;
    if (c->use_vis && (!pf_visibility_same_body(&c->vis, c->vis.elem_body[c->host], node) ||
                       pf_visibility_blocked(&c->vis, c->seen_from, node, xi))) {
        c->hidden++;
        return PF_OK;
    }
    return support_push(&c->s, (uint32_t)node, d, kernel(q2, c->p->sharpness), err);
}

/* Insertion sort of the support by node (grown supports come cell by cell; scale 1 ones are
 * already in order): the fit's sums then run in an order that depends on the support alone. */
static void sort_support(mls_support *s)
{
    for (int32_t i = 1; i < s->n; ++i) {
        uint32_t col = s->col[i];
        if (s->col[i - 1] < col)
            continue;
        double d[3] = {s->d[3 * (size_t)i], s->d[3 * (size_t)i + 1], s->d[3 * (size_t)i + 2]};
        double theta = s->theta[i];
        int32_t k = i;
        for (; k > 0 && s->col[k - 1] > col; --k) {
            s->col[k] = s->col[k - 1];
            memcpy(s->d + 3 * (size_t)k, s->d + 3 * (size_t)(k - 1), 3 * sizeof *s->d);
            s->theta[k] = s->theta[k - 1];
        }
        s->col[k] = col;
        memcpy(s->d + 3 * (size_t)k, d, sizeof d);
        s->theta[k] = theta;
    }
}

/* The offsets over the row's own length scale, the largest scaled radius of its support (a
 * quantity of the support alone, so that a change of the mesh elsewhere leaves the row's bits). */
static void normalise_support(mls_context *c, double scale)
{
    mls_support *s = &c->s;
    double rho = 0;
    for (int32_t i = 0; i < s->n; ++i)
        rho = fmax(rho, scale * c->radius[s->col[i]]);
    if (!(rho > 0))
        return;
    for (int32_t i = 0; i < s->n; ++i)
        pf_v3_store(pf_v3_scale(pf_v3_load(s->d + 3 * (size_t)i), 1.0 / rho),
                    s->d + 3 * (size_t)i);
}

/* The support grid (every node's box of half side its radius), and r_max. */
static pf_status build_supports(mls_context *c, pf_error *err)
{
    const pf_mesh *m = c->m;
    double *box = NULL;
    PF_CHECK(PF_ALLOC_N(box, 6 * (size_t)m->n_nodes), err, PF_ERR_NOMEM,
             "out of memory for %d node boxes", (int)m->n_nodes);
    double mean = 0;
    for (int32_t i = 0; i < m->n_nodes; ++i) {
        double r = c->radius[i];
        mean += r;
        c->r_max = fmax(c->r_max, r);
        for (int a = 0; a < 3; ++a) {
            box[6 * (size_t)i + a] = m->x[3 * (size_t)i + a] - r;
            box[6 * (size_t)i + 3 + a] = m->x[3 * (size_t)i + a] + r;
        }
    }
    c->mean_radius = mean / m->n_nodes;
    pf_status st = pf_bucket_grid_build(&c->supports, box, m->n_nodes, c->mean_radius, err);
    pf_free(box);
    return st;
}

/* The point grid, built by the first grown support (few vertices need one). */
static pf_status build_points(mls_context *c, pf_error *err)
{
    const pf_mesh *m = c->m;
    double *box = NULL;
    PF_CHECK(PF_ALLOC_N(box, 6 * (size_t)m->n_nodes), err, PF_ERR_NOMEM,
             "out of memory for %d node boxes", (int)m->n_nodes);
    for (int32_t i = 0; i < m->n_nodes; ++i)
        for (int a = 0; a < 3; ++a)
            box[6 * (size_t)i + a] = box[6 * (size_t)i + 3 + a] = m->x[3 * (size_t)i + a];
    pf_status st = pf_bucket_grid_build(&c->points, box, m->n_nodes, c->mean_radius, err);
    pf_free(box);
    c->points_built = st >= 0;
    return st;
}

/* The nodes whose (scaled) support holds x, in the order of their indices: at scale 1 the
 * candidates of x's cell of the support grid; grown, every cell of the point grid within
 * scale * r_max. */
typedef struct gather_query {
    mls_context *c;
    pf_vec3 x;
    double scale;
    pf_error *err;
} gather_query;

static int consider_item(void *ctx, int32_t node)
{
    gather_query *q = ctx;
    return consider(q->c, node, q->x, q->scale, q->err);
}

static pf_status gather(mls_context *c, pf_vec3 x, double scale, pf_error *err)
{
    c->s.n = 0;
    c->hidden = 0;
    if (scale != 1 && !c->points_built)
        PF_TRY(build_points(c, err));
    gather_query q = {c, x, scale, err};
    const bucket_grid *g = scale == 1 ? &c->supports : &c->points;
    int st = pf_bucket_grid_visit(g, x, scale == 1 ? 0 : scale * c->r_max, consider_item, &q);
    if (st < 0)
        return (pf_status)st;
    sort_support(&c->s);
    normalise_support(c, scale);
    return PF_OK;
}

static double amplification(const double *w, int32_t n)
{
    double sum = 0;
    for (int32_t i = 0; i < n; ++i)
        sum += fabs(w[i]);
    return sum;
}

/* The host element's own weights (its nodes are of the vertex's body and side). */
static pf_status host_row(mls_context *c, int32_t v, pf_vec3 x, int32_t *n,
                          pf_embed_stats *stats, pf_error *err)
{
    bool fallback;
    PF_CHECK(pf_embed_elem_weights(c->m, c->L, c->host, x, c->elem_col, c->elem_val, c->elem_tmp,
                                   n, &fallback),
             err, PF_ERR_NUMERIC, "surface vertex %d: no usable weights in its element %d", (int)v,
             (int)c->host);
    stats->n_fallback++;
    return PF_OK;
}

double pf_mls_scale(const pf_embed_params *p, int32_t step)
{
    double scale = 1;
    for (int32_t k = 0; k < step; ++k)
        scale *= p->growth;
    return scale;
}

/* One vertex: grow the supports until the fit is well conditioned. With blocking faces, a
 * vertex whose support lost nodes to them (or to another body) and is then too flat, too small
 * or extrapolates (MLS_MAX_AMPLIFICATION) takes its host element's weights instead: growing
 * the support would reach around the cut's front or rim to nodes that do not move with it. */
pf_status pf_mls_row(mls_context *c, int32_t v, pf_vec3 x, uint32_t **col, double **val,
                     int32_t *n, int32_t *step, pf_embed_stats *stats, pf_error *err)
{
    double scale = 1;
    for (*step = 0;; ++*step) {
        if (c->use_vis) {
            pf_visibility_gather(&c->vis, x, scale * c->r_max);
            c->seen_from = c->p->vertex_side
                               ? pf_visibility_nudge(&c->vis, x,
                                                     pf_v3_load(c->p->vertex_side + 3 * (size_t)v))
                               : x;
            double dist;
            if (*step == 0)
                c->host = pf_locator_find(c->L, c->seen_from, &dist);
        }
        PF_TRY(gather(c, x, scale, err));
        bool fit = pf_affine_fit_weights(c->s.d, c->s.theta, c->s.n, c->p->min_spread, c->s.val);
        if (fit && (c->hidden == 0 || amplification(c->s.val, c->s.n) <= MLS_MAX_AMPLIFICATION))
            break;
        if (c->hidden > 0) {
            *step = 0;
            *col = c->elem_col;
            *val = c->elem_val;
            return host_row(c, v, x, n, stats, err);
        }
        PF_CHECK(*step < c->p->max_growth, err, PF_ERR_NUMERIC,
                 "surface vertex %d: the MLS support holds %d nodes, too few or too flat for an "
                 "affine fit even at %g times the radius",
                 (int)v, (int)c->s.n, scale);
        scale *= c->p->growth;
    }
    if (scale > 1)
        stats->n_grown++;
    *col = c->s.col;
    *val = c->s.val;
    *n = c->s.n;
    return PF_OK;
}

void pf_mls_release(mls_context *c)
{
    support_release(&c->s);
    pf_free(c->elem_col);
    pf_free(c->elem_val);
    pf_free(c->elem_tmp);
    pf_visibility_release(&c->vis);
    pf_bucket_grid_release(&c->supports);
    pf_bucket_grid_release(&c->points);
    pf_free(c->radius);
    memset(c, 0, sizeof *c);
}

pf_status pf_mls_init(mls_context *c, const pf_mesh *m, const pf_embed_params *p, locator *L,
                      pf_error *err)
{
    memset(c, 0, sizeof *c);
    c->m = m;
    c->p = p;
    c->L = L;
    PF_CHECK(PF_ALLOC_N(c->radius, (size_t)m->n_nodes), err, PF_ERR_NOMEM,
             "out of memory for %d radii", (int)m->n_nodes);
    PF_TRY(pf_embed_mls_radii(m, p, c->radius, err));
    PF_TRY(build_supports(c, err));
    if (!p->blocking_faces)
        return PF_OK;
    c->use_vis = true;
    PF_TRY(pf_visibility_build(&c->vis, m, p->blocking_faces, err));
    size_t cap = (size_t)(L->geo.max_nodes > 8 ? L->geo.max_nodes : 8);
    PF_CHECK(PF_ALLOC_N(c->elem_col, cap) && PF_ALLOC_N(c->elem_val, cap) &&
                 PF_ALLOC_N(c->elem_tmp, 4 * cap),
             err, PF_ERR_NOMEM, "out of memory for element weights of %d nodes", (int)cap);
    return PF_OK;
}

pf_status pf_embed_mls(const pf_mesh *m, const pf_surface *s, const pf_embed_params *p,
                       locator *L, row_builder *b, int32_t *steps, pf_embed_stats *stats,
                       pf_error *err)
{
    mls_context c;
    pf_status st = pf_mls_init(&c, m, p, L, err);
    for (int32_t v = 0; v < s->n_verts && st >= 0; ++v) {
        pf_vec3 x = pf_v3_load(s->x + 3 * (size_t)v);
        double dist;
        int32_t e = pf_locator_find(L, x, &dist);
        stats->n_by_kind[L->geo.kind[e]]++;
        if (dist > L->tol) {
            stats->n_outside++;
            stats->max_outside = fmax(stats->max_outside, dist);
        }
        uint32_t *col;
        double *val;
        int32_t n, step;
        st = pf_mls_row(&c, v, x, &col, &val, &n, &step, stats, err);
        if (st >= 0)
            st = pf_row_builder_add(b, v, col, val, n, err);
        if (steps)
            steps[v] = step;
    }
    pf_mls_release(&c);
    return st;
}
