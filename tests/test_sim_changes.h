/* Shared by the tests that run the simulator on changing meshes (test_sim_refine.c,
 * test_sim_cut.c, test_crack_contact.c): scenes from JSON text, box meshes, frames, a simulator
 * on them, relative errors.
 * Include after <cmocka.h>, <math.h> and <string.h>. */
#ifndef PF_TEST_SIM_CHANGES_H
#define PF_TEST_SIM_CHANGES_H

#include <stdbool.h>

#include <pf/sim.h>

static inline void parse(pf_scene *sc, const char *json)
{
    pf_error err = {0};
    if (pf_scene_parse(sc, json, strlen(json), "test", &err) < 0)
        fail_msg("scene: %s", err.msg);
}

/* [0, hi] in nx x ny x nz hexes, derived. */
static inline void make_box(pf_mesh *m, pf_vec3 hi, int nx, int ny, int nz)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, pf_v3(0, 0, 0), hi, nx, ny, nz, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
}

/* [0, hi] in nx x ny x nz hexes, or cells of 6 Kuhn tetrahedra (tets), derived. */
static inline void make_box_mesh(pf_mesh *m, pf_vec3 hi, int nx, int ny, int nz, bool tets)
{
    pf_error err = {0};
    if (!tets) {
        make_box(m, hi, nx, ny, nz);
        return;
    }
    assert_int_equal(pf_mesh_make_box_tets(m, pf_v3(0, 0, 0), hi, nx, ny, nz, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
}

static inline void run_frames(pf_sim *sim, int n)
{
    pf_error err = {0};
    for (int f = 0; f < n; ++f)
        if (pf_sim_frame(sim, &err) < 0)
            fail_msg("frame %d: %s", f, err.msg);
}

/* The scene resolved against the mesh's box, and a simulator on them. */
static inline pf_sim *create(pf_scene *sc, const pf_mesh *m)
{
    pf_error err = {0};
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    pf_scene_resolve(sc, lo, hi);
    pf_sim *sim = NULL;
    if (pf_sim_create(&sim, sc, m, &err) < 0)
        fail_msg("create: %s", err.msg);
    return sim;
}

/* One pass of the scene's criterion (pf_sim_refine) at this threshold, one level deep at most;
 * returns the number of elements split. */
static inline int32_t refine_once(pf_sim *sim, pf_scene *sc, double threshold, pf_split_kind kind)
{
    sc->refine = (pf_refine_params){.enabled = true,
                                    .threshold = threshold,
                                    .split = kind,
                                    .max_level = 1,
                                    .max_elements = 100000};
    int32_t split = 0;
    pf_error err = {0};
    if (pf_sim_refine(sim, &split, &err) < 0)
        fail_msg("refine: %s", err.msg);
    return split;
}

static inline double rest_volume(const pf_mesh *m)
{
    double v = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        v += pf_mesh_elem_volume(m, e);
    return v;
}

static inline double rel(double a, double b)
{
    return fabs(a - b) / fmax(fabs(b), 1e-300);
}

static inline double vec_rel(pf_vec3 a, pf_vec3 b)
{
    return pf_v3_norm(pf_v3_sub(a, b)) / fmax(pf_v3_norm(b), 1e-300);
}

#endif
