/* The working state of pf_poly_split (split.c), shared with the grouping of its polygons into
 * pieces (split_pieces.c). Private to geom/. */
#ifndef PF_GEOM_SPLIT_INTERNAL_H
#define PF_GEOM_SPLIT_INTERNAL_H

#include <pf/split.h>

/* Polygons produced on either side, in order. */
typedef struct polys {
    pf_buffer end;    /* int64_t: end offset of each polygon in nodes */
    pf_buffer nodes;  /* uint32_t */
    pf_buffer source; /* int32_t: input face or -1 */
    pf_buffer side;   /* int8_t */
    pf_buffer flat;   /* uint8_t: an input face lying on the plane */
    int32_t n;
} polys;

typedef struct work {
    const pf_polyhedron *p;
    int32_t n_in;    /* input nodes */
    int32_t n_total; /* plus new nodes */
    pf_plane pl;
    double tol;
    double *x;       /* [3 n_total] */
    double *dist;    /* [n_in] signed distances */
    int8_t *cls;     /* [n_total] */
    uint64_t *cross; /* [n_new] sorted keys lo << 32 | hi of the crossing edges */
    int64_t n_new;
    polys out;
    /* per-face scratch, sized for the largest face */
    uint32_t *av;
    int8_t *ac;
    int8_t *es;
    double *as;
    int32_t *zp;
    uint8_t *zin, *zout, *visited;
    int32_t *zto;
} work;

#define BUF(b, T) ((T *)(void *)(b).data)

static inline int64_t poly_begin(const polys *o, int32_t i)
{
    return i == 0 ? 0 : BUF(o->end, int64_t)[i - 1];
}

typedef struct pedge {
    uint64_t key; /* lo << 32 | hi */
    int32_t poly;
    int8_t dir; /* +1: the polygon runs lo -> hi */
    int8_t side;
} pedge;

/* Order by side, key, polygon. */
static inline int compare_pedge(const void *a, const void *b)
{
    const pedge *x = a, *y = b;
    if (x->side != y->side)
        return x->side - y->side;
    if (x->key != y->key)
        return (x->key > y->key) - (x->key < y->key);
    return (x->poly > y->poly) - (x->poly < y->poly);
}

/* Edges of the produced polygons (only on-plane ones when zero_only), sorted by side, key and
 * polygon (compare_pedge). */
pf_status pf_split_collect_edges(const work *w, int zero_only, pedge **out, int64_t *n_out,
                              pf_error *err);

/* piece_of[i] (i < w->out.n): the piece of polygon i, numbered 0 .. *n_pieces - 1, the pieces
 * below the plane first, each side's in the order of their first polygons. */
pf_status pf_split_find_pieces(const work *w, int32_t *piece_of, int32_t *n_pieces, pf_error *err);

#endif
