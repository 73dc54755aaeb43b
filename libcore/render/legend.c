/* The stress legend: a viridis colour bar with three values, drawn on the CPU into the 8-bit image
 * after read-back (integer arithmetic only: identical bytes everywhere). */
#include <pf/render.h>

#include <stdio.h>
#include <string.h>

/* 5 x 7 pixel glyphs, one byte per row, bit 4 the leftmost pixel. */
typedef struct glyph {
    char c;
    uint8_t rows[7];
} glyph;

static const glyph FONT[] = {
    {'0', {0x0e, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0e}},
    {'1', {0x04, 0x0c, 0x04, 0x04, 0x04, 0x04, 0x0e}},
    {'2', {0x0e, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1f}},
    {'3', {0x1e, 0x01, 0x01, 0x0e, 0x01, 0x01, 0x1e}},
    {'4', {0x02, 0x06, 0x0a, 0x12, 0x1f, 0x02, 0x02}},
    {'5', {0x1f, 0x10, 0x1e, 0x01, 0x01, 0x11, 0x0e}},
    {'6', {0x06, 0x08, 0x10, 0x1e, 0x11, 0x11, 0x0e}},
    {'7', {0x1f, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0e, 0x11, 0x11, 0x0e, 0x11, 0x11, 0x0e}},
    {'9', {0x0e, 0x11, 0x11, 0x0f, 0x01, 0x02, 0x0c}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0c, 0x0c}},
    {'-', {0x00, 0x00, 0x00, 0x0e, 0x00, 0x00, 0x00}},
    {'+', {0x00, 0x04, 0x04, 0x1f, 0x04, 0x04, 0x00}},
    {'e', {0x00, 0x00, 0x0e, 0x11, 0x1f, 0x10, 0x0e}},
};

static const glyph *find_glyph(char c)
{
    for (size_t i = 0; i < sizeof FONT / sizeof FONT[0]; ++i)
        if (FONT[i].c == c)
            return &FONT[i];
    return NULL;
}

typedef struct canvas {
    uint8_t *rgb;
    int32_t w, h;
} canvas;

static void put(const canvas *cv, int32_t x, int32_t y, const uint8_t c[3])
{
    if (x < 0 || y < 0 || x >= cv->w || y >= cv->h)
        return;
    memcpy(cv->rgb + 3 * ((size_t)y * (size_t)cv->w + (size_t)x), c, 3);
}

static void fill(const canvas *cv, int32_t x0, int32_t y0, int32_t x1, int32_t y1,
                 const uint8_t c[3])
{
    for (int32_t y = y0; y < y1; ++y)
        for (int32_t x = x0; x < x1; ++x)
            put(cv, x, y, c);
}

/* Lightens the rectangle towards white by 5/8, so that text stays legible over any background. */
static void veil(const canvas *cv, int32_t x0, int32_t y0, int32_t x1, int32_t y1)
{
    for (int32_t y = y0 < 0 ? 0 : y0; y < y1 && y < cv->h; ++y)
        for (int32_t x = x0 < 0 ? 0 : x0; x < x1 && x < cv->w; ++x) {
            uint8_t *p = cv->rgb + 3 * ((size_t)y * (size_t)cv->w + (size_t)x);
            for (int k = 0; k < 3; ++k)
                p[k] = (uint8_t)((3 * p[k] + 5 * 255 + 4) / 8);
        }
}

/* Text with its right end at x and its middle at y, glyphs scaled by s; returns the width. */
static int32_t text_width(const char *t, int32_t s)
{
    return (int32_t)strlen(t) * 6 * s - s;
}

static void draw_text(const canvas *cv, const char *t, int32_t right, int32_t mid, int32_t s,
                      const uint8_t c[3])
{
    int32_t x = right - text_width(t, s), y = mid - 7 * s / 2;
    for (; *t; ++t, x += 6 * s) {
        const glyph *g = find_glyph(*t);
        if (!g)
            continue;
        for (int r = 0; r < 7; ++r)
            for (int b = 0; b < 5; ++b)
                if (g->rows[r] & (0x10 >> b))
                    fill(cv, x + b * s, y + r * s, x + (b + 1) * s, y + (r + 1) * s, c);
    }
}

void pf_render_draw_legend(uint8_t *rgb, int32_t width, int32_t height, double lo, double hi)
{
    canvas cv = {rgb, width, height};
    int32_t s = height / 240 > 1 ? height / 240 : 1;
    int32_t margin = 4 * s, bar_w = 6 * s, gap = 3 * s;
    int32_t x1 = width - margin, x0 = x1 - bar_w;
    int32_t y0 = height / 4, y1 = height - height / 4;
    if (y1 - y0 < 3)
        return;
    char label[3][32];
    double values[3] = {hi, 0.5 * (lo + hi), lo};
    int32_t widest = 0;
    for (int i = 0; i < 3; ++i) {
        snprintf(label[i], sizeof label[i], "%.3g", values[i]);
        int32_t tw = text_width(label[i], s);
        widest = tw > widest ? tw : widest;
    }
    veil(&cv, x0 - gap - widest - 2 * s, y0 - 6 * s, width, y1 + 6 * s);
    static const uint8_t DARK[3] = {40, 40, 44};
    fill(&cv, x0 - s, y0 - s, x1 + s, y1 + s, DARK);
    for (int32_t y = y0; y < y1; ++y) {
        float lin[3];
        pf_colormap_viridis((double)(y1 - 1 - y) / (double)(y1 - 1 - y0 > 0 ? y1 - 1 - y0 : 1),
                            lin);
        uint8_t c[3] = {pf_linear_to_srgb8(lin[0]), pf_linear_to_srgb8(lin[1]),
                        pf_linear_to_srgb8(lin[2])};
        fill(&cv, x0, y, x1, y + 1, c);
    }
    int32_t mids[3] = {y0, (y0 + y1) / 2, y1 - 1};
    for (int i = 0; i < 3; ++i)
        draw_text(&cv, label[i], x0 - gap, mids[i], s, DARK);
}
