/* libFuzzer target for pf's own surface readers (OBJ, OFF, PLY ASCII and binary, STL ASCII and
 * binary) through pf_import_surface. The first byte picks the extension, the rest is the file.
 * Properties:
 * - no crash, no undefined behaviour, no leak; no allocation beyond what the file can hold (a
 *   header's counts are checked against its size: ASan's allocation limit catches a bomb);
 * - a refused file says why, naming the file, and leaves the surface zeroed;
 * - an accepted surface has triangles, indices in range, finite coordinates, and every vertex
 *   used: its statistics compute. */
#define _POSIX_C_SOURCE 200809L /* mkdtemp (fuzz_files.h) */
#include <pf/io.h>
#include <pf/mesh.h>

#include "fuzz_files.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static const char TARGET[] = "fuzz_surface";

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0)
        return 0;
    static const char *NAMES[] = {"in.obj", "in.off", "in.ply", "in.stl"};
    int64_t live = pf_alloc_live_bytes();
    fuzz_dir d;
    fuzz_dir_open(&d, TARGET);
    const char *path = fuzz_dir_write(&d, NAMES[data[0] % 4], data + 1, size - 1, TARGET);
    pf_surface s = {0};
    pf_error err = {0};
    pf_surface_import_info how;
    pf_status st = pf_import_surface_ex(path, &s, &how, &err);
    if (st < 0) {
        fuzz_require(err.msg[0] != '\0' && strstr(err.msg, d.dir) != NULL, TARGET,
                     "a refused file says why and names the file");
        fuzz_require(s.x == NULL && s.tri == NULL && s.n_verts == 0 && s.n_tris == 0, TARGET,
                     "a refused file leaves the surface zeroed");
    } else {
        fuzz_require(!how.single_precision, TARGET, "pf's own readers keep doubles");
        fuzz_require(s.n_tris > 0 && s.n_verts >= 3, TARGET, "an accepted surface has triangles");
        pf_surface_stats stats;
        pf_error serr = {0};
        fuzz_require(pf_surface_compute_stats(&s, &stats, &serr) == PF_OK, TARGET,
                     "an accepted surface has indices in range and finite coordinates");
        char *used = calloc((size_t)s.n_verts, 1);
        fuzz_require(used != NULL, TARGET, "memory");
        for (size_t i = 0; i < 3 * (size_t)s.n_tris; ++i)
            used[s.tri[i]] = 1;
        for (int32_t v = 0; v < s.n_verts; ++v)
            fuzz_require(used[v], TARGET, "every vertex is used by a triangle");
        free(used);
    }
    pf_surface_release(&s);
    fuzz_dir_close(&d);
    fuzz_require(pf_alloc_live_bytes() == live, TARGET, "no pf memory left behind");
    return 0;
}
