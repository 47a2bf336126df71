/* Tests for the editor's GFFD method (src/session/session_gffd.c) through its
 * vtable: identity at rest; after skeleton drags and primitive edits, eval
 * equals ffd_rig_apply of the method's rig; load reproduces a rig; snapshots
 * restore bitwise; bad bodies name the key; the influence is the primitives'
 * share of the field; failing allocations leave nothing behind. */
#include "check_sess_method.h"

#define COW FFD_SOURCE_DIR "/examples/gffd/cow.off"

static sess_method *create(const sess_fixture *f, const char *body)
{
    cJSON *b = json(body);
    sess_method *m = NULL;
    ffd_error err = {{0}};
    if (sess_gffd_create(&f->ctx, b, &m, &err) != FFD_OK) {
        fprintf(stderr, "%s: create: %s\n", check_current, err.message);
        check_failures++;
    }
    cJSON_Delete(b);
    return m;
}

static void test_default_skeleton_identity(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    sess_method *m = create(&f, "{\"method\": \"gffd\"}");
    if (m) {
        CHECK(strcmp(m->vt->name, "gffd") == 0);
        CHECK(m->vt->linear_map == NULL && m->vt->set_variables == NULL);
        CHECK(m->vt->control_count(m) == 5);
        double *x = method_eval(m);
        if (x)
            CHECK(max_diff(x, f.ctx.rest, f.ctx.n) == 0);
        free(x);
        /* along the longest axis through the box centre, 80 % of it */
        double c[15];
        m->vt->controls(m, c);
        int axis = 0;
        for (int a = 1; a < 3; a++)
            if (f.ctx.max[a] - f.ctx.min[a] > f.ctx.max[axis] - f.ctx.min[axis])
                axis = a;
        CHECK_NEAR(c[12 + axis] - c[axis], 0.8 * (f.ctx.max[axis] - f.ctx.min[axis]), 1e-12);
        CHECK_NEAR(c[6 + axis], 0.5 * (f.ctx.min[axis] + f.ctx.max[axis]), 1e-12);
        cJSON *params = cJSON_CreateObject(), *controls = cJSON_CreateObject();
        CHECK_OK(m->vt->describe(m, params, controls, NULL));
        CHECK(strcmp(cJSON_GetObjectItem(params, "tracking")->valuestring, "gradient") == 0);
        CHECK(cJSON_GetObjectItem(params, "unit")->valuedouble > 0);
        cJSON *p0 = cJSON_GetArrayItem(cJSON_GetObjectItem(controls, "primitives"), 0);
        CHECK(strcmp(cJSON_GetObjectItem(p0, "type")->valuestring, "polyline") == 0);
        CHECK_NEAR(cJSON_GetObjectItem(p0, "radius")->valuedouble, 0.3 * f.ctx.diag, 1e-12);
        CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(controls, "edges")) == 4);
        CHECK(cJSON_GetObjectItem(controls, "influenced")->valuedouble > 0);
        cJSON_Delete(params);
        cJSON_Delete(controls);
        check_rig_matches(m, COW);
        m->vt->destroy(m);
    }
    fixture_close(&f);
}

static void test_drags_and_primitives_match_rig(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    const char *trackings[2] = {"gradient", "warp"};
    for (int t = 0; t < 2; t++) {
        char body[128];
        snprintf(body, sizeof body, "{\"method\": \"gffd\", \"tracking\": \"%s\"}", trackings[t]);
        sess_method *m = create(&f, body);
        if (!m)
            continue;
        const double d = 0.06 * f.ctx.diag;
        uint32_t tip = 4, two[2] = {3, 4};
        double up[3] = {0, d, 0.2 * d};
        CHECK_OK(drag_by(m, &tip, 1, up));
        check_rig_matches(m, COW);
        double *moved = method_eval(m);
        if (moved)
            CHECK(max_diff(moved, f.ctx.rest, f.ctx.n) > 1e-3 * f.ctx.diag);
        free(moved);
        CHECK_OK(drag_by(m, two, 2, up));
        check_rig_matches(m, COW);
        /* skeleton editing: the moved polyline keeps its edit */
        int undo = -1;
        ffd_error err = {{0}};
        char add[256];
        snprintf(add, sizeof add,
                 "{\"add\": {\"type\": \"point\", \"position\": [%.17g, %.17g, %.17g],"
                 " \"radius\": %.17g}}",
                 f.ctx.min[0] + 0.2 * (f.ctx.max[0] - f.ctx.min[0]),
                 0.5 * (f.ctx.min[1] + f.ctx.max[1]), 0.5 * (f.ctx.min[2] + f.ctx.max[2]),
                 0.2 * f.ctx.diag);
        double *before = malloc(5 * 3 * sizeof *before);
        m->vt->controls(m, before);
        CHECK_OK(run_op(m, "primitive", add, &undo, &err));
        CHECK(undo == SESS_UNDO_REBUILD);
        CHECK(m->vt->control_count(m) == 6);
        double *after = malloc(6 * 3 * sizeof *after);
        m->vt->controls(m, after);
        CHECK(max_diff(before, after, 5) == 0);
        check_rig_matches(m, COW);
        uint32_t point = 5;
        double side[3] = {0, 0, d};
        CHECK_OK(drag_by(m, &point, 1, side));
        check_rig_matches(m, COW);
        CHECK_OK(run_op(m, "primitive", "{\"index\": 0, \"radius\": 0.25}", &undo, &err));
        check_rig_matches(m, COW);
        CHECK_OK(run_op(m, "primitive", "{\"remove\": 0}", &undo, &err));
        CHECK(m->vt->control_count(m) == 1);
        m->vt->controls(m, after);
        CHECK(after[2] != before[2] || after[1] != before[1]); /* the moved point remains */
        check_rig_matches(m, COW);
        free(before);
        free(after);

        /* load(rig) reproduces the positions */
        double *x = method_eval(m);
        char *text = method_rig_text(m);
        ffd_rig *rig = NULL;
        sess_method *loaded = NULL;
        CHECK_OK(ffd_rig_parse_json(text, strlen(text), "s.json", &rig, NULL));
        if (rig)
            CHECK_OK(sess_gffd_load(&f.ctx, rig, &loaded, NULL));
        if (loaded && x) {
            double *y = method_eval(loaded);
            if (y)
                CHECK(max_diff(x, y, f.ctx.n) == 0);
            free(y);
            loaded->vt->destroy(loaded);
        }
        ffd_rig_destroy(rig);
        cJSON_free(text);
        free(x);
        m->vt->destroy(m);
    }
    fixture_close(&f);
}

/* A rig with a patch, rotate/translate/move edits and options. */
static void test_load_rig(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    const char *text = "{\"deformer\": \"gffd\", \"tracking\": \"warp\", \"unit\": 0.12, "
                       "\"tolerance\": 1e-5,"
                       " \"skeleton\": ["
                       "  {\"type\": \"polyline\", \"vertices\": [[-0.4, 0, 0], [0, 0.02, 0], "
                       "[0.4, 0, 0]],"
                       "   \"radius\": 0.35},"
                       "  {\"type\": \"patch\", \"vertices\": [[0.3, 0.1, -0.1], [0.5, 0.1, "
                       "-0.1],"
                       "   [0.5, 0.1, 0.1], [0.3, 0.1, 0.1]], \"faces\": [[0, 1, 2, 3]], "
                       "\"radius\": 0.15}],"
                       " \"edits\": [{\"primitive\": 1, \"rotate\": {\"axis\": [0, 0, 1], "
                       "\"angle\": 0.3}},"
                       "   {\"primitive\": 0, \"vertex\": 2, \"move\": [0, 0.08, 0]}]}";
    ffd_rig *rig = NULL;
    sess_method *m = NULL;
    CHECK_OK(ffd_rig_parse_json(text, strlen(text), "r.json", &rig, NULL));
    if (rig)
        CHECK_OK(sess_gffd_load(&f.ctx, rig, &m, NULL));
    if (m) {
        double *x = method_eval(m), *y = apply_rig_text(text, COW);
        if (x && y)
            CHECK(max_diff(x, y, f.ctx.n) <= 1e-9 * f.ctx.diag);
        free(x);
        free(y);
        check_rig_matches(m, COW);
        cJSON *params = cJSON_CreateObject(), *controls = cJSON_CreateObject();
        CHECK_OK(m->vt->describe(m, params, controls, NULL));
        CHECK(cJSON_GetObjectItem(params, "unit")->valuedouble == 0.12);
        cJSON *p1 = cJSON_GetArrayItem(cJSON_GetObjectItem(controls, "primitives"), 1);
        CHECK(cJSON_GetObjectItem(p1, "offset")->valueint == 3);
        cJSON *face = cJSON_GetArrayItem(cJSON_GetObjectItem(p1, "faces"), 0);
        CHECK(cJSON_GetArrayItem(face, 0)->valueint == 3); /* control ids */
        /* 2 segments and 4 sides */
        CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(controls, "edges")) == 6);
        cJSON_Delete(params);
        cJSON_Delete(controls);
        m->vt->destroy(m);
    }
    ffd_rig_destroy(rig);

    static const char *const refused[][2] = {
        {"{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"point\", "
         "\"position\": [0,0,0],"
         " \"radius\": 0.3}], \"replace\": [{\"type\": \"point\", \"position\": "
         "[0,0.1,0],"
         " \"radius\": 0.3}]}",
         "replace: the editor edits a skeleton"},
        {"{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"point\", "
         "\"position\": [0,0,0],"
         " \"radius\": 0.3}], \"resample\": true}",
         "use ffd deform"},
        {"{\"deformer\": \"pbffd\"}", "not a \"gffd\" rig"},
    };
    for (size_t i = 0; i < sizeof refused / sizeof *refused; i++) {
        ffd_error err = {{0}};
        rig = NULL;
        m = NULL;
        CHECK_OK(ffd_rig_parse_json(refused[i][0], strlen(refused[i][0]), "r.json", &rig, NULL));
        if (rig)
            check_error(sess_gffd_load(&f.ctx, rig, &m, &err), &err, FFD_ERR_INVALID,
                        refused[i][1]);
        CHECK(m == NULL);
        ffd_rig_destroy(rig);
    }
    fixture_close(&f);
}

static void test_snapshot_and_cancel(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    sess_method *m = create(&f, "{\"method\": \"gffd\", \"unit\": 0.15}");
    if (!m) {
        fixture_close(&f);
        return;
    }
    const double d = 0.05 * f.ctx.diag;
    uint32_t tip = 0, mid = 2;
    double up[3] = {0, d, 0};
    CHECK_OK(drag_by(m, &tip, 1, up));
    void *blob = NULL;
    CHECK_OK(m->vt->snapshot(m, &blob, NULL));
    double *a = method_eval(m), *b;
    CHECK_OK(drag_by(m, &mid, 1, up));
    CHECK_OK(drag_by(m, &tip, 1, up));
    CHECK_OK(m->vt->restore(m, blob, NULL));
    b = method_eval(m);
    if (a && b)
        CHECK(max_diff(a, b, f.ctx.n) == 0);
    free(b);
    /* cancelled */
    double c[15], t[3];
    m->vt->controls(m, c);
    for (int k = 0; k < 3; k++)
        t[k] = c[3 * mid + k] - up[k];
    CHECK_OK(m->vt->begin(m, &mid, 1, 0, NULL));
    CHECK_OK(m->vt->set_controls(m, &mid, 1, t, NULL));
    m->vt->end(m, 0);
    b = method_eval(m);
    if (a && b)
        CHECK(max_diff(a, b, f.ctx.n) == 0);
    free(b);
    /* reset: the rest skeleton again, identity */
    CHECK_OK(m->vt->reset(m, NULL));
    b = method_eval(m);
    if (b)
        CHECK(max_diff(b, f.ctx.rest, f.ctx.n) == 0);
    free(b);
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
    sess_method *m =
        create(&f, "{\"method\": \"gffd\", \"skeleton\": ["
                   " {\"type\": \"polyline\", \"vertices\": [[-0.4, 0, 0], [0, 0, 0]],"
                   "  \"radius\": 0.3},"
                   " {\"type\": \"point\", \"position\": [0.2, 0, 0], \"radius\": 0.3}]}");
    if (!m) {
        fixture_close(&f);
        return;
    }
    size_t n = f.ctx.n;
    float *w0 = malloc(n * sizeof *w0), *w1 = malloc(n * sizeof *w1), *wa = malloc(n * sizeof *wa);
    uint32_t line = 1, point = 2, all[2] = {0, 2};
    CHECK_OK(m->vt->influence(m, &line, 1, w0, NULL));
    CHECK_OK(m->vt->influence(m, &point, 1, w1, NULL));
    CHECK_OK(m->vt->influence(m, all, 2, wa, NULL));
    size_t shared = 0, bad = 0, inside = 0;
    for (size_t i = 0; i < n; i++) {
        inside += wa[i] > 0;
        shared += w0[i] > 0 && w1[i] > 0;
        /* shares of the merged field (eq. 1-2) add up to the whole */
        bad += fabs(w0[i] + w1[i] - wa[i]) > 1e-6 || !(wa[i] == 0 || fabs(wa[i] - 1) < 1e-6);
    }
    CHECK(inside > 0 && shared > 0 && bad == 0);
    free(w0);
    free(w1);
    free(wa);
    m->vt->destroy(m);
    fixture_close(&f);
}

static void create_bad(const sess_fixture *f, const char *body, ffd_status want,
                       const char *fragment)
{
    cJSON *b = json(body);
    sess_method *m = (sess_method *)1;
    ffd_error err = {{0}};
    check_error(sess_gffd_create(&f->ctx, b, &m, &err), &err, want, fragment);
    CHECK(m == NULL);
    cJSON_Delete(b);
}

static void op_bad(sess_method *m, const char *body, ffd_status want, const char *fragment)
{
    ffd_error err = {{0}};
    size_t c = m->vt->control_count(m);
    check_error(run_op(m, "primitive", body, NULL, &err), &err, want, fragment);
    CHECK(m->vt->control_count(m) == c);
}

static void test_bad_bodies(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    create_bad(&f,
               "{\"method\": \"gffd\", \"skeleton\": [{\"type\": \"polyline\", \"file\":"
               " \"spine.obj\", \"radius\": 0.3}]}",
               FFD_ERR_PARSE, "create: skeleton[0].file");
    create_bad(&f, "{\"method\": \"gffd\", \"resample\": true}", FFD_ERR_INVALID,
               "create: resample");
    create_bad(&f, "{\"method\": \"gffd\", \"levels\": 2}", FFD_ERR_PARSE,
               "create: levels: unknown key");
    create_bad(&f, "{\"method\": \"gffd\", \"tracking\": \"fast\"}", FFD_ERR_PARSE,
               "create: tracking: expected \"gradient\" or \"warp\"");
    create_bad(&f, "{\"method\": \"gffd\", \"unit\": 0}", FFD_ERR_INVALID, "create: unit");
    create_bad(&f,
               "{\"method\": \"gffd\", \"skeleton\": [{\"type\": \"point\", "
               "\"position\":"
               " [0, 0, 0], \"radius\": -1}]}",
               FFD_ERR_INVALID, "create: skeleton[0].radius");
    create_bad(&f,
               "{\"method\": \"gffd\", \"skeleton\": [{\"type\": \"polyline\", "
               "\"vertices\":"
               " [[0, 0, 0], [0, 0, 0]], \"radius\": 1}]}",
               FFD_ERR_INVALID, "zero-length segment");
    sess_method *m = create(&f, "{\"method\": \"gffd\"}");
    if (m) {
        op_bad(m, "{\"remove\": 0}", FFD_ERR_INVALID, SESS_CONFLICT "primitive: remove");
        op_bad(m, "{\"remove\": 3}", FFD_ERR_RANGE, "primitive: remove: 3 out of range");
        op_bad(m, "{\"index\": 0}", FFD_ERR_PARSE, "primitive: radius");
        op_bad(m, "{\"index\": 0, \"radius\": 0}", FFD_ERR_INVALID, "primitive: radius");
        op_bad(m, "{\"add\": {\"type\": \"point\", \"radius\": 1}}", FFD_ERR_PARSE,
               "primitive: add.position");
        op_bad(m,
               "{\"add\": {\"type\": \"polyline\", \"file\": \"a.obj\", "
               "\"radius\": 1}}",
               FFD_ERR_PARSE, "primitive: add.file");
        op_bad(m, "{\"remove\": 0, \"index\": 0}", FFD_ERR_PARSE, "primitive: body");
        op_bad(m, "{\"grow\": 1}", FFD_ERR_PARSE, "primitive: grow: unknown key");
        ffd_error err = {{0}};
        check_error(run_op(m, "level", "{\"level\": 1}", NULL, &err), &err, FFD_ERR_UNSUPPORTED,
                    "level");
        /* a drag that folds a segment to zero length is refused and undone */
        double c[15];
        m->vt->controls(m, c);
        uint32_t one = 1;
        double *before = method_eval(m);
        CHECK_OK(m->vt->begin(m, &one, 1, 0, NULL));
        check_error(m->vt->set_controls(m, &one, 1, c, &err), &err, FFD_ERR_INVALID, "zero-length");
        m->vt->end(m, 1);
        double *after = method_eval(m);
        if (before && after)
            CHECK(max_diff(before, after, f.ctx.n) == 0);
        free(before);
        free(after);
        m->vt->destroy(m);
    }
    fixture_close(&f);
}

static void test_failing_allocations(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    for (long k = 0;; k++) {
        fail_alloc fa = {k, 0};
        ffd_allocator al = {fa_malloc, fa_realloc, fa_free, &fa};
        cJSON *body = json("{\"method\": \"gffd\"}");
        double *x = malloc(f.ctx.n * 3 * sizeof *x), c[18];
        float *w = malloc(f.ctx.n * sizeof *w);
        void *blob = NULL;
        uint32_t ids[2] = {4, 5};
        ffd_set_allocator(&al);
        sess_method *m = NULL;
        ffd_status s = sess_gffd_create(&f.ctx, body, &m, NULL);
        if (!s)
            s = run_op(m, "primitive",
                       "{\"add\": {\"type\": \"point\", \"position\": [0.3, 0, 0], "
                       "\"radius\": "
                       "0.2}}",
                       NULL, NULL);
        if (!s) {
            m->vt->controls(m, c);
            c[13] += 0.05;
            c[17] += 0.05;
            s = m->vt->snapshot(m, &blob, NULL);
        }
        if (!s)
            s = m->vt->begin(m, ids, 2, 0, NULL);
        if (!s)
            s = m->vt->set_controls(m, ids, 2, c + 12, NULL);
        if (m)
            m->vt->end(m, s == FFD_OK);
        if (!s)
            s = m->vt->eval(m, x, NULL);
        if (!s)
            s = m->vt->influence(m, ids, 1, w, NULL);
        if (!s)
            s = m->vt->restore(m, blob, NULL);
        if (!s)
            s = m->vt->eval(m, x, NULL);
        ffd_set_allocator(NULL);
        CHECK(s == FFD_OK || s == FFD_ERR_NOMEM);
        if (m) {
            m->vt->snapshot_free(blob);
            m->vt->destroy(m);
        }
        cJSON_Delete(body);
        free(x);
        free(w);
        if (s == FFD_OK)
            break;
        if (k > 100000) {
            CHECK(0);
            break;
        }
    }
    fixture_close(&f);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"default_skeleton_identity", test_default_skeleton_identity},
        {"drags_and_primitives_match_rig", test_drags_and_primitives_match_rig},
        {"load_rig", test_load_rig},
        {"snapshot_and_cancel", test_snapshot_and_cancel},
        {"influence", test_influence},
        {"bad_bodies", test_bad_bodies},
        {"failing_allocations", test_failing_allocations},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
