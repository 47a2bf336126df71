/* mesh — writing: dispatch to the format's codec (mesh_codec.h), lossless
 * patching of the source bytes, output buffer.
 *
 * What a write produces:
 *
 * - Same format as the source, encoding SAME or equal to the source's: the
 *   source bytes are copied and only the position and normal values whose
 *   current value differs from the one the file held are rewritten (a value
 *   equal to it, -0.0 for 0.0 too, keeps the file's text or bytes):
 *   text values as the shortest of %.15g/%.16g/%.17g that reads back exactly,
 *   binary values in the file's own scalar type and byte order (integer types
 *   rounded and clamped, float32 rounded to nearest). An unchanged mesh is
 *   reproduced byte for byte.
 * - PLY to PLY in another encoding: every element and property of the source
 *   is kept and re-encoded (header copied, format line changed); positions
 *   and normals take their current values.
 * - STL to STL in another encoding: facets from the faces, the stored facet
 *   normals; binary STL stores float32 (positions rounded).
 * - Another format (or a mesh made by ffd_mesh_create): written from data.
 *   Positions (17 significant digits in text, double in PLY), faces, and
 *   per-vertex normals when the source had them (PLY nx/ny/nz, NOFF) as OBJ
 *   vn (f v//n) or PLY nx/ny/nz. Texture coordinates, colours, groups,
 *   materials, OBJ vn not tied to one vertex, STL facet normals and extra PLY
 *   elements are not carried across formats. STL output triangulates each
 *   polygon as a fan from its first corner, with facet normals computed from
 *   the written triangle (unit length, 0 0 0 for a zero-area one).
 * - Encodings: FFD_ENCODING_SAME means the source encoding when the format is
 *   the same, else ascii (the first encoding of a binary-only codec: NPY little-endian). OBJ and OFF are ascii only (binary is
 *   FFD_ERR_UNSUPPORTED); STL has ascii and binary (BINARY_LE; BINARY_BE is
 *   FFD_ERR_UNSUPPORTED); PLY has all three.
 */
#include "mesh_codec.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* ======================================================================
 * Output buffer
 * ====================================================================== */

void ffd_buf_put(ffd_buf *b, const void *p, size_t n)
{
    if (b->oom || n == 0)
        return;
    if (b->size + n < b->size || !ffd_grow((void **)&b->data, &b->cap, b->size + n + 1, 1)) {
        b->oom = true;
        return;
    }
    memcpy(b->data + b->size, p, n);
    b->size += n;
}

void ffd_buf_puts(ffd_buf *b, const char *s)
{
    ffd_buf_put(b, s, strlen(s));
}

void ffd_buf_printf(ffd_buf *b, const char *fmt, ...)
{
    char tmp[256];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n < 0) {
        b->oom = true;
        return;
    }
    if ((size_t)n < sizeof tmp) {
        ffd_buf_put(b, tmp, (size_t)n);
        return;
    }
    char *big = ffd_malloc((size_t)n + 1);
    if (!big) {
        b->oom = true;
        return;
    }
    va_start(ap, fmt);
    vsnprintf(big, (size_t)n + 1, fmt, ap);
    va_end(ap);
    ffd_buf_put(b, big, (size_t)n);
    ffd_free(big);
}

void ffd_buf_double(ffd_buf *b, double v)
{
    char tmp[32];
    int n = ffd_format_double(tmp, v);
    ffd_buf_put(b, tmp, (size_t)n);
}

void ffd_buf_vec3_line(ffd_buf *b, const char *prefix, const double p[3])
{
    ffd_buf_puts(b, prefix);
    ffd_buf_double(b, p[0]);
    ffd_buf_puts(b, " ");
    ffd_buf_double(b, p[1]);
    ffd_buf_puts(b, " ");
    ffd_buf_double(b, p[2]);
    ffd_buf_puts(b, "\n");
}

int ffd_format_int(char *buf, int64_t v)
{
    char t[24];
    int n = 0;
    uint64_t u = v < 0 ? 0 - (uint64_t)v : (uint64_t)v;
    do {
        t[n++] = (char)('0' + u % 10);
        u /= 10;
    } while (u);
    int k = 0;
    if (v < 0)
        buf[k++] = '-';
    while (n)
        buf[k++] = t[--n];
    buf[k] = '\0';
    return k;
}

void ffd_buf_uint(ffd_buf *b, uint64_t v)
{
    char t[24];
    int n = 0;
    do {
        t[n++] = (char)('0' + v % 10);
        v /= 10;
    } while (v);
    char d[24];
    for (int i = 0; i < n; i++)
        d[i] = t[n - 1 - i];
    ffd_buf_put(b, d, (size_t)n);
}

void ffd_buf_xyz(ffd_buf *b, const double *v)
{
    for (int d = 0; d < 3; d++) {
        ffd_buf_puts(b, " ");
        ffd_buf_double(b, v[d]);
    }
}

void ffd_buf_free(ffd_buf *b)
{
    ffd_free(b->data);
    b->data = NULL;
    b->size = b->cap = 0;
}

/* ======================================================================
 * Patching the source
 * ====================================================================== */

/* Next changed value at or after *i in (values, spans, n); returns its index or n.
 * A value equal to the one its span holds (==, so -0.0 and +0.0 are the same
 * value) is not changed: its bytes are copied as the file wrote them. */
static size_t next_changed(const ffd_mesh *m, const double *values, const ffd_span *spans,
                           size_t n, size_t i)
{
    for (; i < n; i++)
        if (values[i] != ffd_span_value(m, &spans[i]))
            return i;
    return n;
}

ffd_status ffd_mesh_patch_spans(const ffd_mesh *m, ffd_buf *b, ffd_error *err)
{
    size_t np = 3 * m->vertex_count, nn = m->normal_spans ? 3 * m->normal_count : 0;
    bool be = m->encoding == FFD_ENCODING_BINARY_BE;
    size_t ip = next_changed(m, m->positions, m->position_spans, np, 0);
    size_t in = next_changed(m, m->normals, m->normal_spans, nn, 0);
    if (m->encoding != FFD_ENCODING_ASCII) {
        for (size_t i = ip; i < np; i = next_changed(m, m->positions, m->position_spans, np, i + 1))
            if (!ffd_scalar_fits(m->position_spans[i].kind, m->positions[i]))
                return ffd_fail(err, FFD_ERR_RANGE,
                                "vertex %zu: coordinate %g does not fit the file's binary type", i / 3,
                                m->positions[i]);
        ffd_buf_put(b, m->src, m->src_size);
        if (b->oom)
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing %zu bytes", m->src_size);
        for (; ip < np; ip = next_changed(m, m->positions, m->position_spans, np, ip + 1))
            ffd_write_scalar(b->data + m->position_spans[ip].offset, m->position_spans[ip].kind,
                             be, m->positions[ip]);
        for (; in < nn; in = next_changed(m, m->normals, m->normal_spans, nn, in + 1))
            ffd_write_scalar(b->data + m->normal_spans[in].offset, m->normal_spans[in].kind, be,
                             m->normals[in]);
        return FFD_OK;
    }
    /* Text: both span lists are in file order; merge them. */
    size_t pos = 0;
    while (ip < np || in < nn) {
        const ffd_span *s;
        double v;
        if (in >= nn || (ip < np && m->position_spans[ip].offset < m->normal_spans[in].offset)) {
            s = &m->position_spans[ip];
            v = m->positions[ip];
            ip = next_changed(m, m->positions, m->position_spans, np, ip + 1);
        } else {
            s = &m->normal_spans[in];
            v = m->normals[in];
            in = next_changed(m, m->normals, m->normal_spans, nn, in + 1);
        }
        ffd_buf_put(b, m->src + pos, s->offset - pos);
        ffd_buf_double(b, v);
        pos = s->offset + ffd_span_length(m, s);
    }
    ffd_buf_put(b, m->src + pos, m->src_size - pos);
    if (b->oom)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing the mesh");
    return FFD_OK;
}

/* ======================================================================
 * Dispatch
 * ====================================================================== */

ffd_status ffd_mesh_write_memory(const ffd_mesh *mesh, const ffd_write_options *options,
                                 unsigned char **data, size_t *size, ffd_error *err)
{
    if (!data || !size)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_write_memory: data or size is NULL");
    *data = NULL;
    *size = 0;
    if (!mesh)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_write_memory: mesh is NULL");
    ffd_format format = options ? options->format : FFD_FORMAT_AUTO;
    ffd_encoding enc = options ? options->encoding : FFD_ENCODING_SAME;
    const ffd_mesh_codec *codec = ffd_mesh_codec_find(format);
    if (!codec) {
        char list[FFD_MESH_CODEC_LIST_SIZE];
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_write_memory: options->format must be %s",
                        ffd_mesh_codec_list(true, list, sizeof list));
    }
    if (enc < FFD_ENCODING_SAME || enc > FFD_ENCODING_RAW)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_write_memory: unknown encoding %d",
                        (int)enc);
    bool same_format = mesh->src && mesh->format == format;
    if (enc == FFD_ENCODING_SAME) {
        enc = same_format ? mesh->encoding : FFD_ENCODING_ASCII;
        /* a binary-only format (NPY) defaults to its first encoding */
        while (!(codec->encodings & FFD_CODEC_ENCODING(enc)) && enc < FFD_ENCODING_RAW)
            enc++;
    }
    if (!(codec->encodings & FFD_CODEC_ENCODING(enc))) {
        unsigned binary =
            FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_LE) | FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_BE);
        if (!(codec->encodings & binary) && enc <= FFD_ENCODING_BINARY_BE)
            return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s has no binary encoding", codec->name);
        static const char *const names[] = {"same", "ascii", "little-endian binary",
                                            "big-endian binary", "base64", "raw appended"};
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s has no %s encoding", codec->name,
                        names[enc]);
    }
    if (options && options->compress > 0 && !codec->write_options)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s has no compressed encoding (only VTU)",
                        codec->name);

    ffd_buf b = {0};
    ffd_status s;
    ffd_progress progress;
    ffd_progress_begin(&progress, "writing");
    if (codec->write_options) {
        ffd_write_options o = options ? *options : (ffd_write_options){0};
        o.format = format;
        o.encoding = enc;
        s = codec->write_options(mesh, &o, &b, err);
    } else if (same_format && enc == mesh->encoding)
        s = codec->patch(mesh, &b, err);
    else if (same_format && codec->transcode)
        s = codec->transcode(mesh, enc, &b, err);
    else
        s = codec->write(mesh, enc, &b, err);
    if (s == FFD_OK && b.oom)
        s = ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing the mesh");
    if (s != FFD_OK) {
        ffd_buf_free(&b);
        return s;
    }
    if (!b.data) { /* an empty output still gets a buffer the caller can free */
        b.data = ffd_malloc(1);
        if (!b.data)
            return ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
        b.data[0] = 0;
    }
    ffd_progress_end(&progress);
    *data = b.data;
    *size = b.size;
    return FFD_OK;
}

ffd_status ffd_mesh_write(const ffd_mesh *mesh, const char *path,
                          const ffd_write_options *options, ffd_error *err)
{
    if (!path)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_write: path is NULL");
    ffd_write_options opt = options ? *options : (ffd_write_options){0};
    if (opt.format == FFD_FORMAT_AUTO) {
        opt.format = ffd_format_from_path(path);
        if (opt.format == FFD_FORMAT_AUTO) {
            char list[FFD_MESH_CODEC_LIST_SIZE];
            return ffd_fail(err, FFD_ERR_INVALID, "%s: unknown mesh file extension (expected %s)",
                            path, ffd_mesh_codec_list(false, list, sizeof list));
        }
    }
    const ffd_mesh_codec *codec = ffd_mesh_codec_find(opt.format);
    if (mesh && codec && codec->write_file && opt.encoding == FFD_ENCODING_SAME)
        return codec->write_file(mesh, path, err);
    unsigned char *data;
    size_t size;
    ffd_error inner = {{0}};
    ffd_status s = ffd_mesh_write_memory(mesh, &opt, &data, &size, &inner);
    if (s != FFD_OK)
        return ffd_fail(err, s, "%s: %s", path, inner.message);
    s = ffd_write_file_atomic(path, data, size, err);
    ffd_free(data);
    return s;
}
