/* Each MPI rank assembling its own elements (pf/sim.h, pf_sim_distrib_run): the parts and the
 * static solve, DG here, CG's differences in sim_distrib_cg.c, dynamics in sim_distrib_dyn.c.
 *
 * Rank 0 partitions the elements (PT-Scotch on their face adjacency, pf_petsc_partition_graph)
 * and sends each rank its part: its elements and their face neighbours (the halo) as a mesh of
 * their own (pf_mesh_select_elements, nodes compacted), with each element's PETSc number and
 * owner, each node's number in the whole mesh, and the scene as JSON. Every rank, rank 0
 * included, then runs the same code on its part: the DG method's set-up (sim_dg.c, the code a
 * one-process run uses) and its stiffness and forces, assembled into a block matrix of the part.
 *
 * Which entries a rank sends (MatSetValuesCOO, duplicates summed by PETSc): the diagonal block of
 * an element holds its volume term and the own-side terms of all its faces, which the part has
 * whole, so the owner sends it; the block coupling two elements holds the terms of their common
 * face, which both parts have when the two have different owners, so only the owner of the one
 * with the lower PETSc number sends it. Blocks between halo elements are not sent (a halo
 * element's faces to elements outside the part look like boundary faces here: their terms land
 * in halo rows only). The right-hand side's rows are the owned elements'.
 *
 * PETSc numbers the elements part by part (part 0's first, in mesh order), so each rank's rows
 * are one contiguous range. The solution stays distributed: each rank evaluates its elements'
 * fields at their nodes (sums and counts, the stitching of eq. 30 split by owner) and their von
 * Mises stress, and rank 0 receives the sums. */
#include <pf/io.h>
#include <pf/sim.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../solve/solve_petsc.h"
#include "sim_distrib.h"
#include "sim_internal.h"
#include <pf/integrate.h>

#ifdef PF_HAVE_PETSC

#include <sys/resource.h>

static int rank_of(void)
{
    int r = 0;
    MPI_Comm_rank(PETSC_COMM_WORLD, &r);
    return r;
}

static int ranks(void)
{
    int s = 1;
    MPI_Comm_size(PETSC_COMM_WORLD, &s);
    return s;
}

pf_status pf_sim_distrib_agree(pf_status st, pf_error *err)
{
    int bad = st < 0, any = 0;
    MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, PETSC_COMM_WORLD);
    if (any && !bad)
        return pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                            "another rank failed in the distributed assembly");
    return st;
}

/* ---- rank 0: the partition and the parts ------------------------------------------------ */

/* The elements' face adjacency (both directions) of a derived mesh. */
static pf_status element_graph(const pf_mesh *m, int64_t **offsets, int32_t **adj, pf_error *err)
{
    *offsets = pf_calloc((size_t)m->n_elems + 2, sizeof **offsets);
    int64_t edges = 0;
    for (int32_t f = 0; f < m->n_faces; ++f)
        edges += 2 * (m->face_elems[2 * f] >= 0 && m->face_elems[2 * f + 1] >= 0);
    *adj = pf_alloc_array((size_t)edges + 1, sizeof **adj);
    PF_CHECK(*offsets && *adj, err, PF_ERR_NOMEM, "cannot allocate the graph of %d elements",
             (int)m->n_elems);
    for (int32_t f = 0; f < m->n_faces; ++f)
        if (m->face_elems[2 * f] >= 0 && m->face_elems[2 * f + 1] >= 0) {
            (*offsets)[m->face_elems[2 * f] + 2]++;
            (*offsets)[m->face_elems[2 * f + 1] + 2]++;
        }
    for (int32_t e = 0; e < m->n_elems; ++e)
        (*offsets)[e + 2] += (*offsets)[e + 1];
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
        if (a >= 0 && b >= 0) {
            (*adj)[(*offsets)[a + 1]++] = b;
            (*adj)[(*offsets)[b + 1]++] = a;
        }
    }
    return PF_OK;
}

/* part[e] for every element and pelem[e], its PETSc number. */
static pf_status partition(const pf_mesh *m, int32_t parts, int64_t *owner, int64_t *pelem,
                           pf_error *err)
{
    int64_t *offsets = NULL;
    int32_t *adj = NULL;
    pf_status st = element_graph(m, &offsets, &adj, err);
    if (st >= 0)
        st = pf_petsc_partition_graph(m->n_elems, offsets, adj, parts, owner, err);
    pf_free(offsets);
    pf_free(adj);
    PF_TRY(st);
    int64_t *next = pf_calloc((size_t)parts + 1, sizeof *next);
    PF_CHECK(next, err, PF_ERR_NOMEM, "cannot allocate %d parts", (int)parts);
    for (int32_t e = 0; e < m->n_elems; ++e)
        next[owner[e] + 1]++;
    for (int32_t r = 0; r < parts; ++r)
        next[r + 1] += next[r];
    for (int32_t e = 0; e < m->n_elems; ++e)
        pelem[e] = next[owner[e]]++;
    pf_free(next);
    return PF_OK;
}

static pf_status append(pf_buffer *b, const void *bytes, size_t n, pf_error *err)
{
    return n ? pf_buffer_append(b, bytes, n, err) : PF_OK;
}

/* Part r of the mesh as one message: header, scene JSON, MESH and GRPS payloads, then per
 * element its PETSc number, whole-mesh index and ownership, per node its whole-mesh index, with
 * contact its boundary flag and sharers (contact_whole), and CG's data. */
static pf_status pack_part(const pf_mesh *m, const char *json, const pf_buffer *obstacles,
                           const int64_t *owner, const int64_t *pelem, const cg_whole *cg,
                           const contact_whole *cw, const distrib_out *o, int32_t r,
                           pf_buffer *out, pf_error *err)
{
    int32_t ne = m->n_elems;
    uint8_t *keep = pf_calloc((size_t)ne + 1, 1);
    int32_t *emap = pf_alloc_array((size_t)ne + 1, sizeof *emap);
    int32_t *node_id = pf_alloc_array((size_t)m->n_nodes + 1, sizeof *node_id);
    pf_mesh sub = {0};
    pf_buffer mesh_bytes = {0}, groups = {0};
    pf_status st = keep && emap && node_id ? PF_OK
                                           : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                                          "cannot allocate part %d", (int)r);
    bool any = false; /* a part without elements (more ranks than elements) sends no mesh */
    for (int32_t e = 0; st >= 0 && e < ne; ++e)
        any |= owner[e] == r;
    for (int32_t f = 0; st >= 0 && f < m->n_faces; ++f) {
        int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
        if (a >= 0 && owner[a] == r) /* CG: its own elements only, DG: with their neighbours */
            keep[a] = 1, keep[b >= 0 && !cg ? b : a] = 1;
        if (b >= 0 && owner[b] == r)
            keep[b] = 1, keep[a >= 0 && !cg ? a : b] = 1;
    }
    if (st >= 0 && any)
        st = pf_mesh_select_elements(&sub, m, keep, emap, err);
    if (st >= 0 && any) {
        pf_mesh_compact_nodes(&sub, node_id);
        st = pf_stream_encode_mesh(&sub, &mesh_bytes, err);
    }
    if (st >= 0 && sub.elem_group)
        st = pf_stream_encode_groups(&sub, &groups, err);
    pf_vec3 lo, hi;
    pf_mesh_bounds(m, &lo, &hi);
    part_header h = {.mesh_bytes = (int64_t)mesh_bytes.size,
                     .groups_bytes = (int64_t)groups.size,
                     .n_elems = sub.n_elems,
                     .n_nodes = sub.n_nodes,
                     .all_elems = m->n_elems,
                     .all_nodes = m->n_nodes,
                     .scene_bytes = (int64_t)strlen(json),
                     .obstacle_bytes = (int64_t)obstacles->size,
                     .lo = {lo.x, lo.y, lo.z},
                     .hi = {hi.x, hi.y, hi.z},
                     .all_free = cg ? cg->all_free : 0,
                     .fixed_faces = cg ? cg->fixed_faces : 0,
                     .checkpoint_every = o->opt ? o->opt->checkpoint_every : 0,
                     .restoring = o->opt && o->opt->restore};
    out->size = 0;
    if (st >= 0)
        st = append(out, &h, sizeof h, err);
    if (st >= 0)
        st = append(out, json, (size_t)h.scene_bytes, err);
    if (st >= 0)
        st = append(out, obstacles->data, obstacles->size, err);
    if (st >= 0)
        st = append(out, mesh_bytes.data, mesh_bytes.size, err);
    if (st >= 0)
        st = append(out, groups.data, groups.size, err);
    for (int32_t e = 0; st >= 0 && e < sub.n_elems; ++e) {
        int64_t p = pelem[emap[e]];
        uint8_t own = owner[emap[e]] == r;
        st = append(out, &p, sizeof p, err);
        if (st >= 0)
            st = append(out, &emap[e], sizeof emap[e], err);
        if (st >= 0)
            st = append(out, &own, 1, err);
    }
    for (int32_t i = 0; st >= 0 && any && i < m->n_nodes; ++i)
        if (node_id[i] >= 0)
            st = append(out, &i, sizeof i, err);
    if (st >= 0 && any && cw->boundary)
        st = pf_sim_distrib_contact_pack(m, cw, node_id, out, err);
    if (st >= 0 && any && cg)
        st = pf_sim_distrib_cg_pack(m, cg, keep, node_id, r, out, err);
    pf_mesh_release(&sub);
    pf_buffer_release(&mesh_bytes);
    pf_buffer_release(&groups);
    pf_free(keep), pf_free(emap), pf_free(node_id);
    return st;
}

/* Rank 0 makes every part and sends it (its own last, kept in mine); after a part it failed to
 * make, that part and the rest go out as a size of -1. */
static pf_status send_parts(const pf_mesh *m, const pf_scene *scene, const distrib_out *o,
                            pf_buffer *mine, pf_error *err)
{
    int32_t n = ranks();
    int64_t *owner = pf_alloc_array((size_t)m->n_elems + 1, sizeof *owner);
    int64_t *pelem = pf_alloc_array((size_t)m->n_elems + 1, sizeof *pelem);
    char *json = NULL;
    cg_whole cg = {0};
    contact_whole cw = {0};
    pf_buffer obstacles = {0};
    bool is_cg = scene->method == PF_METHOD_CG;
    pf_status st = owner && pelem ? PF_OK
                                  : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                                 "cannot partition %d elements", (int)m->n_elems);
    if (st >= 0)
        st = partition(m, n, owner, pelem, err);
    if (st >= 0 && is_cg)
        st = pf_sim_distrib_cg_whole(scene, m, owner, n, &cg, err);
    if (st >= 0 && pf_scene_has_contact(scene))
        st = pf_sim_distrib_contact_whole(m, &cw, err);
    if (st >= 0)
        st = pf_sim_distrib_obstacles_pack(scene, &obstacles, err);
    if (st >= 0)
        st = pf_scene_to_json(scene, &json, err);
    st = pf_sim_distrib_agree(st, err); /* a failed partition: no parts, every rank knows */
    bool made = st >= 0;
    for (int32_t r = n - 1; r >= 0 && made; --r) {
        if (st >= 0)
            st = pack_part(m, json, &obstacles, owner, pelem, is_cg ? &cg : NULL, &cw, o, r,
                           mine, err);
        if (r == 0)
            break;
        int64_t size = st >= 0 ? (int64_t)mine->size : -1;
        MPI_Send(&size, 1, MPI_INT64_T, r, 0, PETSC_COMM_WORLD);
        for (int64_t at = 0; at < size; at += 1 << 30) /* MPI counts are int */
            MPI_Send(mine->data + at, (int)(size - at < (1 << 30) ? size - at : 1 << 30), MPI_BYTE,
                     r, 1, PETSC_COMM_WORLD);
    }
    pf_free(owner), pf_free(pelem), pf_free(json);
    pf_sim_distrib_cg_whole_release(&cg);
    pf_sim_distrib_contact_whole_release(&cw);
    pf_buffer_release(&obstacles);
    return st;
}

static pf_status receive_part(pf_buffer *b, pf_error *err)
{
    int64_t size = 0;
    MPI_Recv(&size, 1, MPI_INT64_T, 0, 0, PETSC_COMM_WORLD, MPI_STATUS_IGNORE);
    PF_CHECK(size >= 0, err, PF_ERR_INVALID, "rank 0 could not make this rank's part");
    PF_TRY(pf_buffer_reserve(b, (size_t)size + 1, err));
    for (int64_t at = 0; at < size; at += 1 << 30)
        MPI_Recv(b->data + at, (int)(size - at < (1 << 30) ? size - at : 1 << 30), MPI_BYTE, 0, 1,
                 PETSC_COMM_WORLD, MPI_STATUS_IGNORE);
    b->size = (size_t)size;
    return PF_OK;
}

/* ---- every rank: the part's set-up and assembly ------------------------------------------ */

static pf_status decode_chunk(const char *tag, unsigned char *bytes, int64_t size, pf_mesh *m,
                              pf_error *err)
{
    pf_chunk c = {.version = pf_stream_tag_version(tag), .size = (uint64_t)size, .payload = bytes};
    memcpy(c.tag, tag, 5);
    return tag[0] == 'M' ? pf_stream_decode_mesh(&c, m, err) : pf_stream_decode_groups(&c, m, err);
}

static pf_status unpack_part(part *p, pf_buffer *b, pf_error *err)
{
    unsigned char *at = b->data;
    memcpy(&p->h, at, sizeof p->h);
    at += sizeof p->h;
    PF_TRY(pf_scene_parse(&p->scene, (const char *)at, (size_t)p->h.scene_bytes, "scene", err));
    pf_scene_resolve(&p->scene, pf_v3_load(p->h.lo), pf_v3_load(p->h.hi));
    at += p->h.scene_bytes;
    PF_TRY(pf_sim_distrib_obstacles_unpack(&p->scene, at, p->h.obstacle_bytes, err));
    at += p->h.obstacle_bytes;
    if (p->h.n_elems == 0)
        return PF_OK;
    PF_TRY(decode_chunk("MESH", at, p->h.mesh_bytes, &p->mesh, err));
    at += p->h.mesh_bytes;
    if (p->h.groups_bytes)
        PF_TRY(decode_chunk("GRPS", at, p->h.groups_bytes, &p->mesh, err));
    at += p->h.groups_bytes;
    size_t ne = (size_t)p->h.n_elems, nn = (size_t)p->h.n_nodes;
    p->pelem = pf_alloc_array(ne + 1, sizeof *p->pelem);
    p->gelem = pf_alloc_array(ne + 1, sizeof *p->gelem);
    p->owned = pf_alloc_array(ne + 1, 1);
    p->gnode = pf_alloc_array(nn + 1, sizeof *p->gnode);
    PF_CHECK(p->pelem && p->gelem && p->owned && p->gnode, err, PF_ERR_NOMEM,
             "cannot allocate a part of %zu elements", ne);
    for (size_t e = 0; e < ne; ++e) {
        memcpy(&p->pelem[e], at, sizeof *p->pelem);
        memcpy(&p->gelem[e], at + 8, sizeof *p->gelem);
        p->owned[e] = at[12];
        p->n_owned += p->owned[e];
        at += 13;
    }
    memcpy(p->gnode, at, nn * sizeof *p->gnode);
    at += nn * sizeof *p->gnode;
    if (pf_scene_has_contact(&p->scene))
        PF_TRY(pf_sim_distrib_contact_unpack(p, &at, err));
    if (p->scene.method == PF_METHOD_CG)
        PF_TRY(pf_sim_distrib_cg_unpack(p, at, err));
    return pf_mesh_derive(&p->mesh, err);
}

/* The PETSc rows of a DG part's unknowns: element e's are its PETSc number's block. */
static pf_status dg_rows(part *p, pf_error *err)
{
    p->n_dofs = (int64_t)p->h.n_elems * p->nb3;
    p->local_rows = (PetscInt)p->n_owned * p->nb3;
    p->all_rows = (PetscInt)p->h.all_elems * p->nb3;
    p->row = pf_alloc_array((size_t)p->n_dofs + 1, sizeof *p->row);
    p->row_owned = pf_alloc_array((size_t)p->n_dofs + 1, sizeof *p->row_owned);
    PF_CHECK(p->row && p->row_owned, err, PF_ERR_NOMEM, "cannot allocate %lld rows",
             (long long)p->n_dofs);
    for (int64_t i = 0; i < p->n_dofs; ++i) {
        int64_t e = i / p->nb3;
        p->row[i] = (PetscInt)(p->pelem[e] * p->nb3 + i % p->nb3);
        p->row_owned[i] = p->owned[e];
    }
    return PF_OK;
}

/* The method on the part (none on a rank without elements) and the rows of its unknowns. */
static pf_status create_part(part *p, pf_error *err)
{
    if (p->scene.method == PF_METHOD_CG)
        return pf_sim_distrib_cg_create(p, err);
    int32_t fixed = 0, loaded = 0;
    p->nb3 = 3 * pf_moment_count(p->scene.degree);
    if (p->h.n_elems > 0)
        PF_TRY(pf_sim_dg_create(&p->scene, &p->mesh, NULL, NULL, &p->ops, &p->method, &fixed,
                                &loaded, err));
    return dg_rows(p, err);
}

/* DG: its penalty (corotated dynamics: IP's automatic one with pf_sim's margin), and BZ's body
 * length that of the whole mesh; the count of fixed faces (a static scene needs some). */
static pf_status dg_setup(part *p, pf_error *err)
{
    double volume = p->method ? pf_sim_dg_owned_volume(p->method, p->owned) : 0, total = 0;
    int mine = p->method ? pf_sim_dg_owned_fixed_faces(p->method, p->owned) : 0, faces = 0;
    MPI_Allreduce(&volume, &total, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    MPI_Allreduce(&mine, &faces, 1, MPI_INT, MPI_SUM, PETSC_COMM_WORLD);
    PF_CHECK(faces > 0 || !p->scene.is_static, err, PF_ERR_INVALID,
             "a static scene needs fixed faces: no boundary face centroid lies in any 'fixed' "
             "region");
    if (p->method)
        pf_sim_dg_set_body_length(p->method, cbrt(total));
    if (p->scene.penalty <= 0 && p->scene.flux != PF_FLUX_BZ) { /* IP's automatic penalty */
        PF_TRY(pf_sim_distrib_search_penalty(p, err));
        if (p->scene.corotation && !p->scene.is_static)
            p->penalty *= PF_SIM_COROTATED_PENALTY_MARGIN;
    } else
        p->penalty =
            p->scene.penalty > 0 ? p->scene.penalty : pf_sim_bz_default_penalty(p->scene.degree);
    if (p->method)
        p->ops->set_penalty(p->method, p->penalty);
    return PF_OK;
}

/* The part's vectors and the pattern of its matrix. */
static pf_status allocate_part(part *p, pf_error *err)
{
    if (!p->method)
        return PF_OK;
    size_t n = (size_t)p->n_dofs;
    p->f = pf_calloc(n + 1, sizeof *p->f);
    p->u = pf_calloc(n + 1, sizeof *p->u);
    PF_CHECK(p->f && p->u, err, PF_ERR_NOMEM, "cannot allocate %zu unknowns", n);
    return p->ops->pattern(p->method, &p->k, err);
}

/* The method's parameters of the whole mesh (collective); the part's stiffness and forces. */
static pf_status setup_part(part *p, pf_error *err)
{
    if (p->scene.method == PF_METHOD_CG)
        PF_CHECK(p->h.fixed_faces > 0 || !p->scene.is_static, err, PF_ERR_INVALID,
                 "a static scene needs fixed faces: no boundary face centroid lies in any "
                 "'fixed' region");
    else
        PF_TRY(dg_setup(p, err));
    if (!p->method)
        return PF_OK;
    p->ops->stiffness(p->method, p->u, false, &p->k, p->f);
    p->ops->external_forces(p->method, p->f);
    return PF_OK;
}

/* dst (zeroed) from src [n_dofs]: its owned rows, or with sum (CG's right-hand side) every
 * row of the part, the ranks' shares summed. */
static pf_status set_rows(const part *p, const double *src, bool sum, Vec dst, pf_error *err)
{
    for (int64_t i = 0; i < p->n_dofs; ++i)
        if (sum || p->row_owned[i])
            PF_PETSC_TRY(VecSetValue(dst, p->row[i], src[i], ADD_VALUES));
    PF_PETSC_TRY(VecAssemblyBegin(dst));
    PF_PETSC_TRY(VecAssemblyEnd(dst));
    return PF_OK;
}

pf_status pf_sim_distrib_rigid_modes(part *p, Mat a, pf_error *err)
{
    double c[3];
    for (int k = 0; k < 3; ++k)
        c[k] = 0.5 * (p->h.lo[k] + p->h.hi[k]);
    Vec v[6];
    for (int k = 0; k < 6; ++k) {
        double m[9] = {0}, t[3] = {0};
        if (k < 3) {
            t[k] = 1;
        } else { /* u = e_k x (x - c) */
            int i = (k + 1) % 3, j = (k + 2) % 3;
            m[3 * j + i] = 1;
            m[3 * i + j] = -1;
            for (int r = 0; r < 3; ++r)
                t[r] = -(m[3 * r] * c[0] + m[3 * r + 1] * c[1] + m[3 * r + 2] * c[2]);
        }
        if (p->method)
            p->ops->affine(p->method, m, t, p->u);
        PF_PETSC_TRY(MatCreateVecs(a, &v[k], NULL));
        PF_TRY(set_rows(p, p->u, false, v[k], err));
    }
    PF_TRY(pf_petsc_orthonormalise(v, 6, err));
    MatNullSpace space;
    PF_PETSC_TRY(MatNullSpaceCreate(PETSC_COMM_WORLD, PETSC_FALSE, 6, v, &space));
    PF_PETSC_TRY(MatSetNearNullSpace(a, space));
    PF_PETSC_TRY(MatNullSpaceDestroy(&space));
    for (int k = 0; k < 6; ++k)
        PF_PETSC_TRY(VecDestroy(&v[k]));
    if (p->u)
        memset(p->u, 0, (size_t)p->n_dofs * sizeof *p->u);
    return PF_OK;
}

static double peak_rss_mb(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_maxrss / 1024.0;
}

/* p->u [n_dofs] from x, each unknown's row (other ranks' too: CG's shared nodes, DG's halo). */
static pf_status solution_rows(part *p, Vec x, pf_error *err)
{
    IS rows;
    Vec mine;
    VecScatter take;
    PF_PETSC_TRY(
        ISCreateGeneral(PETSC_COMM_SELF, (PetscInt)p->n_dofs, p->row, PETSC_USE_POINTER, &rows));
    PF_PETSC_TRY(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, (PetscInt)p->n_dofs, p->u, &mine));
    PF_PETSC_TRY(VecScatterCreate(x, rows, mine, NULL, &take));
    PF_PETSC_TRY(VecScatterBegin(take, x, mine, INSERT_VALUES, SCATTER_FORWARD));
    PF_PETSC_TRY(VecScatterEnd(take, x, mine, INSERT_VALUES, SCATTER_FORWARD));
    VecScatterDestroy(&take), VecDestroy(&mine), ISDestroy(&rows);
    return PF_OK;
}

/* The matrix, the solve, and the part's solution in p->u. */
static pf_status solve_part(part *p, rank_stats *rs, double cpu0, pf_error *err)
{
    Mat a;
    Vec x, b;
    KSP ksp;
    PF_TRY(pf_sim_distrib_matrix(p, &a, err));
    pf_block_matrix_release(&p->k);
    PF_PETSC_TRY(MatCreateVecs(a, &x, &b));
    PF_TRY(set_rows(p, p->f, p->scene.method == PF_METHOD_CG, b, err));
    PF_TRY(pf_sim_distrib_rigid_modes(p, a, err));
    PF_TRY(pf_petsc_create_ksp(a, p->scene.solver.tolerance, &ksp, err));
    rs->setup_cpu = pf_cpu_seconds() - cpu0;
    KSPConvergedReason reason;
    PetscInt its;
    PetscReal rnorm, bnorm;
    PF_PETSC_TRY(KSPSolve(ksp, b, x));
    rs->solve_cpu = pf_cpu_seconds() - cpu0 - rs->setup_cpu;
    PF_PETSC_TRY(KSPGetConvergedReason(ksp, &reason));
    PF_PETSC_TRY(KSPGetIterationNumber(ksp, &its));
    PF_PETSC_TRY(KSPGetResidualNorm(ksp, &rnorm));
    PF_PETSC_TRY(VecNorm(b, NORM_2, &bnorm));
    rs->iterations = its, rs->reason = reason, rs->residual = bnorm > 0 ? rnorm / bnorm : 0;
    PF_TRY(solution_rows(p, x, err));
    KSPDestroy(&ksp), MatDestroy(&a), VecDestroy(&x), VecDestroy(&b);
    PF_CHECK(reason > 0, err, PF_ERR_NUMERIC,
             "PETSc's KSP stopped without converging (reason %d) after %d iterations, residual "
             "%.3g relative to the right-hand side",
             (int)reason, (int)its, rs->residual);
    return PF_OK;
}

/* Rank 0's arrays [4 all_nodes] (displacement sums, element counts) and [all_elems] von Mises
 * get every rank's owned elements' shares. */
static pf_status gather_outputs(part *p, double *nodes, double *vm, pf_error *err)
{
    size_t nn = (size_t)p->h.all_nodes, ne = (size_t)p->h.all_elems;
    double *sum = pf_calloc(4 * nn + 1, sizeof *sum), *mises = pf_calloc(ne + 1, sizeof *mises);
    double *local = pf_alloc_array((size_t)p->h.n_elems + 1, sizeof *local);
    double *nodal = pf_alloc_array(3 * (size_t)p->h.n_nodes + 1, sizeof *nodal);
    pf_status st =
        sum && mises && local && nodal
            ? PF_OK
            : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate the outputs");
    st = pf_sim_distrib_agree(st, err); /* before the reductions, which all ranks join */
    if (st < 0) {
        pf_free(sum), pf_free(mises), pf_free(local), pf_free(nodal);
        return st;
    }
    const int64_t *off = NULL, *triple = NULL;
    const double *w = NULL;
    if (p->method) {
        p->ops->nodal_map(p->method, &off, &triple, &w);
        p->ops->von_mises(p->method, p->u, local);
    }
    int32_t nb = p->nb3 / 3;
    if (p->scene.method == PF_METHOD_CG)
        pf_sim_distrib_cg_nodal(p, sum, nodal);
    for (int32_t i = 0; p->method && nb > 0 && i < p->h.n_nodes; ++i) {
        double elems_here = (double)(off[i + 1] - off[i]) / nb; /* w holds phi / elems_here */
        double *s = sum + 4 * (size_t)p->gnode[i];
        for (int64_t q = off[i]; q < off[i + 1]; ++q) {
            if (!p->owned[triple[q] / nb])
                continue;
            for (int c = 0; c < 3; ++c)
                s[c] += w[q] * elems_here * p->u[3 * triple[q] + c];
            s[3] += 1.0 / nb;
        }
    }
    for (int32_t e = 0; e < p->h.n_elems; ++e)
        if (p->owned[e])
            mises[p->gelem[e]] = local[e];
    MPI_Reduce(sum, nodes, (int)(4 * nn), MPI_DOUBLE, MPI_SUM, 0, PETSC_COMM_WORLD);
    MPI_Reduce(mises, vm, (int)ne, MPI_DOUBLE, MPI_SUM, 0, PETSC_COMM_WORLD);
    pf_free(sum), pf_free(mises), pf_free(local), pf_free(nodal);
    return PF_OK;
}

pf_status pf_sim_distrib_outputs(part *p, const distrib_out *o, pf_error *err)
{
    PF_TRY(gather_outputs(p, o ? o->nodes : NULL, o ? o->res->von_mises : NULL, err));
    if (!o)
        return PF_OK;
    const double *nodes = o->nodes;
    for (size_t i = 0; i < (size_t)p->h.all_nodes; ++i)
        for (int c = 0; c < 3; ++c)
            o->res->u[3 * i + c] = nodes[4 * i + 3] > 0 ? nodes[4 * i + c] / nodes[4 * i + 3] : 0;
    return o->frame ? o->frame(o->ctx, o->res, err) : PF_OK;
}

/* DG: the largest distance at a node between an owned element's field and the stitched field
 * avg [3 all_nodes] (eq. 30). */
static double node_jump(const part *p, const double *avg)
{
    if (!p->method)
        return 0;
    const int64_t *off, *triple;
    const double *w;
    p->ops->nodal_map(p->method, &off, &triple, &w);
    int32_t nb = p->nb3 / 3;
    double largest = 0;
    for (int32_t i = 0; i < p->h.n_nodes; ++i) {
        double elems_here = (double)(off[i + 1] - off[i]) / nb; /* w holds phi / elems_here */
        const double *a = avg + 3 * (size_t)p->gnode[i];
        for (int64_t q = off[i]; q < off[i + 1]; q += nb) { /* an element's nb triples */
            if (!p->owned[triple[q] / nb])
                continue;
            double d2 = 0;
            for (int c = 0; c < 3; ++c) {
                double value = 0;
                for (int32_t t = 0; t < nb; ++t)
                    value += w[q + t] * elems_here * p->u[3 * triple[q + t] + c];
                d2 += (value - a[c]) * (value - a[c]);
            }
            largest = fmax(largest, sqrt(d2));
        }
    }
    return largest;
}

/* pf_sim_error_indicator of the part's state into rank 0's res (collective, after the outputs):
 * CG the largest boundary error of the shape functions over all ranks' elements; DG the largest
 * node jump of the owned elements (against rank 0's stitched field, sent to every rank) over the
 * largest stitched displacement. */
static pf_status error_indicator(part *p, const distrib_out *o, pf_error *err)
{
    double mine = 0, all = 0;
    if (p->scene.method == PF_METHOD_CG) {
        /* the field does not enter: the shape functions' error */
        mine = p->method ? p->ops->error_indicator(p->method, p->u) : 0;
        MPI_Reduce(&mine, &all, 1, MPI_DOUBLE, MPI_MAX, 0, PETSC_COMM_WORLD);
        if (o)
            o->res->error_indicator = all;
        return PF_OK;
    }
    size_t nn = (size_t)p->h.all_nodes;
    double *u = o ? o->res->u : pf_alloc_array(3 * nn + 1, sizeof *u);
    pf_status st = u ? PF_OK
                     : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                    "cannot allocate the displacements of %zu nodes", nn);
    st = pf_sim_distrib_agree(st, err);
    if (st >= 0) {
        MPI_Bcast(u, (int)(3 * nn), MPI_DOUBLE, 0, PETSC_COMM_WORLD);
        mine = node_jump(p, u);
        MPI_Reduce(&mine, &all, 1, MPI_DOUBLE, MPI_MAX, 0, PETSC_COMM_WORLD);
    }
    if (!o) {
        pf_free(u);
        return st;
    }
    double umax = 0;
    for (size_t i = 0; i < nn; ++i)
        umax = fmax(umax, sqrt(u[3 * i] * u[3 * i] + u[3 * i + 1] * u[3 * i + 1] +
                               u[3 * i + 2] * u[3 * i + 2]));
    o->res->error_indicator = umax > 0 ? all / umax : 0;
    return st;
}

static void release_part(part *p)
{
    if (p->ops)
        p->ops->destroy(p->method);
    pf_block_matrix_release(&p->k);
    pf_mesh_release(&p->mesh);
    pf_scene_release(&p->scene);
    pf_free(p->pelem), pf_free(p->gelem), pf_free(p->gnode), pf_free(p->owned);
    pf_free(p->boundary), pf_free(p->sharers);
    pf_free(p->f), pf_free(p->u);
    pf_free(p->row), pf_free(p->row_owned), pf_free(p->wdof);
    pf_free(p->coo_v);
    pf_sim_distrib_cg_release(p);
}

void pf_sim_distrib_result_counts(const part *p, const rank_stats *rs, pf_sim_distrib_result *res)
{
    if (!res)
        return;
    res->iterations = (int32_t)rs->iterations;
    res->residual = rs->residual;
    res->penalty = p->penalty;
    res->penalty_doublings = p->doublings;
    bool searched =
        p->scene.method == PF_METHOD_DG && p->scene.penalty <= 0 && p->scene.flux != PF_FLUX_BZ;
    res->factorisations = searched ? p->doublings + 1 : 0; /* MUMPS's definiteness tests */
    res->dofs = p->all_rows;
}

/* A static scene's solve, its frame and checkpoint; restoring, the checkpoint's solution and its
 * outputs (no frame: the stream resumed has it). */
static pf_status static_part(part *p, rank_stats *rs, double cpu0, const distrib_out *o,
                             pf_error *err)
{
    /* at time 0, at rest, the energy check not started; the solve counts as a frame advanced
     * (pf_sim_solve_static), the stream's frame is 0 */
    pf_sim_saved saved = {.frame = 1};
    if (p->h.restoring) {
        rs->setup_cpu = pf_cpu_seconds() - cpu0;
        return pf_sim_distrib_resume(p, NULL, &saved, o, err);
    }
    PF_TRY(pf_sim_distrib_agree(solve_part(p, rs, cpu0, err), err));
    PF_TRY(pf_sim_distrib_agree(pf_sim_distrib_outputs(p, o, err), err));
    return pf_sim_distrib_checkpoint_due(p, 0)
               ? pf_sim_distrib_checkpoint(p, NULL, &saved, rs, o, err)
               : PF_OK;
}

/* Every rank's half after the parts went out (st: whether they did): set-up, then the static
 * solve or the dynamic frames, outputs (to o on rank 0, NULL elsewhere) and every rank's
 * statistics. */
static pf_status run_part(pf_status st, pf_buffer *msg, double cpu0, const distrib_out *o,
                          pf_error *err)
{
    pf_sim_distrib_result *res = o ? o->res : NULL;
    part p = {0};
    rank_stats rs = {0};
    st = pf_sim_distrib_agree(st >= 0 ? unpack_part(&p, msg, err) : st, err);
    pf_buffer_release(msg);
    if (st >= 0)
        st = pf_sim_distrib_agree(create_part(&p, err), err);
    if (st >= 0)
        st = pf_sim_distrib_agree(allocate_part(&p, err), err);
    if (st >= 0)
        st = pf_sim_distrib_agree(setup_part(&p, err), err);
    if (st >= 0)
        st = pf_sim_distrib_agree(pf_sim_distrib_whole_dofs(&p, err), err);
    if (st >= 0 && !p.scene.is_static)
        st = pf_sim_distrib_dynamics(&p, o, &rs, cpu0, err); /* agreed at every step */
    if (st >= 0 && p.scene.is_static)
        st = static_part(&p, &rs, cpu0, o, err);
    if (res)
        res->error_indicator = NAN;
    if (st >= 0)
        st = error_indicator(&p, o, err);
    rs.owned = p.n_owned;
    rs.cpu = pf_cpu_seconds() - cpu0;
    rs.rss_mb = peak_rss_mb();
    rank_stats *all = res ? pf_alloc_array((size_t)res->ranks, sizeof *all) : NULL;
    MPI_Gather(&rs, (int)(sizeof rs / sizeof(double)), MPI_DOUBLE, all,
               (int)(sizeof rs / sizeof(double)), MPI_DOUBLE, 0, PETSC_COMM_WORLD);
    for (int32_t r = 0; all && r < res->ranks; ++r)
        res->rank[r] = (pf_sim_distrib_rank){.elements = (int32_t)all[r].owned,
                                             .setup_cpu_seconds = all[r].setup_cpu,
                                             .assembly_cpu_seconds = all[r].assembly_cpu,
                                             .solve_cpu_seconds = all[r].solve_cpu,
                                             .cpu_seconds = all[r].cpu,
                                             .peak_rss_mb = all[r].rss_mb};
    pf_sim_distrib_result_counts(&p, &rs, res);
    pf_free(all);
    release_part(&p);
    return st;
}

/* Whether a region is a node or element list (indices of the whole mesh, not of a part). */
static bool is_list(const pf_region *r)
{
    return r->kind == PF_REGION_NODES || r->kind == PF_REGION_ELEMENTS;
}

bool pf_sim_distrib_applies(const pf_scene *scene, bool embedded)
{
    bool lists = false;
    for (int32_t k = 0; k < scene->n_fixed; ++k)
        lists |= is_list(&scene->fixed[k].region);
    for (int32_t k = 0; k < scene->n_loads; ++k)
        lists |= is_list(&scene->loads[k].region);
    for (int32_t k = 0; k < scene->n_materials; ++k)
        lists |= is_list(&scene->materials[k].region);
    /* dynamics: with a fixed mesh; contact at the mesh's boundary nodes, not at an embedded
     * surface's vertices (whose rows reach across parts) */
    bool dynamic = !pf_scene_changes_mesh(scene) && !(pf_scene_has_contact(scene) && embedded);
    return scene->solver.method == PF_SOLVER_PETSC && (scene->is_static || dynamic) &&
           (scene->method == PF_METHOD_CG || scene->method == PF_METHOD_DG) && scene->n_cuts == 0 &&
           !lists;
}

pf_status pf_sim_distrib_serve(pf_error *err)
{
    double cpu0 = pf_cpu_seconds();
    pf_status st = pf_sim_distrib_agree(PF_OK, err); /* rank 0's partition */
    pf_buffer msg = {0};
    if (st >= 0)
        st = receive_part(&msg, err);
    return run_part(st, &msg, cpu0, NULL, err);
}

pf_status pf_sim_distrib_run_with(const pf_scene *scene, const pf_mesh *mesh,
                                  const pf_sim_distrib_options *opt, pf_sim_distrib_result *out,
                                  pf_error *err)
{
    memset(out, 0, sizeof *out);
    PetscBool up = PETSC_FALSE;
    PetscInitialized(&up);
    if (!up)
        PF_TRY(pf_petsc_initialize(NULL, NULL, NULL, NULL, err));
    PF_CHECK(rank_of() == 0, err, PF_ERR_INVALID, "the distributed solve is driven by rank 0");
    PF_CHECK(pf_sim_distrib_applies(scene, false), err, PF_ERR_INVALID,
             "the distributed assembly takes scenes with the petsc solver without node or element "
             "lists: static ones, and dynamic ones without cuts or refinement");
    double cpu0 = pf_cpu_seconds();
    out->ranks = ranks();
    size_t nn = (size_t)mesh->n_nodes;
    double *nodes = pf_alloc_array(4 * nn + 1, sizeof *nodes);
    out->u = pf_alloc_array(3 * nn + 1, sizeof *out->u);
    out->von_mises = pf_alloc_array((size_t)mesh->n_elems + 1, sizeof *out->von_mises);
    out->rank = pf_calloc((size_t)out->ranks, sizeof *out->rank);
    if (!nodes || !out->u || !out->von_mises || !out->rank) {
        pf_free(nodes);
        pf_sim_distrib_result_release(out);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate the outputs of %zu nodes", nn);
    }
    pf_petsc_start_task();
    pf_buffer mine = {0};
    distrib_out o = {.res = out,
                     .nodes = nodes,
                     .frame = opt ? opt->frame : NULL,
                     .ctx = opt ? opt->ctx : NULL,
                     .opt = opt,
                     .scene = scene,
                     .mesh = mesh};
    pf_status st = send_parts(mesh, scene, &o, &mine, err);
    st = run_part(st, &mine, cpu0, &o, err);
    pf_free(nodes);
    return st;
}

pf_status pf_sim_distrib_run(const pf_scene *scene, const pf_mesh *mesh,
                             pf_sim_distrib_frame_fn frame, void *ctx, pf_sim_distrib_result *out,
                             pf_error *err)
{
    pf_sim_distrib_options opt = {.frame = frame, .ctx = ctx};
    return pf_sim_distrib_run_with(scene, mesh, &opt, out, err);
}

pf_status pf_sim_distrib_static(const pf_scene *scene, const pf_mesh *mesh,
                                pf_sim_distrib_result *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    PF_CHECK(scene->is_static, err, PF_ERR_INVALID, "pf_sim_distrib_static takes static scenes");
    return pf_sim_distrib_run(scene, mesh, NULL, NULL, out, err);
}

#else /* without PETSc */

bool pf_sim_distrib_applies(const pf_scene *scene, bool embedded)
{
    (void)scene, (void)embedded;
    return false;
}

pf_status pf_sim_distrib_serve(pf_error *err)
{
    return pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__, "built without PETSc");
}

pf_status pf_sim_distrib_run(const pf_scene *scene, const pf_mesh *mesh,
                             pf_sim_distrib_frame_fn frame, void *ctx, pf_sim_distrib_result *out,
                             pf_error *err)
{
    (void)frame, (void)ctx;
    return pf_sim_distrib_static(scene, mesh, out, err);
}

pf_status pf_sim_distrib_run_with(const pf_scene *scene, const pf_mesh *mesh,
                                  const pf_sim_distrib_options *opt, pf_sim_distrib_result *out,
                                  pf_error *err)
{
    (void)opt;
    return pf_sim_distrib_static(scene, mesh, out, err);
}

pf_status pf_sim_distrib_static(const pf_scene *scene, const pf_mesh *mesh,
                                pf_sim_distrib_result *out, pf_error *err)
{
    (void)scene, (void)mesh;
    memset(out, 0, sizeof *out);
    return pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                        "this pf was built without PETSc: configure with -DPF_PETSC=ON");
}

#endif

void pf_sim_distrib_result_release(pf_sim_distrib_result *r)
{
    pf_free(r->u), pf_free(r->von_mises), pf_free(r->rank);
    memset(r, 0, sizeof *r);
}
