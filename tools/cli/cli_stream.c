/* cli_stream — "-" for standard input and output (meshes and rigs), the
 * --format option that names their format, and progress and notes on
 * standard error (--progress, --quiet). docs/cli.md "Pipes". */
#include "cli.h"

#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int cli_quiet;
int cli_progress_lines;
static int bar_open; /* a progress bar is on stderr's last line */

/* The largest rig read from standard input: the rig reader's own limit
 * (docs/rig.md); one byte more is read so that the reader refuses it with
 * the limit named. */
#define CLI_RIG_MAX_BYTES ((size_t)64 << 20)

int cli_is_stdio(const char *path)
{
    return path && strcmp(path, "-") == 0;
}

ffd_format cli_format_from_name(const char *name)
{
    /* the codec table's extensions are the format names: ".ply" -> PLY */
    char ext[32];
    if (!name || !*name || strchr(name, '.') || strchr(name, '/') ||
        (size_t)snprintf(ext, sizeof ext, ".%s", name) >= sizeof ext)
        return FFD_FORMAT_AUTO;
    return ffd_format_from_path(ext);
}

const char *cli_format_label(ffd_format format)
{
    switch (format) {
    case FFD_FORMAT_OBJ: return "OBJ";
    case FFD_FORMAT_PLY: return "PLY";
    case FFD_FORMAT_OFF: return "OFF";
    case FFD_FORMAT_STL: return "STL";
    default: return "mesh";
    }
}

int cli_check_stdio(const char *command, const char *const *inputs, size_t count,
                    const char *format_text, ffd_format *format)
{
    *format = FFD_FORMAT_AUTO;
    if (format_text) {
        *format = cli_format_from_name(format_text);
        if (*format == FFD_FORMAT_AUTO)
            return cli_usage_error(command,
                                   "--format '%s': unknown format (expected obj, ply, off or stl)",
                                   format_text);
    }
    const char *first = NULL;
    for (size_t i = 0; i < count; i += 2) {
        if (!cli_is_stdio(inputs[i + 1]))
            continue;
        if (first)
            return cli_usage_error(command,
                                   "%s and %s both read standard input ('-'): only one input can",
                                   first, inputs[i]);
        first = inputs[i];
    }
    return 0;
}

ffd_status cli_read_stdin(size_t limit, unsigned char **data, size_t *size, ffd_error *err)
{
    *data = NULL;
    *size = 0;
    size_t cap = 65536, n = 0;
    unsigned char *buf = malloc(cap + 1);
    if (!buf) {
        snprintf(err->message, sizeof err->message, "<stdin>: out of memory");
        return FFD_ERR_NOMEM;
    }
    for (;;) {
        if (n == cap) {
            if (limit && cap > limit)
                break; /* more than the limit: the reader names it */
            size_t next = cap * 2;
            unsigned char *grown = next > cap ? malloc(next + 1) : NULL;
            if (!grown) {
                free(buf);
                snprintf(err->message, sizeof err->message,
                         "<stdin>: out of memory after %zu bytes", n);
                return FFD_ERR_NOMEM;
            }
            memcpy(grown, buf, n);
            free(buf);
            buf = grown;
            cap = next;
        }
        size_t got = fread(buf + n, 1, cap - n, stdin);
        n += got;
        if (got == 0)
            break;
    }
    if (ferror(stdin)) {
        free(buf);
        snprintf(err->message, sizeof err->message, "<stdin>: read error");
        return FFD_ERR_IO;
    }
    buf[n] = 0;
    *data = buf;
    *size = n;
    return FFD_OK;
}

ffd_status cli_mesh_read(const char *path, ffd_format format, ffd_mesh **out, ffd_error *err)
{
    if (!cli_is_stdio(path))
        return ffd_mesh_read(path, out, err);
    unsigned char *data;
    size_t size;
    ffd_status s = cli_read_stdin(0, &data, &size, err);
    if (s != FFD_OK)
        return s;
    s = ffd_mesh_read_memory(data, size, format, "<stdin>", out, err);
    free(data);
    return s;
}

ffd_status cli_rig_read(const char *path, ffd_rig **out, ffd_error *err)
{
    if (!cli_is_stdio(path))
        return ffd_rig_read(path, out, err);
    unsigned char *data;
    size_t size;
    ffd_status s = cli_read_stdin(CLI_RIG_MAX_BYTES, &data, &size, err);
    if (s != FFD_OK)
        return s;
    s = ffd_rig_parse_json((const char *)data, size, "<stdin>", out, err);
    free(data);
    return s;
}

/* Bytes a terminal would show as garbage: NUL and control characters other
 * than white space. */
static int is_binary(const unsigned char *data, size_t size)
{
    for (size_t i = 0; i < size; i++)
        if (data[i] == 0 || (data[i] < 0x20 && !strchr("\t\n\v\f\r", data[i])) || data[i] == 0x7f)
            return 1;
    return 0;
}

int cli_mesh_write(const ffd_mesh *mesh, const char *path, const ffd_write_options *options,
                   ffd_error *err)
{
    if (!cli_is_stdio(path))
        return ffd_mesh_write(mesh, path, options, err) == FFD_OK
                   ? CLI_EXIT_OK
                   : cli_error(CLI_EXIT_INPUT, "%s", err->message);
    unsigned char *data = NULL;
    size_t size = 0;
    if (ffd_mesh_write_memory(mesh, options, &data, &size, err) != FFD_OK)
        return cli_error(CLI_EXIT_INPUT, "<stdout>: %s", err->message);
    if (isatty(STDOUT_FILENO) && is_binary(data, size)) {
        ffd_free(data);
        return cli_usage_error(NULL,
                               "refusing to write binary %s to a terminal; redirect or use -o FILE",
                               cli_format_label(options->format));
    }
    size_t put = fwrite(data, 1, size, stdout);
    ffd_free(data);
    if (put != size || fflush(stdout) != 0)
        return cli_error(CLI_EXIT_INPUT, "<stdout>: write error");
    return CLI_EXIT_OK;
}

void cli_progress_break(void)
{
    if (bar_open)
        fputc('\n', stderr);
    bar_open = 0;
}

void cli_note(const char *fmt, ...)
{
    if (cli_quiet)
        return;
    cli_progress_break();
    va_list ap;
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
}

/* ffd_set_progress's hook: a bar on a terminal, else "ffd: STAGE: N%" lines
 * (--progress). */
static void draw_progress(void *user, const char *stage, double fraction)
{
    int *last = user; /* the last percentage printed, as lines */
    int percent = (int)(fraction * 100 + 0.5);
    if (!cli_progress_lines) {
        char bar[31];
        int filled = (int)(fraction * 30);
        for (int i = 0; i < 30; i++)
            bar[i] = i < filled ? '#' : ' ';
        bar[30] = 0;
        fprintf(stderr, "\rffd: %-16s [%s] %3d%%%s", stage, bar, percent,
                fraction >= 1 ? "\n" : "");
        fflush(stderr);
        bar_open = fraction < 1;
        return;
    }
    if (fraction == 0)
        *last = -1;
    if (percent == *last)
        return;
    *last = percent;
    fprintf(stderr, "ffd: %s: %d%%\n", stage, percent);
}

void cli_progress_setup(int want_lines)
{
    static int last = -1;
    if (isatty(STDERR_FILENO) && !cli_quiet) {
        cli_progress_lines = 0;
        ffd_set_progress(draw_progress, &last);
    } else if (want_lines) {
        cli_progress_lines = 1;
        ffd_set_progress(draw_progress, &last);
    }
}
