/* Cutting while the simulation runs (DG paper sec. 9.4, harmonic paper sec. 8 "Progressive
 * Cutting"): the scene's blades find the elements they pass through in the deformed body, their
 * plane is carried into the rest shape, pf_mesh_cut splits and separates, and the change is one
 * transaction of sim_change.c (state carried over, surface cut and re-weighted). */
#include <pf/cut.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_change.h"

/* Bookkeeping of refinement on the cut mesh: a piece keeps its parent's level and leaves its
 * family (a family with a piece missing never merges back), everything starts calm again. */
static pf_status carry_bookkeeping(pf_sim *s, const pf_cut_result *r, const int32_t *old_level,
                                   const int32_t *old_family, pf_error *err)
{
    int32_t n = s->mesh->n_elems;
    int32_t *level = pf_calloc((size_t)n + 1, sizeof *level);
    int32_t *family = pf_alloc_array((size_t)n + 1, sizeof *family);
    int32_t *calm = pf_calloc((size_t)n + 1, sizeof *calm);
    if (!level || !family || !calm) {
        pf_free(level), pf_free(family), pf_free(calm);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the bookkeeping of %d elements", (int)n);
    }
    for (int32_t e = 0; e < n; ++e) {
        int32_t p = r->parent[e];
        level[e] = old_level[p];
        family[e] = r->split[p] ? -1 : old_family[p];
    }
    pf_free(s->level), pf_free(s->family), pf_free(s->calm);
    s->level = level, s->family = family, s->calm = calm;
    return PF_OK;
}

pf_status pf_sim_cut(pf_sim *s, const pf_cut_request *req, int32_t n_req, pf_cut_result *out,
                     pf_error *err)
{
    double t0 = pf_cpu_seconds();
    if (out)
        memset(out, 0, sizeof *out);
    pf_mesh next = {0};
    pf_cut_result r = {0};
    PF_TRY(pf_mesh_cut(s->mesh, req, n_req, NULL, &next, &r, err));
    double mesh_seconds = pf_cpu_seconds() - t0;
    pf_mesh_change change = {.old_mesh = s->mesh,
                             .parent = r.parent,
                             .split = r.split,
                             .node_map = r.node_map,
                             .face_src = r.face_src,
                             .cut = &r};
    pf_sim *old = NULL;
    pf_status st = pf_sim_change_mesh(s, &next, &change, r.changed, &old, err);
    if (st >= 0 && old && old->level)
        st = carry_bookkeeping(s, &r, old->level, old->family, err);
    if (st >= 0) {
        s->stats.cuts++;
        s->stats.elements_cut += r.n_split;
        s->stats.elements_split += r.n_split;
        s->stats.bodies = r.n_bodies;
        s->stats.dropped_volume += r.dropped_volume;
        s->stats.dropped_mass += r.dropped_volume * s->scene->density;
        s->stats.cut_seconds += pf_cpu_seconds() - t0;
        s->stats.refine_seconds += pf_cpu_seconds() - t0;
        s->stats.refine_mesh_seconds += mesh_seconds;
    } else {
        pf_error_prefix(err, "cutting %d elements", (int)n_req);
    }
    pf_sim_destroy(&old);
    pf_mesh_release(&next);
    if (st >= 0 && out)
        *out = r;
    else
        pf_cut_result_release(&r);
    return st;
}

/* ---- which elements a blade passes through ----------------------------------------------------
 */

/* The swept parallelogram of a segment blade: origin o, edges ea (along the blade) and eb (its
 * motion); n = ea x eb normalised. */
typedef struct sweep {
    pf_vec3 o, ea, eb, n;
    bool bounded; /* a segment's sweep (false: a whole plane) */
} sweep;

/* (s, r) with p - o = s ea + r eb for p in the sweep's plane (least squares in the plane). */
static void sweep_coords(const sweep *w, pf_vec3 p, double *s, double *r)
{
    pf_vec3 d = pf_v3_sub(p, w->o);
    double aa = pf_v3_dot(w->ea, w->ea), ab = pf_v3_dot(w->ea, w->eb), bb = pf_v3_dot(w->eb, w->eb);
    double da = pf_v3_dot(d, w->ea), db = pf_v3_dot(d, w->eb), det = aa * bb - ab * ab;
    *s = (da * bb - db * ab) / det;
    *r = (db * aa - da * ab) / det;
}

/* Whether the convex polygon of the points (s, r)[n] (any order) meets the unit square: the
 * separating-axis test over the square's axes and the hull's edge normals (the hull by the
 * monotone chain). */
static int cmp_pt(const void *a, const void *b)
{
    const double *p = a, *q = b;
    return p[0] < q[0] ? -1 : p[0] > q[0] ? 1 : (p[1] > q[1]) - (p[1] < q[1]);
}

static double cross2(const double *o, const double *a, const double *b)
{
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

static bool polygon_meets_square(double (*pt)[2], int n, double (*hull)[2])
{
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 2; ++c)
            lo[c] = fmin(lo[c], pt[i][c]), hi[c] = fmax(hi[c], pt[i][c]);
    if (hi[0] < 0 || lo[0] > 1 || hi[1] < 0 || lo[1] > 1)
        return false;
    qsort(pt, (size_t)n, sizeof *pt, cmp_pt);
    int k = 0;
    for (int i = 0; i < n; ++i) { /* lower hull */
        while (k >= 2 && cross2(hull[k - 2], hull[k - 1], pt[i]) <= 0)
            --k;
        memcpy(hull[k++], pt[i], sizeof *pt);
    }
    for (int i = n - 2, t = k + 1; i >= 0; --i) { /* upper hull */
        while (k >= t && cross2(hull[k - 2], hull[k - 1], pt[i]) <= 0)
            --k;
        memcpy(hull[k++], pt[i], sizeof *pt);
    }
    const double sq[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int i = 0; i + 1 < k; ++i) { /* the square wholly outside one hull edge separates */
        int outside = 0;
        for (int j = 0; j < 4; ++j)
            outside += cross2(hull[i], hull[i + 1], sq[j]) < 0;
        if (outside == 4)
            return false;
    }
    return true;
}

/* Whether element e (deformed node positions y) is crossed by the sweep: nodes strictly on both
 * sides of its plane (beyond tol) and, for a bounded sweep, its section meeting the
 * parallelogram. scratch holds 2 * (2 face nodes) points. */
static bool element_crossed(const pf_mesh *m, const double *y, int32_t e, const sweep *w,
                            double tol, double (*pt)[2], double (*hull)[2])
{
    bool below = false, above = false;
    int n = 0;
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        int64_t o = m->face_offsets[f], len = m->face_offsets[f + 1] - o;
        for (int64_t k = 0; k < len; ++k) {
            pf_vec3 a = pf_v3_load(y + 3 * (size_t)m->face_nodes[o + k]);
            pf_vec3 b = pf_v3_load(y + 3 * (size_t)m->face_nodes[o + (k + 1) % len]);
            double da = pf_v3_dot(w->n, pf_v3_sub(a, w->o)),
                   db = pf_v3_dot(w->n, pf_v3_sub(b, w->o));
            below |= da<-tol, above |= da> tol;
            if (!w->bounded || !((da < 0 && db > 0) || (da > 0 && db < 0)))
                continue;
            pf_vec3 p = pf_v3_add(a, pf_v3_scale(pf_v3_sub(b, a), da / (da - db)));
            sweep_coords(w, p, &pt[n][0], &pt[n][1]);
            n++;
        }
    }
    if (!(below && above))
        return false;
    return !w->bounded || (n >= 3 && polygon_meets_square(pt, n, hull)) ||
           (n > 0 && n < 3 && pt[0][0] >= 0 && pt[0][0] <= 1 && pt[0][1] >= 0 && pt[0][1] <= 1);
}

/* The affine map y = F x + t that best fits (least squares, centred) the motion of the nodes of
 * the elements req[0 .. k) from rest (m->x) to now (y). false when they span no volume. */
static bool fit_affine(const pf_mesh *m, const double *y, const pf_cut_request *req, int32_t k,
                       pf_mat3 *f, pf_vec3 *t)
{
    pf_vec3 xs = pf_v3(0, 0, 0), ys = pf_v3(0, 0, 0);
    double count = 0;
    pf_mat3 c = {{{0}}}, b = {{{0}}}; /* sum dx dx^T, sum dy dx^T */
    for (int pass = 0; pass < 2; ++pass) {
        pf_vec3 xm = pf_v3_scale(xs, 1 / fmax(count, 1)), ym = pf_v3_scale(ys, 1 / fmax(count, 1));
        for (int32_t i = 0; i < k; ++i) {
            int32_t e = req[i].elem;
            for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
                int32_t g = PF_FACE_INDEX(m->elem_faces[q]);
                for (int64_t j = m->face_offsets[g]; j < m->face_offsets[g + 1]; ++j) {
                    pf_vec3 x = pf_v3_load(m->x + 3 * (size_t)m->face_nodes[j]);
                    pf_vec3 yy = pf_v3_load(y + 3 * (size_t)m->face_nodes[j]);
                    if (pass == 0) {
                        xs = pf_v3_add(xs, x), ys = pf_v3_add(ys, yy), count += 1;
                        continue;
                    }
                    double dx[3] = {x.x - xm.x, x.y - xm.y, x.z - xm.z};
                    double dy[3] = {yy.x - ym.x, yy.y - ym.y, yy.z - ym.z};
                    for (int r = 0; r < 3; ++r)
                        for (int q2 = 0; q2 < 3; ++q2)
                            c.m[r][q2] += dx[r] * dx[q2], b.m[r][q2] += dy[r] * dx[q2];
                }
            }
        }
        if (pass == 1) {
            double det;
            pf_mat3 ci = pf_m3_inverse(c, &det);
            *f = pf_m3_mul(b, ci);
            *t = pf_v3_sub(ym, pf_m3_mulv(*f, xm));
            double fdet = pf_m3_det(*f);
            return det > 0 && isfinite(fdet) && fdet > 0;
        }
    }
    return false;
}

/* The world sweep w carried into the rest shape by the inverse of y = F x + t: the parallelogram
 * maps to a parallelogram, the plane's normal to F^T n. */
static sweep sweep_to_rest(const sweep *w, pf_mat3 f, pf_vec3 t)
{
    double det;
    pf_mat3 fi = pf_m3_inverse(f, &det);
    sweep r = *w;
    r.o = pf_m3_mulv(fi, pf_v3_sub(w->o, t));
    r.ea = pf_m3_mulv(fi, w->ea);
    r.eb = pf_m3_mulv(fi, w->eb);
    r.n = pf_v3_normalize(pf_m3_mulv(pf_m3_transpose(f), w->n));
    return r;
}

/* The pieces of earlier cuts (elements with a cut face: the mesh's face group "cut") next to
 * the elements crossed, req[0 .. *k), are requested too, appended in element order. The plane of
 * a blade is fitted anew at every frame, so a crack made over several frames is a few planes a
 * rounding apart: where this frame's plane leaves a thin strip of a face between an earlier
 * piece and a new one on the other side, the strip must open too, or the crack would stay
 * bridged there. An earlier piece the new plane only grazes is not split (the sliver rule) but
 * takes its side. */
static void add_earlier_pieces(const pf_mesh *m, pf_cut_request *req, int32_t *k)
{
    const pf_mesh_group *g = pf_mesh_find_group(m, 2, "cut", 0);
    if (!g || *k == 0)
        return;
    uint8_t *in = pf_calloc((size_t)m->n_elems + 1, 1);
    if (!in)
        return; /* the cut is then only less clean; nothing is wrong */
    for (int32_t i = 0; i < *k; ++i)
        in[req[i].elem] = 1;
    int32_t n0 = *k;
    for (int32_t i = 0; i < n0; ++i) {
        int32_t e = req[i].elem;
        for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
            int32_t nb =
                m->face_elems[2 * f] == e ? m->face_elems[2 * f + 1] : m->face_elems[2 * f];
            if (nb < 0 || in[nb])
                continue;
            for (int64_t p = m->elem_offsets[nb]; p < m->elem_offsets[nb + 1]; ++p)
                if (m->face_group[PF_FACE_INDEX(m->elem_faces[p])] == g->number) {
                    in[nb] = 2;
                    break;
                }
        }
    }
    for (int32_t e = 0; e < m->n_elems; ++e)
        if (in[e] == 2)
            req[(*k)++].elem = e;
    pf_free(in);
}

/* A blade reaches the rest shape through one affine map, fitted to the elements it first passes
 * through and kept for as long as it sweeps the same world plane: the elements it cuts are found
 * in the rest shape (its sweep carried there) and split by one plane, so a crack made over many
 * frames is one plane, exactly, and every element that plane crosses inside the sweep is cut.
 * Maps fitted anew at each frame, or per element, differ by the body's motion between frames and
 * from affine: where their planes meet, faces get strips a rounding wide (degenerate faces,
 * which harmonic elements cannot have), and elements found in the deformed body but cut in the
 * rest shape by another element's plane bridge the crack. The price: a body that turns or bends
 * under such a blade is cut along the material plane the blade entered. */
typedef struct blade_lock {
    bool locked;
    pf_plane world; /* the sweep's world plane when the map was fitted */
    pf_mat3 f;      /* rest to world, y = F x + t, fitted then */
    pf_vec3 t;
} blade_lock;

static bool same_plane(pf_plane a, pf_plane b, double size)
{
    return pf_v3_norm(pf_v3_sub(a.n, b.n)) < 1e-9 && fabs(a.d - b.d) < 1e-9 * size;
}

/* The elements of m (node positions p: rest or deformed) the sweep w crosses, into req. */
static int32_t crossed_elements(const pf_mesh *m, const double *p, const sweep *w, double tol,
                                double (*pt)[2], double (*hull)[2], pf_cut_request *req)
{
    int32_t k = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        if (element_crossed(m, p, e, w, tol, pt, hull))
            req[k++].elem = e;
    return k;
}

/* The elements the sweep passes through, each with the sweep's plane in the rest shape. */
static pf_status blade_requests(pf_sim *s, int32_t blade, const sweep *w, pf_cut_request **req,
                                int32_t *k, pf_error *err)
{
    const pf_mesh *m = s->mesh;
    *k = 0;
    int64_t most = 0; /* face nodes of the largest element */
    for (int32_t e = 0; e < m->n_elems; ++e) {
        int64_t c = 0;
        for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
            c += m->face_offsets[f + 1] - m->face_offsets[f];
        }
        most = c > most ? c : most;
    }
    double *y = pf_alloc_array(3 * (size_t)m->n_nodes + 1, sizeof *y);
    double(*pt)[2] = pf_alloc_array(2 * (size_t)most + 2, sizeof *pt);
    double(*hull)[2] = pf_alloc_array(2 * (size_t)most + 4, sizeof *hull);
    *req = pf_alloc_array((size_t)m->n_elems + 1, sizeof **req);
    if (!y || !pt || !hull || !*req) {
        pf_free(y), pf_free(pt), pf_free(hull), pf_free(*req);
        *req = NULL;
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the cut's search over %d elements", (int)m->n_elems);
    }
    pf_sim_nodal_displacements(s, y);
    for (int32_t i = 0; i < 3 * m->n_nodes; ++i)
        y[i] += m->x[i];
    double tol = 1e-12 * s->model_size;
    blade_lock *lk = &s->blade_locks[blade];
    pf_plane world = {w->n, pf_v3_dot(w->n, w->o)};
    if (!lk->locked || !same_plane(lk->world, world, s->model_size)) {
        /* a new plane: the map fitted to the elements the blade passes through now */
        pf_mat3 f;
        pf_vec3 t;
        int32_t n = crossed_elements(m, y, w, tol, pt, hull, *req);
        if (n > 0 && fit_affine(m, y, *req, n, &f, &t))
            *lk = (blade_lock){.locked = true, .world = world, .f = f, .t = t};
    }
    if (lk->locked && same_plane(lk->world, world, s->model_size)) {
        sweep rest = sweep_to_rest(w, lk->f, lk->t);
        *k = crossed_elements(m, m->x, &rest, tol, pt, hull, *req);
        pf_plane pl = {rest.n, pf_v3_dot(rest.n, rest.o)};
        add_earlier_pieces(m, *req, k);
        for (int32_t i = 0; i < *k; ++i)
            (*req)[i].plane = pl;
    }
    pf_free(y), pf_free(pt), pf_free(hull);
    return PF_OK;
}

/* The sweep of blade b from t0 to t1; false when it sweeps nothing in that time. */
static bool blade_sweep(const pf_blade *b, double t0, double t1, bool first, sweep *w)
{
    if (b->kind == PF_BLADE_PLANE) {
        /* times reached by summing steps: compare within a millionth of the frame */
        double eps = 1e-6 * (t1 - t0);
        if (!(b->time <= t1 + eps && (b->time > t0 + eps || first)))
            return false;
        *w = (sweep){.o = b->point, .n = b->normal, .bounded = false};
        return true;
    }
    pf_vec3 a0, b0, a1, b1;
    pf_blade_at(b, t0, &a0, &b0);
    pf_blade_at(b, t1, &a1, &b1);
    pf_vec3 ea = pf_v3_sub(b0, a0), eb = pf_v3_sub(a1, a0), n = pf_v3_cross(ea, eb);
    /* a blade moving along itself (or not at all) sweeps no area */
    if (!(pf_v3_norm(n) > 1e-9 * pf_v3_norm(ea) * pf_v3_norm(eb)))
        return false;
    *w = (sweep){.o = a0, .ea = ea, .eb = eb, .n = pf_v3_normalize(n), .bounded = true};
    return true;
}

pf_status pf_sim_apply_cuts(pf_sim *s, double t0, double t1, int32_t *n_cut, pf_error *err)
{
    if (n_cut)
        *n_cut = 0;
    if (!s->blade_locks && s->scene->n_cuts > 0) {
        s->blade_locks = pf_calloc((size_t)s->scene->n_cuts, sizeof *s->blade_locks);
        PF_CHECK(s->blade_locks, err, PF_ERR_NOMEM, "cannot allocate %d blades",
                 (int)s->scene->n_cuts);
    }
    for (int32_t i = 0; i < s->scene->n_cuts; ++i) {
        double c0 = pf_cpu_seconds();
        sweep w;
        if (!blade_sweep(&s->scene->cuts[i], t0, t1, t0 <= 0, &w))
            continue;
        pf_cut_request *req = NULL;
        int32_t k = 0;
        PF_TRY(blade_requests(s, i, &w, &req, &k, err));
        s->stats.cut_seconds += pf_cpu_seconds() - c0;
        pf_cut_result r = {0};
        pf_status st = k > 0 ? pf_sim_cut(s, req, k, &r, err) : PF_OK;
        pf_free(req);
        if (st < 0) {
            pf_error_prefix(err, "cuts[%d]", (int)i);
            return st;
        }
        if (n_cut)
            *n_cut += r.n_split;
        pf_cut_result_release(&r);
    }
    return PF_OK;
}
