/* pf/mesh.h: the polyhedral mesh, its validation, builders and text view.
 *
 * Struct of arrays with CSR offsets, the same shape as the MESH chunk of the pf stream and as VTK's
 * polyhedron cells. Faces are planar polygons (convex or not), listed counter-clockwise seen from
 * their first element, i.e. with the outward normal of that element. Elements are closed polyhedra
 * given as lists of faces, each with an orientation bit: bit 31 of an elem_faces entry set means the
 * face is used reversed (its nodes are clockwise seen from outside this element). Every face is used
 * by one element (boundary) or two (interior, once each way round), so the mesh is conforming at face
 * level even where a large cell meets several small ones.
 *
 * The element kind (tet, hex, general polyhedron) is derived from the connectivity, never read.
 */
#ifndef PF_MESH_H
#define PF_MESH_H

#include <stdbool.h>
#include <stdio.h>

#include <pf/base.h>
#include <pf/geom.h>

#ifdef __cplusplus
extern "C" {
#endif

#define PF_FACE_REVERSED 0x80000000u
#define PF_FACE_INDEX(entry) ((int32_t)((entry) & ~PF_FACE_REVERSED))

typedef enum pf_elem_kind {
    PF_ELEM_TET = 0,  /* 4 triangles on 4 nodes */
    PF_ELEM_HEX = 1,  /* 6 quadrilaterals on 8 nodes, 3 faces at every node */
    PF_ELEM_POLY = 2, /* anything else */
    PF_ELEM_KIND_COUNT = 3
} pf_elem_kind;

/* A named region of a mesh (a Gmsh physical group): its number (> 0), its dimension (3: a set of
 * elements, 2: a set of faces) and its name (NUL-terminated, pf_alloc; may be empty). */
typedef struct pf_mesh_group {
    int32_t number;
    int32_t dim;
    char *name;
} pf_mesh_group;

typedef struct pf_mesh {
    uint64_t id;            /* generation: a new id for every new topology (refinement, cutting) */
    int32_t n_nodes;
    int32_t n_faces;
    int32_t n_elems;
    double *x;              /* [3 * n_nodes] node positions */
    int64_t *face_offsets;  /* [n_faces + 1], face_offsets[0] = 0 */
    uint32_t *face_nodes;   /* [face_offsets[n_faces]] node indices */
    int64_t *elem_offsets;  /* [n_elems + 1], elem_offsets[0] = 0 */
    uint32_t *elem_faces;   /* [elem_offsets[n_elems]] face index | PF_FACE_REVERSED */

    /* Derived by pf_mesh_derive, NULL before. */
    int32_t *face_elems;    /* [2 * n_faces]: the element using face f as stored, then the one
                               using it reversed; -1 where there is none */
    uint8_t *elem_kind;     /* [n_elems] pf_elem_kind */

    /* Optional regions (Gmsh physical groups; the GRPS chunk of the stream), NULL / 0 when the
     * mesh has none. A group number is > 0; 0 means "in no group". Kept by pf_mesh_copy and
     * pf_mesh_select_elements; builders and other edits leave them NULL. */
    int32_t *elem_group; /* [n_elems] the 3D group of each element, or NULL */
    int32_t *face_group; /* [n_faces] the 2D group of each face, or NULL */
    int32_t n_groups;
    pf_mesh_group *groups; /* [n_groups] numbers, dimensions and names, numbers unique per
                              dimension */
} pf_mesh;

/* Allocates all arrays of an empty mesh with the given counts (contents uninitialised except
 * face_offsets[0] = elem_offsets[0] = 0). m must be zeroed or released. */
pf_status pf_mesh_alloc(pf_mesh *m, int32_t n_nodes, int32_t n_faces, int64_t n_face_nodes,
                        int32_t n_elems, int64_t n_elem_faces, pf_error *err);
/* Frees every array and zeroes the struct. Safe on a zeroed mesh. */
void pf_mesh_release(pf_mesh *m);
/* Deep copy of src into dst (dst zeroed or released first). */
pf_status pf_mesh_copy(pf_mesh *dst, const pf_mesh *src, pf_error *err);

/* Gives m (without groups) the arrays of groups: elem_group and face_group zeroed (in no group),
 * n_groups entries with zero numbers and NULL names for the caller to fill. PF_ERR_NOMEM. */
pf_status pf_mesh_groups_alloc(pf_mesh *m, int32_t n_groups, pf_error *err);
/* Frees the group arrays and names of m (the mesh itself stays). */
void pf_mesh_groups_release(pf_mesh *m);
/* Gives dst (which has none) src's groups: the names, and the arrays copied when dst has src's
 * element and face counts (zeroed otherwise, for the caller to fill). Nothing when src has no
 * groups. PF_ERR_NOMEM. */
pf_status pf_mesh_groups_copy(pf_mesh *dst, const pf_mesh *src, pf_error *err);
/* The group of dimension dim named name (NULL name: number given) in m; NULL when none. */
const pf_mesh_group *pf_mesh_find_group(const pf_mesh *m, int32_t dim, const char *name,
                                        int32_t number);

/* A change of elements (refinement, coarsening, cutting) carries per-face labels of old (derived)
 * to next (derived): out[f] (next->n_faces) is label[face_src[f]] for a face that is an old one
 * (face_src NULL: none is), else for a boundary face the label of the old boundary face of its
 * element's old element(s) it lies in (parent[e]; merged_into [old elements]: the next element an
 * old one was merged into, or NULL), else 0. PF_ERR_NOMEM. */
pf_status pf_mesh_carry_face_label(const pf_mesh *next, const pf_mesh *old, const int32_t *parent,
                                   const int32_t *merged_into, const int32_t *face_src,
                                   const int32_t *label, int32_t *out, pf_error *err);
/* old's groups on next the same way: an element takes its parent's group, a face its label. */
pf_status pf_mesh_carry_groups(pf_mesh *next, const pf_mesh *old, const int32_t *parent,
                               const int32_t *merged_into, const int32_t *face_src, pf_error *err);

/* Computes face_elems and elem_kind. Fails (PF_ERR_INVALID, naming the face) when a face is
 * used by more than two elements or twice with the same orientation, or when an index is out of
 * range. Idempotent. */
pf_status pf_mesh_derive(pf_mesh *m, pf_error *err);

/* Kind of element e from its connectivity alone. */
pf_elem_kind pf_mesh_classify_elem(const pf_mesh *m, int32_t e);
const char *pf_elem_kind_name(pf_elem_kind k);

/* Outward-oriented view of element e: faces copied (reversed where needed) into scratch from the
 * arena; out->x borrows m->x. Fails with PF_ERR_NOMEM when the arena is too small. */
pf_status pf_mesh_elem_polyhedron(const pf_mesh *m, int32_t e, pf_arena *scratch,
                                  pf_polyhedron *out, pf_error *err);

/* Whether element eb of b is element ea of a node for node, so that anything computed from one
 * element's geometry and node numbering (basis functions, element integrals) is the same bit for
 * bit on both: the same number of faces, in the same order, each with the same orientation flag,
 * on the mesh boundary in both or in neither, and with the same nodes in the same order (a's
 * through node_map [a->n_nodes]: the b index of each a node, -1 for none; NULL: the same
 * indices) at bitwise equal coordinates; and the map keeps the order of the element's node
 * indices (pf_poly_split and the quadrature number by index). Needs both meshes derived. */
bool pf_mesh_elem_same(const pf_mesh *a, int32_t ea, const pf_mesh *b, int32_t eb,
                       const int32_t *node_map);

/* Volume of element e (signed: negative when inside out), exact for planar faces. */
double pf_mesh_elem_volume(const pf_mesh *m, int32_t e);

/* Sum of the signed element volumes, summed in element order (so the same mesh gives the same
 * bits). */
double pf_mesh_volume(const pf_mesh *m);

/* Bounding box of all nodes; both zero for an empty mesh. */
void pf_mesh_bounds(const pf_mesh *m, pf_vec3 *lo, pf_vec3 *hi);

typedef struct pf_mesh_validate_params {
    /* A face is non-planar when a vertex lies farther than planarity_tol * face diameter from
     * its plane. Default 1e-9: well above round-off of coordinates written as doubles, well below
     * any intentional bend. */
    double planarity_tol;
    /* A node counts as repeated in a face when closer than duplicate_tol * face diameter to
     * another of the face's nodes. Default 1e-12. */
    double duplicate_tol;
} pf_mesh_validate_params;

pf_mesh_validate_params pf_mesh_validate_params_default(void);

/* Checks, in this order, and reports the first offending entity in err (PF_ERR_INVALID):
 * array shapes and index ranges; non-finite coordinates; a face with fewer than 3 distinct nodes;
 * a non-planar face; a face used by more than two elements or twice with the same orientation; an
 * element that is not closed or not consistently oriented (every directed edge of its outward
 * faces must be matched by the opposite directed edge); a non-positive element volume.
 * params may be NULL for the defaults. Does not modify m (derived arrays are not needed). */
pf_status pf_mesh_validate(const pf_mesh *m, const pf_mesh_validate_params *params, pf_error *err);

/* The elements e of src with keep[e] != 0 as a mesh of their own, in dst (zeroed or released):
 * every node of src, at the same index (so node data stays valid), the faces the kept elements use
 * (in the order of src, each once, shared faces still shared) and the kept elements in the order of
 * src. elem_map[n_elems of dst], when not NULL and of src->n_elems entries, receives the src index
 * of every dst element. dst->id = src->id. Derived arrays are not computed. PF_ERR_NOMEM. */
pf_status pf_mesh_select_elements(pf_mesh *dst, const pf_mesh *src, const uint8_t *keep,
                                  int32_t *elem_map, pf_error *err);

/* Drops the nodes no face of m uses, renumbering the rest in order: node_id[old n_nodes]
 * receives each old node's new index, -1 for a dropped one. */
void pf_mesh_compact_nodes(pf_mesh *m, int32_t *node_id);

/* Keeps only the largest (by volume) set of elements connected through shared faces, in place:
 * the others' elements, faces and nodes are dropped (nodes renumbered in order), m derived.
 * *parts receives the number of such sets, *dropped the elements dropped. PF_ERR_NOMEM, and
 * pf_mesh_derive's statuses. */
pf_status pf_mesh_keep_largest_part(pf_mesh *m, int32_t *parts, int32_t *dropped, pf_error *err);

/* ---- builders from cell lists ------------------------------------------------------------------
 * Faces shared by two cells are created once. Node numbering of cells follows Gmsh/VTK:
 * tet (0,1,2,3) with node 3 on the positive side of (0,1,2); hex with bottom 0-1-2-3 and top 4-5-6-7
 * above them. Cells given inside-out (negative volume) are reoriented, so the result is valid for
 * any non-degenerate input. Node coordinates are copied. */
pf_status pf_mesh_from_tets(pf_mesh *m, const double *x, int32_t n_nodes, const uint32_t *tets,
                            int32_t n_tets, pf_error *err);
pf_status pf_mesh_from_hexes(pf_mesh *m, const double *x, int32_t n_nodes, const uint32_t *hexes,
                             int32_t n_hexes, pf_error *err);
/* Mixed: cells[cell_offsets[c] .. cell_offsets[c+1]) are 4 (tet) or 8 (hex) node indices. */
pf_status pf_mesh_from_cells(pf_mesh *m, const double *x, int32_t n_nodes,
                             const int64_t *cell_offsets, const uint32_t *cells, int32_t n_cells,
                             pf_error *err);

/* ---- triangle surfaces ------------------------------------------------------------------------
 * The render / embedded surface (SURF chunk): triangles counter-clockwise seen from outside. */
typedef struct pf_surface {
    uint64_t id;
    int32_t n_verts;
    int32_t n_tris;
    double *x;     /* [3 * n_verts] */
    uint32_t *tri; /* [3 * n_tris] vertex indices */
    /* [n_tris] what each triangle is (PF_SURFACE_MODEL, PF_SURFACE_CAP), or NULL: all the model's
     * own surface. Caps close a cut (pf_surface_cut); renderers colour them, exports group them. */
    uint8_t *tri_part;
} pf_surface;

enum { PF_SURFACE_MODEL = 0, PF_SURFACE_CAP = 1 };

pf_status pf_surface_alloc(pf_surface *s, int32_t n_verts, int32_t n_tris, pf_error *err);
void pf_surface_release(pf_surface *s);
/* The triangles whose tri_part is PF_SURFACE_CAP (0 when tri_part is NULL). */
int32_t pf_surface_count_caps(const pf_surface *s);

typedef struct pf_surface_stats {
    int32_t n_verts, n_tris;
    int closed;           /* every edge used by exactly two triangles */
    int manifold;         /* edge-manifold, consistently oriented, vertex-manifold */
    int64_t n_boundary_edges, n_nonmanifold_edges, n_flipped_edges;
    double volume;        /* enclosed volume by the divergence theorem (meaningful when closed) */
    double area;
    pf_vec3 lo, hi;
} pf_surface_stats;

/* Fails (PF_ERR_INVALID) on indices out of range or non-finite coordinates. */
pf_status pf_surface_compute_stats(const pf_surface *s, pf_surface_stats *out, pf_error *err);

/* ---- after import: up axis, scale, orientation ---------------------------------------------------
 * pf's up is +z. A file whose up is another axis (glTF and Collada as assimp returns them: +y) is
 * turned by the proper quarter or half turn that takes its up onto +z. */
typedef enum pf_up_axis {
    PF_UP_Z = 0, /* unchanged */
    PF_UP_X = 1,
    PF_UP_Y = 2,
    PF_UP_NEG_X = 3,
    PF_UP_NEG_Y = 4,
    PF_UP_NEG_Z = 5,
    PF_UP_AUTO = 6, /* the up axis the file declares (pf_import_surface_fixed); for a surface
                       already in memory (pf_surface_fix), +z: no turn */
} pf_up_axis;

/* "z", "x", "y", "-x", "-y", "-z", "auto" ("?" for another value). */
const char *pf_up_axis_name(pf_up_axis up);
/* Parses those names (a leading '+' allowed on an axis); false for anything else. */
bool pf_up_axis_parse(const char *text, pf_up_axis *out);

typedef struct pf_surface_fix_params {
    pf_up_axis up; /* the file's up axis, turned onto +z (default PF_UP_Z: no turn; PF_UP_AUTO:
                      the file's own, see pf_import_surface_fixed) */
    double scale;  /* uniform factor applied after the turn, > 0 (default 1) */
    bool orient;   /* make the orientation consistent and outward (default true) */
} pf_surface_fix_params;

pf_surface_fix_params pf_surface_fix_params_default(void);

typedef struct pf_surface_fix_report {
    int32_t components;         /* patches connected through edges used by exactly two triangles */
    int32_t flipped_faces;      /* triangles turned to agree with the majority of their patch */
    int32_t flipped_components; /* patches turned outward (negative volume, not a cavity) */
    double volume_before;       /* signed volume after the scale, before orienting */
    double volume_after;
} pf_surface_fix_report;

/* Consistent outward orientation in place: per patch, the minority of triangles whose traversal
 * of a shared edge disagrees with the majority is flipped; then every patch of negative signed
 * volume that does not lie inside another patch (winding number of the others <= 1/2 at one of
 * its vertices) is flipped whole. Sets the orientation fields of *r. PF_ERR_NOMEM. */
pf_status pf_surface_orient(pf_surface *s, pf_surface_fix_report *r, pf_error *err);

/* *overlap = true when a patch of s has a vertex inside another patch (winding number of that
 * patch > 1/2 at one of up to 64 sampled vertices), unless it lies wholly inside it facing
 * inward (a cavity): overlapping closed parts, whose union the winding number defines but an
 * exact cut would count twice. Intersections within one patch are not looked for. O(64 patches
 * x triangles). PF_ERR_NOMEM. */
pf_status pf_surface_parts_overlap(const pf_surface *s, bool *overlap, pf_error *err);

/* The post-import step every tool applies to a surface read from a file: turn, scale, orient
 * (params NULL: the defaults). report may be NULL. PF_ERR_INVALID for an unknown axis, a scale
 * that is not finite and > 0, an index out of range or a non-finite coordinate. */
pf_status pf_surface_fix(pf_surface *s, const pf_surface_fix_params *params,
                         pf_surface_fix_report *report, pf_error *err);

/* ---- repair (pf-slice and pf-octree --repair) -------------------------------------------------
 * In place: vertices at exactly one position welded; triangles with a repeated corner removed
 * (degenerate); of triangles on the same three corners, one per orientation kept (duplicates),
 * and a pair facing opposite ways removed both (it bounds nothing: two closed parts touching at
 * a face become their union); orientation made consistent and outward (pf_surface_orient); then
 * every hole (loop of edges used by one triangle) whose perimeter is at most max_hole times the
 * bounding-box diagonal and which has at most max_hole_edges edges is closed by its
 * triangulation of least area, using no diagonal that is an edge already; unused vertices are
 * dropped. Zero-area triangles with three distinct corners are kept (they may join T-junctions). */
typedef struct pf_surface_repair_params {
    double max_hole;        /* largest hole perimeter filled, fraction of the bounding-box
                               diagonal, >= 0 (default 0.5) */
    int32_t max_hole_edges; /* largest hole filled, in edges, 3 .. 4096 (default 600: the
                               O(n^3) triangulation of such a hole takes about 0.1 s) */
} pf_surface_repair_params;

pf_surface_repair_params pf_surface_repair_params_default(void);

typedef struct pf_surface_repair_report {
    int32_t tris_before;
    int32_t welded;         /* vertices merged into another at the same position */
    int32_t degenerate;     /* triangles removed for a repeated corner */
    int32_t duplicates;     /* triangles removed repeating another the same way round */
    int32_t opposite_pairs; /* pairs removed: same corners, opposite orientation */
    pf_surface_fix_report orient;
    int32_t holes;          /* boundary loops found (after the removals) */
    int32_t holes_filled;
    int32_t fill_triangles;
    double largest_left;    /* perimeter of the largest hole left open, over the diagonal */
    bool closed;            /* the result is closed and manifold */
} pf_surface_repair_report;

/* params NULL: the defaults; report may be NULL. PF_ERR_INVALID for parameters out of range,
 * an index out of range or a non-finite coordinate, or when no triangle is left; PF_ERR_NOMEM. */
pf_status pf_surface_repair(pf_surface *s, const pf_surface_repair_params *params,
                            pf_surface_repair_report *report, pf_error *err);

/* Unit vertex normals normals [3 n_verts] of s at positions x [3 n_verts] (NULL: s->x): the
 * area-weighted average of the normals of the triangles around each vertex (outward for an
 * outward surface); the zero vector for a vertex no triangle with area uses. Indices must be in
 * range (pf_surface_compute_stats checks them). */
void pf_surface_vertex_normals(const pf_surface *s, const double *x, double *normals);
/* The same for a surface with cap triangles (tri_part PF_SURFACE_CAP), one normal per vertex for
 * formats that hold no more: a vertex used by the model's triangles takes theirs only (the sharp
 * rim of a cut does not bend the model's shading), a vertex of caps only its caps'. Without caps,
 * pf_surface_vertex_normals exactly. PF_ERR_NOMEM. */
pf_status pf_surface_part_normals(const pf_surface *s, const double *x, double *normals,
                                  pf_error *err);

/* ---- generated models (tests, benchmarks, the demo) -------------------------------------------- */

/* Hex grid of nx * ny * nz cells filling the box [lo, hi]; nodes numbered x fastest, then y,
 * then z, cells the same way. */
pf_status pf_mesh_make_box(pf_mesh *m, pf_vec3 lo, pf_vec3 hi, int32_t nx, int32_t ny, int32_t nz,
                           pf_error *err);
/* The same grid with every cell split into the 6 tetrahedra around its diagonal from its lowest
 * to its highest corner (Kuhn), 6 nx ny nz tets, the 6 of a cell consecutive. */
pf_status pf_mesh_make_box_tets(pf_mesh *m, pf_vec3 lo, pf_vec3 hi, int32_t nx, int32_t ny,
                                int32_t nz, pf_error *err);
/* Closed torus around the z axis through the origin: tube centre radius R, tube radius r < R,
 * n_major >= 3 segments around z, n_minor >= 3 around the tube. Volume -> 2 pi^2 R r^2. */
pf_status pf_surface_make_torus(pf_surface *s, double R, double r, int32_t n_major,
                                int32_t n_minor, pf_error *err);
/* Closed sphere around the origin: n_lat >= 2 bands between the poles, n_lon >= 3 segments. */
pf_status pf_surface_make_sphere(pf_surface *s, double radius, int32_t n_lat, int32_t n_lon,
                                 pf_error *err);
/* Closed box lo..hi (lo < hi componentwise) as 24 vertices, four per face so that each face is
 * shaded flat, and 12 triangles, counter-clockwise seen from outside. Volume: the box's. */
pf_status pf_surface_make_box(pf_surface *s, pf_vec3 lo, pf_vec3 hi, pf_error *err);

/* ---- voxelization -------------------------------------------------------------------------------
 * A regular grid of cubes: cell (i, j, k) is [origin + h (i, j, k), origin + h (i+1, j+1, k+1)]. */
typedef struct pf_grid {
    pf_vec3 origin;
    double h;      /* cell edge length */
    int32_t n[3];  /* cells along x, y, z */
} pf_grid;

typedef enum pf_voxel_mode {
    PF_VOXEL_INSIDE = 0,  /* cells whose centre is inside the surface */
    PF_VOXEL_OVERLAP = 1, /* those, plus every cell a triangle passes through */
} pf_voxel_mode;

typedef enum pf_inside_method {
    PF_INSIDE_RAYS = 0,    /* closed surfaces: signed crossings along grid rows in x, y and z
                              (Embree), inside where at least two of the three agree */
    PF_INSIDE_WINDING = 1, /* open surfaces: generalised winding number >= 1/2 */
    PF_INSIDE_AUTO = 2,    /* a choice only: rays when the surface is closed, else the winding
                              number */
} pf_inside_method;

typedef struct pf_voxelize_params {
    int32_t res;         /* cells along the longest side of the bounding box (default 32) */
    double cell;         /* cell size; > 0 overrides res */
    bool has_origin;     /* grid origin given; else the grid is centred on the bounding box */
    pf_vec3 origin;
    pf_voxel_mode mode;
    /* inside test (default PF_INSIDE_AUTO). PF_INSIDE_RAYS on an open surface is allowed: the
     * two-of-three vote absorbs a hole smaller than a cell that a few rows pass through; the
     * winding number is exact for holes of any size but costs O(triangles) per cell. */
    pf_inside_method inside;
} pf_voxelize_params;

pf_voxelize_params pf_voxelize_params_default(void);

/* The grid the voxelizer uses for a surface's bounding box [lo, hi]: covering it whole. */
pf_status pf_grid_fit(pf_vec3 lo, pf_vec3 hi, const pf_voxelize_params *p, pf_grid *grid,
                      pf_error *err);

/* inside[(k n1 + j) n0 + i] = 1 when the centre of cell (i, j, k) is inside the surface. The
 * method is chosen by the surface: rays for closed ones, the winding number for open ones;
 * *method says which. */
pf_status pf_surface_classify_cells(const pf_surface *s, const pf_grid *grid, uint8_t *inside,
                                    pf_inside_method *method, pf_error *err);
/* As pf_surface_classify_cells, with the test chosen by want (PF_INSIDE_AUTO: by the surface);
 * *method says which ran. PF_ERR_INVALID for another value of want. */
pf_status pf_surface_classify_cells_by(const pf_surface *s, const pf_grid *grid,
                                       pf_inside_method want, uint8_t *inside,
                                       pf_inside_method *method, pf_error *err);

/* A hex mesh of the selected grid cells (inside test p->inside). Nodes not used by a cell are
 * dropped. *grid and *method report what was used (either may be NULL). PF_ERR_INVALID when no
 * cell is selected. */
pf_status pf_mesh_voxelize(pf_mesh *m, const pf_surface *s, const pf_voxelize_params *p,
                           pf_grid *grid, pf_inside_method *method, pf_error *err);

/* ---- the winding-number solid as a closed surface ---------------------------------------------
 * The boundary of {w >= 1/2}, w the generalised winding number of s, on the lattice of nodes
 * origin + h (i, j, k), 0 <= i < n[0] (and so on); the outer layer of nodes counts as outside.
 * Marching tetrahedra on the Kuhn split of the lattice cubes, so the result is closed, manifold,
 * outward and without self-intersections for any s (open, non-manifold, self-intersecting,
 * overlapping parts); a contour vertex lies where its lattice edge crosses s when it does (the
 * contour follows s where s is a clean boundary) and at the linear interpolation of w at 1/2
 * otherwise (holes are spanned), within [0.05, 0.95] of its edge. s should be consistently
 * oriented (pf_surface_orient): w counts inward triangles negatively. */
typedef struct pf_winding_contour_stats {
    int64_t inside_nodes;
    int64_t on_surface;   /* contour vertices placed on s */
    int64_t interpolated; /* contour vertices placed by interpolation of w (holes) */
    int32_t n_tris;
    double seconds;
} pf_winding_contour_stats;

/* out is zeroed first, released on failure; stats may be NULL. PF_ERR_INVALID when no node is
 * inside or the lattice is degenerate; PF_ERR_TOO_LARGE beyond 2^27 nodes; PF_ERR_NOMEM. */
pf_status pf_surface_winding_contour(const pf_surface *s, pf_vec3 origin, double h,
                                     const int32_t n[3], pf_surface *out,
                                     pf_winding_contour_stats *stats, pf_error *err);

/* ---- slicing (DG paper sec. 9.2) ----------------------------------------------------------------
 * The solid bounded by a closed surface intersected with a grid of cubes: interior cells are hexes,
 * every cell the surface crosses becomes the exact polyhedron (one element per connected piece) of
 * the solid inside it, so the mesh's boundary is the surface. Pieces below merge * h^3 are merged
 * into the neighbour sharing the most face area with them (sec. 9.4). */
typedef struct pf_slice_params {
    pf_voxelize_params grid; /* res / cell / origin (mode and inside unused) */
    double merge;            /* sliver threshold, fraction of a cell's volume (default 0.05) */
    /* Robust mode (default true): a surface that is not closed, manifold and outward is oriented
     * (pf_surface_orient) and replaced by the boundary of its winding-number solid
     * (pf_surface_winding_contour on a lattice contour_refine times finer than the grid, offset
     * by half a lattice edge so that no lattice node lies on a grid plane), which is then sliced
     * exactly. A clean surface is sliced as it is, so the mesh is the same to the bit. false:
     * such a surface is refused. */
    bool robust;
    int32_t contour_refine;  /* lattice edges per grid cell edge, 1 .. 8 (default 2) */
    pf_progress_fn progress; /* NULL: none; else called with the grid slabs (along x) done */
    void *progress_ctx;
} pf_slice_params;

pf_slice_params pf_slice_params_default(void);

typedef struct pf_slice_stats {
    pf_grid grid;
    int64_t splits;           /* plane splits performed */
    int32_t pieces;           /* elements before merging */
    int32_t merged;           /* slivers merged into a neighbour */
    int32_t isolated_slivers; /* pieces below the threshold touching no other piece (kept) */
    int32_t kinds[PF_ELEM_KIND_COUNT];
    double seconds;
    bool robust_used;                  /* the surface was not clean: oriented, then maybe contoured */
    bool contoured;                    /* its winding-number contour was sliced */
    pf_surface_fix_report orient;      /* with robust_used: what orienting changed */
    pf_winding_contour_stats contour;  /* with robust_used */
} pf_slice_stats;

/* Slices s into m (derived). A closed, manifold, outward s is cut as it is; any other is, in the
 * robust mode, replaced by the boundary of its winding-number solid first (pf_slice_winding_surface),
 * and refused otherwise (PF_ERR_INVALID, saying what is wrong). stats may be NULL.
 * PF_ERR_NUMERIC when the geometry is too degenerate for a consistent cut at the model's tolerance
 * (1e-10 of its size). */
pf_status pf_mesh_slice(pf_mesh *m, const pf_surface *s, const pf_slice_params *params,
                        pf_slice_stats *stats, pf_error *err);

/* The robust mode's replacement of s for slicing with grid: a copy of s oriented
 * (pf_surface_orient, reported in *orient); when that is closed, manifold and outward, that copy
 * (*contoured false); else the boundary of its winding-number solid on the lattice of spacing
 * grid->h / refine whose nodes sit half a spacing off the grid planes (pf_surface_winding_contour,
 * reported in *contour), covering the grid and one node beyond (*contoured true). out zeroed
 * first. PF_ERR_INVALID for refine outside 1 .. 8, and as those two functions. */
pf_status pf_slice_winding_surface(const pf_surface *s, const pf_grid *grid, int32_t refine,
                                   pf_surface *out, pf_surface_fix_report *orient,
                                   pf_winding_contour_stats *contour, bool *contoured,
                                   pf_error *err);

/* ---- adaptive octree (harmonic paper sec. 7, fig. 4) --------------------------------------------
 * An octree over the bounding cube of a surface (the cube of the bounding box's longest side,
 * centred on the box): the root has depth 0, a cell of depth k has edge size / 2^k. Every cell is
 * refined to min_depth; beyond, a cell is refined while the surface comes within 4e-10 of the
 * model's size (4 times the cutting tolerance) of its closed box (triangle-box separating-axis
 * test), down to depth, so the cells the
 * surface crosses all have depth `depth` and the others are as coarse as min_depth allows; no 2:1
 * balance. The elements are the leaves inside: leaves whose centre is inside the surface, or with
 * slice, the exact solid part of every surface leaf (one element per connected piece, cut as in
 * pf_mesh_slice, sliver merging included) and the leaves wholly inside.
 *
 * Conformity at face level without hanging nodes: where a cell's face meets several smaller
 * leaves, it is split into exactly their faces (coplanar), and every face lists every mesh node
 * lying on its edges, so a large cell becomes a polyhedron with extra nodes and no node lies
 * inside an edge of a face it is not a vertex of. Nodes are shared exactly: lattice points of the
 * finest level are computed by one formula, origin + i * (size / 2^depth). */
#define PF_OCTREE_MAX_DEPTH 12

typedef struct pf_octree_params {
    int32_t depth;     /* depth of the surface cells, 1 .. PF_OCTREE_MAX_DEPTH (default 5: 32
                          finest cells along the bounding cube, pf-slice's default grid) */
    int32_t min_depth; /* every leaf at least this deep, 0 .. depth (default 2) */
    bool slice;        /* cut the surface cells exactly (closed surfaces only) */
    double merge;      /* with slice: merge pieces below merge * (finest cell volume), [0, 1)
                          (default 0.05, as pf_mesh_slice) */
    bool robust;       /* with slice: as pf_slice_params.robust, the lattice over the finest
                          cells (default true) */
    int32_t contour_refine; /* as pf_slice_params (default 2) */
    pf_progress_fn progress; /* NULL: none; else called with the fraction of the root cube's
                                volume whose leaves are built (total 1) */
    void *progress_ctx;
} pf_octree_params;

pf_octree_params pf_octree_params_default(void);

typedef struct pf_octree_stats {
    pf_vec3 origin;          /* lowest corner of the root cube */
    double size;             /* root cube edge (model units) */
    double h;                /* finest cell edge, size / 2^depth */
    int32_t leaves;          /* octree leaves, inside or not */
    int32_t surface_leaves;  /* leaves the surface comes near (all at full depth) */
    int32_t cells_by_depth[PF_OCTREE_MAX_DEPTH + 1]; /* whole-cell elements per depth (before
                                                        sliver merging) */
    int32_t split_faces;     /* cell faces split into several neighbour faces */
    pf_inside_method method; /* centre test without slice (rays: closed, winding: open) */
    int64_t splits;          /* plane splits (slice) */
    int32_t pieces;          /* elements before merging (slice) */
    int32_t merged;          /* slivers merged into a neighbour (slice) */
    int32_t isolated_slivers; /* pieces below the threshold touching no other piece (kept) */
    int32_t kinds[PF_ELEM_KIND_COUNT];
    double seconds;
    bool robust_used, contoured;       /* as pf_slice_stats */
    pf_surface_fix_report orient;
    pf_winding_contour_stats contour;
} pf_octree_stats;

/* Builds the octree mesh of s into m (derived; m is overwritten). params may be NULL for the
 * defaults, stats may be NULL. Without slice, s may be open (winding-number centre test); with
 * slice a surface that is not closed, manifold and outward is, in the robust mode, replaced as in
 * pf_mesh_slice (over the same bounding cube) and otherwise refused (PF_ERR_INVALID, saying what
 * is wrong).
 * Statuses: PF_ERR_INVALID for parameters out of range, a surface without triangles or with a
 * non-finite coordinate, or no leaf inside; PF_ERR_NUMERIC when the geometry is too degenerate
 * for a consistent cut at the model's tolerance (1e-10 of its size); PF_ERR_TOO_LARGE when the
 * mesh would exceed the 32-bit counts; PF_ERR_NOMEM. */
pf_status pf_mesh_octree(pf_mesh *m, const pf_surface *s, const pf_octree_params *params,
                         pf_octree_stats *stats, pf_error *err);

/* Summary statistics, as printed by pf-info. */
typedef struct pf_mesh_stats {
    int32_t n_nodes, n_faces, n_elems, n_boundary_faces;
    int32_t n_by_kind[PF_ELEM_KIND_COUNT];
    double volume, min_volume, max_volume; /* exact, from the element moments */
    pf_vec3 lo, hi;                        /* bounding box */
} pf_mesh_stats;

pf_status pf_mesh_compute_stats(const pf_mesh *m, pf_mesh_stats *out, pf_error *err);

/* Stable text view: counts, then every node, face and element, one per line, %.17g numbers.
 * Golden tests diff it. */
void pf_mesh_print(const pf_mesh *m, FILE *out);

/* ---- embedding weights ------------------------------------------------------------------------
 * The WGHT chunk: a CSR matrix (surface vertex x sim node): the displaced position of
 * surface vertex i is x_i + sum_k val[k] u[col[k]], k in [row_offsets[i], row_offsets[i+1]). */
typedef struct pf_weights {
    uint64_t surface_id;  /* the SURF the rows refer to */
    uint64_t mesh_id;     /* the MESH the columns refer to */
    int32_t rows;         /* surface vertices */
    int32_t cols;         /* sim nodes */
    int64_t *row_offsets; /* [rows + 1], row_offsets[0] = 0, non-decreasing */
    uint32_t *col;        /* [row_offsets[rows]] node indices < cols */
    double *val;          /* [row_offsets[rows]] weights (dimensionless) */
} pf_weights;
/* Allocates the arrays (contents uninitialised except row_offsets[0] = 0); w zeroed or released.
 * PF_ERR_INVALID on negative counts, PF_ERR_NOMEM. */
pf_status pf_weights_alloc(pf_weights *w, int32_t rows, int32_t cols, int64_t nnz, pf_error *err);
void pf_weights_release(pf_weights *w);

/* out[3 i + c] = x0[3 i + c] + sum_k val[k] u[3 col[k] + c] for every row i: the embedded
 * surface's positions (x0 at rest, [3 rows]) for nodal displacements u [3 cols]. out may not alias
 * x0 or u. */
void pf_weights_apply(const pf_weights *w, const double *x0, const double *u, double *out);
/* out[i] = sum_k val[k] v[col[k]]: a nodal scalar field (v [cols]) at the surface vertices. */
void pf_weights_apply_scalar(const pf_weights *w, const double *v, double *out);

/* ---- boundary ----------------------------------------------------------------------------------
 * The faces of a mesh used by exactly one element, each triangulated in its own plane (a fan for
 * convex faces, ear clipping for non-convex ones), oriented outward from their element. Depends
 * only on the topology and the rest positions: compute once per MESH. */
typedef struct pf_boundary {
    int32_t n_faces;      /* boundary faces */
    int32_t *face;        /* [n_faces] mesh face index */
    int32_t *elem;        /* [n_faces] the element using it */
    uint8_t *reversed;    /* [n_faces] 1 when that element uses the face reversed */
    int64_t *tri_offsets; /* [n_faces + 1] triangles of boundary face i: [tri_offsets[i], ..+1) */
    uint8_t *tri_edges;   /* [tri_offsets[n_faces]] bit k set: the edge from corner k to corner
                             k+1 (mod 3) of the triangle is an edge of the polygon */
    uint32_t *tri;        /* [3 tri_offsets[n_faces]] mesh node indices, counter-clockwise seen
                             from outside the element */
} pf_boundary;

/* Extracts the boundary of m (no derived arrays needed). Faces used by more than two elements are
 * not boundary. Statuses: PF_ERR_INVALID when an index is out of range (naming the element or
 * face), PF_ERR_NOMEM. b zeroed or released; zero again after a failure. */
pf_status pf_boundary_extract(const pf_mesh *m, pf_boundary *b, pf_error *err);
void pf_boundary_release(pf_boundary *b);

#ifdef __cplusplus
}
#endif
#endif
