/* session_weights — the editor's vertex-group weights (docs/editor.md,
 * "weights"; the rig's "weights" layer, docs/constraints.md): reading a
 * "weights" op's body, and the per-vertex weights as a binary reply. The
 * session (session.c, op_weights) applies them through the generic layers
 * (deformer/layers.c) with one undo step per brush stroke. */
#include "session/session.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const weights_keys[] = {"values", "vertices", "clear", "stroke", NULL};

/* A weight the editor paints: a finite number in [0, 1]. */
static ffd_status read_weight(const ffd_rig_parser *p, const cJSON *item, const char *path,
                              double *out)
{
    ffd_status st = ffd_rig_read_number(p, item, path, out);
    if (!st && !(*out >= 0.0 && *out <= 1.0))
        st = ffd_fail(p->err, FFD_ERR_RANGE, "%s: %s: the weight %g is outside [0, 1]", p->name,
                      path, *out);
    return st;
}

ffd_status ffd_sess_read_weights(const ffd_rig_parser *p, const cJSON *body, size_t n, double *w,
                                 int *clear, double *stroke)
{
    *clear = 0;
    *stroke = 0;
    ffd_status st = ffd_rig_check_keys(p, body, "body", weights_keys,
                                       "\"values\", \"vertices\", \"clear\" or \"stroke\"");
    if (st)
        return st;
    const cJSON *values = cJSON_GetObjectItemCaseSensitive(body, "values");
    const cJSON *vertices = cJSON_GetObjectItemCaseSensitive(body, "vertices");
    const cJSON *cl = cJSON_GetObjectItemCaseSensitive(body, "clear");
    const cJSON *sk = cJSON_GetObjectItemCaseSensitive(body, "stroke");
    if (!!values + !!vertices + !!cl != 1)
        return ffd_fail(p->err, FFD_ERR_PARSE,
                        "%s: body: expected one of \"values\" (every vertex's weight), "
                        "\"vertices\" ({\"vertex\": weight, ...}) or \"clear\"",
                        p->name);
    if (sk && (!cJSON_IsNumber(sk) || !(sk->valuedouble >= 1 && sk->valuedouble <= 9007199254740992.0) ||
               sk->valuedouble != floor(sk->valuedouble)))
        return ffd_rig_expected(p, "stroke", "a positive integer (the brush stroke's id)");
    *stroke = sk ? sk->valuedouble : 0;
    if (cl) {
        if (!cJSON_IsTrue(cl))
            return ffd_rig_expected(p, "clear", "true");
        *clear = 1;
        return FFD_OK;
    }
    char path[48];
    if (values) {
        if (!cJSON_IsArray(values))
            return ffd_rig_expected(p, "values", "an array of one weight per vertex");
        size_t count = (size_t)cJSON_GetArraySize(values);
        if (count != n)
            return ffd_fail(p->err, FFD_ERR_INVALID, "%s: values: %zu weights for %zu vertices",
                            p->name, count, n);
        size_t i = 0;
        const cJSON *v;
        cJSON_ArrayForEach(v, values)
        {
            snprintf(path, sizeof path, "values[%zu]", i);
            if ((st = read_weight(p, v, path, &w[i])))
                return st;
            i++;
        }
        return FFD_OK;
    }
    if (!cJSON_IsObject(vertices))
        return ffd_rig_expected(p, "vertices", "an object {\"vertex\": weight, ...}");
    /* the new weights go in only when every one is good: read into a copy */
    double *next = ffd_malloc_array(n ? n : 1, sizeof *next);
    unsigned char *seen = ffd_calloc(n ? n : 1, 1);
    if (!next || !seen) {
        ffd_free(next);
        ffd_free(seen);
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    }
    memcpy(next, w, n * sizeof *next);
    const cJSON *v;
    cJSON_ArrayForEach(v, vertices)
    {
        const char *key = v->string;
        char *end = NULL;
        unsigned long long id = strtoull(key, &end, 10);
        if (!*key || *end || key[0] < '0' || key[0] > '9' || (key[0] == '0' && key[1])) {
            st = ffd_fail(p->err, FFD_ERR_PARSE,
                          "%s: vertices: key '%.32s': expected a vertex index (a decimal integer)",
                          p->name, key);
            break;
        }
        if (id >= n) {
            st = ffd_fail(p->err, FFD_ERR_RANGE, "%s: vertices: vertex %llu out of range (%zu vertices)",
                          p->name, id, n);
            break;
        }
        if (seen[id]++) {
            st = ffd_fail(p->err, FFD_ERR_PARSE, "%s: vertices: vertex %llu given twice", p->name,
                          id);
            break;
        }
        snprintf(path, sizeof path, "vertices.%llu", id);
        if ((st = read_weight(p, v, path, &next[id])))
            break;
    }
    if (!st)
        memcpy(w, next, n * sizeof *w);
    ffd_free(next);
    ffd_free(seen);
    return st;
}

ffd_status ffd_sess_weights_reply(const double *w, size_t n, uint32_t revision, void **data,
                                  size_t *size, ffd_error *err)
{
    size_t bytes = 16 + 4 * n;
    unsigned char *buf = ffd_malloc(bytes);
    if (!buf)
        return ffd_fail(err, FFD_ERR_NOMEM, "weights: out of memory");
    uint32_t head[4] = {0, revision, (uint32_t)n, 0};
    memcpy(head, "FFDW", 4);
    memcpy(buf, head, 16);
    float *f = (float *)(void *)(buf + 16);
    for (size_t i = 0; i < n; i++)
        f[i] = (float)w[i];
    *data = buf;
    *size = bytes;
    return FFD_OK;
}
