/* Strict JSON syntax check with precise error positions, for the scene reader. Private to sim/. */
#ifndef PF_SIM_SCENE_JSON_H
#define PF_SIM_SCENE_JSON_H

#include <stddef.h>

#include <pf/base.h>

/* Checks that text[0, len) is exactly one JSON value (RFC 8259, nesting at most 1000 levels, no
 * "\u0000" in strings), after an optional UTF-8 byte-order mark; *start receives the offset of
 * the JSON text (3 after a mark, else 0). PF_ERR_FORMAT "name:LINE:COL: reason" otherwise: a NUL
 * byte, an empty text, or the first byte that cannot continue a valid document. */
pf_status pf_scene_json_check(const char *text, size_t len, const char *name, size_t *start,
                              pf_error *err);

/* PF_ERR_FORMAT "name:LINE:COL: what near '...'" for text[pos] (what NULL: "JSON syntax error");
 * LINE and COL are 1-based, COL counts UTF-8 characters; the excerpt is up to 20 bytes of the
 * rest of the line. */
pf_status pf_scene_json_error_at(const char *text, size_t len, size_t pos, const char *name,
                                 const char *what, pf_error *err);

/* Prints root (taking it: deleted) as indented JSON into *json (pf_alloc, NUL-terminated).
 * PF_ERR_NOMEM "cannot write WHAT as JSON", also for a NULL root. */
struct cJSON;
pf_status pf_sim_json_print(struct cJSON *root, const char *what, char **json, pf_error *err);

#endif
