/* rig — PyGeM FFD parameter files (.prm) read into an ffd_rig.
 *
 * PyGeM (mathLab/PyGeM, pygem/ffd.py, class FFD) reads these files with
 * Python's configparser.RawConfigParser and deforms with one Bernstein volume
 * (Sederberg & Parry 1986) on a box rotated about its origin; points outside
 * the box are left where they are. docs/pygem.md gives the exact mapping, the
 * PyGeM source lines it follows and where we are stricter:
 *
 *   box    origin o, axes a_i = L_i * R e_i,  R = Rx(ax) Ry(ay) Rz(az) (degrees)
 *   moves  control point (i,j,k) moves by R (mu_ijk (.) L)  (mu: normalised weights)
 *   rest   FFD_BASIS_BERNSTEIN, resolution = n control points, FFD_OUTSIDE_FIXED
 *
 * The reader follows configparser's rules (sections, ':' or '=' delimiters,
 * case-insensitive keys, full-line '#'/';' comments, indented continuation
 * lines, duplicate sections/keys rejected) and tolerates unknown sections and
 * keys as PyGeM does; every value it uses must be well formed and finite. */
#include "lattice/lattice_method.h"
#include "rig/rig.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PRM_MAX_RESOLUTION 1024u
#define PRM_NUMBER_MAX 255 /* longest numeric token we convert */
#define PRM_QUOTE_MAX 40   /* longest excerpt of the input quoted in a message */
#define PRM_PI 3.14159265358979323846

/* ======================================================================
 * Keys PyGeM reads
 * ====================================================================== */

enum {
    SEC_BOX = 0, /* [Box info] */
    SEC_WEIGHTS, /* [Parameters weights] */
    SEC_DEFAULT, /* [DEFAULT]: configparser's fallback for every section */
    SEC_KNOWN,
    SEC_OTHER = SEC_KNOWN, /* any other section: read for syntax, then ignored */
    SEC_NONE               /* before the first header */
};

static const char *const section_names[SEC_KNOWN] = {"Box info", "Parameters weights", "DEFAULT"};

enum {
    KEY_N = 0,          /* n control points x, y, z */
    KEY_LENGTH = 3,     /* box length x, y, z */
    KEY_LENGHT = 6,     /* box lenght x, y, z (PyGeM <= 1.x spelling) */
    KEY_ORIGIN = 9,     /* box origin x, y, z */
    KEY_ANGLE = 12,     /* rotation angle x, y, z */
    KEY_MODE = 15,      /* rotation mode (one PyGeM revision) */
    KEY_PARAMETER = 16, /* parameter x, y, z */
    KEY_COUNT = 19
};

/* clang-format off */
static const char *const key_names[KEY_COUNT] = {
    "n control points x", "n control points y", "n control points z",
    "box length x",       "box length y",       "box length z",
    "box lenght x",       "box lenght y",       "box lenght z",
    "box origin x",       "box origin y",       "box origin z",
    "rotation angle x",   "rotation angle y",   "rotation angle z",
    "rotation mode",      "parameter x",        "parameter y",
    "parameter z"};
/* clang-format on */

typedef struct span {
    const char *p;
    size_t n;
} span;

typedef struct value_line {
    span text; /* stripped, never empty */
    size_t line;
} value_line;

typedef struct entry {
    size_t line;  /* 0: absent */
    size_t first; /* its non-empty value lines: lines[first .. first+count) */
    size_t count;
} entry;

typedef struct prm_doc {
    const char *name;
    ffd_error *err;
    size_t section_line[SEC_KNOWN]; /* header line, 0: absent */
    entry keys[SEC_KNOWN][KEY_COUNT];
    value_line *lines;
    size_t line_count, line_cap;
} prm_doc;

/* One normalised weight from a "parameter x/y/z" line. */
typedef struct weight {
    size_t point; /* (i*m + j)*n + k */
    size_t order; /* position in the file: the last assignment wins, as in numpy */
    size_t line;
    int axis;
    double mu;
} weight;

/* ======================================================================
 * Small text helpers (spans are not NUL-terminated)
 * ====================================================================== */

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\v' || c == '\f' || c == '\r' || c == '\n';
}

static span trim(span s)
{
    while (s.n && is_space(s.p[0])) {
        s.p++;
        s.n--;
    }
    while (s.n && is_space(s.p[s.n - 1]))
        s.n--;
    return s;
}

static int lower(int c)
{
    return c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c;
}

/* configparser lower-cases keys (optionxform = str.lower). */
static int key_equals(span key, const char *name)
{
    size_t n = strlen(name);
    if (key.n != n)
        return 0;
    for (size_t i = 0; i < n; i++)
        if (lower((unsigned char)key.p[i]) != name[i])
            return 0;
    return 1;
}

static int span_equals(span s, const char *text)
{
    size_t n = strlen(text);
    return s.n == n && memcmp(s.p, text, n) == 0;
}

/* printf arguments for quoting at most PRM_QUOTE_MAX characters of s. */
#define QUOTE(s)                                                                                   \
    (int)((s).n > PRM_QUOTE_MAX ? PRM_QUOTE_MAX : (s).n), (s).p,                                   \
        ((s).n > PRM_QUOTE_MAX ? "..." : "")

/* ======================================================================
 * Numbers: the subset of Python's int() and float() that means a number
 * ====================================================================== */

/* Python float() grammar without '_' separators: [sign] (digits [. [digits]] | . digits) [e [sign]
 * digits]. Returns 1 for a decimal number, 2 for inf/infinity/nan (any case), 0 otherwise. */
static int scan_float(span s)
{
    size_t i = 0;
    if (i < s.n && (s.p[i] == '+' || s.p[i] == '-'))
        i++;
    span rest = {s.p + i, s.n - i};
    if (key_equals(rest, "inf") || key_equals(rest, "infinity") || key_equals(rest, "nan"))
        return 2;
    size_t digits = 0;
    while (i < s.n && s.p[i] >= '0' && s.p[i] <= '9') {
        i++;
        digits++;
    }
    if (i < s.n && s.p[i] == '.') {
        i++;
        while (i < s.n && s.p[i] >= '0' && s.p[i] <= '9') {
            i++;
            digits++;
        }
    }
    if (!digits)
        return 0;
    if (i < s.n && (s.p[i] == 'e' || s.p[i] == 'E')) {
        i++;
        if (i < s.n && (s.p[i] == '+' || s.p[i] == '-'))
            i++;
        size_t exp_digits = 0;
        while (i < s.n && s.p[i] >= '0' && s.p[i] <= '9') {
            i++;
            exp_digits++;
        }
        if (!exp_digits)
            return 0;
    }
    return i == s.n;
}

/* Converts token s; reports "<what>: ..." at line on failure. */
static ffd_status parse_float(prm_doc *d, span s, size_t line, const char *what, double *out)
{
    int kind = scan_float(s);
    if (kind == 2)
        return ffd_fail(d->err, FFD_ERR_NONFINITE, "%s:%zu: %s: '%.*s%s' is not a finite number",
                        d->name, line, what, QUOTE(s));
    if (kind == 0)
        return ffd_fail(d->err, FFD_ERR_PARSE, "%s:%zu: %s: expected a number, got '%.*s%s'",
                        d->name, line, what, QUOTE(s));
    if (s.n > PRM_NUMBER_MAX)
        return ffd_fail(d->err, FFD_ERR_PARSE, "%s:%zu: %s: number longer than %d characters",
                        d->name, line, what, PRM_NUMBER_MAX);
    char buf[PRM_NUMBER_MAX + 1];
    memcpy(buf, s.p, s.n);
    buf[s.n] = '\0';
    double v = strtod(buf, NULL);
    if (!isfinite(v))
        return ffd_fail(d->err, FFD_ERR_NONFINITE,
                        "%s:%zu: %s: '%.*s%s' overflows a double (not finite)", d->name, line, what,
                        QUOTE(s));
    *out = v;
    return FFD_OK;
}

/* Python int() without '_': [sign] digits; more than 17 significant digits is out of range. */
static ffd_status parse_int(prm_doc *d, span s, size_t line, const char *what, long long *out)
{
    size_t i = 0;
    int negative = 0;
    if (i < s.n && (s.p[i] == '+' || s.p[i] == '-'))
        negative = s.p[i++] == '-';
    if (i == s.n)
        return ffd_fail(d->err, FFD_ERR_PARSE, "%s:%zu: %s: expected an integer, got '%.*s%s'",
                        d->name, line, what, QUOTE(s));
    long long v = 0;
    for (; i < s.n; i++) {
        if (s.p[i] < '0' || s.p[i] > '9')
            return ffd_fail(d->err, FFD_ERR_PARSE, "%s:%zu: %s: expected an integer, got '%.*s%s'",
                            d->name, line, what, QUOTE(s));
        if (v >= 100000000000000000LL) /* 1e17: far beyond any count or index */
            return ffd_fail(d->err, FFD_ERR_RANGE, "%s:%zu: %s: integer '%.*s%s' is out of range",
                            d->name, line, what, QUOTE(s));
        v = v * 10 + (s.p[i] - '0');
    }
    *out = negative ? -v : v;
    return FFD_OK;
}

/* ======================================================================
 * Syntax: configparser's line rules
 * ====================================================================== */

static ffd_status add_value_line(prm_doc *d, entry *e, span text, size_t line)
{
    if (!e || !text.n)
        return FFD_OK; /* ignored key, or a blank line (see docs/pygem.md) */
    if (!ffd_grow((void **)&d->lines, &d->line_cap, d->line_count + 1, sizeof *d->lines))
        return ffd_fail(d->err, FFD_ERR_NOMEM, "%s: out of memory", d->name);
    d->lines[d->line_count].text = text;
    d->lines[d->line_count].line = line;
    d->line_count++;
    e->count++;
    return FFD_OK;
}

static ffd_status read_header(prm_doc *d, span s, size_t line, int *section)
{
    /* configparser's SECTCRE is "\[(?P<header>.+)\]" matched at the start; we
     * also refuse text after the ']' rather than silently drop it. */
    if (s.n < 2 || s.p[s.n - 1] != ']')
        return ffd_fail(d->err, FFD_ERR_PARSE,
                        "%s:%zu: malformed section header '%.*s%s' (expected '[name]')", d->name,
                        line, QUOTE(s));
    span header = {s.p + 1, s.n - 2};
    if (!header.n)
        return ffd_fail(d->err, FFD_ERR_PARSE, "%s:%zu: empty section name '[]'", d->name, line);
    *section = SEC_OTHER;
    for (int i = 0; i < SEC_KNOWN; i++) {
        if (span_equals(header, section_names[i])) {
            if (d->section_line[i])
                return ffd_fail(d->err, FFD_ERR_PARSE,
                                "%s:%zu: duplicate section [%s] (first at line %zu)", d->name, line,
                                section_names[i], d->section_line[i]);
            d->section_line[i] = line;
            *section = i;
        }
    }
    return FFD_OK;
}

/* Reads "key: value" or "key = value" into d; *target receives the entry
 * whose continuation lines follow (NULL for an ignored key). */
static ffd_status read_option(prm_doc *d, span s, size_t line, int section, entry **target)
{
    size_t delim = 0;
    while (delim < s.n && s.p[delim] != ':' && s.p[delim] != '=')
        delim++;
    if (delim == s.n)
        return ffd_fail(d->err, FFD_ERR_PARSE,
                        "%s:%zu: expected 'key: value', a [section] header or a comment, got "
                        "'%.*s%s'",
                        d->name, line, QUOTE(s));
    span key = trim((span){s.p, delim});
    span value = trim((span){s.p + delim + 1, s.n - delim - 1});
    if (!key.n)
        return ffd_fail(d->err, FFD_ERR_PARSE, "%s:%zu: empty key before '%c'", d->name, line,
                        s.p[delim]);
    *target = NULL;
    if (section == SEC_OTHER)
        return FFD_OK;
    for (int k = 0; k < KEY_COUNT; k++) {
        if (!key_equals(key, key_names[k]))
            continue;
        entry *e = &d->keys[section][k];
        if (e->line)
            return ffd_fail(d->err, FFD_ERR_PARSE,
                            "%s:%zu: duplicate key '%s' in [%s] (first at line %zu)", d->name, line,
                            key_names[k], section_names[section], e->line);
        e->line = line;
        e->first = d->line_count;
        e->count = 0;
        *target = e;
        return add_value_line(d, e, value, line);
    }
    return FFD_OK; /* unknown key: PyGeM never asks configparser for it */
}

static ffd_status read_lines(prm_doc *d, const char *text, size_t size)
{
    size_t pos = 0, line = 0;
    int section = SEC_NONE;
    int have_option = 0;     /* configparser's optname: a continuation may follow */
    entry *target = NULL;    /* where continuation lines go (NULL: ignored) */
    size_t indent_level = 0; /* indentation of the last header or key line */
    if (size >= 3 && memcmp(text, "\xEF\xBB\xBF", 3) == 0)
        pos = 3; /* UTF-8 byte order mark */
    while (pos < size) {
        size_t start = pos;
        while (pos < size && text[pos] != '\n' && text[pos] != '\r')
            pos++;
        span raw = {text + start, pos - start};
        /* Universal newlines, as Python's text mode: \n, \r\n or \r. */
        if (pos < size && text[pos++] == '\r' && pos < size && text[pos] == '\n')
            pos++;
        line++;

        span s = trim(raw);
        if (!s.n || s.p[0] == '#' || s.p[0] == ';')
            continue; /* blank lines and full-line comments never end a value */
        size_t indent = (size_t)(s.p - raw.p);
        if (have_option && indent > indent_level) {
            ffd_status st = add_value_line(d, target, s, line);
            if (st)
                return st;
            continue;
        }
        indent_level = indent;
        if (s.p[0] == '[') {
            ffd_status st = read_header(d, s, line, &section);
            if (st)
                return st;
            have_option = 0;
            target = NULL;
            continue;
        }
        if (section == SEC_NONE)
            return ffd_fail(d->err, FFD_ERR_PARSE,
                            "%s:%zu: '%.*s%s' before the first [section] header", d->name, line,
                            QUOTE(s));
        ffd_status st = read_option(d, s, line, section, &target);
        if (st)
            return st;
        have_option = 1;
    }
    return FFD_OK;
}

/* ======================================================================
 * Semantics: PyGeM's FFD.read_parameters and FFD's geometry
 * ====================================================================== */

/* configparser.get(section, key): the section's own value, else [DEFAULT]'s. */
static const entry *lookup(const prm_doc *d, int section, int key)
{
    if (d->keys[section][key].line)
        return &d->keys[section][key];
    if (d->keys[SEC_DEFAULT][key].line)
        return &d->keys[SEC_DEFAULT][key];
    return NULL;
}

/* The single token of a scalar key (NULL-free: reports a missing or multi-line value). */
static ffd_status scalar(prm_doc *d, int section, int key, const value_line **out)
{
    const entry *e = lookup(d, section, key);
    if (!e)
        return ffd_fail(d->err, FFD_ERR_PARSE, "%s:%zu: [%s] has no key '%s'", d->name,
                        d->section_line[section], section_names[section], key_names[key]);
    if (e->count == 0)
        return ffd_fail(d->err, FFD_ERR_PARSE, "%s:%zu: %s: empty value", d->name, e->line,
                        key_names[key]);
    if (e->count > 1)
        return ffd_fail(d->err, FFD_ERR_PARSE,
                        "%s:%zu: %s: expected one number, the value continues on line %zu", d->name,
                        e->line, key_names[key], d->lines[e->first + 1].line);
    *out = &d->lines[e->first];
    return FFD_OK;
}

static ffd_status read_count(prm_doc *d, int axis, uint32_t *out)
{
    const value_line *v = NULL;
    long long n = 0;
    ffd_status s = scalar(d, SEC_BOX, KEY_N + axis, &v);
    if (!s)
        s = parse_int(d, v->text, v->line, key_names[KEY_N + axis], &n);
    if (s)
        return s;
    if (n < 2)
        return ffd_fail(d->err, FFD_ERR_INVALID,
                        "%s:%zu: %s: lattice resolution %lld is below the minimum 2", d->name,
                        v->line, key_names[KEY_N + axis], n);
    if (n > (long long)PRM_MAX_RESOLUTION)
        return ffd_fail(d->err, FFD_ERR_INVALID,
                        "%s:%zu: %s: lattice resolution %lld is above the maximum %u", d->name,
                        v->line, key_names[KEY_N + axis], n, PRM_MAX_RESOLUTION);
    *out = (uint32_t)n;
    return FFD_OK;
}

static ffd_status read_real(prm_doc *d, int key, double *out)
{
    const value_line *v = NULL;
    ffd_status s = scalar(d, SEC_BOX, key, &v);
    if (!s)
        s = parse_float(d, v->text, v->line, key_names[key], out);
    return s;
}

static ffd_status read_length(prm_doc *d, int axis, double *out)
{
    /* PyGeM >= 2 reads "box length", older releases "box lenght"; take either, not both. */
    const entry *now = lookup(d, SEC_BOX, KEY_LENGTH + axis);
    const entry *old = lookup(d, SEC_BOX, KEY_LENGHT + axis);
    if (now && old)
        return ffd_fail(d->err, FFD_ERR_PARSE,
                        "%s:%zu: both '%s' and '%s' (line %zu) given; keep one", d->name, now->line,
                        key_names[KEY_LENGTH + axis], key_names[KEY_LENGHT + axis], old->line);
    int key = old ? KEY_LENGHT + axis : KEY_LENGTH + axis;
    ffd_status s = read_real(d, key, out);
    if (s)
        return s;
    if (!(*out > 0.0))
        return ffd_fail(d->err, FFD_ERR_INVALID,
                        "%s:%zu: %s = %g: zero-volume box (box lengths must be positive)", d->name,
                        lookup(d, SEC_BOX, key)->line, key_names[key], *out);
    return FFD_OK;
}

/* pygem/utils.py angles2matrix(rot_z, rot_y, rot_x) = Rx . Ry . Rz, each
 * counter-clockwise (right-hand rule), applied to column vectors. */
static void rotation_matrix(const double degrees[3], double r[3][3])
{
    double c[3], s[3];
    for (int i = 0; i < 3; i++) {
        double a = degrees[i] * (PRM_PI / 180.0); /* np.radians */
        c[i] = cos(a);
        s[i] = sin(a);
    }
    const double rx[3][3] = {{1, 0, 0}, {0, c[0], -s[0]}, {0, s[0], c[0]}};
    const double ry[3][3] = {{c[1], 0, s[1]}, {0, 1, 0}, {-s[1], 0, c[1]}};
    const double rz[3][3] = {{c[2], -s[2], 0}, {s[2], c[2], 0}, {0, 0, 1}};
    double rxy[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            rxy[i][j] = rx[i][0] * ry[0][j] + rx[i][1] * ry[1][j] + rx[i][2] * ry[2][j];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r[i][j] = rxy[i][0] * rz[0][j] + rxy[i][1] * rz[1][j] + rxy[i][2] * rz[2][j];
}

static int compare_weights(const void *pa, const void *pb)
{
    const weight *a = pa, *b = pb;
    if (a->point != b->point)
        return a->point < b->point ? -1 : 1;
    if (a->order != b->order)
        return a->order < b->order ? -1 : 1;
    return 0;
}

/* Parses "parameter x/y/z" lines "i j k mu" into w (appending). */
static ffd_status read_weights(prm_doc *d, int axis, const uint32_t res[3], weight **w,
                               size_t *count, size_t *cap)
{
    const char *what = key_names[KEY_PARAMETER + axis];
    const entry *e = lookup(d, SEC_WEIGHTS, KEY_PARAMETER + axis);
    if (!e)
        return ffd_fail(d->err, FFD_ERR_PARSE, "%s:%zu: [%s] has no key '%s'", d->name,
                        d->section_line[SEC_WEIGHTS], section_names[SEC_WEIGHTS], what);
    for (size_t l = 0; l < e->count; l++) {
        const value_line *v = &d->lines[e->first + l];
        span tok[5];
        size_t ntok = 0, i = 0;
        while (i < v->text.n && ntok < 5) {
            while (i < v->text.n && is_space(v->text.p[i]))
                i++;
            size_t start = i;
            while (i < v->text.n && !is_space(v->text.p[i]))
                i++;
            if (i > start)
                tok[ntok++] = (span){v->text.p + start, i - start};
        }
        if (ntok != 4)
            return ffd_fail(d->err, FFD_ERR_PARSE,
                            "%s:%zu: %s: expected 'i j k weight', got '%.*s%s'", d->name, v->line,
                            what, QUOTE(v->text));
        long long index[3];
        for (int c = 0; c < 3; c++) {
            ffd_status s = parse_int(d, tok[c], v->line, what, &index[c]);
            if (s)
                return s;
        }
        for (int c = 0; c < 3; c++)
            if (index[c] < 0 || index[c] >= (long long)res[c])
                return ffd_fail(d->err, FFD_ERR_RANGE,
                                "%s:%zu: %s: control point (%lld, %lld, %lld) out of range "
                                "(lattice is %u x %u x %u, indices from 0)",
                                d->name, v->line, what, index[0], index[1], index[2], res[0],
                                res[1], res[2]);
        double mu;
        ffd_status s = parse_float(d, tok[3], v->line, what, &mu);
        if (s)
            return s;
        if (!ffd_grow((void **)w, cap, *count + 1, sizeof **w))
            return ffd_fail(d->err, FFD_ERR_NOMEM, "%s: out of memory", d->name);
        weight *x = &(*w)[*count];
        x->point = ((size_t)index[0] * res[1] + (size_t)index[1]) * res[2] + (size_t)index[2];
        x->order = *count;
        x->line = v->line;
        x->axis = axis;
        x->mu = mu;
        (*count)++;
    }
    return FFD_OK;
}

/* Turns the weights into one move per displaced control point:
 * PyGeM maps p -> o + M (psi(p) + sum b mu), M = R diag(L), so control point
 * (i,j,k) moves by M mu_ijk = R (mu_ijk (.) L) in world space. */
static ffd_status build_moves(prm_doc *d, weight *w, size_t count, double r[3][3],
                              const double length[3], const uint32_t res[3], ffd_rig *rig)
{
    qsort(w, count, sizeof *w, compare_weights);
    size_t moves = 0;
    for (size_t a = 0; a < count;) {
        size_t b = a;
        double mu[3] = {0, 0, 0};
        size_t line = w[a].line;
        for (; b < count && w[b].point == w[a].point; b++) {
            mu[w[b].axis] = w[b].mu; /* later lines overwrite earlier ones */
            if (w[b].line > line)
                line = w[b].line;
        }
        if (mu[0] != 0.0 || mu[1] != 0.0 || mu[2] != 0.0) {
            double v[3] = {mu[0] * length[0], mu[1] * length[1], mu[2] * length[2]};
            double delta[3];
            for (int i = 0; i < 3; i++)
                delta[i] = r[i][0] * v[0] + r[i][1] * v[1] + r[i][2] * v[2];
            size_t p = w[a].point;
            uint32_t k = (uint32_t)(p % res[2]);
            uint32_t j = (uint32_t)(p / res[2] % res[1]);
            uint32_t i = (uint32_t)(p / res[2] / res[1]);
            if (!isfinite(delta[0]) || !isfinite(delta[1]) || !isfinite(delta[2]))
                return ffd_fail(d->err, FFD_ERR_NONFINITE,
                                "%s:%zu: control point (%u, %u, %u): weight times box length "
                                "overflows (not finite)",
                                d->name, line, i, j, k);
            /* moves (<= count entries) reuses the sorted array's order */
            ffd_rig_move *m = &rig->moves[moves++];
            m->index[0] = i;
            m->index[1] = j;
            m->index[2] = k;
            memcpy(m->delta, delta, sizeof delta);
        }
        a = b;
    }
    rig->move_count = moves;
    return FFD_OK;
}

static ffd_status read_rig(prm_doc *d, ffd_rig *rig)
{
    for (int sec = 0; sec < SEC_DEFAULT; sec++)
        if (!d->section_line[sec])
            return ffd_fail(d->err, FFD_ERR_PARSE, "%s: missing section [%s]", d->name,
                            section_names[sec]);

    uint32_t res[3];
    double length[3], origin[3], angle[3];
    ffd_status s = FFD_OK;
    for (int a = 0; a < 3 && !s; a++)
        s = read_count(d, a, &res[a]);
    for (int a = 0; a < 3 && !s; a++)
        s = read_length(d, a, &length[a]);
    for (int a = 0; a < 3 && !s; a++)
        s = read_real(d, KEY_ORIGIN + a, &origin[a]);
    for (int a = 0; a < 3 && !s; a++)
        s = read_real(d, KEY_ANGLE + a, &angle[a]);
    if (s)
        return s;
    if (lookup(d, SEC_BOX, KEY_MODE)) {
        /* One PyGeM revision has "rotation mode": 0 uses the angles; any other
         * value uses a matrix set from Python, which a .prm cannot carry. */
        double mode;
        s = read_real(d, KEY_MODE, &mode);
        if (s)
            return s;
        if (mode != 0.0)
            return ffd_fail(d->err, FFD_ERR_UNSUPPORTED,
                            "%s:%zu: rotation mode %g: only 0 (rotation angles) can be read "
                            "from a .prm file",
                            d->name, lookup(d, SEC_BOX, KEY_MODE)->line, mode);
    }

    weight *w = NULL;
    size_t count = 0, cap = 0;
    for (int a = 0; a < 3 && !s; a++)
        s = read_weights(d, a, res, &w, &count, &cap);
    if (!s) {
        rig->moves = ffd_malloc_array(count ? count : 1, sizeof *rig->moves);
        if (!rig->moves)
            s = ffd_fail(d->err, FFD_ERR_NOMEM, "%s: out of memory", d->name);
    }
    double r[3][3];
    rotation_matrix(angle, r);
    if (!s)
        s = build_moves(d, w, count, r, length, res, rig);
    ffd_free(w);
    if (s)
        return s;

    rig->basis = FFD_BASIS_BERNSTEIN;
    memcpy(rig->resolution, res, sizeof res);
    rig->box_auto = 0;
    memcpy(rig->box.origin, origin, sizeof origin);
    for (int i = 0; i < 3; i++)
        for (int c = 0; c < 3; c++)
            rig->box.axes[i][c] = r[c][i] * length[i]; /* position_vertices: o + (R diag(L)).T */
    rig->outside = FFD_OUTSIDE_FIXED; /* FFD.__call__ deforms only points inside [0,1]^3 */
    return FFD_OK;
}

ffd_status ffd_rig_parse_prm(const char *text, size_t size, const char *name, ffd_rig **out,
                             ffd_error *err)
{
    if (out)
        *out = NULL;
    name = ffd_name_or(name, "<prm>");
    if (!out || (!text && size))
        return ffd_fail(err, FFD_ERR_INVALID, "%s: ffd_rig_parse_prm: NULL %s", name,
                        out ? "text" : "out");
    /* PyGeM's files of other methods: their method's reader (by section name) */
    const ffd_method *other = ffd_method_of_prm(text, size);
    if (other)
        return other->parse_prm(text, size, name, out, err);
    prm_doc d;
    memset(&d, 0, sizeof d);
    d.name = name;
    d.err = err;
    ffd_rig *rig = NULL;
    ffd_status s = read_lines(&d, text ? text : "", size);
    if (s)
        goto fail;
    rig = ffd_rig_new(name);
    if (!rig) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
        goto fail;
    }
    s = read_rig(&d, rig);
    if (s)
        goto fail;
    ffd_free(d.lines);
    *out = rig;
    return FFD_OK;
fail:
    ffd_free(d.lines);
    ffd_rig_destroy(rig);
    return s;
}
