/* ffd tspline — T-spline tools: `proxy` builds the tailored T-spline volume
 * over a mesh (Zhang, Zheng & Cai 2020, §3.2), runs a rig's steps if one is
 * given, and writes the proxy (and the full T-lattice) for inspection. */
#include "cli.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char usage[] =
    "usage: ffd tspline proxy MESH -o PROXY.obj [options]\n"
    "\n"
    "Fits a cubic T-spline volume to MESH's bounding box, finds the cells the\n"
    "mesh meets and writes the proxy: the closed polygon mesh of their boundary\n"
    "faces, over the lattice's control points (OBJ, written atomically), a\n"
    "2-manifold: a control point where inside cells touch only along an edge or\n"
    "at a vertex is written once per sheet. With --rig the rig's steps\n"
    "(refinements, deformations) run first, so the proxy\n"
    "and lattice are written as the rig leaves them. See docs/tspline.md.\n"
    "\n"
    "options:\n"
    "  -o, --output F        the proxy (OBJ: points and polygons)\n"
    "  --resolution L,M,N    control points per axis, >= 4 (default 6,6,6; or one number)\n"
    "  -r, --rig RIG         a \"tspline\" rig whose lattice and steps to use\n"
    "  --lattice F           also write the full T-lattice (OBJ: points and edges)\n"
    "  --report              print the counts as JSON on stdout\n"
    "  --format FMT          MESH '-' is standard input in this format (obj, ply, off,\n"
    "                        stl, gltf, glb, vtk, vtu, msh, su2, xyz, csv or npy);\n"
    "                        RIG '-' reads a JSON rig from standard input\n"
    "  -h, --help            this help\n";

/* "6" or "6,7,5": control points per axis. */
static int parse_resolution(const char *s, unsigned res[3])
{
    char *end;
    for (int a = 0; a < 3; a++) {
        if (*s < '0' || *s > '9') /* strtol would take " 6", "+6" */
            return -1;
        errno = 0;
        long v = strtol(s, &end, 10);
        if (errno || end == s || v < 1 || v > 100000)
            return -1;
        res[a] = (unsigned)v;
        if (a == 0 && *end == 0) {
            res[1] = res[2] = res[0];
            return 0;
        }
        if (a < 2 && *end != ',')
            return -1;
        s = end + 1;
    }
    return *end ? -1 : 0;
}

/* A number of the report's details (absent: NaN, printed as null). */
static double detail(const cJSON *details, const char *key)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(details, key);
    return cJSON_IsNumber(item) ? item->valuedouble : NAN;
}

/* A count of the report's details (absent: 0). */
static size_t detail_count(const cJSON *details, const char *key)
{
    double v = detail(details, key);
    return v >= 0 && v < 1e18 ? (size_t)v : 0;
}

static int cmd_tspline(int argc, char **argv)
{
    if (argc < 2 || cli_is_help(argv[1])) {
        fputs(usage, argc < 2 ? stderr : stdout);
        return argc < 2 ? CLI_EXIT_USAGE : CLI_EXIT_OK;
    }
    if (strcmp(argv[1], "proxy") != 0)
        return cli_usage_error("tspline", "unknown subcommand '%s' (expected proxy)", argv[1]);
    const char *in = NULL, *out = NULL, *rig_path = NULL, *lattice = NULL, *res_text = NULL;
    const char *format_text = NULL;
    int want_report = 0;
    for (int i = 2; i < argc; i++) {
        const char *arg = argv[i];
        int e;
        if (cli_is_help(arg)) {
            fputs(usage, stdout);
            return CLI_EXIT_OK;
        } else if ((e = cli_option_value(argc, argv, &i, "--output", "-o", &out)) != 0) {
            if (e < 0)
                return cli_option_error("tspline proxy", arg, e);
        } else if ((e = cli_option_value(argc, argv, &i, "--rig", "-r", &rig_path)) != 0) {
            if (e < 0)
                return cli_option_error("tspline proxy", arg, e);
        } else if ((e = cli_option_value(argc, argv, &i, "--lattice", NULL, &lattice)) != 0) {
            if (e < 0)
                return cli_option_error("tspline proxy", arg, e);
        } else if ((e = cli_option_value(argc, argv, &i, "--format", NULL, &format_text)) != 0) {
            if (e < 0)
                return cli_option_error("tspline proxy", arg, e);
        } else if ((e = cli_option_value(argc, argv, &i, "--resolution", NULL, &res_text)) != 0) {
            if (e < 0)
                return cli_option_error("tspline proxy", arg, e);
        } else if (strcmp(arg, "--report") == 0) {
            want_report = 1;
        } else if (arg[0] == '-' && arg[1] != 0) {
            return cli_usage_error("tspline proxy", "unknown option '%s'", arg);
        } else if (!in) {
            in = arg;
        } else {
            return cli_usage_error("tspline proxy", "unexpected argument '%s' (one mesh only)", arg);
        }
    }
    if (!in)
        return cli_usage_error("tspline proxy", "missing input mesh MESH");
    if (!out)
        return cli_usage_error("tspline proxy", "missing -o PROXY.obj");
    if (rig_path && res_text)
        return cli_usage_error("tspline proxy",
                               "--resolution and --rig both give the lattice size: use one");
    unsigned res[3] = {6, 6, 6};
    if (res_text && parse_resolution(res_text, res) != 0)
        return cli_usage_error("tspline proxy",
                               "--resolution '%s': expected N or L,M,N (positive integers)", res_text);
    ffd_format stdio_format;
    const char *inputs[] = {"MESH", in, "--rig", rig_path}, *outputs[] = {"-o", out, "--lattice", lattice};
    int bad = cli_check_stdin("tspline proxy", "MESH", inputs, 4, format_text, &stdio_format);
    if (!bad)
        bad = cli_check_stdout("tspline proxy", outputs, 4, 0, in, stdio_format, NULL);
    if (bad)
        return bad;
    bad = cli_check_format("tspline proxy", out);
    if (!bad)
        bad = cli_check_format("tspline proxy", lattice);
    const cli_file files[] = {
        {"the input mesh", in, CLI_FILE_INPUT},
        {"--rig", rig_path, CLI_FILE_INPUT},
        {"-o", out, CLI_FILE_OUTPUT},
        {"--lattice", lattice, CLI_FILE_OUTPUT},
    };
    if (!bad)
        bad = cli_check_files("tspline proxy", files, sizeof files / sizeof *files);
    if (bad)
        return bad;

    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    ffd_rig *rig = NULL;
    ffd_rig_report report = {0};
    int code = CLI_EXIT_INPUT;
    if (cli_mesh_read(in, stdio_format, &mesh, &err) != FFD_OK) {
        cli_error(code, "%s", err.message);
        goto done;
    }
    if (rig_path) {
        if (cli_rig_read(rig_path, &rig, &err) != FFD_OK) {
            cli_error(code, "%s", err.message);
            goto done;
        }
        if ((bad = cli_check_rig_inputs("tspline proxy", rig, files, sizeof files / sizeof *files))) {
            code = bad;
            goto done;
        }
    } else {
        char text[160], name[80];
        int len = snprintf(text, sizeof text,
                           "{\"deformer\": \"tspline\", \"resolution\": [%u, %u, %u]}", res[0],
                           res[1], res[2]);
        snprintf(name, sizeof name, "%s--resolution %u,%u,%u", res_text ? "" : "the default ",
                 res[0], res[1], res[2]);
        if (ffd_rig_parse_json(text, (size_t)len, name, &rig, &err) != FFD_OK) {
            cli_error(code, "%s", err.message);
            goto done;
        }
    }
    if (ffd_rig_apply(rig, mesh, &report, &err) != FFD_OK) {
        cli_error(code, "%s: %s", in, err.message); /* the mesh, then the rig's message */
        goto done;
    }
    if (!report.control_face_offsets) {
        cli_error(code, "%s: not a \"tspline\" rig: it has no proxy", rig_path);
        goto done;
    }
    if (ffd_rig_report_write_proxy(&report, out, &err) != FFD_OK) {
        cli_error(code, "%s", err.message);
        goto done;
    }
    if (lattice && ffd_rig_report_write_lattice(&report, lattice, &err) != FFD_OK) {
        remove(out); /* on failure nothing is written */
        cli_error(code, "%s", err.message);
        goto done;
    }
    /* the T-spline's own counts are in the report's details (docs/rig.md) */
    cJSON *details = cJSON_Parse(report.details ? report.details : "{}");
    size_t cells = detail_count(details, "cells");
    if (want_report) {
        printf("{\"control_points\": %zu, \"cells\": %zu, \"edges\": %zu, \"proxy_points\": %zu, "
               "\"proxy_faces\": %zu, \"refinements\": %zu, \"added_points\": %zu, "
               "\"max_weight_deviation\": ",
               report.control_count, cells, report.control_edge_count,
               report.control_mesh_point_count, report.control_face_count,
               detail_count(details, "refinements"), detail_count(details, "added_points"));
        cli_json_number(stdout, detail(details, "max_weight_deviation"));
        printf("}\n");
    }
    cJSON_Delete(details);
    cli_note("wrote %s (proxy: %zu points, %zu faces; lattice: %zu control points, %zu cells)\n",
            out, report.control_mesh_point_count, report.control_face_count, report.control_count,
            cells);
    code = CLI_EXIT_OK;
done:
    ffd_rig_report_free(&report);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
    return code;
}

const cli_command cli_command_tspline = {
    "tspline",
    "  tspline proxy MESH -o PROXY.obj [--resolution L,M,N] [--rig RIG] [--lattice F]\n"
    "                                         write the T-spline proxy (and T-lattice) of a mesh\n",
    cmd_tspline};
