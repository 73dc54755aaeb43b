/* The CG method for the simulator (harmonic paper sec. 6): nodal unknowns on the harmonic (or
 * closed-form) shape functions of pf/basis.h, 3 per free node. Fixed regions select boundary faces
 * by their centroid; every node of a selected face is fixed strongly at the region's displacement
 * (its unknowns removed; the prescribed displacement enters the right-hand side). Corotation warps
 * each element's stiffness with its shape-matching rotation (pf_cg_rotations). Mass: consistent
 * (the default) or lumped (scene key method.mass). Contact is the driver's, through an element's
 * nodes (point_row). */
#include "method.h"

#include <math.h>
#include <string.h>

#include <pf/fem.h>

typedef struct cg_method {
    const pf_scene *scene;
    const pf_mesh *mesh;
    pf_cg cg;
    pf_cg_map map;
    bool lumped;
    uint8_t *fixed;  /* [n_nodes] */
    double *g;       /* [3 n_nodes] prescribed displacement of fixed nodes, 0 elsewhere */
    double *u_full;  /* [3 n_nodes] scratch: nodal displacements of a state */
    double *rot;     /* [9 n_elems] */
    bool rot_warm;   /* rot holds the last corotated step's (the next one's polar guesses) */
    double *scratch; /* [pf_cg_scratch_size] */
    pf_boundary bd;  /* boundary faces, triangulated (loads only) */
    uint8_t *cut;    /* [n_faces] on a rank's part: 1 for a face between parts (no load); or NULL */
    /* the identity on free nodes as method.h's nodal map (contact) */
    int64_t *map_offsets; /* [n_nodes + 1] */
    int64_t *map_triple;  /* [n_free] */
    double *map_w;        /* [n_free] */
} cg_method;

static int64_t n_dofs(const void *m)
{
    return 3 * (int64_t)((const cg_method *)m)->map.n_free;
}

/* The pattern was built at creation (it fixes the unknowns); hand over a copy's ownership. */
static pf_status pattern(const void *m, pf_block_matrix *k, pf_error *err)
{
    const cg_method *c = m;
    pf_cg_map map;
    PF_TRY(pf_cg_pattern(&c->cg, c->fixed, k, &map, err));
    pf_cg_map_release(&map);
    return PF_OK;
}

/* Free unknowns u [3 n_free] and the prescribed displacements as nodal values out [3 n_nodes]. */
static void to_nodal(const cg_method *c, const double *u, double *out)
{
    memcpy(out, c->g, 3 * (size_t)c->cg.n_nodes * sizeof *out);
    for (int32_t i = 0; i < c->map.n_free; ++i)
        memcpy(out + 3 * (size_t)c->map.block_node[i], u + 3 * (size_t)i, 3 * sizeof *out);
}

/* The nodal field of u in c->u_full and, corotated, the elements' rotations from it (each
 * warm-started from its last one). */
static void nodal_state(cg_method *c, const double *u, bool corotate)
{
    to_nodal(c, u, c->u_full);
    if (corotate) {
        pf_cg_rotations(&c->cg, c->mesh->x, c->u_full, c->rot_warm, c->rot);
        c->rot_warm = true;
    }
}

static void stiffness(void *m, const double *u, bool corotate, pf_block_matrix *k, double *f)
{
    cg_method *c = m;
    if (corotate)
        nodal_state(c, u, true);
    pf_cg_assemble_stiffness(&c->cg, &c->map, corotate ? c->rot : NULL, c->mesh->x, c->g,
                             c->scratch, k, f);
}

static void step_system(void *m, const double *u, const double *v, bool corotate, double kscale,
                        double mscale, pf_block_matrix *k, double *f, double *mv)
{
    cg_method *c = m;
    nodal_state(c, u, corotate);
    pf_cg_step in = {.rot = corotate ? c->rot : NULL,
                     .x0 = c->mesh->x,
                     .u = c->u_full,
                     .v = v,
                     .lumped = c->lumped,
                     .kscale = kscale,
                     .mscale = mscale};
    pf_cg_assemble_step(&c->cg, &c->map, &in, c->scratch, k, f, mv);
}

/* The warp's rotations (method.h): a free node turns with its elements, by the mean of theirs
 * made orthogonal by one step of Bjorck's iteration, Q (3 I - Q^T Q) / 2 (Q the mean scaled to
 * |Q|_F^2 = 3): orthogonal to the square of the elements' disagreement, which is all a
 * preconditioner needs (any non-singular Q keeps it definite). Measured against plain reuse of
 * the factor (PCG iterations per solve, factorisations per 100 steps): the CG beam of
 * bench_solver (1,911 hexes) 2.99 and 3 against 3.88 and 8; a free 2 x 1 x 1 box of 16 x 8 x 8
 * hexes spinning at (0, 1, 5) rad/s 2.9 and 1 against 4.5 and 6; with the body's mean rotation
 * instead of the nodes' the beam needed 3.89 and 5. The polar factor of the sum instead of
 * Bjorck's step: the same iterations, at 1 ms a step more on the beam. */
static void triple_rotations(const void *m, double *rot)
{
    const cg_method *c = m;
    memset(rot, 0, 9 * (size_t)c->map.n_free * sizeof *rot);
    for (int32_t e = 0; e < c->cg.n_elems; ++e) {
        const int32_t *nodes;
        int32_t k = pf_basis_elem_nodes(&c->cg.basis, e, &nodes);
        for (int32_t a = 0; a < k; ++a) {
            int32_t i = c->map.node_block[nodes[a]];
            if (i >= 0)
                for (int q = 0; q < 9; ++q)
                    rot[9 * (size_t)i + q] += c->rot[9 * (size_t)e + q];
        }
    }
    for (int32_t i = 0; i < c->map.n_free; ++i) {
        pf_mat3 q;
        memcpy(q.m, rot + 9 * (size_t)i, sizeof q.m);
        double norm2 = 0; /* 3 k^2 for k equal rotations */
        for (int r = 0; r < 3; ++r)
            norm2 += q.m[r][0] * q.m[r][0] + q.m[r][1] * q.m[r][1] + q.m[r][2] * q.m[r][2];
        q = norm2 > 0 ? pf_m3_scale(q, sqrt(3 / norm2)) : pf_m3_identity();
        pf_mat3 e = pf_m3_mul(pf_m3_transpose(q), q);
        for (int r = 0; r < 3; ++r)
            for (int col = 0; col < 3; ++col)
                e.m[r][col] = 0.5 * ((r == col ? 3.0 : 0.0) - e.m[r][col]);
        q = pf_m3_mul(q, e);
        memcpy(rot + 9 * (size_t)i, q.m, sizeof q.m);
    }
}

/* Element rotations from the last step's (Newton's polar) cost 0.77 of the SVD's on the CG beam
 * of bench_solver (1,911 hexes). */
static void forget_rotations(void *m)
{
    ((cg_method *)m)->rot_warm = false;
}

static void add_mass(const void *m, double alpha, pf_block_matrix *k)
{
    const cg_method *c = m;
    pf_cg_add_mass(&c->cg, &c->map, c->lumped, alpha, k);
}

static void mass_mul(const void *m, double alpha, const double *x, double *y)
{
    const cg_method *c = m;
    pf_cg_mass_mul(&c->cg, &c->map, c->lumped, alpha, x, y);
}

/* Tractions on the boundary faces the loads select, gravity and body forces, as nodal loads;
 * the free rows are kept. */
static void external_forces(const void *m, double *f)
{
    const cg_method *c = m;
    const pf_scene *sc = c->scene;
    const pf_mesh *mesh = c->mesh;
    double *nodal = c->u_full; /* free at this point: used as the nodal load */
    memset(nodal, 0, 3 * (size_t)mesh->n_nodes * sizeof *nodal);
    const pf_boundary *bd = &c->bd;
    for (int32_t q = 0; q < bd->n_faces; ++q) {
        int32_t face = bd->face[q];
        if (c->cut && c->cut[face])
            continue;
        const uint32_t *idx = mesh->face_nodes + mesh->face_offsets[face];
        int64_t n = mesh->face_offsets[face + 1] - mesh->face_offsets[face];
        pf_vec3 centroid = pf_polygon_centroid(mesh->x, idx, n);
        for (int32_t k = 0; k < sc->n_loads; ++k)
            if (pf_region_selects_face(&sc->loads[k].region, mesh, face, centroid))
                pf_cg_add_traction(&c->cg, mesh, bd, q, sc->loads[k].traction, nodal);
    }
    pf_vec3 g = sc->gravity, b = sc->body_force;
    if (g.x != 0 || g.y != 0 || g.z != 0 || b.x != 0 || b.y != 0 || b.z != 0)
        pf_cg_add_gravity(&c->cg, g, b, nodal);
    for (int32_t i = 0; i < c->map.n_free; ++i)
        for (int d = 0; d < 3; ++d)
            f[3 * (size_t)i + d] += nodal[3 * (size_t)c->map.block_node[i] + d];
}

static double ground_stiffness(const void *m, double h)
{
    const cg_method *c = m;
    return pf_method_ground_stiffness(c->cg.materials, c->cg.n_materials, h);
}

/* Half the diagonal of the element's nodes' bounding box. */
static double element_size(const void *m, int32_t e)
{
    return ((const cg_method *)m)->cg.size[e];
}

/* The nodal map of method.h: weight 1 on a free node's own triple. A fixed node has no entry: no
 * unknown moves it, so contact there has nothing to act on (its prescribed displacement is not
 * seen by the contact search). */
static pf_status build_nodal_map(cg_method *c, pf_error *err)
{
    int32_t nn = c->cg.n_nodes, nf = c->map.n_free;
    c->map_offsets = pf_alloc_array((size_t)nn + 1, sizeof *c->map_offsets);
    c->map_triple = pf_alloc_array((size_t)nf + 1, sizeof *c->map_triple);
    c->map_w = pf_alloc_array((size_t)nf + 1, sizeof *c->map_w);
    PF_CHECK(c->map_offsets && c->map_triple && c->map_w, err, PF_ERR_NOMEM,
             "cannot allocate the nodal map of %d nodes", (int)nn);
    int64_t q = 0;
    c->map_offsets[0] = 0;
    for (int32_t i = 0; i < nn; ++i) {
        int32_t block = c->map.node_block[i];
        if (block >= 0) {
            c->map_triple[q] = block;
            c->map_w[q] = 1;
            ++q;
        }
        c->map_offsets[i + 1] = q;
    }
    return PF_OK;
}

static void nodal_map(const void *m, const int64_t **offsets, const int64_t **triple,
                      const double **w)
{
    const cg_method *c = m;
    *offsets = c->map_offsets;
    *triple = c->map_triple;
    *w = c->map_w;
}

/* The least-norm weights lambda over e's free nodes with sum lambda = 1 and
 * sum lambda x_j = x (affine fields reproduced): in coordinates centred at the nodes' mean,
 * lambda_j = 1/f + d_j . S^-1 d, S = sum d_j d_j^T. Falls back to the nearest free node when
 * they span no volume. */
static int32_t point_row(const void *m, int32_t e, pf_vec3 x, int64_t *triple, double *w)
{
    const cg_method *c = m;
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(&c->cg.basis, e, &nodes), f = 0;
    for (int32_t a = 0; a < k; ++a) /* a node point is its own unknowns */
        if (c->map.node_block[nodes[a]] >= 0 &&
            pf_v3_norm(pf_v3_sub(pf_v3_load(c->mesh->x + 3 * (size_t)nodes[a]), x)) == 0) {
            triple[0] = c->map.node_block[nodes[a]];
            w[0] = 1;
            return 1;
        }
    pf_vec3 mean = {0, 0, 0};
    for (int32_t a = 0; a < k; ++a)
        if (c->map.node_block[nodes[a]] >= 0) {
            mean = pf_v3_add(mean, pf_v3_load(c->mesh->x + 3 * (size_t)nodes[a]));
            triple[f++] = c->map.node_block[nodes[a]];
        }
    if (f == 0)
        return 0;
    mean = pf_v3_scale(mean, 1.0 / f);
    pf_mat3 s = {{{0}}};
    int32_t nearest = 0;
    double best = INFINITY;
    for (int32_t a = 0, q = 0; a < k; ++a) {
        if (c->map.node_block[nodes[a]] < 0)
            continue;
        pf_vec3 xa = pf_v3_load(c->mesh->x + 3 * (size_t)nodes[a]), d = pf_v3_sub(xa, mean);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                s.m[i][j] += pf_v3_get(d, i) * pf_v3_get(d, j);
        double dist = pf_v3_norm(pf_v3_sub(xa, x));
        if (dist < best)
            best = dist, nearest = q;
        ++q;
    }
    double det;
    pf_mat3 inv = pf_m3_inverse(s, &det);
    double scale = pf_m3_norm(s);
    if (!(fabs(det) > 1e-12 * scale * scale * scale)) {
        triple[0] = triple[nearest];
        w[0] = 1;
        return 1;
    }
    pf_vec3 y = pf_m3_mulv(inv, pf_v3_sub(x, mean));
    for (int32_t a = 0, q = 0; a < k; ++a)
        if (c->map.node_block[nodes[a]] >= 0) {
            pf_vec3 d = pf_v3_sub(pf_v3_load(c->mesh->x + 3 * (size_t)nodes[a]), mean);
            w[q++] = 1.0 / f + pf_v3_dot(d, y);
        }
    return f;
}

static int32_t max_point_row(const void *m)
{
    const cg_method *c = m;
    int32_t longest = 0;
    for (int32_t e = 0; e < c->cg.n_elems; ++e) {
        const int32_t *nodes;
        int32_t k = pf_basis_elem_nodes(&c->cg.basis, e, &nodes);
        longest = k > longest ? k : longest;
    }
    return longest;
}

static int32_t node_elements(const void *m, int32_t i, const int32_t **elems)
{
    const cg_method *c = m;
    *elems = c->map.node_elem + i;
    return c->map.node_elem[i] >= 0 ? 1 : 0;
}

static int32_t element_of_dof(const void *m, int64_t k)
{
    const cg_method *c = m;
    if (k < 0 || k >= 3 * (int64_t)c->map.n_free)
        return -1;
    return c->map.node_elem[c->map.block_node[k / 3]];
}

static void nodal_displacements(const void *m, const double *u, double *out)
{
    to_nodal(m, u, out);
}

static void von_mises(const void *m, const double *u, double *out)
{
    const cg_method *c = m;
    to_nodal(c, u, c->u_full);
    pf_cg_von_mises(&c->cg, c->u_full, out);
}

/* Kinetic energy 1/2 v^T M v, momentum sum_ab M_ab v_b and angular momentum
 * sum_ab M_ab (x_a + u_a) x v_b (lumped: the diagonal), fixed nodes at rest. */
static void momentum(const void *m, const double *u, const double *v, double *kinetic,
                     pf_vec3 *linear, pf_vec3 *angular)
{
    const cg_method *c = m;
    const pf_cg *cg = &c->cg;
    const int32_t *block = c->map.node_block;
    double ke = 0;
    pf_vec3 p = {0, 0, 0}, l = {0, 0, 0};
    if (c->lumped) {
        for (int32_t i = 0; i < c->map.n_free; ++i) {
            int32_t node = c->map.block_node[i];
            double mi = cg->lumped[node];
            pf_vec3 vi = pf_v3_load(v + 3 * (size_t)i);
            pf_vec3 xi =
                pf_v3_add(pf_v3_load(c->mesh->x + 3 * (size_t)node), pf_v3_load(u + 3 * (size_t)i));
            pf_method_momentum_pair(mi, xi, vi, vi, true, &ke, &p, &l);
        }
    } else {
        for (int32_t e = 0; e < cg->n_elems; ++e) {
            const int32_t *nodes;
            int32_t k = pf_basis_elem_nodes(&cg->basis, e, &nodes);
            const double *me = pf_cg_elem_mass(cg, e);
            for (int32_t a = 0; a < k; ++a) {
                int32_t i = block[nodes[a]];
                pf_vec3 xa = pf_v3_load(c->mesh->x + 3 * (size_t)nodes[a]);
                xa = pf_v3_add(xa, i >= 0 ? pf_v3_load(u + 3 * (size_t)i)
                                          : pf_v3_load(c->g + 3 * (size_t)nodes[a]));
                pf_vec3 va = i >= 0 ? pf_v3_load(v + 3 * (size_t)i) : pf_v3(0, 0, 0);
                for (int32_t b = 0; b < k; ++b) {
                    int32_t j = block[nodes[b]];
                    if (j < 0)
                        continue;
                    pf_vec3 vb = pf_v3_load(v + 3 * (size_t)j);
                    pf_method_momentum_pair(me[a * k + b], xa, va, vb, true, &ke, &p, &l);
                }
            }
        }
    }
    *kinetic = ke;
    *linear = p;
    *angular = l;
}

/* u = A x + b at the free nodes (fixed nodes keep their prescribed displacement). */
static void affine(const void *m, const double a[9], const double b[3], double *u)
{
    const cg_method *c = m;
    for (int32_t i = 0; i < c->map.n_free; ++i) {
        const double *x = c->mesh->x + 3 * (size_t)c->map.block_node[i];
        for (int r = 0; r < 3; ++r)
            u[3 * (size_t)i + r] =
                a[3 * r] * x[0] + a[3 * r + 1] * x[1] + a[3 * r + 2] * x[2] + b[r];
    }
}

static double max_node_jump(const void *m, const double *u)
{
    (void)m;
    (void)u;
    return 0;
}

/* The largest boundary error of the current elements' shape functions (0 when every element
 * has closed forms): how far the method is from conforming, whatever the field. */
static double error_indicator(const void *m, const double *u)
{
    (void)u;
    const pf_basis *basis = &((const cg_method *)m)->cg.basis;
    double largest = 0;
    for (int32_t e = 0; e < basis->n_elems; ++e)
        largest = fmax(largest, basis->stats[e].boundary_error);
    return largest;
}

/* The corotated principal stress of element e at x from the nodal displacements u [3 n_nodes],
 * kept in *best (and its direction) when it is larger in magnitude. */
static void stress_sample(const cg_method *c, const double *u, int32_t e, pf_vec3 x, double *best,
                          pf_vec3 *direction)
{
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(&c->cg.basis, e, &nodes);
    double grad[3 * PF_BASIS_MAX_NODES], sigma[6];
    pf_basis_eval(&c->cg.basis, e, x, NULL, grad);
    pf_mat3 f = pf_m3_identity();
    for (int32_t a = 0; a < k; ++a)
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                f.m[i][j] += u[3 * (size_t)nodes[a] + i] * grad[3 * a + j];
    pf_corotated_stress(f, pf_cg_material(&c->cg, e)->lambda, pf_cg_material(&c->cg, e)->mu, sigma);
    pf_vec3 dir;
    double value = pf_principal_stress(sigma, &dir);
    if (fabs(value) > fabs(*best))
        *best = value, *direction = dir;
}

/* At each element's centroid and at every node of it. */
static void principal_stresses(const void *m, const double *u, double *value, pf_vec3 *direction)
{
    const cg_method *c = m;
    to_nodal(c, u, c->u_full);
    for (int32_t e = 0; e < c->cg.n_elems; ++e) {
        value[e] = 0;
        direction[e] = pf_v3(1, 0, 0);
        stress_sample(c, c->u_full, e, c->cg.centroid[e], &value[e], &direction[e]);
        const int32_t *nodes;
        int32_t k = pf_basis_elem_nodes(&c->cg.basis, e, &nodes);
        for (int32_t a = 0; a < k; ++a)
            stress_sample(c, c->u_full, e, pf_v3_load(c->mesh->x + 3 * (size_t)nodes[a]), &value[e],
                          &direction[e]);
    }
}

/* Node i of the new mesh takes the old field of old element p at its position. */
static void interpolate_node(const cg_method *o, const double *old_nodal, int32_t p, pf_vec3 x,
                             double *value)
{
    const int32_t *nodes;
    int32_t k = pf_basis_elem_nodes(&o->cg.basis, p, &nodes);
    double n[PF_BASIS_MAX_NODES];
    pf_basis_eval(&o->cg.basis, p, x, n, NULL);
    value[0] = value[1] = value[2] = 0;
    for (int32_t a = 0; a < k; ++a)
        for (int i = 0; i < 3; ++i)
            value[i] += n[a] * old_nodal[3 * (size_t)nodes[a] + i];
}

/* Old nodes keep their values (through the change's node map: a merge drops the nodes no face
 * needs any more); a new node takes the field of the split parent of a child it belongs to
 * (children first: their parents' fields hold the node inside or on their boundary), exact
 * where the parent's functions reproduce the field there: affine fields always, trilinear ones
 * on a hexahedron's closed form. Fixed nodes keep their prescribed displacement. */
static pf_status transfer(const void *m, const void *old, const pf_mesh_change *change,
                          const double *u_old, double *u_new, pf_error *err)
{
    const cg_method *c = m, *o = old;
    int32_t old_nodes = o->cg.n_nodes;
    uint8_t *done = pf_calloc((size_t)c->cg.n_nodes + 1, 1);
    PF_CHECK(done, err, PF_ERR_NOMEM, "cannot allocate %d node flags", (int)c->cg.n_nodes);
    to_nodal(o, u_old, o->u_full);
    double *nodal = c->u_full;
    for (int32_t i = 0; i < old_nodes; ++i) {
        int32_t j = change->node_map ? change->node_map[i] : i;
        if (j < 0)
            continue;
        memcpy(nodal + 3 * (size_t)j, o->u_full + 3 * (size_t)i, 3 * sizeof *nodal);
        done[j] = 1;
    }
    for (int pass = 0; pass < 2; ++pass)
        for (int32_t e = 0; e < c->cg.n_elems; ++e) {
            bool child = change->split && change->split[change->parent[e]];
            if (child != (pass == 0))
                continue;
            const int32_t *nodes;
            int32_t k = pf_basis_elem_nodes(&c->cg.basis, e, &nodes);
            for (int32_t a = 0; a < k; ++a)
                if (!done[nodes[a]]) {
                    pf_vec3 x = pf_v3_load(c->mesh->x + 3 * (size_t)nodes[a]);
                    interpolate_node(o, o->u_full, change->parent[e], x,
                                     nodal + 3 * (size_t)nodes[a]);
                    done[nodes[a]] = 1;
                }
        }
    pf_free(done);
    for (int32_t i = 0; i < c->map.n_free; ++i)
        memcpy(u_new + 3 * (size_t)i, nodal + 3 * (size_t)c->map.block_node[i], 3 * sizeof *u_new);
    return PF_OK;
}

/* Elements with closed-form functions (MFS skipped), harmonic elements, their MFS kernels, the
 * largest boundary error of their functions,
 * seconds spent building the shape functions, and the element functions and matrices taken over
 * from the mesh before a change and computed (the last three added over changes). */
static void setup_stats(const void *m, pf_sim_stats *st)
{
    const cg_method *c = m;
    st->basis_reused += c->cg.basis.n_taken;
    st->basis_computed += (int64_t)c->cg.n_elems - c->cg.basis.n_taken;
    st->integrals_reused += c->cg.n_reused;
    st->integrals_computed += (int64_t)c->cg.n_elems - c->cg.n_reused;
    st->closed_form_elems = c->cg.n_closed_form;
    st->harmonic_elems = c->cg.n_elems - c->cg.n_closed_form;
    st->kernels = 0;
    for (int32_t e = 0; e < c->cg.basis.n_elems; ++e)
        st->kernels += c->cg.basis.stats[e].n_kernels;
    st->basis_error = error_indicator(m, NULL);
    st->basis_seconds += c->cg.basis_seconds;
}

static void destroy(void *m)
{
    cg_method *c = m;
    if (!c)
        return;
    pf_cg_release(&c->cg);
    pf_cg_map_release(&c->map);
    pf_free(c->fixed);
    pf_free(c->cut);
    pf_free(c->g);
    pf_free(c->u_full);
    pf_free(c->rot);
    pf_free(c->scratch);
    pf_boundary_release(&c->bd);
    pf_free(c->map_offsets);
    pf_free(c->map_triple);
    pf_free(c->map_w);
    pf_free(c);
}

static const pf_method_ops CG_OPS = {
    .n_dofs = n_dofs,
    .pattern = pattern,
    .stiffness = stiffness,
    .add_mass = add_mass,
    .step_system = step_system,
    .mass_mul = mass_mul,
    .triple_rotations = triple_rotations,
    .forget_rotations = forget_rotations,
    .external_forces = external_forces,
    .ground_stiffness = ground_stiffness,
    .element_size = element_size,
    .set_penalty = NULL,
    .rigid_mode_shift = NULL,
    .element_of_dof = element_of_dof,
    .nodal_map = nodal_map,
    .point_row = point_row,
    .max_point_row = max_point_row,
    .node_elements = node_elements,
    .nodal_displacements = nodal_displacements,
    .von_mises = von_mises,
    .momentum = momentum,
    .affine = affine,
    .max_node_jump = max_node_jump,
    .error_indicator = error_indicator,
    .error_measure = "basis_boundary_error",
    .error_meaning = "largest boundary error of the shape functions, docs/basis.md",
    .principal_stresses = principal_stresses,
    .transfer = transfer,
    .setup_stats = setup_stats,
    .destroy = destroy,
};

const pf_method_ops *pf_sim_cg_ops(void)
{
    return &CG_OPS;
}

int32_t pf_sim_cg_fixed_nodes(const pf_scene *sc, const pf_mesh *mesh, uint8_t *fixed, double *g,
                              int32_t *loaded_faces)
{
    int32_t fixed_faces = 0, loaded = 0;
    for (int32_t f = 0; f < mesh->n_faces; ++f) {
        if (mesh->face_elems[2 * f] >= 0 && mesh->face_elems[2 * f + 1] >= 0)
            continue;
        const uint32_t *idx = mesh->face_nodes + mesh->face_offsets[f];
        int64_t n = mesh->face_offsets[f + 1] - mesh->face_offsets[f];
        pf_vec3 centroid = pf_polygon_centroid(mesh->x, idx, n);
        int32_t k = pf_method_fixed_region(sc, mesh, f, centroid);
        for (int64_t q = 0; k >= 0 && q < n; ++q) {
            if (fixed[idx[q]])
                continue;
            fixed[idx[q]] = 1;
            pf_v3_store(sc->fixed[k].displacement, g + 3 * (size_t)idx[q]);
        }
        fixed_faces += k >= 0;
        loaded += pf_method_face_loaded(sc, mesh, f, centroid);
    }
    if (loaded_faces)
        *loaded_faces = loaded;
    return fixed_faces;
}

/* The free nodes' map (the unknowns) and the nodal map of contact, from c->fixed. */
static pf_status number_free_nodes(cg_method *c, pf_error *err)
{
    /* the driver builds its own matrix from the same pattern */
    pf_block_matrix probe = {0};
    pf_cg_map_release(&c->map);
    pf_status st = pf_cg_pattern(&c->cg, c->fixed, &probe, &c->map, err);
    pf_block_matrix_release(&probe);
    pf_free(c->map_offsets), pf_free(c->map_triple), pf_free(c->map_w);
    c->map_offsets = NULL, c->map_triple = NULL, c->map_w = NULL;
    return st >= 0 ? build_nodal_map(c, err) : st;
}

pf_status pf_sim_cg_set_part(void *m, const uint8_t *fixed, const double *g, const uint8_t *cut,
                             pf_error *err)
{
    cg_method *c = m;
    size_t nn = (size_t)c->mesh->n_nodes, nf = (size_t)c->mesh->n_faces;
    c->cut = pf_alloc_array(nf + 1, sizeof *c->cut);
    PF_CHECK(c->cut, err, PF_ERR_NOMEM, "cannot allocate %zu face flags", nf);
    memcpy(c->cut, cut, nf * sizeof *c->cut);
    memcpy(c->fixed, fixed, nn * sizeof *c->fixed);
    memcpy(c->g, g, 3 * nn * sizeof *c->g);
    return number_free_nodes(c, err);
}

pf_status pf_sim_cg_create(const pf_scene *scene, const pf_mesh *mesh, const pf_method_reuse *reuse,
                           const pf_progress_hook *progress, const pf_method_ops **ops, void **ctx,
                           int32_t *fixed_faces, int32_t *loaded_faces, pf_error *err)
{
    *ops = &CG_OPS;
    *ctx = NULL;
    cg_method *c = pf_calloc(1, sizeof *c);
    PF_CHECK(c, err, PF_ERR_NOMEM, "cannot allocate the CG method");
    c->scene = scene;
    c->mesh = mesh;
    c->lumped = scene->mass == PF_MASS_LUMPED;
    pf_cg_params params = pf_cg_params_default();
    params.basis.no_check_stats = true;
    params.basis.edge_samples = scene->edge_samples;
    params.progress = *progress;
    pf_material *table = NULL;
    int32_t *elem = NULL, n_materials = 0;
    /* an element whose faces are its parent's node for node may take its functions and
     * matrices (pf_cg_create_reusing checks that they are the same element) */
    int32_t *source = NULL;
    pf_status st = pf_scene_materials(scene, mesh, &table, &n_materials, &elem, err);
    if (st >= 0 && reuse) {
        source = pf_alloc_array((size_t)mesh->n_elems + 1, sizeof *source);
        st = source ? PF_OK
                    : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                   "cannot allocate %d element slots", (int)mesh->n_elems);
        for (int32_t e = 0; source && e < mesh->n_elems; ++e)
            source[e] = reuse->same_faces[e] ? reuse->parent[e] : -1;
    }
    if (st >= 0) {
        pf_materials mat = {.n = n_materials, .table = table, .elem = elem};
        pf_cg_reuse cg_reuse = {0};
        if (reuse)
            cg_reuse = (pf_cg_reuse){.old = &((const cg_method *)reuse->old)->cg,
                                     .old_mesh = reuse->old_mesh,
                                     .source = source,
                                     .node_map = reuse->node_map};
        st = pf_cg_create_reusing(&c->cg, mesh, &mat, &params, reuse ? &cg_reuse : NULL, err);
    }
    pf_free(source);
    pf_free(table);
    pf_free(elem);
    if (st >= 0) {
        size_t nn = (size_t)mesh->n_nodes, ne = (size_t)mesh->n_elems;
        c->fixed = pf_calloc(nn + 1, sizeof *c->fixed);
        c->g = pf_calloc(3 * nn + 1, sizeof *c->g);
        c->u_full = pf_calloc(3 * nn + 1, sizeof *c->u_full);
        c->rot = pf_alloc_array(9 * ne + 1, sizeof *c->rot);
        c->scratch = pf_alloc_array(pf_cg_scratch_size(&c->cg) + 1, sizeof *c->scratch);
        st = c->fixed && c->g && c->u_full && c->rot && c->scratch
                 ? PF_OK
                 : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                "cannot allocate the CG state of %d nodes", (int)nn);
    }
    if (st >= 0)
        *fixed_faces = pf_sim_cg_fixed_nodes(scene, mesh, c->fixed, c->g, loaded_faces);
    if (st >= 0 && scene->n_loads > 0)
        st = pf_boundary_extract(mesh, &c->bd, err);
    if (st >= 0)
        st = number_free_nodes(c, err);
    if (st < 0) {
        destroy(c);
        return st;
    }
    *ctx = c;
    return PF_OK;
}
