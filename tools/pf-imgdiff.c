/* pf-imgdiff: compares two PNG images with a per-pixel tolerance; the exit code is the verdict. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <pf/io.h>

#include "cli.h"

static const char USAGE[] =
    "Usage: pf-imgdiff A.png B.png [--tol T] [--max-fraction F] [--diff OUT.png]\n"
    "\n"
    "Compares two images pixel by pixel (as 8-bit RGBA). A pixel differs when one of its\n"
    "channels differs by more than T (0..255, default 0). Prints the number and fraction of\n"
    "differing pixels, the largest channel difference and the PSNR over all channels.\n"
    "\n"
    "  --tol T           per-channel tolerance in 8-bit levels (default 0: exact)\n"
    "  --max-fraction F  the images match when at most this fraction of the pixels differ\n"
    "                    (0..1, default 0)\n"
    "  --diff OUT.png    writes a picture of the differences: A in faded grey, differing pixels\n"
    "                    in red, brighter for larger differences\n"
    "  --help, --version\n"
    "\n"
    "Exit 0 when the images match within the tolerances, 1 when they do not (or their sizes\n"
    "differ), 2 when an image cannot be read or on bad usage.\n";

enum { OPT_TOL = 1, OPT_FRACTION, OPT_DIFF };

typedef struct comparison {
    int64_t differing;
    int max_delta;
    double sum_sq; /* of all channel differences */
} comparison;

static int pixel_delta(const uint8_t *a, const uint8_t *b)
{
    int d = 0;
    for (int c = 0; c < 4; ++c) {
        int x = abs((int)a[c] - (int)b[c]);
        d = x > d ? x : d;
    }
    return d;
}

static comparison compare(const pf_image *a, const pf_image *b, int tol, uint8_t *diff)
{
    comparison r = {0, 0, 0};
    size_t n = (size_t)a->width * (size_t)a->height;
    for (size_t i = 0; i < n; ++i) {
        const uint8_t *pa = a->pixels + 4 * i, *pb = b->pixels + 4 * i;
        int d = pixel_delta(pa, pb);
        for (int c = 0; c < 4; ++c) {
            double x = (double)pa[c] - (double)pb[c];
            r.sum_sq += x * x;
        }
        r.max_delta = d > r.max_delta ? d : r.max_delta;
        if (d > tol)
            r.differing++;
        if (!diff)
            continue;
        uint8_t *q = diff + 3 * i;
        if (d > tol) {
            q[0] = (uint8_t)(128 + 127 * d / 255);
            q[1] = q[2] = 0;
        } else {
            /* grey from Rec. 709 luma weights, faded towards white */
            int y = (2126 * pa[0] + 7152 * pa[1] + 722 * pa[2]) / 10000;
            q[0] = q[1] = q[2] = (uint8_t)(160 + y * 95 / 255);
        }
    }
    return r;
}

static void read_or_exit(const pf_cli *cli, const char *path, pf_image *img)
{
    pf_error err = {0};
    if (pf_png_read(path, img, &err) != PF_OK) {
        fprintf(stderr, "%s: %s\n", cli->tool, err.msg);
        exit(PF_EXIT_USAGE);
    }
}

int main(int argc, char **argv)
{
    static const pf_cli_option OPTIONS[] = {{"tol", true, OPT_TOL},
                                            {"max-fraction", true, OPT_FRACTION},
                                            {"diff", true, OPT_DIFF},
                                            {NULL, false, 0}};
    pf_cli cli;
    pf_cli_init(&cli, "pf-imgdiff", USAGE, argc, argv);
    const char *paths[2] = {NULL, NULL}, *diff_path = NULL, *value;
    long tol = 0;
    double max_fraction = 0;
    int n_paths = 0;
    for (int id; (id = pf_cli_next(&cli, OPTIONS, &value)) != PF_CLI_END;) {
        switch (id) {
        case OPT_TOL:
            tol = pf_cli_parse_long(&cli, "tol", value, 0, 255);
            break;
        case OPT_FRACTION:
            max_fraction = pf_cli_parse_double(&cli, "max-fraction", value);
            if (max_fraction < 0 || max_fraction > 1)
                pf_cli_usage_error(&cli, "--max-fraction expects a number in [0, 1], got '%s'",
                                   value);
            break;
        case OPT_DIFF:
            diff_path = value;
            break;
        default:
            if (n_paths == 2)
                pf_cli_usage_error(&cli, "two images only (got a third, '%s')", value);
            paths[n_paths++] = value;
        }
    }
    if (n_paths != 2)
        pf_cli_usage_error(&cli, "needs two images, A.png and B.png");
    pf_image a = {0}, b = {0};
    read_or_exit(&cli, paths[0], &a);
    read_or_exit(&cli, paths[1], &b);
    if (a.width != b.width || a.height != b.height) {
        printf("sizes differ: %s is %dx%d, %s is %dx%d\n", paths[0], (int)a.width, (int)a.height,
               paths[1], (int)b.width, (int)b.height);
        pf_image_release(&a);
        pf_image_release(&b);
        pf_cli_close_stdout(cli.tool);
        return PF_EXIT_INPUT;
    }
    size_t n = (size_t)a.width * (size_t)a.height;
    uint8_t *diff = diff_path ? pf_alloc_array(3 * n, 1) : NULL;
    if (diff_path && !diff) {
        fprintf(stderr, "%s: out of memory\n", cli.tool);
        return PF_EXIT_USAGE;
    }
    comparison r = compare(&a, &b, (int)tol, diff);
    double fraction = (double)r.differing / (double)n;
    /* PSNR = 10 log10(255^2 / MSE) over all channels; infinite for identical images */
    double mse = r.sum_sq / (4.0 * (double)n);
    printf("%lld of %lld pixels differ by more than %ld (%.6f), largest difference %d, PSNR ",
           (long long)r.differing, (long long)n, tol, fraction, r.max_delta);
    if (mse > 0)
        printf("%.2f dB\n", 10 * log10(255.0 * 255.0 / mse));
    else
        printf("inf\n");
    int code = fraction <= max_fraction ? PF_EXIT_OK : PF_EXIT_INPUT;
    if (diff) {
        pf_error err = {0};
        if (pf_png_write(diff_path, diff, a.width, a.height, 3, &err) != PF_OK) {
            fprintf(stderr, "%s: %s\n", cli.tool, err.msg);
            code = PF_EXIT_USAGE;
        }
    }
    pf_free(diff);
    pf_image_release(&a);
    pf_image_release(&b);
    pf_cli_close_stdout(cli.tool); /* a lost report is an error: exit 1 */
    return code;
}
