/* fuzz_session — libFuzzer target for the editor's request handling: the
 * input is a script of up to 12 requests, one per line, "op body" (the op
 * name, a space, the JSON body), run against a fresh session on a small
 * mesh, as ffd serve runs POST /api/<op>. After every request the frame
 * must be finite and a failing request must leave the state unchanged. */
#include "ffd.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static ffd_mesh *mesh(void)
{
    static const double p[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                   {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    static const uint32_t idx[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                     1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7};
    uint32_t off[13];
    for (int f = 0; f <= 12; f++)
        off[f] = (uint32_t)(3 * f);
    ffd_mesh *m = NULL;
    ffd_mesh_create(&p[0][0], 8, off, idx, 12, &m, NULL);
    return m;
}

static char *state_without_timing(ffd_session *s)
{
    char *json = NULL;
    size_t size = 0;
    if (ffd_session_state(s, &json, &size, NULL) != FFD_OK)
        return NULL;
    char *t = strstr(json, ",\"busy_ms\"");
    if (t)
        *t = 0;
    return json;
}

static void check_frame(ffd_session *s)
{
    void *frame = NULL;
    size_t size = 0;
    if (ffd_session_frame(s, &frame, &size, NULL) != FFD_OK)
        return;
    const float *f = (const float *)((const char *)frame + 20);
    for (size_t i = 0; i < (size - 20) / 4; i++)
        if (!isfinite(f[i]))
            abort();
    ffd_free(frame);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ffd_mesh *m = mesh();
    ffd_session *s = NULL;
    ffd_session_options options = {.max_undo = 20, .max_controls = 4096}; /* small: each input stays fast */
    if (!m || ffd_session_create(m, "cube", &options, &s, NULL) != FFD_OK) {
        ffd_mesh_destroy(m);
        return 0;
    }
    const char *p = (const char *)data, *end = p + size;
    for (int line = 0; line < 12 && p < end; line++) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        const char *stop = nl ? nl : end;
        const char *sp = memchr(p, ' ', (size_t)(stop - p));
        size_t oplen = (size_t)((sp ? sp : stop) - p);
        char op[33];
        if (oplen > 32)
            oplen = 32;
        memcpy(op, p, oplen);
        op[oplen] = 0;
        const char *body = sp ? sp + 1 : stop;
        char *before = state_without_timing(s);
        void *reply = NULL;
        size_t reply_size = 0;
        int binary = 0;
        ffd_error err = {{0}};
        ffd_status st = ffd_session_command(s, op, body, (size_t)(stop - body), &reply,
                                            &reply_size, &binary, &err);
        ffd_free(reply);
        if (st != FFD_OK) {
            char *after = state_without_timing(s);
            if (!err.message[0] || (before && after && strcmp(before, after) != 0))
                abort(); /* a failing request changes nothing */
            ffd_free(after);
        }
        ffd_free(before);
        check_frame(s);
        p = nl ? nl + 1 : end;
    }
    ffd_session_destroy(s);
    return 0;
}
