/* ffd sensitivities — the sparse matrix dX/dP of a mesh's deformed vertices
 * under a rig (ffd_deformer_sensitivities), written as Matrix Market. */
#include "cli.h"
#include "core/core.h" /* ffd_write_file_atomic */

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static const char usage[] =
    "usage: ffd sensitivities MESH --rig RIG -o OUT.mtx [--expand] [--format FMT]\n"
    "\n"
    "Builds the rig's deformer on MESH and writes W = dX/dP, the derivative of the\n"
    "deformed vertices with respect to the deformer's control variables\n"
    "(docs/sensitivities.md), as a Matrix Market coordinate matrix (readable by\n"
    "scipy.io.mmread): one row per vertex, in the mesh's order, one column per\n"
    "control (ties merged as in direct manipulation), and dX/dP = W (x) I3: the\n"
    "derivative of coordinate a of vertex i with respect to coordinate b of\n"
    "control j is W_ij when a = b, else 0. The comment lines say so. OUT is\n"
    "written atomically and is never an input; OUT '-' is standard output.\n"
    "A method whose deformation is not linear in its controls (GFFD) has none:\n"
    "the command says so and exits 1.\n"
    "\n"
    "options:\n"
    "  -o, --output OUT  the matrix (.mtx)\n"
    "  -r, --rig RIG     the rig file (JSON, or PyGeM .prm)\n"
    "  --expand          write the 3N x 3C matrix dX/dP itself: row 3i+a, column\n"
    "                    3j+a (0-based; a = x, y, z) holds W_ij\n"
    "  --format FMT      the format of MESH '-' (obj, ply, off, stl,\n"
    "                    gltf, glb, vtk, vtu, msh, su2, xyz, csv or npy)\n"
    "  -h, --help        this help\n";

/* name with control characters (a newline would end the comment line)
 * shown as '?', into buf. */
static const char *comment_name(const char *name, char *buf, size_t size)
{
    size_t i = 0;
    for (; name[i] && i + 1 < size; i++)
        buf[i] = (unsigned char)name[i] < 0x20 || name[i] == 0x7f ? '?' : name[i];
    buf[i] = 0;
    return buf;
}

/* The Matrix Market text of W (or W (x) I3 when expand), 1-based indices,
 * values with 17 significant digits; NULL when out of memory. */
static char *matrix_market(const ffd_sparse *W, int expand, const char *mesh, const char *rig,
                           const char *method, size_t *size)
{
    size_t k = expand ? 3 : 1;
    /* a line is at most 20 + 20 + 24 digits and signs and 3 separators */
    size_t cap = 4096 + strlen(method), len = 0;
    if (W->nnz > (SIZE_MAX - cap) / (80 * k))
        return NULL;
    cap += W->nnz * k * 80;
    char *text = malloc(cap);
    if (!text)
        return NULL;
#define PUT(...) (len += (size_t)snprintf(text + len, cap - len, __VA_ARGS__))
    PUT("%%%%MatrixMarket matrix coordinate real general\n");
    char mesh_name[1024], rig_name[1024];
    PUT("%% ffd sensitivities: dX/dP of the deformed vertices of %s under %s (%s method)\n",
        comment_name(mesh, mesh_name, sizeof mesh_name), comment_name(rig, rig_name, sizeof rig_name),
        method);
    if (!expand) {
        PUT("%% W: row i = vertex i-1 of the mesh (file order); column j = control j-1 of the\n"
            "%% deformer (ffd_deformer_controls order; tied slots merged, fixed ones dropped)\n"
            "%% dX/dP = W (x) I3: d x_(i,a) / d p_(j,b) = W_ij if a = b, else 0 (a, b = x, y, z)\n");
    } else {
        PUT("%% dX/dP = W (x) I3, expanded: row 3(i-1)+a = coordinate a of vertex i-1, column\n"
            "%% 3(j-1)+b = coordinate b of control j-1 (a, b = 1, 2, 3 for x, y, z; vertices in\n"
            "%% file order, controls in ffd_deformer_controls order, tied slots merged)\n");
    }
    PUT("%zu %zu %zu\n", W->rows * k, W->cols * k, W->nnz * k);
    for (size_t i = 0; i < W->rows; i++)
        for (size_t a = 0; a < k; a++)
            for (size_t e = W->row_ptr[i]; e < W->row_ptr[i + 1]; e++)
                PUT("%zu %zu %.17g\n", i * k + a + 1, (size_t)W->col[e] * k + a + 1, W->val[e]);
#undef PUT
    *size = len;
    return text;
}

int cmd_sensitivities(int argc, char **argv)
{
    const char *in = NULL, *out = NULL, *rig_path = NULL, *format_text = NULL;
    int expand = 0;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        int e;
        if (cli_is_help(arg)) {
            fputs(usage, stdout);
            return CLI_EXIT_OK;
        } else if ((e = cli_option_value(argc, argv, &i, "--output", "-o", &out)) != 0
                   || (e = cli_option_value(argc, argv, &i, "--rig", "-r", &rig_path)) != 0
                   || (e = cli_option_value(argc, argv, &i, "--format", NULL, &format_text)) != 0) {
            if (e < 0)
                return cli_option_error("sensitivities", arg, e);
        } else if (strcmp(arg, "--expand") == 0) {
            expand = 1;
        } else if (arg[0] == '-' && arg[1] != 0) {
            return cli_usage_error("sensitivities", "unknown option '%s'", arg);
        } else if (!in) {
            in = arg;
        } else {
            return cli_usage_error("sensitivities", "unexpected argument '%s' (one mesh only)",
                                   arg);
        }
    }
    if (!in)
        return cli_usage_error("sensitivities", "missing MESH");
    if (!rig_path)
        return cli_usage_error("sensitivities", "missing --rig RIG");
    if (!out)
        return cli_usage_error("sensitivities", "missing -o OUT.mtx");
    ffd_format stdio_format;
    const char *inputs[] = {"the input mesh", in, "--rig", rig_path};
    int bad = cli_check_stdin("sensitivities", "MESH", inputs, 4, format_text, &stdio_format);
    if (bad)
        return bad;
    const cli_file files[] = {
        {"the input mesh", in, CLI_FILE_INPUT},
        {"--rig", rig_path, CLI_FILE_INPUT},
        {"-o", out, CLI_FILE_OUTPUT},
    };
    if ((bad = cli_check_files("sensitivities", files, sizeof files / sizeof *files)))
        return bad;

    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    ffd_rig *rig = NULL;
    ffd_deformer *d = NULL;
    ffd_sparse W = {0};
    char *text = NULL;
    size_t size = 0;
    int code = CLI_EXIT_INPUT;
    if (cli_mesh_read(in, stdio_format, &mesh, &err) != FFD_OK
        || cli_rig_read(rig_path, &rig, &err) != FFD_OK) {
        cli_error(code, "%s", err.message);
        goto done;
    }
    if ((bad = cli_check_rig_inputs("sensitivities", rig, files, sizeof files / sizeof *files))) {
        code = bad;
        goto done;
    }
    if (ffd_deformer_create(rig, mesh, NULL, &d, &err) != FFD_OK
        || ffd_deformer_sensitivities(d, &W, &err) != FFD_OK) {
        cli_error(code, "%s: %s", in, err.message);
        goto done;
    }
    text = matrix_market(&W, expand, cli_is_stdio(in) ? "<stdin>" : in,
                         cli_is_stdio(rig_path) ? "<stdin>" : rig_path, ffd_deformer_method(d),
                         &size);
    if (!text) {
        cli_error(code, "%s: out of memory for %zu entries", out, W.nnz);
        goto done;
    }
    if (cli_is_stdio(out)) {
        if (fwrite(text, 1, size, stdout) != size || fflush(stdout) != 0) {
            cli_error(code, "<stdout>: write failed");
            goto done;
        }
    } else if (ffd_write_file_atomic(out, text, size, &err) != FFD_OK) {
        cli_error(code, "%s", err.message);
        goto done;
    }
    cli_note("wrote %s (%zu x %zu, %zu entries)\n", cli_is_stdio(out) ? "<stdout>" : out,
             W.rows * (expand ? 3 : 1), W.cols * (expand ? 3 : 1), W.nnz * (expand ? 3 : 1));
    code = CLI_EXIT_OK;
done:
    free(text);
    ffd_sparse_free(&W);
    ffd_deformer_destroy(d);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
    return code;
}
