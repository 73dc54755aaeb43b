/* Boundary samples (uniform, and graded by feature size), and the surface patch of a sliced
 * cell: its mesh-boundary facets as one curved face with smooth data (see pf/basis.h, "Sliced
 * cells").
 *
 * Why: a sliced cell's boundary is many small, nearly coplanar facets. One linear hat per facet
 * has a kink across every facet edge; across an edge whose faces meet at 180 - theta degrees,
 * the harmonic extension of such a kink needs a gradient of order kink / sin(theta) normal to
 * the surface, which the kernels resolve only at a high count (sliced sphere: 12 % median
 * boundary error with uniform samples, 3 % at 4x the kernels). On the mesh boundary the data are
 * free (no neighbour shares them), so pf gives them without kinks; the faces shared with
 * neighbours keep their face functions, so conformity is as before. */
#include <math.h>
#include <string.h>

#include "basis_internal.h"

pf_status pf_basis_pts_push(pt_list *l, pt3 v, pf_error *err)
{
    if (l->n == l->cap) {
        int32_t cap = l->cap ? 2 * l->cap : 256;
        pt3 *np = pf_realloc_array(l->p, (size_t)cap, sizeof *np);
        PF_CHECK(np, err, PF_ERR_NOMEM, "boundary samples: no memory for %d points", (int)cap);
        l->p = np;
        l->cap = cap;
    }
    l->p[l->n++] = v;
    return PF_OK;
}

/* ---- boundary samples (paper sec. 5: nodes, points on edges, a uniform sampling of faces) -------
 */

/* Nodes (one per group); on each edge of length L, n = max(edge_min, ceil(L / edge_spacing) - 1)
 * points
 * (edge_phase 0: t = j / (n + 1), j = 1..n; 0.5: t = (j + 0.5) / (n + 1), j = 0..n); and on each
 * face the points of a square grid of the given spacing (offset by grid_phase cells) inside the
 * face and at least margin from its boundary. One spacing for all edges and faces: the samples
 * are uniform over the boundary (paper sec. 5), short edges do not crowd the system. */
pf_status pf_basis_uniform_samples(const elem_ctx *c, double edge_spacing, int32_t edge_min,
                                   double edge_phase, double spacing, double grid_phase,
                                   double margin, pt_list *out, pf_error *err)
{
    out->n = 0;
    for (int32_t g = 0; g < c->ng; ++g) {
        int32_t i = c->grep[g];
        pf_vec3 nn = c->nnrm[i];
        double l = pf_v3_norm(nn);
        PF_TRY(
            pf_basis_pts_push(out,
                              (pt3){c->pos[i], l > 1e-6 ? pf_v3_scale(nn, 1 / l) : pf_v3(0, 0, 0),
                                    i, i, 0, -1, c->nlen[i]},
                              err));
    }
    for (int32_t s = 0; s < c->ne; ++s) {
        const edge3 *ed = &c->edges[s];
        pf_vec3 nn = pf_v3_add(face_out_normal(c, ed->f1), face_out_normal(c, ed->f2));
        double l = pf_v3_norm(nn);
        nn = l > 1e-6 ? pf_v3_scale(nn, 1 / l) : pf_v3(0, 0, 0);
        double cnt = ceil(pf_v3_dist(c->pos[ed->a], c->pos[ed->b]) / edge_spacing - 1e-9) - 1;
        int32_t n = cnt > edge_min ? (int32_t)cnt : edge_min; /* every edge's kink is sampled */
        int32_t j0 = edge_phase > 0 ? 0 : 1, j1 = edge_phase > 0 ? n : n;
        for (int32_t j = j0; j <= j1; ++j) {
            double t = (j + edge_phase) / (n + 1);
            pf_vec3 x =
                pf_v3_add(c->pos[ed->a], pf_v3_scale(pf_v3_sub(c->pos[ed->b], c->pos[ed->a]), t));
            PF_TRY(pf_basis_pts_push(out,
                                     (pt3){x, nn, ed->a, ed->b, t, -1,
                                           pf_v3_dist(c->pos[ed->a], c->pos[ed->b]) / (n + 1)},
                                     err));
        }
    }
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        const face_fn *f = &c->faces[c->face_id[lf]];
        /* Small faces get a grid of their own scale (about 2 points across) so that every face
         * carries samples: the data has a kink at each of its edges. */
        double own = fmin(1, f->diam / (2 * spacing));
        double sp = own * spacing / f->s, mg = own * margin / f->s;
        double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
        for (int32_t a = 0; a < f->n; ++a)
            for (int d = 0; d < 2; ++d) {
                lo[d] = fmin(lo[d], f->p2[2 * a + d]);
                hi[d] = fmax(hi[d], f->p2[2 * a + d]);
            }
        pf_vec3 nn = face_out_normal(c, lf);
        for (double pu = lo[0] + grid_phase * sp; pu < hi[0]; pu += sp)
            for (double pv = lo[1] + grid_phase * sp; pv < hi[1]; pv += sp) {
                if (!pf_polygon_contains(f->p2, f->n, pu, pv) ||
                    pf_polygon_boundary_distance(f->p2, f->n, pu, pv) < mg)
                    continue;
                pf_vec3 x = pf_v3_add(
                    f->o, pf_v3_add(pf_v3_scale(f->u, pu * f->s), pf_v3_scale(f->v, pv * f->s)));
                PF_TRY(pf_basis_pts_push(out, (pt3){x, nn, -1, -1, 0, lf, own * spacing}, err));
            }
    }
    return PF_OK;
}

/* ---- graded samples ------------------------------------------------------------------------ */

/* The sizing field min(h0, feat_i + s alpha |x - x_i|): a Lipschitz spacing that is the
 * feature size at every node and grows away from it at the rate s alpha; s (c->grade_scale,
 * 1 unless the cell is above its kernel budget) makes it grow faster. */
static double local_size(const elem_ctx *c, pf_vec3 x, double h0, double alpha)
{
    double h = h0;
    for (int32_t g = 0; g < c->ng; ++g) {
        int32_t i = c->grep[g];
        h = fmin(h, c->nfeat[i] + c->grade_scale * alpha * pf_v3_dist(x, c->pos[i]));
    }
    return h;
}

/* Whether edge s lies inside the patch (both its faces are patch faces). */
static bool edge_in_patch(const elem_ctx *c, const edge3 *ed)
{
    return c->has_patch && ed->f1 != ed->f2 && c->in_patch[ed->f1] && c->in_patch[ed->f2];
}

pf_status pf_basis_graded_samples(const elem_ctx *c, double h0e, double h0f, double alpha,
                                  double dive, double divf, int32_t edge_min, double margin_frac,
                                  pt_list *out, pf_error *err)
{
    out->n = 0;
    for (int32_t g = 0; g < c->ng; ++g) {
        int32_t i = c->grep[g];
        pf_vec3 nn = c->nnrm[i];
        double l = pf_v3_norm(nn);
        PF_TRY(
            pf_basis_pts_push(out,
                              (pt3){c->pos[i], l > 1e-6 ? pf_v3_scale(nn, 1 / l) : pf_v3(0, 0, 0),
                                    i, i, 0, -1, fmin(c->nlen[i], h0e)},
                              err));
    }
    enum { NSUB = 64 };
    for (int32_t s = 0; s < c->ne; ++s) {
        const edge3 *ed = &c->edges[s];
        pf_vec3 nn = pf_v3_add(face_out_normal(c, ed->f1), face_out_normal(c, ed->f2));
        double l = pf_v3_norm(nn);
        nn = l > 1e-6 ? pf_v3_scale(nn, 1 / l) : pf_v3(0, 0, 0);
        pf_vec3 xa = c->pos[ed->a], ev = pf_v3_sub(c->pos[ed->b], xa);
        double L = pf_v3_norm(ev), cum[NSUB + 1];
        cum[0] = 0;
        for (int q = 0; q < NSUB; ++q) {
            pf_vec3 x = pf_v3_add(xa, pf_v3_scale(ev, (q + 0.5) / NSUB));
            cum[q + 1] = cum[q] + L / NSUB / (local_size(c, x, h0e, alpha) / dive);
        }
        double tot = cum[NSUB];
        int32_t n = (int32_t)(ceil(tot - 1e-9) - 1);
        int32_t emin = c->patch_grading && edge_in_patch(c, ed) ? 0 : edge_min;
        if (n < emin)
            n = emin;
        int q = 0;
        for (int32_t j = 1; j <= n; ++j) {
            double target = tot * j / (n + 1);
            while (q < NSUB - 1 && cum[q + 1] < target)
                ++q;
            double t = (q + (target - cum[q]) / (cum[q + 1] - cum[q])) / NSUB;
            pf_vec3 x = pf_v3_add(xa, pf_v3_scale(ev, t));
            double sp = fmin(L / NSUB / (cum[q + 1] - cum[q]), L / (n + 1));
            PF_TRY(pf_basis_pts_push(out, (pt3){x, nn, ed->a, ed->b, t, -1, sp * dive}, err));
        }
    }
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        const face_fn *f = &c->faces[c->face_id[lf]];
        double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
        for (int32_t a = 0; a < f->n; ++a)
            for (int d = 0; d < 2; ++d) {
                lo[d] = fmin(lo[d], f->p2[2 * a + d]);
                hi[d] = fmax(hi[d], f->p2[2 * a + d]);
            }
        double ext = fmax(hi[0] - lo[0], hi[1] - lo[1]) * f->s, hf = h0f / divf;
        double root = hf;
        while (root < ext)
            root *= 2;
        pf_vec3 nn = face_out_normal(c, lf);
        double stk[64][3];
        int ns = 0;
        stk[ns][0] = lo[0] * f->s, stk[ns][1] = lo[1] * f->s, stk[ns][2] = root, ++ns;
        while (ns > 0) {
            --ns;
            double u0 = stk[ns][0], v0 = stk[ns][1], side = stk[ns][2];
            double cu = u0 + 0.5 * side, cv = v0 + 0.5 * side;
            pf_vec3 x = pf_v3_add(f->o, pf_v3_add(pf_v3_scale(f->u, cu), pf_v3_scale(f->v, cv)));
            double hl = fmin(h0f, local_size(c, x, h0f, alpha)) / divf;
            if (side > hl * 1.0000001 && ns + 4 <= 64 && side > 1e-6 * hf) {
                for (int k = 0; k < 4; ++k) {
                    stk[ns][0] = u0 + 0.5 * side * (k & 1);
                    stk[ns][1] = v0 + 0.5 * side * (k >> 1);
                    stk[ns][2] = 0.5 * side;
                    ++ns;
                }
                continue;
            }
            if (cu / f->s > hi[0] || cv / f->s > hi[1])
                continue;
            if (!pf_polygon_contains(f->p2, f->n, cu / f->s, cv / f->s) ||
                pf_polygon_boundary_distance(f->p2, f->n, cu / f->s, cv / f->s) <
                    margin_frac * side / f->s)
                continue;
            PF_TRY(pf_basis_pts_push(out, (pt3){x, nn, -1, -1, 0, lf, side * divf}, err));
        }
    }
    return PF_OK;
}

/* ---- the surface patch ------------------------------------------------------------------- */

static int32_t edge_index(const elem_ctx *c, int32_t u, int32_t v)
{
    int32_t lo = u < v ? u : v, hi = u < v ? v : u;
    for (int32_t s = 0; s < c->ne; ++s)
        if (c->edges[s].a == lo && c->edges[s].b == hi)
            return s;
    return -1;
}

/* Smooth approximate distance to the patch loop (R-function of trimmed segments), 2D scaled. */
static double loop_distance(const face_fn *f, double u, double v)
{
    double sum = 0;
    for (int32_t a = 0; a < f->n; ++a) {
        int32_t b = (a + 1) % f->n;
        double ax = f->p2[2 * a], ay = f->p2[2 * a + 1], bx = f->p2[2 * b], by = f->p2[2 * b + 1];
        double L = hypot(bx - ax, by - ay);
        if (!(L > 0))
            continue;
        double fe = ((u - ax) * (by - ay) - (v - ay) * (bx - ax)) / L;
        double cx = 0.5 * (ax + bx), cy = 0.5 * (ay + by);
        double te = (0.25 * L * L - ((u - cx) * (u - cx) + (v - cy) * (v - cy))) / L;
        double r = 0.5 * (sqrt(te * te + fe * fe * fe * fe) - te);
        double ph = sqrt(fe * fe + r * r);
        if (ph <= 0)
            return 0;
        sum += 1 / (ph * ph);
    }
    return sum > 0 ? 1 / sqrt(sum) : 0;
}

/* Width of an inner node's bump relative to its distance from the nearest other node. */
enum { BUMP_WIDTH_PERCENT = 50 };
#define BUMP_WIDTH (BUMP_WIDTH_PERCENT / 100.0)

/* Bump k: the smooth loop distance times a Gaussian about inner node k (zero on the loop). */
static double bump(const elem_ctx *c, int32_t k, double u, double v)
{
    double du = u - c->inner_q[2 * k], dv = v - c->inner_q[2 * k + 1], sg = c->inner_sig[k];
    return loop_distance(&c->patch, u, v) * exp(-(du * du + dv * dv) / (sg * sg));
}

/* The element's mesh-boundary faces (used by no other element) as one patch, when their
 * normals lie within maxdev degrees of their area-weighted mean (no crease), they are bounded
 * by one loop, and at most PATCH_MAX_INNER of their nodes lie off the loop. The loop projected
 * on the mean plane is a polygon: its 2D harmonic coordinates (pf_face_solve, the same solver
 * as every face) are the data of the loop nodes. */
pf_status pf_basis_patch_build(elem_ctx *c, double maxdev, const pf_basis_params *p, basis_ws *w,
                               pf_error *err)
{
    c->has_patch = false;
    c->n_inner = 0;
    if (!c->face_uses || c->nf > PATCH_MAX_FACES || !(maxdev > 0))
        return PF_OK;
    pf_vec3 mn = pf_v3(0, 0, 0);
    int32_t np = 0;
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        c->in_patch[lf] = c->face_uses[c->face_id[lf]] == 1;
        if (c->in_patch[lf]) {
            const face_fn *f = &c->faces[c->face_id[lf]];
            mn = pf_v3_add(mn, pf_v3_scale(face_out_normal(c, lf), f->diam * f->diam));
            ++np;
        }
    }
    if (np < 2)
        return PF_OK;
    mn = pf_v3_normalize(mn);
    for (int32_t lf = 0; lf < c->nf; ++lf)
        if (c->in_patch[lf] &&
            pf_v3_dot(face_out_normal(c, lf), mn) < cos(maxdev * 3.14159265358979323846 / 180))
            return PF_OK;
    /* loop edges: edges with exactly one patch face; a node in the patch must be on the loop */
    int32_t nloop = 0, lu[PF_BASIS_MAX_NODES], lv[PF_BASIS_MAX_NODES];
    bool on_loop[PF_BASIS_MAX_NODES] = {0}, on_patch[PF_BASIS_MAX_NODES] = {0};
    for (int32_t s = 0; s < c->ne; ++s) {
        const edge3 *ed = &c->edges[s];
        int cnt = c->in_patch[ed->f1] + (ed->f2 != ed->f1 && c->in_patch[ed->f2]);
        if (cnt > 0)
            on_patch[ed->a] = on_patch[ed->b] = true;
        if (cnt == 1) {
            if (nloop == PF_BASIS_MAX_NODES)
                return PF_OK;
            /* orientation: the patch face's order */
            int32_t lf = c->in_patch[ed->f1] ? ed->f1 : ed->f2;
            int64_t a = c->floc_off[lf], n = c->floc_off[lf + 1] - a;
            int32_t u = ed->a, v = ed->b;
            for (int64_t q = 0; q < n; ++q) {
                int32_t x0 = c->floc[a + q], x1 = c->floc[a + (q + 1) % n];
                if (c->slot[x0] == c->slot[ed->a] && c->slot[x1] == c->slot[ed->b])
                    u = ed->a, v = ed->b;
                if (c->slot[x0] == c->slot[ed->b] && c->slot[x1] == c->slot[ed->a])
                    u = ed->b, v = ed->a;
            }
            if (c->face_rev[lf]) {
                int32_t t = u;
                u = v, v = t;
            }
            lu[nloop] = u, lv[nloop] = v, ++nloop;
            on_loop[ed->a] = on_loop[ed->b] = true;
        }
    }
    c->n_inner = 0;
    for (int32_t i = 0; i < c->k; ++i)
        if (on_patch[i] && !on_loop[i]) {
            if (c->n_inner == PATCH_MAX_INNER)
                return PF_OK;
            c->inner[c->n_inner++] = i;
        }
    if (nloop < 3)
        return PF_OK;
    /* order the loop */
    int32_t order[PF_BASIS_MAX_NODES], cur = 0, cnt = 0;
    bool used[PF_BASIS_MAX_NODES] = {0};
    order[cnt++] = lu[0];
    used[0] = true;
    for (;;) {
        int32_t nx = -1;
        for (int32_t s = 0; s < nloop && nx < 0; ++s)
            if (!used[s] && lu[s] == lv[cur])
                nx = s;
        if (nx < 0)
            break;
        used[nx] = true;
        order[cnt++] = lu[nx];
        cur = nx;
    }
    if (cnt != nloop || lv[cur] != lu[0])
        return PF_OK;
    /* the loop as a face in the plane normal to mn */
    face_fn *f = &c->patch;
    memset(f, 0, sizeof *f);
    f->n = nloop;
    for (int32_t a = 0; a < nloop; ++a) {
        c->patch_loc[a] = order[a];
        c->patch_nodes[a] = (uint32_t)c->nodes[order[a]];
    }
    f->nodes = c->patch_nodes;
    pf_vec3 o = pf_v3(0, 0, 0);
    for (int32_t a = 0; a < nloop; ++a)
        o = pf_v3_add(o, c->pos[order[a]]);
    o = pf_v3_scale(o, 1.0 / nloop);
    double sx = 0, diam = 0;
    int32_t far = 0;
    for (int32_t a = 0; a < nloop; ++a) {
        pf_vec3 r = pf_v3_sub(c->pos[order[a]], o);
        r = pf_v3_sub(r, pf_v3_scale(mn, pf_v3_dot(r, mn)));
        if (pf_v3_norm(r) > sx)
            sx = pf_v3_norm(r), far = a;
        for (int32_t b2 = 0; b2 < a; ++b2)
            diam = fmax(diam, pf_v3_dist(c->pos[order[a]], c->pos[order[b2]]));
    }
    f->o = o, f->s = sx, f->diam = diam, f->nrm = mn;
    pf_vec3 r = pf_v3_sub(c->pos[order[far]], o);
    f->u = pf_v3_normalize(pf_v3_sub(r, pf_v3_scale(mn, pf_v3_dot(r, mn))));
    f->v = pf_v3_cross(mn, f->u);
    PF_CHECK(PF_ALLOC_N(f->p2, 2 * nloop), err, PF_ERR_NOMEM, "patch: no memory");
    c->has_patch = true; /* from here on the caller releases c->patch */
    for (int32_t a = 0; a < nloop; ++a)
        face_coords(f, c->pos[order[a]], &f->p2[2 * a], &f->p2[2 * a + 1]);
    /* counter-clockwise about mn: signed area */
    double ar = 0;
    for (int32_t a = 0; a < nloop; ++a) {
        int32_t b2 = (a + 1) % nloop;
        ar += f->p2[2 * a] * f->p2[2 * b2 + 1] - f->p2[2 * b2] * f->p2[2 * a + 1];
    }
    if (!(ar > 0)) {
        pf_face_release(f);
        c->has_patch = false;
        return PF_OK;
    }
    pf_mesh dummy = {0};
    PF_TRY(pf_face_solve(f, &dummy, -1, p, w, err));
    for (int32_t j = 0; j < c->n_inner; ++j) {
        pf_face_eval(f, c->pos[c->inner[j]], c->inner_phi + (size_t)j * nloop);
        face_coords(f, c->pos[c->inner[j]], &c->inner_q[2 * j], &c->inner_q[2 * j + 1]);
    }
    int32_t J = c->n_inner;
    for (int32_t j = 0; j < J; ++j) {
        double sg = INFINITY;
        for (int32_t a = 0; a < nloop; ++a)
            sg = fmin(sg, hypot(f->p2[2 * a] - c->inner_q[2 * j],
                                f->p2[2 * a + 1] - c->inner_q[2 * j + 1]));
        for (int32_t k = 0; k < J; ++k)
            if (k != j)
                sg = fmin(sg, hypot(c->inner_q[2 * k] - c->inner_q[2 * j],
                                    c->inner_q[2 * k + 1] - c->inner_q[2 * j + 1]));
        c->inner_sig[j] = sg * BUMP_WIDTH;
    }
    if (J > 0) {
        /* M_ik = g_k(q_i); D = M^-T by Gauss-Jordan */
        double M[PATCH_MAX_INNER][2 * PATCH_MAX_INNER];
        for (int32_t i = 0; i < J; ++i) {
            for (int32_t k = 0; k < J; ++k)
                M[i][k] = bump(c, k, c->inner_q[2 * i], c->inner_q[2 * i + 1]);
            for (int32_t k = 0; k < J; ++k)
                M[i][J + k] = i == k;
        }
        for (int32_t col = 0; col < J; ++col) {
            int32_t piv = col;
            for (int32_t rr = col + 1; rr < J; ++rr)
                if (fabs(M[rr][col]) > fabs(M[piv][col]))
                    piv = rr;
            if (!(fabs(M[piv][col]) > 1e-12)) {
                pf_face_release(f);
                c->has_patch = false;
                return PF_OK;
            }
            for (int32_t q = 0; q < 2 * J; ++q) {
                double t = M[col][q];
                M[col][q] = M[piv][q];
                M[piv][q] = t;
            }
            double d = 1 / M[col][col];
            for (int32_t q = 0; q < 2 * J; ++q)
                M[col][q] *= d;
            for (int32_t rr = 0; rr < J; ++rr)
                if (rr != col) {
                    double fct = M[rr][col];
                    for (int32_t q = 0; q < 2 * J; ++q)
                        M[rr][q] -= fct * M[col][q];
                }
        }
        /* Minv[i][k] = M[i][J + k]; D_jk = Minv[k][j] */
        for (int32_t j = 0; j < J; ++j)
            for (int32_t k = 0; k < J; ++k)
                c->inner_D[j * PATCH_MAX_INNER + k] = M[k][J + j];
    }
    c->has_patch = true;
    return PF_OK;
}

void pf_basis_patch_features(elem_ctx *c)
{
    bool on[PF_BASIS_MAX_NODES] = {0};
    for (int32_t s = 0; s < c->ne; ++s) {
        const edge3 *ed = &c->edges[s];
        if (c->in_patch[ed->f1] || c->in_patch[ed->f2])
            on[ed->a] = on[ed->b] = true;
    }
    for (int32_t i = 0; i < c->k; ++i)
        if (on[i])
            c->nfeat[i] = INFINITY;
    for (int32_t s = 0; s < c->ne; ++s) {
        const edge3 *ed = &c->edges[s];
        if (edge_in_patch(c, ed))
            continue;
        double len = pf_v3_dist(c->pos[ed->a], c->pos[ed->b]);
        if (on[ed->a])
            c->nfeat[ed->a] = fmin(c->nfeat[ed->a], len);
        if (on[ed->b])
            c->nfeat[ed->b] = fmin(c->nfeat[ed->b], len);
    }
    for (int32_t lf = 0; lf < c->nf; ++lf) {
        if (c->in_patch[lf])
            continue;
        int64_t a = c->floc_off[lf], n = c->floc_off[lf + 1] - a;
        for (int64_t q = 0; q < n; ++q) {
            int32_t i = c->floc[a + q];
            if (on[i])
                pf_basis_face_edge_feature(c, lf, i);
        }
    }
    for (int32_t j = 0; j < c->n_inner; ++j)
        c->nfeat[c->inner[j]] = c->inner_sig[j] * c->patch.s;
    for (int32_t i = 0; i < c->k; ++i)
        if (!(c->nfeat[i] < INFINITY))
            c->nfeat[i] = c->nlen[i];
}

bool pf_basis_patch_has(const elem_ctx *c, const pt3 *pt)
{
    if (!c->has_patch)
        return false;
    if (pt->face >= 0)
        return c->in_patch[pt->face];
    if (pt->a == pt->b)
        return false;
    int32_t s = edge_index(c, pt->a, pt->b);
    return s >= 0 && c->in_patch[c->edges[s].f1] && c->in_patch[c->edges[s].f2];
}

/* Patch data at pt: the loop's 2D harmonic coordinates phi_a (projected loop), each corrected
 * to vanish at the inner nodes, and the inner nodes' bumps psi_j:
 *   b_a = phi_a - sum_j phi_a(x_j) psi_j,  b_j = psi_j,
 * summed over merged groups; they sum to 1. Then the exactness projection of pf/basis.h, so the
 * data reproduce x exactly on the facets: the correction is (1, x) times a constant matrix, the
 * trace of a linear function, which the MFS space holds. */
void pf_basis_patch_values(const elem_ctx *c, const pt3 *pt, double *faceval, double *B, size_t ldb)
{
    int32_t J = c->n_inner;
    double G[PF_BASIS_MAX_NODES], psi[PATCH_MAX_INNER], gk[PATCH_MAX_INNER], pu, pv;
    face_coords(&c->patch, pt->x, &pu, &pv);
    for (int32_t k = 0; k < J; ++k)
        gk[k] = bump(c, k, pu, pv);
    for (int32_t j = 0; j < J; ++j) {
        psi[j] = 0;
        for (int32_t k = 0; k < J; ++k)
            psi[j] += c->inner_D[j * PATCH_MAX_INNER + k] * gk[k];
    }
    for (int32_t g = 0; g < c->ng; ++g)
        G[g] = 0;
    pf_face_eval(&c->patch, pt->x, faceval);
    for (int32_t a = 0; a < c->patch.n; ++a) {
        double v = faceval[a];
        for (int32_t j = 0; j < J; ++j)
            v -= c->inner_phi[(size_t)j * c->patch.n + a] * psi[j];
        G[c->slot[c->patch_loc[a]]] += v;
    }
    for (int32_t j = 0; j < J; ++j)
        G[c->slot[c->inner[j]]] += psi[j];
    pf_vec3 y = pf_v3_scale(pf_v3_sub(pt->x, c->c), 1 / c->h);
    double t[4] = {1, y.x, y.y, y.z};
    apply_projection(3, c->ng, c->gpos, c->gq, t, G);
    for (int32_t g = 0; g < c->ng; ++g)
        B[(size_t)g * ldb] = G[g];
}
