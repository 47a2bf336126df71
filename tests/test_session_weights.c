/* The editor's vertex-group weights (ffd_session_command "weights" and
 * "weights_values", docs/editor.md): painted weights scale the method's
 * effect (x' = x + w (f(x) - x)) and are saved in the rig's "weights" layer,
 * so the session's rig replayed by ffd_rig_apply (`ffd deform`) gives the
 * session's positions; the steps of one brush stroke are one undo step; a
 * bad request (a vertex out of range, a weight that is not finite or not in
 * [0, 1], a wrong count or key) is refused with a message naming it and
 * changes nothing. */
#include "check.h"
#include "ffd.h"

#include <cJSON.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#define BUNNY FFD_SOURCE_DIR "/examples/lattice/bunny.obj"

static ffd_session *open_session(void)
{
    ffd_mesh *mesh = NULL;
    ffd_session *s = NULL;
    CHECK_OK(ffd_mesh_read(BUNNY, &mesh, NULL));
    if (!mesh)
        return NULL;
    CHECK_OK(ffd_session_create(mesh, "bunny.obj", NULL, &s, NULL));
    return s;
}

/* Runs op; its status, the reply kept in *out when asked for (ffd_free). */
static ffd_status run_reply(ffd_session *s, const char *op, const char *body, ffd_error *err,
                            void **out, size_t *out_size)
{
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    ffd_error local = {{0}};
    ffd_status st = ffd_session_command(s, op, body, body ? strlen(body) : 0, &reply, &size,
                                        &binary, err ? err : &local);
    if (st && !err)
        fprintf(stderr, "  %s %.80s: %s\n", op, body ? body : "", local.message);
    if (out) {
        *out = reply;
        *out_size = size;
    } else {
        ffd_free(reply);
    }
    return st;
}

static ffd_status run(ffd_session *s, const char *op, const char *body, ffd_error *err)
{
    return run_reply(s, op, body, err, NULL, NULL);
}

/* The frame's positions (V by 3 floats); *n the vertex count. */
static float *positions(ffd_session *s, size_t *n)
{
    void *data = NULL;
    size_t size = 0;
    if (ffd_session_frame(s, &data, &size, NULL) != FFD_OK)
        return NULL;
    uint32_t head[5];
    memcpy(head, data, 20);
    *n = head[2];
    float *p = malloc(12 * (size_t)head[2]);
    memcpy(p, (char *)data + 20, 12 * (size_t)head[2]);
    ffd_free(data);
    return p;
}

/* The session's weights (weights_values), n floats. */
static float *weights(ffd_session *s, size_t n)
{
    void *data = NULL;
    size_t size = 0;
    float *w = NULL;
    if (run_reply(s, "weights_values", "{}", NULL, &data, &size) == FFD_OK && size == 16 + 4 * n &&
        memcmp(data, "FFDW", 4) == 0) {
        w = malloc(4 * n);
        memcpy(w, (char *)data + 16, 4 * n);
    }
    CHECK(w != NULL);
    ffd_free(data);
    return w;
}

static double max_change(const float *a, const float *b, size_t n)
{
    double worst = 0;
    for (size_t i = 0; i < 3 * n; i++)
        worst = fabs(a[i] - b[i]) > worst ? fabs(a[i] - b[i]) : worst;
    return worst;
}

/* max |session positions - ffd_rig_apply of the session's rig on the bunny| */
static double replay_difference(ffd_session *s)
{
    char *text = NULL;
    size_t size = 0, n = 0;
    ffd_rig *rig = NULL;
    ffd_mesh *mesh = NULL;
    double worst = INFINITY;
    float *p = positions(s, &n);
    if (ffd_session_rig(s, &text, &size, NULL) == FFD_OK &&
        ffd_rig_parse_json(text, size, "session.json", &rig, NULL) == FFD_OK &&
        ffd_mesh_read(BUNNY, &mesh, NULL) == FFD_OK && ffd_rig_apply(rig, mesh, NULL, NULL) == FFD_OK) {
        const double *x = ffd_mesh_positions(mesh);
        worst = 0;
        for (size_t i = 0; i < 3 * n; i++)
            worst = fmax(worst, fabs(x[i] - p[i]));
    }
    free(p);
    ffd_mesh_destroy(mesh);
    ffd_rig_destroy(rig);
    ffd_free(text);
    return worst;
}

static int undo_count(ffd_session *s)
{
    char *state = NULL;
    size_t size = 0;
    int undo = -1;
    if (ffd_session_state(s, &state, &size, NULL) == FFD_OK) {
        cJSON *j = cJSON_Parse(state);
        cJSON *u = cJSON_GetObjectItem(j, "undo");
        undo = u ? u->valueint : -1;
        cJSON_Delete(j);
    }
    ffd_free(state);
    return undo;
}

/* Weights of 0 keep a vertex at rest, of 1 give it the method's position,
 * of 1/2 half way; the rig holds them and replays the frame; after a drag
 * (the map scaled by the weights) it still does. */
static void test_weights_scale_and_replay(void)
{
    ffd_session *s = open_session();
    size_t n = 0;
    float *rest = positions(s, &n);
    CHECK(run(s, "create", "{\"deformer\":\"lattice\",\"resolution\":[4,4,4]}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[21,22,25,26],\"delta\":[0.8,1.5,-0.4]}", NULL) == FFD_OK);
    float *full = positions(s, &n);
    CHECK(run(s, "weights", "{\"vertices\":{\"0\":0,\"1\":0.5,\"1838\":0}}", NULL) == FFD_OK);
    float *now = positions(s, &n);
    for (int a = 0; a < 3; a++) {
        CHECK(now[a] == rest[a]);                       /* weight 0: at rest, bit for bit */
        CHECK(now[3 * 1838 + a] == rest[3 * 1838 + a]);
        CHECK_NEAR(now[3 + a], rest[3 + a] + 0.5 * (full[3 + a] - rest[3 + a]), 1e-5);
    }
    for (size_t i = 2; i < 1838; i++) /* weight 1: the method's, bit for bit */
        for (int a = 0; a < 3; a++)
            CHECK(now[3 * i + a] == full[3 * i + a]);
    float *w = weights(s, n);
    CHECK(w && w[0] == 0.0f && w[1] == 0.5f && w[2] == 1.0f && w[1838] == 0.0f);
    CHECK(replay_difference(s) < 1e-5);
    char *rig = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_rig(s, &rig, &size, NULL));
    CHECK(rig && strstr(rig, "\"weights\"") && strstr(rig, "\"values\""));
    ffd_free(rig);
    /* a later drag goes through the weighted map; the rig still replays */
    CHECK(run(s, "move", "{\"points\":[5],\"delta\":[0,0.7,0.2]}", NULL) == FFD_OK);
    CHECK(replay_difference(s) < 1e-5);
    /* direct manipulation reaches its target on the weighted positions */
    CHECK(run(s, "drag_begin", "{\"vertex\":900}", NULL) == FFD_OK);
    float *before = positions(s, &n);
    char body[160];
    snprintf(body, sizeof body, "{\"target\":[%.9g,%.9g,%.9g]}", before[2700] + 0.3, before[2701],
             before[2702]);
    CHECK(run(s, "drag", body, NULL) == FFD_OK);
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    float *after = positions(s, &n);
    CHECK_NEAR(after[2700], before[2700] + 0.3, 1e-4);
    CHECK(replay_difference(s) < 1e-5);
    /* every vertex's weight at once */
    char *values = malloc(8 * n + 32), *q = values;
    q += sprintf(q, "{\"values\":[");
    for (size_t i = 0; i < n; i++)
        q += sprintf(q, "%s%g", i ? "," : "", (double)(i % 5) / 4.0);
    sprintf(q, "]}");
    CHECK(run(s, "weights", values, NULL) == FFD_OK);
    free(w);
    w = weights(s, n);
    CHECK(w && w[3] == 0.75f && w[4] == 1.0f && w[5] == 0.0f);
    CHECK(replay_difference(s) < 1e-5);
    /* clear: no weights, the full effect, no "weights" in the rig */
    CHECK(run(s, "weights", "{\"clear\":true}", NULL) == FFD_OK);
    CHECK_OK(ffd_session_rig(s, &rig, &size, NULL));
    CHECK(rig && !strstr(rig, "\"weights\""));
    ffd_free(rig);
    CHECK(replay_difference(s) < 1e-5);
    free(values), free(rest), free(full), free(now), free(w), free(before), free(after);
    ffd_session_destroy(s);
}

/* Every method takes weights the same way (the generic layers): a vertex of
 * weight 0 stays at rest, and the rig replays. */
static void test_every_method(void)
{
    static const char *const creates[] = {
        "{\"deformer\":\"tspline\",\"resolution\":[4,4,4]}",
        "{\"deformer\":\"gffd\"}",
        "{\"deformer\":\"cage\"}",
        "{\"deformer\":\"rbf\"}",
        "{\"deformer\":\"idw\"}",
        "{\"deformer\":\"pbffd\",\"controls\":{\"interior\":8,\"exterior\":8}}",
    };
    for (size_t m = 0; m < sizeof creates / sizeof *creates; m++) {
        ffd_session *s = open_session();
        size_t n = 0;
        float *rest = positions(s, &n);
        CHECK(run(s, "create", creates[m], NULL) == FFD_OK);
        CHECK(run(s, "move", "{\"points\":[1],\"delta\":[0.3,0.6,-0.2]}", NULL) == FFD_OK);
        float *full = positions(s, &n);
        size_t moved = 0;
        for (size_t i = 0; i < n && !moved; i++)
            if (max_change(full + 3 * i, rest + 3 * i, 1) > 1e-3)
                moved = i + 1;
        CHECK(moved > 0);
        char body[96];
        snprintf(body, sizeof body, "{\"vertices\":{\"%zu\":0,\"%zu\":0.5}}", moved ? moved - 1 : 0,
                 moved == n ? (size_t)0 : n - 1);
        CHECK(run(s, "weights", body, NULL) == FFD_OK);
        float *now = positions(s, &n);
        if (moved && max_change(now + 3 * (moved - 1), rest + 3 * (moved - 1), 1) != 0) {
            fprintf(stderr, "  %s: vertex %zu of weight 0 moved by %g\n", creates[m], moved - 1,
                    max_change(now + 3 * (moved - 1), rest + 3 * (moved - 1), 1));
            check_failures++;
        }
        double d = replay_difference(s);
        if (!(d < 1e-5)) {
            fprintf(stderr, "  %s: replay differs by %g\n", creates[m], d);
            check_failures++;
        }
        free(rest), free(full), free(now);
        ffd_session_destroy(s);
    }
}

/* The steps of one stroke are one undo step; another stroke, or the same
 * id after another change, is another; undo brings back the positions and
 * weights before the stroke exactly, across the wrapping of a method that
 * had no weights (the history's earlier control edits still undo). */
static void test_one_undo_step_per_stroke(void)
{
    ffd_session *s = open_session();
    size_t n = 0;
    float *rest = positions(s, &n);
    CHECK(run(s, "create", "{\"deformer\":\"lattice\"}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[62],\"delta\":[0,3,0]}", NULL) == FFD_OK);
    float *moved = positions(s, &n);
    int u0 = undo_count(s);
    CHECK(run(s, "weights", "{\"vertices\":{\"10\":0.2},\"stroke\":7}", NULL) == FFD_OK);
    CHECK(run(s, "weights", "{\"vertices\":{\"11\":0.3},\"stroke\":7}", NULL) == FFD_OK);
    CHECK(run(s, "weights", "{\"vertices\":{\"12\":0.4},\"stroke\":7}", NULL) == FFD_OK);
    CHECK(undo_count(s) == u0 + 1);
    float *stroke1 = positions(s, &n);
    CHECK(run(s, "weights", "{\"vertices\":{\"500\":0},\"stroke\":8}", NULL) == FFD_OK);
    CHECK(undo_count(s) == u0 + 2);
    CHECK(run(s, "move", "{\"points\":[63],\"delta\":[0.1,0,0]}", NULL) == FFD_OK);
    CHECK(run(s, "weights", "{\"vertices\":{\"501\":0},\"stroke\":8}", NULL) == FFD_OK);
    CHECK(undo_count(s) == u0 + 4); /* the move came between: a new step */
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    float *back = positions(s, &n);
    CHECK(max_change(back, stroke1, n) == 0);
    float *w = weights(s, n);
    CHECK(w && w[10] == 0.2f && w[11] == 0.3f && w[12] == 0.4f && w[500] == 1.0f);
    free(w);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK); /* the whole first stroke */
    free(back);
    back = positions(s, &n);
    CHECK(max_change(back, moved, n) == 0);
    w = weights(s, n);
    CHECK(w && w[10] == 1.0f && w[11] == 1.0f && w[12] == 1.0f);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK); /* the move, a snapshot of the unwrapped lattice */
    free(back);
    back = positions(s, &n);
    CHECK(max_change(back, rest, n) < 1e-6);
    CHECK(run(s, "redo", NULL, NULL) == FFD_OK);
    CHECK(run(s, "redo", NULL, NULL) == FFD_OK);
    free(back);
    back = positions(s, &n);
    CHECK(max_change(back, stroke1, n) == 0);
    CHECK(replay_difference(s) < 1e-5);
    free(rest), free(moved), free(stroke1), free(back), free(w);
    ffd_session_destroy(s);
}

/* Refused with a message naming what is wrong; nothing changes, not even
 * the weights or the revision. */
static void test_bad_requests(void)
{
    ffd_session *s = open_session();
    ffd_error err = {{0}};
    CHECK(run(s, "weights", "{\"vertices\":{\"0\":0.5}}", &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "conflict: ") == err.message); /* no deformer */
    CHECK(run(s, "create", "{\"deformer\":\"lattice\"}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[62],\"delta\":[0,3,0]}", NULL) == FFD_OK);
    CHECK(run(s, "weights", "{\"vertices\":{\"3\":0.25}}", NULL) == FFD_OK);
    size_t n = 0;
    float *p0 = positions(s, &n);
    char *before = NULL, *after = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_state(s, &before, &size, NULL));
    static const struct {
        const char *body;
        ffd_status status;
        const char *says;
    } bad[] = {
        {"{\"vertices\":{\"1839\":0.5}}", FFD_ERR_RANGE, "vertex 1839 out of range (1839 vertices)"},
        {"{\"vertices\":{\"5\":0.5,\"99999999999\":1}}", FFD_ERR_RANGE, "out of range"},
        {"{\"vertices\":{\"-1\":0.5}}", FFD_ERR_PARSE, "key '-1'"},
        {"{\"vertices\":{\"x\":0.5}}", FFD_ERR_PARSE, "key 'x'"},
        {"{\"vertices\":{\"07\":0.5}}", FFD_ERR_PARSE, "key '07'"},
        {"{\"vertices\":{\"5\":0,\"5\":1}}", FFD_ERR_PARSE, "vertices: vertex 5 given twice"},
        {"{\"vertices\":{\"5\":1e999}}", FFD_ERR_NONFINITE, "vertices.5: expected a finite number"},
        {"{\"vertices\":{\"5\":1.5}}", FFD_ERR_RANGE, "vertices.5: the weight 1.5 is outside [0, 1]"},
        {"{\"vertices\":{\"5\":-0.25}}", FFD_ERR_RANGE, "outside [0, 1]"},
        {"{\"vertices\":{\"5\":\"half\"}}", FFD_ERR_PARSE, "vertices.5: expected a number"},
        {"{\"vertices\":[0.5]}", FFD_ERR_PARSE, "vertices: expected an object"},
        {"{\"values\":[0.5,1]}", FFD_ERR_INVALID, "values: 2 weights for 1839 vertices"},
        {"{\"values\":{}}", FFD_ERR_PARSE, "values: expected an array"},
        {"{\"clear\":false}", FFD_ERR_PARSE, "clear: expected true"},
        {"{}", FFD_ERR_PARSE, "expected one of"},
        {"{\"clear\":true,\"vertices\":{}}", FFD_ERR_PARSE, "expected one of"},
        {"{\"vertices\":{},\"stroke\":0}", FFD_ERR_PARSE, "stroke: expected a positive integer"},
        {"{\"vertices\":{},\"stroke\":1.5}", FFD_ERR_PARSE, "stroke"},
        {"{\"vertices\":{},\"brush\":1}", FFD_ERR_PARSE, "brush"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        err.message[0] = 0;
        ffd_status st = run(s, "weights", bad[i].body, &err);
        if (st != bad[i].status || !strstr(err.message, bad[i].says) ||
            strncmp(err.message, "weights: ", 9) != 0) {
            fprintf(stderr, "  %s: status %d, message '%s'; expected %d with '%s'\n", bad[i].body,
                    (int)st, err.message, (int)bad[i].status, bad[i].says);
            check_failures++;
        }
    }
    /* values with one bad weight among good ones: none taken */
    char *values = malloc(8 * n + 32), *q = values;
    q += sprintf(q, "{\"values\":[");
    for (size_t i = 0; i < n; i++)
        q += sprintf(q, "%s%g", i ? "," : "", i == 1000 ? 2.0 : 0.0);
    sprintf(q, "]}");
    CHECK(run(s, "weights", values, &err) == FFD_ERR_RANGE);
    CHECK(strstr(err.message, "values[1000]"));
    CHECK(run(s, "weights_values", "{\"x\":1}", &err) == FFD_ERR_PARSE);
    CHECK_OK(ffd_session_state(s, &after, &size, NULL));
    if (before && after) {
        *strstr(before, ",\"busy_ms\"") = 0;
        *strstr(after, ",\"busy_ms\"") = 0;
        CHECK(strcmp(before, after) == 0);
    }
    float *p1 = positions(s, &n), *w = weights(s, n);
    CHECK(max_change(p0, p1, n) == 0);
    CHECK(w && w[3] == 0.25f && w[5] == 1.0f && w[1000] == 1.0f);
    CHECK(replay_difference(s) < 1e-5);
    free(values), free(p0), free(p1), free(w);
    ffd_free(before);
    ffd_free(after);
    ffd_session_destroy(s);
}

/* A session without a deformer has no weights to paint but answers
 * weights_values with ones. */
static void test_values_without_deformer(void)
{
    ffd_session *s = open_session();
    float *w = weights(s, 1839);
    int ones = 1;
    for (size_t i = 0; w && i < 1839; i++)
        ones &= w[i] == 1.0f;
    CHECK(w && ones);
    free(w);
    ffd_session_destroy(s);
}

/* ffd_session_load_weights: a weights file's text (blank and '#' lines
 * skipped) gives what the op's "values" give, one undo step; a bad file is
 * refused naming the line or the count, changing nothing. */
static void test_load_weights_file(void)
{
    ffd_session *s = open_session();
    ffd_error err = {{0}};
    size_t n = 1839;
    char *text = malloc(8 * n + 64), *q = text;
    q += sprintf(q, "# weights\n\n");
    for (size_t i = 0; i < n; i++)
        q += sprintf(q, "%g\n", (double)(i % 4) / 3.0);
    CHECK(ffd_session_load_weights(s, text, strlen(text), "w.txt", &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "conflict: ") == err.message); /* no deformer */
    CHECK(run(s, "create", "{\"deformer\":\"lattice\",\"resolution\":[4,4,4]}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[21,22],\"delta\":[0.8,1.5,-0.4]}", NULL) == FFD_OK);
    float *p0 = positions(s, &n);
    int u0 = undo_count(s);
    static const struct {
        const char *text;
        ffd_status status;
        const char *says;
    } bad[] = {
        {"0.5\nhalf\n", FFD_ERR_PARSE, "w.txt:2: expected one weight (a number) per line, found 'half'"},
        {"0.5\n0.5 0.5\n", FFD_ERR_PARSE, "w.txt:2:"},
        {"nan\n", FFD_ERR_NONFINITE, "w.txt:1: the weight is not finite"},
        {"0.5\n1\n", FFD_ERR_INVALID, "w.txt: 2 weights for 1839 vertices"},
        {"", FFD_ERR_INVALID, "w.txt: 0 weights for 1839 vertices"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        err.message[0] = 0;
        ffd_status st = ffd_session_load_weights(s, bad[i].text, strlen(bad[i].text), "w.txt", &err);
        if (st != bad[i].status || !strstr(err.message, bad[i].says)) {
            fprintf(stderr, "  %s: status %d, message '%s'\n", bad[i].text, (int)st, err.message);
            check_failures++;
        }
    }
    char *range = malloc(8 * n + 8), *r = range;
    for (size_t i = 0; i < n; i++)
        r += sprintf(r, "%g\n", i == 7 ? 1.5 : 1.0);
    CHECK(ffd_session_load_weights(s, range, strlen(range), "w.txt", &err) == FFD_ERR_RANGE);
    CHECK(strstr(err.message, "vertex 7 is 1.5, outside [0, 1]"));
    float *p1 = positions(s, &n);
    CHECK(max_change(p0, p1, n) == 0 && undo_count(s) == u0);
    CHECK_OK(ffd_session_load_weights(s, text, strlen(text), "w.txt", &err));
    CHECK(undo_count(s) == u0 + 1);
    float *w = weights(s, n);
    CHECK(w && w[0] == 0.0f && w[3] == 1.0f && fabs(w[1] - 1.0 / 3.0) < 1e-6 && fabs(w[1838] - 2.0 / 3.0) < 1e-6);
    CHECK(replay_difference(s) < 1e-5);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK);
    float *p2 = positions(s, &n);
    CHECK(max_change(p0, p2, n) == 0);
    free(text), free(range), free(p0), free(p1), free(p2), free(w);
    ffd_session_destroy(s);
}

/* Every allocation of a weights step may fail: a clean NOMEM, no leak, and
 * a session that takes the step again and replays. */
static void test_allocation_failures(void)
{
    for (long k = 0; k < 400; k += 9) {
        ffd_session *s = open_session();
        CHECK(run(s, "create", "{\"deformer\":\"lattice\",\"resolution\":[3,3,3]}", NULL) == FFD_OK);
        CHECK(run(s, "move", "{\"points\":[13],\"delta\":[0,1,0]}", NULL) == FFD_OK);
        size_t n = 0;
        float *p0 = positions(s, &n);
        fail_alloc fa = {k, 0};
        ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&a);
        ffd_error err;
        ffd_status st = run(s, "weights", "{\"vertices\":{\"7\":0.5,\"8\":0}}", &err);
        ffd_set_allocator(NULL);
        CHECK(st == FFD_OK || st == FFD_ERR_NOMEM);
        /* (the allocator keeps failing, so a roll back may fail too, as for
         * any op: the session stays usable, and the next step repairs it) */
        CHECK(run(s, "weights", "{\"vertices\":{\"7\":0.5,\"8\":0}}", NULL) == FFD_OK);
        float *p1 = positions(s, &n);
        CHECK(max_change(p0, p1, n) > 0);
        CHECK(replay_difference(s) < 1e-5);
        free(p0), free(p1);
        ffd_session_destroy(s);
        if (st == FFD_OK)
            break;
    }
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"weights_scale_and_replay", test_weights_scale_and_replay},
        {"one_undo_step_per_stroke", test_one_undo_step_per_stroke},
        {"every_method", test_every_method},
        {"bad_requests", test_bad_requests},
        {"values_without_deformer", test_values_without_deformer},
        {"load_weights_file", test_load_weights_file},
        {"allocation_failures", test_allocation_failures},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
