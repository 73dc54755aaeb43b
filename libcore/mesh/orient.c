/* After import: the up axis onto +z, a uniform scale, and consistent outward orientation.
 *
 * Orientation: triangles sharing an edge used by exactly two of them must traverse it in opposite
 * directions. A breadth-first walk over those edges gives every triangle of a connected patch a
 * parity relative to the first; the minority of each patch is flipped (the file's own choice
 * kept where it was mostly right). A patch whose signed volume is then negative is inside out and
 * is flipped whole, unless it lies inside another patch (the winding number of the others at one
 * of its vertices exceeds 1/2): then it bounds a cavity and inward is right. */
#include <pf/mesh.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

pf_surface_fix_params pf_surface_fix_params_default(void)
{
    return (pf_surface_fix_params){.up = PF_UP_Z, .scale = 1, .orient = true};
}

const char *pf_up_axis_name(pf_up_axis up)
{
    static const char *names[] = {"z", "x", "y", "-x", "-y", "-z", "auto"};
    return (unsigned)up < 7 ? names[up] : "?";
}

bool pf_up_axis_parse(const char *text, pf_up_axis *out)
{
    for (int a = 0; a < 7; ++a) {
        const char *name = pf_up_axis_name((pf_up_axis)a);
        if (strcmp(text, name) == 0 || (a < 6 && text[0] == '+' && strcmp(text + 1, name) == 0)) {
            *out = (pf_up_axis)a;
            return true;
        }
    }
    return false;
}

/* The proper rotation taking the given axis onto +z (a quarter or half turn about x or y). */
static pf_vec3 rotate_up(pf_up_axis up, pf_vec3 p)
{
    switch (up) {
    case PF_UP_X:
        return pf_v3(-p.z, p.y, p.x);
    case PF_UP_Y:
        return pf_v3(p.x, -p.z, p.y);
    case PF_UP_NEG_X:
        return pf_v3(p.z, p.y, -p.x);
    case PF_UP_NEG_Y:
        return pf_v3(p.x, p.z, -p.y);
    case PF_UP_NEG_Z:
        return pf_v3(p.x, -p.y, -p.z);
    default:
        return p;
    }
}

typedef struct edge_use {
    uint64_t key; /* min << 32 | max */
    int32_t tri;
    uint8_t dir; /* 1 when the triangle traverses the edge from max to min */
} edge_use;

static int compare_edge_use(const void *a, const void *b)
{
    const edge_use *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return (x->tri > y->tri) - (x->tri < y->tri);
}

static void flip_triangle(pf_surface *s, int32_t t)
{
    uint32_t tmp = s->tri[3 * (size_t)t + 1];
    s->tri[3 * (size_t)t + 1] = s->tri[3 * (size_t)t + 2];
    s->tri[3 * (size_t)t + 2] = tmp;
}

/* nb[3 t + k]: the triangle across edge k of t over a two-use edge (-1: none), with rel 1 when
 * the two traverse it the same way (one of them must flip). */
static pf_status manifold_neighbours(const pf_surface *s, int32_t *nb, uint8_t *rel, pf_error *err)
{
    size_t n = 3 * (size_t)s->n_tris;
    edge_use *uses = pf_alloc_array(n, sizeof *uses);
    PF_CHECK(uses, err, PF_ERR_NOMEM, "out of memory orienting a surface");
    for (size_t i = 0; i < n; ++i) {
        uint32_t a = s->tri[i], b = s->tri[i - i % 3 + (i % 3 + 1) % 3];
        uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
        uses[i] = (edge_use){((uint64_t)lo << 32) | hi, (int32_t)(i / 3), a > b};
        nb[i] = -1;
    }
    qsort(uses, n, sizeof *uses, compare_edge_use);
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && uses[j].key == uses[i].key)
            ++j;
        if (j - i == 2 && uses[i].tri != uses[i + 1].tri) {
            for (int side = 0; side < 2; ++side) {
                const edge_use *me = &uses[i + side], *other = &uses[i + 1 - side];
                for (int k = 0; k < 3; ++k)
                    if (nb[3 * (size_t)me->tri + k] < 0) {
                        nb[3 * (size_t)me->tri + k] = other->tri;
                        rel[3 * (size_t)me->tri + k] = me->dir == other->dir;
                        break;
                    }
            }
        }
        i = j;
    }
    pf_free(uses);
    return PF_OK;
}

/* Signed volume of the triangles of component c about o (divergence theorem), and their area. */
static double component_volume(const pf_surface *s, const int32_t *comp, int32_t c, pf_vec3 o,
                               double *area)
{
    double v = 0;
    *area = 0;
    for (int32_t t = 0; t < s->n_tris; ++t) {
        if (comp[t] != c)
            continue;
        pf_vec3 p[3];
        for (int q = 0; q < 3; ++q)
            p[q] = pf_v3_sub(pf_v3_load(s->x + 3 * (size_t)s->tri[3 * (size_t)t + q]), o);
        v += pf_v3_dot(p[0], pf_v3_cross(p[1], p[2])) / 6;
        *area += 0.5 * pf_v3_norm(pf_v3_cross(pf_v3_sub(p[1], p[0]), pf_v3_sub(p[2], p[0])));
    }
    return v;
}

/* Where the volume of each component is measured from: the length-weighted centre of its open
 * edges (the volume is then that of the patch closed by the cone from there, a fair closing of
 * one hole), or the bounding-box centre of the surface for a closed component, whose volume does
 * not depend on it. */
static void volume_origins(const pf_surface *s, const int32_t *comp, const int32_t *nb,
                           int32_t n_comp, pf_vec3 centre, pf_vec3 *origin, double *weight)
{
    for (int32_t c = 0; c < n_comp; ++c)
        origin[c] = pf_v3(0, 0, 0), weight[c] = 0;
    for (int32_t t = 0; t < s->n_tris; ++t)
        for (int k = 0; k < 3; ++k) {
            if (nb[3 * (size_t)t + k] >= 0)
                continue;
            pf_vec3 a = pf_v3_load(s->x + 3 * (size_t)s->tri[3 * (size_t)t + k]);
            pf_vec3 b = pf_v3_load(s->x + 3 * (size_t)s->tri[3 * (size_t)t + (k + 1) % 3]);
            double len = pf_v3_dist(a, b);
            origin[comp[t]] = pf_v3_add(origin[comp[t]], pf_v3_scale(pf_v3_add(a, b), 0.5 * len));
            weight[comp[t]] += len;
        }
    for (int32_t c = 0; c < n_comp; ++c)
        origin[c] = weight[c] > 0 ? pf_v3_scale(origin[c], 1 / weight[c]) : centre;
}

/* Winding number at p of the triangles not in component c. */
static double others_winding(const pf_surface *s, const int32_t *comp, int32_t c, pf_vec3 p,
                             uint32_t *scratch)
{
    int32_t n = 0;
    for (int32_t t = 0; t < s->n_tris; ++t)
        if (comp[t] != c)
            memcpy(scratch + 3 * (size_t)n++, s->tri + 3 * (size_t)t, 3 * sizeof *scratch);
    return pf_winding_number(s->x, scratch, n, p);
}

/* Flips every inside-out component that is not a cavity of another. A component whose volume is
 * below 1e-4 A^(3/2) in magnitude (A its area; a sphere has 0.094 A^(3/2)) is a sheet with no
 * inside of its own: sheets are flipped when most of the solid parts' volume was inside out. */
static pf_status orient_outward(pf_surface *s, const int32_t *comp, const int32_t *nb,
                                int32_t n_comp, pf_surface_fix_report *r, pf_error *err)
{
    pf_vec3 lo, hi;
    lo = hi = pf_v3_load(s->x);
    for (int32_t v = 1; v < s->n_verts; ++v) {
        lo = pf_v3_min(lo, pf_v3_load(s->x + 3 * (size_t)v));
        hi = pf_v3_max(hi, pf_v3_load(s->x + 3 * (size_t)v));
    }
    uint32_t *scratch = pf_alloc_array(3 * (size_t)s->n_tris, sizeof *scratch);
    int32_t *first = pf_alloc_array((size_t)n_comp, sizeof *first);
    pf_vec3 *origin = pf_alloc_array((size_t)n_comp, sizeof *origin);
    double *weight = pf_alloc_array((size_t)n_comp, sizeof *weight);
    if (!scratch || !first || !origin || !weight) {
        pf_free(scratch), pf_free(first), pf_free(origin), pf_free(weight);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory orienting");
    }
    volume_origins(s, comp, nb, n_comp, pf_v3_scale(pf_v3_add(lo, hi), 0.5), origin, weight);
    for (int32_t c = 0; c < n_comp; ++c)
        first[c] = -1;
    for (int32_t t = s->n_tris - 1; t >= 0; --t)
        first[comp[t]] = t;
    /* weight[c] becomes 1 for a component to flip, -1 for a sheet */
    double turned = 0, kept = 0;
    for (int32_t c = 0; c < n_comp; ++c) {
        double area, volume = component_volume(s, comp, c, origin[c], &area);
        weight[c] = 0;
        if (fabs(volume) <= 1e-4 * area * sqrt(area)) {
            weight[c] = -1;
            continue;
        }
        pf_vec3 p = pf_v3_load(s->x + 3 * (size_t)s->tri[3 * (size_t)first[c]]);
        if (volume > 0 || (n_comp > 1 && others_winding(s, comp, c, p, scratch) > 0.5)) {
            kept += fabs(volume); /* outward, or a cavity */
            continue;
        }
        weight[c] = 1;
        turned += fabs(volume);
    }
    /* Sheets follow the file's convention, which the solid parts reveal. */
    for (int32_t c = 0; c < n_comp; ++c)
        if (weight[c] == -1 && turned > kept)
            weight[c] = 1;
    for (int32_t t = 0; t < s->n_tris; ++t)
        if (weight[comp[t]] == 1)
            flip_triangle(s, t);
    for (int32_t c = 0; c < n_comp; ++c)
        r->flipped_components += weight[c] == 1;
    pf_free(scratch), pf_free(first), pf_free(origin), pf_free(weight);
    return PF_OK;
}

pf_status pf_surface_orient(pf_surface *s, pf_surface_fix_report *r, pf_error *err)
{
    r->components = r->flipped_faces = r->flipped_components = 0;
    size_t n = 3 * (size_t)s->n_tris;
    int32_t *nb = pf_alloc_array(n + 1, sizeof *nb);
    uint8_t *rel = pf_alloc(n + 1);
    int32_t *comp = pf_alloc_array((size_t)s->n_tris + 1, sizeof *comp);
    uint8_t *flip = pf_calloc((size_t)s->n_tris + 1, 1);
    int32_t *queue = pf_alloc_array((size_t)s->n_tris + 1, sizeof *queue);
    pf_status st = PF_OK;
    if (!nb || !rel || !comp || !flip || !queue) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory orienting");
        goto done;
    }
    st = manifold_neighbours(s, nb, rel, err);
    if (st < 0)
        goto done;
    for (int32_t t = 0; t < s->n_tris; ++t)
        comp[t] = -1;
    int32_t n_comp = 0;
    for (int32_t seed = 0; seed < s->n_tris; ++seed) {
        if (comp[seed] >= 0)
            continue;
        int32_t head = 0, tail = 0, ones = 0;
        comp[seed] = n_comp;
        queue[tail++] = seed;
        while (head < tail) {
            int32_t t = queue[head++];
            ones += flip[t];
            for (int k = 0; k < 3; ++k) {
                int32_t u = nb[3 * (size_t)t + k];
                if (u < 0 || comp[u] >= 0)
                    continue; /* visited: a conflict there means a non-orientable patch */
                comp[u] = n_comp;
                flip[u] = flip[t] ^ rel[3 * (size_t)t + k];
                queue[tail++] = u;
            }
        }
        bool minority_is_ones = 2 * ones <= tail;
        for (int32_t q = 0; q < tail; ++q) {
            int32_t t = queue[q];
            if (flip[t] == minority_is_ones) {
                flip_triangle(s, t);
                r->flipped_faces++;
            }
        }
        n_comp++;
    }
    r->components = n_comp;
    st = orient_outward(s, comp, nb, n_comp, r, err);
done:
    pf_free(nb), pf_free(rel), pf_free(comp), pf_free(flip), pf_free(queue);
    return st;
}

pf_status pf_surface_fix(pf_surface *s, const pf_surface_fix_params *params,
                         pf_surface_fix_report *report, pf_error *err)
{
    pf_surface_fix_params p = params ? *params : pf_surface_fix_params_default();
    pf_surface_fix_report local;
    pf_surface_fix_report *r = report ? report : &local;
    memset(r, 0, sizeof *r);
    PF_CHECK((unsigned)p.up < 7, err, PF_ERR_INVALID, "unknown up axis %d", (int)p.up);
    PF_CHECK(isfinite(p.scale) && p.scale > 0, err, PF_ERR_INVALID,
             "scale must be finite and > 0, got %g", p.scale);
    pf_surface_stats before;
    PF_TRY(pf_surface_compute_stats(s, &before, err));
    r->volume_before = before.volume * p.scale * p.scale * p.scale;
    for (int32_t v = 0; v < s->n_verts; ++v) {
        pf_vec3 q = rotate_up(p.up, pf_v3_load(s->x + 3 * (size_t)v));
        pf_v3_store(pf_v3_scale(q, p.scale), s->x + 3 * (size_t)v);
    }
    if (p.orient && s->n_tris > 0)
        PF_TRY(pf_surface_orient(s, r, err));
    pf_surface_stats after;
    PF_TRY(pf_surface_compute_stats(s, &after, err));
    r->volume_after = after.volume;
    return PF_OK;
}

/* The triangles of every part, grouped (tri[3 off[c] ..] for part c), with their bounding box. */
typedef struct parts {
    int32_t n;
    int64_t *off; /* [n + 1] */
    pf_vec3 *lo, *hi;
} parts;

/* c against d (their boxes overlapping): up to 64 of c's vertices, evenly strided, inside d
 * (winding number of d > 1/2) mean an overlap, unless all are inside and c faces inward (a
 * cavity of d). */
static bool part_overlaps(const pf_surface *s, const parts *pt, const uint32_t *grouped, int32_t c,
                          int32_t d)
{
    int64_t nc = pt->off[c + 1] - pt->off[c], stride = nc / 64 + 1;
    double volume = 0;
    for (int64_t t = pt->off[c]; t < pt->off[c + 1]; ++t) {
        pf_vec3 q[3];
        for (int k = 0; k < 3; ++k)
            q[k] = pf_v3_load(s->x + 3 * (size_t)grouped[3 * t + k]);
        volume += pf_v3_dot(q[0], pf_v3_cross(q[1], q[2])) / 6;
    }
    int32_t inside = 0, n = 0;
    for (int64_t t = pt->off[c]; t < pt->off[c + 1]; t += stride, ++n) {
        pf_vec3 p = pf_v3_load(s->x + 3 * (size_t)grouped[3 * t]);
        inside += pf_winding_number(s->x, grouped + 3 * pt->off[d],
                                    (int32_t)(pt->off[d + 1] - pt->off[d]), p) > 0.5;
    }
    return inside > 0 && !(volume < 0 && inside == n);
}

static pf_status compare_parts(const pf_surface *s, const int32_t *comp, int32_t n_comp,
                               uint32_t *grouped, bool *overlap, pf_error *err)
{
    parts pt = {.n = n_comp};
    pt.off = pf_calloc((size_t)n_comp + 1, sizeof *pt.off);
    pt.lo = pf_alloc_array((size_t)n_comp, sizeof *pt.lo);
    pt.hi = pf_alloc_array((size_t)n_comp, sizeof *pt.hi);
    int64_t *at = pf_alloc_array((size_t)n_comp + 1, sizeof *at);
    if (!pt.off || !pt.lo || !pt.hi || !at) {
        pf_free(pt.off), pf_free(pt.lo), pf_free(pt.hi), pf_free(at);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
    }
    for (int32_t t = 0; t < s->n_tris; ++t)
        pt.off[comp[t] + 1]++;
    for (int32_t c = 0; c < n_comp; ++c) {
        pt.off[c + 1] += pt.off[c];
        at[c] = pt.off[c];
        pt.lo[c] = pf_v3(INFINITY, INFINITY, INFINITY);
        pt.hi[c] = pf_v3_scale(pt.lo[c], -1);
    }
    for (int32_t t = 0; t < s->n_tris; ++t) {
        int32_t c = comp[t];
        for (int k = 0; k < 3; ++k) {
            uint32_t v = s->tri[3 * (size_t)t + k];
            grouped[3 * at[c] + k] = v;
            pt.lo[c] = pf_v3_min(pt.lo[c], pf_v3_load(s->x + 3 * (size_t)v));
            pt.hi[c] = pf_v3_max(pt.hi[c], pf_v3_load(s->x + 3 * (size_t)v));
        }
        at[c]++;
    }
    for (int32_t c = 0; c < n_comp && !*overlap; ++c)
        for (int32_t d = 0; d < n_comp && !*overlap; ++d) {
            bool apart = pt.hi[c].x < pt.lo[d].x || pt.hi[d].x < pt.lo[c].x ||
                         pt.hi[c].y < pt.lo[d].y || pt.hi[d].y < pt.lo[c].y ||
                         pt.hi[c].z < pt.lo[d].z || pt.hi[d].z < pt.lo[c].z;
            if (d != c && !apart)
                *overlap = part_overlaps(s, &pt, grouped, c, d);
        }
    pf_free(pt.off), pf_free(pt.lo), pf_free(pt.hi), pf_free(at);
    return PF_OK;
}

pf_status pf_surface_parts_overlap(const pf_surface *s, bool *overlap, pf_error *err)
{
    *overlap = false;
    size_t n = 3 * (size_t)s->n_tris;
    int32_t *nb = pf_alloc_array(n + 1, sizeof *nb);
    uint8_t *rel = pf_alloc(n + 1);
    int32_t *comp = pf_alloc_array((size_t)s->n_tris + 1, sizeof *comp);
    int32_t *queue = pf_alloc_array((size_t)s->n_tris + 1, sizeof *queue);
    uint32_t *scratch = pf_alloc_array(n + 1, sizeof *scratch);
    pf_status st = PF_OK;
    if (!nb || !rel || !comp || !queue || !scratch) {
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
        goto done;
    }
    st = manifold_neighbours(s, nb, rel, err);
    if (st < 0)
        goto done;
    for (int32_t t = 0; t < s->n_tris; ++t)
        comp[t] = -1;
    int32_t n_comp = 0;
    for (int32_t seed = 0; seed < s->n_tris; ++seed) {
        if (comp[seed] >= 0)
            continue;
        int32_t head = 0, tail = 0;
        comp[seed] = n_comp;
        queue[tail++] = seed;
        while (head < tail) {
            int32_t t = queue[head++];
            for (int k = 0; k < 3; ++k) {
                int32_t u = nb[3 * (size_t)t + k];
                if (u >= 0 && comp[u] < 0) {
                    comp[u] = n_comp;
                    queue[tail++] = u;
                }
            }
        }
        n_comp++;
    }
    st = compare_parts(s, comp, n_comp, scratch, overlap, err);
done:
    pf_free(nb), pf_free(rel), pf_free(comp), pf_free(queue), pf_free(scratch);
    return st;
}
