/* Value rules of scenes shared by the file reader (scene.c) and the command-line overrides
 * (scene_override.c): ranges and their messages, method / flux / mass names, the static-ground
 * rule. Private to sim/. */
#ifndef PF_SIM_SCENE_VALUES_H
#define PF_SIM_SCENE_VALUES_H

#include <stdbool.h>

#include <pf/sim.h>

typedef enum scene_range {
    RANGE_FINITE,        /* any finite number */
    RANGE_POSITIVE,      /* > 0 */
    RANGE_NONNEG,        /* >= 0 */
    RANGE_POISSON,       /* (-1, 0.5): the bulk and shear moduli are then positive */
    RANGE_DEGREE,        /* integer 1 or 2 */
    RANGE_EDGE_SAMPLES,  /* integer 1 .. 16 */
    RANGE_INT_NONNEG,    /* integer >= 0 (fits int32) */
    RANGE_INT_POS,       /* integer >= 1 (fits int32) */
    RANGE_OPEN_UNIT,     /* (0, 1) */
    RANGE_UNIT_INTERVAL, /* [0, 1) */
} scene_range;

bool pf_scene_range_is_integer(scene_range r);
/* Finite, integral for the integer ranges (and within int32), inside the range. */
bool pf_scene_in_range(scene_range r, double v);
/* "must be ...", for messages. */
const char *pf_scene_range_text(scene_range r);

/* Names of the scene's enumerations; false for an unknown name (out untouched). */
bool pf_scene_parse_method_name(const char *text, pf_method *out);
bool pf_scene_parse_flux_name(const char *text, pf_flux *out);
bool pf_scene_parse_mass_name(const char *text, pf_mass *out);
bool pf_scene_parse_solver_name(const char *text, pf_solver_method *out);
bool pf_scene_parse_split_name(const char *text, pf_split_kind *out);

/* n as a unit vector into out; false for the zero vector (out untouched). A unit vector (to 8
 * ulps) is kept as it is: normalising again is not idempotent in floating point ((0, 0.2, 1)
 * normalised, written with 17 digits and normalised again moved from ...404 to ...407 in its
 * last digits), and the scene a stream's SCEN stores must read back into the same bits (pf-sim
 * --resume). */
bool pf_scene_unit_direction(pf_vec3 n, pf_vec3 *out);

/* A static scene has no ground unless the file asks for one; override of "static" re-applies
 * this rule, hence ground_given. */
void pf_scene_apply_static_ground_rule(pf_scene *s);

/* A path's translation at time t: linear between keyframes (key_time strictly increasing), the
 * first and last held before and after; zero without keys (obstacles, blades). */
pf_vec3 pf_scene_path_at(int32_t n_keys, const double *key_time, const pf_vec3 *key_translation,
                         double t);

#endif
