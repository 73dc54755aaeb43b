/* Colour: the sRGB transfer function, the viridis map, element-kind colours. */
#include <pf/render.h>

/* IEC 61966-2-1: linear segment below 0.04045 (encoded) / 0.0031308 (linear), a 2.4 power above. */
double pf_srgb_to_linear(double c)
{
    c = fmin(fmax(c, 0.0), 1.0);
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

double pf_linear_to_srgb(double c)
{
    c = fmin(fmax(c, 0.0), 1.0);
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

uint8_t pf_linear_to_srgb8(double c)
{
    if (!(c > 0)) /* also NaN */
        return 0;
    return (uint8_t)floor(255.0 * pf_linear_to_srgb(c) + 0.5);
}

/* Viridis (van der Walt and Smith, 2015) sampled at t = k / 8, in sRGB. Between the samples the map
 * is interpolated linearly in sRGB, which stays within about one 8-bit level of the full map. */
static const double VIRIDIS[9][3] = {
    {0.267004, 0.004874, 0.329415}, {0.278826, 0.175490, 0.483397}, {0.229739, 0.322361, 0.545706},
    {0.172719, 0.448791, 0.557885}, {0.127568, 0.566949, 0.550556}, {0.157851, 0.683765, 0.501686},
    {0.369214, 0.788888, 0.382914}, {0.678489, 0.863742, 0.189503}, {0.993248, 0.906157, 0.143936},
};

void pf_colormap_viridis(double t, float rgb[3])
{
    if (!(t > 0)) /* also NaN */
        t = 0;
    if (t > 1)
        t = 1;
    double s = t * 8;
    int k = (int)s;
    if (k > 7)
        k = 7;
    double w = s - k;
    for (int c = 0; c < 3; ++c)
        rgb[c] = (float)pf_srgb_to_linear((1 - w) * VIRIDIS[k][c] + w * VIRIDIS[k + 1][c]);
}

/* Tets warm orange, hexes steel blue, general polyhedra green (sRGB), distinct in hue and in
 * lightness so that they separate in grey-scale prints too. */
void pf_render_kind_color(pf_elem_kind kind, float rgb[3])
{
    static const double SRGB[PF_ELEM_KIND_COUNT][3] = {
        {0.93, 0.55, 0.25}, {0.36, 0.56, 0.80}, {0.50, 0.78, 0.45}};
    int k = kind >= 0 && kind < PF_ELEM_KIND_COUNT ? (int)kind : PF_ELEM_POLY;
    for (int c = 0; c < 3; ++c)
        rgb[c] = (float)pf_srgb_to_linear(SRGB[k][c]);
}
