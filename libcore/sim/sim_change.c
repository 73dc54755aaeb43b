/* Changing the simulation mesh between steps: one transaction for refinement and coarsening
 * (sim_refine.c), and cutting later.
 *
 * A change is the new mesh and how its elements and nodes relate to the old ones
 * (pf_mesh_change). A complete simulator is built on the new mesh (pf_sim_build), taking over
 * from the old method what the change left as it was (DG: the integrals of unchanged elements
 * and faces; CG: the shape functions and matrices of unchanged elements), the state is carried over
 * by the method, and only then is the new simulator swapped in: until the swap nothing of the
 * running simulator is touched, so a failure leaves it as it was. */
#include <pf/embed.h>

#include <math.h>
#include <string.h>

#include "sim_change.h"

const pf_mesh *pf_sim_mesh(const pf_sim *s)
{
    return s->mesh;
}

const pf_weights *pf_sim_weights(const pf_sim *s)
{
    return s->weights;
}

const pf_surface *pf_sim_surface(const pf_sim *s)
{
    return s->surface;
}

/* Statistics: cumulative ones from s, what describes the mesh from t. */
static void carry_stats(pf_sim *t, const pf_sim *s, double transfer_seconds)
{
    pf_sim_stats mesh_stats = t->stats;
    t->stats = s->stats;
    t->stats.dofs = mesh_stats.dofs;
    t->stats.elements = mesh_stats.elements;
    t->stats.contact_points = mesh_stats.contact_points;
    t->stats.contact_samples = mesh_stats.contact_samples;
    t->stats.fixed_faces = mesh_stats.fixed_faces;
    t->stats.loaded_faces = mesh_stats.loaded_faces;
    t->stats.closed_form_elems = mesh_stats.closed_form_elems;
    t->stats.harmonic_elems = mesh_stats.harmonic_elems;
    t->stats.kernels = mesh_stats.kernels;
    t->stats.uncapped_faces = mesh_stats.uncapped_faces;
    t->stats.basis_seconds += mesh_stats.basis_seconds;
    t->stats.integrals_reused += mesh_stats.integrals_reused;
    t->stats.integrals_computed += mesh_stats.integrals_computed;
    t->stats.basis_reused += mesh_stats.basis_reused;
    t->stats.basis_computed += mesh_stats.basis_computed;
    t->stats.embed_rows += mesh_stats.embed_rows;
    t->stats.embed_rows_computed += mesh_stats.embed_rows_computed;
    t->stats.refine_embed_seconds += mesh_stats.refine_embed_seconds;
    t->stats.refine_transfer_seconds += transfer_seconds;
    t->solver_before = s->stats.solver;
    pf_sim_sync_solver_stats(t);
}

/* The new simulator t (built) takes over s's state, time and energy bookkeeping. */
static pf_status carry_over(pf_sim *t, const pf_sim *s, const pf_mesh_change *change, pf_error *err)
{
    double t0 = pf_cpu_seconds();
    PF_TRY(t->ops->transfer(t->method, s->method, change, s->u, t->u, err));
    PF_TRY(t->ops->transfer(t->method, s->method, change, s->v, t->v, err));
    t->time = s->time;
    t->frame = s->frame;
    t->energy_started = s->energy_started;
    t->kinetic0 = s->kinetic0;
    t->work = s->work;
    t->fixed_energy = s->fixed_energy;
    t->energy_floor = s->energy_floor;
    carry_stats(t, s, pf_cpu_seconds() - t0);
    return PF_OK;
}

/* The surface's weights on t's mesh: only the rows the change reaches recomputed when s's
 * weights are its own (their growth steps known), all of them after the caller's or a cut's. */
static pf_status reweight(pf_sim *t, const pf_sim *s, const pf_mesh_change *change, pf_error *err)
{
    double t0 = pf_cpu_seconds();
    int32_t n = s->surface->n_verts;
    t->owned_weights = pf_calloc(1, sizeof *t->owned_weights);
    t->embed_steps = pf_alloc_array(n > 0 ? (size_t)n : 1, sizeof *t->embed_steps);
    PF_CHECK(t->owned_weights && t->embed_steps, err, PF_ERR_NOMEM,
             "cannot allocate the surface's weights");
    pf_embed_update_stats st = {.rows = n, .rows_computed = n};
    if (s->embed_steps)
        PF_TRY(pf_embed_update(s->mesh, s->weights, s->embed_steps, t->owned_mesh,
                               change->node_map, s->surface, NULL, t->owned_weights,
                               t->embed_steps, &st, err));
    else
        PF_TRY(pf_embed_compute_steps(t->owned_mesh, s->surface, NULL, t->owned_weights,
                                      t->embed_steps, NULL, err));
    t->weights = t->owned_weights;
    t->stats.embed_rows = st.rows;
    t->stats.embed_rows_computed = st.rows_computed;
    t->stats.refine_embed_seconds = pf_cpu_seconds() - t0;
    return PF_OK;
}

/* A simulator on the new mesh (moved into it) with s's scene, surface and penalty. */
static pf_status build_on(pf_sim *t, const pf_sim *s, pf_mesh *mesh, const pf_mesh_change *change,
                          const uint8_t *changed, pf_error *err)
{
    t->scene = s->scene;
    t->progress = s->progress;
    t->surface = s->surface;
    t->uncut_surface = s->uncut_surface;
    t->solver_before.method = pf_solver_get_stats(s->solver)->method; /* auto's choice goes on */
    t->owned_mesh = pf_calloc(1, sizeof *t->owned_mesh);
    PF_CHECK(t->owned_mesh, err, PF_ERR_NOMEM, "cannot allocate the new mesh");
    *t->owned_mesh = *mesh;
    memset(mesh, 0, sizeof *mesh);
    PF_TRY(pf_mesh_derive(t->owned_mesh, err));
    if (!t->owned_mesh->elem_group) /* a cut carries them itself */
        PF_TRY(pf_mesh_carry_groups(t->owned_mesh, s->mesh, change->parent, change->merged_into,
                                    change->face_src, err));
    if (s->surface && change->cut) {
        t->owned_surface = pf_calloc(1, sizeof *t->owned_surface);
        t->owned_weights = pf_calloc(1, sizeof *t->owned_weights);
        PF_CHECK(t->owned_surface && t->owned_weights, err, PF_ERR_NOMEM,
                 "cannot allocate the cut surface");
        /* the caller's surface cut by every face opened so far, at once: cutting the cut
         * surface again along a crack that goes on (a progressive blade) left triangles across
         * the crack where one cut's faces met the next's */
        pf_cut_result all = *change->cut;
        all.opened = change->cut->cut_face;
        pf_surface_cut_stats cs;
        PF_TRY(pf_surface_cut(s->uncut_surface, t->owned_mesh, &all, NULL, t->owned_surface,
                              t->owned_weights, &cs, err));
        t->stats.uncapped_faces = cs.n_uncapped;
        t->owned_surface->id = t->owned_weights->surface_id = s->surface->id + 1;
        t->surface = t->owned_surface;
        t->weights = t->owned_weights;
    } else if (s->surface) {
        PF_TRY(reweight(t, s, change, err));
        t->stats.uncapped_faces = s->stats.uncapped_faces; /* the same surface goes on */
    }
    /* same solid: neither a child nor a merged element (a neighbour whose faces were only
     * subdivided or united is the same polyhedron) */
    int32_t ne = t->owned_mesh->n_elems;
    uint8_t *same = pf_calloc(2 * (size_t)ne + 1, 1);
    PF_CHECK(same, err, PF_ERR_NOMEM, "cannot allocate %d element flags", (int)ne);
    for (int32_t e = 0; e < ne; ++e) {
        int32_t p = change->parent[e];
        bool merged = change->merged_into && change->merged_into[p] >= 0;
        bool child = change->split && change->split[p];
        same[e] = !merged && !child;
        same[ne + e] = same[e] && !changed[e];
    }
    pf_status carried =
        pf_scene_carry_lists(s->scene, s->mesh, t->owned_mesh, change, &t->owned_scene, err);
    if (carried < 0) {
        pf_free(same);
        return carried;
    }
    if (t->owned_scene)
        t->scene = t->owned_scene;
    pf_method_reuse reuse = {.old = s->method,
                             .old_mesh = s->mesh,
                             .parent = change->parent,
                             .same_solid = same,
                             .same_faces = same + ne,
                             .face_src = change->face_src,
                             .node_map = change->node_map};
    pf_status st = pf_sim_build(t, t->owned_mesh, s->scene->refine.rebuild ? NULL : &reuse,
                                s->stats.penalty, err);
    pf_free(same);
    return st;
}

pf_status pf_sim_change_mesh(pf_sim *s, pf_mesh *next, const pf_mesh_change *change,
                             const uint8_t *changed, pf_sim **old, pf_error *err)
{
    *old = NULL;
    pf_sim *t = pf_calloc(1, sizeof *t);
    PF_CHECK(t, err, PF_ERR_NOMEM, "cannot allocate the simulator on the new mesh");
    double t0 = pf_cpu_seconds();
    pf_status st = build_on(t, s, next, change, changed, err);
    double build_seconds = pf_cpu_seconds() - t0;
    if (st >= 0)
        st = carry_over(t, s, change, err);
    if (st < 0) {
        pf_sim_destroy(&t);
        return st;
    }
    t->stats.refinements++;
    t->stats.refine_method_seconds += t->method_seconds;
    t->stats.refine_setup_seconds += build_seconds - t->method_seconds;
    t->blade_locks = s->blade_locks; /* the blades' planes go on */
    s->blade_locks = NULL;
    if (!t->owned_surface) { /* the surface of an earlier cut goes on */
        t->owned_surface = s->owned_surface;
        s->owned_surface = NULL;
    }
    pf_sim swap = *s;
    *s = *t;
    *t = swap;
    *old = t;
    return PF_OK;
}
