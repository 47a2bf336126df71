/* partition — ffd-mpi's partitioned-mesh formats (docs/mpi.md "Partition
 * formats"): a ParaView .pvtu and its .vtu pieces, Gmsh's split pieces
 * (`gmsh -part N -part_split`: mesh_1.msh .. mesh_N.msh), or a name pattern
 * with %d; and each piece's global vertex ids. */
#include "partition.h"

#include "core/core.h" /* ffd_fail, ffd_read_file */
#include "mesh/mesh.h" /* ffd_mesh_vertex_attribute: a point field, PLY property or OBJ "#NAME" lines */

#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static char *dup_printf(const char *fmt, ...) FFD_PRINTF(1, 2);
static char *dup_printf(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0)
        return NULL;
    char *s = malloc((size_t)n + 1);
    if (!s)
        return NULL;
    va_start(ap, fmt);
    vsnprintf(s, (size_t)n + 1, fmt, ap);
    va_end(ap);
    return s;
}

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    if (n < m)
        return 0;
    for (size_t i = 0; i < m; i++)
        if (tolower((unsigned char)s[n - m + i]) != tolower((unsigned char)suffix[i]))
            return 0;
    return 1;
}

static int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* The directory part of path with its slash ("" when none). */
static size_t dir_length(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? (size_t)(slash - path) + 1 : 0;
}

static ffd_status nomem(ffd_error *err)
{
    return ffd_fail(err, FFD_ERR_NOMEM, "ffd-mpi: out of memory");
}

/* ======================================================================
 * Patterns: one %d (or %Nd, %0Nd) and %% for a percent sign
 * ====================================================================== */

/* Checks pattern; *width and *zero its field. 0, or -1 with a message. */
static int pattern_check(const char *pattern, const char *what, int *width, int *zero,
                         ffd_error *err)
{
    int conversions = 0;
    for (const char *p = pattern; *p; p++) {
        if (*p != '%')
            continue;
        if (p[1] == '%') {
            p++;
            continue;
        }
        const char *q = p + 1;
        int z = *q == '0', w = 0;
        while (isdigit((unsigned char)*q) && w < 100)
            w = 10 * w + (*q++ - '0');
        if (*q != 'd' || w >= 100) {
            ffd_fail(err, FFD_ERR_INVALID,
                     "%s '%s': only %%d, %%Nd or %%0Nd (the rank) and %%%% may follow '%%'", what,
                     pattern);
            return -1;
        }
        conversions++;
        *width = w;
        *zero = z;
        p = q;
    }
    if (conversions != 1) {
        ffd_fail(err, FFD_ERR_INVALID, "%s '%s': expected one %%d (the rank), found %d", what,
                 pattern, conversions);
        return -1;
    }
    return 0;
}

/* The pattern with value for its conversion (checked by pattern_check). */
static char *pattern_format(const char *pattern, long value)
{
    size_t cap = strlen(pattern) + 128;
    char *s = malloc(cap), *o = s;
    if (!s)
        return NULL;
    for (const char *p = pattern; *p; p++) {
        if (*p != '%') {
            *o++ = *p;
            continue;
        }
        if (p[1] == '%') {
            *o++ = '%';
            p++;
            continue;
        }
        const char *q = p + 1;
        int zero = *q == '0', width = 0;
        while (isdigit((unsigned char)*q))
            width = 10 * width + (*q++ - '0');
        o += snprintf(o, cap - (size_t)(o - s), zero ? "%0*ld" : "%*ld", width, value);
        p = q; /* the 'd' */
    }
    *o = 0;
    return s;
}

static int has_conversion(const char *s)
{
    for (const char *p = s; *p; p++)
        if (*p == '%') {
            if (p[1] == '%')
                p++;
            else
                return 1;
        }
    return 0;
}

/* ======================================================================
 * .pvtu: the <Piece Source="..."/> elements, in order
 * ====================================================================== */

typedef struct pvtu_piece {
    size_t value_at, value_end; /* the Source value's bytes in the text */
} pvtu_piece;

static size_t line_of(const char *s, const char *at)
{
    size_t line = 1;
    for (const char *q = s; q < at; q++)
        line += *q == '\n';
    return line;
}

/* The pieces of the .pvtu text (NUL-terminated, size bytes): comments,
 * processing instructions and CDATA are read past; each <Piece ...> must
 * have one Source attribute, quoted. */
static ffd_status pvtu_parse(const char *path, const char *s, size_t size, pvtu_piece **out,
                             size_t *count, ffd_error *err)
{
    pvtu_piece *pieces = NULL;
    size_t n = 0, cap = 0;
    int grid = 0;
    const char *end = s + size;
    *out = NULL;
    *count = 0;
    if (memchr(s, 0, size))
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: a NUL byte in the file", path,
                        line_of(s, memchr(s, 0, size)));
    for (const char *p = s; p < end; p++) {
        if (*p != '<')
            continue;
        const char *close = NULL;
        if (strncmp(p, "<!--", 4) == 0)
            close = strstr(p + 4, "-->");
        else if (strncmp(p, "<![CDATA[", 9) == 0)
            close = strstr(p + 9, "]]>");
        else if (p[1] == '?' || p[1] == '!')
            close = strchr(p, '>');
        if (p[1] == '?' || p[1] == '!') {
            if (!close) {
                free(pieces);
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: unterminated '%.4s'", path,
                                line_of(s, p), p);
            }
            p = close;
            continue;
        }
        if (strncmp(p + 1, "PUnstructuredGrid", 17) == 0 &&
            (isspace((unsigned char)p[18]) || p[18] == '>'))
            grid = 1;
        if (strncmp(p + 1, "Piece", 5) != 0 || !(isspace((unsigned char)p[6]) || p[6] == '/' ||
                                                 p[6] == '>'))
            continue;
        /* the element's attributes, up to its '>' (quotes may hold one) */
        const char *q = p + 6, *value = NULL, *value_end = NULL;
        int sources = 0;
        for (;;) {
            while (q < end && isspace((unsigned char)*q))
                q++;
            if (q >= end) {
                free(pieces);
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: unterminated <Piece>", path,
                                line_of(s, p));
            }
            if (*q == '>' || (q[0] == '/' && q[1] == '>'))
                break;
            const char *name = q;
            while (q < end && (isalnum((unsigned char)*q) || *q == '_' || *q == ':' || *q == '-'))
                q++;
            size_t name_len = (size_t)(q - name);
            while (q < end && isspace((unsigned char)*q))
                q++;
            if (name_len == 0 || *q != '=') {
                free(pieces);
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: <Piece>: expected an attribute, "
                                "found '%.10s'", path, line_of(s, q), q);
            }
            q++;
            while (q < end && isspace((unsigned char)*q))
                q++;
            char quote = *q;
            const char *close_quote = (quote == '"' || quote == '\'') ? strchr(q + 1, quote) : NULL;
            if (!close_quote) {
                free(pieces);
                return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: <Piece>: expected a quoted value",
                                path, line_of(s, q));
            }
            if (name_len == 6 && memcmp(name, "Source", 6) == 0) {
                sources++;
                value = q + 1;
                value_end = close_quote;
            }
            q = close_quote + 1;
        }
        if (sources != 1) {
            free(pieces);
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: <Piece> with %s Source attribute",
                            path, line_of(s, p), sources ? "more than one" : "no");
        }
        if (value == value_end || memchr(value, '&', (size_t)(value_end - value)) ||
            memchr(value, '\n', (size_t)(value_end - value))) {
            free(pieces);
            return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: <Piece Source=\"%.*s\">: expected a "
                            "file name (no entity references or line breaks)", path,
                            line_of(s, p), (int)(value_end - value), value);
        }
        if (n == cap) {
            cap = cap ? 2 * cap : 8;
            pvtu_piece *grown = realloc(pieces, cap * sizeof *pieces);
            if (!grown) {
                free(pieces);
                return nomem(err);
            }
            pieces = grown;
        }
        pieces[n++] = (pvtu_piece){(size_t)(value - s), (size_t)(value_end - s)};
        p = q;
    }
    if (!grid) {
        free(pieces);
        return ffd_fail(err, FFD_ERR_PARSE, "%s:1: expected a VTKFile of type "
                        "PUnstructuredGrid (a <PUnstructuredGrid> element)", path);
    }
    if (n == 0) {
        free(pieces);
        return ffd_fail(err, FFD_ERR_PARSE, "%s:%zu: no <Piece Source=\"...\"/>", path,
                        line_of(s, end));
    }
    *out = pieces;
    *count = n;
    return FFD_OK;
}

/* The output piece r's file name (no directory): OUT's stem, _r, and the
 * input piece's extension. */
static char *pvtu_out_name(const char *out, const char *source, int r)
{
    const char *base = out + dir_length(out);
    size_t stem = strlen(base) - 5; /* ".pvtu" */
    const char *slash = strrchr(source, '/');
    const char *dot = strrchr(slash ? slash : source, '.');
    return dup_printf("%.*s_%d%s", (int)stem, base, r, dot ? dot : ".vtu");
}

static ffd_status plan_pvtu(const char *parts, const char *out, int rank, int size,
                            part_plan *plan, ffd_error *err)
{
    if (!ends_with(out, ".pvtu"))
        return ffd_fail(err, FFD_ERR_INVALID, "-o %s: the input %s is a .pvtu: the output must "
                        "be one too", out, parts);
    unsigned char *text = NULL;
    size_t size_bytes = 0;
    ffd_status st = ffd_read_file(parts, &text, &size_bytes, err);
    if (st)
        return st;
    pvtu_piece *pieces = NULL;
    size_t n = 0;
    const char *s = (const char *)text;
    if ((st = pvtu_parse(parts, s, size_bytes, &pieces, &n, err))) {
        ffd_free(text);
        return st;
    }
    plan->piece_count = n;
    if (n != (size_t)size) {
        st = ffd_fail(err, FFD_ERR_INVALID, "%s names %zu piece%s but the run has %d rank%s: "
                      "run mpirun -np %zu", parts, n, n == 1 ? "" : "s", size,
                      size == 1 ? "" : "s", n);
        goto done;
    }
    const pvtu_piece *mine = &pieces[rank];
    size_t len = mine->value_end - mine->value_at;
    const char *value = s + mine->value_at;
    if (value[0] == '/')
        plan->piece = dup_printf("%.*s", (int)len, value);
    else
        plan->piece = dup_printf("%.*s%.*s", (int)dir_length(parts), parts, (int)len, value);
    char *source = dup_printf("%.*s", (int)len, value);
    char *name = source ? pvtu_out_name(out, source, rank) : NULL;
    if (name)
        plan->out_piece = dup_printf("%.*s%s", (int)dir_length(out), out, name);
    free(name);
    free(source);
    if (!plan->piece || !plan->out_piece) {
        st = nomem(err);
        goto done;
    }
    if (rank == 0) {
        /* the input's text with each Source replaced by the output piece's name */
        size_t cap = size_bytes + 1;
        char **names = calloc(n, sizeof *names);
        if (!names) {
            st = nomem(err);
            goto done;
        }
        for (size_t r = 0; r < n && st == FFD_OK; r++) {
            char *src = dup_printf("%.*s", (int)(pieces[r].value_end - pieces[r].value_at),
                                   s + pieces[r].value_at);
            names[r] = src ? pvtu_out_name(out, src, (int)r) : NULL;
            free(src);
            if (!names[r])
                st = nomem(err);
            else
                cap += strlen(names[r]);
        }
        char *t = st == FFD_OK ? malloc(cap) : NULL;
        if (st == FFD_OK && !t)
            st = nomem(err);
        if (t) {
            size_t o = 0, from = 0;
            for (size_t r = 0; r < n; r++) {
                memcpy(t + o, s + from, pieces[r].value_at - from);
                o += pieces[r].value_at - from;
                memcpy(t + o, names[r], strlen(names[r]));
                o += strlen(names[r]);
                from = pieces[r].value_end;
            }
            memcpy(t + o, s + from, size_bytes - from);
            o += size_bytes - from;
            t[o] = 0;
            plan->index_text = t;
            plan->index_size = o;
            if (!(plan->out_index = dup_printf("%s", out)))
                st = nomem(err);
        }
        for (size_t r = 0; r < n; r++)
            free(names[r]);
        free(names);
    }
done:
    free(pieces);
    ffd_free(text);
    return st;
}

/* ======================================================================
 * Gmsh: mesh.msh -> mesh_1.msh .. mesh_N.msh
 * ====================================================================== */

static char *msh_piece(const char *path, int k)
{
    return dup_printf("%.*s_%d.msh", (int)(strlen(path) - 4), path, k);
}

static ffd_status plan_msh(const char *parts, const char *out, int rank, int size,
                           part_plan *plan, ffd_error *err)
{
    if (!ends_with(out, ".msh") || has_conversion(out))
        return ffd_fail(err, FFD_ERR_INVALID, "-o %s: the input %s is a Gmsh mesh: the output "
                        "must be a .msh name too (its pieces: OUT_1.msh .. OUT_N.msh)", out, parts);
    /* the pieces present: mesh_1.msh, mesh_2.msh, ... up to the first missing */
    size_t found = 0;
    for (;;) {
        char *p = msh_piece(parts, (int)found + 1);
        if (!p)
            return nomem(err);
        int there = file_exists(p);
        free(p);
        if (!there)
            break;
        found++;
        if (found > (size_t)size) /* enough to say there are more */
            break;
    }
    if (found == 0 && size == 1) {
        /* one rank and no pieces: the whole file is the one piece */
        plan->piece_count = 1;
        plan->piece = dup_printf("%s", parts);
        plan->out_piece = dup_printf("%s", out);
        return plan->piece && plan->out_piece ? FFD_OK : nomem(err);
    }
    plan->piece_count = found;
    if (found == 0) {
        char *p = msh_piece(parts, 1);
        ffd_status st = ffd_fail(err, FFD_ERR_IO, "%s: no Gmsh pieces next to it (%s, ... as "
                                 "`gmsh -part N -part_split` writes them)", parts, p ? p : "");
        free(p);
        return st;
    }
    if (found != (size_t)size) {
        if (found > (size_t)size)
            return ffd_fail(err, FFD_ERR_INVALID, "%s has more than %d pieces (its _%zu.msh "
                            "exists) but the run has %d rank%s", parts, size, found, size,
                            size == 1 ? "" : "s");
        return ffd_fail(err, FFD_ERR_INVALID, "%s has %zu piece%s (_1.msh .. _%zu.msh) but the "
                        "run has %d rank%s: run mpirun -np %zu", parts, found,
                        found == 1 ? "" : "s", found, size, size == 1 ? "" : "s", found);
    }
    plan->piece = msh_piece(parts, rank + 1);
    plan->out_piece = msh_piece(out, rank + 1);
    return plan->piece && plan->out_piece ? FFD_OK : nomem(err);
}

/* ======================================================================
 * The plan
 * ====================================================================== */

ffd_status part_plan_make(const char *parts, const char *out, int rank, int size, part_plan *plan,
                          ffd_error *err)
{
    memset(plan, 0, sizeof *plan);
    ffd_status st;
    if (has_conversion(parts)) {
        plan->kind = PART_PATTERN;
        plan->piece_count = (size_t)size;
        int w, z;
        if (pattern_check(parts, "PARTS", &w, &z, err) || pattern_check(out, "-o", &w, &z, err))
            return FFD_ERR_INVALID;
        plan->piece = pattern_format(parts, rank);
        plan->out_piece = pattern_format(out, rank);
        char *next = pattern_format(parts, size);
        if (!plan->piece || !plan->out_piece || !next) {
            free(next);
            part_plan_free(plan);
            return nomem(err);
        }
        /* a piece for rank `size` means more pieces than ranks: refused, as
         * rank-major numbering would silently leave vertices out */
        if (file_exists(next)) {
            st = ffd_fail(err, FFD_ERR_INVALID, "%s exists: the pattern %s names more pieces "
                          "than the %d rank%s", next, parts, size, size == 1 ? "" : "s");
            free(next);
            part_plan_free(plan);
            return st;
        }
        free(next);
        return FFD_OK;
    }
    if (has_conversion(out))
        return ffd_fail(err, FFD_ERR_INVALID, "-o %s: a pattern output needs a pattern input "
                        "(PARTS with %%d)", out);
    if (ends_with(parts, ".pvtu")) {
        plan->kind = PART_PVTU;
        st = plan_pvtu(parts, out, rank, size, plan, err);
    } else if (ends_with(parts, ".msh")) {
        plan->kind = PART_MSH;
        st = plan_msh(parts, out, rank, size, plan, err);
    } else {
        st = ffd_fail(err, FFD_ERR_INVALID, "%s: expected a .pvtu, a Gmsh .msh with its pieces "
                      "NAME_1.msh .. NAME_N.msh, or a name with %%d (one file per rank)", parts);
    }
    if (st)
        part_plan_free(plan);
    return st;
}

void part_plan_free(part_plan *plan)
{
    free(plan->piece);
    free(plan->out_piece);
    free(plan->out_index);
    free(plan->index_text);
    memset(plan, 0, sizeof *plan);
}

/* ======================================================================
 * Global ids
 * ====================================================================== */

static const char *const id_names[] = {"GlobalNodeID", "GlobalNodeIds", "vtkGlobalIds"};

ffd_status part_global_ids(const ffd_mesh *piece, const char *path, uint64_t **ids,
                           const char **source, ffd_error *err)
{
    size_t n = ffd_mesh_vertex_count(piece);
    *ids = NULL;
    *source = "none";
    const uint64_t *tags = ffd_mesh_node_tags(piece);
    if (tags) {
        uint64_t *v = malloc((n ? n : 1) * sizeof *v);
        if (!v)
            return nomem(err);
        for (size_t i = 0; i < n; i++)
            v[i] = tags[i] - 1; /* tags are >= 1: tag 1 is vertex 0 of the whole mesh */
        *ids = v;
        *source = "node tags";
        return FFD_OK;
    }
    for (size_t k = 0; k < sizeof id_names / sizeof *id_names; k++) {
        double *values = NULL;
        ffd_error e = {{0}};
        ffd_status st = ffd_mesh_vertex_attribute(piece, id_names[k], &values, &e);
        if (st == FFD_ERR_INVALID) /* no such attribute */
            continue;
        if (st)
            return ffd_fail(err, st, "%s: %s", path, e.message);
        uint64_t *v = malloc((n ? n : 1) * sizeof *v);
        if (!v) {
            ffd_free(values);
            return nomem(err);
        }
        for (size_t i = 0; i < n; i++) {
            double x = values[i];
            if (!(x >= 0 && x < 9007199254740992.0 && x == floor(x))) {
                st = ffd_fail(err, FFD_ERR_RANGE, "%s: %s of vertex %zu is %.17g: expected a "
                              "whole number in 0 .. 2^53", path, id_names[k], i, x);
                free(v);
                ffd_free(values);
                return st;
            }
            v[i] = (uint64_t)x;
        }
        ffd_free(values);
        *ids = v;
        *source = id_names[k];
        return FFD_OK;
    }
    return FFD_OK;
}
