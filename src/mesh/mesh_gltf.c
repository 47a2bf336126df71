/* mesh_gltf — glTF 2.0 (Khronos glTF 2.0 specification): `.gltf` (JSON,
 * buffers in external files next to it or in base64 `data:` URIs) and
 * `.glb` (12-byte header, JSON chunk, BIN chunk), told apart by the GLB
 * magic. Parsed with cJSON (Debian packages no C glTF library).
 *
 * Read: every primitive of every mesh instance of the default scene (all
 * root nodes when the file has no scene), in WORLD space: each node's
 * matrix or TRS composed down the hierarchy (spec 5.25 "Nodes"). Modes
 * TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN; indices UNSIGNED_BYTE/SHORT/
 * INT or none. POSITION must be FLOAT VEC3 with a bufferView; NORMAL, when
 * present, FLOAT VEC3 too (read as per-vertex normals in world space);
 * TANGENT, when present with NORMAL (spec 3.7.2 "Meshes": tangents are used
 * only with normals; without NORMAL they are kept as they are), FLOAT VEC4
 * with w = +-1 (read as per-vertex tangents, xyz in world space by the
 * node's linear part, renormalised). A POSITION accessor used by several
 * instances is one set of vertices when their world matrices are equal and
 * refused otherwise; primitives sharing it must share its NORMAL and
 * TANGENT accessors too.
 *
 * Write (same format and kind): the source bytes with only the moved
 * POSITION elements rewritten (the inverse world matrix back to the node's
 * local space, as float), their NORMAL elements (M^T n renormalised), their
 * TANGENT elements (M^-1 t renormalised, w kept; see ffd_mesh_set_positions
 * for how tangents follow the deformation) and the POSITION accessors'
 * min/max numbers patched in place in the JSON text
 * (spec: min/max are required for POSITION). Nothing else is re-serialised:
 * every node, material, skin, animation, extension, image and other buffer
 * byte is kept; an untouched mesh is written byte for byte. A .glb whose
 * JSON text changed length gets new chunk and file lengths (JSON padded
 * with spaces). Embedded buffers are re-encoded in place; external buffers
 * are written next to the output file (gltf_write_file), and in memory they
 * become data: URIs. Refused: sparse, Draco, meshopt, quantized data, point
 * and line primitives, and anything out of bounds. */
#include "mesh_codec.h"

#include <assert.h>
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* GLB container (spec 4.4 "Binary glTF Layout") */
#define GLB_MAGIC 0x46546C67u      /* "glTF" */
#define GLB_VERSION 2u
#define GLB_HEADER_SIZE 12u
#define GLB_CHUNK_HEADER_SIZE 8u
#define GLB_CHUNK_JSON 0x4E4F534Au /* "JSON" */
#define GLB_CHUNK_BIN 0x004E4942u  /* "BIN\0" */

/* accessor.componentType */
#define GL_UNSIGNED_BYTE 5121
#define GL_UNSIGNED_SHORT 5123
#define GL_UNSIGNED_INT 5125
#define GL_FLOAT 5126

/* primitive.mode */
#define MODE_POINTS 0
#define MODE_TRIANGLES 4
#define MODE_TRIANGLE_STRIP 5
#define MODE_TRIANGLE_FAN 6

#define VEC3_SIZE 12u     /* FLOAT VEC3 element */
#define VEC4_SIZE 16u     /* FLOAT VEC4 element (TANGENT) */
#define MAX_STRIDE 252u   /* bufferView.byteStride maximum */
#define DATA_URI_BASE64 "data:application/octet-stream;base64,"

enum { BUF_GLB, BUF_EXTERNAL, BUF_DATA_URI };

typedef struct gltf_buffer {
    unsigned char *data; /* owned copy, size bytes */
    size_t size;
    int where;           /* BUF_* */
    char *uri;           /* EXTERNAL: decoded relative path */
    char *path;          /* EXTERNAL: the file read */
    size_t text_off, text_len; /* DATA_URI/EXTERNAL: the uri string's characters in the JSON text */
    size_t glb_off;      /* GLB: offset of the BIN chunk data in src */
} gltf_buffer;

typedef struct gltf_elem {
    uint32_t buffer;
    size_t offset;
} gltf_elem;

/* A POSITION accessor: its vertices and its min/max numbers in the JSON text. */
typedef struct gltf_pos_accessor {
    size_t index, first, count;
    long long normal, tangent; /* the NORMAL and TANGENT accessors read with it; -1: none */
    uint32_t xform;
    bool has_minmax;
    size_t mm_off[6], mm_len[6]; /* min x y z, max x y z: offsets in the JSON text */
    double mm_val[6];
} gltf_pos_accessor;

typedef struct gltf_state {
    bool glb;
    size_t json_off, json_len; /* JSON text in src (GLB: the whole JSON chunk) */
    size_t glb_json_end;       /* GLB: end of the JSON chunk in src */
    gltf_buffer *buffers;
    size_t buffer_count;
    double *xforms; /* 16 per transform (column-major), then 16 for its inverse */
    size_t xform_count, xform_cap;
    gltf_elem *pos;  /* per vertex */
    uint32_t *vxform;
    double *orig_pos;  /* world positions as read */
    gltf_elem *nrm;    /* per normal */
    double *orig_nrm;
    gltf_elem *tan;   /* per tangent */
    double *orig_tan; /* 4 per tangent, world space as read */
    gltf_pos_accessor *acc;
    size_t acc_count, acc_cap;
    char *source_path; /* the .gltf read (for the external buffers' check) */
} gltf_state;

static void state_free(void *p)
{
    gltf_state *s = p;
    if (!s)
        return;
    for (size_t i = 0; i < s->buffer_count; i++) {
        ffd_free(s->buffers[i].data);
        ffd_free(s->buffers[i].uri);
        ffd_free(s->buffers[i].path);
    }
    ffd_free(s->buffers);
    ffd_free(s->xforms);
    ffd_free(s->pos);
    ffd_free(s->vxform);
    ffd_free(s->orig_pos);
    ffd_free(s->nrm);
    ffd_free(s->orig_nrm);
    ffd_free(s->tan);
    ffd_free(s->orig_tan);
    ffd_free(s->acc);
    ffd_free(s->source_path);
    ffd_free(s);
}

static uint32_t get_u32le(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static void put_u32le(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}
static float get_f32le(const unsigned char *p)
{
    uint32_t u = get_u32le(p);
    float f;
    memcpy(&f, &u, 4);
    return f;
}
static void put_f32le(unsigned char *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_u32le(p, u);
}

/* ======================================================================
 * Locating values in the JSON text (cJSON gives no offsets). The text was
 * accepted by cJSON, so it is valid JSON; these only walk it.
 * ====================================================================== */

static const char *js_ws(const char *p, const char *e)
{
    while (p < e && (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r'))
        p++;
    return p;
}

/* End of the value starting at p. */
static const char *js_skip(const char *p, const char *e)
{
    if (p >= e)
        return e;
    if (*p == '"') {
        for (p++; p < e && *p != '"'; p++)
            if (*p == '\\')
                p++;
        return p < e ? p + 1 : e;
    }
    if (*p == '{' || *p == '[') {
        size_t depth = 0;
        for (; p < e; p++) {
            if (*p == '"') {
                p = js_skip(p, e) - 1;
            } else if (*p == '{' || *p == '[') {
                depth++;
            } else if (*p == '}' || *p == ']') {
                if (--depth == 0)
                    return p + 1;
            }
        }
        return e;
    }
    while (p < e && !strchr(",]} \t\r\n", *p))
        p++;
    return p;
}

/* The value of the first member named key of the object at p, or NULL. */
static const char *js_member(const char *p, const char *e, const char *key)
{
    if (!p || p >= e || *p != '{')
        return NULL;
    size_t kl = strlen(key);
    p = js_ws(p + 1, e);
    while (p < e && *p == '"') {
        const char *ks = p + 1, *ke = js_skip(p, e) - 1;
        p = js_ws(ke + 1, e);
        if (p >= e || *p != ':')
            return NULL;
        p = js_ws(p + 1, e);
        if ((size_t)(ke - ks) == kl && memcmp(ks, key, kl) == 0)
            return p;
        p = js_ws(js_skip(p, e), e);
        if (p < e && *p == ',')
            p = js_ws(p + 1, e);
    }
    return NULL;
}

/* Element i of the array at p, or NULL. */
static const char *js_element(const char *p, const char *e, size_t i)
{
    if (!p || p >= e || *p != '[')
        return NULL;
    p = js_ws(p + 1, e);
    for (size_t k = 0; p < e && *p != ']'; k++) {
        if (k == i)
            return p;
        p = js_ws(js_skip(p, e), e);
        if (p < e && *p == ',')
            p = js_ws(p + 1, e);
    }
    return NULL;
}

/* ======================================================================
 * Reading
 * ====================================================================== */

typedef struct reader {
    ffd_mesh *m;
    gltf_state *s;
    const char *name;
    ffd_error *err;
    cJSON *root;
    const char *jt, *je; /* JSON text */
    cJSON *accessors, *views, *nodes, *meshes;
    unsigned char *visiting; /* per node: on the current path (cycle check) */
    uint32_t *acc_vertex;    /* per accessor: index into s->acc + 1, 0 when unused */
} reader;

static ffd_status nomem(reader *r)
{
    return ffd_fail(r->err, FFD_ERR_NOMEM, "%s: out of memory", r->name);
}

/* A non-negative integer member; -1 when absent; -2 when not an integer in [0, limit). */
static long long int_member(const cJSON *o, const char *key, long long limit)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!v)
        return -1;
    if (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble >= (double)limit ||
        v->valuedouble != floor(v->valuedouble))
        return -2;
    return (long long)v->valuedouble;
}

/* Refuses the file: status st (FFD_ERR_PARSE for malformed input,
 * FFD_ERR_UNSUPPORTED for valid glTF this codec cannot write back) with
 * the message prefixed by the file's name. */
static ffd_status refuse(reader *r, ffd_status st, const char *fmt, ...) FFD_PRINTF(3, 4);
static ffd_status refuse(reader *r, ffd_status st, const char *fmt, ...)
{
    char msg[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return ffd_fail(r->err, st, "%s: %s", r->name, msg);
}

static int b64_value(int c)
{
    if (c >= 'A' && c <= 'Z')
        return c - 'A';
    if (c >= 'a' && c <= 'z')
        return c - 'a' + 26;
    if (c >= '0' && c <= '9')
        return c - '0' + 52;
    if (c == '+')
        return 62;
    if (c == '/')
        return 63;
    return -1;
}

/* Decodes base64 text (padding optional); false at a character that is not base64. */
static bool b64_decode(const char *t, size_t n, unsigned char *out, size_t *out_n, size_t *bad_at)
{
    while (n && t[n - 1] == '=')
        n--;
    size_t o = 0;
    uint32_t acc = 0;
    int bits = 0;
    for (size_t i = 0; i < n; i++) {
        int v = b64_value((unsigned char)t[i]);
        if (v < 0) {
            *bad_at = i;
            return false;
        }
        acc = acc << 6 | (uint32_t)v;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            out[o++] = (unsigned char)(acc >> bits);
        }
    }
    if (n % 4 == 1) {
        *bad_at = n - 1;
        return false;
    }
    *out_n = o;
    return true;
}

static void b64_encode(ffd_buf *b, const unsigned char *p, size_t n)
{
    static const char tab[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)p[i] << 16;
        if (i + 1 < n)
            v |= (uint32_t)p[i + 1] << 8;
        if (i + 2 < n)
            v |= p[i + 2];
        char q[4] = {tab[v >> 18 & 63], tab[v >> 12 & 63], i + 1 < n ? tab[v >> 6 & 63] : '=',
                     i + 2 < n ? tab[v & 63] : '='};
        ffd_buf_put(b, q, 4);
    }
}

static int hex_value(int c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

/* Percent-decoding of a relative URI; NULL on OOM. */
static char *uri_decode(const char *u)
{
    size_t n = strlen(u);
    char *o = ffd_malloc(n + 1);
    if (!o)
        return NULL;
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        int h1 = i + 2 < n ? hex_value(u[i + 1]) : -1, h2 = i + 2 < n ? hex_value(u[i + 2]) : -1;
        if (u[i] == '%' && h1 >= 0 && h2 >= 0) {
            o[k++] = (char)(h1 * 16 + h2);
            i += 2;
        } else {
            o[k++] = u[i];
        }
    }
    o[k] = 0;
    return o;
}

static ffd_status read_buffers(reader *r, const unsigned char *bin, size_t bin_size, size_t bin_off)
{
    cJSON *bufs = cJSON_GetObjectItemCaseSensitive(r->root, "buffers");
    if (bufs && !cJSON_IsArray(bufs))
        return refuse(r, FFD_ERR_PARSE, "$.buffers: expected an array");
    size_t n = (size_t)cJSON_GetArraySize(bufs);
    r->s->buffers = ffd_calloc(n ? n : 1, sizeof(gltf_buffer));
    if (!r->s->buffers)
        return nomem(r);
    r->s->buffer_count = n;
    const char *jbufs = js_member(js_ws(r->jt, r->je), r->je, "buffers");
    for (size_t i = 0; i < n; i++) {
        cJSON *b = cJSON_GetArrayItem(bufs, (int)i);
        gltf_buffer *gb = &r->s->buffers[i];
        long long len = int_member(b, "byteLength", (long long)1 << 52);
        if (len < 0)
            return refuse(r, FFD_ERR_PARSE,
                          "$.buffers[%zu].byteLength: expected a non-negative integer", i);
        const cJSON *uri = cJSON_GetObjectItemCaseSensitive(b, "uri");
        const char *ju = js_member(js_element(jbufs, r->je, i), r->je, "uri");
        if (ju && *ju == '"') {
            gb->text_off = (size_t)(ju + 1 - r->jt);
            gb->text_len = (size_t)(js_skip(ju, r->je) - 1 - (ju + 1));
        }
        if (!uri) {
            if (i != 0 || !bin)
                return refuse(r, FFD_ERR_PARSE, "$.buffers[%zu]: no uri and no GLB BIN chunk", i);
            if ((size_t)len > bin_size)
                return refuse(r, FFD_ERR_PARSE,
                              "$.buffers[0].byteLength %lld exceeds the BIN chunk (%zu bytes)", len,
                              bin_size);
            gb->where = BUF_GLB;
            gb->glb_off = bin_off;
            gb->size = bin_size;
            gb->data = ffd_malloc(bin_size ? bin_size : 1);
            if (!gb->data)
                return nomem(r);
            if (bin_size)
                memcpy(gb->data, bin, bin_size);
            continue;
        }
        if (!cJSON_IsString(uri))
            return refuse(r, FFD_ERR_PARSE, "$.buffers[%zu].uri: expected a string", i);
        const char *u = uri->valuestring;
        if (strncmp(u, "data:", 5) == 0) {
            const char *comma = strstr(u, ";base64,");
            if (!comma)
                return refuse(r, FFD_ERR_UNSUPPORTED,
                              "$.buffers[%zu].uri: data URI without ;base64,", i);
            const char *t = comma + 8;
            size_t tn = strlen(t), dn = 0, at = 0;
            gb->data = ffd_malloc(tn / 4 * 3 + 3);
            if (!gb->data)
                return nomem(r);
            if (!b64_decode(t, tn, gb->data, &dn, &at))
                return refuse(r, FFD_ERR_PARSE,
                              "$.buffers[%zu].uri: character %zu of the base64 data is not base64",
                              i, at);
            gb->where = BUF_DATA_URI;
            gb->size = dn;
            if (ju) { /* the base64 characters only (the text has no escapes there) */
                size_t pre = (size_t)(t - u);
                gb->text_off += pre;
                gb->text_len = gb->text_len >= pre ? gb->text_len - pre : 0;
            }
        } else {
            if (!r->m->source_is_path)
                return refuse(r, FFD_ERR_UNSUPPORTED,
                              "$.buffers[%zu].uri: external buffer \"%s\" in a glTF read "
                              "from memory (read the file by its path, or use .glb or "
                              "embedded buffers)",
                              i, u);
            if (strstr(u, "://") || u[0] == '/')
                return refuse(r, FFD_ERR_UNSUPPORTED,
                              "$.buffers[%zu].uri: \"%s\" is not a relative file name", i, u);
            gb->uri = uri_decode(u);
            if (!gb->uri)
                return nomem(r);
            const char *slash = strrchr(r->name, '/');
            size_t dl = slash ? (size_t)(slash - r->name) + 1 : 0;
            gb->path = ffd_malloc(dl + strlen(gb->uri) + 1);
            if (!gb->path)
                return nomem(r);
            memcpy(gb->path, r->name, dl);
            strcpy(gb->path + dl, gb->uri);
            ffd_error inner = {{0}};
            ffd_status st = ffd_read_file(gb->path, &gb->data, &gb->size, &inner);
            if (st != FFD_OK)
                return ffd_fail(r->err, st, "%s: $.buffers[%zu].uri: %s", r->name, i,
                                inner.message);
            gb->where = BUF_EXTERNAL;
        }
        if (gb->size < (size_t)len)
            return refuse(r, FFD_ERR_PARSE,
                          "$.buffers[%zu]: byteLength %lld but the data holds %zu bytes", i, len,
                          gb->size);
        gb->size = (size_t)len; /* bytes past byteLength are kept but not addressed */
    }
    return FFD_OK;
}

/* Column-major 4x4 products and inverse of an affine matrix. */
static void mat_mul(const double *a, const double *b, double *o)
{
    double t[16];
    for (int c = 0; c < 4; c++)
        for (int rr = 0; rr < 4; rr++) {
            double v = 0;
            for (int k = 0; k < 4; k++)
                v += a[k * 4 + rr] * b[c * 4 + k];
            t[c * 4 + rr] = v;
        }
    memcpy(o, t, sizeof t);
}

static bool mat_affine_inverse(const double *m, double *o)
{
    double a = m[0], b = m[4], c = m[8], d = m[1], e = m[5], f = m[9], g = m[2], h = m[6],
           i = m[10];
    double A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
    double det = a * A + b * B + c * C;
    if (!(fabs(det) > 0) || !isfinite(det))
        return false;
    double inv[9] = {A / det, -(b * i - c * h) / det, (b * f - c * e) / det,
                     B / det, (a * i - c * g) / det,  -(a * f - c * d) / det,
                     C / det, -(a * h - b * g) / det, (a * e - b * d) / det}; /* row-major */
    memset(o, 0, 16 * sizeof(double));
    for (int rr = 0; rr < 3; rr++)
        for (int cc = 0; cc < 3; cc++)
            o[cc * 4 + rr] = inv[rr * 3 + cc];
    for (int rr = 0; rr < 3; rr++)
        o[12 + rr] = -(o[rr] * m[12] + o[4 + rr] * m[13] + o[8 + rr] * m[14]);
    o[15] = 1;
    return true;
}

static void mat_point(const double *m, const double *p, double *o)
{
    for (int rr = 0; rr < 3; rr++)
        o[rr] = m[rr] * p[0] + m[4 + rr] * p[1] + m[8 + rr] * p[2] + m[12 + rr];
}

static void normalize3(double *n)
{
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (l > 0)
        for (int d = 0; d < 3; d++)
            n[d] /= l;
}

/* The node's local matrix (matrix, or T * R * S; spec 5.25). */
static ffd_status node_local(reader *r, const cJSON *node, size_t ni, double *L)
{
    static const double I[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    memcpy(L, I, sizeof I);
    const cJSON *mx = cJSON_GetObjectItemCaseSensitive(node, "matrix");
    if (mx) {
        if (!cJSON_IsArray(mx) || cJSON_GetArraySize(mx) != 16)
            return refuse(r, FFD_ERR_PARSE, "$.nodes[%zu].matrix: expected 16 numbers", ni);
        for (int k = 0; k < 16; k++) {
            const cJSON *v = cJSON_GetArrayItem(mx, k);
            if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble))
                return refuse(r, FFD_ERR_PARSE, "$.nodes[%zu].matrix[%d]: expected a number", ni,
                              k);
            L[k] = v->valuedouble;
        }
        return FFD_OK;
    }
    double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, sc[3] = {1, 1, 1};
    const char *keys[3] = {"translation", "rotation", "scale"};
    double *dst[3] = {t, q, sc};
    int len[3] = {3, 4, 3};
    for (int k = 0; k < 3; k++) {
        const cJSON *a = cJSON_GetObjectItemCaseSensitive(node, keys[k]);
        if (!a)
            continue;
        if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != len[k])
            return refuse(r, FFD_ERR_PARSE, "$.nodes[%zu].%s: expected %d numbers", ni, keys[k],
                          len[k]);
        for (int c = 0; c < len[k]; c++) {
            const cJSON *v = cJSON_GetArrayItem(a, c);
            if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble))
                return refuse(r, FFD_ERR_PARSE, "$.nodes[%zu].%s[%d]: expected a number", ni,
                              keys[k], c);
            dst[k][c] = v->valuedouble;
        }
    }
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                   2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                   2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
    /* R is column-major: column c = R[3c..3c+2] */
    for (int c = 0; c < 3; c++)
        for (int rr = 0; rr < 3; rr++)
            L[c * 4 + rr] = R[c * 3 + rr] * sc[c];
    L[12] = t[0];
    L[13] = t[1];
    L[14] = t[2];
    return FFD_OK;
}

/* A FLOAT VEC3 accessor's elements: buffer, first byte, stride, count, all bounds-checked. */
typedef struct acc_view {
    uint32_t buffer;
    size_t offset, stride, count;
    int component;
} acc_view;

static ffd_status accessor_view(reader *r, long long ai, const char *what, acc_view *v)
{
    cJSON *a = cJSON_GetArrayItem(r->accessors, (int)ai);
    if (cJSON_GetObjectItemCaseSensitive(a, "sparse"))
        return refuse(r, FFD_ERR_UNSUPPORTED,
                      "$.accessors[%lld]: sparse accessor (%s) is not supported", ai, what);
    long long bv = int_member(a, "bufferView", cJSON_GetArraySize(r->views));
    if (bv < 0)
        return bv == -1 ? refuse(r, FFD_ERR_UNSUPPORTED,
                                 "$.accessors[%lld]: %s accessor without bufferView", ai, what)
                        : refuse(r, FFD_ERR_PARSE,
                                 "$.accessors[%lld].bufferView: not a bufferView index", ai);
    long long count = int_member(a, "count", (long long)UINT32_MAX);
    if (count < 1)
        return refuse(r, FFD_ERR_PARSE, "$.accessors[%lld].count: expected an integer in [1, %u)",
                      ai, UINT32_MAX);
    long long ct = int_member(a, "componentType", 100000);
    long long off = int_member(a, "byteOffset", (long long)1 << 52);
    if (off == -2)
        return refuse(r, FFD_ERR_PARSE,
                      "$.accessors[%lld].byteOffset: expected a non-negative integer", ai);
    cJSON *view = cJSON_GetArrayItem(r->views, (int)bv);
    long long buf = int_member(view, "buffer", (long long)r->s->buffer_count);
    if (buf < 0)
        return refuse(r, FFD_ERR_PARSE, "$.bufferViews[%lld].buffer: not a buffer index", bv);
    long long voff = int_member(view, "byteOffset", (long long)1 << 52);
    long long vlen = int_member(view, "byteLength", (long long)1 << 52);
    long long stride = int_member(view, "byteStride", MAX_STRIDE + 1);
    if (voff == -2 || vlen < 0 || stride == -2)
        return refuse(r, FFD_ERR_PARSE,
                      "$.bufferViews[%lld]: bad byteOffset, byteLength or byteStride", bv);
    if (cJSON_GetObjectItemCaseSensitive(view, "extensions"))
        return refuse(r, FFD_ERR_UNSUPPORTED,
                      "$.bufferViews[%lld].extensions: compressed buffer views are not "
                      "supported",
                      bv);
    voff = voff < 0 ? 0 : voff;
    off = off < 0 ? 0 : off;
    if ((unsigned long long)voff + (unsigned long long)vlen > r->s->buffers[buf].size)
        return refuse(
            r, FFD_ERR_PARSE,
            "$.bufferViews[%lld]: bytes %lld..%lld past the end of buffer %lld (%zu bytes)", bv,
            voff, voff + vlen, buf, r->s->buffers[buf].size);
    size_t elem = ct == GL_UNSIGNED_BYTE ? 1 : ct == GL_UNSIGNED_SHORT ? 2 : 4;
    if (strcmp(what, "TANGENT") == 0)
        elem = VEC4_SIZE;
    else if (strcmp(what, "indices") != 0)
        elem = VEC3_SIZE;
    if (stride > 0 && (size_t)stride < elem)
        return refuse(r, FFD_ERR_PARSE,
                      "$.bufferViews[%lld].byteStride %lld is less than the element (%zu bytes)",
                      bv, stride, elem);
    size_t st = stride > 0 ? (size_t)stride : elem;
    unsigned long long need = (unsigned long long)off + (unsigned long long)(count - 1) * st + elem;
    if (need > (unsigned long long)vlen)
        return refuse(r, FFD_ERR_PARSE,
                      "$.accessors[%lld]: %lld elements from byte %lld need %llu bytes, "
                      "bufferView %lld has %lld",
                      ai, count, off, need, bv, vlen);
    v->buffer = (uint32_t)buf;
    v->offset = (size_t)(voff + off);
    v->stride = st;
    v->count = (size_t)count;
    v->component = (int)ct;
    return FFD_OK;
}

/* The accessor holds FLOAT vectors of the type ("VEC3", "VEC4"), not normalized. */
static ffd_status float_vec(reader *r, long long ai, const char *what, const char *vec)
{
    cJSON *a = cJSON_GetArrayItem(r->accessors, (int)ai);
    long long ct = int_member(a, "componentType", 100000);
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(a, "type");
    if (ct != GL_FLOAT || !cJSON_IsString(type) || strcmp(type->valuestring, vec) != 0)
        return refuse(r, FFD_ERR_UNSUPPORTED,
                      "$.accessors[%lld]: %s must be FLOAT (5126) %s to be written back "
                      "losslessly",
                      ai, what, vec);
    if (cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(a, "normalized")))
        return refuse(r, FFD_ERR_UNSUPPORTED, "$.accessors[%lld]: normalized %s", ai, what);
    return FFD_OK;
}

static bool same_matrix(const double *a, const double *b)
{
    for (int k = 0; k < 16; k++)
        if (a[k] != b[k])
            return false;
    return true;
}

/* A per-vertex attribute accessor read with POSITION: its type (FLOAT vec),
 * its elements in bounds, one per POSITION element. */
static ffd_status vertex_attribute(reader *r, long long ai, const char *what, const char *vec,
                                   const acc_view *pos, long long pos_ai, acc_view *v)
{
    ffd_status st = float_vec(r, ai, what, vec);
    if (st == FFD_OK)
        st = accessor_view(r, ai, what, v);
    if (st == FFD_OK && v->count != pos->count)
        st = refuse(r, FFD_ERR_PARSE,
                    "$.accessors[%lld]: %s count %zu differs from POSITION "
                    "(accessor %lld) count %zu",
                    ai, what, v->count, pos_ai, pos->count);
    return st;
}

/* Adds the vertices of POSITION accessor ai under world matrix W (or finds
 * them), with their normals (NORMAL accessor nrm_ai) and tangents (TANGENT
 * accessor tan_ai, read only with normals); -1: none. */
static ffd_status position_vertices(reader *r, long long ai, long long ni, const double *W,
                                    long long nrm_ai, long long tan_ai, size_t *first)
{
    gltf_state *s = r->s;
    if (nrm_ai < 0)
        tan_ai = -1;
    if (r->acc_vertex[ai]) {
        gltf_pos_accessor *pa = &s->acc[r->acc_vertex[ai] - 1];
        if (!same_matrix(s->xforms + 32 * pa->xform, W))
            return refuse(r, FFD_ERR_UNSUPPORTED,
                          "$.accessors[%lld]: POSITION shared by instances with different "
                          "world transforms (node %lld); it cannot be written back",
                          ai, ni);
        /* only the attributes read with the POSITION first are written back */
        bool nrm_differs = nrm_ai >= 0 && nrm_ai != pa->normal;
        if (nrm_differs || (tan_ai >= 0 && tan_ai != pa->tangent)) {
            long long had = nrm_differs ? pa->normal : pa->tangent;
            char first_read[32] = "none";
            if (had >= 0)
                snprintf(first_read, sizeof first_read, "accessor %lld", had);
            return refuse(r, FFD_ERR_UNSUPPORTED,
                          "$.accessors[%lld]: POSITION shared by primitives with different %s "
                          "(accessor %lld; first read with %s): it cannot be written back",
                          ai, nrm_differs ? "NORMAL" : "TANGENT", nrm_differs ? nrm_ai : tan_ai,
                          first_read);
        }
        *first = pa->first;
        return FFD_OK;
    }
    ffd_status st = float_vec(r, ai, "POSITION", "VEC3");
    acc_view v, nv = {0}, tv = {0};
    if (st == FFD_OK)
        st = accessor_view(r, ai, "POSITION", &v);
    if (st == FFD_OK && nrm_ai >= 0)
        st = vertex_attribute(r, nrm_ai, "NORMAL", "VEC3", &v, ai, &nv);
    if (st == FFD_OK && tan_ai >= 0)
        st = vertex_attribute(r, tan_ai, "TANGENT", "VEC4", &v, ai, &tv);
    if (st != FFD_OK)
        return st;
    ffd_mesh *m = r->m;
    if (m->vertex_count + v.count >= UINT32_MAX)
        return refuse(r, FFD_ERR_UNSUPPORTED, "more than %u vertices", UINT32_MAX - 1);
    if (!ffd_grow((void **)&s->xforms, &s->xform_cap, s->xform_count + 1, 32 * sizeof(double)) ||
        !ffd_grow((void **)&s->acc, &s->acc_cap, s->acc_count + 1, sizeof *s->acc))
        return nomem(r);
    double *X = s->xforms + 32 * s->xform_count;
    memcpy(X, W, 16 * sizeof(double));
    if (!mat_affine_inverse(W, X + 16))
        return refuse(r, FFD_ERR_UNSUPPORTED,
                      "$.nodes[%lld]: singular world transform; positions cannot be "
                      "written back",
                      ni);
    uint32_t xi = (uint32_t)s->xform_count++;
    gltf_pos_accessor *pa = &s->acc[s->acc_count];
    memset(pa, 0, sizeof *pa);
    pa->index = (size_t)ai;
    pa->normal = nrm_ai;
    pa->tangent = tan_ai;
    pa->first = m->vertex_count;
    pa->count = v.count;
    pa->xform = xi;
    /* min/max numbers in the text */
    cJSON *a = cJSON_GetArrayItem(r->accessors, (int)ai);
    const char *ja = js_element(js_member(js_ws(r->jt, r->je), r->je, "accessors"), r->je,
                                (size_t)ai);
    const cJSON *mn = cJSON_GetObjectItemCaseSensitive(a, "min");
    const cJSON *mxv = cJSON_GetObjectItemCaseSensitive(a, "max");
    if (mn && mxv) {
        if (!cJSON_IsArray(mn) || !cJSON_IsArray(mxv) || cJSON_GetArraySize(mn) != 3 ||
            cJSON_GetArraySize(mxv) != 3)
            return refuse(r, FFD_ERR_PARSE, "$.accessors[%lld]: min and max must hold 3 numbers",
                          ai);
        const char *arr[2] = {js_member(ja, r->je, "min"), js_member(ja, r->je, "max")};
        for (int k = 0; k < 6; k++) {
            const cJSON *num = cJSON_GetArrayItem(k < 3 ? mn : mxv, k % 3);
            if (!cJSON_IsNumber(num))
                return refuse(r, FFD_ERR_PARSE, "$.accessors[%lld].%s[%d]: expected a number", ai,
                              k < 3 ? "min" : "max", k % 3);
            const char *p = js_element(arr[k / 3], r->je, (size_t)k % 3);
            if (!p)
                return refuse(r, FFD_ERR_PARSE, "$.accessors[%lld]: min/max not found in the text",
                              ai);
            pa->mm_off[k] = (size_t)(p - r->jt);
            pa->mm_len[k] = (size_t)(js_skip(p, r->je) - p);
            pa->mm_val[k] = num->valuedouble;
        }
        pa->has_minmax = true;
    }
    s->acc_count++;
    r->acc_vertex[ai] = (uint32_t)s->acc_count;
    double Nm[9]; /* normals to world: (W^-1)^T, i.e. row r of W^-1 as column */
    const double *Wi = X + 16;
    for (int rr = 0; rr < 3; rr++)
        for (int c = 0; c < 3; c++)
            Nm[rr * 3 + c] = Wi[rr * 4 + c]; /* Nm row rr = column rr of Wi */
    ffd_span zero[3] = {{0}};
    for (size_t k = 0; k < v.count; k++) {
        const unsigned char *p = s->buffers[v.buffer].data + v.offset + k * v.stride;
        double l[3] = {get_f32le(p), get_f32le(p + 4), get_f32le(p + 8)}, w[3];
        if (!isfinite(l[0]) || !isfinite(l[1]) || !isfinite(l[2]))
            return refuse(r, FFD_ERR_PARSE, "$.accessors[%lld]: element %zu is not finite", ai, k);
        mat_point(W, l, w);
        if (!ffd_mesh_push_vertex(m, w, zero))
            return nomem(r);
    }
    *first = pa->first;
    if (nrm_ai >= 0) {
        for (size_t k = 0; k < nv.count; k++) {
            const unsigned char *p = s->buffers[nv.buffer].data + nv.offset + k * nv.stride;
            double l[3] = {get_f32le(p), get_f32le(p + 4), get_f32le(p + 8)}, w[3];
            for (int rr = 0; rr < 3; rr++)
                w[rr] = Nm[rr * 3] * l[0] + Nm[rr * 3 + 1] * l[1] + Nm[rr * 3 + 2] * l[2];
            normalize3(w);
            if (!isfinite(w[0]) || !isfinite(w[1]) || !isfinite(w[2]))
                return refuse(r, FFD_ERR_PARSE, "$.accessors[%lld]: element %zu is not finite",
                              nrm_ai, k);
            if (!ffd_mesh_push_normal(m, w, zero, (uint32_t)(pa->first + k)))
                return nomem(r);
        }
    }
    /* tangents to world: the direction by W's linear part, renormalised; w kept */
    for (size_t k = 0; k < tv.count && tan_ai >= 0; k++) {
        const unsigned char *p = s->buffers[tv.buffer].data + tv.offset + k * tv.stride;
        double l[4] = {get_f32le(p), get_f32le(p + 4), get_f32le(p + 8), get_f32le(p + 12)};
        if (!isfinite(l[0]) || !isfinite(l[1]) || !isfinite(l[2]))
            return refuse(r, FFD_ERR_PARSE, "$.accessors[%lld]: element %zu is not finite", tan_ai,
                          k);
        if (l[3] != 1.0 && l[3] != -1.0)
            return refuse(r, FFD_ERR_PARSE,
                          "$.accessors[%lld]: element %zu: TANGENT w is %g, "
                          "expected 1 or -1 (the bitangent's handedness)",
                          tan_ai, k, l[3]);
        double w[4] = {0, 0, 0, l[3]};
        for (int rr = 0; rr < 3; rr++)
            w[rr] = W[rr] * l[0] + W[4 + rr] * l[1] + W[8 + rr] * l[2];
        normalize3(w);
        if (!ffd_mesh_push_tangent(m, w, (uint32_t)(pa->first + k)))
            return nomem(r);
    }
    return FFD_OK;
}

static ffd_status read_primitive(reader *r, const cJSON *prim, long long mi, int pi, long long ni,
                                 const double *W)
{
    long long mode = int_member(prim, "mode", 7);
    if (mode == -2)
        return refuse(r, FFD_ERR_PARSE, "$.meshes[%lld].primitives[%d].mode: expected 0..6", mi,
                      pi);
    if (mode < 0)
        mode = MODE_TRIANGLES;
    if (mode < MODE_TRIANGLES)
        return refuse(r, FFD_ERR_UNSUPPORTED,
                      "$.meshes[%lld].primitives[%d].mode %lld: only triangle modes "
                      "(4, 5, 6) are supported",
                      mi, pi, mode);
    if (cJSON_GetObjectItemCaseSensitive(prim, "extensions"))
        return refuse(r, FFD_ERR_UNSUPPORTED,
                      "$.meshes[%lld].primitives[%d].extensions: compressed primitives "
                      "are not supported",
                      mi, pi);
    const cJSON *attr = cJSON_GetObjectItemCaseSensitive(prim, "attributes");
    long long na = cJSON_GetArraySize(r->accessors);
    long long pos = int_member(attr, "POSITION", na);
    if (pos < 0)
        return refuse(r, FFD_ERR_PARSE, "$.meshes[%lld].primitives[%d].attributes.POSITION: %s", mi,
                      pi, pos == -1 ? "missing" : "not an accessor index");
    long long nrm = int_member(attr, "NORMAL", na);
    if (nrm == -2)
        return refuse(r, FFD_ERR_PARSE,
                      "$.meshes[%lld].primitives[%d].attributes.NORMAL: not an accessor index", mi,
                      pi);
    long long tan = int_member(attr, "TANGENT", na);
    if (tan == -2)
        return refuse(r, FFD_ERR_PARSE,
                      "$.meshes[%lld].primitives[%d].attributes.TANGENT: not an accessor index", mi,
                      pi);
    size_t first = 0;
    ffd_status st = position_vertices(r, pos, ni, W, nrm, tan, &first);
    if (st != FFD_OK)
        return st;
    size_t vcount = r->s->acc[r->acc_vertex[pos] - 1].count;
    long long ix = int_member(prim, "indices", na);
    if (ix == -2)
        return refuse(r, FFD_ERR_PARSE,
                      "$.meshes[%lld].primitives[%d].indices: not an accessor index", mi, pi);
    acc_view iv = {0};
    if (ix >= 0) {
        cJSON *a = cJSON_GetArrayItem(r->accessors, (int)ix);
        long long ct = int_member(a, "componentType", 100000);
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(a, "type");
        if ((ct != GL_UNSIGNED_BYTE && ct != GL_UNSIGNED_SHORT && ct != GL_UNSIGNED_INT) ||
            !cJSON_IsString(type) || strcmp(type->valuestring, "SCALAR") != 0)
            return refuse(r, FFD_ERR_PARSE,
                          "$.accessors[%lld]: indices must be UNSIGNED_BYTE/SHORT/INT SCALAR", ix);
        st = accessor_view(r, ix, "indices", &iv);
        if (st != FFD_OK)
            return st;
    }
    size_t n = ix >= 0 ? iv.count : vcount;
    const unsigned char *ib = ix >= 0 ? r->s->buffers[iv.buffer].data + iv.offset : NULL;
    uint32_t corner[3];
    size_t tri = mode == MODE_TRIANGLES ? n / 3 : n >= 3 ? n - 2 : 0;
    for (size_t t = 0; t < tri; t++) {
        size_t k[3];
        if (mode == MODE_TRIANGLES) {
            k[0] = 3 * t, k[1] = 3 * t + 1, k[2] = 3 * t + 2;
        } else if (mode == MODE_TRIANGLE_STRIP) { /* spec 3.7.2.1: winding alternates */
            k[0] = t + (t & 1), k[1] = t + 1 - (t & 1), k[2] = t + 2;
        } else {
            k[0] = t + 1, k[1] = t + 2, k[2] = 0;
        }
        for (int c = 0; c < 3; c++) {
            size_t idx = k[c];
            if (ib) {
                const unsigned char *p = ib + k[c] * iv.stride;
                idx = iv.component == GL_UNSIGNED_BYTE    ? p[0]
                      : iv.component == GL_UNSIGNED_SHORT ? (size_t)(p[0] | p[1] << 8)
                                                          : (size_t)get_u32le(p);
                if (idx >= vcount)
                    return refuse(r, FFD_ERR_PARSE,
                                  "$.accessors[%lld]: index %zu of element %zu out of range (%zu "
                                  "vertices)",
                                  ix, idx, k[c], vcount);
            }
            corner[c] = (uint32_t)(first + idx);
        }
        for (int c = 0; c < 3; c++)
            if (!ffd_mesh_push_index(r->m, corner[c]))
                return nomem(r);
        if (!ffd_mesh_end_face(r->m))
            return nomem(r);
    }
    return FFD_OK;
}

static ffd_status read_node(reader *r, long long ni, const double *parent, size_t depth)
{
    long long nn = cJSON_GetArraySize(r->nodes);
    if (ni < 0 || ni >= nn)
        return refuse(r, FFD_ERR_PARSE, "node index %lld out of range (%lld nodes)", ni, nn);
    if (r->visiting[ni])
        return refuse(r, FFD_ERR_PARSE, "$.nodes[%lld]: the node hierarchy has a cycle", ni);
    cJSON *node = cJSON_GetArrayItem(r->nodes, (int)ni);
    double L[16], W[16];
    ffd_status st = node_local(r, node, (size_t)ni, L);
    if (st != FFD_OK)
        return st;
    mat_mul(parent, L, W);
    long long mi = int_member(node, "mesh", cJSON_GetArraySize(r->meshes));
    if (mi == -2)
        return refuse(r, FFD_ERR_PARSE, "$.nodes[%lld].mesh: not a mesh index", ni);
    if (mi >= 0) {
        cJSON *prims = cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(r->meshes, (int)mi),
                                                        "primitives");
        if (!cJSON_IsArray(prims))
            return refuse(r, FFD_ERR_PARSE, "$.meshes[%lld].primitives: expected an array", mi);
        for (int pi = 0; pi < cJSON_GetArraySize(prims); pi++) {
            st = read_primitive(r, cJSON_GetArrayItem(prims, pi), mi, pi, ni, W);
            if (st != FFD_OK)
                return st;
        }
    }
    const cJSON *ch = cJSON_GetObjectItemCaseSensitive(node, "children");
    if (ch && !cJSON_IsArray(ch))
        return refuse(r, FFD_ERR_PARSE, "$.nodes[%lld].children: expected an array", ni);
    r->visiting[ni] = 1;
    for (int k = 0; k < cJSON_GetArraySize(ch); k++) {
        const cJSON *c = cJSON_GetArrayItem(ch, k);
        if (!cJSON_IsNumber(c) || c->valuedouble != floor(c->valuedouble))
            return refuse(r, FFD_ERR_PARSE, "$.nodes[%lld].children[%d]: expected a node index", ni,
                          k);
        st = read_node(r, (long long)c->valuedouble, W, depth + 1);
        if (st != FFD_OK)
            return st;
    }
    r->visiting[ni] = 0;
    return FFD_OK;
}

static ffd_status read_scene(reader *r)
{
    static const char *const refused[] = {"KHR_draco_mesh_compression", "EXT_meshopt_compression",
                                          "KHR_mesh_quantization"};
    const char *lists[2] = {"extensionsUsed", "extensionsRequired"};
    for (int l = 0; l < 2; l++) {
        const cJSON *ex = cJSON_GetObjectItemCaseSensitive(r->root, lists[l]);
        for (int k = 0; k < cJSON_GetArraySize(ex); k++) {
            const cJSON *e = cJSON_GetArrayItem(ex, k);
            for (size_t q = 0; q < 3; q++)
                if (cJSON_IsString(e) && strcmp(e->valuestring, refused[q]) == 0)
                    return refuse(r, FFD_ERR_UNSUPPORTED,
                                  "$.%s[%d]: %s is not supported (its data cannot be "
                                  "rewritten losslessly)",
                                  lists[l], k, refused[q]);
        }
    }
    r->accessors = cJSON_GetObjectItemCaseSensitive(r->root, "accessors");
    r->views = cJSON_GetObjectItemCaseSensitive(r->root, "bufferViews");
    r->nodes = cJSON_GetObjectItemCaseSensitive(r->root, "nodes");
    r->meshes = cJSON_GetObjectItemCaseSensitive(r->root, "meshes");
    long long nn = cJSON_GetArraySize(r->nodes), na = cJSON_GetArraySize(r->accessors);
    if ((r->accessors && !cJSON_IsArray(r->accessors)) || (r->views && !cJSON_IsArray(r->views)) ||
        (r->nodes && !cJSON_IsArray(r->nodes)) || (r->meshes && !cJSON_IsArray(r->meshes)))
        return refuse(r, FFD_ERR_PARSE,
                      "$.accessors, bufferViews, nodes and meshes must be arrays");
    r->visiting = ffd_calloc(nn ? (size_t)nn : 1, 1);
    r->acc_vertex = ffd_calloc(na ? (size_t)na : 1, sizeof(uint32_t));
    if (!r->visiting || !r->acc_vertex)
        return nomem(r);
    static const double I[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const cJSON *scenes = cJSON_GetObjectItemCaseSensitive(r->root, "scenes");
    long long sc = int_member(r->root, "scene", cJSON_GetArraySize(scenes));
    if (sc == -2)
        return refuse(r, FFD_ERR_PARSE, "$.scene: not a scene index");
    if (sc < 0 && cJSON_GetArraySize(scenes) > 0)
        sc = 0;
    ffd_status st = FFD_OK;
    if (sc >= 0) {
        const cJSON *roots =
            cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(scenes, (int)sc), "nodes");
        for (int k = 0; k < cJSON_GetArraySize(roots) && st == FFD_OK; k++) {
            const cJSON *c = cJSON_GetArrayItem(roots, k);
            if (!cJSON_IsNumber(c) || c->valuedouble != floor(c->valuedouble))
                return refuse(r, FFD_ERR_PARSE, "$.scenes[%lld].nodes[%d]: expected a node index",
                              sc, k);
            st = read_node(r, (long long)c->valuedouble, I, 0);
        }
    } else {
        unsigned char *child = ffd_calloc(nn ? (size_t)nn : 1, 1);
        if (!child)
            return nomem(r);
        for (long long ni = 0; ni < nn; ni++) {
            const cJSON *ch =
                cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(r->nodes, (int)ni), "children");
            for (int k = 0; k < cJSON_GetArraySize(ch); k++) {
                const cJSON *c = cJSON_GetArrayItem(ch, k);
                if (cJSON_IsNumber(c) && c->valuedouble >= 0 && c->valuedouble < (double)nn)
                    child[(size_t)c->valuedouble] = 1;
            }
        }
        for (long long ni = 0; ni < nn && st == FFD_OK; ni++)
            if (!child[ni])
                st = read_node(r, ni, I, 0);
        ffd_free(child);
    }
    if (st != FFD_OK)
        return st;
    if (r->m->vertex_count == 0)
        return refuse(r, FFD_ERR_PARSE, "no triangle primitive in the %s",
                      sc >= 0 ? "default scene" : "nodes");
    return FFD_OK;
}

/* Element locations of every vertex, normal and tangent (the accessors'
 * views again): normals and tangents were pushed right after their
 * positions, in the order of s->acc. */
static ffd_status record_elements(reader *r)
{
    gltf_state *s = r->s;
    ffd_mesh *m = r->m;
    size_t nn = m->normal_count ? m->normal_count : 1, nt = m->tangent_count ? m->tangent_count : 1;
    s->pos = ffd_calloc(m->vertex_count, sizeof *s->pos);
    s->vxform = ffd_calloc(m->vertex_count, sizeof *s->vxform);
    s->orig_pos = ffd_malloc_array(3 * m->vertex_count, sizeof(double));
    s->nrm = ffd_calloc(nn, sizeof *s->nrm);
    s->orig_nrm = ffd_malloc_array(3 * nn, sizeof(double));
    s->tan = ffd_calloc(nt, sizeof *s->tan);
    s->orig_tan = ffd_malloc_array(4 * nt, sizeof(double));
    if (!s->pos || !s->vxform || !s->orig_pos || !s->nrm || !s->orig_nrm || !s->tan || !s->orig_tan)
        return nomem(r);
    memcpy(s->orig_pos, m->positions, 3 * m->vertex_count * sizeof(double));
    if (m->normal_count)
        memcpy(s->orig_nrm, m->normals, 3 * m->normal_count * sizeof(double));
    if (m->tangent_count)
        memcpy(s->orig_tan, m->tangents, 4 * m->tangent_count * sizeof(double));
    size_t ni = 0, ti = 0;
    for (size_t k = 0; k < s->acc_count; k++) {
        gltf_pos_accessor *pa = &s->acc[k];
        acc_view v, nv = {0}, tv = {0};
        ffd_status st = accessor_view(r, (long long)pa->index, "POSITION", &v);
        if (st == FFD_OK && pa->normal >= 0)
            st = accessor_view(r, pa->normal, "NORMAL", &nv);
        if (st == FFD_OK && pa->tangent >= 0)
            st = accessor_view(r, pa->tangent, "TANGENT", &tv);
        if (st != FFD_OK)
            return st;
        for (size_t e = 0; e < v.count; e++) {
            s->pos[pa->first + e] = (gltf_elem){v.buffer, v.offset + e * v.stride};
            s->vxform[pa->first + e] = pa->xform;
        }
        for (size_t e = 0; e < nv.count; e++)
            s->nrm[ni + e] = (gltf_elem){nv.buffer, nv.offset + e * nv.stride};
        for (size_t e = 0; e < tv.count; e++)
            s->tan[ti + e] = (gltf_elem){tv.buffer, tv.offset + e * tv.stride};
        ni += nv.count;
        ti += tv.count;
    }
    assert(ni == m->normal_count && ti == m->tangent_count);
    m->vertex_normals = m->normal_count == m->vertex_count;
    return FFD_OK;
}

static ffd_status gltf_read(ffd_mesh *m, const char *name, ffd_error *err)
{
    gltf_state *s = ffd_calloc(1, sizeof *s);
    if (!s)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    m->codec_state = s;
    m->codec_state_free = state_free;
    reader r = {.m = m, .s = s, .name = name, .err = err};
    const unsigned char *src = m->src;
    size_t n = m->src_size;
    const unsigned char *bin = NULL;
    size_t bin_size = 0, bin_off = 0;
    ffd_status st;
    if (n >= 4 && get_u32le(src) == GLB_MAGIC) {
        s->glb = true;
        m->encoding = FFD_ENCODING_BINARY_LE;
        if (n < GLB_HEADER_SIZE + GLB_CHUNK_HEADER_SIZE)
            return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: truncated GLB header", name, n);
        if (get_u32le(src + 4) != GLB_VERSION)
            return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: byte 4: GLB version %u (expected 2)",
                            name, get_u32le(src + 4));
        if (get_u32le(src + 8) != n)
            return ffd_fail(err, FFD_ERR_PARSE, "%s: byte 8: GLB length %u but the file has %zu bytes",
                            name, get_u32le(src + 8), n);
        size_t jl = get_u32le(src + 12);
        if (get_u32le(src + 16) != GLB_CHUNK_JSON)
            return ffd_fail(err, FFD_ERR_PARSE, "%s: byte 16: first GLB chunk is not JSON", name);
        if (jl > n - 20)
            return ffd_fail(err, FFD_ERR_PARSE, "%s: byte 12: JSON chunk length %zu past the end of "
                            "the file (%zu bytes)", name, jl, n);
        s->json_off = 20;
        s->json_len = jl;
        s->glb_json_end = 20 + jl;
        size_t at = 20 + jl;
        if (at + GLB_CHUNK_HEADER_SIZE <= n && get_u32le(src + at + 4) == GLB_CHUNK_BIN) {
            size_t bl = get_u32le(src + at);
            if (bl > n - at - GLB_CHUNK_HEADER_SIZE)
                return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: BIN chunk length %zu past the "
                                "end of the file", name, at, bl);
            bin = src + at + 8;
            bin_size = bl;
            bin_off = at + 8;
        } else if (at != n && at + GLB_CHUNK_HEADER_SIZE > n) {
            return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: truncated GLB chunk header", name, at);
        }
    } else {
        m->encoding = FFD_ENCODING_ASCII;
        s->json_off = 0;
        s->json_len = n;
    }
    r.jt = (const char *)src + s->json_off;
    r.je = r.jt + s->json_len;
    bool escaped;
    size_t nul = ffd_json_nul_at(r.jt, s->json_len, &escaped);
    if (nul < s->json_len)
        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: NUL in the JSON text", name,
                        s->json_off + nul);
    unsigned long fails = ffd_json_alloc_failures();
    r.root = cJSON_ParseWithLength(r.jt, s->json_len);
    if (!r.root) {
        if (ffd_json_alloc_failures() != fails)
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory parsing JSON", name);
        const char *at = cJSON_GetErrorPtr();
        size_t off = at && at >= r.jt && at <= r.je ? (size_t)(at - r.jt) : 0;
        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte %zu: invalid JSON", name, s->json_off + off);
    }
    if (!cJSON_IsObject(r.root)) {
        st = refuse(&r, FFD_ERR_PARSE, "byte %zu: the JSON text is not an object", s->json_off);
        goto done;
    }
    const cJSON *asset = cJSON_GetObjectItemCaseSensitive(r.root, "asset");
    const cJSON *ver = cJSON_GetObjectItemCaseSensitive(asset, "version");
    if (!cJSON_IsString(ver) || strncmp(ver->valuestring, "2.", 2) != 0) {
        st = refuse(&r, FFD_ERR_UNSUPPORTED, "$.asset.version: expected \"2.x\"");
        goto done;
    }
    s->source_path = ffd_strdup(name);
    if (!s->source_path) {
        st = nomem(&r);
        goto done;
    }
    st = read_buffers(&r, bin, bin_size, bin_off);
    if (st == FFD_OK)
        st = read_scene(&r);
    if (st == FFD_OK)
        st = record_elements(&r);
done:
    cJSON_Delete(r.root);
    ffd_free(r.visiting);
    ffd_free(r.acc_vertex);
    return st;
}

/* ======================================================================
 * Writing
 * ====================================================================== */

typedef struct text_edit {
    size_t off, len;
    char text[40];
} text_edit;

static int cmp_edit(const void *a, const void *b)
{
    const text_edit *x = a, *y = b;
    return (x->off > y->off) - (x->off < y->off);
}

/* The writable copy of buffer i (made on first use); NULL on OOM. */
static unsigned char *writable(const gltf_state *s, unsigned char **bufs, uint32_t i)
{
    if (!bufs[i]) {
        bufs[i] = ffd_malloc(s->buffers[i].size + 1);
        if (bufs[i])
            memcpy(bufs[i], s->buffers[i].data, s->buffers[i].size);
    }
    return bufs[i];
}

/* The buffers with moved positions, normals and tangents written back
 * (local space), and the min/max edits; bufs[i] stays NULL for a buffer
 * none of whose bytes changed. */
static ffd_status patched_buffers(const ffd_mesh *m, unsigned char ***out, text_edit **edits,
                                  size_t *edit_count, ffd_error *err)
{
    const gltf_state *s = m->codec_state;
    unsigned char **bufs = ffd_calloc(s->buffer_count ? s->buffer_count : 1, sizeof *bufs);
    text_edit *ed = ffd_calloc(6 * s->acc_count + 1, sizeof *ed);
    bool *acc_moved = ffd_calloc(s->acc_count + 1, 1);
    if (!bufs || !ed || !acc_moved) {
        ffd_free(bufs);
        ffd_free(ed);
        ffd_free(acc_moved);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing glTF");
    }
    size_t ne = 0;
    ffd_status st = FFD_OK;
    for (size_t k = 0; k < s->acc_count && st == FFD_OK; k++) {
        const gltf_pos_accessor *pa = &s->acc[k];
        const double *Wi = s->xforms + 32 * pa->xform + 16, *W = s->xforms + 32 * pa->xform;
        bool moved = false;
        for (size_t v = pa->first; v < pa->first + pa->count; v++) {
            const double *P = m->positions + 3 * v, *O = s->orig_pos + 3 * v;
            if (P[0] == O[0] && P[1] == O[1] && P[2] == O[2])
                continue;
            const gltf_elem *e = &s->pos[v];
            if (!writable(s, bufs, e->buffer)) {
                st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing glTF");
                break;
            }
            double l[3];
            mat_point(Wi, P, l);
            for (int d = 0; d < 3; d++) {
                if (!(fabs(l[d]) <= 3.4028234663852886e38)) {
                    st = ffd_fail(err, FFD_ERR_RANGE, "vertex %zu: coordinate %g does not fit a "
                                  "float", v, l[d]);
                    break;
                }
                put_f32le(bufs[e->buffer] + e->offset + 4 * (size_t)d, (float)l[d]);
            }
            moved = true;
        }
        acc_moved[k] = moved;
        (void)W;
    }
    /* normals: n_local = W^T n_world, renormalised */
    for (size_t i = 0; i < m->normal_count && st == FFD_OK; i++) {
        const double *N = m->normals + 3 * i, *O = s->orig_nrm + 3 * i;
        if (N[0] == O[0] && N[1] == O[1] && N[2] == O[2])
            continue;
        uint32_t v = m->normal_anchors[i];
        const double *W = s->xforms + 32 * s->vxform[v];
        double l[3];
        for (int c = 0; c < 3; c++)
            l[c] = W[c * 4] * N[0] + W[c * 4 + 1] * N[1] + W[c * 4 + 2] * N[2];
        normalize3(l);
        const gltf_elem *e = &s->nrm[i];
        if (!writable(s, bufs, e->buffer)) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing glTF");
            break;
        }
        for (int d = 0; d < 3; d++)
            put_f32le(bufs[e->buffer] + e->offset + 4 * (size_t)d, (float)l[d]);
    }
    /* tangents: t_local = W^-1 t_world (a direction), renormalised; w kept */
    for (size_t i = 0; i < m->tangent_count && st == FFD_OK; i++) {
        const double *T = m->tangents + 4 * i, *O = s->orig_tan + 4 * i;
        if (T[0] == O[0] && T[1] == O[1] && T[2] == O[2] && T[3] == O[3])
            continue;
        const double *Wi = s->xforms + 32 * s->vxform[m->tangent_anchors[i]] + 16;
        double l[3];
        for (int rr = 0; rr < 3; rr++)
            l[rr] = Wi[rr] * T[0] + Wi[4 + rr] * T[1] + Wi[8 + rr] * T[2];
        normalize3(l);
        const gltf_elem *e = &s->tan[i];
        if (!writable(s, bufs, e->buffer)) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing glTF");
            break;
        }
        for (int d = 0; d < 3; d++)
            put_f32le(bufs[e->buffer] + e->offset + 4 * (size_t)d, (float)l[d]);
        if (T[3] != O[3])
            put_f32le(bufs[e->buffer] + e->offset + 12, (float)T[3]);
    }
    /* min/max of the accessors whose elements moved (spec: required for POSITION) */
    for (size_t k = 0; k < s->acc_count && st == FFD_OK; k++) {
        const gltf_pos_accessor *pa = &s->acc[k];
        if (!acc_moved[k] || !pa->has_minmax)
            continue;
        float mm[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
        for (size_t v = pa->first; v < pa->first + pa->count; v++) {
            const gltf_elem *e = &s->pos[v];
            const unsigned char *p =
                (bufs[e->buffer] ? bufs[e->buffer] : s->buffers[e->buffer].data) + e->offset;
            for (int d = 0; d < 3; d++) {
                float f = get_f32le(p + 4 * d);
                mm[d] = f < mm[d] ? f : mm[d];
                mm[3 + d] = f > mm[3 + d] ? f : mm[3 + d];
            }
        }
        for (int d = 0; d < 6; d++) {
            if ((float)pa->mm_val[d] == mm[d])
                continue;
            ed[ne].off = pa->mm_off[d];
            ed[ne].len = pa->mm_len[d];
            ffd_format_float(ed[ne].text, mm[d]);
            ne++;
        }
    }
    ffd_free(acc_moved);
    if (st != FFD_OK) {
        for (size_t i = 0; i < s->buffer_count; i++)
            ffd_free(bufs[i]);
        ffd_free(bufs);
        ffd_free(ed);
        return st;
    }
    qsort(ed, ne, sizeof *ed, cmp_edit);
    *out = bufs;
    *edits = ed;
    *edit_count = ne;
    return FFD_OK;
}

static void free_bufs(const gltf_state *s, unsigned char **bufs)
{
    if (!bufs)
        return;
    for (size_t i = 0; i < s->buffer_count; i++)
        ffd_free(bufs[i]);
    ffd_free(bufs);
}

/* The JSON text with the min/max edits, changed data: URIs re-encoded, and
 * (embed) external buffers turned into data: URIs. */
static void put_json(ffd_buf *b, const ffd_mesh *m, unsigned char **bufs, const text_edit *ed,
                     size_t ne, bool embed)
{
    const gltf_state *s = m->codec_state;
    const char *jt = (const char *)m->src + s->json_off;
    size_t at = 0, ie = 0;
    for (;;) {
        /* the next edit: a min/max number or a buffer's uri text */
        size_t next = s->json_len, which = SIZE_MAX;
        bool is_buf = false;
        if (ie < ne)
            next = ed[ie].off;
        for (size_t i = 0; i < s->buffer_count; i++) {
            const gltf_buffer *gb = &s->buffers[i];
            bool re = (gb->where == BUF_DATA_URI && bufs[i]) || (gb->where == BUF_EXTERNAL && embed);
            if (re && gb->text_off >= at && gb->text_off < next) {
                next = gb->text_off;
                which = i;
                is_buf = true;
            }
        }
        ffd_buf_put(b, jt + at, next - at);
        if (next >= s->json_len)
            break;
        if (is_buf) {
            const gltf_buffer *gb = &s->buffers[which];
            const unsigned char *d = bufs[which] ? bufs[which] : gb->data;
            if (gb->where == BUF_EXTERNAL)
                ffd_buf_puts(b, DATA_URI_BASE64);
            b64_encode(b, d, gb->size);
            at = gb->text_off + gb->text_len;
        } else {
            ffd_buf_puts(b, ed[ie].text);
            at = ed[ie].off + ed[ie].len;
            ie++;
        }
    }
}

static ffd_status patch_to(const ffd_mesh *m, ffd_buf *b, bool embed, unsigned char ***bufs_out,
                           ffd_error *err)
{
    const gltf_state *s = m->codec_state;
    if (!s)
        return ffd_fail(err, FFD_ERR_INVALID, "glTF: the mesh has no glTF source");
    unsigned char **bufs = NULL;
    text_edit *ed = NULL;
    size_t ne = 0;
    ffd_status st = patched_buffers(m, &bufs, &ed, &ne, err);
    if (st != FFD_OK)
        return st;
    if (!s->glb) {
        put_json(b, m, bufs, ed, ne, embed);
    } else {
        ffd_buf j = {0};
        put_json(&j, m, bufs, ed, ne, false);
        size_t jl = j.size;
        if (jl != s->json_len) {
            while (jl > 0 && j.data[jl - 1] == ' ')
                jl--;
            j.size = jl;
            while (j.size % 4 && !j.oom) /* an OOM buffer never grows */
                ffd_buf_put(&j, " ", 1);
        }
        size_t rest = m->src_size - s->glb_json_end;
        long long delta = (long long)j.size - (long long)s->json_len;
        unsigned char head[20];
        memcpy(head, m->src, 20);
        put_u32le(head + 8, (uint32_t)(m->src_size + delta));
        put_u32le(head + 12, (uint32_t)j.size);
        ffd_buf_put(b, head, 20);
        ffd_buf_put(b, j.data, j.size);
        size_t base = b->size;
        ffd_buf_put(b, m->src + s->glb_json_end, rest);
        bool oom = j.oom;
        ffd_buf_free(&j);
        if (!b->oom && !oom && m->src_size + delta > UINT32_MAX)
            st = ffd_fail(err, FFD_ERR_RANGE, "GLB larger than 4 GiB");
        for (size_t i = 0; i < s->buffer_count && !b->oom && st == FFD_OK; i++)
            if (s->buffers[i].where == BUF_GLB && bufs[i])
                memcpy(b->data + base + (s->buffers[i].glb_off - s->glb_json_end), bufs[i],
                       s->buffers[i].size);
        if (oom)
            b->oom = true;
    }
    ffd_free(ed);
    if (st == FFD_OK && b->oom)
        st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing glTF");
    if (st == FFD_OK && bufs_out)
        *bufs_out = bufs;
    else
        free_bufs(s, bufs);
    return st;
}

/* In memory, external buffers become data: URIs (the text is self-contained). */
static ffd_status gltf_patch(const ffd_mesh *m, ffd_buf *b, ffd_error *err)
{
    return patch_to(m, b, true, NULL, err);
}

static ffd_status gltf_write(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err);

static bool same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    return stat(a, &sa) == 0 && stat(b, &sb) == 0 && sa.st_dev == sb.st_dev &&
           sa.st_ino == sb.st_ino;
}

/* A .gltf with external buffers: the .gltf and each buffer under its uri
 * next to path, all written to temporary files first and then renamed (so
 * either all are replaced or, on an error before the renames, none). */
static ffd_status gltf_write_file(const ffd_mesh *m, const char *path, ffd_error *err)
{
    const char *dot = strrchr(path, '.');
    bool want_glb = dot && strcasecmp(dot, ".glb") == 0;
    if (!(m->src && m->format == FFD_FORMAT_GLTF && m->codec_state)) {
        ffd_buf b = {0};
        ffd_error inner = {{0}};
        ffd_status st =
            gltf_write(m, want_glb ? FFD_ENCODING_BINARY_LE : FFD_ENCODING_ASCII, &b, &inner);
        if (st == FFD_OK)
            st = ffd_write_file_atomic(path, b.data, b.size, err);
        else
            ffd_fail(err, st, "%s: %s", path, inner.message);
        ffd_buf_free(&b);
        return st;
    }
    const gltf_state *s = m->codec_state;
    if (want_glb != s->glb)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: the source is %s; writing it as %s is not "
                        "supported (keep the extension)", path, s->glb ? ".glb" : ".gltf",
                        want_glb ? ".glb" : ".gltf");
    bool external = false;
    for (size_t i = 0; s && i < s->buffer_count; i++)
        external |= s->buffers[i].where == BUF_EXTERNAL;
    ffd_buf b = {0};
    unsigned char **bufs = NULL;
    ffd_error inner = {{0}};
    ffd_status st = patch_to(m, &b, false, &bufs, &inner);
    if (st != FFD_OK) {
        ffd_buf_free(&b);
        return ffd_fail(err, st, "%s: %s", path, inner.message);
    }
    if (!external) {
        free_bufs(s, bufs);
        st = ffd_write_file_atomic(path, b.data, b.size, err);
        ffd_buf_free(&b);
        return st;
    }
    bool in_place = same_file(path, s->source_path);
    const char *slash = strrchr(path, '/');
    size_t dl = slash ? (size_t)(slash - path) + 1 : 0;
    size_t nb = s->buffer_count;
    char **dst = ffd_calloc(nb + 1, sizeof *dst), **tmp = ffd_calloc(nb + 1, sizeof *tmp);
    size_t made = 0;
    if (!dst || !tmp)
        st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
    for (size_t i = 0; i <= nb && st == FFD_OK; i++) {
        const gltf_buffer *gb = i < nb ? &s->buffers[i] : NULL;
        if (gb && gb->where != BUF_EXTERNAL)
            continue;
        const char *rel = gb ? gb->uri : path + dl;
        dst[i] = ffd_malloc(dl + strlen(rel) + 1);
        tmp[i] = ffd_malloc(dl + strlen(rel) + 32);
        if (!dst[i] || !tmp[i]) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory");
            break;
        }
        memcpy(dst[i], path, dl);
        strcpy(dst[i] + dl, rel);
        snprintf(tmp[i], dl + strlen(rel) + 32, "%s.ffd-part%ld", dst[i], (long)getpid());
        if (gb && !in_place && same_file(dst[i], gb->path)) {
            st = ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: its buffer %s would replace the source's "
                          "buffer %s; write to another directory or to .glb", path, dst[i],
                          gb->path);
            break;
        }
        const unsigned char *d = gb ? (bufs[i] ? bufs[i] : gb->data) : b.data;
        size_t n = gb ? gb->size : b.size;
        /* bytes past byteLength in the source file are kept */
        if (gb && !bufs[i])
            n = gb->size;
        st = ffd_write_file_atomic(tmp[i], d, n, err);
        if (st == FFD_OK)
            made = i + 1;
    }
    for (size_t i = 0; i <= nb && st == FFD_OK; i++)
        if (tmp[i] && rename(tmp[i], dst[i]) != 0)
            st = ffd_fail(err, FFD_ERR_IO, "%s: %s", dst[i], strerror(errno));
    for (size_t i = 0; tmp && i < made; i++)
        if (tmp[i] && st != FFD_OK)
            unlink(tmp[i]);
    for (size_t i = 0; i <= nb && dst && tmp; i++) {
        ffd_free(dst[i]);
        ffd_free(tmp[i]);
    }
    ffd_free(dst);
    ffd_free(tmp);
    free_bufs(s, bufs);
    ffd_buf_free(&b);
    return st;
}

/* From data (another format or ffd_mesh_create): one buffer holding the
 * positions (FLOAT VEC3), per-vertex normals when the mesh has one per
 * vertex, and UNSIGNED_INT indices of the faces fanned into triangles; one
 * mesh, one node, one scene. ASCII: .gltf with a data: URI; BINARY_LE: .glb. */
static ffd_status gltf_write(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    size_t nv = m->vertex_count, tris = 0;
    for (size_t f = 0; f < m->face_count; f++) {
        size_t k = m->face_offsets[f + 1] - m->face_offsets[f];
        tris += k >= 3 ? k - 2 : 0;
    }
    if (nv == 0 || tris == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "glTF: a mesh without triangles cannot be written");
    bool normals = m->vertex_normals && m->normal_count == nv;
    size_t psize = VEC3_SIZE * nv, nsize = normals ? psize : 0, isize = 12 * tris;
    if (nv > UINT32_MAX / VEC3_SIZE / 2 || tris > UINT32_MAX / 24)
        return ffd_fail(err, FFD_ERR_RANGE, "glTF: mesh too large for one buffer");
    size_t total = psize + nsize + isize;
    unsigned char *bin = ffd_malloc(total);
    if (!bin)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing glTF");
    float mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < nv; v++)
        for (int d = 0; d < 3; d++) {
            double x = m->positions[3 * v + d];
            if (!(fabs(x) <= 3.4028234663852886e38)) {
                ffd_free(bin);
                return ffd_fail(err, FFD_ERR_RANGE, "vertex %zu: coordinate %g does not fit a float",
                                v, x);
            }
            float f = (float)x;
            put_f32le(bin + VEC3_SIZE * v + 4 * (size_t)d, f);
            mn[d] = f < mn[d] ? f : mn[d];
            mx[d] = f > mx[d] ? f : mx[d];
            if (normals)
                put_f32le(bin + psize + VEC3_SIZE * v + 4 * (size_t)d, (float)m->normals[3 * v + d]);
        }
    size_t t = 0;
    for (size_t f = 0; f < m->face_count; f++) {
        uint32_t a = m->face_offsets[f], e = m->face_offsets[f + 1];
        for (uint32_t k = a + 1; k + 1 < e; k++, t++) {
            put_u32le(bin + psize + nsize + 12 * t, m->face_indices[a]);
            put_u32le(bin + psize + nsize + 12 * t + 4, m->face_indices[k]);
            put_u32le(bin + psize + nsize + 12 * t + 8, m->face_indices[k + 1]);
        }
    }
    ffd_buf j = {0};
    char num[32];
    ffd_buf_puts(&j, "{\"asset\":{\"version\":\"2.0\",\"generator\":\"ffdkit\"},\"scene\":0,"
                     "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                     "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0");
    if (normals)
        ffd_buf_puts(&j, ",\"NORMAL\":2");
    ffd_buf_printf(&j, "},\"indices\":1,\"mode\":%d}]}],\"accessors\":[{\"bufferView\":0,"
                       "\"componentType\":%d,\"count\":%zu,\"type\":\"VEC3\",\"min\":[",
                   MODE_TRIANGLES, GL_FLOAT, nv);
    for (int d = 0; d < 6; d++) {
        ffd_format_float(num, d < 3 ? mn[d] : mx[d - 3]);
        ffd_buf_puts(&j, num);
        ffd_buf_puts(&j, d == 2 ? "],\"max\":[" : d == 5 ? "]}" : ",");
    }
    ffd_buf_printf(&j, ",{\"bufferView\":1,\"componentType\":%d,\"count\":%zu,\"type\":\"SCALAR\"}",
                   GL_UNSIGNED_INT, 3 * tris);
    if (normals)
        ffd_buf_printf(&j, ",{\"bufferView\":2,\"componentType\":%d,\"count\":%zu,\"type\":\"VEC3\"}",
                       GL_FLOAT, nv);
    ffd_buf_printf(&j, "],\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":%zu},"
                       "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}",
                   psize, psize + nsize, isize);
    if (normals)
        ffd_buf_printf(&j, ",{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", psize, nsize);
    ffd_buf_printf(&j, "],\"buffers\":[{\"byteLength\":%zu", total);
    if (enc == FFD_ENCODING_ASCII) {
        ffd_buf_puts(&j, ",\"uri\":\"" DATA_URI_BASE64);
        b64_encode(&j, bin, total);
        ffd_buf_puts(&j, "\"}]}\n");
        ffd_buf_put(b, j.data, j.size);
    } else {
        ffd_buf_puts(&j, "}]}");
        while (j.size % 4 && !j.oom) /* an OOM buffer never grows */
            ffd_buf_put(&j, " ", 1);
        unsigned char h[20];
        put_u32le(h, GLB_MAGIC);
        put_u32le(h + 4, GLB_VERSION);
        put_u32le(h + 8, (uint32_t)(GLB_HEADER_SIZE + 2 * GLB_CHUNK_HEADER_SIZE + j.size + total));
        put_u32le(h + 12, (uint32_t)j.size);
        put_u32le(h + 16, GLB_CHUNK_JSON);
        ffd_buf_put(b, h, 20);
        ffd_buf_put(b, j.data, j.size);
        put_u32le(h, (uint32_t)total);
        put_u32le(h + 4, GLB_CHUNK_BIN);
        ffd_buf_put(b, h, 8);
        ffd_buf_put(b, bin, total); /* total is a multiple of 4 */
    }
    bool oom = j.oom;
    ffd_buf_free(&j);
    ffd_free(bin);
    if (oom || b->oom)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory writing glTF");
    return FFD_OK;
}

static ffd_status gltf_refine(ffd_refine_ctx *c, ffd_buf *b, ffd_error *err)
{
    (void)c;
    (void)b;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                    "glTF: refinement is not supported (new vertices would need every vertex "
                    "attribute, skin weight and morph target of their accessors rebuilt)");
}

static const char *const gltf_extensions[] = {"gltf", "glb", NULL};

const ffd_mesh_codec ffd_mesh_codec_gltf = {
    .format = FFD_FORMAT_GLTF,
    .name = "glTF",
    .extensions = gltf_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII) | FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_LE),
    .read = gltf_read,
    .patch = gltf_patch,
    .write = gltf_write,
    .write_file = gltf_write_file,
    .refine = gltf_refine,
};
