/* ffd deform — apply a rig (JSON or PyGeM .prm) to a mesh and write the result. */
#include "cli.h"
#include "core/core.h" /* ffd_write_file_atomic: the checked bytes are the ones written */

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char usage[] =
    "usage: ffd deform IN -o OUT --rig RIG [options]\n"
    "       ffd deform IN --in-place --rig RIG [options]\n"
    "       ffd deform - -o - --rig RIG --format FMT < IN > OUT\n"
    "\n"
    "Reads the mesh IN and the rig RIG (JSON, or PyGeM FFD parameters when the name\n"
    "ends in .prm; see docs/rig.md), deforms the mesh and writes OUT in the format\n"
    "of its extension. OUT is written atomically: on failure an existing OUT is\n"
    "untouched, and IN is never modified unless --in-place is given. IN, OUT or\n"
    "RIG '-' is standard input or output (one input at most; a rig from standard\n"
    "input is JSON); OUT '-' is written only when all went well.\n"
    "\n"
    "options:\n"
    "  -o, --output OUT  the deformed mesh\n"
    "  -r, --rig RIG     the rig file\n"
    "  --format FMT      the format of IN or OUT '-' (obj, ply, off, stl, gltf,\n"
    "                    glb, vtk, vtu, msh, su2, xyz, csv or npy; OUT '-' without\n"
    "                    it: the format of IN's extension)\n"
    "  --in-place        allow OUT to be IN (OUT defaults to IN)\n"
    "  --report          print the report as JSON on stdout: residuals, then the\n"
    "                    method's details (docs/rig.md \"The report\"), the inverted\n"
    "                    cells and flipped faces (\"inversions\") and the fold check\n"
    "                    of the map (\"folds\"; docs/volume.md)\n"
    "  --fail-on-inversion  exit 1 without writing anything when a cell inverted or\n"
    "                    a face flipped (the message names the count and the worst cell)\n"
    "  --lattice-out F   also write the deformed control structure to F (OBJ: its\n"
    "                    control points, and lines along its edges or grid if it has\n"
    "                    them; what each method writes: docs/cli.md)\n"
    "  --proxy-out F     also write the deformed control mesh (proxy) to F (OBJ), for\n"
    "                    a method that has one (docs/cli.md)\n"
    "  --timings         print the seconds per phase as JSON on stderr\n"
    "  --max-memory SIZE raise the limits (docs/rig.md \"Limits\"): refuse a step estimated\n"
    "                    to need more than SIZE bytes (K, M, G, T suffixes: 8G; default 2G),\n"
    "                    and allow work in proportion (SIZE/2G times the default)\n"
    "  --no-limits       no limits on memory or work (batch runs you watch)\n"
    "  --ascii           text encoding (PLY, STL)\n"
    "  --binary          binary little-endian (PLY, STL)\n"
    "  --binary-be       binary big-endian (PLY)\n"
    "  --base64          VTU: inline base64 data arrays (format=\"binary\")\n"
    "  --raw             VTU: raw appended data arrays\n"
    "  --compress        VTU: zlib-compressed data arrays (with --base64 or --raw)\n"
    "  -h, --help        this help\n";

static void print_timings(double read, const ffd_timings *t, double write)
{
    fprintf(stderr, "{\"read\": %.6f, \"bind\": %.6f, \"solve\": %.6f, \"evaluate\": %.6f,"
                    " \"write\": %.6f}\n",
            read, t->bind, t->solve, t->evaluate, write);
}

int cmd_deform(int argc, char **argv)
{
    const char *in = NULL, *out = NULL, *rig_path = NULL, *lattice_out = NULL, *proxy_out = NULL;
    ffd_write_options options = {FFD_FORMAT_AUTO, FFD_ENCODING_SAME, 0};
    int in_place = 0, want_report = 0, want_timings = 0, fail_on_inversion = 0;
    const char *max_memory = NULL, *format_text = NULL;
    ffd_limits limits = {0};
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        int e;
        if (cli_is_help(arg)) {
            fputs(usage, stdout);
            return CLI_EXIT_OK;
        } else if ((e = cli_option_value(argc, argv, &i, "--output", "-o", &out)) != 0) {
            if (e < 0)
                return cli_option_error("deform", arg, e);
        } else if ((e = cli_option_value(argc, argv, &i, "--rig", "-r", &rig_path)) != 0) {
            if (e < 0)
                return cli_option_error("deform", arg, e);
        } else if ((e = cli_option_value(argc, argv, &i, "--lattice-out", NULL, &lattice_out)) !=
                   0) {
            if (e < 0)
                return cli_option_error("deform", arg, e);
        } else if ((e = cli_option_value(argc, argv, &i, "--proxy-out", NULL, &proxy_out)) != 0) {
            if (e < 0)
                return cli_option_error("deform", arg, e);
        } else if ((e = cli_option_value(argc, argv, &i, "--max-memory", NULL, &max_memory)) !=
                   0) {
            if (e < 0)
                return cli_option_error("deform", arg, e);
            if (!(limits.max_memory = cli_parse_size(max_memory)))
                return cli_usage_error("deform",
                                       "--max-memory '%s': expected a size such as 8G, 512M or "
                                       "a number of bytes",
                                       max_memory);
            /* more memory granted: proportionally more work (docs/rig.md "Limits") */
            double scale = (double)limits.max_memory / 2147483648.0;
            limits.max_work = 3e10 * (scale > 1 ? scale : 1);
        } else if ((e = cli_option_value(argc, argv, &i, "--format", NULL, &format_text)) != 0) {
            if (e < 0)
                return cli_option_error("deform", arg, e);
        } else if (strcmp(arg, "--no-limits") == 0) {
            limits.unlimited = 1;
        } else if ((e = cli_encoding_option(arg, &options.encoding)) != 0) {
            if (e < 0)
                return cli_usage_error("deform", "'%s' conflicts with an earlier encoding option",
                                       arg);
        } else if (strcmp(arg, "--compress") == 0) {
            options.compress = 1;
        } else if (strcmp(arg, "--in-place") == 0) {
            in_place = 1;
        } else if (strcmp(arg, "--report") == 0) {
            want_report = 1;
        } else if (strcmp(arg, "--fail-on-inversion") == 0) {
            fail_on_inversion = 1;
        } else if (strcmp(arg, "--timings") == 0) {
            want_timings = 1;
        } else if (arg[0] == '-' && arg[1] != 0) {
            return cli_usage_error("deform", "unknown option '%s'", arg);
        } else if (!in) {
            in = arg;
        } else {
            return cli_usage_error("deform", "unexpected argument '%s' (one input mesh only)", arg);
        }
    }
    if (!in)
        return cli_usage_error("deform", "missing input mesh IN");
    if (!rig_path)
        return cli_usage_error("deform", "missing --rig RIG");
    if (!out) {
        if (!in_place)
            return cli_usage_error("deform", "missing -o OUT (or --in-place to overwrite IN)");
        out = in;
    }
    ffd_format stdio_format;
    const char *inputs[] = {"the input mesh", in, "--rig", rig_path};
    const char *outputs[] = {"-o", out, "--lattice-out", lattice_out, "--proxy-out", proxy_out};
    int bad = cli_check_stdin("deform", "IN", inputs, 4, format_text, &stdio_format);
    if (!bad)
        bad = cli_check_stdout("deform", outputs, 6, 1, in, stdio_format, &options.format);
    if (bad)
        return bad;
    if (cli_is_stdio(out) && want_report)
        return cli_usage_error("deform", "--report prints on standard output, which -o - "
                                         "writes the mesh to: use -o FILE");
    if ((bad = cli_check_output("deform", in, out, in_place)))
        return bad;
    const cli_file files[] = {
        {in_place ? "the input mesh (--in-place)" : "the input mesh", in,
         in_place ? CLI_FILE_IN_PLACE : CLI_FILE_INPUT},
        {"--rig", rig_path, CLI_FILE_INPUT},
        {"-o", in_place ? NULL : out, CLI_FILE_OUTPUT},
        {"--lattice-out", lattice_out, CLI_FILE_OUTPUT},
        {"--proxy-out", proxy_out, CLI_FILE_OUTPUT},
    };
    if ((bad = cli_check_files("deform", files, sizeof files / sizeof *files)))
        return bad;

    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    ffd_rig *rig = NULL;
    unsigned char *bytes = NULL; /* the output mesh, made before any file is written */
    size_t nbytes = 0;
    ffd_rig_report report = {0};
    ffd_inversion_report inv = {0};
    ffd_fold_report folds = {0};
    int have_inv = 0, have_folds = 0;
    double *rest = NULL;
    ffd_deformer *deformer = NULL;
    int code = CLI_EXIT_INPUT;
    double t0 = cli_now();
    if (cli_mesh_read(in, stdio_format, &mesh, &err) != FFD_OK ||
        cli_rig_read(rig_path, &rig, &err) != FFD_OK) {
        cli_error(code, "%s", err.message);
        goto done;
    }
    if ((bad = cli_check_rig_inputs("deform", rig, files, sizeof files / sizeof *files))) {
        code = bad;
        goto done;
    }
    size_t rest_count = ffd_mesh_vertex_count(mesh);
    if (want_report || fail_on_inversion) {
        /* the rest state for the inversion check, and the rig's deformer
         * (the rig replayed once more) for the fold check of its map */
        rest = malloc((rest_count ? rest_count : 1) * 3 * sizeof *rest);
        if (!rest) {
            cli_error(code, "%s: out of memory", in);
            goto done;
        }
        memcpy(rest, ffd_mesh_positions(mesh), rest_count * 3 * sizeof *rest);
        if (want_report) {
            ffd_error ferr = {{0}};
            /* a rig no deformer replays (GFFD's resampling or replacement
             * changes the mesh) has no fold check; its own errors come
             * from the application below */
            ffd_status fs = ffd_deformer_create(rig, mesh, &limits, &deformer, &ferr);
            if (fs == FFD_OK)
                fs = ffd_deformer_fold_check(deformer, &folds, &ferr);
            else
                fs = FFD_ERR_UNSUPPORTED;
            if (fs == FFD_OK) {
                have_folds = 1;
            } else if (fs != FFD_ERR_UNSUPPORTED) {
                cli_error(code, "%s: fold check: %s", in, ferr.message);
                goto done;
            }
            ffd_deformer_destroy(deformer);
            deformer = NULL;
        }
    }
    double t1 = cli_now();
    if (ffd_rig_apply_limited(rig, mesh, &limits, &report, &err) != FFD_OK) {
        cli_error(code, "%s: %s", in, err.message); /* the mesh, then the rig's message */
        goto done;
    }
    if (rest && ffd_mesh_vertex_count(mesh) == rest_count) {
        if (ffd_mesh_check_inversions(mesh, rest, 0, &inv, &err) != FFD_OK) {
            cli_error(code, "%s: inversion check: %s", in, err.message);
            goto done;
        }
        have_inv = 1;
    } else if (fail_on_inversion) {
        cli_error(code, "%s: --fail-on-inversion: the %s method replaced the mesh (%zu vertices, "
                        "%zu at rest): its cells cannot be compared with the rest state",
                  in, report.method ? report.method : "rig's", ffd_mesh_vertex_count(mesh),
                  rest_count);
        goto done;
    }
    if (fail_on_inversion && (inv.inverted || inv.flipped_faces)) {
        if (inv.inverted)
            cli_error(code,
                      "%s: %zu cell%s inverted (worst det J %.6g at cell %zu), %zu face%s "
                      "flipped: nothing written (--fail-on-inversion)",
                      in, inv.inverted, inv.inverted == 1 ? "" : "s", inv.worst_det,
                      inv.worst_cell, inv.flipped_faces, inv.flipped_faces == 1 ? "" : "s");
        else
            cli_error(code, "%s: %zu face%s flipped (the first: face %u): nothing written "
                            "(--fail-on-inversion)",
                      in, inv.flipped_faces, inv.flipped_faces == 1 ? "" : "s", inv.face_ids[0]);
        goto done;
    }
    double t2 = cli_now();
    /* Every output is made before any is written: a deformation or encoding
     * error leaves every file as it was. Then the side outputs, the mesh last;
     * on a write failure the outputs this run created are removed, and files
     * that existed before keep their old bytes or get the complete new ones
     * (each write is atomic). */
    int to_stdout = cli_is_stdio(out);
    int lattice_existed = lattice_out && access(lattice_out, F_OK) == 0;
    int proxy_existed = proxy_out && access(proxy_out, F_OK) == 0;
    ffd_write_options check = options;
    if (check.format == FFD_FORMAT_AUTO)
        check.format = ffd_format_from_path(out);
    if (!to_stdout && ffd_mesh_write_memory(mesh, &check, &bytes, &nbytes, &err) != FFD_OK) {
        cli_error(code, "%s: %s", out, err.message);
        goto done;
    }
    /* The bytes just made are the file ffd_mesh_write would make again
     * (its memory write, then an atomic write); glTF writes through its
     * codec (external buffers) and standard output is made once, by
     * cli_mesh_write, before it writes. */
    if (bytes && check.format == FFD_FORMAT_GLTF) {
        ffd_free(bytes);
        bytes = NULL;
    }
    if (lattice_out && ffd_rig_report_write_lattice(&report, lattice_out, &err) != FFD_OK) {
        cli_error(code, "%s", err.message);
        goto done;
    }
    if (proxy_out && ffd_rig_report_write_proxy(&report, proxy_out, &err) != FFD_OK) {
        cli_error(code, "%s", err.message);
        if (lattice_out && !lattice_existed)
            unlink(lattice_out);
        goto done;
    }
    if (bytes) {
        bad = ffd_write_file_atomic(out, bytes, nbytes, &err) == FFD_OK
                  ? CLI_EXIT_OK
                  : cli_error(CLI_EXIT_INPUT, "%s", err.message);
        ffd_free(bytes);
        bytes = NULL;
    } else {
        bad = cli_mesh_write(mesh, out, &options, &err);
    }
    if (bad != CLI_EXIT_OK) {
        code = bad;
        if (lattice_out && !lattice_existed)
            unlink(lattice_out);
        if (proxy_out && !proxy_existed)
            unlink(proxy_out);
        goto done;
    }
    double t3 = cli_now();
    /* the method's notes and warnings, one "ffd: " line each */
    for (const char *line = report.notes; line && *line;) {
        const char *eol = strchr(line, '\n');
        int len = eol ? (int)(eol - line) : (int)strlen(line);
        cli_note("ffd: %.*s\n", len, line);
        line += len + (eol != NULL);
    }
    if (want_report)
        cli_print_report(&report, have_inv ? &inv : NULL, have_folds ? &folds : NULL);
    if (want_timings)
        print_timings(t1 - t0, &report.timings, t3 - t2);
    cli_note("wrote %s (%zu vertices, %zu faces)\n", to_stdout ? "<stdout>" : out,
             ffd_mesh_vertex_count(mesh), ffd_mesh_face_count(mesh));
    code = CLI_EXIT_OK;
done:
    ffd_free(bytes);
    free(rest);
    ffd_deformer_destroy(deformer);
    ffd_inversion_report_free(&inv);
    ffd_fold_report_free(&folds);
    ffd_rig_report_free(&report);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
    return code;
}
