/* Tests for PB-FFD rigs (src/rig with "deformer": "pbffd"): every key, every
 * rejected value with its JSON path, the control-set writer round trip, and
 * ffd_rig_apply with explicit and placed controls, constraints and curves. */
#include "check.h"
#include "report_details.h"
#include "check_rig.h"
#include "pbffd/pbffd_method.h"

#include <stdio.h>
#include <unistd.h>


#define PB "{\"deformer\": \"pbffd\", "
#define ONE "\"controls\": [{\"center\": [0,0,0], \"radius\": 1}]"

/* A g x g x g grid of vertices in [0,1]^3 with one triangle. */
static ffd_mesh *grid_mesh(int g)
{
    size_t n = (size_t)g * g * g, v = 0;
    double *p = malloc(3 * n * sizeof *p);
    for (int i = 0; i < g; i++)
        for (int j = 0; j < g; j++)
            for (int k = 0; k < g; k++, v++) {
                p[3 * v] = (double)i / (g - 1);
                p[3 * v + 1] = (double)j / (g - 1);
                p[3 * v + 2] = (double)k / (g - 1);
            }
    uint32_t offsets[2] = {0, 3}, indices[3] = {0, 1, 2};
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_mesh_create(p, n, offsets, indices, 1, &mesh, NULL));
    free(p);
    return mesh;
}

static void test_parse_every_key(void)
{
    ffd_rig *rig = parse_ok(
        PB "\"version\": 1, \"sigma\": 2.5, \"master\": {\"radius\": 3, \"weight\": 0.5},"
           " \"levels\": 2, \"constraint_level\": 1, \"rcond\": 1e-8,"
           " \"controls\": [{\"center\": [1,2,3], \"radius\": [1,2,3],"
           "   \"frame\": [[1,0,0],[0,2,0],[0,0,3]], \"enabled\": false},"
           "  {\"center\": [0,0,0], \"radius\": 0.5}],"
           " \"moves\": [{\"control\": 1, \"delta\": [0,1,0]}, {\"near\": [1,2,3], \"level\": 1,"
           "   \"delta\": [1,0,0]}],"
           " \"frames\": [{\"control\": 0, \"frame\": [[2,0,0],[0,2,0],[0,0,2]]},"
           "   {\"near\": [0,0,0], \"rotate\": {\"axis\": [0,0,1], \"angle\": 0.5},"
           "    \"scale\": [1,2,1]}],"
           " \"constraints\": [{\"vertex\": 3, \"target\": [0,0,1]}],"
           " \"curves\": [{\"points\": [[0,0,0],[1,0,0],[2,1,0]], \"radius\": 0.5,"
           "   \"samples\": 20, \"moves\": [{\"index\": 2, \"delta\": [0,0,1]}]}]}");
    if (!rig)
        return;
    CHECK(rig->method == &ffd_method_pbffd);
    const ffd_rig_pbffd *pb = ffd_rig_pbffd_of(rig);
    CHECK(pb->controls_auto == 0);
    CHECK(pb->control_count == 2);
    CHECK(pb->controls[0].disabled == 1 && pb->controls[1].disabled == 0);
    CHECK(pb->controls[0].radius[2] == 3 && pb->controls[0].frame[1][1] == 2);
    /* a frame left out is axis-aligned with the radius as its lengths */
    CHECK(pb->controls[1].frame[0][0] == 0.5 && pb->controls[1].frame[2][2] == 0.5 &&
          pb->controls[1].frame[0][1] == 0);
    CHECK(pb->options.sigma == 2.5 && pb->options.master_radius == 3 &&
          pb->options.master_weight == 0.5 && pb->options.levels == 2);
    CHECK(pb->constraint_level == 1 && rig->rcond == 1e-8);
    CHECK(pb->move_count == 2 && pb->moves[1].by_near && pb->moves[1].level == 1);
    CHECK(pb->frame_count == 2 && pb->frames[0].frame_kind == 1 && pb->frames[1].frame_kind == 2);
    CHECK(pb->frames[1].angle == 0.5 && pb->frames[1].scale[1] == 2);
    CHECK(pb->curve_count == 1 && pb->curves[0].point_count == 3 &&
          pb->curves[0].samples == 20 && pb->curves[0].move_count == 1);
    CHECK(rig->constraint_count == 1);
    ffd_rig_destroy(rig);

    rig = parse_ok(PB "\"controls\": {\"interior\": 10, \"exterior\": 20, \"offset\": 0.02,"
                      " \"radius_factor\": 2, \"surface\": \"open\", \"voronoi_sites\": 500,"
                      " \"cover\": false}, \"master\": false}");
    if (rig) {
        const ffd_placement_options *o = &ffd_rig_pbffd_of(rig)->placement;
        CHECK(ffd_rig_pbffd_of(rig)->controls_auto == 1 && o->interior_count == 10 && o->exterior_count == 20);
        CHECK(o->offset == 0.02 && o->radius_factor == 2 && o->surface == FFD_SURFACE_OPEN);
        CHECK(o->voronoi_sites == 500 && o->no_cover == 1 && ffd_rig_pbffd_of(rig)->options.no_master == 1);
        ffd_rig_destroy(rig);
    }
    rig = parse_ok(PB "\"controls\": \"auto\"}");
    if (rig) {
        CHECK(ffd_rig_pbffd_of(rig)->controls_auto == 1);
        ffd_rig_destroy(rig);
    }
    rig = parse_ok("{\"deformer\": \"pbffd\"}"); /* auto placement is the default */
    if (rig) {
        CHECK(ffd_rig_pbffd_of(rig)->controls_auto == 1 && ffd_rig_pbffd_of(rig)->options.levels == 0);
        ffd_rig_destroy(rig);
    }
}

static void test_parse_bad(void)
{
    parse_bad(PB "\"resolution\": [3,3,3]}", FFD_ERR_PARSE, "resolution: only for \"deformer\": \"lattice\"");
    parse_bad("{\"levels\": 2}", FFD_ERR_PARSE, "levels: only for \"deformer\": \"pbffd\"");
    parse_bad("{\"deformer\": \"pb\"}", FFD_ERR_PARSE, "deformer: expected \"lattice\", \"pbffd\", \"gffd\", \"tspline\", \"rbf\" or \"idw\"");
    parse_bad(PB "\"controls\": []}", FFD_ERR_PARSE, "controls: expected at least one");
    parse_bad(PB "\"controls\": \"some\"}", FFD_ERR_PARSE, "controls: expected \"auto\"");
    parse_bad(PB "\"controls\": [{\"center\": [0,0,0], \"radius\": 0}]}", FFD_ERR_INVALID,
              "controls[0].radius: 0: expected a radius > 0");
    parse_bad(PB "\"controls\": [{\"center\": [0,0,0], \"radius\": [1,-1,1]}]}", FFD_ERR_INVALID,
              "controls[0].radius: -1");
    parse_bad(PB "\"controls\": [{\"center\": [0,0,0]}]}", FFD_ERR_PARSE,
              "controls[0].radius: expected a number > 0 or an array of 3 (missing)");
    parse_bad(PB "\"controls\": [{\"radius\": 1}]}", FFD_ERR_PARSE, "controls[0].center");
    parse_bad(PB "\"controls\": [{\"center\": [0,0,0], \"radius\": 1, \"frame\": [[1,0,0]]}]}",
              FFD_ERR_PARSE, "controls[0].frame: expected an array of 3 axes");
    parse_bad(PB "\"controls\": [{\"center\": [0,0,0], \"radius\": 1, \"size\": 1}]}",
              FFD_ERR_PARSE, "controls[0].size: unknown key");
    parse_bad(PB "\"controls\": [{\"center\": [0,0,0], \"radius\": 1, \"enabled\": 1}]}",
              FFD_ERR_PARSE, "controls[0].enabled: expected true or false");
    parse_bad(PB "\"controls\": {\"interior\": 0}}", FFD_ERR_PARSE, "controls.interior: expected a positive integer");
    parse_bad(PB "\"controls\": {\"surface\": \"flat\"}}", FFD_ERR_PARSE, "controls.surface");
    parse_bad(PB "\"controls\": {\"voronoi_sites\": 3}}", FFD_ERR_INVALID, "at least 5");
    parse_bad(PB "\"controls\": {\"offset\": 0}}", FFD_ERR_INVALID, "controls.offset: 0: expected a number > 0");
    parse_bad(PB "\"levels\": 0}", FFD_ERR_INVALID, "levels: 0: expected 1 to 32");
    parse_bad(PB "\"sigma\": -1}", FFD_ERR_INVALID, "sigma: -1");
    parse_bad(PB "\"master\": {\"radius\": 0.5}}", FFD_ERR_INVALID, "master.radius: 0.5");
    parse_bad(PB "\"master\": 1}", FFD_ERR_PARSE, "master: expected true, false");
    parse_bad(PB ONE ", \"moves\": [{\"delta\": [0,0,0]}]}", FFD_ERR_PARSE,
              "moves[0]: expected a \"control\" index or a \"near\" point");
    parse_bad(PB ONE ", \"moves\": [{\"control\": 0, \"near\": [0,0,0], \"delta\": [0,0,0]}]}",
              FFD_ERR_PARSE, "not both");
    parse_bad(PB ONE ", \"moves\": [{\"control\": 0}]}", FFD_ERR_PARSE, "moves[0].delta");
    parse_bad(PB ONE ", \"moves\": [{\"control\": 1, \"delta\": [0,0,0]}]}", FFD_ERR_RANGE,
              "moves[0].control: 1 out of range (1 controls)");
    parse_bad(PB ONE ", \"moves\": [{\"control\": 0, \"level\": 1, \"delta\": [0,0,0]}]}",
              FFD_ERR_RANGE, "moves[0].level: 1 out of range (the rig has 1 level;");
    parse_bad(PB ONE ", \"frames\": [{\"control\": 0}]}", FFD_ERR_PARSE,
              "frames[0]: expected a \"frame\", \"rotate\" or \"scale\" key");
    parse_bad(PB ONE ", \"frames\": [{\"control\": 0, \"scale\": [1,1,1], \"frame\": [[1,0,0],[0,1,0],[0,0,1]]}]}",
              FFD_ERR_PARSE, "not both");
    parse_bad(PB ONE ", \"frames\": [{\"control\": 0, \"rotate\": {\"axis\": [0,0,0], \"angle\": 1}}]}",
              FFD_ERR_INVALID, "frames[0].rotate.axis: the zero vector is no axis");
    parse_bad(PB ONE ", \"frames\": [{\"control\": 0, \"rotate\": {\"axis\": [0,0,1]}}]}",
              FFD_ERR_PARSE, "frames[0].rotate.angle");
    parse_bad(PB ONE ", \"frames\": [{\"control\": 0, \"scale\": [1,0,1]}]}", FFD_ERR_INVALID,
              "frames[0].scale[1]: a zero scale");
    parse_bad(PB ONE ", \"constraint_level\": 2}", FFD_ERR_RANGE, "constraint_level: 2 out of range");
    parse_bad(PB "\"curves\": [{\"points\": [[0,0,0]], \"radius\": 1}]}", FFD_ERR_PARSE,
              "curves[0].points: expected an array of at least 2 points");
    parse_bad(PB "\"curves\": [{\"points\": [[0,0,0],[1,0,0]], \"radius\": 0}]}", FFD_ERR_INVALID,
              "curves[0].radius: 0");
    parse_bad(PB "\"curves\": [{\"points\": [[0,0,0],[1,0,0]]}]}", FFD_ERR_PARSE,
              "curves[0].radius: expected a number > 0 (missing)");
    parse_bad(PB "\"curves\": [{\"points\": [[0,0,0],[1,0,0]], \"radius\": 1, \"moves\":"
                 " [{\"index\": 2, \"delta\": [0,0,0]}]}]}",
              FFD_ERR_RANGE, "curves[0].moves[0].index: 2 out of range (the curve has 2 points)");
    parse_bad(PB "\"curves\": [{\"points\": [[0,0,0],[1,0,1e999]], \"radius\": 1}]}",
              FFD_ERR_NONFINITE, "curves[0].points[1][2]");
}

static void test_write_round_trip(void)
{
    ffd_ebf controls[3];
    memset(controls, 0, sizeof controls);
    for (int i = 0; i < 3; i++) {
        for (int a = 0; a < 3; a++) {
            controls[i].center[a] = check_rand01() * 10 - 5;
            controls[i].radius[a] = 0.1 + check_rand01();
            for (int b = 0; b < 3; b++)
                controls[i].frame[a][b] = check_rand01() - 0.5 + (a == b);
        }
    }
    controls[1].disabled = 1;
    char path[64];
    snprintf(path, sizeof path, "pbffd_controls_%ld.json", (long)getpid());
    ffd_pbffd_options options = {0};
    options.levels = 3;
    options.sigma = 2;
    ffd_error err = {{0}};
    CHECK_OK(ffd_rig_write_pbffd_controls(path, controls, 3, &options, &err));
    ffd_rig *rig = NULL;
    CHECK_OK(ffd_rig_read(path, &rig, &err));
    if (rig) {
        CHECK(rig->method == &ffd_method_pbffd && ffd_rig_pbffd_of(rig)->control_count == 3);
        CHECK(ffd_rig_pbffd_of(rig)->options.levels == 3 && ffd_rig_pbffd_of(rig)->options.sigma == 2);
        for (int i = 0; i < 3 && ffd_rig_pbffd_of(rig)->control_count == 3; i++) {
            /* 17 significant digits read back bit for bit */
            CHECK(memcmp(ffd_rig_pbffd_of(rig)->controls[i].center, controls[i].center, 3 * sizeof(double)) == 0);
            CHECK(memcmp(ffd_rig_pbffd_of(rig)->controls[i].radius, controls[i].radius, 3 * sizeof(double)) == 0);
            CHECK(memcmp(ffd_rig_pbffd_of(rig)->controls[i].frame, controls[i].frame, 9 * sizeof(double)) == 0);
            CHECK(ffd_rig_pbffd_of(rig)->controls[i].disabled == controls[i].disabled);
        }
        ffd_rig_destroy(rig);
    }
    /* non-finite input is refused and nothing is written */
    controls[2].center[1] = NAN;
    unlink(path);
    CHECK(ffd_rig_write_pbffd_controls(path, controls, 3, NULL, &err) == FFD_ERR_NONFINITE);
    CHECK(access(path, F_OK) != 0);
}

#define FOUR_CONTROLS                                                                    \
    "\"controls\": [{\"center\": [0.25,0.5,0.5], \"radius\": 0.5},"                       \
    " {\"center\": [0.75,0.5,0.5], \"radius\": 0.5}, {\"center\": [0.5,0.25,0.5], \"radius\": 0.5}," \
    " {\"center\": [0.5,0.75,0.5], \"radius\": 0.5}]"

static void test_apply_identity_and_move(void)
{
    ffd_mesh *mesh = grid_mesh(9);
    size_t n = ffd_mesh_vertex_count(mesh);
    double *rest = malloc(3 * n * sizeof *rest);
    memcpy(rest, ffd_mesh_positions(mesh), 3 * n * sizeof *rest);
    ffd_error err = {{0}};
    ffd_rig_report report = {0};
    CHECK_OK(apply_json(PB FOUR_CONTROLS "}", mesh, &report, &err));
    CHECK(memcmp(rest, ffd_mesh_positions(mesh), 3 * n * sizeof *rest) == 0);
    CHECK(report.control_count == 4 && detail(&report, "levels") == 1 && detail(&report, "placed") == 0);
    ffd_rig_report_free(&report);

    CHECK_OK(apply_json(PB FOUR_CONTROLS ", \"moves\": [{\"near\": [1,0.5,0.5], \"delta\": [0.2,0,0]}]}",
                        mesh, &report, &err));
    const double *p = ffd_mesh_positions(mesh);
    size_t moved = 0, far_moved = 0;
    for (size_t i = 0; i < n; i++) {
        double dx = p[3 * i] - rest[3 * i], dy = p[3 * i + 1] - rest[3 * i + 1];
        double r2 = 0;
        for (int a = 0; a < 3; a++) {
            double d = rest[3 * i + a] - (a == 0 ? 0.75 : 0.5);
            r2 += d * d;
        }
        if (r2 >= 0.25) /* outside control 1's ROI: only control 1 moved */
            far_moved += dx != 0 || dy != 0 || p[3 * i + 2] != rest[3 * i + 2];
        else
            moved += dx > 0;
        CHECK(dx >= 0 && dx <= 0.2 + 1e-12);
    }
    CHECK(moved > 0);
    CHECK(far_moved == 0);
    CHECK(report.control_points && report.control_points[3] == 0.95);
    ffd_rig_report_free(&report);
    free(rest);
    ffd_mesh_destroy(mesh);
}

/* An extra "enabled": false control (far away or near, last or first)
 * leaves the result bitwise unchanged: moves at both levels, a frame edit
 * and a constraint solve (control indices shift with a first one). */
static void test_apply_disabled_changes_nothing(void)
{
    static const char *const extra[] = {
        "", /* the reference */
        ", {\"center\": [100,-40,250], \"radius\": 2, \"enabled\": false}]",
        ", {\"center\": [0.5,0.5,0.5], \"radius\": 0.4, \"enabled\": false}]",
        "[{\"center\": [-300,7,9], \"radius\": 1, \"enabled\": false}, "};
    size_t centre = (4 * 9 + 4) * 9 + 4, n = 0;
    double *ref = NULL;
    for (size_t t = 0; t < sizeof extra / sizeof extra[0]; t++) {
        int first = t == 3;
        char controls[512], json[2048];
        const char *list = strchr(FOUR_CONTROLS, '[');
        if (t == 0)
            snprintf(controls, sizeof controls, "%s", FOUR_CONTROLS);
        else if (!first)
            snprintf(controls, sizeof controls, "%.*s%s", (int)(strlen(FOUR_CONTROLS) - 1),
                     FOUR_CONTROLS, extra[t]);
        else
            snprintf(controls, sizeof controls, "\"controls\": %s%s", extra[t], list + 1);
        snprintf(json, sizeof json,
                 PB "%s, \"levels\": 2,"
                    " \"moves\": [{\"control\": %d, \"delta\": [0.05,0,0.02]},"
                    " {\"control\": 1, \"level\": 1, \"delta\": [0,0.03,0]},"
                    " {\"near\": [0.5,0.75,0.5], \"delta\": [0,0,-0.04]}],"
                    " \"frames\": [{\"control\": %d, \"rotate\": {\"axis\": [0,0,1], \"angle\": 0.2}}],"
                    " \"constraints\": [{\"vertex\": %zu, \"target\": [0.5,0.56,0.5]}]}",
                 controls, first ? 2 : 1, first ? 3 : 2, centre);
        ffd_mesh *mesh = grid_mesh(9);
        n = ffd_mesh_vertex_count(mesh);
        ffd_error err = {{0}};
        ffd_rig_report report = {0};
        ffd_status st = apply_json(json, mesh, &report, &err);
        CHECK(st == FFD_OK);
        if (st != FFD_OK)
            fprintf(stderr, "     %s\n     %s\n", json, err.message);
        CHECK(report.control_count == (t == 0 ? 4u : 5u));
        ffd_rig_report_free(&report);
        if (t == 0) {
            ref = copy_positions(mesh);
        } else {
            CHECK(memcmp(ref, ffd_mesh_positions(mesh), 3 * n * sizeof *ref) == 0);
        }
        ffd_mesh_destroy(mesh);
    }
    free(ref);
}

static void test_apply_constraints(void)
{
    ffd_mesh *mesh = grid_mesh(9);
    ffd_error err = {{0}};
    ffd_rig_report report = {0};
    /* vertex (4,4,4) is the centre (0.5,0.5,0.5); pull it up; pin a point */
    size_t centre = (4 * 9 + 4) * 9 + 4;
    char json[1024];
    snprintf(json, sizeof json,
             PB FOUR_CONTROLS ", \"constraints\": [{\"vertex\": %zu, \"target\": [0.5,0.6,0.5]},"
                              " {\"point\": [0.3,0.5,0.5], \"target\": [0.3,0.5,0.52]}]}",
             centre);
    CHECK_OK(apply_json(json, mesh, &report, &err));
    CHECK(report.constraint_count == 2);
    if (report.constraint_count == 2) {
        CHECK(report.residuals[0] < 1e-9 && report.residuals[1] < 1e-9);
        CHECK_NEAR(ffd_mesh_positions(mesh)[3 * centre + 1], 0.6, 1e-9);
    }
    ffd_rig_report_free(&report);
    /* a vertex under no control point but the master cannot move: a clear error */
    CHECK(apply_json(PB FOUR_CONTROLS ", \"constraints\": [{\"vertex\": 0, \"target\": [0,0,1]}]}",
                     mesh, NULL, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "constraints[0].vertex: vertex 0 lies in no control point's region "
                              "of influence but the master's") != NULL);
    CHECK(apply_json(PB FOUR_CONTROLS ", \"constraints\": [{\"vertex\": 729, \"target\": [0,0,1]}]}",
                     mesh, NULL, &err) == FFD_ERR_RANGE);
    CHECK(apply_json(PB FOUR_CONTROLS ", \"moves\": [{\"control\": 0, \"delta\": [0,0,1e308]},"
                                      "{\"control\": 0, \"delta\": [0,0,1e308]}]}",
                     mesh, NULL, &err) != FFD_OK);
    ffd_mesh_destroy(mesh);
}

static void test_apply_levels_and_frames(void)
{
    ffd_mesh *mesh = grid_mesh(9);
    size_t n = ffd_mesh_vertex_count(mesh);
    double *rest = malloc(3 * n * sizeof *rest);
    memcpy(rest, ffd_mesh_positions(mesh), 3 * n * sizeof *rest);
    ffd_error err = {{0}};
    ffd_rig_report report = {0};
    CHECK_OK(apply_json(PB FOUR_CONTROLS ", \"levels\": 2,"
                           " \"moves\": [{\"control\": 0, \"level\": 1, \"delta\": [0,0.1,0]}],"
                           " \"frames\": [{\"control\": 2, \"rotate\": {\"axis\": [0,0,1],"
                           " \"angle\": 0.3}}]}",
                        mesh, &report, &err));
    CHECK(detail(&report, "levels") == 2);
    size_t changed = 0;
    for (size_t i = 0; i < 3 * n; i++)
        changed += ffd_mesh_positions(mesh)[i] != rest[i];
    CHECK(changed > 0);
    ffd_rig_report_free(&report);
    /* a level-1 control index past the end is named */
    CHECK(apply_json(PB FOUR_CONTROLS ", \"levels\": 2,"
                        " \"moves\": [{\"control\": 7, \"level\": 1, \"delta\": [0,0.1,0]}]}",
                     mesh, NULL, &err) == FFD_ERR_RANGE);
    CHECK(strstr(err.message, "moves[0].control: 7 out of range (level 1 has") != NULL);
    free(rest);
    ffd_mesh_destroy(mesh);
}

static void test_apply_curve(void)
{
    ffd_mesh *mesh = grid_mesh(9);
    size_t n = ffd_mesh_vertex_count(mesh);
    double *rest = malloc(3 * n * sizeof *rest);
    memcpy(rest, ffd_mesh_positions(mesh), 3 * n * sizeof *rest);
    ffd_error err = {{0}};
    CHECK_OK(apply_json(PB FOUR_CONTROLS ", \"curves\": [{\"points\": [[0,0.5,0.5],[0.5,0.5,0.5],"
                           "[1,0.5,0.5]], \"radius\": 0.3, \"moves\": [{\"index\": 2, "
                           "\"delta\": [0,0.2,0]}]}]}",
                        mesh, NULL, &err));
    const double *p = ffd_mesh_positions(mesh);
    size_t outside_moved = 0, moved = 0;
    for (size_t i = 0; i < n; i++) {
        double dy = rest[3 * i + 1] - 0.5, dz = rest[3 * i + 2] - 0.5;
        int changed = memcmp(p + 3 * i, rest + 3 * i, 3 * sizeof *p) != 0;
        /* the curve's ROI is the union of balls of radius 0.3 around it (plus its end caps) */
        if (sqrt(dy * dy + dz * dz) > 0.3 + 1e-9)
            outside_moved += changed;
        else
            moved += changed;
    }
    CHECK(outside_moved == 0);
    CHECK(moved > 0);
    free(rest);
    ffd_mesh_destroy(mesh);
}

static void test_apply_placed_cow(void)
{
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read(FFD_DATA_DIR "/cow.off", &mesh, &err));
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh);
    double *rest = malloc(3 * n * sizeof *rest);
    memcpy(rest, ffd_mesh_positions(mesh), 3 * n * sizeof *rest);
    ffd_rig_report report = {0};
    CHECK_OK(apply_json(PB "\"controls\": {\"interior\": 30, \"exterior\": 30}}", mesh, &report,
                        &err));
    CHECK(memcmp(rest, ffd_mesh_positions(mesh), 3 * n * sizeof *rest) == 0);
    CHECK(detail(&report, "placed") == 1 && report.control_count == 60);
    CHECK(detail(&report, "placement.interior") == 30 && detail(&report, "placement.exterior") == 30);
    CHECK(detail(&report, "uncovered") == 0 && report.outside_count == 0);
    ffd_rig_report_free(&report);
    /* direct manipulation of a vertex of the placed set reaches its target */
    double t[3] = {rest[0] + 0.02, rest[1] + 0.03, rest[2]};
    char json[512];
    snprintf(json, sizeof json,
             PB "\"controls\": {\"interior\": 30, \"exterior\": 30},"
                " \"constraints\": [{\"vertex\": 0, \"target\": [%.17g, %.17g, %.17g]}]}",
             t[0], t[1], t[2]);
    CHECK_OK(apply_json(json, mesh, &report, &err));
    for (int a = 0; a < 3; a++)
        CHECK_NEAR(ffd_mesh_positions(mesh)[a], t[a], 1e-9);
    ffd_rig_report_free(&report);
    /* more points than the mesh offers: the error names how many there are */
    CHECK(apply_json(PB "\"controls\": {\"exterior\": 100000}}", mesh, NULL, &err) ==
          FFD_ERR_INVALID);
    CHECK(strstr(err.message, "controls (automatic placement)") != NULL);
    free(rest);
    ffd_mesh_destroy(mesh);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"parse_every_key", test_parse_every_key},
        {"parse_bad", test_parse_bad},
        {"write_round_trip", test_write_round_trip},
        {"apply_identity_and_move", test_apply_identity_and_move},
        {"apply_disabled_changes_nothing", test_apply_disabled_changes_nothing},
        {"apply_constraints", test_apply_constraints},
        {"apply_levels_and_frames", test_apply_levels_and_frames},
        {"apply_curve", test_apply_curve},
        {"apply_placed_cow", test_apply_placed_cow},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
