/* cli — what the `ffd` subcommands share: exit codes, messages, option helpers,
 * JSON output. The subcommands only parse, call the library and print. */
#ifndef FFD_CLI_H
#define FFD_CLI_H

#include "ffd.h"

#include <stdio.h>

#if defined(__GNUC__)
#define CLI_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define CLI_PRINTF(a, b)
#endif

enum {
    CLI_EXIT_OK = 0,
    CLI_EXIT_INPUT = 1, /* a file could not be read, parsed, deformed or written */
    CLI_EXIT_USAGE = 2  /* bad command line */
};

/* Prints "ffd: MESSAGE" to stderr and returns code. */
int cli_error(int code, const char *fmt, ...) CLI_PRINTF(2, 3);
/* Prints "ffd: MESSAGE" and a pointer to `ffd COMMAND --help`; returns CLI_EXIT_USAGE. */
int cli_usage_error(const char *command, const char *fmt, ...) CLI_PRINTF(2, 3);
/* The usage error for a negative cli_option_value result e on option arg. */
int cli_option_error(const char *command, const char *arg, int e);

/* 1 when arg is -h or --help. */
int cli_is_help(const char *arg);

/* Matches an option taking a value, as "NAME VALUE" or "NAME=VALUE" (short
 * names only the first form). Returns 1 and sets *value (advancing *i) on a
 * match, 0 when argv[*i] is another argument, -1 when the value is missing. */
/* Returns 1 when argv[*i] is the option (value stored), 0 when not, -1 when the value is
 * missing, -2 when the option was already given. */
int cli_option_value(int argc, char **argv, int *i, const char *name, const char *short_name,
                     const char **value);

/* Matches --ascii, --binary, --binary-be. Returns 1 and sets *encoding on a
 * match, 0 when arg is something else, -1 when another encoding was already given. */
int cli_encoding_option(const char *arg, ffd_encoding *encoding);

/* Checks an output path before any work: a known mesh extension, and not the
 * input file (same path, or same device and inode) unless in_place. Returns 0,
 * or prints a usage error for command and returns CLI_EXIT_USAGE. */
int cli_check_output(const char *command, const char *in, const char *out, int in_place);
/* The first half of cli_check_output: out (NULL: skipped) has a mesh extension. */
int cli_check_format(const char *command, const char *out);

/* 1 when a and b name the same file: same device and inode when both exist
 * (a symbolic or hard link to a file is that file), else the same canonical
 * directory and name (two outputs not yet written, a directory reached
 * through a symbolic link). */
int cli_same_file(const char *a, const char *b);

/* A file a command reads or writes, for cli_check_files. */
typedef enum { CLI_FILE_INPUT, CLI_FILE_OUTPUT, CLI_FILE_IN_PLACE } cli_file_role;
typedef struct cli_file {
    const char *option; /* how the user named it: "-o", "--lattice-out", "the input mesh" */
    const char *path;   /* NULL: not given (skipped) */
    cli_file_role role; /* CLI_FILE_IN_PLACE: an input the command rewrites (--in-place) */
} cli_file;

/* The one aliasing rule of every command, checked before any work: no
 * output (CLI_FILE_OUTPUT or CLI_FILE_IN_PLACE) is an input or another output
 * (cli_same_file). Returns 0, or prints a usage error naming both options
 * ("--lattice-out a.obj is the same file as the input mesh a.obj") and
 * returns CLI_EXIT_USAGE. */
int cli_check_files(const char *command, const cli_file *files, size_t count);
/* cli_check_files for the outputs in files (count of them) against the files
 * the rig read besides itself (ffd_rig_input_path: files its method section names), once
 * the rig is read and before any work. */
int cli_check_rig_inputs(const char *command, const ffd_rig *rig, const cli_file *files,
                         size_t count);

/* Standard input and output (cli_stream.c, docs/cli.md "Pipes"). */
extern int cli_quiet;          /* --quiet: no notes or warnings on stderr */
extern int cli_progress_lines; /* progress as "ffd: STAGE: N%" lines */
/* 1 when path is "-": standard input (an input) or output (an output). */
int cli_is_stdio(const char *path);
/* The format named by --format ("obj", "ply", ...: the codec table's
 * extensions), or FFD_FORMAT_AUTO when unknown. */
ffd_format cli_format_from_name(const char *name);
/* "OBJ", "PLY", "glTF", ...: the codec's name, for messages. */
const char *cli_format_label(ffd_format format);
/* "obj", "ply", "gltf", ...: the codec's first extension, for info. */
const char *cli_format_name(ffd_format format);
/* "obj, ply, off, stl, gltf or glb": every extension of the mesh codec table,
 * each after dot ("" for --format's names, "." for file names), in buf. */
const char *cli_format_names(const char *dot, char *buf, size_t size);
#define CLI_FORMAT_NAMES_SIZE 160
/* A command's standard input, checked before any work: parses --format
 * (format_text may be NULL: *format AUTO), refuses two inputs that are both
 * "-", and a mesh from "-" without --format. inputs: count/2 pairs (how the
 * user named it, path), the input mesh first; mesh_name is how the usage
 * names the mesh ("IN", "MESH"). Returns 0 or the usage error's exit code. */
int cli_check_stdin(const char *command, const char *mesh_name, const char *const *inputs,
                    size_t count, const char *format_text, ffd_format *format);
/* A command's standard output, checked before any work. outputs: count/2
 * pairs (how the user named it, path). mesh_first: the first output is a
 * mesh that may be "-" (its format: format from --format, else in's
 * extension, set in *out_format; refused when neither) and the others are
 * files only; 0: every output is a file only. Returns 0 or the usage
 * error's exit code. */
int cli_check_stdout(const char *command, const char *const *outputs, size_t count,
                     int mesh_first, const char *in, ffd_format format, ffd_format *out_format);
/* Reads all of standard input (free *data with free); limit 0: none, else reading stops after a
 * little more than limit bytes (the parser then refuses it naming its limit). */
ffd_status cli_read_stdin(size_t limit, unsigned char **data, size_t *size, ffd_error *err);
/* ffd_mesh_read, or for "-" standard input in format (not AUTO). */
ffd_status cli_mesh_read(const char *path, ffd_format format, ffd_mesh **out, ffd_error *err);
/* ffd_rig_read, or for "-" a JSON rig from standard input ("<stdin>"). */
ffd_status cli_rig_read(const char *path, ffd_rig **out, ffd_error *err);
/* ffd_mesh_write, or for "-" the whole mesh made in memory and then written
 * to standard output (nothing on failure; binary bytes are refused when
 * stdout is a terminal). options->format must be set for "-". Prints the
 * error and returns the exit code. */
int cli_mesh_write(const ffd_mesh *mesh, const char *path, const ffd_write_options *options,
                   ffd_error *err);
/* Ends an unfinished progress bar's line (a stage that failed), so that a
 * message starts on a line of its own. */
void cli_progress_break(void);
/* A note or warning on stderr, unless --quiet. */
void cli_note(const char *fmt, ...) CLI_PRINTF(1, 2);
/* Installs the progress hook: a bar when stderr is a terminal (and not
 * --quiet), "ffd: STAGE: N%" lines when want_lines (--progress) and it is not. */
void cli_progress_setup(int want_lines);

/* Monotonic seconds. */
double cli_now(void);

/* JSON output: a quoted, escaped string; a number (null when not finite). */
void cli_json_string(FILE *f, const char *s);
void cli_json_number(FILE *f, double v);
/* The report on stdout, one line of JSON: residuals, then the method's
 * details, the inversions and the fold check when not NULL (`ffd deform
 * --report`; cli_report.c). */
void cli_print_report(const ffd_rig_report *report, const ffd_inversion_report *inv,
                      const ffd_fold_report *folds);
/* "8G", "512M", "3000000000": bytes (--max-memory); 0 on a malformed or zero
 * size (cli_report.c). */
size_t cli_parse_size(const char *text);

/* Subcommands: argv[0] is the command name. Each returns the exit code. */
int cmd_info(int argc, char **argv);
int cmd_convert(int argc, char **argv);
int cmd_deform(int argc, char **argv);
int cmd_sensitivities(int argc, char **argv);
int cmd_serve(int argc, char **argv);

/* A method's own command (`ffd METHOD SUBCOMMAND ...`), described in the
 * method's tools/cli/cmd_<method>.c and listed in cli_methods.c. */
typedef struct cli_command {
    const char *name;  /* argv[1] */
    const char *usage; /* its lines of the top-level help, each "  ...\n" */
    int (*run)(int argc, char **argv); /* argv[0] is name; returns the exit code */
} cli_command;

/* The methods' commands, in the order the help lists them (i < count). */
size_t cli_method_command_count(void);
const cli_command *cli_method_command_at(size_t i);

#endif
