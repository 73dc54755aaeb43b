/* Triangle surfaces through assimp's C API, then vertices joined by exact position.
 *
 * assimp's JoinIdenticalVertices joins only vertices equal in every attribute, so a cube whose
 * file gives each face its own normals comes out as six separate patches: open, and useless as
 * the boundary of a solid. Positions are therefore joined here, by exact equality of the
 * coordinates assimp returns (no tolerance: distinct but close vertices are the file's business).
 */
#include <pf/io.h>

#include <errno.h>
#include <stdbool.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <assimp/cimport.h>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

/* One vertex of the scene with its position, for sorting by position. */
typedef struct vertex_key {
    double p[3];
    int64_t index; /* in the concatenation of the scene's meshes */
} vertex_key;

static int compare_vertex_key(const void *pa, const void *pb)
{
    const vertex_key *a = pa, *b = pb;
    for (int c = 0; c < 3; ++c)
        if (a->p[c] != b->p[c])
            return a->p[c] < b->p[c] ? -1 : 1;
    return (a->index > b->index) - (a->index < b->index);
}

typedef struct scene_counts {
    size_t verts; /* all vertices of all meshes */
    size_t tris;  /* faces with 3 indices */
} scene_counts;

static const struct aiScene *read_scene(const char *path, pf_error *err)
{
    struct aiPropertyStore *props = aiCreatePropertyStore();
    if (!props) {
        pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "%s: out of memory", path);
        return NULL;
    }
    /* Degenerate triangles are removed rather than turned into lines and points, and points and
     * lines (from the file or from that) are dropped by the sort by primitive type. */
    aiSetImportPropertyInteger(props, AI_CONFIG_PP_FD_REMOVE, 1);
    aiSetImportPropertyInteger(props, AI_CONFIG_PP_SBP_REMOVE,
                               aiPrimitiveType_POINT | aiPrimitiveType_LINE);
    const unsigned flags = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                           aiProcess_PreTransformVertices | aiProcess_FindDegenerates |
                           aiProcess_SortByPType | aiProcess_ValidateDataStructure;
    const struct aiScene *scene = aiImportFileExWithProperties(path, flags, NULL, props);
    aiReleasePropertyStore(props);
    if (!scene)
        pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__, "%s: assimp cannot read it: %s", path,
                     aiGetErrorString());
    return scene;
}

/* Counts, and every position checked finite before any work. */
static pf_status count_scene(const char *path, const struct aiScene *scene, scene_counts *n,
                             pf_error *err)
{
    memset(n, 0, sizeof *n);
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const struct aiMesh *mesh = scene->mMeshes[m];
        for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
            const struct aiVector3D p = mesh->mVertices[v];
            PF_CHECK(isfinite(p.x) && isfinite(p.y) && isfinite(p.z), err, PF_ERR_FORMAT,
                     "%s: mesh %u, vertex %u has a non-finite coordinate", path, m, v);
        }
        n->verts += mesh->mNumVertices;
        for (unsigned f = 0; f < mesh->mNumFaces; ++f)
            n->tris += mesh->mFaces[f].mNumIndices == 3;
    }
    PF_CHECK(n->verts <= INT32_MAX && n->tris <= INT32_MAX, err, PF_ERR_TOO_LARGE,
             "%s: %zu vertices and %zu triangles: more than pf handles", path, n->verts, n->tris);
    PF_CHECK(n->tris > 0, err, PF_ERR_FORMAT, "%s: no triangles (%u meshes read by assimp)", path,
             scene->mNumMeshes);
    return PF_OK;
}

/* Equal coordinates (so -0 and +0 are one position; NaN was refused before). */
static bool same_position(const vertex_key *a, const vertex_key *b)
{
    return a->p[0] == b->p[0] && a->p[1] == b->p[1] && a->p[2] == b->p[2];
}

/* group[i]: the joined vertex of scene vertex i, numbered in the order of first occurrence. */
static void join_positions(vertex_key *keys, size_t n, int32_t *group, int32_t *n_groups)
{
    qsort(keys, n, sizeof *keys, compare_vertex_key);
    /* Sorted by position, then index: each run of equal positions starts with its smallest
     * index, which every vertex of the run points at. */
    for (size_t i = 0, run = 0; i < n; ++i) {
        if (!same_position(&keys[i], &keys[run]))
            run = i;
        group[keys[i].index] = (int32_t)keys[run].index;
    }
    int32_t count = 0;
    for (size_t i = 0; i < n; ++i)
        group[i] = group[i] == (int32_t)i ? count++ : group[group[i]];
    *n_groups = count;
}

static pf_status build_surface(const char *path, const struct aiScene *scene, const scene_counts *n,
                               pf_surface *s, pf_error *err)
{
    vertex_key *keys = pf_alloc_array(n->verts, sizeof *keys);
    int32_t *group = pf_alloc_array(n->verts, sizeof *group);
    uint32_t *tri = pf_alloc_array(3 * n->tris, sizeof *tri);
    int32_t *used = NULL;
    pf_status st = PF_OK;
    if (!keys || !group || !tri)
        st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "%s: out of memory", path);
    int32_t n_groups = 0, n_tris = 0, n_used = 0;
    if (st == PF_OK) {
        size_t k = 0;
        for (unsigned m = 0; m < scene->mNumMeshes; ++m)
            for (unsigned v = 0; v < scene->mMeshes[m]->mNumVertices; ++v, ++k) {
                const struct aiVector3D p = scene->mMeshes[m]->mVertices[v];
                keys[k] = (vertex_key){{p.x, p.y, p.z}, (int64_t)k};
            }
        join_positions(keys, n->verts, group, &n_groups);
        /* Triangles on joined vertices; those that lost a corner to the join are degenerate. */
        size_t base = 0;
        for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
            const struct aiMesh *mesh = scene->mMeshes[m];
            for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
                const struct aiFace *face = &mesh->mFaces[f];
                if (face->mNumIndices != 3)
                    continue;
                uint32_t c[3];
                for (int i = 0; i < 3; ++i)
                    c[i] = (uint32_t)group[base + face->mIndices[i]];
                if (c[0] == c[1] || c[1] == c[2] || c[2] == c[0])
                    continue;
                memcpy(tri + 3 * (size_t)n_tris++, c, sizeof c);
            }
            base += mesh->mNumVertices;
        }
        used = pf_alloc_array((size_t)n_groups, sizeof *used);
        if (n_tris == 0)
            st = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__,
                              "%s: no triangles (all degenerate)", path);
        else if (!used)
            st = pf_error_set(err, PF_ERR_NOMEM, __FILE__, __LINE__, "%s: out of memory", path);
    }
    if (st == PF_OK) {
        /* Vertices no triangle uses (points, dropped degenerates) are left out. */
        for (int32_t g = 0; g < n_groups; ++g)
            used[g] = -1;
        for (size_t i = 0; i < 3 * (size_t)n_tris; ++i)
            used[tri[i]] = 0;
        for (int32_t g = 0; g < n_groups; ++g)
            if (used[g] == 0)
                used[g] = n_used++;
        st = pf_surface_alloc(s, n_used, n_tris, err);
    }
    if (st == PF_OK) {
        s->id = 1;
        for (size_t i = 0; i < n->verts; ++i) {
            int32_t v = used[group[keys[i].index]];
            if (v >= 0)
                memcpy(s->x + 3 * (size_t)v, keys[i].p, sizeof keys[i].p);
        }
        for (size_t i = 0; i < 3 * (size_t)n_tris; ++i)
            s->tri[i] = (uint32_t)used[tri[i]];
    }
    pf_free(keys);
    pf_free(group);
    pf_free(tri);
    pf_free(used);
    return st;
}

pf_status pf_import_surface(const char *path, pf_surface *s, pf_error *err)
{
    memset(s, 0, sizeof *s);
    /* A missing file is an I/O error, not a format one: checked before assimp guesses. */
    FILE *f = fopen(path, "rb");
    PF_CHECK(f, err, PF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    fclose(f);
    const struct aiScene *scene = read_scene(path, err);
    if (!scene)
        return err ? err->status : PF_ERR_FORMAT;
    scene_counts n;
    pf_status st = count_scene(path, scene, &n, err);
    if (st == PF_OK)
        st = build_surface(path, scene, &n, s, err);
    aiReleaseImport(scene);
    if (st < 0)
        pf_surface_release(s);
    return st;
}
