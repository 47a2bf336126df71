/* mesh_xyz — point sets as text, one point per line (mesh_codec.h,
 * docs/volume.md "Point sets").
 *
 * Two spellings share the codec: .xyz, numbers separated by blanks, and
 * .csv, fields separated by commas with an optional first line of column
 * names. The first content line tells them apart (a comma: CSV), so a file
 * read from memory needs no extension. Every point line starts with x y z;
 * further columns are kept in the line (lossless: only coordinate bytes are
 * ever rewritten) and, when every point has the same number of numeric
 * extra columns, become point fields (named by the CSV header, else
 * "column_<k>", k counted from 1 over all columns). Lines starting with '#'
 * are comments and blank lines are allowed anywhere; in .xyz a '#' after
 * the numbers also starts a comment. The mesh has vertices only: no faces,
 * no cells; every method binds the points.
 *
 * Hand-written because no library keeps the byte offset of each number,
 * which is what lets a deformed point set differ from its source only in
 * the coordinates that moved. */
#include "mesh_cells.h"
#include "mesh_codec.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

/* What the codec remembers of its source: the spelling, for write_file. */
typedef struct {
    bool csv;
} xyz_state;

static void state_free(void *s)
{
    ffd_free(s);
}

typedef struct {
    const char *name;
    const char *s, *end;
    bool csv;
    size_t line;
} xyz_ctx;

static ffd_status bad_value(const xyz_ctx *c, const char *t, const char *e, const char *what,
                            ffd_error *err)
{
    int len = 0;
    while (t + len < e && len < 20 && t[len] != '\n' && t[len] != '\r')
        len++;
    if (len == 0)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s, found an empty field", c->name,
                        c->line, what);
    return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected %s, found '%.*s'", c->name, c->line,
                    what, len, t);
}

/* The next field of a data line at *p (content end e): [*b, *fe), blanks
 * trimmed; *p moves past its separator. false when the line has no more. */
static bool next_field(const xyz_ctx *c, const char **p, const char *e, const char **b,
                       const char **fe)
{
    if (c->csv) {
        if (*p > e) /* past the last field */
            return false;
        const char *q = ffd_text_skip_blanks(*p, e);
        const char *comma = memchr(q, ',', (size_t)(e - q));
        *b = q;
        *fe = comma ? comma : e;
        while (*fe > *b && ffd_is_blank((*fe)[-1]))
            (*fe)--;
        *p = comma ? comma + 1 : e + 1;
        return true;
    }
    const char *q = ffd_text_skip_blanks(*p, e);
    if (q >= e)
        return false;
    *b = q;
    *fe = ffd_text_word_end(q, e);
    *p = *fe;
    return true;
}

/* A number filling the field [b, fe) exactly. */
static bool field_number(const char *b, const char *fe, double *v)
{
    const char *q = b;
    return fe > b && ffd_parse_number(&q, fe, false, v) == 1 && q == fe;
}

/* The content of a line: without its line end, without a comment. NULL
 * when it has no content (blank or comment line). */
static const char *content_end(const xyz_ctx *c, const ffd_text_line *l)
{
    const char *q = ffd_text_skip_blanks(l->p, l->ce);
    if (q >= l->ce || *q == '#')
        return NULL;
    const char *e = c->csv ? l->ce : ffd_text_hash_in(q, l->ce);
    while (e > q && ffd_is_blank(e[-1]))
        e--;
    return e;
}

static ffd_status read_xyz(ffd_mesh *m, const char *name, ffd_error *err)
{
    const char *s = (const char *)m->src;
    xyz_ctx c = {name, s, s + m->src_size, false, 0};
    const char *at = s + ffd_utf8_bom_length(m->src, m->src_size);

    /* The spelling: a comma in the first content line. */
    {
        const char *q = at;
        ffd_text_line l;
        while (ffd_text_next_line(&q, c.end, &l)) {
            const char *e = content_end(&c, &l);
            if (e) {
                c.csv = memchr(l.p, ',', (size_t)(l.ce - l.p)) != NULL;
                break;
            }
        }
    }
    xyz_state *state = ffd_malloc(sizeof *state);
    if (!state)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    state->csv = c.csv;
    m->codec_state = state;
    m->codec_state_free = state_free;
    m->encoding = FFD_ENCODING_ASCII;

    /* Extra columns: values per point (while every point has the same
     * number of numeric extras), and the CSV header's names. */
    double *extra = NULL;
    size_t extra_n = 0, extra_cap = 0;
    long ncols = -1; /* extras per point; -2: inconsistent or not numeric */
    const char *header = NULL, *header_end = NULL;
    ffd_status st = FFD_OK;
    ffd_text_line l;
    bool first = true;
    while (ffd_text_next_line(&at, c.end, &l)) {
        c.line++;
        const char *e = content_end(&c, &l);
        if (!e)
            continue;
        const char *p = ffd_text_skip_blanks(l.p, e), *b, *fe;
        double v[3];
        ffd_span sp[3];
        int got = 0;
        for (; got < 3; got++) {
            if (!next_field(&c, &p, e, &b, &fe)) {
                if (got == 0)
                    break;
                st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected x%sy%sz, found %d value%s",
                              name, c.line, c.csv ? "," : " ", c.csv ? "," : " ", got,
                              got == 1 ? "" : "s");
                goto fail;
            }
            if (!field_number(b, fe, &v[got])) {
                if (first && got == 0 && c.csv) /* the header line of names */
                    break;
                st = bad_value(&c, b, fe, got == 0 ? "x" : got == 1 ? "y" : "z", err);
                goto fail;
            }
            if (!isfinite(v[got])) {
                st = ffd_fail(err, FFD_ERR_NONFINITE, "%s:%zu: coordinate %c of point %zu is not finite",
                              name, c.line, "xyz"[got], m->vertex_count + 1);
                goto fail;
            }
            sp[got].offset = (uint64_t)(b - s);
            sp[got].kind = FFD_SPAN_TEXT;
        }
        if (got < 3) { /* a CSV header */
            header = ffd_text_skip_blanks(l.p, e);
            header_end = e;
            first = false;
            continue;
        }
        first = false;
        if (!ffd_mesh_push_vertex(m, v, sp)) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory at point %zu", name,
                          m->vertex_count + 1);
            goto fail;
        }
        long k = 0;
        bool numeric = true;
        size_t mark = extra_n;
        while (next_field(&c, &p, e, &b, &fe)) {
            double x;
            if (!field_number(b, fe, &x) || !isfinite(x)) {
                numeric = false;
                continue;
            }
            if (ncols == -2)
                continue;
            if (extra_n == extra_cap &&
                !ffd_grow((void **)&extra, &extra_cap, extra_n + 1, sizeof(double))) {
                st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
                goto fail;
            }
            extra[extra_n++] = x;
            k++;
        }
        if (ncols == -2)
            continue;
        if (!numeric || (ncols >= 0 && k != ncols)) {
            ncols = -2;
            extra_n = mark;
        } else
            ncols = k;
    }
    if (m->vertex_count == 0) {
        st = ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: expected a point (x%sy%sz), found none", name,
                      c.line ? c.line : 1, c.csv ? "," : " ", c.csv ? "," : " ");
        goto fail;
    }
    if (ncols > 0) {
        size_t nv = m->vertex_count, k = (size_t)ncols;
        double *col = ffd_malloc(nv * sizeof(double));
        if (!col) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
            goto fail;
        }
        /* Header names of the extra columns, when the header has them. */
        const char *hp = header;
        const char *hb = NULL, *hfe = NULL;
        if (hp)
            for (int skip = 0; skip < 3 && next_field(&c, &hp, header_end, &hb, &hfe); skip++) {
            }
        for (size_t j = 0; j < k; j++) {
            char fname[72];
            if (hp && next_field(&c, &hp, header_end, &hb, &hfe) && hfe > hb) {
                size_t len = (size_t)(hfe - hb);
                if (len >= 2 && hb[0] == '"' && hfe[-1] == '"') {
                    hb++;
                    len -= 2;
                }
                if (len > sizeof fname - 1)
                    len = sizeof fname - 1;
                memcpy(fname, hb, len);
                fname[len] = 0;
            } else {
                snprintf(fname, sizeof fname, "column_%zu", j + 4);
                hp = NULL;
            }
            for (size_t i = 0; i < nv; i++)
                col[i] = extra[i * k + j];
            if (!ffd_mesh_add_field(m, fname, FFD_FIELD_POINT, 1, FFD_SPAN_F64, col, nv)) {
                ffd_free(col);
                st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
                goto fail;
            }
        }
        ffd_free(col);
    }
    ffd_free(extra);
    return FFD_OK;
fail:
    ffd_free(extra);
    return st;
}

/* ======================================================================
 * Writing from data
 * ====================================================================== */

/* x y z and every point field's components, one point a line; CSV with a
 * header of names. */
static ffd_status write_points(const ffd_mesh *m, bool csv, ffd_buf *b, ffd_error *err)
{
    (void)err;
    const char *sep = csv ? "," : " ";
    if (csv) {
        ffd_buf_puts(b, "x,y,z");
        for (size_t f = 0; f < m->field_count; f++) {
            const ffd_mesh_field *fd = &m->fields[f];
            if (fd->association != FFD_FIELD_POINT)
                continue;
            for (uint32_t k = 0; k < fd->components; k++) {
                ffd_buf_puts(b, ",");
                ffd_buf_puts(b, fd->name);
                if (fd->components > 1)
                    ffd_buf_printf(b, "_%u", k);
            }
        }
        ffd_buf_puts(b, "\n");
    }
    for (size_t i = 0; i < m->vertex_count; i++) {
        const double *p = m->positions + 3 * i;
        ffd_buf_double(b, p[0]);
        ffd_buf_puts(b, sep);
        ffd_buf_double(b, p[1]);
        ffd_buf_puts(b, sep);
        ffd_buf_double(b, p[2]);
        for (size_t f = 0; f < m->field_count; f++) {
            const ffd_mesh_field *fd = &m->fields[f];
            if (fd->association != FFD_FIELD_POINT)
                continue;
            for (uint32_t k = 0; k < fd->components; k++) {
                ffd_buf_puts(b, sep);
                ffd_buf_double(b, fd->values[i * fd->components + k]);
            }
        }
        ffd_buf_puts(b, "\n");
    }
    return FFD_OK;
}

static ffd_status write_xyz(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    (void)enc;
    return write_points(m, false, b, err);
}

static bool path_is_csv(const char *path)
{
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    return dot && (!slash || dot > slash) && strcasecmp(dot + 1, "csv") == 0;
}

/* The spelling follows the path: a source of the other spelling (or of
 * another format) is written from data; the same one is patched. */
static ffd_status write_file_xyz(const ffd_mesh *m, const char *path, ffd_error *err)
{
    bool csv = path_is_csv(path);
    const xyz_state *s = m->src && m->format == FFD_FORMAT_XYZ ? m->codec_state : NULL;
    ffd_buf b = {0};
    ffd_error inner = {{0}};
    ffd_status st = s && s->csv == csv ? ffd_mesh_patch_spans(m, &b, &inner)
                                       : write_points(m, csv, &b, &inner);
    if (st == FFD_OK && b.oom)
        st = ffd_fail(&inner, FFD_ERR_NOMEM, "out of memory writing the points");
    if (st == FFD_OK)
        st = ffd_write_file_atomic(path, b.data ? b.data : (const unsigned char *)"", b.size, err);
    else
        ffd_fail(err, st, "%s: %s", path, inner.message);
    ffd_buf_free(&b);
    return st;
}

static const char *const xyz_extensions[] = {"xyz", "csv", NULL};

const ffd_mesh_codec ffd_mesh_codec_xyz = {
    .format = FFD_FORMAT_XYZ,
    .name = "XYZ",
    .extensions = xyz_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII),
    .read = read_xyz,
    .patch = ffd_mesh_patch_spans,
    .write = write_xyz,
    .write_file = write_file_xyz,
};
