/* DG set-up: everything that depends on the mesh and the material only, computed once per
 * topology. Element terms come from the element's own moments (a derivative of a monomial is a
 * monomial, so every element integral is one moment); face terms from the face's moments after
 * writing both elements' basis functions in the face's frame. */
#include <pf/fem.h>

#include "fem_internal.h"

#include <math.h>
#include <string.h>

void pf_lame(double E, double nu, double *lambda, double *mu)
{
    *mu = E / (2 * (1 + nu));
    *lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
}

void pf_dg_release(pf_dg *dg)
{
    pf_free(dg->frame);
    pf_free(dg->volume);
    pf_free(dg->centroid);
    pf_free(dg->ke);
    pf_free(dg->me);
    pf_free(dg->phi_int);
    pf_free(dg->faces);
    pf_free(dg->face_slot);
    pf_free(dg->face_storage);
    pf_free(dg->node_offsets);
    pf_free(dg->node_elem);
    pf_free(dg->node_phi);
    pf_free(dg->materials);
    pf_free(dg->elem_material);
    memset(dg, 0, sizeof *dg);
}

static void exponents_of(int index, int e[3])
{
    pf_moment_exponents(index, &e[0], &e[1], &e[2]);
}

/* int_K d_i phi_a d_k phi_b = e_a[i] e_b[k] / h^2 times the moment of the product of the two
 * lowered monomials. */
static double gradient_product(const double *m, double h, int a, int i, int b, int k)
{
    int ea[3], eb[3];
    exponents_of(a, ea);
    exponents_of(b, eb);
    if (ea[i] == 0 || eb[k] == 0)
        return 0;
    double factor = (double)ea[i] * eb[k] / (h * h);
    ea[i]--;
    eb[k]--;
    return factor * m[pf_moment_index(ea[0] + eb[0], ea[1] + eb[1], ea[2] + eb[2])];
}

/* K[(a, i), (b, k)] = lambda D(a i, b k) + mu (delta_ik sum_j D(a j, b j) + D(a k, b i)), the
 * isotropic form of int B^T C B (sec. 4.2, eq. 23). */
static void element_stiffness(const pf_dg *dg, const pf_material *mat, const double *m, double h,
                              double *ke)
{
    int nb = dg->nb, n = 3 * nb;
    for (int a = 0; a < nb; ++a)
        for (int b = 0; b < nb; ++b) {
            double d[3][3];
            for (int i = 0; i < 3; ++i)
                for (int k = 0; k < 3; ++k)
                    d[i][k] = gradient_product(m, h, a, i, b, k);
            double trace = d[0][0] + d[1][1] + d[2][2];
            for (int i = 0; i < 3; ++i)
                for (int k = 0; k < 3; ++k)
                    ke[(3 * a + i) * n + 3 * b + k] =
                        mat->lambda * d[i][k] + mat->mu * ((i == k ? trace : 0) + d[k][i]);
        }
}

static void element_mass(const pf_dg *dg, double density, const double *m, double *me,
                         double *phi_int)
{
    int nb = dg->nb;
    for (int a = 0; a < nb; ++a) {
        int ea[3];
        exponents_of(a, ea);
        phi_int[a] = m[a];
        for (int b = 0; b < nb; ++b) {
            int eb[3];
            exponents_of(b, eb);
            me[a * nb + b] =
                density * m[pf_moment_index(ea[0] + eb[0], ea[1] + eb[1], ea[2] + eb[2])];
        }
    }
}

/* Element e's terms copied from element p of old (the same polyhedron). */
static void copy_element(pf_dg *dg, int32_t e, const pf_dg *old, int32_t p)
{
    size_t nb = (size_t)dg->nb, n = 3 * nb;
    dg->frame[e] = old->frame[p];
    dg->volume[e] = old->volume[p];
    memcpy(dg->centroid + 3 * (size_t)e, old->centroid + 3 * (size_t)p, 3 * sizeof(double));
    memcpy(dg->ke + (size_t)e * n * n, old->ke + (size_t)p * n * n, n * n * sizeof(double));
    memcpy(dg->me + (size_t)e * nb * nb, old->me + (size_t)p * nb * nb, nb * nb * sizeof(double));
    memcpy(dg->phi_int + (size_t)e * nb, old->phi_int + (size_t)p * nb, nb * sizeof(double));
}

static pf_status setup_elements(pf_dg *dg, const pf_mesh *mesh, const pf_dg_reuse *reuse,
                                const pf_progress_hook *progress, pf_arena *arena, pf_error *err)
{
    int nb = dg->nb, n = 3 * nb;
    double m[PF_MOMENT_MAX_COUNT];
    pf_progress_post(progress, "element integrals", 0, mesh->n_elems);
    for (int32_t e = 0; e < mesh->n_elems; ++e) {
        if (e > 0)
            pf_progress_post(progress, "element integrals", e, mesh->n_elems);
        if (reuse && reuse->same_solid[e]) {
            copy_element(dg, e, reuse->old, reuse->parent[e]);
            dg->reused_elems++;
            continue;
        }
        size_t mark = pf_arena_mark(arena);
        pf_polyhedron p;
        PF_TRY(pf_mesh_elem_polyhedron(mesh, e, arena, &p, err));
        pf_frame fr = pf_frame_of_polyhedron(&p);
        pf_status s = pf_polyhedron_moments(&p, &fr, 2 * dg->degree, m, err);
        pf_arena_reset(arena, mark);
        if (s < 0) {
            pf_error_prefix(err, "element %d", (int)e);
            return s;
        }
        PF_CHECK(m[0] > 0, err, PF_ERR_INVALID, "element %d has volume %g", (int)e, m[0]);
        dg->frame[e] = fr;
        dg->volume[e] = m[0];
        dg->centroid[3 * e + 0] = fr.center.x + fr.scale * m[1] / m[0];
        dg->centroid[3 * e + 1] = fr.center.y + fr.scale * m[2] / m[0];
        dg->centroid[3 * e + 2] = fr.center.z + fr.scale * m[3] / m[0];
        const pf_material *mat = pf_dg_material(dg, e);
        element_stiffness(dg, mat, m, fr.scale, dg->ke + (size_t)e * n * n);
        element_mass(dg, mat->density, m, dg->me + (size_t)e * nb * nb,
                     dg->phi_int + (size_t)e * nb);
    }
    if (mesh->n_elems > 0)
        pf_progress_post(progress, "element integrals", mesh->n_elems, mesh->n_elems);
    return PF_OK;
}

/* The face's frame: centre and half diagonal of its nodes' bounding box. */
static pf_frame face_frame(const pf_mesh *mesh, int32_t f)
{
    pf_vec3 lo = {INFINITY, INFINITY, INFINITY}, hi = {-INFINITY, -INFINITY, -INFINITY};
    for (int64_t k = mesh->face_offsets[f]; k < mesh->face_offsets[f + 1]; ++k) {
        const double *x = mesh->x + 3 * (size_t)mesh->face_nodes[k];
        lo = (pf_vec3){fmin(lo.x, x[0]), fmin(lo.y, x[1]), fmin(lo.z, x[2])};
        hi = (pf_vec3){fmax(hi.x, x[0]), fmax(hi.y, x[1]), fmax(hi.z, x[2])};
    }
    pf_frame fr = {pf_v3_scale(pf_v3_add(lo, hi), 0.5), 0.5 * pf_v3_norm(pf_v3_sub(hi, lo))};
    if (!(fr.scale > 0))
        fr.scale = 1;
    return fr;
}

/* Basis functions of element e and their derivatives, written in the face frame: basis[a] has
 * count(p) coefficients, deriv[a][j] count(p - 1) (padded to count(p)). */
static void basis_in_face_frame(const pf_dg *dg, int32_t e, const pf_frame *ff, double *basis,
                                double *deriv)
{
    int nb = dg->nb;
    const pf_frame *fe = &dg->frame[e];
    memset(basis, 0, (size_t)nb * nb * sizeof *basis);
    for (int a = 0; a < nb; ++a) {
        pf_poly_monomial_in_frame(a, fe, ff, basis + a * nb); /* writes count(deg a) entries */
        int ea[3];
        exponents_of(a, ea);
        for (int j = 0; j < 3; ++j) {
            double *d = deriv + (a * 3 + j) * nb;
            memset(d, 0, (size_t)nb * sizeof *d);
            if (ea[j] == 0)
                continue;
            int lowered[3] = {ea[0], ea[1], ea[2]};
            lowered[j]--;
            pf_poly_monomial_in_frame(pf_moment_index(lowered[0], lowered[1], lowered[2]), fe, ff,
                                      d);
            double factor = ea[j] / fe->scale;
            for (int k = 0; k < nb; ++k)
                d[k] *= factor;
        }
    }
}

/* BZ's penalty growth (Babuska and Zlamal 1973: an inconsistent penalty method converges when
 * its penalty grows faster than 1 / h). With the face weight eta h^-b, sec. 3.3's missing
 * consistency term costs a squared energy error of order h^(b - 1) / eta (Strang's lemma: the
 * normal stress, of order h^-1/2 on the faces of a unit volume, against jumps that the penalty
 * bounds by (h^b / eta)^1/2 of the energy), while the jumps of the element-wise polynomial
 * approximation of degree p (h^(p+1)) cost eta h^(2p+1-b). The super-penalty b = 2p + 1 of the
 * literature (Arnold, Brezzi, Cockburn and Marini 2002) leaves the second term O(1): it needs
 * continuous fields of the space that approximate to full order, as continuous P_p fields do on
 * simplices. On hexahedra and general polyhedra they do not (the continuous degree-1 fields of
 * a hex mesh cannot bend: at the largest penalty of bench_dg bzpenalty the cantilever is 96 %
 * too stiff on every mesh), so pf balances the two terms: b = p + 1, both O(h^p), the factor
 * (L / h_f)^p on top of eq. 20's 1 / h. Measured (tests/test_sim.c, bench_dg bzconverge): the
 * cantilever's error falls by 0.29 and 0.26 per halving of h at degree 1, by 0.13 and 0.09 at
 * degree 2. L is the body's length, fixed under refinement, so eta stays dimensionless;
 * h_f = sides / eta_geometry is the harmonic mean of vol / area over the face's elements (the
 * edge of a cube). */
static double bz_growth(const pf_dg *dg, double eta_geometry, int sides)
{
    return pow(dg->body_length * eta_geometry / sides, dg->degree);
}

static pf_status setup_face(pf_dg *dg, const pf_mesh *mesh, int32_t f, int32_t left, int32_t right,
                            double sign, pf_dg_face *out, pf_error *err)
{
    int nb = dg->nb, p = dg->degree;
    const uint32_t *idx = mesh->face_nodes + mesh->face_offsets[f];
    int64_t count = mesh->face_offsets[f + 1] - mesh->face_offsets[f];
    pf_frame ff = face_frame(mesh, f);
    double m[PF_MOMENT_MAX_COUNT];
    PF_TRY(pf_polygon_moments(mesh->x, idx, count, &ff, 2 * p, m, err));
    pf_vec3 area_vector = pf_polygon_area_vector(mesh->x, idx, count);
    double area = pf_v3_norm(area_vector);
    PF_CHECK(area > 0 && m[0] > 0, err, PF_ERR_INVALID, "face %d has no area", (int)f);
    out->face = f;
    out->elem[0] = left;
    out->elem[1] = right;
    out->normal = pf_v3_scale(area_vector, sign / area);
    out->area = m[0];
    out->centroid =
        (pf_vec3){ff.center.x + ff.scale * m[1] / m[0], ff.center.y + ff.scale * m[2] / m[0],
                  ff.center.z + ff.scale * m[3] / m[0]};
    out->eta_geometry = m[0] * (1 / dg->volume[left] + (right >= 0 ? 1 / dg->volume[right] : 0));
    out->bz_growth = bz_growth(dg, out->eta_geometry, right >= 0 ? 2 : 1);

    double basis[2][10 * 10], deriv[2][10 * 3 * 10];
    int sides = right >= 0 ? 2 : 1;
    for (int s = 0; s < sides; ++s)
        basis_in_face_frame(dg, out->elem[s], &ff, basis[s], deriv[s]);
    for (int s = 0; s < sides; ++s)
        for (int t = 0; t < sides; ++t)
            for (int a = 0; a < nb; ++a)
                for (int b = 0; b < nb; ++b) {
                    size_t st = (size_t)((s * 2 + t) * nb + a) * nb + b;
                    out->S[st] =
                        pf_poly_integrate_product(basis[s] + a * nb, p, basis[t] + b * nb, p, m);
                    for (int j = 0; j < 3; ++j)
                        out->G[3 * st + j] = pf_poly_integrate_product(
                            basis[s] + a * nb, p, deriv[t] + (b * 3 + j) * nb, p - 1, m);
                }
    return PF_OK;
}

/* Whether old face g has the old elements of left and right in the same roles. */
static bool same_roles(const pf_dg_reuse *reuse, int32_t g, int32_t left, int32_t right)
{
    const pf_mesh *om = reuse->old_mesh;
    int32_t a = om->face_elems[2 * g], b = om->face_elems[2 * g + 1];
    int32_t old_left = a >= 0 ? a : b, old_right = a >= 0 ? b : -1;
    return old_left == reuse->parent[left] && old_right == (right >= 0 ? reuse->parent[right] : -1);
}

/* The face of old with the same polygon and the same elements in the same roles as face f of
 * mesh, or -1. With reuse->face_src (refinement): that face, when both elements are their
 * parents' solids (their frames, so their basis functions, are the old ones). Without: when
 * both elements have their parents' faces node for node (reuse->same_faces), f is, in its
 * element's face list, where the old face is in the parent's. */
static int32_t old_face_of(const pf_mesh *mesh, int32_t f, int32_t left, int32_t right,
                           const pf_dg_reuse *reuse)
{
    if (!reuse)
        return -1;
    if (reuse->face_src) {
        int32_t g = reuse->face_src[f];
        bool solids = reuse->same_solid[left] && (right < 0 || reuse->same_solid[right]);
        return g >= 0 && solids && same_roles(reuse, g, left, right) ? g : -1;
    }
    if (!reuse->same_faces[left] || (right >= 0 && !reuse->same_faces[right]))
        return -1;
    const pf_mesh *om = reuse->old_mesh;
    int32_t p = reuse->parent[left];
    int64_t n = mesh->elem_offsets[left + 1] - mesh->elem_offsets[left];
    for (int64_t k = 0; k < n; ++k) {
        if (PF_FACE_INDEX(mesh->elem_faces[mesh->elem_offsets[left] + k]) != f)
            continue;
        int32_t g = PF_FACE_INDEX(om->elem_faces[om->elem_offsets[p] + k]);
        return same_roles(reuse, g, left, right) ? g : -1;
    }
    return -1;
}

/* Face f's terms copied from the old face g (the same polygon between the same elements). */
static void copy_face(const pf_dg *dg, pf_dg_face *out, int32_t f, int32_t left, int32_t right,
                      const pf_dg *old, int32_t g)
{
    const pf_dg_face *in = &old->faces[old->face_slot[g]];
    size_t nb = (size_t)dg->nb;
    double *S = out->S, *G = out->G;
    *out = *in;
    out->S = S;
    out->G = G;
    out->face = f;
    out->elem[0] = left;
    out->elem[1] = right;
    memcpy(S, in->S, 4 * nb * nb * sizeof *S);
    memcpy(G, in->G, 12 * nb * nb * sizeof *G);
}

static pf_status setup_faces(pf_dg *dg, const pf_mesh *mesh, const pf_dg_reuse *reuse,
                             const pf_progress_hook *progress, pf_error *err)
{
    int nb = dg->nb;
    size_t per_face = 4 * (size_t)nb * nb * 4; /* S and G (3 per entry) */
    dg->faces = pf_calloc((size_t)mesh->n_faces, sizeof *dg->faces);
    dg->face_slot = pf_alloc_array((size_t)mesh->n_faces, sizeof *dg->face_slot);
    dg->face_storage = pf_alloc_array((size_t)mesh->n_faces * per_face, sizeof(double));
    PF_CHECK(dg->faces && dg->face_slot && (dg->face_storage || mesh->n_faces == 0), err,
             PF_ERR_NOMEM, "cannot allocate the terms of %d faces", (int)mesh->n_faces);
    dg->n_faces = mesh->n_faces;
    /* Interior faces first, then boundary faces. */
    int32_t slot = 0;
    pf_progress_post(progress, "face integrals", 0, mesh->n_faces);
    for (int pass = 0; pass < 2; ++pass)
        for (int32_t f = 0; f < mesh->n_faces; ++f) {
            int32_t a = mesh->face_elems[2 * f], b = mesh->face_elems[2 * f + 1];
            bool interior = a >= 0 && b >= 0;
            if (interior != (pass == 0))
                continue;
            pf_dg_face *out = &dg->faces[slot];
            dg->face_slot[f] = slot;
            out->S = dg->face_storage + (size_t)slot * per_face;
            out->G = out->S + 4 * (size_t)nb * nb;
            /* The stored orientation is outward for face_elems[2f]; a boundary face used only
             * reversed has its outward normal opposite to the stored one. */
            int32_t left = a >= 0 ? a : b, right = a >= 0 ? b : -1;
            int32_t g = old_face_of(mesh, f, left, right, reuse);
            if (g >= 0) {
                copy_face(dg, out, f, left, right, reuse->old, g);
                dg->reused_faces++;
            }
            pf_status s =
                g >= 0 ? PF_OK : setup_face(dg, mesh, f, left, right, a >= 0 ? 1 : -1, out, err);
            if (s < 0) {
                pf_error_prefix(err, "face %d", (int)f);
                return s;
            }
            ++slot;
            if (pass == 0)
                dg->n_interior = slot;
            if (slot < mesh->n_faces)
                pf_progress_post(progress, "face integrals", slot, mesh->n_faces);
        }
    if (mesh->n_faces > 0)
        pf_progress_post(progress, "face integrals", mesh->n_faces, mesh->n_faces);
    return PF_OK;
}

/* For every node, the elements using it and their basis values there. */
static pf_status setup_stitching(pf_dg *dg, const pf_mesh *mesh, pf_error *err)
{
    int nb = dg->nb;
    dg->n_nodes = mesh->n_nodes;
    int32_t *last = pf_alloc_array((size_t)mesh->n_nodes, sizeof *last); /* dedupe marker */
    dg->node_offsets = pf_calloc((size_t)mesh->n_nodes + 1, sizeof *dg->node_offsets);
    PF_CHECK(last && dg->node_offsets, err, PF_ERR_NOMEM, "cannot allocate node incidences");
    for (int pass = 0; pass < 2; ++pass) {
        for (int32_t i = 0; i < mesh->n_nodes; ++i)
            last[i] = -1;
        for (int32_t e = 0; e < mesh->n_elems; ++e)
            for (int64_t k = mesh->elem_offsets[e]; k < mesh->elem_offsets[e + 1]; ++k) {
                int32_t f = PF_FACE_INDEX(mesh->elem_faces[k]);
                for (int64_t q = mesh->face_offsets[f]; q < mesh->face_offsets[f + 1]; ++q) {
                    uint32_t node = mesh->face_nodes[q];
                    if (last[node] == e)
                        continue;
                    last[node] = e;
                    if (pass == 0) {
                        dg->node_offsets[node + 1]++;
                        continue;
                    }
                    int64_t at = dg->node_offsets[node]++;
                    dg->node_elem[at] = e;
                    const double *x = mesh->x + 3 * (size_t)node;
                    const pf_frame *fr = &dg->frame[e];
                    pf_vec3 local = {(x[0] - fr->center.x) / fr->scale,
                                     (x[1] - fr->center.y) / fr->scale,
                                     (x[2] - fr->center.z) / fr->scale};
                    pf_moment_monomials(local, dg->degree, dg->node_phi + at * nb);
                }
            }
        if (pass == 0) {
            for (int32_t i = 0; i < mesh->n_nodes; ++i)
                dg->node_offsets[i + 1] += dg->node_offsets[i];
            int64_t total = dg->node_offsets[mesh->n_nodes];
            dg->node_elem = pf_alloc_array((size_t)total, sizeof *dg->node_elem);
            dg->node_phi = pf_alloc_array((size_t)total * nb, sizeof *dg->node_phi);
            if (!dg->node_elem || !dg->node_phi) {
                pf_free(last);
                return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                    "cannot allocate %lld node incidences", (long long)total);
            }
        }
    }
    /* The second pass advanced each offset to the next node's start: shift back. */
    for (int32_t i = mesh->n_nodes; i > 0; --i)
        dg->node_offsets[i] = dg->node_offsets[i - 1];
    dg->node_offsets[0] = 0;
    pf_free(last);
    return PF_OK;
}

static pf_status allocate_elements(pf_dg *dg, pf_error *err)
{
    size_t ne = (size_t)dg->n_elems, nb = (size_t)dg->nb;
    dg->frame = pf_alloc_array(ne, sizeof *dg->frame);
    dg->volume = pf_alloc_array(ne, sizeof *dg->volume);
    dg->centroid = pf_alloc_array(3 * ne, sizeof *dg->centroid);
    dg->ke = pf_alloc_array(ne * 9 * nb * nb, sizeof *dg->ke);
    dg->me = pf_alloc_array(ne * nb * nb, sizeof *dg->me);
    dg->phi_int = pf_alloc_array(ne * nb, sizeof *dg->phi_int);
    PF_CHECK(ne == 0 ||
                 (dg->frame && dg->volume && dg->centroid && dg->ke && dg->me && dg->phi_int),
             err, PF_ERR_NOMEM, "cannot allocate the terms of %d elements", (int)dg->n_elems);
    return PF_OK;
}

pf_material pf_material_make(double E, double nu, double density)
{
    pf_material m = {.E = E, .nu = nu, .density = density};
    pf_lame(E, nu, &m.lambda, &m.mu);
    return m;
}

/* Copies the materials into *table and *elem (n_elems entries), checked. */
pf_status pf_fem_copy_materials(const pf_materials *mat, int32_t n_elems, pf_material **table,
                                int32_t **elem, pf_error *err)
{
    PF_CHECK(mat && mat->n >= 1 && mat->table, err, PF_ERR_INVALID, "no material");
    for (int32_t k = 0; k < mat->n; ++k) {
        double E = mat->table[k].E, nu = mat->table[k].nu, rho = mat->table[k].density;
        PF_CHECK(E > 0 && isfinite(E) && nu > -1 && nu < 0.5 && rho > 0 && isfinite(rho), err,
                 PF_ERR_INVALID, "bad material %d: E = %g, nu = %g, density = %g", (int)k, E, nu,
                 rho);
    }
    *table = pf_alloc_array((size_t)mat->n, sizeof **table);
    *elem = pf_calloc((size_t)n_elems + 1, sizeof **elem);
    PF_CHECK(*table && *elem, err, PF_ERR_NOMEM, "cannot allocate the materials");
    for (int32_t k = 0; k < mat->n; ++k)
        (*table)[k] = pf_material_make(mat->table[k].E, mat->table[k].nu, mat->table[k].density);
    for (int32_t e = 0; mat->elem && e < n_elems; ++e) {
        PF_CHECK(mat->elem[e] >= 0 && mat->elem[e] < mat->n, err, PF_ERR_INVALID,
                 "element %d has material %d of %d", (int)e, (int)mat->elem[e], (int)mat->n);
        (*elem)[e] = mat->elem[e];
    }
    return PF_OK;
}

void pf_material_stiffest(const pf_material *table, int32_t n, double *modulus,
                          double *modulus_per_density)
{
    *modulus = *modulus_per_density = 0;
    for (int32_t k = 0; k < n; ++k) {
        const pf_material *m = &table[k];
        *modulus = fmax(*modulus, m->lambda + 2 * m->mu);
        *modulus_per_density = fmax(*modulus_per_density, (m->lambda + 2 * m->mu) / m->density);
    }
}

void pf_dg_add_gravity(const pf_dg *dg, pf_vec3 g, pf_vec3 b, double *f)
{
    int nb = dg->nb;
    for (int32_t e = 0; e < dg->n_elems; ++e) {
        pf_vec3 load = pf_v3_add(pf_v3_scale(g, pf_dg_material(dg, e)->density), b);
        for (int a = 0; a < nb; ++a) {
            double w = dg->phi_int[(size_t)e * nb + a];
            double *fa = f + 3 * ((size_t)e * nb + a);
            fa[0] += w * load.x;
            fa[1] += w * load.y;
            fa[2] += w * load.z;
        }
    }
}

pf_status pf_dg_create(pf_dg *dg, const pf_mesh *m, int32_t degree, double E, double nu,
                       double density, pf_error *err)
{
    pf_material one = {.E = E, .nu = nu, .density = density};
    pf_materials mat = {.n = 1, .table = &one, .elem = NULL};
    return pf_dg_create_materials(dg, m, degree, &mat, err);
}

pf_status pf_dg_create_materials(pf_dg *dg, const pf_mesh *m, int32_t degree,
                                 const pf_materials *materials, pf_error *err)
{
    return pf_dg_create_reusing(dg, m, degree, materials, NULL, NULL, err);
}

pf_status pf_dg_create_reusing(pf_dg *dg, const pf_mesh *m, int32_t degree,
                               const pf_materials *materials, const pf_dg_reuse *reuse,
                               const pf_progress_hook *progress, pf_error *err)
{
    memset(dg, 0, sizeof *dg);
    PF_CHECK(degree == 1 || degree == 2, err, PF_ERR_INVALID, "DG degree must be 1 or 2, got %d",
             (int)degree);
    PF_CHECK(m->face_elems, err, PF_ERR_INVALID, "mesh not derived (pf_mesh_derive)");
    pf_status s =
        pf_fem_copy_materials(materials, m->n_elems, &dg->materials, &dg->elem_material, err);
    if (s < 0) {
        pf_dg_release(dg);
        return s;
    }
    dg->n_materials = materials->n;
    dg->degree = degree;
    dg->nb = pf_moment_count(degree);
    dg->n_elems = m->n_elems;
    dg->n_dofs = 3 * (int64_t)dg->nb * m->n_elems;
    dg->density = dg->materials[0].density;
    dg->lambda = dg->materials[0].lambda;
    dg->mu = dg->materials[0].mu;

    pf_arena arena;
    s = pf_arena_init(&arena, (size_t)1 << 20, err);
    if (s >= 0)
        s = allocate_elements(dg, err);
    if (s >= 0)
        s = setup_elements(dg, m, reuse, progress, &arena, err);
    if (s >= 0) {
        double total = 0;
        for (int32_t e = 0; e < dg->n_elems; ++e)
            total += dg->volume[e];
        dg->body_length = cbrt(total);
        s = setup_faces(dg, m, reuse, progress, err);
    }
    if (s >= 0)
        s = setup_stitching(dg, m, err);
    pf_arena_release(&arena);
    if (s < 0)
        pf_dg_release(dg);
    return s;
}
