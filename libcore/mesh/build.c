/* Meshes from tet and hex cell lists: faces shared by two cells are created once. */
#include <pf/mesh.h>

#include <stdlib.h>
#include <string.h>

/* Outward faces of a positively oriented cell in Gmsh/VTK numbering (see pf/mesh.h). */
static const uint8_t TET_FACES[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
static const uint8_t HEX_FACES[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                        {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};

typedef struct cell_face {
    uint32_t key[4]; /* sorted node ids, padded with UINT32_MAX */
    uint32_t nodes[4];
    int32_t cell;
    uint8_t size;
} cell_face;

static int compare_cell_face(const void *pa, const void *pb)
{
    const cell_face *a = pa, *b = pb;
    for (int i = 0; i < 4; ++i)
        if (a->key[i] != b->key[i])
            return a->key[i] < b->key[i] ? -1 : 1;
    return (a->cell > b->cell) - (a->cell < b->cell);
}

static int same_key(const cell_face *a, const cell_face *b)
{
    return memcmp(a->key, b->key, sizeof a->key) == 0;
}

static void make_key(cell_face *cf)
{
    for (int i = 0; i < 4; ++i)
        cf->key[i] = i < cf->size ? cf->nodes[i] : UINT32_MAX;
    for (int i = 1; i < 4; ++i)
        for (int j = i; j > 0 && cf->key[j - 1] > cf->key[j]; --j) {
            uint32_t t = cf->key[j];
            cf->key[j] = cf->key[j - 1];
            cf->key[j - 1] = t;
        }
}

/* Signed volume of a tet (a, b, c, d) times 6. */
static double tet_volume6(const double *x, const uint32_t *c)
{
    pf_vec3 a = pf_v3_load(x + 3 * (size_t)c[0]);
    pf_vec3 u = pf_v3_sub(pf_v3_load(x + 3 * (size_t)c[1]), a);
    pf_vec3 v = pf_v3_sub(pf_v3_load(x + 3 * (size_t)c[2]), a);
    pf_vec3 w = pf_v3_sub(pf_v3_load(x + 3 * (size_t)c[3]), a);
    return pf_v3_dot(u, pf_v3_cross(v, w));
}

/* Signed volume of a hex with planar or slightly warped faces, times 6, from its 5-tet split. */
static double hex_volume6(const double *x, const uint32_t *c)
{
    static const uint8_t SPLIT[5][4] = {{0, 1, 3, 4}, {1, 2, 3, 6}, {1, 4, 5, 6}, {3, 6, 7, 4},
                                        {1, 3, 4, 6}};
    double v = 0;
    for (int t = 0; t < 5; ++t) {
        uint32_t tet[4] = {c[SPLIT[t][0]], c[SPLIT[t][1]], c[SPLIT[t][2]], c[SPLIT[t][3]]};
        v += tet_volume6(x, tet);
    }
    return v;
}

/* The cell's nodes in positive orientation: inside-out cells are mirrored (tet: swap 1 and 2;
 * hex: swap bottom and top). */
static void oriented_cell(const double *x, const uint32_t *in, int n, uint32_t *out)
{
    memcpy(out, in, (size_t)n * sizeof *out);
    double v = n == 4 ? tet_volume6(x, in) : hex_volume6(x, in);
    if (v >= 0)
        return;
    if (n == 4) {
        out[1] = in[2];
        out[2] = in[1];
    } else {
        memcpy(out, in + 4, 4 * sizeof *out);
        memcpy(out + 4, in, 4 * sizeof *out);
    }
}

static pf_status collect_faces(const double *x, int32_t n_nodes, const int64_t *offsets,
                               const uint32_t *cells, int32_t n_cells, cell_face *faces,
                               int64_t *n_out, pf_error *err)
{
    int64_t n = 0;
    for (int32_t c = 0; c < n_cells; ++c) {
        int64_t len = offsets[c + 1] - offsets[c];
        PF_CHECK(len == 4 || len == 8, err, PF_ERR_INVALID,
                 "cell %d has %lld nodes (4 for a tet, 8 for a hex)", (int)c, (long long)len);
        const uint32_t *in = cells + offsets[c];
        for (int i = 0; i < len; ++i)
            PF_CHECK(in[i] < (uint32_t)n_nodes, err, PF_ERR_INVALID,
                     "cell %d references node %u of %d", (int)c, in[i], (int)n_nodes);
        uint32_t nodes[8];
        oriented_cell(x, in, (int)len, nodes);
        int n_faces = len == 4 ? 4 : 6, size = len == 4 ? 3 : 4;
        for (int f = 0; f < n_faces; ++f) {
            cell_face *cf = &faces[n++];
            cf->cell = c;
            cf->size = (uint8_t)size;
            for (int i = 0; i < size; ++i)
                cf->nodes[i] = nodes[len == 4 ? TET_FACES[f][i] : HEX_FACES[f][i]];
            make_key(cf);
        }
    }
    *n_out = n;
    return PF_OK;
}

/* Fills the mesh from sorted cell faces: one mesh face per distinct key, stored as its first
 * cell sees it; the second cell uses it reversed. */
static pf_status fill_mesh(pf_mesh *m, const double *x, int32_t n_nodes, int32_t n_cells,
                           const cell_face *faces, int64_t n_cf, int32_t *slot, pf_error *err)
{
    int64_t n_faces = 0, n_face_nodes = 0;
    for (int64_t i = 0; i < n_cf; ++i) {
        if (i > 0 && same_key(&faces[i], &faces[i - 1]))
            continue;
        n_faces++;
        n_face_nodes += faces[i].size;
    }
    PF_CHECK(n_faces <= INT32_MAX, err, PF_ERR_TOO_LARGE, "too many faces");
    PF_TRY(pf_mesh_alloc(m, n_nodes, (int32_t)n_faces, n_face_nodes, n_cells, n_cf, err));
    memcpy(m->x, x, 3 * (size_t)n_nodes * sizeof *x);
    for (int32_t c = 0; c <= n_cells; ++c)
        m->elem_offsets[c] = 0;
    for (int64_t i = 0; i < n_cf; ++i)
        m->elem_offsets[faces[i].cell + 1]++;
    for (int32_t c = 0; c < n_cells; ++c)
        m->elem_offsets[c + 1] += m->elem_offsets[c];
    for (int32_t c = 0; c < n_cells; ++c)
        slot[c] = 0;
    int32_t f = -1;
    for (int64_t i = 0; i < n_cf; ++i) {
        const cell_face *cf = &faces[i];
        uint32_t entry;
        if (i > 0 && same_key(cf, &faces[i - 1])) {
            PF_CHECK(i < 2 || !same_key(cf, &faces[i - 2]), err, PF_ERR_INVALID,
                     "a face of cell %d is shared by three or more cells", (int)cf->cell);
            entry = (uint32_t)f | PF_FACE_REVERSED;
        } else {
            ++f;
            m->face_offsets[f + 1] = m->face_offsets[f] + cf->size;
            memcpy(m->face_nodes + m->face_offsets[f], cf->nodes, cf->size * sizeof(uint32_t));
            entry = (uint32_t)f;
        }
        m->elem_faces[m->elem_offsets[cf->cell] + slot[cf->cell]++] = entry;
    }
    return PF_OK;
}

pf_status pf_mesh_from_cells(pf_mesh *m, const double *x, int32_t n_nodes,
                             const int64_t *cell_offsets, const uint32_t *cells, int32_t n_cells,
                             pf_error *err)
{
    memset(m, 0, sizeof *m);
    PF_CHECK(n_nodes >= 0 && n_cells >= 0, err, PF_ERR_INVALID, "negative counts");
    cell_face *faces = pf_alloc_array(6 * (size_t)n_cells, sizeof *faces);
    int32_t *slot = pf_alloc_array((size_t)n_cells, sizeof *slot);
    pf_status s = PF_OK;
    if ((!faces || !slot) && n_cells > 0)
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cannot allocate %d cells",
                         (int)n_cells);
    int64_t n_cf = 0;
    if (s == PF_OK)
        s = collect_faces(x, n_nodes, cell_offsets, cells, n_cells, faces, &n_cf, err);
    if (s == PF_OK) {
        qsort(faces, (size_t)n_cf, sizeof *faces, compare_cell_face);
        s = fill_mesh(m, x, n_nodes, n_cells, faces, n_cf, slot, err);
    }
    if (s == PF_OK)
        s = pf_mesh_derive(m, err);
    if (s < 0)
        pf_mesh_release(m);
    pf_free(faces);
    pf_free(slot);
    return s;
}

static pf_status from_uniform_cells(pf_mesh *m, const double *x, int32_t n_nodes,
                                    const uint32_t *cells, int32_t n_cells, int per_cell,
                                    pf_error *err)
{
    PF_CHECK(n_cells >= 0, err, PF_ERR_INVALID, "negative cell count");
    int64_t *offsets = pf_alloc_array((size_t)n_cells + 1, sizeof *offsets);
    PF_CHECK(offsets, err, PF_ERR_NOMEM, "cannot allocate %d cells", (int)n_cells);
    for (int32_t c = 0; c <= n_cells; ++c)
        offsets[c] = (int64_t)c * per_cell;
    pf_status s = pf_mesh_from_cells(m, x, n_nodes, offsets, cells, n_cells, err);
    pf_free(offsets);
    return s;
}

pf_status pf_mesh_from_tets(pf_mesh *m, const double *x, int32_t n_nodes, const uint32_t *tets,
                            int32_t n_tets, pf_error *err)
{
    return from_uniform_cells(m, x, n_nodes, tets, n_tets, 4, err);
}

pf_status pf_mesh_from_hexes(pf_mesh *m, const double *x, int32_t n_nodes, const uint32_t *hexes,
                             int32_t n_hexes, pf_error *err)
{
    return from_uniform_cells(m, x, n_nodes, hexes, n_hexes, 8, err);
}
