/* The editor session (ffd_session): every op through ffd_session_command,
 * with the lattice and T-spline methods: drags, direct manipulation with
 * pins, undo/redo, and the central property: the session's rig replayed by
 * ffd_rig_apply (what `ffd deform` does) gives the session's positions. */
#include "check.h"
#include "ffd.h"

#include <cJSON.h>
#include <stdint.h>
#include <stdlib.h>
#include <unistd.h>

#define BUNNY FFD_SOURCE_DIR "/examples/lattice/bunny.obj"
#define COW FFD_SOURCE_DIR "/examples/tspline/cow.off"

static ffd_session *open_session(const char *path)
{
    ffd_mesh *mesh = NULL;
    ffd_session *s = NULL;
    CHECK_OK(ffd_mesh_read(path, &mesh, NULL));
    if (!mesh)
        return NULL;
    CHECK_OK(ffd_session_create(mesh, "mesh", NULL, &s, NULL));
    return s;
}

/* Runs op; returns its status, the reply freed (err kept for messages). */
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

/* The frame's deformed positions (V by 3 floats) and header fields. */
static float *frame_positions(ffd_session *s, uint32_t head[5])
{
    void *data = NULL;
    size_t size = 0;
    if (ffd_session_frame(s, &data, &size, NULL) != FFD_OK)
        return NULL;
    memcpy(head, data, 20);
    float *p = malloc(12 * (size_t)head[2]);
    memcpy(p, (char *)data + 20, 12 * (size_t)head[2]);
    ffd_free(data);
    return p;
}

/* max |session positions - replay of the session's rig on the file| */
static double replay_difference(ffd_session *s, const char *path)
{
    char *text = NULL;
    size_t size = 0;
    ffd_rig *rig = NULL;
    ffd_mesh *mesh = NULL;
    uint32_t head[5];
    double worst = INFINITY;
    float *p = frame_positions(s, head);
    if (ffd_session_rig(s, &text, &size, NULL) == FFD_OK &&
        ffd_rig_parse_json(text, size, "session.json", &rig, NULL) == FFD_OK &&
        ffd_mesh_read(path, &mesh, NULL) == FFD_OK && ffd_rig_apply(rig, mesh, NULL, NULL) == FFD_OK) {
        const double *x = ffd_mesh_positions(mesh);
        worst = 0;
        for (size_t i = 0; i < 3 * (size_t)head[2]; i++) {
            double d = fabs(x[i] - p[i]);
            worst = d > worst ? d : worst;
        }
    }
    free(p);
    ffd_mesh_destroy(mesh);
    ffd_rig_destroy(rig);
    ffd_free(text);
    return worst;
}

static double max_change(const float *a, const float *b, size_t n)
{
    double worst = 0;
    for (size_t i = 0; i < 3 * n; i++)
        worst = fabs(a[i] - b[i]) > worst ? fabs(a[i] - b[i]) : worst;
    return worst;
}

static void test_identity_and_create(void)
{
    ffd_session *s = open_session(BUNNY);
    uint32_t head[5];
    float *rest = frame_positions(s, head);
    CHECK(head[3] == 0 && head[4] == 0);
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[4,5,6]}", NULL) == FFD_OK);
    float *now = frame_positions(s, head);
    CHECK(head[3] == 120);
    CHECK(max_change(rest, now, head[2]) < 1e-5); /* identity at rest (float32) */
    char *state = NULL;
    size_t size;
    CHECK_OK(ffd_session_state(s, &state, &size, NULL));
    CHECK(state && strstr(state, "\"method\":\"lattice\"") && strstr(state, "\"count\":120"));
    ffd_free(state);
    free(rest);
    free(now);
    ffd_session_destroy(s);
}

static void test_lattice_drag_replays(void)
{
    ffd_session *s = open_session(BUNNY);
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[5,5,5]}", NULL) == FFD_OK);
    CHECK(run(s, "drag_begin", "{\"points\":[62,63,67]}", NULL) == FFD_OK);
    CHECK(run(s, "drag", "{\"delta\":[0.5,1,0]}", NULL) == FFD_OK);
    CHECK(run(s, "drag", "{\"delta\":[1.5,2,-1]}", NULL) == FFD_OK); /* total, not added */
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[100,101],\"axis\":[0,0,1],\"angle\":0.4}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[24],\"scale\":[2,1,1],\"center\":[0,0,0]}", NULL) == FFD_OK);
    double d = replay_difference(s, BUNNY);
    CHECK(d < 1e-5); /* float32 frame vs double replay */
    /* the drag's total: control 62 moved by exactly (1.5, 2, -1) */
    void *data;
    size_t size;
    uint32_t head[5];
    CHECK_OK(ffd_session_frame(s, &data, &size, NULL));
    memcpy(head, data, 20);
    CHECK(size == 20 + 12 * ((size_t)head[2] + head[3]) + 4 * head[4]);
    ffd_free(data);
    ffd_session_destroy(s);
}

static void test_undo_redo(void)
{
    ffd_session *s = open_session(BUNNY);
    uint32_t head[5];
    float *rest = frame_positions(s, head);
    CHECK(run(s, "undo", NULL, &(ffd_error){{0}}) == FFD_ERR_INVALID); /* nothing yet */
    CHECK(run(s, "create", "{\"method\":\"lattice\"}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[62],\"delta\":[0,3,0]}", NULL) == FFD_OK);
    float *a = frame_positions(s, head);
    CHECK(run(s, "move", "{\"points\":[12],\"delta\":[1,0,0]}", NULL) == FFD_OK);
    float *b = frame_positions(s, head);
    CHECK(max_change(a, b, head[2]) > 0.01);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    float *c = frame_positions(s, head);
    CHECK(max_change(a, c, head[2]) == 0);
    CHECK(run(s, "redo", NULL, NULL) == FFD_OK);
    float *d = frame_positions(s, head);
    CHECK(max_change(b, d, head[2]) == 0);
    /* switching method is undoable, back to the same lattice state */
    CHECK(run(s, "create", "{\"method\":\"tspline\",\"resolution\":[5,5,5]}", NULL) == FFD_OK);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    float *e = frame_positions(s, head);
    CHECK(max_change(b, e, head[2]) == 0);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK); /* before "create": no deformer */
    float *f = frame_positions(s, head);
    CHECK(head[3] == 0 && max_change(rest, f, head[2]) == 0);
    /* a new change clears redo */
    CHECK(run(s, "create", "{\"method\":\"lattice\"}", NULL) == FFD_OK);
    CHECK(run(s, "redo", NULL, &(ffd_error){{0}}) == FFD_ERR_INVALID);
    free(rest), free(a), free(b), free(c), free(d), free(e), free(f);
    ffd_session_destroy(s);
}

static void test_direct_manipulation_and_pins(void)
{
    ffd_session *s = open_session(BUNNY);
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[6,6,6]}", NULL) == FFD_OK);
    CHECK(run(s, "pin", "{\"vertex\":1791}", NULL) == FFD_OK);
    CHECK(run(s, "pin", "{\"vertex\":1043}", NULL) == FFD_OK);
    uint32_t head[5];
    float *before = frame_positions(s, head);
    CHECK(run(s, "drag_begin", "{\"vertex\":553}", NULL) == FFD_OK);
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    const char *step = "{\"target\":[2.0,8.4,-1.0]}";
    CHECK_OK(ffd_session_command(s, "drag", step, strlen(step), &reply, &size, &binary, NULL));
    CHECK(binary == 1 && reply && size > 20);
    if (reply) {
        uint32_t h[5];
        memcpy(h, reply, 20);
        CHECK(h[4] == 3); /* two pins and the dragged vertex */
        const float *x = (const float *)((char *)reply + 20);
        const float *res = x + 3 * ((size_t)h[2] + h[3]);
        CHECK_NEAR(x[3 * 553], 2.0, 1e-4); /* the target is reached */
        CHECK_NEAR(x[3 * 553 + 1], 8.4, 1e-4);
        CHECK(res[0] < 1e-6 && res[1] < 1e-6 && res[2] < 1e-6);
        CHECK_NEAR(x[3 * 1791], before[3 * 1791], 1e-5); /* pins hold */
        CHECK_NEAR(x[3 * 1043 + 1], before[3 * 1043 + 1], 1e-5);
    }
    ffd_free(reply);
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    CHECK(replay_difference(s, BUNNY) < 1e-5);
    /* over-constrained: two pins on nearly the same spot pulled apart leave a residual */
    CHECK(run(s, "pin", "{\"vertex\":553,\"target\":[30,8.4,-1]}", NULL) == FFD_OK);
    char *state = NULL;
    CHECK_OK(ffd_session_state(s, &state, &size, NULL));
    CHECK(state && strstr(state, "\"pins\":[{\"vertex\":1791"));
    ffd_free(state);
    CHECK(run(s, "unpin", "{\"all\":true}", NULL) == FFD_OK);
    CHECK(run(s, "unpin", "{\"vertex\":5}", &(ffd_error){{0}}) == FFD_ERR_RANGE);
    free(before);
    ffd_session_destroy(s);
}

static void test_cancel_restores(void)
{
    ffd_session *s = open_session(BUNNY);
    CHECK(run(s, "create", "{\"method\":\"lattice\"}", NULL) == FFD_OK);
    uint32_t head[5];
    float *a = frame_positions(s, head);
    CHECK(run(s, "drag_begin", "{\"points\":[62]}", NULL) == FFD_OK);
    CHECK(run(s, "drag", "{\"delta\":[1,1,1]}", NULL) == FFD_OK);
    ffd_error err = {{0}};
    CHECK(run(s, "create", "{\"method\":\"lattice\"}", &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "conflict: ") == err.message);
    CHECK(run(s, "drag_cancel", "{}", NULL) == FFD_OK);
    float *b = frame_positions(s, head);
    CHECK(max_change(a, b, head[2]) == 0);
    free(a);
    free(b);
    ffd_session_destroy(s);
}

static void test_tspline_session(void)
{
    ffd_session *s = open_session(COW);
    uint32_t head[5];
    float *rest = frame_positions(s, head);
    CHECK(run(s, "create", "{\"method\":\"tspline\",\"resolution\":[5,5,5]}", NULL) == FFD_OK);
    /* ARAP drag of two proxy points, then a refinement: the shape must not change */
    CHECK(run(s, "freeze", "{\"points\":[0,1,2,3,4]}", NULL) == FFD_OK);
    CHECK(run(s, "drag_begin", "{\"points\":[124]}", NULL) == FFD_OK);
    CHECK(run(s, "drag", "{\"delta\":[0.1,0.2,0]}", NULL) == FFD_OK);
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    float *a = frame_positions(s, head);
    CHECK(max_change(rest, a, head[2]) > 0.01);
    uint32_t before_count = head[3];
    CHECK(run(s, "refine", "{\"insertions\":[{\"cell\":10},{\"face\":{\"near\":[0,0,0]}}]}", NULL) ==
          FFD_OK);
    float *b = frame_positions(s, head);
    CHECK(head[3] > before_count);
    CHECK(max_change(a, b, head[2]) < 1e-5); /* refinement invariance */
    CHECK(run(s, "move", "{\"points\":[3],\"delta\":[0,0,0.3],\"arap\":false}", NULL) == FFD_OK);
    CHECK(run(s, "drag_begin", "{\"vertex\":100}", NULL) == FFD_OK);
    CHECK(run(s, "drag", "{\"target\":[0.5,0.5,0.5]}", NULL) == FFD_OK);
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    CHECK(replay_difference(s, COW) < 1e-5);
    /* undo the refinement: back to the lattice before it, same shape as a */
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    float *c = frame_positions(s, head);
    CHECK(head[3] == before_count);
    CHECK(max_change(a, c, head[2]) < 1e-6);
    CHECK(run(s, "redo", NULL, NULL) == FFD_OK);
    float *d = frame_positions(s, head);
    CHECK(head[3] > before_count && max_change(b, d, head[2]) < 1e-6);
    /* a loaded rig reproduces the session */
    char *text = NULL;
    size_t size;
    CHECK_OK(ffd_session_rig(s, &text, &size, NULL));
    ffd_session *t = open_session(COW);
    CHECK_OK(ffd_session_load_rig(t, text, size, "r.json", NULL, NULL));
    float *e = frame_positions(t, head);
    CHECK(max_change(d, e, head[2]) < 1e-6);
    ffd_free(text);
    free(rest), free(a), free(b), free(c), free(d), free(e);
    ffd_session_destroy(t);
    ffd_session_destroy(s);
}

/* The editor's proxy of cells touching along an edge and at vertices
 * (tests/data/tspline-contacts.obj): "face_points" over "point_controls" is
 * the same faces as "faces", a closed 2-manifold (each directed edge once,
 * with its reverse), a control point once per sheet. */
static void test_tspline_proxy_manifold(void)
{
    ffd_session *s = open_session(FFD_SOURCE_DIR "/tests/data/tspline-contacts.obj");
    if (!s)
        return;
    CHECK(run(s, "create", "{\"method\":\"tspline\",\"resolution\":[4,4,4]}", NULL) == FFD_OK);
    char *state = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_state(s, &state, &size, NULL));
    cJSON *root = state ? cJSON_ParseWithLength(state, size) : NULL;
    const cJSON *proxy = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(root, "controls"), "proxy");
    CHECK(proxy != NULL);
    const cJSON *faces = cJSON_GetObjectItemCaseSensitive(proxy, "faces");
    const cJSON *fpts = cJSON_GetObjectItemCaseSensitive(proxy, "face_points");
    const cJSON *ctl = cJSON_GetObjectItemCaseSensitive(proxy, "point_controls");
    const cJSON *pts = cJSON_GetObjectItemCaseSensitive(proxy, "points");
    CHECK(cJSON_GetArraySize(faces) == 24 && cJSON_GetArraySize(fpts) == 24);
    CHECK(cJSON_GetArraySize(pts) == 28 && cJSON_GetArraySize(ctl) == 32);
    int n_ctl = cJSON_GetArraySize(ctl), bad = 0, dir[32][32] = {{0}};
    for (int f = 0; f < cJSON_GetArraySize(faces) && f < cJSON_GetArraySize(fpts); f++) {
        const cJSON *a = cJSON_GetArrayItem(faces, f), *b = cJSON_GetArrayItem(fpts, f);
        int m = cJSON_GetArraySize(b);
        bad += cJSON_GetArraySize(a) != m;
        for (int i = 0; i < m && i < cJSON_GetArraySize(a); i++) {
            int p = cJSON_GetArrayItem(b, i)->valueint;
            int q = cJSON_GetArrayItem(b, (i + 1) % m)->valueint;
            if (p < 0 || p >= n_ctl || p >= 32 || q < 0 || q >= n_ctl || q >= 32) {
                bad++;
                continue;
            }
            bad += cJSON_GetArrayItem(ctl, p)->valueint != cJSON_GetArrayItem(a, i)->valueint;
            dir[p][q]++;
        }
    }
    for (int p = 0; p < 32; p++)
        for (int q = 0; q < 32; q++)
            bad += dir[p][q] > 1 || dir[p][q] != dir[q][p];
    CHECK(bad == 0);
    cJSON_Delete(root);
    ffd_free(state);
    ffd_session_destroy(s);
}

static void test_influence(void)
{
    ffd_session *s = open_session(BUNNY);
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[4,4,4]}", NULL) == FFD_OK);
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    /* all controls: partition of unity, weight 1 everywhere */
    char body[1024] = "{\"points\":[";
    for (int i = 0; i < 64; i++)
        snprintf(body + strlen(body), sizeof body - strlen(body), "%s%d", i ? "," : "", i);
    strcat(body, "]}");
    CHECK_OK(ffd_session_command(s, "influence", body, strlen(body), &reply, &size, &binary, NULL));
    CHECK(binary && size == 16 + 4 * 1839);
    const float *w = (const float *)((char *)reply + 16);
    double lo = 1;
    for (size_t i = 0; i < 1839; i++)
        lo = w[i] < lo ? w[i] : lo;
    CHECK(lo > 1 - 1e-5);
    ffd_free(reply);
    ffd_session_destroy(s);
}

static void test_bad_requests(void)
{
    ffd_session *s = open_session(BUNNY);
    ffd_error err = {{0}};
    CHECK(run(s, "create", "{\"method\":", &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "byte"));
    CHECK(run(s, "create", "[1]", &err) == FFD_ERR_PARSE);
    CHECK(run(s, "create", "{\"method\":\"blob\"}", &err) == FFD_ERR_PARSE);
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[1,5,5]}", &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "resolution[0]"));
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"colour\":1}", &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "colour"));
    CHECK(run(s, "drag_begin", "{\"points\":[0]}", &err) == FFD_ERR_INVALID); /* no deformer */
    CHECK(strstr(err.message, "conflict: ") == err.message);
    CHECK(run(s, "frobnicate", "{}", &err) == FFD_ERR_UNSUPPORTED);
    CHECK(run(s, "create", "{\"method\":\"lattice\"}", NULL) == FFD_OK);
    CHECK(run(s, "drag_begin", "{\"points\":[125]}", &err) == FFD_ERR_RANGE);
    CHECK(run(s, "drag_begin", "{\"points\":[1,1]}", &err) == FFD_ERR_INVALID);
    CHECK(run(s, "drag", "{\"delta\":[1,1,1]}", &err) == FFD_ERR_INVALID); /* no drag */
    CHECK(run(s, "drag_begin", "{\"points\":[1]}", NULL) == FFD_OK);
    CHECK(run(s, "drag", "{\"delta\":[1e999,1,1]}", &err) == FFD_ERR_NONFINITE);
    CHECK(run(s, "drag", "{\"angle\":1}", &err) == FFD_ERR_PARSE);
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    CHECK(run(s, "refine", "{\"insertions\":[{\"cell\":0}]}", &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "conflict: ") == err.message);
    CHECK(run(s, "pin", "{\"vertex\":99999}", &err) == FFD_ERR_RANGE);
    CHECK_OK(ffd_session_load_rig(s, "{\"deformer\":\"gffd\",\"skeleton\":[{\"type\":\"polyline\","
                                     "\"file\":\"x.obj\",\"radius\":1}]}", 78, "up.json", NULL, &err) ==
             FFD_ERR_INVALID ? FFD_OK : FFD_ERR_IO);
    CHECK(run(s, "reset", "{\"method\":1} {\"x\":1}", &err) == FFD_ERR_PARSE); /* trailing text */
    CHECK(strstr(err.message, "after the value"));
    CHECK(run(s, "move", "{\"points\":[0],\"delta\":[1e300,0,0]}", &err) == FFD_ERR_NONFINITE);
    CHECK(run(s, "pin", "{\"vertex\":0,\"target\":[1e300,0,0]}", &err) == FFD_ERR_NONFINITE);
    CHECK(run(s, "move", "{\"points\":[0],\"axis\":[0,0,1],\"angle\":1,\"center\":[1e300,0,0]}",
              &err) == FFD_ERR_NONFINITE);
    CHECK(run(s, "unpin", "{\"all\":true}", &err) == FFD_ERR_INVALID); /* no pins */
    char *before = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_state(s, &before, &size, NULL));
    CHECK(run(s, "move", "{\"points\":[0]}", &err) == FFD_ERR_PARSE); /* no delta */
    char *after = NULL;
    CHECK_OK(ffd_session_state(s, &after, &size, NULL));
    /* the failed move changed nothing, not even the revision (busy_ms aside) */
    if (before && after) {
        *strstr(before, ",\"busy_ms\"") = 0;
        *strstr(after, ",\"busy_ms\"") = 0;
        CHECK(strcmp(before, after) == 0);
    }
    ffd_free(before);
    ffd_free(after);
    /* a deformer over the control limit is refused before it is built */
    CHECK(run(s, "create", "{\"method\":\"lattice\",\"resolution\":[1024,1024,1024]}", &err) ==
          FFD_ERR_INVALID);
    CHECK(strstr(err.message, "limit"));
    CHECK(run(s, "create", "{\"method\":\"tspline\",\"resolution\":[256,256,256]}", &err) ==
          FFD_ERR_INVALID);
    CHECK_OK(ffd_session_load_rig(s, "{\"resolution\":[512,512,512]}", 28, "big.json", NULL,
                                  &err) == FFD_ERR_INVALID ? FFD_OK : FFD_ERR_IO);
    /* after all that the session is intact: the one move-free lattice */
    CHECK(replay_difference(s, BUNNY) < 1e-5);
    ffd_session_destroy(s);
}

static void test_export_is_the_replay(void)
{
    ffd_session *s = open_session(BUNNY);
    CHECK(run(s, "create", "{\"method\":\"lattice\"}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[62],\"delta\":[0,3,0]}", NULL) == FFD_OK);
    void *data = NULL;
    size_t size = 0;
    ffd_write_options o = {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_LE, 0};
    CHECK_OK(ffd_session_export(s, &o, &data, &size, NULL));
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read_memory(data, size, FFD_FORMAT_PLY, "x.ply", &m, NULL));
    uint32_t head[5];
    float *p = frame_positions(s, head);
    double worst = 0;
    for (size_t i = 0; m && i < 3 * (size_t)head[2]; i++)
        worst = fmax(worst, fabs(ffd_mesh_positions(m)[i] - p[i]));
    CHECK(m && worst < 1e-5);
    free(p);
    ffd_mesh_destroy(m);
    ffd_free(data);
    ffd_session_destroy(s);
}

static void test_allocation_failures(void)
{
    /* every allocation of a create + drag + undo sequence may fail: clean errors, no leaks */
    for (size_t k = 0; k < 4000; k += 7) {
        ffd_session *s = open_session(BUNNY);
        fail_alloc fa = {k, 0};
        ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&a);
        ffd_error err;
        ffd_status st = run(s, "create", "{\"method\":\"lattice\",\"resolution\":[4,4,4]}", &err);
        if (!st)
            st = run(s, "move", "{\"points\":[5],\"delta\":[0,1,0]}", &err);
        if (!st)
            st = run(s, "pin", "{\"vertex\":4}", &err);
        if (!st)
            st = run(s, "undo", NULL, &err);
        ffd_set_allocator(NULL);
        CHECK(st == FFD_OK || st == FFD_ERR_NOMEM);
        ffd_session_destroy(s);
        if (st == FFD_OK)
            break;
    }
}

/* Issue 14: a NUL (\u0000) in a request's key or string is refused (cJSON
 * would read "lattice\u0000x" as "lattice"), in commands and in loaded rigs;
 * a rig with a byte order mark is still checked for files outside root. */
static void test_nul_and_bom(void)
{
    ffd_session *s = open_session(BUNNY);
    ffd_error err = {{0}};
    CHECK(run(s, "create", "{\"method\":\"lattice\\u0000x\"}", &err) == FFD_ERR_PARSE);
    CHECK(strcmp(err.message, "create:1:19: a NUL character (\\u0000) in a string is not allowed") == 0);
    CHECK(run(s, "create", "{\"method\\u0000\":\"lattice\"}", &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "create:1:9: a NUL character"));
    CHECK(run(s, "create", "{\"method\":\"lattice\"}", NULL) == FFD_OK);
    CHECK(run(s, "drag_begin", "{\"points\":[1],\"mode\\u0000x\":1}", &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "a NUL character"));
    static const char raw[] = "{\"points\":[1]}\0{\"x\":1}";
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    CHECK(ffd_session_command(s, "drag_begin", raw, sizeof raw - 1, &reply, &size, &binary, &err) ==
          FFD_ERR_PARSE);
    CHECK(strstr(err.message, "drag_begin:1:15: a NUL byte"));
    ffd_free(reply);

    /* rigs: the file check and the rig parser see the same text */
    char root[] = "/tmp/ffd_session_nul_XXXXXX";
    CHECK(mkdtemp(root) != NULL);
    char name[128], rig[512];
    snprintf(name, sizeof name, "%s/up.json", root);
    snprintf(rig, sizeof rig,
             "{\"deformer\":\"gffd\",\"skeleton\":[{\"type\":\"polyline\",\"file\":\"spine.obj\\u0000/"
             "../../x\",\"radius\":1}]}");
    CHECK(ffd_session_load_rig(s, rig, strlen(rig), name, root, &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "up.json:1:68: a NUL character (\\u0000) in a string is not allowed"));
    snprintf(rig, sizeof rig,
             "\xEF\xBB\xBF{\"deformer\":\"gffd\",\"skeleton\":[{\"type\":\"polyline\",\"file\":\"%s\","
             "\"radius\":1}]}",
             FFD_SOURCE_DIR "/examples/gffd/spine.obj");
    CHECK(ffd_session_load_rig(s, rig, strlen(rig), name, root, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "is outside the server's directory"));
    CHECK(rmdir(root) == 0);
    /* the session still holds its lattice, unmoved */
    CHECK(replay_difference(s, BUNNY) < 1e-5);
    ffd_session_destroy(s);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"identity_and_create", test_identity_and_create},
        {"lattice_drag_replays", test_lattice_drag_replays},
        {"undo_redo", test_undo_redo},
        {"direct_manipulation_and_pins", test_direct_manipulation_and_pins},
        {"cancel_restores", test_cancel_restores},
        {"tspline_session", test_tspline_session},
        {"tspline_proxy_manifold", test_tspline_proxy_manifold},
        {"influence", test_influence},
        {"bad_requests", test_bad_requests},
        {"nul_and_bom", test_nul_and_bom},
        {"export_is_the_replay", test_export_is_the_replay},
        {"allocation_failures", test_allocation_failures},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
