/* Graded monomial ordering, monomial evaluation, and the element frame.
 *
 * Ordering: block d holds the (d+1)(d+2)/2 monomials of degree d and starts at
 * count(d - 1) = d(d+1)(d+2)/6. Inside the block x^a y^b z^c comes by descending a, then
 * descending b; the monomials with a > a' number sum_{k=0}^{d-a-1} (k+1) = (d-a)(d-a+1)/2, and
 * for fixed a the position is (d - a) - b = c, so index = d(d+1)(d+2)/6 + (d-a)(d-a+1)/2 + c.
 *
 * Evaluation: the monomials of block d with a >= 1 are x times block d-1 in its own order, the
 * next d (a = 0, b >= 1) are y times the last d of block d-1, (0, b-1, c), and the last is
 * z times z^(d-1). One multiplication per monomial. */
#include <math.h>

#include <pf/integrate.h>

int pf_moment_count(int degree)
{
    if (degree < 0)
        return 0;
    return (degree + 1) * (degree + 2) * (degree + 3) / 6;
}

int pf_moment_index(int a, int b, int c)
{
    if (a < 0 || b < 0 || c < 0)
        return -1;
    int d = a + b + c;
    return d * (d + 1) * (d + 2) / 6 + (d - a) * (d - a + 1) / 2 + c;
}

void pf_moment_exponents(int index, int *a, int *b, int *c)
{
    *a = *b = *c = -1;
    if (index < 0 || index >= pf_moment_count(PF_MOMENT_MAX_DEGREE))
        return;
    int d = 0;
    while (pf_moment_count(d) <= index)
        ++d;
    int pos = index - pf_moment_count(d - 1);
    int k = 0; /* k = d - a: block positions (k)(k+1)/2 .. (k+1)(k+2)/2 - 1 share a */
    while ((k + 1) * (k + 2) / 2 <= pos)
        ++k;
    *c = pos - k * (k + 1) / 2;
    *a = d - k;
    *b = k - *c;
}

void pf_moment_monomials(pf_vec3 p, int degree, double *v)
{
    v[0] = 1;
    for (int d = 1; d <= degree; ++d) {
        int prev = pf_moment_count(d - 2), prev_n = d * (d + 1) / 2; /* block d-1 */
        int cur = pf_moment_count(d - 1);
        for (int i = 0; i < prev_n; ++i)
            v[cur + i] = p.x * v[prev + i];
        for (int j = 0; j < d; ++j)
            v[cur + prev_n + j] = p.y * v[prev + prev_n - d + j];
        v[cur + prev_n + d] = p.z * v[prev + prev_n - 1];
    }
}

pf_frame pf_frame_of_polyhedron(const pf_polyhedron *p)
{
    pf_vec3 lo, hi;
    pf_polyhedron_bounds(p, &lo, &hi);
    pf_vec3 half = pf_v3_scale(pf_v3_sub(hi, lo), 0.5);
    double scale = pf_v3_norm(half);
    pf_frame f = {pf_v3_add(lo, half), scale > 0 && isfinite(scale) ? scale : 1.0};
    return f;
}
