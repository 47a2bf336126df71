/* rig — writing a PB-FFD rig that holds an explicit control set: the output
 * of `ffd pbffd place`, meant to be edited by hand and replayed. One control
 * per line, numbers with 17 significant digits (they read back exactly). */
#include "rig/rig.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static void vec3(char *buf, size_t cap, size_t *len, const double v[3])
{
    *len += (size_t)snprintf(buf + *len, cap - *len, "[%.17g, %.17g, %.17g]", v[0], v[1], v[2]);
}

ffd_status ffd_rig_write_pbffd_controls(const char *path, const ffd_ebf *controls, size_t count,
                                        const ffd_pbffd_options *options, ffd_error *err)
{
    if (!path || (!controls && count))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_rig_write_pbffd_controls: NULL argument");
    for (size_t i = 0; i < count; i++) {
        const ffd_ebf *c = &controls[i];
        const double *v[3] = {c->center, c->radius, &c->frame[0][0]};
        size_t len[3] = {3, 3, 9};
        for (int a = 0; a < 3; a++)
            for (size_t j = 0; j < len[a]; j++)
                if (!isfinite(v[a][j]))
                    return ffd_fail(err, FFD_ERR_NONFINITE, "%s: controls[%zu]: not finite", path,
                                    i);
    }
    /* one control: 15 numbers of at most 25 characters plus the punctuation */
    size_t cap = 256 + count * (15 * 26 + 128);
    if (count && cap / count < 15 * 26)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: too many controls", path);
    char *buf = ffd_malloc(cap);
    if (!buf)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
    size_t len = (size_t)snprintf(buf, cap, "{\n  \"version\": 1,\n  \"deformer\": \"pbffd\",\n");
    if (options && options->sigma > 0 && options->sigma != 3)
        len += (size_t)snprintf(buf + len, cap - len, "  \"sigma\": %.17g,\n", options->sigma);
    if (options && options->no_master)
        len += (size_t)snprintf(buf + len, cap - len, "  \"master\": false,\n");
    else if (options && (options->master_radius > 0 || options->master_weight > 0))
        len += (size_t)snprintf(buf + len, cap - len,
                                "  \"master\": {\"radius\": %.17g, \"weight\": %.17g},\n",
                                options->master_radius > 0 ? options->master_radius : 2.0,
                                options->master_weight > 0 ? options->master_weight : 1.0);
    if (options && options->levels > 1)
        len += (size_t)snprintf(buf + len, cap - len, "  \"levels\": %u,\n", options->levels);
    len += (size_t)snprintf(buf + len, cap - len, "  \"controls\": [");
    for (size_t i = 0; i < count; i++) {
        const ffd_ebf *c = &controls[i];
        len += (size_t)snprintf(buf + len, cap - len, "%s\n    {\"center\": ", i ? "," : "");
        vec3(buf, cap, &len, c->center);
        len += (size_t)snprintf(buf + len, cap - len, ", \"radius\": ");
        vec3(buf, cap, &len, c->radius);
        len += (size_t)snprintf(buf + len, cap - len, ", \"frame\": [");
        for (int a = 0; a < 3; a++) {
            if (a)
                len += (size_t)snprintf(buf + len, cap - len, ", ");
            vec3(buf, cap, &len, c->frame[a]);
        }
        len += (size_t)snprintf(buf + len, cap - len, "]%s}", c->disabled ? ", \"enabled\": false"
                                                                          : "");
    }
    len += (size_t)snprintf(buf + len, cap - len, "\n  ],\n  \"moves\": []\n}\n");
    ffd_status s = ffd_write_file_atomic(path, buf, len, err);
    ffd_free(buf);
    return s;
}
