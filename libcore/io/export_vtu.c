/* ParaView output: a mesh (and one frame of it) as a VTK XML unstructured grid (.vtu) with ASCII
 * data arrays, and .pvd collections that make a time series of such files.
 *
 * Tets and hexes become VTK_TETRA / VTK_HEXAHEDRON cells (ParaView's filters know them best), all
 * other elements VTK_POLYHEDRON cells in VTK's "faces" / "faceoffsets" layout: per cell the face
 * count, then per face its node count and nodes. That layout is our element -> face -> node CSR
 * spelled out cell by cell, with every face walked outward (counter-clockwise seen from outside),
 * as VTK expects. */
#include <pf/io.h>

#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "atomic_file.h"

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

/* ---- writing --------------------------------------------------------------------------------- */

static void open_array(FILE *f, const char *type, const char *name, int components)
{
    fprintf(f, "        <DataArray type=\"%s\" Name=\"%s\"", type, name);
    if (components > 1)
        fprintf(f, " NumberOfComponents=\"%d\"", components);
    fputs(" format=\"ascii\">\n", f);
}

static void close_array(FILE *f) { fputs("        </DataArray>\n", f); }

/* rows of `components` doubles, one row a line */
static void write_doubles(FILE *f, const char *name, const double *v, int64_t rows,
                          int components)
{
    open_array(f, "Float64", name, components);
    for (int64_t i = 0; i < rows; ++i) {
        fputs("         ", f);
        for (int c = 0; c < components; ++c)
            fprintf(f, " %.17g", v[i * components + c]);
        fputc('\n', f);
    }
    close_array(f);
}

/* v[ends[i-1] .. ends[i]) on line i; ends NULL: one value a line */
static void write_int64s(FILE *f, const char *name, const int64_t *v, int64_t n,
                         const int64_t *ends, int64_t rows)
{
    open_array(f, "Int64", name, 1);
    int64_t start = 0;
    for (int64_t r = 0; r < (ends ? rows : n); ++r) {
        int64_t end = ends ? ends[r] : r + 1;
        if (end < 0) /* faceoffsets of a non-polyhedron: nothing in the stream */
            continue;
        fputs("         ", f);
        for (int64_t i = start; i < end; ++i)
            fprintf(f, " %lld", (long long)v[i]);
        fputc('\n', f);
        start = end;
    }
    close_array(f);
}

static void write_cells(FILE *f, const pf_mesh *m, const vtk_cells *c)
{
    fputs("      <Cells>\n", f);
    write_int64s(f, "connectivity", c->conn, c->n_conn, c->offsets, m->n_elems);
    write_int64s(f, "offsets", c->offsets, m->n_elems, NULL, 0);
    open_array(f, "UInt8", "types", 1);
    for (int32_t e = 0; e < m->n_elems; ++e)
        fprintf(f, "          %u\n", (unsigned)c->types[e]);
    close_array(f);
    if (c->any_poly) {
        write_int64s(f, "faces", c->faces, c->n_faces, c->faceoffsets, m->n_elems);
        write_int64s(f, "faceoffsets", c->faceoffsets, m->n_elems, NULL, 0);
    }
    fputs("      </Cells>\n", f);
}

static void write_cell_data(FILE *f, const pf_mesh *m, const vtk_cells *c,
                            const pf_stress_data *stress)
{
    fputs("      <CellData Scalars=\"kind\">\n", f);
    open_array(f, "Int32", "kind", 1);
    for (int32_t e = 0; e < m->n_elems; ++e)
        fprintf(f, "          %d\n", (int)c->kind[e]);
    close_array(f);
    open_array(f, "Float64", "volume", 1);
    for (int32_t e = 0; e < m->n_elems; ++e)
        fprintf(f, "          %.17g\n", pf_mesh_elem_volume(m, e));
    close_array(f);
    if (stress)
        write_doubles(f, "stress", stress->values, m->n_elems, stress->components);
    fputs("      </CellData>\n", f);
}

static void write_vtu(FILE *f, const pf_mesh *m, const vtk_cells *c, const double *u,
                      const pf_stress_data *stress)
{
    fputs("<?xml version=\"1.0\"?>\n"
          "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
          "header_type=\"UInt64\">\n"
          "  <UnstructuredGrid>\n",
          f);
    fprintf(f, "    <Piece NumberOfPoints=\"%d\" NumberOfCells=\"%d\">\n", (int)m->n_nodes,
            (int)m->n_elems);
    if (u) {
        fputs("      <PointData Vectors=\"displacement\">\n", f);
        write_doubles(f, "displacement", u, m->n_nodes, 3);
        fputs("      </PointData>\n", f);
    }
    write_cell_data(f, m, c, stress);
    fputs("      <Points>\n", f);
    write_doubles(f, "Points", m->x, m->n_nodes, 3);
    fputs("      </Points>\n", f);
    write_cells(f, m, c);
    fputs("    </Piece>\n"
          "  </UnstructuredGrid>\n"
          "</VTKFile>\n",
          f);
}

pf_status pf_export_vtu(const char *path, const pf_mesh *m, const double *u,
                        const pf_stress_data *stress, pf_error *err)
{
    PF_TRY(check_mesh(path, m, err));
    PF_TRY(check_fields(path, m, u, stress, err));
    vtk_cells c = {0};
    pf_status s = build_cells(path, m, &c, err);
    pf_atomic_file out = {0};
    if (s == PF_OK)
        s = pf_atomic_file_open(&out, path, err);
    if (s == PF_OK) {
        write_vtu(out.f, m, &c, u, stress);
        s = pf_atomic_file_commit(&out, "VTU file", err);
    }
    cells_release(&c);
    return s;
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
