/* TetGen .node/.ele import (the TetGen manual, "File formats"): '#' starts a comment anywhere on
 * a line; points are numbered consecutively from the first index (0 or 1) and tets refer to them
 * by those numbers. */
#include <pf/io.h>

#include <ctype.h>
#include <stdio.h>
#include <string.h>

#include "import_volume.h"
#include "text_reader.h"

typedef struct tetgen_nodes {
    int64_t n;
    int64_t first; /* the index of the first point: 0 or 1 */
    double *x;     /* [3 n] */
} tetgen_nodes;

static bool ends_with(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    if (n <= e)
        return false;
    for (size_t i = 0; i < e; ++i)
        if (tolower((unsigned char)path[n - e + i]) != ext[i])
            return false;
    return true;
}

/* "stem.node" and "stem.ele" from a path that is either file or the stem; the given file keeps
 * its own spelling. */
static pf_status sibling_paths(const char *path, char **node, char **ele, pf_error *err)
{
    size_t n = strlen(path), stem = n;
    if (ends_with(path, ".node"))
        stem = n - 5;
    else if (ends_with(path, ".ele"))
        stem = n - 4;
    *node = pf_alloc(stem + 6);
    *ele = pf_alloc(stem + 6);
    PF_CHECK(*node && *ele, err, PF_ERR_NOMEM, "%s: out of memory", path);
    snprintf(*node, stem + 6, "%.*s.node", (int)stem, path);
    snprintf(*ele, stem + 6, "%.*s.ele", (int)stem, path);
    if (ends_with(path, ".node"))
        memcpy(*node, path, n + 1);
    if (ends_with(path, ".ele"))
        memcpy(*ele, path, n + 1);
    return PF_OK;
}

/* A whole token skipped (attributes: their values are not used). */
static pf_status skip_token(text_reader *r, const char *what, pf_error *err)
{
    size_t len;
    TEXT_CHECK(pf_text_reader_token(r, &len), r, err, PF_ERR_FORMAT,
               "expected %s at the end of the line", what);
    return PF_OK;
}

/* Header "points dimension attributes markers" (the last two may be left out), then one line per
 * point: "index x y z [attributes] [marker]". */
static pf_status read_node_file(text_reader *r, tetgen_nodes *nodes, pf_error *err)
{
    int64_t count, dim, attrs = 0, markers = 0;
    TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT, "no header line");
    PF_TRY(pf_text_reader_int(r, &count, "the number of points", err));
    PF_TRY(pf_text_reader_int(r, &dim, "the dimension", err));
    if (!pf_text_reader_at_line_end(r))
        PF_TRY(pf_text_reader_int(r, &attrs, "the number of attributes", err));
    if (!pf_text_reader_at_line_end(r))
        PF_TRY(pf_text_reader_int(r, &markers, "the boundary marker flag", err));
    PF_TRY(pf_text_reader_expect_line_end(r, "the header", err));
    TEXT_CHECK(dim == 3, r, err, PF_ERR_UNSUPPORTED, "dimension %lld (pf reads 3D meshes)",
               (long long)dim);
    TEXT_CHECK(count != 0, r, err, PF_ERR_UNSUPPORTED,
               "0 points: the points are in a .poly or .smesh file, which pf does not read");
    TEXT_CHECK(markers == 0 || markers == 1, r, err, PF_ERR_FORMAT,
               "boundary marker flag %lld (0 or 1)", (long long)markers);
    PF_TRY(pf_text_reader_check_count(r, attrs, 1, "attributes per point", err));
    PF_TRY(pf_text_reader_check_count(r, count, 4 + attrs + markers, "points", err));
    nodes->x = pf_alloc_array(3 * (size_t)count, sizeof *nodes->x);
    PF_CHECK(nodes->x, err, PF_ERR_NOMEM, "%s: cannot allocate %lld points", r->path,
             (long long)count);
    for (int64_t i = 0; i < count; ++i) {
        int64_t index;
        TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT,
                   "the file ends after %lld of the %lld points it announces", (long long)i,
                   (long long)count);
        PF_TRY(pf_text_reader_int(r, &index, "a point index", err));
        if (i == 0) {
            TEXT_CHECK(index == 0 || index == 1, r, err, PF_ERR_FORMAT,
                       "the first point has index %lld (0 or 1)", (long long)index);
            nodes->first = index;
        }
        TEXT_CHECK(index == nodes->first + i, r, err, PF_ERR_FORMAT,
                   "point index %lld out of sequence (expected %lld)", (long long)index,
                   (long long)(nodes->first + i));
        for (int c = 0; c < 3; ++c) {
            char what[64];
            snprintf(what, sizeof what, "the %c coordinate of point %lld", "xyz"[c],
                     (long long)index);
            PF_TRY(pf_text_reader_double(r, &nodes->x[3 * i + c], what, err));
        }
        for (int64_t k = 0; k < attrs; ++k)
            PF_TRY(skip_token(r, "a point attribute", err));
        if (markers)
            PF_TRY(skip_token(r, "a boundary marker", err));
        PF_TRY(pf_text_reader_expect_line_end(r, "the point", err));
        nodes->n = i + 1;
    }
    TEXT_CHECK(!pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT,
               "more points than the %lld the header announces", (long long)count);
    return PF_OK;
}

/* Header "tets nodes_per_tet attributes", then "index n1 .. nk [attributes]" per tet, k = 4 or
 * 10 (corners first). */
static pf_status read_ele_file(text_reader *r, const char *node_path, const tetgen_nodes *nodes,
                               cell_list *cells, pf_error *err)
{
    int64_t count, per_tet, attrs = 0;
    TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT, "no header line");
    PF_TRY(pf_text_reader_int(r, &count, "the number of tetrahedra", err));
    PF_TRY(pf_text_reader_int(r, &per_tet, "the number of nodes per tetrahedron", err));
    if (!pf_text_reader_at_line_end(r))
        PF_TRY(pf_text_reader_int(r, &attrs, "the number of attributes", err));
    PF_TRY(pf_text_reader_expect_line_end(r, "the header", err));
    TEXT_CHECK(per_tet == 4 || per_tet == 10, r, err, PF_ERR_UNSUPPORTED,
               "%lld nodes per tetrahedron (4 or 10)", (long long)per_tet);
    PF_TRY(pf_text_reader_check_count(r, attrs, 1, "attributes per tetrahedron", err));
    PF_TRY(pf_text_reader_check_count(r, count, 1 + per_tet + attrs, "tetrahedra", err));
    TEXT_CHECK(count > 0, r, err, PF_ERR_INVALID, "no tetrahedra");
    for (int64_t i = 0; i < count; ++i) {
        int64_t index;
        TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT,
                   "the file ends after %lld of the %lld tetrahedra it announces", (long long)i,
                   (long long)count);
        PF_TRY(pf_text_reader_int(r, &index, "a tetrahedron index", err));
        uint32_t corners[4];
        for (int k = 0; k < per_tet; ++k) {
            int64_t node;
            char what[64];
            snprintf(what, sizeof what, "node %d of tetrahedron %lld", k + 1, (long long)index);
            PF_TRY(pf_text_reader_int(r, &node, what, err));
            TEXT_CHECK(node >= nodes->first && node - nodes->first < nodes->n, r, err,
                       PF_ERR_FORMAT,
                       "tetrahedron %lld refers to node %lld, which %s does not define "
                       "(%lld to %lld)",
                       (long long)index, (long long)node, node_path, (long long)nodes->first,
                       (long long)(nodes->first + nodes->n - 1));
            if (k < 4)
                corners[k] = (uint32_t)(node - nodes->first);
        }
        for (int64_t k = 0; k < attrs; ++k)
            PF_TRY(skip_token(r, "a tetrahedron attribute", err));
        PF_TRY(pf_text_reader_expect_line_end(r, "the tetrahedron", err));
        pf_status s = pf_cell_list_add(cells, corners, 4, err);
        if (s < 0) {
            pf_error_prefix(err, "%s:%lld", r->path, (long long)r->line_no);
            return s;
        }
    }
    TEXT_CHECK(!pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT,
               "more tetrahedra than the %lld the header announces", (long long)count);
    return PF_OK;
}

pf_status pf_import_tetgen(const char *path, pf_mesh *m, pf_error *err)
{
    memset(m, 0, sizeof *m);
    char *node_path = NULL, *ele_path = NULL;
    tetgen_nodes nodes = {0};
    cell_list cells = {0};
    text_reader r;
    memset(&r, 0, sizeof r);
    pf_status s = sibling_paths(path, &node_path, &ele_path, err);
    if (s == PF_OK)
        s = pf_text_reader_open(&r, node_path, '#', err);
    if (s == PF_OK)
        s = read_node_file(&r, &nodes, err);
    pf_text_reader_close(&r);
    if (s == PF_OK)
        s = pf_text_reader_open(&r, ele_path, '#', err);
    if (s == PF_OK)
        s = read_ele_file(&r, node_path, &nodes, &cells, err);
    pf_text_reader_close(&r);
    if (s == PF_OK) {
        s = pf_cell_list_build_mesh(&cells, nodes.x, nodes.n, m, NULL, err);
        if (s < 0)
            pf_error_prefix(err, "%s", ele_path);
    }
    pf_cell_list_release(&cells);
    pf_free(nodes.x);
    pf_free(node_path);
    pf_free(ele_path);
    return s;
}
