/* Plane splits per second of pf_poly_split on a hex, a 20-face cell and a non-convex cell.
 *
 * CSV on stdout: cell,faces,nodes,splits_per_second
 * Planes: random unit normals (fixed seed) through random points of the cell's bounding box,
 * so most of them cut the cell; the same plane sequence for every cell. Each cell is timed for
 * about half a second of wall clock after a warm-up. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <pf/geom.h>
#include <pf/split.h>

enum { MAXN = 64, MAXF = 32, MAXFN = 256 };

typedef struct cell {
    const char *name;
    int32_t nn, nf;
    double x[3 * MAXN];
    int64_t off[MAXF + 1];
    uint32_t fn[MAXFN];
} cell;

static void add_face(cell *c, const uint32_t *v, int n)
{
    memcpy(c->fn + c->off[c->nf], v, (size_t)n * sizeof *v);
    c->off[c->nf + 1] = c->off[c->nf] + n;
    c->nf++;
}

/* Prism z in [0, 1] over polygons (counter-clockwise in xy) that share edges: bottom and top
 * copies of each, a side quad on every unshared edge. */
static void make_prism(cell *c, const char *name, const double *xy, int nv, const int *poff,
                       const int *pv, int np)
{
    c->name = name;
    c->nn = 2 * nv;
    c->nf = 0;
    c->off[0] = 0;
    for (int i = 0; i < nv; ++i)
        for (int z = 0; z < 2; ++z) {
            double *p = c->x + 3 * (i + z * nv);
            p[0] = xy[2 * i], p[1] = xy[2 * i + 1], p[2] = z;
        }
    for (int p = 0; p < np; ++p) {
        uint32_t v[64];
        int n = poff[p + 1] - poff[p];
        for (int i = 0; i < n; ++i)
            v[i] = (uint32_t)pv[poff[p + 1] - 1 - i]; /* bottom, seen from below */
        add_face(c, v, n);
        for (int i = 0; i < n; ++i)
            v[i] = (uint32_t)(pv[poff[p] + i] + nv);
        add_face(c, v, n);
    }
    for (int p = 0; p < np; ++p) {
        int n = poff[p + 1] - poff[p];
        for (int i = 0; i < n; ++i) {
            int a = pv[poff[p] + i], b = pv[poff[p] + (i + 1) % n], shared = 0;
            for (int q = 0; q < np; ++q) {
                int m = poff[q + 1] - poff[q];
                for (int j = 0; j < m; ++j)
                    shared |= pv[poff[q] + j] == b && pv[poff[q] + (j + 1) % m] == a;
            }
            if (!shared) {
                uint32_t quad[4] = {(uint32_t)a, (uint32_t)b, (uint32_t)(b + nv),
                                    (uint32_t)(a + nv)};
                add_face(c, quad, 4);
            }
        }
    }
}

static void single_prism(cell *c, const char *name, const double *xy, int nv)
{
    int off[2] = {0, nv}, v[64];
    for (int i = 0; i < nv; ++i)
        v[i] = i;
    make_prism(c, name, xy, nv, off, v, 1);
}

static uint64_t rng_state = 0x2545f4914f6cdd1dull;

static double uniform(double lo, double hi)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return lo + (hi - lo) * (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

enum { N_PLANES = 1024 };

static double splits_per_second(const cell *c, const pf_plane *planes)
{
    pf_polyhedron p = {.x = c->x, .n_faces = c->nf, .face_offsets = c->off, .face_nodes = c->fn};
    pf_error err = {0};
    pf_split s;
    int64_t done = 0;
    double t0 = pf_time_seconds(), t = t0;
    for (int round = 0; t - t0 < 0.5 || round < 2; ++round) {
        for (int i = 0; i < N_PLANES; ++i) {
            if (pf_poly_split(&p, c->nn, &planes[i], NULL, &s, &err) != PF_OK) {
                fprintf(stderr, "bench_split: %s: %s\n", c->name, err.msg);
                return -1;
            }
            pf_split_release(&s);
        }
        if (round == 0) { /* warm-up */
            t0 = pf_time_seconds();
            continue;
        }
        done += N_PLANES;
        t = pf_time_seconds();
    }
    return (double)done / (t - t0);
}

int main(void)
{
    static cell cells[3];
    const double square[] = {0, 0, 1, 0, 1, 1, 0, 1};
    single_prism(&cells[0], "hex", square, 4);
    double ring[2 * 18];
    for (int i = 0; i < 18; ++i) {
        ring[2 * i] = 0.5 + 0.5 * cos(2 * 3.14159265358979323846 * i / 18);
        ring[2 * i + 1] = 0.5 + 0.5 * sin(2 * 3.14159265358979323846 * i / 18);
    }
    single_prism(&cells[1], "18-gon prism (20 faces)", ring, 18);
    /* square frame: a box with a square through-hole, non-convex, 16 faces */
    const double frame[] = {0, 0, 3, 0, 3, 3, 0, 3, 1, 1, 2, 1, 2, 2, 1, 2};
    const int off[] = {0, 4, 8, 12, 16};
    const int v[] = {0, 1, 5, 4, 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7};
    make_prism(&cells[2], "frame with through-hole (non-convex)", frame, 8, off, v, 4);
    for (int i = 0; i < cells[2].nn; ++i) /* into the unit cube, like the others */
        cells[2].x[3 * i] /= 3, cells[2].x[3 * i + 1] /= 3;

    static pf_plane planes[N_PLANES];
    for (int i = 0; i < N_PLANES; ++i) {
        pf_vec3 n;
        do
            n = pf_v3(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1));
        while (pf_v3_norm(n) < 0.1 || pf_v3_norm(n) > 1);
        pf_vec3 at = pf_v3(uniform(0, 1), uniform(0, 1), uniform(0, 1));
        planes[i] = pf_plane_from_point_normal(at, n);
    }
    printf("cell,faces,nodes,splits_per_second\n");
    for (int k = 0; k < 3; ++k) {
        double rate = splits_per_second(&cells[k], planes);
        if (rate < 0)
            return 1;
        printf("\"%s\",%d,%d,%.0f\n", cells[k].name, (int)cells[k].nf, (int)cells[k].nn, rate);
    }
    return 0;
}
