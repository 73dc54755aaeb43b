/* pf_mesh_cut: elements split by planes, then the material separated across the cut (pf/cut.h).
 *
 * Four passes on a working copy of the mesh:
 *   1. split: pf_mesh_refine with one plane request per element (the exact split; its sliver rule
 *      leaves an element whole when a piece would be too small: the snap);
 *   2. sides: every element of the cut (a piece, or a requested element left whole) lies on the
 *      side of its volume centroid; a face between two of them on opposite sides is opened: its
 *      first user keeps it, the second gets a reversed copy;
 *   3. nodes: a node of an opened face is duplicated once per connected group of the elements
 *      around it (connected through interior faces that contain the node), so the two sides no
 *      longer share it; where the cut ends (the crack front) the elements around a node stay
 *      connected through the uncut neighbour and the node stays shared;
 *   4. bodies: connected groups of elements; a new body smaller than the sliver rule is dropped.
 * The output is then compacted (dropped elements, their faces and nodes) and derived. */
#include <pf/cut.h>
#include <pf/refine.h>

#include "mesh_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct cutter {
    const pf_mesh *src;
    double min_fraction;
    double floor; /* smallest piece and new body: min_fraction of src's median element volume */
    double tol;   /* on-plane tolerance: 1e-10 of the mesh's bounding-box diagonal */
    pf_mesh mid;  /* the split mesh */
    pf_refine_result rr;
    int8_t *side;     /* [mid elems] 0: not in the cut; -1, +1 */
    int32_t *snapped; /* [mid elems] the request of an element its plane left whole, else -1 */
    const pf_cut_request *req;
    /* the working mesh: mid's faces then the opened faces' copies */
    int32_t n_faces;
    int64_t *foff;
    uint32_t *fnodes;
    int32_t *fuser;     /* [2 n_faces] users as in face_elems, after opening */
    uint8_t *fflag;     /* [n_faces] FLAG_* */
    uint32_t *efaces;   /* [mid elem_offsets[n]] entries, the second users of opened faces moved */
    int32_t n_nodes;    /* mid's nodes and the copies */
    int32_t *node_orig; /* [n_nodes] the mid node a node is a copy of (itself for mid's) */
    double *x;
    uint8_t *echanged; /* [mid elems] */
    int32_t *body;     /* [mid elems] union-find of bodies */
    uint8_t *dropped;  /* [mid elems] */
} cutter;

enum { FLAG_OPENED = 1, FLAG_RENUMBERED = 2, FLAG_OLD_CUT = 4 };

static void cutter_release(cutter *c)
{
    pf_mesh_release(&c->mid);
    pf_refine_result_release(&c->rr);
    void *a[] = {c->side, c->foff,      c->fnodes, c->fuser,    c->fflag,  c->efaces,
                 c->x,    c->node_orig, c->body,   c->echanged, c->dropped, c->snapped};
    for (size_t i = 0; i < sizeof a / sizeof *a; ++i)
        pf_free(a[i]);
    memset(c, 0, sizeof *c);
}

/* ---- 1. the split ---------------------------------------------------------------------------- */

/* c->floor = min_fraction times src's median element volume. */
static pf_status find_floor(cutter *c, pf_error *err)
{
    int32_t ne = c->src->n_elems;
    double *vol = pf_alloc_array((size_t)ne + 1, sizeof *vol);
    PF_CHECK(vol, err, PF_ERR_NOMEM, "cut: cannot allocate %d volumes", (int)ne);
    for (int32_t e = 0; e < ne; ++e)
        vol[e] = pf_mesh_elem_volume(c->src, e);
    c->floor = c->min_fraction * pf_median(vol, ne);
    pf_free(vol);
    return PF_OK;
}

static pf_status split(cutter *c, const pf_cut_request *req, int32_t n_req, pf_error *err)
{
    pf_refine_request *rq = pf_alloc_array((size_t)n_req + 1, sizeof *rq);
    PF_CHECK(rq, err, PF_ERR_NOMEM, "cut: cannot allocate %d requests", (int)n_req);
    pf_status st = PF_OK;
    for (int32_t r = 0; r < n_req && st >= 0; ++r) {
        pf_plane pl = req[r].plane;
        double len = pf_v3_norm(pl.n);
        if (!(isfinite(len) && len > 0 && isfinite(pl.d)))
            st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                              "cut: request %d (element %d): the plane is not finite or has a "
                              "zero normal",
                              (int)r, (int)req[r].elem);
        rq[r] = (pf_refine_request){.elem = req[r].elem,
                                    .kind = PF_SPLIT_PLANE,
                                    .normal = pl.n,
                                    .point = pf_v3_scale(pl.n, pl.d / (len * len)),
                                    .min_fraction = c->min_fraction,
                                    .min_volume = c->floor};
    }
    if (st >= 0)
        st = pf_mesh_refine(c->src, rq, n_req, &c->mid, &c->rr, err);
    pf_free(rq);
    if (st < 0)
        pf_error_prefix(err, "cut");
    return st;
}

/* ---- 2. sides and opened faces --------------------------------------------------------------- */

/* The volume centroid of element e of m (fan tetrahedra from its first node; exact for planar
 * faces). */
static pf_vec3 elem_centroid(const pf_mesh *m, int32_t e)
{
    uint32_t o = m->face_nodes[m->face_offsets[PF_FACE_INDEX(m->elem_faces[m->elem_offsets[e]])]];
    pf_vec3 p0 = pf_v3_load(m->x + 3 * (size_t)o), sum = pf_v3(0, 0, 0);
    double vol = 0;
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        bool rev = (m->elem_faces[q] & PF_FACE_REVERSED) != 0;
        const uint32_t *v = m->face_nodes + m->face_offsets[f];
        int64_t n = m->face_offsets[f + 1] - m->face_offsets[f];
        pf_vec3 a = pf_v3_load(m->x + 3 * (size_t)v[0]);
        for (int64_t k = 1; k + 1 < n; ++k) {
            pf_vec3 b = pf_v3_load(m->x + 3 * (size_t)v[rev ? n - k : k]);
            pf_vec3 d = pf_v3_load(m->x + 3 * (size_t)v[rev ? n - k - 1 : k + 1]);
            double t = pf_v3_dot(pf_v3_sub(a, p0), pf_v3_cross(pf_v3_sub(b, p0), pf_v3_sub(d, p0)));
            vol += t;
            sum = pf_v3_add(sum, pf_v3_scale(pf_v3_add(pf_v3_add(p0, a), pf_v3_add(b, d)), t));
        }
    }
    return vol != 0 ? pf_v3_scale(sum, 1.0 / (4 * vol)) : p0;
}

static pf_status find_sides(cutter *c, const pf_cut_request *req, int32_t n_req, pf_error *err)
{
    const pf_mesh *m = &c->mid;
    int32_t *req_of = pf_alloc_array((size_t)c->src->n_elems + 1, sizeof *req_of);
    c->side = pf_calloc((size_t)m->n_elems + 1, sizeof *c->side);
    c->snapped = pf_alloc_array((size_t)m->n_elems + 1, sizeof *c->snapped);
    PF_CHECK(req_of && c->side && c->snapped, err, PF_ERR_NOMEM, "cut: cannot allocate %d sides",
             (int)m->n_elems);
    c->req = req;
    for (int32_t e = 0; e < c->src->n_elems; ++e)
        req_of[e] = -1;
    for (int32_t r = 0; r < n_req; ++r)
        req_of[req[r].elem] = r;
    for (int32_t e = 0; e < m->n_elems; ++e) {
        int32_t r = req_of[c->rr.parent[e]], p = c->rr.parent[e];
        bool whole = (e == 0 || c->rr.parent[e - 1] != p) &&
                     (e + 1 == m->n_elems || c->rr.parent[e + 1] != p);
        c->snapped[e] = r >= 0 && whole ? r : -1;
        if (r >= 0)
            c->side[e] = pf_plane_signed_distance(req[r].plane, elem_centroid(m, e)) < 0 ? -1 : 1;
    }
    pf_free(req_of);
    return PF_OK;
}

/* Whether element e of m lies wholly on side `side` of the plane (its nodes there or within tol
 * of the plane). */
static bool wholly_on(const pf_mesh *m, int32_t e, pf_plane pl, int side, double tol)
{
    for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q) {
        int32_t f = PF_FACE_INDEX(m->elem_faces[q]);
        for (int64_t k = m->face_offsets[f]; k < m->face_offsets[f + 1]; ++k)
            if (side *
                    pf_plane_signed_distance(pl, pf_v3_load(m->x + 3 * (size_t)m->face_nodes[k])) <
                -tol)
                return false;
    }
    return true;
}

/* Whether the face between a and b opens: both in the cut on opposite sides; or one of them left
 * whole by the sliver rule (it reaches a little across its plane) and the other, not in the cut,
 * wholly on the far side of that plane: else the snapped element would bridge the crack there.
 * A neighbour straddling the plane is beyond the crack's front and stays attached. */
static bool opens(const cutter *c, int32_t a, int32_t b)
{
    if (a < 0 || b < 0)
        return false;
    if (c->side[a] && c->side[b])
        return c->side[a] != c->side[b];
    for (int k = 0; k < 2; ++k) {
        int32_t s = k ? b : a, o = k ? a : b;
        if (c->snapped[s] >= 0 && !c->side[o]) {
            pf_plane pl = c->req[c->snapped[s]].plane;
            double len = pf_v3_norm(pl.n);
            pl = (pf_plane){pf_v3_scale(pl.n, 1 / len), pl.d / len};
            return wholly_on(&c->mid, o, pl, -c->side[s], c->tol);
        }
    }
    return false;
}

/* The working copy of mid's faces with every opened face's second user moved to a reversed copy. */
static pf_status open_faces(cutter *c, const uint8_t *old_cut, pf_error *err)
{
    const pf_mesh *m = &c->mid;
    int32_t n_open = 0;
    int64_t open_nodes = 0;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
        if (opens(c, a, b))
            n_open++, open_nodes += m->face_offsets[f + 1] - m->face_offsets[f];
    }
    int32_t nf = m->n_faces + n_open;
    int64_t nfn = m->face_offsets[m->n_faces] + open_nodes, nef = m->elem_offsets[m->n_elems];
    c->foff = pf_alloc_array((size_t)nf + 1, sizeof *c->foff);
    c->fnodes = pf_alloc_array((size_t)nfn + 1, sizeof *c->fnodes);
    c->fuser = pf_alloc_array(2 * (size_t)nf + 1, sizeof *c->fuser);
    c->fflag = pf_calloc((size_t)nf + 1, 1);
    c->efaces = pf_alloc_array((size_t)nef + 1, sizeof *c->efaces);
    PF_CHECK(c->foff && c->fnodes && c->fuser && c->fflag && c->efaces, err, PF_ERR_NOMEM,
             "cut: cannot allocate %d faces", (int)nf);
    memcpy(c->foff, m->face_offsets, ((size_t)m->n_faces + 1) * sizeof *c->foff);
    memcpy(c->fnodes, m->face_nodes, (size_t)m->face_offsets[m->n_faces] * sizeof *c->fnodes);
    memcpy(c->fuser, m->face_elems, 2 * (size_t)m->n_faces * sizeof *c->fuser);
    memcpy(c->efaces, m->elem_faces, (size_t)nef * sizeof *c->efaces);
    for (int32_t f = 0; f < m->n_faces; ++f)
        c->fflag[f] = old_cut && old_cut[f] ? FLAG_OLD_CUT : 0;
    int32_t g = m->n_faces;
    for (int32_t f = 0; f < m->n_faces; ++f) {
        int32_t a = m->face_elems[2 * f], b = m->face_elems[2 * f + 1];
        if (!opens(c, a, b))
            continue;
        int64_t n = m->face_offsets[f + 1] - m->face_offsets[f], at = c->foff[g];
        for (int64_t k = 0; k < n; ++k) /* the copy runs the other way: b uses it as stored */
            c->fnodes[at + k] = m->face_nodes[m->face_offsets[f + 1] - 1 - k];
        c->foff[g + 1] = at + n;
        for (int64_t q = m->elem_offsets[b]; q < m->elem_offsets[b + 1]; ++q)
            if (PF_FACE_INDEX(c->efaces[q]) == (uint32_t)f)
                c->efaces[q] = (uint32_t)g;
        c->fuser[2 * f + 1] = -1;
        c->fuser[2 * g] = b;
        c->fuser[2 * g + 1] = -1;
        c->fflag[f] = c->fflag[g] = FLAG_OPENED;
        c->echanged[a] = c->echanged[b] = 1;
        g++;
    }
    c->n_faces = nf;
    return PF_OK;
}

/* ---- 3. duplicated nodes --------------------------------------------------------------------- */

/* Scratch of split_node, each [2 most + 2] for a node of at most `most` incident faces. */
typedef struct node_scratch {
    int32_t *elems, *uf, *copy;
} node_scratch;

/* Slot of element e in elems[n] (present by construction). */
static int32_t slot_of(const int32_t *elems, int32_t e)
{
    int32_t k = 0;
    while (elems[k] != e)
        ++k;
    return k;
}

/* Node v's incident faces are inc[0 .. n): their users are grouped through the interior ones;
 * every group but the one of the lowest element gets its own copy of v. */
static void split_node(cutter *c, uint32_t v, const int32_t *inc, int32_t n, node_scratch *ns)
{
    int32_t ne = 0, *elems = ns->elems, *uf = ns->uf;
    for (int32_t i = 0; i < n; ++i)
        for (int s = 0; s < 2; ++s) {
            int32_t e = c->fuser[2 * inc[i] + s], k = 0;
            while (e >= 0 && k < ne && elems[k] != e)
                ++k;
            if (e >= 0 && k == ne)
                elems[ne++] = e;
        }
    int32_t lowest = 0;
    for (int32_t k = 0; k < ne; ++k) {
        uf[k] = k, ns->copy[k] = -1;
        if (elems[k] < elems[lowest])
            lowest = k;
    }
    for (int32_t i = 0; i < n; ++i) {
        int32_t a = c->fuser[2 * inc[i]], b = c->fuser[2 * inc[i] + 1];
        if (a >= 0 && b >= 0)
            pf_uf_union(uf, slot_of(elems, a), slot_of(elems, b));
    }
    int32_t keep = pf_uf_find(uf, lowest);
    for (int32_t i = 0; i < n; ++i) {
        int32_t e = c->fuser[2 * inc[i]] >= 0 ? c->fuser[2 * inc[i]] : c->fuser[2 * inc[i] + 1];
        int32_t root = pf_uf_find(uf, slot_of(elems, e));
        if (root == keep)
            continue;
        if (ns->copy[root] < 0) {
            int32_t copy = c->n_nodes++;
            memcpy(c->x + 3 * (size_t)copy, c->x + 3 * (size_t)v, 3 * sizeof *c->x);
            c->node_orig[copy] = c->node_orig[v];
            ns->copy[root] = copy;
        }
        for (int64_t q = c->foff[inc[i]]; q < c->foff[inc[i] + 1]; ++q)
            if (c->fnodes[q] == v)
                c->fnodes[q] = (uint32_t)ns->copy[root];
        c->fflag[inc[i]] |= FLAG_RENUMBERED;
        for (int s = 0; s < 2; ++s)
            if (c->fuser[2 * inc[i] + s] >= 0)
                c->echanged[c->fuser[2 * inc[i] + s]] = 1;
    }
}

static pf_status duplicate_nodes(cutter *c, pf_error *err)
{
    int32_t nn = c->mid.n_nodes;
    uint8_t *cand = pf_calloc((size_t)nn + 1, 1);
    int64_t *start = pf_calloc((size_t)nn + 2, sizeof *start);
    PF_CHECK(cand && start, err, PF_ERR_NOMEM, "cut: cannot allocate %d node flags", (int)nn);
    for (int32_t f = 0; f < c->n_faces; ++f)
        for (int64_t q = c->foff[f]; (c->fflag[f] & FLAG_OPENED) && q < c->foff[f + 1]; ++q)
            cand[c->fnodes[q]] = 1;
    for (int32_t f = 0; f < c->n_faces; ++f)
        for (int64_t q = c->foff[f]; q < c->foff[f + 1]; ++q)
            start[c->fnodes[q] + 1] += cand[c->fnodes[q]];
    int64_t most = 0;
    for (int32_t v = 0; v < nn; ++v) {
        most = start[v + 1] > most ? start[v + 1] : most;
        start[v + 1] += start[v];
    }
    int64_t total = start[nn];
    int32_t *inc = pf_alloc_array((size_t)total + 1, sizeof *inc);
    int64_t *fill = pf_alloc_array((size_t)nn + 1, sizeof *fill);
    node_scratch ns = {pf_alloc_array(2 * (size_t)most + 2, sizeof(int32_t)),
                       pf_alloc_array(2 * (size_t)most + 2, sizeof(int32_t)),
                       pf_alloc_array(2 * (size_t)most + 2, sizeof(int32_t))};
    /* at most one copy per incidence */
    c->x = pf_alloc_array(3 * ((size_t)nn + (size_t)total) + 3, sizeof *c->x);
    c->node_orig = pf_alloc_array((size_t)nn + (size_t)total + 1, sizeof *c->node_orig);
    pf_status st = PF_OK;
    if (!inc || !fill || !ns.elems || !ns.uf || !ns.copy || !c->x || !c->node_orig)
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                          "cut: cannot allocate %lld node incidences", (long long)total);
    if (st >= 0) {
        memcpy(c->x, c->mid.x, 3 * (size_t)nn * sizeof *c->x);
        for (int32_t v = 0; v < nn; ++v)
            c->node_orig[v] = v, fill[v] = start[v];
        c->n_nodes = nn;
        for (int32_t f = 0; f < c->n_faces; ++f)
            for (int64_t q = c->foff[f]; q < c->foff[f + 1]; ++q)
                if (cand[c->fnodes[q]])
                    inc[fill[c->fnodes[q]]++] = f;
        for (int32_t v = 0; v < nn; ++v)
            if (cand[v])
                split_node(c, (uint32_t)v, inc + start[v], (int32_t)(start[v + 1] - start[v]), &ns);
    }
    pf_free(cand);
    pf_free(start);
    pf_free(inc);
    pf_free(fill);
    pf_free(ns.elems);
    pf_free(ns.uf);
    pf_free(ns.copy);
    return st;
}

/* ---- 4. bodies ------------------------------------------------------------------------------- */

/* Bodies through interior faces; a body with an element of this cut (a new body) below the
 * floor is dropped. */
static pf_status find_bodies(cutter *c, pf_cut_result *res, pf_error *err)
{
    int32_t ne = c->mid.n_elems;
    double *vol = pf_alloc_array(2 * (size_t)ne + 1, sizeof *vol), *sum = vol + ne;
    c->body = pf_alloc_array((size_t)ne + 1, sizeof *c->body);
    c->dropped = pf_calloc((size_t)ne + 1, 1);
    uint8_t *is_new = pf_calloc((size_t)ne + 1, 1);
    pf_status st = PF_OK;
    if (!vol || !c->body || !c->dropped || !is_new)
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cut: cannot allocate %d bodies",
                          (int)ne);
    for (int32_t e = 0; e < ne && st >= 0; ++e)
        c->body[e] = e, vol[e] = pf_mesh_elem_volume(&c->mid, e);
    for (int32_t f = 0; f < c->n_faces && st >= 0; ++f)
        if (c->fuser[2 * f] >= 0 && c->fuser[2 * f + 1] >= 0)
            pf_uf_union(c->body, c->fuser[2 * f], c->fuser[2 * f + 1]);
    if (st >= 0 && ne > 0) {
        for (int32_t e = 0; e < ne; ++e) { /* body volumes gathered at the roots (in sum) */
            int32_t r = pf_uf_find(c->body, e);
            sum[e] = 0;
            is_new[r] |= c->side[e] != 0;
        }
        for (int32_t e = 0; e < ne; ++e)
            sum[c->body[e]] += vol[e];
        for (int32_t e = 0; e < ne; ++e) {
            int32_t r = c->body[e];
            c->dropped[e] = is_new[r] && sum[r] < c->floor;
            if (c->dropped[e])
                res->n_dropped++, res->dropped_volume += vol[e];
            res->n_bodies += r == e && !c->dropped[e];
        }
    }
    pf_free(vol);
    pf_free(is_new);
    return st;
}

/* ---- the output ------------------------------------------------------------------------------ */

/* dst's face group "cut" (dimension 2) holds exactly the cut faces: made when missing. */
static pf_status set_cut_group(pf_mesh *dst, const uint8_t *cut_face, pf_error *err)
{
    const pf_mesh_group *found = pf_mesh_find_group(dst, 2, "cut", 0);
    int32_t number = found ? found->number : 0;
    if (!found) {
        int32_t n = dst->n_groups, top = 0;
        pf_mesh_group *g = pf_realloc_array(dst->groups, (size_t)n + 1, sizeof *g);
        PF_CHECK(g, err, PF_ERR_NOMEM, "cut: cannot add the group of cut faces");
        dst->groups = g;
        if (!dst->elem_group) {
            dst->elem_group = pf_calloc((size_t)dst->n_elems + 1, sizeof *dst->elem_group);
            dst->face_group = pf_calloc((size_t)dst->n_faces + 1, sizeof *dst->face_group);
            PF_CHECK(dst->elem_group && dst->face_group, err, PF_ERR_NOMEM,
                     "cut: cannot add the group of cut faces");
        }
        for (int32_t k = 0; k < n; ++k)
            if (g[k].dim == 2 && g[k].number > top)
                top = g[k].number;
        char *name = pf_alloc(4);
        PF_CHECK(name, err, PF_ERR_NOMEM, "cut: cannot add the group of cut faces");
        memcpy(name, "cut", 4);
        number = top + 1;
        g[n] = (pf_mesh_group){.number = number, .dim = 2, .name = name};
        dst->n_groups = n + 1;
    }
    for (int32_t f = 0; f < dst->n_faces; ++f)
        if (cut_face[f])
            dst->face_group[f] = number;
        else if (dst->face_group[f] == number)
            dst->face_group[f] = 0;
    return PF_OK;
}

typedef struct numbering {
    int32_t *face, *node, *elem; /* new index of each working face, node, mid element; -1 */
    int32_t n_faces, n_nodes, n_elems;
    int64_t n_face_nodes, n_elem_faces;
} numbering;

static pf_status number_output(const cutter *c, numbering *nb, pf_error *err)
{
    memset(nb, 0, sizeof *nb);
    nb->face = pf_alloc_array((size_t)c->n_faces + 1, sizeof *nb->face);
    nb->node = pf_alloc_array((size_t)c->n_nodes + 1, sizeof *nb->node);
    nb->elem = pf_alloc_array((size_t)c->mid.n_elems + 1, sizeof *nb->elem);
    PF_CHECK(nb->face && nb->node && nb->elem, err, PF_ERR_NOMEM,
             "cut: cannot allocate the numbering");
    for (int32_t v = 0; v < c->n_nodes; ++v)
        nb->node[v] = -1;
    for (int32_t e = 0; e < c->mid.n_elems; ++e) {
        nb->elem[e] = c->dropped[e] ? -1 : nb->n_elems++;
        if (!c->dropped[e])
            nb->n_elem_faces += c->mid.elem_offsets[e + 1] - c->mid.elem_offsets[e];
    }
    for (int32_t f = 0; f < c->n_faces; ++f) {
        int32_t e = c->fuser[2 * f] >= 0 ? c->fuser[2 * f] : c->fuser[2 * f + 1];
        nb->face[f] = e >= 0 && !c->dropped[e] ? nb->n_faces++ : -1;
        for (int64_t q = c->foff[f]; nb->face[f] >= 0 && q < c->foff[f + 1]; ++q)
            nb->node[c->fnodes[q]] = 0;
        if (nb->face[f] >= 0)
            nb->n_face_nodes += c->foff[f + 1] - c->foff[f];
    }
    for (int32_t v = 0; v < c->n_nodes; ++v)
        nb->node[v] = nb->node[v] == 0 ? nb->n_nodes++ : -1;
    return PF_OK;
}

static void numbering_release(numbering *nb)
{
    pf_free(nb->face);
    pf_free(nb->node);
    pf_free(nb->elem);
}

/* The mesh and the change's maps from the numbering. */
static pf_status write_output(const cutter *c, const numbering *nb, pf_mesh *dst,
                              pf_cut_result *res, pf_error *err)
{
    const pf_mesh *src = c->src, *m = &c->mid;
    PF_TRY(pf_mesh_alloc(dst, nb->n_nodes, nb->n_faces, nb->n_face_nodes, nb->n_elems,
                         nb->n_elem_faces, err));
    bool ok = PF_ALLOC_N(res->parent, nb->n_elems) && PF_ALLOC_N(res->changed, nb->n_elems) &&
              PF_ALLOC_N(res->face_src, nb->n_faces) && PF_ALLOC_N(res->node_map, src->n_nodes) &&
              PF_ALLOC_N(res->node_src, nb->n_nodes) && PF_ALLOC_N(res->cut_face, nb->n_faces) &&
              PF_ALLOC_N(res->opened, nb->n_faces) && PF_ALLOC_N(res->split, src->n_elems);
    PF_CHECK(ok, err, PF_ERR_NOMEM, "cut: cannot allocate the change's maps");
    dst->id = src->id + 1;
    for (int32_t v = 0; v < c->n_nodes; ++v)
        if (nb->node[v] >= 0) {
            memcpy(dst->x + 3 * (size_t)nb->node[v], c->x + 3 * (size_t)v, 3 * sizeof *dst->x);
            int32_t o = c->node_orig[v];
            res->node_src[nb->node[v]] = o < src->n_nodes ? o : -1;
        }
    for (int32_t i = 0; i < src->n_nodes; ++i)
        res->node_map[i] = nb->node[i];
    for (int32_t f = 0; f < c->n_faces; ++f) {
        int32_t g = nb->face[f];
        if (g < 0)
            continue;
        int64_t at = dst->face_offsets[g];
        for (int64_t q = c->foff[f]; q < c->foff[f + 1]; ++q)
            dst->face_nodes[at++] = (uint32_t)nb->node[c->fnodes[q]];
        dst->face_offsets[g + 1] = at;
        bool same = f < m->n_faces && !(c->fflag[f] & (FLAG_OPENED | FLAG_RENUMBERED));
        res->face_src[g] = same ? c->rr.face_src[f] : -1;
        res->cut_face[g] = (c->fflag[f] & (FLAG_OPENED | FLAG_OLD_CUT)) != 0;
        res->opened[g] = (c->fflag[f] & FLAG_OPENED) != 0;
        res->n_opened += (c->fflag[f] & FLAG_OPENED) && f < m->n_faces;
    }
    memset(res->split, 0, (size_t)src->n_elems);
    for (int32_t e = 0; e < m->n_elems; ++e) {
        int32_t p = c->rr.parent[e];
        res->split[p] = e > 0 && c->rr.parent[e - 1] == p ? 1 : res->split[p];
        int32_t d = nb->elem[e];
        if (d < 0)
            continue;
        int64_t at = dst->elem_offsets[d];
        for (int64_t q = m->elem_offsets[e]; q < m->elem_offsets[e + 1]; ++q)
            dst->elem_faces[at++] =
                (uint32_t)nb->face[PF_FACE_INDEX(c->efaces[q])] | (c->efaces[q] & PF_FACE_REVERSED);
        dst->elem_offsets[d + 1] = at;
        res->parent[d] = p;
        res->changed[d] = c->rr.changed[e] || c->echanged[e];
    }
    for (int32_t v = 0; v < c->n_nodes; ++v)
        res->n_duplicated += v >= m->n_nodes && nb->node[v] >= 0;
    for (int32_t e = 0; e < src->n_elems; ++e)
        res->n_split += res->split[e];
    PF_TRY(pf_mesh_derive(dst, err));
    PF_TRY(pf_mesh_carry_groups(dst, src, res->parent, NULL, res->face_src, err));
    return set_cut_group(dst, res->cut_face, err);
}

/* The faces of mid earlier cuts opened: params' flags or src's "cut" group, carried to mid. */
static pf_status old_cut_faces(const cutter *c, const pf_cut_params *params, uint8_t **out,
                               pf_error *err)
{
    *out = NULL;
    const pf_mesh *src = c->src;
    const pf_mesh_group *g = pf_mesh_find_group(src, 2, "cut", 0);
    if (!(params && params->src_cut_face) && !g)
        return PF_OK;
    int32_t *label = pf_calloc((size_t)src->n_faces + 1, sizeof *label);
    int32_t *carried = pf_calloc((size_t)c->mid.n_faces + 1, sizeof *carried);
    *out = pf_calloc((size_t)c->mid.n_faces + 1, 1);
    pf_status st = label && carried && *out ? PF_OK
                                            : pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__,
                                                           "cut: cannot allocate face labels");
    for (int32_t f = 0; f < src->n_faces && st >= 0; ++f)
        label[f] = params && params->src_cut_face ? params->src_cut_face[f] != 0
                                                  : src->face_group[f] == g->number;
    if (st >= 0)
        st = pf_mesh_carry_face_label(&c->mid, src, c->rr.parent, NULL, c->rr.face_src, label,
                                      carried, err);
    for (int32_t f = 0; f < c->mid.n_faces && st >= 0; ++f)
        (*out)[f] = carried[f] != 0;
    pf_free(label);
    pf_free(carried);
    return st;
}

static pf_status check_requests(const pf_mesh *src, const pf_cut_request *req, int32_t n_req,
                                pf_error *err)
{
    PF_CHECK(src->face_elems, err, PF_ERR_INVALID, "cut: the mesh is not derived");
    uint8_t *seen = pf_calloc((size_t)src->n_elems + 1, 1);
    PF_CHECK(seen, err, PF_ERR_NOMEM, "cut: out of memory");
    pf_status st = PF_OK;
    for (int32_t r = 0; r < n_req && st >= 0; ++r) {
        int32_t e = req[r].elem;
        if (e < 0 || e >= src->n_elems || seen[e])
            st = pf_error_set(err, PF_ERR_INVALID, __FILE__, __LINE__,
                              "cut: request %d names element %d %s", (int)r, (int)e,
                              e < 0 || e >= src->n_elems ? "out of range" : "a second time");
        else
            seen[e] = 1;
    }
    pf_free(seen);
    return st;
}

pf_status pf_mesh_cut(const pf_mesh *src, const pf_cut_request *req, int32_t n_req,
                      const pf_cut_params *params, pf_mesh *dst, pf_cut_result *res, pf_error *err)
{
    PF_CHECK(src && dst && res && n_req >= 0 && (req || n_req == 0), err, PF_ERR_INVALID,
             "cut: NULL argument or negative request count");
    memset(dst, 0, sizeof *dst);
    memset(res, 0, sizeof *res);
    cutter c = {.src = src};
    pf_vec3 lo, hi;
    pf_mesh_bounds(src, &lo, &hi);
    c.tol = 1e-10 * pf_v3_dist(lo, hi);
    c.min_fraction =
        params && params->min_fraction > 0 ? params->min_fraction : PF_REFINE_MIN_FRACTION;
    uint8_t *old_cut = NULL;
    numbering nb = {0};
    pf_status st = check_requests(src, req, n_req, err);
    if (st >= 0)
        st = find_floor(&c, err);
    if (st >= 0)
        st = split(&c, req, n_req, err);
    if (st >= 0)
        st = old_cut_faces(&c, params, &old_cut, err);
    if (st >= 0 && !(c.echanged = pf_calloc((size_t)c.mid.n_elems + 1, 1)))
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "cut: out of memory");
    if (st >= 0)
        st = find_sides(&c, req, n_req, err);
    if (st >= 0)
        st = open_faces(&c, old_cut, err);
    if (st >= 0)
        st = duplicate_nodes(&c, err);
    if (st >= 0)
        st = find_bodies(&c, res, err);
    if (st >= 0)
        st = number_output(&c, &nb, err);
    if (st >= 0)
        st = write_output(&c, &nb, dst, res, err);
    if (st >= 0)
        res->n_snapped = n_req - res->n_split;
    numbering_release(&nb);
    pf_free(old_cut);
    cutter_release(&c);
    if (st < 0) {
        pf_mesh_release(dst);
        pf_cut_result_release(res);
    }
    return st;
}

void pf_cut_result_release(pf_cut_result *r)
{
    void *a[] = {r->parent,   r->split,    r->changed,  r->face_src,
                 r->node_map, r->node_src, r->cut_face, r->opened};
    for (size_t i = 0; i < sizeof a / sizeof *a; ++i)
        pf_free(a[i]);
    memset(r, 0, sizeof *r);
}
