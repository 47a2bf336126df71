/* ffd — the command-line tool: dispatch to one subcommand per file, and the
 * helpers they share (cli.h). docs/cli.md is the manual. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* realpath, readlink, lstat */
#endif
#include "cli.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* The help: the generic commands, the methods' commands (cli_methods.c)
 * between deform and serve, then the rest. */
static const char usage_head[] =
    "usage: ffd COMMAND [ARGS]\n"
    "       ffd --help | --version\n"
    "\n"
    "Free-form deformation of triangle and polygon meshes (OBJ, PLY, OFF, STL).\n"
    "\n"
    "commands:\n"
    "  info MESH [--json]                     counts, bounding box and edge topology\n"
    "  convert IN OUT [--ascii|--binary|--binary-be]\n"
    "                                         rewrite a mesh in the format of OUT's extension\n"
    "  deform IN -o OUT --rig RIG [--report] [--timings] [--in-place]\n"
    "         [--ascii|--binary|--binary-be]  apply a rig (JSON or PyGeM .prm) to a mesh\n"
    "  sensitivities MESH --rig RIG -o OUT.mtx [--expand]\n"
    "                                         dX/dP of the deformed vertices (Matrix Market)\n";
static const char usage_tail[] =
    "  serve [MESH] [--port N] [--host ADDR] [--root DIR] [--web DIR] [--max-upload MB]\n"
    "        [--verbose]                      the editor: a local web server, deform in a browser\n"
    "\n"
    "global options (any command):\n"
    "  --progress                             progress on stderr as lines when it is not\n"
    "                                         a terminal (on a terminal: always a bar)\n"
    "  --quiet                                no notes, warnings or progress bar on stderr\n"
    "                                         (errors are still printed)\n"
    "\n"
    "'-' as a mesh or rig file reads standard input or writes standard output;\n"
    "--format FMT (obj, ply, off, stl, gltf, glb, vtk, vtu, msh, su2, xyz, csv or\n"
    "npy) names its format (docs/cli.md \"Pipes\").\n"
    "Run 'ffd COMMAND --help' for a command's options.\n"
    "Exit status: 0 success, 1 bad or unreadable input (or a failed write), 2 usage error.\n";

static void print_message(const char *fmt, va_list ap)
{
    cli_progress_break();
    fputs("ffd: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
}

int cli_error(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    print_message(fmt, ap);
    va_end(ap);
    return code;
}

int cli_usage_error(const char *command, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    print_message(fmt, ap);
    va_end(ap);
    if (command)
        fprintf(stderr, "Try 'ffd %s --help'.\n", command);
    else
        fputs("Try 'ffd --help'.\n", stderr);
    return CLI_EXIT_USAGE;
}

int cli_is_help(const char *arg)
{
    return strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0;
}

int cli_option_value(int argc, char **argv, int *i, const char *name, const char *short_name,
                     const char **value)
{
    const char *arg = argv[*i];
    size_t len = strlen(name);
    if (strncmp(arg, name, len) == 0 && arg[len] == '=') {
        if (*value)
            return -2; /* given twice */
        *value = arg + len + 1;
        return 1;
    }
    if (strcmp(arg, name) != 0 && !(short_name && strcmp(arg, short_name) == 0))
        return 0;
    if (*value)
        return -2;
    if (*i + 1 >= argc)
        return -1;
    *value = argv[++*i];
    return 1;
}

int cli_option_error(const char *command, const char *arg, int e)
{
    return cli_usage_error(command, e == -2 ? "'%s' given twice" : "'%s' needs a value", arg);
}

int cli_encoding_option(const char *arg, ffd_encoding *encoding)
{
    ffd_encoding e;
    if (strcmp(arg, "--ascii") == 0)
        e = FFD_ENCODING_ASCII;
    else if (strcmp(arg, "--binary") == 0)
        e = FFD_ENCODING_BINARY_LE;
    else if (strcmp(arg, "--binary-be") == 0)
        e = FFD_ENCODING_BINARY_BE;
    else if (strcmp(arg, "--base64") == 0)
        e = FFD_ENCODING_BASE64;
    else if (strcmp(arg, "--raw") == 0)
        e = FFD_ENCODING_RAW;
    else
        return 0;
    if (*encoding != FFD_ENCODING_SAME && *encoding != e)
        return -1;
    *encoding = e;
    return 1;
}

/* The canonical name of a file that may not exist yet: realpath when it
 * exists; a dangling symbolic link is followed by hand (a write would create
 * its target); otherwise the canonical directory and the last name. NULL on
 * failure to allocate; the path itself when its directory cannot be resolved. */
static char *canonical_path(const char *path, int depth)
{
    char *real = realpath(path, NULL);
    if (real)
        return real;
    const char *slash = strrchr(path, '/');
    size_t dir_len = slash ? (size_t)(slash - path) : 0;
    struct stat st;
    if (depth < 40 && lstat(path, &st) == 0 && S_ISLNK(st.st_mode)) {
        char link[4096];
        ssize_t n = readlink(path, link, sizeof link - 1);
        if (n > 0) {
            link[n] = 0;
            char *next = malloc(dir_len + (size_t)n + 2);
            if (!next)
                return NULL;
            if (link[0] == '/' || !slash)
                memcpy(next, link, (size_t)n + 1);
            else
                sprintf(next, "%.*s/%s", (int)dir_len, path, link);
            char *out = canonical_path(next, depth + 1);
            free(next);
            return out;
        }
    }
    const char *name = slash ? slash + 1 : path;
    char *dir = NULL;
    if (!slash) {
        dir = realpath(".", NULL);
    } else {
        char *d = malloc(dir_len + 2);
        if (!d)
            return NULL;
        memcpy(d, path, dir_len);
        strcpy(d + dir_len, dir_len ? "" : "/");
        dir = realpath(d, NULL);
        free(d);
    }
    size_t len = (dir ? strlen(dir) : 0) + strlen(name) + 2;
    char *out = malloc(len > strlen(path) + 1 ? len : strlen(path) + 1);
    if (out) {
        if (dir)
            snprintf(out, len, "%s/%s", strcmp(dir, "/") == 0 ? "" : dir, name);
        else
            strcpy(out, path);
    }
    free(dir);
    return out;
}

int cli_same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (strcmp(a, b) == 0)
        return 1;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char *ca = canonical_path(a, 0), *cb = canonical_path(b, 0);
    int same = ca && cb && strcmp(ca, cb) == 0;
    free(ca);
    free(cb);
    return same;
}

int cli_check_files(const char *command, const cli_file *files, size_t count)
{
    for (size_t j = 1; j < count; j++) {
        for (size_t i = 0; i < j; i++) {
            const cli_file *a = &files[i], *b = &files[j];
            if (!a->path || !b->path || (a->role == CLI_FILE_INPUT && b->role == CLI_FILE_INPUT))
                continue;
            if (cli_is_stdio(a->path) || cli_is_stdio(b->path))
                continue; /* standard input and output are not files of the command */
            if (!cli_same_file(a->path, b->path))
                continue;
            /* name the output first (the later of two outputs) */
            const cli_file *o = b->role != CLI_FILE_INPUT ? b : a, *other = o == b ? a : b;
            return cli_usage_error(command, "%s %s is the same file as %s %s: refusing to %s",
                                   o->option, o->path, other->option, other->path,
                                   other->role == CLI_FILE_OUTPUT ? "write both to one file"
                                                                  : "overwrite an input");
        }
    }
    return 0;
}

int cli_check_format(const char *command, const char *out)
{
    char names[CLI_FORMAT_NAMES_SIZE];
    if (out && !cli_is_stdio(out) && ffd_format_from_path(out) == FFD_FORMAT_AUTO)
        return cli_usage_error(command, "%s: unknown output format (expected %s)", out,
                               cli_format_names(".", names, sizeof names));
    return 0;
}

int cli_check_output(const char *command, const char *in, const char *out, int in_place)
{
    if (cli_check_format(command, out))
        return CLI_EXIT_USAGE;
    if (in_place && (cli_is_stdio(in) || cli_is_stdio(out)))
        return cli_usage_error(command, "--in-place: standard input or output ('-') is not a file");
    if (cli_is_stdio(in) || cli_is_stdio(out))
        return 0;
    int same = cli_same_file(in, out);
    if (!in_place && same)
        return cli_usage_error(command,
                               "%s: the output is the input file; pass --in-place to overwrite it",
                               out);
    if (in_place && !same)
        return cli_usage_error(command, "--in-place: %s is not the input file", out);
    return 0;
}

int cli_check_rig_inputs(const char *command, const ffd_rig *rig, const cli_file *files,
                         size_t count)
{
    for (size_t k = 0; k < ffd_rig_input_count(rig); k++) {
        for (size_t i = 0; i < count; i++) {
            const cli_file pair[2] = {
                {"the rig's skeleton file", ffd_rig_input_path(rig, k), CLI_FILE_INPUT}, files[i]};
            int bad = cli_check_files(command, pair, 2);
            if (bad)
                return bad;
        }
    }
    return 0;
}

double cli_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The command names for messages: "info, convert, deform, sensitivities, M1, M2, serve",
 * the last separator being last_sep (", " or " or "). */
static const char *command_list(char *buf, size_t size, const char *last_sep)
{
    int n = snprintf(buf, size, "info, convert, deform, sensitivities");
    for (size_t i = 0; i < cli_method_command_count() && n >= 0 && (size_t)n < size; i++)
        n += snprintf(buf + n, size - (size_t)n, ", %s", cli_method_command_at(i)->name);
    if (n >= 0 && (size_t)n < size)
        snprintf(buf + n, size - (size_t)n, "%sserve", last_sep);
    return buf;
}

int main(int argc, char **argv)
{
    char names[512];
    /* the global options, taken out wherever they are */
    int want_progress = 0, kept = 1;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--progress") == 0)
            want_progress = 1;
        else if (strcmp(argv[i], "--quiet") == 0)
            cli_quiet = 1;
        else
            argv[kept++] = argv[i];
    }
    argc = kept;
    argv[argc] = NULL;
    cli_progress_setup(want_progress);
    if (argc < 2)
        return cli_usage_error(NULL, "missing command (%s)", command_list(names, sizeof names, ", "));
    const char *command = argv[1];
    if (cli_is_help(command)) {
        fputs(usage_head, stdout);
        for (size_t i = 0; i < cli_method_command_count(); i++)
            fputs(cli_method_command_at(i)->usage, stdout);
        fputs(usage_tail, stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(command, "--version") == 0) {
        printf("ffd %d.%d.%d\n", FFD_VERSION_MAJOR, FFD_VERSION_MINOR, FFD_VERSION_PATCH);
        return CLI_EXIT_OK;
    }
    if (strcmp(command, "info") == 0)
        return cmd_info(argc - 1, argv + 1);
    if (strcmp(command, "convert") == 0)
        return cmd_convert(argc - 1, argv + 1);
    if (strcmp(command, "deform") == 0)
        return cmd_deform(argc - 1, argv + 1);
    if (strcmp(command, "sensitivities") == 0)
        return cmd_sensitivities(argc - 1, argv + 1);
    for (size_t i = 0; i < cli_method_command_count(); i++) {
        const cli_command *c = cli_method_command_at(i);
        if (strcmp(command, c->name) == 0)
            return c->run(argc - 1, argv + 1);
    }
    if (strcmp(command, "serve") == 0)
        return cmd_serve(argc - 1, argv + 1);
    if (command[0] == '-')
        return cli_usage_error(NULL, "unknown option '%s'", command);
    return cli_usage_error(NULL, "unknown command '%s' (expected %s)", command,
                           command_list(names, sizeof names, " or "));
}
