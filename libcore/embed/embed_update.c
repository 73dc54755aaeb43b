/* Embedding weights after a change of the simulation mesh (refinement, coarsening): only the MLS
 * rows whose support the change reaches are recomputed, the others are copied with their nodes
 * renumbered. An MLS row is a function of its support alone (mls.c), so the result is bit for
 * bit the full computation on the new mesh. */
#include "mls_internal.h"

#include <string.h>

typedef struct node_changes {
    const int32_t *node_map; /* [old nodes] or NULL: the identity */
    uint8_t *old_changed;    /* [old nodes] removed, moved, or of a new radius */
    int32_t *changed;        /* [n_changed] new nodes that are new, moved, or of a new radius */
    int32_t n_changed;
    double r_max;            /* largest radius of those */
    bucket_grid grid;        /* their support boxes; items index changed[] */
} node_changes;

static void changes_release(node_changes *nc)
{
    pf_free(nc->old_changed);
    pf_free(nc->changed);
    pf_bucket_grid_release(&nc->grid);
    memset(nc, 0, sizeof *nc);
}

static int32_t mapped(const node_changes *nc, int32_t i)
{
    return nc->node_map ? nc->node_map[i] : i;
}

/* A node is the same when an old node maps to it with the same position and radius bits. */
static void mark_changes(node_changes *nc, const pf_mesh *old_mesh, const double *old_radius,
                         const pf_mesh *m, const double *radius, uint8_t *new_same)
{
    memset(new_same, 0, (size_t)m->n_nodes);
    for (int32_t i = 0; i < old_mesh->n_nodes; ++i) {
        int32_t j = mapped(nc, i);
        bool same = j >= 0 &&
                    !memcmp(old_mesh->x + 3 * (size_t)i, m->x + 3 * (size_t)j, 3 * sizeof *m->x) &&
                    !memcmp(old_radius + i, radius + j, sizeof *radius);
        nc->old_changed[i] = !same;
        if (same)
            new_same[j] = 1;
    }
    nc->n_changed = 0;
    for (int32_t j = 0; j < m->n_nodes; ++j)
        if (!new_same[j]) {
            nc->changed[nc->n_changed++] = j;
            nc->r_max = fmax(nc->r_max, radius[j]);
        }
}

static pf_status find_changes(node_changes *nc, const pf_mesh *old_mesh, const pf_mesh *m,
                              const pf_embed_params *p, const double *radius, pf_error *err)
{
    double *old_radius = NULL, *box = NULL;
    uint8_t *new_same = NULL;
    pf_status st = PF_OK;
    if (!PF_ALLOC_N(old_radius, (size_t)old_mesh->n_nodes) ||
        !PF_ALLOC_N(nc->old_changed, (size_t)old_mesh->n_nodes) ||
        !PF_ALLOC_N(nc->changed, (size_t)m->n_nodes) || !PF_ALLOC_N(new_same, (size_t)m->n_nodes))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                          "out of memory for the node changes of %d nodes", (int)m->n_nodes);
    if (st >= 0)
        st = pf_embed_mls_radii(old_mesh, p, old_radius, err);
    if (st >= 0)
        mark_changes(nc, old_mesh, old_radius, m, radius, new_same);
    if (st >= 0 && nc->n_changed > 0 && !PF_ALLOC_N(box, 6 * (size_t)nc->n_changed))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                          "out of memory for %d node boxes", (int)nc->n_changed);
    if (st >= 0 && nc->n_changed > 0) {
        double mean = 0;
        for (int32_t k = 0; k < nc->n_changed; ++k) {
            int32_t j = nc->changed[k];
            mean += radius[j];
            for (int a = 0; a < 3; ++a) {
                box[6 * (size_t)k + a] = m->x[3 * (size_t)j + a] - radius[j];
                box[6 * (size_t)k + 3 + a] = m->x[3 * (size_t)j + a] + radius[j];
            }
        }
        st = pf_bucket_grid_build(&nc->grid, box, nc->n_changed, mean / nc->n_changed, err);
    }
    pf_free(old_radius);
    pf_free(new_same);
    pf_free(box);
    return st;
}

/* Whether node j is in the support of x at the given scale (as mls.c's test). */
static bool reaches(const pf_mesh *m, const double *radius, int32_t j, pf_vec3 x, double scale)
{
    pf_vec3 d = pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)j), x);
    double r = scale * radius[j];
    return pf_v3_dot(d, d) / (r * r) < 1;
}

/* Whether a changed node of the new mesh reaches x at the row's scale (or below: the supports
 * grow with the scale). Its box, of half side its radius, holds x at scale 1; grown, the node
 * lies within scale * r_max of x. */
typedef struct reach_query {
    const node_changes *nc;
    const pf_mesh *m;
    const double *radius;
    pf_vec3 x;
    double scale;
} reach_query;

static int changed_node_reaches(void *ctx, int32_t item)
{
    const reach_query *q = ctx;
    return reaches(q->m, q->radius, q->nc->changed[item], q->x, q->scale);
}

static bool new_node_reaches(const node_changes *nc, const pf_mesh *m, const double *radius,
                             pf_vec3 x, double scale)
{
    if (nc->n_changed == 0)
        return false;
    reach_query q = {nc, m, radius, x, scale};
    double reach = scale == 1 ? 0 : scale * nc->r_max;
    return pf_bucket_grid_visit(&nc->grid, x, reach, changed_node_reaches, &q) != 0;
}

/* The old row of v renumbered into col (false when it must be recomputed: it holds a changed
 * node, or the renumbering reorders it). */
static bool copy_row(const node_changes *nc, const pf_weights *old, int32_t v, uint32_t *col)
{
    int64_t lo = old->row_offsets[v], hi = old->row_offsets[v + 1];
    int64_t prev = -1;
    for (int64_t q = lo; q < hi; ++q) {
        int32_t i = (int32_t)old->col[q];
        if (nc->old_changed[i])
            return false;
        int32_t j = mapped(nc, i);
        if (j <= prev)
            return false;
        col[q - lo] = (uint32_t)j;
        prev = j;
    }
    return true;
}

typedef struct update_job {
    const pf_weights *old;
    const int32_t *old_steps;
    const pf_surface *s;
    node_changes nc;
    mls_context c;
    row_builder b;
    uint32_t *col; /* [longest old row] */
    double *val;   /* [same] */
} update_job;

/* Marks the rows to recompute (redo[v]) and returns the entries of the rows copied plus twice
 * those of the rows recomputed: room for them to grow without moving the arrays. */
static int64_t mark_rows(update_job *u, uint8_t *redo)
{
    const pf_weights *old = u->old;
    int64_t room = 0;
    for (int32_t v = 0; v < u->s->n_verts; ++v) {
        pf_vec3 x = pf_v3_load(u->s->x + 3 * (size_t)v);
        double scale = pf_mls_scale(u->c.p, u->old_steps[v]);
        redo[v] = !copy_row(&u->nc, old, v, u->col) ||
                  new_node_reaches(&u->nc, u->c.m, u->c.radius, x, scale);
        room += (old->row_offsets[v + 1] - old->row_offsets[v]) * (redo[v] ? 2 : 1);
    }
    return room;
}

static pf_status update_rows(update_job *u, const uint8_t *redo, int32_t *steps,
                             pf_embed_update_stats *st, pf_error *err)
{
    pf_embed_stats row_stats;
    memset(&row_stats, 0, sizeof row_stats);
    const pf_weights *old = u->old;
    for (int32_t v = 0; v < u->s->n_verts; ++v) {
        int32_t n = (int32_t)(old->row_offsets[v + 1] - old->row_offsets[v]);
        if (!redo[v]) {
            copy_row(&u->nc, old, v, u->col);
            memcpy(u->val, old->val + old->row_offsets[v], (size_t)n * sizeof *u->val);
            PF_TRY(pf_row_builder_add(&u->b, v, u->col, u->val, n, err));
            steps[v] = u->old_steps[v];
            continue;
        }
        uint32_t *col;
        double *val;
        pf_vec3 x = pf_v3_load(u->s->x + 3 * (size_t)v);
        PF_TRY(pf_mls_row(&u->c, v, x, &col, &val, &n, &steps[v], &row_stats, err));
        PF_TRY(pf_row_builder_add(&u->b, v, col, val, n, err));
        st->rows_computed++;
    }
    return PF_OK;
}

static pf_status check_old(const pf_mesh *old_mesh, const pf_weights *old,
                           const int32_t *old_steps, const pf_mesh *m, const int32_t *node_map,
                           const pf_surface *s, pf_error *err)
{
    PF_CHECK(old->rows == s->n_verts && old->cols == old_mesh->n_nodes && old_steps, err,
             PF_ERR_INVALID,
             "weights of %d x %d (steps %s) do not fit a surface of %d vertices on a mesh of %d "
             "nodes",
             (int)old->rows, (int)old->cols, old_steps ? "given" : "missing", (int)s->n_verts,
             (int)old_mesh->n_nodes);
    for (int32_t i = 0; node_map && i < old_mesh->n_nodes; ++i)
        PF_CHECK(node_map[i] >= -1 && node_map[i] < m->n_nodes, err, PF_ERR_INVALID,
                 "node map: old node %d goes to %d, not a node of the new mesh (%d nodes)", (int)i,
                 (int)node_map[i], (int)m->n_nodes);
    return PF_OK;
}

static pf_status update_mls(update_job *u, const pf_mesh *old_mesh, const pf_mesh *m,
                            const pf_embed_params *p, pf_weights *w, int32_t *steps,
                            pf_embed_update_stats *st, pf_error *err)
{
    int64_t longest = 1;
    for (int32_t v = 0; v < u->old->rows; ++v)
        if (u->old->row_offsets[v + 1] - u->old->row_offsets[v] > longest)
            longest = u->old->row_offsets[v + 1] - u->old->row_offsets[v];
    PF_CHECK(PF_ALLOC_N(u->col, (size_t)longest) && PF_ALLOC_N(u->val, (size_t)longest), err,
             PF_ERR_NOMEM, "out of memory for a row of %lld weights", (long long)longest);
    PF_TRY(pf_mls_init(&u->c, m, p, NULL, err));
    PF_TRY(find_changes(&u->nc, old_mesh, m, p, u->c.radius, err));
    st->nodes_changed = u->nc.n_changed;
    uint8_t *redo = NULL;
    PF_CHECK(PF_ALLOC_N(redo, (size_t)u->s->n_verts), err, PF_ERR_NOMEM,
             "out of memory for %d row flags", (int)u->s->n_verts);
    int64_t room = mark_rows(u, redo);
    pf_status status = pf_row_builder_init(&u->b, w, u->s->n_verts, m->n_nodes, room + 16, err);
    if (status >= 0)
        status = update_rows(u, redo, steps, st, err);
    pf_free(redo);
    if (status >= 0)
        pf_row_builder_finish(&u->b);
    return status;
}

pf_status pf_embed_update(const pf_mesh *old_mesh, const pf_weights *old, const int32_t *old_steps,
                          const pf_mesh *m, const int32_t *node_map, const pf_surface *s,
                          const pf_embed_params *params, pf_weights *w, int32_t *steps,
                          pf_embed_update_stats *stats, pf_error *err)
{
    double t0 = pf_cpu_seconds();
    memset(w, 0, sizeof *w);
    pf_embed_update_stats local;
    pf_embed_update_stats *st = stats ? stats : &local;
    memset(st, 0, sizeof *st);
    st->rows = s->n_verts;
    pf_embed_params p;
    PF_TRY(pf_embed_resolve_params(params, &p, err));
    if (p.method != PF_EMBED_MLS || p.blocking_faces) {
        st->rows_computed = s->n_verts;
        PF_TRY(pf_embed_compute_steps(m, s, params, w, steps, NULL, err));
        st->cpu_seconds = pf_cpu_seconds() - t0;
        return PF_OK;
    }
    PF_TRY(check_old(old_mesh, old, old_steps, m, node_map, s, err));
    PF_TRY(pf_embed_check_inputs(m, s, err));
    update_job u;
    memset(&u, 0, sizeof u);
    u.old = old;
    u.old_steps = old_steps;
    u.s = s;
    u.nc.node_map = node_map;
    pf_status status = update_mls(&u, old_mesh, m, &p, w, steps, st, err);
    pf_free(u.col);
    pf_free(u.val);
    pf_mls_release(&u.c);
    changes_release(&u.nc);
    if (status < 0) {
        pf_weights_release(w);
        return status;
    }
    w->surface_id = s->id;
    w->mesh_id = m->id;
    st->cpu_seconds = pf_cpu_seconds() - t0;
    return PF_OK;
}
