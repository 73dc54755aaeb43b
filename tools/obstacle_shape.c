/* The shapes pf-render draws for a scene's obstacles. */
#include "obstacle_shape.h"

#include <math.h>
#include <string.h>

#include <pf/io.h>

pf_status pf_obstacle_read_file(const pf_obstacle *o, pf_surface *out, pf_error *err)
{
    pf_surface_fix_params fix = pf_surface_fix_params_default();
    fix.up = o->up;
    fix.scale = o->scale > 0 ? o->scale : 1;
    fix.orient = false;
    return pf_import_surface_fixed(o->file, &fix, out, NULL, NULL, err);
}

/* The triangles of obstacle o at rest: a sphere of 16 x 32 bands, a box, the mesh's file, a plane
 * as a square of side 4 size centred under the body's centre c. */
pf_status pf_obstacle_shape(const pf_obstacle *o, pf_vec3 c, double size, pf_surface *out,
                            pf_error *err)
{
    if (o->kind == PF_OBSTACLE_BOX)
        return pf_surface_make_box(out, o->lo, o->hi, err);
    if (o->kind == PF_OBSTACLE_MESH)
        return pf_obstacle_read_file(o, out, err);
    if (o->kind == PF_OBSTACLE_SPHERE) {
        PF_TRY(pf_surface_make_sphere(out, o->radius, 16, 32, err));
        for (int32_t i = 0; i < out->n_verts; ++i)
            pf_v3_store(pf_v3_add(pf_v3_load(out->x + 3 * i), o->centre), out->x + 3 * i);
        return PF_OK;
    }
    /* a plane: two unit vectors across the normal, the square's centre on the plane below c */
    pf_vec3 n = o->normal, t = fabs(n.x) < 0.9 ? pf_v3(1, 0, 0) : pf_v3(0, 1, 0);
    pf_vec3 e1 = pf_v3_normalize(pf_v3_cross(n, t)), e2 = pf_v3_cross(n, e1);
    pf_vec3 m = pf_v3_sub(c, pf_v3_scale(n, pf_v3_dot(n, pf_v3_sub(c, o->point))));
    PF_TRY(pf_surface_alloc(out, 4, 2, err));
    for (int q = 0; q < 4; ++q) {
        double s1 = (q == 1 || q == 2) ? 2 * size : -2 * size, s2 = q >= 2 ? 2 * size : -2 * size;
        pf_v3_store(pf_v3_add(m, pf_v3_add(pf_v3_scale(e1, s1), pf_v3_scale(e2, s2))),
                    out->x + 3 * q);
    }
    const uint32_t tri[6] = {0, 1, 2, 0, 2, 3}; /* e1 x e2 = n: counter-clockwise seen from n */
    memcpy(out->tri, tri, sizeof tri);
    return PF_OK;
}
