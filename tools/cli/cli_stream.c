/* cli_stream — "-" for standard input and output (meshes and rigs), the
 * --format option that names their format, and progress and notes on
 * standard error (--progress, --quiet). docs/cli.md "Pipes". */
#include "cli.h"
#include "mesh/mesh_codec.h"

#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int cli_quiet;
int cli_progress_lines;
static int bar_open; /* a progress bar is on stderr's last line */

/* A stage shorter than this draws no bar on a terminal (a small mesh's
 * reading would flash one); the --progress lines report every stage. */
#define CLI_BAR_DELAY_SECONDS 1.0

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
    const ffd_mesh_codec *codec = ffd_mesh_codec_find(format);
    return codec ? codec->name : "mesh";
}

const char *cli_format_name(ffd_format format)
{
    const ffd_mesh_codec *codec = ffd_mesh_codec_find(format);
    return codec ? codec->extensions[0] : "unknown";
}

/* The codecs in the table's order: ffd_format's values from the first. */
static const ffd_mesh_codec *codec_at(size_t i)
{
    return ffd_mesh_codec_find((ffd_format)(FFD_FORMAT_AUTO + 1 + i));
}

const char *cli_format_names(const char *dot, char *buf, size_t size)
{
    size_t count = 0, at = 0;
    for (size_t i = 0; codec_at(i); i++)
        for (const char *const *e = codec_at(i)->extensions; *e; e++)
            count++;
    buf[0] = 0;
    size_t k = 0;
    for (size_t i = 0; codec_at(i); i++) {
        for (const char *const *e = codec_at(i)->extensions; *e && at < size; e++, k++) {
            const char *sep = k == 0 ? "" : k + 1 == count ? " or " : ", ";
            int n = snprintf(buf + at, size - at, "%s%s%s", sep, dot, *e);
            if (n < 0)
                return buf;
            at += (size_t)n;
        }
    }
    return buf;
}

int cli_check_stdin(const char *command, const char *mesh_name, const char *const *inputs,
                    size_t count, const char *format_text, ffd_format *format)
{
    char names[CLI_FORMAT_NAMES_SIZE];
    *format = FFD_FORMAT_AUTO;
    if (format_text) {
        *format = cli_format_from_name(format_text);
        if (*format == FFD_FORMAT_AUTO)
            return cli_usage_error(command, "--format '%s': unknown format (expected %s)",
                                   format_text, cli_format_names("", names, sizeof names));
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
    if (count && cli_is_stdio(inputs[1]) && !*format)
        return cli_usage_error(command, "%s '-' (standard input) needs --format FMT (%s)",
                               mesh_name, cli_format_names("", names, sizeof names));
    return 0;
}

int cli_check_stdout(const char *command, const char *const *outputs, size_t count,
                     int mesh_first, const char *in, ffd_format format, ffd_format *out_format)
{
    for (size_t i = mesh_first ? 2 : 0; i < count; i += 2)
        if (cli_is_stdio(outputs[i + 1]))
            return mesh_first ? cli_usage_error(command,
                                                "%s -: only the mesh (%s) can go to standard output",
                                                outputs[i], outputs[0])
                              : cli_usage_error(command, "%s -: this command writes files only",
                                                outputs[i]);
    if (!mesh_first || count < 2 || !cli_is_stdio(outputs[1]))
        return 0;
    *out_format = format ? format : ffd_format_from_path(in);
    if (!*out_format) {
        char names[CLI_FORMAT_NAMES_SIZE];
        return cli_usage_error(command, "%s '-' (standard output) needs --format FMT (%s)",
                               outputs[0], cli_format_names("", names, sizeof names));
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

/* What draw_progress keeps between calls. */
typedef struct progress_state {
    int last;       /* the last percentage printed, as lines */
    double started; /* when the stage began (cli_now) */
} progress_state;

/* ffd_set_progress's hook: a bar on a terminal once a stage has run for
 * CLI_BAR_DELAY_SECONDS, else "ffd: STAGE: N%" lines (--progress). */
static void draw_progress(void *user, const char *stage, double fraction)
{
    progress_state *state = user;
    int *last = &state->last;
    int percent = (int)(fraction * 100 + 0.5);
    if (fraction == 0 && !bar_open)
        state->started = cli_now();
    if (!cli_progress_lines) {
        if (!bar_open && cli_now() - state->started < CLI_BAR_DELAY_SECONDS)
            return;
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
    static progress_state state = {-1, 0};
    if (isatty(STDERR_FILENO) && !cli_quiet) {
        cli_progress_lines = 0;
        ffd_set_progress(draw_progress, &state);
    } else if (want_lines) {
        cli_progress_lines = 1;
        ffd_set_progress(draw_progress, &state);
    }
}
