/* Value rules of scenes shared by the reader and the overrides (scene_values.h). */
#include "scene_values.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

/* A static scene has no ground unless the file asks for one; override of "static" re-applies
 * this rule, hence ground_given. */
void pf_scene_apply_static_ground_rule(pf_scene *s)
{
    if (!s->ground_given)
        s->ground = !s->is_static;
}

bool pf_scene_range_is_integer(scene_range r)
{
    return r == RANGE_DEGREE || r == RANGE_EDGE_SAMPLES || r == RANGE_INT_NONNEG ||
           r == RANGE_INT_POS;
}

bool pf_scene_in_range(scene_range r, double v)
{
    if (!isfinite(v))
        return false;
    if (pf_scene_range_is_integer(r) && (v != floor(v) || v > INT32_MAX))
        return false;
    switch (r) {
    case RANGE_FINITE:
        return true;
    case RANGE_POSITIVE:
        return v > 0;
    case RANGE_NONNEG:
        return v >= 0;
    case RANGE_POISSON:
        return v > -1 && v < 0.5;
    case RANGE_DEGREE:
        return v == 1 || v == 2;
    case RANGE_EDGE_SAMPLES:
        return v >= 1 && v <= 16;
    case RANGE_INT_NONNEG:
        return v >= 0;
    case RANGE_INT_POS:
        return v >= 1;
    case RANGE_OPEN_UNIT:
        return v > 0 && v < 1;
    case RANGE_UNIT_INTERVAL:
        return v >= 0 && v < 1;
    }
    return false;
}

const char *pf_scene_range_text(scene_range r)
{
    switch (r) {
    case RANGE_FINITE:
        return "must be finite";
    case RANGE_POSITIVE:
        return "must be > 0";
    case RANGE_NONNEG:
        return "must be >= 0";
    case RANGE_POISSON:
        return "must be in (-1, 0.5)";
    case RANGE_DEGREE:
        return "must be 1 or 2";
    case RANGE_EDGE_SAMPLES:
        return "must be an integer from 1 to 16";
    case RANGE_INT_NONNEG:
        return "must be an integer >= 0";
    case RANGE_INT_POS:
        return "must be an integer >= 1";
    case RANGE_OPEN_UNIT:
        return "must be in (0, 1)";
    case RANGE_UNIT_INTERVAL:
        return "must be in [0, 1)";
    }
    return "out of range";
}

bool pf_scene_parse_method_name(const char *text, pf_method *out)
{
    if (!strcmp(text, "dg"))
        *out = PF_METHOD_DG;
    else if (!strcmp(text, "cg"))
        *out = PF_METHOD_CG;
    else
        return false;
    return true;
}

bool pf_scene_parse_flux_name(const char *text, pf_flux *out)
{
    if (!strcmp(text, "ip"))
        *out = PF_FLUX_IP;
    else if (!strcmp(text, "bz"))
        *out = PF_FLUX_BZ;
    else
        return false;
    return true;
}

bool pf_scene_parse_mass_name(const char *text, pf_mass *out)
{
    if (!strcmp(text, "consistent"))
        *out = PF_MASS_CONSISTENT;
    else if (!strcmp(text, "lumped"))
        *out = PF_MASS_LUMPED;
    else
        return false;
    return true;
}

bool pf_scene_parse_solver_name(const char *text, pf_solver_method *out)
{
    return pf_solver_method_parse(text, out);
}

bool pf_scene_parse_split_name(const char *text, pf_split_kind *out)
{
    bool octs = !strcmp(text, "octs"), halves = !strcmp(text, "halves");
    if (octs || halves)
        *out = octs ? PF_SPLIT_OCTS : PF_SPLIT_HALVES;
    return octs || halves;
}

/* The defaults of every key (docs/scene.md's tables). */
void pf_scene_default(pf_scene *s)
{
    *s = (pf_scene){
        .E = 1e5,
        .nu = 0.3,
        .density = 1000,
        .method = PF_METHOD_DG,
        .degree = 1,
        .flux = PF_FLUX_IP,
        .penalty = 0,
        .corotation = true,
        .edge_samples = 2,
        .gravity = {0, 0, -9.81},
        .body_force = {0, 0, 0},
        .damping_alpha = 0,
        .damping_beta = 0.01,
        .ground = true,
        .ground_given = false,
        .ground_auto = true,
        .ground_normal = {0, 0, 1},
        .ground_stiffness = 0,
        .is_static = false,
        .dt = 1.0 / 30.0,
        .frames = 60,
        .substeps = 10,
        .solver = pf_solver_params_default(),
        .refine = {.split = PF_SPLIT_OCTS,
                   .max_level = 2,
                   .max_elements = 100000,
                   .coarsen_fraction = 0.5,
                   .coarsen_after = 10},
    };
}

bool pf_scene_unit_direction(pf_vec3 n, pf_vec3 *out)
{
    if (fabs(pf_v3_dot(n, n) - 1) <= 8 * DBL_EPSILON) {
        *out = n;
        return true;
    }
    pf_plane pl = pf_plane_from_point_normal(pf_v3(0, 0, 0), n);
    if (pf_v3_max_abs(pl.n) == 0)
        return false;
    *out = pl.n;
    return true;
}
