/* The files a scene names besides itself, read by the tools and handed to the scene (libcore/sim
 * reads no files): the triangles of mesh obstacles, and the lists of nodes and elements of
 * regions. */
#ifndef PF_TOOLS_SCENE_FILES_H
#define PF_TOOLS_SCENE_FILES_H

#include <pf/mesh.h>
#include <pf/sim.h>

/* Reads every mesh obstacle's file (pf_obstacle_read_file) and every "nodes_file" and
 * "elements_file" of fixed, loads and materials (pf_import_index_list, indices of mesh m), and
 * hands them to sc. Errors name the key and the file: "fixed[0].nodes_file: clamp.txt:3: node
 * 12 out of range: the mesh has 8 nodes, numbered from 0". */
pf_status pf_scene_read_files(pf_scene *sc, const pf_mesh *m, pf_error *err);

#endif
