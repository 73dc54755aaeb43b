/* Gmsh physical groups while a .msh file is read (import_msh.c), and their transfer to the mesh
 * built from it: element groups by cell, face groups by matching the corners of the 2D physical
 * elements to the mesh's faces. */
#ifndef PF_IO_IMPORT_MSH_GROUPS_H
#define PF_IO_IMPORT_MSH_GROUPS_H

#include <pf/mesh.h>

typedef struct msh_groups {
    pf_buffer names;      /* pf_mesh_group per $PhysicalNames entry (names owned) */
    pf_buffer entities;   /* msh_entity: surfaces and volumes with a physical tag (version 4) */
    pf_buffer cell_group; /* int32_t per cell read: its physical group, 0 for none */
    pf_buffer faces;      /* msh_face: the triangles and quadrangles of 2D physical groups */
} msh_groups;

pf_status pf_msh_groups_add_name(msh_groups *g, int32_t dim, int32_t number, const char *name,
                                 size_t len, pf_error *err);
pf_status pf_msh_groups_add_entity(msh_groups *g, int dim, int64_t tag, int64_t physical,
                                   pf_error *err);
/* The first physical tag of entity (dim, tag), 0 when it has none. */
int64_t pf_msh_groups_entity_physical(const msh_groups *g, int64_t dim, int64_t tag);
pf_status pf_msh_groups_add_cell(msh_groups *g, int64_t group, pf_error *err);
/* A 2D element of group `group` with n (3 or 4) corner nodes, as indices into the file's nodes;
 * elem and line for messages. */
pf_status pf_msh_groups_add_face(msh_groups *g, const int64_t *corners, int n, int64_t group,
                                 int64_t elem, int64_t line, pf_error *err);
/* Gives m (built from the cells, node_map: file node -> mesh node or -1) its groups: nothing
 * when the file has no physical group. PF_ERR_FORMAT "line L: element E of physical group G
 * matches no face of the volume mesh"; PF_ERR_NOMEM. */
pf_status pf_msh_groups_apply(const msh_groups *g, const int32_t *node_map, pf_mesh *m,
                              pf_error *err);
void pf_msh_groups_release(msh_groups *g);

#endif
