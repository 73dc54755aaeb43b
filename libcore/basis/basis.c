/* Nodal shape functions per element: closed forms (tet, parallelepiped hex) and harmonic
 * coordinates by the method of fundamental solutions (harmonic paper sec. 4-5, eq. 11-14): their
 * construction (or their copy from a changed mesh's old functions) and statistics; the summary
 * is summary.c. The MFS polynomial part is the linear polynomial of eq. 11
 * plus the harmonic polynomials of degree 2 and 3 (a departure from the paper, explained in
 * pf/basis.h: the smooth part of the boundary data no longer needs kernels). Element data
 * layouts: basis_internal.h; evaluation: eval.c.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "basis_internal.h"

const char *pf_basis_kind_name(pf_basis_kind k)
{
    switch (k) {
    case PF_BASIS_TET:
        return "tet";
    case PF_BASIS_HEX:
        return "hex";
    case PF_BASIS_HARMONIC:
        return "harmonic";
    default:
        return "unknown";
    }
}

pf_basis_params pf_basis_params_default(void)
{
    pf_basis_params p = {0};
    p.xi = 0.1;
    p.edge_samples = 2;
    p.collocation_density = 3;
    p.face_spacing = 1;
    p.parallel_tol = 1e-9;
    p.merge_tol = 1e-9;
    p.rank_rcond = 1e-13;
    p.sliced = PF_BASIS_SLICED_AUTO;
    p.sliced_xi = 0.2;
    p.grading = 0.2;
    p.patch_angle = 60;
    p.max_kernels = PF_BASIS_DEFAULT_MAX_KERNELS;
    return p;
}

pf_basis_params pf_basis_params_accurate(void)
{
    pf_basis_params p = pf_basis_params_default();
    p.sliced = PF_BASIS_SLICED_ALL;
    p.xi = 0.2;
    p.max_kernels = -1;
    return p;
}

pf_basis_params pf_basis_params_uniform(void)
{
    pf_basis_params p = pf_basis_params_default();
    p.sliced = PF_BASIS_SLICED_OFF;
    return p;
}

static pf_basis_params fill_defaults(const pf_basis_params *in)
{
    pf_basis_params d = pf_basis_params_default(), p = in ? *in : d;
    if (!(p.xi > 0))
        p.xi = d.xi;
    if (p.edge_samples <= 0)
        p.edge_samples = d.edge_samples;
    if (!(p.face_spacing > 0))
        p.face_spacing = d.face_spacing;
    if (!(p.collocation_density >= 1))
        p.collocation_density = d.collocation_density;
    if (!(p.parallel_tol > 0))
        p.parallel_tol = d.parallel_tol;
    if (!(p.merge_tol > 0))
        p.merge_tol = d.merge_tol;
    if (!(p.rank_rcond > 0))
        p.rank_rcond = d.rank_rcond;
    if (p.sliced != PF_BASIS_SLICED_ALL && p.sliced != PF_BASIS_SLICED_OFF)
        p.sliced = PF_BASIS_SLICED_AUTO;
    if (!(p.sliced_xi > 0))
        p.sliced_xi = d.sliced_xi;
    if (!(p.grading > 0))
        p.grading = d.grading;
    if (!(p.patch_angle > 0))
        p.patch_angle = d.patch_angle;
    if (p.max_kernels == 0)
        p.max_kernels = d.max_kernels;
    return p;
}

/* ---- element context ---------------------------------------------------------------------------
 */

/* Ray parity against the element's faces (a fixed direction with no simple ratios, so a ray
 * through an edge or a vertex has probability zero for the points we test). */
static bool elem_contains(const elem_ctx *c, pf_vec3 q)
{
    const pf_vec3 dir = {0.5427189, 0.3169312, 0.7778174};
    int cross = 0;
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        const face_fn *f = &c->faces[c->face_id[lf]];
        double den = pf_v3_dot(dir, f->nrm);
        if (fabs(den) < 1e-14)
            continue;
        double t = pf_v3_dot(pf_v3_sub(f->o, q), f->nrm) / den;
        if (t <= 0)
            continue;
        double pu, pv;
        face_coords(f, pf_v3_add(q, pf_v3_scale(dir, t)), &pu, &pv);
        cross += pf_polygon_contains(f->p2, f->n, pu, pv);
    }
    return cross & 1;
}

/* Whether q lies within dist of the element's boundary. Faces whose plane is dist or more away
 * are skipped before the in-plane distance (most faces, for a kernel near one face). */
static bool elem_boundary_within(const elem_ctx *c, pf_vec3 q, double dist)
{
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        const face_fn *f = &c->faces[c->face_id[lf]];
        double dp = pf_v3_dot(pf_v3_sub(q, f->o), f->nrm);
        if (fabs(dp) >= dist)
            continue;
        double pu, pv;
        face_coords(f, q, &pu, &pv);
        double din = pf_polygon_contains(f->p2, f->n, pu, pv)
                         ? 0
                         : pf_polygon_boundary_distance(f->p2, f->n, pu, pv) * f->s;
        if (dp * dp + din * din < dist * dist)
            return true;
    }
    return false;
}

static int32_t local_index(const elem_ctx *c, int32_t node)
{
    for (int32_t i = 0; i < c->k; ++i)
        if (c->nodes[i] == node)
            return i;
    return -1;
}

/* Faces, distinct nodes, groups of coincident nodes, edges, frame of element e. */
static pf_status elem_setup(elem_ctx *c, const pf_basis_params *p, basis_ws *w, pf_error *err)
{
    const pf_mesh *m = c->m;
    int32_t e = c->e;
    int64_t f0 = m->elem_offsets[e], f1 = m->elem_offsets[e + 1];
    c->nf = (int32_t)(f1 - f0);
    PF_CHECK(c->nf >= 4, err, PF_ERR_INVALID, "element %d has %d faces", (int)e, (int)c->nf);
    int64_t nfn = 0;
    for (int64_t q = f0; q < f1; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        PF_CHECK(f >= 0 && f < m->n_faces, err, PF_ERR_INVALID, "element %d: face %d out of range",
                 (int)e, (int)f);
        nfn += m->face_offsets[f + 1] - m->face_offsets[f];
    }
    c->face_id = pf_ws_get(w, WS_EFACE, (size_t)c->nf, sizeof *c->face_id);
    c->floc_off = pf_ws_get(w, WS_EFOFF, (size_t)c->nf + 1, sizeof *c->floc_off);
    c->face_rev = pf_ws_get(w, WS_EREV, (size_t)c->nf, sizeof *c->face_rev);
    c->floc = pf_ws_get(w, WS_ELOCAL, (size_t)nfn + 1, sizeof *c->floc);
    c->edges = pf_ws_get(w, WS_EDGES, (size_t)nfn + 1, sizeof *c->edges);
    PF_CHECK(c->face_id && c->floc_off && c->face_rev && c->floc && c->edges, err, PF_ERR_NOMEM,
             "element %d: no memory", (int)e);
    c->k = 0;
    c->floc_off[0] = 0;
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        uint32_t entry = m->elem_faces[f0 + lf];
        int32_t f = PF_FACE_INDEX(entry);
        c->face_id[lf] = f;
        c->face_rev[lf] = (entry & PF_FACE_REVERSED) != 0;
        if (c->faces[f].n == 0)
            PF_TRY(pf_face_init(&c->faces[f], m, f, err));
        int64_t a = m->face_offsets[f], b = m->face_offsets[f + 1];
        for (int64_t q = a; q < b; ++q) {
            int32_t node = (int32_t)m->face_nodes[q];
            int32_t li = local_index(c, node);
            if (li < 0) {
                PF_CHECK(c->k < PF_BASIS_MAX_NODES, err, PF_ERR_TOO_LARGE,
                         "element %d has more than %d nodes", (int)e, PF_BASIS_MAX_NODES);
                li = c->k++;
                c->nodes[li] = node;
                c->pos[li] = pf_v3_load(m->x + 3 * (size_t)node);
            }
            c->floc[c->floc_off[lf] + (q - a)] = li;
        }
        c->floc_off[lf + 1] = c->floc_off[lf] + (b - a);
    }
    PF_CHECK(c->k >= 4, err, PF_ERR_INVALID, "element %d has %d distinct nodes", (int)e, (int)c->k);
    pf_vec3 ctr = pf_v3(0, 0, 0);
    for (int32_t i = 0; i < c->k; ++i)
        ctr = pf_v3_add(ctr, c->pos[i]);
    c->c = pf_v3_scale(ctr, 1.0 / c->k);
    c->h = 0;
    c->diam = 0;
    for (int32_t i = 0; i < c->k; ++i) {
        c->h = fmax(c->h, pf_v3_dist(c->pos[i], c->c));
        for (int32_t j = 0; j < i; ++j)
            c->diam = fmax(c->diam, pf_v3_dist(c->pos[i], c->pos[j]));
    }
    /* Coincident nodes: one group (paper sec. 5). */
    c->ng = 0;
    for (int32_t i = 0; i < c->k; ++i) {
        int32_t g = -1;
        for (int32_t j = 0; j < i && g < 0; ++j)
            if (pf_v3_dist(c->pos[i], c->pos[j]) <= p->merge_tol * c->diam)
                g = c->slot[j];
        if (g < 0) {
            g = c->ng++;
            c->gcount[g] = 0;
            c->grep[g] = i;
        }
        c->slot[i] = g;
        c->gcount[g] += 1;
    }
    /* Node normals: mean of the outward normals of the faces at the node. */
    for (int32_t i = 0; i < c->k; ++i)
        c->nnrm[i] = pf_v3(0, 0, 0);
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        pf_vec3 nn = face_out_normal(c, lf);
        for (int64_t q = c->floc_off[lf]; q < c->floc_off[lf + 1]; ++q)
            c->nnrm[c->floc[q]] = pf_v3_add(c->nnrm[c->floc[q]], nn);
    }
    /* Edges, each once with its two faces. */
    c->ne = 0;
    c->max_edge = 0;
    for (int32_t i = 0; i < c->k; ++i)
        c->nlen[i] = INFINITY;
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        int64_t a = c->floc_off[lf], n = c->floc_off[lf + 1] - a;
        for (int64_t q = 0; q < n; ++q) {
            int32_t u = c->floc[a + q], v = c->floc[a + (q + 1) % n];
            if (c->slot[u] == c->slot[v])
                continue;
            int32_t lo = u < v ? u : v, hi = u < v ? v : u, found = -1;
            for (int32_t s = 0; s < c->ne && found < 0; ++s)
                if (c->edges[s].a == lo && c->edges[s].b == hi)
                    found = s;
            if (found >= 0) {
                c->edges[found].f2 = lf;
                continue;
            }
            c->edges[c->ne++] = (edge3){lo, hi, lf, lf};
            double len = pf_v3_dist(c->pos[lo], c->pos[hi]);
            c->max_edge = fmax(c->max_edge, len);
            c->nlen[lo] = fmin(c->nlen[lo], len);
            c->nlen[hi] = fmin(c->nlen[hi], len);
        }
    }
    PF_CHECK(c->ne > 0 && c->h > 0, err, PF_ERR_INVALID, "element %d is degenerate", (int)e);
    for (int32_t i = 0; i < c->k; ++i)
        c->nfeat[i] = c->nlen[i];
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        int64_t a = c->floc_off[lf], n = c->floc_off[lf + 1] - a;
        for (int64_t q = 0; q < n; ++q)
            pf_basis_face_edge_feature(c, lf, c->floc[a + q]);
    }
    return PF_OK;
}

/* Lowers node i's feature size to its distance from each edge of local face lf that does not
 * touch it (a node near a face's far edge makes a narrow corner the samples must resolve). */
void pf_basis_face_edge_feature(elem_ctx *c, int32_t lf, int32_t i)
{
    int64_t a = c->floc_off[lf], n = c->floc_off[lf + 1] - a;
    for (int64_t r = 0; r < n; ++r) {
        int32_t u = c->floc[a + r], v = c->floc[a + (r + 1) % n];
        if (c->slot[u] == c->slot[i] || c->slot[v] == c->slot[i] || c->slot[u] == c->slot[v])
            continue;
        pf_vec3 ev = pf_v3_sub(c->pos[v], c->pos[u]), dv = pf_v3_sub(c->pos[i], c->pos[u]);
        double t = pf_v3_dot(dv, ev) / pf_v3_dot(ev, ev);
        t = t < 0 ? 0 : t > 1 ? 1 : t;
        double d = pf_v3_dist(c->pos[i], pf_v3_add(c->pos[u], pf_v3_scale(ev, t)));
        c->nfeat[i] = fmin(c->nfeat[i], d);
    }
}

/* ---- closed forms
 * -------------------------------------------------------------------------------- */

static bool affine_inverse(pf_vec3 e1, pf_vec3 e2, pf_vec3 e3, double *minv)
{
    pf_mat3 a = {{{e1.x, e2.x, e3.x}, {e1.y, e2.y, e3.y}, {e1.z, e2.z, e3.z}}};
    double det;
    pf_mat3 inv = pf_m3_inverse(a, &det);
    double scale = pf_v3_norm(e1) * pf_v3_norm(e2) * pf_v3_norm(e3);
    if (!(fabs(det) > 1e-12 * scale))
        return false;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            minv[3 * i + j] = inv.m[i][j];
    return true;
}

/* Tet: barycentric coordinates with x0 = local node 0. */
static bool closed_tet(const elem_ctx *c, double *d, int32_t *slot)
{
    if (c->k != 4 || c->nf != 4 || c->ng != 4)
        return false;
    pf_v3_store(c->pos[0], d);
    if (!affine_inverse(pf_v3_sub(c->pos[1], c->pos[0]), pf_v3_sub(c->pos[2], c->pos[0]),
                        pf_v3_sub(c->pos[3], c->pos[0]), d + 3))
        return false;
    for (int i = 0; i < 4; ++i)
        slot[i] = i;
    return true;
}

/* Parallelepiped: node 0 and its three edge neighbours span it; every node must sit at a corner
 * x0 + sum_d bit_d e_d within parallel_tol * diameter, each corner taken once. */
static bool closed_hex(const elem_ctx *c, double tol, double *d, int32_t *slot)
{
    if (c->k != 8 || c->nf != 6 || c->ng != 8 || c->ne != 12)
        return false;
    int32_t nb[3], nnb = 0;
    for (int32_t s = 0; s < c->ne; ++s) {
        if (c->edges[s].a == 0 || c->edges[s].b == 0) {
            if (nnb == 3)
                return false;
            nb[nnb++] = c->edges[s].a == 0 ? c->edges[s].b : c->edges[s].a;
        }
    }
    if (nnb != 3)
        return false;
    pf_vec3 e[3];
    for (int i = 0; i < 3; ++i)
        e[i] = pf_v3_sub(c->pos[nb[i]], c->pos[0]);
    pf_v3_store(c->pos[0], d);
    if (!affine_inverse(e[0], e[1], e[2], d + 3))
        return false;
    int used = 0;
    for (int32_t i = 0; i < 8; ++i) {
        pf_vec3 r = pf_v3_sub(c->pos[i], c->pos[0]);
        int bits = 0;
        pf_vec3 corner = c->pos[0];
        for (int dd = 0; dd < 3; ++dd) {
            double l = d[3 + 3 * dd] * r.x + d[4 + 3 * dd] * r.y + d[5 + 3 * dd] * r.z;
            if (l > 0.5) {
                bits |= 1 << dd;
                corner = pf_v3_add(corner, e[dd]);
            }
        }
        if (pf_v3_dist(corner, c->pos[i]) > tol * c->diam || (used >> bits) & 1)
            return false;
        used |= 1 << bits;
        slot[i] = bits;
    }
    return true;
}

/* Boundary data b_g at a sample (paper sec. 4): delta at nodes, linear on edges, the face
 * functions on faces; summed over merged groups. B is a row with stride ldb. */
static void boundary_values(const elem_ctx *c, const pt3 *pt, double *faceval, double *B,
                            size_t ldb)
{
    if (pf_basis_patch_has(c, pt)) {
        pf_basis_patch_values(c, pt, faceval, B, ldb);
        return;
    }
    for (int32_t g = 0; g < c->ng; ++g)
        B[(size_t)g * ldb] = 0;
    if (pt->face < 0) {
        B[(size_t)c->slot[pt->a] * ldb] += 1 - pt->t;
        if (pt->b != pt->a)
            B[(size_t)c->slot[pt->b] * ldb] += pt->t;
        return;
    }
    const face_fn *f = &c->faces[c->face_id[pt->face]];
    pf_face_eval(f, pt->x, faceval);
    const int32_t *loc = c->floc + c->floc_off[pt->face];
    for (int32_t a = 0; a < f->n; ++a)
        B[(size_t)c->slot[loc[a]] * ldb] += faceval[a];
}

/* ---- 3D MFS (paper eq. 11-14 with psi = 1/r)
 * ----------------------------------------------------- */

typedef struct mfs_out {
    int32_t nk, m, moved, dropped;
    bool svd;
} mfs_out;

static pf_status grow_data(double **data, int64_t *cap, int64_t need, pf_error *err)
{
    if (need <= *cap)
        return PF_OK;
    int64_t nc = *cap ? *cap : 1024;
    while (nc < need)
        nc *= 2;
    double *nd = pf_realloc_array(*data, (size_t)nc, sizeof *nd);
    PF_CHECK(nd, err, PF_ERR_NOMEM, "basis data: no memory for %lld doubles", (long long)nc);
    *data = nd;
    *cap = nc;
    return PF_OK;
}

/* Graded kernel samples of element c (pf_basis_graded_samples) within the kernel budget: while
 * they exceed p->max_kernels, the grading rate is raised by one factor over the cell
 * (c->grade_scale; away from the features a surface's sample count goes as the inverse square
 * of the rate), keeping the spacing at every feature, until they fit or their count stops
 * falling (the features alone exceed the budget). The collocation points use the same rate. */
static pf_status graded_within_budget(elem_ctx *c, const pf_basis_params *p, double spacing,
                                      double fsp, pt_list *pts, pf_error *err)
{
    int32_t last = INT32_MAX;
    for (int it = 0;; ++it) {
        PF_TRY(pf_basis_graded_samples(c, spacing, fsp, p->grading, 1, 1, 1, 0.5, pts, err));
        int32_t n = pts->n;
        if (p->max_kernels < 0 || n <= p->max_kernels || it == 16 || n > 0.99 * last)
            return PF_OK;
        last = n;
        c->grade_scale *= 1.1 * sqrt((double)n / p->max_kernels);
    }
}

static pf_status elem_mfs(elem_ctx *c, const pf_basis_params *p, basis_ws *w, pt_list *pts,
                          double **data, int64_t *cap, int64_t at, mfs_out *st, pf_error *err)
{
    int32_t e = c->e;
    memset(st, 0, sizeof *st);
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        face_fn *f = &c->faces[c->face_id[lf]];
        if (f->kind == FACE_NONE)
            PF_TRY(pf_face_solve(f, c->m, c->face_id[lf], p, w, err));
    }
    for (int32_t g = 0; g < c->ng; ++g)
        pf_v3_store(pf_v3_scale(pf_v3_sub(c->pos[c->grep[g]], c->c), 1 / c->h), c->gpos + 3 * g);
    PF_CHECK(pf_exactness_projection(3, c->ng, c->gpos, c->gq) == PF_OK, err, PF_ERR_INVALID,
             "element %d: nodes are coplanar", (int)e);
    bool sliced_on = p->sliced != PF_BASIS_SLICED_OFF;
    PF_TRY(pf_basis_patch_build(c, sliced_on ? p->patch_angle : 0, p, w, err));
    bool graded = sliced_on;
    double xi =
        p->sliced == PF_BASIS_SLICED_ALL || (sliced_on && c->has_patch) ? p->sliced_xi : p->xi;
    /* AUTO: the patch's data are smooth over its facets, so only its loop edges and its inner
     * nodes' bump widths set the feature sizes (pf_basis_patch_features). */
    c->patch_grading = p->sliced == PF_BASIS_SLICED_AUTO && c->has_patch;
    if (c->patch_grading)
        pf_basis_patch_features(c);
    c->grade_scale = 1;
    double rho = p->collocation_density;
    double spacing = c->max_edge / (p->edge_samples + 1), fsp = spacing * p->face_spacing;
    /* Kernels (eq. 12): samples moved outward by xi * size, size the element's diameter, scaled
     * down where the local sample spacing (short edges, small faces: the facets of a sliced
     * surface) is finer than the element's: a kernel resolves boundary data on the scale of its
     * distance. Kept only outside the element and at least 0.2 offsets clear of its boundary
     * (non-convex cells), else moved back by halves, else dropped. The samples are graded by
     * feature size (pf_basis_graded_samples) on the cells with the sliced-cell settings, within
     * the kernel budget (graded_within_budget); elsewhere uniform: every edge and face at one
     * spacing. */
    if (graded)
        PF_TRY(graded_within_budget(c, p, spacing, fsp, pts, err));
    else
        PF_TRY(pf_basis_uniform_samples(c, spacing, 1, 0, fsp, 0.5, 0.5 * fsp, pts, err));
    int32_t ns = pts->n, ng = c->ng;
    PF_TRY(grow_data(data, cap, at + HDR + 3 * (int64_t)ns, err));
    double *kern = *data + at + HDR;
    int32_t nk = 0;
    for (int32_t s = 0; s < ns; ++s) {
        const pt3 *pt = &pts->p[s];
        double off = xi * c->diam * fmin(1, pt->len / fsp);
        bool placed = false;
        if (pf_v3_norm(pt->nrm) > 0)
            for (double shrink = 1; shrink > 0.2 && !placed; shrink *= 0.5) {
                pf_vec3 k = pf_v3_add(pt->x, pf_v3_scale(pt->nrm, shrink * off));
                if (elem_contains(c, k) || elem_boundary_within(c, k, 0.2 * shrink * off))
                    continue;
                pf_vec3 y = pf_v3_scale(pf_v3_sub(k, c->c), 1 / c->h);
                pf_v3_store(y, kern + 3 * nk);
                ++nk;
                placed = true;
                st->moved += shrink < 1;
            }
        st->dropped += !placed;
    }
    st->nk = nk;

    /* Collocation points, about rho times denser (eq. 13), and the system of eq. 14. */
    double sc = fsp / sqrt(rho);
    if (graded)
        PF_TRY(pf_basis_graded_samples(c, spacing, fsp, p->grading, rho, sqrt(rho),
                                       (int32_t)ceil(rho), 0.5, pts, err));
    else
        PF_TRY(pf_basis_uniform_samples(c, spacing / rho, (int32_t)ceil(rho), 0, sc, 0.5, 0.5 * sc,
                                        pts, err));
    int32_t m = pts->n, cols = nk + N_POLY;
    size_t ldb = (size_t)(m > cols ? m : cols);
    st->m = m;
    double *A = pf_ws_get(w, WS_A, (size_t)m * cols, sizeof *A);
    double *A0 = pf_ws_get(w, WS_A0, (size_t)m * cols, sizeof *A0);
    double *B = pf_ws_get(w, WS_B, ldb * ng, sizeof *B);
    double *B0 = pf_ws_get(w, WS_B0, ldb * ng, sizeof *B0);
    double *fv = pf_ws_get(w, WS_FACEVAL, PF_BASIS_MAX_NODES, sizeof *fv);
    PF_CHECK(A && A0 && B && B0 && fv, err, PF_ERR_NOMEM,
             "element %d: no memory for a %d x %d "
             "system",
             (int)e, (int)m, (int)cols);
    kern = *data + at + HDR;
    for (int32_t r = 0; r < m; ++r) {
        pf_vec3 y = pf_v3_scale(pf_v3_sub(pts->p[r].x, c->c), 1 / c->h);
        for (int32_t j = 0; j < nk; ++j)
            A[r + (size_t)j * m] = 1 / pf_v3_dist(y, pf_v3_load(kern + 3 * j));
        A[r + (size_t)nk * m] = y.x;
        A[r + (size_t)(nk + 1) * m] = y.y;
        A[r + (size_t)(nk + 2) * m] = y.z;
        A[r + (size_t)(nk + 3) * m] = 1;
        double hv[N_HIGH];
        harmonic_high((const double[3]){y.x, y.y, y.z}, hv, NULL);
        for (int a = 0; a < N_HIGH; ++a)
            A[r + (size_t)(nk + N_LINEAR + a) * m] = hv[a];
    }
    memset(B, 0, ldb * ng * sizeof *B);
    for (int32_t r = 0; r < m; ++r)
        boundary_values(c, &pts->p[r], fv, B + r, ldb);
    memcpy(A0, A, (size_t)m * cols * sizeof *A);
    memcpy(B0, B, ldb * ng * sizeof *B);
    pf_status s = pf_lsq_solve(w, m, cols, ng, p->rank_rcond, &st->svd, err);
    if (s < 0) {
        pf_error_prefix(err, "element %d", (int)e);
        return s;
    }

    /* Store: header, kernels (already in place), coefficients, groups, projection, counts. */
    int64_t need = at + HDR + 3 * (int64_t)nk + (int64_t)cols * ng + 8 * (int64_t)ng;
    PF_TRY(grow_data(data, cap, need, err));
    double *d = *data + at;
    pf_v3_store(c->c, d);
    d[3] = c->h;
    d[4] = nk;
    d[5] = ng;
    double *coef = d + HDR + 3 * nk;
    for (int32_t j = 0; j < cols; ++j)
        for (int32_t g = 0; g < ng; ++g) {
            double v = B[j + (size_t)g * ldb];
            PF_CHECK(isfinite(v), err, PF_ERR_NUMERIC, "element %d: non-finite MFS coefficient",
                     (int)e);
            coef[(size_t)j * ng + g] = v;
        }
    double *gpos = coef + (size_t)cols * ng, *q = gpos + 3 * ng, *gc = q + 4 * ng;
    for (int32_t g = 0; g < ng; ++g) {
        pf_v3_store(pf_v3_scale(pf_v3_sub(c->pos[c->grep[g]], c->c), 1 / c->h), gpos + 3 * g);
        gc[g] = c->gcount[g];
    }
    PF_CHECK(pf_exactness_projection(3, ng, gpos, q) == PF_OK, err, PF_ERR_INVALID,
             "element %d: nodes are coplanar", (int)e);
    return PF_OK;
}

/* ---- statistics
 * ------------------------------------------------------------------------------------ */

/* Accumulates partition-of-unity and linear-reproduction errors and the smallest value at x. */
static void check_point(const pf_basis *b, int32_t e, const elem_ctx *c, pf_vec3 x,
                        pf_basis_elem_stats *st)
{
    double n[PF_BASIS_MAX_NODES], g[3 * PF_BASIS_MAX_NODES];
    pf_basis_eval(b, e, x, n, g);
    double su = -1, sx[3] = {-x.x, -x.y, -x.z}, sg[3] = {0, 0, 0},
           sxg[9] = {-1, 0, 0, 0, -1, 0, 0, 0, -1};
    for (int32_t i = 0; i < c->k; ++i) {
        su += n[i];
        double xi[3] = {c->pos[i].x, c->pos[i].y, c->pos[i].z};
        for (int a = 0; a < 3; ++a) {
            sx[a] += xi[a] * n[i];
            sg[a] += g[3 * i + a];
            for (int bb = 0; bb < 3; ++bb)
                sxg[3 * a + bb] += xi[a] * g[3 * i + bb];
        }
        st->min_value = fmin(st->min_value, n[i]);
    }
    double lin = sqrt(sx[0] * sx[0] + sx[1] * sx[1] + sx[2] * sx[2]) / c->diam;
    for (int a = 0; a < 9; ++a)
        lin = fmax(lin, fabs(sxg[a]));
    double uni = fabs(su);
    for (int a = 0; a < 3; ++a)
        uni = fmax(uni, fabs(sg[a]) * c->diam);
    st->linear_error = fmax(st->linear_error, lin);
    st->unity_error = fmax(st->unity_error, uni);
}

static pf_status elem_stats(const pf_basis *b, elem_ctx *c, const pf_basis_params *p, pt_list *pts,
                            pf_basis_elem_stats *st, pf_error *err)
{
    int32_t e = c->e;
    bool full = !p->no_check_stats; /* else the boundary error only */
    st->min_value = full ? INFINITY : 0;
    st->linear_error = st->unity_error = 0;
    for (int32_t i = 0; i < c->k && full; ++i)
        check_point(b, e, c, c->pos[i], st);
    if (b->kind[e] != PF_BASIS_HARMONIC) {
        st->boundary_error = 0;
        if (!full)
            return PF_OK;
        /* Convex: the centroid, the midpoints of node pairs and the centroid-node midpoints. */
        check_point(b, e, c, c->c, st);
        for (int32_t i = 0; i < c->k; ++i) {
            check_point(b, e, c, pf_v3_scale(pf_v3_add(c->pos[i], c->c), 0.5), st);
            for (int32_t j = 0; j < i; ++j)
                check_point(b, e, c, pf_v3_scale(pf_v3_add(c->pos[i], c->pos[j]), 0.5), st);
        }
        st->boundary_error = 0;
        return PF_OK;
    }
    /* Boundary error: the L2 norm over the faces (eq. 13's integral), by a uniform grid of
     * points shifted by half a cell against the collocation grid and twice as fine, so that
     * every point carries the same area. Edge points (half-way between collocation points) only
     * enter the unity / linear checks. */
    double spacing = c->max_edge / (p->edge_samples + 1) * p->face_spacing;
    double sc = 0.5 * spacing / sqrt(p->collocation_density);
    PF_TRY(pf_basis_uniform_samples(c, c->max_edge / (p->edge_samples + 1) / p->collocation_density,
                                    (int32_t)ceil(p->collocation_density), 0.5, sc, 0, 0, pts,
                                    err));
    double fv[PF_BASIS_MAX_NODES], bv[PF_BASIS_MAX_NODES], n[PF_BASIS_MAX_NODES];
    double num = 0, den = 0;
    for (int32_t r = 0; r < pts->n; ++r) {
        const pt3 *pt = &pts->p[r];
        if (full)
            check_point(b, e, c, pt->x, st);
        if (pt->face < 0)
            continue;
        boundary_values(c, pt, fv, bv, 1);
        pf_basis_eval(b, e, pt->x, n, NULL);
        for (int32_t i = 0; i < c->k; ++i) {
            double bi = bv[c->slot[i]] / c->gcount[c->slot[i]];
            num += (n[i] - bi) * (n[i] - bi);
            den += bi * bi;
        }
    }
    st->boundary_error = den > 0 ? sqrt(num / den) : 0;
    if (!full)
        return PF_OK;
    /* Interior: a 5 x 5 x 5 grid over the bounding box, points inside only. */
    pf_vec3 lo = c->pos[0], hi = c->pos[0];
    for (int32_t i = 1; i < c->k; ++i) {
        lo = pf_v3_min(lo, c->pos[i]);
        hi = pf_v3_max(hi, c->pos[i]);
    }
    for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j)
            for (int l = 0; l < 5; ++l) {
                pf_vec3 x = pf_v3(lo.x + (i + 0.5) / 5 * (hi.x - lo.x),
                                  lo.y + (j + 0.5) / 5 * (hi.y - lo.y),
                                  lo.z + (l + 0.5) / 5 * (hi.z - lo.z));
                if (elem_contains(c, x))
                    check_point(b, e, c, x, st);
            }
    return PF_OK;
}

/* ---- create / release --------------------------------------------------------------------------
 */

void pf_basis_release(pf_basis *b)
{
    pf_free(b->node_offsets);
    pf_free(b->nodes);
    pf_free(b->node_slot);
    pf_free(b->kind);
    pf_free(b->data_offsets);
    pf_free(b->data);
    pf_free(b->stats);
    pf_free(b->taken);
    memset(b, 0, sizeof *b);
}

typedef struct create_state {
    face_fn *faces;
    basis_ws ws;
    pt_list pts;
    elem_ctx *ctx;
    int64_t data_cap, nodes_cap;
    uint8_t *face_uses;
} create_state;

static pf_status grow_nodes(pf_basis *b, int64_t *cap, int64_t need, pf_error *err)
{
    if (need <= *cap)
        return PF_OK;
    int64_t nc = *cap ? *cap : 1024;
    while (nc < need)
        nc *= 2;
    int32_t *n1 = pf_realloc_array(b->nodes, (size_t)nc, sizeof *n1);
    if (n1)
        b->nodes = n1;
    int32_t *n2 = n1 ? pf_realloc_array(b->node_slot, (size_t)nc, sizeof *n2) : NULL;
    if (n2)
        b->node_slot = n2;
    PF_CHECK(n1 && n2, err, PF_ERR_NOMEM, "basis: no memory for %lld node entries", (long long)nc);
    *cap = nc;
    return PF_OK;
}

static pf_status build_elem(pf_basis *b, create_state *cs, const pf_mesh *m, int32_t e,
                            const pf_basis_params *p, pf_error *err)
{
    double t0 = pf_time_seconds();
    elem_ctx *c = cs->ctx;
    c->m = m;
    c->faces = cs->faces;
    c->e = e;
    c->has_patch = false;
    c->face_uses = cs->face_uses;
    PF_TRY(elem_setup(c, p, &cs->ws, err));
    int64_t at = b->data_offsets[e];
    PF_TRY(grow_data(&b->data, &cs->data_cap, at + 12, err));
    int64_t no = b->node_offsets[e];
    PF_TRY(grow_nodes(b, &cs->nodes_cap, no + c->k, err));
    pf_basis_elem_stats *st = &b->stats[e];
    memset(st, 0, sizeof *st);
    st->n_nodes = c->k;
    st->n_faces = c->nf;
    st->n_merged = c->k - c->ng;
    pf_elem_kind mk = pf_mesh_classify_elem(m, e);
    int32_t *slot = b->node_slot + no;
    pf_basis_kind kind = PF_BASIS_HARMONIC;
    if (!p->force_mfs && mk == PF_ELEM_TET && closed_tet(c, b->data + at, slot))
        kind = PF_BASIS_TET;
    else if (!p->force_mfs && mk == PF_ELEM_HEX &&
             closed_hex(c, p->parallel_tol, b->data + at, slot))
        kind = PF_BASIS_HEX;
    int64_t end = at + 12;
    if (kind == PF_BASIS_HARMONIC) {
        mfs_out mo;
        PF_TRY(elem_mfs(c, p, &cs->ws, &cs->pts, &b->data, &cs->data_cap, at, &mo, err));
        st->n_kernels = mo.nk;
        st->n_collocation = mo.m;
        st->n_kernels_moved = mo.moved;
        st->n_kernels_dropped = mo.dropped;
        st->used_svd = mo.svd;
        end =
            at + HDR + 3 * (int64_t)mo.nk + (int64_t)(mo.nk + N_POLY) * c->ng + 8 * (int64_t)c->ng;
        for (int32_t i = 0; i < c->k; ++i)
            slot[i] = c->slot[i];
    }
    for (int32_t i = 0; i < c->k; ++i)
        b->nodes[no + i] = c->nodes[i];
    b->node_offsets[e + 1] = no + c->k;
    b->data_offsets[e + 1] = end;
    b->kind[e] = (uint8_t)kind;
    st->setup_ms = 1e3 * (pf_time_seconds() - t0);
    pf_status sst = elem_stats(b, c, p, &cs->pts, st, err);
    if (c->has_patch)
        pf_face_release(&c->patch);
    c->has_patch = false;
    return sst;
}

static bool same_params(const pf_basis_params *a, const pf_basis_params *b)
{
    return a->xi == b->xi && a->edge_samples == b->edge_samples &&
           a->face_spacing == b->face_spacing && a->collocation_density == b->collocation_density &&
           a->parallel_tol == b->parallel_tol && a->merge_tol == b->merge_tol &&
           a->rank_rcond == b->rank_rcond && a->grading == b->grading &&
           a->patch_angle == b->patch_angle && a->sliced == b->sliced &&
           a->sliced_xi == b->sliced_xi && a->max_kernels == b->max_kernels &&
           a->force_mfs == b->force_mfs && a->no_check_stats == b->no_check_stats;
}

/* Element e takes old element o's functions: its data, node slots and statistics as they are
 * (all in element-local order and coordinates), its nodes through the node map. */
static pf_status take_elem(pf_basis *b, create_state *cs, const pf_basis_reuse *r, int32_t e,
                           int32_t o, pf_error *err)
{
    const pf_basis *old = r->old;
    int64_t at = b->data_offsets[e], len = old->data_offsets[o + 1] - old->data_offsets[o];
    int64_t no = b->node_offsets[e], k = old->node_offsets[o + 1] - old->node_offsets[o];
    PF_TRY(grow_data(&b->data, &cs->data_cap, at + len, err));
    PF_TRY(grow_nodes(b, &cs->nodes_cap, no + k, err));
    memcpy(b->data + at, old->data + old->data_offsets[o], (size_t)len * sizeof *b->data);
    for (int64_t i = 0; i < k; ++i) {
        int32_t node = old->nodes[old->node_offsets[o] + i];
        b->nodes[no + i] = r->node_map ? r->node_map[node] : node;
        b->node_slot[no + i] = old->node_slot[old->node_offsets[o] + i];
    }
    b->node_offsets[e + 1] = no + k;
    b->data_offsets[e + 1] = at + len;
    b->kind[e] = old->kind[o];
    b->stats[e] = old->stats[o];
    b->stats[e].setup_ms = 0;
    b->taken[e] = o;
    b->n_taken++;
    return PF_OK;
}

/* The old element whose functions e can take, or -1. */
static int32_t source_of(const pf_basis_reuse *r, const pf_basis_params *p, const pf_mesh *m,
                         int32_t e)
{
    int32_t o = r && r->source ? r->source[e] : -1;
    if (o < 0 || o >= r->old->n_elems || !same_params(&r->old->params, p))
        return -1;
    return pf_mesh_elem_same(r->old_mesh, o, m, e, r->node_map) ? o : -1;
}

pf_status pf_basis_create(pf_basis *b, const pf_mesh *m, const pf_basis_params *params,
                          pf_error *err)
{
    return pf_basis_create_reusing(b, m, params, NULL, err);
}

pf_status pf_basis_create_reusing(pf_basis *b, const pf_mesh *m, const pf_basis_params *params,
                                  const pf_basis_reuse *reuse, pf_error *err)
{
    memset(b, 0, sizeof *b);
    double t0 = pf_time_seconds();
    pf_basis_params p = fill_defaults(params);
    PF_CHECK(m && m->n_elems >= 0 && (m->n_elems == 0 || (m->elem_offsets && m->face_offsets)), err,
             PF_ERR_INVALID, "basis: empty or malformed mesh");
    PF_CHECK(!reuse || (reuse->old && reuse->old_mesh && reuse->old_mesh->face_elems &&
                        m->face_elems && reuse->old->n_elems == reuse->old_mesh->n_elems),
             err, PF_ERR_INVALID, "basis: reuse needs the old functions and both meshes derived");
    int32_t ne = m->n_elems;
    b->n_elems = ne;
    b->params = p;
    b->params.progress = (pf_progress_hook){0}; /* borrowed for the set-up only */
    create_state cs = {0};
    pf_status s = PF_OK;
    if (!PF_ALLOC_N(b->node_offsets, ne + 1) || !PF_ALLOC_N(b->data_offsets, ne + 1) ||
        !PF_ALLOC_N(b->kind, ne) || !PF_ALLOC_N(b->stats, ne) || !PF_ALLOC_N(b->taken, ne + 1) ||
        !PF_ALLOC_N(cs.faces, m->n_faces) || !PF_ALLOC_N(cs.ctx, 1)) {
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "basis: no memory for %d elements",
                         (int)ne);
        goto done;
    }
    memset(cs.faces, 0, (size_t)m->n_faces * sizeof *cs.faces);
    memset(cs.ctx, 0, sizeof *cs.ctx);
    if (!PF_ALLOC_N(cs.face_uses, m->n_faces + 1)) {
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "basis: no memory");
        goto done;
    }
    memset(cs.face_uses, 0, (size_t)m->n_faces);
    for (int64_t q = 0; q < m->elem_offsets[ne]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        if (f >= 0 && f < m->n_faces && cs.face_uses[f] < 255)
            cs.face_uses[f]++;
    }
    b->node_offsets[0] = 0;
    b->data_offsets[0] = 0;
    /* One BLAS thread: small systems, and bits independent of the core count (pf/base.h). */
    pf_blas_threads blas = pf_blas_threads_set(1, false);
    pf_progress_post(&p.progress, "basis functions", 0, ne);
    for (int32_t e = 0; e < ne && s >= 0; ++e) {
        if (e > 0)
            pf_progress_post(&p.progress, "basis functions", e, ne);
        int32_t o = source_of(reuse, &p, m, e);
        b->taken[e] = -1;
        s = o >= 0 ? take_elem(b, &cs, reuse, e, o, err) : build_elem(b, &cs, m, e, &p, err);
    }
    pf_blas_threads_restore(blas);
    if (s >= 0 && ne > 0)
        pf_progress_post(&p.progress, "basis functions", ne, ne);
    for (int32_t f = 0; f < m->n_faces; ++f) {
        b->n_face_mfs += cs.faces[f].kind == FACE_MFS;
        b->n_face_closed += cs.faces[f].kind == FACE_LINEAR || cs.faces[f].kind == FACE_BILINEAR;
    }
done:
    if (cs.ctx && cs.ctx->has_patch)
        pf_face_release(&cs.ctx->patch);
    if (cs.faces)
        for (int32_t f = 0; f < m->n_faces; ++f)
            pf_face_release(&cs.faces[f]);
    pf_free(cs.faces);
    pf_free(cs.ctx);
    pf_free(cs.face_uses);
    pf_free(cs.pts.p);
    pf_ws_release(&cs.ws);
    if (s < 0) {
        pf_basis_release(b);
        return s;
    }
    b->setup_seconds = pf_time_seconds() - t0;
    return PF_OK;
}
