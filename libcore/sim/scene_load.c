/* Scenes from files, completed against a mesh, and region tests; the JSON reader is scene.c. */
#include <pf/sim.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

enum { SCENE_MAX_BYTES = 64 << 20 };

pf_status pf_scene_load(pf_scene *s, const char *path, pf_error *err)
{
    memset(s, 0, sizeof *s);
    pf_scene_default(s);
    PF_CHECK(path, err, PF_ERR_INVALID, "scene: no file name");
    FILE *f = fopen(path, "rb");
    PF_CHECK(f, err, PF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    /* Read to the end in growing chunks: works for pipes and process substitution too. */
    pf_buffer buf = {0};
    pf_status st = PF_OK;
    char chunk[8192];
    size_t n;
    while (st == PF_OK && (n = fread(chunk, 1, sizeof chunk, f)) > 0) {
        st = pf_buffer_append(&buf, chunk, n, err);
        if (st == PF_OK && buf.size > SCENE_MAX_BYTES)
            st = pf_error_set(err, PF_ERR_TOO_LARGE, __FILE__, __LINE__,
                              "%s: larger than %d bytes: not a scene file", path, SCENE_MAX_BYTES);
    }
    if (st == PF_OK && ferror(f))
        st = pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "%s: read failed: %s", path,
                          strerror(errno));
    fclose(f);
    if (st == PF_OK)
        st = pf_scene_parse(s, (const char *)buf.data, buf.size, path, err);
    else if (st == PF_ERR_NOMEM)
        pf_error_prefix(err, "%s", path);
    pf_buffer_release(&buf);
    return st;
}

/* ---- completion against a mesh, regions ------------------------------------------------------ */

void pf_scene_resolve(pf_scene *s, pf_vec3 lo, pf_vec3 hi)
{
    if (s->ground_auto) {
        /* The bounding box's extent along the normal from its 8 corners; the plane sits 5 % of
         * that extent below the lowest corner, so the body starts just above the ground. */
        pf_vec3 n = s->ground_normal;
        double smin = INFINITY, smax = -INFINITY;
        for (int c = 0; c < 8; ++c) {
            pf_vec3 corner = pf_v3(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z);
            double d = pf_v3_dot(n, corner);
            smin = fmin(smin, d);
            smax = fmax(smax, d);
        }
        s->ground_point = pf_v3_scale(n, smin - 0.05 * (smax - smin));
    }
    double tol = 1e-6 * pf_v3_dist(lo, hi);
    for (int32_t i = 0; i < s->n_fixed; ++i)
        if (s->fixed[i].region.kind == PF_REGION_PLANE && s->fixed[i].region.tol < 0)
            s->fixed[i].region.tol = tol;
    for (int32_t i = 0; i < s->n_loads; ++i)
        if (s->loads[i].region.kind == PF_REGION_PLANE && s->loads[i].region.tol < 0)
            s->loads[i].region.tol = tol;
}

bool pf_region_contains(const pf_region *r, pf_vec3 p)
{
    if (r->kind == PF_REGION_BOX)
        return p.x >= r->lo.x && p.x <= r->hi.x && p.y >= r->lo.y && p.y <= r->hi.y &&
               p.z >= r->lo.z && p.z <= r->hi.z;
    return fabs(pf_plane_signed_distance(r->plane, p)) <= r->tol;
}
