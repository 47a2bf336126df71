/* Tests for T-spline rigs (src/rig with "deformer": "tspline", docs/rig.md
 * "T-spline rigs"): every key and its parsed value, every row of the
 * "T-spline errors" table and other malformed values, and ffd_rig_apply on
 * real meshes: identity (empty rig, refinement only), translations and
 * rotations of the whole lattice, a deformation with a frozen region,
 * direct manipulation of vertices, refinement after a deformation, the
 * report's fields, the lattice and proxy OBJ files, and allocation failures. */
#include "check.h"
#include "report_details.h"
#include "check_rig.h"
#include "tspline/tspline_method.h"

#include <dirent.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#define T "{\"deformer\": \"tspline\", "
#define BUNNY FFD_DATA_DIR "/bunny.obj"
/* a handle that moves every control point */
#define ALL "\"box\": {\"min\": [-1e9, -1e9, -1e9], \"max\": [1e9, 1e9, 1e9]}"

static ffd_mesh *read_mesh(const char *path)
{
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    ffd_status s = ffd_mesh_read(path, &mesh, &err);
    if (s != FFD_OK) {
        fprintf(stderr, "%s: cannot read %s: %s\n", check_current, path, err.message);
        check_failures++;
    }
    return mesh;
}

static void bbox(const ffd_mesh *mesh, double mn[3], double mx[3])
{
    const double *p = ffd_mesh_positions(mesh);
    size_t n = ffd_mesh_vertex_count(mesh);
    for (int a = 0; a < 3; a++) {
        mn[a] = INFINITY;
        mx[a] = -INFINITY;
    }
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            if (p[3 * i + a] < mn[a])
                mn[a] = p[3 * i + a];
            if (p[3 * i + a] > mx[a])
                mx[a] = p[3 * i + a];
        }
}

static double diag(const ffd_mesh *mesh)
{
    double mn[3], mx[3];
    bbox(mesh, mn, mx);
    return sqrt((mx[0] - mn[0]) * (mx[0] - mn[0]) + (mx[1] - mn[1]) * (mx[1] - mn[1]) +
                (mx[2] - mn[2]) * (mx[2] - mn[2]));
}

/* max over vertices of |a_i - b_i| */
static double max_diff(const double *a, const double *b, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; i++) {
        double d = sqrt((a[3 * i] - b[3 * i]) * (a[3 * i] - b[3 * i]) +
                        (a[3 * i + 1] - b[3 * i + 1]) * (a[3 * i + 1] - b[3 * i + 1]) +
                        (a[3 * i + 2] - b[3 * i + 2]) * (a[3 * i + 2] - b[3 * i + 2]));
        if (!(d <= m))
            m = d;
    }
    return m;
}

/* Applies json to a fresh copy of path's mesh; returns its positions
 * (malloc) and fills the report (may be NULL). NULL on failure. */
static double *apply_to(const char *path, const char *json, ffd_rig_report *report)
{
    ffd_mesh *mesh = read_mesh(path);
    if (!mesh)
        return NULL;
    ffd_error err = {{0}};
    ffd_status s = apply_json(json, mesh, report, &err);
    double *out = NULL;
    if (s != FFD_OK) {
        fprintf(stderr, "%s: apply failed (%s): %s\n  json: %s\n", check_current,
                ffd_status_string(s), err.message, json);
        check_failures++;
    } else {
        out = copy_positions(mesh);
    }
    ffd_mesh_destroy(mesh);
    return out;
}

/* ---------------------------------------------------------------------- */

static void test_parse_every_key(void)
{
    ffd_rig *rig = parse_ok(
        T "\"version\": 1, \"resolution\": [5, 6, 7], \"padding\": 0.25, \"fold_samples\": 4,"
          " \"steps\": ["
          "  {\"refine\": [{\"cell\": 3}, {\"face\": {\"near\": [1, 2, 3]}},"
          "               {\"edge\": 5, \"ratio\": 0.25}, {\"cells\": \"proxy\"},"
          "               {\"edge\": {\"near\": [4, 5, 6]}}, {\"face\": 7}, {\"edge\": 8},"
          "               {\"cell\": {\"near\": [0, 0, 1]}}]},"
          "  {\"deform\": {\"handles\": ["
          "      {\"points\": [1, 2], \"delta\": [0, 0, 1]},"
          "      {\"near\": [1, 2, 3], \"rotate\": {\"axis\": [0, 0, 2], \"angle\": 0.5,"
          "                                          \"center\": [1, 1, 1]}},"
          "      {\"box\": {\"min\": [0, 0, 0], \"max\": [1, 2, 3]},"
          "       \"rotate\": {\"axis\": [1, 0, 0], \"angle\": -0.25}},"
          "      {\"edges\": [4], \"delta\": [1, 0, 0]}, {\"faces\": [5, 6], \"delta\": [0, 1, 0]},"
          "      {\"cells\": [7], \"delta\": [0, 0, -1]}],"
          "    \"freeze\": [{\"edges\": [1]}, {\"faces\": [2, 3]}, {\"cells\": [4]},"
          "                 {\"points\": [9]}, {\"near\": [0, 0, 0]},"
          "                 {\"box\": {\"min\": [-1, -1, -1], \"max\": [0, 0, 0]}}],"
          "    \"weights\": {\"one_form\": 1.5, \"proxy\": 1, \"volume\": 0.75, \"target\": 2},"
          "    \"iterations\": 7, \"soft\": true, \"only_target\": true}},"
          "  {\"move\": [{\"cells\": [0], \"delta\": [1, 0, 0]},"
          "             {\"points\": [3], \"rotate\": {\"axis\": [0, 1, 0], \"angle\": 1}}]},"
          "  {\"constraints\": {\"targets\": [{\"vertex\": 3, \"target\": [1, 2, 3]},"
          "                                  {\"vertex\": 0, \"target\": [0, 0, 0]}],"
          "                     \"freeze\": [{\"points\": [0, 1]}]}},"
          "  {\"deform\": {\"handles\": [{\"points\": [0], \"delta\": [0, 0, 0]}]}}"
          "]}");
    if (!rig)
        return;
    CHECK(rig->method == &ffd_method_tspline);
    const ffd_rig_tspline *t = ffd_rig_tspline_of(rig);
    CHECK(t->resolution[0] == 5 && t->resolution[1] == 6 && t->resolution[2] == 7);
    CHECK(t->options.padding == 0.25);
    CHECK(t->fold_samples == 4);
    CHECK(t->step_count == 5);
    if (t->step_count != 5) {
        ffd_rig_destroy(rig);
        return;
    }
    const ffd_rig_tsv_step *st = &t->steps[0];
    CHECK(st->kind == FFD_RIG_STEP_REFINE && st->refinement_count == 8);
    if (st->refinement_count == 8) {
        const ffd_rig_tsv_refinement *r = st->refinements;
        CHECK(r[0].kind == FFD_TSV_CELL && r[0].id == 3 && !r[0].by_near && !r[0].proxy_cells);
        CHECK(r[1].kind == FFD_TSV_FACE && r[1].by_near && r[1].near[0] == 1 &&
              r[1].near[1] == 2 && r[1].near[2] == 3);
        CHECK(r[2].kind == FFD_TSV_EDGE && r[2].id == 5 && r[2].ratio == 0.25);
        CHECK(r[3].kind == FFD_TSV_CELL && r[3].proxy_cells);
        CHECK(r[4].kind == FFD_TSV_EDGE && r[4].by_near && r[4].near[2] == 6);
        CHECK(r[5].kind == FFD_TSV_FACE && r[5].id == 7 && !r[5].by_near);
        CHECK(r[6].kind == FFD_TSV_EDGE && r[6].id == 8 && r[6].ratio == 0);
        CHECK(r[7].kind == FFD_TSV_CELL && r[7].by_near && r[7].near[2] == 1);
    }
    st = &t->steps[1];
    CHECK(st->kind == FFD_RIG_STEP_DEFORM && st->handle_count == 6 && st->freeze_count == 6);
    if (st->handle_count == 6) {
        const ffd_rig_tsv_handle *h = st->handles;
        CHECK(h[0].sel.kind == FFD_RIG_SELECT_POINTS && h[0].sel.id_count == 2 &&
              h[0].sel.ids[0] == 1 && h[0].sel.ids[1] == 2);
        CHECK(h[0].has_delta && !h[0].has_rotate && h[0].delta[2] == 1);
        CHECK(h[1].sel.kind == FFD_RIG_SELECT_NEAR && h[1].sel.near[1] == 2);
        CHECK(h[1].has_rotate && !h[1].has_delta && h[1].axis[2] == 2 && h[1].angle == 0.5 &&
              h[1].has_center && h[1].center[0] == 1);
        CHECK(h[2].sel.kind == FFD_RIG_SELECT_BOX && h[2].sel.box_max[2] == 3 &&
              h[2].sel.box_min[0] == 0);
        CHECK(h[2].has_rotate && !h[2].has_center && h[2].angle == -0.25 && h[2].axis[0] == 1);
        CHECK(h[3].sel.kind == FFD_RIG_SELECT_EDGES && h[3].sel.id_count == 1 &&
              h[3].sel.ids[0] == 4 && h[3].delta[0] == 1);
        CHECK(h[4].sel.kind == FFD_RIG_SELECT_FACES && h[4].sel.id_count == 2 &&
              h[4].sel.ids[1] == 6);
        CHECK(h[5].sel.kind == FFD_RIG_SELECT_CELLS && h[5].sel.ids[0] == 7 &&
              h[5].delta[2] == -1);
    }
    if (st->freeze_count == 6) {
        const ffd_rig_tsv_selection *f = st->freeze;
        CHECK(f[0].kind == FFD_RIG_SELECT_EDGES && f[0].ids[0] == 1);
        CHECK(f[1].kind == FFD_RIG_SELECT_FACES && f[1].id_count == 2);
        CHECK(f[2].kind == FFD_RIG_SELECT_CELLS && f[2].ids[0] == 4);
        CHECK(f[3].kind == FFD_RIG_SELECT_POINTS && f[3].ids[0] == 9);
        CHECK(f[4].kind == FFD_RIG_SELECT_NEAR);
        CHECK(f[5].kind == FFD_RIG_SELECT_BOX && f[5].box_min[1] == -1);
    }
    CHECK(st->arap.w_one_form == 1.5 && st->arap.w_proxy == 1 && st->arap.w_volume == 0.75 &&
          st->arap.w_target == 2);
    CHECK(st->arap.iterations == 7 && st->arap.soft == 1 && st->arap.only_target == 1);
    st = &t->steps[2];
    CHECK(st->kind == FFD_RIG_STEP_MOVE && st->handle_count == 2);
    if (st->handle_count == 2) {
        CHECK(st->handles[0].sel.kind == FFD_RIG_SELECT_CELLS && st->handles[0].delta[0] == 1);
        CHECK(st->handles[1].has_rotate && st->handles[1].angle == 1);
    }
    st = &t->steps[3];
    CHECK(st->kind == FFD_RIG_STEP_CONSTRAIN && st->constraint_count == 2 &&
          st->freeze_count == 1);
    if (st->constraint_count == 2) {
        CHECK(st->constraints[0].kind == FFD_RIG_CONSTRAINT_VERTEX &&
              st->constraints[0].vertex == 3 && st->constraints[0].target[2] == 3);
        CHECK(st->constraints[1].vertex == 0);
    }
    if (st->freeze_count == 1)
        CHECK(st->freeze[0].id_count == 2 && st->freeze[0].ids[1] == 1);
    /* defaults of a deform step: zero (the library's defaults) */
    st = &t->steps[4];
    CHECK(st->kind == FFD_RIG_STEP_DEFORM && st->freeze_count == 0);
    CHECK(st->arap.w_one_form == 0 && st->arap.iterations == 0 && st->arap.soft == 0 &&
          st->arap.only_target == 0);
    ffd_rig_destroy(rig);

    /* defaults */
    rig = parse_ok(T "\"version\": 1}");
    if (rig) {
        CHECK(rig->method == &ffd_method_tspline);
        CHECK(ffd_rig_tspline_of(rig)->resolution[0] == 6 && ffd_rig_tspline_of(rig)->resolution[1] == 6 &&
              ffd_rig_tspline_of(rig)->resolution[2] == 6);
        CHECK(ffd_rig_tspline_of(rig)->options.padding == 0 && ffd_rig_tspline_of(rig)->step_count == 0 &&
              ffd_rig_tspline_of(rig)->fold_samples == 0);
        ffd_rig_destroy(rig);
    }
    rig = parse_ok("{\"deformer\": \"tspline\", \"steps\": [], \"resolution\": [4, 256, 4]}");
    if (rig) {
        CHECK(ffd_rig_tspline_of(rig)->step_count == 0 && ffd_rig_tspline_of(rig)->resolution[1] == 256);
        ffd_rig_destroy(rig);
    }
    /* bounds that are allowed */
    rig = parse_ok(T "\"padding\": 100, \"fold_samples\": 64, \"steps\": [{\"deform\": {"
                     "\"handles\": [{\"points\": [0], \"delta\": [0,0,0]}], \"iterations\": 1000,"
                     " \"weights\": {\"one_form\": 1e6}, \"freeze\": []}}]}");
    if (rig) {
        CHECK(ffd_rig_tspline_of(rig)->options.padding == 100 && ffd_rig_tspline_of(rig)->fold_samples == 64);
        CHECK(ffd_rig_tspline_of(rig)->steps[0].arap.iterations == 1000 &&
              ffd_rig_tspline_of(rig)->steps[0].arap.w_one_form == 1e6 && ffd_rig_tspline_of(rig)->steps[0].freeze_count == 0);
        ffd_rig_destroy(rig);
    }
}

/* The parse-time rows of docs/rig.md's "T-spline errors" table. */
static void test_doc_errors_parse(void)
{
    parse_bad(T "\"resolution\": [3, 6, 6]}", FFD_ERR_INVALID,
              "rig.json: resolution[0]: 3: expected 4 to 256 control points (a cubic T-spline "
              "volume needs at least 4 per axis)");
    parse_bad(T "\"steps\": [{\"refine\": [{\"edge\": 2, \"ratio\": 1.5}]}]}", FFD_ERR_INVALID,
              "rig.json: steps[0].refine[0].ratio: 1.5: expected a number in (0, 1)");
    parse_bad(T "\"steps\": [{\"move\": [{\"points\": [0], \"delta\": [0,0,0]}]},"
                "{\"deform\": {\"handles\": [{\"points\": [0], \"delta\": [0,0,0]}]}},"
                "{\"constraints\": {\"targets\": [{\"point\": [0,0,0], \"target\": [1,1,1]}]}}]}",
              FFD_ERR_PARSE,
              "rig.json: steps[2].constraints.targets[0].point: T-spline rigs constrain object "
              "vertices (\"vertex\": id)");
    parse_bad(T "\"moves\": []}", FFD_ERR_PARSE,
              "rig.json: moves: not a key of \"deformer\": \"tspline\" rigs, expected one of");
    parse_bad(T "\"box\": \"auto\"}", FFD_ERR_PARSE,
              "rig.json: box: not a key of \"deformer\": \"tspline\" rigs");
    parse_bad(T "\"skeleton\": []}", FFD_ERR_PARSE,
              "rig.json: skeleton: not a key of \"deformer\": \"tspline\" rigs");
    parse_bad(T "\"constraints\": []}", FFD_ERR_PARSE,
              "rig.json: constraints: not a key of \"deformer\": \"tspline\" rigs");
}

static void test_parse_malformed(void)
{
    /* top level */
    parse_bad(T "\"version\": 2}", FFD_ERR_PARSE, "rig.json: version: expected 1");
    parse_bad(T "\"version\": \"1\"}", FFD_ERR_PARSE, "rig.json: version: expected 1");
    parse_bad(T "\"speed\": 1}", FFD_ERR_PARSE, "rig.json: speed: not a key of");
    parse_bad(T "\"resolution\": [6, 6, 6], \"resolution\": [6, 6, 6]}", FFD_ERR_PARSE,
              "resolution: key given twice");
    parse_bad(T "\"resolution\": [6, 6, 257]}", FFD_ERR_INVALID,
              "rig.json: resolution[2]: 257: expected 4 to 256 control points");
    parse_bad(T "\"resolution\": [6, 0, 6]}", FFD_ERR_INVALID, "rig.json: resolution[1]: 0:");
    parse_bad(T "\"resolution\": [6, 6]}", FFD_ERR_PARSE, "rig.json: resolution");
    parse_bad(T "\"resolution\": 6}", FFD_ERR_PARSE, "rig.json: resolution");
    parse_bad(T "\"resolution\": [6, 6.5, 6]}", FFD_ERR_PARSE, "rig.json: resolution");
    parse_bad(T "\"resolution\": [6, -6, 6]}", FFD_ERR_PARSE, "rig.json: resolution");
    parse_bad(T "\"padding\": -0.1}", FFD_ERR_PARSE, "rig.json: padding: expected a number in [0, 100]");
    parse_bad(T "\"padding\": 101}", FFD_ERR_PARSE, "rig.json: padding:");
    parse_bad(T "\"padding\": \"0\"}", FFD_ERR_PARSE, "rig.json: padding:");
    parse_bad(T "\"fold_samples\": 0}", FFD_ERR_PARSE, "rig.json: fold_samples: expected an integer in 1..64");
    parse_bad(T "\"fold_samples\": 65}", FFD_ERR_PARSE, "rig.json: fold_samples:");
    parse_bad(T "\"fold_samples\": 2.5}", FFD_ERR_PARSE, "rig.json: fold_samples:");
    parse_bad(T "\"steps\": {}}", FFD_ERR_PARSE, "rig.json: steps: expected an array of steps");
    parse_bad(T "\"steps\": [3]}", FFD_ERR_PARSE, "rig.json: steps[0]: expected an object with one key");
    parse_bad(T "\"steps\": [{}]}", FFD_ERR_PARSE, "rig.json: steps[0]: expected an object with one key");
    parse_bad(T "\"steps\": [{\"move\": [{\"points\": [0], \"delta\": [0,0,0]}],"
                " \"refine\": [{\"cell\": 0}]}]}",
              FFD_ERR_PARSE, "rig.json: steps[0]: expected an object with one key");
    parse_bad(T "\"steps\": [{\"bend\": []}]}", FFD_ERR_PARSE, "rig.json: steps[0].bend: unknown key");

    /* refine */
    parse_bad(T "\"steps\": [{\"refine\": []}]}", FFD_ERR_PARSE, "rig.json: steps[0].refine: expected a non-empty array");
    parse_bad(T "\"steps\": [{\"refine\": {\"cell\": 0}}]}", FFD_ERR_PARSE, "rig.json: steps[0].refine: expected");
    parse_bad(T "\"steps\": [{\"refine\": [3]}]}", FFD_ERR_PARSE, "rig.json: steps[0].refine[0]: expected an object");
    parse_bad(T "\"steps\": [{\"refine\": [{}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].refine[0]: expected exactly one of \"cell\", \"face\", \"edge\", \"cells\"");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cell\": 0, \"face\": 1}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].refine[0]: expected exactly one of");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cell\": 0, \"size\": 1}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].refine[0].size: unknown key");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cell\": -1}]}]}", FFD_ERR_PARSE, "rig.json: steps[0].refine[0].cell:");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cell\": 1.5}]}]}", FFD_ERR_PARSE, "rig.json: steps[0].refine[0].cell:");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cell\": \"3\"}]}]}", FFD_ERR_PARSE, "rig.json: steps[0].refine[0].cell:");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cells\": \"all\"}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].refine[0].cells: expected \"proxy\"");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cells\": 3}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].refine[0].cells: expected \"proxy\"");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cell\": {}}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].refine[0].cell.near: expected an array of 3 finite numbers (missing)");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cell\": {\"near\": [0,0,0], \"far\": 1}}]}]}",
              FFD_ERR_PARSE, "rig.json: steps[0].refine[0].cell.far: unknown key");
    parse_bad(T "\"steps\": [{\"refine\": [{\"face\": {\"near\": [0,0]}}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].refine[0].face.near: expected an array of 3");
    parse_bad(T "\"steps\": [{\"refine\": [{\"cell\": 0, \"ratio\": 0.5}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].refine[0].ratio: only for an \"edge\" insertion");
    parse_bad(T "\"steps\": [{\"refine\": [{\"edge\": 0, \"ratio\": 0}]}]}", FFD_ERR_INVALID,
              "rig.json: steps[0].refine[0].ratio: 0: expected a number in (0, 1)");
    parse_bad(T "\"steps\": [{\"refine\": [{\"edge\": 0, \"ratio\": 1}]}]}", FFD_ERR_INVALID,
              "rig.json: steps[0].refine[0].ratio: 1: expected a number in (0, 1)");
    parse_bad(T "\"steps\": [{\"refine\": [{\"edge\": 0, \"ratio\": \"half\"}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].refine[0].ratio:");
    parse_bad(T "\"steps\": [{\"refine\": [{\"edge\": 0}, {\"edge\": 0, \"ratio\": -1e999}]}]}",
              FFD_ERR_NONFINITE, "rig.json: steps[0].refine[1].ratio: expected a finite number");

    /* deform */
#define D(body) T "\"steps\": [{\"deform\": " body "}]}"
#define H0 "{\"points\": [0], \"delta\": [0,0,1]}"
    parse_bad(D("[]"), FFD_ERR_PARSE, "rig.json: steps[0].deform: expected an object");
    parse_bad(D("{}"), FFD_ERR_PARSE, "rig.json: steps[0].deform.handles: expected an array of handles (missing");
    parse_bad(D("{\"freeze\": [{\"points\": [0]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles: expected an array of handles (missing");
    parse_bad(D("{\"handles\": []}"), FFD_ERR_PARSE, "rig.json: steps[0].deform.handles: expected a non-empty array");
    parse_bad(D("{\"handles\": [" H0 "], \"speed\": 1}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.speed: unknown key");
    parse_bad(D("{\"handles\": [3]}"), FFD_ERR_PARSE, "rig.json: steps[0].deform.handles[0]: expected an object");
    parse_bad(D("{\"handles\": [{\"points\": [0]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0]: expected either \"delta\" or \"rotate\"");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"delta\": [0,0,1],"
                " \"rotate\": {\"axis\": [0,0,1], \"angle\": 1}}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].deform.handles[0]: expected either \"delta\" or \"rotate\"");
    parse_bad(D("{\"handles\": [{\"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0]: expected one of \"points\", \"near\", \"box\"");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"near\": [0,0,0], \"delta\": [0,0,1]}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].deform.handles[0]: expected exactly one of \"points\"");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"delta\": [0,0,1], \"speed\": 1}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].deform.handles[0].speed: unknown key");
    parse_bad(D("{\"handles\": [{\"points\": [], \"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].points: expected a non-empty array of ids");
    parse_bad(D("{\"handles\": [{\"points\": [0, -1], \"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].points[1]: expected an id");
    parse_bad(D("{\"handles\": [{\"cells\": [0.5], \"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].cells[0]: expected an id");
    parse_bad(D("{\"handles\": [{\"edges\": 3, \"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].edges: expected a non-empty array of ids");
    parse_bad(D("{\"handles\": [{\"faces\": [\"1\"], \"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].faces[0]: expected an id");
    parse_bad(D("{\"handles\": [{\"near\": [0,0], \"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].near: expected an array of 3");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"delta\": [0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].delta: expected an array of 3");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"delta\": [0,-1e999,1]}]}"), FFD_ERR_NONFINITE,
              "rig.json: steps[0].deform.handles[0].delta[1]: expected a finite number, got -inf");
    /* box */
    parse_bad(D("{\"handles\": [{\"box\": [0,0,0], \"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].box: expected an object {\"min\"");
    parse_bad(D("{\"handles\": [{\"box\": {\"min\": [0,0,0]}, \"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].box.max: expected an array of 3 finite numbers (missing)");
    parse_bad(D("{\"handles\": [{\"box\": {\"max\": [0,0,0]}, \"delta\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].box.min: expected an array of 3 finite numbers (missing)");
    parse_bad(D("{\"handles\": [{\"box\": {\"min\": [0,0,0], \"max\": [1,1,1], \"mid\": 0},"
                " \"delta\": [0,0,1]}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].deform.handles[0].box.mid: unknown key");
    parse_bad(D("{\"handles\": [{\"box\": {\"min\": [0,2,0], \"max\": [1,1,1]}, \"delta\": [0,0,1]}]}"),
              FFD_ERR_INVALID, "rig.json: steps[0].deform.handles[0].box: min[1] 2 is above max[1] 1");
    /* rotate */
    parse_bad(D("{\"handles\": [{\"points\": [0], \"rotate\": [0,0,1]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].rotate: expected an object {\"axis\"");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"rotate\": {\"axis\": [0,0,0], \"angle\": 1}}]}"),
              FFD_ERR_INVALID, "rig.json: steps[0].deform.handles[0].rotate.axis: the zero vector is no axis");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"rotate\": {\"angle\": 1}}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].rotate.axis: expected an array of 3 finite numbers (missing)");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"rotate\": {\"axis\": [0,0,1]}}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.handles[0].rotate.angle: expected an angle in radians (missing)");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"rotate\": {\"axis\": [0,0,1], \"angle\": \"1\"}}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].deform.handles[0].rotate.angle:");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"rotate\": {\"axis\": [0,0,1], \"angle\": 1,"
                " \"centre\": [0,0,0]}}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].deform.handles[0].rotate.centre: unknown key");
    parse_bad(D("{\"handles\": [{\"points\": [0], \"rotate\": {\"axis\": [0,0,1], \"angle\": 1,"
                " \"center\": [0,0]}}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].deform.handles[0].rotate.center: expected an array of 3");
    /* freeze */
    parse_bad(D("{\"handles\": [" H0 "], \"freeze\": {\"points\": [1]}}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.freeze: expected an array of selections");
    parse_bad(D("{\"handles\": [" H0 "], \"freeze\": [3]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.freeze[0]: expected an object");
    parse_bad(D("{\"handles\": [" H0 "], \"freeze\": [{\"points\": [1], \"delta\": [0,0,0]}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].deform.freeze[0].delta: unknown key");
    parse_bad(D("{\"handles\": [" H0 "], \"freeze\": [{}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.freeze[0]: expected one of \"points\"");
    parse_bad(D("{\"handles\": [" H0 "], \"freeze\": [{\"points\": [1], \"cells\": [1]}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].deform.freeze[0]: expected exactly one of");
    /* weights, iterations, soft, only_target */
    parse_bad(D("{\"handles\": [" H0 "], \"weights\": [1, 1, 1, 1]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.weights: expected an object");
    parse_bad(D("{\"handles\": [" H0 "], \"weights\": {\"smooth\": 1}}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.weights.smooth: unknown key");
    parse_bad(D("{\"handles\": [" H0 "], \"weights\": {\"proxy\": 0}}"), FFD_ERR_INVALID,
              "rig.json: steps[0].deform.weights.proxy: 0: expected a number > 0");
    parse_bad(D("{\"handles\": [" H0 "], \"weights\": {\"volume\": -1}}"), FFD_ERR_INVALID,
              "rig.json: steps[0].deform.weights.volume: -1: expected a number > 0");
    parse_bad(D("{\"handles\": [" H0 "], \"weights\": {\"target\": 2e6}}"), FFD_ERR_INVALID,
              "rig.json: steps[0].deform.weights.target: 2e+06: expected a weight in (0, 1e6]");
    parse_bad(D("{\"handles\": [" H0 "], \"weights\": {\"one_form\": \"1\"}}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.weights.one_form:");
    parse_bad(D("{\"handles\": [" H0 "], \"iterations\": 0}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.iterations: expected an integer in 1..1000");
    parse_bad(D("{\"handles\": [" H0 "], \"iterations\": 1001}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.iterations: expected an integer in 1..1000");
    parse_bad(D("{\"handles\": [" H0 "], \"iterations\": 2.5}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.iterations:");
    parse_bad(D("{\"handles\": [" H0 "], \"soft\": 1}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.soft: expected true or false");
    parse_bad(D("{\"handles\": [" H0 "], \"only_target\": \"yes\"}"), FFD_ERR_PARSE,
              "rig.json: steps[0].deform.only_target: expected true or false");
    parse_bad(D("{\"handles\": [" H0 "], \"soft\": true, \"soft\": false}"), FFD_ERR_PARSE,
              "soft: key given twice");
#undef D

    /* move */
    parse_bad(T "\"steps\": [{\"move\": []}]}", FFD_ERR_PARSE, "rig.json: steps[0].move: expected a non-empty array");
    parse_bad(T "\"steps\": [{\"move\": {\"points\": [0], \"delta\": [0,0,1]}}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].move: expected a non-empty array");
    parse_bad(T "\"steps\": [{\"move\": [{\"points\": [0]}]}]}", FFD_ERR_PARSE,
              "rig.json: steps[0].move[0]: expected either \"delta\" or \"rotate\"");

    /* constraints */
#define C(body) T "\"steps\": [{\"constraints\": " body "}]}"
    parse_bad(C("[]"), FFD_ERR_PARSE, "rig.json: steps[0].constraints: expected an object");
    parse_bad(C("{}"), FFD_ERR_PARSE, "rig.json: steps[0].constraints.targets: expected an array");
    parse_bad(C("{\"freeze\": []}"), FFD_ERR_PARSE, "rig.json: steps[0].constraints.targets: expected");
    parse_bad(C("{\"targets\": [], \"weights\": {}}"), FFD_ERR_PARSE,
              "rig.json: steps[0].constraints.weights: unknown key");
    parse_bad(C("{\"targets\": [{\"vertex\": 0}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].constraints.targets[0]");
    parse_bad(C("{\"targets\": [{\"vertex\": -1, \"target\": [0,0,0]}]}"), FFD_ERR_PARSE,
              "rig.json: steps[0].constraints.targets[0].vertex");
    parse_bad(C("{\"targets\": [{\"vertex\": 0, \"target\": [0,0,1e999]}]}"), FFD_ERR_NONFINITE,
              "rig.json: steps[0].constraints.targets[0].target[2]: expected a finite number, got inf");
    parse_bad(C("{\"targets\": [{\"vertex\": 0, \"target\": [0,0,0], \"speed\": 1}]}"),
              FFD_ERR_PARSE, "rig.json: steps[0].constraints.targets[0].speed: unknown key");
    parse_bad(C("{\"targets\": [{\"vertex\": 0, \"target\": [0,0,0]}], \"freeze\": 1}"),
              FFD_ERR_PARSE, "rig.json: steps[0].constraints.freeze: expected an array of selections");
    parse_bad(C("{\"targets\": [{\"vertex\": 0, \"target\": [0,0,0]}],"
                " \"freeze\": [{\"box\": {\"min\": [1,0,0], \"max\": [0,1,1]}}]}"),
              FFD_ERR_INVALID, "rig.json: steps[0].constraints.freeze[0].box: min[0] 1 is above max[0] 0");
#undef C
#undef H0
}

/* An edge of the lattice of res over the bunny whose knot interval along its
 * own axis is zero (in an end layer); UINT32_MAX when none. */
static uint32_t end_layer_edge(const ffd_mesh *mesh, const uint32_t res[3])
{
    ffd_tsv *t = NULL;
    uint32_t found = UINT32_MAX;
    CHECK_OK(ffd_tsv_create(ffd_mesh_positions(mesh), ffd_mesh_vertex_count(mesh),
                            ffd_mesh_face_offsets(mesh), ffd_mesh_face_indices(mesh),
                            ffd_mesh_face_count(mesh), res, NULL, &t, NULL));
    if (!t)
        return found;
    size_t ne = ffd_tsv_element_count(t, FFD_TSV_EDGE);
    for (uint32_t e = 0; e < ne && found == UINT32_MAX; e++) {
        uint32_t ends[2];
        int axis = -1;
        double lo[3], hi[3];
        CHECK_OK(ffd_tsv_edge(t, e, ends, &axis, NULL));
        CHECK_OK(ffd_tsv_element_box(t, FFD_TSV_EDGE, e, lo, hi, NULL));
        if (axis >= 0 && axis < 3 && hi[axis] == lo[axis])
            found = e;
    }
    ffd_tsv_destroy(t);
    return found;
}

/* The apply-time rows of the table (and others found at apply time). */
static void test_doc_errors_apply(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    char json[1024];
    /* res 6 x 7 x 8: 5 * 6 * 7 = 210 cells */
    apply_bad(T "\"resolution\": [6, 7, 8], \"steps\": [{\"refine\": [{\"cell\": 400}]}]}", mesh,
              FFD_ERR_RANGE, "rig.json: steps[0].refine: cell 400: there are 210 cells");
    apply_bad(T "\"steps\": [{\"refine\": [{\"cell\": 62}]}, {\"refine\": [{\"face\": 100000}]}]}",
              mesh, FFD_ERR_RANGE, "rig.json: steps[1].refine: face 100000: there are");
    apply_bad(T "\"steps\": [{\"refine\": [{\"edge\": 100000}]}]}", mesh, FFD_ERR_RANGE,
              "rig.json: steps[0].refine: edge 100000: there are");
    uint32_t res[3] = {6, 6, 6};
    uint32_t e = end_layer_edge(mesh, res);
    CHECK(e != UINT32_MAX);
    if (e != UINT32_MAX) {
        char want[128];
        snprintf(json, sizeof json, T "\"steps\": [{\"refine\": [{\"edge\": %u}]}]}", e);
        snprintf(want, sizeof want, "rig.json: steps[0].refine: edge %u: zero knot interval", e);
        apply_bad(json, mesh, FFD_ERR_INVALID, want);
    }
    apply_bad(T "\"steps\": [{\"move\": [{\"points\": [0], \"delta\": [0,0,0]}]},"
                "{\"deform\": {\"handles\": [{\"points\": [17], \"delta\": [0,0,1]}],"
                " \"freeze\": [{\"points\": [3, 17]}]}}]}",
              mesh, FFD_ERR_INVALID,
              "rig.json: steps[1].deform: handles[0]: control point 17 is also frozen: a target "
              "for a frozen point conflicts with keeping it fixed");
    /* a point in two handles (two targets for one point) */
    apply_bad(T "\"steps\": [{\"move\": [{\"points\": [0], \"delta\": [0,0,0]}]},"
                "{\"deform\": {\"handles\": [{\"points\": [1, 9], \"delta\": [0,0,1]},"
                " {\"points\": [5], \"delta\": [0,0,1]}, {\"points\": [7], \"delta\": [0,0,1]},"
                " {\"points\": [8, 9], \"delta\": [0,1,0]}]}}]}",
              mesh, FFD_ERR_INVALID, "rig.json: steps[1].deform: handles[3]: control point 9");
    apply_bad(T "\"steps\": [{\"move\": [{\"points\": [0], \"delta\": [0,0,0]}]},"
                "{\"deform\": {\"handles\": [{\"points\": [1, 9], \"delta\": [0,0,1]},"
                " {\"points\": [5], \"delta\": [0,0,1]}, {\"points\": [7], \"delta\": [0,0,1]},"
                " {\"points\": [8, 9], \"delta\": [0,1,0]}]}}]}",
              mesh, FFD_ERR_INVALID, "control point 9 is given twice");
    /* a point twice in the same handle is one point with one target: fine */
    {
        ffd_error err = {{0}};
        ffd_mesh *m2 = read_mesh(BUNNY);
        if (m2) {
            ffd_status s = apply_json(T "\"steps\": [{\"deform\": {\"handles\": [{\"points\": "
                                        "[9, 9], \"delta\": [0,0,0]}]}}]}",
                                      m2, NULL, &err);
            CHECK(s == FFD_OK);
            if (s)
                fprintf(stderr, "  %s\n", err.message);
            /* overlapping selections: a box whose points an earlier selection
               already froze still holds control points */
            s = apply_json(T "\"steps\": [{\"deform\": {\"handles\": [{\"near\": [0, 10, 0],"
                             " \"delta\": [0, 0.1, 0]}], \"freeze\": ["
                             "{\"box\": {\"min\": [-9, -9, -9], \"max\": [9, 3, 9]}},"
                             "{\"box\": {\"min\": [-9, -9, -9], \"max\": [9, 2, 9]}}]}}]}",
                           m2, NULL, &err);
            CHECK(s == FFD_OK);
            if (s)
                fprintf(stderr, "  %s\n", err.message);
            ffd_mesh_destroy(m2);
        }
    }
    apply_bad(T "\"steps\": [{\"move\": [{\"points\": [0], \"delta\": [0,0,0]}]},"
                "{\"deform\": {\"handles\": [{\"box\": {\"min\": [1000, 1000, 1000], \"max\":"
                " [1001, 1001, 1001]}, \"delta\": [0,0,1]}]}}]}",
              mesh, FFD_ERR_INVALID, "rig.json: steps[1].deform: handles[0]: box [");
    apply_bad(T "\"steps\": [{\"deform\": {\"handles\": [{\"box\": {\"min\": [1000, 1000, 1000],"
                " \"max\": [1001, 1001, 1001]}, \"delta\": [0,0,1]}]}}]}",
              mesh, FFD_ERR_INVALID, "holds no control point");
    apply_bad(T "\"steps\": [{\"deform\": {\"handles\": [{\"points\": [0], \"delta\": [0,0,1]}],"
                " \"freeze\": [{\"box\": {\"min\": [1000, 1000, 1000],"
                " \"max\": [1001, 1001, 1001]}}]}}]}",
              mesh, FFD_ERR_INVALID, "rig.json: steps[0].deform: freeze[0]: box [");
    apply_bad(T "\"steps\": [{\"move\": [{\"box\": {\"min\": [1000, 1000, 1000],"
                " \"max\": [1001, 1001, 1001]}, \"delta\": [0,0,1]}]}]}",
              mesh, FFD_ERR_INVALID, "rig.json: steps[0].move: move[0]: box [");
    /* ids past the end */
    apply_bad(T "\"steps\": [{\"deform\": {\"handles\": [{\"points\": [216], \"delta\": [0,0,1]}]}}]}",
              mesh, FFD_ERR_RANGE, "rig.json: steps[0].deform: handles[0]: points[0]: control point 216: there are 216");
    apply_bad(T "\"steps\": [{\"deform\": {\"handles\": [{\"cells\": [125], \"delta\": [0,0,1]}]}}]}",
              mesh, FFD_ERR_RANGE, "rig.json: steps[0].deform: handles[0]: cells[0]:");
    apply_bad(T "\"steps\": [{\"deform\": {\"handles\": [{\"edges\": [0, 540], \"delta\": [0,0,1]}]}}]}",
              mesh, FFD_ERR_RANGE, "rig.json: steps[0].deform: handles[0]: edges[1]:");
    apply_bad(T "\"steps\": [{\"move\": [{\"faces\": [100000], \"delta\": [0,0,1]}]}]}",
              mesh, FFD_ERR_RANGE, "rig.json: steps[0].move: move[0]: faces[0]:");
    apply_bad(T "\"steps\": [{\"constraints\": {\"targets\": [{\"vertex\": 9001, \"target\": [0,0,0]}]}}]}",
              mesh, FFD_ERR_RANGE, "rig.json: steps[0].constraints: targets[0].vertex: 9001: the mesh has 1839 vertices");
    apply_bad(T "\"steps\": [{\"constraints\": {\"targets\": [{\"vertex\": 0, \"target\": [0,0,0]}],"
                " \"freeze\": [{\"points\": [100000]}]}}]}",
              mesh, FFD_ERR_RANGE, "rig.json: steps[0].constraints: freeze[0]: points[0]:");
    /* a move that overflows names the move */
    apply_bad(T "\"steps\": [{\"move\": [{\"points\": [0], \"delta\": [0,0,1e308]},"
                " {\"points\": [0], \"delta\": [0,0,1e308]}]}]}",
              mesh, FFD_ERR_NONFINITE, "rig.json: steps[0].move: move[1]: control point 0:");
    /* a late failure (after a refinement and a deformation) leaves the mesh alone too */
    apply_bad(T "\"steps\": [{\"refine\": [{\"cells\": \"proxy\"}]},"
                "{\"deform\": {\"handles\": [{\"near\": [0, 10, 0], \"delta\": [0, 1, 0]}],"
                " \"freeze\": [{\"box\": {\"min\": [-9, -9, -9], \"max\": [9, 2, 9]}}]}},"
                "{\"refine\": [{\"cell\": 100000}]}]}",
              mesh, FFD_ERR_RANGE, "rig.json: steps[2].refine: cell 100000: there are");
    ffd_mesh_destroy(mesh);
}

/* ---------------------------------------------------------------------- */

static void test_identity(void)
{
    const char *meshes[] = {BUNNY, FFD_DATA_DIR "/cow.off", FFD_DATA_DIR "/teapot.obj"};
    for (size_t m = 0; m < 3; m++) {
        ffd_mesh *mesh = read_mesh(meshes[m]);
        if (!mesh)
            continue;
        size_t n = ffd_mesh_vertex_count(mesh);
        double *rest = copy_positions(mesh), d = diag(mesh);
        ffd_mesh_destroy(mesh);
        ffd_rig_report r;
        double *x = apply_to(meshes[m], "{\"deformer\": \"tspline\"}", &r);
        if (x) {
            CHECK(max_diff(x, rest, n) <= 1e-12 * (d > 1 ? d : 1));
            CHECK(strcmp(r.method, "tspline") == 0 && r.control_count == 216 && detail(&r, "cells") == 125);
            CHECK(r.control_edge_count == 540);
            CHECK(detail(&r, "refinements") == 0 && detail(&r, "added_points") == 0 && detail(&r, "arap_solves") == 0);
            CHECK(detail(&r, "folds.folded_cells") == 0 && detail(&r, "folds.inverted_faces") == 0);
            CHECK(detail(&r, "folds.cells_checked") > 0 && detail(&r, "folds.cells_checked") <= detail(&r, "cells"));
            CHECK_NEAR(detail(&r, "folds.min_det"), 1, 1e-9);
            CHECK(r.control_face_count > 0 && detail(&r, "proxy_vertices") > 0 &&
                  detail(&r, "proxy_vertices") <= r.control_count);
            ffd_rig_report_free(&r);
            free(x);
        }
        /* refinement only: the map does not change */
        x = apply_to(meshes[m],
                     T "\"resolution\": [5, 6, 7], \"steps\": ["
                       "{\"refine\": [{\"cells\": \"proxy\"}]},"
                       "{\"refine\": [{\"cell\": 37}, {\"face\": {\"near\": [1, 3, 1]}}, {\"edge\": {\"near\": [0, 1, 0]},"
                       " \"ratio\": 0.3}, {\"cell\": {\"near\": [0, 5, 0]}}]},"
                       "{\"refine\": [{\"face\": {\"near\": [0, 0, 0]}}]}]}",
                     &r);
        if (x) {
            double err = max_diff(x, rest, n);
            CHECK(err <= 1e-12 * d);
            if (err > 1e-12 * d)
                fprintf(stderr, "  %s: refinement moved a vertex by %g (diag %g)\n", meshes[m],
                        err, d);
            CHECK(strcmp(r.method, "tspline") == 0 && detail(&r, "refinements") == 3 && detail(&r, "added_points") > 0);
            CHECK(r.control_count == 5 * 6 * 7 + detail(&r, "added_points"));
            CHECK(detail(&r, "cells") > 4 * 5 * 6 && detail(&r, "arap_solves") == 0);
            CHECK(detail(&r, "max_weight_deviation") >= 0 && detail(&r, "max_weight_deviation") < 1); /* rational after uneven splits */
            CHECK(detail(&r, "folds.folded_cells") == 0 && detail(&r, "folds.inverted_faces") == 0);
            ffd_rig_report_free(&r);
            free(x);
        }
        free(rest);
    }
}

/* Moving every control point by delta (deform with a box holding all of
 * them, or move) translates the mesh; rotating them about a centre rotates
 * it (the B-spline volume reproduces affine maps). */
static void test_rigid(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh);
    double *rest = copy_positions(mesh), d = diag(mesh);
    ffd_mesh_destroy(mesh);
    double *want = malloc(3 * n * sizeof *want);
    for (size_t i = 0; i < n; i++) {
        want[3 * i] = rest[3 * i] + 1;
        want[3 * i + 1] = rest[3 * i + 1] - 2;
        want[3 * i + 2] = rest[3 * i + 2] + 0.5;
    }
    const char *rigs[] = {
        T "\"steps\": [{\"deform\": {\"handles\": [{" ALL ", \"delta\": [1, -2, 0.5]}]}}]}",
        T "\"steps\": [{\"refine\": [{\"cells\": \"proxy\"}]}, "
          "{\"deform\": {\"handles\": [{" ALL ", \"delta\": [1, -2, 0.5]}], \"soft\": true}}]}",
        T "\"steps\": [{\"move\": [{" ALL ", \"delta\": [1, -2, 0.5]}]}]}",
        T "\"steps\": [{\"move\": [{" ALL ", \"delta\": [1, 0, 0]}]},"
          "{\"deform\": {\"handles\": [{" ALL ", \"delta\": [0, -2, 0.5]}]}}]}",
    };
    for (size_t k = 0; k < 4; k++) {
        ffd_rig_report r;
        double *x = apply_to(BUNNY, rigs[k], &r);
        if (!x)
            continue;
        double e = max_diff(x, want, n);
        CHECK(e <= 1e-9 * d);
        if (e > 1e-9 * d)
            fprintf(stderr, "  rig %zu: off the translation by %g\n", k, e);
        CHECK(detail(&r, "folds.folded_cells") == 0 && detail(&r, "folds.inverted_faces") == 0);
        CHECK_NEAR(detail(&r, "folds.min_det"), 1, 1e-6);
        CHECK(detail(&r, "arap_solves") == (k == 2 ? 0 : 1));
        ffd_rig_report_free(&r);
        free(x);
    }
    /* rotation about z by 0.3 through a centre */
    const double c[3] = {1, 2, 0.5}, a = 0.3;
    for (size_t i = 0; i < n; i++) {
        double px = rest[3 * i] - c[0], py = rest[3 * i + 1] - c[1];
        want[3 * i] = c[0] + cos(a) * px - sin(a) * py;
        want[3 * i + 1] = c[1] + sin(a) * px + cos(a) * py;
        want[3 * i + 2] = rest[3 * i + 2];
    }
    const char *rot[] = {
        T "\"steps\": [{\"move\": [{" ALL ", \"rotate\": {\"axis\": [0, 0, 3], \"angle\": 0.3,"
          " \"center\": [1, 2, 0.5]}}]}]}",
        T "\"steps\": [{\"deform\": {\"handles\": [{" ALL ", \"rotate\": {\"axis\": [0, 0, 1],"
          " \"angle\": 0.3, \"center\": [1, 2, 0.5]}}]}}]}",
    };
    for (size_t k = 0; k < 2; k++) {
        ffd_rig_report r;
        double *x = apply_to(BUNNY, rot[k], &r);
        if (!x)
            continue;
        double e = max_diff(x, want, n);
        CHECK(e <= 1e-9 * d);
        if (e > 1e-9 * d)
            fprintf(stderr, "  rotation %zu: off by %g\n", k, e);
        CHECK_NEAR(detail(&r, "folds.min_det"), 1, 1e-6);
        ffd_rig_report_free(&r);
        free(x);
    }
    /* no centre: about the centroid of the selection; a rigid motion still,
       so every distance is kept */
    double *x = apply_to(BUNNY,
                         T "\"steps\": [{\"move\": [{" ALL ", \"rotate\": {\"axis\": [1, 1, 0],"
                           " \"angle\": 1.2}}]}]}",
                         NULL);
    if (x) {
        double worst = 0;
        for (size_t i = 1; i < n; i += 7) {
            double d0 = 0, d1 = 0;
            for (int q = 0; q < 3; q++) {
                d0 += (rest[3 * i + q] - rest[q]) * (rest[3 * i + q] - rest[q]);
                d1 += (x[3 * i + q] - x[q]) * (x[3 * i + q] - x[q]);
            }
            worst = fmax(worst, fabs(sqrt(d0) - sqrt(d1)));
        }
        CHECK(worst <= 1e-9 * d);
        CHECK(max_diff(x, rest, n) > 0.1 * d);
        free(x);
    }
    free(want);
    free(rest);
}

/* A deformation with the bottom frozen and the top dragged sideways: the
 * top follows, the bottom (whose whole support is frozen) stays put. */
static void test_frozen_region(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh);
    double mn[3], mx[3];
    bbox(mesh, mn, mx);
    double *rest = copy_positions(mesh), d = diag(mesh), ey = mx[1] - mn[1];
    ffd_mesh_destroy(mesh);
    /* res 10 along y: knots k/7, Greville 0, 1/21, 1/7, 2/7, 3/7, ...; the
       freeze below y = 0.5 holds the first 5 layers, so vertices with y
       parameter below 2/7 depend on frozen points only */
    double shift = 0.15 * ey;
    char rig[1024];
    snprintf(rig, sizeof rig,
             T "\"resolution\": [6, 10, 6], \"steps\": [{\"deform\": {"
               "\"handles\": [{\"box\": {\"min\": [-1e9, %.17g, -1e9], \"max\": [1e9, 1e9, 1e9]},"
               " \"delta\": [%.17g, 0, 0]}],"
               "\"freeze\": [{\"box\": {\"min\": [-1e9, -1e9, -1e9], \"max\": [1e9, %.17g, 1e9]}}]"
               "}}]}",
             mn[1] + 0.85 * ey, shift, mn[1] + 0.5 * ey);
    ffd_rig_report r;
    double *x = apply_to(BUNNY, rig, &r);
    if (x) {
        size_t low = 0, high = 0;
        double low_err = 0, high_dx = 0;
        for (size_t i = 0; i < n; i++) {
            double v = (rest[3 * i + 1] - mn[1]) / ey;
            if (v < 0.25) {
                low++;
                low_err = fmax(low_err, max_diff(x + 3 * i, rest + 3 * i, 1));
            } else if (v > 0.93) {
                high++;
                high_dx += x[3 * i] - rest[3 * i];
            }
        }
        CHECK(low > 50 && high > 10);
        CHECK(low_err <= 1e-9 * d);
        if (low_err > 1e-9 * d)
            fprintf(stderr, "  the frozen region moved by %g\n", low_err);
        if (high)
            high_dx /= (double)high;
        CHECK(high_dx > 0.5 * shift && high_dx < 1.2 * shift);
        CHECK(detail(&r, "arap_solves") == 1 && detail(&r, "max_handle_error") < 1e-9 * d);
        CHECK(detail(&r, "folds.folded_cells") == 0);
        CHECK(r.control_count == 6 * 10 * 6);
        ffd_rig_report_free(&r);
        free(x);

        /* the same rig, then a refinement: the shape is kept */
        size_t len = strlen(rig);
        snprintf(rig + len - 2, sizeof rig - len + 2,
                 ", {\"refine\": [{\"cells\": \"proxy\"}]}, {\"refine\": [{\"edge\": {\"near\": [0, 5, 0]}}]}]}");
        double *before = apply_to(BUNNY, rig, &r);
        snprintf(rig + len - 2, sizeof rig - len + 2, "]}");
        double *plain = apply_to(BUNNY, rig, NULL);
        if (before && plain) {
            double e = max_diff(before, plain, n);
            CHECK(e <= 1e-10 * d);
            if (e > 1e-10 * d)
                fprintf(stderr, "  refinement after the deformation moved a vertex by %g\n", e);
            CHECK(detail(&r, "refinements") == 2 && detail(&r, "arap_solves") == 1 && detail(&r, "added_points") > 0);
            ffd_rig_report_free(&r);
        }
        free(before);
        free(plain);
    }
    /* deform, refine, deform again: edits accumulate and the second one
       works on the refined lattice (handles by near, faces and cells) */
    snprintf(rig, sizeof rig,
             T "\"steps\": [{\"deform\": {\"handles\": [{\"near\": [0, %.17g, 0], \"delta\": [0, 0.5, 0]}],"
               " \"freeze\": [{\"box\": {\"min\": [-1e9, -1e9, -1e9], \"max\": [1e9, %.17g, 1e9]}}],"
               " \"iterations\": 3, \"weights\": {\"one_form\": 1.5, \"proxy\": 1, \"volume\": 0.75}}},"
               "{\"refine\": [{\"cells\": \"proxy\"}]},"
               "{\"deform\": {\"handles\": [{\"faces\": [0], \"delta\": [0, 0, 0.2]},"
               " {\"cells\": [62], \"delta\": [0, 0, -0.2]}],"
               " \"freeze\": [{\"edges\": [539]}, {\"points\": [215]}], \"soft\": true}}]}",
             mx[1], mn[1] + 0.3 * ey);
    x = apply_to(BUNNY, rig, &r);
    if (x) {
        CHECK(detail(&r, "arap_solves") == 2 && detail(&r, "refinements") == 1);
        CHECK(max_diff(x, rest, n) > 0.01);
        ffd_rig_report_free(&r);
        free(x);
    }
    free(rest);
}

/* Direct manipulation of vertices: the targets are reached. */
static void test_constraints(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    double *rest = copy_positions(mesh), d = diag(mesh);
    ffd_mesh_destroy(mesh);
    const uint32_t ids[3] = {0, 900, 1700};
    double tg[3][3];
    for (int c = 0; c < 3; c++)
        for (int a = 0; a < 3; a++)
            tg[c][a] = rest[3 * ids[c] + a] + (a == c ? 0.3 : -0.1);
    char rig[2048];
    for (int with_freeze = 0; with_freeze < 2; with_freeze++) {
        snprintf(rig, sizeof rig,
                 T "\"steps\": [{\"refine\": [{\"cells\": \"proxy\"}]}, {\"constraints\": {\"targets\": ["
                   "{\"vertex\": %u, \"target\": [%.17g, %.17g, %.17g]},"
                   "{\"vertex\": %u, \"target\": [%.17g, %.17g, %.17g]},"
                   "{\"vertex\": %u, \"target\": [%.17g, %.17g, %.17g]}]%s}}]}",
                 ids[0], tg[0][0], tg[0][1], tg[0][2], ids[1], tg[1][0], tg[1][1], tg[1][2], ids[2],
                 tg[2][0], tg[2][1], tg[2][2],
                 with_freeze ? ", \"freeze\": [{\"points\": [0, 1, 2, 3]}]" : "");
        ffd_rig_report r;
        double *x = apply_to(BUNNY, rig, &r);
        if (!x)
            continue;
        CHECK(r.constraint_count == 3 && r.residuals && r.reached);
        CHECK(r.max_residual <= 1e-9 * d);
        CHECK(r.rank > 0);
        for (int c = 0; c < 3; c++) {
            CHECK(max_diff(x + 3 * ids[c], tg[c], 1) <= 1e-9 * d);
            if (r.reached)
                CHECK(max_diff(r.reached + 3 * c, tg[c], 1) <= 1e-9 * d);
        }
        CHECK(detail(&r, "refinements") == 1 && detail(&r, "arap_solves") == 0);
        if (with_freeze) { /* frozen control points stay where the refinement left them */
            ffd_rig_report r0;
            double *x0 = apply_to(BUNNY, T "\"steps\": [{\"refine\": [{\"cells\": \"proxy\"}]}]}",
                                  &r0);
            if (x0) {
                CHECK(r0.control_count == r.control_count);
                CHECK(max_diff(r0.control_points, r.control_points, 4) == 0);
                CHECK(max_diff(r0.control_points, r.control_points, r.control_count) > 0.01);
                ffd_rig_report_free(&r0);
                free(x0);
            }
        }
        ffd_rig_report_free(&r);
        free(x);
    }
    free(rest);
}

/* The report's lattice and proxy as OBJ files. */
static size_t count_lines(const char *path, const char *prefix)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    char line[512];
    size_t count = 0, len = strlen(prefix);
    while (fgets(line, sizeof line, f))
        count += strncmp(line, prefix, len) == 0;
    fclose(f);
    return count;
}

static size_t dir_entries(const char *dir)
{
    DIR *d = opendir(dir);
    size_t n = 0;
    if (!d)
        return 0;
    struct dirent *e;
    while ((e = readdir(d)))
        n += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
    closedir(d);
    return n;
}

static void test_write_files(void)
{
    char dir[] = "/tmp/ffd_test_tspline_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char proxy[256], lattice[256], sub[256];
    snprintf(proxy, sizeof proxy, "%s/proxy.obj", dir);
    snprintf(lattice, sizeof lattice, "%s/lattice.obj", dir);
    snprintf(sub, sizeof sub, "%s/sub", dir);
    CHECK(mkdir(sub, 0755) == 0);
    const char *rigs[] = {
        "{\"deformer\": \"tspline\"}",
        T "\"resolution\": [5, 7, 6], \"steps\": [{\"refine\": [{\"cells\": \"proxy\"}]},"
          "{\"deform\": {\"handles\": [{\"near\": [0, 10, 0], \"delta\": [0, 1, 0]}],"
          " \"freeze\": [{\"box\": {\"min\": [-9, -9, -9], \"max\": [9, 3, 9]}}]}}]}",
    };
    for (size_t k = 0; k < 2; k++) {
        ffd_rig_report r;
        double *x = apply_to(BUNNY, rigs[k], &r);
        if (!x)
            continue;
        ffd_error err = {{0}};
        CHECK_OK(ffd_rig_report_write_proxy(&r, proxy, &err));
        CHECK_OK(ffd_rig_report_write_lattice(&r, lattice, &err));
        ffd_mesh *pm = NULL;
        CHECK_OK(ffd_mesh_read(proxy, &pm, &err));
        if (pm) {
            /* the manifold proxy: one point per sheet of each control point */
            CHECK(ffd_mesh_vertex_count(pm) == r.control_mesh_point_count);
            CHECK(r.control_mesh_point_count >= detail(&r, "proxy_vertices"));
            CHECK(ffd_mesh_face_count(pm) == r.control_face_count);
            /* point i is control point proxy_point_controls[i], deformed */
            const double *pp = ffd_mesh_positions(pm);
            size_t matched = 0, distinct = 0;
            for (size_t i = 0; i < ffd_mesh_vertex_count(pm) && i < r.control_mesh_point_count; i++) {
                uint32_t v = r.control_mesh_points[i];
                distinct += i == 0 || v != r.control_mesh_points[i - 1];
                matched += v < r.control_count &&
                           max_diff(pp + 3 * i, r.control_points + 3 * (size_t)v, 1) <= 1e-12;
            }
            CHECK(matched == r.control_mesh_point_count);
            CHECK(distinct == detail(&r, "proxy_vertices"));
            ffd_mesh_destroy(pm);
        }
        CHECK(count_lines(lattice, "v ") == r.control_count);
        CHECK(count_lines(lattice, "l ") == r.control_edge_count);
        CHECK(count_lines(proxy, "f ") == r.control_face_count);
        /* the mesh written by the rig and the proxy of the deformed lattice */
        CHECK(detail(&r, "proxy_vertices") <= r.control_count);
        /* atomic: a failing write leaves nothing behind */
        size_t before = dir_entries(dir), before_sub = dir_entries(sub);
        CHECK(ffd_rig_report_write_proxy(&r, sub, &err) != FFD_OK);
        CHECK(ffd_rig_report_write_lattice(&r, sub, &err) != FFD_OK);
        CHECK(dir_entries(dir) == before && dir_entries(sub) == before_sub);
        ffd_rig_report_free(&r);
        free(x);
    }
    /* a lattice rig has no proxy */
    {
        ffd_rig_report r;
        double *x = apply_to(BUNNY, "{\"resolution\": [3, 3, 3]}", &r);
        if (x) {
            ffd_error err = {{0}};
            CHECK(ffd_rig_report_write_proxy(&r, proxy, &err) == FFD_ERR_INVALID);
            CHECK(strstr(err.message, "only a T-spline rig has a proxy") != NULL);
            CHECK(r.control_face_offsets == NULL);
            ffd_rig_report_free(&r);
            free(x);
        }
    }
    remove(proxy);
    remove(lattice);
    CHECK(rmdir(sub) == 0);
    CHECK(rmdir(dir) == 0);
}

/* Other meshes: a few examples run (no folds for gentle edits). */
static void test_other_meshes(void)
{
    const char *meshes[] = {FFD_DATA_DIR "/cow.off", FFD_DATA_DIR "/hinge.stl",
                            FFD_DATA_DIR "/double-torus-example.off"};
    for (size_t m = 0; m < 3; m++) {
        ffd_mesh *mesh = read_mesh(meshes[m]);
        if (!mesh)
            continue;
        double mn[3], mx[3];
        bbox(mesh, mn, mx);
        size_t n = ffd_mesh_vertex_count(mesh);
        double *rest = copy_positions(mesh), d = diag(mesh);
        ffd_mesh_destroy(mesh);
        char rig[1024];
        snprintf(rig, sizeof rig,
                 T "\"steps\": [{\"refine\": [{\"cells\": \"proxy\"}]}, {\"deform\": {"
                   "\"handles\": [{\"near\": [%.17g, %.17g, %.17g], \"delta\": [0, 0, %.17g]}],"
                   "\"freeze\": [{\"box\": {\"min\": [-1e30, -1e30, -1e30], \"max\": [%.17g, 1e30, 1e30]}}]"
                   "}}]}",
                 mx[0], mx[1], mx[2], 0.05 * d, mn[0] + 0.3 * (mx[0] - mn[0]));
        ffd_rig_report r;
        double *x = apply_to(meshes[m], rig, &r);
        if (x) {
            CHECK(max_diff(x, rest, n) > 1e-3 * d);
            CHECK(strcmp(r.method, "tspline") == 0 && detail(&r, "arap_solves") == 1 && detail(&r, "refinements") == 1);
            CHECK(detail(&r, "folds.folded_cells") == 0);
            ffd_rig_report_free(&r);
            free(x);
        }
        free(rest);
    }
}

/* Allocation failures: FFD_OK or FFD_ERR_NOMEM, the mesh unchanged on failure. */
/* A map that folds: the report's details list the folded cell and the
 * inverted faces, and its notes carry one warning that counts them (what
 * ffd deform prints on stderr without knowing the method). */
static void test_fold_warning(void)
{
    ffd_rig_report r = {0};
    double *x = apply_to(BUNNY,
                         T "\"resolution\": [4, 4, 4], \"steps\": [{\"move\": [{\"points\": [0],"
                           " \"delta\": [1000, 1000, 1000]}]}]}",
                         &r);
    if (!x)
        return;
    CHECK(strcmp(r.method, "tspline") == 0);
    double folded = detail(&r, "folds.folded_cells"), inverted = detail(&r, "folds.inverted_faces");
    CHECK(folded >= 1 && inverted >= 1 && detail(&r, "folds.min_det") < 0);
    CHECK(r.notes != NULL);
    if (r.notes) {
        char expect[160];
        snprintf(expect, sizeof expect,
                 "warning: the deformation folds over: %.0f cell%s with a non-positive Jacobian "
                 "determinant (min ",
                 folded, folded == 1 ? "" : "s");
        CHECK(strncmp(r.notes, expect, strlen(expect)) == 0);
        snprintf(expect, sizeof expect, "), %.0f inverted faces (--report lists all)\n", inverted);
        CHECK(strstr(r.notes, expect) != NULL);
        CHECK(strchr(r.notes, '\n') == r.notes + strlen(r.notes) - 1); /* one line */
    }
    ffd_rig_report_free(&r);
    free(x);
    /* a map that does not fold has no notes */
    x = apply_to(BUNNY, T "\"resolution\": [4, 4, 4]}", &r);
    if (x)
        CHECK(r.notes == NULL && detail(&r, "folds.folded_cells") == 0);
    ffd_rig_report_free(&r);
    free(x);
}

static void test_failing_allocations(void)
{
    /* an octahedron */
    const double p[18] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1.5, 0, 0, -1};
    const uint32_t idx[24] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4,
                              2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    uint32_t off[9];
    for (int f = 0; f <= 8; f++)
        off[f] = (uint32_t)(3 * f);
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_mesh_create(p, 6, off, idx, 8, &mesh, NULL));
    if (!mesh)
        return;
    ffd_rig *rig = parse_ok(
        T "\"resolution\": [4, 4, 5], \"steps\": ["
          "{\"refine\": [{\"cell\": {\"near\": [0, 0, 0]}}, {\"edge\": {\"near\": [0.1, 0.1, 0.2]}, \"ratio\": 0.25}]},"
          "{\"deform\": {\"handles\": [{\"near\": [0, 0, 1.5], \"delta\": [0, 0.2, 0.1]}],"
          " \"freeze\": [{\"box\": {\"min\": [-9, -9, -9], \"max\": [9, 9, -0.5]}}], \"iterations\": 2}},"
          "{\"move\": [{\"points\": [3], \"rotate\": {\"axis\": [0, 0, 1], \"angle\": 0.1}}]},"
          "{\"constraints\": {\"targets\": [{\"vertex\": 0, \"target\": [1.1, 0, 0]}],"
          " \"freeze\": [{\"points\": [0]}]}}]}");
    if (!rig) {
        ffd_mesh_destroy(mesh);
        return;
    }
    double *rest = copy_positions(mesh);
    long k;
    for (k = 0;; k += check_sweep_step()) {
        fail_alloc fa = {k, 0};
        ffd_allocator al = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_rig_report r;
        ffd_error err = {{0}};
        ffd_set_allocator(&al);
        ffd_status s = ffd_rig_apply(rig, mesh, &r, &err);
        ffd_set_allocator(NULL);
        CHECK(s == FFD_OK || s == FFD_ERR_NOMEM);
        ffd_rig_report_free(&r);
        if (s != FFD_OK && s != FFD_ERR_NOMEM) {
            fprintf(stderr, "  k = %ld: %s: %s\n", k, ffd_status_string(s), err.message);
            break;
        }
        if (s == FFD_OK)
            break;
        CHECK(memcmp(rest, ffd_mesh_positions(mesh), 6 * 3 * sizeof *rest) == 0);
        if (k > 200000) {
            CHECK(0);
            break;
        }
    }
    CHECK(k > 10);
    CHECK(memcmp(rest, ffd_mesh_positions(mesh), 6 * 3 * sizeof *rest) != 0);
    free(rest);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"parse_every_key", test_parse_every_key},
        {"doc_errors_parse", test_doc_errors_parse},
        {"parse_malformed", test_parse_malformed},
        {"doc_errors_apply", test_doc_errors_apply},
        {"identity", test_identity},
        {"rigid", test_rigid},
        {"frozen_region", test_frozen_region},
        {"constraints", test_constraints},
        {"write_files", test_write_files},
        {"other_meshes", test_other_meshes},
        {"fold_warning", test_fold_warning},
        {"failing_allocations", test_failing_allocations},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
