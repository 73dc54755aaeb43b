/* What a checkpoint holds of the simulator (sim_state.c), lent by sim.c, which owns the struct.
 * Private to sim/. */
#ifndef PF_SIM_STATE_H
#define PF_SIM_STATE_H

#include <pf/sim.h>

typedef struct pf_sim_state_view {
    const pf_scene *scene;
    const pf_mesh *mesh;
    int64_t n;          /* unknowns */
    double *u, *v, *dv; /* [n] displacement, velocity, the warm start's trend */
    double *time;
    int32_t *frame;
    bool *energy_started; /* the energy check's accumulators (sim.c, energy_is_bounded) */
    double *kinetic0, *work, *fixed_energy, *energy_floor;
} pf_sim_state_view;

/* Pointers into s's state. */
void pf_sim_state_view_of(pf_sim *s, pf_sim_state_view *v);

/* Drops the solver's factor and marks the matrix as new, so that the next step factorises as the
 * first step of a fresh simulator does: from here on the run depends on the view's state alone. */
void pf_sim_restart_point(pf_sim *s);

#endif
