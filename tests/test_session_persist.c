/* Work is never lost (docs/editor.md "Work is never lost"): pins in the
 * rig (round trip, replay, bad vertex ids), the history's named steps and
 * history_goto, and the autosave record written and resumed in a temporary
 * directory: state, pins and history come back exactly; a record of
 * another mesh version, a malformed one, or a session with changes is
 * refused and changes nothing. */
#include "check.h"
#include "ffd.h"
#include "rig/rig_json.h"

#include <cJSON.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/stat.h>
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
    CHECK_OK(ffd_session_create(mesh, "bunny.obj", NULL, &s, NULL));
    return s;
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

/* The frame's vertex and control positions (without the header: its revision differs). */
static float *frame(const ffd_session *s, size_t *count)
{
    void *data = NULL;
    size_t size = 0;
    *count = 0;
    if (ffd_session_frame(s, &data, &size, NULL) != FFD_OK)
        return NULL;
    uint32_t head[5];
    memcpy(head, data, 20);
    *count = 3 * ((size_t)head[2] + head[3]);
    float *p = malloc(4 * *count + 4);
    memcpy(p, (char *)data + 20, 4 * *count);
    ffd_free(data);
    return p;
}

static int same_frame(const float *a, size_t na, const float *b, size_t nb)
{
    return a && b && na == nb && memcmp(a, b, 4 * na) == 0;
}

static cJSON *state(const ffd_session *s)
{
    char *json = NULL;
    size_t size = 0;
    if (ffd_session_state(s, &json, &size, NULL) != FFD_OK)
        return NULL;
    cJSON *doc = cJSON_Parse(json);
    ffd_free(json);
    return doc;
}

/* The state's pins as "vertex:x,y,z;..." (17 digits). */
static void pins_text(const ffd_session *s, char *out, size_t size)
{
    cJSON *doc = state(s);
    const cJSON *pin;
    size_t used = 0;
    out[0] = 0;
    cJSON_ArrayForEach(pin, cJSON_GetObjectItem(doc, "pins"))
    {
        const cJSON *t = cJSON_GetObjectItem(pin, "target");
        used += (size_t)snprintf(out + used, size - used, "%d:%.17g,%.17g,%.17g;",
                                 cJSON_GetObjectItem(pin, "vertex")->valueint,
                                 cJSON_GetArrayItem(t, 0)->valuedouble,
                                 cJSON_GetArrayItem(t, 1)->valuedouble,
                                 cJSON_GetArrayItem(t, 2)->valuedouble);
    }
    cJSON_Delete(doc);
}

/* The history as "current|name|name|...". */
static void history_text(const ffd_session *s, char *out, size_t size)
{
    char *json = NULL;
    size_t n = 0;
    out[0] = 0;
    if (ffd_session_history(s, &json, &n, NULL) != FFD_OK)
        return;
    cJSON *doc = cJSON_Parse(json);
    ffd_free(json);
    size_t used = (size_t)snprintf(out, size, "%d", cJSON_GetObjectItem(doc, "current")->valueint);
    const cJSON *step;
    cJSON_ArrayForEach(step, cJSON_GetObjectItem(doc, "steps"))
        used += (size_t)snprintf(out + used, size - used, "|%s", step->valuestring);
    cJSON_Delete(doc);
}

/* A lattice, a drag, two pins: the state the tests save and restore. */
static void edit(ffd_session *s)
{
    CHECK(run(s, "create", "{\"deformer\":\"lattice\",\"resolution\":[4,4,4]}", NULL) == FFD_OK);
    CHECK(run(s, "move", "{\"points\":[21,22,25],\"delta\":[0,0.4,0.1]}", NULL) == FFD_OK);
    CHECK(run(s, "pin", "{\"vertex\":893}", NULL) == FFD_OK);
    CHECK(run(s, "pin", "{\"vertex\":12,\"target\":[0.5,1.2,0.3]}", NULL) == FFD_OK);
}

static void test_pins_in_the_rig(void)
{
    ffd_session *s = open_session(BUNNY);
    edit(s);
    char *text = NULL;
    size_t size = 0;
    ffd_rig *rig = NULL;
    CHECK_OK(ffd_session_rig(s, &text, &size, NULL));
    CHECK_OK(ffd_rig_parse_json(text, size, "session.json", &rig, NULL));
    CHECK(rig && rig->pin_count == 2);
    if (rig && rig->pin_count == 2) {
        CHECK(rig->pins[0].vertex == 893 && rig->pins[1].vertex == 12);
        CHECK(rig->pins[1].target[0] == 0.5 && rig->pins[1].target[1] == 1.2 &&
              rig->pins[1].target[2] == 0.3);
    }
    /* written back by the rig writer: the same pins */
    char *again = NULL;
    ffd_rig *reread = NULL;
    CHECK_OK(ffd_rig_write_json(rig, &again, NULL));
    CHECK_OK(ffd_rig_parse_json(again, strlen(again), "again.json", &reread, NULL));
    CHECK(reread && reread->pin_count == 2);
    for (size_t i = 0; reread && reread->pin_count == 2 && i < 2; i++) {
        CHECK(reread->pins[i].vertex == rig->pins[i].vertex);
        CHECK(memcmp(reread->pins[i].target, rig->pins[i].target, sizeof rig->pins[i].target) == 0);
    }
    /* pins do not change a deform: the moves hold the result */
    ffd_mesh *with = NULL, *without = NULL;
    CHECK_OK(ffd_mesh_read(BUNNY, &with, NULL));
    CHECK_OK(ffd_mesh_read(BUNNY, &without, NULL));
    CHECK_OK(ffd_rig_apply(rig, with, NULL, NULL));
    size_t pin_count = rig->pin_count;
    rig->pin_count = 0;
    CHECK_OK(ffd_rig_apply(rig, without, NULL, NULL));
    rig->pin_count = pin_count;
    CHECK(memcmp(ffd_mesh_positions(with), ffd_mesh_positions(without),
                 3 * sizeof(double) * ffd_mesh_vertex_count(with)) == 0);
    /* loading the rig brings the pins back, and the same frame */
    char before[512], after[512];
    pins_text(s, before, sizeof before);
    size_t na, nb;
    float *fa = frame(s, &na);
    ffd_session *t = open_session(BUNNY);
    CHECK_OK(ffd_session_load_rig(t, text, size, "session.json", NULL, NULL));
    pins_text(t, after, sizeof after);
    CHECK(strcmp(before, after) == 0 && strlen(before) > 10);
    float *fb = frame(t, &nb);
    for (size_t i = 0; fa && fb && na == nb && i < na; i++)
        CHECK_NEAR(fa[i], fb[i], 1e-5);
    /* and the load is one step, undone with its pins */
    CHECK(run(t, "undo", NULL, NULL) == FFD_OK);
    pins_text(t, after, sizeof after);
    CHECK(after[0] == 0);
    free(fa);
    free(fb);
    ffd_mesh_destroy(with);
    ffd_mesh_destroy(without);
    ffd_rig_destroy(rig);
    ffd_rig_destroy(reread);
    ffd_free(again);
    ffd_free(text);
    ffd_session_destroy(s);
    ffd_session_destroy(t);
}

static void test_bad_pins(void)
{
    static const char head[] = "{\"version\":1,\"deformer\":\"lattice\",\"resolution\":[2,2,2],";
    char text[512];
    ffd_error err = {{0}};
    ffd_rig *rig = NULL;
    /* a vertex the mesh does not have: applying (ffd deform) and loading say which */
    snprintf(text, sizeof text, "%s\"pins\":[{\"vertex\":3,\"target\":[0,0,0]},"
                                "{\"vertex\":5000,\"target\":[1,2,3]}]}", head);
    CHECK_OK(ffd_rig_parse_json(text, strlen(text), "pinned.json", &rig, NULL));
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_mesh_read(BUNNY, &mesh, NULL));
    CHECK(ffd_rig_apply(rig, mesh, NULL, &err) == FFD_ERR_RANGE);
    CHECK(strcmp(err.message, "pinned.json: pins[1].vertex: 5000 out of range: the mesh has "
                              "1839 vertices (ids 0 to 1838)") == 0);
    ffd_session *s = open_session(BUNNY);
    CHECK(run(s, "create", "{\"deformer\":\"lattice\"}", NULL) == FFD_OK);
    char before[256], after[256];
    history_text(s, before, sizeof before);
    CHECK(ffd_session_load_rig(s, text, strlen(text), "pinned.json", NULL, &err) ==
          FFD_ERR_RANGE);
    CHECK(strstr(err.message, "pins[1].vertex: 5000 out of range") != NULL);
    history_text(s, after, sizeof after);
    CHECK(strcmp(before, after) == 0); /* nothing changed */
    /* malformed pins are parse errors naming the key */
    static const struct {
        const char *pins, *message;
    } bad[] = {
        {"{\"vertex\":1}", "bad.json: pins: expected an array of {\"vertex\": id, \"target\": [x, y, z]}"},
        {"[{\"vertex\":1}]", "bad.json: pins[0].target: expected an array of 3 finite numbers (missing)"},
        {"[{\"target\":[0,0,0]}]", "bad.json: pins[0].vertex: expected a vertex id (missing)"},
        {"[{\"vertex\":-1,\"target\":[0,0,0]}]", "pins[0].vertex"},
        {"[{\"vertex\":1,\"target\":[0,0,0],\"weight\":2}]", "weight"},
        {"[{\"vertex\":1,\"target\":[0,0,0]},{\"vertex\":1,\"target\":[1,0,0]}]",
         "bad.json: pins[1].vertex: vertex 1 is pinned twice (pins[0] too)"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        ffd_rig *b = NULL;
        snprintf(text, sizeof text, "%s\"pins\":%s}", head, bad[i].pins);
        CHECK(ffd_rig_parse_json(text, strlen(text), "bad.json", &b, &err) == FFD_ERR_PARSE);
        CHECK(strstr(err.message, bad[i].message) != NULL);
        if (!strstr(err.message, bad[i].message))
            fprintf(stderr, "  %s -> %s\n", bad[i].pins, err.message);
        CHECK(b == NULL);
    }
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
    ffd_session_destroy(s);
}

static void test_history_goto(void)
{
    ffd_session *s = open_session(BUNNY);
    size_t n[6];
    float *f[6];
    f[0] = frame(s, &n[0]);
    CHECK(run(s, "create", "{\"deformer\":\"lattice\",\"resolution\":[5,5,5]}", NULL) == FFD_OK);
    f[1] = frame(s, &n[1]);
    CHECK(run(s, "move", "{\"points\":[30,31,32],\"delta\":[0,0.3,0]}", NULL) == FFD_OK);
    f[2] = frame(s, &n[2]);
    CHECK(run(s, "pin", "{\"vertex\":893}", NULL) == FFD_OK);
    f[3] = frame(s, &n[3]);
    CHECK(run(s, "move", "{\"points\":[7],\"angle\":0.3,\"axis\":[0,1,0]}", NULL) == FFD_OK);
    f[4] = frame(s, &n[4]);
    CHECK(run(s, "unpin", "{\"all\":true}", NULL) == FFD_OK);
    f[5] = frame(s, &n[5]);
    char h[512];
    history_text(s, h, sizeof h);
    CHECK(strcmp(h, "5|Open bunny.obj|Create lattice 5\xc3\x97" "5\xc3\x97" "5|Drag 3 controls|"
                    "Pin vertex 893|Rotate control 7|Unpin all (1 pin)") == 0);
    if (strncmp(h, "5|", 2) != 0)
        fprintf(stderr, "  %s\n", h);
    /* every step, in any order, gives that step's frame */
    static const int order[] = {1, 4, 0, 5, 2, 3, 3, 0};
    for (size_t i = 0; i < sizeof order / sizeof *order; i++) {
        char body[32];
        snprintf(body, sizeof body, "{\"index\":%d}", order[i]);
        CHECK(run(s, "history_goto", body, NULL) == FFD_OK);
        size_t m;
        float *g = frame(s, &m);
        if (order[i] == 0)
            CHECK(m == n[0]); /* no deformer: no controls */
        CHECK(m >= n[0] && memcmp(g, f[order[i]], 4 * n[0]) == 0);
        if (order[i] > 0)
            CHECK(same_frame(g, m, f[order[i]], n[order[i]]));
        free(g);
        cJSON *st = state(s);
        CHECK(cJSON_GetObjectItem(st, "undo")->valueint == order[i]);
        CHECK(cJSON_GetObjectItem(cJSON_GetObjectItem(st, "history"), "current")->valueint ==
              order[i]);
        CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(st, "pins")) == (order[i] == 3 || order[i] == 4));
        cJSON_Delete(st);
    }
    /* a bad request changes nothing */
    char before[512], after[512];
    history_text(s, before, sizeof before);
    ffd_error err = {{0}};
    CHECK(run(s, "history_goto", "{\"index\":6}", &err) == FFD_ERR_RANGE);
    CHECK(strcmp(err.message, "history_goto: index: 6 out of range (the history has 6 steps, 0 to 5)") == 0);
    CHECK(run(s, "history_goto", "{}", &err) == FFD_ERR_PARSE);
    CHECK(run(s, "history_goto", "{\"index\":1,\"x\":1}", &err) == FFD_ERR_PARSE);
    CHECK(run(s, "history_goto", "{\"index\":-1}", &err) == FFD_ERR_PARSE);
    history_text(s, after, sizeof after);
    CHECK(strcmp(before, after) == 0);
    /* a new change after going back drops the steps after it, like undo */
    CHECK(run(s, "history_goto", "{\"index\":2}", NULL) == FFD_OK);
    CHECK(run(s, "reset", NULL, NULL) == FFD_OK);
    history_text(s, h, sizeof h);
    CHECK(strcmp(h, "3|Open bunny.obj|Create lattice 5\xc3\x97" "5\xc3\x97" "5|Drag 3 controls|"
                    "Reset to rest") == 0);
    for (int i = 0; i < 6; i++)
        free(f[i]);
    ffd_session_destroy(s);
}

/* A temporary directory's file path. */
static void temp_path(char *dir, size_t size, char *path, const char *name)
{
    snprintf(dir, size, "/tmp/ffd-persist-XXXXXX");
    CHECK(mkdtemp(dir) != NULL);
    snprintf(path, 4200, "%s/%s", dir, name);
}

static void test_autosave_and_resume(void)
{
    char dir[64], path[4200];
    temp_path(dir, sizeof dir, path, "autosave-bunny.obj.json");
    ffd_session *s = open_session(BUNNY);
    edit(s);
    CHECK(run(s, "undo", NULL, NULL) == FFD_OK); /* a redo step to keep as well */
    CHECK_OK(ffd_session_autosave(s, path, "bunny.obj", NULL));
    struct stat sb;
    CHECK(stat(path, &sb) == 0 && sb.st_size > 100);
    char tmp[4300];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    CHECK(access(tmp, F_OK) != 0); /* written through a renamed temporary */
    unsigned char *text = NULL;
    size_t size = 0;
    CHECK_OK(ffd_read_file(path, &text, &size, NULL));

    ffd_session *t = open_session(BUNNY);
    CHECK_OK(ffd_session_resume(t, (const char *)text, size, "autosave", NULL, NULL));
    char a[1024], b[1024];
    history_text(s, a, sizeof a);
    history_text(t, b, sizeof b);
    CHECK(strcmp(a, b) == 0);
    pins_text(s, a, sizeof a);
    pins_text(t, b, sizeof b);
    CHECK(strcmp(a, b) == 0 && strlen(a) > 5);
    cJSON *st = state(t);
    const cJSON *note = cJSON_GetObjectItem(st, "autosave");
    CHECK(cJSON_IsTrue(cJSON_GetObjectItem(note, "resumed")));
    CHECK(cJSON_IsString(cJSON_GetObjectItem(note, "saved")));
    CHECK(cJSON_GetObjectItem(st, "undo")->valueint == 3 && cJSON_GetObjectItem(st, "redo")->valueint == 1);
    cJSON_Delete(st);
    /* the file it goes to joins the note */
    ffd_session_set_autosave_file(t, ".ffd/autosave-bunny.obj.json");
    st = state(t);
    note = cJSON_GetObjectItem(st, "autosave");
    CHECK(cJSON_IsTrue(cJSON_GetObjectItem(note, "resumed")));
    CHECK(cJSON_IsString(cJSON_GetObjectItem(note, "file")) &&
          !strcmp(cJSON_GetObjectItem(note, "file")->valuestring, ".ffd/autosave-bunny.obj.json"));
    cJSON_Delete(st);
    /* every step of the resumed history is the saved session's */
    for (int i = 4; i >= 0; i--) {
        char body[32];
        snprintf(body, sizeof body, "{\"index\":%d}", i);
        CHECK(run(s, "history_goto", body, NULL) == FFD_OK);
        CHECK(run(t, "history_goto", body, NULL) == FFD_OK);
        size_t na, nb;
        float *fa = frame(s, &na), *fb = frame(t, &nb);
        CHECK(na == nb);
        for (size_t k = 0; fa && fb && na == nb && k < na; k++)
            CHECK_NEAR(fa[k], fb[k], 1e-5);
        free(fa);
        free(fb);
        pins_text(s, a, sizeof a);
        pins_text(t, b, sizeof b);
        CHECK(strcmp(a, b) == 0);
    }
    /* long jumps in the resumed history (every step rebuilds from its rig:
     * only the target is built) give the same steps, frames and pins, and
     * leave stacks that undo and redo one step at a time like the original */
    static const int jumps[] = {4, 0, 3, 1, 4, 2};
    for (size_t j = 0; j < sizeof jumps / sizeof *jumps; j++) {
        char body[32];
        snprintf(body, sizeof body, "{\"index\":%d}", jumps[j]);
        CHECK(run(s, "history_goto", body, NULL) == FFD_OK);
        CHECK(run(t, "history_goto", body, NULL) == FFD_OK);
        for (int step = 0; step < 3; step++) {
            history_text(s, a, sizeof a);
            history_text(t, b, sizeof b);
            CHECK(strcmp(a, b) == 0);
            pins_text(s, a, sizeof a);
            pins_text(t, b, sizeof b);
            CHECK(strcmp(a, b) == 0);
            size_t na, nb;
            float *fa = frame(s, &na), *fb = frame(t, &nb);
            CHECK(na == nb);
            for (size_t k = 0; fa && fb && na == nb && k < na; k++)
                CHECK_NEAR(fa[k], fb[k], 1e-5);
            free(fa);
            free(fb);
            /* then one undo (or redo at the start) on both */
            const char *op = step == 1 ? "redo" : "undo";
            ffd_error e1 = {{0}}, e2 = {{0}};
            CHECK(run(s, op, NULL, &e1) == run(t, op, NULL, &e2));
        }
    }
    /* resuming twice, or into a session with changes, is refused */
    ffd_error err = {{0}};
    CHECK(ffd_session_resume(t, (const char *)text, size, "autosave", NULL, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "the session has changes already") != NULL);

    /* another mesh: refused, nothing changes, the note says why */
    ffd_mesh *cow = NULL;
    ffd_session *c = NULL;
    CHECK_OK(ffd_mesh_read(COW, &cow, NULL));
    CHECK_OK(ffd_session_create(cow, "bunny.obj", NULL, &c, NULL));
    CHECK(ffd_session_resume(c, (const char *)text, size, "autosave", "kept.json", &err) ==
          FFD_ERR_INVALID);
    CHECK(strstr(err.message, "autosave: saved for another version of bunny.obj (1839 vertices") &&
          strstr(err.message, "; kept as kept.json"));
    history_text(c, a, sizeof a);
    CHECK(strcmp(a, "0|Open bunny.obj") == 0);
    st = state(c);
    note = cJSON_GetObjectItem(st, "autosave");
    CHECK(cJSON_IsFalse(cJSON_GetObjectItem(note, "resumed")));
    CHECK(cJSON_IsString(cJSON_GetObjectItem(note, "reason")) &&
          strstr(cJSON_GetObjectItem(note, "reason")->valuestring, "another version"));
    CHECK(cJSON_IsNull(cJSON_GetObjectItem(st, "method")));
    cJSON_Delete(st);
    /* the same vertex count, one vertex moved: refused too */
    ffd_mesh *moved = NULL;
    CHECK_OK(ffd_mesh_read(BUNNY, &moved, NULL));
    size_t nv = ffd_mesh_vertex_count(moved);
    double *x = malloc(3 * nv * sizeof *x);
    memcpy(x, ffd_mesh_positions(moved), 3 * nv * sizeof *x);
    x[7] += 1e-9;
    CHECK_OK(ffd_mesh_set_positions(moved, x, NULL, NULL));
    free(x);
    ffd_session *m = NULL;
    CHECK_OK(ffd_session_create(moved, "bunny.obj", NULL, &m, NULL));
    CHECK(ffd_session_resume(m, (const char *)text, size, "autosave", NULL, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "the same 1839 vertices and 3674 faces, but other positions") != NULL);
    /* a cut-off or malformed record */
    ffd_session *u = open_session(BUNNY);
    CHECK(ffd_session_resume(u, (const char *)text, size / 2, "autosave", NULL, &err) == FFD_ERR_PARSE);
    CHECK(ffd_session_resume(u, "{\"format\":\"x\"}", 14, "autosave", NULL, &err) == FFD_ERR_PARSE);
    CHECK(strcmp(err.message, "autosave: format: not an autosave this version of ffd writes") == 0);
    history_text(u, a, sizeof a);
    CHECK(strcmp(a, "0|Open bunny.obj") == 0);
    /* a drag in progress is not saved (only whole steps are) */
    CHECK(run(u, "create", "{\"deformer\":\"lattice\"}", NULL) == FFD_OK);
    CHECK(run(u, "drag_begin", "{\"points\":[1]}", NULL) == FFD_OK);
    char *json = NULL;
    CHECK(ffd_session_autosave_text(u, NULL, &json, &size, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "a drag is in progress") != NULL);
    ffd_free(text);
    ffd_session_destroy(s);
    ffd_session_destroy(t);
    ffd_session_destroy(c);
    ffd_session_destroy(m);
    ffd_session_destroy(u);
    unlink(path);
    rmdir(dir);
}

/* More steps than an autosave keeps: the newest FFD_AUTOSAVE_STEPS, the
 * first of them named after its change. */
static void test_autosave_cap(void)
{
    ffd_session *s = open_session(BUNNY);
    CHECK(run(s, "create", "{\"deformer\":\"lattice\",\"resolution\":[2,2,2]}", NULL) == FFD_OK);
    for (int i = 0; i < FFD_AUTOSAVE_STEPS + 5; i++)
        CHECK(run(s, "move", "{\"points\":[1],\"delta\":[0,0.001,0]}", NULL) == FFD_OK);
    char *json = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_autosave_text(s, NULL, &json, &size, NULL));
    ffd_session *t = open_session(BUNNY);
    CHECK_OK(ffd_session_resume(t, json, size, "autosave", NULL, NULL));
    cJSON *st = state(t);
    const cJSON *h = cJSON_GetObjectItem(st, "history");
    CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(h, "steps")) == FFD_AUTOSAVE_STEPS);
    CHECK(cJSON_GetObjectItem(h, "current")->valueint == FFD_AUTOSAVE_STEPS - 1);
    CHECK(strcmp(cJSON_GetArrayItem(cJSON_GetObjectItem(h, "steps"), 0)->valuestring,
                 "Drag control 1") == 0);
    cJSON_Delete(st);
    size_t na, nb;
    float *fa = frame(s, &na), *fb = frame(t, &nb);
    CHECK(same_frame(fa, na, fb, nb) || (fa && fb && na == nb));
    for (size_t k = 0; fa && fb && na == nb && k < na; k++)
        CHECK_NEAR(fa[k], fb[k], 1e-5);
    free(fa);
    free(fb);
    ffd_free(json);
    ffd_session_destroy(s);
    ffd_session_destroy(t);
}

/* Structural steps (a T-spline refinement, undone by rebuilding) in the
 * history, its names, goto across them and their resume. */
static void test_structural_steps(void)
{
    ffd_session *s = open_session(BUNNY);
    CHECK(run(s, "create", "{\"deformer\":\"tspline\",\"resolution\":[4,4,4]}", NULL) == FFD_OK);
    size_t n[4];
    float *f[4];
    f[0] = frame(s, &n[0]);
    CHECK(run(s, "refine", "{\"insertions\":[{\"cell\":13}]}", NULL) == FFD_OK);
    f[1] = frame(s, &n[1]);
    CHECK(run(s, "move", "{\"points\":[3],\"delta\":[0.2,0,0],\"arap\":false}", NULL) == FFD_OK);
    f[2] = frame(s, &n[2]);
    CHECK(run(s, "freeze", "{\"points\":[1,2],\"frozen\":true}", NULL) == FFD_OK);
    f[3] = frame(s, &n[3]);
    char h[512];
    history_text(s, h, sizeof h);
    CHECK(strcmp(h, "4|Open bunny.obj|Create T-spline 4\xc3\x97" "4\xc3\x97" "4|Refine T-spline cell 13|"
                    "Drag control 3|Freeze 2 points") == 0);
    if (strncmp(h, "4|", 2) != 0 || !strstr(h, "Freeze"))
        fprintf(stderr, "  %s\n", h);
    char *json = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_autosave_text(s, NULL, &json, &size, NULL));
    ffd_session *t = open_session(BUNNY);
    CHECK_OK(ffd_session_resume(t, json, size, "autosave", NULL, NULL));
    static const int order[] = {1, 2, 4, 3};
    for (size_t i = 0; i < sizeof order / sizeof *order; i++) {
        char body[32];
        snprintf(body, sizeof body, "{\"index\":%d}", order[i]);
        for (int w = 0; w < 2; w++) {
            ffd_session *x = w ? t : s;
            CHECK(run(x, "history_goto", body, NULL) == FFD_OK);
            size_t m;
            float *g = frame(x, &m);
            CHECK(m == n[order[i] - 1]);
            for (size_t k = 0; g && m == n[order[i] - 1] && k < m; k++)
                CHECK_NEAR(g[k], f[order[i] - 1][k], 1e-5);
            free(g);
        }
    }
    for (int i = 0; i < 4; i++)
        free(f[i]);
    ffd_free(json);
    ffd_session_destroy(s);
    ffd_session_destroy(t);
}

/* The record's byte budget: the present step always, then the steps
 * before it, newest first, then those after it. */
static void test_autosave_byte_budget(void)
{
    ffd_mesh *mesh = NULL;
    ffd_session *s = NULL;
    CHECK_OK(ffd_mesh_read(BUNNY, &mesh, NULL));
    ffd_session_options o = {0};
    o.autosave_max_bytes = 1;
    CHECK_OK(ffd_session_create(mesh, "bunny.obj", &o, &s, NULL));
    CHECK(run(s, "create", "{\"deformer\":\"lattice\",\"resolution\":[3,3,3]}", NULL) == FFD_OK);
    for (int i = 0; i < 6; i++)
        CHECK(run(s, "move", "{\"points\":[4],\"delta\":[0,0.01,0]}", NULL) == FFD_OK);
    CHECK(run(s, "history_goto", "{\"index\":5}", NULL) == FFD_OK);
    char *json = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_autosave_text(s, NULL, &json, &size, NULL));
    cJSON *doc = cJSON_Parse(json);
    const cJSON *h = cJSON_GetObjectItem(doc, "history");
    /* one byte: only the present step (step 5 of 8) */
    CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(h, "steps")) == 1);
    CHECK(cJSON_GetObjectItem(h, "current")->valueint == 0);
    CHECK(cJSON_GetObjectItem(h, "dropped")->valueint == 5);
    CHECK(!strcmp(cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(h, "steps"), 0), "name")->valuestring,
                  "Drag control 4"));
    cJSON_Delete(doc);
    ffd_free(json);
    ffd_session *t = open_session(BUNNY);
    CHECK_OK(ffd_session_autosave_text(s, NULL, &json, &size, NULL));
    CHECK_OK(ffd_session_resume(t, json, size, "autosave", NULL, NULL));
    char a[512];
    history_text(t, a, sizeof a);
    CHECK(strcmp(a, "0|Drag control 4") == 0);
    ffd_free(json);
    ffd_session_destroy(t);
    ffd_session_destroy(s);
}

static void test_allocation_failures(void)
{
    /* every allocation of an autosave, a resume and a goto may fail: clean errors, no leaks */
    ffd_session *s = open_session(BUNNY);
    edit(s);
    /* dense over the first allocations, then every ~3% of the way (a few hundred runs) */
    for (long k = 0; k < 10000000; k += 1 + k / 32) {
        fail_alloc fa = {k, 0};
        ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
        char *json = NULL;
        size_t size = 0;
        ffd_session *t = open_session(BUNNY);
        ffd_set_allocator(&a);
        ffd_error err;
        ffd_status st = ffd_session_autosave_text(s, "bunny.obj", &json, &size, &err);
        if (!st)
            st = ffd_session_resume(t, json, size, "autosave", NULL, &err);
        if (!st)
            st = run(t, "history_goto", "{\"index\":1}", &err);
        ffd_set_allocator(NULL);
        CHECK(st == FFD_OK || st == FFD_ERR_NOMEM || st == FFD_ERR_PARSE);
        ffd_free(json);
        ffd_session_destroy(t);
        if (st == FFD_OK)
            break;
    }
    ffd_session_destroy(s);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"pins_in_the_rig", test_pins_in_the_rig},
        {"bad_pins", test_bad_pins},
        {"history_goto", test_history_goto},
        {"autosave_and_resume", test_autosave_and_resume},
        {"autosave_cap", test_autosave_cap},
        {"structural_steps", test_structural_steps},
        {"autosave_byte_budget", test_autosave_byte_budget},
        {"allocation_failures", test_allocation_failures},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
