/* region lists: fixed, loaded and material regions given as files of node or element indices
 * ("nodes_file", "elements_file") select exactly what the equivalent boxes select, so the frames
 * are the same bits; and every malformed list is an error naming its file and line. */
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

/* The bar [0, 2] x [0, 1] x [0, 1] in 4 x 2 x 2 hexes: clamped at x = 0, pulled down at x = 2,
 * stiffer for x > 1, under gravity. */
static const double BAR_L = 2;

static void make_bar(pf_mesh *m)
{
    pf_error err = {0};
    assert_int_equal(pf_mesh_make_box(m, (pf_vec3){0, 0, 0}, (pf_vec3){BAR_L, 1, 1}, 4, 2, 2, &err),
                     PF_OK);
    assert_int_equal(pf_mesh_derive(m, &err), PF_OK);
}

static char *tmp_path(const char *name)
{
    static char paths[4][96];
    static int next = 0;
    char *p = paths[next++ % 4];
    snprintf(p, sizeof paths[0], "/tmp/pf_lists_%d_%s", (int)getpid(), name);
    return p;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* The nodes with x == at (exactly: the box mesh's nodes are products of its spacing), with a
 * comment and a blank line, as a user's list has them. */
static void write_nodes_at(const pf_mesh *m, double at, const char *path)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "# nodes at x = %g\n\n", at);
    for (int32_t i = 0; i < m->n_nodes; ++i)
        if (m->x[3 * i] == at)
            fprintf(f, "%d   # (%g, %g)\n", (int)i, m->x[3 * i + 1], m->x[3 * i + 2]);
    fclose(f);
}

/* The elements whose nodes all have x >= 1: those right of the material interface. */
static void write_elements_right(const pf_mesh *m, const char *path)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    for (int32_t e = 0; e < m->n_elems; ++e) {
        bool right = true;
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t face = PF_FACE_INDEX(m->elem_faces[k]);
            for (int64_t q = m->face_offsets[face]; q < m->face_offsets[face + 1]; ++q)
                right = right && m->x[3 * m->face_nodes[q]] >= 1;
        }
        if (right)
            fprintf(f, "%d\n", (int)e);
    }
    fclose(f);
}

/* The scene with the three regions given by boxes, or by list files. */
static const char *bar_scene(const char *method, bool lists, const char *clamp, const char *tip,
                             const char *right)
{
    static char text[2048];
    char fixed[256], load[256], mat[256];
    if (lists) {
        snprintf(fixed, sizeof fixed, "\"nodes_file\": \"%s\"", clamp);
        snprintf(load, sizeof load, "\"nodes_file\": \"%s\"", tip);
        snprintf(mat, sizeof mat, "\"elements_file\": \"%s\"", right);
    } else {
        snprintf(fixed, sizeof fixed, "\"box\": [[-1, -1, -1], [0, 2, 2]]");
        snprintf(load, sizeof load, "\"box\": [[2, -1, -1], [3, 2, 2]]");
        snprintf(mat, sizeof mat, "\"box\": [[1, -1, -1], [3, 2, 2]]");
    }
    snprintf(text, sizeof text,
             "{\"method\": %s, \"material\": {\"E\": 1e5, \"nu\": 0.3, \"density\": 100},"
             " \"materials\": [{%s, \"E\": 4e5}], \"fixed\": [{%s}],"
             " \"loads\": [{%s, \"traction\": [0, 0, -200]}], \"ground\": false,"
             " \"time\": {\"dt\": 0.02, \"frames\": 3, \"substeps\": 2}}",
             method, mat, fixed, load);
    return text;
}

/* What pf-sim does with a scene's lists (tools/scene_files.c): read each file, hand it over. */
static void hand_over(pf_region *r, const pf_mesh *m)
{
    if (r->kind != PF_REGION_NODES && r->kind != PF_REGION_ELEMENTS)
        return;
    bool nodes = r->kind == PF_REGION_NODES;
    int32_t *idx = NULL, n = 0;
    pf_error err = {0};
    if (pf_import_index_list(r->file, nodes ? m->n_nodes : m->n_elems, nodes ? "node" : "element",
                             &idx, &n, &err) != PF_OK)
        fail_msg("%s", err.msg);
    assert_int_equal(pf_region_set_list(r, m, idx, n, &err), PF_OK);
    pf_free(idx);
}

/* Nodal displacements [3 n_nodes] after the scene's frames (malloc'd), and the faces selected. */
static double *run_frames(const pf_mesh *m, const char *json, int32_t *fixed, int32_t *loaded)
{
    pf_error err = {0};
    pf_scene sc;
    if (pf_scene_parse(&sc, json, strlen(json), "bar.json", &err) != PF_OK)
        fail_msg("%s", err.msg);
    hand_over(&sc.fixed[0].region, m);
    hand_over(&sc.loads[0].region, m);
    hand_over(&sc.materials[0].region, m);
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    pf_scene_resolve(&sc, lo, hi);
    pf_sim *sim = NULL;
    if (pf_sim_create(&sim, &sc, m, &err) != PF_OK)
        fail_msg("%s", err.msg);
    for (int32_t k = 0; k < sc.frames; ++k)
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    double *u = malloc(3 * (size_t)m->n_nodes * sizeof *u);
    pf_sim_nodal_displacements(sim, u);
    *fixed = pf_sim_get_stats(sim)->fixed_faces;
    *loaded = pf_sim_get_stats(sim)->loaded_faces;
    pf_sim_destroy(&sim);
    pf_scene_release(&sc);
    return u;
}

/* Lists naming what the boxes select give the same selection, hence the same arithmetic in the
 * same order: the frames must agree bit for bit (no tolerance), with DG and CG. */
static void lists_select_like_boxes(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_mesh m = {0};
    make_bar(&m);
    char *clamp = tmp_path("clamp.txt"), *tip = tmp_path("tip.txt"), *right = tmp_path("right.txt");
    write_nodes_at(&m, 0, clamp);
    write_nodes_at(&m, BAR_L, tip);
    write_elements_right(&m, right);
    const char *methods[] = {"\"dg\"", "{\"name\": \"dg\", \"degree\": 2}", "\"cg\""};
    for (size_t k = 0; k < 3; ++k) {
        int32_t fb, lb, fl, ll;
        double *by_box = run_frames(&m, bar_scene(methods[k], false, NULL, NULL, NULL), &fb, &lb);
        double *by_list = run_frames(&m, bar_scene(methods[k], true, clamp, tip, right), &fl, &ll);
        /* 2 x 2 faces at each end; the bar must have moved for the comparison to mean anything */
        assert_int_equal(fb, 4);
        assert_int_equal(lb, 4);
        assert_int_equal(fl, fb);
        assert_int_equal(ll, lb);
        double largest = 0;
        for (int32_t i = 0; i < 3 * m.n_nodes; ++i)
            largest = fmax(largest, fabs(by_box[i]));
        assert_true(largest > 1e-6);
        if (memcmp(by_box, by_list, 3 * (size_t)m.n_nodes * sizeof *by_box) != 0)
            fail_msg("%s: the frames by lists differ from those by boxes", methods[k]);
        free(by_box);
        free(by_list);
    }
    remove(clamp);
    remove(tip);
    remove(right);
    pf_mesh_release(&m);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A node list selects the elements all of whose nodes it names, and an element list the boundary
 * faces of its elements. */
static void list_selections(void **state)
{
    (void)state;
    pf_mesh m = {0};
    make_bar(&m);
    pf_error err = {0};
    pf_region nodes = {.kind = PF_REGION_NODES}, elems = {.kind = PF_REGION_ELEMENTS};
    int32_t *all = malloc((size_t)m.n_nodes * sizeof *all);
    int32_t n = 0;
    for (int32_t i = 0; i < m.n_nodes; ++i)
        if (m.x[3 * i] <= 0.5)
            all[n++] = i;
    assert_int_equal(pf_region_set_list(&nodes, &m, all, n, &err), PF_OK);
    int32_t first = 0;
    assert_int_equal(pf_region_set_list(&elems, &m, &first, 1, &err), PF_OK);
    int32_t faces_of_first = 0, faces_by_nodes = 0;
    for (int32_t f = 0; f < m.n_faces; ++f) {
        bool boundary = m.face_elems[2 * f] < 0 || m.face_elems[2 * f + 1] < 0;
        pf_vec3 c = {0, 0, 0};
        faces_of_first += boundary && pf_region_selects_face(&elems, &m, f, c);
        faces_by_nodes += boundary && pf_region_selects_face(&nodes, &m, f, c);
    }
    /* element 0, a corner hex, has 3 boundary faces; x <= 0.5 holds the end face's 4 and the
     * 2 x 4 side faces of the first layer */
    assert_int_equal(faces_of_first, 3);
    assert_int_equal(faces_by_nodes, 4 + 8);
    /* one out of range is refused and keeps nothing */
    int32_t bad = m.n_nodes;
    pf_region none = {.kind = PF_REGION_NODES};
    assert_int_equal(pf_region_set_list(&none, &m, &bad, 1, &err), PF_ERR_INVALID);
    assert_null(none.listed);
    assert_non_null(strstr(err.msg, "out of range"));
    pf_free(nodes.listed);
    pf_free(elems.listed);
    free(all);
    pf_mesh_release(&m);
}

/* Each malformed list names its file and line. */
static void list_file_errors(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    struct {
        const char *text;
        pf_status status;
        const char *message; /* after "path:" */
    } cases[] = {
        {"0\n1\nabc\n", PF_ERR_FORMAT, ":3: expected node, found 'abc'"},
        {"# x\n3\n45\n", PF_ERR_INVALID, ":3: node 45 out of range: the mesh has 45 nodes"},
        {"-1\n", PF_ERR_INVALID, ":1: node -1 out of range"},
        {"1 2\n", PF_ERR_FORMAT, ":1: unexpected '2' after node"},
        {"1.5\n", PF_ERR_FORMAT, ":1: expected node, found '1.5'"},
        {"99999999999999999999\n", PF_ERR_FORMAT, ":1: node 99999999999999999999 is out of range"},
        {"# only a comment\n\n", PF_ERR_FORMAT, ": no node index in the file"},
        {"", PF_ERR_FORMAT, ":1: empty file"},
    };
    char *path = tmp_path("bad.txt");
    for (size_t k = 0; k < sizeof cases / sizeof *cases; ++k) {
        write_text(path, cases[k].text);
        int32_t *idx = NULL, n = 0;
        pf_error err = {0};
        assert_int_equal(pf_import_index_list(path, 45, "node", &idx, &n, &err), cases[k].status);
        assert_null(idx);
        char expected[256];
        snprintf(expected, sizeof expected, "%s%s", path, cases[k].message);
        if (!strstr(err.msg, expected))
            fail_msg("case %zu: '%s' does not contain '%s'", k, err.msg, expected);
    }
    remove(path);
    int32_t *idx = NULL, n = 0;
    pf_error err = {0};
    assert_int_equal(pf_import_index_list(path, 45, "node", &idx, &n, &err), PF_ERR_IO);
    assert_non_null(strstr(err.msg, path));
    /* comments, blanks, repeats and CRLF line ends are fine */
    write_text(path, "# clamp\r\n\r\n7\r\n  3 # corner\r\n7\r\n");
    assert_int_equal(pf_import_index_list(path, 45, "node", &idx, &n, &err), PF_OK);
    assert_int_equal(n, 3);
    assert_int_equal(idx[0], 7);
    assert_int_equal(idx[1], 3);
    assert_int_equal(idx[2], 7);
    pf_free(idx);
    remove(path);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* The scene reader's rules for the new keys, the simulator's checks, and the written scene. */
static void scene_list_keys(void **state)
{
    (void)state;
    size_t live = pf_alloc_live_bytes();
    pf_error err = {0};
    pf_scene sc;
    struct {
        const char *json, *message;
    } bad[] = {
        {"{\"fixed\": [{\"nodes_file\": \"\"}]}",
         "s.json: fixed[0].nodes_file: must be a non-empty file name"},
        {"{\"fixed\": [{\"nodes_file\": 3}]}", "fixed[0].nodes_file: must be a non-empty file name"},
        {"{\"loads\": [{\"nodes_file\": \"a\", \"box\": [[0,0,0],[1,1,1]], \"traction\": [0,0,1]}]}",
         "loads[0]: give one region"},
        {"{\"materials\": [{\"elements_file\": \"a\", \"nodes_file\": \"b\"}]}",
         "materials[0]: give one region"},
        {"{\"materials\": [{\"plane\": {\"point\": [0,0,0], \"normal\": [1,0,0]}}]}",
         "materials[0].plane: unknown key"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof *bad; ++k) {
        assert_int_equal(pf_scene_parse(&sc, bad[k].json, strlen(bad[k].json), "s.json", &err),
                         PF_ERR_INVALID);
        if (!strstr(err.msg, bad[k].message))
            fail_msg("'%s': '%s' does not contain '%s'", bad[k].json, err.msg, bad[k].message);
        pf_scene_release(&sc);
    }
    /* a relative file is relative to the scene file's directory, and is written back resolved */
    const char *json = "{\"fixed\": [{\"nodes_file\": \"clamp.txt\"}],"
                       " \"materials\": [{\"elements_file\": \"/abs/soft.txt\", \"E\": 7}]}";
    assert_int_equal(pf_scene_parse(&sc, json, strlen(json), "dir/s.json", &err), PF_OK);
    assert_int_equal(sc.fixed[0].region.kind, PF_REGION_NODES);
    assert_string_equal(sc.fixed[0].region.file, "dir/clamp.txt");
    assert_int_equal(sc.materials[0].region.kind, PF_REGION_ELEMENTS);
    assert_string_equal(sc.materials[0].region.file, "/abs/soft.txt");
    char *text = NULL;
    assert_int_equal(pf_scene_to_json(&sc, &text, &err), PF_OK);
    assert_non_null(strstr(text, "\"nodes_file\":\t\"dir/clamp.txt\""));
    pf_scene back;
    assert_int_equal(pf_scene_parse(&back, text, strlen(text), "SCEN", &err), PF_OK);
    assert_string_equal(back.fixed[0].region.file, "dir/clamp.txt");
    assert_string_equal(back.materials[0].region.file, "/abs/soft.txt");
    pf_scene_release(&back);
    pf_free(text);

    /* not handed over, handed over for another mesh, or in a scene that changes its mesh */
    pf_mesh m = {0};
    make_bar(&m);
    pf_sim *sim = NULL;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "fixed[0].nodes_file: dir/clamp.txt: the list was not handed"));
    int32_t zero = 0;
    assert_int_equal(pf_region_set_list(&sc.fixed[0].region, &m, &zero, 1, &err), PF_OK);
    assert_int_equal(pf_region_set_list(&sc.materials[0].region, &m, &zero, 1, &err), PF_OK);
    m.id = 5;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "the list numbers mesh 0, not mesh 5"));
    m.id = 0;
    sc.refine.enabled = true; /* a mesh that changes takes its lists along (sim_lists.sh) */
    sc.refine.threshold = 1;
    assert_int_equal(pf_sim_create(&sim, &sc, &m, &err), PF_OK);
    for (int k = 0; k < 2; ++k) /* the lists' copies on each new mesh are freed with it */
        assert_int_equal(pf_sim_frame(sim, &err), PF_OK);
    assert_true(pf_sim_get_stats(sim)->refinements >= 1);
    pf_sim_destroy(&sim);
    pf_mesh_release(&m);
    pf_scene_release(&sc);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lists_select_like_boxes),
        cmocka_unit_test(list_selections),
        cmocka_unit_test(list_file_errors),
        cmocka_unit_test(scene_list_keys),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
