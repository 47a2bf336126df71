/* Tests for GFFD rigs (src/rig with "deformer": "gffd"): every key, every
 * rejected value of docs/rig.md's "GFFD errors" with its JSON path, skeleton
 * files resolved against the rig's directory, and ffd_rig_apply on the three
 * examples (report fields, untouched regions, resampling), an unedited rig
 * (identity), failing rigs (mesh unchanged) and scale invariance. */
#include "check.h"
#include "gffd/gffd_method.h"
#include "report_details.h"
#include "check_rig.h"

#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#define G "{\"deformer\": \"gffd\", "
#define PT "{\"type\": \"point\", \"position\": [0,0,0], \"radius\": 1}"
#define SK "\"skeleton\": [" PT "]"
/* a two-vertex polyline along x */
#define LINE "{\"type\": \"polyline\", \"vertices\": [[0,0,0],[1,0,0]], \"radius\": 0.5}"
#define SKL "\"skeleton\": [" LINE "]"
/* a closed tetrahedron */
#define TET_VERTS "[[0,0,0],[1,0,0],[0,1,0],[0,0,1]]"
#define TET_FACES "[[0,2,1],[0,1,3],[0,3,2],[1,2,3]]"

#define EXAMPLES FFD_SOURCE_DIR "/examples/gffd"

/* A g x g x g grid of vertices in [-1,1]^3 with one triangle. */
static ffd_mesh *grid_mesh(int g)
{
    size_t n = (size_t)g * g * g, v = 0;
    double *p = malloc(3 * n * sizeof *p);
    for (int i = 0; i < g; i++)
        for (int j = 0; j < g; j++)
            for (int k = 0; k < g; k++, v++) {
                p[3 * v] = -1 + 2.0 * i / (g - 1);
                p[3 * v + 1] = -1 + 2.0 * j / (g - 1);
                p[3 * v + 2] = -1 + 2.0 * k / (g - 1);
            }
    uint32_t offsets[2] = {0, 3}, indices[3] = {0, 1, 2};
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_mesh_create(p, n, offsets, indices, 1, &mesh, NULL));
    free(p);
    return mesh;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (!f)
        return;
    fputs(text, f);
    fclose(f);
}

/* ---------------------------------------------------------------------- */

static void test_parse_every_key(void)
{
    ffd_rig *rig = parse_ok(
        G "\"version\": 1, \"skeleton\": [" PT ", " LINE
          ", {\"type\": \"patch\", \"vertices\": [[0,0,0],[1,0,0],[0,1,0]], \"faces\": [[0,1,2]],"
          "   \"radius\": 0.25, \"name\": \"tri\"},"
          "  {\"type\": \"polyhedron\", \"vertices\": " TET_VERTS ", \"faces\": " TET_FACES
          ", \"radius\": 2}],"
          " \"unit\": 0.5, \"tolerance\": 1e-4, \"max_iterations\": 50, \"tracking\": \"warp\","
          " \"max_samples\": 300,"
          " \"edits\": [{\"primitive\": 1, \"translate\": [0,1,0]},"
          "   {\"primitive\": \"all\", \"rotate\": {\"axis\": [0,0,2], \"angle\": 0.5},"
          "    \"center\": [1,2,3]},"
          "   {\"primitive\": 2, \"scale\": 2}, {\"primitive\": 2, \"scale\": [1,2,3]},"
          "   {\"primitive\": 1, \"vertex\": 1, \"move\": [0,0,1]},"
          "   {\"primitive\": 1, \"vertices\": [[0,0,0],[2,0,0]]}],"
          " \"correspondences\": [{\"from\": [0,0,0], \"to\": [0,1,0]}],"
          " \"resample\": {\"ratio\": 1.5, \"max_rounds\": 3, \"max_vertices\": 1000}}");
    if (!rig)
        return;
    CHECK(rig->method == &ffd_method_gffd);
    const ffd_rig_gffd *g = ffd_rig_gffd_of(rig);
    CHECK(g->skeleton_count == 4);
    if (g->skeleton_count == 4) {
        CHECK(g->skeleton[0].kind == FFD_GFFD_POINT && g->skeleton[0].vertex_count == 1);
        CHECK(g->skeleton[1].kind == FFD_GFFD_POLYLINE && g->skeleton[1].vertex_count == 2 &&
              g->skeleton[1].radius == 0.5 && g->skeleton[1].vertices[3] == 1);
        CHECK(g->skeleton[2].kind == FFD_GFFD_PATCH && g->skeleton[2].face_count == 1 &&
              g->skeleton[2].face_offsets[1] == 3 && g->skeleton[2].face_indices[2] == 2);
        CHECK(g->skeleton[3].kind == FFD_GFFD_POLYHEDRON && g->skeleton[3].face_count == 4 &&
              g->skeleton[3].vertex_count == 4 && g->skeleton[3].radius == 2);
    }
    CHECK(g->options.unit == 0.5 && g->options.tolerance == 1e-4);
    CHECK(g->options.max_iterations == 50 && g->options.max_samples == 300);
    CHECK(g->options.tracking == FFD_GFFD_TRACK_WARP);
    CHECK(g->edit_count == 6);
    if (g->edit_count == 6) {
        CHECK(g->edits[0].kind == FFD_RIG_EDIT_TRANSLATE && g->edits[0].primitive == 1 &&
              g->edits[0].delta[1] == 1);
        CHECK(g->edits[1].kind == FFD_RIG_EDIT_ROTATE && g->edits[1].all == 1 &&
              g->edits[1].angle == 0.5 && g->edits[1].axis[2] == 2 && g->edits[1].has_center &&
              g->edits[1].center[2] == 3);
        CHECK(g->edits[2].kind == FFD_RIG_EDIT_SCALE && g->edits[2].scale[0] == 2 &&
              g->edits[2].scale[2] == 2 && !g->edits[2].has_center);
        CHECK(g->edits[3].kind == FFD_RIG_EDIT_SCALE && g->edits[3].scale[1] == 2 &&
              g->edits[3].scale[2] == 3);
        CHECK(g->edits[4].kind == FFD_RIG_EDIT_MOVE && g->edits[4].vertex == 1 &&
              g->edits[4].delta[2] == 1);
        CHECK(g->edits[5].kind == FFD_RIG_EDIT_VERTICES && g->edits[5].vertex_count == 2 &&
              g->edits[5].vertices[3] == 2);
    }
    CHECK(g->corr_count == 1 && g->corr_to[1] == 1);
    CHECK(g->resample == 1 && g->resample_options.ratio == 1.5 &&
          g->resample_options.max_rounds == 3 && g->resample_options.max_vertices == 1000);
    CHECK(g->replace == NULL);
    ffd_rig_destroy(rig);

    /* defaults; replace; resample as a boolean */
    rig = parse_ok(G SK ", \"replace\": [" LINE "], \"resample\": true}");
    if (rig) {
        CHECK(ffd_rig_gffd_of(rig)->replace_count == 1 && ffd_rig_gffd_of(rig)->replace[0].kind == FFD_GFFD_POLYLINE);
        CHECK(ffd_rig_gffd_of(rig)->options.tracking == FFD_GFFD_TRACK_GRADIENT);
        CHECK(ffd_rig_gffd_of(rig)->options.unit == 0 && ffd_rig_gffd_of(rig)->edit_count == 0);
        CHECK(ffd_rig_gffd_of(rig)->resample == 1 && ffd_rig_gffd_of(rig)->resample_options.ratio == 0);
        ffd_rig_destroy(rig);
    }
    rig = parse_ok(G SK ", \"resample\": false, \"tracking\": \"gradient\"}");
    if (rig) {
        CHECK(ffd_rig_gffd_of(rig)->resample == 0);
        ffd_rig_destroy(rig);
    }
    /* warp after replace is fine with correspondences */
    rig = parse_ok(G SK ", \"replace\": [" LINE "], \"tracking\": \"warp\","
                     " \"correspondences\": [{\"from\": [0,0,0], \"to\": [1,0,0]}]}");
    if (rig)
        ffd_rig_destroy(rig);
}

/* Errors found while reading the rig (docs/rig.md, "GFFD errors" and "Errors"). */
static void test_parse_bad(void)
{
    /* radius */
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"position\": [0,0,0], \"radius\": 0}]}",
              FFD_ERR_INVALID, "rig.json: skeleton[0].radius: 0: expected a number > 0");
    parse_bad(G "\"skeleton\": [" PT ", {\"type\": \"polyline\", \"vertices\": [[0,0,0],[1,0,0]],"
                " \"radius\": -2}]}",
              FFD_ERR_INVALID, "rig.json: skeleton[1].radius: -2: expected a number > 0");
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"position\": [0,0,0]}]}", FFD_ERR_PARSE,
              "rig.json: skeleton[0].radius: expected the influence radius r_s > 0 (missing)");
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"position\": [0,0,0], \"radius\": \"1\"}]}",
              FFD_ERR_PARSE, "skeleton[0].radius: expected a number");
    /* geometry */
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"radius\": 1}]}", FFD_ERR_PARSE,
              "rig.json: skeleton[0].position: expected an array of 3 finite numbers (missing)");
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"position\": [0,0], \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0].position: expected an array of 3 finite numbers");
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"vertices\": [[0,0,0]], \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0]: expected a point with a \"position\" only");
    parse_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"vertices\": [[0,0,0]], \"radius\": 1}]}",
              FFD_ERR_PARSE, "rig.json: skeleton[0].vertices: expected an array of at least 2 points");
    parse_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"radius\": 1}]}", FFD_ERR_PARSE,
              "skeleton[0].vertices: expected an array of points [x,y,z], or a \"file\" (missing)");
    parse_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"position\": [0,0,0], \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0]: expected \"vertices\" or \"file\" (\"position\" is for points)");
    parse_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"vertices\": [[0,0,0],[1,0,0]],"
                " \"faces\": [[0,1,0]], \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0].faces: expected no faces");
    parse_bad(G "\"skeleton\": [{\"type\": \"patch\", \"vertices\": [[0,0,0],[1,0,0],[0,1,0]],"
                " \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0].faces: expected an array of faces (missing)");
    parse_bad(G "\"skeleton\": [{\"type\": \"patch\", \"vertices\": [[0,0,0],[1,0,0],[0,1,0]],"
                " \"faces\": [[0,1]], \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0].faces: expected an array of faces, each an array of >= 3");
    parse_bad(G "\"skeleton\": [{\"type\": \"patch\", \"vertices\": [[0,0,0],[1,0,0],[0,1,0]],"
                " \"faces\": [[0,1,-2]], \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0].faces[0]: expected vertex indices");
    parse_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"vertices\": [[0,0,0],[1,0,0]],"
                " \"file\": \"x.obj\", \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0]: expected either \"file\" or \"vertices\", not both");
    parse_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"\", \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0].file: expected a file name");
    /* types and keys */
    parse_bad(G "\"skeleton\": [{\"type\": \"sphere\", \"position\": [0,0,0], \"radius\": 1}]}",
              FFD_ERR_PARSE,
              "rig.json: skeleton[0].type: expected \"point\", \"polyline\", \"patch\" or "
              "\"polyhedron\"");
    parse_bad(G "\"skeleton\": [{\"position\": [0,0,0], \"radius\": 1}]}", FFD_ERR_PARSE,
              "skeleton[0].type: expected \"point\", \"polyline\", \"patch\" or \"polyhedron\" "
              "(missing)");
    parse_bad(G "\"skeleton\": [" PT ", {\"type\": \"point\", \"position\": [0,0,0], "
                "\"radius\": 1, \"colour\": \"red\"}]}",
              FFD_ERR_PARSE, "rig.json: skeleton[1].colour: unknown key, expected one of \"type\"");
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"position\": [0,0,0], \"radius\": 1,"
                " \"name\": 3}]}",
              FFD_ERR_PARSE, "skeleton[0].name: expected a string");
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"position\": [0,0,0], \"radius\": 1,"
                " \"radius\": 2}]}",
              FFD_ERR_PARSE, "skeleton[0].radius: key given twice");
    parse_bad(G "\"skeleton\": [1]}", FFD_ERR_PARSE, "skeleton[0]: expected a primitive");
    parse_bad(G "\"skeleton\": []}", FFD_ERR_PARSE, "rig.json: skeleton: expected an array of at least one primitive");
    parse_bad("{\"deformer\": \"gffd\"}", FFD_ERR_PARSE, "rig.json: skeleton: expected an array of primitives (missing)");
    parse_bad(G SK ", \"moves\": []}", FFD_ERR_PARSE,
              "rig.json: moves: not a key of \"deformer\": \"gffd\" rigs, expected one of "
              "\"skeleton\"");
    parse_bad(G SK ", \"basis\": \"bspline\"}", FFD_ERR_PARSE,
              "rig.json: basis: not a key of \"deformer\": \"gffd\" rigs");
    parse_bad(G SK ", \"controls\": \"auto\"}", FFD_ERR_PARSE,
              "rig.json: controls: not a key of \"deformer\": \"gffd\" rigs");
    parse_bad(G SK ", \"constraints\": [{\"vertex\": 0, \"target\": [0,0,0]}]}", FFD_ERR_PARSE,
              "rig.json: constraints: not a key of \"deformer\": \"gffd\" rigs");
    parse_bad(G SK ", \"unit\": 1, \"unit\": 2}", FFD_ERR_PARSE, "rig.json: unit: key given twice");
    /* gffd keys in other rigs */
    parse_bad("{\"skeleton\": [" PT "]}", FFD_ERR_PARSE,
              "rig.json: skeleton: only for \"deformer\": \"gffd\" rigs");
    parse_bad("{\"deformer\": \"lattice\", \"tracking\": \"warp\"}", FFD_ERR_PARSE,
              "rig.json: tracking: only for \"deformer\": \"gffd\" rigs");
    parse_bad("{\"deformer\": \"pbffd\", \"resample\": true}", FFD_ERR_PARSE,
              "rig.json: resample: only for \"deformer\": \"gffd\" rigs");
    parse_bad("{\"resolution\": [3,3,3], \"edits\": []}", FFD_ERR_PARSE,
              "rig.json: edits: only for \"deformer\": \"gffd\" rigs");

    /* edits */
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"translate\": [1,0,0]}], \"replace\": ["
                LINE "]}",
              FFD_ERR_PARSE, "rig.json: edits: a rig either edits its skeleton or replaces it, not both");
    parse_bad(G SKL ", \"edits\": {}}", FFD_ERR_PARSE, "rig.json: edits: expected an array of skeleton edits");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 1, \"translate\": [1,0,0]}]}", FFD_ERR_RANGE,
              "rig.json: edits[0].primitive: 1 out of range (the skeleton has 1 primitive)");
    parse_bad(G "\"skeleton\": [" PT ", " LINE "], \"edits\": [{\"primitive\": 0, \"translate\": [1,0,0]},"
                " {\"primitive\": 5, \"scale\": 2}]}",
              FFD_ERR_RANGE, "rig.json: edits[1].primitive: 5 out of range (the skeleton has 2 primitives)");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"vertex\": 2, \"move\": [1,0,0]}]}",
              FFD_ERR_RANGE, "rig.json: edits[0].vertex: 2 out of range (skeleton[0] has 2 vertices)");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"vertices\": [[0,0,0],[1,0,0],[2,0,0]]}]}",
              FFD_ERR_INVALID,
              "rig.json: edits[0].vertices: 3 vertices, but skeleton[0] has 2: an edit keeps the "
              "skeleton's structure; to change it, use \"replace\" with \"correspondences\"");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": \"all\", \"vertex\": 0, \"move\": [1,0,0]}]}",
              FFD_ERR_PARSE, "rig.json: edits[0]: expected a primitive index with \"move\" (not \"all\")");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": \"all\", \"vertices\": [[0,0,0],[1,0,0]]}]}",
              FFD_ERR_PARSE, "rig.json: edits[0]: expected a primitive index with \"vertices\" (not \"all\")");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"move\": [1,0,0]}]}", FFD_ERR_PARSE,
              "edits[0]: expected \"vertex\" together with \"move\"");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"vertex\": 0, \"translate\": [1,0,0]}]}",
              FFD_ERR_PARSE, "edits[0]: expected \"vertex\" together with \"move\"");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"translate\": [1,0,0], \"scale\": 2}]}",
              FFD_ERR_PARSE, "edits[0]: expected one of \"translate\", \"rotate\", \"scale\", \"move\", "
                             "\"vertices\" per edit");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0}]}", FFD_ERR_PARSE,
              "edits[0]: expected one of \"translate\"");
    parse_bad(G SKL ", \"edits\": [{\"translate\": [1,0,0]}]}", FFD_ERR_PARSE,
              "edits[0].primitive: expected a primitive index or \"all\" (missing)");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": \"some\", \"translate\": [1,0,0]}]}",
              FFD_ERR_PARSE, "edits[0].primitive: expected a primitive index or \"all\"");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"translate\": [1,0,0], \"center\": [0,0,0]}]}",
              FFD_ERR_PARSE, "edits[0]: expected \"center\" only with \"rotate\" or \"scale\"");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"turn\": 1}]}", FFD_ERR_PARSE,
              "rig.json: edits[0].turn: unknown key");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"rotate\": {\"axis\": [0,0,0], \"angle\": 1}}]}",
              FFD_ERR_INVALID, "rig.json: edits[0].rotate.axis: the zero vector is no axis");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"rotate\": {\"axis\": [0,0,1]}}]}",
              FFD_ERR_PARSE, "edits[0].rotate.angle: expected an angle in radians (missing)");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"rotate\": {\"angle\": 1}}]}",
              FFD_ERR_PARSE, "edits[0].rotate.axis: expected an array of 3 finite numbers (missing)");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"rotate\": {\"axis\": [0,0,1], \"angle\": 1,"
                " \"about\": 2}}]}",
              FFD_ERR_PARSE, "edits[0].rotate.about: unknown key");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"rotate\": 1}]}", FFD_ERR_PARSE,
              "edits[0].rotate: expected an object {\"axis\": [x,y,z], \"angle\": radians}");

    /* replace and correspondences */
    parse_bad(G SK ", \"replace\": [" LINE "], \"tracking\": \"warp\"}", FFD_ERR_INVALID,
              "rig.json: replace: warp tracking after a skeleton replacement needs "
              "\"correspondences\"");
    parse_bad(G SK ", \"replace\": []}", FFD_ERR_PARSE, "rig.json: replace: expected an array of at least one primitive");
    parse_bad(G SK ", \"replace\": [{\"type\": \"point\", \"position\": [0,0,0], \"radius\": 0}]}",
              FFD_ERR_INVALID, "rig.json: replace[0].radius: 0: expected a number > 0");
    parse_bad(G SK ", \"correspondences\": []}", FFD_ERR_PARSE, "rig.json: correspondences: expected an array of");
    parse_bad(G SK ", \"correspondences\": [{\"from\": [0,0,0]}]}", FFD_ERR_PARSE,
              "correspondences[0].to: expected a point [x,y,z] on the new skeleton (missing)");
    parse_bad(G SK ", \"correspondences\": [{\"from\": [0,0,0], \"to\": [0,0,0], \"via\": 1}]}",
              FFD_ERR_PARSE, "correspondences[0].via: unknown key");

    /* options */
    parse_bad(G SK ", \"tracking\": \"closest\"}", FFD_ERR_PARSE,
              "rig.json: tracking: expected \"gradient\" or \"warp\"");
    parse_bad(G SK ", \"tracking\": 1}", FFD_ERR_PARSE, "rig.json: tracking: expected \"gradient\" or \"warp\"");
    parse_bad(G SK ", \"tolerance\": 1.5}", FFD_ERR_INVALID,
              "rig.json: tolerance: 1.5: expected a number in (0, 1]");
    parse_bad(G SK ", \"version\": 2}", FFD_ERR_PARSE, "rig.json: version: expected 1");
    parse_bad(G SK ", \"tolerance\": 0}", FFD_ERR_INVALID, "rig.json: tolerance: 0: expected a number > 0");
    parse_bad(G SK ", \"unit\": -1}", FFD_ERR_INVALID, "rig.json: unit: -1: expected a number > 0");
    parse_bad(G SK ", \"max_iterations\": 0}", FFD_ERR_PARSE, "rig.json: max_iterations: expected an integer in 1..100000");
    parse_bad(G SK ", \"max_iterations\": 100001}", FFD_ERR_PARSE, "max_iterations: expected an integer in 1..100000");
    parse_bad(G SK ", \"max_iterations\": 2.5}", FFD_ERR_PARSE, "max_iterations: expected an integer in 1..100000");
    parse_bad(G SK ", \"max_samples\": 0}", FFD_ERR_PARSE, "rig.json: max_samples: expected an integer in 1..20000");
    parse_bad(G SK ", \"max_samples\": 20001}", FFD_ERR_PARSE, "max_samples: expected an integer in 1..20000");
    parse_bad(G SK ", \"resample\": {\"ratio\": 1}}", FFD_ERR_PARSE,
              "rig.json: resample.ratio: expected a number > 1");
    parse_bad(G SK ", \"resample\": {\"ratio\": 0.5}}", FFD_ERR_PARSE,
              "rig.json: resample.ratio: expected a number > 1");
    parse_bad(G SK ", \"resample\": {\"max_rounds\": 0}}", FFD_ERR_PARSE,
              "rig.json: resample.max_rounds: expected an integer in 1..64");
    parse_bad(G SK ", \"resample\": {\"max_rounds\": 65}}", FFD_ERR_PARSE,
              "rig.json: resample.max_rounds: expected an integer in 1..64");
    parse_bad(G SK ", \"resample\": {\"max_vertices\": 0}}", FFD_ERR_PARSE,
              "rig.json: resample.max_vertices: expected a positive integer");
    parse_bad(G SK ", \"resample\": {\"rounds\": 2}}", FFD_ERR_PARSE,
              "rig.json: resample.rounds: unknown key, expected one of \"ratio\"");
    parse_bad(G SK ", \"resample\": \"yes\"}", FFD_ERR_PARSE, "rig.json: resample: expected true, false or");

    /* non-finite numbers (cJSON reads 1e999 as inf) */
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"position\": [0,0,0], \"radius\": 1e999}]}",
              FFD_ERR_NONFINITE, "rig.json: skeleton[0].radius: expected a finite number, got inf");
    parse_bad(G "\"skeleton\": [{\"type\": \"point\", \"position\": [0,-1e999,0], \"radius\": 1}]}",
              FFD_ERR_NONFINITE, "rig.json: skeleton[0].position[1]: expected a finite number, got -inf");
    parse_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"vertices\": [[0,0,0],[1,0,1e999]],"
                " \"radius\": 1}]}",
              FFD_ERR_NONFINITE, "rig.json: skeleton[0].vertices[1][2]: expected a finite number");
    parse_bad(G SK ", \"unit\": 1e999}", FFD_ERR_NONFINITE, "rig.json: unit: expected a finite number, got inf");
    parse_bad(G SK ", \"tolerance\": -1e999}", FFD_ERR_NONFINITE, "rig.json: tolerance: expected a finite number");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"translate\": [1e999,0,0]}]}",
              FFD_ERR_NONFINITE, "rig.json: edits[0].translate[0]: expected a finite number, got inf");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"rotate\": {\"axis\": [0,0,1], \"angle\": 1e999}}]}",
              FFD_ERR_NONFINITE, "rig.json: edits[0].rotate.angle: expected a finite number");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"scale\": -1e999}]}", FFD_ERR_NONFINITE,
              "rig.json: edits[0].scale: expected a finite number, got -inf");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"vertex\": 1, \"move\": [0,1e999,0]}]}",
              FFD_ERR_NONFINITE, "rig.json: edits[0].move[1]");
    parse_bad(G SKL ", \"edits\": [{\"primitive\": 0, \"vertices\": [[0,0,0],[1e999,0,0]]}]}",
              FFD_ERR_NONFINITE, "rig.json: edits[0].vertices[1][0]");
    parse_bad(G SK ", \"correspondences\": [{\"from\": [0,0,0], \"to\": [0,0,1e999]}]}",
              FFD_ERR_NONFINITE, "rig.json: correspondences[0].to[2]: expected a finite number");
    parse_bad(G SK ", \"resample\": {\"ratio\": 1e999}}", FFD_ERR_NONFINITE,
              "rig.json: resample.ratio: expected a finite number");
}

/* Skeleton files: errors name the rig, the JSON path and the file (and line). */
static void test_skeleton_files(void)
{
    char dir[] = "/tmp/ffd_rig_gffd_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[256], rig_path[256], json[1024], want[1024];
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
#define FILE_RIG(file) G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"" file "\", \"radius\": 1}]}"

    /* a missing file: FFD_ERR_IO naming the file, resolved in the rig's directory */
    snprintf(rig_path, sizeof rig_path, "%s/missing.json", dir);
    write_text(rig_path, FILE_RIG("nowhere.obj"));
    CHECK(ffd_rig_read(rig_path, &rig, &err) == FFD_ERR_IO && rig == NULL);
    snprintf(want, sizeof want, "%s: skeleton[0].file: %s/nowhere.obj", rig_path, dir);
    if (!strstr(err.message, want)) {
        fprintf(stderr, "  expected \"%s\" in \"%s\"\n", want, err.message);
        CHECK(!"missing file message");
    }
    parse_bad(FILE_RIG("/nonexistent-dir/trunk.obj"), FFD_ERR_IO,
              "rig.json: skeleton[0].file: /nonexistent-dir/trunk.obj");

    /* STL is refused for skeletons, before reading it */
    parse_bad(G "\"skeleton\": [{\"type\": \"patch\", \"file\": \"" FFD_DATA_DIR
                "/hinge.stl\", \"radius\": 1}]}",
              FFD_ERR_UNSUPPORTED, "skeleton[0].file: " FFD_DATA_DIR "/hinge.stl: STL has no shared vertices");
    parse_bad(FILE_RIG("/nonexistent-dir/x.STL"), FFD_ERR_UNSUPPORTED, "STL has no shared vertices");

    /* a polyline OBJ with two l statements */
    snprintf(path, sizeof path, "%s/two.obj", dir);
    write_text(path, "v 0 0 0\nv 1 0 0\nv 2 0 0\nl 1 2\nl 2 3\n");
    snprintf(json, sizeof json,
             G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"%s\", \"radius\": 1}]}", path);
    snprintf(want, sizeof want,
             "rig.json: skeleton[0].file: %s:5: a second 'l' statement (line 4 had one)", path);
    parse_bad(json, FFD_ERR_PARSE, want);

    /* a bad v line: file:line */
    snprintf(path, sizeof path, "%s/badv.obj", dir);
    write_text(path, "# a comment\nv 0 0 0\nv 1 0\nl 1 2\n");
    snprintf(json, sizeof json,
             G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"%s\", \"radius\": 1}]}", path);
    snprintf(want, sizeof want, "rig.json: skeleton[0].file: %s:3: expected 3 numbers after 'v'",
             path);
    parse_bad(json, FFD_ERR_PARSE, want);

    /* an l index out of range */
    snprintf(path, sizeof path, "%s/range.obj", dir);
    write_text(path, "v 0 0 0\nv 1 0 0\nl 1 2 5\n");
    snprintf(json, sizeof json,
             G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"%s\", \"radius\": 1}]}", path);
    snprintf(want, sizeof want,
             "rig.json: skeleton[0].file: %s:3: vertex index 5 out of range (2 vertices so far)",
             path);
    parse_bad(json, FFD_ERR_RANGE, want);

    /* one vertex only */
    snprintf(path, sizeof path, "%s/one.obj", dir);
    write_text(path, "v 0 0 0\n");
    snprintf(json, sizeof json,
             G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"%s\", \"radius\": 1}]}", path);
    parse_bad(json, FFD_ERR_PARSE, "a polyline needs at least 2 vertices, found 1");

    /* a mesh file for a polyline, a polyline file for a patch */
    parse_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"" EXAMPLES
                "/head.off\", \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0].file: expected a polyline file (OBJ v and l lines), not a mesh");
    parse_bad(G "\"skeleton\": [{\"type\": \"patch\", \"file\": \"" EXAMPLES
                "/spine.obj\", \"radius\": 1}]}",
              FFD_ERR_PARSE, "skeleton[0].file: expected a mesh file with faces");

    /* the v lines in order without an l statement; l reorders them */
    snprintf(path, sizeof path, "%s/order.obj", dir);
    write_text(path, "v 0 0 0\nv 1 0 0\nv 2 0 0\n");
    snprintf(json, sizeof json,
             G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"%s\", \"radius\": 1}]}", path);
    rig = parse_ok(json);
    if (rig) {
        CHECK(ffd_rig_gffd_of(rig)->skeleton[0].vertex_count == 3 && ffd_rig_gffd_of(rig)->skeleton[0].vertices[6] == 2);
        ffd_rig_destroy(rig);
    }
    write_text(path, "v 0 0 0\nv 1 0 0\nv 2 0 0\nl 3 -3 2\n");
    rig = parse_ok(json);
    if (rig) {
        const double *v = ffd_rig_gffd_of(rig)->skeleton[0].vertices;
        CHECK(ffd_rig_gffd_of(rig)->skeleton[0].vertex_count == 3 && v[0] == 2 && v[3] == 0 && v[6] == 1);
        ffd_rig_destroy(rig);
    }

    /* a UTF-8 byte order mark before the first v line: that vertex is read
     * (issue 14: it was lost, silently) */
    snprintf(path, sizeof path, "%s/bom.obj", dir);
    write_text(path, "\xEF\xBB\xBFv 5 0 0\nv 1 0 0\nv 2 0 0\n");
    snprintf(json, sizeof json,
             G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"%s\", \"radius\": 1}]}", path);
    rig = parse_ok(json);
    if (rig) {
        const double *v = ffd_rig_gffd_of(rig)->skeleton[0].vertices;
        CHECK(ffd_rig_gffd_of(rig)->skeleton[0].vertex_count == 3 && v[0] == 5 && v[3] == 1 && v[6] == 2);
        ffd_rig_destroy(rig);
    }

    /* a polyhedron from a mesh file keeps its faces */
    rig = parse_ok(G "\"skeleton\": [{\"type\": \"polyhedron\", \"file\": \"" EXAMPLES
                     "/head.off\", \"radius\": 1}]}");
    if (rig) {
        CHECK(ffd_rig_gffd_of(rig)->skeleton[0].vertex_count == 6 && ffd_rig_gffd_of(rig)->skeleton[0].face_count == 8);
        CHECK(ffd_rig_gffd_of(rig)->skeleton[0].kind == FFD_GFFD_POLYHEDRON &&
              ffd_rig_gffd_of(rig)->skeleton[0].radius == 1);
        ffd_rig_destroy(rig);
    }
#undef FILE_RIG
    const char *names[] = {"missing.json", "two.obj", "badv.obj", "range.obj", "one.obj", "order.obj", "bom.obj"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        unlink(path);
    }
    CHECK(rmdir(dir) == 0);
}

/* Files resolve relative to the rig file's directory, not the cwd. */
static void test_relative_files(void)
{
    char dir[] = "/tmp/ffd_rig_gffd_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char cwd[4096], path[256];
    CHECK(getcwd(cwd, sizeof cwd) != NULL);
    snprintf(path, sizeof path, "%s/sub", dir);
    CHECK(mkdir(path, 0700) == 0);
    /* sub/rig.json names spine.obj: sub/spine.obj (3 vertices), not ./spine.obj (2) */
    snprintf(path, sizeof path, "%s/sub/rig.json", dir);
    write_text(path, G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"spine.obj\","
                       " \"radius\": 0.5}], \"edits\": [{\"primitive\": 0, \"vertex\": 2,"
                       " \"move\": [0,0.25,0]}]}");
    snprintf(path, sizeof path, "%s/sub/spine.obj", dir);
    write_text(path, "v -1 0 0\nv 0 0 0\nv 1 0 0\nl 1 2 3\n");
    snprintf(path, sizeof path, "%s/spine.obj", dir);
    write_text(path, "v 5 5 5\nv 6 5 5\n");
    snprintf(path, sizeof path, "%s/sub/bad.json", dir);
    write_text(path, G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"nowhere.obj\","
                       " \"radius\": 0.5}]}");

    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    CHECK(chdir(dir) == 0);
    CHECK_OK(ffd_rig_read("sub/rig.json", &rig, &err));
    if (rig) {
        CHECK(ffd_rig_gffd_of(rig)->skeleton_count == 1 && ffd_rig_gffd_of(rig)->skeleton[0].vertex_count == 3);
        CHECK(ffd_rig_gffd_of(rig)->skeleton[0].vertices[0] == -1 && ffd_rig_gffd_of(rig)->skeleton[0].vertices[6] == 1);
        /* and it applies: the mesh near the moved end moves, the rest of the grid does not */
        ffd_mesh *mesh = grid_mesh(9);
        double *rest = copy_positions(mesh);
        ffd_rig_report report = {0};
        CHECK_OK(ffd_rig_apply(rig, mesh, &report, &err));
        size_t n = ffd_mesh_vertex_count(mesh), moved = 0, far_moved = 0;
        const double *p = ffd_mesh_positions(mesh);
        for (size_t i = 0; i < n; i++) {
            int changed = memcmp(p + 3 * i, rest + 3 * i, 3 * sizeof *p) != 0;
            double dy = rest[3 * i + 1], dz = rest[3 * i + 2];
            if (sqrt(dy * dy + dz * dz) > 1.25 * 0.5) /* well beyond r from the line */
                far_moved += changed;
            moved += changed;
        }
        CHECK(moved > 0);
        CHECK(far_moved == 0);
        CHECK(report.control_count == 3 && report.control_points &&
              report.control_points[7] == 0.25);
        ffd_rig_report_free(&report);
        free(rest);
        ffd_mesh_destroy(mesh);
        ffd_rig_destroy(rig);
    }
    /* a missing file is looked for next to the rig, and the message says where */
    CHECK(ffd_rig_read("sub/bad.json", &rig, &err) == FFD_ERR_IO);
    CHECK(strstr(err.message, "sub/bad.json: skeleton[0].file: sub/nowhere.obj") != NULL);
    /* from another cwd, by absolute path */
    CHECK(chdir("/") == 0);
    snprintf(path, sizeof path, "%s/sub/rig.json", dir);
    CHECK_OK(ffd_rig_read(path, &rig, &err));
    if (rig) {
        CHECK(ffd_rig_gffd_of(rig)->skeleton[0].vertex_count == 3 && ffd_rig_gffd_of(rig)->skeleton[0].vertices[0] == -1);
        ffd_rig_destroy(rig);
    }
    CHECK(chdir(cwd) == 0);
    const char *names[] = {"sub/rig.json", "sub/spine.obj", "sub/bad.json", "spine.obj", "sub"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        CHECK(remove(path) == 0);
    }
    CHECK(rmdir(dir) == 0);
}

/* Errors found when the rig is applied: the message names the JSON path and
 * the mesh is unchanged. */
static void test_apply_bad(void)
{
    ffd_mesh *mesh = grid_mesh(5);
    apply_bad(G "\"skeleton\": [" PT ", {\"type\": \"polyline\", \"vertices\": "
                "[[0,0,0],[0.5,0,0],[1,0,0],[1,0,0]], \"radius\": 1}]}",
              mesh, FFD_ERR_INVALID,
              "rig.json: skeleton: skeleton[1]: zero-length segment between vertices 2 and 3");
    apply_bad(G "\"skeleton\": [{\"type\": \"polyhedron\", \"vertices\": [[0,0,0],[1,0,0],[0,1,0]],"
                " \"faces\": [[0,1,2]], \"radius\": 1}]}",
              mesh, FFD_ERR_INVALID,
              "rig.json: skeleton: skeleton[0]: polyhedron is not closed: edge (0, 1) is used by 1 "
              "face, expected 2 (an open mesh is a \"patch\")");
    /* a tetrahedron missing a face is open too */
    apply_bad(G "\"skeleton\": [" PT ", {\"type\": \"polyhedron\", \"vertices\": " TET_VERTS
                ", \"faces\": [[0,2,1],[0,1,3],[0,3,2]], \"radius\": 1}]}",
              mesh, FFD_ERR_INVALID, "rig.json: skeleton: skeleton[1]: polyhedron is not closed");
    apply_bad(G "\"skeleton\": [{\"type\": \"patch\", \"vertices\": [[0,0,0],[1,0,0],[0,1,0],"
                "[1,1,0],[2,0,0],[2,1,0]], \"faces\": [[0,1,2],[1,3,2],[1,4,3],[4,5,9]],"
                " \"radius\": 1}]}",
              mesh, FFD_ERR_RANGE,
              "rig.json: skeleton: skeleton[0]: face 3: vertex index 9 out of range (6 vertices)");
    apply_bad(G "\"skeleton\": [{\"type\": \"patch\", \"vertices\": [[0,0,0],[1,0,0],[0,1,0],[1,1,0]],"
                " \"faces\": [[0,1,2],[1,3,1]], \"radius\": 1}]}",
              mesh, FFD_ERR_INVALID, "rig.json: skeleton: skeleton[0]: face 1 repeats vertex 1");
    apply_bad(G "\"skeleton\": [{\"type\": \"patch\", \"vertices\": [[0,0,0],[1,0,0],[2,0,0],[0,1,0]],"
                " \"faces\": [[0,1,3],[0,1,2]], \"radius\": 1}]}",
              mesh, FFD_ERR_INVALID, "rig.json: skeleton: skeleton[0]: face 1 has zero area");
    /* a unit too small for the skeleton */
    apply_bad(G SK ", \"unit\": 1e-6}", mesh, FFD_ERR_INVALID,
              "rig.json: skeleton: unit 1e-06 is too small for this skeleton");
    /* an edit that makes a segment vanish: nothing applied */
    apply_bad(G "\"skeleton\": [" LINE "], \"edits\": [{\"primitive\": 0, \"translate\": [0,0.1,0]},"
                " {\"primitive\": 0, \"scale\": 2}, {\"primitive\": 0, \"vertex\": 1, \"move\": [-2,0,0]}]}",
              mesh, FFD_ERR_INVALID,
              "rig.json: edits[2]: skeleton[0]: zero-length segment between vertices 0 and 1");
    apply_bad(G "\"skeleton\": [" PT ", " LINE "], \"edits\": [{\"primitive\": \"all\", \"scale\": 0}]}",
              mesh, FFD_ERR_INVALID, "rig.json: edits[0]: skeleton[1]: zero-length segment");
    apply_bad(G "\"skeleton\": [" PT ", " LINE "], \"edits\": [{\"primitive\": 1, \"vertices\":"
                " [[0.5,0,0],[0.5,0,0]]}]}",
              mesh, FFD_ERR_INVALID, "rig.json: edits[0]: skeleton[1]: zero-length segment");
    /* an edit that flattens a face */
    apply_bad(G "\"skeleton\": [{\"type\": \"polyhedron\", \"vertices\": " TET_VERTS ", \"faces\": "
                TET_FACES ", \"radius\": 1}], \"edits\": [{\"primitive\": 0, \"vertex\": 3,"
                " \"move\": [0,0,-1]}]}",
              mesh, FFD_ERR_INVALID, "rig.json: edits[0]: skeleton[0]: face ");
    /* a bad replacement */
    apply_bad(G SK ", \"replace\": [{\"type\": \"polyline\", \"vertices\": [[0,0,0],[0,0,0]],"
                " \"radius\": 1}]}",
              mesh, FFD_ERR_INVALID, "rig.json: replace: skeleton[0]: zero-length segment");
    ffd_mesh_destroy(mesh);
}

/* A skeleton that is not edited: every vertex stays, bitwise. */
static void test_apply_identity(void)
{
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read(EXAMPLES "/bunny.obj", &mesh, &err));
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh), nf = ffd_mesh_face_count(mesh);
    double *rest = copy_positions(mesh);
    static const char *const rigs[] = {
        G "\"skeleton\": [{\"type\": \"polyline\", \"vertices\": [[3.0, 3.0, 0.8], [0.5, 3.5, 0.8],"
          " [-1.0, 4.5, 0.9]], \"radius\": 2.5}]}",
        G "\"skeleton\": [{\"type\": \"polyline\", \"vertices\": [[3.0, 3.0, 0.8], [0.5, 3.5, 0.8],"
          " [-1.0, 4.5, 0.9]], \"radius\": 2.5}], \"tracking\": \"warp\", \"edits\": []}",
        G "\"skeleton\": [{\"type\": \"polyhedron\", \"file\": \"" EXAMPLES "/head.off\","
          " \"radius\": 2.5}, {\"type\": \"point\", \"position\": [0,2,0], \"radius\": 2}],"
          " \"resample\": true}",
        /* an edit that changes nothing */
        G "\"skeleton\": [{\"type\": \"point\", \"position\": [0,2,0], \"radius\": 2}],"
          " \"edits\": [{\"primitive\": 0, \"translate\": [0,0,0]}], \"tracking\": \"warp\"}",
    };
    for (size_t r = 0; r < sizeof rigs / sizeof *rigs; r++) {
        ffd_rig_report report = {0};
        CHECK_OK(apply_json(rigs[r], mesh, &report, &err));
        CHECK(ffd_mesh_vertex_count(mesh) == n && ffd_mesh_face_count(mesh) == nf);
        if (ffd_mesh_vertex_count(mesh) == n &&
            memcmp(rest, ffd_mesh_positions(mesh), 3 * n * sizeof *rest) != 0) {
            fprintf(stderr, "  rig %zu moved vertices\n", r);
            CHECK(!"an unedited rig leaves the mesh unchanged");
        }
        CHECK(detail(&report, "influenced") > 0 && detail(&report, "influenced") < n);
        CHECK(detail(&report, "unit") > 0);
        CHECK(detail(&report, "tracked") == 0 && detail(&report, "not_converged") == 0);
        CHECK(!detail_has(&report, "resample") || detail(&report, "resample.added_vertices") == 0);
        CHECK(detail_has(&report, "resample") == (r == 2));
        ffd_rig_report_free(&report);
    }
    free(rest);
    ffd_mesh_destroy(mesh);
}

/* A number of the report's "resample" details; 0 when it did not resample. */
static double resampled(const ffd_rig_report *report, const char *key)
{
    char path[64];
    snprintf(path, sizeof path, "resample.%s", key);
    return detail_has(report, "resample") ? detail(report, path) : 0;
}

static void check_track_report(const ffd_rig_report *report, size_t n)
{
    double tracked = detail(report, "tracked"), failed = detail(report, "not_converged");
    CHECK(detail(report, "influenced") > 0 && detail(report, "influenced") <= n);
    CHECK(detail(report, "unit") > 0 && isfinite(detail(report, "unit")));
    CHECK(tracked > 0);
    CHECK(detail(report, "converged") + failed == tracked);
    CHECK(detail(report, "failed") == failed); /* the array lists every one */
    for (size_t i = 0; i + 1 < failed; i++)
        CHECK(detail_at(report, "failed", i) < detail_at(report, "failed", i + 1));
    CHECK(detail(report, "iterations") >= tracked);
    CHECK(isfinite(detail(report, "max_field_error")));
    CHECK(detail(report, "regularised") == 0);
    CHECK(report->constraint_count == 0);
}

static ffd_mesh *read_example(const char *mesh_name)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", EXAMPLES, mesh_name);
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read(path, &mesh, &err));
    return mesh;
}

static ffd_status apply_example(const char *rig_name, ffd_mesh *mesh, ffd_rig_report *report)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", EXAMPLES, rig_name);
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    ffd_status s = ffd_rig_read(path, &rig, &err);
    if (s == FFD_OK)
        s = ffd_rig_apply(rig, mesh, report, &err);
    if (s != FFD_OK)
        fprintf(stderr, "%s: %s\n", rig_name, err.message);
    ffd_rig_destroy(rig);
    return s;
}

static double segment_distance(const double p[3], const double a[3], const double b[3])
{
    double d[3], w[3], dd = 0, dw = 0;
    for (int k = 0; k < 3; k++) {
        d[k] = b[k] - a[k];
        w[k] = p[k] - a[k];
        dd += d[k] * d[k];
        dw += d[k] * w[k];
    }
    double t = dd > 0 ? fmax(0, fmin(1, dw / dd)) : 0, r = 0;
    for (int k = 0; k < 3; k++)
        r += (w[k] - t * d[k]) * (w[k] - t * d[k]);
    return sqrt(r);
}

/* 1 when the bunny vertex is farther than margin x radius from every
 * primitive of twist.json's rest skeleton (a lower bound of the distance to
 * the head's octahedron: to its centre less its circumradius 1.2). */
static int far_from_twist_skeleton(const double p[3], double margin)
{
    static const double head[3] = {-3.2, 6.4, 1.1};
    static const double ears[2][3] = {{-2.6, 7.6, 0.2}, {-1.3, 9.3, -1.6}};
    static const double body[3][3] = {{3.0, 3.0, 0.8}, {0.5, 3.5, 0.8}, {-1.0, 4.5, 0.9}};
    double dh = segment_distance(p, head, head) - 1.2;
    double de = segment_distance(p, ears[0], ears[1]);
    double db = fmin(segment_distance(p, body[0], body[1]), segment_distance(p, body[1], body[2]));
    return dh > margin * 2.5 && de > margin * 1.2 && db > margin * 2.5;
}

static void test_apply_twist(void)
{
    ffd_mesh *mesh = read_example("bunny.obj");
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh), nf = ffd_mesh_face_count(mesh);
    double *rest = copy_positions(mesh);
    ffd_rig_report report = {0};
    CHECK_OK(apply_example("twist.json", mesh, &report));
    check_track_report(&report, ffd_mesh_vertex_count(mesh));
    CHECK(detail(&report, "not_converged") == 0);
    /* the band where the ears' influence ends stretches: resampling splits
     * it, and no edge is left long */
    CHECK(detail_has(&report, "resample") == 1 && resampled(&report, "added_vertices") > 0);
    CHECK(resampled(&report, "long_edges") == 0 && !resampled(&report, "capped"));
    CHECK(ffd_mesh_vertex_count(mesh) == n + resampled(&report, "added_vertices") &&
          ffd_mesh_face_count(mesh) > nf);
    /* the skeleton in the report: 6 + 2 + 3 vertices; the body polyline held still */
    CHECK(report.control_count == 11);
    if (report.control_count == 11) {
        CHECK(report.control_points[3 * 8] == 3.0 && report.control_points[3 * 10 + 2] == 0.9);
        /* the ears' first vertex turned 0.6 rad about y through (-2.6, 5.5, 1.0) */
        double dx = -2.6 - -2.6, dz = 0.2 - 1.0, c = cos(0.6), s = sin(0.6);
        CHECK_NEAR(report.control_points[3 * 6], -2.6 + c * dx + s * dz, 1e-12);
        CHECK_NEAR(report.control_points[3 * 6 + 1], 7.6, 1e-12);
        CHECK_NEAR(report.control_points[3 * 6 + 2], 1.0 - s * dx + c * dz, 1e-12);
    }
    const double *p = ffd_mesh_positions(mesh);
    size_t unchanged = 0, far = 0, far_moved = 0, head_moved = 0;
    for (size_t i = 0; i < n; i++) {
        int changed = memcmp(p + 3 * i, rest + 3 * i, 3 * sizeof *p) != 0;
        CHECK(isfinite(p[3 * i]) && isfinite(p[3 * i + 1]) && isfinite(p[3 * i + 2]));
        unchanged += !changed;
        if (far_from_twist_skeleton(rest + 3 * i, 1.25)) {
            far++;
            far_moved += changed;
        }
        if (rest[3 * i] < -3 && rest[3 * i + 1] > 5) /* the head */
            head_moved += changed;
    }
    /* vertices outside every influence region never move */
    CHECK(unchanged >= n - detail(&report, "influenced"));
    CHECK(far > 100);
    CHECK(far_moved == 0);
    CHECK(head_moved > 10);
    ffd_rig_report_free(&report);

    /* gradient tracking: where the field did not change (the body, x > 2),
     * nothing moves, bitwise */
    ffd_mesh_destroy(mesh);
    mesh = read_example("bunny.obj");
    if (!mesh) {
        free(rest);
        return;
    }
    p = ffd_mesh_positions(mesh);
    CHECK_OK(apply_json(G "\"tracking\": \"gradient\", \"skeleton\": ["
                          "{\"type\": \"polyhedron\", \"file\": \"" EXAMPLES "/head.off\", \"radius\": 2.5},"
                          " {\"type\": \"polyline\", \"vertices\": [[-2.6, 7.6, 0.2], [-1.3, 9.3, -1.6]],"
                          "  \"radius\": 1.2},"
                          " {\"type\": \"polyline\", \"vertices\": [[3.0, 3.0, 0.8], [0.5, 3.5, 0.8],"
                          "  [-1.0, 4.5, 0.9]], \"radius\": 2.5}],"
                          " \"edits\": [{\"primitive\": 0, \"rotate\": {\"axis\": [0, 1, 0],"
                          "  \"angle\": 0.6}, \"center\": [-2.6, 5.5, 1.0]}, {\"primitive\": 1,"
                          "  \"rotate\": {\"axis\": [0, 1, 0], \"angle\": 0.6}, \"center\": [-2.6, 5.5, 1.0]}]}",
                        mesh, &report, NULL));
    check_track_report(&report, n);
    CHECK(detail(&report, "not_converged") == 0);
    far = far_moved = head_moved = 0;
    for (size_t i = 0; i < n; i++) {
        int changed = memcmp(p + 3 * i, rest + 3 * i, 3 * sizeof *p) != 0;
        if (rest[3 * i] > 2) {
            far++;
            far_moved += changed;
        }
        if (rest[3 * i] < -3 && rest[3 * i + 1] > 5)
            head_moved += changed;
    }
    CHECK(far > 100);
    CHECK(far_moved == 0);
    CHECK(head_moved > 10);
    ffd_rig_report_free(&report);
    free(rest);
    ffd_mesh_destroy(mesh);
}

static void test_apply_bend_resample(void)
{
    ffd_mesh *mesh = read_example("elephant.off");
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh), nf = ffd_mesh_face_count(mesh);
    double *rest = copy_positions(mesh);
    ffd_rig_report report = {0};
    CHECK_OK(apply_example("bend.json", mesh, &report));
    check_track_report(&report, ffd_mesh_vertex_count(mesh));
    CHECK(detail_has(&report, "resample") == 1);
    CHECK(resampled(&report, "rounds") >= 1 && resampled(&report, "added_vertices") > 0);
    CHECK(resampled(&report, "split_edges") >= resampled(&report, "added_vertices"));
    CHECK(ffd_mesh_vertex_count(mesh) == n + resampled(&report, "added_vertices"));
    CHECK(ffd_mesh_face_count(mesh) > nf);
    /* tracking covers the added vertices too */
    CHECK(detail(&report, "tracked") <= detail(&report, "influenced") + resampled(&report, "added_vertices"));
    /* the trunk's tip moved by the sum of its edit */
    CHECK(report.control_count == 5);
    if (report.control_count == 5) {
        CHECK_NEAR(report.control_points[12], 0.18 - 0.14, 1e-15);
        CHECK_NEAR(report.control_points[13], 0.46 - 0.06, 1e-15);
        CHECK(report.control_points[0] == 0.23 && report.control_points[1] == 0.16);
    }
    /* the original vertices keep their ids; the far ones do not move */
    const double *p = ffd_mesh_positions(mesh);
    size_t moved_left = 0, far_moved = 0;
    size_t m = ffd_mesh_vertex_count(mesh) < n ? ffd_mesh_vertex_count(mesh) : n;
    for (size_t i = 0; i < m; i++) {
        double dy = rest[3 * i + 1] - 0.3, dx = rest[3 * i] - 0.2;
        if (sqrt(dx * dx + dy * dy) > 0.6)
            far_moved += memcmp(p + 3 * i, rest + 3 * i, 3 * sizeof *p) != 0;
        moved_left += p[3 * i] < rest[3 * i] - 0.01;
    }
    for (size_t i = 0; i < 3 * ffd_mesh_vertex_count(mesh); i++)
        if (!isfinite(p[i])) {
            CHECK(!"non-finite position after resampling");
            break;
        }
    CHECK(moved_left > 10);
    CHECK(far_moved == 0);
    /* the refined mesh is valid: it writes and reads back with the same counts */
    unsigned char *data = NULL;
    size_t size = 0;
    ffd_error err = {{0}};
    ffd_write_options wo = {FFD_FORMAT_OFF, FFD_ENCODING_SAME, 0};
    CHECK_OK(ffd_mesh_write_memory(mesh, &wo, &data, &size, &err));
    if (data) {
        ffd_mesh *back = NULL;
        CHECK_OK(ffd_mesh_read_memory(data, size, FFD_FORMAT_OFF, "refined.off", &back, &err));
        if (back) {
            CHECK(ffd_mesh_vertex_count(back) == ffd_mesh_vertex_count(mesh));
            CHECK(ffd_mesh_face_count(back) == ffd_mesh_face_count(mesh));
            const uint32_t *off = ffd_mesh_face_offsets(back), *idx = ffd_mesh_face_indices(back);
            size_t bad = 0;
            for (size_t c = 0; c < off[ffd_mesh_face_count(back)]; c++)
                bad += idx[c] >= ffd_mesh_vertex_count(back);
            CHECK(bad == 0);
            ffd_mesh_destroy(back);
        }
        ffd_free(data);
    }
    ffd_rig_report_free(&report);
    free(rest);
    ffd_mesh_destroy(mesh);
}

static void test_apply_replace(void)
{
    ffd_mesh *mesh = read_example("cow.off");
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh);
    double *rest = copy_positions(mesh);
    ffd_rig_report report = {0};
    CHECK_OK(apply_example("replace.json", mesh, &report));
    check_track_report(&report, n);
    CHECK(ffd_mesh_vertex_count(mesh) == n);
    CHECK(report.control_count == 4);
    if (report.control_count == 4) /* the replacement's (sagging) vertices */
        CHECK(report.control_points[4] == 0.00 && report.control_points[7] == 0.00);
    /* the middle of the spine sags: vertices near its middle move down on average */
    const double *p = ffd_mesh_positions(mesh);
    double dy = 0;
    size_t mid = 0;
    for (size_t i = 0; i < n; i++) {
        CHECK(isfinite(p[3 * i + 1]));
        if (fabs(rest[3 * i]) < 0.1) {
            dy += p[3 * i + 1] - rest[3 * i + 1];
            mid++;
        }
    }
    CHECK(mid > 0 && dy / (double)mid < -0.01);
    ffd_rig_report_free(&report);
    free(rest);
    ffd_mesh_destroy(mesh);
}

/* A failing rig after a successful parse leaves a real mesh untouched. */
static void test_apply_bad_keeps_mesh(void)
{
    ffd_mesh *mesh = read_example("elephant.off");
    if (!mesh)
        return;
    /* the bend example with a last edit that makes the tip meet vertex 3 */
    apply_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"" EXAMPLES "/trunk.obj\","
                " \"radius\": 0.12}], \"tracking\": \"warp\", \"resample\": true,"
                " \"edits\": [{\"primitive\": 0, \"vertex\": 2, \"move\": [-0.02, 0.0, 0.0]},"
                "  {\"primitive\": 0, \"vertex\": 4, \"move\": [-0.02, -0.07, 0.04]}]}",
              mesh, FFD_ERR_INVALID,
              "rig.json: edits[1]: skeleton[0]: zero-length segment between vertices 3 and 4");
    apply_bad(G "\"skeleton\": [{\"type\": \"polyline\", \"file\": \"" EXAMPLES "/trunk.obj\","
                " \"radius\": 0.12}], \"unit\": 1e-5, \"resample\": true,"
                " \"edits\": [{\"primitive\": 0, \"vertex\": 2, \"move\": [-0.02, 0.0, 0.0]}]}",
              mesh, FFD_ERR_INVALID, "rig.json: skeleton: unit 1e-05 is too small for this skeleton");
    ffd_mesh_destroy(mesh);
}

/* A rig's rotation of the whole skeleton reaches every vertex, whatever the
 * skeleton: one point, two points, a straight polyline, a patch and a
 * polyhedron, turned about an off-centre point and about their own centroid
 * (no "center"), with the influence region covering the grid (radius 3 over
 * [-1,1]^3, so every vertex lies deeper than the band): each vertex moves
 * by exactly that rotation (1e-12), in both tracking modes. Before, a point
 * turned about an off-centre point translated the vertices, and about itself
 * moved nothing. */
static void test_apply_rigid_any_skeleton(void)
{
    static const char *const skeletons[] = {
        "{\"type\": \"point\", \"position\": [0.1, 0.2, -0.1], \"radius\": 3}",
        "{\"type\": \"point\", \"position\": [-0.4, 0, 0], \"radius\": 3},"
        " {\"type\": \"point\", \"position\": [0.4, 0.1, 0], \"radius\": 3}",
        "{\"type\": \"polyline\", \"vertices\": [[-0.5,0,0],[0,0,0],[0.5,0,0]], \"radius\": 3}",
        "{\"type\": \"patch\", \"vertices\": [[-0.5,-0.5,0],[0.5,-0.5,0],[0.5,0.5,0],[-0.5,0.5,0]],"
        " \"faces\": [[0,1,2,3]], \"radius\": 3}",
        "{\"type\": \"polyhedron\", \"vertices\": " TET_VERTS ", \"faces\": " TET_FACES
        ", \"radius\": 3}",
    };
    static const double centroid[5][3] = {
        {0.1, 0.2, -0.1}, {0, 0.05, 0}, {0, 0, 0}, {0, 0, 0}, {0.25, 0.25, 0.25}};
    const double axis[3] = {0.3, -0.5, 0.8}, angle = 0.7, off[3] = {1.5, -1.0, 0.4};
    double l = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    double k[3] = {axis[0] / l, axis[1] / l, axis[2] / l};
    for (size_t sk = 0; sk < sizeof skeletons / sizeof *skeletons; sk++)
        for (int about = 0; about < 2; about++)
            for (int mode = 0; mode < 2; mode++) {
                ffd_mesh *mesh = grid_mesh(9);
                size_t n = ffd_mesh_vertex_count(mesh);
                double *rest = copy_positions(mesh);
                char json[1024], edits[512] = "";
                size_t count = sk == 1 ? 2 : 1;
                for (size_t j = 0; j < count; j++) {
                    char one[200];
                    if (about == 0)
                        snprintf(one, sizeof one,
                                 "%s{\"primitive\": %zu, \"rotate\": {\"axis\": [0.3, -0.5, 0.8],"
                                 " \"angle\": 0.7}, \"center\": [1.5, -1.0, 0.4]}",
                                 j ? ", " : "", j);
                    else /* about the centroid of all the skeleton's vertices */
                        snprintf(one, sizeof one,
                                 "%s{\"primitive\": \"all\", \"rotate\": {\"axis\": [0.3, -0.5, 0.8],"
                                 " \"angle\": 0.7}}",
                                 j ? ", " : "");
                    if (about == 0 || j == 0)
                        strcat(edits, one);
                }
                snprintf(json, sizeof json,
                         G "\"tracking\": \"%s\", \"skeleton\": [%s], \"edits\": [%s]}",
                         mode ? "warp" : "gradient", skeletons[sk], edits);
                ffd_rig_report report = {0};
                ffd_error err = {{0}};
                CHECK_OK(apply_json(json, mesh, &report, &err));
                CHECK(detail(&report, "influenced") == n && detail(&report, "not_converged") == 0);
                const double *c = about ? centroid[sk] : off;
                const double *p = ffd_mesh_positions(mesh);
                double worst = 0, most = 0, cs = cos(angle), sn = sin(angle);
                for (size_t i = 0; i < n; i++) {
                    double d[3], want[3];
                    for (int a = 0; a < 3; a++)
                        d[a] = rest[3 * i + a] - c[a];
                    double kd = k[0] * d[0] + k[1] * d[1] + k[2] * d[2];
                    double kx[3] = {k[1] * d[2] - k[2] * d[1], k[2] * d[0] - k[0] * d[2],
                                    k[0] * d[1] - k[1] * d[0]};
                    double m = 0;
                    for (int a = 0; a < 3; a++) {
                        want[a] = c[a] + d[a] * cs + kx[a] * sn + k[a] * kd * (1 - cs);
                        worst = fmax(worst, fabs(p[3 * i + a] - want[a]) / fmax(1, fabs(want[a])));
                        m += (p[3 * i + a] - rest[3 * i + a]) * (p[3 * i + a] - rest[3 * i + a]);
                    }
                    most = fmax(most, sqrt(m));
                }
                if (!(worst <= 1e-12))
                    fprintf(stderr, "  skeleton %zu about %s, %s tracking: %.3g off the rotation\n",
                            sk, about ? "itself" : "an off-centre point",
                            mode ? "warp" : "gradient", worst);
                CHECK(worst <= 1e-12);
                CHECK(most > 0.5);
                ffd_rig_report_free(&report);
                free(rest);
                ffd_mesh_destroy(mesh);
            }
}

/* Edges of out between original vertices (ids < n) stretched by >= ratio
 * from their rest length. */
static size_t stretched_edges(const double *rest, size_t n, const ffd_mesh *out, double ratio)
{
    const double *p = ffd_mesh_positions(out);
    const uint32_t *off = ffd_mesh_face_offsets(out), *idx = ffd_mesh_face_indices(out);
    size_t count = 0;
    for (size_t f = 0; f < ffd_mesh_face_count(out); f++)
        for (uint32_t c = off[f]; c < off[f + 1]; c++) {
            uint32_t a = idx[c], b = idx[c + 1 < off[f + 1] ? c + 1 : off[f]];
            if (a >= n || b >= n || a > b) /* each interior edge once (consistent orientation) */
                continue;
            double lr = 0, ld = 0;
            for (int k = 0; k < 3; k++) {
                lr += (rest[3 * a + k] - rest[3 * b + k]) * (rest[3 * a + k] - rest[3 * b + k]);
                ld += (p[3 * a + k] - p[3 * b + k]) * (p[3 * a + k] - p[3 * b + k]);
            }
            count += ld >= ratio * ratio * lr;
        }
    return count;
}

/* The examples do not tear: no edge between original vertices is stretched
 * beyond the resampling ratio (1.8) unless the report counts it among the
 * long edges it could not split. (Before the influence band and the
 * resampling of twist.json, the twist left 90 such edges, up to 9.8 times
 * their length, that nothing reported.) */
static void test_apply_examples_no_tear(void)
{
    static const char *const cases[][2] = {
        {"bend.json", "elephant.off"}, {"twist.json", "bunny.obj"}, {"replace.json", "cow.off"}};
    for (size_t c = 0; c < 3; c++) {
        ffd_mesh *mesh = read_example(cases[c][1]);
        if (!mesh)
            continue;
        size_t n = ffd_mesh_vertex_count(mesh);
        double *rest = copy_positions(mesh);
        ffd_rig_report report = {0};
        CHECK_OK(apply_example(cases[c][0], mesh, &report));
        size_t long_edges = stretched_edges(rest, n, mesh, 1.8);
        if (long_edges > resampled(&report, "long_edges"))
            fprintf(stderr, "  %s: %zu edges stretched >= 1.8, the report counts %g\n",
                    cases[c][0], long_edges, resampled(&report, "long_edges"));
        CHECK(long_edges <= resampled(&report, "long_edges"));
        CHECK(detail(&report, "not_converged") == 0);
        ffd_rig_report_free(&report);
        free(rest);
        ffd_mesh_destroy(mesh);
    }
}

/* Scale invariance: the bunny and the twist rig scaled by 1000 give the
 * unscaled result scaled by 1000 (the default unit follows the model). */
static char *twist_rig(double s)
{
    ffd_mesh *head = read_example("head.off");
    if (!head)
        return NULL;
    size_t cap = 8192, len = 0;
    char *json = malloc(cap);
    len += (size_t)snprintf(json + len, cap - len,
                            G "\"tracking\": \"warp\", \"resample\": true,"
                              " \"skeleton\": [{\"type\": \"polyhedron\","
                              " \"radius\": %.17g, \"vertices\": [", 2.5 * s);
    const double *v = ffd_mesh_positions(head);
    for (size_t i = 0; i < ffd_mesh_vertex_count(head); i++)
        len += (size_t)snprintf(json + len, cap - len, "%s[%.17g, %.17g, %.17g]", i ? ", " : "",
                                v[3 * i] * s, v[3 * i + 1] * s, v[3 * i + 2] * s);
    len += (size_t)snprintf(json + len, cap - len, "], \"faces\": [");
    const uint32_t *off = ffd_mesh_face_offsets(head), *idx = ffd_mesh_face_indices(head);
    for (size_t f = 0; f < ffd_mesh_face_count(head); f++) {
        len += (size_t)snprintf(json + len, cap - len, "%s[", f ? ", " : "");
        for (uint32_t c = off[f]; c < off[f + 1]; c++)
            len += (size_t)snprintf(json + len, cap - len, "%s%u", c > off[f] ? ", " : "", idx[c]);
        len += (size_t)snprintf(json + len, cap - len, "]");
    }
    len += (size_t)snprintf(
        json + len, cap - len,
        "]}, {\"type\": \"polyline\", \"vertices\": [[%.17g, %.17g, %.17g], [%.17g, %.17g, %.17g]],"
        " \"radius\": %.17g},"
        " {\"type\": \"polyline\", \"vertices\": [[%.17g, %.17g, %.17g], [%.17g, %.17g, %.17g],"
        " [%.17g, %.17g, %.17g]], \"radius\": %.17g}],"
        " \"edits\": [{\"primitive\": 0, \"rotate\": {\"axis\": [0, 1, 0], \"angle\": 0.6},"
        " \"center\": [%.17g, %.17g, %.17g]}, {\"primitive\": 1, \"rotate\": {\"axis\": [0, 1, 0],"
        " \"angle\": 0.6}, \"center\": [%.17g, %.17g, %.17g]}]}",
        -2.6 * s, 7.6 * s, 0.2 * s, -1.3 * s, 9.3 * s, -1.6 * s, 1.2 * s, 3.0 * s, 3.0 * s,
        0.8 * s, 0.5 * s, 3.5 * s, 0.8 * s, -1.0 * s, 4.5 * s, 0.9 * s, 2.5 * s, -2.6 * s, 5.5 * s,
        1.0 * s, -2.6 * s, 5.5 * s, 1.0 * s);
    CHECK(len < cap);
    ffd_mesh_destroy(head);
    return json;
}

static void test_apply_scale_invariance(void)
{
    ffd_mesh *small = read_example("bunny.obj"), *big = read_example("bunny.obj");
    char *json1 = twist_rig(1), *json1000 = twist_rig(1000);
    if (!small || !big || !json1 || !json1000)
        goto done;
    size_t n = ffd_mesh_vertex_count(small);
    double *scaled = copy_positions(big);
    for (size_t i = 0; i < 3 * n; i++)
        scaled[i] *= 1000;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_set_positions(big, scaled, NULL, &err));
    free(scaled);

    /* the inline rig at scale 1 is the example, bit for bit */
    ffd_mesh *example = read_example("bunny.obj");
    ffd_rig_report r0 = {0}, r1 = {0}, r1000 = {0};
    CHECK_OK(apply_example("twist.json", example, &r0));
    CHECK_OK(apply_json(json1, small, &r1, &err));
    CHECK_OK(apply_json(json1000, big, &r1000, &err));
    CHECK(memcmp(ffd_mesh_positions(example), ffd_mesh_positions(small), 3 * n * sizeof(double)) == 0);
    CHECK(detail(&r0, "unit") == detail(&r1, "unit"));

    CHECK_NEAR(detail(&r1000, "unit") / detail(&r1, "unit"), 1000, 1e-9);
    CHECK(detail(&r1000, "influenced") == detail(&r1, "influenced"));
    CHECK(detail(&r1000, "not_converged") == 0 && detail(&r1, "not_converged") == 0);
    CHECK(detail(&r1000, "tracked") == detail(&r1, "tracked"));
    const double *a = ffd_mesh_positions(small), *b = ffd_mesh_positions(big);
    double worst = 0, moved = 0;
    for (size_t i = 0; i < n; i++) {
        double d = 0, norm = 0;
        for (int k = 0; k < 3; k++) {
            double e = b[3 * i + k] - 1000 * a[3 * i + k];
            d += e * e;
            norm += 1e6 * a[3 * i + k] * a[3 * i + k];
        }
        /* relative to the point's distance from the origin, at least 1 model unit */
        double rel = sqrt(d) / fmax(sqrt(norm), 1000.0);
        if (rel > worst)
            worst = rel;
    }
    /* the twist did something, so the comparison means something */
    ffd_mesh *orig = read_example("bunny.obj");
    if (orig) {
        const double *o = ffd_mesh_positions(orig);
        for (size_t i = 0; i < 3 * n; i++)
            if (fabs(a[i] - o[i]) > moved)
                moved = fabs(a[i] - o[i]);
        ffd_mesh_destroy(orig);
    }
    CHECK(moved > 0.1);
    if (!(worst <= 1e-6))
        fprintf(stderr, "  worst relative difference %.3g\n", worst);
    CHECK(worst <= 1e-6);
    ffd_rig_report_free(&r0);
    ffd_rig_report_free(&r1);
    ffd_rig_report_free(&r1000);
    ffd_mesh_destroy(example);
done:
    free(json1);
    free(json1000);
    ffd_mesh_destroy(small);
    ffd_mesh_destroy(big);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"parse_every_key", test_parse_every_key},
        {"parse_bad", test_parse_bad},
        {"skeleton_files", test_skeleton_files},
        {"relative_files", test_relative_files},
        {"apply_bad", test_apply_bad},
        {"apply_identity", test_apply_identity},
        {"apply_twist", test_apply_twist},
        {"apply_bend_resample", test_apply_bend_resample},
        {"apply_replace", test_apply_replace},
        {"apply_bad_keeps_mesh", test_apply_bad_keeps_mesh},
        {"apply_scale_invariance", test_apply_scale_invariance},
        {"apply_rigid_any_skeleton", test_apply_rigid_any_skeleton},
        {"apply_examples_no_tear", test_apply_examples_no_tear},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
