/* Ray crossings and closest points against a triangle surface through Embree 3. */
#include <pf/geom.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <embree3/rtcore.h>

struct pf_rayscene {
    RTCDevice device;
    RTCScene scene;
    pf_vec3 centre; /* subtracted from every coordinate before conversion to float */
    double *x;      /* [3 nv] the vertices in double, for exact closest points */
    uint32_t *tri;  /* [3 nt] */
    double extent;  /* largest |coordinate - centre|: the scale of the float rounding */
};

/* The context handed to the filter: Embree passes the RTCIntersectContext pointer through, so the
 * hit list travels in a struct that begins with it. */
typedef struct hit_collector {
    struct RTCIntersectContext context;
    pf_crossing *hits;
    int64_t cap, n;
    double dir_x, dir_y, dir_z;
} hit_collector;

/* Records every candidate hit and rejects it, so traversal goes on to the next one. The hit
 * arrays are laid out by component: Ng_x at [0 N + i], Ng_y [1 N], Ng_z [2 N]; the ray's tfar,
 * which holds the candidate's distance, at [8 N + i]. */
static void collect_hit(const struct RTCFilterFunctionNArguments *args)
{
    hit_collector *c = (hit_collector *)args->context;
    const float *ray = (const float *)args->ray;
    const float *hit = (const float *)args->hit;
    unsigned N = args->N;
    for (unsigned i = 0; i < N; ++i) {
        if (args->valid[i] == 0)
            continue;
        args->valid[i] = 0;
        double dot = hit[0 * N + i] * c->dir_x + hit[1 * N + i] * c->dir_y +
                     hit[2 * N + i] * c->dir_z;
        if (dot == 0) /* grazing: the line runs in the triangle's plane and crosses nothing */
            continue;
        if (c->n < c->cap)
            c->hits[c->n] = (pf_crossing){.t = ray[8 * N + i], .sign = dot > 0 ? 1 : -1};
        c->n++;
    }
}

pf_status pf_rayscene_create(pf_rayscene **rs, const double *x, int32_t nv, const uint32_t *tri,
                             int32_t nt, pf_error *err)
{
    *rs = NULL;
    PF_CHECK(nv >= 0 && nt >= 0, err, PF_ERR_INVALID, "negative surface counts");
    pf_vec3 lo = pf_v3(0, 0, 0), hi = lo;
    for (int32_t i = 0; i < nv; ++i) {
        pf_vec3 p = pf_v3_load(x + 3 * (size_t)i);
        PF_CHECK(pf_v3_isfinite(p), err, PF_ERR_INVALID,
                 "surface vertex %d has a non-finite coordinate", (int)i);
        lo = i ? pf_v3_min(lo, p) : p;
        hi = i ? pf_v3_max(hi, p) : p;
    }
    for (int64_t i = 0; i < 3 * (int64_t)nt; ++i)
        PF_CHECK(tri[i] < (uint32_t)nv, err, PF_ERR_INVALID,
                 "surface triangle %lld references vertex %u of %d", (long long)(i / 3), tri[i],
                 (int)nv);
    pf_rayscene *s = pf_calloc(1, sizeof *s);
    PF_CHECK(s, err, PF_ERR_NOMEM, "cannot allocate a ray scene");
    s->centre = pf_v3_scale(pf_v3_add(lo, hi), 0.5);
    s->device = rtcNewDevice(NULL);
    if (!s->device) {
        pf_free(s);
        return pf_error_set(err, PF_ERR_UNSUPPORTED, __FILE__, __LINE__,
                            "Embree could not create a device (error %d)",
                            (int)rtcGetDeviceError(NULL));
    }
    s->scene = rtcNewScene(s->device);
    /* Robust traversal: no missed hits at shared edges from aggressive culling. */
    rtcSetSceneFlags(s->scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(s->scene, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry g = rtcNewGeometry(s->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                       3 * sizeof(float), (size_t)nv);
    unsigned *idx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                            3 * sizeof(unsigned), (size_t)nt);
    if ((!v && nv) || (!idx && nt)) {
        rtcReleaseGeometry(g);
        pf_rayscene_destroy(&s);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "Embree could not allocate %d vertices", (int)nv);
    }
    for (int32_t i = 0; i < nv; ++i) {
        v[3 * i + 0] = (float)(x[3 * i + 0] - s->centre.x);
        v[3 * i + 1] = (float)(x[3 * i + 1] - s->centre.y);
        v[3 * i + 2] = (float)(x[3 * i + 2] - s->centre.z);
    }
    for (int64_t i = 0; i < 3 * (int64_t)nt; ++i)
        idx[i] = tri[i];
    s->x = pf_alloc_array(3 * (size_t)nv + 1, sizeof *s->x);
    s->tri = pf_alloc_array(3 * (size_t)nt + 1, sizeof *s->tri);
    if (!s->x || !s->tri) {
        rtcReleaseGeometry(g);
        pf_rayscene_destroy(&s);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot copy a surface of %d vertices", (int)nv);
    }
    if (nv)
        memcpy(s->x, x, 3 * (size_t)nv * sizeof *x);
    if (nt)
        memcpy(s->tri, tri, 3 * (size_t)nt * sizeof *tri);
    s->extent = pf_v3_max_abs(pf_v3_sub(hi, s->centre));
    rtcSetGeometryIntersectFilterFunction(g, collect_hit);
    rtcCommitGeometry(g);
    rtcAttachGeometry(s->scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(s->scene);
    *rs = s;
    return PF_OK;
}

void pf_rayscene_destroy(pf_rayscene **rs)
{
    if (!*rs)
        return;
    if ((*rs)->scene)
        rtcReleaseScene((*rs)->scene);
    if ((*rs)->device)
        rtcReleaseDevice((*rs)->device);
    pf_free((*rs)->x);
    pf_free((*rs)->tri);
    PF_FREE(*rs);
}

static int compare_crossing(const void *pa, const void *pb)
{
    const pf_crossing *a = pa, *b = pb;
    if (a->t != b->t)
        return a->t < b->t ? -1 : 1;
    return (a->sign > b->sign) - (a->sign < b->sign);
}

pf_status pf_rayscene_crossings(const pf_rayscene *rs, pf_vec3 org, pf_vec3 dir, double t_max,
                                double merge_eps, pf_crossing *out, int64_t cap, int64_t *n,
                                pf_error *err)
{
    PF_CHECK(pf_v3_isfinite(org) && pf_v3_isfinite(dir) && pf_v3_norm(dir) > 0 && t_max >= 0,
             err, PF_ERR_INVALID, "ray needs a finite origin and a non-zero direction");
    hit_collector c = {.hits = out, .cap = cap, .dir_x = dir.x, .dir_y = dir.y, .dir_z = dir.z};
    rtcInitIntersectContext(&c.context);
    pf_vec3 o = pf_v3_sub(org, rs->centre);
    struct RTCRayHit rh;
    memset(&rh, 0, sizeof rh);
    rh.ray.org_x = (float)o.x, rh.ray.org_y = (float)o.y, rh.ray.org_z = (float)o.z;
    rh.ray.dir_x = (float)dir.x, rh.ray.dir_y = (float)dir.y, rh.ray.dir_z = (float)dir.z;
    rh.ray.tnear = 0;
    rh.ray.tfar = (float)t_max;
    rh.ray.mask = ~0u;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(rs->scene, &c.context, &rh);
    if (c.n > cap) {
        *n = c.n;
        return PF_OK;
    }
    qsort(out, (size_t)c.n, sizeof *out, compare_crossing);
    /* One crossing per place: hits of the same sign within merge_eps of the previous kept one
     * are the same passage through a shared edge or vertex. */
    int64_t kept = 0;
    for (int64_t i = 0; i < c.n; ++i) {
        int dup = 0;
        for (int64_t j = kept - 1; j >= 0 && out[i].t - out[j].t <= merge_eps && !dup; --j)
            dup = out[j].sign == out[i].sign;
        if (!dup)
            out[kept++] = out[i];
    }
    *n = kept;
    return PF_OK;
}

pf_vec3 pf_triangle_closest_point(pf_vec3 p, pf_vec3 a, pf_vec3 b, pf_vec3 c)
{
    /* p's projection onto the plane in barycentric form, clamped region by region: each corner's
     * region is where both edge parameters from it are <= 0, each edge's where the barycentric
     * coordinate of the opposite corner is <= 0 and the projection falls within the edge. */
    pf_vec3 ab = pf_v3_sub(b, a), ac = pf_v3_sub(c, a), ap = pf_v3_sub(p, a);
    double d1 = pf_v3_dot(ab, ap), d2 = pf_v3_dot(ac, ap);
    if (d1 <= 0 && d2 <= 0)
        return a;
    pf_vec3 bp = pf_v3_sub(p, b);
    double d3 = pf_v3_dot(ab, bp), d4 = pf_v3_dot(ac, bp);
    if (d3 >= 0 && d4 <= d3)
        return b;
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0)
        return pf_v3_add(a, pf_v3_scale(ab, d1 / (d1 - d3)));
    pf_vec3 cp = pf_v3_sub(p, c);
    double d5 = pf_v3_dot(ab, cp), d6 = pf_v3_dot(ac, cp);
    if (d6 >= 0 && d5 <= d6)
        return c;
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0)
        return pf_v3_add(a, pf_v3_scale(ac, d2 / (d2 - d6)));
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
        return pf_v3_add(b, pf_v3_scale(pf_v3_sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
    double den = va + vb + vc;
    if (!(den > 0)) /* degenerate triangle: the nearest of its corners */
        return pf_v3_dist(p, a) <= pf_v3_dist(p, b)
                   ? (pf_v3_dist(p, a) <= pf_v3_dist(p, c) ? a : c)
                   : (pf_v3_dist(p, b) <= pf_v3_dist(p, c) ? b : c);
    return pf_v3_add(a, pf_v3_add(pf_v3_scale(ab, vb / den), pf_v3_scale(ac, vc / den)));
}

typedef struct closest_query {
    const pf_rayscene *rs;
    pf_vec3 p;
    double best;   /* distance of the best candidate, INFINITY before one */
    double align;  /* |cos| between p - point and the best triangle's normal */
    double slack;  /* added to the float radius: the rounding of the float BVH */
    pf_closest out;
    bool found;
} closest_query;

static bool visit_triangle(struct RTCPointQueryFunctionArguments *args)
{
    closest_query *q = args->userPtr;
    const pf_rayscene *rs = q->rs;
    const uint32_t *t = rs->tri + 3 * (size_t)args->primID;
    pf_vec3 a = pf_v3_load(rs->x + 3 * (size_t)t[0]);
    pf_vec3 b = pf_v3_load(rs->x + 3 * (size_t)t[1]);
    pf_vec3 c = pf_v3_load(rs->x + 3 * (size_t)t[2]);
    pf_vec3 point = pf_triangle_closest_point(q->p, a, b, c);
    pf_vec3 d = pf_v3_sub(q->p, point);
    double dist = pf_v3_norm(d);
    if (dist > q->best * (1 + 1e-12) + 1e-300)
        return false;
    pf_vec3 n = pf_v3_cross(pf_v3_sub(b, a), pf_v3_sub(c, a));
    double nn = pf_v3_norm(n);
    if (!(nn > 0))
        return false;
    n = pf_v3_scale(n, 1 / nn);
    double align = dist > 0 ? fabs(pf_v3_dot(d, n)) / dist : 1;
    /* equally near (an edge or corner shared with the best so far): keep the better aligned */
    if (q->found && dist >= q->best * (1 - 1e-12) && align <= q->align)
        return false;
    bool shrink = dist < q->best;
    q->best = fmin(dist, q->best);
    q->align = align;
    q->out = (pf_closest){.point = point, .normal = n, .tri = (int32_t)args->primID,
                          .dist = dist};
    q->found = true;
    if (!shrink)
        return false;
    args->query->radius = (float)(dist + q->slack);
    return true;
}

bool pf_rayscene_closest(const pf_rayscene *rs, pf_vec3 p, double max_dist, pf_closest *out)
{
    pf_vec3 o = pf_v3_sub(p, rs->centre);
    /* float rounding of the stored vertices and of the query: a few ulps of the coordinates */
    double slack = 4e-7 * (rs->extent + pf_v3_max_abs(o)) + 1e-30;
    closest_query q = {.rs = rs, .p = p, .best = max_dist, .align = 0, .slack = slack};
    struct RTCPointQuery query = {.x = (float)o.x, .y = (float)o.y, .z = (float)o.z,
                                  .time = 0, .radius = (float)(max_dist + slack)};
    struct RTCPointQueryContext context;
    rtcInitPointQueryContext(&context);
    rtcPointQuery(rs->scene, &query, &context, visit_triangle, &q);
    if (!q.found)
        return false;
    *out = q.out;
    return true;
}

double pf_winding_number(const double *x, const uint32_t *tri, int32_t nt, pf_vec3 p)
{
    /* tan(Omega / 2) = a . (b x c) / (|a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|), with a, b, c
     * the corners relative to p; atan2 keeps the branch right for any solid angle. */
    double sum = 0;
    for (int32_t t = 0; t < nt; ++t) {
        pf_vec3 a = pf_v3_sub(pf_v3_load(x + 3 * (size_t)tri[3 * t + 0]), p);
        pf_vec3 b = pf_v3_sub(pf_v3_load(x + 3 * (size_t)tri[3 * t + 1]), p);
        pf_vec3 c = pf_v3_sub(pf_v3_load(x + 3 * (size_t)tri[3 * t + 2]), p);
        double la = pf_v3_norm(a), lb = pf_v3_norm(b), lc = pf_v3_norm(c);
        double num = pf_v3_dot(a, pf_v3_cross(b, c));
        double den = la * lb * lc + pf_v3_dot(a, b) * lc + pf_v3_dot(a, c) * lb +
                     pf_v3_dot(b, c) * la;
        sum += 2 * atan2(num, den);
    }
    return sum / (4 * 3.14159265358979323846);
}
