/* The editor's "create" body is the creation part of a rig (issue 15, "one
 * schema per method"): for every method a create body and the same keys
 * loaded as a rig give the same deformer (state, rig, frame bytes); the old
 * body forms ("method", PB-FFD's top-level placement keys) and the editor's
 * defaults (PB-FFD 60/60, GFFD's default polyline) still give what they
 * gave; a bad value gets the rig reader's message; keys that are not part
 * of creating a deformer are refused by name. */
#include "check.h"
#include "ffd.h"

#include <cJSON.h>
#include <stdlib.h>

#define BUNNY FFD_SOURCE_DIR "/examples/lattice/bunny.obj"
#define COW_PB FFD_SOURCE_DIR "/examples/pbffd/cow.off"
#define COW_GFFD FFD_SOURCE_DIR "/examples/gffd/cow.off"
#define COW_TSV FFD_SOURCE_DIR "/examples/tspline/cow.off"

static ffd_session *open_session(const char *path)
{
    ffd_mesh *mesh = NULL;
    ffd_session *s = NULL;
    CHECK_OK(ffd_mesh_read(path, &mesh, NULL));
    if (mesh)
        CHECK_OK(ffd_session_create(mesh, "mesh", NULL, &s, NULL));
    return s;
}

static ffd_status run(ffd_session *s, const char *op, const char *body, ffd_error *err)
{
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    ffd_status st =
        ffd_session_command(s, op, body, body ? strlen(body) : 0, &reply, &size, &binary, err);
    ffd_free(reply);
    return st;
}

/* The session's state without what says how it got there (timing, the
 * undo entry's label), its rig, and its frame. */
typedef struct snapshot {
    char *state, *rig;
    void *frame;
    size_t frame_size;
} snapshot;

static int take(ffd_session *s, snapshot *out)
{
    size_t size = 0;
    memset(out, 0, sizeof *out);
    if (ffd_session_state(s, &out->state, &size, NULL) || ffd_session_rig(s, &out->rig, &size, NULL) ||
        ffd_session_frame(s, &out->frame, &out->frame_size, NULL))
        return 0;
    char *cut = strstr(out->state, ",\"busy_ms\"");
    if (cut)
        *cut = 0;
    return 1;
}

static void release(snapshot *a)
{
    ffd_free(a->state);
    ffd_free(a->rig);
    ffd_free(a->frame);
}

/* create with body on one session, load rig on another: the same deformer. */
static void same_deformer(const char *mesh, const char *body, const char *rig)
{
    ffd_session *a = open_session(mesh), *b = open_session(mesh);
    ffd_error err = {{0}};
    snapshot x, y;
    if (!a || !b)
        goto done;
    if (run(a, "create", body, &err)) {
        fprintf(stderr, "  create %s: %s\n", body, err.message);
        CHECK(0);
        goto done;
    }
    if (ffd_session_load_rig(b, rig, strlen(rig), "rig.json", NULL, &err)) {
        fprintf(stderr, "  load %s: %s\n", rig, err.message);
        CHECK(0);
        goto done;
    }
    int ok = take(a, &x) && take(b, &y);
    CHECK(ok);
    if (ok) {
        CHECK(strcmp(x.state, y.state) == 0);
        CHECK(strcmp(x.rig, y.rig) == 0);
        CHECK(x.frame_size == y.frame_size && memcmp(x.frame, y.frame, x.frame_size) == 0);
        if (strcmp(x.state, y.state) || strcmp(x.rig, y.rig))
            fprintf(stderr, "  body %s\n  rig  %s\n", body, rig);
    }
    release(&x);
    release(&y);
done:
    ffd_session_destroy(a);
    ffd_session_destroy(b);
}

static void test_lattice(void)
{
    same_deformer(BUNNY,
                  "{\"deformer\":\"lattice\",\"resolution\":[4,5,6],\"basis\":\"bernstein\","
                  "\"margin\":0.1,\"outside\":\"clamp\"}",
                  "{\"deformer\":\"lattice\",\"resolution\":[4,5,6],\"basis\":\"bernstein\","
                  "\"margin\":0.1,\"outside\":\"clamp\"}");
    const char *box = "\"box\":{\"origin\":[-6,-1,-5],\"axes\":[[12,0,0],[0,12,0],[0,0,10]]}";
    char body[256], rig[256];
    snprintf(body, sizeof body, "{\"deformer\":\"lattice\",\"version\":1,%s}", box);
    snprintf(rig, sizeof rig, "{\"deformer\":\"lattice\",%s}", box);
    same_deformer(BUNNY, body, rig);
    /* the old form, and the defaults (5x5x5 B-spline, margin 0.05) */
    same_deformer(BUNNY, "{\"method\":\"lattice\",\"resolution\":[4,5,6]}",
                  "{\"deformer\":\"lattice\",\"resolution\":[4,5,6]}");
    same_deformer(BUNNY, "{\"method\":\"lattice\",\"deformer\":\"lattice\"}", "{}");
}

static void test_pbffd(void)
{
    const char *rig = "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":16,\"exterior\":16},"
                      "\"levels\":2,\"sigma\":2.5}";
    same_deformer(COW_PB, rig, rig);
    /* the old form: placement counts at the top level */
    same_deformer(COW_PB,
                  "{\"method\":\"pbffd\",\"interior\":16,\"exterior\":16,\"levels\":2,"
                  "\"sigma\":2.5}",
                  rig);
    same_deformer(COW_PB,
                  "{\"method\":\"pbffd\",\"interior\":16,\"exterior\":12,\"offset\":0.1,"
                  "\"radius_factor\":2,\"voronoi_sites\":40}",
                  "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":16,\"exterior\":12,"
                  "\"offset\":0.1,\"radius_factor\":2,\"voronoi_sites\":40}}");
    /* the editor's default: automatic placement of 60 and 60 */
    same_deformer(COW_PB, "{\"deformer\":\"pbffd\"}",
                  "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":60,\"exterior\":60}}");
    same_deformer(COW_PB, "{\"deformer\":\"pbffd\",\"exterior\":20,\"controls\":\"auto\"}",
                  "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":60,\"exterior\":20}}");
    same_deformer(COW_PB, "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":20}}",
                  "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":20,\"exterior\":60}}");
    /* an explicit control set, as a rig gives it */
    const char *given = "{\"deformer\":\"pbffd\",\"controls\":[{\"center\":[0,0,0],\"radius\":0.5},"
                        "{\"center\":[0.3,0,0],\"radius\":[0.4,0.3,0.3]}],\"master\":false}";
    same_deformer(COW_PB, given, given);
}

/* The editor's default skeleton, written out: one polyline of 5 vertices
 * along the mesh's longest axis through its box centre, spanning 80 % of
 * that extent, radius 0.3 times the diagonal. */
static char *default_gffd_rig(const char *path)
{
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read(path, &m, NULL));
    if (!m)
        return NULL;
    const double *x = ffd_mesh_positions(m);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < ffd_mesh_vertex_count(m); i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], x[3 * i + a]);
            hi[a] = fmax(hi[a], x[3 * i + a]);
        }
    ffd_mesh_destroy(m);
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (hi[a] - lo[a] > hi[axis] - lo[axis])
            axis = a;
    double d = 0;
    for (int a = 0; a < 3; a++)
        d += (hi[a] - lo[a]) * (hi[a] - lo[a]);
    cJSON *root = cJSON_CreateObject(), *prim = cJSON_CreateObject(), *v = cJSON_CreateArray();
    cJSON_AddStringToObject(root, "deformer", "gffd");
    cJSON_AddItemToArray(cJSON_AddArrayToObject(root, "skeleton"), prim);
    cJSON_AddStringToObject(prim, "type", "polyline");
    cJSON_AddItemToObject(prim, "vertices", v);
    for (int i = 0; i < 5; i++) {
        double p[3];
        for (int a = 0; a < 3; a++) {
            double c = 0.5 * (lo[a] + hi[a]);
            p[a] = a == axis ? c + 0.8 * (hi[axis] - lo[axis]) * ((double)i / 4 - 0.5) : c;
        }
        cJSON_AddItemToArray(v, cJSON_CreateDoubleArray(p, 3));
    }
    cJSON_AddNumberToObject(prim, "radius", 0.3 * sqrt(d));
    char *text = cJSON_PrintUnformatted(root); /* %1.17g: reads back exactly */
    cJSON_Delete(root);
    return text;
}

static void test_gffd(void)
{
    const char *skeleton = "\"skeleton\":[{\"type\":\"point\",\"position\":[0.1,0,0],\"radius\":0.3},"
                           "{\"type\":\"polyline\",\"vertices\":[[-0.3,0,0],[0.3,0.05,0]],"
                           "\"radius\":0.25}]";
    char body[512], rig[512];
    snprintf(body, sizeof body,
             "{\"deformer\":\"gffd\",\"unit\":0.12,\"tracking\":\"warp\",\"tolerance\":0.5,"
             "\"max_iterations\":50,\"max_samples\":500,%s}",
             skeleton);
    same_deformer(COW_GFFD, body, body);
    snprintf(body, sizeof body, "{\"method\":\"gffd\",\"unit\":0.12,%s}", skeleton);
    snprintf(rig, sizeof rig, "{\"deformer\":\"gffd\",\"unit\":0.12,%s}", skeleton);
    same_deformer(COW_GFFD, body, rig);
    char *def = default_gffd_rig(COW_GFFD);
    if (def) {
        same_deformer(COW_GFFD, "{\"method\":\"gffd\"}", def);
        same_deformer(COW_GFFD, "{\"deformer\":\"gffd\"}", def);
    }
    cJSON_free(def);
}

static void test_tspline(void)
{
    same_deformer(COW_TSV, "{\"deformer\":\"tspline\",\"resolution\":[5,4,6],\"padding\":0.05}",
                  "{\"deformer\":\"tspline\",\"resolution\":[5,4,6],\"padding\":0.05}");
    same_deformer(COW_TSV, "{\"method\":\"tspline\",\"resolution\":[4,4,4]}",
                  "{\"deformer\":\"tspline\",\"resolution\":[4,4,4]}");
    same_deformer(COW_TSV, "{\"method\":\"tspline\"}", "{\"deformer\":\"tspline\"}");
}

/* A bad value in a create body gets the message a rig named "create" gets. */
static void same_message(const char *mesh, const char *body, const char *rig)
{
    ffd_session *s = open_session(mesh);
    ffd_error a = {{0}}, b = {{0}};
    ffd_rig *r = NULL;
    ffd_status sa = s ? run(s, "create", body, &a) : FFD_OK;
    ffd_status sb = ffd_rig_parse_json(rig, strlen(rig), "create", &r, &b);
    CHECK(sa != FFD_OK && sa == sb);
    CHECK(strcmp(a.message, b.message) == 0);
    if (strcmp(a.message, b.message))
        fprintf(stderr, "  create: %s\n  rig:    %s\n", a.message, b.message);
    ffd_rig_destroy(r);
    ffd_session_destroy(s);
}

static void test_bad_values_as_in_rigs(void)
{
    same_message(BUNNY, "{\"deformer\":\"lattice\",\"resolution\":[1,5,5]}",
                 "{\"deformer\":\"lattice\",\"resolution\":[1,5,5]}");
    same_message(BUNNY, "{\"method\":\"lattice\",\"margin\":-1}",
                 "{\"deformer\":\"lattice\",\"margin\":-1}");
    same_message(BUNNY, "{\"method\":\"lattice\",\"basis\":\"cubic\"}",
                 "{\"deformer\":\"lattice\",\"basis\":\"cubic\"}");
    same_message(BUNNY, "{\"deformer\":\"lattice\",\"box\":{\"origin\":[0,0]}}",
                 "{\"deformer\":\"lattice\",\"box\":{\"origin\":[0,0]}}");
    /* PB-FFD: one placement reader, whichever form the body uses */
    same_message(COW_PB, "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":0}}",
                 "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":0}}");
    same_message(COW_PB, "{\"method\":\"pbffd\",\"interior\":0}",
                 "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":0}}");
    same_message(COW_PB, "{\"method\":\"pbffd\",\"offset\":2}",
                 "{\"deformer\":\"pbffd\",\"controls\":{\"offset\":2}}");
    same_message(COW_PB, "{\"method\":\"pbffd\",\"voronoi_sites\":3}",
                 "{\"deformer\":\"pbffd\",\"controls\":{\"voronoi_sites\":3}}");
    same_message(COW_PB, "{\"method\":\"pbffd\",\"levels\":40}",
                 "{\"deformer\":\"pbffd\",\"levels\":40}");
    same_message(COW_PB, "{\"method\":\"pbffd\",\"sigma\":0.01}",
                 "{\"deformer\":\"pbffd\",\"sigma\":0.01}");
    same_message(COW_GFFD, "{\"method\":\"gffd\",\"unit\":0}",
                 "{\"deformer\":\"gffd\",\"skeleton\":[{\"type\":\"point\",\"position\":[0,0,0],"
                 "\"radius\":1}],\"unit\":0}");
    same_message(COW_TSV, "{\"deformer\":\"tspline\",\"resolution\":[3,5,5]}",
                 "{\"deformer\":\"tspline\",\"resolution\":[3,5,5]}");
    same_message(COW_TSV, "{\"deformer\":\"tspline\",\"padding\":-1}",
                 "{\"deformer\":\"tspline\",\"padding\":-1}");
}

static void refused(const char *mesh, const char *body, ffd_status want, const char *fragment)
{
    ffd_session *s = open_session(mesh);
    ffd_error err = {{0}};
    if (!s)
        return;
    ffd_status st = run(s, "create", body, &err);
    CHECK(st == want);
    CHECK(strstr(err.message, fragment) != NULL);
    if (st != want || !strstr(err.message, fragment))
        fprintf(stderr, "  %s: %s\n", body, err.message);
    ffd_session_destroy(s);
}

static void test_refusals(void)
{
    refused(BUNNY, "{}", FFD_ERR_PARSE, "create: deformer: expected \"lattice\", \"pbffd\"");
    refused(BUNNY, "{\"deformer\":\"blob\"}", FFD_ERR_PARSE, "create: deformer: expected");
    refused(BUNNY, "{\"method\":\"blob\"}", FFD_ERR_PARSE, "create: method: expected");
    refused(BUNNY, "{\"method\":\"lattice\",\"deformer\":\"pbffd\"}", FFD_ERR_PARSE,
            "create: method: \"lattice\" and deformer: \"pbffd\"");
    /* what a rig does after creating its deformer comes with rig/load */
    refused(BUNNY, "{\"deformer\":\"lattice\",\"moves\":[]}", FFD_ERR_PARSE,
            "create: moves: unknown key");
    refused(BUNNY, "{\"deformer\":\"lattice\",\"constraints\":[]}", FFD_ERR_PARSE,
            "rig/load");
    refused(COW_PB, "{\"deformer\":\"pbffd\",\"frames\":[]}", FFD_ERR_PARSE,
            "create: frames: unknown key");
    refused(COW_GFFD, "{\"deformer\":\"gffd\",\"edits\":[]}", FFD_ERR_PARSE,
            "create: edits: unknown key");
    refused(COW_GFFD,
            "{\"deformer\":\"gffd\",\"replace\":[{\"type\":\"polyline\",\"file\":\"x.obj\","
            "\"radius\":1}]}",
            FFD_ERR_PARSE, "create: replace: unknown key");
    refused(COW_TSV, "{\"deformer\":\"tspline\",\"steps\":[]}", FFD_ERR_PARSE,
            "create: steps: unknown key");
    refused(BUNNY, "{\"deformer\":\"lattice\",\"colour\":1}", FFD_ERR_PARSE,
            "create: colour: unknown key");
    /* the old top-level placement keys are the old form of "controls" */
    refused(COW_PB, "{\"deformer\":\"pbffd\",\"interior\":20,\"controls\":{\"interior\":20}}",
            FFD_ERR_PARSE, "create: interior: given twice");
    refused(COW_PB,
            "{\"deformer\":\"pbffd\",\"interior\":20,\"controls\":[{\"center\":[0,0,0],"
            "\"radius\":1}]}",
            FFD_ERR_PARSE, "create: interior: a placement option");
    /* an editing session reads no files */
    refused(COW_GFFD,
            "{\"deformer\":\"gffd\",\"skeleton\":[{\"type\":\"polyline\",\"file\":\"spine.obj\","
            "\"radius\":1}]}",
            FFD_ERR_PARSE, "create: skeleton[0].file");
    refused(COW_GFFD, "{\"deformer\":\"gffd\",\"resample\":true}", FFD_ERR_INVALID,
            "create: resample: adaptive resampling");
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"lattice", test_lattice},
        {"pbffd", test_pbffd},
        {"gffd", test_gffd},
        {"tspline", test_tspline},
        {"bad_values_as_in_rigs", test_bad_values_as_in_rigs},
        {"refusals", test_refusals},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
