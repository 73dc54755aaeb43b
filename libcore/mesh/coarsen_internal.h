/* Internal to libcore/mesh: the state of pf_mesh_coarsen (coarsen.c: groups, merging, output;
 * coarsen_clean.c: uniting faces and removing nodes). */
#ifndef PF_COARSEN_INTERNAL_H
#define PF_COARSEN_INTERNAL_H

#include <pf/refine.h>

#include "mesh_internal.h"

#include <string.h>

enum { FACE_SRC = 0, FACE_DEAD = 1, FACE_OWN = 2 };

typedef struct coarsen {
    const pf_mesh *src;
    /* groups, numbered by their first element; elements ascending in each */
    int32_t n_groups;
    int32_t *group_off;  /* [n_groups + 1] */
    int32_t *group_elem; /* [group_off[n_groups]] */
    int32_t *elem_group; /* [src->n_elems] compact group, -1 for an element that stays */
    int32_t *face_user;  /* [2 src->n_faces] element using the face as stored, then reversed */
    /* faces */
    uint8_t *face_state; /* [src->n_faces] FACE_* */
    int64_t *own_start;  /* [src->n_faces] with FACE_OWN: the polygon in pool */
    int32_t *own_len;
    int64_t n_pool, cap_pool;
    uint32_t *pool;
    int32_t *dead;  /* faces removed inside groups (their edges are the cut edges) */
    int64_t n_dead; /* of them */
    /* cut edges: undirected edges of the dead faces, an open-addressing set */
    int64_t edge_slots;
    uint64_t *edge_table;
    /* nodes */
    uint8_t *candidate; /* [src->n_nodes] may have become unneeded */
    int32_t *node_map;  /* [src->n_nodes] */
    uint8_t *touched;   /* [src->n_elems] an element some face of which changed */
    pf_buffer cands;    /* int32 the candidate nodes */
} coarsen;

static inline uint64_t mix(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    return h ^ (h >> 33);
}

/* Hash table size: a power of two, at least n and 16. */
static inline int64_t pow2_at_least(int64_t n)
{
    int64_t s = 16;
    while (s < n)
        s *= 2;
    return s;
}

/* The polygon of face f as it stands. */
static inline const uint32_t *poly(const coarsen *c, int32_t f, int32_t *n)
{
    const pf_mesh *m = c->src;
    if (c->face_state[f] == FACE_OWN) {
        *n = c->own_len[f];
        return c->pool + c->own_start[f];
    }
    *n = (int32_t)(m->face_offsets[f + 1] - m->face_offsets[f]);
    return m->face_nodes + m->face_offsets[f];
}

static inline pf_vec3 node_at(const coarsen *c, uint32_t v)
{
    return pf_v3_load(c->src->x + 3 * (size_t)v);
}

/* Face f gets the polygon nodes[n] of its own, written at the pool's end (nodes may point into
 * src, not into the pool). */
pf_status pf_coarsen_set_poly(coarsen *c, int32_t f, const uint32_t *nodes, int32_t n,
                              pf_error *err);
/* Marks node v as one that may have become unneeded. */
pf_status pf_coarsen_add_candidate(coarsen *c, uint32_t v, pf_error *err);
/* The cut edges: the undirected edges of the faces inside groups (c->dead). */
pf_status pf_coarsen_cut_edges(coarsen *c, pf_error *err);
/* Unites the pieces of polygons around every merged element. */
pf_status pf_coarsen_unite(coarsen *c, pf_error *err);
/* Removes the candidates no face needs; *n_removed counts them. */
pf_status pf_coarsen_remove_nodes(coarsen *c, int32_t *n_removed, pf_error *err);

#endif
