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

#endif
