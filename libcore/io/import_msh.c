/* Gmsh .msh import: ASCII formats 2.x and 4.1 (the Gmsh reference manual, "MSH file format").
 *
 * Both versions are read line by line: a section starts with "$Name" and ends with "$EndName";
 * $MeshFormat, $PhysicalNames, $Entities (4.1), $Nodes and $Elements are read, every other
 * section is skipped whole. Physical groups become the mesh's groups: a solid element's group is
 * its first physical tag (2.x: the element's first tag; 4.1: its entity's first physical tag),
 * and the triangles and quadrangles of 2D physical groups tag the mesh faces with the same
 * corners (import_msh_groups.c). Node tags
 * are arbitrary positive integers (sparse, in any order), so element nodes are looked up by tag in
 * a sorted index rather than used as array positions. No count read from the file is trusted: it
 * is checked against the bytes left before anything is allocated from it.
 */
#include <pf/io.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "import_msh_groups.h"
#include "import_volume.h"
#include "text_reader.h"

enum { SECTION_NAME_MAX = 64 };

typedef struct elem_type {
    int32_t type;   /* Gmsh element type number */
    int8_t dim;     /* 0..3 */
    int8_t corners; /* 4 (tet), 8 (hex), 0: a 3D type pf does not read */
    int16_t nodes;  /* nodes listed per element (3D types only) */
    const char *name;
} elem_type;

/* Corner nodes come first in every Gmsh element, so higher-order tets and hexes give their
 * linear cell by their first 4 or 8 nodes. Lower-dimensional types are listed so that they can be
 * skipped in version 2, where nothing else says an element is not a solid. */
static const elem_type TYPES[] = {
    {15, 0, 0, 0, "point"},
    {1, 1, 0, 0, "line"},
    {8, 1, 0, 0, "line"},
    {26, 1, 0, 0, "line"},
    {27, 1, 0, 0, "line"},
    {28, 1, 0, 0, "line"},
    {2, 2, 0, 0, "triangle"},
    {9, 2, 0, 0, "triangle"},
    {20, 2, 0, 0, "triangle"},
    {21, 2, 0, 0, "triangle"},
    {22, 2, 0, 0, "triangle"},
    {23, 2, 0, 0, "triangle"},
    {24, 2, 0, 0, "triangle"},
    {25, 2, 0, 0, "triangle"},
    {3, 2, 0, 0, "quadrangle"},
    {10, 2, 0, 0, "quadrangle"},
    {16, 2, 0, 0, "quadrangle"},
    {4, 3, 4, 4, "tetrahedron"},
    {11, 3, 4, 10, "10-node tetrahedron"},
    {5, 3, 8, 8, "hexahedron"},
    {17, 3, 8, 20, "20-node hexahedron"},
    {12, 3, 8, 27, "27-node hexahedron"},
    {6, 3, 0, 6, "prism"},
    {18, 3, 0, 15, "prism"},
    {13, 3, 0, 18, "prism"},
    {7, 3, 0, 5, "pyramid"},
    {19, 3, 0, 13, "pyramid"},
    {14, 3, 0, 14, "pyramid"},
};

static const elem_type *find_type(int64_t type)
{
    for (size_t i = 0; i < sizeof TYPES / sizeof TYPES[0]; ++i)
        if (TYPES[i].type == type)
            return &TYPES[i];
    return NULL;
}

typedef struct msh_file {
    text_reader r;
    int version;    /* 2 or 4 */
    bool has_nodes; /* $Nodes read (it must come before $Elements) */
    bool has_elements;
    int64_t n_nodes; /* nodes read */
    int64_t *tag;    /* [n_nodes] node tags in file order */
    double *x;       /* [3 n_nodes] */
    int64_t *by_tag; /* [n_nodes] node indices sorted by tag */
    cell_list cells; /* tets and hexes, nodes as indices into x */
    msh_groups groups;
} msh_file;

static void msh_release(msh_file *f)
{
    pf_text_reader_close(&f->r);
    pf_free(f->tag);
    pf_free(f->x);
    pf_free(f->by_tag);
    pf_cell_list_release(&f->cells);
    pf_msh_groups_release(&f->groups);
}

/* ---- lines and sections ---------------------------------------------------------------------- */

static bool line_starts_section(const text_reader *r)
{
    return r->line[r->cursor] == '$';
}

/* The header line of a section (the line after "$Name"). */
static pf_status header_line(msh_file *f, const char *section, pf_error *err)
{
    text_reader *r = &f->r;
    TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT, "file ends after %s", section);
    TEXT_CHECK(!line_starts_section(r), r, err, PF_ERR_FORMAT, "%s has no header line", section);
    return PF_OK;
}

/* The line of entry i (from 0) of count in section: the file must not end or close the section
 * before it. */
static pf_status entry_line(msh_file *f, const char *section, const char *entries, int64_t i,
                            int64_t count, pf_error *err)
{
    text_reader *r = &f->r;
    TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT,
               "file ends inside %s after %lld of %lld %s", section, (long long)i, (long long)count,
               entries);
    TEXT_CHECK(!line_starts_section(r), r, err, PF_ERR_FORMAT,
               "%s ends after %lld of the %lld %s it announces", section, (long long)i,
               (long long)count, entries);
    return PF_OK;
}

static pf_status end_line(msh_file *f, const char *section, const char *end, const char *entries,
                          pf_error *err)
{
    text_reader *r = &f->r;
    TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT, "missing %s (the file ends)", end);
    if (pf_text_reader_line_is(r, end))
        return PF_OK;
    size_t len;
    const char *tok = pf_text_reader_token(r, &len);
    TEXT_CHECK(tok[0] != '$', r, err, PF_ERR_FORMAT, "missing %s before %.*s", end,
               (int)(len < SECTION_NAME_MAX ? len : SECTION_NAME_MAX), tok);
    return TEXT_FAIL(r, err, PF_ERR_FORMAT, "%s holds more %s than it announces (expected %s)",
                     section, entries, end);
}

/* A count from the file, bounded by the bytes left with tokens tokens per entry. */
static pf_status check_count(msh_file *f, int64_t count, int tokens, const char *entries,
                             const char *section, pf_error *err)
{
    char what[64];
    snprintf(what, sizeof what, "%s in %s", entries, section);
    return pf_text_reader_check_count(&f->r, count, tokens, what, err);
}

/* Skips an unknown section "$Name" up to its "$EndName". */
static pf_status skip_section(msh_file *f, pf_error *err)
{
    text_reader *r = &f->r;
    size_t len;
    const char *tok = pf_text_reader_token(r, &len);
    char end[SECTION_NAME_MAX + 8];
    TEXT_CHECK(len >= 2 && len < SECTION_NAME_MAX && !memchr(tok, '\0', len), r, err, PF_ERR_FORMAT,
               "malformed section name");
    snprintf(end, sizeof end, "$End%.*s", (int)(len - 1), tok + 1);
    int64_t start = r->line_no;
    while (pf_text_reader_next_line(r))
        if (pf_text_reader_line_is(r, end))
            return PF_OK;
    return TEXT_FAIL(r, err, PF_ERR_FORMAT, "the section opened on line %lld has no %s",
                     (long long)start, end);
}

/* ---- nodes ----------------------------------------------------------------------------------- */

static pf_status alloc_nodes(msh_file *f, int64_t count, pf_error *err)
{
    f->tag = pf_alloc_array((size_t)count, sizeof *f->tag);
    f->x = pf_alloc_array(3 * (size_t)count, sizeof *f->x);
    f->by_tag = pf_alloc_array((size_t)count, sizeof *f->by_tag);
    PF_CHECK((f->tag && f->x && f->by_tag) || count == 0, err, PF_ERR_NOMEM,
             "%s: cannot allocate %lld nodes", f->r.path, (long long)count);
    return PF_OK;
}

static pf_status read_node_tag(msh_file *f, int64_t i, pf_error *err)
{
    PF_TRY(pf_text_reader_int(&f->r, &f->tag[i], "a node tag", err));
    TEXT_CHECK(f->tag[i] > 0, &f->r, err, PF_ERR_FORMAT, "node tag %lld is not positive",
               (long long)f->tag[i]);
    return PF_OK;
}

static pf_status read_coordinates(msh_file *f, int64_t i, pf_error *err)
{
    static const char *const AXES[3] = {"x", "y", "z"};
    for (int c = 0; c < 3; ++c) {
        char what[64];
        snprintf(what, sizeof what, "the %s coordinate of node %lld", AXES[c],
                 (long long)f->tag[i]);
        PF_TRY(pf_text_reader_double(&f->r, &f->x[3 * i + c], what, err));
    }
    return PF_OK;
}

/* qsort has no context argument: sort (tag, index) pairs instead. */
typedef struct tag_index {
    int64_t tag, index;
} tag_index;

static int compare_tag_index(const void *pa, const void *pb)
{
    const tag_index *a = pa, *b = pb;
    if (a->tag != b->tag)
        return (a->tag > b->tag) - (a->tag < b->tag);
    return (a->index > b->index) - (a->index < b->index);
}

/* Sorts the node indices by tag for lookup; a tag defined twice is an error. */
static pf_status index_nodes(msh_file *f, pf_error *err)
{
    tag_index *pairs = pf_alloc_array((size_t)f->n_nodes, sizeof *pairs);
    PF_CHECK(pairs || f->n_nodes == 0, err, PF_ERR_NOMEM, "%s: cannot allocate %lld nodes",
             f->r.path, (long long)f->n_nodes);
    for (int64_t i = 0; i < f->n_nodes; ++i)
        pairs[i] = (tag_index){f->tag[i], i};
    if (f->n_nodes > 1)
        qsort(pairs, (size_t)f->n_nodes, sizeof *pairs, compare_tag_index);
    int64_t twice = 0;
    for (int64_t i = 0; i < f->n_nodes; ++i) {
        f->by_tag[i] = pairs[i].index;
        if (i > 0 && pairs[i].tag == pairs[i - 1].tag && !twice)
            twice = pairs[i].tag;
    }
    pf_free(pairs);
    TEXT_CHECK(!twice, &f->r, err, PF_ERR_FORMAT, "$Nodes defines node %lld twice",
               (long long)twice);
    f->has_nodes = true;
    return PF_OK;
}

/* The index of the node with Gmsh tag t, or -1. */
static int64_t find_node(const msh_file *f, int64_t t)
{
    int64_t lo = 0, hi = f->n_nodes;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        int64_t m = f->tag[f->by_tag[mid]];
        if (m == t)
            return f->by_tag[mid];
        if (m < t)
            lo = mid + 1;
        else
            hi = mid;
    }
    return -1;
}

/* Version 2: "n", then n lines "tag x y z". */
static pf_status read_nodes_v2(msh_file *f, pf_error *err)
{
    text_reader *r = &f->r;
    int64_t count;
    PF_TRY(header_line(f, "$Nodes", err));
    PF_TRY(pf_text_reader_int(r, &count, "the number of nodes", err));
    PF_TRY(pf_text_reader_expect_line_end(r, "the number of nodes", err));
    PF_TRY(check_count(f, count, 4, "nodes", "$Nodes", err));
    PF_TRY(alloc_nodes(f, count, err));
    for (int64_t i = 0; i < count; ++i) {
        PF_TRY(entry_line(f, "$Nodes", "nodes", i, count, err));
        PF_TRY(read_node_tag(f, i, err));
        PF_TRY(read_coordinates(f, i, err));
        PF_TRY(pf_text_reader_expect_line_end(r, "the coordinates", err));
        f->n_nodes = i + 1;
    }
    PF_TRY(end_line(f, "$Nodes", "$EndNodes", "nodes", err));
    return index_nodes(f, err);
}

/* Version 4.1: "blocks nodes min_tag max_tag", then per block "dim entity parametric n", n tag
 * lines and n coordinate lines (x y z, followed by parametric coordinates when parametric). */
static pf_status read_nodes_v4(msh_file *f, pf_error *err)
{
    text_reader *r = &f->r;
    int64_t blocks, count, min_tag, max_tag;
    PF_TRY(header_line(f, "$Nodes", err));
    PF_TRY(pf_text_reader_int(r, &blocks, "the number of node blocks", err));
    PF_TRY(pf_text_reader_int(r, &count, "the number of nodes", err));
    PF_TRY(pf_text_reader_int(r, &min_tag, "the smallest node tag", err));
    PF_TRY(pf_text_reader_int(r, &max_tag, "the largest node tag", err));
    PF_TRY(pf_text_reader_expect_line_end(r, "the node counts", err));
    PF_TRY(check_count(f, blocks, 4, "node blocks", "$Nodes", err));
    PF_TRY(check_count(f, count, 4, "nodes", "$Nodes", err));
    PF_TRY(alloc_nodes(f, count, err));
    for (int64_t b = 0; b < blocks; ++b) {
        int64_t dim, entity, parametric, n;
        PF_TRY(entry_line(f, "$Nodes", "node blocks", b, blocks, err));
        PF_TRY(pf_text_reader_int(r, &dim, "the entity dimension", err));
        PF_TRY(pf_text_reader_int(r, &entity, "the entity tag", err));
        PF_TRY(pf_text_reader_int(r, &parametric, "the parametric flag", err));
        PF_TRY(pf_text_reader_int(r, &n, "the number of nodes in the block", err));
        PF_TRY(pf_text_reader_expect_line_end(r, "the node block header", err));
        TEXT_CHECK(dim >= 0 && dim <= 3, r, err, PF_ERR_FORMAT, "entity dimension %lld",
                   (long long)dim);
        TEXT_CHECK(parametric == 0 || parametric == 1, r, err, PF_ERR_FORMAT,
                   "parametric flag %lld (0 or 1)", (long long)parametric);
        TEXT_CHECK(n >= 0 && n <= count - f->n_nodes, r, err, PF_ERR_FORMAT,
                   "node block %lld holds %lld nodes: more than the %lld $Nodes announces",
                   (long long)(b + 1), (long long)n, (long long)count);
        int64_t first = f->n_nodes;
        for (int64_t k = 0; k < n; ++k) {
            PF_TRY(entry_line(f, "$Nodes", "node tags of the block", k, n, err));
            PF_TRY(read_node_tag(f, first + k, err));
            PF_TRY(pf_text_reader_expect_line_end(r, "the node tag", err));
        }
        for (int64_t k = 0; k < n; ++k) {
            PF_TRY(entry_line(f, "$Nodes", "node coordinates of the block", k, n, err));
            PF_TRY(read_coordinates(f, first + k, err));
            if (!parametric)
                PF_TRY(pf_text_reader_expect_line_end(r, "the coordinates", err));
            f->n_nodes = first + k + 1;
        }
        f->n_nodes = first + n;
    }
    TEXT_CHECK(f->n_nodes == count, r, err, PF_ERR_FORMAT,
               "$Nodes announces %lld nodes but its blocks hold %lld", (long long)count,
               (long long)f->n_nodes);
    PF_TRY(end_line(f, "$Nodes", "$EndNodes", "node blocks", err));
    (void)min_tag;
    (void)max_tag;
    return index_nodes(f, err);
}

/* ---- elements -------------------------------------------------------------------------------- */

/* The node tags of a tet or hex on the current line, checked and kept as a cell of its corners. */
static pf_status read_cell(msh_file *f, int64_t elem, const elem_type *t, int64_t group,
                           pf_error *err)
{
    text_reader *r = &f->r;
    TEXT_CHECK(t->corners, r, err, PF_ERR_UNSUPPORTED,
               "element %lld is a %s (type %d); only tetrahedra and hexahedra are imported",
               (long long)elem, t->name, (int)t->type);
    uint32_t corners[8];
    for (int k = 0; k < t->nodes; ++k) {
        int64_t tag, index;
        char what[80];
        snprintf(what, sizeof what, "node %d of element %lld (a %s)", k + 1, (long long)elem,
                 t->name);
        PF_TRY(pf_text_reader_int(r, &tag, what, err));
        TEXT_CHECK((index = find_node(f, tag)) >= 0, r, err, PF_ERR_FORMAT,
                   "element %lld refers to node %lld, which the file does not define",
                   (long long)elem, (long long)tag);
        if (k < t->corners)
            corners[k] = (uint32_t)index;
    }
    PF_TRY(pf_text_reader_expect_line_end(r, "the element's nodes", err));
    pf_status s = pf_cell_list_add(&f->cells, corners, t->corners, err);
    if (s == PF_OK)
        s = pf_msh_groups_add_cell(&f->groups, group, err);
    if (s < 0)
        pf_error_prefix(err, "%s:%lld", r->path, (long long)r->line_no);
    return s;
}

/* The corners of a triangle or quadrangle of physical group `group` on the current line (the
 * rest of the line, higher-order nodes, is not read), kept to tag the mesh face they match. */
static pf_status read_face(msh_file *f, int64_t elem, const elem_type *t, int64_t group,
                           pf_error *err)
{
    text_reader *r = &f->r;
    int n = t->name[0] == 't' ? 3 : 4;
    int64_t corners[4];
    for (int k = 0; k < n; ++k) {
        int64_t tag;
        char what[80];
        snprintf(what, sizeof what, "node %d of element %lld (a %s)", k + 1, (long long)elem,
                 t->name);
        PF_TRY(pf_text_reader_int(r, &tag, what, err));
        TEXT_CHECK((corners[k] = find_node(f, tag)) >= 0, r, err, PF_ERR_FORMAT,
                   "element %lld refers to node %lld, which the file does not define",
                   (long long)elem, (long long)tag);
    }
    return pf_msh_groups_add_face(&f->groups, corners, n, group, elem, r->line_no, err);
}

/* Version 2: "n", then n lines "tag type n_tags tags... nodes...". */
static pf_status read_elements_v2(msh_file *f, pf_error *err)
{
    text_reader *r = &f->r;
    int64_t count;
    PF_TRY(header_line(f, "$Elements", err));
    PF_TRY(pf_text_reader_int(r, &count, "the number of elements", err));
    PF_TRY(pf_text_reader_expect_line_end(r, "the number of elements", err));
    PF_TRY(check_count(f, count, 4, "elements", "$Elements", err));
    for (int64_t i = 0; i < count; ++i) {
        int64_t elem, type, n_tags, tag;
        PF_TRY(entry_line(f, "$Elements", "elements", i, count, err));
        PF_TRY(pf_text_reader_int(r, &elem, "an element tag", err));
        PF_TRY(pf_text_reader_int(r, &type, "the element type", err));
        PF_TRY(pf_text_reader_int(r, &n_tags, "the number of element tags", err));
        TEXT_CHECK(n_tags >= 0 && (uint64_t)n_tags <= r->line_len, r, err, PF_ERR_FORMAT,
                   "element %lld has %lld tags", (long long)elem, (long long)n_tags);
        int64_t physical = 0;
        for (int64_t k = 0; k < n_tags; ++k) {
            PF_TRY(pf_text_reader_int(r, &tag, "an element tag (physical, entity, ...)", err));
            if (k == 0)
                physical = tag;
        }
        TEXT_CHECK(physical >= 0 && physical <= INT32_MAX, r, err, PF_ERR_FORMAT,
                   "element %lld: physical group %lld out of range", (long long)elem,
                   (long long)physical);
        const elem_type *t = find_type(type);
        TEXT_CHECK(t, r, err, PF_ERR_UNSUPPORTED,
                   "element %lld has type %lld, which pf does not read", (long long)elem,
                   (long long)type);
        if (t->dim == 3)
            PF_TRY(read_cell(f, elem, t, physical, err));
        else if (t->dim == 2 && physical > 0)
            PF_TRY(read_face(f, elem, t, physical, err));
    }
    return end_line(f, "$Elements", "$EndElements", "elements", err);
}

/* Version 4.1: "blocks elements min_tag max_tag", then per block "dim entity type n" and n lines
 * "tag nodes...". Blocks of dimension below 3 are skipped whatever their type. */
static pf_status read_elements_v4(msh_file *f, pf_error *err)
{
    text_reader *r = &f->r;
    int64_t blocks, count, min_tag, max_tag, read = 0;
    PF_TRY(header_line(f, "$Elements", err));
    PF_TRY(pf_text_reader_int(r, &blocks, "the number of element blocks", err));
    PF_TRY(pf_text_reader_int(r, &count, "the number of elements", err));
    PF_TRY(pf_text_reader_int(r, &min_tag, "the smallest element tag", err));
    PF_TRY(pf_text_reader_int(r, &max_tag, "the largest element tag", err));
    PF_TRY(pf_text_reader_expect_line_end(r, "the element counts", err));
    PF_TRY(check_count(f, blocks, 4, "element blocks", "$Elements", err));
    PF_TRY(check_count(f, count, 2, "elements", "$Elements", err));
    for (int64_t b = 0; b < blocks; ++b) {
        int64_t dim, entity, type, n;
        PF_TRY(entry_line(f, "$Elements", "element blocks", b, blocks, err));
        PF_TRY(pf_text_reader_int(r, &dim, "the entity dimension", err));
        PF_TRY(pf_text_reader_int(r, &entity, "the entity tag", err));
        PF_TRY(pf_text_reader_int(r, &type, "the element type", err));
        PF_TRY(pf_text_reader_int(r, &n, "the number of elements in the block", err));
        PF_TRY(pf_text_reader_expect_line_end(r, "the element block header", err));
        TEXT_CHECK(dim >= 0 && dim <= 3, r, err, PF_ERR_FORMAT, "entity dimension %lld",
                   (long long)dim);
        TEXT_CHECK(n >= 0 && n <= count - read, r, err, PF_ERR_FORMAT,
                   "element block %lld holds %lld elements: more than the %lld $Elements "
                   "announces",
                   (long long)(b + 1), (long long)n, (long long)count);
        const elem_type *t = find_type(type);
        TEXT_CHECK(dim < 3 || t, r, err, PF_ERR_UNSUPPORTED,
                   "element block %lld has type %lld, which pf does not read", (long long)(b + 1),
                   (long long)type);
        TEXT_CHECK(!t || t->dim == dim, r, err, PF_ERR_FORMAT,
                   "element block %lld: type %lld is not of dimension %lld", (long long)(b + 1),
                   (long long)type, (long long)dim);
        int64_t physical = pf_msh_groups_entity_physical(&f->groups, dim, entity);
        for (int64_t k = 0; k < n; ++k) {
            int64_t elem;
            PF_TRY(entry_line(f, "$Elements", "elements of the block", k, n, err));
            if (dim < 2 || (dim == 2 && physical == 0))
                continue;
            PF_TRY(pf_text_reader_int(r, &elem, "an element tag", err));
            if (dim == 3)
                PF_TRY(read_cell(f, elem, t, physical, err));
            else
                PF_TRY(read_face(f, elem, t, physical, err));
        }
        read += n;
    }
    TEXT_CHECK(read == count, r, err, PF_ERR_FORMAT,
               "$Elements announces %lld elements but its blocks hold %lld", (long long)count,
               (long long)read);
    (void)min_tag;
    (void)max_tag;
    return end_line(f, "$Elements", "$EndElements", "element blocks", err);
}

/* ---- the file -------------------------------------------------------------------------------- */

/* "$MeshFormat", "version file_type data_size", "$EndMeshFormat". Binary files are refused on
 * the format line, before a single binary byte is looked at. */
static pf_status read_format(msh_file *f, pf_error *err)
{
    text_reader *r = &f->r;
    TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT, "blank file");
    /* Format 1 has no $MeshFormat and starts with its node section. */
    TEXT_CHECK(!pf_text_reader_line_is(r, "$NOD"), r, err, PF_ERR_UNSUPPORTED,
               "format version 1 is not supported (ASCII 2.x or 4.1; re-save from Gmsh with "
               "-format msh41 or msh22)");
    TEXT_CHECK(pf_text_reader_line_is(r, "$MeshFormat"), r, err, PF_ERR_FORMAT,
               "not a Gmsh .msh file (it does not start with $MeshFormat)");
    PF_TRY(header_line(f, "$MeshFormat", err));
    size_t len;
    const char *tok = pf_text_reader_token(r, &len);
    char version[16] = "";
    if (len < sizeof version && !memchr(tok, '\0', len))
        memcpy(version, tok, len);
    int64_t file_type, data_size;
    PF_TRY(pf_text_reader_int(r, &file_type, "the file type (0 for ASCII)", err));
    TEXT_CHECK(file_type == 0, r, err, PF_ERR_UNSUPPORTED,
               "binary .msh is not supported; re-save as ASCII");
    PF_TRY(pf_text_reader_int(r, &data_size, "the data size", err));
    PF_TRY(pf_text_reader_expect_line_end(r, "the format", err));
    if (strncmp(version, "2.", 2) == 0 && version[2] >= '0' && version[2] <= '9' &&
        version[3] == '\0')
        f->version = 2;
    else if (strcmp(version, "4.1") == 0)
        f->version = 4;
    TEXT_CHECK(f->version, r, err, PF_ERR_UNSUPPORTED,
               "format version '%.15s' is not supported (ASCII 2.x or 4.1; re-save from Gmsh "
               "with -format msh41 or msh22)",
               version);
    TEXT_CHECK(pf_text_reader_next_line(r), r, err, PF_ERR_FORMAT, "missing $EndMeshFormat");
    TEXT_CHECK(pf_text_reader_line_is(r, "$EndMeshFormat"), r, err, PF_ERR_FORMAT,
               "expected $EndMeshFormat");
    return PF_OK;
}

/* "n", then n lines 'dim number "name"'. */
static pf_status read_physical_names(msh_file *f, pf_error *err)
{
    text_reader *r = &f->r;
    int64_t count;
    PF_TRY(header_line(f, "$PhysicalNames", err));
    PF_TRY(pf_text_reader_int(r, &count, "the number of physical names", err));
    PF_TRY(pf_text_reader_expect_line_end(r, "the number of physical names", err));
    PF_TRY(check_count(f, count, 3, "physical names", "$PhysicalNames", err));
    for (int64_t i = 0; i < count; ++i) {
        int64_t dim, number;
        PF_TRY(entry_line(f, "$PhysicalNames", "physical names", i, count, err));
        PF_TRY(pf_text_reader_int(r, &dim, "the dimension of a physical group", err));
        PF_TRY(pf_text_reader_int(r, &number, "the number of a physical group", err));
        TEXT_CHECK(dim >= 0 && dim <= 3 && number > 0 && number <= INT32_MAX, r, err, PF_ERR_FORMAT,
                   "physical group of dimension %lld and number %lld", (long long)dim,
                   (long long)number);
        /* the name: the rest of the line between double quotes (it may hold spaces) */
        const char *s = r->line + r->cursor, *end = r->line + r->line_len;
        while (s < end && (*s == ' ' || *s == '\t'))
            ++s;
        const char *close = s < end && *s == '"' ? memchr(s + 1, '"', (size_t)(end - s - 1)) : NULL;
        TEXT_CHECK(close, r, err, PF_ERR_FORMAT, "physical group %lld: its name must be quoted",
                   (long long)number);
        r->cursor = (size_t)(close + 1 - r->line);
        PF_TRY(pf_text_reader_expect_line_end(r, "the physical name", err));
        PF_TRY(pf_msh_groups_add_name(&f->groups, (int32_t)dim, (int32_t)number, s + 1,
                                      (size_t)(close - s - 1), err));
    }
    return end_line(f, "$PhysicalNames", "$EndPhysicalNames", "physical names", err);
}

/* Version 4.1: "points curves surfaces volumes", then per entity "tag" and either "x y z"
 * (points) or its bounding box (6 numbers), then "n physical_tags..." and, past points, the
 * bounding entities (not read). The first physical tag of every surface and volume is kept. */
static pf_status read_entities(msh_file *f, pf_error *err)
{
    text_reader *r = &f->r;
    int64_t counts[4];
    PF_TRY(header_line(f, "$Entities", err));
    for (int d = 0; d < 4; ++d)
        PF_TRY(pf_text_reader_int(r, &counts[d], "an entity count", err));
    PF_TRY(pf_text_reader_expect_line_end(r, "the entity counts", err));
    for (int d = 0; d < 4; ++d) {
        PF_TRY(check_count(f, counts[d], 5, "entities", "$Entities", err));
        for (int64_t i = 0; i < counts[d]; ++i) {
            int64_t tag, n_physical, physical = 0;
            PF_TRY(entry_line(f, "$Entities", "entities", i, counts[d], err));
            PF_TRY(pf_text_reader_int(r, &tag, "an entity tag", err));
            for (int k = 0; k < (d == 0 ? 3 : 6); ++k) {
                double v;
                PF_TRY(pf_text_reader_double(r, &v, "an entity coordinate", err));
            }
            PF_TRY(pf_text_reader_int(r, &n_physical, "the number of physical tags", err));
            TEXT_CHECK(n_physical >= 0 && (uint64_t)n_physical <= r->line_len, r, err,
                       PF_ERR_FORMAT, "entity %lld has %lld physical tags", (long long)tag,
                       (long long)n_physical);
            for (int64_t k = 0; k < n_physical; ++k) {
                int64_t p;
                PF_TRY(pf_text_reader_int(r, &p, "a physical tag", err));
                /* Gmsh writes negative tags for physical groups of reversed orientation */
                p = p < 0 ? -p : p;
                TEXT_CHECK(p > 0 && p <= INT32_MAX, r, err, PF_ERR_FORMAT,
                           "entity %lld: physical tag %lld out of range", (long long)tag,
                           (long long)p);
                if (k == 0)
                    physical = p;
            }
            if (d >= 2 && physical > 0)
                PF_TRY(pf_msh_groups_add_entity(&f->groups, d, tag, physical, err));
        }
    }
    return end_line(f, "$Entities", "$EndEntities", "entities", err);
}

static pf_status read_sections(msh_file *f, pf_error *err)
{
    text_reader *r = &f->r;
    while (pf_text_reader_next_line(r)) {
        if (pf_text_reader_line_is(r, "$Nodes")) {
            TEXT_CHECK(!f->has_nodes, r, err, PF_ERR_FORMAT, "a second $Nodes section");
            PF_TRY(f->version == 2 ? read_nodes_v2(f, err) : read_nodes_v4(f, err));
        } else if (pf_text_reader_line_is(r, "$Elements")) {
            TEXT_CHECK(f->has_nodes, r, err, PF_ERR_FORMAT, "$Elements before $Nodes");
            TEXT_CHECK(!f->has_elements, r, err, PF_ERR_FORMAT, "a second $Elements section");
            PF_TRY(f->version == 2 ? read_elements_v2(f, err) : read_elements_v4(f, err));
            f->has_elements = true;
        } else if (pf_text_reader_line_is(r, "$PhysicalNames")) {
            PF_TRY(read_physical_names(f, err));
        } else if (pf_text_reader_line_is(r, "$Entities") && f->version == 4) {
            TEXT_CHECK(!f->has_elements, r, err, PF_ERR_FORMAT, "$Entities after $Elements");
            PF_TRY(read_entities(f, err));
        } else if (line_starts_section(r)) {
            PF_TRY(skip_section(f, err));
        } else {
            size_t len;
            const char *tok = pf_text_reader_token(r, &len);
            return TEXT_FAIL(r, err, PF_ERR_FORMAT, "expected a section ($Name), found '%.*s'",
                             (int)(len < 24 ? len : 24), tok);
        }
    }
    TEXT_CHECK(f->has_nodes, r, err, PF_ERR_FORMAT, "no $Nodes section");
    TEXT_CHECK(f->has_elements, r, err, PF_ERR_FORMAT, "no $Elements section");
    TEXT_CHECK(f->cells.n_cells > 0, r, err, PF_ERR_INVALID,
               "no tetrahedra or hexahedra in the file");
    return PF_OK;
}

pf_status pf_import_msh(const char *path, pf_mesh *m, pf_error *err)
{
    memset(m, 0, sizeof *m);
    msh_file f;
    memset(&f, 0, sizeof f);
    pf_status s = pf_text_reader_open(&f.r, path, '\0', err);
    if (s == PF_OK)
        s = read_format(&f, err);
    if (s == PF_OK)
        s = read_sections(&f, err);
    if (s == PF_OK) {
        int32_t *node_map = pf_alloc_array((size_t)f.n_nodes + 1, sizeof *node_map);
        s = node_map ? pf_cell_list_build_mesh(&f.cells, f.x, f.n_nodes, m, node_map, err)
                     : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "out of memory");
        if (s == PF_OK)
            s = pf_msh_groups_apply(&f.groups, node_map, m, err);
        pf_free(node_map);
        if (s < 0) {
            pf_error_prefix(err, "%s", path);
            pf_mesh_release(m);
        }
    }
    msh_release(&f);
    return s;
}
