/* Volume-mesh import: choosing the reader by extension, and the cell list both readers fill. */
#include <pf/io.h>

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "import_volume.h"

pf_status pf_cell_list_add(cell_list *c, const uint32_t *nodes, int n, pf_error *err)
{
    PF_CHECK(c->n_cells < INT32_MAX, err, PF_ERR_TOO_LARGE, "more than %d cells", INT32_MAX);
    int64_t end = (int64_t)(c->nodes.size / sizeof *nodes) + n;
    if (c->n_cells == 0) {
        int64_t zero = 0;
        PF_TRY(pf_buffer_append(&c->offsets, &zero, sizeof zero, err));
    }
    PF_TRY(pf_buffer_append(&c->offsets, &end, sizeof end, err));
    PF_TRY(pf_buffer_append(&c->nodes, nodes, (size_t)n * sizeof *nodes, err));
    c->n_cells++;
    return PF_OK;
}

void pf_cell_list_release(cell_list *c)
{
    pf_buffer_release(&c->offsets);
    pf_buffer_release(&c->nodes);
    c->n_cells = 0;
}

pf_status pf_cell_list_build_mesh(const cell_list *c, const double *x, int64_t n_nodes, pf_mesh *m,
                                  int32_t *node_map, pf_error *err)
{
    memset(m, 0, sizeof *m);
    size_t n_refs = c->nodes.size / sizeof(uint32_t);
    const uint32_t *refs = (const uint32_t *)(void *)c->nodes.data;
    int32_t *renumber = pf_alloc_array((size_t)n_nodes, sizeof *renumber);
    uint32_t *cells = pf_alloc_array(n_refs, sizeof *cells);
    double *kept = NULL;
    pf_status s = PF_OK;
    if ((!renumber && n_nodes > 0) || (!cells && n_refs > 0))
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate %lld nodes",
                         (long long)n_nodes);
    int32_t n_kept = 0;
    if (s == PF_OK) {
        for (int64_t i = 0; i < n_nodes; ++i)
            renumber[i] = -1;
        for (size_t k = 0; k < n_refs; ++k)
            renumber[refs[k]] = 0;
        /* Kept nodes stay in file order: the mesh reads like the file it came from. */
        for (int64_t i = 0; i < n_nodes; ++i)
            if (renumber[i] >= 0)
                renumber[i] = n_kept++;
        for (size_t k = 0; k < n_refs; ++k)
            cells[k] = (uint32_t)renumber[refs[k]];
        kept = pf_alloc_array(3 * (size_t)n_kept, sizeof *kept);
        if (!kept && n_kept > 0)
            s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate %d nodes",
                             (int)n_kept);
    }
    if (s == PF_OK) {
        for (int64_t i = 0; i < n_nodes; ++i)
            if (renumber[i] >= 0)
                memcpy(kept + 3 * (size_t)renumber[i], x + 3 * (size_t)i, 3 * sizeof *x);
        const int64_t *offsets = (const int64_t *)(void *)c->offsets.data;
        int64_t no_cells = 0;
        s = pf_mesh_from_cells(m, kept, n_kept, c->n_cells ? offsets : &no_cells, cells,
                               (int32_t)c->n_cells, err);
    }
    if (s == PF_OK && node_map && n_nodes > 0)
        memcpy(node_map, renumber, (size_t)n_nodes * sizeof *node_map);
    pf_free(renumber);
    pf_free(cells);
    pf_free(kept);
    return s;
}

/* ---- dispatch by extension ------------------------------------------------------------------- */

static bool has_extension(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    if (n <= e)
        return false;
    for (size_t i = 0; i < e; ++i)
        if (tolower((unsigned char)path[n - e + i]) != ext[i])
            return false;
    return true;
}

/* True when path names no file but STEM.node exists: a TetGen stem. */
static bool is_tetgen_stem(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f) {
        fclose(f);
        return false;
    }
    char node_path[4096];
    int n = snprintf(node_path, sizeof node_path, "%s.node", path);
    f = n > 0 && (size_t)n < sizeof node_path ? fopen(node_path, "rb") : NULL;
    if (f)
        fclose(f);
    return f != NULL;
}

bool pf_import_is_volume_path(const char *path)
{
    return has_extension(path, ".msh") || has_extension(path, ".node") ||
           has_extension(path, ".ele") || is_tetgen_stem(path);
}

pf_status pf_import_volume(const char *path, pf_mesh *m, pf_error *err)
{
    memset(m, 0, sizeof *m);
    if (has_extension(path, ".msh"))
        return pf_import_msh(path, m, err);
    if (has_extension(path, ".node") || has_extension(path, ".ele"))
        return pf_import_tetgen(path, m, err);
    /* A TetGen stem: STEM.node beside it. */
    char node_path[4096];
    int n = snprintf(node_path, sizeof node_path, "%s.node", path);
    FILE *f = n > 0 && (size_t)n < sizeof node_path ? fopen(node_path, "rb") : NULL;
    PF_CHECK(f, err, PF_ERR_UNSUPPORTED,
             "%s: not a volume mesh (expected .msh, .node, .ele, or the stem of a .node/.ele pair)",
             path);
    fclose(f);
    return pf_import_tetgen(path, m, err);
}
