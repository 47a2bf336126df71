/* rig_prm — PyGeM parameter files (.prm) of the methods other than the
 * lattice: the configparser syntax (rig_prm.h), the dispatch on section
 * names (ffd_method.prm_section), and the writer's entry point
 * ffd_rig_write_prm (ffd_method.write_prm). */
#include "rig/rig_prm.h"
#include "deformer/method.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PRM_NUMBER_MAX 255

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\v' || c == '\f' || c == '\r' || c == '\n';
}

static void trim(const char **p, size_t *n)
{
    while (*n && is_space((*p)[0]))
        (*p)++, (*n)--;
    while (*n && is_space((*p)[*n - 1]))
        (*n)--;
}

static int lower(int c)
{
    return c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c;
}

static int same_key(const char *a, size_t n, const char *b)
{
    if (strlen(b) != n)
        return 0;
    for (size_t i = 0; i < n; i++)
        if (lower((unsigned char)a[i]) != lower((unsigned char)b[i]))
            return 0;
    return 1;
}

void ffd_prm_free(ffd_prm *prm)
{
    ffd_free(prm->entries);
    ffd_free(prm->lines);
    memset(prm, 0, sizeof *prm);
}

static ffd_status add_line(ffd_prm *d, const char *p, size_t n, size_t line, ffd_error *err)
{
    if (!ffd_grow((void **)&d->lines, &d->line_cap, d->line_count + 1, sizeof *d->lines))
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", d->name);
    d->lines[d->line_count++] = (ffd_prm_line){p, n, line};
    d->entries[d->entry_count - 1].count++;
    return FFD_OK;
}

ffd_status ffd_prm_read(const char *text, size_t size, const char *name, ffd_prm *d,
                        ffd_error *err)
{
    memset(d, 0, sizeof *d);
    d->name = name;
    const char *section = NULL;
    size_t section_size = 0, pos = 0, line = 0, indent_level = 0;
    int in_value = 0;
    ffd_status s = FFD_OK;
    if (size >= 3 && memcmp(text, "\xEF\xBB\xBF", 3) == 0)
        pos = 3;
    while (pos < size && !s) {
        size_t start = pos;
        while (pos < size && text[pos] != '\n' && text[pos] != '\r')
            pos++;
        const char *p = text + start;
        size_t n = pos - start;
        if (pos < size && text[pos++] == '\r' && pos < size && text[pos] == '\n')
            pos++;
        line++;
        const char *raw = p;
        trim(&p, &n);
        if (!n || p[0] == '#' || p[0] == ';')
            continue;
        size_t indent = (size_t)(p - raw);
        if (in_value && indent > indent_level) {
            s = add_line(d, p, n, line, err);
            continue;
        }
        indent_level = indent;
        in_value = 0;
        if (p[0] == '[') {
            if (n < 3 || p[n - 1] != ']')
                s = ffd_fail(err, FFD_ERR_PARSE,
                             "%s:%zu: malformed section header (expected '[name]')", name, line);
            section = p + 1;
            section_size = n - 2;
            continue;
        }
        size_t delim = 0;
        while (delim < n && p[delim] != ':' && p[delim] != '=')
            delim++;
        if (!section || delim == n || delim == 0) {
            s = ffd_fail(err, FFD_ERR_PARSE,
                         "%s:%zu: expected 'key: value' in a [section], a [section] header or a "
                         "comment",
                         name, line);
            continue;
        }
        const char *key = p, *value = p + delim + 1;
        size_t key_size = delim, value_size = n - delim - 1;
        trim(&key, &key_size);
        trim(&value, &value_size);
        for (size_t i = 0; i < d->entry_count; i++) {
            const ffd_prm_entry *e = &d->entries[i];
            if (e->section_size == section_size && !memcmp(e->section, section, section_size) &&
                e->key_size == key_size) {
                char k[128];
                snprintf(k, sizeof k, "%.*s", (int)key_size, key);
                if (same_key(e->key, e->key_size, k)) {
                    s = ffd_fail(err, FFD_ERR_PARSE,
                                 "%s:%zu: duplicate key '%s' in [%.*s] (first at line %zu)", name,
                                 line, k, (int)section_size, section, e->line);
                    break;
                }
            }
        }
        if (s)
            break;
        if (!ffd_grow((void **)&d->entries, &d->entry_cap, d->entry_count + 1, sizeof *d->entries)) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
            break;
        }
        d->entries[d->entry_count++] = (ffd_prm_entry){section, key, section_size, key_size, line,
                                                       d->line_count, 0};
        in_value = 1;
        if (value_size)
            s = add_line(d, value, value_size, line, err);
    }
    if (s)
        ffd_prm_free(d);
    return s;
}

const ffd_prm_entry *ffd_prm_get(const ffd_prm *prm, const char *section, const char *key)
{
    size_t n = strlen(section);
    for (size_t i = 0; i < prm->entry_count; i++) {
        const ffd_prm_entry *e = &prm->entries[i];
        if (e->section_size == n && !memcmp(e->section, section, n) &&
            same_key(e->key, e->key_size, key))
            return e;
    }
    return NULL;
}

int ffd_prm_has_section(const char *text, size_t size, const char *section)
{
    size_t n = strlen(section), pos = 0;
    while (text && pos < size) {
        size_t start = pos;
        while (pos < size && text[pos] != '\n' && text[pos] != '\r')
            pos++;
        const char *p = text + start;
        size_t len = pos - start;
        pos++;
        trim(&p, &len);
        if (len == n + 2 && p[0] == '[' && p[len - 1] == ']' && !memcmp(p + 1, section, n))
            return 1;
    }
    return 0;
}

/* One number token (Python float() without inf/nan, which we refuse). */
static ffd_status number(const ffd_prm *prm, const char *p, size_t n, size_t line,
                         const char *what, double *out, ffd_error *err)
{
    char buf[PRM_NUMBER_MAX + 1], *end;
    if (n > PRM_NUMBER_MAX)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: %s: number longer than %d characters",
                        prm->name, line, what, PRM_NUMBER_MAX);
    memcpy(buf, p, n);
    buf[n] = 0;
    double v = strtod(buf, &end);
    if (end == buf || *end)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: %s: expected a number, got '%.40s'",
                        prm->name, line, what, buf);
    if (!isfinite(v))
        return ffd_fail(err, FFD_ERR_NONFINITE, "%s:%zu: %s: '%.40s' is not a finite number",
                        prm->name, line, what, buf);
    *out = v;
    return FFD_OK;
}

ffd_status ffd_prm_number(const ffd_prm *prm, const ffd_prm_entry *e, double *out, ffd_error *err)
{
    char what[64];
    snprintf(what, sizeof what, "%.*s", (int)e->key_size, e->key);
    if (e->count != 1)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: %s: expected one number", prm->name,
                        e->line, what);
    const ffd_prm_line *l = &prm->lines[e->first];
    return number(prm, l->text, l->size, l->line, what, out, err);
}

ffd_status ffd_prm_required(const ffd_prm *prm, const char *section, const char *key,
                            const ffd_prm_entry **out, ffd_error *err)
{
    *out = ffd_prm_get(prm, section, key);
    return *out ? FFD_OK
                : ffd_fail(err, FFD_ERR_PARSE, "%s: [%s] has no key '%s'", prm->name, section, key);
}

ffd_status ffd_prm_control_points(const ffd_prm *prm, double **points, size_t *count,
                                  double **deformed, ffd_error *err)
{
    static const char section[] = "Control points";
    const ffd_prm_entry *orig, *moved;
    size_t deformed_count;
    ffd_status s;
    if ((s = ffd_prm_required(prm, section, "original control points", &orig, err)) ||
        (s = ffd_prm_required(prm, section, "deformed control points", &moved, err)) ||
        (s = ffd_prm_points(prm, orig, points, count, err)) ||
        (s = ffd_prm_points(prm, moved, deformed, &deformed_count, err)))
        return s;
    if (deformed_count != *count)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s:%zu: deformed control points: %zu points for %zu original control "
                        "points (expected one per control point)",
                        prm->name, moved->line, deformed_count, *count);
    return FFD_OK;
}

ffd_status ffd_prm_points(const ffd_prm *prm, const ffd_prm_entry *e, double **points,
                          size_t *count, ffd_error *err)
{
    char what[64];
    snprintf(what, sizeof what, "%.*s", (int)e->key_size, e->key);
    *points = NULL;
    *count = 0;
    if (e->count == 0)
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: %s: no points", prm->name, e->line, what);
    double *p = ffd_malloc_array(e->count, 3 * sizeof *p);
    if (!p)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", prm->name);
    for (size_t i = 0; i < e->count; i++) {
        const ffd_prm_line *l = &prm->lines[e->first + i];
        size_t at = 0, k = 0;
        while (at < l->size) {
            while (at < l->size && is_space(l->text[at]))
                at++;
            size_t start = at;
            while (at < l->size && !is_space(l->text[at]))
                at++;
            if (at == start)
                break;
            ffd_status s = k >= 3 ? ffd_fail(err, FFD_ERR_PARSE,
                                             "%s:%zu: %s: expected 3 numbers a line, got more",
                                             prm->name, l->line, what)
                                  : number(prm, l->text + start, at - start, l->line, what,
                                           &p[3 * i + k], err);
            if (s) {
                ffd_free(p);
                return s;
            }
            k++;
        }
        if (k != 3) {
            ffd_free(p);
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: %s: expected 3 numbers a line, got %zu",
                            prm->name, l->line, what, k);
        }
    }
    *points = p;
    *count = e->count;
    return FFD_OK;
}

int ffd_prm_append(char **text, size_t *size, size_t *cap, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0 || !ffd_grow((void **)text, cap, *size + (size_t)n + 1, 1))
        return 0;
    va_start(ap, fmt);
    vsnprintf(*text + *size, (size_t)n + 1, fmt, ap);
    va_end(ap);
    *size += (size_t)n;
    return 1;
}

int ffd_prm_append_points(char **text, size_t *size, size_t *cap, const char *key,
                          const double *points, size_t count)
{
    int ok = ffd_prm_append(text, size, cap, "%s:", key);
    for (size_t i = 0; ok && i < count; i++)
        ok = ffd_prm_append(text, size, cap, "%*s%.17g   %.17g   %.17g\n", i ? 25 : 1, "",
                            points[3 * i], points[3 * i + 1], points[3 * i + 2]);
    return ok;
}

/* ---- the dispatch (ffd_rig_parse_prm, lattice_prm.c) and the writer ---- */

const ffd_method *ffd_method_of_prm(const char *text, size_t size)
{
    for (size_t i = 0; i < ffd_method_count(); i++) {
        const ffd_method *m = ffd_method_at(i);
        if (m->prm_section && m->parse_prm && ffd_prm_has_section(text, size, m->prm_section))
            return m;
    }
    return NULL;
}

ffd_status ffd_rig_write_prm(const ffd_rig *rig, char **text, ffd_error *err)
{
    if (!text)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_rig_write_prm: NULL text");
    *text = NULL;
    if (!rig || !rig->method || !rig->method->write_prm) {
        char names[256] = "";
        size_t used = 0;
        for (size_t i = 0; i < ffd_method_count() && used < sizeof names; i++)
            if (ffd_method_at(i)->write_prm) {
                int w = snprintf(names + used, sizeof names - used, "%s\"%s\"", used ? ", " : "",
                                 ffd_method_at(i)->name);
                used += w > 0 ? (size_t)w : 0;
            }
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "%s: PyGeM parameter files are written for %s rigs only",
                        rig && rig->name ? rig->name : "rig", names);
    }
    if (rig->constraint_count)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "%s: a PyGeM parameter file cannot hold constraints (apply the rig, or "
                        "write its deformer's rig, first)",
                        rig->name);
    return rig->method->write_prm(rig, text, err);
}
