/* ffd pbffd — PB-FFD tools: `place` runs the automatic control-point
 * placement (McDonnell & Qin §3.2) and writes the control set as a rig. */
#include "cli.h"

#include <errno.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static const char usage[] =
    "usage: ffd pbffd place MESH -o CONTROLS.json [options]\n"
    "\n"
    "Places PB-FFD control points for MESH (interior points from a Voronoi\n"
    "medial-axis approximation, exterior points offset along the normals; open\n"
    "or non-manifold meshes take the open-surface path) and writes them as a\n"
    "PB-FFD rig (docs/rig.md) that can be edited and replayed with\n"
    "'ffd deform MESH -o OUT --rig CONTROLS.json'. Written atomically.\n"
    "\n"
    "options:\n"
    "  -o, --output F        the rig to write (JSON)\n"
    "  --interior N          interior control points (default 60)\n"
    "  --exterior N          exterior control points (default 60)\n"
    "  --offset F            exterior offset, fraction of the bounding-box diagonal (default 0.05)\n"
    "  --radius-factor F     radius = F x nearest-neighbour distance (default 1.5)\n"
    "  --surface KIND        auto, closed or open (default auto)\n"
    "  --voronoi-sites N     at most N vertices go into the Voronoi diagram (default 8000)\n"
    "  --no-cover            do not grow radii so that every vertex is under two points\n"
    "  --levels N            hierarchy levels recorded in the rig (default 1)\n"
    "  --points F            also write the control points as an OBJ point cloud\n"
    "  --report              print the placement report as JSON on stdout\n"
    "  --format FMT          MESH '-' is standard input in this format (obj, ply, off,\n"
    "                        stl, gltf, glb, vtk, vtu, msh, su2, xyz, csv or npy)\n"
    "  -h, --help            this help\n";

/* A positive integer, or -1. */
static long long parse_count(const char *s)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || end == s || *end || v <= 0)
        return -1;
    return v;
}

static double parse_positive(const char *s)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !(v > 0) || v > 1e300)
        return -1;
    return v;
}

static void print_report(const ffd_placement_report *r, size_t count)
{
    printf("{\"controls\": %zu, \"interior\": %zu, \"exterior\": %zu, \"open\": %s, "
           "\"fell_back\": %s, \"voronoi_sites\": %zu, \"voronoi_vertices\": %zu, "
           "\"inside_vertices\": %zu, \"grown_radii\": %zu, \"seconds_voronoi\": ",
           count, r->interior_count, r->exterior_count, r->open ? "true" : "false",
           r->fell_back ? "true" : "false", r->voronoi_sites, r->voronoi_vertices,
           r->inside_vertices, r->grown_radii);
    cli_json_number(stdout, r->seconds_voronoi);
    printf(", \"seconds_total\": ");
    cli_json_number(stdout, r->seconds_total);
    printf(", \"note\": ");
    cli_json_string(stdout, r->note);
    printf("}\n");
}

static int write_points(const char *path, const ffd_ebf *controls, size_t count, ffd_error *err)
{
    /* the points as a mesh without faces: OBJ 'v' lines */
    double *p = malloc((count ? count : 1) * 3 * sizeof *p);
    if (!p)
        return cli_error(CLI_EXIT_INPUT, "%s: out of memory", path);
    for (size_t i = 0; i < count; i++)
        memcpy(p + 3 * i, controls[i].center, sizeof controls[i].center);
    ffd_mesh *mesh = NULL;
    ffd_write_options options = {FFD_FORMAT_AUTO, FFD_ENCODING_SAME, 0};
    int code = CLI_EXIT_OK;
    if (ffd_mesh_create(p, count, NULL, NULL, 0, &mesh, err) != FFD_OK)
        code = cli_error(CLI_EXIT_INPUT, "%s: %s", path, err->message);
    else if (ffd_mesh_write(mesh, path, &options, err) != FFD_OK)
        code = cli_error(CLI_EXIT_INPUT, "%s", err->message); /* names path */
    ffd_mesh_destroy(mesh);
    free(p);
    return code;
}

static int cmd_place(int argc, char **argv)
{
    const char *in = NULL, *out = NULL, *points = NULL;
    const char *interior = NULL, *exterior = NULL, *offset = NULL, *factor = NULL;
    const char *surface = NULL, *sites = NULL, *levels = NULL, *format_text = NULL;
    int want_report = 0;
    ffd_placement_options options = {0};
    ffd_pbffd_options pb_options = {0};
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        int e = 0;
        if (cli_is_help(arg)) {
            fputs(usage, stdout);
            return CLI_EXIT_OK;
        }
        if ((e = cli_option_value(argc, argv, &i, "--output", "-o", &out)) ||
            (e = cli_option_value(argc, argv, &i, "--interior", NULL, &interior)) ||
            (e = cli_option_value(argc, argv, &i, "--exterior", NULL, &exterior)) ||
            (e = cli_option_value(argc, argv, &i, "--offset", NULL, &offset)) ||
            (e = cli_option_value(argc, argv, &i, "--radius-factor", NULL, &factor)) ||
            (e = cli_option_value(argc, argv, &i, "--surface", NULL, &surface)) ||
            (e = cli_option_value(argc, argv, &i, "--voronoi-sites", NULL, &sites)) ||
            (e = cli_option_value(argc, argv, &i, "--levels", NULL, &levels)) ||
            (e = cli_option_value(argc, argv, &i, "--points", NULL, &points)) ||
            (e = cli_option_value(argc, argv, &i, "--format", NULL, &format_text))) {
            if (e < 0)
                return cli_option_error("pbffd place", arg, e);
        } else if (strcmp(arg, "--no-cover") == 0) {
            options.no_cover = 1;
        } else if (strcmp(arg, "--report") == 0) {
            want_report = 1;
        } else if (arg[0] == '-' && arg[1] != 0) {
            return cli_usage_error("pbffd place", "unknown option '%s'", arg);
        } else if (!in) {
            in = arg;
        } else {
            return cli_usage_error("pbffd place", "unexpected argument '%s' (one mesh only)", arg);
        }
    }
    if (!in)
        return cli_usage_error("pbffd place", "missing input mesh MESH");
    if (!out)
        return cli_usage_error("pbffd place", "missing -o CONTROLS.json");
    long long v;
    if (interior) {
        if ((v = parse_count(interior)) < 0 || v > 10000000)
            return cli_usage_error("pbffd place", "--interior '%s': expected a positive integer",
                                   interior);
        options.interior_count = (size_t)v;
    }
    if (exterior) {
        if ((v = parse_count(exterior)) < 0 || v > 10000000)
            return cli_usage_error("pbffd place", "--exterior '%s': expected a positive integer",
                                   exterior);
        options.exterior_count = (size_t)v;
    }
    if (sites) {
        if ((v = parse_count(sites)) < 5)
            return cli_usage_error("pbffd place", "--voronoi-sites '%s': expected an integer >= 5",
                                   sites);
        options.voronoi_sites = (size_t)v;
    }
    if (levels) {
        if ((v = parse_count(levels)) < 0 || v > 32)
            return cli_usage_error("pbffd place", "--levels '%s': expected 1 to 32", levels);
        pb_options.levels = (uint32_t)v;
    }
    if (offset && ((options.offset = parse_positive(offset)) < 0 || options.offset > 1))
        return cli_usage_error("pbffd place",
                               "--offset '%s': expected a fraction of the diagonal in (0, 1]",
                               offset);
    if (factor && ((options.radius_factor = parse_positive(factor)) < 0 ||
                   options.radius_factor > 100))
        return cli_usage_error("pbffd place", "--radius-factor '%s': expected a number in (0, 100]",
                               factor);
    if (surface) {
        if (strcmp(surface, "auto") == 0)
            options.surface = FFD_SURFACE_AUTO;
        else if (strcmp(surface, "closed") == 0)
            options.surface = FFD_SURFACE_CLOSED;
        else if (strcmp(surface, "open") == 0)
            options.surface = FFD_SURFACE_OPEN;
        else
            return cli_usage_error("pbffd place", "--surface '%s': expected auto, closed or open",
                                   surface);
    }
    ffd_format stdio_format;
    const char *inputs[] = {"MESH", in}, *outputs[] = {"-o", out, "--points", points};
    int bad = cli_check_stdin("pbffd place", "MESH", inputs, 2, format_text, &stdio_format);
    if (!bad)
        bad = cli_check_stdout("pbffd place", outputs, 4, 0, in, stdio_format, NULL);
    if (bad)
        return bad;
    const cli_file files[] = {
        {"the input mesh", in, CLI_FILE_INPUT},
        {"-o", out, CLI_FILE_OUTPUT},
        {"--points", points, CLI_FILE_OUTPUT},
    };
    bad = cli_check_files("pbffd place", files, sizeof files / sizeof *files);
    if (bad)
        return bad;
    if (points && ffd_format_from_path(points) == FFD_FORMAT_AUTO)
        return cli_usage_error("pbffd place",
                               "--points %s: unknown format (expected .obj, .ply, .off, .stl, .gltf or .glb)",
                               points);

    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    ffd_ebf *controls = NULL;
    size_t count = 0;
    ffd_placement_report report = {0};
    int code = CLI_EXIT_INPUT;
    if (cli_mesh_read(in, stdio_format, &mesh, &err) != FFD_OK) {
        cli_error(code, "%s", err.message);
        goto done;
    }
    if (ffd_pbffd_place(mesh, &options, &controls, &count, &report, &err) != FFD_OK) {
        cli_error(code, "%s: %s", in, err.message);
        goto done;
    }
    /* the rig must replay: the library checks the levels against the count */
    ffd_pbffd *check = NULL;
    if (ffd_pbffd_create(controls, count, NULL, 0, &pb_options, &check, &err) != FFD_OK) {
        cli_error(code, "%s: --levels %u: %s", in, pb_options.levels, err.message);
        goto done;
    }
    ffd_pbffd_destroy(check);
    if (points && (code = write_points(points, controls, count, &err)) != CLI_EXIT_OK)
        goto done;
    code = CLI_EXIT_INPUT;
    if (ffd_rig_write_pbffd_controls(out, controls, count, &pb_options, &err) != FFD_OK) {
        cli_error(code, "%s", err.message);
        goto done;
    }
    if (report.note[0])
        cli_note("ffd: note: %s\n", report.note);
    if (want_report)
        print_report(&report, count);
    cli_note("wrote %s (%zu control points: %zu interior, %zu exterior; %s surface; %.3f s)\n",
            out, count, report.interior_count, report.exterior_count,
            report.open ? "open" : "closed", report.seconds_total);
    code = CLI_EXIT_OK;
done:
    ffd_free(controls);
    ffd_mesh_destroy(mesh);
    return code;
}

static int cmd_pbffd(int argc, char **argv)
{
    if (argc < 2)
        return cli_usage_error("pbffd", "missing subcommand (place)");
    if (cli_is_help(argv[1])) {
        fputs(usage, stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(argv[1], "place") == 0)
        return cmd_place(argc - 1, argv + 1);
    return cli_usage_error("pbffd", "unknown subcommand '%s' (expected place)", argv[1]);
}

const cli_command cli_command_pbffd = {
    "pbffd",
    "  pbffd place MESH -o CONTROLS.json [--interior N] [--exterior N] ...\n"
    "                                         place PB-FFD control points, write them as a rig\n",
    cmd_pbffd};
