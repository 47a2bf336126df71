/* Tests for the sensitivities dX/dP (ffd.h "Sensitivities"), through the
 * public deformer for every method's example rigs (check_deformer.h): W
 * against central differences of the evaluation when one control coordinate
 * moves (the map is linear in the controls, so the differences are exact up
 * to rounding), the products W v and W^T w against the formed W and against
 * each other (<W v, w> = <v, W^T w>), B-spline border ties merged (a corner
 * point follows its corner control alone), frozen T-spline points,
 * the same bits for any thread count, a method's own products (the
 * sess_vtable hook) and the refusals. */
#include "check.h"
#include "check_deformer.h"

#include "deformer/method.h"
#include "ffd.h"

#include <omp.h>

/* Deterministic values in [-1, 1). */
static double next_random(uint64_t *state)
{
    *state = *state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*state >> 11) / (double)(1ULL << 52) - 1.0;
}

static double *random_vector(size_t count, uint64_t seed)
{
    double *v = malloc((count ? count : 1) * sizeof *v);
    for (size_t i = 0; i < count; i++)
        v[i] = next_random(&seed);
    return v;
}

/* CSR well formed: rows and columns as asked, row_ptr increasing from 0 to
 * nnz, columns in range and strictly increasing in each row, values finite. */
static int sparse_well_formed(const ffd_sparse *W, size_t rows, size_t cols)
{
    if (W->rows != rows || W->cols != cols || !W->row_ptr || W->row_ptr[0] != 0
        || W->row_ptr[rows] != W->nnz)
        return 0;
    for (size_t i = 0; i < rows; i++) {
        if (W->row_ptr[i + 1] < W->row_ptr[i])
            return 0;
        for (size_t k = W->row_ptr[i]; k < W->row_ptr[i + 1]; k++)
            if (W->col[k] >= cols || (k > W->row_ptr[i] && W->col[k] <= W->col[k - 1])
                || !isfinite(W->val[k]))
                return 0;
    }
    return 1;
}

static double *dense(const ffd_sparse *W)
{
    double *a = calloc(W->rows * W->cols + 1, sizeof *a);
    for (size_t i = 0; i < W->rows; i++)
        for (size_t k = W->row_ptr[i]; k < W->row_ptr[i + 1]; k++)
            a[i * W->cols + W->col[k]] += W->val[k];
    return a;
}

static double control_diagonal(ffd_deformer *d)
{
    size_t count = ffd_deformer_control_count(d);
    double *ctl = malloc(3 * count * sizeof *ctl);
    ffd_deformer_controls(d, ctl);
    double diag = diagonal(ctl, count);
    free(ctl);
    return diag > 0 ? diag : 1;
}

/* Column j of W (coordinate a) against central differences of the
 * evaluation of the s bound points; returns the worst relative error. */
static double column_fd_error(ffd_deformer *d, const double *Wd, size_t s, size_t count,
                              uint32_t j, double h)
{
    ffd_error err = {{0}};
    double ctl[3], p[3], worst = 0;
    double *plus = malloc(3 * s * sizeof *plus), *minus = malloc(3 * s * sizeof *minus);
    double *all = malloc(3 * count * sizeof *all);
    ffd_deformer_controls(d, all);
    memcpy(ctl, all + 3 * (size_t)j, sizeof ctl);
    for (int a = 0; a < 3; a++) {
        memcpy(p, ctl, sizeof p);
        p[a] += h;
        CHECK_OK(ffd_deformer_set_controls(d, &j, 1, p, &err));
        CHECK_OK(ffd_deformer_eval(d, plus, &err));
        p[a] = ctl[a] - h;
        CHECK_OK(ffd_deformer_set_controls(d, &j, 1, p, &err));
        CHECK_OK(ffd_deformer_eval(d, minus, &err));
        CHECK_OK(ffd_deformer_set_controls(d, &j, 1, ctl, &err));
        for (size_t i = 0; i < s; i++)
            for (int b = 0; b < 3; b++) {
                double fd = (plus[3 * i + b] - minus[3 * i + b]) / (2 * h);
                double want = b == a ? Wd[i * count + j] : 0; /* dX/dP = W (x) I3 */
                worst = fmax(worst, fabs(fd - want) / fmax(1, fabs(want)));
            }
    }
    free(plus);
    free(minus);
    free(all);
    return worst;
}

/* W against central differences for the columns of a spread of its
 * entries and a spread of all controls (zero columns must stay zero). */
static void check_fd(const rig_case *rc, const ffd_mesh *mesh, ffd_deformer *d)
{
    ffd_error err = {{0}};
    double points[3 * 60];
    size_t s = bind_sample(d, mesh, 60, points), count = ffd_deformer_control_count(d);
    ffd_sparse W;
    ffd_status st = ffd_deformer_sensitivities(d, &W, &err);
    if (st == FFD_ERR_UNSUPPORTED) {
        CHECK(strstr(err.message, ffd_deformer_method(d)) != NULL);
        CHECK(W.row_ptr == NULL && W.nnz == 0);
        return;
    }
    CHECK(st == FFD_OK);
    if (st)
        return;
    CHECK(sparse_well_formed(&W, s, count));
    double *Wd = dense(&W);
    const double h = 1e-3 * control_diagonal(d);
    size_t samples = getenv("FFD_TEST_QUICK") ? 4 : 12;
    double worst = 0;
    for (size_t q = 0; q < samples && W.nnz; q++)
        worst = fmax(worst, column_fd_error(d, Wd, s, count, W.col[q * W.nnz / samples], h));
    for (size_t q = 0; q < samples; q++)
        worst = fmax(worst, column_fd_error(d, Wd, s, count, (uint32_t)(q * count / samples), h));
    if (worst > 1e-8)
        fprintf(stderr, "%s: W vs central differences: %.3g\n", rc->rig, worst);
    CHECK(worst <= 1e-8);
    free(Wd);
    ffd_sparse_free(&W);
    CHECK(W.row_ptr == NULL && W.col == NULL && W.val == NULL && W.nnz == 0);
}

static void test_fd(void)
{
    for_each_case(check_fd);
}

/* The products on all the mesh's vertices against the formed W, and
 * against each other: <W v, w> = <v, W^T w>. */
static void check_products(const rig_case *rc, const ffd_mesh *mesh, ffd_deformer *d)
{
    (void)mesh;
    ffd_error err = {{0}};
    size_t n = ffd_deformer_point_count(d), count = ffd_deformer_control_count(d);
    double *v = random_vector(3 * count, 7), *w = random_vector(3 * n, 11);
    double *Wv = malloc(3 * n * sizeof *Wv), *Wtw = malloc(3 * count * sizeof *Wtw);
    ffd_sparse W;
    ffd_status st = ffd_deformer_sensitivities(d, &W, &err);
    if (st == FFD_ERR_UNSUPPORTED) {
        CHECK(ffd_deformer_sensitivity_product(d, v, Wv, &err) == FFD_ERR_UNSUPPORTED);
        CHECK(strstr(err.message, ffd_deformer_method(d)) != NULL);
        CHECK(ffd_deformer_sensitivity_transpose_product(d, w, Wtw, &err) == FFD_ERR_UNSUPPORTED);
        CHECK(strstr(err.message, ffd_deformer_method(d)) != NULL);
    } else {
        CHECK(st == FFD_OK);
        CHECK_OK(ffd_deformer_sensitivity_product(d, v, Wv, &err));
        CHECK_OK(ffd_deformer_sensitivity_transpose_product(d, w, Wtw, &err));
        double *wantv = calloc(3 * n, sizeof *wantv), *wantt = calloc(3 * count, sizeof *wantt);
        double bound = 0, dot_v = 0, dot_t = 0, worst_v = 0, worst_t = 0;
        for (size_t i = 0; i < n; i++)
            for (size_t k = W.row_ptr[i]; k < W.row_ptr[i + 1]; k++)
                for (int a = 0; a < 3; a++) {
                    wantv[3 * i + a] += W.val[k] * v[3 * (size_t)W.col[k] + a];
                    wantt[3 * (size_t)W.col[k] + a] += W.val[k] * w[3 * i + a];
                    bound += fabs(W.val[k] * v[3 * (size_t)W.col[k] + a] * w[3 * i + a]);
                }
        for (size_t i = 0; i < 3 * n; i++) {
            worst_v = fmax(worst_v, fabs(Wv[i] - wantv[i]));
            dot_v += Wv[i] * w[i];
        }
        for (size_t c = 0; c < 3 * count; c++) {
            worst_t = fmax(worst_t, fabs(Wtw[c] - wantt[c]));
            dot_t += v[c] * Wtw[c];
        }
        /* entries of v and w are at most 1; W's rows sum to 1 with few
         * negative weights, its columns to at most the point count */
        if (worst_v > 1e-12 || worst_t > 1e-12 * (double)n || fabs(dot_v - dot_t) > 1e-12 * bound)
            fprintf(stderr, "%s: W v %.3g, W^T w %.3g, <Wv,w> - <v,W^T w> %.3g\n", rc->rig,
                    worst_v, worst_t, dot_v - dot_t);
        CHECK(worst_v <= 1e-12);
        CHECK(worst_t <= 1e-12 * (double)n);
        CHECK(fabs(dot_v - dot_t) <= 1e-12 * bound);
        free(wantv);
        free(wantt);
    }
    ffd_sparse_free(&W);
    free(v);
    free(w);
    free(Wv);
    free(Wtw);
}

static void test_products(void)
{
    for_each_case(check_products);
}

/* The same bits for 1, 2 and 3 threads: W, W v and W^T w, on the mesh's
 * vertices and on 20,000 points spread over the controls' box (many
 * blocks of the lattice's binding per thread). */
static void check_threads(const rig_case *rc, const ffd_mesh *mesh, ffd_deformer *d)
{
    (void)mesh;
    ffd_error err = {{0}};
    size_t count = ffd_deformer_control_count(d);
    ffd_sparse probe;
    if (ffd_deformer_sensitivities(d, &probe, &err) == FFD_ERR_UNSUPPORTED)
        return;
    ffd_sparse_free(&probe);
    for (int set = 0; set < 2; set++) {
        if (set == 1) {
            const size_t m = getenv("FFD_TEST_QUICK") ? 2000 : 20000;
            double lo[3], hi[3];
            const double *rest = ffd_mesh_positions(mesh);
            for (int a = 0; a < 3; a++)
                lo[a] = hi[a] = rest[a];
            for (size_t i = 0; i < ffd_mesh_vertex_count(mesh); i++)
                for (int a = 0; a < 3; a++) {
                    lo[a] = fmin(lo[a], rest[3 * i + a]);
                    hi[a] = fmax(hi[a], rest[3 * i + a]);
                }
            double *pts = random_vector(3 * m, 3);
            for (size_t i = 0; i < m; i++)
                for (int a = 0; a < 3; a++)
                    pts[3 * i + a] = lo[a] + (hi[a] - lo[a]) * (0.5 + 0.5 * pts[3 * i + a]);
            CHECK_OK(ffd_deformer_bind(d, pts, m, &err));
            free(pts);
        }
        size_t n = ffd_deformer_point_count(d);
        double *v = random_vector(3 * count, 5), *w = random_vector(3 * n, 9);
        double *Wv[3], *Wtw[3];
        ffd_sparse W[3];
        for (int t = 0; t < 3; t++) {
            omp_set_num_threads(t + 1);
            Wv[t] = malloc(3 * n * sizeof *Wv[t]);
            Wtw[t] = malloc(3 * count * sizeof *Wtw[t]);
            CHECK_OK(ffd_deformer_sensitivities(d, &W[t], &err));
            CHECK_OK(ffd_deformer_sensitivity_product(d, v, Wv[t], &err));
            CHECK_OK(ffd_deformer_sensitivity_transpose_product(d, w, Wtw[t], &err));
        }
        omp_set_num_threads(omp_get_num_procs());
        for (int t = 1; t < 3; t++) {
            int same = W[t].nnz == W[0].nnz
                       && !memcmp(W[t].row_ptr, W[0].row_ptr, (n + 1) * sizeof *W[0].row_ptr)
                       && !memcmp(W[t].col, W[0].col, W[0].nnz * sizeof *W[0].col)
                       && !memcmp(W[t].val, W[0].val, W[0].nnz * sizeof *W[0].val);
            int same_v = !memcmp(Wv[t], Wv[0], 3 * n * sizeof *Wv[0]);
            int same_t = !memcmp(Wtw[t], Wtw[0], 3 * count * sizeof *Wtw[0]);
            if (!same || !same_v || !same_t)
                fprintf(stderr, "%s: %d threads: W %s, W v %s, W^T w %s\n", rc->rig, t + 1,
                        same ? "same" : "differs", same_v ? "same" : "differs",
                        same_t ? "same" : "differs");
            CHECK(same && same_v && same_t);
        }
        for (int t = 0; t < 3; t++) {
            ffd_sparse_free(&W[t]);
            free(Wv[t]);
            free(Wtw[t]);
        }
        free(v);
        free(w);
    }
}

static void test_threads(void)
{
    for_each_case(check_threads);
}

/* A B-spline lattice's tripled border: each of the (l+4)(m+4)(n+4) slots
 * lands on the control it follows, so W has l m n columns, its rows sum to
 * 1, and a point at a corner of the box follows its corner control alone
 * (the 27 slots there merged into one entry of weight 1). */
static void test_ties_merged(void)
{
    static const char rig[] = "{\"version\": 1, \"deformer\": \"lattice\", \"basis\": \"bspline\","
                              " \"resolution\": [4, 5, 6], \"box\": {\"origin\": [0, 0, 0],"
                              " \"axes\": [[3, 0, 0], [0, 4, 0], [0, 0, 5]]}}";
    double pts[3 * 12] = {0, 0, 0, 3, 0, 0, 0, 4, 0, 0, 0, 5, 3, 4, 5, 1.5, 2, 2.5};
    uint64_t seed = 17;
    for (size_t i = 6; i < 12; i++) {
        pts[3 * i] = 1.5 + 1.5 * next_random(&seed);
        pts[3 * i + 1] = 2 + 2 * next_random(&seed);
        pts[3 * i + 2] = 2.5 + 2.5 * next_random(&seed);
    }
    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    ffd_deformer *d = NULL;
    CHECK_OK(ffd_mesh_create(pts, 12, NULL, NULL, 0, &mesh, &err));
    CHECK_OK(ffd_deformer_create_json(rig, sizeof rig - 1, "ties.json", mesh, NULL, &d, &err));
    if (!d) {
        ffd_mesh_destroy(mesh);
        return;
    }
    ffd_sparse W;
    CHECK_OK(ffd_deformer_sensitivities(d, &W, &err));
    CHECK(ffd_deformer_control_count(d) == 4 * 5 * 6);
    CHECK(sparse_well_formed(&W, 12, 4 * 5 * 6));
    double ctl[3 * 120];
    ffd_deformer_controls(d, ctl);
    for (size_t i = 0; i < 12; i++) {
        double sum = 0;
        for (size_t k = W.row_ptr[i]; k < W.row_ptr[i + 1]; k++)
            sum += W.val[k];
        CHECK_NEAR(sum, 1, 1e-14);
        CHECK(W.row_ptr[i + 1] - W.row_ptr[i] <= 64);
        if (i >= 5)
            continue;
        /* a corner: one entry, weight 1, on the control standing there */
        CHECK(W.row_ptr[i + 1] - W.row_ptr[i] == 1);
        size_t k = W.row_ptr[i];
        CHECK_NEAR(W.val[k], 1, 1e-14);
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(ctl[3 * (size_t)W.col[k] + a], pts[3 * i + a], 1e-14);
    }
    ffd_sparse_free(&W);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* Frozen T-spline points only hold still in ARAP drags of proxy handles:
 * they are controls of the deformer like the others, so freezing changes
 * no entry of W, and a frozen point's column still matches the differences. */
static void test_tspline_frozen(void)
{
    const rig_case rc = {"tspline", EX "tspline/bunny.obj", EX "tspline/bunny-ears.json"};
    ffd_mesh *mesh = read_mesh(rc.mesh);
    ffd_deformer *d = mesh ? make(&rc, mesh) : NULL;
    CHECK(d != NULL);
    if (d) {
        ffd_error err = {{0}};
        double points[3 * 60];
        size_t s = bind_sample(d, mesh, 60, points), count = ffd_deformer_control_count(d);
        ffd_sparse before, after;
        CHECK_OK(ffd_deformer_sensitivities(d, &before, &err));
        uint32_t frozen = before.col[before.nnz / 2];
        char body[64];
        snprintf(body, sizeof body, "{\"points\": [%u, 0, 1]}", frozen);
        if (frozen <= 1)
            snprintf(body, sizeof body, "{\"points\": [0, 1]}");
        CHECK_OK(ffd_deformer_command(d, "freeze", body, strlen(body), &err));
        CHECK_OK(ffd_deformer_sensitivities(d, &after, &err));
        CHECK(after.nnz == before.nnz && !memcmp(after.col, before.col, after.nnz * sizeof *after.col)
              && !memcmp(after.val, before.val, after.nnz * sizeof *after.val));
        double *Wd = dense(&after);
        double worst = column_fd_error(d, Wd, s, count, frozen, 1e-3 * control_diagonal(d));
        CHECK(worst <= 1e-8);
        free(Wd);
        ffd_sparse_free(&before);
        ffd_sparse_free(&after);
    }
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* ---- a method's own products (sess_vtable hooks) ----
 * A copy of the lattice's vtable without map_points and with products
 * computed here from the lattice's map: the deformer must use them for the
 * products and form W from them, one control at a time. */
static const sess_vtable *hooked_original;
static int hook_calls;

static ffd_status hook_product(sess_method *m, const sess_binding *b, const double *v, double *out,
                               ffd_error *err)
{
    ffd_linear_map map;
    ffd_status st = hooked_original->map_points(m, b, &map, err);
    if (st)
        return st;
    hook_calls++;
    uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
    double *w = malloc(map.max_row_nnz * sizeof *w);
    for (size_t i = 0; i < map.point_count; i++) {
        size_t k = map.row(map.self, i, cols, w);
        out[3 * i] = out[3 * i + 1] = out[3 * i + 2] = 0;
        for (size_t e = 0; e < k; e++) {
            uint32_t var = map.tie ? map.tie[cols[e]] : cols[e];
            for (int a = 0; a < 3; a++)
                out[3 * i + a] += w[e] * v[3 * (size_t)var + a];
        }
    }
    free(cols);
    free(w);
    return FFD_OK;
}

static ffd_status hook_transpose(sess_method *m, const sess_binding *b, const double *w,
                                 double *out, ffd_error *err)
{
    (void)m, (void)b, (void)w, (void)out;
    hook_calls += 100;
    return ffd_fail(err, FFD_ERR_NUMERIC, "the method's own transpose product");
}

static void test_method_hooks(void)
{
    const rig_case rc = {"lattice", EX "lattice/bunny.obj", EX "lattice/pins.json"};
    ffd_mesh *mesh = read_mesh(rc.mesh);
    ffd_deformer *d = mesh ? make(&rc, mesh) : NULL;
    CHECK(d != NULL);
    if (!d) {
        ffd_mesh_destroy(mesh);
        return;
    }
    ffd_error err = {{0}};
    double points[3 * 30];
    size_t s = bind_sample(d, mesh, 30, points), count = ffd_deformer_control_count(d);
    ffd_sparse generic, hooked;
    CHECK_OK(ffd_deformer_sensitivities(d, &generic, &err));
    const sess_binding *b = NULL;
    sess_method *m = ffd_deformer_session_method(d, &b);
    hooked_original = m->vt;
    sess_vtable vt = *m->vt;
    vt.map_points = NULL;
    vt.sensitivity_product = hook_product;
    vt.sensitivity_transpose_product = hook_transpose;
    m->vt = &vt;
    CHECK_OK(ffd_deformer_sensitivities(d, &hooked, &err));
    CHECK(hook_calls == (int)(2 * count)); /* two passes over the controls */
    CHECK(sparse_well_formed(&hooked, s, count));
    double *a = dense(&generic), *h = dense(&hooked);
    CHECK(max_diff(a, h, s * count) <= 1e-15);
    CHECK(hooked.nnz <= generic.nnz);
    double *v = random_vector(3 * count, 1), out[3 * 30], tout[3 * 30];
    hook_calls = 0;
    CHECK_OK(ffd_deformer_sensitivity_product(d, v, out, &err));
    CHECK(hook_calls == 1);
    CHECK(ffd_deformer_sensitivity_transpose_product(d, out, tout, &err) == FFD_ERR_NUMERIC);
    CHECK(hook_calls == 101 && strstr(err.message, "own transpose") != NULL);
    m->vt = hooked_original;
    free(v);
    free(a);
    free(h);
    ffd_sparse_free(&generic);
    ffd_sparse_free(&hooked);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* Refusals: a method without a linear map (GFFD) names itself; NULL
 * arguments; an empty binding gives an empty W. */
static void test_bad_input(void)
{
    const rig_case gffd = {"gffd", EX "gffd/elephant.off", DATA "gffd-bend.json"};
    ffd_mesh *mesh = read_mesh(gffd.mesh);
    ffd_deformer *d = mesh ? make(&gffd, mesh) : NULL;
    CHECK(d != NULL);
    ffd_error err = {{0}};
    ffd_sparse W;
    double v[3] = {0}, out[3];
    if (d) {
        CHECK(ffd_deformer_sensitivities(d, &W, &err) == FFD_ERR_UNSUPPORTED);
        CHECK(strstr(err.message, "gffd method") != NULL);
        CHECK(strstr(err.message, "not a linear map") != NULL);
    }
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);

    const rig_case lat = {"lattice", EX "lattice/bunny.obj", EX "lattice/bernstein.json"};
    mesh = read_mesh(lat.mesh);
    d = mesh ? make(&lat, mesh) : NULL;
    CHECK(d != NULL);
    if (d) {
        CHECK(ffd_deformer_sensitivities(d, NULL, &err) == FFD_ERR_INVALID);
        CHECK(ffd_deformer_sensitivities(NULL, &W, &err) == FFD_ERR_INVALID);
        CHECK(ffd_deformer_sensitivity_product(d, NULL, out, &err) == FFD_ERR_INVALID);
        CHECK(ffd_deformer_sensitivity_product(d, v, NULL, &err) == FFD_ERR_INVALID);
        CHECK(ffd_deformer_sensitivity_transpose_product(d, NULL, out, &err) == FFD_ERR_INVALID);
        CHECK(ffd_deformer_sensitivity_transpose_product(NULL, v, out, &err) == FFD_ERR_INVALID);
        CHECK_OK(ffd_deformer_bind(d, v, 0, &err));
        CHECK_OK(ffd_deformer_sensitivities(d, &W, &err));
        CHECK(W.rows == 0 && W.nnz == 0 && W.cols == ffd_deformer_control_count(d));
        ffd_sparse_free(&W);
        size_t count = ffd_deformer_control_count(d);
        double *t = malloc(3 * count * sizeof *t), *w = random_vector(3 * count, 2);
        CHECK_OK(ffd_deformer_sensitivity_product(d, w, NULL, &err));
        CHECK_OK(ffd_deformer_sensitivity_transpose_product(d, NULL, t, &err));
        size_t zeros = 0;
        for (size_t c = 0; c < 3 * count; c++)
            zeros += t[c] == 0;
        CHECK(zeros == 3 * count);
        free(t);
        free(w);
    }
    ffd_sparse_free(NULL);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"fd", test_fd},
        {"products", test_products},
        {"threads", test_threads},
        {"ties_merged", test_ties_merged},
        {"tspline_frozen", test_tspline_frozen},
        {"method_hooks", test_method_hooks},
        {"bad_input", test_bad_input},
    };
    choose_cases();
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
