/* The shapes pf-render draws for a scene's obstacles. */
#ifndef PF_TOOLS_OBSTACLE_SHAPE_H
#define PF_TOOLS_OBSTACLE_SHAPE_H

#include <pf/mesh.h>
#include <pf/sim.h>

/* The triangles of obstacle o at rest (out released by the caller, also on failure): a sphere of
 * 16 x 32 bands, a box, the mesh's file, a plane as a square of side 4 size centred under the
 * body's centre c. The errors of pf_import_surface and the surface builders. */
/* The triangles of mesh obstacle o's file, turned by o->up (auto: the axis the file declares)
 * and scaled by o->scale as the tools do to a surface; the orientation is the file's (an open
 * obstacle is solid behind its triangles' front side). Errors name the file. */
pf_status pf_obstacle_read_file(const pf_obstacle *o, pf_surface *out, pf_error *err);

pf_status pf_obstacle_shape(const pf_obstacle *o, pf_vec3 c, double size, pf_surface *out,
                            pf_error *err);

#endif
