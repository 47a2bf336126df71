/* Tests for the editor's GFFD method (src/gffd/gffd_session.c) through its
 * vtable: identity at rest; after skeleton drags and primitive edits, eval
 * equals ffd_rig_apply of the method's rig; load reproduces a rig; snapshots
 * restore bitwise; bad bodies name the key; the influence is the primitives'
 * share of the field; failing allocations leave nothing behind. */
#include "check_sess_method.h"
#include "gffd/gffd_method.h"

#define COW FFD_SOURCE_DIR "/examples/gffd/cow.off"

static sess_method *create(const sess_fixture *f, const char *body)
{
    cJSON *b = json(body);
    sess_method *m = NULL;
    ffd_error err = {{0}};
    if (ffd_sess_gffd_create(&f->ctx, b, &m, &err) != FFD_OK) {
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
            CHECK_OK(ffd_sess_gffd_load(&f.ctx, rig, &loaded, NULL));
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
        CHECK_OK(ffd_sess_gffd_load(&f.ctx, rig, &m, NULL));
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
            check_error(ffd_sess_gffd_load(&f.ctx, rig, &m, &err), &err, FFD_ERR_INVALID,
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

/* x -> center + R(axis, angle) (x - center), Rodrigues written out here. */
static void rigid_apply(const double axis[3], double angle, const double center[3],
                        const double *x, double *out)
{
    double len = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    double k[3] = {axis[0] / len, axis[1] / len, axis[2] / len}, c = cos(angle), s = sin(angle);
    double d[3] = {x[0] - center[0], x[1] - center[1], x[2] - center[2]};
    double kd = k[0] * d[0] + k[1] * d[1] + k[2] * d[2];
    double kxd[3] = {k[1] * d[2] - k[2] * d[1], k[2] * d[0] - k[0] * d[2],
                     k[0] * d[1] - k[1] * d[0]};
    for (int a = 0; a < 3; a++)
        out[a] = center[a] + d[a] * c + kxd[a] * s + k[a] * kd * (1 - c);
}

/* A whole rotate drag of controls ids as the session does it (docs/editor.md
 * drag_begin mode "rotate"): two steps, the targets and the motion. */
static ffd_status rotate_by(sess_method *m, const uint32_t *ids, size_t k, const double axis[3],
                            double angle, const double center[3])
{
    size_t c = m->vt->control_count(m);
    double *pos = malloc(c * 3 * sizeof *pos), *t = malloc(k * 3 * sizeof *t);
    const double zero[3] = {0, 0, 0};
    m->vt->controls(m, pos);
    ffd_error err = {{0}};
    ffd_status s = m->vt->begin(m, ids, k, 0, &err);
    for (int step = 1; !s && step <= 2; step++) {
        double a = 0.5 * step * angle;
        for (size_t i = 0; i < k; i++)
            rigid_apply(axis, a, center, pos + 3 * ids[i], t + 3 * i);
        s = m->vt->set_motion ? m->vt->set_motion(m, ids, k, t, axis, a, center, zero, &err)
                              : m->vt->set_controls(m, ids, k, t, &err);
    }
    if (s)
        fprintf(stderr, "%s: rotate: %s\n", check_current, err.message);
    m->vt->end(m, s == FFD_OK);
    free(pos);
    free(t);
    return s;
}

/* A rotation of a whole point or straight polyline primitive, about an
 * off-centre point and about the primitive itself (a turn its vertices
 * cannot show), moves every influenced vertex by exactly that rigid motion
 * (blended by its weight in the influence band), and the rig replays it;
 * a second rotation composes; undo (restore) and cancel are exact. */
static void test_rotate_primitive_about_itself(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    static const char *const bodies[2] = {
        "{\"method\": \"gffd\", \"unit\": 0.12, \"skeleton\": [{\"type\": \"point\", "
        "\"position\": [0.02, 0.01, 0], \"radius\": 0.3}]}",
        "{\"method\": \"gffd\", \"unit\": 0.12, \"skeleton\": [{\"type\": \"polyline\", "
        "\"vertices\": [[-0.3, 0.01, 0], [0, 0.01, 0], [0.3, 0.01, 0]], \"radius\": 0.25}]}"};
    const double point[3] = {0.02, 0.01, 0}, line[9] = {-0.3, 0.01, 0, 0, 0.01, 0, 0.3, 0.01, 0};
    for (int kind = 0; kind < 2; kind++) {
        ffd_gffd_primitive prim = {kind ? FFD_GFFD_POLYLINE : FFD_GFFD_POINT,
                                   kind ? line : point, kind ? 3 : 1, NULL, NULL, 0,
                                   kind ? 0.25 : 0.3};
        ffd_gffd_options opt;
        memset(&opt, 0, sizeof opt);
        opt.unit = 0.12;
        ffd_gffd *bound = NULL; /* the blend weights b (ffd_gffd_track) */
        CHECK_OK(ffd_gffd_create(&prim, 1, f.ctx.rest, f.ctx.n, &opt, &bound, NULL));
        const double *b = bound ? ffd_gffd_bound_weights(bound) : NULL;
        /* about itself (a point's position; the line's own axis through its
         * middle), then about an off-centre point */
        const double self_axis[3] = {kind ? 1 : 0.3, kind ? 0 : 0.4, kind ? 0 : 0.5};
        const double self_center[3] = {kind ? 0 : 0.02, 0.01, 0};
        const double off_axis[3] = {0.2, 1, -0.3}, off_center[3] = {0.1, -0.05, 0.04};
        for (int off = 0; off < 2 && b; off++) {
            sess_method *m = create(&f, bodies[kind]);
            if (!m)
                break;
            const uint32_t ids[3] = {0, 1, 2};
            const double *axis = off ? off_axis : self_axis, *center = off ? off_center : self_center;
            const double angle = 0.7;
            void *rest = NULL;
            CHECK_OK(m->vt->snapshot(m, &rest, NULL));
            CHECK_OK(rotate_by(m, ids, kind ? 3 : 1, axis, angle, center));
            double *x = method_eval(m);
            size_t moved = 0;
            for (size_t v = 0; x && v < f.ctx.n; v++) {
                double to[3], want[3];
                rigid_apply(axis, angle, center, f.ctx.rest + 3 * v, to);
                for (int a = 0; a < 3; a++) {
                    const double r = f.ctx.rest[3 * v + a];
                    want[a] = r + b[v] * (to[a] - r);
                }
                double d = 0, e = 0;
                for (int a = 0; a < 3; a++) {
                    d = fmax(d, fabs(x[3 * v + a] - want[a]));
                    e = fmax(e, fabs(x[3 * v + a] - f.ctx.rest[3 * v + a]));
                }
                if (!(d <= 1e-12 * f.ctx.diag)) {
                    fprintf(stderr, "%s: kind %d off %d: vertex %zu (b %.3g) is %.3g off the motion\n",
                            check_current, kind, off, v, b[v], d);
                    check_failures++;
                    break;
                }
                moved += e > 1e-3 * f.ctx.diag;
            }
            CHECK(moved > 100);
            check_rig_matches(m, COW);
            char *text = method_rig_text(m);
            cJSON *doc = text ? cJSON_Parse(text) : NULL, *edit;
            edit = cJSON_GetArrayItem(cJSON_GetObjectItem(doc, "edits"), 0);
            CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(doc, "edits")) == 1 &&
                  cJSON_GetObjectItem(edit, "rotate") && cJSON_GetObjectItem(edit, "center"));
            cJSON_Delete(doc);
            /* the rig loads back to the same positions, bitwise */
            ffd_rig *rig = NULL;
            sess_method *loaded = NULL;
            if (text)
                CHECK_OK(ffd_rig_parse_json(text, strlen(text), "r.json", &rig, NULL));
            if (rig)
                CHECK_OK(ffd_sess_gffd_load(&f.ctx, rig, &loaded, NULL));
            if (loaded) {
                double *y = method_eval(loaded);
                if (x && y)
                    CHECK(max_diff(x, y, f.ctx.n) == 0);
                free(y);
                loaded->vt->destroy(loaded);
            }
            ffd_rig_destroy(rig);
            cJSON_free(text);
            /* a cancelled translation, then a committed one, keep the turn */
            uint32_t tip = 0;
            double c[9];
            m->vt->controls(m, c);
            CHECK_OK(m->vt->begin(m, ids, kind ? 3 : 1, 0, NULL));
            CHECK_OK(m->vt->set_controls(m, &tip, 1, (double[3]){c[0] + 0.05, c[1], c[2]}, NULL));
            m->vt->end(m, 0);
            double *y = method_eval(m);
            if (x && y)
                CHECK(max_diff(x, y, f.ctx.n) == 0);
            free(y);
            const double delta[3] = {0.01, -0.02, 0.005};
            double tt[9];
            for (int i = 0; i < (kind ? 3 : 1); i++)
                for (int a = 0; a < 3; a++)
                    tt[3 * i + a] = c[3 * i + a] + delta[a];
            CHECK_OK(m->vt->begin(m, ids, kind ? 3 : 1, 0, NULL));
            const double zero[3] = {0, 0, 0};
            if (m->vt->set_motion)
                CHECK_OK(m->vt->set_motion(m, ids, kind ? 3 : 1, tt, zero, 0, center, delta, NULL));
            else
                CHECK_OK(m->vt->set_controls(m, ids, kind ? 3 : 1, tt, NULL));
            m->vt->end(m, 1);
            y = method_eval(m);
            for (size_t v = 0; x && y && v < f.ctx.n; v++) {
                double d = 0;
                for (int a = 0; a < 3; a++)
                    d = fmax(d, fabs(y[3 * v + a] - (x[3 * v + a] + b[v] * delta[a])));
                if (!(d <= 1e-12 * f.ctx.diag)) {
                    fprintf(stderr, "%s: kind %d off %d: translated vertex %zu is %.3g off\n",
                            check_current, kind, off, v, d);
                    check_failures++;
                    break;
                }
            }
            free(y);
            check_rig_matches(m, COW);
            /* a skeleton edit (a new radius) keeps the primitive's motions */
            CHECK_OK(run_op(m, "primitive", kind ? "{\"index\": 0, \"radius\": 0.27}"
                                                 : "{\"index\": 0, \"radius\": 0.32}",
                            NULL, NULL));
            text = method_rig_text(m);
            doc = text ? cJSON_Parse(text) : NULL;
            edit = cJSON_GetArrayItem(cJSON_GetObjectItem(doc, "edits"), 0);
            CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(doc, "edits")) == 2 &&
                  cJSON_GetObjectItem(edit, "rotate"));
            cJSON_Delete(doc);
            cJSON_free(text);
            check_rig_matches(m, COW);
            /* undo: the snapshot at rest, identity again */
            CHECK_OK(m->vt->restore(m, rest, NULL));
            y = method_eval(m);
            if (y)
                CHECK(max_diff(y, f.ctx.rest, f.ctx.n) == 0);
            free(y);
            free(x);
            m->vt->snapshot_free(rest);
            m->vt->destroy(m);
        }
        ffd_gffd_destroy(bound);
    }
    fixture_close(&f);
}

/* Runs a session op (reply freed). */
static ffd_status session_run(ffd_session *s, const char *op, const char *body)
{
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    ffd_error err = {{0}};
    ffd_status st = ffd_session_command(s, op, body, strlen(body), &reply, &size, &binary, &err);
    if (st)
        fprintf(stderr, "%s: %s %s: %s\n", check_current, op, body, err.message);
    ffd_free(reply);
    return st;
}

/* The frame's positions and controls (malloc'd floats after the header). */
static float *session_frame(ffd_session *s, size_t *count)
{
    void *data = NULL;
    size_t size = 0;
    float *p = NULL;
    if (ffd_session_frame(s, &data, &size, NULL) == FFD_OK && size > 20) {
        *count = (size - 20) / 4;
        p = malloc(size - 20);
        memcpy(p, (char *)data + 20, size - 20);
    }
    ffd_free(data);
    return p;
}

/* The session's rotate op ("move" with an angle, a gizmo rotation) of a
 * point primitive about itself turns the mesh, writes a "rotate" edit that
 * ffd deform replays, and undo, redo and load_rig are exact. */
static void test_session_rotate_op(void)
{
    ffd_mesh *mesh = NULL;
    ffd_session *s = NULL;
    CHECK_OK(ffd_mesh_read(COW, &mesh, NULL));
    if (mesh)
        CHECK_OK(ffd_session_create(mesh, "cow", NULL, &s, NULL));
    if (!s)
        return;
    size_t n0 = 0, n1 = 0, n2 = 0, n3 = 0;
    float *rest = NULL, *turned = NULL, *again = NULL, *loaded = NULL;
    char *text = NULL;
    size_t size = 0;
    if (!session_run(s, "create",
                     "{\"method\": \"gffd\", \"unit\": 0.12, \"skeleton\": [{\"type\": \"point\", "
                     "\"position\": [0.02, 0.01, 0], \"radius\": 0.3}]}") &&
        (rest = session_frame(s, &n0)) &&
        !session_run(s, "move", "{\"points\": [0], \"axis\": [0.3, 0.4, 0.5], \"angle\": 0.7}") &&
        (turned = session_frame(s, &n1))) {
        size_t differ = 0;
        for (size_t i = 0; i < n0 && n1 == n0; i++)
            differ += fabsf(turned[i] - rest[i]) > 1e-3f;
        CHECK(n1 == n0 && differ > 100);
        CHECK_OK(ffd_session_rig(s, &text, &size, NULL));
        CHECK(text && strstr(text, "\"rotate\""));
        ffd_mesh *deformed = NULL; /* what ffd deform writes */
        CHECK_OK(ffd_session_deformed(s, &deformed, NULL));
        if (deformed) {
            const double *x = ffd_mesh_positions(deformed);
            double d = 0;
            for (size_t i = 0; i < 3 * ffd_mesh_vertex_count(deformed); i++)
                d = fmax(d, fabs(x[i] - turned[i]));
            CHECK(d <= 1e-6);
        }
        ffd_mesh_destroy(deformed);
        CHECK_OK(session_run(s, "undo", ""));
        free(again);
        again = session_frame(s, &n2);
        CHECK(again && n2 == n0 && memcmp(again, rest, n0 * sizeof *rest) == 0);
        CHECK_OK(session_run(s, "redo", ""));
        free(again);
        again = session_frame(s, &n2);
        CHECK(again && n2 == n1 && memcmp(again, turned, n1 * sizeof *turned) == 0);
        CHECK_OK(session_run(s, "reset", ""));
        if (text)
            CHECK_OK(ffd_session_load_rig(s, text, size, "rig.json", NULL, NULL));
        loaded = session_frame(s, &n3);
        CHECK(loaded && n3 == n1 && memcmp(loaded, turned, n1 * sizeof *turned) == 0);
    }
    free(rest);
    free(turned);
    free(again);
    free(loaded);
    ffd_free(text);
    ffd_session_destroy(s);
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
    check_error(ffd_sess_gffd_create(&f->ctx, b, &m, &err), &err, want, fragment);
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
    for (long k = 0;; k += check_sweep_step()) {
        fail_alloc fa = {k, 0};
        ffd_allocator al = {fa_malloc, fa_realloc, fa_free, &fa};
        cJSON *body = json("{\"method\": \"gffd\"}");
        double *x = malloc(f.ctx.n * 3 * sizeof *x), c[18];
        float *w = malloc(f.ctx.n * sizeof *w);
        void *blob = NULL;
        uint32_t ids[2] = {4, 5};
        ffd_set_allocator(&al);
        sess_method *m = NULL;
        ffd_status s = ffd_sess_gffd_create(&f.ctx, body, &m, NULL);
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
        /* the point turned about itself (a rotate edit), then re-bound */
        const double axis[3] = {0, 0, 1}, zero[3] = {0, 0, 0};
        if (!s)
            s = m->vt->begin(m, ids + 1, 1, 0, NULL);
        if (!s)
            s = m->vt->set_motion(m, ids + 1, 1, c + 15, axis, 0.5, c + 15, zero, NULL);
        if (m)
            m->vt->end(m, s == FFD_OK);
        if (!s)
            s = run_op(m, "primitive", "{\"index\": 1, \"radius\": 0.25}", NULL, NULL);
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
        {"rotate_primitive_about_itself", test_rotate_primitive_about_itself},
        {"session_rotate_op", test_session_rotate_op},
        {"influence", test_influence},
        {"bad_bodies", test_bad_bodies},
        {"failing_allocations", test_failing_allocations},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
