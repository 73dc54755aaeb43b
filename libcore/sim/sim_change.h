/* Changing the simulation mesh between steps (sim_change.c), for refinement and coarsening
 * (sim_refine.c). Private to libcore/sim. */
#ifndef PF_SIM_CHANGE_H
#define PF_SIM_CHANGE_H

#include "sim_internal.h"

/* Builds a simulator on next (moved into it, emptied) for s's scene, carries s's state over as
 * change describes (changed: [new elements] pf_refine_result.changed or its coarsening
 * counterpart), and swaps it into s: *old then holds the simulator on the mesh before, for the
 * caller to read (element bookkeeping) and destroy. On failure s is unchanged and *old NULL. */
pf_status pf_sim_change_mesh(pf_sim *s, pf_mesh *next, const pf_mesh_change *change,
                             const uint8_t *changed, pf_sim **old, pf_error *err);

/* The scene src with its node and element lists carried from old_mesh to m over change: the
 * elements' children inherit their membership, old nodes keep theirs, and a new node is named
 * when it lies on an old face all of whose nodes the list named (so the faces split out of a
 * listed face are listed). *out is NULL when src has no lists, else a copy that shares all but
 * its fixed, loads and materials arrays and their lists with src (free with
 * pf_scene_free_lists; the scene src is or was copied from must outlive it). PF_ERR_NOMEM. */
pf_status pf_scene_carry_lists(const pf_scene *src, const pf_mesh *old_mesh, const pf_mesh *m,
                               const pf_mesh_change *change, pf_scene **out, pf_error *err);
void pf_scene_free_lists(pf_scene **s);

#endif
