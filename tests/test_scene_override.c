/* scene_override: the command-line overrides of scene keys (pf_scene_override): every key, every
 * refusal with its exact message, and the static-ground rule an override re-applies. Every test
 * checks that the live pf allocation count returns to its start. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include <pf/sim.h>

static pf_status parse(pf_scene *s, const char *text, pf_error *err)
{
    return pf_scene_parse(s, text, strlen(text), "scene.json", err);
}

typedef struct override_case {
    const char *key, *value, *message;
} override_case;

static const override_case bad_overrides[] = {
    {"degree", "3", "degree: must be 1 or 2, got '3'"},
    {"degree", "2x", "degree: must be an integer, got '2x'"},
    {"frames", "1.5", "frames: must be an integer, got '1.5'"},
    {"frames", "-1", "frames: must be an integer >= 0, got '-1'"},
    {"frames", "99999999999", "frames: must be an integer >= 0, got '99999999999'"},
    {"frames", " 5", "frames: must be an integer, got ' 5'"},
    {"substeps", "0", "substeps: must be an integer >= 1, got '0'"},
    {"dt", "0.1x", "dt: must be a number, got '0.1x'"},
    {"dt", "0.1 ", "dt: must be a number, got '0.1 '"},
    {"dt", "0", "dt: must be > 0, got '0'"},
    {"dt", "nan", "dt: must be > 0, got 'nan'"},
    {"E", "", "E: must be a number, got ''"},
    {"E", NULL, "E: must be a number, got ''"},
    {"E", "1e999", "E: must be > 0, got '1e999'"},
    {"nu", "0.5", "nu: must be in (-1, 0.5), got '0.5'"},
    {"density", "-1", "density: must be > 0, got '-1'"},
    {"penalty", "-1", "penalty: must be >= 0, got '-1'"},
    {"method", "fem", "method: must be dg or cg, got 'fem'"},
    {"flux", "", "flux: must be ip or bz, got ''"},
    {"static", "yes", "static: must be true or false, got 'yes'"},
    {"corotation", "1", "corotation: must be true or false, got '1'"},
    {"gravity", "0",
     "gravity: unknown scene option (expected one of: method, degree, flux, "
     "mass, edge_samples, frames, dt, static, E, nu, density, penalty, substeps, corotation, "
     "solver, tolerance)"},
};

static void test_overrides(void **state)
{
    (void)state;
    pf_scene s;
    pf_error err = {0};
    pf_scene_default(&s);
    assert_int_equal(pf_scene_override(&s, "method", "cg", &err), PF_OK);
    assert_int_equal(s.method, PF_METHOD_CG);
    assert_int_equal(pf_scene_override(&s, "degree", "2", &err), PF_OK);
    assert_int_equal(s.degree, 2);
    assert_int_equal(pf_scene_override(&s, "flux", "bz", &err), PF_OK);
    assert_int_equal(s.flux, PF_FLUX_BZ);
    assert_int_equal(pf_scene_override(&s, "frames", "0", &err), PF_OK);
    assert_int_equal(s.frames, 0);
    assert_int_equal(pf_scene_override(&s, "substeps", "25", &err), PF_OK);
    assert_int_equal(s.substeps, 25);
    assert_int_equal(pf_scene_override(&s, "dt", "0.04", &err), PF_OK);
    assert_true(s.dt == 0.04);
    assert_int_equal(pf_scene_override(&s, "E", "2.5e6", &err), PF_OK);
    assert_true(s.E == 2.5e6);
    assert_int_equal(pf_scene_override(&s, "nu", "0.499", &err), PF_OK);
    assert_true(s.nu == 0.499);
    assert_int_equal(pf_scene_override(&s, "density", "7800", &err), PF_OK);
    assert_true(s.density == 7800);
    assert_int_equal(pf_scene_override(&s, "penalty", "16", &err), PF_OK);
    assert_true(s.penalty == 16);
    assert_int_equal(pf_scene_override(&s, "corotation", "false", &err), PF_OK);
    assert_false(s.corotation);
    assert_int_equal(pf_scene_override(&s, "corotation", "", &err), PF_OK);
    assert_true(s.corotation);

    /* static without a ground in the file: the ground goes, and comes back with static=false */
    assert_int_equal(pf_scene_override(&s, "static", "", &err), PF_OK);
    assert_true(s.is_static);
    assert_false(s.ground);
    assert_int_equal(pf_scene_override(&s, "static", "false", &err), PF_OK);
    assert_false(s.is_static);
    assert_true(s.ground);
    assert_int_equal(pf_scene_override(&s, "static", NULL, &err), PF_OK);
    assert_true(s.is_static);

    /* a rejected value leaves the scene as it was */
    pf_scene before = s;
    for (size_t i = 0; i < sizeof bad_overrides / sizeof bad_overrides[0]; ++i) {
        const override_case *c = &bad_overrides[i];
        pf_status st = pf_scene_override(&s, c->key, c->value, &err);
        if (st != PF_ERR_INVALID || strcmp(err.msg, c->message) != 0)
            fail_msg("override %s=%s: status %d, message\n  %s\nexpected\n  %s", c->key,
                     c->value ? c->value : "(null)", st, err.msg, c->message);
        assert_true(s.E == before.E && s.nu == before.nu && s.density == before.density &&
                    s.penalty == before.penalty && s.dt == before.dt);
        assert_true(s.method == before.method && s.flux == before.flux &&
                    s.degree == before.degree && s.frames == before.frames &&
                    s.substeps == before.substeps);
        assert_true(s.corotation == before.corotation && s.is_static == before.is_static &&
                    s.ground == before.ground);
    }
    pf_scene_release(&s);
}

static void test_static_override_keeps_a_ground_the_file_gave(void **state)
{
    (void)state;
    int64_t live = pf_alloc_live_bytes();
    pf_scene s;
    pf_error err = {0};
    assert_int_equal(parse(&s, "{\"ground\": {\"point\": [0, 0, -2]}}", &err), PF_OK);
    assert_int_equal(pf_scene_override(&s, "static", "true", &err), PF_OK);
    assert_true(s.ground);
    assert_false(s.ground_auto);
    pf_scene_release(&s);
    assert_int_equal(pf_alloc_live_bytes(), live);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_overrides),
        cmocka_unit_test(test_static_override_keeps_a_ground_the_file_gave),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
