/* Index list files: the nodes or elements a scene's region names by number ("nodes_file",
 * "elements_file" in docs/scene.md). Plain text, one index per line, '#' comments. */
#include <pf/io.h>

#include "text_reader.h"

pf_status pf_import_index_list(const char *path, int64_t count, const char *what,
                               int32_t **indices, int32_t *n, pf_error *err)
{
    *indices = NULL;
    *n = 0;
    text_reader r;
    PF_TRY(pf_text_reader_open(&r, path, '#', err));
    pf_buffer out = {0};
    pf_status st = PF_OK;
    while (st >= 0 && pf_text_reader_next_line(&r)) {
        int64_t k = 0;
        st = pf_text_reader_int(&r, &k, what, err);
        if (st >= 0 && (k < 0 || k >= count))
            st = TEXT_FAIL(&r, err, PF_ERR_INVALID,
                           "%s %lld out of range: the mesh has %lld %ss, numbered from 0", what,
                           (long long)k, (long long)count, what);
        if (st >= 0)
            st = pf_text_reader_expect_line_end(&r, what, err);
        if (st >= 0 && out.size / sizeof(int32_t) >= INT32_MAX)
            st = TEXT_FAIL(&r, err, PF_ERR_TOO_LARGE, "more than %d indices", INT32_MAX - 1);
        int32_t index = (int32_t)k; /* < count <= INT32_MAX when checked */
        if (st >= 0)
            st = pf_buffer_append(&out, &index, sizeof index, err);
    }
    if (st >= 0 && out.size == 0)
        st = pf_error_set(err, PF_ERR_FORMAT, __FILE__, __LINE__, "%s: no %s index in the file",
                          path, what);
    pf_text_reader_close(&r);
    if (st < 0) {
        pf_buffer_release(&out);
        return st;
    }
    *indices = (int32_t *)out.data;
    *n = (int32_t)(out.size / sizeof **indices);
    return PF_OK;
}
