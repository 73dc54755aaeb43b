/* libFuzzer target for the volume-mesh importers: Gmsh .msh (v2 and v4 ASCII) and TetGen
 * .node/.ele. The first byte picks the format; for TetGen the rest is split at the first line
 * "@@ele" into the .node and the .ele file. Properties:
 * - no crash, no undefined behaviour, no leak (pf's live-byte counter returns to where it was);
 * - a refused file says why, naming the file, and leaves the mesh zeroed;
 * - an accepted mesh has indices in range and finite coordinates: validation and statistics
 *   run on it without failing for those reasons (they may still find it invalid: importers do
 *   not promise valid elements). */
#define _POSIX_C_SOURCE 200809L /* mkdtemp (fuzz_files.h) */
#include <math.h>

#include <pf/io.h>
#include <pf/mesh.h>

#include "fuzz_files.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static const char TARGET[] = "fuzz_volume";

static int is_zero_mesh(const pf_mesh *m)
{
    return m->n_nodes == 0 && m->n_faces == 0 && m->n_elems == 0 && m->x == NULL &&
           m->face_offsets == NULL && m->elem_offsets == NULL;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size == 0)
        return 0;
    int64_t live = pf_alloc_live_bytes();
    fuzz_dir d;
    fuzz_dir_open(&d, TARGET);
    const uint8_t *body = data + 1;
    size_t n = size - 1;
    const char *path;
    pf_mesh m = {0};
    pf_error err = {0};
    pf_status st;
    if (data[0] % 2 == 0) {
        path = fuzz_dir_write(&d, "in.msh", body, n, TARGET);
        st = pf_import_msh(path, &m, &err);
    } else {
        static const char SEP[] = "@@ele\n";
        size_t cut = n;
        for (size_t i = 0; i + sizeof SEP - 1 <= n; ++i)
            if (memcmp(body + i, SEP, sizeof SEP - 1) == 0 && (i == 0 || body[i - 1] == '\n')) {
                cut = i;
                break;
            }
        size_t rest = cut < n ? cut + sizeof SEP - 1 : n;
        fuzz_dir_write(&d, "in.node", body, cut, TARGET);
        path = fuzz_dir_write(&d, "in.ele", body + rest, n - rest, TARGET);
        st = pf_import_tetgen(path, &m, &err);
    }
    if (st < 0) {
        fuzz_require(err.msg[0] != '\0' && strstr(err.msg, d.dir) != NULL, TARGET,
                     "a refused file says why and names the file");
        fuzz_require(is_zero_mesh(&m), TARGET, "a refused file leaves the mesh zeroed");
    } else {
        for (size_t i = 0; i < 3 * (size_t)m.n_nodes; ++i)
            fuzz_require(isfinite(m.x[i]), TARGET,
                         "accepted coordinates are finite");
        pf_error verr = {0};
        (void)pf_mesh_validate(&m, NULL, &verr);
        pf_mesh_stats stats;
        (void)pf_mesh_compute_stats(&m, &stats, &verr);
    }
    pf_mesh_release(&m);
    fuzz_dir_close(&d);
    fuzz_require(pf_alloc_live_bytes() == live, TARGET, "no pf memory left behind");
    return 0;
}
