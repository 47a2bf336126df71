/* ffd info — a mesh's counts, bounding box and edge topology, as text or JSON. */
#include "cli.h"

#include <string.h>

static const char usage[] =
    "usage: ffd info MESH [--json] [--format FMT]\n"
    "\n"
    "Prints the vertex, face, corner, edge, normal and texture-coordinate counts,\n"
    "the bounding box, whether the surface is closed, and its boundary and\n"
    "non-manifold edges (after welding exactly equal positions). A mesh with cells\n"
    "(a volume format) also gets its cells per type and, with 3D cells, its\n"
    "boundary faces, the total volume and the minimum scaled Jacobian with the\n"
    "cell that has it (docs/volume.md).\n"
    "\n"
    "options:\n"
    "  --json        one JSON object on stdout instead of text\n"
    "  --format FMT  MESH '-' is standard input in this format (obj, ply, off, stl,\n"
    "                gltf, glb, vtk, vtu, msh, su2, xyz, csv or npy)\n"
    "  -h, --help    this help\n";

/* The cells part of a mesh with cells (JSON keys after the surface's). */
static void print_cells_json(const ffd_mesh_quality *q)
{
    printf(", \"cells\": {");
    int first = 1;
    for (unsigned t = 0; t < 32; t++)
        if (q->cells_of_type[t]) {
            printf("%s\"%s\": %zu", first ? "" : ", ", ffd_cell_type_name(t), q->cells_of_type[t]);
            first = 0;
        }
    printf("}");
    if (!q->volume_cell_count)
        return;
    printf(", \"boundary_faces\": %zu, \"volume\": ", q->boundary_face_count);
    cli_json_number(stdout, q->volume);
    printf(", \"min_scaled_jacobian\": ");
    cli_json_number(stdout, q->min_scaled_jacobian);
    printf(", \"min_scaled_jacobian_cell\": %zu, \"inverted_cells\": %zu", q->min_scaled_cell,
           q->inverted_count);
}

static void print_cells_text(const ffd_mesh_quality *q)
{
    printf("  cells               %zu\n", q->cell_count);
    for (unsigned t = 0; t < 32; t++)
        if (q->cells_of_type[t])
            printf("    %-17s %zu\n", ffd_cell_type_name(t), q->cells_of_type[t]);
    if (!q->volume_cell_count)
        return;
    printf("  boundary faces      %zu\n", q->boundary_face_count);
    printf("  volume              %.9g\n", q->volume);
    printf("  min scaled Jacobian %.6g (cell %zu)\n", q->min_scaled_jacobian, q->min_scaled_cell);
    printf("  inverted cells      %zu\n", q->inverted_count);
}

static void print_json(const char *path, ffd_format format, const ffd_mesh_info *info,
                       const ffd_mesh_quality *cells)
{
    printf("{\"file\": ");
    cli_json_string(stdout, path);
    printf(", \"format\": \"%s\", \"vertices\": %zu, \"faces\": %zu, \"corners\": %zu,"
           " \"welded_vertices\": %zu, \"edges\": %zu, \"boundary_edges\": %zu,"
           " \"nonmanifold_edges\": %zu, \"closed\": %s, \"normals\": %zu, \"texcoords\": %zu",
           cli_format_name(format), info->vertex_count, info->face_count, info->corner_count,
           info->welded_vertex_count, info->edge_count, info->boundary_edge_count,
           info->nonmanifold_edge_count, info->closed ? "true" : "false", info->normal_count,
           info->texcoord_count);
    if (cells)
        print_cells_json(cells);
    if (info->vertex_count == 0) {
        printf(", \"bbox\": null}\n");
        return;
    }
    printf(", \"bbox\": {\"min\": [");
    for (int a = 0; a < 3; a++) {
        printf(a ? ", " : "");
        cli_json_number(stdout, info->bbox_min[a]);
    }
    printf("], \"max\": [");
    for (int a = 0; a < 3; a++) {
        printf(a ? ", " : "");
        cli_json_number(stdout, info->bbox_max[a]);
    }
    printf("]}}\n");
}

static void print_text(const char *path, ffd_format format, const ffd_mesh_info *info,
                       const ffd_mesh_quality *cells)
{
    printf("%s (%s)\n", path, cli_format_name(format));
    printf("  vertices            %zu (%zu distinct positions)\n", info->vertex_count,
           info->welded_vertex_count);
    printf("  faces               %zu (%zu corners)\n", info->face_count, info->corner_count);
    printf("  edges               %zu\n", info->edge_count);
    printf("  boundary edges      %zu\n", info->boundary_edge_count);
    printf("  non-manifold edges  %zu\n", info->nonmanifold_edge_count);
    printf("  surface             %s\n", info->closed ? "closed" : "open");
    printf("  normals             %zu\n", info->normal_count);
    printf("  texcoords           %zu\n", info->texcoord_count);
    if (cells)
        print_cells_text(cells);
    if (info->vertex_count) {
        printf("  bbox min            %.9g %.9g %.9g\n", info->bbox_min[0], info->bbox_min[1],
               info->bbox_min[2]);
        printf("  bbox max            %.9g %.9g %.9g\n", info->bbox_max[0], info->bbox_max[1],
               info->bbox_max[2]);
    }
}

int cmd_info(int argc, char **argv)
{
    const char *path = NULL, *format_text = NULL;
    int json = 0;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        int e;
        if (cli_is_help(arg)) {
            fputs(usage, stdout);
            return CLI_EXIT_OK;
        } else if (strcmp(arg, "--json") == 0) {
            json = 1;
        } else if ((e = cli_option_value(argc, argv, &i, "--format", NULL, &format_text)) != 0) {
            if (e < 0)
                return cli_option_error("info", arg, e);
        } else if (arg[0] == '-' && arg[1] != 0) {
            return cli_usage_error("info", "unknown option '%s'", arg);
        } else if (!path) {
            path = arg;
        } else {
            return cli_usage_error("info", "unexpected argument '%s' (one MESH only)", arg);
        }
    }
    if (!path)
        return cli_usage_error("info", "missing MESH");
    ffd_format stdio_format;
    const char *inputs[] = {"MESH", path};
    int bad = cli_check_stdin("info", "MESH", inputs, 2, format_text, &stdio_format);
    if (bad)
        return bad;

    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    if (cli_mesh_read(path, stdio_format, &mesh, &err) != FFD_OK)
        return cli_error(CLI_EXIT_INPUT, "%s", err.message);
    ffd_mesh_info info;
    ffd_status s = ffd_mesh_compute_info(mesh, &info, &err);
    ffd_mesh_quality quality;
    int has_cells = ffd_mesh_cell_count(mesh) > 0;
    if (s == FFD_OK && has_cells)
        s = ffd_mesh_quality_compute(mesh, &quality, &err);
    ffd_format format = ffd_mesh_source_format(mesh);
    ffd_mesh_destroy(mesh);
    if (s != FFD_OK)
        return cli_error(CLI_EXIT_INPUT, "%s: %s", path, err.message);
    const char *name = cli_is_stdio(path) ? "<stdin>" : path;
    if (json)
        print_json(name, format, &info, has_cells ? &quality : NULL);
    else
        print_text(name, format, &info, has_cells ? &quality : NULL);
    return CLI_EXIT_OK;
}
