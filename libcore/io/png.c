/* PNG files through libpng: a deterministic writer (explicit zlib and filter settings, no time
 * stamp) and a reader for any PNG into 8-bit RGBA. */
#include <pf/io.h>


#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include <png.h>
#include <zlib.h>

void pf_image_release(pf_image *img)
{
    pf_free(img->pixels);
    memset(img, 0, sizeof *img);
}

/* libpng reports errors through a callback that must not return: keep the message, jump back. */
enum { WHY_MAX = 200 };

static void on_error(png_structp png, png_const_charp msg)
{
    char *why = png_get_error_ptr(png);
    snprintf(why, WHY_MAX, "%s", msg);
    png_longjmp(png, 1);
}

static void on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

/* Writes the PNG data stream to f; on failure returns false with libpng's reason in why. Nothing
 * that setjmp may roll back is modified between setjmp and the end (C11 7.13.2.1). */
static bool write_png(FILE *f, const uint8_t *pixels, int32_t width, int32_t height,
                      int32_t channels, char *why)
{
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, why, on_error, on_warning);
    if (!png) {
        snprintf(why, WHY_MAX, "out of memory");
        return false;
    }
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, NULL);
        snprintf(why, WHY_MAX, "out of memory");
        return false;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8,
                 channels == 4 ? PNG_COLOR_TYPE_RGB_ALPHA : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    /* Rendered frames are mostly flat background and smooth shading: zlib level 2 without row
     * filters writes a 1280x720 frame about 4x faster than level 6 with Paeth filtering, for
     * about 15 % more bytes (measured on pf-render frames). PNG writing is a third of a frame's
     * time at 100k triangles, so speed wins. */
    png_set_compression_level(png, 2);
    png_set_compression_strategy(png, Z_DEFAULT_STRATEGY);
    png_set_compression_window_bits(png, 15);
    png_set_compression_mem_level(png, 8);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
    png_write_info(png, info);
    size_t stride = (size_t)width * (size_t)channels;
    for (int32_t y = 0; y < height; ++y)
        png_write_row(png, pixels + stride * (size_t)y);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    return true;
}

pf_status pf_png_write(const char *path, const uint8_t *pixels, int32_t width, int32_t height,
                       int32_t channels, pf_error *err)
{
    PF_CHECK(width >= 1 && height >= 1 && width <= (1 << 20) && height <= (1 << 20) &&
                 (channels == 3 || channels == 4),
             err, PF_ERR_INVALID, "%s: cannot write a %dx%d image with %d channels as PNG", path,
             (int)width, (int)height, (int)channels);
    pf_atomic_file out;
    PF_TRY(pf_atomic_file_open(&out, path, err));
    char why[WHY_MAX] = "";
    if (!write_png(out.f, pixels, width, height, channels, why)) {
        pf_atomic_file_abort(&out);
        return pf_error_set(err, PF_ERR_IO, __FILE__, __LINE__, "%s: cannot write PNG: %s", path,
                            why);
    }
    return pf_atomic_file_commit(&out, "PNG", err);
}

pf_status pf_png_read(const char *path, pf_image *img, pf_error *err)
{
    memset(img, 0, sizeof *img);
    FILE *f = fopen(path, "rb");
    PF_CHECK(f, err, PF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    png_image im;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    pf_status s = PF_OK;
    if (!png_image_begin_read_from_stdio(&im, f)) {
        s = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__, "%s: not a readable PNG: %s", path,
                         im.message);
    } else if ((uint64_t)im.width * im.height > (1u << 30)) {
        s = pf_error_set(err, PF_ERR_TOO_LARGE, __FILE__, __LINE__, "%s: %ux%u pixels are too many",
                         path, (unsigned)im.width, (unsigned)im.height);
    } else {
        im.format = PNG_FORMAT_RGBA;
        img->pixels = pf_alloc_array(PNG_IMAGE_SIZE(im), 1);
        if (!img->pixels)
            s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "%s: out of memory", path);
        else if (!png_image_finish_read(&im, NULL, img->pixels, 0, NULL))
            s = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__, "%s: not a readable PNG: %s",
                             path, im.message);
    }
    png_image_free(&im);
    fclose(f);
    if (s != PF_OK) {
        pf_image_release(img);
        return s;
    }
    img->width = (int32_t)im.width;
    img->height = (int32_t)im.height;
    img->channels = 4;
    return PF_OK;
}
