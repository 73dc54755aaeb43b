/* Quadrature over polyhedra for integrands that are not polynomials (harmonic shape functions).
 *
 * A convex polyhedron is a cone from its node average over its faces, each face a fan of
 * triangles, so a union of tetrahedra. A non-convex one is the same cone from a point that sees
 * every face from inside, when there is one (star-shaped; faces then triangulated by ear
 * clipping, as they may be non-convex); otherwise it is cut into pieces by the planes of its
 * reflex faces (pf_poly_split: a face is reflex when some node lies beyond its plane) until
 * they are star-shaped or convex. A tetrahedron gets the collapsed-coordinate (Duffy)
 * product of Gauss-Legendre rules: with (a, b, c) in [0, 1]^3,
 *     x = v0 + a e1 + b (1 - a) e2 + c (1 - a)(1 - b) e3,   dx = 6 V (1 - a)^2 (1 - b) da db dc,
 * so a polynomial of degree d in x becomes one of degree d + 2 in a, d + 1 in b, d in c, and n
 * Gauss points per direction, exact to degree 2n - 1, integrate it exactly for d <= 2n - 3. All
 * weights are positive. */
#include <pf/integrate.h>
#include <pf/split.h>

#include <math.h>
#include <stdbool.h>
#include <string.h>

enum { MAX_POINTS_1D = 16, MAX_CONVEX_DEPTH = 64, MAX_LOCAL_PLANES = 64 };

/* A star-shaped polyhedron's apex keeps this fraction of its diagonal from every face plane. */
static const double STAR_MARGIN = 0.02;

void pf_gauss_legendre(int n, double *nodes, double *weights)
{
    /* Newton on P_n from Chebyshev-like initial guesses; nodes and weights mapped to [0, 1]. */
    for (int i = 0; i < n; ++i) {
        double x = cos(3.14159265358979323846 * (i + 0.75) / (n + 0.5)), dp = 1;
        for (int iter = 0; iter < 100; ++iter) {
            double p0 = 1, p1 = x;
            for (int k = 2; k <= n; ++k) {
                double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            double pn = n == 1 ? x : p1, pm = n == 1 ? 1 : p0;
            dp = n * (x * pn - pm) / (x * x - 1);
            double dx = pn / dp;
            x -= dx;
            if (fabs(dx) < 1e-16)
                break;
        }
        nodes[i] = 0.5 * (1 - x);
        weights[i] = 1 / ((1 - x * x) * dp * dp); /* 2 / ((1 - x^2) P'^2), halved for [0, 1] */
    }
}

void pf_quadrature_release(pf_quadrature *q)
{
    pf_free(q->x);
    pf_free(q->w);
    memset(q, 0, sizeof *q);
}

static pf_status push_point(pf_quadrature *q, pf_vec3 p, double w, int64_t *cap, pf_error *err)
{
    if (q->n == *cap) {
        int64_t c = *cap ? 2 * *cap : 256;
        double *x = pf_realloc_array(q->x, 3 * (size_t)c, sizeof *x);
        if (x)
            q->x = x;
        double *ww = pf_realloc_array(q->w, (size_t)c, sizeof *ww);
        if (ww)
            q->w = ww;
        PF_CHECK(x && ww, err, PF_ERR_NOMEM, "cannot allocate %lld quadrature points",
                 (long long)c);
        *cap = c;
    }
    q->x[3 * q->n] = p.x;
    q->x[3 * q->n + 1] = p.y;
    q->x[3 * q->n + 2] = p.z;
    q->w[q->n++] = w;
    return PF_OK;
}

typedef struct rule {
    bool tets;   /* collect the tetrahedra themselves (4 points each) instead of a rule */
    double flat; /* with tets: |6 V| at or below this is a flat tet (a zero volume's rounding) */
    int n;
    double node[MAX_POINTS_1D], weight[MAX_POINTS_1D];
    pf_quadrature *out;
    int64_t cap;
    pf_plane planes[MAX_LOCAL_PLANES]; /* face planes of a polyhedron with few faces */
    pf_arena scratch; /* face triangulations of star-shaped cells and the planes of polyhedra
                         with more faces, made on first use */
} rule;

static pf_status add_tet(rule *r, pf_vec3 v0, pf_vec3 v1, pf_vec3 v2, pf_vec3 v3, pf_error *err)
{
    pf_vec3 e1 = pf_v3_sub(v1, v0), e2 = pf_v3_sub(v2, v0), e3 = pf_v3_sub(v3, v0);
    double six_v = pf_v3_dot(e1, pf_v3_cross(e2, e3)); /* signed: reversed tets subtract */
    if (six_v == 0)
        return PF_OK;
    if (r->tets) {
        if (fabs(six_v) <= r->flat)
            return PF_OK;
        const pf_vec3 v[4] = {v0, v1, v2, v3};
        for (int i = 0; i < 4; ++i)
            PF_TRY(push_point(r->out, v[i], six_v / 24, &r->cap, err));
        return PF_OK;
    }
    for (int i = 0; i < r->n; ++i)
        for (int j = 0; j < r->n; ++j)
            for (int k = 0; k < r->n; ++k) {
                double a = r->node[i], b = r->node[j], c = r->node[k];
                pf_vec3 p =
                    pf_v3_add(v0, pf_v3_add(pf_v3_scale(e1, a),
                                            pf_v3_add(pf_v3_scale(e2, b * (1 - a)),
                                                      pf_v3_scale(e3, c * (1 - a) * (1 - b)))));
                double w = r->weight[i] * r->weight[j] * r->weight[k] * six_v * (1 - a) * (1 - a) *
                           (1 - b);
                PF_TRY(push_point(r->out, p, w, &r->cap, err));
            }
    return PF_OK;
}

/* The cone from apex c over the fans of p's faces: a decomposition into tetrahedra when every
 * face plane has c on its inner side (p convex, or star-shaped about c). */
static pf_status add_cone(rule *r, const pf_polyhedron *p, pf_vec3 c, pf_error *err)
{
    for (int32_t f = 0; f < p->n_faces; ++f) {
        const uint32_t *idx = p->face_nodes + p->face_offsets[f];
        int64_t n = p->face_offsets[f + 1] - p->face_offsets[f];
        pf_vec3 a = pf_v3_load(p->x + 3 * (size_t)idx[0]);
        for (int64_t k = 1; k + 1 < n; ++k)
            PF_TRY(add_tet(r, c, a, pf_v3_load(p->x + 3 * (size_t)idx[k]),
                           pf_v3_load(p->x + 3 * (size_t)idx[k + 1]), err));
    }
    return PF_OK;
}

static pf_vec3 node_average(const pf_polyhedron *p)
{
    pf_vec3 c = {0, 0, 0};
    int64_t count = p->face_offsets[p->n_faces];
    for (int64_t k = 0; k < count; ++k)
        c = pf_v3_add(c, pf_v3_load(p->x + 3 * (size_t)p->face_nodes[k]));
    return pf_v3_scale(c, 1.0 / (double)count);
}

/* scratch with room for bytes (its contents lost). */
static pf_status reserve_scratch(rule *r, size_t bytes, pf_error *err)
{
    pf_arena_reset(&r->scratch, 0);
    if (r->scratch.capacity >= bytes)
        return PF_OK;
    pf_arena_release(&r->scratch);
    return pf_arena_init(&r->scratch, 2 * bytes, err);
}

/* The outward unit-normal planes of p's faces (in r->planes, or in scratch for more than
 * MAX_LOCAL_PLANES faces: no allocation for the usual cell); a degenerate face gets a zero
 * normal (every point then lies on it at distance -d = 0, never beyond it or violating it). */
static pf_status face_planes(rule *r, const pf_polyhedron *p, pf_plane **out, pf_error *err)
{
    pf_plane *pl = r->planes;
    if (p->n_faces > MAX_LOCAL_PLANES) {
        PF_TRY(reserve_scratch(r, (size_t)p->n_faces * sizeof *pl + 64, err));
        pl = pf_arena_push(&r->scratch, (size_t)p->n_faces, sizeof *pl);
    }
    for (int32_t f = 0; f < p->n_faces; ++f) {
        const uint32_t *idx = p->face_nodes + p->face_offsets[f];
        int64_t n = p->face_offsets[f + 1] - p->face_offsets[f];
        pf_vec3 normal = pf_polygon_area_vector(p->x, idx, n);
        pl[f] = pf_v3_norm(normal) == 0
                    ? (pf_plane){{0, 0, 0}, 0}
                    : pf_plane_from_point_normal(pf_v3_load(p->x + 3 * (size_t)idx[0]), normal);
    }
    *out = pl;
    return PF_OK;
}

/* A point at least margin inside every face plane of p, so that p is star-shaped about it and
 * the cone from it is a decomposition: cyclic projections onto the violated half-spaces
 * (Agmon-Motzkin relaxation; each moves the point just past its plane), from the node
 * average. False when STAR_SWEEPS sweeps leave a plane violated (no such point, or a thin one).
 * A non-convex sliced cell (a cube cut by a curved sheet of facets) usually has one: one cone
 * then replaces the many convex pieces of cutting it by its reflex planes (5x fewer points for
 * the cells of a coarsely sliced bunny). */
static bool star_center(const pf_polyhedron *p, const pf_plane *planes, double margin, pf_vec3 *c)
{
    enum { STAR_SWEEPS = 64 };
    pf_vec3 x = node_average(p);
    for (int sweep = 0; sweep < STAR_SWEEPS; ++sweep) {
        bool moved = false;
        for (int32_t f = 0; f < p->n_faces; ++f) {
            if (pf_v3_norm(planes[f].n) == 0)
                continue;
            double d = pf_plane_signed_distance(planes[f], x);
            if (d > -margin) {
                x = pf_v3_sub(x, pf_v3_scale(planes[f].n, d + 1.5 * margin));
                moved = true;
            }
        }
        if (!moved) {
            *c = x;
            return true;
        }
    }
    return false;
}

/* The cone from c over p's faces, each triangulated in its plane (ear clipping when it is not
 * convex: the faces of a cut cell, unlike those of its convex pieces, may not be), as for a
 * star-shaped p: added when every tetrahedron has positive volume, else *ok false (also for a
 * face that is not simple) and nothing added. */
static pf_status add_star_cone(rule *r, const pf_polyhedron *p, pf_vec3 c, bool *ok, pf_error *err)
{
    int64_t nmax = 3, ntri = 0;
    for (int32_t f = 0; f < p->n_faces; ++f) {
        int64_t n = p->face_offsets[f + 1] - p->face_offsets[f];
        nmax = n > nmax ? n : nmax;
        ntri += n - 2;
    }
    PF_TRY(reserve_scratch(r,
                           3 * (size_t)(ntri + nmax) * sizeof(uint32_t) +
                               2 * (size_t)nmax * (sizeof(double) + sizeof(int32_t)) + 128,
                           err));
    uint32_t *tri = pf_arena_push(&r->scratch, 3 * (size_t)ntri, sizeof *tri);
    uint32_t *local = pf_arena_push(&r->scratch, 3 * (size_t)nmax, sizeof *local);
    /* Node indices of every triangle, then the sign check, then the points. */
    int64_t t = 0;
    for (int32_t f = 0; f < p->n_faces; ++f) {
        const uint32_t *idx = p->face_nodes + p->face_offsets[f];
        int32_t n = (int32_t)(p->face_offsets[f + 1] - p->face_offsets[f]);
        PF_TRY(pf_polygon_triangulate(p->x, idx, n, &r->scratch, local, NULL, err));
        for (int32_t k = 0; k < 3 * (n - 2); ++k)
            tri[3 * t + k] = idx[local[k]];
        t += n - 2;
    }
    *ok = true;
    for (int64_t k = 0; k < ntri && *ok; ++k) {
        pf_vec3 a = pf_v3_sub(pf_v3_load(p->x + 3 * (size_t)tri[3 * k]), c);
        pf_vec3 b = pf_v3_sub(pf_v3_load(p->x + 3 * (size_t)tri[3 * k + 1]), c);
        pf_vec3 d = pf_v3_sub(pf_v3_load(p->x + 3 * (size_t)tri[3 * k + 2]), c);
        *ok = pf_v3_dot(a, pf_v3_cross(b, d)) > 0;
    }
    for (int64_t k = 0; k < ntri && *ok; ++k)
        PF_TRY(add_tet(r, c, pf_v3_load(p->x + 3 * (size_t)tri[3 * k]),
                       pf_v3_load(p->x + 3 * (size_t)tri[3 * k + 1]),
                       pf_v3_load(p->x + 3 * (size_t)tri[3 * k + 2]), err));
    return PF_OK;
}

/* The plane of a face some node lies beyond (by more than tol), or false when p is convex. */
static bool reflex_plane(const pf_polyhedron *p, const pf_plane *planes, double tol,
                         pf_plane *plane)
{
    int64_t count = p->face_offsets[p->n_faces];
    double worst = tol;
    bool found = false;
    for (int32_t f = 0; f < p->n_faces; ++f)
        for (int64_t k = 0; k < count; ++k) {
            double d = pf_plane_signed_distance(planes[f],
                                                pf_v3_load(p->x + 3 * (size_t)p->face_nodes[k]));
            if (d > worst) {
                worst = d;
                *plane = planes[f];
                found = true;
            }
        }
    return found;
}

static pf_status add_pieces(rule *r, const pf_polyhedron *p, int32_t n_nodes, double tol,
                            double size, int depth, pf_error *err)
{
    pf_plane *planes, plane;
    PF_TRY(face_planes(r, p, &planes, err));
    if (!reflex_plane(p, planes, tol, &plane))
        return add_cone(r, p, node_average(p), err);
    pf_vec3 apex;
    if (star_center(p, planes, STAR_MARGIN * size, &apex)) {
        bool ok; /* planes are lost from here: the scratch is reused */
        PF_TRY(add_star_cone(r, p, apex, &ok, err));
        if (ok)
            return PF_OK;
    }
    PF_CHECK(depth < MAX_CONVEX_DEPTH, err, PF_ERR_NUMERIC,
             "polyhedron not convex after %d cuts by its reflex faces", MAX_CONVEX_DEPTH);
    pf_split s;
    pf_split_params params = {.tol = tol};
    PF_TRY(pf_poly_split(p, n_nodes, &plane, &params, &s, err));
    pf_status st = PF_OK;
    for (int32_t k = 0; st >= 0 && k < s.n_pieces; ++k) {
        pf_polyhedron piece = {s.x, (int32_t)(s.piece_faces[k + 1] - s.piece_faces[k]),
                               s.face_offsets + s.piece_faces[k], s.face_nodes};
        st = add_pieces(r, &piece, s.n_nodes, tol, size, depth + 1, err);
    }
    pf_split_release(&s);
    return st;
}

pf_status pf_polyhedron_quadrature(const pf_polyhedron *p, int32_t n_nodes, int degree,
                                   pf_quadrature *q, pf_error *err)
{
    memset(q, 0, sizeof *q);
    int n = (degree + 4) / 2; /* 2n - 3 >= degree */
    PF_CHECK(degree >= 0 && n <= MAX_POINTS_1D, err, PF_ERR_INVALID,
             "quadrature degree must be in [0, %d], got %d", 2 * MAX_POINTS_1D - 3, degree);
    PF_CHECK(p->n_faces > 0, err, PF_ERR_INVALID, "polyhedron without faces");
    rule r = {.n = n, .out = q};
    pf_gauss_legendre(n, r.node, r.weight);
    pf_vec3 lo, hi;
    pf_polyhedron_bounds(p, &lo, &hi);
    double size = pf_v3_norm(pf_v3_sub(hi, lo));
    pf_status st = add_pieces(&r, p, n_nodes, 1e-10 * size, size, 0, err);
    pf_arena_release(&r.scratch);
    if (st < 0)
        pf_quadrature_release(q);
    return st;
}

pf_status pf_polyhedron_tetrahedra(const pf_polyhedron *p, int32_t n_nodes, double **tets,
                                   int64_t *n_tets, pf_error *err)
{
    *tets = NULL;
    *n_tets = 0;
    PF_CHECK(p->n_faces > 0, err, PF_ERR_INVALID, "polyhedron without faces");
    pf_quadrature q = {0};
    pf_vec3 lo, hi;
    pf_polyhedron_bounds(p, &lo, &hi);
    double size = pf_v3_norm(pf_v3_sub(hi, lo));
    /* a cone over a face with collinear nodes, or over a face through the apex, gives tets of
     * zero volume whose computed 6 V is rounding, ~1e-16 size^3, of either sign */
    rule r = {.tets = true, .flat = 1e-12 * size * size * size, .out = &q};
    pf_status st = add_pieces(&r, p, n_nodes, 1e-10 * size, size, 0, err);
    pf_arena_release(&r.scratch);
    if (st >= 0) {
        *tets = q.x;
        *n_tets = q.n / 4;
        q.x = NULL;
    }
    pf_quadrature_release(&q);
    return st;
}
