/* Tests for src/rig: the rig JSON format (every key, every rejected input with
 * its JSON path or line:column) and ffd_rig_apply on small meshes. */
#include "check.h"
#include "check_rig.h"
#include "deformer/method.h"

#include <cjson/cJSON.h>

#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

/* ======================================================================
 * Helpers
 * ====================================================================== */


/* A g x g x g grid of vertices in [lo, hi]^3 with one triangle (so the mesh has a face). */
static ffd_mesh *grid_mesh(int g, double lo, double hi)
{
    size_t n = (size_t)g * g * g;
    double *p = malloc(3 * n * sizeof *p);
    size_t v = 0;
    for (int i = 0; i < g; i++)
        for (int j = 0; j < g; j++)
            for (int k = 0; k < g; k++, v++) {
                p[3 * v] = lo + (hi - lo) * i / (g - 1);
                p[3 * v + 1] = lo + (hi - lo) * j / (g - 1) * 0.8;
                p[3 * v + 2] = lo + (hi - lo) * k / (g - 1) * 0.6;
            }
    uint32_t offsets[2] = {0, 3}, indices[3] = {0, 1, 2};
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_create(p, n, offsets, indices, 1, &mesh, &err) != FFD_OK) {
        fprintf(stderr, "%s: ffd_mesh_create: %s\n", check_current, err.message);
        check_failures++;
    }
    free(p);
    return mesh;
}

static int same_positions(const ffd_mesh *mesh, const double *before)
{
    size_t n = 3 * ffd_mesh_vertex_count(mesh);
    return memcmp(ffd_mesh_positions(mesh), before, n * sizeof *before) == 0;
}

static double max_rel_change(const ffd_mesh *mesh, const double *before)
{
    size_t n = 3 * ffd_mesh_vertex_count(mesh);
    const double *p = ffd_mesh_positions(mesh);
    double worst = 0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs(p[i] - before[i]) / fmax(1.0, fabs(before[i]));
        if (d > worst)
            worst = d;
    }
    return worst;
}

/* ======================================================================
 * Parsing
 * ====================================================================== */

static void test_parse_every_key(void)
{
    ffd_rig *rig = parse_ok(
        "{\"version\": 1, \"deformer\": \"lattice\", \"basis\": \"bernstein\",\n"
        " \"resolution\": [3, 4, 5],\n"
        " \"box\": {\"origin\": [1, 2, 3], \"axes\": [[2, 0, 0], [0, 3, 0], [0, 0.5, 4]]},\n"
        " \"margin\": 0.25, \"outside\": \"clamp\", \"rcond\": 1e-8,\n"
        " \"moves\": [{\"index\": [0, 1, 2], \"delta\": [0.5, -1, 2e-3]},\n"
        "           {\"delta\": [1, 1, 1], \"index\": [2, 3, 4]}],\n"
        " \"constraints\": [{\"vertex\": 7, \"target\": [1, 2, 3]},\n"
        "                 {\"point\": [1.5, 2.5, 3.5], \"target\": [-1, -2, -3.25]}]}");
    if (!rig)
        return;
    CHECK(strcmp(rig->name, "rig.json") == 0);
    CHECK(rig->basis == FFD_BASIS_BERNSTEIN);
    CHECK(rig->resolution[0] == 3 && rig->resolution[1] == 4 && rig->resolution[2] == 5);
    CHECK(rig->box_auto == 0);
    CHECK(rig->box.origin[0] == 1 && rig->box.origin[1] == 2 && rig->box.origin[2] == 3);
    CHECK(rig->box.axes[0][0] == 2 && rig->box.axes[1][1] == 3 && rig->box.axes[2][1] == 0.5 &&
          rig->box.axes[2][2] == 4 && rig->box.axes[0][1] == 0);
    CHECK(rig->margin == 0.25);
    CHECK(rig->outside == FFD_OUTSIDE_CLAMP);
    CHECK(rig->rcond == 1e-8);
    CHECK(rig->move_count == 2);
    CHECK(rig->moves[0].index[0] == 0 && rig->moves[0].index[1] == 1 && rig->moves[0].index[2] == 2);
    CHECK(rig->moves[0].delta[0] == 0.5 && rig->moves[0].delta[1] == -1 &&
          rig->moves[0].delta[2] == 2e-3);
    CHECK(rig->moves[1].index[0] == 2 && rig->moves[1].index[2] == 4 && rig->moves[1].delta[1] == 1);
    CHECK(rig->constraint_count == 2);
    CHECK(rig->constraints[0].kind == FFD_RIG_CONSTRAINT_VERTEX && rig->constraints[0].vertex == 7);
    CHECK(rig->constraints[0].target[2] == 3);
    CHECK(rig->constraints[1].kind == FFD_RIG_CONSTRAINT_POINT);
    CHECK(rig->constraints[1].point[0] == 1.5 && rig->constraints[1].point[2] == 3.5);
    CHECK(rig->constraints[1].target[2] == -3.25);
    ffd_rig_destroy(rig);
}

static void test_parse_defaults(void)
{
    ffd_rig *rig = parse_ok("{}");
    if (!rig)
        return;
    CHECK(rig->basis == FFD_BASIS_BSPLINE);
    CHECK(rig->resolution[0] == 5 && rig->resolution[1] == 5 && rig->resolution[2] == 5);
    CHECK(rig->box_auto == 1);
    CHECK(rig->margin == 0.05);
    CHECK(rig->outside == FFD_OUTSIDE_FIXED);
    CHECK(rig->rcond == 0);
    CHECK(rig->move_count == 0 && rig->moves == NULL);
    CHECK(rig->constraint_count == 0 && rig->constraints == NULL);
    ffd_rig_destroy(rig);

    rig = parse_ok("  \n{\"box\": \"auto\", \"basis\": \"bspline\", \"outside\": \"extrapolate\","
                   " \"moves\": [], \"constraints\": [], \"resolution\": [2, 2, 2]}\n\n");
    if (rig) {
        CHECK(rig->box_auto == 1);
        CHECK(rig->outside == FFD_OUTSIDE_EXTRAPOLATE);
        CHECK(rig->resolution[2] == 2);
        ffd_rig_destroy(rig);
    }
    rig = parse_ok("{\"outside\": \"fixed\", \"margin\": 0, \"rcond\": 0}");
    if (rig) {
        CHECK(rig->outside == FFD_OUTSIDE_FIXED);
        CHECK(rig->margin == 0);
        ffd_rig_destroy(rig);
    }
    /* The name defaults when NULL. */
    ffd_rig *r2 = NULL;
    CHECK_OK(ffd_rig_parse_json("{}", 2, NULL, &r2, NULL));
    if (r2) {
        CHECK(r2->name && strcmp(r2->name, "rig") == 0);
        ffd_rig_destroy(r2);
    }
    /* Text need not be NUL-terminated: only size bytes are read. */
    const char text[] = "{\"margin\": 0.5}garbage";
    CHECK_OK(ffd_rig_parse_json(text, 15, "r", &r2, NULL));
    if (r2) {
        CHECK(r2->margin == 0.5);
        ffd_rig_destroy(r2);
    }
}

static void test_parse_bad_keys_and_types(void)
{
    parse_bad("{\"foo\": 1}", FFD_ERR_PARSE, "rig.json: foo: unknown key");
    parse_bad("{\"$schema\": \"x\"}", FFD_ERR_PARSE, "rig.json: $schema: unknown key");
    parse_bad("{\"Basis\": \"bspline\"}", FFD_ERR_PARSE, "Basis: unknown key");
    parse_bad("{\"margin\": 1, \"margin\": 2}", FFD_ERR_PARSE, "margin: key given twice");
    parse_bad("[1, 2]", FFD_ERR_PARSE, "rig.json: expected a JSON object");
    parse_bad("\"lattice\"", FFD_ERR_PARSE, "expected a JSON object");
    parse_bad("{\"version\": 2}", FFD_ERR_PARSE, "rig.json: version: expected 1");
    parse_bad("{\"version\": \"1\"}", FFD_ERR_PARSE, "version: expected 1");
    parse_bad("{\"deformer\": \"tsplines\"}", FFD_ERR_PARSE, "rig.json: deformer: expected \"lattice\", \"pbffd\", \"gffd\", \"tspline\"");
    parse_bad("{\"deformer\": 1}", FFD_ERR_PARSE, "deformer: expected \"lattice\"");
    parse_bad("{\"basis\": \"nurbs\"}", FFD_ERR_PARSE,
              "rig.json: basis: expected \"linear\", \"cardinal\", \"catmull-rom\", "
              "\"bspline\" or \"bernstein\"");
    parse_bad("{\"basis\": null}", FFD_ERR_PARSE, "basis: expected");
    parse_bad("{\"resolution\": [5, 5]}", FFD_ERR_PARSE,
              "rig.json: resolution: expected an array of 3 non-negative integers");
    parse_bad("{\"resolution\": [5, 5, 5.5]}", FFD_ERR_PARSE, "resolution: expected an array of 3");
    parse_bad("{\"resolution\": [5, -1, 5]}", FFD_ERR_PARSE, "resolution: expected");
    parse_bad("{\"resolution\": 5}", FFD_ERR_PARSE, "resolution: expected");
    parse_bad("{\"box\": \"fit\"}", FFD_ERR_PARSE, "rig.json: box: expected \"auto\" or an object");
    parse_bad("{\"box\": 3}", FFD_ERR_PARSE, "box: expected \"auto\"");
    parse_bad("{\"box\": {\"origin\": [0, 0, 0]}}", FFD_ERR_PARSE, "box.axes: expected");
    parse_bad("{\"box\": {\"axes\": [[1,0,0],[0,1,0],[0,0,1]]}}", FFD_ERR_PARSE,
              "box.origin: expected");
    parse_bad("{\"box\": {\"origin\": [0, 0], \"axes\": [[1,0,0],[0,1,0],[0,0,1]]}}",
              FFD_ERR_PARSE, "box.origin: expected an array of 3 finite numbers");
    parse_bad("{\"box\": {\"origin\": [0, 0, 0], \"axes\": [[1,0,0],[0,1],[0,0,1]]}}",
              FFD_ERR_PARSE, "box.axes[1]: expected an array of 3 finite numbers");
    parse_bad("{\"box\": {\"origin\": [0, 0, 0], \"axes\": [[1,0,0],[0,1,0]]}}", FFD_ERR_PARSE,
              "box.axes: expected an array of 3 axes");
    parse_bad("{\"box\": {\"origin\": [0,0,0], \"axes\": [[1,0,0],[0,1,0],[0,0,1]], \"size\": 1}}",
              FFD_ERR_PARSE, "box.size: unknown key");
    parse_bad("{\"margin\": \"0.1\"}", FFD_ERR_PARSE, "rig.json: margin: expected a number");
    parse_bad("{\"margin\": -0.1}", FFD_ERR_PARSE, "margin: expected a number >= 0");
    parse_bad("{\"outside\": \"wrap\"}", FFD_ERR_PARSE,
              "outside: expected \"fixed\", \"clamp\", \"extrapolate\" or \"falloff\"");
    parse_bad("{\"rcond\": 2}", FFD_ERR_PARSE, "rcond: expected a number in [0, 1)");
    parse_bad("{\"rcond\": true}", FFD_ERR_PARSE, "rcond: expected a number");
    parse_bad("{\"moves\": {}}", FFD_ERR_PARSE, "rig.json: moves: expected an array");
    parse_bad("{\"moves\": [1]}", FFD_ERR_PARSE, "moves[0]: expected an object");
    parse_bad("{\"moves\": [{\"delta\": [0, 0, 0]}]}", FFD_ERR_PARSE, "moves[0].index: expected");
    parse_bad("{\"moves\": [{\"index\": [0, 0, 0]}]}", FFD_ERR_PARSE, "moves[0].delta: expected");
    parse_bad("{\"moves\": [{\"index\": [0,0,0], \"delta\": [0,0,0]},"
              " {\"index\": [1,1,1], \"delta\": [1, 2]}]}",
              FFD_ERR_PARSE, "rig.json: moves[1].delta: expected an array of 3 finite numbers");
    parse_bad("{\"moves\": [{\"index\": [0,0,0], \"delta\": [0,\"1\",0]}]}", FFD_ERR_PARSE,
              "moves[0].delta: expected an array of 3 finite numbers");
    parse_bad("{\"moves\": [{\"index\": [0,0,0], \"delta\": [0,0,0], \"weight\": 1}]}",
              FFD_ERR_PARSE, "moves[0].weight: unknown key");
    parse_bad("{\"moves\": [{\"index\": [0,0.5,0], \"delta\": [0,0,0]}]}", FFD_ERR_PARSE,
              "moves[0].index: expected an array of 3 non-negative integers");
    parse_bad("{\"constraints\": \"none\"}", FFD_ERR_PARSE, "rig.json: constraints: expected an array");
    parse_bad("{\"constraints\": [[]]}", FFD_ERR_PARSE, "constraints[0]: expected an object");
    parse_bad("{\"constraints\": [{\"target\": [0,0,0]}]}", FFD_ERR_PARSE,
              "constraints[0]: expected a \"vertex\" or a \"point\" key");
    parse_bad("{\"constraints\": [{\"vertex\": 1, \"point\": [0,0,0], \"target\": [0,0,0]}]}",
              FFD_ERR_PARSE, "constraints[0]: expected either \"vertex\" or \"point\", not both");
    parse_bad("{\"constraints\": [{\"vertex\": -1, \"target\": [0,0,0]}]}", FFD_ERR_PARSE,
              "constraints[0].vertex: expected a vertex id");
    parse_bad("{\"constraints\": [{\"vertex\": 1.5, \"target\": [0,0,0]}]}", FFD_ERR_PARSE,
              "constraints[0].vertex: expected a vertex id");
    parse_bad("{\"constraints\": [{\"vertex\": \"3\", \"target\": [0,0,0]}]}", FFD_ERR_PARSE,
              "constraints[0].vertex: expected");
    parse_bad("{\"constraints\": [{\"vertex\": 1e12, \"target\": [0,0,0]}]}", FFD_ERR_PARSE,
              "constraints[0].vertex: expected");
    parse_bad("{\"constraints\": [{\"vertex\": 3}]}", FFD_ERR_PARSE,
              "constraints[0].target: expected an array of 3 finite numbers (missing)");
    parse_bad("{\"constraints\": [{\"vertex\": 3, \"target\": [0,0,0]},"
              " {\"point\": [0,0], \"target\": [0,0,0]}]}",
              FFD_ERR_PARSE, "constraints[1].point: expected an array of 3 finite numbers");
    parse_bad("{\"constraints\": [{\"vertex\": 3, \"target\": [0,0,0], \"weight\": 2}]}",
              FFD_ERR_PARSE, "constraints[0].weight: unknown key");
}

static void test_parse_bad_values(void)
{
    /* JSON has no NaN or Inf, but an overflowing literal reads as Inf. */
    parse_bad("{\"margin\": 1e999}", FFD_ERR_NONFINITE, "rig.json: margin: expected a finite number");
    parse_bad("{\"constraints\": [{\"vertex\": 0, \"target\": [0, -1e400, 0]}]}",
              FFD_ERR_NONFINITE, "rig.json: constraints[0].target[1]: expected a finite number");
    parse_bad("{\"moves\": [{\"index\": [0,0,0], \"delta\": [1e999, 0, 0]}]}", FFD_ERR_NONFINITE,
              "moves[0].delta[0]: expected a finite number");
    parse_bad("{\"box\": {\"origin\": [0, 0, 1e309], \"axes\": [[1,0,0],[0,1,0],[0,0,1]]}}",
              FFD_ERR_NONFINITE, "box.origin[2]");
    parse_bad("{\"constraints\": [{\"vertex\": 0, \"target\": [NaN, 0, 0]}]}", FFD_ERR_PARSE,
              "rig.json:1:");
    parse_bad("{\"resolution\": [1, 5, 5]}", FFD_ERR_INVALID,
              "rig.json: resolution[0]: 1 is below the minimum 2 control points of the bspline basis");
    parse_bad("{\"basis\": \"bernstein\", \"resolution\": [4, 4, 0]}", FFD_ERR_INVALID,
              "resolution[2]: 0 is below the minimum 2 control points of the bernstein basis");
    parse_bad("{\"resolution\": [5, 1025, 5]}", FFD_ERR_INVALID,
              "rig.json: resolution[1]: 1025 is above the maximum 1024");
    parse_bad("{\"resolution\": [3, 3, 3], \"moves\": [{\"index\": [0, 3, 0], \"delta\": [0,0,0]}]}",
              FFD_ERR_RANGE, "rig.json: moves[0].index: [0, 3, 0] out of range for a 3 x 3 x 3 lattice");
    /* Moves are checked against the resolution wherever it appears in the file. */
    parse_bad("{\"moves\": [{\"index\": [5, 0, 0], \"delta\": [0,0,0]}]}", FFD_ERR_RANGE,
              "moves[0].index: [5, 0, 0] out of range for a 5 x 5 x 5 lattice");
}

static void test_parse_syntax_errors(void)
{
    parse_bad("", FFD_ERR_PARSE, "rig.json: empty file");
    parse_bad(" \n\t ", FFD_ERR_PARSE, "rig.json: empty file");
    parse_bad("{\n  \"basis\": \"bspline\",\n  \"margin\": ,\n}", FFD_ERR_PARSE,
              "rig.json:3:13: invalid JSON");
    parse_bad("{\"margin\": 0.1} x", FFD_ERR_PARSE,
              "rig.json:1:17: invalid JSON: unexpected text after the JSON value");
    parse_bad("{\"margin\": 0.1", FFD_ERR_PARSE, "rig.json:1:");
    parse_bad("{\"moves\": [\n{\"index\": [0,0,0], \"delta\": [0,0,0]},\n]}", FFD_ERR_PARSE,
              "rig.json:3:");
    parse_bad("{\"a\" 1}", FFD_ERR_PARSE, "rig.json:1:");
    parse_bad("{'margin': 1}", FFD_ERR_PARSE, "rig.json:1:");
    parse_bad("{} {}", FFD_ERR_PARSE, "rig.json:1:4: invalid JSON: unexpected text");

    /* Nesting deeper than 64 levels is refused before cJSON recurses. */
    char deep[300];
    size_t n = 0;
    deep[n++] = '{';
    memcpy(deep + n, "\"moves\": ", 9);
    n += 9;
    for (int i = 0; i < 100; i++)
        deep[n++] = '[';
    for (int i = 0; i < 100; i++)
        deep[n++] = ']';
    deep[n++] = '}';
    deep[n] = 0;
    parse_bad(deep, FFD_ERR_PARSE, "nested deeper than 64 levels");
    /* Brackets inside strings do not count. */
    char quoted[300] = "{\"x\": \"";
    for (int i = 0; i < 100; i++)
        strcat(quoted, "[");
    strcat(quoted, "\"}");
    parse_bad(quoted, FFD_ERR_PARSE, "x: unknown key");
}

static void test_parse_size_limit(void)
{
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    /* The size is checked before the text is read: no 64 MiB buffer is needed. */
    CHECK(ffd_rig_parse_json("{}", ((size_t)64 << 20) + 1, "big.json", &rig, &err) ==
          FFD_ERR_INVALID);
    CHECK(rig == NULL);
    CHECK(strstr(err.message, "big.json") && strstr(err.message, "64 MiB"));
}

static void test_read_files(void)
{
    ffd_rig *rig = (ffd_rig *)1;
    ffd_error err = {{0}};
    CHECK(ffd_rig_read("/nonexistent/dir/rig.json", &rig, &err) == FFD_ERR_IO);
    CHECK(rig == NULL);
    CHECK(strstr(err.message, "/nonexistent/dir/rig.json") != NULL);

    CHECK(ffd_rig_read(".", &rig, &err) == FFD_ERR_IO);
    CHECK(strstr(err.message, "directory") != NULL);

    char path[64];
    snprintf(path, sizeof path, "test_rig_%ld.json", (long)getpid());
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (!f)
        return;
    fputs("{\"basis\": \"bernstein\",\n \"resolution\": [2, 3, 2]}\n", f);
    fclose(f);
    CHECK_OK(ffd_rig_read(path, &rig, NULL));
    if (rig) {
        CHECK(rig->basis == FFD_BASIS_BERNSTEIN && rig->resolution[1] == 3);
        CHECK(strcmp(rig->name, path) == 0);
        ffd_rig_destroy(rig);
    }
    f = fopen(path, "wb");
    fputs("{\"basis\": \"bernstein\",\n \"moves\": 3}\n", f);
    fclose(f);
    CHECK(ffd_rig_read(path, &rig, &err) == FFD_ERR_PARSE);
    CHECK(strncmp(err.message, path, strlen(path)) == 0 && strstr(err.message, ": moves: expected"));
    remove(path);

    /* .prm goes to the PyGeM parser (any case), whatever the content. */
    snprintf(path, sizeof path, "test_rig_%ld.PRM", (long)getpid());
    f = fopen(path, "wb");
    fputs("{}\n", f);
    fclose(f);
    ffd_status s = ffd_rig_read(path, &rig, &err);
    CHECK(s != FFD_OK);
    CHECK(strstr(err.message, "invalid JSON") == NULL);
    if (s == FFD_OK)
        ffd_rig_destroy(rig);
    remove(path);
}

/* ======================================================================
 * Applying
 * ====================================================================== */

static void apply_identity(const char *json)
{
    ffd_mesh *mesh = grid_mesh(6, -1.0, 2.0);
    ffd_rig *rig = parse_ok(json);
    if (!mesh || !rig)
        goto done;
    double *before = copy_positions(mesh);
    ffd_rig_report report;
    ffd_error err = {{0}};
    ffd_status s = ffd_rig_apply(rig, mesh, &report, &err);
    CHECK(s == FFD_OK);
    if (s)
        fprintf(stderr, "  %s: %s\n", json, err.message);
    CHECK(max_rel_change(mesh, before) <= 1e-12);
    CHECK(report.constraint_count == 0);
    CHECK(report.residuals == NULL && report.reached == NULL);
    CHECK(report.max_residual == 0);
    CHECK(report.timings.bind >= 0 && report.timings.solve >= 0 && report.timings.evaluate >= 0);
    ffd_rig_report_free(&report);
    free(before);
done:
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

static void test_apply_identity(void)
{
    apply_identity("{}");
    apply_identity("{\"basis\": \"bernstein\", \"resolution\": [3, 4, 2]}");
    apply_identity("{\"basis\": \"bspline\", \"resolution\": [2, 7, 4], \"margin\": 0}");
    apply_identity("{\"basis\": \"bernstein\", \"outside\": \"extrapolate\","
                   " \"box\": {\"origin\": [-1, -1, -1], \"axes\": [[2,0,0],[0,2,0],[0,0,2]]}}");
    apply_identity("{\"outside\": \"clamp\","
                   " \"box\": {\"origin\": [-1.5, -1.5, -1.5], \"axes\": [[5,0,1],[0,5,0],[0,0,5]]}}");
    /* Zero moves are a no-op too. */
    apply_identity("{\"moves\": [{\"index\": [4, 4, 4], \"delta\": [0, 0, 0]}]}");
}

/* Moving every control point by d translates every point inside the box by d
 * (partition of unity), for both bases. */
static void test_apply_moves_translate(void)
{
    static const char *const rigs[] = {
        "{\"basis\": \"bernstein\", \"resolution\": [2, 2, 2], \"moves\": ["
        "{\"index\": [0,0,0], \"delta\": [0.5,-1,2]}, {\"index\": [0,0,1], \"delta\": [0.5,-1,2]},"
        "{\"index\": [0,1,0], \"delta\": [0.5,-1,2]}, {\"index\": [0,1,1], \"delta\": [0.5,-1,2]},"
        "{\"index\": [1,0,0], \"delta\": [0.5,-1,2]}, {\"index\": [1,0,1], \"delta\": [0.5,-1,2]},"
        "{\"index\": [1,1,0], \"delta\": [0.5,-1,2]}, {\"index\": [1,1,1], \"delta\": [0.5,-1,2]}]}",
        "{\"basis\": \"bspline\", \"resolution\": [2, 2, 2], \"moves\": ["
        "{\"index\": [0,0,0], \"delta\": [0.5,-1,2]}, {\"index\": [0,0,1], \"delta\": [0.5,-1,2]},"
        "{\"index\": [0,1,0], \"delta\": [0.5,-1,2]}, {\"index\": [0,1,1], \"delta\": [0.5,-1,2]},"
        "{\"index\": [1,0,0], \"delta\": [0.5,-1,2]}, {\"index\": [1,0,1], \"delta\": [0.5,-1,2]},"
        "{\"index\": [1,1,0], \"delta\": [0.5,-1,2]}, {\"index\": [1,1,1], \"delta\": [0.5,-1,2]}]}",
    };
    for (size_t r = 0; r < 2; r++) {
        ffd_mesh *mesh = grid_mesh(4, 0.0, 1.0);
        ffd_rig *rig = parse_ok(rigs[r]);
        if (!mesh || !rig) {
            ffd_rig_destroy(rig);
            ffd_mesh_destroy(mesh);
            continue;
        }
        double *before = copy_positions(mesh);
        ffd_rig_report report;
        CHECK_OK(ffd_rig_apply(rig, mesh, &report, NULL));
        const double *p = ffd_mesh_positions(mesh);
        size_t n = ffd_mesh_vertex_count(mesh);
        for (size_t i = 0; i < n; i++) {
            CHECK_NEAR(p[3 * i], before[3 * i] + 0.5, 1e-12);
            CHECK_NEAR(p[3 * i + 1], before[3 * i + 1] - 1, 1e-12);
            CHECK_NEAR(p[3 * i + 2], before[3 * i + 2] + 2, 1e-12);
        }
        CHECK(report.outside_count == 0);
        ffd_rig_report_free(&report);
        free(before);
        ffd_rig_destroy(rig);
        ffd_mesh_destroy(mesh);
    }
}

static void apply_constraints(const char *basis)
{
    char json[1024];
    snprintf(json, sizeof json,
             "{\"basis\": \"%s\", \"resolution\": [4, 4, 4], \"margin\": 0.1,"
             " \"moves\": [{\"index\": [1, 1, 1], \"delta\": [0.1, 0.1, 0]}],"
             " \"constraints\": ["
             "  {\"vertex\": 0, \"target\": [-1.1, -1.0, -1.05]},"
             "  {\"vertex\": 215, \"target\": [2.2, 1.5, 0.9]},"
             "  {\"vertex\": 100, \"target\": [0.5, 0.3, 0.2]},"
             "  {\"point\": [0.5, 0.5, 0.2], \"target\": [0.6, 0.4, 0.3]}]}",
             basis);
    ffd_mesh *mesh = grid_mesh(6, -1.0, 2.0);
    ffd_rig *rig = parse_ok(json);
    if (!mesh || !rig)
        goto done;
    ffd_rig_report report;
    ffd_error err = {{0}};
    ffd_status s = ffd_rig_apply(rig, mesh, &report, &err);
    CHECK(s == FFD_OK);
    if (s) {
        fprintf(stderr, "  %s: %s\n", basis, err.message);
        goto done;
    }
    CHECK(report.constraint_count == 4);
    CHECK(report.rank >= 4);
    CHECK(report.max_residual <= 1e-10);
    CHECK(report.outside_count == 0);
    for (size_t c = 0; c < 4; c++) {
        CHECK(report.residuals[c] <= 1e-10);
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(report.reached[3 * c + a], rig->constraints[c].target[a], 1e-10);
    }
    /* The mesh vertices themselves reached their targets. */
    const double *p = ffd_mesh_positions(mesh);
    for (size_t c = 0; c < 3; c++) {
        uint32_t v = rig->constraints[c].vertex;
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(p[3 * v + a], rig->constraints[c].target[a], 1e-10);
    }
    ffd_rig_report_free(&report);
    CHECK(report.residuals == NULL && report.constraint_count == 0);
done:
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

static void test_apply_constraints_bspline(void) { apply_constraints("bspline"); }
static void test_apply_constraints_bernstein(void) { apply_constraints("bernstein"); }

/* Unreachable (conflicting) constraints are a residual, not an error. */
static void test_apply_conflicting_constraints(void)
{
    ffd_mesh *mesh = grid_mesh(4, 0.0, 1.0);
    ffd_rig *rig = parse_ok("{\"constraints\": [{\"vertex\": 5, \"target\": [0, 0, 0]},"
                            " {\"vertex\": 5, \"target\": [1, 0, 0]}], \"rcond\": 1e-9}");
    if (mesh && rig) {
        ffd_rig_report report;
        CHECK_OK(ffd_rig_apply(rig, mesh, &report, NULL));
        CHECK_NEAR(report.residuals[0], 0.5, 1e-9);
        CHECK_NEAR(report.residuals[1], 0.5, 1e-9);
        CHECK_NEAR(report.max_residual, 0.5, 1e-9);
        CHECK_NEAR(report.reached[0], 0.5, 1e-9);
        ffd_rig_report_free(&report);
    }
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

static void apply_fails(const char *json, ffd_status status, const char *fragment)
{
    ffd_mesh *mesh = grid_mesh(4, 0.0, 1.0);
    ffd_rig *rig = parse_ok(json);
    if (!mesh || !rig)
        goto done;
    double *before = copy_positions(mesh);
    ffd_rig_report report;
    ffd_error err = {{0}};
    ffd_status s = ffd_rig_apply(rig, mesh, &report, &err);
    CHECK(s == status);
    CHECK(strstr(err.message, fragment) != NULL);
    if (s != status || !strstr(err.message, fragment))
        fprintf(stderr, "  got %s \"%s\", expected %s \"%s\"\n", ffd_status_string(s),
                err.message, ffd_status_string(status), fragment);
    CHECK(same_positions(mesh, before));
    CHECK(report.residuals == NULL && report.reached == NULL && report.constraint_count == 0);
    ffd_rig_report_free(&report);
    free(before);
done:
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

static void test_apply_errors(void)
{
    apply_fails("{\"constraints\": [{\"vertex\": 9001, \"target\": [0, 0, 0]}]}", FFD_ERR_RANGE,
                "rig.json: constraints[0].vertex: 9001 out of range (mesh has 64 vertices)");
    apply_fails("{\"constraints\": [{\"vertex\": 1, \"target\": [0, 0, 0]},"
                " {\"vertex\": 64, \"target\": [0, 0, 0]}]}",
                FFD_ERR_RANGE, "constraints[1].vertex: 64 out of range (mesh has 64 vertices)");
    apply_fails("{\"constraints\": [{\"point\": [5, 0, 0], \"target\": [0, 0, 0]}]}",
                FFD_ERR_INVALID, "rig.json: constraints[0].point: [5, 0, 0] is outside the lattice");
    apply_fails("{\"box\": {\"origin\": [0, 0, 0], \"axes\": [[0.5,0,0],[0,1,0],[0,0,1]]},"
                " \"constraints\": [{\"vertex\": 63, \"target\": [0, 0, 0]}]}",
                FFD_ERR_INVALID, "constraints[0].vertex: vertex 63 is outside the lattice box");
    apply_fails("{\"box\": {\"origin\": [0, 0, 0], \"axes\": [[1,0,0],[0,1,0],[2,0,0]]}}",
                FFD_ERR_INVALID, "rig.json: box: ");
    apply_fails("{\"box\": {\"origin\": [0, 0, 0], \"axes\": [[1,0,0],[0,0,0],[0,0,1]]}}",
                FFD_ERR_INVALID, "rig.json: box: ");
}

/* Outside vertices: counted, and kept in place by the "fixed" policy. */
static void test_apply_outside(void)
{
    ffd_mesh *mesh = grid_mesh(4, 0.0, 1.0); /* x in {0, 1/3, 2/3, 1} */
    ffd_rig *rig = parse_ok(
        "{\"basis\": \"bernstein\", \"resolution\": [2, 2, 2],"
        " \"box\": {\"origin\": [-0.1, -0.1, -0.1], \"axes\": [[0.6,0,0],[0,1.2,0],[0,0,1.2]]},"
        " \"moves\": [{\"index\": [1, 1, 1], \"delta\": [0, 0, 0.3]}]}");
    if (mesh && rig) {
        double *before = copy_positions(mesh);
        ffd_rig_report report;
        CHECK_OK(ffd_rig_apply(rig, mesh, &report, NULL));
        CHECK(report.outside_count == 32);
        const double *p = ffd_mesh_positions(mesh);
        for (size_t i = 0; i < 64; i++)
            if (before[3 * i] > 0.5)
                CHECK(memcmp(p + 3 * i, before + 3 * i, 3 * sizeof *p) == 0);
        ffd_rig_report_free(&report);
        free(before);
    }
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

/* A mesh with normals goes through the Jacobian path; the report may be NULL. */
static void test_apply_normals(void)
{
    static const char obj[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                              "vn 0 0 -1\nvn 0 -1 0\nvn -1 0 0\nvn 0.577 0.577 0.577\n"
                              "f 1//1 3//1 2//1\nf 1//2 2//2 4//2\nf 1//3 4//3 3//3\n"
                              "f 2//4 3//4 4//4\n";
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read_memory(obj, sizeof obj - 1, FFD_FORMAT_OBJ, "tet.obj", &mesh, &err)) {
        fprintf(stderr, "%s: %s\n", check_current, err.message);
        check_failures++;
        return;
    }
    CHECK(ffd_mesh_normal_count(mesh) == 4);
    ffd_rig *rig = parse_ok("{\"basis\": \"bernstein\", \"resolution\": [2, 2, 2],"
                            " \"constraints\": [{\"vertex\": 1, \"target\": [1.5, 0, 0]}]}");
    if (rig) {
        CHECK_OK(ffd_rig_apply(rig, mesh, NULL, NULL));
        CHECK_NEAR(ffd_mesh_positions(mesh)[3], 1.5, 1e-10);
        const double *nrm = ffd_mesh_normals(mesh);
        for (size_t i = 0; i < 4; i++)
            CHECK(isfinite(nrm[3 * i]) && isfinite(nrm[3 * i + 1]) && isfinite(nrm[3 * i + 2]));
    }
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

/* Whether the n characters at s contain text. */
static int has_text(const char *s, size_t n, const char *text)
{
    size_t k = strlen(text);
    for (size_t i = 0; i + k <= n; i++)
        if (memcmp(s + i, text, k) == 0)
            return 1;
    return 0;
}

/* A partial move keeps the bytes of what it does not reach: one corner
 * control point of a B-spline lattice moves; every vertex outside its
 * support keeps its "v" line ("-0.000000" included) and its "vn" line
 * (the Jacobian there is exactly the identity), and the vertices inside move. */
static void test_apply_partial_move_keeps_bytes(void)
{
    const char *path = FFD_SOURCE_DIR "/tests/data/mesh/identity_smooth.obj";
    unsigned char *src = NULL;
    size_t size = 0;
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_read_file(path, &src, &size, &check_err_));
    CHECK_OK(ffd_mesh_read(path, &mesh, &check_err_));
    if (!src || !mesh) {
        ffd_free(src);
        ffd_mesh_destroy(mesh);
        return;
    }
    size_t n = ffd_mesh_vertex_count(mesh);
    CHECK(ffd_mesh_normal_count(mesh) == n);
    /* which vertices the moved control point reaches: its rows' tied columns */
    const ffd_box box = {{-2, -2, -2}, {{4, 0, 0}, {0, 4, 0}, {0, 0, 4}}};
    const uint32_t res[3] = {5, 5, 5};
    ffd_lattice *lat = NULL;
    ffd_lattice_binding *bind = NULL;
    CHECK_OK(ffd_lattice_create(FFD_BASIS_BSPLINE, &box, res, &lat, &check_err_));
    if (lat)
        CHECK_OK(ffd_lattice_bind(lat, ffd_mesh_positions(mesh), n, FFD_OUTSIDE_FIXED, &bind,
                                  &check_err_));
    unsigned char *reached = calloc(n, 1);
    if (bind) {
        ffd_linear_map map;
        ffd_lattice_linear_map(lat, bind, &map);
        uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
        double *w = malloc(map.max_row_nnz * sizeof *w);
        const uint32_t moved = (4 * 5 + 4) * 5 + 4; /* control [4, 4, 4] */
        for (size_t i = 0; i < n; i++) {
            size_t k = map.row(map.self, i, cols, w);
            for (size_t e = 0; e < k; e++)
                reached[i] |= w[e] != 0.0 && map.tie[cols[e]] == moved;
        }
        free(cols);
        free(w);
    }
    ffd_lattice_binding_destroy(bind);
    ffd_lattice_destroy(lat);
    ffd_error err = {{0}};
    ffd_status s = apply_json("{\"basis\": \"bspline\", \"resolution\": [5, 5, 5],"
                              " \"box\": {\"origin\": [-2, -2, -2], \"axes\": [[4,0,0],[0,4,0],[0,0,4]]},"
                              " \"moves\": [{\"index\": [4, 4, 4], \"delta\": [0.7, 0.9, 0.8]}]}",
                              mesh, NULL, &err);
    CHECK(s == FFD_OK);
    if (s)
        fprintf(stderr, "  %s\n", err.message);
    unsigned char *out = NULL;
    size_t out_size = 0;
    ffd_write_options opt = {FFD_FORMAT_OBJ, FFD_ENCODING_SAME, 0};
    if (s == FFD_OK)
        CHECK_OK(ffd_mesh_write_memory(mesh, &opt, &out, &out_size, &check_err_));
    if (out) {
        /* walk both files line by line: v lines are vertices, vn lines their normals */
        const char *a = (const char *)src, *ae = a + size, *b = (const char *)out,
                   *be = b + out_size;
        size_t v = 0, vn = 0, kept = 0, moved_lines = 0, bad = 0, zeros = 0;
        while (a < ae && b < be) {
            size_t la = strcspn(a, "\n"), lb = strcspn(b, "\n");
            int same = la == lb && memcmp(a, b, la) == 0;
            size_t *counter = strncmp(a, "v ", 2) == 0 ? &v : strncmp(a, "vn ", 3) == 0 ? &vn : NULL;
            if (counter && *counter < n) {
                size_t i = (*counter)++;
                if (!reached[i]) {
                    kept++;
                    bad += !same;
                    zeros += counter == &v && has_text(a, la, "-0.000000");
                } else if (counter == &v) {
                    moved_lines += !same;
                }
            } else {
                bad += !same;
            }
            a += la + 1;
            b += lb + 1;
        }
        CHECK(v == n && vn == n);
        CHECK(bad == 0);
        if (bad)
            fprintf(stderr, "  %zu lines outside the moved support changed\n", bad);
        CHECK(kept > 0 && moved_lines > 0 && zeros > 0); /* both kinds occur */
    }
    ffd_free(out);
    free(reached);
    ffd_free(src);
    ffd_mesh_destroy(mesh);
}

/* Random vertices pulled by random small offsets: generically reachable when
 * there are fewer constraints than control points. */
static void test_apply_random_pins(void)
{
    ffd_mesh *mesh = grid_mesh(6, -1.0, 2.0);
    char json[2048];
    size_t len = (size_t)snprintf(json, sizeof json, "{\"basis\": \"bernstein\", "
                                  "\"resolution\": [4, 4, 4], \"constraints\": [");
    uint32_t ids[10];
    for (int c = 0; c < 10; c++) {
        ids[c] = (uint32_t)(c * 21 + (int)(check_rand01() * 20)); /* distinct, < 216 */
        const double *p = ffd_mesh_positions(mesh) + 3 * (size_t)ids[c];
        len += (size_t)snprintf(json + len, sizeof json - len,
                                "%s{\"vertex\": %u, \"target\": [%.17g, %.17g, %.17g]}",
                                c ? ", " : "", ids[c], p[0] + 0.2 * (check_rand01() - 0.5),
                                p[1] + 0.2 * (check_rand01() - 0.5),
                                p[2] + 0.2 * (check_rand01() - 0.5));
    }
    snprintf(json + len, sizeof json - len, "]}");
    ffd_rig *rig = parse_ok(json);
    if (mesh && rig) {
        ffd_rig_report report;
        CHECK_OK(ffd_rig_apply(rig, mesh, &report, NULL));
        CHECK(report.rank == 10);
        CHECK(report.max_residual <= 1e-10);
        const double *p = ffd_mesh_positions(mesh);
        for (int c = 0; c < 10; c++)
            for (int a = 0; a < 3; a++)
                CHECK_NEAR(p[3 * ids[c] + a], rig->constraints[c].target[a], 1e-10);
        ffd_rig_report_free(&report);
    }
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

/* Every prefix of a valid rig fails cleanly (or parses, for the whole text). */
static void test_parse_prefixes(void)
{
    static const char text[] =
        "{\"version\": 1, \"basis\": \"bernstein\", \"resolution\": [3, 3, 3],"
        " \"box\": {\"origin\": [0, 0, 0], \"axes\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]},"
        " \"outside\": \"clamp\", \"moves\": [{\"index\": [1, 1, 1], \"delta\": [0.5, 0, 0]}],"
        " \"constraints\": [{\"point\": [0.5, 0.5, 0.5], \"target\": [0.5, 0.6, 0.5]}]}";
    for (size_t n = 0; n < sizeof text - 1; n++) {
        ffd_rig *rig = (ffd_rig *)1;
        ffd_error err = {{0}};
        ffd_status s = ffd_rig_parse_json(text, n, "p.json", &rig, &err);
        CHECK(s == FFD_ERR_PARSE);
        CHECK(rig == NULL);
        CHECK(strncmp(err.message, "p.json", 6) == 0);
    }
    ffd_rig *rig = parse_ok(text);
    ffd_rig_destroy(rig);
}

/* Fails the N-th allocation for every N until the call succeeds: each failure
 * is a clean status, leaves the mesh unchanged and leaks nothing (ASan). */
static void test_allocation_failures(void)
{
    static const char json[] =
        "{\"resolution\": [4, 4, 4], \"moves\": [{\"index\": [1, 1, 1], \"delta\": [0.1, 0, 0]}],"
        " \"constraints\": [{\"vertex\": 3, \"target\": [0.1, 0.2, 0.3]},"
        " {\"point\": [0.5, 0.5, 0.5], \"target\": [0.5, 0.6, 0.5]}]}";
    fail_alloc f = {0, 0};
    ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &f};
    int parsed = 0, applied = 0;
    for (long n = 0; n < 10000 && !parsed; n++) {
        ffd_rig *rig = NULL;
        f.left = n;
        ffd_set_allocator(&a);
        ffd_status s = ffd_rig_parse_json(json, sizeof json - 1, "a.json", &rig, NULL);
        ffd_set_allocator(NULL);
        CHECK(s == FFD_OK || s == FFD_ERR_NOMEM);
        CHECK((s == FFD_OK) == (rig != NULL));
        parsed = s == FFD_OK;
        ffd_rig_destroy(rig);
    }
    CHECK(parsed);
    ffd_rig *rig = parse_ok(json);
    ffd_mesh *mesh = grid_mesh(4, 0.0, 1.0);
    if (!rig || !mesh)
        goto done;
    double *before = copy_positions(mesh);
    for (long n = 0; n < 10000 && !applied; n++) {
        ffd_rig_report report;
        f.left = n;
        ffd_set_allocator(&a);
        ffd_status s = ffd_rig_apply(rig, mesh, &report, NULL);
        ffd_set_allocator(NULL);
        CHECK(s == FFD_OK || s == FFD_ERR_NOMEM);
        if (s != FFD_OK) {
            CHECK(same_positions(mesh, before));
            CHECK(report.residuals == NULL && report.reached == NULL);
        }
        applied = s == FFD_OK;
        ffd_rig_report_free(&report);
    }
    CHECK(applied);
    free(before);
done:
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

/* Every registered method reads its own rigs (ffd_method.parse): a rig whose
 * "deformer" names it comes back tagged with it; no "deformer" is a lattice. */
static void test_registry_schemas(void)
{
    static const char *const rigs[] = {
        "{\"deformer\": \"lattice\", \"resolution\": [4, 4, 4]}",
        "{\"deformer\": \"pbffd\", \"controls\": [{\"center\": [0, 0, 0], \"radius\": 1}]}",
        "{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"point\", \"position\": [0, 0, 0], "
        "\"radius\": 1}]}",
        "{\"deformer\": \"tspline\", \"resolution\": [4, 4, 4]}",
        "{\"deformer\": \"cage\", \"cage\": \"auto\"}",
        "{\"deformer\": \"kelvinlet\", \"brushes\": []}",
        "{\"deformer\": \"rbf\", \"control_points\": [[0, 0, 0]]}",
        "{\"deformer\": \"idw\", \"control_points\": [[0, 0, 0]]}",
    };
    CHECK(ffd_method_count() == sizeof rigs / sizeof *rigs);
    for (size_t i = 0; i < ffd_method_count(); i++) {
        const ffd_method *m = ffd_method_at(i);
        CHECK(m->parse != NULL);
        ffd_rig *rig = parse_ok(rigs[i]);
        CHECK(rig && strstr(rigs[i], m->name) && rig->method == m);
        CHECK(rig && ffd_method_of_rig(rig) == m);
        ffd_rig_destroy(rig);
    }
    ffd_rig *rig = parse_ok("{\"moves\": []}");
    CHECK(rig && rig->method == ffd_method_find("lattice"));
    ffd_rig_destroy(rig);
}

/* The registry's rig keys are the schema: a key of another method in a
 * rig of a method with direct manipulation is refused naming its method
 * (the first in registry order that has it), whatever the method; a rig of
 * a method with its own key list names the list; and an uploaded rig's
 * "file" is refused before anything is read. */
static void test_registry_rig_keys(void)
{
    static const char *const linear[] = {"lattice", "pbffd"};
    size_t refused = 0;
    for (size_t l = 0; l < 2; l++) {
        const ffd_method *own = ffd_method_find(linear[l]);
        CHECK(own && own->rig_keys && own->rig_keys[0]);
        for (size_t i = 0; own && i < ffd_method_count(); i++) {
            const ffd_method *other = ffd_method_at(i);
            for (const char *const *k = other->rig_keys; other != own && k && *k; k++) {
                int shared = 0, first = 1;
                for (const char *const *o = own->rig_keys; *o; o++)
                    shared |= !strcmp(*o, *k);
                for (size_t j = 0; j < i; j++)
                    for (const char *const *o = ffd_method_at(j)->rig_keys;
                         ffd_method_at(j) != own && o && *o; o++)
                        first &= strcmp(*o, *k) != 0;
                if (shared || !first)
                    continue;
                char json[160], want[160];
                snprintf(json, sizeof json, "{\"deformer\": \"%s\", \"%s\": 1}", own->name, *k);
                snprintf(want, sizeof want,
                         "rig.json: %s: only for \"deformer\": \"%s\" rigs (this rig's deformer "
                         "is \"%s\")",
                         *k, other->name, own->name);
                parse_bad(json, FFD_ERR_PARSE, want);
                refused++;
            }
        }
    }
    CHECK(refused >= 10);
    parse_bad("{\"steps\": []}", FFD_ERR_PARSE,
              "steps: only for \"deformer\": \"tspline\" rigs (this rig's deformer is \"lattice\")");
    parse_bad("{\"deformer\": \"tspline\", \"moves\": []}", FFD_ERR_PARSE,
              "moves: not a key of \"deformer\": \"tspline\" rigs, expected one of \"resolution\", "
              "\"padding\", \"steps\", \"fold_samples\"");
    parse_bad("{\"moves\": [], \"margin\": 0, \"moves\": []}", FFD_ERR_PARSE, "moves: key given twice");

    static const char gffd_file[] =
        "{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"polyline\", \"radius\": 1, "
        "\"file\": \"/etc/passwd\"}]}";
    const ffd_rig_files uploaded = {NULL};
    ffd_rig *rig = (ffd_rig *)1;
    ffd_error err = {{0}};
    CHECK(ffd_rig_parse_json_files(gffd_file, strlen(gffd_file), "rig.json", &uploaded, &rig,
                                   &err) == FFD_ERR_INVALID && rig == NULL);
    CHECK(strstr(err.message, "rig.json: skeleton: refers to the file \"/etc/passwd\": an "
                              "uploaded rig cannot read files"));
    const ffd_rig_files under_tmp = {"/tmp"};
    CHECK(ffd_rig_parse_json_files(gffd_file, strlen(gffd_file), "rig.json", &under_tmp, &rig,
                                   &err) == FFD_ERR_INVALID && rig == NULL);
    CHECK(strstr(err.message, "skeleton: the file \"/etc/passwd\" is outside the server's directory"));
}

/* One schema per method: each method's writer (ffd_method.write, in the
 * file of its reader) writes what its reader reads back to the same rig,
 * every kind of entry of every method included: parse, write, parse, write
 * gives the same text twice, and the text holds what the rig said. */
static void test_registry_write_round_trip(void)
{
    static const struct {
        const char *rig, *holds;
    } rigs[] = {
        {"{\"box\": {\"origin\": [0, 0, 0], \"axes\": [[2, 0, 0], [0, 1, 0], [0, 0, 1]]}, "
         "\"basis\": \"bernstein\", \"resolution\": [3, 4, 5], \"outside\": \"clamp\", \"moves\": "
         "[{\"index\": [1, 2, 3], \"delta\": [0.25, 0, -1]}], \"rcond\": 1e-6, \"constraints\": "
         "[{\"vertex\": 3, \"target\": [1, 2, 3]}, {\"point\": [0.5, 0.5, 0.5], \"target\": [0, 0, 1]}]}",
         "\"outside\":\t\"clamp\""},
        {"{\"margin\": 0.2, \"resolution\": [2, 2, 2]}", "\"margin\":\t0.2"},
        {"{\"deformer\": \"pbffd\", \"controls\": [{\"center\": [0, 0, 0], \"radius\": 1}, "
         "{\"center\": [1, 0, 0], \"radius\": [1, 2, 1], \"enabled\": false}], \"sigma\": 2, "
         "\"levels\": 2, \"master\": {\"radius\": 3, \"weight\": 0.5}, \"moves\": [{\"control\": 1, "
         "\"delta\": [0, 0, 1]}, {\"near\": [1, 0, 0], \"level\": 1, \"delta\": [1, 0, 0]}], "
         "\"frames\": [{\"control\": 0, \"scale\": [1, 2, 1]}, {\"control\": 1, \"frame\": [[1, 0, 0], "
         "[0, 2, 0], [0, 0, 1]]}, {\"control\": 0, \"rotate\": {\"axis\": [0, 0, 1], \"angle\": 1}}], "
         "\"curves\": [{\"points\": [[0, 0, 0], [1, 0, 0], [2, 0, 0]], \"radius\": 0.5, \"samples\": 9, "
         "\"moves\": [{\"index\": 2, \"delta\": [0, 1, 0]}]}], \"constraint_level\": 1, "
         "\"constraints\": [{\"vertex\": 0, \"target\": [0, 0, 0]}]}",
         "\"enabled\":\tfalse"},
        {"{\"deformer\": \"pbffd\", \"controls\": {\"interior\": 10, \"exterior\": 20, \"offset\": "
         "0.2, \"radius_factor\": 2, \"surface\": \"open\", \"voronoi_sites\": 500, \"cover\": false}, "
         "\"master\": false}",
         "\"surface\":\t\"open\""},
        {"{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"polyline\", \"vertices\": [[0, 0, 0], "
         "[1, 0, 0], [2, 0, 0]], \"radius\": 1}, {\"type\": \"patch\", \"vertices\": [[0, 0, 0], "
         "[1, 0, 0], [0, 1, 0]], \"faces\": [[0, 1, 2]], \"radius\": 1}, {\"type\": \"point\", "
         "\"position\": [5, 5, 5], \"radius\": 2}], \"unit\": 0.5, \"tracking\": \"warp\", "
         "\"tolerance\": 0.01, \"max_iterations\": 7, \"max_samples\": 300, \"edits\": "
         "[{\"primitive\": 0, \"vertices\": [[0, 0, 0], [1, 1, 0], [2, 0, 0]]}, {\"primitive\": 1, "
         "\"move\": [0, 0, 1], \"vertex\": 2}, {\"primitive\": \"all\", \"translate\": [1, 0, 0]}, "
         "{\"primitive\": 2, \"rotate\": {\"axis\": [0, 1, 0], \"angle\": 0.5}, \"center\": [0, 0, 0]}, "
         "{\"primitive\": 1, \"scale\": [1, 2, 3]}], \"resample\": {\"ratio\": 2, \"max_rounds\": 3, "
         "\"max_vertices\": 99}}",
         "\"primitive\":\t\"all\""},
        {"{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"point\", \"position\": [0, 0, 0], "
         "\"radius\": 1}], \"replace\": [{\"type\": \"polyline\", \"vertices\": [[0, 0, 0], "
         "[1, 0, 0]], \"radius\": 1}], \"correspondences\": [{\"from\": [0, 0, 0], \"to\": "
         "[1, 0, 0]}], \"resample\": true}",
         "\"replace\":"},
        {"{\"deformer\": \"tspline\", \"resolution\": [5, 6, 7], \"padding\": 0.1, \"fold_samples\": "
         "16, \"steps\": [{\"refine\": [{\"cell\": 0}, {\"edge\": {\"near\": [0, 0, 0]}, \"ratio\": "
         "0.25}, {\"cells\": \"proxy\"}, {\"face\": 3}]}, {\"deform\": {\"handles\": [{\"points\": "
         "[1, 2], \"delta\": [0, 0, 1]}, {\"box\": {\"min\": [0, 0, 0], \"max\": [1, 1, 1]}, "
         "\"rotate\": {\"axis\": [0, 0, 1], \"angle\": 0.5, \"center\": [1, 1, 1]}}], \"freeze\": "
         "[{\"edges\": [3]}, {\"near\": [0, 0, 0]}, {\"faces\": [1]}], \"weights\": {\"one_form\": 2, "
         "\"target\": 3}, \"iterations\": 9, \"soft\": true, \"only_target\": true}}, {\"move\": "
         "[{\"cells\": [0, 1], \"delta\": [1, 0, 0]}]}, {\"constraints\": {\"targets\": [{\"vertex\": "
         "4, \"target\": [1, 2, 3]}], \"freeze\": [{\"points\": [7]}]}}]}",
         "\"only_target\":\ttrue"},
        {"{\"deformer\": \"cage\", \"cage\": {\"vertices\": [[1, 0, 0], [-1, 0, 0], [0, 1, 0], "
         "[0, -1, 0], [0, 0, 1], [0, 0, -1]], \"faces\": [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], "
         "[2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]}, \"coordinates\": \"harmonic\", "
         "\"resolution\": 9, \"outside\": \"clamp\", \"moves\": [{\"index\": 4, \"delta\": [0, "
         "0, 0.5]}]}",
         "\"outside\":\t\"clamp\""},
        {"{\"deformer\": \"kelvinlet\", \"poisson_ratio\": 0.3, \"combine\": \"sequence\", "
         "\"steps\": 3, \"multiscale\": \"triscale\", \"ratio\": 1.5, \"brushes\": [{\"type\": "
         "\"grab\", \"center\": [0, 0, 0], \"radius\": 1, \"displacement\": [0, 0, 1]}, "
         "{\"type\": \"twist\", \"center\": [1, 0, 0], \"radius\": 2, \"axis\": [0, 1, 0], "
         "\"angle\": 0.5}, {\"type\": \"scale\", \"center\": [0, 1, 0], \"radius\": 1, "
         "\"factor\": 2}, {\"type\": \"pinch\", \"center\": [0, 0, 1], \"radius\": 1, "
         "\"pinch\": [[1, 0, 0], [0, -1, 0], [0, 0, 0]]}]}",
         "\"ratio\":\t1.5"},
    };
    CHECK(ffd_method_count() == 8);
    for (size_t i = 0; i < ffd_method_count(); i++)
        CHECK(ffd_method_at(i)->write != NULL);
    for (size_t r = 0; r < sizeof rigs / sizeof *rigs; r++) {
        ffd_error err = {{0}};
        ffd_rig *first = parse_ok(rigs[r].rig), *second = NULL;
        char *text1 = NULL, *text2 = NULL;
        CHECK(first && ffd_rig_write_json(first, &text1, &err) == FFD_OK);
        CHECK(text1 && ffd_rig_parse_json(text1, strlen(text1), "written.json", &second, &err) ==
                           FFD_OK);
        if (!second)
            fprintf(stderr, "  rig %zu: %s\n", r, err.message);
        CHECK(second && ffd_rig_write_json(second, &text2, &err) == FFD_OK);
        CHECK(text1 && text2 && strcmp(text1, text2) == 0);
        CHECK(text1 && strstr(text1, rigs[r].holds));
        if (!text1 || !strstr(text1, rigs[r].holds))
            fprintf(stderr, "  rig %zu written as:\n%s\n  (%s)\n", r, text1 ? text1 : "(none)",
                    err.message);
        ffd_free(text1);
        ffd_free(text2);
        ffd_rig_destroy(first);
        ffd_rig_destroy(second);
    }
}

/* The arrays of every method's schema (ffd_rig_read_array: elements that own
 * memory, nested arrays) under every allocation failure: NOMEM, nothing
 * leaked (ASan), and the rig reads once allocation succeeds. */
static void test_allocation_failures_every_method(void)
{
    static const char *const rigs[] = {
        "{\"deformer\": \"pbffd\", \"controls\": [{\"center\": [0, 0, 0], \"radius\": 1}, "
        "{\"center\": [1, 0, 0], \"radius\": [1, 2, 1]}], \"moves\": [{\"control\": 1, \"delta\": "
        "[0, 0, 1]}], \"frames\": [{\"control\": 0, \"scale\": [1, 2, 1]}], \"curves\": "
        "[{\"points\": [[0, 0, 0], [1, 0, 0], [2, 0, 0]], \"radius\": 0.5, \"moves\": "
        "[{\"index\": 2, \"delta\": [0, 1, 0]}]}, {\"points\": [[0, 1, 0], [1, 1, 0]], "
        "\"radius\": 0.5}], \"constraints\": [{\"vertex\": 0, \"target\": [0, 0, 0]}]}",
        "{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"polyline\", \"vertices\": [[0, 0, 0], "
        "[1, 0, 0], [2, 0, 0]], \"radius\": 1}, {\"type\": \"patch\", \"vertices\": [[0, 0, 0], "
        "[1, 0, 0], [0, 1, 0]], \"faces\": [[0, 1, 2]], \"radius\": 1}], \"edits\": "
        "[{\"primitive\": 0, \"vertices\": [[0, 0, 0], [1, 1, 0], [2, 0, 0]]}, {\"primitive\": 1, "
        "\"move\": [0, 0, 1], \"vertex\": 2}]}",
        "{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"point\", \"position\": [0, 0, 0], "
        "\"radius\": 1}], \"replace\": [{\"type\": \"polyline\", \"vertices\": [[0, 0, 0], "
        "[1, 0, 0]], \"radius\": 1}], \"correspondences\": [{\"from\": [0, 0, 0], \"to\": "
        "[1, 0, 0]}]}",
        "{\"deformer\": \"tspline\", \"steps\": [{\"refine\": [{\"cell\": 0}, {\"edge\": {\"near\": "
        "[0, 0, 0]}}]}, {\"deform\": {\"handles\": [{\"points\": [1, 2], \"delta\": [0, 0, 1]}, "
        "{\"box\": {\"min\": [0, 0, 0], \"max\": [1, 1, 1]}, \"rotate\": {\"axis\": [0, 0, 1], "
        "\"angle\": 0.5}}], \"freeze\": [{\"edges\": [3]}, {\"near\": [0, 0, 0]}]}}, {\"move\": "
        "[{\"cells\": [0, 1], \"delta\": [1, 0, 0]}]}]}",
    };
    fail_alloc f = {0, 0};
    ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &f};
    for (size_t r = 0; r < sizeof rigs / sizeof *rigs; r++) {
        int parsed = 0;
        ffd_rig *ok = parse_ok(rigs[r]);
        CHECK(ok != NULL);
        ffd_rig_destroy(ok);
        for (long n = 0; n < 10000 && !parsed; n++) {
            ffd_rig *rig = NULL;
            f.left = n;
            ffd_set_allocator(&a);
            ffd_status s = ffd_rig_parse_json(rigs[r], strlen(rigs[r]), "a.json", &rig, NULL);
            ffd_set_allocator(NULL);
            CHECK(s == FFD_OK || s == FFD_ERR_NOMEM);
            CHECK((s == FFD_OK) == (rig != NULL));
            parsed = s == FFD_OK;
            ffd_rig_destroy(rig);
        }
        CHECK(parsed);
    }
}

/* Every method's report has the same shape: its name, the shared fields,
 * and details that parse as one JSON object; only the method's own keys
 * differ (the lattice has none). */
static void test_report_every_method(void)
{
    static const struct {
        const char *method, *mesh, *rig, *key;
    } cases[] = {
        {"lattice", "lattice/bunny.obj", "lattice/pins.json", NULL},
        {"pbffd", "pbffd/cow.off", "pbffd/cow-drag.json", "levels"},
        {"gffd", "gffd/bunny.obj", "gffd/twist.json", "influenced"},
        {"tspline", "tspline/bunny.obj", "tspline/bunny-ears.json", "folds"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        char mesh_path[512], rig_path[512];
        snprintf(mesh_path, sizeof mesh_path, "%s/examples/%s", FFD_SOURCE_DIR, cases[c].mesh);
        snprintf(rig_path, sizeof rig_path, "%s/examples/%s", FFD_SOURCE_DIR, cases[c].rig);
        ffd_mesh *mesh = NULL;
        ffd_rig *rig = NULL;
        ffd_rig_report report;
        memset(&report, 0xab, sizeof report); /* the apply sets every field */
        ffd_error err = {{0}};
        CHECK_OK(ffd_mesh_read(mesh_path, &mesh, &err));
        CHECK_OK(ffd_rig_read(rig_path, &rig, &err));
        if (mesh && rig && ffd_rig_apply(rig, mesh, &report, &err) == FFD_OK) {
            CHECK(report.method && strcmp(report.method, cases[c].method) == 0);
            CHECK(report.control_count > 0 && report.control_points != NULL);
            cJSON *details = cJSON_Parse(report.details ? report.details : "");
            CHECK(cJSON_IsObject(details));
            if (cases[c].key)
                CHECK(cJSON_GetObjectItemCaseSensitive(details, cases[c].key) != NULL);
            else
                CHECK(details && details->child == NULL);
            cJSON_Delete(details);
            /* only the T-spline has a control mesh and explicit control edges */
            int tspline = strcmp(cases[c].method, "tspline") == 0;
            CHECK((report.control_face_offsets != NULL) == tspline);
            CHECK((report.control_edges != NULL) == tspline);
            CHECK(report.notes == NULL); /* the examples neither fold nor lose vertices */
            ffd_rig_report_free(&report);
        } else {
            fprintf(stderr, "  %s: %s\n", cases[c].rig, err.message);
            CHECK(!"the example applies");
        }
        ffd_rig_destroy(rig);
        ffd_mesh_destroy(mesh);
    }
    /* a failed apply leaves the report empty */
    ffd_rig *rig = NULL;
    ffd_mesh *mesh = NULL;
    static const char bad[] = "{\"resolution\": [3, 3, 3], \"constraints\": [{\"vertex\": 4000000, "
                              "\"target\": [0, 0, 0]}]}";
    ffd_error err = {{0}};
    CHECK_OK(ffd_rig_parse_json(bad, sizeof bad - 1, "bad.json", &rig, &err));
    char mesh_path[512];
    snprintf(mesh_path, sizeof mesh_path, "%s/examples/lattice/bunny.obj", FFD_SOURCE_DIR);
    CHECK_OK(ffd_mesh_read(mesh_path, &mesh, &err));
    if (rig && mesh) {
        ffd_rig_report report;
        memset(&report, 0xab, sizeof report);
        CHECK(ffd_rig_apply(rig, mesh, &report, &err) == FFD_ERR_RANGE);
        CHECK(report.method == NULL && report.details == NULL && report.notes == NULL);
        ffd_rig_report_free(&report);
    }
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

static void test_report_free_null(void)
{
    ffd_rig_report_free(NULL);
    ffd_rig_destroy(NULL);
    ffd_rig_report report = {0};
    ffd_rig_report_free(&report);
    CHECK(report.residuals == NULL);
}

/* Issue 14: cJSON decodes \u0000 into a NUL and the rig saw the text before
 * it ({"margin\u0000x": 0.1} set "margin"); a NUL in any key or string is
 * refused with line:column. A UTF-8 byte order mark before the JSON is read
 * past (cJSON alone fails on it). */
static void test_parse_nul_and_bom(void)
{
    parse_bad("{\"deformer\": \"lattice\", \"margin\\u0000x\": 0.1}", FFD_ERR_PARSE,
              "rig.json:1:32: a NUL character (\\u0000) in a string is not allowed");
    parse_bad("{\"deformer\": \"lattice\",\n \"basis\": \"bspline\\u0000junk\"}", FFD_ERR_PARSE,
              "rig.json:2:19: a NUL character (\\u0000) in a string is not allowed");
    parse_bad("{\"deformer\": \"lattice\\u0000\"}", FFD_ERR_PARSE, "rig.json:1:22: a NUL character");
    parse_bad("{\"deformer\": \"lattice\", \"moves\": [{\"index\\u0000\": [0,0,0]}]}", FFD_ERR_PARSE,
              "a NUL character (\\u0000) in a string");
    /* an escaped backslash before u0000 is text, and no NUL */
    parse_bad("{\"deformer\": \"lattice\", \"basis\": \"\\\\u0000\"}", FFD_ERR_PARSE, "rig.json: basis: expected");
    /* the byte order mark */
    ffd_rig *rig = parse_ok("\xEF\xBB\xBF{\"deformer\": \"lattice\", \"margin\": 0.25}");
    if (rig) {
        CHECK(rig->margin == 0.25);
        ffd_rig_destroy(rig);
    }
    rig = parse_ok("\xEF\xBB\xBF\r\n  {\"deformer\": \"lattice\"}\n");
    ffd_rig_destroy(rig);
    parse_bad("\xEF\xBB\xBF", FFD_ERR_PARSE, "rig.json: empty file");
    parse_bad("\xEF\xBB\xBF{\n\"deformer\": }", FFD_ERR_PARSE, "rig.json:2:");
    parse_bad("{\"deformer\": \"lattice\"}\xEF\xBB\xBF", FFD_ERR_PARSE, "unexpected text after the JSON value");
    parse_bad(" \xEF\xBB\xBF{\"deformer\": \"lattice\"}", FFD_ERR_PARSE, "rig.json:1:2: invalid JSON");
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"parse_every_key", test_parse_every_key},
        {"parse_defaults", test_parse_defaults},
        {"parse_bad_keys_and_types", test_parse_bad_keys_and_types},
        {"parse_bad_values", test_parse_bad_values},
        {"parse_syntax_errors", test_parse_syntax_errors},
        {"parse_nul_and_bom", test_parse_nul_and_bom},
        {"parse_size_limit", test_parse_size_limit},
        {"parse_prefixes", test_parse_prefixes},
        {"read_files", test_read_files},
        {"report_free_null", test_report_free_null},
        {"report_every_method", test_report_every_method},
        {"apply_identity", test_apply_identity},
        {"apply_moves_translate", test_apply_moves_translate},
        {"apply_constraints_bspline", test_apply_constraints_bspline},
        {"apply_constraints_bernstein", test_apply_constraints_bernstein},
        {"apply_conflicting_constraints", test_apply_conflicting_constraints},
        {"apply_errors", test_apply_errors},
        {"apply_random_pins", test_apply_random_pins},
        {"apply_outside", test_apply_outside},
        {"apply_normals", test_apply_normals},
        {"apply_partial_move_keeps_bytes", test_apply_partial_move_keeps_bytes},
        {"allocation_failures", test_allocation_failures},
        {"allocation_failures_every_method", test_allocation_failures_every_method},
        {"registry_schemas", test_registry_schemas},
        {"registry_rig_keys", test_registry_rig_keys},
        {"registry_write_round_trip", test_registry_write_round_trip},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
