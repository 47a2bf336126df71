/* Tests for the binding of any point set by the GFFD and T-spline methods
 * (the vtable's bind, eval_points, jacobian_points, map_points, handle:
 * what ffd_deformer_bind uses): the mesh's vertices bound as other points
 * (in reverse order) deform bit for bit as the mesh does, and stay so across
 * control drags, method ops that change the structure (a T-spline
 * refinement, GFFD primitive edits), snapshot restores and reset (the
 * identity, bit for bit); the T-spline's linear map of the points gives
 * their positions; failing allocations leave a clean status. */
#include "check_sess_method.h"
#include "gffd/gffd_method.h"
#include "tspline/tspline_method.h"

#define BUNNY FFD_SOURCE_DIR "/examples/tspline/bunny.obj"
#define COW FFD_SOURCE_DIR "/examples/gffd/cow.off"

static sess_method *create(const sess_fixture *f, const char *body,
                           ffd_status (*make)(const sess_ctx *, const cJSON *, sess_method **,
                                              ffd_error *))
{
    cJSON *b = json(body);
    sess_method *m = NULL;
    ffd_error err = {{0}};
    if (make(&f->ctx, b, &m, &err) != FFD_OK) {
        fprintf(stderr, "%s: create: %s\n", check_current, err.message);
        check_failures++;
    }
    cJSON_Delete(b);
    return m;
}

/* The vertices in reverse order, bound. */
static sess_binding *bind_reversed(sess_method *m, double **points)
{
    size_t n = m->ctx->n;
    *points = malloc(3 * n * sizeof **points);
    for (size_t i = 0; i < n; i++)
        memcpy(*points + 3 * i, m->ctx->rest + 3 * (n - 1 - i), 3 * sizeof **points);
    sess_binding *b = NULL;
    ffd_error err = {{0}};
    CHECK(m->vt->bind != NULL);
    if (m->vt->bind)
        CHECK_OK(m->vt->bind(m, *points, n, &b, &err));
    return b;
}

/* The bound points (the vertices reversed) deform bit for bit as the mesh. */
static void check_same_at(sess_method *m, const sess_binding *b, const char *when, int line)
{
    size_t n = m->ctx->n;
    double *full = method_eval(m), *got = malloc(3 * n * sizeof *got);
    ffd_error err = {{0}};
    ffd_status st = b ? m->vt->eval_points(m, b, got, &err) : FFD_ERR_UNSUPPORTED;
    if (st || !full) {
        fprintf(stderr, "%s:%d: %s: eval_points: %s\n", check_current, line, when, err.message);
        check_failures++;
    } else {
        size_t differ = 0;
        for (size_t i = 0; i < n; i++)
            for (int a = 0; a < 3; a++)
                differ += got[3 * i + a] != full[3 * (n - 1 - i) + a];
        if (differ) {
            fprintf(stderr, "%s:%d: %s: %zu coordinates differ from the mesh's\n", check_current,
                    line, when, differ);
            check_failures++;
        }
    }
    free(full);
    free(got);
}
#define check_same(m, b, when) check_same_at(m, b, when, __LINE__)

/* Reset: the bound points come back bit for bit. */
static void check_identity(sess_method *m, const sess_binding *b, const double *points)
{
    size_t n = m->ctx->n;
    double *got = malloc(3 * n * sizeof *got);
    CHECK_OK(m->vt->reset(m, NULL));
    if (b) {
        CHECK_OK(m->vt->eval_points(m, b, got, NULL));
        CHECK(memcmp(got, points, 3 * n * sizeof *got) == 0);
    }
    free(got);
}

static void drag_control(sess_method *m, uint32_t id, double scale)
{
    double d[3] = {0.05 * scale, -0.03 * scale, 0.02 * scale};
    CHECK_OK(drag_by(m, &id, 1, d));
}

static void test_tspline_refine_restore(void)
{
    sess_fixture f;
    if (!fixture_open(&f, BUNNY))
        return;
    ffd_sess_ctx_init(&f.ctx, f.mesh, 0, NULL);
    sess_method *m =
        create(&f, "{\"method\":\"tspline\",\"resolution\":[5,5,5]}", ffd_sess_tspline_create);
    if (!m) {
        fixture_close(&f);
        return;
    }
    double *points = NULL, diag = f.ctx.diag;
    sess_binding *b = bind_reversed(m, &points);
    check_same(m, b, "rest");
    drag_control(m, 62, diag);
    check_same(m, b, "drag");
    size_t before = m->vt->control_count(m);
    CHECK_OK(run_op(m, "refine",
                    "{\"insertions\":[{\"cell\":21},{\"face\":{\"near\":[0,0,0]}}]}", NULL, NULL));
    CHECK(m->vt->control_count(m) > before);
    check_same(m, b, "refine"); /* Phi of the bound points rebuilt for the new lattice */
    drag_control(m, (uint32_t)(m->vt->control_count(m) - 1), diag);
    check_same(m, b, "drag after refine");

    /* the linear map: x'_i = sum_c w_ic P_c over the current controls */
    ffd_linear_map map;
    size_t count = m->vt->control_count(m), n = f.ctx.n;
    CHECK(m->vt->map_points != NULL);
    if (b && m->vt->map_points && m->vt->map_points(m, b, &map, NULL) == FFD_OK) {
        CHECK(map.point_count == n && map.column_count == count && map.variable_count == count);
        double *ctl = malloc(3 * count * sizeof *ctl), *got = malloc(3 * n * sizeof *got);
        uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
        double *w = malloc(map.max_row_nnz * sizeof *w), worst = 0;
        m->vt->controls(m, ctl);
        CHECK_OK(m->vt->eval_points(m, b, got, NULL));
        for (size_t i = 0; i < n; i++) {
            size_t k = map.row(map.self, i, cols, w);
            double x[3] = {0, 0, 0};
            for (size_t e = 0; e < k; e++) {
                CHECK(map.tie[cols[e]] == cols[e]);
                for (int a = 0; a < 3; a++)
                    x[a] += w[e] * ctl[3 * (size_t)cols[e] + a];
            }
            worst = fmax(worst, max_diff(x, got + 3 * i, 1));
        }
        CHECK(worst <= 1e-12 * diag);
        free(ctl);
        free(got);
        free(cols);
        free(w);
    }

    /* undo of a control edit (snapshot, restore) */
    void *blob = NULL;
    CHECK_OK(m->vt->snapshot(m, &blob, NULL));
    drag_control(m, 3, diag);
    CHECK_OK(m->vt->restore(m, blob, NULL));
    m->vt->snapshot_free(blob);
    check_same(m, b, "restore");

    /* at rest: the identity, and a Jacobian of exactly I */
    check_identity(m, b, points);
    double *jac = malloc(9 * n * sizeof *jac);
    if (b && m->vt->jacobian_points) {
        CHECK_OK(m->vt->jacobian_points(m, b, jac, NULL));
        size_t differ = 0;
        for (size_t i = 0; i < 9 * n; i++)
            differ += jac[i] != (i % 9 == 0 || i % 9 == 4 || i % 9 == 8);
        CHECK(differ == 0);
    }
    CHECK(m->vt->handle && m->vt->handle(m) != NULL);
    free(jac);
    if (b)
        m->vt->binding_free(b);
    free(points);
    m->vt->destroy(m);
    fixture_close(&f);
}

static void test_gffd_primitive_ops(void)
{
    sess_fixture f;
    if (!fixture_open(&f, COW))
        return;
    ffd_sess_ctx_init(&f.ctx, f.mesh, 0, NULL);
    sess_method *m = create(&f, "{\"method\":\"gffd\"}", ffd_sess_gffd_create);
    if (!m) {
        fixture_close(&f);
        return;
    }
    double *points = NULL, diag = f.ctx.diag;
    sess_binding *b = bind_reversed(m, &points);
    check_same(m, b, "rest");
    drag_control(m, 4, diag);
    check_same(m, b, "drag");
    /* a new primitive changes the rest field: the bound values e_0 change */
    char body[256];
    double c[3];
    for (int a = 0; a < 3; a++)
        c[a] = 0.5 * (f.ctx.min[a] + f.ctx.max[a]);
    snprintf(body, sizeof body,
             "{\"add\":{\"type\":\"point\",\"position\":[%.17g,%.17g,%.17g],\"radius\":%.17g}}",
             c[0], c[1] + 0.1 * diag, c[2], 0.25 * diag);
    CHECK_OK(run_op(m, "primitive", body, NULL, NULL));
    check_same(m, b, "add");
    drag_control(m, (uint32_t)(m->vt->control_count(m) - 1), diag);
    check_same(m, b, "drag of the added point");
    snprintf(body, sizeof body, "{\"index\":0,\"radius\":%.17g}", 0.4 * diag);
    CHECK_OK(run_op(m, "primitive", body, NULL, NULL));
    check_same(m, b, "radius");

    void *blob = NULL;
    CHECK_OK(m->vt->snapshot(m, &blob, NULL));
    drag_control(m, 1, diag);
    CHECK_OK(m->vt->restore(m, blob, NULL));
    m->vt->snapshot_free(blob);
    check_same(m, b, "restore");
    CHECK_OK(run_op(m, "primitive", "{\"remove\":1}", NULL, NULL));
    check_same(m, b, "remove");

    check_identity(m, b, points);
    /* tracking has no exact derivative; the map is not linear */
    CHECK(m->vt->jacobian_points == NULL && m->vt->map_points == NULL);
    CHECK(m->vt->handle && m->vt->handle(m) != NULL);
    if (b)
        m->vt->binding_free(b);
    free(points);
    m->vt->destroy(m);
    fixture_close(&f);
}

/* Every allocation of bind, eval_points and map_points failing in turn:
 * FFD_ERR_NOMEM, nothing leaked (the ASan build checks), and then it works. */
static void sweep_binding(sess_method *m, const double *points, size_t n)
{
    double *out = malloc(3 * n * sizeof *out);
    for (long k = 0;; k += check_sweep_step()) {
        fail_alloc fa = {k, 0};
        ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&a);
        sess_binding *b = NULL;
        ffd_linear_map map;
        ffd_error err = {{0}};
        ffd_status st = m->vt->bind(m, points, n, &b, &err);
        if (!st)
            st = m->vt->eval_points(m, b, out, &err);
        if (!st && m->vt->map_points)
            st = m->vt->map_points(m, b, &map, &err);
        if (b)
            m->vt->binding_free(b);
        ffd_set_allocator(NULL);
        CHECK(st == FFD_OK || st == FFD_ERR_NOMEM);
        CHECK(st == FFD_OK || strstr(err.message, "out of memory") != NULL);
        if (st == FFD_OK || k > 200) {
            CHECK(st == FFD_OK && fa.count <= k); /* every allocation was failed once */
            break;
        }
    }
    free(out);
}

static void test_binding_out_of_memory(void)
{
    sess_fixture f;
    if (!fixture_open(&f, BUNNY))
        return;
    ffd_sess_ctx_init(&f.ctx, f.mesh, 0, NULL);
    sess_method *t =
        create(&f, "{\"method\":\"tspline\",\"resolution\":[4,4,4]}", ffd_sess_tspline_create);
    sess_method *g = create(&f, "{\"method\":\"gffd\"}", ffd_sess_gffd_create);
    if (t && t->vt->bind) {
        CHECK_OK(run_op(t, "refine", "{\"insertions\":[{\"cell\":13}]}", NULL, NULL));
        sweep_binding(t, f.ctx.rest, 200);
    }
    if (g && g->vt->bind) {
        drag_control(g, 2, f.ctx.diag);
        sweep_binding(g, f.ctx.rest, 200);
    }
    CHECK(t && t->vt->bind && g && g->vt->bind);
    if (t)
        t->vt->destroy(t);
    if (g)
        g->vt->destroy(g);
    fixture_close(&f);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"tspline_refine_restore", test_tspline_refine_restore},
        {"gffd_primitive_ops", test_gffd_primitive_ops},
        {"binding_out_of_memory", test_binding_out_of_memory},
    };
    (void)check_error_at; /* helpers of check_sess_method.h this file does not need */
    (void)check_rig_matches_at;
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
