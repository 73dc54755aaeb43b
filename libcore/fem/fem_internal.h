/* Shared by the DG and CG set-ups (private to libcore/fem). */
#ifndef PF_FEM_INTERNAL_H
#define PF_FEM_INTERNAL_H

#include <pf/fem.h>

/* Copies the materials into *table [materials->n] (Lame parameters computed) and *elem
 * [n_elems] (zeros when materials->elem is NULL), both pf_alloc'd, after checking every material
 * and index: PF_ERR_INVALID naming the first bad one, PF_ERR_NOMEM. */
pf_status pf_fem_copy_materials(const pf_materials *materials, int32_t n_elems, pf_material **table,
                                int32_t **elem, pf_error *err);

#endif
