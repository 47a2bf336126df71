/* Several meshes in one session (ffd_session_add_mesh, remove_mesh,
 * ffd_session_deformed_mesh / export_mesh): the deformer binds the
 * concatenation of the meshes' vertices, and the session's rig replayed on
 * each mesh's file alone (what `ffd deform` does) gives that mesh's range of
 * the session's positions, for a lattice and for direct manipulation.
 * Also the session's side of "pins hard, drag soft" (state "manip"). */
#include "check.h"
#include "ffd.h"

#include <cJSON.h>
#include <stdint.h>
#include <stdlib.h>

#define BUNNY FFD_SOURCE_DIR "/examples/lattice/bunny.obj"
#define ELEPHANT FFD_SOURCE_DIR "/data/elephant.off"

static unsigned char *read_all(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    unsigned char *data = NULL;
    *size = 0;
    if (f && fseek(f, 0, SEEK_END) == 0) {
        long n = ftell(f);
        rewind(f);
        data = n >= 0 ? malloc((size_t)n + 1) : NULL;
        if (data && fread(data, 1, (size_t)n, f) == (size_t)n)
            *size = (size_t)n;
    }
    if (f)
        fclose(f);
    return data;
}

static ffd_session *open_session(const char *path, const char *name)
{
    ffd_mesh *mesh = NULL;
    ffd_session *s = NULL;
    CHECK_OK(ffd_mesh_read(path, &mesh, NULL));
    CHECK_OK(ffd_session_create(mesh, name, NULL, &s, NULL));
    return s;
}

static ffd_status add(ffd_session *s, const char *path, const char *name, ffd_error *err)
{
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_mesh_read(path, &mesh, NULL));
    ffd_status st = ffd_session_add_mesh(s, mesh, name, err);
    if (st)
        ffd_mesh_destroy(mesh); /* untouched on error: still ours */
    return st;
}

static ffd_status run(ffd_session *s, const char *op, const char *body, ffd_error *err)
{
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    ffd_error local = {{0}};
    ffd_status st = ffd_session_command(s, op, body, body ? strlen(body) : 0, &reply, &size,
                                        &binary, err ? err : &local);
    if (st && !err)
        fprintf(stderr, "  %s %s: %s\n", op, body ? body : "", local.message);
    ffd_free(reply);
    return st;
}

static cJSON *state(ffd_session *s)
{
    char *text = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_state(s, &text, &size, NULL));
    cJSON *doc = cJSON_Parse(text);
    ffd_free(text);
    return doc;
}

/* The frame's positions (doubles from float32), *n vertices. */
static double *frame(ffd_session *s, size_t *n)
{
    void *data = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_frame(s, &data, &size, NULL));
    uint32_t head[5];
    memcpy(head, data, 20);
    *n = head[2];
    double *p = malloc(3 * *n * sizeof *p);
    const float *f = (const float *)((char *)data + 20);
    for (size_t i = 0; i < 3 * *n; i++)
        p[i] = f[i];
    ffd_free(data);
    return p;
}

/* max |replay of the session's rig on path alone - the session's positions from first| */
static double replay_difference(ffd_session *s, const char *path, size_t first)
{
    char *text = NULL;
    size_t size = 0, n = 0;
    ffd_rig *rig = NULL;
    ffd_mesh *mesh = NULL;
    double worst = INFINITY;
    double *p = frame(s, &n);
    if (ffd_session_rig(s, &text, &size, NULL) == FFD_OK &&
        ffd_rig_parse_json(text, size, "session.json", &rig, NULL) == FFD_OK &&
        ffd_mesh_read(path, &mesh, NULL) == FFD_OK && ffd_rig_apply(rig, mesh, NULL, NULL) == FFD_OK &&
        first + ffd_mesh_vertex_count(mesh) <= n) {
        const double *x = ffd_mesh_positions(mesh);
        worst = 0;
        for (size_t i = 0; i < 3 * ffd_mesh_vertex_count(mesh); i++)
            worst = fmax(worst, fabs(x[i] - p[3 * first + i]));
    }
    free(p);
    ffd_mesh_destroy(mesh);
    ffd_rig_destroy(rig);
    ffd_free(text);
    return worst;
}

/* max change of a mesh's range between two frames */
static double range_change(const double *a, const double *b, size_t first, size_t count)
{
    double worst = 0;
    for (size_t i = 3 * first; i < 3 * (first + count); i++)
        worst = fmax(worst, fabs(a[i] - b[i]));
    return worst;
}

static void test_add_mesh_concatenates(void)
{
    ffd_session *s = open_session(BUNNY, "bunny.obj");
    size_t nb = ffd_mesh_vertex_count(ffd_session_mesh(s));
    size_t fb = ffd_mesh_face_count(ffd_session_mesh(s));
    CHECK(ffd_session_mesh_count(s) == 1);
    CHECK_OK(add(s, ELEPHANT, "elephant.off", NULL));
    CHECK(ffd_session_mesh_count(s) == 2);
    CHECK(!strcmp(ffd_session_mesh_name(s, 1), "elephant.off"));
    CHECK(!strcmp(ffd_session_name(s), "bunny.obj"));
    CHECK(ffd_session_mesh_name(s, 2) == NULL);
    size_t n = ffd_mesh_vertex_count(ffd_session_mesh(s));
    CHECK(n == nb + 2775);
    cJSON *doc = state(s);
    cJSON *meshes = cJSON_GetObjectItem(doc, "meshes");
    CHECK(cJSON_GetArraySize(meshes) == 2);
    cJSON *e = cJSON_GetArrayItem(meshes, 1);
    CHECK(cJSON_GetObjectItem(e, "first")->valuedouble == (double)nb);
    CHECK(cJSON_GetObjectItem(e, "vertices")->valuedouble == 2775);
    CHECK(!strcmp(cJSON_GetObjectItem(e, "name")->valuestring, "elephant.off"));
    CHECK(cJSON_GetObjectItem(cJSON_GetObjectItem(doc, "mesh"), "vertices")->valuedouble == (double)n);
    cJSON_Delete(doc);
    /* the topology's triangles of the elephant index its range */
    void *topo = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_topology(s, &topo, &size, NULL));
    uint32_t head[4];
    memcpy(head, topo, 16);
    CHECK(head[2] == n);
    const uint32_t *tri = (const uint32_t *)((char *)topo + 16 + 12 * (size_t)n);
    CHECK(tri[3 * fb] >= nb && tri[3 * (size_t)head[3] - 1] < n);
    uint32_t lo = UINT32_MAX;
    for (size_t t = 0; t < 3 * fb; t++)
        lo = tri[t] < lo ? tri[t] : lo;
    CHECK(lo == 0);
    ffd_free(topo);
    /* no deformer: each mesh exported alone is its file as read, byte for byte */
    void *bytes = NULL;
    size_t file_size = 0;
    CHECK_OK(ffd_session_export_mesh(s, 1, NULL, &bytes, &size, NULL));
    unsigned char *file = read_all(ELEPHANT, &file_size);
    CHECK(size == file_size && bytes && file && memcmp(bytes, file, size) == 0);
    ffd_free(bytes);
    free(file);
    ffd_error err = {{0}};
    CHECK(ffd_session_export_mesh(s, 2, NULL, &bytes, &size, &err) == FFD_ERR_RANGE);
    CHECK(bytes == NULL && strstr(err.message, "mesh 2 out of range (2 meshes)"));
    ffd_session_destroy(s);
}

/* A lattice around both: each file replayed alone is its range of the frame. */
static void test_lattice_replays_per_mesh(void)
{
    ffd_session *s = open_session(BUNNY, "bunny.obj");
    size_t nb = ffd_mesh_vertex_count(ffd_session_mesh(s));
    CHECK_OK(add(s, ELEPHANT, "elephant.off", NULL));
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[4,4,4]}", NULL) == FFD_OK);
    size_t n;
    double *rest = frame(s, &n);
    CHECK(run(s, "move", "{\"points\":[21,22,25,26],\"delta\":[0.3,0.4,-0.2]}", NULL) == FFD_OK);
    double *moved = frame(s, &n);
    CHECK(range_change(rest, moved, 0, nb) > 1e-3); /* both meshes move */
    CHECK(range_change(rest, moved, nb, 2775) > 1e-3);
    CHECK(replay_difference(s, BUNNY, 0) < 1e-5);
    CHECK(replay_difference(s, ELEPHANT, nb) < 1e-5);
    /* the exported mesh is the replay */
    ffd_mesh *one = NULL;
    CHECK_OK(ffd_session_deformed_mesh(s, 1, &one, NULL));
    CHECK(one && ffd_mesh_vertex_count(one) == 2775);
    if (one) {
        const double *x = ffd_mesh_positions(one);
        double worst = 0;
        for (size_t i = 0; i < 3 * 2775; i++)
            worst = fmax(worst, fabs(x[i] - moved[3 * nb + i]));
        CHECK(worst < 1e-5);
    }
    ffd_mesh_destroy(one);
    free(rest);
    free(moved);
    ffd_session_destroy(s);
}

/* Direct manipulation across meshes: a pin on the bunny, an elephant vertex
 * dragged; then the bunny removed: the elephant's pin shifts with it. */
static void test_direct_manipulation_per_mesh(void)
{
    ffd_session *s = open_session(BUNNY, "bunny.obj");
    size_t nb = ffd_mesh_vertex_count(ffd_session_mesh(s));
    CHECK_OK(add(s, ELEPHANT, "elephant.off", NULL));
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[6,6,6]}", NULL) == FFD_OK);
    char body[160];
    snprintf(body, sizeof body, "{\"vertex\":%zu}", nb + 100);
    CHECK(run(s, "pin", body, NULL) == FFD_OK);
    CHECK(run(s, "pin", "{\"vertex\":5}", NULL) == FFD_OK);
    size_t n;
    double *before = frame(s, &n);
    snprintf(body, sizeof body, "{\"vertex\":%zu}", nb + 2000);
    CHECK(run(s, "drag_begin", body, NULL) == FFD_OK);
    double t[3] = {before[3 * (nb + 2000)] + 0.05, before[3 * (nb + 2000) + 1] + 0.1,
                   before[3 * (nb + 2000) + 2]};
    snprintf(body, sizeof body, "{\"target\":[%.17g,%.17g,%.17g]}", t[0], t[1], t[2]);
    CHECK(run(s, "drag", body, NULL) == FFD_OK);
    ffd_error err = {{0}};
    ffd_mesh *extra = NULL;
    CHECK_OK(ffd_mesh_read(BUNNY, &extra, NULL));
    CHECK(ffd_session_add_mesh(s, extra, "again.obj", &err) == FFD_ERR_INVALID); /* mid-drag */
    CHECK(strstr(err.message, "a drag is in progress") != NULL);
    ffd_mesh_destroy(extra);
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    double *after = frame(s, &n);
    CHECK(range_change(before, after, nb, 2775) > 1e-3);
    CHECK(replay_difference(s, BUNNY, 0) < 1e-5);
    CHECK(replay_difference(s, ELEPHANT, nb) < 1e-5);
    /* removing the bunny keeps the deformation and the elephant's pin */
    CHECK(run(s, "remove_mesh", "{\"mesh\":0}", NULL) == FFD_OK);
    CHECK(ffd_session_mesh_count(s) == 1);
    CHECK(!strcmp(ffd_session_name(s), "elephant.off"));
    double *alone = frame(s, &n);
    CHECK(n == 2775);
    double worst = 0;
    for (size_t i = 0; i < 3 * n; i++)
        worst = fmax(worst, fabs(alone[i] - after[3 * nb + i]));
    CHECK(worst < 1e-5);
    cJSON *doc = state(s);
    cJSON *pins = cJSON_GetObjectItem(doc, "pins");
    CHECK(cJSON_GetArraySize(pins) == 1);
    CHECK(cJSON_GetObjectItem(cJSON_GetArrayItem(pins, 0), "vertex")->valuedouble == 100);
    CHECK(cJSON_GetObjectItem(doc, "undo")->valuedouble == 0); /* history cleared */
    CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(doc, "meshes")) == 1);
    cJSON_Delete(doc);
    CHECK(replay_difference(s, ELEPHANT, 0) < 1e-5);
    free(before);
    free(after);
    free(alone);
    ffd_session_destroy(s);
}

/* Adding a mesh to a deformed session keeps what the first mesh shows. */
static void test_add_keeps_the_deformation(void)
{
    ffd_session *s = open_session(BUNNY, "bunny.obj");
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[5,5,5]}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[62,63],\"delta\":[0.2,0.1,0]}", NULL) == FFD_OK);
    size_t n, n2;
    double *before = frame(s, &n);
    CHECK_OK(add(s, ELEPHANT, "elephant.off", NULL));
    double *after = frame(s, &n2);
    CHECK(n2 == n + 2775);
    CHECK(range_change(before, after, 0, n) < 1e-6);
    CHECK(replay_difference(s, ELEPHANT, n) < 1e-5);
    /* three meshes, the middle one removed: ranges close up */
    CHECK_OK(add(s, BUNNY, "bunny2.obj", NULL));
    CHECK(run(s, "remove_mesh", "{\"mesh\":1}", NULL) == FFD_OK);
    CHECK(ffd_session_mesh_count(s) == 2);
    CHECK(!strcmp(ffd_session_mesh_name(s, 1), "bunny2.obj"));
    CHECK(replay_difference(s, BUNNY, n) < 1e-5);
    free(before);
    free(after);
    ffd_session_destroy(s);
}

static void test_bad_requests(void)
{
    ffd_session *s = open_session(BUNNY, "bunny.obj");
    ffd_error err = {{0}};
    CHECK(run(s, "remove_mesh", "{\"mesh\":0}", &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "conflict: remove_mesh: the session's only mesh stays"));
    CHECK_OK(add(s, ELEPHANT, "elephant.off", NULL));
    CHECK(run(s, "remove_mesh", "{\"mesh\":2}", &err) == FFD_ERR_RANGE);
    CHECK(strstr(err.message, "mesh 2 out of range (2 meshes)"));
    CHECK(run(s, "remove_mesh", "{}", &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "mesh"));
    CHECK(run(s, "remove_mesh", "{\"mesh\":-1}", &err) == FFD_ERR_PARSE);
    CHECK(run(s, "remove_mesh", "{\"mesh\":0,\"all\":true}", &err) == FFD_ERR_PARSE);
    CHECK(ffd_session_mesh_count(s) == 2);
    /* a mesh without vertices is refused and stays the caller's */
    ffd_mesh *empty = NULL;
    CHECK_OK(ffd_mesh_create(NULL, 0, NULL, NULL, 0, &empty, NULL));
    CHECK(ffd_session_add_mesh(s, empty, "empty.obj", &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "empty.obj: the mesh has no vertices"));
    ffd_mesh_destroy(empty);
    CHECK(ffd_session_mesh_count(s) == 2);
    ffd_session_destroy(s);
}

/* Pins hard, drag soft in the session: a Bernstein lattice of 8 control
 * points held by 8 pins has no freedom left; dragging a ninth vertex moves
 * nothing, the pins stay exactly where they are, and the state reports the
 * drag's shortfall (the distance to its target) and that the pins held. */
static void test_pins_hard_drag_soft(void)
{
    ffd_session *s = open_session(BUNNY, "bunny.obj");
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[2,2,2],\"basis\":\"bernstein\"}",
              NULL) == FFD_OK);
    static const int pins[8] = {5, 100, 400, 700, 1000, 1300, 1600, 1800};
    char body[160];
    for (int i = 0; i < 8; i++) {
        snprintf(body, sizeof body, "{\"vertex\":%d}", pins[i]);
        CHECK(run(s, "pin", body, NULL) == FFD_OK);
    }
    size_t n;
    double *before = frame(s, &n);
    cJSON *doc = state(s);
    CHECK(cJSON_IsObject(cJSON_GetObjectItem(doc, "manip")));
    cJSON_Delete(doc);
    CHECK(run(s, "drag_begin", "{\"vertex\":900}", NULL) == FFD_OK);
    double t[3] = {before[2700] + 0.3, before[2701] - 0.2, before[2702] + 0.1};
    snprintf(body, sizeof body, "{\"target\":[%.17g,%.17g,%.17g]}", t[0], t[1], t[2]);
    CHECK(run(s, "drag", body, NULL) == FFD_OK);
    doc = state(s);
    cJSON *manip = cJSON_GetObjectItem(doc, "manip");
    CHECK(cJSON_IsTrue(cJSON_GetObjectItem(manip, "pins_met")));
    CHECK_NEAR(cJSON_GetObjectItem(manip, "drag_residual")->valuedouble,
               sqrt(0.3 * 0.3 + 0.2 * 0.2 + 0.1 * 0.1), 1e-6); /* nothing could move */
    cJSON *pin;
    cJSON_ArrayForEach(pin, cJSON_GetObjectItem(doc, "pins"))
        CHECK(cJSON_GetObjectItem(pin, "residual")->valuedouble <= 1e-12 * 10);
    cJSON_Delete(doc);
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    double *after = frame(s, &n);
    CHECK(range_change(before, after, 0, n) < 1e-6);
    /* the state keeps the last drag's shortfall; after undo it is gone */
    doc = state(s);
    CHECK(cJSON_IsNumber(cJSON_GetObjectItem(cJSON_GetObjectItem(doc, "manip"), "drag_residual")));
    cJSON_Delete(doc);
    CHECK(run(s, "undo", "{}", NULL) == FFD_OK);
    doc = state(s);
    CHECK(cJSON_IsNull(cJSON_GetObjectItem(doc, "manip")));
    cJSON_Delete(doc);
    /* two pins of one spot with targets apart: least squares over the pins, said so */
    CHECK(run(s, "unpin", "{\"all\":true}", NULL) == FFD_OK);
    CHECK(run(s, "pin", "{\"vertex\":900}", NULL) == FFD_OK);
    snprintf(body, sizeof body, "{\"vertex\":901,\"target\":[%.17g,%.17g,%.17g]}",
             before[2700] + 1.0, before[2701], before[2702]);
    for (int i = 0; i < 8; i++) { /* more pins than the lattice can serve */
        char b2[64];
        snprintf(b2, sizeof b2, "{\"vertex\":%d}", pins[i]);
        CHECK(run(s, "pin", b2, NULL) == FFD_OK);
    }
    CHECK(run(s, "pin", body, NULL) == FFD_OK);
    doc = state(s);
    CHECK(cJSON_IsFalse(cJSON_GetObjectItem(cJSON_GetObjectItem(doc, "manip"), "pins_met")));
    CHECK(cJSON_IsNull(cJSON_GetObjectItem(cJSON_GetObjectItem(doc, "manip"), "drag_residual")));
    cJSON_Delete(doc);
    free(before);
    free(after);
    ffd_session_destroy(s);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"add_mesh_concatenates", test_add_mesh_concatenates},
        {"lattice_replays_per_mesh", test_lattice_replays_per_mesh},
        {"direct_manipulation_per_mesh", test_direct_manipulation_per_mesh},
        {"add_keeps_the_deformation", test_add_keeps_the_deformation},
        {"bad_requests", test_bad_requests},
        {"pins_hard_drag_soft", test_pins_hard_drag_soft},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
