/* Penalty contact between the two sides of a crack (contact_crack.h; DG paper sec. 8 applied to
 * the faces a cut opened).
 *
 * Set-up, once per mesh (a cut or a refinement makes a new mesh, and the simulator a new crack):
 * the opened faces (group "cut", kept by pf_mesh_carry_face_label through later changes) are
 * listed with the compact rows of their vertices, and every node on them gets its twin faces by
 * their rest shape: opened faces of the other side (not holding the node itself: a node the
 * crack front left shared moves with both sides), in the plane of the node, facing a face at the
 * node (outward normals opposite), whose polygon holds the node. Both sides of an opened face
 * start coincident, so this holds after any sequence of cuts (the twins are found anew on each
 * mesh, tests/test_crack_contact.c checks every copied node finds one); a refinement that splits
 * one side's face and not the other's leaves each node inside its twin's polygon, so the rule
 * needs no twin to be the same polygon (not tested on a refined crack). The narrow phase is then
 * a lookup over a node's few twins, no search.
 *
 * Why the majorant (contact_crack.h): the exact stiffness k (a - b)(a - b)^T couples an element of
 * each side, which the method's pattern no longer has across the crack; adding the pairs (once
 * per mesh, from the twins) would give the factor back the fill the cut removed, and contact
 * keeps the method's pattern (as contact.c does). Since (a - b)(a - b)^T <=
 * 2 (a a^T + b b^T) (the difference is (a + b)(a + b)^T >= 0), the step's matrix is at least as
 * stiff as the exact linearisation (as contact.c's surface vertices), and stays in the pattern.
 * The forces are exact, so a resting state is the exact penalty's. The price is in the motion:
 * the excess k (a + b)(a + b)^T acts on the pair's common velocity along n, in the step
 * (M + (h beta + h^2)(K + C')) v' = M v + h (f - K u), as a dashpot of (beta + h) 2 k per point,
 * which is no force between the sides: a closed crack creeps to its rest (a compressed bar's
 * over seconds) and linear momentum along n is not conserved (tests/test_crack_contact.c
 * measures both). Cancelling the excess at the velocity before the step (its term on the
 * right-hand side) turns the dashpot into a mass of (beta h + h^2) 2 k per point instead: the
 * same bar then overshot its rest three times over. Only the exact term, which couples the two
 * sides in the pattern, is free of both: tried on DG (the pattern rebuilt once per mesh with every
 * point's element paired with its twins' elements, k (a - b)(a - b)^T added), the pattern grew by
 * 9 % (hexes) and 22 % (Kuhn tetrahedra) of its entries, the free body's momentum held to 5e-13
 * and the compressed bars came to rest within 0.2 % of the uncut tip instead of creeping. */
#include "contact_crack.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A point projecting outside its twin polygon by up to this fraction of the polygon's diameter
 * is still in contact with it: a node sits on the boundary of its twins, and slides a little
 * across it. */
#define OUTSIDE_TOLERANCE 0.05
/* Rest-shape twins: coplanar and containing within this fraction of the diameter (both sides
 * are copies of one polygon, equal to rounding). */
#define TWIN_TOLERANCE 1e-6
/* A gap counts as a penetration below -GAP_FLOOR model sizes: both sides of a fresh cut carry
 * the same field in frames of their own, equal to rounding. */
#define GAP_FLOOR 1e-12

/* Compact rows (method.h, point_row): offsets [n + 1], triple and w. */
typedef struct rows {
    int64_t *offsets;
    int64_t *triple;
    double *w;
} rows;

struct pf_crack {
    const pf_mesh *mesh;
    double stiffness;
    double floor;
    /* the opened faces: mesh face, element, outward sign for that element, rest diameter, and
     * their vertices (slots fv_offsets [nf + 1]) with one row each; per step the vertices'
     * predicted positions and the faces' outward unit normals */
    int32_t nf;
    int32_t *face, *face_elem;
    double *face_sign, *face_diam;
    int64_t *fv_offsets;
    rows fv;
    uint32_t *slot; /* [vertex slots] 0, 1, ...: the polygons' indices into fpos */
    double *fpos;
    pf_vec3 *fnormal;
    /* the points: rest position, share, row a; their candidate twins (cand_offsets [np + 1]) as
     * faces with the partner's row b */
    int32_t np;
    double *x0, *share;
    rows a;
    int64_t *cand_offsets;
    int32_t *cand_face;
    rows b;
    int32_t *triple_block;
    /* the last detection: point, candidate, normal; the one before, to tell changes */
    int64_t n_hits, n_prev;
    int64_t *hit_cand, *prev_cand;
    int32_t *hit_point;
    pf_vec3 *hit_normal;
    bool set_changed;
    pf_crack_stats stats;
};

/* ---- set-up ------------------------------------------------------------------------------ */

static pf_status alloc_rows(rows *r, int64_t n, int64_t cap, pf_error *err)
{
    r->offsets = pf_calloc((size_t)n + 1, sizeof *r->offsets);
    r->triple = pf_alloc_array((size_t)cap + 1, sizeof *r->triple);
    r->w = pf_alloc_array((size_t)cap + 1, sizeof *r->w);
    PF_CHECK(r->offsets && r->triple && r->w, err, PF_ERR_NOMEM,
             "cannot allocate %lld crack contact rows", (long long)n);
    return PF_OK;
}

static void free_rows(rows *r)
{
    pf_free(r->offsets), pf_free(r->triple), pf_free(r->w);
}

/* Row q of r: element e's field at x, sorted (pf_contact_add_row wants triples ascending). */
static void fill_row(rows *r, int64_t q, const pf_contact_setup *s, int32_t e, pf_vec3 x)
{
    int64_t o = r->offsets[q];
    int32_t n = s->ops->point_row(s->method, e, x, r->triple + o, r->w + o);
    sort_row(r->triple + o, r->w + o, n);
    r->offsets[q + 1] = o + n;
}

/* The opened faces of the mesh (boundary faces of group "cut"), their elements and rows. */
static pf_status list_faces(pf_crack *c, const pf_contact_setup *s, int32_t group, pf_error *err)
{
    const pf_mesh *m = s->mesh;
    int64_t nv = 0;
    for (int32_t f = 0; f < m->n_faces; ++f)
        if (m->face_group[f] == group &&
            (m->face_elems[2 * f] < 0) != (m->face_elems[2 * f + 1] < 0)) {
            c->nf++;
            nv += m->face_offsets[f + 1] - m->face_offsets[f];
        }
    c->face = pf_alloc_array((size_t)c->nf + 1, sizeof *c->face);
    c->face_elem = pf_alloc_array((size_t)c->nf + 1, sizeof *c->face_elem);
    c->face_sign = pf_alloc_array((size_t)c->nf + 1, sizeof *c->face_sign);
    c->face_diam = pf_alloc_array((size_t)c->nf + 1, sizeof *c->face_diam);
    c->fnormal = pf_alloc_array((size_t)c->nf + 1, sizeof *c->fnormal);
    c->fv_offsets = pf_calloc((size_t)c->nf + 1, sizeof *c->fv_offsets);
    c->slot = pf_alloc_array((size_t)nv + 1, sizeof *c->slot);
    c->fpos = pf_alloc_array(3 * (size_t)nv + 1, sizeof *c->fpos);
    PF_CHECK(c->face && c->face_elem && c->face_sign && c->face_diam && c->fnormal &&
                 c->fv_offsets && c->slot && c->fpos,
             err, PF_ERR_NOMEM, "cannot allocate %d opened faces", (int)c->nf);
    PF_TRY(alloc_rows(&c->fv, nv, nv * s->ops->max_point_row(s->method), err));
    int32_t k = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        bool stored = m->face_elems[2 * f] >= 0;
        if (m->face_group[f] != group || stored == (m->face_elems[2 * f + 1] >= 0))
            continue;
        int64_t o = m->face_offsets[f], len = m->face_offsets[f + 1] - o;
        c->face[k] = f;
        c->face_elem[k] = m->face_elems[2 * f + (stored ? 0 : 1)];
        c->face_sign[k] = stored ? 1 : -1;
        c->face_diam[k] = pf_polygon_diameter(m->x, m->face_nodes + o, len);
        for (int64_t j = 0; j < len; ++j) {
            int64_t q = c->fv_offsets[k] + j;
            c->slot[q] = (uint32_t)q;
            fill_row(&c->fv, q, s, c->face_elem[k],
                     pf_v3_load(m->x + 3 * (size_t)m->face_nodes[o + j]));
        }
        c->fv_offsets[k + 1] = c->fv_offsets[k] + len;
        ++k;
    }
    return PF_OK;
}

/* The signed distance in the plane (unit normal n) from p's projection to the boundary of the
 * polygon idx [len] of points x: positive inside (crossing number), negative outside. */
static double polygon_margin(const double *x, const uint32_t *idx, int64_t len, pf_vec3 n,
                             pf_vec3 p)
{
    pf_vec3 o = pf_v3_load(x + 3 * (size_t)idx[0]);
    pf_vec3 t1 = pf_v3_normalize(pf_v3_sub(pf_v3_load(x + 3 * (size_t)idx[1]), o));
    pf_vec3 t2 = pf_v3_cross(n, t1);
    pf_vec3 d = pf_v3_sub(p, o);
    double px = pf_v3_dot(d, t1), py = pf_v3_dot(d, t2), best = INFINITY;
    bool inside = false;
    for (int64_t j = 0; j < len; ++j) {
        pf_vec3 ea = pf_v3_sub(pf_v3_load(x + 3 * (size_t)idx[j]), o);
        pf_vec3 eb = pf_v3_sub(pf_v3_load(x + 3 * (size_t)idx[(j + 1) % len]), o);
        double ax = pf_v3_dot(ea, t1), ay = pf_v3_dot(ea, t2);
        double bx = pf_v3_dot(eb, t1), by = pf_v3_dot(eb, t2);
        if ((ay > py) != (by > py) && px < ax + (py - ay) * (bx - ax) / (by - ay))
            inside = !inside;
        double ex = bx - ax, ey = by - ay, ll = ex * ex + ey * ey;
        double t = ll > 0 ? fmin(fmax(((px - ax) * ex + (py - ay) * ey) / ll, 0), 1) : 0;
        best = fmin(best, hypot(px - ax - t * ex, py - ay - t * ey));
    }
    return inside ? best : -best;
}

/* The rest outward unit normal of opened face k. */
static pf_vec3 rest_normal(const pf_crack *c, int32_t k)
{
    const pf_mesh *m = c->mesh;
    int32_t f = c->face[k];
    int64_t o = m->face_offsets[f];
    pf_vec3 a = pf_polygon_area_vector(m->x, m->face_nodes + o, m->face_offsets[f + 1] - o);
    return pf_v3_scale(pf_v3_normalize(a), c->face_sign[k]);
}

static bool face_has_node(const pf_mesh *m, int32_t f, int32_t i)
{
    for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j)
        if ((int32_t)m->face_nodes[j] == i)
            return true;
    return false;
}

/* The twin faces of node i (node_faces: the opened faces at it, n_at of them), into out (NULL:
 * counted only). */
static int32_t twins_of(const pf_crack *c, int32_t i, const int32_t *node_faces, int32_t n_at,
                        int32_t *out)
{
    const pf_mesh *m = c->mesh;
    pf_vec3 x = pf_v3_load(m->x + 3 * (size_t)i);
    int32_t n = 0;
    for (int32_t g = 0; g < c->nf; ++g) {
        int32_t f = c->face[g];
        int64_t o = m->face_offsets[f], len = m->face_offsets[f + 1] - o;
        double tol = TWIN_TOLERANCE * c->face_diam[g];
        pf_vec3 ng = rest_normal(c, g);
        pf_vec3 cg = pf_v3_load(m->x + 3 * (size_t)m->face_nodes[o]);
        if (fabs(pf_v3_dot(ng, pf_v3_sub(x, cg))) > tol || face_has_node(m, f, i))
            continue;
        bool facing = false;
        for (int32_t q = 0; q < n_at && !facing; ++q)
            facing = pf_v3_dot(rest_normal(c, node_faces[q]), ng) < -0.99;
        if (!facing || polygon_margin(m->x, m->face_nodes + o, len, ng, x) < -tol)
            continue;
        if (out)
            out[n] = g;
        ++n;
    }
    return n;
}

/* Node -> opened faces at it (CSR over the nodes). */
static pf_status faces_at_nodes(const pf_crack *c, int64_t **offsets, int32_t **list, pf_error *err)
{
    const pf_mesh *m = c->mesh;
    *offsets = pf_calloc((size_t)m->n_nodes + 2, sizeof **offsets);
    *list = pf_alloc_array((size_t)c->fv_offsets[c->nf] + 1, sizeof **list);
    PF_CHECK(*offsets && *list, err, PF_ERR_NOMEM, "cannot allocate the crack's node faces");
    int64_t *o = *offsets;
    for (int32_t g = 0; g < c->nf; ++g)
        for (int64_t j = m->face_offsets[c->face[g]]; j < m->face_offsets[c->face[g] + 1]; ++j)
            o[m->face_nodes[j] + 2]++;
    for (int32_t i = 0; i < m->n_nodes; ++i)
        o[i + 2] += o[i + 1];
    for (int32_t g = 0; g < c->nf; ++g)
        for (int64_t j = m->face_offsets[c->face[g]]; j < m->face_offsets[c->face[g] + 1]; ++j)
            (*list)[o[m->face_nodes[j] + 1]++] = g;
    return PF_OK;
}

/* The points (a node on an opened face, once per element moving it) and their twins: counted
 * (pass 0), then filled (pass 1). */
static pf_status make_points(pf_crack *c, const pf_contact_setup *s, const int64_t *at,
                             const int32_t *at_list, pf_error *err)
{
    const pf_mesh *m = c->mesh;
    int64_t np = 0, nc = 0;
    for (int pass = 0; pass < 2; ++pass) {
        int32_t p = 0;
        int64_t q = 0;
        for (int32_t i = 0; i < m->n_nodes; ++i) {
            int32_t n_at = (int32_t)(at[i + 1] - at[i]);
            if (n_at == 0)
                continue;
            const int32_t *elems;
            int32_t ne = s->ops->node_elements(s->method, i, &elems);
            int32_t nt = twins_of(c, i, at_list + at[i], n_at, pass ? c->cand_face + q : NULL);
            if (nt == 0) { /* the crack front: the node moves with both sides */
                c->stats.unpaired += pass;
                continue;
            }
            pf_vec3 x = pf_v3_load(m->x + 3 * (size_t)i);
            for (int32_t e = 0; e < ne; ++e, ++p) {
                if (pass) {
                    pf_v3_store(x, c->x0 + 3 * (size_t)p);
                    c->share[p] = 1.0 / ne;
                    fill_row(&c->a, p, s, elems[e], x);
                    c->cand_offsets[p] = q;
                    if (e + 1 < ne) /* each element's point has the node's twins */
                        memcpy(c->cand_face + q + nt, c->cand_face + q,
                               (size_t)nt * sizeof(int32_t));
                    for (int32_t t = 0; t < nt; ++t)
                        fill_row(&c->b, q + t, s, c->face_elem[c->cand_face[q + t]], x);
                }
                q += nt;
            }
        }
        if (pass == 0) {
            np = p, nc = q;
            PF_CHECK(np < INT32_MAX, err, PF_ERR_TOO_LARGE, "%lld crack points are too many",
                     (long long)np);
            c->np = (int32_t)np;
            int64_t longest = s->ops->max_point_row(s->method);
            c->x0 = pf_alloc_array(3 * (size_t)np + 1, sizeof *c->x0);
            c->share = pf_alloc_array((size_t)np + 1, sizeof *c->share);
            c->cand_offsets = pf_calloc((size_t)np + 1, sizeof *c->cand_offsets);
            c->cand_face = pf_alloc_array((size_t)nc + 1, sizeof *c->cand_face);
            PF_CHECK(c->x0 && c->share && c->cand_offsets && c->cand_face, err, PF_ERR_NOMEM,
                     "cannot allocate %lld crack points", (long long)np);
            PF_TRY(alloc_rows(&c->a, np, np * longest, err));
            PF_TRY(alloc_rows(&c->b, nc, nc * longest, err));
        } else {
            c->cand_offsets[np] = nc;
        }
    }
    return PF_OK;
}

static pf_status allocate_hits(pf_crack *c, const pf_contact_setup *s, pf_error *err)
{
    size_t np = (size_t)c->np + 1, nt = (size_t)s->n_triples + 1;
    c->hit_cand = pf_alloc_array(np, sizeof *c->hit_cand);
    c->prev_cand = pf_alloc_array(np, sizeof *c->prev_cand);
    c->hit_point = pf_alloc_array(np, sizeof *c->hit_point);
    c->hit_normal = pf_alloc_array(np, sizeof *c->hit_normal);
    c->triple_block = pf_calloc(nt, sizeof *c->triple_block);
    PF_CHECK(c->hit_cand && c->prev_cand && c->hit_point && c->hit_normal && c->triple_block, err,
             PF_ERR_NOMEM, "cannot allocate the crack's contacts");
    for (int32_t b = 0; b < s->n_blocks; ++b)
        for (int64_t u = s->block_start[b]; u < s->block_start[b + 1]; u += 3)
            c->triple_block[u / 3] = b;
    return PF_OK;
}

pf_status pf_crack_create(pf_crack **out, const pf_contact_setup *s, pf_error *err)
{
    *out = NULL;
    const pf_mesh *m = s->mesh;
    const pf_mesh_group *g = m->face_group ? pf_mesh_find_group(m, 2, "cut", 0) : NULL;
    if (!g || s->scene->is_static)
        return PF_OK;
    pf_crack *c = pf_calloc(1, sizeof *c);
    PF_CHECK(c, err, PF_ERR_NOMEM, "cannot allocate the crack's contact");
    c->mesh = m;
    c->stiffness = s->scene->ground_stiffness > 0 ? s->scene->ground_stiffness : s->auto_stiffness;
    c->floor = GAP_FLOOR * s->model_size;
    int64_t *at = NULL;
    int32_t *at_list = NULL;
    pf_status st = list_faces(c, s, g->number, err);
    if (st >= 0 && c->nf > 0)
        st = faces_at_nodes(c, &at, &at_list, err);
    if (st >= 0 && c->nf > 0)
        st = make_points(c, s, at, at_list, err);
    if (st >= 0 && c->nf > 0)
        st = allocate_hits(c, s, err);
    pf_free(at), pf_free(at_list);
    if (st < 0 || c->np == 0) {
        pf_crack_destroy(&c);
        return st < 0 ? st : PF_OK;
    }
    c->stats.faces = c->nf;
    c->stats.points = c->np;
    c->stats.stiffness = c->stiffness;
    for (int32_t p = 0; p < c->np; ++p)
        c->stats.nodes += c->share[p];
    *out = c;
    return PF_OK;
}

void pf_crack_destroy(pf_crack **cp)
{
    pf_crack *c = *cp;
    if (!c)
        return;
    void *arrays[] = {c->face,         c->face_elem, c->face_sign,    c->face_diam, c->fv_offsets,
                      c->slot,         c->fpos,      c->fnormal,      c->x0,        c->share,
                      c->cand_offsets, c->cand_face, c->triple_block, c->hit_cand,  c->prev_cand,
                      c->hit_point,    c->hit_normal};
    for (size_t k = 0; k < sizeof arrays / sizeof *arrays; ++k)
        pf_free(arrays[k]);
    free_rows(&c->fv), free_rows(&c->a), free_rows(&c->b);
    pf_free(c);
    *cp = NULL;
}

/* ---- each step --------------------------------------------------------------------------- */

/* w^T (u + h v) over row q of r (v NULL: w^T u). */
static pf_vec3 row_mul(const rows *r, int64_t q, const double *u, const double *v, double h)
{
    double s[3] = {0, 0, 0};
    for (int64_t k = r->offsets[q]; k < r->offsets[q + 1]; ++k) {
        const double *ut = u + 3 * r->triple[k];
        for (int d = 0; d < 3; ++d)
            s[d] += r->w[k] * (v ? ut[d] + h * v[3 * r->triple[k] + d] : ut[d]);
    }
    return pf_v3_load(s);
}

int64_t pf_crack_detect(pf_crack *c, const double *u, const double *v, double h)
{
    const pf_mesh *m = c->mesh;
    /* the opened faces where u + h v puts them */
    for (int32_t g = 0; g < c->nf; ++g) {
        int32_t f = c->face[g];
        for (int64_t q = c->fv_offsets[g]; q < c->fv_offsets[g + 1]; ++q) {
            int64_t j = m->face_offsets[f] + (q - c->fv_offsets[g]);
            pf_vec3 x = pf_v3_add(pf_v3_load(m->x + 3 * (size_t)m->face_nodes[j]),
                                  row_mul(&c->fv, q, u, v, h));
            pf_v3_store(x, c->fpos + 3 * q);
        }
        int64_t o = c->fv_offsets[g];
        pf_vec3 a = pf_polygon_area_vector(c->fpos, c->slot + o, c->fv_offsets[g + 1] - o);
        c->fnormal[g] = pf_v3_scale(pf_v3_normalize(a), c->face_sign[g]);
    }
    int64_t *swap = c->prev_cand;
    c->prev_cand = c->hit_cand;
    c->hit_cand = swap;
    c->n_prev = c->n_hits;
    c->n_hits = 0;
    c->stats.max_depth = 0;
    for (int32_t p = 0; p < c->np; ++p) {
        pf_vec3 x0 = pf_v3_load(c->x0 + 3 * (size_t)p);
        pf_vec3 xp = pf_v3_add(x0, row_mul(&c->a, p, u, v, h));
        /* the twin the point lies deepest inside of (in projection) */
        int64_t best = -1;
        double margin = -INFINITY;
        for (int64_t q = c->cand_offsets[p]; q < c->cand_offsets[p + 1]; ++q) {
            int32_t g = c->cand_face[q];
            int64_t o = c->fv_offsets[g];
            double d =
                polygon_margin(c->fpos, c->slot + o, c->fv_offsets[g + 1] - o, c->fnormal[g], xp) /
                c->face_diam[g];
            if (d > margin)
                margin = d, best = q;
        }
        if (best < 0 || margin < -OUTSIDE_TOLERANCE)
            continue;
        /* in contact when penetrating now or at the predicted end of the step: a point that
         * penetrates but moves out would otherwise leave the set for a step, fall back in and
         * chatter with a period of two steps (a closed crack under load did, 5x deeper than the
         * penalty's depth, whatever its stiffness) */
        pf_vec3 n = c->fnormal[c->cand_face[best]];
        double gap = pf_v3_dot(n, pf_v3_sub(xp, pf_v3_add(x0, row_mul(&c->b, best, u, v, h))));
        gap = fmin(gap, pf_v3_dot(n, pf_v3_sub(row_mul(&c->a, p, u, NULL, 0),
                                               row_mul(&c->b, best, u, NULL, 0))));
        if (!(gap < -c->floor))
            continue;
        c->stats.max_depth = fmax(c->stats.max_depth, -gap);
        c->hit_point[c->n_hits] = p;
        c->hit_normal[c->n_hits] = n;
        c->hit_cand[c->n_hits++] = best;
    }
    c->set_changed = c->n_hits != c->n_prev ||
                     memcmp(c->hit_cand, c->prev_cand, (size_t)c->n_hits * sizeof *c->hit_cand);
    return c->n_hits;
}

/* f += s w (x) F over row q of r. */
static void row_add(const rows *r, int64_t q, double s, pf_vec3 force, double *f)
{
    for (int64_t k = r->offsets[q]; k < r->offsets[q + 1]; ++k) {
        double *ft = f + 3 * r->triple[k], w = s * r->w[k];
        ft[0] += w * force.x;
        ft[1] += w * force.y;
        ft[2] += w * force.z;
    }
}

void pf_crack_forces(const pf_crack *c, const double *u, double *f)
{
    for (int64_t e = 0; e < c->n_hits; ++e) {
        int32_t p = c->hit_point[e];
        int64_t q = c->hit_cand[e];
        pf_vec3 n = c->hit_normal[e];
        /* g = n . (a - b)^T u: the rest positions coincide */
        double gap =
            pf_v3_dot(n, pf_v3_sub(row_mul(&c->a, p, u, NULL, 0), row_mul(&c->b, q, u, NULL, 0)));
        pf_vec3 force = pf_v3_scale(n, -c->stiffness * c->share[p] * gap);
        row_add(&c->a, p, 1, force, f);
        row_add(&c->b, q, -1, force, f);
    }
}

void pf_crack_add_stiffness(const pf_crack *c, double alpha, pf_block_matrix *k)
{
    for (int64_t e = 0; e < c->n_hits; ++e) {
        int32_t p = c->hit_point[e];
        int64_t q = c->hit_cand[e];
        double a = 2 * alpha * c->stiffness * c->share[p];
        pf_vec3 n = c->hit_normal[e];
        int64_t ao = c->a.offsets[p], bo = c->b.offsets[q];
        pf_contact_add_row(k, c->triple_block, c->a.triple + ao, c->a.w + ao,
                           c->a.offsets[p + 1] - ao, n, a);
        pf_contact_add_row(k, c->triple_block, c->b.triple + bo, c->b.w + bo,
                           c->b.offsets[q + 1] - bo, n, a);
    }
}

bool pf_crack_set_changed(const pf_crack *c)
{
    return c->set_changed;
}

int64_t pf_crack_count(const pf_crack *c)
{
    return c->n_hits;
}

const pf_crack_stats *pf_crack_get_stats(const pf_crack *c)
{
    return &c->stats;
}
