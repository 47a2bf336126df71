/* Helpers for the tests of the session's method files
 * (src/session/session_*.c): a context on a mesh file, the method's rig applied
 * by ffd_rig_apply to a fresh copy of that file, and comparisons of positions.
 */
#ifndef FFD_TEST_CHECK_SESS_METHOD_H
#define FFD_TEST_CHECK_SESS_METHOD_H

#include "check.h"
#include "session/session.h"

typedef struct sess_fixture {
    const char *path;
    ffd_mesh *mesh;
    sess_ctx ctx;
} sess_fixture;

static int fixture_open(sess_fixture *f, const char *path)
{
    memset(f, 0, sizeof *f);
    f->path = path;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &f->mesh, &err) != FFD_OK) {
        fprintf(stderr, "%s: %s\n", check_current, err.message);
        check_failures++;
        return 0;
    }
    sess_ctx *c = &f->ctx;
    c->mesh = f->mesh;
    c->n = ffd_mesh_vertex_count(f->mesh);
    c->rest = ffd_mesh_positions(f->mesh);
    for (int a = 0; a < 3; a++) {
        c->min[a] = INFINITY;
        c->max[a] = -INFINITY;
    }
    for (size_t i = 0; i < c->n; i++)
        for (int a = 0; a < 3; a++) {
            c->min[a] = fmin(c->min[a], c->rest[3 * i + a]);
            c->max[a] = fmax(c->max[a], c->rest[3 * i + a]);
        }
    double d = 0;
    for (int a = 0; a < 3; a++)
        d += (c->max[a] - c->min[a]) * (c->max[a] - c->min[a]);
    c->diag = d > 0 ? sqrt(d) : 1;
    return 1;
}

static void fixture_close(sess_fixture *f)
{
    ffd_mesh_destroy(f->mesh);
}

static double max_diff(const double *a, const double *b, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < 3 * n; i++)
        m = fmax(m, fabs(a[i] - b[i]));
    return m;
}

/* The method's positions (malloc'd, n by 3), or NULL after a reported failure.
 */
static double *method_eval(sess_method *m)
{
    double *out = malloc((m->ctx->n ? m->ctx->n : 1) * 3 * sizeof *out);
    ffd_error err = {{0}};
    if (m->vt->eval(m, out, &err) != FFD_OK) {
        fprintf(stderr, "%s: eval: %s\n", check_current, err.message);
        check_failures++;
        free(out);
        return NULL;
    }
    return out;
}

/* The method's rig as JSON text (cJSON_free). */
static char *method_rig_text(const sess_method *m)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddNumberToObject(root, "version", 1);
    cJSON_AddStringToObject(root, "deformer", m->vt->name);
    ffd_error err = {{0}};
    char *text = NULL;
    if (m->vt->rig(m, root, &err) != FFD_OK) {
        fprintf(stderr, "%s: rig: %s\n", check_current, err.message);
        check_failures++;
    } else {
        text = cJSON_PrintUnformatted(root);
    }
    cJSON_Delete(root);
    return text;
}

/* ffd_rig_apply of text on a fresh read of path: the positions (malloc'd). */
static double *apply_rig_text(const char *text, const char *path)
{
    ffd_rig *rig = NULL;
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    double *out = NULL;
    if (ffd_rig_parse_json(text, strlen(text), "session.json", &rig, &err) == FFD_OK &&
        ffd_mesh_read(path, &mesh, &err) == FFD_OK &&
        ffd_rig_apply(rig, mesh, NULL, &err) == FFD_OK) {
        size_t n = ffd_mesh_vertex_count(mesh);
        out = malloc((n ? n : 1) * 3 * sizeof *out);
        memcpy(out, ffd_mesh_positions(mesh), n * 3 * sizeof *out);
    } else {
        fprintf(stderr, "%s: applying the rig: %s\n  rig: %.400s\n", check_current, err.message,
                text);
        check_failures++;
    }
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
    return out;
}

/* The invariant of session.h: eval equals ffd_rig_apply of the method's rig. */
static void check_rig_matches_at(const sess_method *m, const char *path, int line)
{
    double *eval = method_eval((sess_method *)m);
    char *text = method_rig_text(m);
    double *applied = text ? apply_rig_text(text, path) : NULL;
    if (eval && applied) {
        double d = max_diff(eval, applied, m->ctx->n), tol = 1e-9 * m->ctx->diag;
        if (!(d <= tol)) {
            fprintf(stderr, "line %d: %s: eval and the rig differ by %.3g > %.3g\n", line,
                    check_current, d, tol);
            check_failures++;
        }
    }
    free(eval);
    free(applied);
    cJSON_free(text);
}
#define check_rig_matches(m, path) check_rig_matches_at(m, path, __LINE__)

/* Expects status and a message containing fragment. */
static void check_error_at(ffd_status got, const ffd_error *err, ffd_status want,
                           const char *fragment, int line)
{
    if (got != want || !strstr(err->message, fragment)) {
        fprintf(stderr, "line %d: %s: expected %s with \"%s\", got %s \"%s\"\n", line,
                check_current, ffd_status_string(want), fragment, ffd_status_string(got),
                err->message);
        check_failures++;
    }
}
#define check_error(got, err, want, fragment) check_error_at(got, err, want, fragment, __LINE__)

static cJSON *json(const char *text)
{
    cJSON *j = cJSON_Parse(text);
    if (!j) {
        fprintf(stderr, "%s: bad test JSON: %s\n", check_current, text);
        check_failures++;
    }
    return j;
}

/* Runs op with the JSON body text; returns its status. Under a failing
 * allocator the body's parse can run out of memory too (cJSON allocates
 * through ffd_set_allocator's allocator): FFD_ERR_NOMEM then. */
static ffd_status run_op(sess_method *m, const char *op, const char *body, int *undo,
                         ffd_error *err)
{
    unsigned long oom = ffd_json_alloc_failures();
    cJSON *b = cJSON_Parse(body);
    if (!b && ffd_json_alloc_failures() != oom)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory parsing the body", op);
    if (!b)
        b = json(body); /* reports the bad test JSON */
    int u = -1;
    ffd_status s = m->vt->op(m, op, b, undo ? undo : &u, err);
    cJSON_Delete(b);
    return s;
}

/* A whole drag of controls ids by delta, in two steps, committed. */
static ffd_status drag_by(sess_method *m, const uint32_t *ids, size_t k, const double delta[3])
{
    size_t c = m->vt->control_count(m);
    double *pos = malloc(c * 3 * sizeof *pos), *t = malloc((k ? k : 1) * 3 * sizeof *t);
    m->vt->controls(m, pos);
    ffd_error err = {{0}};
    ffd_status s = m->vt->begin(m, ids, k, 0, &err);
    for (int step = 1; !s && step <= 2; step++) {
        for (size_t i = 0; i < k; i++)
            for (int a = 0; a < 3; a++)
                t[3 * i + a] = pos[3 * ids[i] + a] + 0.5 * step * delta[a];
        s = m->vt->set_controls(m, ids, k, t, &err);
    }
    if (s)
        fprintf(stderr, "%s: drag: %s\n", check_current, err.message);
    m->vt->end(m, s == FFD_OK);
    free(pos);
    free(t);
    return s;
}

#endif
