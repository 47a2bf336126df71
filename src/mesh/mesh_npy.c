/* mesh_npy — a point set as a NumPy array file, .npy (mesh_codec.h,
 * docs/volume.md "Point sets").
 *
 * The NumPy format (numpy/lib/format.py; versions 1.0, 2.0 and 3.0): the
 * magic "\x93NUMPY", a major and a minor version byte, the header length
 * (uint16 little-endian in 1.0, uint32 in 2.0 and 3.0), then the header, a
 * Python dict literal with the keys 'descr', 'fortran_order' and 'shape',
 * and the array's bytes. A point set is a float array of shape (N, 3):
 * descr '<f8', '>f8', '<f4' or '>f4' (m->encoding BINARY_LE or BINARY_BE);
 * fortran_order True is read too (column-major: all x, then all y, then all
 * z). Every coordinate is a binary span, so a deformed file differs from
 * its source only in the bytes of the coordinates that moved. Refused,
 * naming what was found: another dtype (integers, complex, native '='
 * order, structured), another shape, object arrays, data bytes missing or
 * left over. Written from data: '<f8' (BINARY_LE, the default) or '>f8'
 * (BINARY_BE), shape (N, 3), C order, version 1.0 (2.0 past 65535 header
 * bytes, which (N, 3) never needs).
 *
 * Hand-written: numpy's loaders keep no byte offsets, and the library has
 * no Python to call. */
#include "mesh_cells.h"
#include "mesh_codec.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define NPY_MAGIC "\x93NUMPY"
#define NPY_MAGIC_SIZE 6
#define NPY_ALIGN 64 /* numpy pads the header so the data starts at a multiple of 64 */

typedef struct {
    const char *p, *end;
} npy_scan;

static void skip_blanks(npy_scan *s)
{
    while (s->p < s->end && (*s->p == ' ' || *s->p == '\t' || *s->p == '\n' || *s->p == '\r'))
        s->p++;
}

static bool eat(npy_scan *s, char c)
{
    skip_blanks(s);
    if (s->p < s->end && *s->p == c) {
        s->p++;
        return true;
    }
    return false;
}

/* A quoted string ('...' or "..."): [*b, *e). */
static bool quoted(npy_scan *s, const char **b, const char **e)
{
    skip_blanks(s);
    if (s->p >= s->end || (*s->p != '\'' && *s->p != '"'))
        return false;
    char q = *s->p++;
    *b = s->p;
    while (s->p < s->end && *s->p != q)
        s->p++;
    if (s->p >= s->end)
        return false;
    *e = s->p++;
    return true;
}

static bool word(npy_scan *s, const char *w)
{
    skip_blanks(s);
    size_t n = strlen(w);
    if ((size_t)(s->end - s->p) >= n && memcmp(s->p, w, n) == 0) {
        s->p += n;
        return true;
    }
    return false;
}

static bool integer(npy_scan *s, uint64_t *v)
{
    skip_blanks(s);
    const char *q = s->p;
    uint64_t x = 0;
    while (s->p < s->end && *s->p >= '0' && *s->p <= '9') {
        if (x > (UINT64_MAX - 9) / 10)
            return false;
        x = x * 10 + (uint64_t)(*s->p - '0');
        s->p++;
    }
    if (s->p < s->end && *s->p == 'L') /* Python 2 longs */
        s->p++;
    *v = x;
    return s->p > q;
}

static ffd_status read_npy(ffd_mesh *m, const char *name, ffd_error *err)
{
    const unsigned char *u = m->src;
    size_t size = m->src_size;
    if (size < NPY_MAGIC_SIZE + 2 || memcmp(u, NPY_MAGIC, NPY_MAGIC_SIZE) != 0)
        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte 0: expected the NumPy magic \\x93NUMPY", name);
    unsigned major = u[6], minor = u[7];
    if (major < 1 || major > 3 || minor != 0)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "%s: byte 6: NumPy format version %u.%u (1.0, 2.0 and 3.0 are read)", name,
                        major, minor);
    size_t len_size = major == 1 ? 2 : 4;
    if (size < 8 + len_size)
        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte 8: expected the header length, found end of file",
                        name);
    uint64_t hlen = (uint64_t)u[8] | (uint64_t)u[9] << 8;
    if (len_size == 4)
        hlen |= (uint64_t)u[10] << 16 | (uint64_t)u[11] << 24;
    size_t hstart = 8 + len_size;
    if (hlen > size - hstart)
        return ffd_fail(err, FFD_ERR_PARSE,
                        "%s: byte 8: header length %llu exceeds the %zu bytes left in the file", name,
                        (unsigned long long)hlen, size - hstart);
    size_t data = hstart + (size_t)hlen;
    npy_scan s = {(const char *)u + hstart, (const char *)u + data};

    /* The header dict. */
    const char *descr = NULL, *descr_end = NULL;
    int fortran = -1;
    bool have_shape = false;
    uint64_t shape[4] = {0};
    size_t ndim = 0;
    if (!eat(&s, '{'))
        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: expected the header dict '{'", name,
                        (size_t)(s.p - (const char *)u));
    while (!eat(&s, '}')) {
        const char *kb, *ke;
        size_t at = (size_t)(s.p - (const char *)u);
        if (!quoted(&s, &kb, &ke) || !eat(&s, ':'))
            return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: expected a quoted key and ':' in the header",
                            name, at);
        size_t kl = (size_t)(ke - kb);
        at = (size_t)(s.p - (const char *)u);
        if (kl == 5 && memcmp(kb, "descr", 5) == 0) {
            if (!quoted(&s, &descr, &descr_end))
                return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                                "%s: byte %zu: 'descr' is not a simple type string (structured arrays are not point sets)",
                                name, at);
        } else if (kl == 13 && memcmp(kb, "fortran_order", 13) == 0) {
            if (word(&s, "True"))
                fortran = 1;
            else if (word(&s, "False"))
                fortran = 0;
            else
                return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: expected True or False for 'fortran_order'",
                                name, at);
        } else if (kl == 5 && memcmp(kb, "shape", 5) == 0) {
            if (!eat(&s, '('))
                return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: expected a tuple for 'shape'", name, at);
            while (!eat(&s, ')')) {
                uint64_t v;
                if (ndim >= 4 || !integer(&s, &v))
                    return ffd_fail(err, FFD_ERR_PARSE,
                                    "%s: byte %zu: expected a shape of non-negative integers", name, at);
                shape[ndim++] = v;
                if (!eat(&s, ',')) {
                    if (!eat(&s, ')'))
                        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: expected ',' or ')' in 'shape'",
                                        name, (size_t)(s.p - (const char *)u));
                    break;
                }
            }
            have_shape = true;
        } else
            return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: unknown header key '%.*s'", name, at,
                            (int)(kl > 20 ? 20 : kl), kb);
        if (!eat(&s, ',')) {
            if (!eat(&s, '}'))
                return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: expected ',' or '}' in the header",
                                name, (size_t)(s.p - (const char *)u));
            break;
        }
    }
    if (!descr || fortran < 0 || !have_shape)
        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: the header lacks '%s'", name, hstart,
                        !descr ? "descr" : fortran < 0 ? "fortran_order" : "shape");
    size_t dl = (size_t)(descr_end - descr);
    int kind;
    if (dl == 3 && (descr[0] == '<' || descr[0] == '>') && descr[1] == 'f' &&
        (descr[2] == '8' || descr[2] == '4')) {
        kind = descr[2] == '8' ? FFD_SPAN_F64 : FFD_SPAN_F32;
        m->encoding = descr[0] == '<' ? FFD_ENCODING_BINARY_LE : FFD_ENCODING_BINARY_BE;
    } else
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "%s: byte %zu: dtype '%.*s' is not a point set's ('<f8', '>f8', '<f4' or '>f4')",
                        name, hstart, (int)(dl > 20 ? 20 : dl), descr);
    if (ndim != 2 || shape[1] != 3) {
        char t[96];
        int n = snprintf(t, sizeof t, "(");
        for (size_t i = 0; i < ndim && n < 70; i++)
            n += snprintf(t + n, sizeof t - (size_t)n, "%s%llu", i ? ", " : "",
                          (unsigned long long)shape[i]);
        snprintf(t + n, sizeof t - (size_t)n, ndim == 1 ? ",)" : ")");
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: byte %zu: shape %s is not (N, 3)", name,
                        hstart, t);
    }
    uint64_t nv = shape[0];
    size_t vsize = ffd_span_kind_size(kind);
    size_t left = size - data;
    if (nv > left / (3 * vsize))
        return ffd_fail(err, FFD_ERR_PARSE,
                        "%s: byte %zu: shape (%llu, 3) needs more than the %zu data bytes the file has",
                        name, data, (unsigned long long)nv, left);
    if (nv * 3 * vsize != left)
        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: %zu bytes after the (%llu, 3) array",
                        name, data + (size_t)nv * 3 * vsize, left - (size_t)nv * 3 * vsize,
                        (unsigned long long)nv);
    if (nv > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_RANGE, "%s: byte %zu: %llu points, more than 4294967295",
                        name, hstart, (unsigned long long)nv);
    if (!ffd_mesh_reserve(m, (size_t)nv, 0, 0, 0))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %llu points", name,
                        (unsigned long long)nv);
    bool be = m->encoding == FFD_ENCODING_BINARY_BE;
    for (size_t i = 0; i < (size_t)nv; i++) {
        double v[3];
        ffd_span sp[3];
        for (int d = 0; d < 3; d++) {
            size_t k = fortran ? (size_t)d * (size_t)nv + i : 3 * i + (size_t)d;
            size_t off = data + k * vsize;
            v[d] = ffd_read_scalar(u + off, kind, be);
            if (!isfinite(v[d]))
                return ffd_fail(err, FFD_ERR_NONFINITE,
                                "%s: byte %zu: element [%zu, %d] (point %zu's %c, 0-based) is not finite",
                                name, off, i, d, i, "xyz"[d]);
            sp[d].offset = off;
            sp[d].kind = (uint64_t)kind;
        }
        if (!ffd_mesh_push_vertex(m, v, sp))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    }
    return FFD_OK;
}

/* (N, 3) float64 in C order, little- or big-endian by enc. */
static ffd_status write_npy(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    (void)err;
    bool be = enc == FFD_ENCODING_BINARY_BE;
    char dict[128];
    int n = snprintf(dict, sizeof dict, "{'descr': '%cf8', 'fortran_order': False, 'shape': (%zu, 3), }",
                     be ? '>' : '<', m->vertex_count);
    size_t hlen = (size_t)n + 1; /* and the closing '\n' */
    size_t total = NPY_MAGIC_SIZE + 2 + 2 + hlen;
    size_t pad = (NPY_ALIGN - total % NPY_ALIGN) % NPY_ALIGN;
    hlen += pad;
    unsigned char pre[10] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, (unsigned char)(hlen & 0xff),
                             (unsigned char)(hlen >> 8)};
    ffd_buf_put(b, pre, sizeof pre);
    ffd_buf_put(b, dict, (size_t)n);
    for (size_t i = 0; i < pad; i++)
        ffd_buf_puts(b, " ");
    ffd_buf_puts(b, "\n");
    unsigned char v[8];
    for (size_t i = 0; i < 3 * m->vertex_count; i++) {
        ffd_write_scalar(v, FFD_SPAN_F64, be, m->positions[i]);
        ffd_buf_put(b, v, 8);
    }
    return FFD_OK;
}

static const char *const npy_extensions[] = {"npy", NULL};

const ffd_mesh_codec ffd_mesh_codec_npy = {
    .format = FFD_FORMAT_NPY,
    .name = "NPY",
    .extensions = npy_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_LE) | FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_BE),
    .read = read_npy,
    .patch = ffd_mesh_patch_spans,
    .write = write_npy,
};
