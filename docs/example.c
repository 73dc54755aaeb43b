/* Prints the volume of the first mesh in a pf stream read from stdin (docs/library.md). */
#include <pf/io.h>
#include <pf/mesh.h>
#include <string.h>

int main(void) {
    pf_error err = {0};
    pf_stream_reader *r = NULL;
    pf_chunk c;
    bool end = false, found = false;
    pf_status s = pf_stream_reader_create(&r, stdin, "stdin", &err);
    while (s == PF_OK && !found && !(s = pf_stream_read_chunk(r, &c, &end, &err)) && !end) {
        if (strcmp(c.tag, "MESH") != 0) continue;
        pf_mesh m = {0};
        pf_mesh_stats st;
        found = true;
        if (!(s = pf_stream_decode_mesh(&c, &m, &err)) && !(s = pf_mesh_compute_stats(&m, &st, &err)))
            printf("%d elements, volume %.17g\n", st.n_elems, st.volume);
        pf_mesh_release(&m);
    }
    pf_stream_reader_destroy(&r);
    if (s == PF_OK && !found) s = pf_error_set(&err, PF_ERR_FORMAT, __FILE__, __LINE__, "stdin: no MESH");
    if (s != PF_OK) fprintf(stderr, "example: %s\n", err.msg);
    return s == PF_OK ? 0 : 1;
}
