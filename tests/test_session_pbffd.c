/* Tests for the editor's PB-FFD method (src/pbffd/pbffd_session.c) through
 * its vtable: identity at rest; after drags, pin-style variable moves, frame
 * edits and curves, eval equals ffd_rig_apply of the method's rig; load
 * reproduces a rig; snapshots restore bitwise; bad bodies name the key;
 * failing allocations leave nothing behind. */
#include "check_sess_method.h"
#include "pbffd/pbffd_method.h"

#define COW FFD_SOURCE_DIR "/examples/pbffd/cow.off"
#define SMALL "{\"method\": \"pbffd\", \"interior\": 16, \"exterior\": 16"

static sess_method *create(const sess_fixture *f, const char *body)
{
    cJSON *b = json(body);
    sess_method *m = NULL;
    ffd_error err = {{0}};
    if (ffd_sess_pbffd_create(&f->ctx, b, &m, &err) != FFD_OK) {
        fprintf(stderr, "%s: create: %s\n", check_current, err.message);
        check_failures++;
    }
    cJSON_Delete(b);
    return m;
}

/* Moves the shown level's variables by dv (pins, a vertex drag). */
static ffd_status move_variables(sess_method *m, double scale)
{
    ffd_linear_map map;
    ffd_error err = {{0}};
    ffd_status s = m->vt->begin(m, NULL, 0, 0, &err);
    if (!s)
        s = m->vt->linear_map(m, &map, &err);
    double *dv = s ? NULL : calloc(map.variable_count ? map.variable_count : 1, 3 * sizeof *dv);
    for (size_t j = 0; !s && j < map.variable_count; j += 3)
        dv[3 * j + 1] = scale * (double)(j % 5) / 5.0;
    if (!s)
        s = m->vt->set_variables(m, dv, &err);
    if (s)
        fprintf(stderr, "%s: variables: %s\n", check_current, err.message);
    m->vt->end(m, s == FFD_OK);
    free(dv);
    return s;
}

static void test_identity_at_rest(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    sess_method *m = create(&f, SMALL ", \"levels\": 2}");
    if (m) {
        CHECK(strcmp(m->vt->name, "pbffd") == 0);
        double *x = method_eval(m);
        if (x)
            CHECK(max_diff(x, f.ctx.rest, f.ctx.n) == 0);
        free(x);
        cJSON *params = cJSON_CreateObject(), *built = cJSON_CreateObject();
        CHECK_OK(m->vt->describe(m, params, built, NULL));
        /* numbers are raw (exact) items: read them through the printed text */
        char *text = cJSON_PrintUnformatted(built);
        cJSON *controls = cJSON_Parse(text);
        free(text);
        cJSON_Delete(built);
        CHECK(cJSON_GetObjectItem(params, "interior")->valueint == 16);
        CHECK(cJSON_GetObjectItem(params, "levels")->valueint == 2);
        CHECK(cJSON_GetObjectItem(params, "sigma")->valuedouble == 3);
        cJSON *ebfs = cJSON_GetObjectItem(controls, "ebfs");
        CHECK((size_t)cJSON_GetArraySize(ebfs) == m->vt->control_count(m));
        cJSON *frame = cJSON_GetObjectItem(cJSON_GetArrayItem(ebfs, 0), "frame");
        CHECK_NEAR(cJSON_GetArrayItem(cJSON_GetArrayItem(frame, 0), 0)->valuedouble, 1, 1e-15);
        CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(controls, "edges")) == 0);
        cJSON_Delete(params);
        cJSON_Delete(controls);
        check_rig_matches(m, COW);
        m->vt->destroy(m);
    }
    fixture_close(&f);
}

/* The curve along the cow's long axis, through the middle of its box. */
static void curve_body(const sess_ctx *c, char *body, size_t size)
{
    double y = 0.5 * (c->min[1] + c->max[1]), z = 0.5 * (c->min[2] + c->max[2]);
    double x0 = c->min[0] + 0.6 * (c->max[0] - c->min[0]);
    double x1 = c->min[0] + 0.95 * (c->max[0] - c->min[0]);
    snprintf(body, size,
             "{\"points\": [[%.17g, %.17g, %.17g], [%.17g, %.17g, %.17g], "
             "[%.17g, %.17g, %.17g]],"
             " \"radius\": %.17g}",
             x0, y, z, 0.5 * (x0 + x1), y, z, x1, y, z, 0.12 * c->diag);
}

static void test_edits_match_rig(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    sess_method *m = create(&f, SMALL ", \"levels\": 2, \"sigma\": 2.5}");
    if (!m) {
        fixture_close(&f);
        return;
    }
    const double d = 0.05 * f.ctx.diag;
    uint32_t ids[2] = {0, 3};
    double delta[3] = {d, 0.5 * d, 0};
    ffd_error err = {{0}};
    int undo = -1;
    CHECK_OK(drag_by(m, ids, 2, delta));
    check_rig_matches(m, COW);
    double *moved = method_eval(m);
    if (moved)
        CHECK(max_diff(moved, f.ctx.rest, f.ctx.n) > 1e-3 * f.ctx.diag);
    free(moved);
    /* the coarser level: a vertex-drag style move of its variables */
    CHECK_OK(run_op(m, "level", "{\"level\": 1}", &undo, &err));
    CHECK(undo == SESS_UNDO_NONE);
    CHECK_OK(move_variables(m, 0.03 * f.ctx.diag));
    check_rig_matches(m, COW);
    /* frames, then a move after them (replayed before them, as in the rig) */
    CHECK_OK(run_op(m, "frame", "{\"points\": [1, 2], \"axis\": [0, 0, 1], \"angle\": 0.4}", &undo,
                    &err));
    CHECK(undo == SESS_UNDO_STATE);
    CHECK_OK(run_op(m, "frame", "{\"points\": [1], \"scale\": [1.5, 1, 0.8]}", &undo, &err));
    check_rig_matches(m, COW);
    uint32_t one = 2;
    CHECK_OK(drag_by(m, &one, 1, delta));
    check_rig_matches(m, COW);
    /* a curve on the result, its points dragged, then an EBF drag under it */
    char body[512];
    curve_body(&f.ctx, body, sizeof body);
    CHECK_OK(run_op(m, "level", "{\"level\": 0}", &undo, &err));
    size_t e = m->vt->control_count(m);
    CHECK_OK(run_op(m, "curve", body, &undo, &err));
    CHECK(undo == SESS_UNDO_REBUILD);
    CHECK(m->vt->control_count(m) == e + 3);
    check_rig_matches(m, COW);
    uint32_t tip = (uint32_t)e + 2;
    double up[3] = {0, d, 0.3 * d};
    double *before = method_eval(m);
    CHECK_OK(drag_by(m, &tip, 1, up));
    double *after = method_eval(m);
    if (before && after)
        CHECK(max_diff(before, after, f.ctx.n) > 1e-3 * f.ctx.diag);
    free(before);
    free(after);
    check_rig_matches(m, COW);
    CHECK_OK(drag_by(m, ids, 1, delta));
    check_rig_matches(m, COW);
    /* a second curve stands on the first */
    CHECK_OK(run_op(m, "curve", body, &undo, &err));
    uint32_t mid = (uint32_t)e + 1;
    CHECK_OK(drag_by(m, &mid, 1, up));
    check_rig_matches(m, COW);
    cJSON *params = cJSON_CreateObject(), *controls = cJSON_CreateObject();
    CHECK_OK(m->vt->describe(m, params, controls, NULL));
    CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(controls, "curves")) == 2);
    CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(controls, "edges")) == 4);
    cJSON_Delete(params);
    cJSON_Delete(controls);

    /* load(rig) reproduces the positions */
    double *x = method_eval(m);
    char *text = method_rig_text(m);
    ffd_rig *rig = NULL;
    sess_method *loaded = NULL;
    CHECK_OK(ffd_rig_parse_json(text, strlen(text), "s.json", &rig, NULL));
    if (rig)
        CHECK_OK(ffd_sess_pbffd_load(&f.ctx, rig, &loaded, NULL));
    if (loaded && x) {
        double *y = method_eval(loaded);
        if (y)
            CHECK(max_diff(x, y, f.ctx.n) <= 1e-12 * f.ctx.diag);
        free(y);
        CHECK(loaded->vt->control_count(loaded) == e + 6);
        check_rig_matches(loaded, COW);
        loaded->vt->destroy(loaded);
    }
    ffd_rig_destroy(rig);
    cJSON_free(text);
    free(x);
    m->vt->destroy(m);
    fixture_close(&f);
}

static void test_snapshot_and_cancel(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    sess_method *m = create(&f, SMALL ", \"levels\": 2}");
    if (!m) {
        fixture_close(&f);
        return;
    }
    const double d = 0.05 * f.ctx.diag;
    double delta[3] = {0, d, 0};
    uint32_t ids[1] = {5};
    char body[512];
    curve_body(&f.ctx, body, sizeof body);
    CHECK_OK(run_op(m, "curve", body, NULL, NULL));
    CHECK_OK(drag_by(m, ids, 1, delta));
    void *blob = NULL;
    CHECK_OK(m->vt->snapshot(m, &blob, NULL));
    double *a = method_eval(m);
    /* change everything, then restore */
    uint32_t cp = (uint32_t)(m->vt->control_count(m) - 1);
    CHECK_OK(drag_by(m, &cp, 1, delta));
    CHECK_OK(
        run_op(m, "frame", "{\"points\": [0], \"axis\": [1, 0, 0], \"angle\": 0.3}", NULL, NULL));
    CHECK_OK(run_op(m, "level", "{\"level\": 1}", NULL, NULL));
    CHECK_OK(move_variables(m, d));
    CHECK_OK(m->vt->restore(m, blob, NULL));
    double *b = method_eval(m);
    if (a && b)
        CHECK(max_diff(a, b, f.ctx.n) == 0);
    free(b);
    /* a cancelled drag leaves no trace */
    ffd_error err = {{0}};
    uint32_t two[2] = {1, cp};
    double t[6];
    double *pos = malloc(m->vt->control_count(m) * 3 * sizeof *pos);
    m->vt->controls(m, pos);
    for (int k = 0; k < 3; k++) {
        t[k] = pos[3 + k] + delta[k];
        t[3 + k] = pos[3 * cp + k] + delta[k];
    }
    CHECK_OK(m->vt->begin(m, two, 2, 0, &err));
    CHECK_OK(m->vt->set_controls(m, two, 2, t, &err));
    b = method_eval(m);
    if (a && b)
        CHECK(max_diff(a, b, f.ctx.n) > 0);
    free(b);
    m->vt->end(m, 0);
    b = method_eval(m);
    if (a && b)
        CHECK(max_diff(a, b, f.ctx.n) == 0);
    free(b);
    check_rig_matches(m, COW);
    /* reset: every control at rest, the curve kept */
    CHECK_OK(m->vt->reset(m, NULL));
    b = method_eval(m);
    char *text = method_rig_text(m);
    if (text)
        CHECK(strstr(text, "\"moves\":[]") != NULL);
    cJSON_free(text);
    check_rig_matches(m, COW);
    free(b);
    free(pos);
    free(a);
    m->vt->snapshot_free(blob);
    m->vt->destroy(m);
    fixture_close(&f);
}

static void test_influence(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    sess_method *m = create(&f, SMALL "}");
    if (!m) {
        fixture_close(&f);
        return;
    }
    char body[512];
    curve_body(&f.ctx, body, sizeof body);
    CHECK_OK(run_op(m, "curve", body, NULL, NULL));
    size_t n = f.ctx.n, e = m->vt->control_count(m) - 3;
    float *w = malloc(n * sizeof *w);
    uint32_t ebf = 0, cp = (uint32_t)e + 1;
    CHECK_OK(m->vt->influence(m, &ebf, 1, w, NULL));
    size_t some = 0, bad = 0;
    for (size_t i = 0; i < n; i++) {
        some += w[i] > 0;
        bad += !(w[i] >= 0 && w[i] <= 1);
    }
    CHECK(some > 0 && some < n && bad == 0);
    CHECK_OK(m->vt->influence(m, &cp, 1, w, NULL));
    some = bad = 0;
    for (size_t i = 0; i < n; i++) {
        some += w[i] == 1;
        bad += w[i] != 0 && w[i] != 1;
    }
    CHECK(some > 0 && some < n && bad == 0);
    free(w);
    m->vt->destroy(m);
    fixture_close(&f);
}

/* A rig with placement options, "near" moves, frames and vertex constraints. */
static void test_load_rig(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    const char *text = "{\"deformer\": \"pbffd\", \"controls\": {\"interior\": 12, "
                       "\"exterior\": 12},"
                       " \"levels\": 2, \"master\": {\"radius\": 2.5},"
                       " \"moves\": [{\"level\": 1, \"near\": [0.4, 0.15, 0], \"delta\": [0.05, "
                       "0.1, 0]},"
                       "             {\"near\": [-0.5, -0.15, 0.0], \"delta\": [-0.04, 0.1, "
                       "0.0]}],"
                       " \"frames\": [{\"near\": [0, 0, 0], \"rotate\": {\"axis\": [0, 1, 0], "
                       "\"angle\": 0.3}}],"
                       " \"constraints\": [{\"vertex\": 1156, \"target\": [0.53, 0.04, -0.01]}],"
                       " \"curves\": [{\"points\": [[0.2, 0, 0], [0.35, 0.05, 0]], \"radius\": "
                       "0.12,"
                       "   \"moves\": [{\"index\": 1, \"delta\": [0, 0.05, 0]}]}]}";
    ffd_rig *rig = NULL;
    sess_method *m = NULL;
    CHECK_OK(ffd_rig_parse_json(text, strlen(text), "r.json", &rig, NULL));
    if (rig)
        CHECK_OK(ffd_sess_pbffd_load(&f.ctx, rig, &m, NULL));
    if (m) {
        double *x = method_eval(m), *y = apply_rig_text(text, COW);
        if (x && y)
            CHECK(max_diff(x, y, f.ctx.n) <= 1e-9 * f.ctx.diag);
        free(x);
        free(y);
        check_rig_matches(m, COW);
        m->vt->destroy(m);
    }
    ffd_rig_destroy(rig);

    /* refused: point constraints, another deformer */
    const char *point = "{\"deformer\": \"pbffd\", \"controls\": {\"interior\": 12, "
                        "\"exterior\": 12}, \"constraints\": [{\"point\": [0, 0, 0], "
                        "\"target\": [0, 0.1, 0]}]}";
    ffd_error err = {{0}};
    CHECK_OK(ffd_rig_parse_json(point, strlen(point), "r.json", &rig, NULL));
    m = NULL;
    if (rig)
        check_error(ffd_sess_pbffd_load(&f.ctx, rig, &m, &err), &err, FFD_ERR_INVALID,
                    "constraints[0].point: point constraints");
    CHECK(m == NULL);
    ffd_rig_destroy(rig);
    CHECK_OK(ffd_rig_parse_json("{}", 2, "r.json", &rig, NULL));
    if (rig)
        check_error(ffd_sess_pbffd_load(&f.ctx, rig, &m, &err), &err, FFD_ERR_INVALID,
                    "not a \"pbffd\" rig");
    ffd_rig_destroy(rig);
    fixture_close(&f);
}

static void create_bad(const sess_fixture *f, const char *body, ffd_status want,
                       const char *fragment)
{
    cJSON *b = json(body);
    sess_method *m = (sess_method *)1;
    ffd_error err = {{0}};
    check_error(ffd_sess_pbffd_create(&f->ctx, b, &m, &err), &err, want, fragment);
    CHECK(m == NULL);
    cJSON_Delete(b);
}

static void op_bad(sess_method *m, const char *op, const char *body, ffd_status want,
                   const char *fragment)
{
    ffd_error err = {{0}};
    double *before = method_eval(m);
    check_error(run_op(m, op, body, NULL, &err), &err, want, fragment);
    double *after = method_eval(m);
    if (before && after)
        CHECK(max_diff(before, after, m->ctx->n) == 0);
    free(before);
    free(after);
}

static void test_bad_bodies(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    create_bad(&f, "{\"method\": \"pbffd\", \"interior\": 0}", FFD_ERR_PARSE,
               "create: controls.interior: expected a positive integer");
    create_bad(&f, "{\"method\": \"pbffd\", \"resolution\": [3,3,3]}", FFD_ERR_PARSE,
               "create: resolution: unknown key");
    create_bad(&f, "{\"method\": \"pbffd\", \"sigma\": 0.01}", FFD_ERR_INVALID, "create: sigma");
    create_bad(&f, "{\"method\": \"pbffd\", \"levels\": 33}", FFD_ERR_INVALID, "create: levels");
    create_bad(&f, "{\"method\": \"pbffd\", \"offset\": 2}", FFD_ERR_INVALID, "create: controls.offset");
    create_bad(&f, "{\"method\": \"pbffd\", \"voronoi_sites\": 2}", FFD_ERR_INVALID,
               "create: controls.voronoi_sites");
    create_bad(&f, "{\"method\": \"pbffd\", \"radius_factor\": \"big\"}", FFD_ERR_PARSE,
               "create: controls.radius_factor: expected a number");
    create_bad(&f, "{\"method\": \"pbffd\", \"interior\": 100000}", FFD_ERR_INVALID,
               "create: controls (automatic placement):");
    sess_method *m = create(&f, SMALL "}");
    if (m) {
        size_t e = m->vt->control_count(m);
        op_bad(m, "level", "{\"level\": 1}", FFD_ERR_RANGE, "level: level: 1 out of range");
        op_bad(m, "level", "{\"levels\": 1}", FFD_ERR_PARSE, "level: levels: unknown key");
        op_bad(m, "frame", "{\"points\": [0], \"axis\": [0, 0, 0], \"angle\": 1}", FFD_ERR_INVALID,
               "frame: axis: the zero vector");
        op_bad(m, "frame", "{\"points\": [0], \"axis\": [0, 0, 1]}", FFD_ERR_PARSE, "frame: angle");
        op_bad(m, "frame", "{\"points\": [0], \"scale\": [1, 0, 1]}", FFD_ERR_INVALID,
               "frame: scale[1]");
        op_bad(m, "frame", "{\"points\": [99999], \"scale\": [1, 2, 1]}", FFD_ERR_RANGE,
               "frame: points[0]");
        op_bad(m, "frame", "{\"scale\": [1, 2, 1]}", FFD_ERR_PARSE, "frame: points");
        op_bad(m, "curve", "{\"points\": [[0, 0, 0]]}", FFD_ERR_PARSE, "curve: points");
        op_bad(m, "curve", "{\"points\": [[0, 0, 0], [0, 0, 0]]}", FFD_ERR_INVALID, "curve: ");
        op_bad(m, "curve", "{\"points\": [[0, 0, 0], [1, 0, 0]], \"radius\": -1}", FFD_ERR_INVALID,
               "curve: radius");
        op_bad(m, "refine", "{}", FFD_ERR_UNSUPPORTED, "refine");
        CHECK(m->vt->control_count(m) == e);
        char body[512];
        curve_body(&f.ctx, body, sizeof body);
        CHECK_OK(run_op(m, "curve", body, NULL, NULL));
        char frame[128];
        snprintf(frame, sizeof frame, "{\"points\": [%zu], \"scale\": [1, 2, 1]}", e);
        op_bad(m, "frame", frame, FFD_ERR_INVALID, "is a curve point");
        /* a drag that would make two curve points coincide is refused and undone */
        double *pos = malloc(m->vt->control_count(m) * 3 * sizeof *pos);
        m->vt->controls(m, pos);
        uint32_t id = (uint32_t)e + 1;
        ffd_error err = {{0}};
        double *before = method_eval(m);
        CHECK_OK(m->vt->begin(m, &id, 1, 0, &err));
        check_error(m->vt->set_controls(m, &id, 1, pos + 3 * e, &err), &err, FFD_ERR_INVALID,
                    "drag: curve 0 point 1");
        double *after = method_eval(m);
        if (before && after)
            CHECK(max_diff(before, after, f.ctx.n) == 0);
        m->vt->end(m, 1);
        check_rig_matches(m, COW);
        free(before);
        free(after);
        free(pos);
        m->vt->destroy(m);
    }
    fixture_close(&f);
}

/* Every operation under an allocator failing at the k-th call: a clean
 * error (or success) and nothing leaked (ASan). */
static void test_failing_allocations(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    sess_method *proto = create(&f, SMALL ", \"levels\": 2}");
    char *text = NULL;
    if (proto) {
        char body[512];
        curve_body(&f.ctx, body, sizeof body);
        CHECK_OK(run_op(proto, "curve", body, NULL, NULL));
        text = method_rig_text(proto);
        proto->vt->destroy(proto);
    }
    ffd_rig *rig = NULL;
    if (text)
        CHECK_OK(ffd_rig_parse_json(text, strlen(text), "s.json", &rig, NULL));
    for (long k = 0; rig; k++) {
        fail_alloc fa = {k, 0};
        ffd_allocator al = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&al);
        sess_method *m = NULL;
        void *blob = NULL;
        double *x = malloc(f.ctx.n * 3 * sizeof *x);
        float *w = malloc(f.ctx.n * sizeof *w);
        uint32_t ids[2] = {0, 0};
        double t[6] = {0};
        ffd_status s = ffd_sess_pbffd_load(&f.ctx, rig, &m, NULL);
        if (!s) {
            ids[1] = (uint32_t)m->vt->control_count(m) - 1;
            double *pos = malloc(m->vt->control_count(m) * 3 * sizeof *pos);
            m->vt->controls(m, pos);
            memcpy(t, pos, 3 * sizeof *t);
            memcpy(t + 3, pos + 3 * ids[1], 3 * sizeof *t);
            t[1] += 0.02;
            t[4] += 0.02;
            free(pos);
            s = m->vt->begin(m, ids, 2, 0, NULL);
        }
        if (!s)
            s = m->vt->set_controls(m, ids, 2, t, NULL);
        if (m)
            m->vt->end(m, s == FFD_OK);
        if (!s)
            s = m->vt->snapshot(m, &blob, NULL);
        if (!s)
            s = m->vt->eval(m, x, NULL);
        if (!s)
            s = run_op(m, "frame", "{\"points\": [1], \"scale\": [1, 1.2, 1]}", NULL, NULL);
        if (!s)
            s = m->vt->restore(m, blob, NULL);
        if (!s)
            s = run_op(m, "curve", "{\"points\": [[0, 0, 0], [0.1, 0, 0]], \"radius\": 0.1}", NULL,
                       NULL);
        if (!s)
            s = m->vt->influence(m, ids, 2, w, NULL);
        if (!s)
            s = m->vt->eval(m, x, NULL);
        ffd_set_allocator(NULL);
        CHECK(s == FFD_OK || s == FFD_ERR_NOMEM);
        if (m)
            m->vt->snapshot_free(blob);
        if (m)
            m->vt->destroy(m);
        free(x);
        free(w);
        if (s == FFD_OK)
            break;
        if (k > 100000) {
            CHECK(0);
            break;
        }
    }
    ffd_rig_destroy(rig);
    cJSON_free(text);
    fixture_close(&f);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"identity_at_rest", test_identity_at_rest},
        {"edits_match_rig", test_edits_match_rig},
        {"snapshot_and_cancel", test_snapshot_and_cancel},
        {"influence", test_influence},
        {"load_rig", test_load_rig},
        {"bad_bodies", test_bad_bodies},
        {"failing_allocations", test_failing_allocations},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
