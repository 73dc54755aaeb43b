/* The polygon soup every surface reader fills, and what turns it into a pf_surface.
 *
 * A reader appends positions (double) and polygons (indices into those positions, already checked
 * in range); pf_surface_soup_finish triangulates, joins identical positions, drops degenerate
 * triangles and unused vertices. Shared by pf's own readers (OBJ, OFF, PLY, STL) and the assimp
 * path, so every format gets the same joining rules. */
#ifndef PF_IO_SURFACE_SOUP_H
#define PF_IO_SURFACE_SOUP_H

#include <stdint.h>

#include <pf/io.h>

/* Largest polygon a file may give: ear clipping is quadratic in the vertex count, and no surface
 * format in use writes faces anywhere near this. */
enum { SURFACE_POLYGON_MAX = 4096 };

typedef struct surface_soup {
    pf_buffer x;       /* double [3 n_verts] */
    pf_buffer offsets; /* int64_t [n_polys + 1], offsets[0] = 0 once the first polygon is added */
    pf_buffer nodes;   /* uint32_t [offsets[n_polys]] */
    int64_t n_verts, n_polys;
} surface_soup;

void pf_surface_soup_release(surface_soup *s);

/* Appends one position; the caller has checked it finite. */
pf_status pf_surface_soup_vertex(surface_soup *s, const double p[3], pf_error *err);

/* Appends one polygon of n <= SURFACE_POLYGON_MAX vertex indices, each < s->n_verts (both checked
 * by the caller, so that its message can name the line or record). Polygons of fewer than 3 vertices (points, lines) are
 * dropped, as the assimp path drops them. */
pf_status pf_surface_soup_polygon(surface_soup *s, const uint32_t *idx, int64_t n, pf_error *err);

/* The soup as a surface (out zeroed first; s->id = 1): polygons triangulated (a fan when convex,
 * ear clipping in the polygon's plane otherwise), positions joined by exact equality, triangles
 * that lost a corner to the join dropped, unused vertices dropped. PF_ERR_FORMAT
 * "path: no triangles (...)" when nothing is left, PF_ERR_TOO_LARGE beyond INT32_MAX vertices or
 * triangles, PF_ERR_NOMEM. */
pf_status pf_surface_soup_finish(const surface_soup *s, const char *path, pf_surface *out,
                              pf_error *err);

/* pf's own readers: fill soup from the file at path; every message starts with "path:" and names
 * the line (text) or the byte offset / record (binary). Counts in headers are checked against the
 * bytes left before anything is allocated from them. */
pf_status pf_surface_read_obj(const char *path, surface_soup *soup, pf_error *err);
pf_status pf_surface_read_off(const char *path, surface_soup *soup, pf_error *err);
pf_status pf_surface_read_ply(const char *path, surface_soup *soup, pf_error *err);
pf_status pf_surface_read_stl(const char *path, surface_soup *soup, pf_error *err);

#endif
