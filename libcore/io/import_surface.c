/* Triangle surfaces from files: pf's own double-precision readers for OBJ, OFF, PLY and STL, and
 * assimp's C API for every other format.
 *
 * assimp keeps coordinates in float: a surface it reads is rounded to about 7 significant digits
 * (a sphere sliced from it loses 1.6e-8 of its volume), and its FindDegenerates step drops
 * triangles by an absolute area threshold and JoinIdenticalVertices joins within an absolute
 * distance, which together empty a valid surface scaled to 1e-12. The
 * formats users give most are therefore read here, exactly; the rest go through assimp with the
 * area test off, and the caller is told the coordinates came through single precision. Either way
 * the polygons end in one soup (surface_soup.c), joined and cleaned by the same rules.
 */
#include <pf/io.h>

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include <assimp/cimport.h>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "surface_soup.h"

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
    /* No absolute area threshold: a valid surface at any scale keeps its triangles (the exact
     * degenerate test of the join remains). */
    aiSetImportPropertyInteger(props, AI_CONFIG_PP_FD_CHECKAREA, 0);
    aiSetImportPropertyInteger(props, AI_CONFIG_PP_SBP_REMOVE,
                               aiPrimitiveType_POINT | aiPrimitiveType_LINE);
    /* No JoinIdenticalVertices: it joins within an absolute distance (1e-5), which collapses a
     * surface scaled small; the soup joins exactly equal positions instead. */
    const unsigned flags = aiProcess_Triangulate | aiProcess_PreTransformVertices |
                           aiProcess_FindDegenerates | aiProcess_SortByPType |
                           aiProcess_ValidateDataStructure;
    const struct aiScene *scene = aiImportFileExWithProperties(path, flags, NULL, props);
    aiReleasePropertyStore(props);
    if (!scene)
        pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__, "%s: assimp cannot read it: %s", path,
                     aiGetErrorString());
    return scene;
}

/* The triangles of every mesh of the scene into the soup; positions checked finite. */
static pf_status scene_to_soup(const char *path, const struct aiScene *scene, surface_soup *soup,
                               pf_error *err)
{
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const struct aiMesh *mesh = scene->mMeshes[m];
        const int64_t base = soup->n_verts;
        for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
            const struct aiVector3D p = mesh->mVertices[v];
            PF_CHECK(isfinite(p.x) && isfinite(p.y) && isfinite(p.z), err, PF_ERR_FORMAT,
                     "%s: mesh %u, vertex %u has a non-finite coordinate", path, m, v);
            const double x[3] = {p.x, p.y, p.z};
            PF_TRY(pf_surface_soup_vertex(soup, x, err));
        }
        for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
            const struct aiFace *face = &mesh->mFaces[f];
            if (face->mNumIndices != 3)
                continue; /* points and lines; polygons were triangulated by assimp */
            uint32_t c[3];
            for (int i = 0; i < 3; ++i) {
                PF_CHECK(face->mIndices[i] < mesh->mNumVertices, err, PF_ERR_FORMAT,
                         "%s: mesh %u, face %u refers to vertex %u of %u", path, m, f,
                         face->mIndices[i], mesh->mNumVertices);
                c[i] = (uint32_t)(base + face->mIndices[i]);
            }
            PF_TRY(pf_surface_soup_polygon(soup, c, 3, err));
        }
    }
    PF_CHECK(soup->n_polys > 0, err, PF_ERR_FORMAT, "%s: no triangles (%u meshes read by assimp)",
             path, scene->mNumMeshes);
    return PF_OK;
}

/* The up axis the file declares, as assimp reports it: FBX's UpAxis and UpAxisSign metadata
 * (assimp leaves the coordinates as the file has them); glTF is +y up by its specification, and
 * assimp turns every Collada file to +y whatever its <up_axis> says. Other formats say nothing:
 * +z, pf's own, with source NULL. */
static pf_up_axis scene_up_axis(const struct aiScene *scene, const char **source)
{
    *source = NULL;
    const struct aiMetadata *md = scene->mMetaData;
    int32_t axis = -1, sign = 1;
    const char *format = "";
    for (unsigned i = 0; md && i < md->mNumProperties; ++i) {
        const struct aiMetadataEntry *e = &md->mValues[i];
        const char *key = md->mKeys[i].data;
        if (e->mType == AI_INT32 && strcmp(key, "UpAxis") == 0)
            axis = *(const int32_t *)e->mData;
        else if (e->mType == AI_INT32 && strcmp(key, "UpAxisSign") == 0)
            sign = *(const int32_t *)e->mData;
        else if (e->mType == AI_AISTRING && strcmp(key, "SourceAsset_Format") == 0)
            format = ((const struct aiString *)e->mData)->data;
    }
    if (axis >= 0 && axis <= 2) {
        static const pf_up_axis pos[3] = {PF_UP_X, PF_UP_Y, PF_UP_Z};
        static const pf_up_axis neg[3] = {PF_UP_NEG_X, PF_UP_NEG_Y, PF_UP_NEG_Z};
        *source = "the file's UpAxis";
        return sign < 0 ? neg[axis] : pos[axis];
    }
    if (strstr(format, "glTF")) {
        *source = "glTF's convention";
        return PF_UP_Y;
    }
    if (strstr(format, "Collada")) {
        *source = "Collada as assimp turns it";
        return PF_UP_Y;
    }
    return PF_UP_Z;
}

static pf_status read_with_assimp(const char *path, surface_soup *soup,
                                  pf_surface_import_info *info, pf_error *err)
{
    const struct aiScene *scene = read_scene(path, err);
    if (!scene)
        return err ? err->status : PF_ERR_FORMAT;
    info->up = scene_up_axis(scene, &info->up_source);
    pf_status st = scene_to_soup(path, scene, soup, err);
    aiReleaseImport(scene);
    return st;
}

/* True when path ends in "." ext, case-insensitive. */
static bool has_extension(const char *path, const char *ext)
{
    const char *dot = strrchr(path, '.');
    if (!dot || strchr(dot, '/'))
        return false;
    ++dot;
    size_t n = strlen(ext);
    if (strlen(dot) != n)
        return false;
    for (size_t i = 0; i < n; ++i)
        if (tolower((unsigned char)dot[i]) != ext[i])
            return false;
    return true;
}

typedef pf_status (*surface_reader)(const char *path, surface_soup *soup, pf_error *err);

static const struct {
    const char *ext;
    surface_reader read;
} OWN_READERS[] = {{"obj", pf_surface_read_obj},
                   {"off", pf_surface_read_off},
                   {"ply", pf_surface_read_ply},
                   {"stl", pf_surface_read_stl}};

pf_status pf_import_surface_ex(const char *path, pf_surface *s, pf_surface_import_info *info,
                               pf_error *err)
{
    memset(s, 0, sizeof *s);
    pf_surface_import_info local;
    if (!info)
        info = &local;
    *info = (pf_surface_import_info){"assimp", true, PF_UP_Z, NULL};
    /* A missing file is an I/O error, not a format one: checked before any reader guesses. */
    FILE *f = fopen(path, "rb");
    PF_CHECK(f, err, PF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    fclose(f);
    surface_reader read = NULL;
    for (size_t i = 0; i < sizeof OWN_READERS / sizeof OWN_READERS[0]; ++i)
        if (has_extension(path, OWN_READERS[i].ext)) {
            read = OWN_READERS[i].read;
            *info = (pf_surface_import_info){OWN_READERS[i].ext, false, PF_UP_Z, NULL};
        }
    surface_soup soup = {0};
    pf_status st = read ? read(path, &soup, err) : read_with_assimp(path, &soup, info, err);
    if (st == PF_OK)
        st = pf_surface_soup_finish(&soup, path, s, err);
    pf_surface_soup_release(&soup);
    if (st < 0)
        pf_surface_release(s);
    return st;
}

pf_status pf_import_surface_fixed(const char *path, const pf_surface_fix_params *fix, pf_surface *s,
                                  pf_surface_import_info *info, pf_surface_fix_report *report,
                                  pf_error *err)
{
    pf_surface_import_info local;
    if (!info)
        info = &local;
    PF_TRY(pf_import_surface_ex(path, s, info, err));
    pf_surface_fix_params p = fix ? *fix : pf_surface_fix_params_default();
    if (p.up == PF_UP_AUTO)
        p.up = info->up;
    pf_status st = pf_surface_fix(s, &p, report, err);
    if (st < 0) {
        pf_error_prefix(err, "%s", path);
        pf_surface_release(s);
    }
    return st;
}

pf_status pf_import_surface(const char *path, pf_surface *s, pf_error *err)
{
    return pf_import_surface_ex(path, s, NULL, err);
}
