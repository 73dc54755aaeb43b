/* Exact polyhedral moments: speed and accuracy by cell shape and degree.
 *
 * CSV on stdout: cell,faces,degree,moments_per_second,max_rel_error
 * after one comment line "# ..." describing the machine. The hex, tet and L-prism sit at
 * (1e4, 1e4, 1e4); the sliced-sphere cell stays at the origin, because its clipped nodes are not
 * representable at 1e4: rounding them there bends its facets by ~1e-12, and the fan-triangle
 * reference and the plane of the face then describe different solids (3.7e-14 apart at degree 1,
 * an input effect, not an integration error). Every cell is integrated in its own frame
 * (pf_frame_of_polyhedron). moments_per_second counts all
 * pf_moment_count(degree) moments one pf_polyhedron_moments call returns. max_rel_error is the
 * largest |m - reference| / (|volume| rho^d) over the moments of degree d <= degree (rho = the
 * largest local coordinate of a node; the same measure as tests/test_integrate.c: odd moments
 * can vanish, so errors are taken relative to a bound on int |monomial|). The reference is
 * independent of the divergence-theorem code: the cell is cut into signed tetrahedra (faces
 * fanned, coned to the frame centre), and each tet's moments are the simplex formula
 * int xi^a eta^b zeta^c = a! b! c! / (a+b+c+3)! pulled back through the tet's affine map, whose
 * polynomial is expanded in long double. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/integrate.h>

#include "machine.h"

#define COUNT PF_MOMENT_MAX_COUNT
#define DMAX  PF_MOMENT_MAX_DEGREE

typedef long double real;

/* ---- a polyhedron as faces of explicit points (each face owns copies of its nodes) ---------- */

enum { MAX_FACES = 64, MAX_POINTS = 1024, MAX_FACE_POINTS = 32 };

typedef struct soup {
    double x[3 * MAX_POINTS];
    uint32_t nodes[MAX_POINTS];
    int64_t offsets[MAX_FACES + 1];
    int32_t n_faces;
} soup;

static void soup_face(soup *s, int n, const pf_vec3 *p)
{
    int64_t k = s->offsets[s->n_faces];
    if (s->n_faces >= MAX_FACES || k + n > MAX_POINTS) {
        fprintf(stderr, "bench_integrate: cell too large\n");
        exit(1);
    }
    for (int i = 0; i < n; ++i) {
        pf_v3_store(p[i], s->x + 3 * (k + i));
        s->nodes[k + i] = (uint32_t)(k + i);
    }
    s->offsets[++s->n_faces] = k + n;
}

static pf_vec3 soup_point(const soup *s, int64_t k)
{
    return pf_v3_load(s->x + 3 * k);
}

static pf_polyhedron soup_view(const soup *s)
{
    return (pf_polyhedron){s->x, s->n_faces, s->offsets, s->nodes};
}

static void soup_box(soup *s, pf_vec3 lo, pf_vec3 hi)
{
    static const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                    {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    memset(s, 0, sizeof *s);
    for (int f = 0; f < 6; ++f) {
        pf_vec3 p[4];
        for (int j = 0; j < 4; ++j) {
            int i = faces[f][j];
            p[j] = pf_v3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
        }
        soup_face(s, 4, p);
    }
}

static void soup_tet(soup *s, const pf_vec3 v[4])
{
    static const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    memset(s, 0, sizeof *s);
    for (int f = 0; f < 4; ++f) {
        pf_vec3 p[3] = {v[faces[f][0]], v[faces[f][1]], v[faces[f][2]]};
        soup_face(s, 3, p);
    }
}

/* The prism over the L [0,2]x[0,1] u [0,1]x[1,2], height 2, moved by t. */
static void soup_L_prism(soup *s, pf_vec3 t)
{
    static const double l[] = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
    memset(s, 0, sizeof *s);
    pf_vec3 bottom[6], top[6];
    for (int i = 0; i < 6; ++i) {
        bottom[5 - i] = pf_v3_add(t, pf_v3(l[2 * i], l[2 * i + 1], 0));
        top[i] = pf_v3_add(t, pf_v3(l[2 * i], l[2 * i + 1], 2));
    }
    soup_face(s, 6, bottom);
    soup_face(s, 6, top);
    for (int i = 0; i < 6; ++i) {
        int j = (i + 1) % 6;
        pf_vec3 side[4] = {top[i], top[j], top[j], top[i]};
        side[0].z = side[1].z = t.z;
        soup_face(s, 4, side);
    }
}

/* Keeps the part of the convex soup with dot(n, x) <= d; the cut closes with one face whose
 * nodes are the crossing points, ordered counter-clockwise about n. */
static void soup_clip(soup *s, pf_vec3 n, double d)
{
    soup out;
    memset(&out, 0, sizeof out);
    pf_vec3 cap[MAX_FACE_POINTS * 4];
    int n_cap = 0;
    const double eps = 1e-12;
    for (int32_t f = 0; f < s->n_faces; ++f) {
        pf_vec3 poly[MAX_FACE_POINTS];
        int m = 0;
        int64_t k0 = s->offsets[f], k1 = s->offsets[f + 1];
        for (int64_t k = k0; k < k1; ++k) {
            pf_vec3 a = soup_point(s, k), b = soup_point(s, k + 1 < k1 ? k + 1 : k0);
            double sa = pf_v3_dot(n, a) - d, sb = pf_v3_dot(n, b) - d;
            if (sa <= eps)
                poly[m++] = a;
            if (fabs(sa) <= eps && n_cap < MAX_FACE_POINTS * 4)
                cap[n_cap++] = a;
            if ((sa < -eps && sb > eps) || (sa > eps && sb < -eps)) {
                pf_vec3 c = pf_v3_add(a, pf_v3_scale(pf_v3_sub(b, a), sa / (sa - sb)));
                poly[m++] = c;
                cap[n_cap++] = c;
            }
        }
        if (m >= 3)
            soup_face(&out, m, poly);
    }
    /* the cap: distinct crossing points sorted by angle about their mean, in a basis (u, v)
     * with u x v = n, so counter-clockwise seen from outside */
    pf_vec3 pts[MAX_FACE_POINTS], mean = pf_v3(0, 0, 0);
    int np = 0;
    for (int i = 0; i < n_cap; ++i) {
        int dup = 0;
        for (int j = 0; j < np; ++j)
            dup |= pf_v3_dist(cap[i], pts[j]) <= 1e-9;
        if (!dup && np < MAX_FACE_POINTS) {
            pts[np++] = cap[i];
            mean = pf_v3_add(mean, cap[i]);
        }
    }
    if (np >= 3) {
        mean = pf_v3_scale(mean, 1.0 / np);
        pf_vec3 u = pf_v3_normalize(pf_v3_sub(pts[0], mean)), v = pf_v3_cross(n, u);
        double angle[MAX_FACE_POINTS];
        for (int i = 0; i < np; ++i) {
            pf_vec3 r = pf_v3_sub(pts[i], mean);
            angle[i] = atan2(pf_v3_dot(r, v), pf_v3_dot(r, u));
        }
        for (int i = 1; i < np; ++i) /* insertion sort by angle */
            for (int j = i; j > 0 && angle[j] < angle[j - 1]; --j) {
                double ta = angle[j];
                angle[j] = angle[j - 1], angle[j - 1] = ta;
                pf_vec3 tp = pts[j];
                pts[j] = pts[j - 1], pts[j - 1] = tp;
            }
        soup_face(&out, np, pts);
    }
    *s = out;
}

/* A boundary cell of a sliced sphere: the cube [-1,1]^3 cut by the tangent planes of a sphere
 * of radius 1.3 at 20 Fibonacci directions (those that reach into the cube become facets),
 * moved by t. */
static void soup_sliced_sphere(soup *s, pf_vec3 t)
{
    soup_box(s, pf_v3(-1, -1, -1), pf_v3(1, 1, 1));
    const int n_dir = 20;
    const double golden = 3.14159265358979323846 * (3 - sqrt(5.0));
    for (int i = 0; i < n_dir; ++i) {
        double z = 1 - (2 * i + 1.0) / n_dir, r = sqrt(1 - z * z);
        pf_vec3 n = pf_v3(r * cos(golden * i), r * sin(golden * i), z);
        soup_clip(s, n, 1.3);
    }
    for (int64_t k = 0; k < s->offsets[s->n_faces]; ++k)
        pf_v3_store(pf_v3_add(soup_point(s, k), t), s->x + 3 * k);
}

/* ---- reference: signed tets, simplex formula through the affine map, long double ------------ */

typedef struct tables {
    int expo[COUNT][3];
    int index[DMAX + 1][DMAX + 1][DMAX + 1];
    real simplex[COUNT]; /* a! b! c! / (a+b+c+3)! */
} tables;

static real factorial(int n)
{
    real f = 1;
    for (int k = 2; k <= n; ++k)
        f *= k;
    return f;
}

static void build_tables(tables *t)
{
    int i = 0;
    for (int d = 0; d <= DMAX; ++d)
        for (int a = d; a >= 0; --a)
            for (int b = d - a; b >= 0; --b, ++i) {
                int c = d - a - b;
                t->expo[i][0] = a, t->expo[i][1] = b, t->expo[i][2] = c;
                t->index[a][b][c] = i;
                t->simplex[i] = factorial(a) * factorial(b) * factorial(c) / factorial(d + 3);
            }
}

/* Adds the moments of the tet (p0, p1, p2, p3), signed by its orientation, to out. coef is
 * scratch of COUNT x COUNT: coef[i] = the polynomial in xi of monomial i of xhat = o + A xi. */
static void add_tet(const tables *t, const pf_frame *fr, pf_vec3 p0, pf_vec3 p1, pf_vec3 p2,
                    pf_vec3 p3, real (*coef)[COUNT], real *out)
{
    const pf_vec3 p[3] = {p1, p2, p3};
    real o[3] = {((real)p0.x - fr->center.x) / fr->scale, ((real)p0.y - fr->center.y) / fr->scale,
                 ((real)p0.z - fr->center.z) / fr->scale};
    real a[3][3];
    for (int j = 0; j < 3; ++j) {
        a[0][j] = ((real)p[j].x - p0.x) / fr->scale;
        a[1][j] = ((real)p[j].y - p0.y) / fr->scale;
        a[2][j] = ((real)p[j].z - p0.z) / fr->scale;
    }
    real det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
               a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
               a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    real volume_unit = (real)fr->scale * fr->scale * fr->scale;
    memset(coef, 0, sizeof(real) * COUNT * COUNT);
    coef[0][0] = 1;
    int lower = 1; /* monomials of degree < the current one */
    for (int i = 1; i < COUNT; ++i) {
        int e[3] = {t->expo[i][0], t->expo[i][1], t->expo[i][2]};
        int d = e[0] + e[1] + e[2];
        lower = d * (d + 1) * (d + 2) / 6;
        int v = e[0] > 0 ? 0 : e[1] > 0 ? 1 : 2;
        e[v] -= 1;
        const real *parent = coef[t->index[e[0]][e[1]][e[2]]];
        for (int k = 0; k < lower; ++k) {
            if (parent[k] == 0)
                continue;
            coef[i][k] += o[v] * parent[k];
            const int *f = t->expo[k];
            coef[i][t->index[f[0] + 1][f[1]][f[2]]] += a[v][0] * parent[k];
            coef[i][t->index[f[0]][f[1] + 1][f[2]]] += a[v][1] * parent[k];
            coef[i][t->index[f[0]][f[1]][f[2] + 1]] += a[v][2] * parent[k];
        }
    }
    for (int i = 0; i < COUNT; ++i) {
        real s = 0;
        for (int k = 0; k < COUNT; ++k)
            s += coef[i][k] * t->simplex[k];
        out[i] += volume_unit * det * s;
    }
}

static void reference_moments(const tables *t, const soup *s, const pf_frame *fr, real *out)
{
    real(*coef)[COUNT] = malloc(sizeof(real) * COUNT * COUNT);
    if (!coef) {
        fprintf(stderr, "bench_integrate: out of memory\n");
        exit(1);
    }
    memset(out, 0, sizeof(real) * COUNT);
    for (int32_t f = 0; f < s->n_faces; ++f) {
        int64_t k0 = s->offsets[f];
        for (int64_t k = k0 + 1; k + 1 < s->offsets[f + 1]; ++k)
            add_tet(t, fr, fr->center, soup_point(s, k0), soup_point(s, k), soup_point(s, k + 1),
                    coef, out);
    }
    free(coef);
}

/* ---- measurement --------------------------------------------------------------------------- */

static double local_radius(const soup *s, const pf_frame *fr)
{
    double r = 0;
    for (int64_t k = 0; k < s->offsets[s->n_faces]; ++k)
        r = fmax(r, pf_v3_max_abs(pf_v3_sub(soup_point(s, k), fr->center)) / fr->scale);
    return r;
}

static void machine_line(void)
{
    char machine[512];
    bench_describe_machine(machine, sizeof machine);
    printf("# %s; single thread\n", machine);
}

static double sink; /* keeps the timed calls observable */

static void bench_cell(const tables *t, const char *name, const soup *s)
{
    pf_polyhedron p = soup_view(s);
    pf_frame fr = pf_frame_of_polyhedron(&p);
    real ref[COUNT];
    reference_moments(t, s, &fr, ref);
    double rho = local_radius(s, &fr);
    double m[COUNT];
    pf_error err = {0};
    for (int degree = 0; degree <= DMAX; ++degree) {
        if (pf_polyhedron_moments(&p, &fr, degree, m, &err) != PF_OK) {
            fprintf(stderr, "bench_integrate: %s: %s\n", name, err.msg);
            exit(1);
        }
        double worst = 0;
        for (int i = 0; i < pf_moment_count(degree); ++i) {
            int d = t->expo[i][0] + t->expo[i][1] + t->expo[i][2];
            double bound = fabs((double)ref[0]) * pow(rho, d);
            worst = fmax(worst, (double)(fabsl((real)m[i] - ref[i]) / bound));
        }
        long calls = 0;
        double t0 = pf_time_seconds(), elapsed = 0;
        while (elapsed < 0.2) {
            for (int r = 0; r < 64; ++r, ++calls) {
                pf_polyhedron_moments(&p, &fr, degree, m, &err);
                sink += m[0];
            }
            elapsed = pf_time_seconds() - t0;
        }
        printf("%s,%d,%d,%.4g,%.3g\n", name, (int)s->n_faces, degree,
               (double)calls * pf_moment_count(degree) / elapsed, worst);
        fflush(stdout);
    }
}

int main(void)
{
    static tables t;
    static soup s;
    build_tables(&t);
    const pf_vec3 offset = pf_v3(1e4, 1e4, 1e4);
    machine_line();
    printf("cell,faces,degree,moments_per_second,max_rel_error\n");
    soup_box(&s, offset, pf_v3_add(offset, pf_v3(1, 0.75, 0.5)));
    bench_cell(&t, "hex", &s);
    const pf_vec3 tet[4] = {offset, pf_v3_add(offset, pf_v3(1, 0.1, 0.2)),
                            pf_v3_add(offset, pf_v3(0.3, 0.9, -0.1)),
                            pf_v3_add(offset, pf_v3(0.2, 0.3, 0.8))};
    soup_tet(&s, tet);
    bench_cell(&t, "tet", &s);
    soup_L_prism(&s, offset);
    bench_cell(&t, "L-prism", &s);
    soup_sliced_sphere(&s, pf_v3(0, 0, 0));
    bench_cell(&t, "sliced-sphere", &s);
    fprintf(stderr, "bench_integrate: checksum %.17g\n", sink);
    return 0;
}
