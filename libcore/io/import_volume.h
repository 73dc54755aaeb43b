/* Shared by the volume-mesh importers: a growing list of tet and hex cells whose nodes index the
 * file's node array, turned into a pf_mesh without the nodes no cell uses. */
#ifndef PF_IO_IMPORT_VOLUME_H
#define PF_IO_IMPORT_VOLUME_H

#include <pf/mesh.h>

typedef struct cell_list {
    pf_buffer offsets; /* int64_t [n_cells + 1] once a cell was added */
    pf_buffer nodes;   /* uint32_t: 4 (tet) or 8 (hex) node indices per cell */
    int64_t n_cells;
} cell_list;

/* Appends a cell of n = 4 or 8 node indices. PF_ERR_TOO_LARGE beyond INT32_MAX cells. */
pf_status pf_cell_list_add(cell_list *c, const uint32_t *nodes, int n, pf_error *err);

/* The mesh of the cells over nodes x [3 n_nodes] (every index < n_nodes), nodes no cell uses
 * dropped and the others kept in their order; built by pf_mesh_from_cells (shared faces once,
 * inside-out cells reoriented, element e is cell e). node_map [n_nodes], when not NULL, receives
 * the mesh index of every file node (-1: dropped). m is overwritten. */
pf_status pf_cell_list_build_mesh(const cell_list *c, const double *x, int64_t n_nodes, pf_mesh *m,
                                  int32_t *node_map, pf_error *err);

void pf_cell_list_release(cell_list *c);

#endif
