/* GLSL 3.30 core sources. All shading is in linear light; the resolve pass averages the samples of
 * each pixel (a box filter over the multisample pattern) and applies the sRGB transfer function
 * once, so anti-aliased edges blend in linear light. */
#include "gl.h"

/* clang-format off */

/* Soft shadows: percentage-closer filtering (Reeves, Salesin and Cook 1987): the mean of TAPS
 * bilinear depth comparisons at fixed offsets u_taps (a Vogel spiral computed on the CPU), so the
 * same pixel gets the same value every run. The shadow-map coordinate comes from the vertex
 * shader. Outside the map (border depth 1) everything is lit. TAPS 0: no shadow (ground far from
 * the objects). */
#define SHADOW_GLSL                                                                                \
    "uniform sampler2DShadow u_shadow;\n"                                                          \
    "#if TAPS > 0\n"                                                                               \
    "uniform vec2 u_taps[TAPS];\n"                                                                 \
    "#endif\n"                                                                                     \
    "float shadow_at(vec3 s) {\n"                                                                  \
    "#if TAPS > 0\n"                                                                               \
    "    float sum = 0.0;\n"                                                                       \
    "    for (int i = 0; i < TAPS; ++i)\n"                                                         \
    "        sum += texture(u_shadow, vec3(s.xy + u_taps[i], s.z));\n"                             \
    "    return sum / float(TAPS);\n"                                                              \
    "#else\n"                                                                                      \
    "    return 1.0;\n"                                                                            \
    "#endif\n"                                                                                     \
    "}\n"

/* Lighting: a hemisphere ambient term (sky above, bounce from the ground below, blended by the
 * normal's up component), one shadowed directional key light with Lambert diffuse and a
 * Blinn-Phong highlight, and a weak unshadowed fill from the viewer so that faces turned from the
 * key light keep their shape. */
#define LIGHT_GLSL                                                                                 \
    "uniform vec3 u_light_dir;\n"                                                                  \
    "uniform vec3 u_up;\n"                                                                         \
    "uniform vec3 u_eye;\n"                                                                        \
    "vec3 shade(vec3 albedo, vec3 n, vec3 p, float sh) {\n"                                        \
    "    vec3 v = normalize(u_eye - p);\n"                                                         \
    "    float ndl = max(dot(n, u_light_dir), 0.0);\n"                                             \
    "    float hemi = 0.5 + 0.5 * dot(n, u_up);\n"                                                 \
    "    vec3 ambient = mix(vec3(0.16, 0.15, 0.14), vec3(0.36, 0.39, 0.44), hemi);\n"              \
    "    vec3 h = normalize(u_light_dir + v);\n"                                                   \
    "    float spec = ndl > 0.0 ? pow(max(dot(n, h), 0.0), 40.0) : 0.0;\n"                         \
    "    float fill = 0.12 * max(dot(n, v), 0.0);\n"                                               \
    "    return albedo * (ambient + vec3(1.0, 0.97, 0.92) * (1.05 * ndl * sh) + fill)\n"           \
    "         + vec3(0.10 * spec * sh);\n"                                                         \
    "}\n"

/* The scene shaders are compiled twice: with WIRE 1 for wireframes, WIRE 0 otherwise (three fewer
 * interpolants and no derivatives). */
const char *const PF_GLSL_SCENE_VS =
    "in vec3 a_pos;\n"
    "in vec3 a_normal;\n"
    "in vec3 a_color;\n"
    "in vec3 a_edge;\n"
    "uniform mat4 u_view_proj;\n"
    "uniform mat4 u_light_view_proj;\n"
    "uniform float u_normal_offset;\n"
    "out vec3 v_pos;\n"
    "out vec3 v_normal;\n"
    "out vec3 v_color;\n"
    "out vec3 v_shadow;\n"
    "#if WIRE\n"
    "out vec3 v_edge;\n"
    "#endif\n"
    "void main() {\n"
    "    v_pos = a_pos;\n"
    "    v_normal = a_normal;\n"
    "    v_color = a_color;\n"
    "    vec3 p = a_pos + a_normal * u_normal_offset;\n"
    "    v_shadow = (u_light_view_proj * vec4(p, 1.0)).xyz * 0.5 + 0.5;\n"
    "#if WIRE\n"
    "    v_edge = a_edge;\n"
    "#endif\n"
    "    gl_Position = u_view_proj * vec4(a_pos, 1.0);\n"
    "}\n";

/* Wireframe: the edge tags are barycentric coordinates (1 at a corner, 0 on the opposite edge);
 * divided by their screen-space derivative they are distances in pixels to the tagged edges
 * (Baerentzen et al., "Single-pass wireframe rendering", 2006). Untagged components are constant
 * 1: a zero derivative makes their distance huge. */
const char *const PF_GLSL_SCENE_FS =
    SHADOW_GLSL
    LIGHT_GLSL
    "uniform float u_wire_half_width;\n"
    "uniform vec3 u_wire_color;\n"
    "in vec3 v_pos;\n"
    "in vec3 v_normal;\n"
    "in vec3 v_color;\n"
    "in vec3 v_shadow;\n"
    "#if WIRE\n"
    "in vec3 v_edge;\n"
    "#endif\n"
    "out vec4 o_color;\n"
    "void main() {\n"
    "    vec3 n = normalize(v_normal);\n"
    "    if (!gl_FrontFacing) n = -n;\n"
    "    vec3 c = shade(v_color, n, v_pos, shadow_at(v_shadow));\n"
    "#if WIRE\n"
    "    vec3 d = v_edge / max(fwidth(v_edge), vec3(1e-7));\n"
    "    float line = clamp(u_wire_half_width + 0.5 - min(min(d.x, d.y), d.z), 0.0, 1.0);\n"
    "    c = mix(c, u_wire_color, line);\n"
    "#endif\n"
    "    o_color = vec4(c, 1.0);\n"
    "}\n";

const char *const PF_GLSL_DEPTH_VS =
    "in vec3 a_pos;\n"
    "uniform mat4 u_view_proj;\n"
    "void main() { gl_Position = u_view_proj * vec4(a_pos, 1.0); }\n";

const char *const PF_GLSL_DEPTH_FS =
    "out vec4 o_color;\n"
    "void main() { o_color = vec4(1.0); }\n";

const char *const PF_GLSL_GROUND_VS =
    "in vec3 a_pos;\n"
    "uniform mat4 u_view_proj;\n"
    "uniform mat4 u_light_view_proj;\n"
    "out vec3 v_pos;\n"
    "out vec3 v_shadow;\n"
    "void main() {\n"
    "    v_pos = a_pos;\n"
    "    v_shadow = (u_light_view_proj * vec4(a_pos, 1.0)).xyz * 0.5 + 0.5;\n"
    "    gl_Position = u_view_proj * vec4(a_pos, 1.0);\n"
    "}\n";

/* The ground: a grid of anti-aliased lines (distance to the nearest line in pixels from the
 * derivative of the grid coordinate), lit like an upward face by the sky and the key light but
 * without a highlight, the shadow, and a radial fade into the background so that the plane has no
 * visible edge. */
const char *const PF_GLSL_GROUND_FS =
    SHADOW_GLSL
    "uniform vec3 u_light_dir;\n"
    "uniform vec3 u_up;\n"
    "uniform vec3 u_center;\n"
    "uniform vec3 u_axis1;\n"
    "uniform vec3 u_axis2;\n"
    "uniform float u_grid;\n"
    "uniform float u_fade0;\n"
    "uniform float u_fade1;\n"
    "uniform vec3 u_ground_color;\n"
    "uniform vec3 u_background;\n"
    "in vec3 v_pos;\n"
    "in vec3 v_shadow;\n"
    "out vec4 o_color;\n"
    "void main() {\n"
    "    vec3 r = v_pos - u_center;\n"
    "    vec2 g = vec2(dot(r, u_axis1), dot(r, u_axis2)) / u_grid;\n"
    "    vec2 d = abs(fract(g - 0.5) - 0.5) / max(fwidth(g), vec2(1e-7));\n"
    "    float line = 1.0 - clamp(min(d.x, d.y), 0.0, 1.0);\n"
    "    float sh = shadow_at(v_shadow);\n"
    "    float ndl = max(dot(u_up, u_light_dir), 0.0);\n"
    "    vec3 light = vec3(0.36, 0.39, 0.44) + vec3(1.0, 0.97, 0.92) * (1.05 * ndl * sh);\n"
    "    vec3 c = u_ground_color * (1.0 - 0.18 * line) * light;\n"
    "    float f = smoothstep(u_fade0, u_fade1, length(r));\n"
    "    o_color = vec4(mix(c, u_background, f), 1.0);\n"
    "}\n";

const char *const PF_GLSL_RESOLVE_VS =
    "void main() {\n"
    "    vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);\n"
    "    gl_Position = vec4(p, 0.0, 1.0);\n"
    "}\n";

/* IEC 61966-2-1 encoding of the mean of the samples. */
const char *const PF_GLSL_RESOLVE_FS =
    "uniform sampler2DMS u_color;\n"
    "uniform int u_samples;\n"
    "out vec4 o_color;\n"
    "void main() {\n"
    "    ivec2 p = ivec2(gl_FragCoord.xy);\n"
    "    vec3 s = vec3(0.0);\n"
    "    for (int i = 0; i < u_samples; ++i) s += texelFetch(u_color, p, i).rgb;\n"
    "    vec3 c = clamp(s / float(u_samples), 0.0, 1.0);\n"
    "    vec3 lo = 12.92 * c;\n"
    "    vec3 hi = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;\n"
    "    o_color = vec4(mix(hi, lo, vec3(lessThanEqual(c, vec3(0.0031308)))), 1.0);\n"
    "}\n";
/* clang-format on */
