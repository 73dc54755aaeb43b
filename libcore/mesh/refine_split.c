/* One element of pf_mesh_refine cut into its children: the octs planes from the principal axes of
 * its second moments (harmonic paper sec. 8: "three planes through the centroid"; for a box the
 * regular 1-to-8 subdivision) or the halves plane, each applied by pf_poly_split to every piece
 * the earlier planes made, with the sliver rule and a bound on the pieces (at most twice as many
 * after a plane as before it). Everything here is in the element's own node numbering
 * (refine_local); refine.c puts the children into the mesh. */
#include <pf/integrate.h>

#include "refine_internal.h"

#include <math.h>
#include <string.h>

/* ---- local nodes and piece sets ----------------------------------------------------------- */

pf_status pf_refine_grow(void *pp, int64_t *cap, int64_t need, size_t size, pf_error *err)
{
    if (need <= *cap)
        return PF_OK;
    PF_CHECK(need < INT32_MAX || size <= sizeof(uint32_t), err, PF_ERR_TOO_LARGE,
             "refine: the mesh would exceed 2^31 entries");
    int64_t n = *cap ? 2 * *cap : 16;
    while (n < need)
        n *= 2;
    void **p = pp;
    void *q = pf_realloc_array(*p, (size_t)n, size);
    PF_CHECK(q, err, PF_ERR_NOMEM, "refine: out of memory");
    *p = q;
    *cap = n;
    return PF_OK;
}

void pf_refine_local_release(refine_local *L)
{
    refine_pieces *ps[2] = {&L->cur, &L->next};
    for (int i = 0; i < 2; ++i) {
        pf_free(ps[i]->first_face);
        pf_free(ps[i]->volume);
        pf_free(ps[i]->off);
        pf_free(ps[i]->origin);
        pf_free(ps[i]->nodes);
    }
    pf_free(L->x);
    pf_free(L->glob);
    memset(L, 0, sizeof *L);
}

pf_status pf_refine_local_reserve(refine_local *L, int64_t n, pf_error *err)
{
    if (n <= L->cap)
        return PF_OK;
    int64_t cap = L->cap;
    PF_TRY(pf_refine_grow(&L->glob, &cap, n, sizeof *L->glob, err));
    double *x = pf_realloc_array(L->x, 3 * (size_t)cap, sizeof *x);
    PF_CHECK(x, err, PF_ERR_NOMEM, "refine: out of memory");
    L->x = x;
    L->cap = cap;
    return PF_OK;
}

pf_status pf_refine_local_node(refine_local *L, const double *p, int32_t *id, pf_error *err)
{
    /* A new node of one plane lies on an edge shared by at most a few pieces: a short scan of
     * the new nodes finds it (they are a few dozen for a hexahedron's octs). */
    for (int32_t i = L->n_orig; i < L->n; ++i) {
        const double *q = L->x + 3 * (size_t)i;
        if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) {
            *id = i;
            return PF_OK;
        }
    }
    PF_TRY(pf_refine_local_reserve(L, (int64_t)L->n + 1, err));
    memcpy(L->x + 3 * (size_t)L->n, p, 3 * sizeof *p);
    L->glob[L->n] = -1;
    *id = L->n++;
    return PF_OK;
}

void pf_refine_pieces_clear(refine_pieces *ps)
{
    ps->n = 0;
    ps->n_faces = 0;
}

pf_status pf_refine_pieces_begin(refine_pieces *ps, pf_error *err)
{
    if ((int64_t)ps->n + 2 > ps->cap) {
        int64_t cap = ps->cap;
        PF_TRY(
            pf_refine_grow(&ps->first_face, &cap, (int64_t)ps->n + 2, sizeof *ps->first_face, err));
        double *v = pf_realloc_array(ps->volume, (size_t)cap, sizeof *v);
        PF_CHECK(v, err, PF_ERR_NOMEM, "refine: out of memory");
        ps->volume = v;
        ps->cap = cap;
    }
    if (ps->n == 0)
        ps->first_face[0] = 0;
    ps->volume[ps->n] = 0;
    ps->n++;
    ps->first_face[ps->n] = ps->n_faces;
    return PF_OK;
}

pf_status pf_refine_pieces_face(refine_pieces *ps, const uint32_t *nodes, int64_t n, int32_t origin,
                                pf_error *err)
{
    if ((int64_t)ps->n_faces + 2 > ps->cap_faces) {
        int64_t cap = ps->cap_faces;
        PF_TRY(pf_refine_grow(&ps->off, &cap, (int64_t)ps->n_faces + 2, sizeof *ps->off, err));
        int32_t *o = pf_realloc_array(ps->origin, (size_t)cap, sizeof *o);
        PF_CHECK(o, err, PF_ERR_NOMEM, "refine: out of memory");
        ps->origin = o;
        ps->cap_faces = cap;
    }
    if (ps->n_faces == 0)
        ps->off[0] = 0;
    int64_t at = ps->off[ps->n_faces];
    PF_TRY(pf_refine_grow(&ps->nodes, &ps->cap_nodes, at + n, sizeof *ps->nodes, err));
    memcpy(ps->nodes + at, nodes, (size_t)n * sizeof *nodes);
    ps->origin[ps->n_faces] = origin;
    ps->n_faces++;
    ps->off[ps->n_faces] = at + n;
    ps->first_face[ps->n] = ps->n_faces;
    return PF_OK;
}

pf_polyhedron pf_refine_piece_view(const refine_local *L, const refine_pieces *ps, int32_t k)
{
    int64_t f0 = ps->first_face[k];
    return (pf_polyhedron){L->x, (int32_t)(ps->first_face[k + 1] - f0), ps->off + f0, ps->nodes};
}

/* ---- the octs planes ----------------------------------------------------------------------- */

/* v with its largest component (the first of equal ones) made positive: a deterministic sign.
 * Components below 1e-12 are rounding (of the moments of a face with extra collinear nodes, or of
 * the Jacobi rotations) and are dropped, so that a box's planes are exactly its axes. */
static pf_vec3 canonical_sign(pf_vec3 v)
{
    v = pf_v3(fabs(v.x) < 1e-12 ? 0 : v.x, fabs(v.y) < 1e-12 ? 0 : v.y,
              fabs(v.z) < 1e-12 ? 0 : v.z);
    v = pf_v3_normalize(v);
    double c[3] = {v.x, v.y, v.z};
    int k = 0;
    for (int i = 1; i < 3; ++i)
        if (fabs(c[i]) > fabs(c[k]))
            k = i;
    return c[k] < 0 ? pf_v3_scale(v, -1) : v;
}

static pf_vec3 axis_unit(int i)
{
    return pf_v3(i == 0, i == 1, i == 2);
}

/* The unit vector of the plane orthogonal to n (unit) nearest to a coordinate axis: the
 * projection of the axis with the longest projection, the first of equal ones (ties toward x). */
static pf_vec3 nearest_axis_in_plane(pf_vec3 n)
{
    double c[3] = {n.x, n.y, n.z};
    int best = 0;
    for (int i = 1; i < 3; ++i)
        if (fabs(c[i]) < fabs(c[best]) - 1e-12)
            best = i;
    pf_vec3 e = axis_unit(best);
    return pf_v3_normalize(pf_v3_sub(e, pf_v3_scale(n, c[best])));
}

pf_status pf_refine_element_axes(const pf_polyhedron *p, double *vol, pf_vec3 *centroid,
                                 pf_vec3 axes[3], pf_error *err)
{
    pf_frame frame = pf_frame_of_polyhedron(p);
    double m[10];
    PF_TRY(pf_polyhedron_moments(p, &frame, 2, m, err));
    *vol = m[0];
    PF_CHECK(m[0] > 0 && isfinite(m[0]), err, PF_ERR_INVALID, "volume %g is not positive", m[0]);
    /* Centroid and central second moments in the local frame: int xhat_a xhat_b - V c_a c_b. */
    double c[3] = {m[pf_moment_index(1, 0, 0)] / m[0], m[pf_moment_index(0, 1, 0)] / m[0],
                   m[pf_moment_index(0, 0, 1)] / m[0]};
    *centroid = pf_v3_add(frame.center, pf_v3_scale(pf_v3(c[0], c[1], c[2]), frame.scale));
    pf_mat3 s;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            int e[3] = {0, 0, 0};
            e[a]++;
            e[b]++;
            s.m[a][b] = m[pf_moment_index(e[0], e[1], e[2])] - m[0] * c[a] * c[b];
        }
    double val[3];
    pf_mat3 vec;
    pf_mat3_sym_eigen(s, val, &vec);
    PF_CHECK(isfinite(val[0]) && isfinite(val[2]), err, PF_ERR_NUMERIC,
             "second moments are not finite");
    pf_vec3 v[3];
    for (int i = 0; i < 3; ++i)
        v[i] = pf_v3(vec.m[0][i], vec.m[1][i], vec.m[2][i]);
    /* Moments equal within 1e-10 of the largest (rounding of exact moments is ~1e-16) span an
     * eigenspace in which any basis is principal: pick the one nearest to x, y, z. */
    double tie = 1e-10 * fabs(val[2]);
    bool eq01 = val[1] - val[0] <= tie, eq12 = val[2] - val[1] <= tie;
    if (eq01 && eq12) {
        for (int i = 0; i < 3; ++i)
            axes[i] = axis_unit(i);
        return PF_OK;
    }
    if (eq01 || eq12) {
        /* One distinct axis u, a plane of equal moments orthogonal to it. */
        pf_vec3 u = canonical_sign(eq01 ? v[2] : v[0]);
        pf_vec3 a = canonical_sign(nearest_axis_in_plane(u));
        pf_vec3 b = canonical_sign(pf_v3_cross(u, a));
        if (eq01) { /* the distinct moment is the largest */
            axes[0] = u, axes[1] = a, axes[2] = b;
        } else {
            axes[0] = a, axes[1] = b, axes[2] = u;
        }
        return PF_OK;
    }
    for (int i = 0; i < 3; ++i)
        axes[i] = canonical_sign(v[2 - i]);
    return PF_OK;
}

/* ---- the planes applied to every piece ----------------------------------------------------- */

/* Splits every piece of L->cur by pl into L->next (on-plane tolerance tol, 0: pf_poly_split's);
 * *cut when some piece was split, *smallest the smallest resulting volume. */
static pf_status split_all(refine_local *L, const pf_plane *pl, double tol, bool closed, bool *cut,
                           double *smallest, pf_error *err)
{
    refine_pieces *cur = &L->cur, *next = &L->next;
    pf_refine_pieces_clear(next);
    pf_split_params sp = pf_split_params_default();
    sp.tol = tol;
    sp.assume_closed = closed; /* pieces of a split are closed; the element is checked */
    *cut = false;
    pf_status st = PF_OK;
    for (int32_t k = 0; k < cur->n && st >= 0; ++k) {
        pf_polyhedron view = pf_refine_piece_view(L, cur, k);
        int64_t f0 = cur->first_face[k];
        pf_split s;
        st = pf_poly_split(&view, L->n, pl, &sp, &s, err);
        if (st < 0)
            break;
        /* pf_poly_split's new nodes, merged with those of earlier pieces by exact coordinates
         * (its node formula makes a shared edge's node bit-identical in both pieces). */
        int32_t *map = pf_alloc_array((size_t)s.n_nodes + 1, sizeof *map);
        uint32_t *face =
            pf_alloc_array((size_t)(s.n_faces ? s.face_offsets[s.n_faces] : 0) + 1, sizeof *face);
        if (!map || !face)
            st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "refine: out of memory");
        for (int32_t i = 0; i < s.n_nodes && st >= 0; ++i)
            if (i < s.n_input_nodes)
                map[i] = i;
            else
                st = pf_refine_local_node(L, s.x + 3 * (size_t)i, &map[i], err);
        if (s.n_pieces > 1)
            *cut = true;
        for (int32_t q = 0; q < s.n_pieces && st >= 0; ++q) {
            st = pf_refine_pieces_begin(next, err);
            for (int64_t f = s.piece_faces[q]; f < s.piece_faces[q + 1] && st >= 0; ++f) {
                int64_t n = s.face_offsets[f + 1] - s.face_offsets[f];
                for (int64_t j = 0; j < n; ++j)
                    face[j] = (uint32_t)map[s.face_nodes[s.face_offsets[f] + j]];
                int32_t src = s.face_source[f];
                st = pf_refine_pieces_face(next, face, n, src >= 0 ? cur->origin[f0 + src] : -1,
                                           err);
            }
        }
        pf_free(map);
        pf_free(face);
        pf_split_release(&s);
    }
    if (st < 0)
        return st;
    *smallest = INFINITY;
    for (int32_t k = 0; k < next->n; ++k) {
        pf_polyhedron view = pf_refine_piece_view(L, next, k);
        next->volume[k] = pf_polyhedron_volume(&view);
        if (next->volume[k] < *smallest)
            *smallest = next->volume[k];
    }
    return PF_OK;
}

/* ---- planes through the nodes near them ------------------------------------------------------ */

/* The bounding-box diagonal of the element (its own nodes, before any plane). */
static double element_diagonal(const refine_local *L)
{
    pf_vec3 lo = pf_v3_load(L->x), hi = lo;
    for (int32_t i = 1; i < L->n_orig; ++i) {
        pf_vec3 p = pf_v3_load(L->x + 3 * (size_t)i);
        lo = pf_v3(fmin(lo.x, p.x), fmin(lo.y, p.y), fmin(lo.z, p.z));
        hi = pf_v3(fmax(hi.x, p.x), fmax(hi.y, p.y), fmax(hi.z, p.z));
    }
    return pf_v3_dist(lo, hi);
}

/* The least change of pl, a turn and a shift, that puts the nodes of L within band of it on it:
 * with pl's normal n, two unit vectors t1, t2 across it, the near nodes' mean r and
 * y_i = (x_i - r) / diag, the plane (n + a t1 + b t2) . (x - r) = h + e diag (h: pl's offset at
 * r) holds node i when a t1.y_i + b t2.y_i - e = -d_i / diag, d_i its distance from pl. The
 * least-squares solution of least norm (a, b, e) comes from the normal equations through their
 * eigenvectors, eigenvalues below 1e-12 of the largest dropped (near nodes along a line leave
 * the turn about it free: none is taken). *resid: the largest distance of a near node from the
 * result (pl itself when no node is near). */
static pf_plane fit_plane(const refine_local *L, pf_plane pl, double diag, double band,
                          double *resid)
{
    pf_vec3 r = pf_v3(0, 0, 0);
    int32_t n_near = 0;
    for (int32_t i = 0; i < L->n; ++i) {
        pf_vec3 x = pf_v3_load(L->x + 3 * (size_t)i);
        if (fabs(pf_plane_signed_distance(pl, x)) < band) {
            r = pf_v3_add(r, x);
            n_near++;
        }
    }
    *resid = 0;
    if (n_near == 0)
        return pl;
    r = pf_v3_scale(r, 1.0 / n_near);
    pf_vec3 t1 =
        pf_v3_normalize(pf_v3_cross(pl.n, fabs(pl.n.x) < 0.6 ? pf_v3(1, 0, 0) : pf_v3(0, 1, 0)));
    pf_vec3 t2 = pf_v3_cross(pl.n, t1);
    pf_mat3 m = {{{0}}};
    double rhs[3] = {0, 0, 0};
    for (int32_t i = 0; i < L->n; ++i) {
        pf_vec3 x = pf_v3_load(L->x + 3 * (size_t)i);
        double d = pf_plane_signed_distance(pl, x);
        if (!(fabs(d) < band))
            continue;
        pf_vec3 y = pf_v3_scale(pf_v3_sub(x, r), 1.0 / diag);
        double row[3] = {pf_v3_dot(t1, y), pf_v3_dot(t2, y), -1};
        for (int a = 0; a < 3; ++a) {
            rhs[a] -= row[a] * d / diag;
            for (int b = 0; b < 3; ++b)
                m.m[a][b] += row[a] * row[b];
        }
    }
    double val[3];
    pf_mat3 v;
    pf_mat3_sym_eigen(m, val, &v);
    double u[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) {
        if (!(val[k] > 1e-12 * val[2]))
            continue;
        double c = (v.m[0][k] * rhs[0] + v.m[1][k] * rhs[1] + v.m[2][k] * rhs[2]) / val[k];
        for (int a = 0; a < 3; ++a)
            u[a] += c * v.m[a][k];
    }
    pf_vec3 nn = pf_v3_add(pl.n, pf_v3_add(pf_v3_scale(t1, u[0]), pf_v3_scale(t2, u[1])));
    double len = pf_v3_norm(nn), h = pl.d - pf_v3_dot(pl.n, r);
    pf_plane fit = {pf_v3_scale(nn, 1.0 / len), (h + u[2] * diag + pf_v3_dot(nn, r)) / len};
    for (int32_t i = 0; i < L->n; ++i) {
        pf_vec3 x = pf_v3_load(L->x + 3 * (size_t)i);
        if (fabs(pf_plane_signed_distance(pl, x)) < band)
            *resid = fmax(*resid, fabs(pf_plane_signed_distance(fit, x)));
    }
    return fit;
}

/* Whether splitting the pieces of L by pl makes no edge or face narrower than PF_REFINE_SNAP of
 * the diagonal: no piece edge has one end off pl by more than on but less than that, and the
 * other end beyond on on the other side (the split would put a node just beside the first). */
static bool clear_of_nodes(const refine_local *L, pf_plane pl, double diag, double on)
{
    const refine_pieces *ps = &L->cur;
    double near = PF_REFINE_SNAP * diag;
    for (int32_t f = 0; f < ps->n_faces; ++f)
        for (int64_t k = ps->off[f]; k < ps->off[f + 1]; ++k) {
            int64_t k1 = k + 1 < ps->off[f + 1] ? k + 1 : ps->off[f];
            double du = pf_plane_signed_distance(pl, pf_v3_load(L->x + 3 * (size_t)ps->nodes[k]));
            double dv = pf_plane_signed_distance(pl, pf_v3_load(L->x + 3 * (size_t)ps->nodes[k1]));
            if (fabs(du) > near || fabs(du) <= on) /* far from pl, or on it */
                continue;
            if ((du > 0 && dv < -on) || (du < 0 && dv > on))
                return false;
        }
    return true;
}

/* The plane an octs or halves split uses instead of pl, and its on-plane tolerance *tol (0:
 * pf_poly_split's own; PF_REFINE_SNAP). pl itself when it is clear of the nodes (clear_of_nodes;
 * on it: within rounding, 1e-11 of the diagonal: boxes keep their exact planes). Else the nodes within
 * PF_REFINE_SNAP of the diagonal (else within 1e-8) are put on it by fit_plane when they are
 * coplanar to 1e-10 of the diagonal and the fit leaves every other node clear (*tol twice what
 * they stay off it, at least 1e-10 of the diagonal: a cap stays planar within pf_mesh_validate's
 * 1e-9 of the face for caps down to a tenth of the element). Else (the near nodes lie on lines
 * that the planes of several neighbours put on the element's faces at slightly different
 * places, which no plane passes through) pl moved along its normal by the least multiple of
 * PF_REFINE_SHIFT of the diagonal, up to PF_REFINE_SHIFT_STEPS of them (+ before -), that leaves
 * every node clear; pl when none does. */
static pf_plane snap_plane(const refine_local *L, pf_plane pl, double diag, double *tol)
{
    *tol = 0;
    if (clear_of_nodes(L, pl, diag, 1e-11 * diag))
        return pl;
    const double bands[2] = {PF_REFINE_SNAP, 1e-8};
    for (int k = 0; k < 2; ++k) {
        double resid;
        pf_plane fit = fit_plane(L, pl, diag, bands[k] * diag, &resid);
        if (resid <= 1e-10 * diag && clear_of_nodes(L, fit, diag, resid)) {
            *tol = fmax(2 * resid, 1e-10 * diag);
            return fit;
        }
    }
    for (int k = 1; k <= PF_REFINE_SHIFT_STEPS; ++k)
        for (int sign = 1; sign >= -1; sign -= 2) {
            pf_plane moved = {pl.n, pl.d + sign * k * PF_REFINE_SHIFT * diag};
            if (clear_of_nodes(L, moved, diag, 0))
                return moved;
        }
    return pl;
}

pf_status pf_refine_split_local(refine_local *L, const pf_refine_request *req, double vol,
                                pf_vec3 centroid, const pf_vec3 axes[3], int32_t *planes_applied,
                                int32_t *planes_skipped, pf_error *err)
{
    *planes_applied = 0;
    *planes_skipped = 0;
    int n_planes = req->kind == PF_SPLIT_OCTS ? 3 : 1;
    double diag = element_diagonal(L);
    double min_fraction = req->min_fraction > 0 ? req->min_fraction : PF_REFINE_MIN_FRACTION;
    double min_piece = fmax(min_fraction * vol, req->min_volume);
    for (int i = 0; i < n_planes; ++i) {
        pf_vec3 n = req->kind == PF_SPLIT_OCTS ? axes[i] : req->normal;
        pf_vec3 at = req->kind == PF_SPLIT_PLANE ? req->point : centroid;
        pf_plane pl = pf_plane_from_point_normal(at, n);
        double tol = 0;
        if (req->kind != PF_SPLIT_PLANE) /* a cut's plane is the blade's, the same in every cell */
            pl = snap_plane(L, pl, diag, &tol);
        int32_t n_before = L->n;
        bool cut;
        double smallest;
        PF_TRY(split_all(L, &pl, tol, *planes_applied > 0, &cut, &smallest, err));
        /* A plane through a non-convex piece may leave more than two pieces of it: octs and
         * halves planes stay within twice the pieces they cut, so that an octs split makes at
         * most 8 children and a halves split at most 2 (the simulator's max_elements counts on
         * it); a cut's plane makes what the blade makes. */
        bool too_many = req->kind != PF_SPLIT_PLANE && L->next.n > 2 * L->cur.n;
        if (!cut || smallest < min_piece || too_many) {
            L->n = n_before; /* the trial's nodes are dropped with it */
            if (cut)
                ++*planes_skipped;
            continue;
        }
        refine_pieces t = L->cur;
        L->cur = L->next;
        L->next = t;
        ++*planes_applied;
    }
    return PF_OK;
}
