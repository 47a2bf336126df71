/* ffd convert — rewrite a mesh in another format or encoding. */
#include "cli.h"

#include <string.h>

static const char usage[] =
    "usage: ffd convert IN OUT [ENCODING] [--in-place] [--format FMT]\n"
    "       ffd convert IN -o OUT [options]\n"
    "\n"
    "Reads IN and writes OUT in the format of OUT's extension (.obj .ply .off .stl).\n"
    "IN or OUT '-' is standard input or output, in the format --format names (OUT\n"
    "'-' without --format: the format of IN's extension).\n"
    "The same format keeps every byte but the positions; another format writes the\n"
    "geometry and the attributes that format can hold. OUT is written atomically:\n"
    "on failure an existing OUT is untouched.\n"
    "\n"
    "options:\n"
    "  --ascii       text encoding (PLY, STL)\n"
    "  --binary      binary little-endian (PLY binary_little_endian, STL binary)\n"
    "  --binary-be   binary big-endian (PLY only)\n"
    "  --base64      VTU: inline base64 data arrays (format=\"binary\")\n"
    "  --raw         VTU: raw appended data arrays\n"
    "  --compress    VTU: zlib-compressed data arrays (with --base64 or --raw)\n"
    "  --in-place    allow OUT to be IN itself\n"
    "  -o, --output OUT\n"
    "                the output, instead of the second argument\n"
    "  --format FMT  the format of '-' (obj, ply, off, stl, gltf, glb, vtk,\n"
    "                vtu, msh, su2, xyz, csv or npy)\n"
    "  -h, --help    this help\n";

int cmd_convert(int argc, char **argv)
{
    const char *in = NULL, *out = NULL, *format_text = NULL;
    ffd_write_options options = {FFD_FORMAT_AUTO, FFD_ENCODING_SAME, 0};
    int in_place = 0;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        int e;
        if (cli_is_help(arg)) {
            fputs(usage, stdout);
            return CLI_EXIT_OK;
        } else if ((e = cli_encoding_option(arg, &options.encoding)) != 0) {
            if (e < 0)
                return cli_usage_error("convert", "'%s' conflicts with an earlier encoding option",
                                       arg);
        } else if ((e = cli_option_value(argc, argv, &i, "--output", "-o", &out)) != 0) {
            if (e < 0)
                return cli_option_error("convert", arg, e);
        } else if ((e = cli_option_value(argc, argv, &i, "--format", NULL, &format_text)) != 0) {
            if (e < 0)
                return cli_option_error("convert", arg, e);
        } else if (strcmp(arg, "--compress") == 0) {
            options.compress = 1;
        } else if (strcmp(arg, "--in-place") == 0) {
            in_place = 1;
        } else if (arg[0] == '-' && arg[1] != 0) {
            return cli_usage_error("convert", "unknown option '%s'", arg);
        } else if (!in) {
            in = arg;
        } else if (!out) {
            out = arg;
        } else {
            return cli_usage_error("convert", "unexpected argument '%s'", arg);
        }
    }
    if (!in || !out)
        return cli_usage_error("convert", "expected IN and OUT");
    ffd_format stdio_format;
    const char *inputs[] = {"the input mesh", in}, *outputs[] = {"OUT", out};
    int bad = cli_check_stdin("convert", "IN", inputs, 2, format_text, &stdio_format);
    if (!bad)
        bad = cli_check_stdout("convert", outputs, 2, 1, in, stdio_format, &options.format);
    if (bad)
        return bad;
    if ((bad = cli_check_output("convert", in, out, in_place)))
        return bad;
    const cli_file files[] = {{"the input mesh", in, CLI_FILE_INPUT}, {"OUT", out, CLI_FILE_OUTPUT}};
    if (!in_place && (bad = cli_check_files("convert", files, 2)))
        return bad;

    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    if (cli_mesh_read(in, stdio_format, &mesh, &err) != FFD_OK)
        return cli_error(CLI_EXIT_INPUT, "%s", err.message);
    int code = cli_mesh_write(mesh, out, &options, &err);
    size_t nv = ffd_mesh_vertex_count(mesh), nf = ffd_mesh_face_count(mesh);
    ffd_mesh_destroy(mesh);
    if (code != CLI_EXIT_OK)
        return code;
    cli_note("wrote %s (%zu vertices, %zu faces)\n", cli_is_stdio(out) ? "<stdout>" : out, nv, nf);
    return CLI_EXIT_OK;
}
