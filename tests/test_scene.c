/* scene: the JSON reader (every key, every error class with its exact message), defaults,
 * completion against a bounding box, region tests, and the examples of docs/scene.md.
 *
 * Numbers read from JSON are compared exactly: the reader and the C compiler both convert a
 * decimal literal to the nearest double, so "0.0333" in the text and 0.0333 in this file are the
 * same double. Every test checks that the live pf allocation count returns to its start. */
#define _POSIX_C_SOURCE 200809L /* mkstemp */
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

#include <pf/basis.h>
#include <pf/sim.h>

static const char example[] =
    "{\n"
    "  \"material\": {\"E\": 100000, \"nu\": 0.3, \"density\": 1},\n"
    "  \"method\": {\"name\": \"dg\", \"degree\": 2, \"flux\": \"ip\", \"penalty\": 0, "
    "\"corotation\": true},\n"
    "  \"gravity\": [0, 0, 0],\n"
    "  \"body_force\": [0, 0, 0],\n"
    "  \"damping\": {\"alpha\": 0, \"beta\": 0.01},\n"
    "  \"fixed\": [{\"box\": [[-0.001, -1, -1], [0.001, 2, 2]]},\n"
    "            {\"plane\": {\"point\": [0,0,0], \"normal\": [1,0,0], \"tol\": 1e-6}, "
    "\"displacement\": [0, 0, 0.1]}],\n"
    "  \"loads\": [{\"box\": [[3.999, -1, -1], [4.001, 2, 2]], \"traction\": [0, 0, -1]}],\n"
    "  \"ground\": {\"point\": [0, 0, -1], \"normal\": [0, 0, 1], \"stiffness\": 0},\n"
    "  \"time\": {\"dt\": 0.0333, \"frames\": 60, \"substeps\": 10},\n"
    "  \"static\": true\n"
    "}\n";

static void assert_vec3(pf_vec3 v, double x, double y, double z)
{
    assert_true(v.x == x);
    assert_true(v.y == y);
    assert_true(v.z == z);
}

/* Parses text (as a NUL-terminated string) under the name scene.json. */
static pf_status parse(pf_scene *s, const char *text, pf_error *err)
{
    return pf_scene_parse(s, text, strlen(text), "scene.json", err);
}

/* ---- the example and the defaults ------------------------------------------------------------ */

static void test_example_parses_field_by_field(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_scene s;
    pf_error err = {0};
    assert_int_equal(parse(&s, example, &err), PF_OK);

    assert_true(s.E == 100000);
    assert_true(s.nu == 0.3);
    assert_true(s.density == 1);
    assert_int_equal(s.method, PF_METHOD_DG);
    assert_int_equal(s.degree, 2);
    assert_int_equal(s.flux, PF_FLUX_IP);
    assert_true(s.penalty == 0);
    assert_true(s.corotation);
    assert_vec3(s.gravity, 0, 0, 0);
    assert_vec3(s.body_force, 0, 0, 0);
    assert_true(s.damping_alpha == 0);
    assert_true(s.damping_beta == 0.01);

    assert_int_equal(s.n_fixed, 2);
    assert_int_equal(s.fixed[0].region.kind, PF_REGION_BOX);
    assert_vec3(s.fixed[0].region.lo, -0.001, -1, -1);
    assert_vec3(s.fixed[0].region.hi, 0.001, 2, 2);
    assert_vec3(s.fixed[0].displacement, 0, 0, 0);
    assert_int_equal(s.fixed[1].region.kind, PF_REGION_PLANE);
    assert_vec3(s.fixed[1].region.plane.n, 1, 0, 0);
    assert_true(s.fixed[1].region.plane.d == 0);
    assert_true(s.fixed[1].region.tol == 1e-6);
    assert_vec3(s.fixed[1].displacement, 0, 0, 0.1);

    assert_int_equal(s.n_loads, 1);
    assert_int_equal(s.loads[0].region.kind, PF_REGION_BOX);
    assert_vec3(s.loads[0].region.lo, 3.999, -1, -1);
    assert_vec3(s.loads[0].region.hi, 4.001, 2, 2);
    assert_vec3(s.loads[0].traction, 0, 0, -1);

    /* "ground" given in a static scene: kept, at the given point */
    assert_true(s.ground);
    assert_true(s.ground_given);
    assert_false(s.ground_auto);
    assert_vec3(s.ground_point, 0, 0, -1);
    assert_vec3(s.ground_normal, 0, 0, 1);
    assert_true(s.ground_stiffness == 0);

    assert_true(s.dt == 0.0333);
    assert_int_equal(s.frames, 60);
    assert_int_equal(s.substeps, 10);
    assert_true(s.is_static);

    assert_non_null(s.json);
    assert_string_equal(s.json, example);
    pf_scene_release(&s);
    assert_null(s.json);
    assert_null(s.fixed);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void assert_defaults(const pf_scene *s)
{
    assert_true(s->E == 1e5);
    assert_true(s->nu == 0.3);
    assert_true(s->density == 1000);
    assert_int_equal(s->method, PF_METHOD_DG);
    assert_int_equal(s->degree, 1);
    assert_int_equal(s->flux, PF_FLUX_IP);
    assert_true(s->penalty == 0);
    assert_true(s->corotation);
    assert_vec3(s->gravity, 0, 0, -9.81);
    assert_vec3(s->body_force, 0, 0, 0);
    assert_int_equal(s->n_fixed, 0);
    assert_int_equal(s->n_loads, 0);
    assert_true(s->damping_alpha == 0);
    assert_true(s->damping_beta == 0.01);
    assert_true(s->ground);
    assert_false(s->ground_given);
    assert_true(s->ground_auto);
    assert_vec3(s->ground_normal, 0, 0, 1);
    assert_true(s->ground_stiffness == 0);
    assert_false(s->is_static);
    assert_true(s->dt == 1.0 / 30.0);
    assert_int_equal(s->frames, 60);
    assert_int_equal(s->substeps, 10);
}

static void test_defaults_without_file_and_for_empty_object(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_scene s;
    pf_scene_default(&s);
    assert_defaults(&s);
    assert_null(s.json);
    assert_null(s.fixed);
    assert_null(s.loads);
    pf_scene_release(&s);

    pf_error err = {0};
    assert_int_equal(parse(&s, " { } ", &err), PF_OK);
    assert_defaults(&s);
    assert_string_equal(s.json, " { } ");
    pf_scene_release(&s);

    /* empty arrays: no regions */
    assert_int_equal(parse(&s, "{\"fixed\": [], \"loads\": []}", &err), PF_OK);
    assert_int_equal(s.n_fixed, 0);
    assert_int_equal(s.n_loads, 0);
    pf_scene_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- the alternative forms ------------------------------------------------------------------- */

static void test_method_string_and_corotation_at_top_level(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_scene s;
    pf_error err = {0};
    assert_int_equal(parse(&s, "{\"method\": \"cg\", \"corotation\": false}", &err), PF_OK);
    assert_int_equal(s.method, PF_METHOD_CG);
    assert_false(s.corotation);
    pf_scene_release(&s);

    /* escapes are decoded: \u0063\u0067 is "cg"; a surrogate pair is valid in a string */
    assert_int_equal(parse(&s, "{\"method\": \"\\u0063\\u0067\"}", &err), PF_OK);
    assert_int_equal(s.method, PF_METHOD_CG);
    pf_scene_release(&s);
    assert_int_equal(parse(&s, "{\"method\": \"\\ud83d\\ude00\"}", &err), PF_ERR_INVALID);
    assert_string_equal(err.msg, "scene.json: method: must be \"dg\" or \"cg\", got string "
                                 "\"\xF0\x9F\x98\x80\"");
    pf_scene_release(&s);

    assert_int_equal(parse(&s, "{\"method\": {\"flux\": \"bz\", \"penalty\": 8}}", &err), PF_OK);
    assert_int_equal(s.method, PF_METHOD_DG);
    assert_int_equal(s.flux, PF_FLUX_BZ);
    assert_true(s.penalty == 8);
    pf_scene_release(&s);

    /* given twice is ambiguous even when the values agree */
    assert_int_equal(parse(&s, "{\"corotation\": true, \"method\": {\"corotation\": true}}", &err),
                     PF_ERR_INVALID);
    assert_string_equal(err.msg, "scene.json: method.corotation: corotation is given both at the "
                                 "top level and in method: give it once");
    pf_scene_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_ground_forms_and_static_rule(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_scene s;
    pf_error err = {0};

    assert_int_equal(parse(&s, "{\"ground\": false}", &err), PF_OK);
    assert_false(s.ground);
    assert_true(s.ground_given);
    pf_scene_release(&s);

    assert_int_equal(parse(&s, "{\"ground\": true, \"static\": true}", &err), PF_OK);
    assert_true(s.ground);
    assert_true(s.ground_auto);
    pf_scene_release(&s);

    /* an object without a point: automatic placement, normal normalised */
    assert_int_equal(parse(&s, "{\"ground\": {\"normal\": [0, 3, 4], \"stiffness\": 5}}", &err),
                     PF_OK);
    assert_true(s.ground);
    assert_true(s.ground_auto);
    /* 3/5 and 4/5: the norm of (0, 3, 4)/4 is exactly 1.25; 1/1.25 and the products round
     * twice, each within half an ulp (<= 0.56e-16 near 0.6 and 0.8): 3e-16 allows for both */
    assert_true(s.ground_normal.x == 0);
    assert_true(fabs(s.ground_normal.y - 0.6) <= 3e-16 && fabs(s.ground_normal.z - 0.8) <= 3e-16);
    assert_true(s.ground_stiffness == 5);
    pf_scene_release(&s);

    /* static without "ground": no ground */
    assert_int_equal(parse(&s, "{\"static\": true}", &err), PF_OK);
    assert_true(s.is_static);
    assert_false(s.ground);
    pf_scene_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- errors ---------------------------------------------------------------------------------- */

typedef struct bad_case {
    const char *text;
    pf_status status;
    const char *message; /* exact */
} bad_case;

static const bad_case bad_cases[] = {
    /* unknown and duplicate keys, at every depth */
    {"{\"method\": {\"name\": \"dg\", \"fluxx\": \"ip\"}}", PF_ERR_INVALID,
     "scene.json: method.fluxx: unknown key (expected one of: name, degree, flux, penalty, "
     "corotation, mass, edge_samples)"},
    {"{\"gravty\": [0, 0, 0]}", PF_ERR_INVALID,
     "scene.json: gravty: unknown key (expected one of: material, materials, method, corotation, "
     "gravity, "
     "body_force, damping, fixed, loads, ground, obstacles, time, static, solver, refine, cuts)"},
    {"{\"fixed\": [{\"box\": [[0,0,0],[1,1,1]]}, {\"plane\": {\"point\": [0,0,0], "
     "\"normal\": [1,0,0], \"tolerance\": 1}}]}",
     PF_ERR_INVALID,
     "scene.json: fixed[1].plane.tolerance: unknown key (expected one of: point, normal, tol)"},
    {"{\"time\": {\"dt\": 0.1, \"dt\": 0.2}}", PF_ERR_INVALID,
     "scene.json: time.dt: duplicate key"},
    /* ranges */
    {"{\"material\": {\"nu\": 0.5}}", PF_ERR_INVALID,
     "scene.json: material.nu: must be in (-1, 0.5), got 0.5"},
    {"{\"material\": {\"nu\": -1}}", PF_ERR_INVALID,
     "scene.json: material.nu: must be in (-1, 0.5), got -1"},
    {"{\"material\": {\"E\": 0}}", PF_ERR_INVALID, "scene.json: material.E: must be > 0, got 0"},
    {"{\"material\": {\"density\": -2.5}}", PF_ERR_INVALID,
     "scene.json: material.density: must be > 0, got -2.5"},
    {"{\"method\": {\"degree\": 3}}", PF_ERR_INVALID,
     "scene.json: method.degree: must be 1 or 2, got 3"},
    {"{\"method\": {\"degree\": 1.5}}", PF_ERR_INVALID,
     "scene.json: method.degree: must be 1 or 2, got 1.5"},
    {"{\"method\": {\"penalty\": -1}}", PF_ERR_INVALID,
     "scene.json: method.penalty: must be >= 0, got -1"},
    {"{\"damping\": {\"beta\": -0.1}}", PF_ERR_INVALID,
     "scene.json: damping.beta: must be >= 0, got -0.1"},
    {"{\"time\": {\"frames\": -1}}", PF_ERR_INVALID,
     "scene.json: time.frames: must be an integer >= 0, got -1"},
    {"{\"time\": {\"frames\": 3000000000}}", PF_ERR_INVALID,
     "scene.json: time.frames: must be an integer >= 0, got 3000000000"},
    {"{\"time\": {\"substeps\": 0}}", PF_ERR_INVALID,
     "scene.json: time.substeps: must be an integer >= 1, got 0"},
    {"{\"time\": {\"dt\": 0}}", PF_ERR_INVALID, "scene.json: time.dt: must be > 0, got 0"},
    {"{\"ground\": {\"stiffness\": -1}}", PF_ERR_INVALID,
     "scene.json: ground.stiffness: must be >= 0, got -1"},
    {"{\"fixed\": [{\"plane\": {\"point\": [0,0,0], \"normal\": [1,0,0], \"tol\": -1}}]}",
     PF_ERR_INVALID, "scene.json: fixed[0].plane.tol: must be >= 0, got -1"},
    /* non-finite numbers */
    {"{\"material\": {\"E\": 1e999}}", PF_ERR_INVALID,
     "scene.json: material.E: must be finite (the number overflows a double)"},
    {"{\"gravity\": [0, -1e400, 0]}", PF_ERR_INVALID,
     "scene.json: gravity[1]: must be finite (the number overflows a double)"},
    /* types */
    {"{\"material\": {\"E\": \"1e5\"}}", PF_ERR_INVALID,
     "scene.json: material.E: must be a number, got string \"1e5\""},
    {"{\"time\": {\"frames\": null}}", PF_ERR_INVALID,
     "scene.json: time.frames: must be an integer, got null"},
    {"{\"material\": [1]}", PF_ERR_INVALID,
     "scene.json: material: must be an object, got an array of 1"},
    {"{\"method\": \"fem\"}", PF_ERR_INVALID,
     "scene.json: method: must be \"dg\" or \"cg\", got string \"fem\""},
    {"{\"method\": 2}", PF_ERR_INVALID,
     "scene.json: method: must be \"dg\", \"cg\" or an object, got 2"},
    {"{\"method\": {\"flux\": \"sip\"}}", PF_ERR_INVALID,
     "scene.json: method.flux: must be \"ip\" or \"bz\", got string \"sip\""},
    {"{\"static\": 1}", PF_ERR_INVALID, "scene.json: static: must be true or false, got 1"},
    {"{\"ground\": \"yes\"}", PF_ERR_INVALID,
     "scene.json: ground: must be true, false or an object, got string \"yes\""},
    {"{\"gravity\": [0, 0]}", PF_ERR_INVALID,
     "scene.json: gravity: must be an array of 3 numbers, got an array of 2"},
    {"{\"body_force\": [0, \"a\", 0]}", PF_ERR_INVALID,
     "scene.json: body_force[1]: must be a number, got string \"a\""},
    {"{\"fixed\": {\"box\": [[0,0,0],[1,1,1]]}}", PF_ERR_INVALID,
     "scene.json: fixed: must be an array, got an object"},
    {"[]", PF_ERR_INVALID, "scene.json: the scene must be a JSON object, got an array of 0"},
    /* regions */
    {"{\"fixed\": [{\"box\": [[0, 2, 0], [1, 1, 1]]}]}", PF_ERR_INVALID,
     "scene.json: fixed[0].box: lower corner above upper corner along y (2 > 1)"},
    {"{\"fixed\": [{\"box\": [[0, 0, 0]]}]}", PF_ERR_INVALID,
     "scene.json: fixed[0].box: must be [[xlo, ylo, zlo], [xhi, yhi, zhi]], got an array of 1"},
    {"{\"fixed\": [{\"box\": [[0, 0, 0], [1, 1]]}]}", PF_ERR_INVALID,
     "scene.json: fixed[0].box[1]: must be an array of 3 numbers, got an array of 2"},
    {"{\"loads\": [{\"plane\": {\"point\": [0,0,0], \"normal\": [0,0,0]}, \"traction\": [1,0,0]}]}",
     PF_ERR_INVALID, "scene.json: loads[0].plane.normal: must be a non-zero vector"},
    {"{\"ground\": {\"normal\": [0, 0, 0]}}", PF_ERR_INVALID,
     "scene.json: ground.normal: must be a non-zero vector"},
    {"{\"loads\": [{\"plane\": {\"normal\": [0,0,1]}, \"traction\": [1,0,0]}]}", PF_ERR_INVALID,
     "scene.json: loads[0].plane: missing key \"point\""},
    {"{\"loads\": [{\"box\": [[0,0,0],[1,1,1]]}]}", PF_ERR_INVALID,
     "scene.json: loads[0]: missing key \"traction\""},
    {"{\"fixed\": [{\"displacement\": [0,0,1]}]}", PF_ERR_INVALID,
     "scene.json: fixed[0]: missing region: give \"box\", \"plane\", \"group\", "
     "\"nodes_file\" or \"elements_file\""},
    {"{\"fixed\": [{\"box\": [[0,0,0],[1,1,1]], \"plane\": {\"point\": [0,0,0], "
     "\"normal\": [1,0,0]}}]}",
     PF_ERR_INVALID,
     "scene.json: fixed[0]: give one region, \"box\", \"plane\", \"group\", \"nodes_file\" or "
     "\"elements_file\", not several"},
    {"{\"loads\": [{\"box\": [[0,0,0],[1,1,1]], \"traction\": [1,0,0], "
     "\"displacement\": [0,0,0]}]}",
     PF_ERR_INVALID,
     "scene.json: loads[0].displacement: unknown key (expected one of: box, plane, group, nodes_file, elements_file, "
     "traction)"},
    /* syntax: line:col where the parser stopped (columns count characters) */
    {"{\n  \"material\": {\"E\": 1}\n  \"static\": true\n}", PF_ERR_FORMAT,
     "scene.json:3:3: JSON syntax error near '\"static\": true'"},
    {"{\"static\": tru}", PF_ERR_FORMAT, "scene.json:1:12: JSON syntax error near 'tru}'"},
    {"{} x", PF_ERR_FORMAT, "scene.json:1:4: JSON syntax error near 'x'"},
    {"{\n\"\xC3\xA9\": x}", PF_ERR_FORMAT, "scene.json:2:6: JSON syntax error near 'x}'"},
    {"{\"gravity\": [0, 0,, 1]}", PF_ERR_FORMAT, "scene.json:1:19: JSON syntax error near ', 1]}'"},
    {"{\"time\": {\"dt\": 1}", PF_ERR_FORMAT, "scene.json:1:19: JSON syntax error at end of text"},
    {"  \n ", PF_ERR_FORMAT,
     "scene.json:2:2: JSON syntax error: no JSON value (the empty scene is {})"},
    {"{\"a very long key that goes on and on\" 1}", PF_ERR_FORMAT,
     "scene.json:1:40: JSON syntax error near '1}'"},
    {"{\"static\": true,\n\"ground\": falsehood}", PF_ERR_FORMAT,
     "scene.json:2:11: JSON syntax error near 'falsehood}'"},
    {"{\"fixed\": [{\"box\": [[0,0,0],[1,1,1]]},]}", PF_ERR_FORMAT,
     "scene.json:1:39: JSON syntax error near ']}'"},
    {"{\"time\": {\"dt\": 1,}}", PF_ERR_FORMAT, "scene.json:1:19: JSON syntax error near '}}'"},
    {"{\"time\": {\"dt\": 1.2.3}}", PF_ERR_FORMAT,
     "scene.json:1:17: JSON syntax error near '1.2.3}}'"},
    {"{\"time\": {\"dt\": -}}", PF_ERR_FORMAT, "scene.json:1:17: JSON syntax error near '-}}'"},
    {"{\"time\": {\"dt\": 1}}}", PF_ERR_FORMAT, "scene.json:1:20: JSON syntax error near '}'"},
    {"{\"method\": \"dg}", PF_ERR_FORMAT, "scene.json:1:12: unterminated string near '\"dg}'"},
    {"{\"method\": \"d\\g\"}", PF_ERR_FORMAT,
     "scene.json:1:14: bad escape in a string near '\\g\"}'"},
    {"{\"method\": \"\\u00zz\"}", PF_ERR_FORMAT,
     "scene.json:1:13: bad \\u escape in a string near '\\u00zz\"}'"},
    {"{\"time\": {\"d\\u0000t\": 1}}", PF_ERR_FORMAT,
     "scene.json:1:13: \\u0000 in a string near '\\u0000t\": 1}}'"},
    /* strict numbers and strings, where cJSON alone is lax */
    {"{\"time\": {\"dt\": -.5}}", PF_ERR_FORMAT, "scene.json:1:17: JSON syntax error near '-.5}}'"},
    {"{\"time\": {\"dt\": 01}}", PF_ERR_FORMAT, "scene.json:1:17: JSON syntax error near '01}}'"},
    {"{\"time\": {\"dt\": 1.}}", PF_ERR_FORMAT, "scene.json:1:17: JSON syntax error near '1.}}'"},
    {"{\"time\": {\"dt\": 1e}}", PF_ERR_FORMAT, "scene.json:1:17: JSON syntax error near '1e}}'"},
    {"{\"method\": \"d\tg\"}", PF_ERR_FORMAT,
     "scene.json:1:14: control character in a string (write it as an escape) near ' g\"}'"},
    {"{\"method\": \"\\udc00\"}", PF_ERR_FORMAT,
     "scene.json:1:13: unpaired UTF-16 surrogate in a string near '\\udc00\"}'"},
    {"{\"method\": \"\\ud800x\"}", PF_ERR_FORMAT,
     "scene.json:1:13: unpaired UTF-16 surrogate in a string near '\\ud800x\"}'"},
    {"{\"time\": {\"dt\": 1} \"frames\": 2}", PF_ERR_FORMAT,
     "scene.json:1:20: JSON syntax error near '\"frames\": 2}'"},
};

static void test_every_error_names_the_path_or_position(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; ++i) {
        pf_scene s;
        pf_error err = {0};
        pf_status st = parse(&s, bad_cases[i].text, &err);
        if (st != bad_cases[i].status || strcmp(err.msg, bad_cases[i].message) != 0)
            fail_msg("case %zu: %s\n  status %d, expected %d\n  got      %s\n  expected %s", i,
                     bad_cases[i].text, st, bad_cases[i].status, err.msg, bad_cases[i].message);
        assert_int_equal(err.status, st);
        /* the text is kept for the caller even when it is rejected */
        assert_string_equal(s.json, bad_cases[i].text);
        pf_scene_release(&s);
    }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_nul_byte_and_unterminated_buffer(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_scene s;
    pf_error err = {0};
    assert_int_equal(pf_scene_parse(&s, "{\n \0}", 4, "scene.json", &err), PF_ERR_FORMAT);
    assert_string_equal(err.msg, "scene.json:2:2: NUL byte in the text");
    pf_scene_release(&s);

    /* len, not a terminator, delimits the text: the bytes after it are not read */
    const char buf[] = {'{', '}', 'x', 'y'};
    assert_int_equal(pf_scene_parse(&s, buf, 2, "scene.json", &err), PF_OK);
    assert_string_equal(s.json, "{}");
    pf_scene_release(&s);

    /* a byte-order mark is skipped */
    assert_int_equal(parse(&s, "\xEF\xBB\xBF{\"frames\": 1}", &err), PF_ERR_INVALID);
    assert_string_equal(
        err.msg, "scene.json: frames: unknown key (expected one of: material, "
                 "materials, method, corotation, gravity, body_force, damping, fixed, loads, "
                 "ground, obstacles, time, static, solver, refine, cuts)");
    pf_scene_release(&s);
    assert_int_equal(parse(&s, "\xEF\xBB\xBF{\"time\": {\"frames\": 1}}", &err), PF_OK);
    assert_int_equal(s.frames, 1);
    pf_scene_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Nesting is limited to 1000 levels (cJSON's limit; recursion depth stays bounded). */
static void test_nesting_limit(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    char text[2 * 1001 + 1];
    for (int levels = 1000; levels <= 1001; ++levels) {
        memset(text, '[', (size_t)levels);
        memset(text + levels, ']', (size_t)levels);
        text[2 * levels] = '\0';
        pf_scene s;
        pf_error err = {0};
        pf_status st = parse(&s, text, &err);
        if (levels == 1000) {
            assert_int_equal(st, PF_ERR_INVALID);
            assert_string_equal(err.msg, "scene.json: the scene must be a JSON object, got an "
                                         "array of 1");
        } else {
            assert_int_equal(st, PF_ERR_FORMAT);
            assert_string_equal(err.msg, "scene.json:1:1001: JSON nested too deeply near "
                                         "'[]]]]]]]]]]]]]]]]]]]'");
        }
        pf_scene_release(&s);
    }
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- files ----------------------------------------------------------------------------------- */

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, strlen(text), f), strlen(text));
    assert_int_equal(fclose(f), 0);
}

/* A scene file as pf-sim reads it: the text whole (pf_buffer_read_file), parsed under the file's
 * name. The scene holds the defaults when the file cannot be read. */
static pf_status load(pf_scene *s, const char *path, pf_error *err)
{
    memset(s, 0, sizeof *s);
    pf_scene_default(s);
    pf_buffer text = {0};
    pf_status st = pf_buffer_read_file(&text, path, PF_SCENE_MAX_BYTES, err);
    if (st == PF_OK)
        st = pf_scene_parse(s, (const char *)text.data, text.size, path, err);
    pf_buffer_release(&text);
    return st;
}

static void test_messages_name_the_file(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    char path[] = "pf_scene_test_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    pf_scene s;
    pf_error err = {0};

    write_file(path, example);
    assert_int_equal(load(&s, path, &err), PF_OK);
    assert_string_equal(s.json, example);
    assert_int_equal(s.degree, 2);
    pf_scene_release(&s);

    write_file(path, "{\"time\": {\"substeps\": 0.5}}");
    assert_int_equal(load(&s, path, &err), PF_ERR_INVALID);
    char expected[256];
    snprintf(expected, sizeof expected, "%s: time.substeps: must be an integer >= 1, got 0.5",
             path);
    assert_string_equal(err.msg, expected);
    pf_scene_release(&s);

    write_file(path, "{\n\n   ]");
    assert_int_equal(load(&s, path, &err), PF_ERR_FORMAT);
    snprintf(expected, sizeof expected, "%s:3:4: JSON syntax error near ']'", path);
    assert_string_equal(err.msg, expected);
    pf_scene_release(&s);

    assert_int_equal(remove(path), 0);
    assert_int_equal(load(&s, path, &err), PF_ERR_IO);
    snprintf(expected, sizeof expected, "%s: cannot open: ", path);
    assert_memory_equal(err.msg, expected, strlen(expected));
    assert_null(s.json);
    pf_scene_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Every ```json block of docs/scene.md parses: the reference cannot drift from the reader. */
static void test_documentation_examples_parse(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    FILE *f = fopen(PF_TEST_DATA_DIR "/../../docs/scene.md", "rb");
    assert_non_null(f);
    static char doc[1 << 16];
    size_t n = fread(doc, 1, sizeof doc - 1, f);
    fclose(f);
    assert_true(n > 0 && n < sizeof doc - 1);
    doc[n] = '\0';
    int blocks = 0;
    bool example_found = false;
    for (char *p = strstr(doc, "```json\n"); p; p = strstr(p, "```json\n")) {
        p += strlen("```json\n");
        char *end = strstr(p, "```");
        assert_non_null(end);
        pf_scene s;
        pf_error err = {0};
        pf_status st = pf_scene_parse(&s, p, (size_t)(end - p), "scene.md", &err);
        if (st != PF_OK)
            fail_msg("docs/scene.md block %d: %s", blocks, err.msg);
        /* the task's reference example appears verbatim in the documentation */
        example_found |=
            (size_t)(end - p) == strlen(example) && !memcmp(p, example, strlen(example));
        pf_scene_release(&s);
        ++blocks;
        p = end + 3;
    }
    assert_true(blocks >= 5);
    assert_true(example_found);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* Hostile input: 20000 deterministic mutations of the example (bytes replaced by structural
 * characters, digits, quotes, backslashes, high bytes; bytes deleted or duplicated). Each parse
 * must end in OK, a format error with "scene.json:LINE:COL: " or an invalid-input error with
 * "scene.json: ", and free everything (ASan and LeakSanitizer check the rest in the sanitizer
 * build). */
static void test_mutated_scenes_fail_cleanly(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    static const char alphabet[] = "{}[]:,\"\\0123456789.-eE tfn\n\x01\xC3\xFF";
    size_t len = strlen(example);
    char text[sizeof example + 8];
    uint64_t seed = 88172645463325252ull;
    int counts[3] = {0, 0, 0};
    for (int trial = 0; trial < 20000; ++trial) {
        memcpy(text, example, len + 1);
        size_t n = len;
        int edits = 1 + trial % 3;
        for (int e = 0; e < edits; ++e) {
            seed ^= seed << 13, seed ^= seed >> 7, seed ^= seed << 17; /* xorshift64 */
            size_t at = (size_t)(seed % n);
            int kind = (int)((seed >> 32) % 3);
            if (kind == 0) {
                text[at] = alphabet[(seed >> 40) % (sizeof alphabet - 1)];
            } else if (kind == 1 && n > 1) {
                memmove(text + at, text + at + 1, n - at);
                --n;
            } else if (n < sizeof text - 1) {
                memmove(text + at + 1, text + at, n - at + 1);
                ++n;
            }
        }
        pf_scene s;
        pf_error err = {0};
        pf_status st = pf_scene_parse(&s, text, n, "scene.json", &err);
        if (st == PF_OK) {
            ++counts[0];
        } else if (st == PF_ERR_FORMAT) {
            long line, col;
            char colon;
            if (sscanf(err.msg, "scene.json:%ld:%ld%c", &line, &col, &colon) != 3 || colon != ':' ||
                line < 1 || col < 1)
                fail_msg("trial %d: format error without a position: %s", trial, err.msg);
            ++counts[1];
        } else {
            if (st != PF_ERR_INVALID || strncmp(err.msg, "scene.json: ", 12) != 0)
                fail_msg("trial %d: status %d: %s", trial, st, err.msg);
            ++counts[2];
        }
        assert_memory_equal(s.json, text, n);
        pf_scene_release(&s);
    }
    /* every outcome occurs: the mutations reach the semantic checks, not only the syntax */
    assert_true(counts[0] > 0 && counts[1] > 0 && counts[2] > 0);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* ---- resolve and regions --------------------------------------------------------------------- */

static void test_resolve_places_the_ground_and_tolerances(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_scene s;
    pf_error err = {0};
    const char *text = "{\"fixed\": [{\"plane\": {\"point\": [0,0,0], \"normal\": [0,0,2]}},"
                       "           {\"plane\": {\"point\": [0,0,1], \"normal\": [0,0,1], "
                       "\"tol\": 0.125}}],"
                       " \"loads\": [{\"plane\": {\"point\": [0,0,4], \"normal\": [0,0,-1]}, "
                       "\"traction\": [0,0,1]}]}";
    assert_int_equal(parse(&s, text, &err), PF_OK);
    assert_true(s.fixed[0].region.tol == -1);
    assert_true(s.loads[0].region.tol == -1);
    /* unresolved tolerance selects nothing, not everything */
    assert_false(pf_region_contains(&s.fixed[0].region, pf_v3(0, 0, 0)));

    /* box [0,2]x[0,1]x[0,4], ground normal +z: lowest corner at z = 0, extent 4, so the plane is
     * at z = -0.05 * 4 = -0.2; 0.05 * 4 is an exact scaling by 4, hence equality. */
    pf_scene_resolve(&s, pf_v3(0, 0, 0), pf_v3(2, 1, 4));
    assert_true(s.ground_auto);
    assert_vec3(s.ground_point, 0, 0, -0.2);
    /* 1e-6 x the diagonal sqrt(4 + 1 + 16), one rounding each for sqrt and product */
    double tol = 1e-6 * sqrt(21.0);
    assert_true(fabs(s.fixed[0].region.tol - tol) <= 1e-15 * tol);
    assert_true(fabs(s.loads[0].region.tol - tol) <= 1e-15 * tol);
    assert_true(s.fixed[1].region.tol == 0.125);

    /* a new mesh moves the automatic ground, not the tolerances already set */
    pf_scene_resolve(&s, pf_v3(0, 0, 10), pf_v3(1, 1, 12));
    assert_vec3(s.ground_point, 0, 0, 10 - 0.05 * 2);
    assert_true(fabs(s.fixed[0].region.tol - tol) <= 1e-15 * tol);
    pf_scene_release(&s);

    /* tilted normal n = (1, 1, 0)/sqrt 2 on the box [-1,1]x[-1,3]x[0,1]: dot(n, corner) ranges over
     * [-2, 4]/sqrt 2, so s = -sqrt 2, ext = 3 sqrt 2 and the point is (s - 0.15 sqrt 2) n =
     * -1.15 sqrt 2 n = (-1.15, -1.15, 0); a few roundings of O(1) terms: 1e-15. */
    assert_int_equal(parse(&s, "{\"ground\": {\"normal\": [1, 1, 0]}}", &err), PF_OK);
    pf_scene_resolve(&s, pf_v3(-1, -1, 0), pf_v3(1, 3, 1));
    assert_true(fabs(s.ground_point.x + 1.15) <= 1e-15);
    assert_true(fabs(s.ground_point.y + 1.15) <= 1e-15);
    assert_true(s.ground_point.z == 0);
    pf_scene_release(&s);

    /* a given point is kept */
    assert_int_equal(parse(&s, "{\"ground\": {\"point\": [0, 0, -7]}}", &err), PF_OK);
    pf_scene_resolve(&s, pf_v3(0, 0, 0), pf_v3(1, 1, 1));
    assert_vec3(s.ground_point, 0, 0, -7);
    pf_scene_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

static void test_region_contains(void **state)
{
    (void)state;
    pf_region box = {.kind = PF_REGION_BOX, .lo = {-1, 0, 2}, .hi = {1, 0.5, 3}};
    /* bounds inclusive: every corner and face point is inside */
    assert_true(pf_region_contains(&box, pf_v3(-1, 0, 2)));
    assert_true(pf_region_contains(&box, pf_v3(1, 0.5, 3)));
    assert_true(pf_region_contains(&box, pf_v3(0, 0.25, 2.5)));
    /* one ulp outside along each axis */
    assert_false(pf_region_contains(&box, pf_v3(nextafter(1, 2), 0.25, 2.5)));
    assert_false(pf_region_contains(&box, pf_v3(0, nextafter(0, -1), 2.5)));
    assert_false(pf_region_contains(&box, pf_v3(0, 0.25, nextafter(3, 4))));
    /* a degenerate (flat) box is allowed and selects its plane */
    pf_region flat = {.kind = PF_REGION_BOX, .lo = {0, 0, 0}, .hi = {0, 1, 1}};
    assert_true(pf_region_contains(&flat, pf_v3(0, 0.5, 0.5)));

    /* plane x = 1 with tol 0.25 (binary fractions: distances below are exact) */
    pf_region plane = {.kind = PF_REGION_PLANE,
                       .plane = pf_plane_from_point_normal(pf_v3(1, 5, 5), pf_v3(2, 0, 0)),
                       .tol = 0.25};
    assert_true(pf_region_contains(&plane, pf_v3(1, -3, 8)));
    assert_true(pf_region_contains(&plane, pf_v3(1.25, 0, 0)));
    assert_true(pf_region_contains(&plane, pf_v3(0.75, 0, 0)));
    assert_false(pf_region_contains(&plane, pf_v3(nextafter(1.25, 2), 0, 0)));
    assert_false(pf_region_contains(&plane, pf_v3(nextafter(0.75, 0), 0, 0)));
}

/* ---- keys of the cg method ------------------------------------------------------------------- */

static void mass_key_is_parsed(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_scene s;
    pf_error err = {0};
    static const char good[] = "{\"method\": {\"name\": \"cg\", \"mass\": \"lumped\"}}";
    assert_int_equal(pf_scene_parse(&s, good, sizeof good - 1, "scene.json", &err), PF_OK);
    assert_true(s.method == PF_METHOD_CG && s.mass == PF_MASS_LUMPED);
    char *json = NULL;
    assert_int_equal(pf_scene_to_json(&s, &json, &err), PF_OK);
    pf_scene t;
    assert_int_equal(pf_scene_parse(&t, json, strlen(json), "SCEN", &err), PF_OK);
    assert_true(t.mass == PF_MASS_LUMPED);
    assert_int_equal(pf_scene_override(&t, "mass", "consistent", &err), PF_OK);
    assert_true(t.mass == PF_MASS_CONSISTENT);
    assert_int_equal(pf_scene_override(&t, "mass", "diagonal", &err), PF_ERR_INVALID);
    assert_string_equal(err.msg, "mass: must be consistent or lumped, got 'diagonal'");
    pf_free(json);
    pf_scene_release(&s);
    pf_scene_release(&t);
    static const char bad[] = "{\"method\": {\"name\": \"cg\", \"mass\": 1}}";
    assert_int_equal(pf_scene_parse(&s, bad, sizeof bad - 1, "scene.json", &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "method.mass"));
    pf_scene_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* method.edge_samples: default 2 (pf_basis_params_default), read, written back, overridden,
 * refused outside 1..16 with the key named. */
static void edge_samples_key_is_parsed(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_scene s, t;
    pf_error err = {0};
    static const char none[] = "{\"method\": \"cg\"}";
    assert_int_equal(pf_scene_parse(&s, none, sizeof none - 1, "scene.json", &err), PF_OK);
    assert_int_equal(s.edge_samples, pf_basis_params_default().edge_samples);
    pf_scene_release(&s);
    static const char good[] = "{\"method\": {\"name\": \"cg\", \"edge_samples\": 5}}";
    assert_int_equal(pf_scene_parse(&s, good, sizeof good - 1, "scene.json", &err), PF_OK);
    assert_int_equal(s.edge_samples, 5);
    char *json = NULL;
    assert_int_equal(pf_scene_to_json(&s, &json, &err), PF_OK);
    assert_int_equal(pf_scene_parse(&t, json, strlen(json), "SCEN", &err), PF_OK);
    assert_int_equal(t.edge_samples, 5);
    assert_int_equal(pf_scene_override(&t, "edge_samples", "3", &err), PF_OK);
    assert_int_equal(t.edge_samples, 3);
    assert_int_equal(pf_scene_override(&t, "edge_samples", "17", &err), PF_ERR_INVALID);
    assert_string_equal(err.msg, "edge_samples: must be an integer from 1 to 16, got '17'");
    assert_int_equal(t.edge_samples, 3);
    pf_free(json);
    pf_scene_release(&s);
    pf_scene_release(&t);
    static const char bad[] = "{\"method\": {\"name\": \"cg\", \"edge_samples\": 2.5}}";
    assert_int_equal(pf_scene_parse(&s, bad, sizeof bad - 1, "scene.json", &err), PF_ERR_INVALID);
    assert_non_null(strstr(err.msg, "method.edge_samples"));
    pf_scene_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

/* A scene written (pf_scene_to_json) reads back into the same bits: its JSON written again is the
 * same text, for normals of every direction (normalised once, kept as they are when read back)
 * and plane regions anywhere (their point written so that n . point gives d back exactly). What
 * pf-sim --resume relies on to continue a run from the SCEN it stored. */
static void written_scene_reads_back_into_the_same_bits(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    uint64_t seed = 12345;
    int kept = 0;
    for (int trial = 0; trial < 300; ++trial) {
        double v[12];
        for (int k = 0; k < 12; ++k) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            v[k] = (double)(seed >> 11) / 9007199254740992.0 * 20 - 10;
        }
        char text[1024];
        snprintf(text, sizeof text,
                 "{\"ground\": {\"normal\": [%.17g, %.17g, %.17g]},"
                 " \"fixed\": [{\"plane\": {\"point\": [%.17g, %.17g, %.17g],"
                 " \"normal\": [%.17g, %.17g, %.17g]}}],"
                 " \"obstacles\": [{\"plane\": {\"point\": [0, 0, 0],"
                 " \"normal\": [%.17g, %.17g, %.17g]}}]}",
                 v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11]);
        pf_scene a, b;
        pf_error err = {0};
        char *first = NULL, *second = NULL;
        assert_int_equal(pf_scene_parse(&a, text, strlen(text), "scene.json", &err), PF_OK);
        assert_int_equal(pf_scene_to_json(&a, &first, &err), PF_OK);
        assert_int_equal(pf_scene_parse(&b, first, strlen(first), "SCEN", &err), PF_OK);
        assert_int_equal(pf_scene_to_json(&b, &second, &err), PF_OK);
        assert_string_equal(first, second);
        assert_memory_equal(&a.ground_normal, &b.ground_normal, sizeof a.ground_normal);
        assert_memory_equal(&a.fixed[0].region.plane, &b.fixed[0].region.plane, sizeof(pf_plane));
        assert_memory_equal(&a.obstacles[0].normal, &b.obstacles[0].normal, sizeof(pf_vec3));
        kept += fabs(pf_v3_norm(a.ground_normal) - 1) < 1e-15;
        pf_free(first);
        pf_free(second);
        pf_scene_release(&a);
        pf_scene_release(&b);
    }
    assert_int_equal(kept, 300); /* every normal unit */
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_example_parses_field_by_field),
        cmocka_unit_test(test_defaults_without_file_and_for_empty_object),
        cmocka_unit_test(test_method_string_and_corotation_at_top_level),
        cmocka_unit_test(test_ground_forms_and_static_rule),
        cmocka_unit_test(test_every_error_names_the_path_or_position),
        cmocka_unit_test(test_nul_byte_and_unterminated_buffer),
        cmocka_unit_test(test_mutated_scenes_fail_cleanly),
        cmocka_unit_test(test_nesting_limit),
        cmocka_unit_test(test_messages_name_the_file),
        cmocka_unit_test(test_documentation_examples_parse),
        cmocka_unit_test(test_resolve_places_the_ground_and_tolerances),
        cmocka_unit_test(test_region_contains),
        cmocka_unit_test(mass_key_is_parsed),
        cmocka_unit_test(edge_samples_key_is_parsed),
        cmocka_unit_test(written_scene_reads_back_into_the_same_bits),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
