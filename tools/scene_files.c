/* The files a scene names besides itself, read here and handed to the scene. */
#include "scene_files.h"

#include <pf/io.h>

#include "obstacle_shape.h"

static pf_status read_obstacles(pf_scene *sc, pf_error *err)
{
    for (int32_t i = 0; i < sc->n_obstacles; ++i) {
        if (sc->obstacles[i].kind != PF_OBSTACLE_MESH)
            continue;
        pf_surface s = {0};
        pf_status st = pf_obstacle_read_file(&sc->obstacles[i], &s, err);
        if (st < 0)
            pf_error_prefix(err, "obstacles[%d].mesh", (int)i);
        else
            st = pf_scene_set_obstacle_surface(sc, i, &s, err);
        pf_surface_release(&s);
        PF_TRY(st);
    }
    return PF_OK;
}

/* The list of region r (what[k]), when it has one, read and handed over. */
static pf_status read_list(pf_region *r, const pf_mesh *m, const char *what, int32_t k,
                           pf_error *err)
{
    if (r->kind != PF_REGION_NODES && r->kind != PF_REGION_ELEMENTS)
        return PF_OK;
    bool nodes = r->kind == PF_REGION_NODES;
    int32_t *indices = NULL, n = 0;
    pf_status st = pf_import_index_list(r->file, nodes ? m->n_nodes : m->n_elems,
                                        nodes ? "node" : "element", &indices, &n, err);
    if (st >= 0)
        st = pf_region_set_list(r, m, indices, n, err);
    pf_free(indices);
    if (st < 0)
        pf_error_prefix(err, "%s[%d].%s", what, (int)k, nodes ? "nodes_file" : "elements_file");
    return st;
}

pf_status pf_scene_read_files(pf_scene *sc, const pf_mesh *m, pf_error *err)
{
    PF_TRY(read_obstacles(sc, err));
    for (int32_t k = 0; k < sc->n_fixed; ++k)
        PF_TRY(read_list(&sc->fixed[k].region, m, "fixed", k, err));
    for (int32_t k = 0; k < sc->n_loads; ++k)
        PF_TRY(read_list(&sc->loads[k].region, m, "loads", k, err));
    for (int32_t k = 0; k < sc->n_materials; ++k)
        PF_TRY(read_list(&sc->materials[k].region, m, "materials", k, err));
    return PF_OK;
}
