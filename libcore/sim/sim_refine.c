/* Stress-based refinement and coarsening (DG paper sec. 9.3, harmonic paper sec. 8; coarsening,
 * which neither paper does, is the inverse: children merged back into their parent).
 *
 * Every element carries its level (splits deep), its family (the split that made it, an index
 * into s->families, -1 for the elements of the first mesh) and a calm count (frames in a row
 * with its stress below the coarsening stress). A family whose children are all still there (none
 * split further) and all calm for coarsen_after frames merges back. The band between the
 * coarsening stress (coarsen_fraction * threshold) and the threshold is the hysteresis: a merged
 * parent carries its children's field, below the coarsening stress, so it is not split again
 * until its stress has grown past the threshold. The mesh changes themselves are sim_change.c's. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_change.h"

/* A split: the family of the element split, its children, their level. */
typedef struct family {
    int32_t parent_family;
    int32_t children;
    int32_t level;
} family;

static const family *families(const pf_sim *s)
{
    return (const family *)(const void *)s->families.data;
}

static int32_t n_families(const pf_sim *s)
{
    return (int32_t)(s->families.size / sizeof(family));
}

/* The bookkeeping arrays of n elements, allocated together or not at all. */
static pf_status allocate_bookkeeping(int32_t n, int32_t **level, int32_t **fam, int32_t **calm,
                                      pf_error *err)
{
    *level = pf_calloc((size_t)n + 1, sizeof **level);
    *fam = pf_alloc_array((size_t)n + 1, sizeof **fam);
    *calm = pf_calloc((size_t)n + 1, sizeof **calm);
    if (*level && *fam && *calm)
        return PF_OK;
    pf_free(*level);
    pf_free(*fam);
    pf_free(*calm);
    *level = *fam = *calm = NULL;
    return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                        "cannot allocate the bookkeeping of %d elements", (int)n);
}

/* s (on the new mesh) takes the bookkeeping arrays and the family table of old. */
static void install_bookkeeping(pf_sim *s, pf_sim *old, int32_t *level, int32_t *fam, int32_t *calm)
{
    s->level = level;
    s->family = fam;
    s->calm = calm;
    pf_buffer_release(&s->families);
    s->families = old->families;
    memset(&old->families, 0, sizeof old->families);
}

static int32_t level_of(const pf_sim *s, int32_t e)
{
    return s->level ? s->level[e] : 0;
}

static int32_t family_of(const pf_sim *s, int32_t e)
{
    return s->family ? s->family[e] : -1;
}

/* split[p] = 1 for the old elements with more than one child. */
static uint8_t *split_parents(const int32_t *parent, int32_t n_new, int32_t n_old)
{
    int32_t *children = pf_calloc((size_t)n_old + 1, sizeof *children);
    uint8_t *split = pf_calloc((size_t)n_old + 1, 1);
    if (!children || !split) {
        pf_free(children);
        pf_free(split);
        return NULL;
    }
    for (int32_t e = 0; e < n_new; ++e)
        children[parent[e]]++;
    for (int32_t p = 0; p < n_old; ++p)
        split[p] = children[p] > 1;
    pf_free(children);
    return split;
}

/* One new family per split parent (in the old mesh's order), its children numbered so. */
static pf_status record_splits(pf_sim *s, const pf_sim *old, const int32_t *parent,
                               const uint8_t *split, int32_t *level, int32_t *fam, pf_error *err)
{
    int32_t n_old = old->mesh->n_elems, n_new = s->mesh->n_elems;
    int32_t *first_child = pf_alloc_array((size_t)n_old + 1, sizeof *first_child);
    PF_CHECK(first_child, err, PF_ERR_NOMEM, "cannot allocate %d split slots", (int)n_old);
    for (int32_t p = 0; p < n_old; ++p)
        first_child[p] = -1;
    for (int32_t e = 0; e < n_new; ++e) {
        int32_t p = parent[e];
        if (!split[p]) {
            level[e] = level_of(old, p);
            fam[e] = family_of(old, p);
            continue;
        }
        if (first_child[p] < 0) {
            first_child[p] = n_families(s);
            family f = {family_of(old, p), 0, level_of(old, p) + 1};
            pf_status st = pf_buffer_append(&s->families, &f, sizeof f, err);
            if (st < 0) {
                pf_free(first_child);
                return st;
            }
        }
        family *f = (family *)(void *)s->families.data + first_child[p];
        f->children++;
        level[e] = f->level;
        fam[e] = first_child[p];
    }
    pf_free(first_child);
    return PF_OK;
}

pf_status pf_sim_split(pf_sim *s, const pf_refine_request *req, int32_t n_req, int32_t *n_split,
                       pf_error *err)
{
    double t0 = pf_cpu_seconds();
    if (n_split)
        *n_split = 0;
    pf_mesh next = {0};
    pf_refine_result res = {0};
    PF_TRY(pf_mesh_refine(s->mesh, req, n_req, &next, &res, err));
    double mesh_seconds = pf_cpu_seconds() - t0;
    int32_t n_old = s->mesh->n_elems, n_new = next.n_elems;
    int32_t *level = NULL, *fam = NULL, *calm = NULL;
    uint8_t *split = NULL;
    pf_sim *old = NULL;
    pf_status st = PF_OK;
    if (res.n_split > 0) {
        split = split_parents(res.parent, n_new, n_old);
        st = split ? allocate_bookkeeping(n_new, &level, &fam, &calm, err)
                   : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                  "cannot allocate %d split flags", (int)n_old);
    }
    pf_mesh_change change = {
        .old_mesh = s->mesh, .parent = res.parent, .split = split, .face_src = res.face_src};
    if (res.n_split > 0 && st >= 0)
        st = pf_sim_change_mesh(s, &next, &change, res.changed, &old, err);
    if (old) {
        install_bookkeeping(s, old, level, fam, calm);
        level = fam = calm = NULL;
        st = record_splits(s, old, res.parent, split, s->level, s->family, err);
        s->stats.elements_split += res.n_split;
        s->stats.refine_seconds += pf_cpu_seconds() - t0;
        s->stats.refine_mesh_seconds += mesh_seconds;
        if (n_split)
            *n_split = res.n_split;
    }
    if (st < 0)
        pf_error_prefix(err, "refining %d elements", (int)n_req);
    pf_sim_destroy(&old);
    pf_free(level);
    pf_free(fam);
    pf_free(calm);
    pf_free(split);
    pf_mesh_release(&next);
    pf_refine_result_release(&res);
    return st;
}

/* A merged element has been calm as long as the least calm of the elements merged into it (each
 * below the coarsening stress that many frames, and its field is their projection), so that the
 * family above it can merge as soon as the rest of that family is calm too, instead of waiting
 * coarsen_after frames more per level. Its own stress is measured at the next criterion before
 * any further merge, and resets the count when it is not calm. */
static void merged_calm(const pf_sim *old, const int32_t *merged_into, int32_t n_old,
                        int32_t *calm)
{
    if (!old->calm)
        return;
    for (int32_t q = 0; q < n_old; ++q)
        if (merged_into[q] >= 0)
            calm[merged_into[q]] = INT32_MAX;
    for (int32_t q = 0; q < n_old; ++q)
        if (merged_into[q] >= 0 && old->calm[q] < calm[merged_into[q]])
            calm[merged_into[q]] = old->calm[q];
}

pf_status pf_sim_merge(pf_sim *s, const int32_t *group, int32_t *n_merged, pf_error *err)
{
    double t0 = pf_cpu_seconds();
    if (n_merged)
        *n_merged = 0;
    pf_mesh next = {0};
    pf_coarsen_result res = {0};
    PF_TRY(pf_mesh_coarsen(s->mesh, group, &next, &res, err));
    double mesh_seconds = pf_cpu_seconds() - t0;
    int32_t n_old = s->mesh->n_elems, n_new = next.n_elems;
    int32_t *merged_into = pf_alloc_array((size_t)n_old + 1, sizeof *merged_into);
    int32_t *level = NULL, *fam = NULL, *calm = NULL;
    pf_status st = merged_into ? allocate_bookkeeping(n_new, &level, &fam, &calm, err)
                               : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                              "cannot allocate %d merge slots", (int)n_old);
    if (st >= 0) {
        /* a group's new element is the one whose parent is in the group */
        int32_t *new_of_group = pf_alloc_array((size_t)n_old + 1, sizeof *new_of_group);
        st = new_of_group ? PF_OK
                          : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                         "cannot allocate %d group slots", (int)n_old);
        for (int32_t e = 0; st >= 0 && e < n_new; ++e)
            if (group[res.parent[e]] >= 0)
                new_of_group[group[res.parent[e]]] = e;
        for (int32_t q = 0; st >= 0 && q < n_old; ++q)
            merged_into[q] = group[q] >= 0 ? new_of_group[group[q]] : -1;
        pf_free(new_of_group);
    }
    pf_mesh_change change = {.old_mesh = s->mesh,
                             .parent = res.parent,
                             .merged_into = merged_into,
                             .node_map = res.node_map,
                             .face_src = res.face_src};
    pf_sim *old = NULL;
    if (st >= 0 && res.n_merged > 0)
        st = pf_sim_change_mesh(s, &next, &change, res.changed, &old, err);
    if (old) {
        for (int32_t e = 0; e < n_new; ++e) {
            int32_t p = res.parent[e], f = family_of(old, p);
            bool merged = merged_into[p] >= 0;
            level[e] = merged && level_of(old, p) > 0 ? level_of(old, p) - 1 : level_of(old, p);
            fam[e] = merged && f >= 0 ? families(old)[f].parent_family : merged ? -1 : f;
            calm[e] = merged || !old->calm ? 0 : old->calm[p];
        }
        merged_calm(old, merged_into, n_old, calm);
        install_bookkeeping(s, old, level, fam, calm);
        level = fam = calm = NULL;
        s->stats.elements_merged += res.n_merged;
        s->stats.refine_seconds += pf_cpu_seconds() - t0;
        s->stats.refine_mesh_seconds += mesh_seconds;
        if (n_merged)
            *n_merged = res.n_merged;
    }
    if (st < 0)
        pf_error_prefix(err, "coarsening");
    pf_sim_destroy(&old);
    pf_free(level);
    pf_free(fam);
    pf_free(calm);
    pf_free(merged_into);
    pf_mesh_release(&next);
    pf_coarsen_result_release(&res);
    return st;
}

/* ---- the criterion ---------------------------------------------------------------------- */

/* A refinement candidate: an element, its stress and the stress's direction. */
typedef struct candidate {
    int32_t elem;
    double stress; /* absolute */
    pf_vec3 direction;
} candidate;

/* The most stressed first; ties by element index (deterministic). */
static int compare_candidates(const void *pa, const void *pb)
{
    const candidate *a = pa, *b = pb;
    if (a->stress != b->stress)
        return a->stress > b->stress ? -1 : 1;
    return (a->elem > b->elem) - (a->elem < b->elem);
}

static int compare_requests(const void *pa, const void *pb)
{
    const pf_refine_request *a = pa, *b = pb;
    return (a->elem > b->elem) - (a->elem < b->elem);
}

/* Splits the candidates c[0 .. n), the most stressed first, while the mesh stays within
 * max_elements. */
static pf_status refine_candidates(pf_sim *s, candidate *c, int32_t n, int32_t *n_split,
                                   pf_error *err)
{
    const pf_refine_params *p = &s->scene->refine;
    qsort(c, (size_t)n, sizeof *c, compare_candidates);
    /* a split adds up to 7 elements (octs) or 1 (halves) */
    int64_t added = p->split == PF_SPLIT_OCTS ? 7 : 1, total = s->mesh->n_elems;
    pf_refine_request *req = pf_alloc_array((size_t)n + 1, sizeof *req);
    PF_CHECK(req, err, PF_ERR_NOMEM, "cannot allocate %d refinement requests", (int)n);
    int32_t n_req = 0;
    for (int32_t k = 0; k < n && total + added <= p->max_elements; ++k, total += added)
        req[n_req++] = (pf_refine_request){
            .elem = c[k].elem, .kind = p->split, .normal = c[k].direction};
    /* in the mesh's element order: the new mesh's numbering does not depend on the stresses */
    qsort(req, (size_t)n_req, sizeof *req, compare_requests);
    pf_status st = n_req > 0 ? pf_sim_split(s, req, n_req, n_split, err) : PF_OK;
    pf_free(req);
    return st;
}

/* The families whose children are all there and calm long enough, as merge groups; *n_groups. */
static pf_status calm_families(const pf_sim *s, int32_t *group, int32_t *n_groups, pf_error *err)
{
    const pf_refine_params *p = &s->scene->refine;
    int32_t nf = n_families(s), ne = s->mesh->n_elems;
    int32_t *present = pf_calloc((size_t)nf + 1, sizeof *present);
    int32_t *calm = pf_calloc((size_t)nf + 1, sizeof *calm);
    int32_t *id = pf_alloc_array((size_t)nf + 1, sizeof *id);
    if (!present || !calm || !id) {
        pf_free(present), pf_free(calm), pf_free(id);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate %d family counts", (int)nf);
    }
    for (int32_t e = 0; e < ne; ++e) {
        int32_t f = family_of(s, e);
        if (f < 0)
            continue;
        present[f]++;
        calm[f] += s->calm[e] >= p->coarsen_after;
    }
    *n_groups = 0;
    for (int32_t f = 0; f < nf; ++f)
        id[f] = present[f] == families(s)[f].children && calm[f] == present[f] ? (*n_groups)++ : -1;
    for (int32_t e = 0; e < ne; ++e)
        group[e] = family_of(s, e) >= 0 ? id[family_of(s, e)] : -1;
    pf_free(present), pf_free(calm), pf_free(id);
    return PF_OK;
}

pf_status pf_sim_refine(pf_sim *s, int32_t *n_changed, pf_error *err)
{
    const pf_refine_params *p = &s->scene->refine;
    if (n_changed)
        *n_changed = 0;
    if (!p->enabled)
        return PF_OK;
    double t0 = pf_cpu_seconds();
    const pf_mesh *m = s->mesh;
    int32_t ne = m->n_elems;
    if (!s->calm) { /* the first mesh: its elements are roots */
        pf_free(s->level), pf_free(s->family);
        PF_TRY(allocate_bookkeeping(ne, &s->level, &s->family, &s->calm, err));
        for (int32_t e = 0; e < ne; ++e)
            s->family[e] = -1;
    }
    candidate *c = pf_alloc_array((size_t)ne + 1, sizeof *c);
    int32_t *group = pf_alloc_array((size_t)ne + 1, sizeof *group);
    double *stress = pf_alloc_array((size_t)ne + 1, sizeof *stress);
    pf_vec3 *dir = pf_alloc_array((size_t)ne + 1, sizeof *dir);
    if (!c || !group || !stress || !dir) {
        pf_free(c), pf_free(group), pf_free(stress), pf_free(dir);
        return pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                            "cannot allocate %d refinement candidates", (int)ne);
    }
    s->ops->principal_stresses(s->method, s->u, stress, dir);
    int32_t n = 0;
    double calm_stress = p->coarsen_fraction * p->threshold;
    for (int32_t e = 0; e < ne; ++e) {
        double value = fabs(stress[e]);
        s->calm[e] = value < calm_stress ? s->calm[e] + 1 : 0;
        bool small = p->min_size > 0 && cbrt(fabs(pf_mesh_elem_volume(m, e))) <= p->min_size;
        if (value > p->threshold && s->level[e] < p->max_level && !small)
            c[n++] = (candidate){e, value, dir[e]};
    }
    pf_free(stress);
    pf_free(dir);
    double criterion_seconds = pf_cpu_seconds() - t0;
    /* merging first; splits wait for the next frame (their stresses are the old mesh's) */
    int32_t n_groups = 0;
    pf_status st = p->coarsen_fraction > 0 ? calm_families(s, group, &n_groups, err) : PF_OK;
    if (st >= 0 && n_groups > 0)
        st = pf_sim_merge(s, group, n_changed, err);
    else if (st >= 0)
        st = refine_candidates(s, c, n, n_changed, err);
    pf_free(c);
    pf_free(group);
    s->stats.refine_seconds += criterion_seconds;
    return st;
}
