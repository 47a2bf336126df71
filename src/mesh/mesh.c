/* mesh — the mesh type: building, accessors, reading (through the format's
 * codec, mesh_codec.h), positions and normals update, and topology info
 * (welding, edges, boundary).
 *
 * Info semantics: welded_vertex_count counts distinct positions (exactly
 * equal coordinates merged, -0 == 0). Edges are taken over the file's own
 * vertex sharing, except for STL, which shares none, where they are taken
 * between welded positions; so hinge.stl is closed while teapot.obj (32
 * patches whose seams the file leaves unwelded) has 528 boundary edges.
 * Edges whose two ends coincide (after welding) are not counted.
 *
 * Numbers are parsed with strtod, so the C locale's decimal point is assumed
 * (the library never calls setlocale). */
#include "mesh_codec.h"
#include "mesh_cells.h"

#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ======================================================================
 * Building
 * ====================================================================== */

ffd_mesh *ffd_mesh_alloc(ffd_format format)
{
    ffd_mesh *m = ffd_calloc(1, sizeof *m);
    if (!m)
        return NULL;
    m->format = format;
    m->encoding = FFD_ENCODING_ASCII;
    m->face_offsets = ffd_malloc(sizeof(uint32_t) * 16);
    if (!m->face_offsets) {
        ffd_free(m);
        return NULL;
    }
    m->face_cap = 15;
    m->face_offsets[0] = 0;
    return m;
}

void ffd_mesh_destroy(ffd_mesh *mesh)
{
    if (!mesh)
        return;
    ffd_free(mesh->src);
    ffd_free(mesh->positions);
    ffd_free(mesh->position_spans);
    ffd_free(mesh->face_offsets);
    ffd_free(mesh->face_indices);
    ffd_free(mesh->normals);
    ffd_free(mesh->normal_spans);
    ffd_free(mesh->normal_anchors);
    ffd_free(mesh->tangents);
    ffd_free(mesh->tangent_anchors);
    ffd_mesh_free_cells(mesh);
    if (mesh->codec_state_free)
        mesh->codec_state_free(mesh->codec_state);
    ffd_free(mesh);
}

static bool grow_vertices(ffd_mesh *m, size_t need)
{
    if (need <= m->vertex_cap)
        return true;
    size_t cap = m->vertex_cap;
    if (!ffd_grow((void **)&m->positions, &cap, need, 3 * sizeof(double)))
        return false;
    if (m->src) {
        size_t cap2 = m->vertex_cap;
        if (!ffd_grow((void **)&m->position_spans, &cap2, cap, 3 * sizeof(ffd_span)))
            return false;
    }
    m->vertex_cap = cap;
    return true;
}

static bool grow_normals(ffd_mesh *m, size_t need)
{
    if (need <= m->normal_cap)
        return true;
    size_t cap = m->normal_cap;
    if (!ffd_grow((void **)&m->normals, &cap, need, 3 * sizeof(double)))
        return false;
    size_t cap2 = m->normal_cap;
    if (!ffd_grow((void **)&m->normal_anchors, &cap2, cap, sizeof(uint32_t)))
        return false;
    if (m->src) {
        cap2 = m->normal_cap;
        if (!ffd_grow((void **)&m->normal_spans, &cap2, cap, 3 * sizeof(ffd_span)))
            return false;
    }
    m->normal_cap = cap;
    return true;
}

static bool grow_faces(ffd_mesh *m, size_t need)
{
    if (need <= m->face_cap)
        return true;
    size_t cap = m->face_cap + 1, want = need + 1;
    if (need == SIZE_MAX || !ffd_grow((void **)&m->face_offsets, &cap, want, sizeof(uint32_t)))
        return false;
    m->face_cap = cap - 1;
    return true;
}

bool ffd_mesh_reserve(ffd_mesh *m, size_t vertices, size_t faces, size_t indices, size_t normals)
{
    return grow_vertices(m, vertices) && grow_faces(m, faces) &&
           ffd_grow((void **)&m->face_indices, &m->index_cap, indices ? indices : 1,
                    sizeof(uint32_t)) &&
           grow_normals(m, normals);
}

bool ffd_mesh_push_vertex(ffd_mesh *m, const double xyz[3], const ffd_span spans[3])
{
    if (m->vertex_count >= UINT32_MAX || !grow_vertices(m, m->vertex_count + 1))
        return false;
    memcpy(m->positions + 3 * m->vertex_count, xyz, 3 * sizeof(double));
    if (m->position_spans && spans)
        memcpy(m->position_spans + 3 * m->vertex_count, spans, 3 * sizeof(ffd_span));
    m->vertex_count++;
    return true;
}

bool ffd_mesh_push_normal(ffd_mesh *m, const double n[3], const ffd_span spans[3], uint32_t anchor)
{
    if (m->normal_count >= UINT32_MAX || !grow_normals(m, m->normal_count + 1))
        return false;
    memcpy(m->normals + 3 * m->normal_count, n, 3 * sizeof(double));
    if (m->normal_spans && spans)
        memcpy(m->normal_spans + 3 * m->normal_count, spans, 3 * sizeof(ffd_span));
    m->normal_anchors[m->normal_count] = anchor;
    m->normal_count++;
    return true;
}

bool ffd_mesh_push_tangent(ffd_mesh *m, const double t[4], uint32_t anchor)
{
    size_t need = m->tangent_count + 1;
    if (m->tangent_count >= UINT32_MAX)
        return false;
    if (need > m->tangent_cap) {
        size_t cap = m->tangent_cap, cap2 = m->tangent_cap;
        if (!ffd_grow((void **)&m->tangents, &cap, need, 4 * sizeof(double)) ||
            !ffd_grow((void **)&m->tangent_anchors, &cap2, cap, sizeof(uint32_t)))
            return false;
        m->tangent_cap = cap;
    }
    memcpy(m->tangents + 4 * m->tangent_count, t, 4 * sizeof(double));
    m->tangent_anchors[m->tangent_count++] = anchor;
    return true;
}

bool ffd_mesh_push_index(ffd_mesh *m, uint32_t index)
{
    if (m->index_count >= UINT32_MAX ||
        !ffd_grow((void **)&m->face_indices, &m->index_cap, m->index_count + 1, sizeof(uint32_t)))
        return false;
    m->face_indices[m->index_count++] = index;
    return true;
}

bool ffd_mesh_end_face(ffd_mesh *m)
{
    if (!grow_faces(m, m->face_count + 1))
        return false;
    m->face_offsets[++m->face_count] = (uint32_t)m->index_count;
    return true;
}

/* ======================================================================
 * Numbers
 * ====================================================================== */

/* strtod, with Clinger's fast path first: a plain decimal
 * [sign] digits [. digits] [e [sign] digits] whose significand has at most 19
 * digits, is at most 2^53, and whose exponent is within +-22 is one exact
 * integer times or over one exact power of ten, a single correctly rounded
 * operation, so it equals strtod's result. The token must end where a number
 * ends for every reader (whitespace, '#', NUL); anything else (hex, inf, nan,
 * "1e" with no digits, long significands) goes to strtod itself. */
double ffd_strtod(const char *s, char **end)
{
    static const double ten[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                   1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                   1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    const char *p = s;
    bool negative = *p == '-';
    if (*p == '-' || *p == '+')
        p++;
    uint64_t m = 0;
    int digits = 0, exp10 = 0, seen = 0;
    for (; *p >= '0' && *p <= '9'; p++, seen++) {
        if (m == 0 && *p == '0')
            continue; /* leading zeros carry no digit */
        if (++digits > 19)
            goto slow;
        m = 10 * m + (uint64_t)(*p - '0');
    }
    if (*p == '.') {
        for (p++; *p >= '0' && *p <= '9'; p++, seen++) {
            exp10--;
            if (m == 0 && *p == '0')
                continue;
            if (++digits > 19)
                goto slow;
            m = 10 * m + (uint64_t)(*p - '0');
        }
    }
    if (!seen)
        goto slow;
    if (*p == 'e' || *p == 'E') {
        const char *q = p + 1;
        bool eneg = *q == '-';
        if (*q == '-' || *q == '+')
            q++;
        if (!(*q >= '0' && *q <= '9'))
            goto slow;
        int e = 0;
        for (; *q >= '0' && *q <= '9'; q++) {
            if (e > 1000)
                goto slow;
            e = 10 * e + (*q - '0');
        }
        exp10 += eneg ? -e : e;
        p = q;
    }
    if (!(*p == '\0' || ffd_is_space(*p) || *p == '#'))
        goto slow;
    if (m > (UINT64_C(1) << 53) || exp10 < -22 || exp10 > 22)
        goto slow;
    double v = (double)m;
    v = exp10 >= 0 ? v * ten[exp10] : v / ten[-exp10];
    if (end)
        *end = (char *)p;
    return negative ? -v : v;
slow:
    return strtod(s, end);
}

int ffd_parse_number(const char **p, const char *end, bool hash_ends, double *out)
{
    const char *s = *p;
    if (s >= end)
        return 0;
    char c = *s;
    /* strtod would skip leading whitespace (newlines included); refuse it here. */
    if (!(isdigit((unsigned char)c) || c == '-' || c == '+' || c == '.' || c == 'n' ||
          c == 'N' || c == 'i' || c == 'I'))
        return 0;
    char *e;
    double v = ffd_strtod(s, &e);
    if (e == s)
        return 0;
    if (e > end) /* cannot happen with a NUL at end, kept as a guard */
        e = (char *)end;
    if (e < end && !ffd_is_space(*e) && !(hash_ends && *e == '#')) {
        *p = e;
        return -1;
    }
    *out = v;
    *p = e;
    return 1;
}

/* Shortest round-trip printing without printf per value.
 *
 * The output is exactly that of the loop "the first of %.<pmin>g ..
 * %.<pmax>g that reads back as v" (glibc's printf is exact, strtod correctly
 * rounded), computed from integers: the P significant digits of |v| are the
 * nearest integer N to T = |v| 10^(P-1-X), X = floor(log10 |v|). T is one
 * long double product or quotient (10^k is exact in a 64-bit significand for
 * k <= 27), so |T - exact| <= 10^P 2^-64 < 0.006: N is the correctly rounded
 * digit string unless T is within 0.01 of a half, where the exact tie rules
 * matter and the printf loop decides (rare). Whether N 10^e reads back as v
 * is decided exactly by Clinger's fast path (N < 2^53 and |e| <= 22: one
 * correctly rounded double operation); otherwise strtod decides. Values
 * outside the exact range of the scaling (|X| large), NaN and Inf take the
 * printf loop too. */

static int format_printf(char *buf, double v, int pmin, int pmax, bool is_float)
{
    int n = 0;
    for (int prec = pmin; prec <= pmax; prec++) {
        n = snprintf(buf, 32, "%.*g", prec, v);
        if (is_float ? strtof(buf, NULL) == (float)v : strtod(buf, NULL) == v)
            break;
    }
    return n;
}

#if LDBL_MANT_DIG >= 64
static const long double ten_ld[28] = {
    1e0L,  1e1L,  1e2L,  1e3L,  1e4L,  1e5L,  1e6L,  1e7L,  1e8L,  1e9L,
    1e10L, 1e11L, 1e12L, 1e13L, 1e14L, 1e15L, 1e16L, 1e17L, 1e18L, 1e19L,
    1e20L, 1e21L, 1e22L, 1e23L, 1e24L, 1e25L, 1e26L, 1e27L};
static const double ten_d[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                 1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/* |v| 10^k in long double (one rounding); |k| <= 27. */
static long double scale_ld(double a, int k)
{
    return k >= 0 ? (long double)a * ten_ld[k] : (long double)a / ten_ld[-k];
}

/* "%.Pg" of sign * N 10^(X-P+1), N holding exactly P digits. */
static int put_g(char *buf, bool negative, uint64_t N, int P, int X)
{
    char d[20];
    for (int i = P - 1; i >= 0; i--) {
        d[i] = (char)('0' + N % 10);
        N /= 10;
    }
    int L = P;
    while (L > 1 && d[L - 1] == '0')
        L--;
    char *o = buf;
    if (negative)
        *o++ = '-';
    if (X < -4 || X >= P) {
        *o++ = d[0];
        if (L > 1) {
            *o++ = '.';
            memcpy(o, d + 1, (size_t)(L - 1));
            o += L - 1;
        }
        *o++ = 'e';
        *o++ = X < 0 ? '-' : '+';
        int e = X < 0 ? -X : X;
        if (e >= 100)
            *o++ = (char)('0' + e / 100);
        *o++ = (char)('0' + e / 10 % 10);
        *o++ = (char)('0' + e % 10);
    } else if (X >= 0) {
        for (int i = 0; i <= X; i++)
            *o++ = i < L ? d[i] : '0';
        if (L > X + 1) {
            *o++ = '.';
            memcpy(o, d + X + 1, (size_t)(L - X - 1));
            o += L - X - 1;
        }
    } else {
        *o++ = '0';
        *o++ = '.';
        for (int i = 0; i < -X - 1; i++)
            *o++ = '0';
        memcpy(o, d, (size_t)L);
        o += L;
    }
    *o = '\0';
    return (int)(o - buf);
}
#endif

/* Whether long double arithmetic really carries a 64-bit significand at run
 * time: the type says so, but an emulator (valgrind computes x87 operations
 * in double precision) or an unusual FPU control word may not, and then the
 * error bound above does not hold. Checked on every call (a few operations),
 * so that no state is shared between threads. */
static bool long_double_is_extended(void)
{
    volatile long double one = 1.0L, tiny = LDBL_EPSILON;
    return one + tiny != one && LDBL_EPSILON <= 0x1p-63L;
}

static int format_shortest(char *buf, double v, int pmin, int pmax, bool is_float)
{
#if LDBL_MANT_DIG >= 64
    if (!long_double_is_extended())
        return format_printf(buf, v, pmin, pmax, is_float);
    double a = fabs(v);
    if (a == 0.0) {
        memcpy(buf, signbit(v) ? "-0" : "0", signbit(v) ? 3 : 2);
        return signbit(v) ? 2 : 1;
    }
    /* the scaling by 10^(P-1-X) stays within 10^27 for every P */
    if (!(a >= 1e-10 && a < 1e26))
        return format_printf(buf, v, pmin, pmax, is_float);
    int X = (int)floor(log10(a));
    for (int tries = 0;; tries++) { /* log10 may be one off near a power of ten */
        long double S = scale_ld(a, pmax - 1 - X);
        if (S < ten_ld[pmax - 1])
            X--;
        else if (S >= ten_ld[pmax])
            X++;
        else
            break;
        if (tries == 2)
            return format_printf(buf, v, pmin, pmax, is_float);
    }
    for (int P = pmin; P <= pmax; P++) {
        long double T = scale_ld(a, P - 1 - X);
        long double fl = floorl(T), fr = T - fl;
        if (fabsl(fr - 0.5L) < 0.01L)
            return format_printf(buf, v, pmin, pmax, is_float);
        uint64_t N = (uint64_t)fl + (fr > 0.5L);
        int Xp = X;
        if (N >= (uint64_t)ten_d[P]) { /* rounded up to 10^P */
            N /= 10;
            Xp++;
        }
        int n = put_g(buf, signbit(v), N, P, Xp);
        if (P == pmax)
            return n; /* the loop's last precision is taken as it is */
        int e = Xp - P + 1;
        bool back;
        if (N < (UINT64_C(1) << 53) && e >= -22 && e <= 22) {
            double d = e >= 0 ? (double)N * ten_d[e] : (double)N / ten_d[-e];
            if (!is_float) {
                back = d == a;
            } else {
                /* decimal -> double -> float rounds twice; it differs from
                 * decimal -> float only when d lands on a float midpoint */
                uint64_t bits;
                memcpy(&bits, &d, 8);
                if ((bits & ((UINT64_C(1) << 29) - 1)) == (UINT64_C(1) << 28))
                    back = strtof(buf, NULL) == (float)v;
                else
                    back = (float)d == (float)a;
            }
        } else {
            back = is_float ? strtof(buf, NULL) == (float)v : strtod(buf, NULL) == v;
        }
        if (back)
            return n;
    }
    return 0; /* not reached: P == pmax returns */
#else
    return format_printf(buf, v, pmin, pmax, is_float);
#endif
}

int ffd_format_double(char *buf, double v)
{
    return format_shortest(buf, v, 15, 17, false);
}

int ffd_format_float(char *buf, float v)
{
    return format_shortest(buf, (double)v, 6, 9, true);
}

size_t ffd_span_kind_size(int kind)
{
    switch (kind) {
    case FFD_SPAN_I8:
    case FFD_SPAN_U8: return 1;
    case FFD_SPAN_I16:
    case FFD_SPAN_U16: return 2;
    case FFD_SPAN_I32:
    case FFD_SPAN_U32:
    case FFD_SPAN_F32: return 4;
    case FFD_SPAN_F64: return 8;
    default: return 0;
    }
}

static uint64_t load_bits(const unsigned char *p, size_t n, bool big_endian)
{
    uint64_t v = 0;
    for (size_t i = 0; i < n; i++) {
        size_t k = big_endian ? i : n - 1 - i;
        v = (v << 8) | p[k];
    }
    return v;
}

static void store_bits(unsigned char *p, size_t n, bool big_endian, uint64_t v)
{
    for (size_t i = 0; i < n; i++) {
        size_t k = big_endian ? n - 1 - i : i;
        p[k] = (unsigned char)(v & 0xff);
        v >>= 8;
    }
}

double ffd_read_scalar(const unsigned char *p, int kind, bool big_endian)
{
    uint64_t b = load_bits(p, ffd_span_kind_size(kind), big_endian);
    switch (kind) {
    case FFD_SPAN_I8: return (double)(int8_t)(uint8_t)b;
    case FFD_SPAN_U8: return (double)(uint8_t)b;
    case FFD_SPAN_I16: return (double)(int16_t)(uint16_t)b;
    case FFD_SPAN_U16: return (double)(uint16_t)b;
    case FFD_SPAN_I32: return (double)(int32_t)(uint32_t)b;
    case FFD_SPAN_U32: return (double)(uint32_t)b;
    case FFD_SPAN_F32: {
        uint32_t u = (uint32_t)b;
        float f;
        memcpy(&f, &u, 4);
        return (double)f;
    }
    case FFD_SPAN_F64: {
        double d;
        memcpy(&d, &b, 8);
        return d;
    }
    default: return 0.0;
    }
}

static double clamp_round(double v, double lo, double hi)
{
    v = nearbyint(v);
    if (!(v >= lo)) /* NaN goes low */
        return lo;
    return v > hi ? hi : v;
}

bool ffd_scalar_fits(int kind, double v)
{
    switch (kind) {
    case FFD_SPAN_I8: return v >= INT8_MIN - 0.5 && v < INT8_MAX + 0.5;
    case FFD_SPAN_U8: return v >= -0.5 && v < UINT8_MAX + 0.5;
    case FFD_SPAN_I16: return v >= INT16_MIN - 0.5 && v < INT16_MAX + 0.5;
    case FFD_SPAN_U16: return v >= -0.5 && v < UINT16_MAX + 0.5;
    case FFD_SPAN_I32: return v >= INT32_MIN - 0.5 && v < INT32_MAX + 0.5;
    case FFD_SPAN_U32: return v >= -0.5 && v < UINT32_MAX + 0.5;
    case FFD_SPAN_F32: return isfinite(v) && fabs(v) <= FLT_MAX;
    default: return isfinite(v);
    }
}

void ffd_write_scalar(unsigned char *p, int kind, bool big_endian, double v)
{
    uint64_t b = 0;
    switch (kind) {
    case FFD_SPAN_I8: b = (uint8_t)(int8_t)clamp_round(v, INT8_MIN, INT8_MAX); break;
    case FFD_SPAN_U8: b = (uint8_t)clamp_round(v, 0, UINT8_MAX); break;
    case FFD_SPAN_I16: b = (uint16_t)(int16_t)clamp_round(v, INT16_MIN, INT16_MAX); break;
    case FFD_SPAN_U16: b = (uint16_t)clamp_round(v, 0, UINT16_MAX); break;
    case FFD_SPAN_I32: b = (uint32_t)(int32_t)clamp_round(v, INT32_MIN, INT32_MAX); break;
    case FFD_SPAN_U32: b = (uint32_t)clamp_round(v, 0, UINT32_MAX); break;
    case FFD_SPAN_F32: {
        float f = (float)v;
        uint32_t u;
        memcpy(&u, &f, 4);
        b = u;
        break;
    }
    case FFD_SPAN_F64: memcpy(&b, &v, 8); break;
    default: return;
    }
    store_bits(p, ffd_span_kind_size(kind), big_endian, b);
}

double ffd_span_value(const ffd_mesh *m, const ffd_span *s)
{
    if (s->kind == FFD_SPAN_TEXT)
        return ffd_strtod((const char *)m->src + s->offset, NULL);
    return ffd_read_scalar(m->src + s->offset, s->kind, m->encoding == FFD_ENCODING_BINARY_BE);
}

size_t ffd_span_length(const ffd_mesh *m, const ffd_span *s)
{
    if (s->kind != FFD_SPAN_TEXT)
        return ffd_span_kind_size(s->kind);
    const char *p = (const char *)m->src + s->offset;
    char *e;
    ffd_strtod(p, &e);
    return (size_t)(e - p);
}

/* ======================================================================
 * Creation, accessors, reading
 * ====================================================================== */

static bool all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return false;
    return true;
}

ffd_status ffd_mesh_create(const double *positions, size_t vertex_count,
                           const uint32_t *face_offsets, const uint32_t *face_indices,
                           size_t face_count, ffd_mesh **out, ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_create: out is NULL");
    *out = NULL;
    if (vertex_count && !positions)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_create: positions is NULL");
    if (vertex_count > UINT32_MAX || vertex_count > SIZE_MAX / 24)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_create: too many vertices");
    if (face_count && (!face_offsets || !face_indices))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_create: faces are NULL");
    if (vertex_count && !all_finite(positions, 3 * vertex_count))
        return ffd_fail(err, FFD_ERR_NONFINITE, "ffd_mesh_create: non-finite position");
    if (face_count) {
        if (face_offsets[0] != 0)
            return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_create: face_offsets[0] must be 0");
        for (size_t f = 0; f < face_count; f++) {
            if (face_offsets[f + 1] < face_offsets[f] ||
                face_offsets[f + 1] - face_offsets[f] < 3)
                return ffd_fail(err, FFD_ERR_INVALID,
                                "ffd_mesh_create: face %zu has fewer than 3 vertices", f);
        }
        for (size_t i = 0; i < face_offsets[face_count]; i++)
            if (face_indices[i] >= vertex_count)
                return ffd_fail(err, FFD_ERR_RANGE,
                                "ffd_mesh_create: face index %u out of range (%zu vertices)",
                                face_indices[i], vertex_count);
    }
    ffd_mesh *m = ffd_mesh_alloc(FFD_FORMAT_AUTO);
    size_t nidx = face_count ? face_offsets[face_count] : 0;
    if (!m || !ffd_mesh_reserve(m, vertex_count, face_count, nidx, 0)) {
        ffd_mesh_destroy(m);
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_create: out of memory");
    }
    if (vertex_count)
        memcpy(m->positions, positions, 3 * sizeof(double) * vertex_count);
    m->vertex_count = vertex_count;
    if (face_count) {
        memcpy(m->face_offsets, face_offsets, sizeof(uint32_t) * (face_count + 1));
        memcpy(m->face_indices, face_indices, sizeof(uint32_t) * nidx);
    }
    m->face_count = face_count;
    m->index_count = nidx;
    *out = m;
    return FFD_OK;
}

ffd_format ffd_mesh_source_format(const ffd_mesh *mesh) { return mesh ? mesh->format : FFD_FORMAT_AUTO; }
size_t ffd_mesh_vertex_count(const ffd_mesh *mesh) { return mesh ? mesh->vertex_count : 0; }
size_t ffd_mesh_face_count(const ffd_mesh *mesh) { return mesh ? mesh->face_count : 0; }
const double *ffd_mesh_positions(const ffd_mesh *mesh) { return mesh ? mesh->positions : NULL; }
const uint32_t *ffd_mesh_face_offsets(const ffd_mesh *mesh) { return mesh ? mesh->face_offsets : NULL; }
const uint32_t *ffd_mesh_face_indices(const ffd_mesh *mesh) { return mesh ? mesh->face_indices : NULL; }
size_t ffd_mesh_normal_count(const ffd_mesh *mesh) { return mesh ? mesh->normal_count : 0; }

const double *ffd_mesh_normals(const ffd_mesh *mesh)
{
    return mesh && mesh->normal_count ? mesh->normals : NULL;
}

const uint32_t *ffd_mesh_normal_anchors(const ffd_mesh *mesh)
{
    return mesh && mesh->normal_count ? mesh->normal_anchors : NULL;
}

ffd_format ffd_format_from_path(const char *path)
{
    if (!path)
        return FFD_FORMAT_AUTO;
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    if (!dot || (slash && dot < slash))
        return FFD_FORMAT_AUTO;
    const ffd_mesh_codec *codec = ffd_mesh_codec_for_extension(dot + 1);
    return codec ? codec->format : FFD_FORMAT_AUTO;
}

/* source_is_path: name is the file's path, so a codec may read the files
 * its format keeps beside it (glTF's external buffers). */
static ffd_status read_owned(unsigned char *data, size_t size, ffd_format format,
                             const char *name, bool source_is_path, ffd_mesh **out,
                             ffd_error *err)
{
    *out = NULL;
    name = ffd_name_or(name, "<memory>");
    const ffd_mesh_codec *codec = ffd_mesh_codec_find(format);
    if (!codec) {
        char list[FFD_MESH_CODEC_LIST_SIZE];
        ffd_free(data);
        return ffd_fail(err, FFD_ERR_INVALID, "%s: unknown mesh format (expected %s)", name,
                        ffd_mesh_codec_list(false, list, sizeof list));
    }
    if (size == 0) {
        ffd_free(data);
        return ffd_fail(err, FFD_ERR_PARSE, "%s: byte 0: empty file, expected a mesh", name);
    }
    ffd_mesh *m = ffd_mesh_alloc(format);
    if (!m) {
        ffd_free(data);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    }
    m->src = data;
    m->src_size = size;
    m->source_is_path = source_is_path;
    ffd_progress progress;
    ffd_progress_begin(&progress, "reading");
    ffd_status s = codec->read(m, name, err);
    if (s != FFD_OK) {
        ffd_mesh_destroy(m);
        return s;
    }
    ffd_progress_end(&progress);
    *out = m;
    return FFD_OK;
}

ffd_status ffd_mesh_read_owned(unsigned char *data, size_t size, ffd_format format,
                               const char *name, ffd_mesh **out, ffd_error *err)
{
    return read_owned(data, size, format, name, false, out, err);
}

ffd_status ffd_mesh_read_memory(const void *data, size_t size, ffd_format format,
                                const char *name, ffd_mesh **out, ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_read_memory: out is NULL");
    *out = NULL;
    if (!data && size)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_read_memory: data is NULL");
    if (size == SIZE_MAX)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: too large", ffd_name_or(name, "<memory>"));
    unsigned char *copy = ffd_malloc(size + 1);
    if (!copy)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory copying %zu bytes",
                        ffd_name_or(name, "<memory>"), size);
    if (size)
        memcpy(copy, data, size);
    copy[size] = 0;
    return ffd_mesh_read_owned(copy, size, format, name, out, err);
}

ffd_status ffd_mesh_read(const char *path, ffd_mesh **out, ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_read: out is NULL");
    *out = NULL;
    if (!path)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_read: path is NULL");
    ffd_format format = ffd_format_from_path(path);
    if (format == FFD_FORMAT_AUTO) {
        char list[FFD_MESH_CODEC_LIST_SIZE];
        return ffd_fail(err, FFD_ERR_INVALID, "%s: unknown mesh file extension (expected %s)", path,
                        ffd_mesh_codec_list(false, list, sizeof list));
    }
    unsigned char *data;
    size_t size;
    ffd_status s = ffd_read_file(path, &data, &size, err);
    if (s != FFD_OK)
        return s;
    return read_owned(data, size, format, path, true, out, err);
}

/* ======================================================================
 * Positions and normals
 * ====================================================================== */

static void cross(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static double norm3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

void ffd_triangle_normal(const double *a, const double *b, const double *c, double n[3])
{
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    cross(u, v, n);
    double l = norm3(n);
    if (l > 0 && isfinite(l)) {
        n[0] /= l;
        n[1] /= l;
        n[2] /= l;
    } else {
        n[0] = n[1] = n[2] = 0.0;
    }
}

/* Rescales t to length len; keeps old when t is ~zero relative to scale. */
static void set_scaled(double *normal, const double t[3], double scale)
{
    double len = norm3(normal), tl = norm3(t);
    if (!(tl > 1e-12 * scale) || !isfinite(tl))
        return;
    for (int k = 0; k < 3; k++)
        normal[k] = t[k] * (len / tl);
}

/* Whether J (row-major 3x3) is exactly the identity (== : -0.0 counts as 0). */
static bool is_identity(const double *J)
{
    return J[0] == 1.0 && J[4] == 1.0 && J[8] == 1.0 && J[1] == 0.0 && J[2] == 0.0 &&
           J[3] == 0.0 && J[5] == 0.0 && J[6] == 0.0 && J[7] == 0.0;
}

/* Tangents (glTF TANGENT) after the normals: at a vertex whose surface
 * changed, t' = J t (a tangent vector is carried by J itself, unlike the
 * normal's cofactor), made orthogonal to the vertex's updated normal n
 * (Gram-Schmidt: t' - (t'.n / n.n) n) and rescaled to unit length; w (the
 * handedness) is kept. Without Jacobians (GFFD) the fallback is the old
 * tangent projected onto the plane of the new normal. A tangent is left as
 * it is where its Jacobian is exactly the identity, where its anchor and the
 * faces around it did not move, and where the result degenerates (t' ~ 0 or
 * along n). normal_of[v]: the normal anchored at v, or FFD_NO_ANCHOR. */
static void update_tangents(ffd_mesh *mesh, const double *jacobians, const unsigned char *moved,
                            const uint32_t *normal_of)
{
    size_t nv = mesh->vertex_count;
    for (size_t i = 0; i < mesh->tangent_count; i++) {
        uint32_t v = mesh->tangent_anchors[i];
        if (v == FFD_NO_ANCHOR || v >= nv || !moved[v])
            continue;
        double *T = mesh->tangents + 4 * i, t[3] = {T[0], T[1], T[2]};
        double scale = norm3(t);
        if (jacobians) {
            const double *J = jacobians + 9 * (size_t)v;
            if (is_identity(J))
                continue;
            double jn = 0;
            for (int k = 0; k < 9; k++)
                jn += J[k] * J[k];
            for (int r = 0; r < 3; r++)
                t[r] = J[3 * r] * T[0] + J[3 * r + 1] * T[1] + J[3 * r + 2] * T[2];
            scale *= sqrt(jn);
        }
        uint32_t ni = normal_of ? normal_of[v] : FFD_NO_ANCHOR;
        if (ni == FFD_NO_ANCHOR && !jacobians)
            continue; /* no normal to project onto: nothing changes it */
        if (ni != FFD_NO_ANCHOR) {
            const double *n = mesh->normals + 3 * (size_t)ni;
            double nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
            if (nn > 0 && isfinite(nn)) {
                double c = (t[0] * n[0] + t[1] * n[1] + t[2] * n[2]) / nn;
                for (int k = 0; k < 3; k++)
                    t[k] -= c * n[k];
            }
        }
        double l = norm3(t);
        if (!(l > 1e-12 * scale) || !isfinite(l))
            continue;
        for (int k = 0; k < 3; k++)
            T[k] = t[k] / l;
    }
}

/* Identity is kept at the level of the stored values: a coordinate whose new
 * value equals the stored one numerically (==, so -0.0 and +0.0 are equal)
 * keeps the stored value, and with it the bytes the writer copies from the
 * source ("-0.000000" stays). moved[v] says whether any coordinate of vertex
 * v changed. A normal is left alone (value and bytes) where the deformation
 * is the identity around its anchor: its Jacobian is exactly the identity,
 * or neither the anchor nor any corner of a face around it moved (the
 * surface there is unchanged, so its normal is too). */
ffd_status ffd_mesh_set_positions(ffd_mesh *mesh, const double *positions,
                                  const double *jacobians, ffd_error *err)
{
    if (!mesh)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_set_positions: mesh is NULL");
    size_t nv = mesh->vertex_count;
    if (nv == 0)
        return FFD_OK;
    if (!positions)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_set_positions: positions is NULL");
    for (size_t i = 0; i < 3 * nv; i++)
        if (!isfinite(positions[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE,
                            "ffd_mesh_set_positions: position %zu coordinate %zu is not finite",
                            i / 3, i % 3);
    if (jacobians && !mesh->facet_normals && (mesh->normal_count || mesh->tangent_count))
        for (size_t i = 0; i < 9 * nv; i++)
            if (!isfinite(jacobians[i]))
                return ffd_fail(err, FFD_ERR_NONFINITE,
                                "ffd_mesh_set_positions: jacobian of vertex %zu is not finite",
                                i / 9);
    /* moved[v]: bit 0 the vertex moved, bit 1 a corner of a face around it moved */
    unsigned char *moved = NULL;
    double *acc = NULL;
    uint32_t *normal_of = NULL; /* per vertex: the normal anchored there (tangents) */
    if (mesh->normal_count || mesh->tangent_count) {
        moved = ffd_calloc(nv, 1);
        if (mesh->normal_count && !mesh->facet_normals && !jacobians)
            acc = ffd_calloc(nv, 3 * sizeof(double));
        if (mesh->tangent_count && mesh->normal_count)
            normal_of = ffd_malloc_array(nv, sizeof *normal_of);
        if (!moved || (mesh->normal_count && !mesh->facet_normals && !jacobians && !acc) ||
            (mesh->tangent_count && mesh->normal_count && !normal_of)) {
            ffd_free(moved);
            ffd_free(acc);
            ffd_free(normal_of);
            return ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_set_positions: out of memory");
        }
    }
    for (size_t v = 0; v < nv; v++) {
        double *P = mesh->positions + 3 * v;
        const double *Q = positions + 3 * v;
        bool changed = false;
        for (int d = 0; d < 3; d++)
            if (Q[d] != P[d]) {
                P[d] = Q[d];
                changed = true;
            }
        if (moved && changed)
            moved[v] = 1;
    }
    if (!moved)
        return FFD_OK;
    const double *P = mesh->positions;
    if (mesh->facet_normals) {
        /* a facet whose corners did not move keeps its stored normal (and bytes) */
        for (size_t f = 0; f < mesh->normal_count && f < mesh->face_count; f++) {
            const uint32_t *ix = mesh->face_indices + mesh->face_offsets[f];
            if (moved[ix[0]] || moved[ix[1]] || moved[ix[2]])
                ffd_triangle_normal(P + 3 * ix[0], P + 3 * ix[1], P + 3 * ix[2],
                                    mesh->normals + 3 * f);
        }
        goto done;
    }
    for (size_t f = 0; f < mesh->face_count; f++) {
        uint32_t b = mesh->face_offsets[f], e = mesh->face_offsets[f + 1];
        bool any = false;
        for (uint32_t k = b; k < e && !any; k++)
            any = moved[mesh->face_indices[k]] & 1;
        if (any)
            for (uint32_t k = b; k < e; k++)
                moved[mesh->face_indices[k]] |= 2;
    }
    if (acc) {
        /* Area-weighted: the polygon's area vector (Newell) added to each corner. */
        for (size_t f = 0; f < mesh->face_count; f++) {
            uint32_t b = mesh->face_offsets[f], e = mesh->face_offsets[f + 1];
            double a[3] = {0, 0, 0};
            for (uint32_t k = b; k < e; k++) {
                const double *p = P + 3 * mesh->face_indices[k];
                const double *q = P + 3 * mesh->face_indices[k + 1 < e ? k + 1 : b];
                double c[3];
                cross(p, q, c);
                a[0] += c[0];
                a[1] += c[1];
                a[2] += c[2];
            }
            for (uint32_t k = b; k < e; k++)
                for (int d = 0; d < 3; d++)
                    acc[3 * mesh->face_indices[k] + d] += 0.5 * a[d];
        }
        for (size_t i = 0; i < mesh->normal_count; i++) {
            uint32_t v = mesh->normal_anchors[i];
            if (v == FFD_NO_ANCHOR || v >= nv || !moved[v])
                continue;
            set_scaled(mesh->normals + 3 * i, acc + 3 * v, 1e-300);
        }
        goto done;
    }
    for (size_t i = 0; i < mesh->normal_count; i++) {
        uint32_t v = mesh->normal_anchors[i];
        if (v == FFD_NO_ANCHOR || v >= nv || !moved[v])
            continue;
        const double *J = jacobians + 9 * (size_t)v;
        if (is_identity(J))
            continue;
        /* Cofactor matrix = det(J) J^-T: maps normals, defined for singular J too. */
        double C[9] = {
            J[4] * J[8] - J[5] * J[7], J[5] * J[6] - J[3] * J[8], J[3] * J[7] - J[4] * J[6],
            J[2] * J[7] - J[1] * J[8], J[0] * J[8] - J[2] * J[6], J[1] * J[6] - J[0] * J[7],
            J[1] * J[5] - J[2] * J[4], J[2] * J[3] - J[0] * J[5], J[0] * J[4] - J[1] * J[3]};
        double *n = mesh->normals + 3 * i;
        double t[3];
        for (int r = 0; r < 3; r++)
            t[r] = C[3 * r] * n[0] + C[3 * r + 1] * n[1] + C[3 * r + 2] * n[2];
        double jn = 0;
        for (int k = 0; k < 9; k++)
            jn += J[k] * J[k];
        set_scaled(n, t, jn * norm3(n));
    }
done:
    if (mesh->tangent_count) {
        if (normal_of) {
            for (size_t v = 0; v < nv; v++)
                normal_of[v] = FFD_NO_ANCHOR;
            for (size_t i = mesh->normal_count; i-- > 0;)
                if (mesh->normal_anchors[i] < nv)
                    normal_of[mesh->normal_anchors[i]] = (uint32_t)i;
        }
        update_tangents(mesh, mesh->facet_normals ? NULL : jacobians, moved, normal_of);
    }
    ffd_free(normal_of);
    ffd_free(acc);
    ffd_free(moved);
    return FFD_OK;
}

/* ======================================================================
 * Info
 * ====================================================================== */

typedef struct {
    double x, y, z;
    uint32_t i;
} keyed_point;

static int cmp_point(const void *pa, const void *pb)
{
    const keyed_point *a = pa, *b = pb;
    if (a->x != b->x)
        return a->x < b->x ? -1 : 1;
    if (a->y != b->y)
        return a->y < b->y ? -1 : 1;
    if (a->z != b->z)
        return a->z < b->z ? -1 : 1;
    return (a->i > b->i) - (a->i < b->i);
}

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

ffd_status ffd_mesh_compute_info(const ffd_mesh *mesh, ffd_mesh_info *info, ffd_error *err)
{
    if (!mesh || !info)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_compute_info: NULL argument");
    memset(info, 0, sizeof *info);
    size_t nv = mesh->vertex_count;
    info->vertex_count = nv;
    info->face_count = mesh->face_count;
    info->corner_count = mesh->index_count;
    info->normal_count = mesh->normal_count;
    info->texcoord_count = mesh->texcoord_count;
    if (nv) {
        for (int d = 0; d < 3; d++)
            info->bbox_min[d] = info->bbox_max[d] = mesh->positions[d];
        for (size_t i = 1; i < nv; i++)
            for (int d = 0; d < 3; d++) {
                double v = mesh->positions[3 * i + d];
                if (v < info->bbox_min[d])
                    info->bbox_min[d] = v;
                if (v > info->bbox_max[d])
                    info->bbox_max[d] = v;
            }
    }
    keyed_point *pts = ffd_malloc_array(nv ? nv : 1, sizeof *pts);
    uint32_t *weld = ffd_malloc_array(nv ? nv : 1, sizeof *weld);
    uint64_t *edges = ffd_malloc_array(mesh->index_count ? mesh->index_count : 1, sizeof *edges);
    if (!pts || !weld || !edges) {
        ffd_free(pts);
        ffd_free(weld);
        ffd_free(edges);
        return ffd_fail(err, FFD_ERR_NOMEM, "ffd_mesh_compute_info: out of memory");
    }
    for (size_t i = 0; i < nv; i++) {
        pts[i].x = mesh->positions[3 * i];
        pts[i].y = mesh->positions[3 * i + 1];
        pts[i].z = mesh->positions[3 * i + 2];
        pts[i].i = (uint32_t)i;
    }
    qsort(pts, nv, sizeof *pts, cmp_point);
    size_t welded = 0;
    for (size_t i = 0; i < nv; i++) {
        if (i == 0 || pts[i].x != pts[i - 1].x || pts[i].y != pts[i - 1].y ||
            pts[i].z != pts[i - 1].z)
            welded++;
        weld[pts[i].i] = (uint32_t)(welded - 1);
    }
    info->welded_vertex_count = welded;
    /* Edges follow the file's own vertex sharing; STL has none (every facet
     * has its own corners), so its edges are taken between welded positions.
     * Seams a file leaves unwelded (teapot patches) stay boundaries. */
    if (!mesh->facet_normals)
        for (size_t i = 0; i < nv; i++)
            weld[i] = (uint32_t)i;
    size_t ne = 0;
    for (size_t f = 0; f < mesh->face_count; f++) {
        uint32_t b = mesh->face_offsets[f], e = mesh->face_offsets[f + 1];
        for (uint32_t k = b; k < e; k++) {
            uint32_t u = weld[mesh->face_indices[k]];
            uint32_t v = weld[mesh->face_indices[k + 1 < e ? k + 1 : b]];
            if (u == v)
                continue; /* degenerate edge after welding */
            if (u > v) {
                uint32_t t = u;
                u = v;
                v = t;
            }
            edges[ne++] = ((uint64_t)u << 32) | v;
        }
    }
    qsort(edges, ne, sizeof *edges, cmp_u64);
    for (size_t i = 0; i < ne;) {
        size_t j = i + 1;
        while (j < ne && edges[j] == edges[i])
            j++;
        info->edge_count++;
        if (j - i == 1)
            info->boundary_edge_count++;
        else if (j - i >= 3)
            info->nonmanifold_edge_count++;
        i = j;
    }
    info->closed = mesh->face_count > 0 && info->boundary_edge_count == 0;
    ffd_free(pts);
    ffd_free(weld);
    ffd_free(edges);
    return FFD_OK;
}
