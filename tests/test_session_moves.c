/* The session's per-control drag step, {"moves": [[id, dx, dy, dz], ...]}
 * (session_moves.c; the editor's mirror, proportional and individual-origin
 * transforms): identity keeps every bit, each control gets exactly its own
 * change, bad requests are refused and change nothing, one undo step. */
#include "check.h"
#include "ffd.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#define BUNNY FFD_SOURCE_DIR "/examples/lattice/bunny.obj"

static ffd_session *lattice_session(void)
{
    ffd_mesh *mesh = NULL;
    ffd_session *s = NULL;
    CHECK_OK(ffd_mesh_read(BUNNY, &mesh, NULL));
    if (!mesh)
        return NULL;
    CHECK_OK(ffd_session_create(mesh, "bunny.obj", NULL, &s, NULL));
    const char *create = "{\"deformer\":\"lattice\",\"resolution\":[5,5,5]}";
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    CHECK_OK(ffd_session_command(s, "create", create, strlen(create), &reply, &size, &binary, NULL));
    ffd_free(reply);
    return s;
}

static ffd_status run(ffd_session *s, const char *op, const char *body, ffd_error *err)
{
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    ffd_error local = {{0}};
    ffd_status st = ffd_session_command(s, op, body, strlen(body), &reply, &size, &binary,
                                        err ? err : &local);
    if (st && !err)
        fprintf(stderr, "  %s %s: %s\n", op, body, local.message);
    ffd_free(reply);
    return st;
}

/* The whole frame after its revision: vertex and control positions (float32). */
typedef struct frame {
    unsigned char *bytes; /* from the vertex count on */
    size_t size;
    uint32_t V, C;
    const float *controls;
} frame;

static frame take(ffd_session *s)
{
    frame f = {0};
    void *data = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_frame(s, &data, &size, NULL));
    if (!data)
        return f;
    f.size = size - 8;
    f.bytes = malloc(f.size);
    memcpy(f.bytes, (char *)data + 8, f.size);
    memcpy(&f.V, (char *)data + 8, 4);
    memcpy(&f.C, (char *)data + 12, 4);
    f.controls = (const float *)(f.bytes + 12 + 12 * (size_t)f.V);
    ffd_free(data);
    return f;
}

static int same_bits(const frame *a, const frame *b)
{
    return a->size == b->size && memcmp(a->bytes, b->bytes, a->size) == 0;
}

static int undo_count(ffd_session *s)
{
    char *state = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_state(s, &state, &size, NULL));
    const char *u = state ? strstr(state, "\"undo\":") : NULL;
    int n = u ? atoi(u + 7) : -1;
    ffd_free(state);
    return n;
}

static void test_identity_keeps_bits(void)
{
    ffd_session *s = lattice_session();
    frame rest = take(s);
    int undo = undo_count(s);
    CHECK(run(s, "drag_begin", "{\"points\":[62,63,67],\"mode\":\"rotate\"}", NULL) == FFD_OK);
    CHECK(run(s, "drag", "{\"moves\":[]}", NULL) == FFD_OK);
    frame none = take(s);
    CHECK(same_bits(&rest, &none));
    CHECK(run(s, "drag", "{\"moves\":[[62,0,0,0],[63,0,0,0],[67,0,-0,0]]}", NULL) == FFD_OK);
    frame zero = take(s);
    CHECK(same_bits(&rest, &zero));
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    CHECK(undo_count(s) == undo + 1);
    free(rest.bytes);
    free(none.bytes);
    free(zero.bytes);
    ffd_session_destroy(s);
}

static void test_each_control_its_own_change(void)
{
    ffd_session *s = lattice_session();
    frame rest = take(s);
    int undo = undo_count(s);
    CHECK(run(s, "drag_begin", "{\"points\":[62,63,67]}", NULL) == FFD_OK);
    /* totals since drag_begin: the second step replaces the first */
    CHECK(run(s, "drag", "{\"moves\":[[63,1,1,1]]}", NULL) == FFD_OK);
    CHECK(run(s, "drag", "{\"moves\":[[67,0,-0.25,0],[62,0.5,0,0]]}", NULL) == FFD_OK);
    frame moved = take(s);
    CHECK(run(s, "drag_end", "{}", NULL) == FFD_OK);
    CHECK(undo_count(s) == undo + 1); /* one step for the whole drag */
    CHECK(moved.C == 125 && rest.C == 125);
    for (uint32_t c = 0; c < moved.C; c++)
        for (int a = 0; a < 3; a++) {
            double was = rest.controls[3 * c + a], want = was;
            if (c == 62 && a == 0)
                want += 0.5;
            if (c == 67 && a == 1)
                want -= 0.25;
            if (want == was) /* not moved: every bit kept */
                CHECK(moved.controls[3 * c + a] == rest.controls[3 * c + a]);
            else /* moved in double, then rounded to float32 once */
                CHECK_NEAR(moved.controls[3 * c + a], want, 1e-6 * (1 + fabs(want)));
        }
    /* the mesh followed: it differs from rest, and undo brings back every bit */
    CHECK(!same_bits(&rest, &moved));
    CHECK(run(s, "undo", "{}", NULL) == FFD_OK);
    frame back = take(s);
    CHECK(same_bits(&rest, &back));
    /* the whole drag in one request */
    CHECK(run(s, "move", "{\"points\":[62,63,67],\"moves\":[[67,0,-0.25,0],[62,0.5,0,0]]}",
              NULL) == FFD_OK);
    frame again = take(s);
    CHECK(same_bits(&moved, &again));
    free(rest.bytes);
    free(moved.bytes);
    free(back.bytes);
    free(again.bytes);
    ffd_session_destroy(s);
}

static void test_bad_moves_change_nothing(void)
{
    ffd_session *s = lattice_session();
    frame rest = take(s);
    ffd_error err = {{0}};
    CHECK(run(s, "drag_begin", "{\"points\":[62,63]}", NULL) == FFD_OK);
    CHECK(run(s, "drag", "{\"moves\":[[62,0.5,0,0]]}", NULL) == FFD_OK);
    frame step = take(s);
    static const struct {
        const char *body;
        ffd_status st;
        const char *message;
    } bad[] = {
        {"{\"moves\":[[125,1,0,0]]}", FFD_ERR_RANGE, "drag: moves[0]: control 125 out of range (125 controls)"},
        {"{\"moves\":[[62,1,0,0],[64,1,0,0]]}", FFD_ERR_INVALID, "drag: moves[1]: control 64 is not dragged"},
        {"{\"moves\":[[63,1,0,0],[63,0,0,0]]}", FFD_ERR_INVALID, "drag: moves[1]: control 63 given twice"},
        {"{\"moves\":[[-1,1,0,0]]}", FFD_ERR_PARSE, "drag: moves[0]: expected [control id, dx, dy, dz] with a control id first"},
        {"{\"moves\":[[62.5,1,0,0]]}", FFD_ERR_PARSE, "with a control id first"},
        {"{\"moves\":[[62,1,0]]}", FFD_ERR_PARSE, "drag: moves[0]: expected [control id, dx, dy, dz]"},
        {"{\"moves\":[[62,1,\"a\",0]]}", FFD_ERR_PARSE, "drag: moves[0][2]: expected a number"},
        {"{\"moves\":[[62,1,0,1e999]]}", FFD_ERR_NONFINITE, "drag: moves[0][3]: expected a finite number"},
        {"{\"moves\":[[62,1e16,0,0]]}", FFD_ERR_NONFINITE, "beyond"},
        {"{\"moves\":{}}", FFD_ERR_PARSE, "drag: moves: expected an array of [control id, dx, dy, dz]"},
        {"{\"moves\":[],\"delta\":[1,0,0]}", FFD_ERR_PARSE, "unknown key"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        CHECK(run(s, "drag", bad[i].body, &err) == bad[i].st);
        if (!strstr(err.message, bad[i].message))
            fprintf(stderr, "  %s: %s\n", bad[i].body, err.message);
        CHECK(strstr(err.message, bad[i].message) != NULL);
        frame after = take(s);
        CHECK(same_bits(&step, &after)); /* the last good step stands */
        free(after.bytes);
    }
    CHECK(run(s, "drag_cancel", "{}", NULL) == FFD_OK);
    frame back = take(s);
    CHECK(same_bits(&rest, &back));
    /* no drag: a conflict */
    CHECK(run(s, "drag", "{\"moves\":[[62,1,0,0]]}", &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "conflict: drag: no drag in progress") != NULL);
    free(rest.bytes);
    free(step.bytes);
    free(back.bytes);
    ffd_session_destroy(s);
}

static void test_allocation_failures(void)
{
    /* every allocation of a moves step may fail: a clean error, no leak, and the drag goes on
     * (a failure inside the method's evaluation may leave the frame between two steps, as for
     * every drag step form; the next step or drag_cancel puts it right) */
    ffd_session *s = lattice_session();
    frame rest = take(s);
    CHECK(run(s, "drag_begin", "{\"points\":[62,63,67]}", NULL) == FFD_OK);
    for (size_t k = 0; k < 400; k++) {
        fail_alloc fa = {k, 0};
        ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_error err;
        ffd_set_allocator(&a);
        ffd_status st = run(s, "drag", "{\"moves\":[[67,0,1,0],[62,0.5,0,0]]}", &err);
        ffd_set_allocator(NULL);
        CHECK(st == FFD_OK || st == FFD_ERR_NOMEM);
        if (st == FFD_OK)
            break;
    }
    frame moved = take(s);
    CHECK(!same_bits(&rest, &moved));
    CHECK(run(s, "drag_cancel", "{}", NULL) == FFD_OK);
    frame back = take(s);
    CHECK(same_bits(&rest, &back));
    free(rest.bytes);
    free(moved.bytes);
    free(back.bytes);
    ffd_session_destroy(s);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"identity_keeps_bits", test_identity_keeps_bits},
        {"each_control_its_own_change", test_each_control_its_own_change},
        {"bad_moves_change_nothing", test_bad_moves_change_nothing},
        {"allocation_failures", test_allocation_failures},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
