/* Polynomials in local frames: a monomial of one element's frame rewritten in another frame
 * (a face's), and integrals of products from moments. DG face terms multiply basis functions of
 * two elements, each a monomial in its own frame; writing both in the face's frame makes every
 * face integral a combination of the face's moments, exact like the moments themselves. */
#include <pf/fem.h>

#include <math.h>
#include <pthread.h>

/* Exponents of every monomial of degree <= PF_MOMENT_MAX_DEGREE, and the index of the product of
 * two monomials of degree <= PF_MOMENT_MAX_DEGREE / 2, tabulated once. */
enum { HALF_COUNT = 35 }; /* pf_moment_count(PF_MOMENT_MAX_DEGREE / 2) */
static int exponents[PF_MOMENT_MAX_COUNT][3];
static int product_index[HALF_COUNT][HALF_COUNT];
static pthread_once_t tables_once = PTHREAD_ONCE_INIT;

static void build_tables(void)
{
    for (int k = 0; k < PF_MOMENT_MAX_COUNT; ++k)
        pf_moment_exponents(k, &exponents[k][0], &exponents[k][1], &exponents[k][2]);
    for (int p = 0; p < HALF_COUNT; ++p)
        for (int q = 0; q < HALF_COUNT; ++q)
            product_index[p][q] =
                pf_moment_index(exponents[p][0] + exponents[q][0],
                                exponents[p][1] + exponents[q][1],
                                exponents[p][2] + exponents[q][2]);
}

static void ensure_tables(void)
{
    pthread_once(&tables_once, build_tables);
}

static double binomial(int n, int k)
{
    double r = 1;
    for (int i = 1; i <= k; ++i)
        r = r * (n - k + i) / i;
    return r;
}

/* Coefficients of (alpha t + beta)^n in powers of t: c[i] = C(n, i) alpha^i beta^(n - i). */
static void binomial_powers(int n, double alpha, double beta, double *c)
{
    for (int i = 0; i <= n; ++i)
        c[i] = binomial(n, i) * pow(alpha, i) * pow(beta, n - i);
}

void pf_poly_monomial_in_frame(int index, const pf_frame *from, const pf_frame *to, double *out)
{
    ensure_tables();
    const int *e = exponents[index];
    int degree = e[0] + e[1] + e[2];
    /* xhat_from = alpha xhat_to + beta, per axis */
    double alpha = to->scale / from->scale;
    double beta[3] = {(to->center.x - from->center.x) / from->scale,
                      (to->center.y - from->center.y) / from->scale,
                      (to->center.z - from->center.z) / from->scale};
    double c[3][PF_MOMENT_MAX_DEGREE + 1];
    for (int axis = 0; axis < 3; ++axis)
        binomial_powers(e[axis], alpha, beta[axis], c[axis]);
    for (int k = 0; k < pf_moment_count(degree); ++k)
        out[k] = 0;
    for (int i = 0; i <= e[0]; ++i)
        for (int j = 0; j <= e[1]; ++j)
            for (int l = 0; l <= e[2]; ++l)
                out[pf_moment_index(i, j, l)] += c[0][i] * c[1][j] * c[2][l];
}

double pf_poly_integrate_product(const double *p, int deg_p, const double *q, int deg_q,
                                 const double *m)
{
    ensure_tables();
    int np = pf_moment_count(deg_p), nq = pf_moment_count(deg_q);
    double sum = 0;
    for (int i = 0; i < np; ++i) {
        if (p[i] == 0)
            continue;
        double row = 0;
        for (int j = 0; j < nq; ++j)
            row += q[j] * m[product_index[i][j]];
        sum += p[i] * row;
    }
    return sum;
}
