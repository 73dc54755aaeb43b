/* regions: Gmsh physical groups carried into the mesh and the stream, scenes selecting fixed and
 * loaded faces by group, and several materials per scene, against two springs in series. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <pf/io.h>
#include <pf/sim.h>

/* The bar [0, L] x [0, 1] x [0, 1], L = 2, in NX x 1 x 1 hexes; x < 1 is material 1, the rest
 * material 2. */
enum { NX = 4 };
static const double BAR_L = 2, SPLIT = 1;
static const double E1 = 2e5, E2 = 5e4, TRACTION = 100;

/* A static scene on the bar: no gravity, nu = 0 (the exact solution is then uniaxial: u_x
 * piecewise linear, u_y = u_z = 0, so fixing every component at x = 0 is exact), x = 0 fixed,
 * traction along x at x = L. by_group: faces and materials chosen by the .msh groups. */
static const char *bar_scene(const char *method, bool by_group)
{
    static char text[2048];
    const char *select_fixed =
        by_group ? "\"group\": \"clamp\"" : "\"box\": [[-1, -1, -1], [0, 2, 2]]";
    const char *select_load = by_group ? "\"group\": 2" : "\"box\": [[2, -1, -1], [3, 2, 2]]";
    const char *select_soft =
        by_group ? "\"group\": \"soft\"" : "\"box\": [[1, -1, -1], [3, 2, 2]]";
    snprintf(text, sizeof text,
             "{\"static\": true, \"gravity\": [0, 0, 0], \"method\": %s,"
             " \"material\": {\"E\": %.17g, \"nu\": 0},"
             " \"materials\": [{%s, \"E\": %.17g}],"
             " \"fixed\": [{%s}], \"loads\": [{%s, \"traction\": [%.17g, 0, 0]}]}",
             method, E1, select_soft, E2, select_fixed, select_load, TRACTION);
    return text;
}

/* Mean x displacement of the nodes at x = L. */
static double tip_displacement(const pf_mesh *m, const char *json)
{
    pf_error err = {0};
    pf_scene sc;
    if (pf_scene_parse(&sc, json, strlen(json), "bar.json", &err) != PF_OK)
        fail_msg("%s", err.msg);
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim *sim = NULL;
    if (pf_sim_create(&sim, &sc, m, &err) != PF_OK)
        fail_msg("%s", err.msg);
    assert_int_equal(pf_sim_solve_static(sim, &err), PF_OK);
    double *u = malloc(3 * (size_t)m->n_nodes * sizeof *u);
    pf_sim_nodal_displacements(sim, u);
    double sum = 0;
    int n = 0;
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (fabs(m->x[3 * i] - BAR_L) < 1e-12) {
            sum += u[3 * i];
            ++n;
        }
    free(u);
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    return sum / n;
}

/* Two springs in series: u(L) = t L1 / E1 + t L2 / E2 (A = 1, F = t A). The discrete spaces
 * hold the exact piecewise-linear field (the interface is a face plane) and IP and CG are
 * consistent, so the only error is round-off (about 5e-15 seen): 1e-12 relative. */
static const char *const METHODS[] = {"{\"name\": \"dg\", \"degree\": 1}",
                                      "{\"name\": \"dg\", \"degree\": 2}", "\"cg\""};

static void check_two_materials(const pf_mesh *m, bool by_group)
{
    double exact = TRACTION * SPLIT / E1 + TRACTION * (BAR_L - SPLIT) / E2;
    for (size_t k = 0; k < sizeof METHODS / sizeof *METHODS; ++k) {
        double u = tip_displacement(m, bar_scene(METHODS[k], by_group));
        printf("%s%s: tip relative error %.2e\n", METHODS[k], by_group ? " by group" : "",
               fabs(u - exact) / exact);
        if (!(fabs(u - exact) <= 1e-12 * exact))
            fail_msg("%s%s: tip %.15g, two springs %.15g (relative error %.2e)", METHODS[k],
                     by_group ? " by group" : "", u, exact, fabs(u - exact) / exact);
    }
}

static void two_material_bar(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    pf_error err = {0};
    assert_int_equal(
        pf_mesh_make_box(&m, (pf_vec3){0, 0, 0}, (pf_vec3){BAR_L, 1, 1}, NX, 1, 1, &err), PF_OK);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    check_two_materials(&m, false);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- the bar as a Gmsh file ------------------------------------------------------------------ */

static int node_tag(int i, int j, int k)
{
    return 1 + i + (NX + 1) * (j + 2 * k);
}

/* The bar as .msh (version 2.2 or 4.1) with physical volumes 10 "stiff" (x < 1) and 11 "soft",
 * physical surfaces 1 "clamp" (x = 0) and 2 "tip end" (x = L). */
static void write_bar_msh(const char *path, int version)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "$MeshFormat\n%s 0 8\n$EndMeshFormat\n", version == 2 ? "2.2" : "4.1");
    fprintf(f, "$PhysicalNames\n4\n2 1 \"clamp\"\n2 2 \"tip end\"\n3 10 \"stiff\"\n"
               "3 11 \"soft\"\n$EndPhysicalNames\n");
    int nn = (NX + 1) * 4;
    if (version == 4) {
        /* surfaces 1 (x = 0), 2 (x = L), 3 (no group); volumes 1 (stiff), 2 (soft) */
        fprintf(f, "$Entities\n0 0 3 2\n"
                   "1 0 0 0 0 1 1 1 1 0\n2 2 0 0 2 1 1 1 2 0\n3 0 0 0 2 1 1 0 0\n"
                   "1 0 0 0 1 1 1 1 10 0\n2 1 0 0 2 1 1 1 11 0\n$EndEntities\n");
        fprintf(f, "$Nodes\n1 %d 1 %d\n3 1 0 %d\n", nn, nn, nn);
        for (int t = 1; t <= nn; ++t)
            fprintf(f, "%d\n", t);
    } else {
        fprintf(f, "$Nodes\n%d\n", nn);
    }
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i <= NX; ++i) {
                if (version == 2)
                    fprintf(f, "%d ", node_tag(i, j, k));
                fprintf(f, "%.17g %d %d\n", BAR_L * i / NX, j, k);
            }
    fprintf(f, "$EndNodes\n");
    int quad0[4] = {node_tag(0, 0, 0), node_tag(0, 1, 0), node_tag(0, 1, 1), node_tag(0, 0, 1)};
    int quad1[4] = {node_tag(NX, 0, 0), node_tag(NX, 0, 1), node_tag(NX, 1, 1), node_tag(NX, 1, 0)};
    if (version == 2) {
        fprintf(f, "$Elements\n%d\n", NX + 2);
        fprintf(f, "1 3 2 1 1 %d %d %d %d\n", quad0[0], quad0[1], quad0[2], quad0[3]);
        fprintf(f, "2 3 2 2 2 %d %d %d %d\n", quad1[0], quad1[1], quad1[2], quad1[3]);
    } else {
        fprintf(f, "$Elements\n%d %d 1 %d\n", NX + 3, NX + 3, NX + 3);
        fprintf(f, "2 1 3 1\n1 %d %d %d %d\n", quad0[0], quad0[1], quad0[2], quad0[3]);
        fprintf(f, "2 2 3 1\n2 %d %d %d %d\n", quad1[0], quad1[1], quad1[2], quad1[3]);
        /* a quadrangle of a surface in no group: skipped */
        fprintf(f, "2 3 3 1\n3 %d %d %d %d\n", quad0[0], quad0[1], quad0[2], quad0[3]);
    }
    for (int i = 0; i < NX; ++i) {
        bool soft = (i + 0.5) * BAR_L / NX > SPLIT;
        if (version == 4)
            fprintf(f, "3 %d 5 1\n", soft ? 2 : 1);
        else
            fprintf(f, "%d 5 2 %d %d ", 3 + i, soft ? 11 : 10, soft ? 2 : 1);
        if (version == 4)
            fprintf(f, "%d ", 4 + i);
        fprintf(f, "%d %d %d %d %d %d %d %d\n", node_tag(i, 0, 0), node_tag(i + 1, 0, 0),
                node_tag(i + 1, 1, 0), node_tag(i, 1, 0), node_tag(i, 0, 1), node_tag(i + 1, 0, 1),
                node_tag(i + 1, 1, 1), node_tag(i, 1, 1));
    }
    fprintf(f, "$EndElements\n");
    fclose(f);
}

static int32_t count_tag(const int32_t *tags, int32_t n, int32_t tag)
{
    int32_t c = 0;
    for (int32_t i = 0; i < n; ++i)
        c += tags[i] == tag;
    return c;
}

/* The groups read from the file: names, numbers, dimensions; the two end faces tagged, the
 * elements split 2 / 2; then the same tip displacement as the box selection. */
static void check_msh_groups(const pf_mesh *m)
{
    assert_int_equal(m->n_groups, 4);
    const pf_mesh_group *clamp = pf_mesh_find_group(m, 2, "clamp", 0);
    assert_non_null(clamp);
    assert_int_equal(clamp->number, 1);
    assert_non_null(pf_mesh_find_group(m, 2, "tip end", 0));
    assert_null(pf_mesh_find_group(m, 3, "clamp", 0)); /* names are per dimension */
    assert_int_equal(pf_mesh_find_group(m, 3, "soft", 0)->number, 11);
    assert_int_equal(count_tag(m->face_group, m->n_faces, 1), 1);
    assert_int_equal(count_tag(m->face_group, m->n_faces, 2), 1);
    assert_int_equal(count_tag(m->face_group, m->n_faces, 0), m->n_faces - 2);
    assert_int_equal(count_tag(m->elem_group, m->n_elems, 10), NX / 2);
    assert_int_equal(count_tag(m->elem_group, m->n_elems, 11), NX / 2);
    for (int32_t f = 0; f < m->n_faces; ++f) {
        if (!m->face_group[f])
            continue;
        double x = m->x[3 * m->face_nodes[m->face_offsets[f]]];
        assert_true(m->face_group[f] == 1 ? x == 0 : x == BAR_L);
    }
}

static void msh_groups_select_like_boxes(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    char path[64];
    snprintf(path, sizeof path, "/tmp/pf_regions_%d.msh", (int)getpid());
    for (int version = 2; version <= 4; version += 2) {
        write_bar_msh(path, version);
        pf_mesh m = {0};
        pf_error err = {0};
        if (pf_import_msh(path, &m, &err) != PF_OK)
            fail_msg("version %d: %s", version, err.msg);
        assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
        check_msh_groups(&m);
        for (size_t k = 0; k < sizeof METHODS / sizeof *METHODS; ++k) {
            double by_box = tip_displacement(&m, bar_scene(METHODS[k], false));
            double by_group = tip_displacement(&m, bar_scene(METHODS[k], true));
            if (!(fabs(by_box - by_group) <= 1e-12 * fabs(by_box)))
                fail_msg("%s: box %.17g, group %.17g", METHODS[k], by_box, by_group);
        }
        check_two_materials(&m, true);
        pf_mesh_release(&m);
    }
    remove(path);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A group the mesh does not have is an error naming the scene key and listing the mesh's. */
static void unknown_group_is_an_error(void **state)
{
    (void)state;
    char path[64];
    snprintf(path, sizeof path, "/tmp/pf_regions_u%d.msh", (int)getpid());
    write_bar_msh(path, 2);
    pf_mesh m = {0};
    pf_error err = {0};
    assert_int_equal(pf_import_msh(path, &m, &err), PF_OK);
    remove(path);
    assert_int_equal(pf_mesh_derive(&m, &err), PF_OK);
    const char *json = "{\"static\": true, \"fixed\": [{\"group\": \"top\"}]}";
    pf_scene sc;
    assert_int_equal(pf_scene_parse(&sc, json, strlen(json), "s.json", &err), PF_OK);
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "fixed[0].group: the mesh has no group 'top' of faces"));
    assert_non_null(strstr(err.msg, "1 'clamp' of faces"));
    pf_scene_release(&sc);
    /* a volume group named for faces */
    json = "{\"static\": true, \"fixed\": [{\"group\": 10}]}";
    assert_int_equal(pf_scene_parse(&sc, json, strlen(json), "s.json", &err), PF_OK);
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "no group 10 of faces"));
    pf_scene_release(&sc);
    pf_mesh_release(&m);
}

/* A surface element whose corners are no face of the volume mesh names its line. */
static void unmatched_surface_is_an_error(void **state)
{
    (void)state;
    char path[64];
    snprintf(path, sizeof path, "/tmp/pf_regions_s%d.msh", (int)getpid());
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n"
               "4 0 0 1\n5 1 1 1\n$EndNodes\n$Elements\n2\n1 4 2 7 1 1 2 3 4\n"
               "2 2 2 3 1 2 3 5\n$EndElements\n");
    fclose(f);
    pf_mesh m = {0};
    pf_error err = {0};
    assert_int_equal(pf_import_msh(path, &m, &err), PF_ERR_FORMAT);
    remove(path);
    assert_non_null(strstr(err.msg, "line 15: element 2 of physical group 3 matches no face"));
}

/* ---- the stream ------------------------------------------------------------------------------ */

/* MESH + GRPS written, read back through the reader state: the same groups; a GRPS naming
 * another mesh is an error. */
static void groups_travel_in_the_stream(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    char path[64];
    snprintf(path, sizeof path, "/tmp/pf_regions_g%d.msh", (int)getpid());
    write_bar_msh(path, 4);
    pf_mesh m = {0};
    pf_error err = {0};
    assert_int_equal(pf_import_msh(path, &m, &err), PF_OK);
    remove(path);
    m.id = 7;
    FILE *out = tmpfile();
    assert_non_null(out);
    pf_stream_writer *w = NULL;
    assert_int_equal(pf_stream_writer_create(&w, out, "mem", &err), PF_OK);
    assert_int_equal(pf_stream_write_mesh(w, &m, &err), PF_OK);
    assert_int_equal(pf_stream_writer_finish(w, &err), PF_OK);
    pf_stream_writer_destroy(&w);
    rewind(out);
    FILE *in = out;
    pf_stream_reader *r = NULL;
    assert_int_equal(pf_stream_reader_create(&r, in, "mem", &err), PF_OK);
    pf_stream_state st = {0};
    pf_chunk c;
    bool end = false;
    int chunks = 0;
    while (pf_stream_read_chunk(r, &c, &end, &err) == PF_OK && !end) {
        if (strcmp(c.tag, "GRPS") == 0) {
            assert_false(pf_stream_tag_is_critical("GRPS"));
            assert_true(pf_stream_tag_is_mesh_dependent("GRPS"));
            /* a GRPS of another mesh */
            pf_mesh other = {0};
            assert_int_equal(pf_mesh_copy(&other, &st.mesh, &err), PF_OK);
            other.id = 8;
            assert_int_equal(pf_stream_decode_groups(&c, &other, &err), PF_ERR_FORMAT);
            assert_non_null(strstr(err.msg, "groups of mesh 7"));
            pf_mesh_release(&other);
        }
        assert_int_equal(pf_stream_state_take(&st, &c, &err), PF_OK);
        ++chunks;
    }
    assert_int_equal(chunks, 3); /* MESH, GRPS, END_ */
    check_msh_groups(&st.mesh);
    assert_memory_equal(st.mesh.elem_group, m.elem_group, (size_t)m.n_elems * sizeof(int32_t));
    assert_memory_equal(st.mesh.face_group, m.face_group, (size_t)m.n_faces * sizeof(int32_t));
    /* after another MESH, the same GRPS is ignored: the new mesh has no groups */
    rewind(in);
    pf_stream_reader_destroy(&r);
    assert_int_equal(pf_stream_reader_create(&r, in, "mem", &err), PF_OK);
    pf_chunk mesh_chunk = {0}, groups_chunk = {0};
    pf_mesh box = {0};
    assert_int_equal(pf_mesh_make_box(&box, (pf_vec3){0, 0, 0}, (pf_vec3){1, 1, 1}, 1, 1, 1, &err),
                     PF_OK);
    pf_buffer enc = {0};
    assert_int_equal(pf_stream_encode_mesh(&box, &enc, &err), PF_OK);
    mesh_chunk = (pf_chunk){.tag = "MESH", .version = 1, .size = enc.size, .payload = enc.data};
    assert_int_equal(pf_stream_read_chunk(r, &groups_chunk, &end, &err), PF_OK); /* MESH */
    assert_int_equal(pf_stream_read_chunk(r, &groups_chunk, &end, &err), PF_OK); /* GRPS */
    assert_string_equal(groups_chunk.tag, "GRPS");
    assert_int_equal(pf_stream_state_take(&st, &mesh_chunk, &err), PF_OK);
    assert_int_equal(pf_stream_state_take(&st, &groups_chunk, &err), PF_OK);
    assert_null(st.mesh.elem_group);
    assert_int_equal(st.mesh.n_groups, 0);
    pf_buffer_release(&enc);
    pf_mesh_release(&box);
    pf_stream_state_release(&st);
    pf_stream_reader_destroy(&r);
    fclose(in);

    /* the groups follow their elements and faces into a sub-mesh */
    uint8_t keep[NX] = {0, 0, 1, 1};
    pf_mesh half = {0};
    assert_int_equal(pf_mesh_select_elements(&half, &m, keep, NULL, &err), PF_OK);
    assert_int_equal(count_tag(half.elem_group, half.n_elems, 11), NX / 2);
    assert_int_equal(count_tag(half.face_group, half.n_faces, 2), 1);
    assert_int_equal(count_tag(half.face_group, half.n_faces, 1), 0);
    pf_mesh_release(&half);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- scenes ---------------------------------------------------------------------------------- */

static void scene_reads_groups_and_materials(void **state)
{
    (void)state;
    pf_error err = {0};
    pf_scene sc;
    const char *json = "{\"material\": {\"E\": 3, \"density\": 7},"
                       " \"materials\": [{\"group\": \"soft\", \"nu\": 0.2},"
                       "                 {\"box\": [[0, 0, 0], [1, 1, 1]], \"E\": 5}],"
                       " \"fixed\": [{\"group\": 4}], \"loads\": [{\"group\": \"tip\","
                       " \"traction\": [1, 0, 0]}]}";
    assert_int_equal(pf_scene_parse(&sc, json, strlen(json), "s.json", &err), PF_OK);
    assert_int_equal(sc.n_materials, 2);
    assert_int_equal(sc.materials[0].region.kind, PF_REGION_GROUP);
    assert_string_equal(sc.materials[0].region.group_name, "soft");
    assert_true(sc.materials[0].E == 3 && sc.materials[0].nu == 0.2 &&
                sc.materials[0].density == 7);
    assert_true(sc.materials[1].E == 5 && sc.materials[1].nu == 0.3);
    assert_int_equal(sc.fixed[0].region.group, 4);
    assert_string_equal(sc.loads[0].region.group_name, "tip");
    /* the scene written back reads the same */
    char *text = NULL;
    assert_int_equal(pf_scene_to_json(&sc, &text, &err), PF_OK);
    pf_scene back;
    assert_int_equal(pf_scene_parse(&back, text, strlen(text), "back", &err), PF_OK);
    assert_int_equal(back.n_materials, 2);
    assert_memory_equal(back.materials, sc.materials, 2 * sizeof *sc.materials);
    assert_memory_equal(&back.fixed[0].region, &sc.fixed[0].region, sizeof(pf_region));
    pf_free(text);
    pf_scene_release(&back);
    pf_scene_release(&sc);

    static const struct {
        const char *json, *message;
    } BAD[] = {
        {"{\"fixed\": [{\"group\": \"\"}]}", "fixed[0].group: a group name has 1 to"},
        {"{\"fixed\": [{\"group\": 0}]}", "fixed[0].group: must be an integer >= 1"},
        {"{\"fixed\": [{\"group\": 1, \"box\": [[0,0,0],[1,1,1]]}]}", "not several"},
        {"{\"materials\": [{\"E\": 1}]}", "materials[0]: missing region"},
        {"{\"materials\": [{\"group\": 1, \"nu\": 0.5}]}", "materials[0].nu"},
        {"{\"materials\": [{\"plane\": {}}]}", "materials[0].plane: unknown key"},
    };
    for (size_t k = 0; k < sizeof BAD / sizeof *BAD; ++k) {
        assert_int_equal(pf_scene_parse(&sc, BAD[k].json, strlen(BAD[k].json), "s.json", &err),
                         PF_ERR_INVALID);
        if (!strstr(err.msg, BAD[k].message))
            fail_msg("%s: got '%s', expected '%s'", BAD[k].json, err.msg, BAD[k].message);
        pf_scene_release(&sc);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(two_material_bar),
        cmocka_unit_test(msh_groups_select_like_boxes),
        cmocka_unit_test(unknown_group_is_an_error),
        cmocka_unit_test(unmatched_surface_is_an_error),
        cmocka_unit_test(groups_travel_in_the_stream),
        cmocka_unit_test(scene_reads_groups_and_materials),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
