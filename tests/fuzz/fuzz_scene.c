/* libFuzzer target for scene files (pf_scene_parse). Properties:
 * - no crash, no undefined behaviour, no leak;
 * - a refused scene says why;
 * - an accepted scene written back (pf_scene_to_json) parses again, and so does what that
 *   writes: a stream's SCEN is always a valid scene. (Not yet a fixed point: directions are
 *   normalised again on every read, which moves their last bit; see corpus/scene/ground-normal.)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pf/sim.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void require(int ok, const char *what)
{
    if (!ok) {
        fprintf(stderr, "fuzz_scene: property violated: %s\n", what);
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    int64_t live = pf_alloc_live_bytes();
    pf_scene s;
    pf_error err = {0};
    pf_status st = pf_scene_parse(&s, (const char *)data, size, "fuzz.json", &err);
    if (st < 0) {
        require(err.msg[0] != '\0' && strstr(err.msg, "fuzz.json") != NULL,
                "a refused scene says why and names the file");
    } else {
        char *once = NULL, *twice = NULL;
        require(pf_scene_to_json(&s, &once, &err) == PF_OK, "an accepted scene is written");
        pf_scene again;
        pf_error err2 = {0};
        if (pf_scene_parse(&again, once, strlen(once), "again.json", &err2) != PF_OK) {
            fprintf(stderr, "fuzz_scene: %s\n%s\n", err2.msg, once);
            require(0, "a written scene parses");
        }
        require(pf_scene_to_json(&again, &twice, &err2) == PF_OK, "it is written again");
        pf_scene third;
        require(pf_scene_parse(&third, twice, strlen(twice), "third.json", &err2) == PF_OK,
                "a scene written twice parses");
        pf_scene_release(&third);
        pf_free(once);
        pf_free(twice);
        pf_scene_release(&again);
    }
    pf_scene_release(&s);
    require(pf_alloc_live_bytes() == live, "no pf memory left behind");
    return 0;
}
