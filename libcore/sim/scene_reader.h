/* The strict JSON reader of scenes (scene_reader.c), shared by the parts of the scene that are
 * read in their own files (scene.c, scene_cuts.c). Private to libcore/sim. */
#ifndef PF_SIM_SCENE_READER_H
#define PF_SIM_SCENE_READER_H

#include <pf/sim.h>

#include <cjson/cJSON.h>

#include "scene_values.h"

enum { PATH_MAX_CHARS = 256 };

/* Where the reader is: the file name and the key path ("fixed[1].plane.normal") for messages. */
typedef struct reader {
    const char *name;
    pf_error *err;
    char path[PATH_MAX_CHARS];
    size_t len;
    bool corotation_seen; /* given at the top level or in method: only one of them */
} reader;

/* Key path bookkeeping: push a key or an index (returns the mark to pop back to). */
size_t pf_scene_push_key(reader *r, const char *key);
size_t pf_scene_push_index(reader *r, int i);
void pf_scene_pop(reader *r, size_t mark);
/* "name: path: reason" as PF_ERR_INVALID. */
pf_status pf_scene_fail(reader *r, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* A short description of a JSON value for "got ..." in messages. */
void pf_scene_describe(const cJSON *v, char buf[64]);
/* "must be EXPECTED, got <what v is>". */
pf_status pf_scene_fail_type(reader *r, const cJSON *v, const char *expected);
/* v must be an object whose keys are all in keys (NULL-terminated), none twice. */
pf_status pf_scene_begin_object(reader *r, const cJSON *v, const char *const *keys);
pf_status pf_scene_read_number(reader *r, const cJSON *v, scene_range rg, double *out);
pf_status pf_scene_read_int(reader *r, const cJSON *v, scene_range rg, int32_t *out);
pf_status pf_scene_read_bool(reader *r, const cJSON *v, bool *out);
pf_status pf_scene_read_vec3(reader *r, const cJSON *v, pf_vec3 *out);
/* A direction: non-zero, returned as a unit vector. */
pf_status pf_scene_read_normal(reader *r, const cJSON *v, pf_vec3 *out);
/* A path of keyframes [{"time", "translation"}, ...] (at least one, times strictly increasing)
 * into *n_keys and the arrays (pf_alloc; the caller frees them, also after a failure). */
pf_status pf_scene_read_path(reader *r, const cJSON *v, int32_t *n_keys, double **key_time,
                            pf_vec3 **key_translation);
/* The scene's "cuts" (scene_cuts.c): read into s (replacing any), released. */
pf_status pf_scene_read_cuts(reader *r, const cJSON *v, pf_scene *s);
void pf_scene_release_cuts(pf_scene *s);

/* The shortest of %.15g / %.17g that reads back as v. */
void pf_scene_format_number(double v, char buf[32]);

/* Reads the key of object item v with the given reader function, path pushed around it. */
#define READ_KEY(r, it, call)                                                                      \
    do {                                                                                           \
        size_t mark_ = pf_scene_push_key((r), (it)->string);                                                \
        PF_TRY(call);                                                                              \
        pf_scene_pop((r), mark_);                                                                           \
    } while (0)

#endif
