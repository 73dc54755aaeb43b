/* The MLS embedding's per-row machinery (mls.c), shared by the full computation and the
 * incremental update (embed_update.c). Private to libcore/embed. */
#ifndef PF_MLS_INTERNAL_H
#define PF_MLS_INTERNAL_H

#include "embed_internal.h"

typedef struct mls_support {
    int32_t n, cap;
    uint32_t *col; /* [cap] node, increasing once gathered */
    double *d;     /* [3 cap] x_i - x, then divided by the row's length scale */
    double *theta; /* [cap] */
    double *val;   /* [cap] */
} mls_support;

typedef struct mls_context {
    const pf_mesh *m;
    const pf_embed_params *p;
    double *radius; /* [n_nodes] owned: pf_embed_mls_radii */
    double r_max;
    bucket_grid supports; /* nodes by their support boxes */
    bucket_grid points;   /* nodes by position, for grown supports (built by the first) */
    bool points_built;
    double mean_radius;   /* the grids' cell size */
    mls_support s;
    visibility vis;
    bool use_vis;      /* p->blocking_faces given */
    locator *L;
    pf_vec3 seen_from; /* the vertex, nudged into its side of a cut */
    int32_t host;      /* with blocking faces: the element holding seen_from */
    int32_t hidden;    /* nodes of the last gather within reach but hidden (a cut, a body) */
    uint32_t *elem_col; /* [max(8, max_nodes)] the host element's own weights */
    double *elem_val;   /* [same] */
    double *elem_tmp;   /* [4 times that] */
} mls_context;

/* The radii, grids and (with p->blocking_faces) visibility of mesh m. p resolved; L may be NULL
 * without blocking faces. Released by pf_mls_release, also after a failure. */
pf_status pf_mls_init(mls_context *c, const pf_mesh *m, const pf_embed_params *p, locator *L,
                      pf_error *err);
void pf_mls_release(mls_context *c);

/* The row of vertex v at x: *col, *val (n entries, columns increasing; valid until the next row)
 * and the growth step of its radii (growth^step; 0 for an element's own weights). A row depends
 * only on the nodes in its support (positions, radii) and, with blocking faces, the cut. */
pf_status pf_mls_row(mls_context *c, int32_t v, pf_vec3 x, uint32_t **col, double **val,
                     int32_t *n, int32_t *step, pf_embed_stats *stats, pf_error *err);

/* growth^step, multiplied up as pf_mls_row does. */
double pf_mls_scale(const pf_embed_params *p, int32_t step);

#endif
