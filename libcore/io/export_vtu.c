/* ParaView output: a mesh (and one frame of it) as a VTK XML unstructured grid (.vtu) with ASCII
 * data arrays, and .pvd collections that make a time series of such files.
 *
 * Tets and hexes become VTK_TETRA / VTK_HEXAHEDRON cells (ParaView's filters know them best), all
 * other elements VTK_POLYHEDRON cells in VTK's "faces" / "faceoffsets" layout: per cell the face
 * count, then per face its node count and nodes. That layout is our element -> face -> node CSR
 * spelled out cell by cell, with every face walked outward (counter-clockwise seen from outside),
 * as VTK expects. */
#include <pf/integrate.h>
#include <pf/io.h>

#include <math.h>
#include <stdbool.h>
#include <string.h>

#include <zlib.h>


enum { VTK_TETRA = 10, VTK_HEXAHEDRON = 12, VTK_POLYHEDRON = 42 };

/* ---- checks ---------------------------------------------------------------------------------- */

static pf_status check_offsets(const char *path, const int64_t *off, int32_t n, int64_t len_cap,
                               const char *what, pf_error *err)
{
    PF_CHECK(off && off[0] == 0, err, PF_ERR_INVALID, "%s: %s offsets do not start at 0", path,
             what);
    for (int32_t i = 0; i < n; ++i)
        PF_CHECK(off[i + 1] >= off[i] && off[i + 1] <= len_cap, err, PF_ERR_INVALID,
                 "%s: %s %d has a bad offset range [%lld, %lld)", path, what, (int)i,
                 (long long)off[i], (long long)off[i + 1]);
    return PF_OK;
}

/* Index ranges and finite coordinates: what the writer relies on not to read out of bounds
 * (pf_stream_decode_mesh and pf_mesh_validate guarantee it; a hand-built mesh may not). */
static pf_status check_mesh(const char *path, const pf_mesh *m, pf_error *err)
{
    PF_CHECK(m->n_nodes >= 0 && m->n_faces >= 0 && m->n_elems >= 0, err, PF_ERR_INVALID,
             "%s: negative mesh counts", path);
    PF_CHECK(m->x || m->n_nodes == 0, err, PF_ERR_INVALID, "%s: mesh without node positions",
             path);
    PF_TRY(check_offsets(path, m->face_offsets, m->n_faces, INT64_MAX, "face", err));
    PF_TRY(check_offsets(path, m->elem_offsets, m->n_elems, INT64_MAX, "element", err));
    for (int64_t k = 0; k < m->face_offsets[m->n_faces]; ++k)
        PF_CHECK(m->face_nodes[k] < (uint32_t)m->n_nodes, err, PF_ERR_INVALID,
                 "%s: face node entry %lld is node %u of %d", path, (long long)k,
                 (unsigned)m->face_nodes[k], (int)m->n_nodes);
    for (int64_t k = 0; k < m->elem_offsets[m->n_elems]; ++k)
        PF_CHECK(PF_FACE_INDEX(m->elem_faces[k]) < m->n_faces, err, PF_ERR_INVALID,
                 "%s: element face entry %lld is face %d of %d", path, (long long)k,
                 (int)PF_FACE_INDEX(m->elem_faces[k]), (int)m->n_faces);
    for (int64_t i = 0; i < 3 * (int64_t)m->n_nodes; ++i)
        PF_CHECK(isfinite(m->x[i]), err, PF_ERR_INVALID, "%s: node %lld has a non-finite position",
                 path, (long long)(i / 3));
    return PF_OK;
}

static pf_status check_fields(const char *path, const pf_mesh *m, const double *u,
                              const pf_stress_data *stress, pf_error *err)
{
    for (int64_t i = 0; u && i < 3 * (int64_t)m->n_nodes; ++i)
        PF_CHECK(isfinite(u[i]), err, PF_ERR_INVALID,
                 "%s: node %lld has a non-finite displacement", path, (long long)(i / 3));
    if (!stress)
        return PF_OK;
    PF_CHECK(stress->n_elems == m->n_elems && (stress->components == 1 || stress->components == 6)
                 && (stress->values || m->n_elems == 0),
             err, PF_ERR_INVALID,
             "%s: stress of %d elements with %d components for a mesh of %d elements", path,
             (int)stress->n_elems, (int)stress->components, (int)m->n_elems);
    for (int64_t i = 0; i < (int64_t)m->n_elems * stress->components; ++i)
        PF_CHECK(isfinite(stress->values[i]), err, PF_ERR_INVALID,
                 "%s: element %lld has a non-finite stress", path,
                 (long long)(i / stress->components));
    return PF_OK;
}

/* ---- cells ----------------------------------------------------------------------------------- */

typedef struct vtk_cells {
    int64_t *conn;        /* [n_conn] point ids of every cell */
    int64_t n_conn;
    int64_t *offsets;     /* [n_elems] end of each cell in conn */
    uint8_t *types;       /* [n_elems] VTK cell type */
    int32_t *kind;        /* [n_elems] pf_elem_kind */
    int64_t *faces;       /* [n_faces] the polyhedra's face streams */
    int64_t n_faces;
    int64_t *faceoffsets; /* [n_elems] end of each polyhedron's stream in faces, -1 for others */
    bool any_poly;
    const int32_t *element; /* [n cells] the element a cell comes from (tets), or NULL: itself */
    int32_t *seen;        /* [n_nodes] scratch: element that last listed the node, -1 */
} vtk_cells;

static void cells_release(vtk_cells *c)
{
    pf_free(c->conn);
    pf_free(c->offsets);
    pf_free(c->types);
    pf_free(c->kind);
    pf_free(c->faces);
    pf_free(c->faceoffsets);
    pf_free(c->seen);
    memset(c, 0, sizeof *c);
}

/* Node j of the face in element entry `entry`, walking the face outward from the element. */
static uint32_t outward_node(const pf_mesh *m, uint32_t entry, int64_t j)
{
    int32_t f = PF_FACE_INDEX(entry);
    int64_t a = m->face_offsets[f], n = m->face_offsets[f + 1] - a;
    return m->face_nodes[a + ((entry & PF_FACE_REVERSED) ? (n - j) % n : j)];
}

static int find_node(const uint32_t *v, int n, uint32_t node)
{
    for (int i = 0; i < n; ++i)
        if (v[i] == node)
            return i;
    return -1;
}

/* VTK numbers a tet's nodes so that 0, 1, 2 turn counter-clockwise seen from 3, and a hex's so
 * that the base 0-1-2-3 turns counter-clockwise seen from the top 4-5-6-7, node 4 above node 0 and
 * so on. Both bases are an outward face walked backwards; the other nodes are found along the
 * element's edges. false when the connectivity does not allow it (the caller writes a polyhedron
 * instead). */
static bool native_nodes(const pf_mesh *m, int32_t e, int n_base, int64_t out[8])
{
    int64_t k0 = m->elem_offsets[e], k1 = m->elem_offsets[e + 1];
    uint32_t base[4], top[4];
    bool have_top[4] = {false, false, false, false};
    for (int i = 0; i < n_base; ++i)
        base[i] = outward_node(m, m->elem_faces[k0], (n_base - i) % n_base);
    for (int64_t k = k0 + 1; k < k1; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        int64_t a = m->face_offsets[f], n = m->face_offsets[f + 1] - a;
        for (int64_t j = 0; j < n; ++j) {
            uint32_t p = m->face_nodes[a + j], q = m->face_nodes[a + (j + 1) % n];
            const uint32_t edge[2][2] = {{p, q}, {q, p}}; /* both directions of the edge */
            for (int side = 0; side < 2; ++side) {
                uint32_t from = edge[side][0], to = edge[side][1];
                int i = find_node(base, n_base, from);
                if (i < 0 || find_node(base, n_base, to) >= 0)
                    continue;
                if (n_base == 3) /* a tet: every edge off the base goes to the apex */
                    i = 0;
                if (have_top[i] && top[i] != to)
                    return false;
                top[i] = to;
                have_top[i] = true;
            }
        }
    }
    int n_top = n_base == 3 ? 1 : 4;
    for (int i = 0; i < n_top; ++i)
        if (!have_top[i] || find_node(top, i, top[i]) >= 0)
            return false;
    for (int i = 0; i < n_base; ++i)
        out[i] = base[i];
    for (int i = 0; i < n_top; ++i)
        out[n_base + i] = top[i];
    return true;
}

/* Distinct nodes in first-seen order into conn, the face stream into faces. */
static void add_polyhedron(const pf_mesh *m, int32_t e, vtk_cells *c)
{
    int64_t k0 = m->elem_offsets[e], k1 = m->elem_offsets[e + 1];
    c->faces[c->n_faces++] = k1 - k0;
    for (int64_t k = k0; k < k1; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
        c->faces[c->n_faces++] = n;
        for (int64_t j = 0; j < n; ++j) {
            uint32_t v = outward_node(m, m->elem_faces[k], j);
            c->faces[c->n_faces++] = v;
            if (c->seen[v] != e) {
                c->seen[v] = e;
                c->conn[c->n_conn++] = v;
            }
        }
    }
    c->faceoffsets[e] = c->n_faces;
    c->any_poly = true;
}

static pf_status build_cells(const char *path, const pf_mesh *m, vtk_cells *c, pf_error *err)
{
    /* bounds: a cell lists at most all its face-node entries; a face stream adds the counts */
    int64_t face_entries = 0;
    for (int32_t e = 0; e < m->n_elems; ++e)
        for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
            int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
            face_entries += m->face_offsets[f + 1] - m->face_offsets[f];
        }
    int64_t stream = face_entries + m->elem_offsets[m->n_elems] + m->n_elems;
    size_t ne = (size_t)m->n_elems + 1;
    c->conn = pf_alloc_array((size_t)face_entries + 8, sizeof *c->conn);
    c->faces = pf_alloc_array((size_t)stream + 1, sizeof *c->faces);
    c->offsets = pf_alloc_array(ne, sizeof *c->offsets);
    c->types = pf_alloc_array(ne, sizeof *c->types);
    c->kind = pf_alloc_array(ne, sizeof *c->kind);
    c->faceoffsets = pf_alloc_array(ne, sizeof *c->faceoffsets);
    c->seen = pf_alloc_array((size_t)m->n_nodes + 1, sizeof *c->seen);
    PF_CHECK(c->conn && c->faces && c->offsets && c->types && c->kind && c->faceoffsets && c->seen,
             err, PF_ERR_NOMEM, "%s: out of memory for %d cells", path, (int)m->n_elems);
    for (int32_t i = 0; i < m->n_nodes; ++i)
        c->seen[i] = -1;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        pf_elem_kind kind = m->elem_kind ? (pf_elem_kind)m->elem_kind[e]
                                         : pf_mesh_classify_elem(m, e);
        c->kind[e] = (int32_t)kind;
        c->faceoffsets[e] = -1;
        int n_base = kind == PF_ELEM_TET ? 3 : kind == PF_ELEM_HEX ? 4 : 0;
        if (n_base && native_nodes(m, e, n_base, c->conn + c->n_conn)) {
            c->n_conn += n_base == 3 ? 4 : 8;
            c->types[e] = n_base == 3 ? VTK_TETRA : VTK_HEXAHEDRON;
        } else {
            add_polyhedron(m, e, c);
            c->types[e] = VTK_POLYHEDRON;
        }
        c->offsets[e] = c->n_conn;
    }
    return PF_OK;
}

/* ---- writing --------------------------------------------------------------------------------
 * ASCII: every array inline, one row a line. Binary: each array's values, little-endian as in
 * memory, zlib-compressed in blocks of VTU_BLOCK bytes (vtkZLibDataCompressor's layout: a UInt64
 * header [blocks, block size, size of the last block or 0 when it is full, compressed size of
 * every block], then the compressed blocks) and appended after the XML in one raw
 * <AppendedData> section; the DataArray tag gives the array's offset into that section. */

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "binary VTU output assumes a little-endian machine (byte_order=\"LittleEndian\")"
#endif

enum { VTU_BLOCK = 1 << 15 };

typedef struct vtu_writer {
    FILE *f;
    bool ascii;
    pf_buffer appended; /* binary: the <AppendedData> bytes so far */
    pf_buffer block;    /* binary: one compressed block */
    pf_status status;   /* first failure of a binary append (the caller stops there) */
    pf_error *err;
    const char *path;
} vtu_writer;

static void open_array(vtu_writer *w, const char *type, const char *name, int components)
{
    fprintf(w->f, "        <DataArray type=\"%s\" Name=\"%s\"", type, name);
    if (components > 1)
        fprintf(w->f, " NumberOfComponents=\"%d\"", components);
    if (w->ascii)
        fputs(" format=\"ascii\">\n", w->f);
    else
        fprintf(w->f, " format=\"appended\" offset=\"%zu\"/>\n", w->appended.size);
}

static void close_array(vtu_writer *w)
{
    if (w->ascii)
        fputs("        </DataArray>\n", w->f);
}

/* Appends bytes [n] as one compressed array to w->appended (binary mode). */
static void append_compressed(vtu_writer *w, const void *bytes, size_t n)
{
    if (w->status < 0)
        return;
    uint64_t blocks = (n + VTU_BLOCK - 1) / VTU_BLOCK;
    uint64_t head[3] = {blocks, VTU_BLOCK, n % VTU_BLOCK};
    size_t head_at = w->appended.size;
    pf_status s = pf_buffer_append(&w->appended, head, sizeof head, w->err);
    for (uint64_t b = 0; s == PF_OK && b < blocks; ++b) /* room for the block sizes */
        s = pf_buffer_append(&w->appended, &(uint64_t){0}, sizeof(uint64_t), w->err);
    const unsigned char *src = bytes;
    for (uint64_t b = 0; s == PF_OK && b < blocks; ++b) {
        size_t len = b + 1 < blocks || n % VTU_BLOCK == 0 ? VTU_BLOCK : n % VTU_BLOCK;
        uLongf out = compressBound((uLong)len);
        s = pf_buffer_reserve(&w->block, out, w->err);
        if (s == PF_OK && compress(w->block.data, &out, src + b * VTU_BLOCK, (uLong)len) != Z_OK)
            s = pf_error_set(w->err, PF_ERR_NOMEM, __FILE__, __LINE__,
                             "%s: zlib cannot compress a block of %zu bytes", w->path, len);
        if (s == PF_OK) {
            uint64_t size = out;
            memcpy(w->appended.data + head_at + sizeof head + b * sizeof size, &size, sizeof size);
            s = pf_buffer_append(&w->appended, w->block.data, out, w->err);
        }
    }
    w->status = s;
}

/* rows of `components` doubles, one row a line */
static void write_doubles(vtu_writer *w, const char *name, const double *v, int64_t rows,
                          int components)
{
    open_array(w, "Float64", name, components);
    if (!w->ascii) {
        append_compressed(w, v, (size_t)(rows * components) * sizeof *v);
        return;
    }
    for (int64_t i = 0; i < rows; ++i) {
        fputs("         ", w->f);
        for (int c = 0; c < components; ++c)
            fprintf(w->f, " %.17g", v[i * components + c]);
        fputc('\n', w->f);
    }
    close_array(w);
}

/* v[ends[i-1] .. ends[i]) on line i; ends NULL: one value a line */
static void write_int64s(vtu_writer *w, const char *name, const int64_t *v, int64_t n,
                         const int64_t *ends, int64_t rows)
{
    open_array(w, "Int64", name, 1);
    if (!w->ascii) {
        append_compressed(w, v, (size_t)n * sizeof *v);
        return;
    }
    int64_t start = 0;
    for (int64_t r = 0; r < (ends ? rows : n); ++r) {
        int64_t end = ends ? ends[r] : r + 1;
        if (end < 0) /* faceoffsets of a non-polyhedron: nothing in the stream */
            continue;
        fputs("         ", w->f);
        for (int64_t i = start; i < end; ++i)
            fprintf(w->f, " %lld", (long long)v[i]);
        fputc('\n', w->f);
        start = end;
    }
    close_array(w);
}

static void write_int32s(vtu_writer *w, const char *name, const int32_t *v, int64_t n)
{
    open_array(w, "Int32", name, 1);
    if (!w->ascii) {
        append_compressed(w, v, (size_t)n * sizeof *v);
        return;
    }
    for (int64_t i = 0; i < n; ++i)
        fprintf(w->f, "          %d\n", (int)v[i]);
    close_array(w);
}

static void write_uint8s(vtu_writer *w, const char *name, const uint8_t *v, int64_t n)
{
    open_array(w, "UInt8", name, 1);
    if (!w->ascii) {
        append_compressed(w, v, (size_t)n);
        return;
    }
    for (int64_t i = 0; i < n; ++i)
        fprintf(w->f, "          %u\n", (unsigned)v[i]);
    close_array(w);
}

static void write_cells(vtu_writer *w, const vtk_cells *c, int32_t n_cells)
{
    fputs("      <Cells>\n", w->f);
    write_int64s(w, "connectivity", c->conn, c->n_conn, c->offsets, n_cells);
    write_int64s(w, "offsets", c->offsets, n_cells, NULL, 0);
    write_uint8s(w, "types", c->types, n_cells);
    if (c->any_poly) {
        write_int64s(w, "faces", c->faces, c->n_faces, c->faceoffsets, n_cells);
        write_int64s(w, "faceoffsets", c->faceoffsets, n_cells, NULL, 0);
    }
    fputs("      </Cells>\n", w->f);
}

static void write_cell_data(vtu_writer *w, const vtk_cells *c, int32_t n_cells,
                            const double *volume, const pf_stress_data *stress)
{
    fputs("      <CellData Scalars=\"kind\">\n", w->f);
    write_int32s(w, "kind", c->kind, n_cells);
    if (c->element)
        write_int32s(w, "element", c->element, n_cells);
    write_doubles(w, "volume", volume, n_cells, 1);
    if (stress)
        write_doubles(w, "stress", stress->values, n_cells, stress->components);
    fputs("      </CellData>\n", w->f);
}

static void write_vtu(vtu_writer *w, const vtk_cells *c, int32_t n_points, const double *x,
                      int32_t n_cells, const double *u, const double *volume,
                      const pf_stress_data *stress)
{
    FILE *f = w->f;
    fprintf(f,
            "<?xml version=\"1.0\"?>\n"
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
            "header_type=\"UInt64\"%s>\n"
            "  <UnstructuredGrid>\n",
            w->ascii ? "" : " compressor=\"vtkZLibDataCompressor\"");
    fprintf(f, "    <Piece NumberOfPoints=\"%d\" NumberOfCells=\"%d\">\n", (int)n_points,
            (int)n_cells);
    if (u) {
        fputs("      <PointData Vectors=\"displacement\">\n", f);
        write_doubles(w, "displacement", u, n_points, 3);
        fputs("      </PointData>\n", f);
    }
    write_cell_data(w, c, n_cells, volume, stress);
    fputs("      <Points>\n", f);
    write_doubles(w, "Points", x, n_points, 3);
    fputs("      </Points>\n", f);
    write_cells(w, c, n_cells);
    fputs("    </Piece>\n"
          "  </UnstructuredGrid>\n",
          f);
    if (!w->ascii && w->status == PF_OK) {
        fputs("  <AppendedData encoding=\"raw\">\n   _", f);
        fwrite(w->appended.data, 1, w->appended.size, f);
        fputs("\n  </AppendedData>\n", f);
    }
    fputs("</VTKFile>\n", f);
}

static pf_status write_file(const char *path, const vtk_cells *c, int32_t n_points,
                            const double *x, int32_t n_cells, const double *u,
                            const double *volume, const pf_stress_data *stress,
                            const pf_vtu_params *p, pf_error *err)
{
    pf_atomic_file out = {0};
    PF_TRY(pf_atomic_file_open(&out, path, err));
    vtu_writer w = {.f = out.f, .ascii = p->ascii, .err = err, .path = path};
    write_vtu(&w, c, n_points, x, n_cells, u, volume, stress);
    pf_buffer_release(&w.appended);
    pf_buffer_release(&w.block);
    if (w.status < 0) {
        pf_atomic_file_abort(&out);
        return w.status;
    }
    return pf_atomic_file_commit(&out, "VTU file", err);
}

/* ---- the tetrahedral decomposition ------------------------------------------------------------
 * VTK computes a polyhedron's volume (and integrates over it) as if it were convex; pf's cells
 * need not be. With params->tets every element is written as the tetrahedra of
 * pf_polyhedron_tetrahedra, whose volumes sum to the element's exactly up to rounding. A tet
 * vertex that is an element node (same coordinates bit for bit) is that mesh point; the others
 * (cone apexes, nodes of the cuts) are new points, one per element and position, whose
 * displacement is the element's affine least-squares fit of its nodes' displacements
 * u(x) = mean(u) + B (x - mean(x)), B^T = S^-1 sum_i (x_i - c)(u_i - mean u)^T with
 * S = sum_i (x_i - c)(x_i - c)^T: exact when the element moves affinely, and not interpolating
 * otherwise (the node values themselves are kept). */

typedef struct tet_points {
    pf_buffer x, u; /* new points' positions and displacements, 3 doubles each */
    int32_t n;      /* all points: the mesh's, then the new ones */
} tet_points;

/* The cells being built, one buffer per array. */
typedef struct tet_cells {
    pf_buffer conn;                   /* int64 [4 n] point ids */
    pf_buffer element, kind;          /* int32 [n] the element a tet comes from, and its kind */
    pf_buffer volume, stress;         /* double [n], [components n] */
    int64_t n;
} tet_cells;

static void tet_cells_release(tet_cells *t)
{
    pf_buffer_release(&t->conn);
    pf_buffer_release(&t->element);
    pf_buffer_release(&t->kind);
    pf_buffer_release(&t->volume);
    pf_buffer_release(&t->stress);
}

/* The affine fit's centre c, mean displacement and gradient B for element e's nodes. */
static void affine_fit(const pf_mesh *m, const double *u, int32_t e, pf_vec3 *c, pf_vec3 *mean,
                       pf_mat3 *b)
{
    const pf_vec3 zero = {0, 0, 0};
    pf_vec3 sx = zero, su = zero;
    int64_t count = 0;
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j, ++count) {
            sx = pf_v3_add(sx, pf_v3_load(m->x + 3 * (size_t)m->face_nodes[j]));
            su = pf_v3_add(su, pf_v3_load(u + 3 * (size_t)m->face_nodes[j]));
        }
    }
    *c = pf_v3_scale(sx, 1.0 / (double)count); /* nodes weighted by their face count: any */
    *mean = pf_v3_scale(su, 1.0 / (double)count); /* weights give an exact affine fit */
    pf_mat3 s = {{{0}}}, r = {{{0}}};
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
            pf_vec3 d = pf_v3_sub(pf_v3_load(m->x + 3 * (size_t)m->face_nodes[j]), *c);
            pf_vec3 du = pf_v3_sub(pf_v3_load(u + 3 * (size_t)m->face_nodes[j]), *mean);
            for (int i = 0; i < 3; ++i)
                for (int l = 0; l < 3; ++l) {
                    s.m[i][l] += pf_v3_get(d, i) * pf_v3_get(d, l);
                    r.m[i][l] += pf_v3_get(d, i) * pf_v3_get(du, l);
                }
        }
    }
    double det;
    *b = pf_m3_transpose(pf_m3_mul(pf_m3_inverse(s, &det), r));
}

/* The point id of tet vertex v of element e: a node of e, or a new point. */
static pf_status tet_vertex(const pf_mesh *m, const double *u, int32_t e, const double *v,
                            int64_t first_new, tet_points *pts, int64_t *id, pf_error *err)
{
    for (int64_t k = m->elem_offsets[e]; k < m->elem_offsets[e + 1]; ++k) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[k]);
        for (int64_t j = m->face_offsets[f]; j < m->face_offsets[f + 1]; ++j) {
            const double *x = m->x + 3 * (size_t)m->face_nodes[j];
            if (x[0] == v[0] && x[1] == v[1] && x[2] == v[2]) {
                *id = m->face_nodes[j];
                return PF_OK;
            }
        }
    }
    const double *xs = (const double *)pts->x.data;
    for (int64_t i = first_new; i < pts->n - m->n_nodes; ++i)
        if (xs[3 * i] == v[0] && xs[3 * i + 1] == v[1] && xs[3 * i + 2] == v[2]) {
            *id = m->n_nodes + i;
            return PF_OK;
        }
    PF_CHECK(pts->n < INT32_MAX, err, PF_ERR_TOO_LARGE, "too many points for one VTU file");
    PF_TRY(pf_buffer_append(&pts->x, v, 3 * sizeof *v, err));
    if (u) {
        pf_vec3 c, mean;
        pf_mat3 b;
        affine_fit(m, u, e, &c, &mean, &b);
        pf_vec3 d = pf_v3_add(mean, pf_m3_mulv(b, pf_v3_sub(pf_v3_load(v), c)));
        double du[3] = {d.x, d.y, d.z};
        PF_TRY(pf_buffer_append(&pts->u, du, sizeof du, err));
    }
    *id = pts->n++;
    return PF_OK;
}

/* Appends element e's tetrahedra to c (cells), pts (new points), volume and stress rows. */
static pf_status add_elem_tets(const pf_mesh *m, const double *u, const pf_stress_data *stress,
                               int32_t e, pf_arena *scratch, tet_cells *c, tet_points *pts,
                               pf_error *err)
{
    pf_polyhedron poly;
    double *tets = NULL;
    int64_t n_tets = 0, first_new = pts->n - m->n_nodes;
    pf_arena_reset(scratch, 0);
    PF_TRY(pf_mesh_elem_polyhedron(m, e, scratch, &poly, err));
    PF_TRY(pf_polyhedron_tetrahedra(&poly, m->n_nodes, &tets, &n_tets, err));
    pf_status s = PF_OK;
    int32_t kind = (int32_t)(m->elem_kind ? (pf_elem_kind)m->elem_kind[e]
                                          : pf_mesh_classify_elem(m, e));
    for (int64_t t = 0; s == PF_OK && t < n_tets; ++t) {
        const double *v = tets + 12 * t;
        int64_t ids[4];
        for (int i = 0; s == PF_OK && i < 4; ++i)
            s = tet_vertex(m, u, e, v + 3 * i, first_new, pts, &ids[i], err);
        pf_vec3 a = pf_v3_load(v);
        double vol = pf_v3_dot(pf_v3_sub(pf_v3_load(v + 3), a),
                               pf_v3_cross(pf_v3_sub(pf_v3_load(v + 6), a),
                                           pf_v3_sub(pf_v3_load(v + 9), a))) / 6;
        if (s == PF_OK)
            s = pf_buffer_append(&c->conn, ids, sizeof ids, err);
        if (s == PF_OK)
            s = pf_buffer_append(&c->volume, &vol, sizeof vol, err);
        if (s == PF_OK)
            s = pf_buffer_append(&c->element, &e, sizeof e, err);
        if (s == PF_OK)
            s = pf_buffer_append(&c->kind, &kind, sizeof kind, err);
        if (s == PF_OK && stress)
            s = pf_buffer_append(&c->stress, stress->values + (size_t)e * stress->components,
                                 (size_t)stress->components * sizeof(double), err);
        c->n += s == PF_OK;
    }
    pf_free(tets);
    return s;
}

/* Everything in one array: the mesh's points then the new ones (positions, displacements). */
static pf_status join_points(const pf_mesh *m, const double *u, const tet_points *pts,
                             double **x, double **ux, pf_error *err)
{
    size_t n_new = pts->x.size / sizeof(double), n_mesh = 3 * (size_t)m->n_nodes;
    *x = pf_alloc_array(n_mesh + n_new + 1, sizeof **x);
    *ux = u ? pf_alloc_array(n_mesh + n_new + 1, sizeof **ux) : NULL;
    PF_CHECK(*x && (*ux || !u), err, PF_ERR_NOMEM, "out of memory for %zu points",
             (n_mesh + n_new) / 3);
    memcpy(*x, m->x, n_mesh * sizeof **x);
    if (n_new)
        memcpy(*x + n_mesh, pts->x.data, n_new * sizeof **x);
    if (u) {
        memcpy(*ux, u, n_mesh * sizeof **ux);
        if (n_new)
            memcpy(*ux + n_mesh, pts->u.data, n_new * sizeof **ux);
    }
    return PF_OK;
}

static pf_status export_tets(const char *path, const pf_mesh *m, const double *u,
                             const pf_stress_data *stress, const pf_vtu_params *p, pf_error *err)
{
    tet_cells tc = {0};
    tet_points pts = {.n = m->n_nodes};
    pf_arena scratch = {0};
    pf_status s = pf_arena_init(&scratch, 1 << 20, err);
    for (int32_t e = 0; s == PF_OK && e < m->n_elems; ++e) {
        s = add_elem_tets(m, u, stress, e, &scratch, &tc, &pts, err);
        if (s < 0)
            pf_error_prefix(err, "%s: element %d", path, (int)e);
    }
    PF_CHECK(s < 0 || tc.n < INT32_MAX, err, PF_ERR_TOO_LARGE, "%s: too many tetrahedra", path);
    double *x = NULL, *ux = NULL;
    vtk_cells c = {0};
    if (s == PF_OK)
        s = join_points(m, u, &pts, &x, &ux, err);
    if (s == PF_OK && !(PF_ALLOC_N(c.offsets, tc.n) && PF_ALLOC_N(c.types, tc.n)))
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "%s: out of memory", path);
    if (s == PF_OK) {
        c.conn = (int64_t *)tc.conn.data;
        c.n_conn = 4 * tc.n;
        c.kind = (int32_t *)tc.kind.data;
        c.element = (int32_t *)tc.element.data;
        for (int64_t t = 0; t < tc.n; ++t) {
            c.offsets[t] = 4 * (t + 1);
            c.types[t] = VTK_TETRA;
        }
        pf_stress_data ts = {.n_elems = (int32_t)tc.n,
                             .components = stress ? stress->components : 1,
                             .values = (double *)tc.stress.data};
        s = write_file(path, &c, pts.n, x, (int32_t)tc.n, ux, (const double *)tc.volume.data,
                       stress ? &ts : NULL, p, err);
    }
    pf_free(c.offsets);
    pf_free(c.types);
    pf_free(x);
    pf_free(ux);
    pf_buffer_release(&pts.x);
    pf_buffer_release(&pts.u);
    tet_cells_release(&tc);
    pf_arena_release(&scratch);
    return s;
}

pf_vtu_params pf_vtu_params_default(void)
{
    return (pf_vtu_params){.ascii = false, .tets = false};
}

pf_status pf_export_vtu_with(const char *path, const pf_mesh *m, const double *u,
                             const pf_stress_data *stress, const pf_vtu_params *params,
                             pf_error *err)
{
    pf_vtu_params p = params ? *params : pf_vtu_params_default();
    PF_TRY(check_mesh(path, m, err));
    PF_TRY(check_fields(path, m, u, stress, err));
    if (p.tets)
        return export_tets(path, m, u, stress, &p, err);
    vtk_cells c = {0};
    double *volume = NULL;
    pf_status s = build_cells(path, m, &c, err);
    if (s == PF_OK && !PF_ALLOC_N(volume, m->n_elems))
        s = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "%s: out of memory", path);
    for (int32_t e = 0; s == PF_OK && e < m->n_elems; ++e)
        volume[e] = pf_mesh_elem_volume(m, e);
    if (s == PF_OK)
        s = write_file(path, &c, m->n_nodes, m->x, m->n_elems, u, volume, stress, &p, err);
    pf_free(volume);
    cells_release(&c);
    return s;
}

pf_status pf_export_vtu(const char *path, const pf_mesh *m, const double *u,
                        const pf_stress_data *stress, pf_error *err)
{
    return pf_export_vtu_with(path, m, u, stress, NULL, err);
}

/* ---- .pvd ------------------------------------------------------------------------------------ */

/* An XML attribute value: the five characters XML reserves, escaped. */
static void write_attribute(FILE *f, const char *s)
{
    for (; *s; ++s) {
        switch (*s) {
        case '&': fputs("&amp;", f); break;
        case '<': fputs("&lt;", f); break;
        case '>': fputs("&gt;", f); break;
        case '"': fputs("&quot;", f); break;
        case '\'': fputs("&apos;", f); break;
        default: fputc(*s, f);
        }
    }
}

pf_status pf_export_pvd(const char *path, const char *const *files, const double *times, int32_t n,
                        pf_error *err)
{
    PF_CHECK(n >= 0 && (n == 0 || (files && times)), err, PF_ERR_INVALID,
             "%s: a collection of %d files", path, (int)n);
    for (int32_t i = 0; i < n; ++i) {
        PF_CHECK(files[i] && files[i][0], err, PF_ERR_INVALID, "%s: file %d has no name", path,
                 (int)i);
        PF_CHECK(isfinite(times[i]), err, PF_ERR_INVALID, "%s: file %s has a non-finite time",
                 path, files[i]);
    }
    pf_atomic_file out;
    PF_TRY(pf_atomic_file_open(&out, path, err));
    FILE *f = out.f;
    fputs("<?xml version=\"1.0\"?>\n"
          "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
          "  <Collection>\n",
          f);
    for (int32_t i = 0; i < n; ++i) {
        fprintf(f, "    <DataSet timestep=\"%.17g\" group=\"\" part=\"0\" file=\"", times[i]);
        write_attribute(f, files[i]);
        fputs("\"/>\n", f);
    }
    fputs("  </Collection>\n"
          "</VTKFile>\n",
          f);
    return pf_atomic_file_commit(&out, "PVD file", err);
}
