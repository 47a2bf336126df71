/* Tests of the public T-spline deformer (ffd_tsv_*, Zhang, Zheng & Cai 2020)
 * on real meshes: identity at rest, partition of unity, refinement
 * invariance through the public API (before and after deformations),
 * linear precision, the proxy (closed, outward, enclosing every vertex),
 * ARAP (rigid motions, targets reached, frozen points), direct
 * manipulation, the fold-over check, and the bad inputs of the issue. */
#include "check.h"

#include <ffd.h>

/* see check_proxy_tol */
#define TOL_REFINED 0.05

/* A mesh of the repository's data/ folder (FFD_DATA_DIR; the environment's
 * FFD_TEST_DATA_DIR replaces it, which tests/cli/test_data.sh uses to check
 * this path). A file that cannot be read is a failure naming the file, and
 * NULL: every caller returns at once, since the ffd_tsv getters take no NULL
 * (a NULL mesh makes ffd_tsv_create fail and leave the lattice NULL). */
static ffd_mesh *load(const char *name)
{
    const char *dir = getenv("FFD_TEST_DATA_DIR");
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir && *dir ? dir : FFD_DATA_DIR, name);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &m, &err) != FFD_OK) {
        fprintf(stderr, "%s: cannot read the test mesh %s: %s\n", check_current, path, err.message);
        CHECK(!"test mesh missing or unreadable");
    }
    return m;
}

static ffd_tsv *make(const ffd_mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    uint32_t res[3] = {a, b, c};
    ffd_tsv *t = NULL;
    CHECK_OK(ffd_tsv_create(ffd_mesh_positions(m), ffd_mesh_vertex_count(m),
                            ffd_mesh_face_offsets(m), ffd_mesh_face_indices(m),
                            ffd_mesh_face_count(m), res, NULL, &t, NULL));
    return t;
}

static double diag_of(const ffd_tsv *t)
{
    double mn[3], mx[3];
    ffd_tsv_box(t, mn, mx);
    return sqrt((mx[0] - mn[0]) * (mx[0] - mn[0]) + (mx[1] - mn[1]) * (mx[1] - mn[1]) +
                (mx[2] - mn[2]) * (mx[2] - mn[2]));
}

static double max_dist(const double *a, const double *b, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; i++) {
        double d = sqrt((a[3 * i] - b[3 * i]) * (a[3 * i] - b[3 * i]) +
                        (a[3 * i + 1] - b[3 * i + 1]) * (a[3 * i + 1] - b[3 * i + 1]) +
                        (a[3 * i + 2] - b[3 * i + 2]) * (a[3 * i + 2] - b[3 * i + 2]));
        if (d > m)
            m = d;
    }
    return m;
}

static double *eval_all(const ffd_tsv *t)
{
    size_t n = ffd_tsv_point_count(t);
    double *x = malloc(3 * n * sizeof *x);
    CHECK_OK(ffd_tsv_eval(t, x, NULL));
    return x;
}

/* Current control points = rest + noise of frac x the box extent. */
static void perturb(ffd_tsv *t, double frac)
{
    size_t nv = ffd_tsv_control_count(t);
    double mn[3], mx[3];
    ffd_tsv_box(t, mn, mx);
    double *p = malloc(3 * nv * sizeof *p);
    for (size_t v = 0; v < nv; v++) {
        CHECK_OK(ffd_tsv_rest_point(t, (uint32_t)v, p + 3 * v, NULL));
        for (int a = 0; a < 3; a++)
            p[3 * v + a] += frac * (mx[a] - mn[a]) * (check_rand01() - 0.5);
    }
    CHECK_OK(ffd_tsv_set_control_points(t, p, NULL));
    free(p);
}

/* A random legal insertion (edges and faces in end layers may be refused: retried). */
static void random_refine(ffd_tsv *t, size_t count)
{
    for (size_t done = 0, tries = 0; done < count && tries < 50 * count; tries++) {
        ffd_tsv_insertion ins;
        ins.kind = (ffd_tsv_element)(check_rand01() * 3);
        if (ins.kind > FFD_TSV_CELL)
            ins.kind = FFD_TSV_CELL;
        size_t n = ffd_tsv_element_count(t, ins.kind);
        ins.id = (uint32_t)(check_rand01() * n);
        if (ins.id >= n)
            ins.id = (uint32_t)n - 1;
        ins.ratio = ins.kind == FFD_TSV_EDGE && check_rand01() < 0.3 ? 0.25 : 0;
        ffd_error err = {{0}};
        ffd_status s = ffd_tsv_refine(t, &ins, 1, NULL, &err);
        if (s == FFD_OK)
            done++;
        else
            CHECK(s == FFD_ERR_INVALID && strstr(err.message, "zero knot interval"));
    }
}

static void test_identity_at_rest(void)
{
    ffd_mesh *m = load("bunny.obj");
    if (!m)
        return;
    ffd_tsv *t = make(m, 6, 7, 5);
    double *x = eval_all(t);
    size_t n = ffd_mesh_vertex_count(m);
    CHECK(max_dist(x, ffd_mesh_positions(m), n) <= 1e-12 * diag_of(t));
    CHECK(ffd_tsv_control_count(t) == 6 * 7 * 5);
    CHECK(ffd_tsv_element_count(t, FFD_TSV_CELL) == 5 * 6 * 4);
    /* Jacobians are the identity at rest */
    double *J = malloc(9 * n * sizeof *J);
    CHECK_OK(ffd_tsv_jacobian(t, J, NULL));
    double e = 0;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 9; k++)
            e = fmax(e, fabs(J[9 * i + k] - (k % 4 == 0)));
    CHECK(e < 1e-10);
    free(J);
    free(x);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

/* Displacement form (tsv_eval.c): at rest, after refinement too, every point
 * comes back bitwise and every Jacobian is exactly the identity; moving one
 * control point changes only the points in its support (the others keep
 * their bits and identity Jacobians), and the result equals eq. 1 summed
 * over the positions (ffd_tsv_eval_params) to rounding. A mesh of the
 * repository, so that it runs everywhere. */
static void test_exact_identity_and_partial_move(void)
{
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read(FFD_SOURCE_DIR "/tests/data/mesh/identity_smooth.obj", &m, NULL));
    if (!m)
        return;
    size_t n = ffd_mesh_vertex_count(m);
    const double *x0 = ffd_mesh_positions(m);
    ffd_tsv *t = make(m, 5, 6, 4);
    if (!t) {
        ffd_mesh_destroy(m);
        return;
    }
    random_refine(t, 6);
    double *x = eval_all(t), *J = malloc(9 * n * sizeof *J);
    CHECK(memcmp(x, x0, 3 * n * sizeof *x) == 0);
    CHECK_OK(ffd_tsv_jacobian(t, J, NULL));
    size_t not_identity = 0;
    for (size_t i = 0; i < 9 * n; i++)
        not_identity += J[i] != (i % 9 % 4 == 0 ? 1.0 : 0.0);
    CHECK(not_identity == 0);
    /* one control point in the middle of the lattice */
    double mid[3] = {0.1, -0.2, 0.05};
    uint32_t cell = 0, v = 0, *ids = NULL;
    size_t count = 0;
    CHECK_OK(ffd_tsv_locate(t, FFD_TSV_CELL, mid, &cell, NULL));
    CHECK_OK(ffd_tsv_element_points(t, FFD_TSV_CELL, cell, &ids, &count, NULL));
    if (count)
        v = ids[0];
    ffd_free(ids);
    const double delta[3] = {0.3, -0.2, 0.25};
    CHECK_OK(ffd_tsv_move(t, v, delta, NULL));
    ffd_linear_map map;
    CHECK_OK(ffd_tsv_linear_map(t, &map, NULL));
    uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
    double *w = malloc(map.max_row_nnz * sizeof *w);
    free(x);
    x = eval_all(t);
    CHECK_OK(ffd_tsv_jacobian(t, J, NULL));
    size_t inside = 0, outside = 0, bad = 0;
    double worst = 0;
    for (size_t i = 0; i < n; i++) {
        size_t k = map.row(map.self, i, cols, w);
        int reached = 0;
        for (size_t e = 0; e < k; e++)
            reached |= cols[e] == v && w[e] != 0.0;
        if (reached) {
            inside++;
        } else {
            outside++;
            bad += memcmp(x + 3 * i, x0 + 3 * i, 3 * sizeof *x) != 0;
            /* on the box boundary a clamped blending function is 0 with a
             * non-zero one-sided derivative: the point stays, its
             * neighbourhood does not, and neither does its Jacobian */
            double stu[3];
            ffd_tsv_point_params(t, i, stu);
            int interior = stu[0] > 0 && stu[0] < 1 && stu[1] > 0 && stu[1] < 1 && stu[2] > 0 &&
                           stu[2] < 1;
            for (int c = 0; c < 9 && interior; c++)
                bad += J[9 * i + c] != (c % 4 == 0 ? 1.0 : 0.0);
        }
        double stu[3], y[3];
        ffd_tsv_point_params(t, i, stu);
        ffd_tsv_eval_params(t, stu, y, NULL);
        worst = fmax(worst, max_dist(x + 3 * i, y, 1));
    }
    CHECK(inside > 0 && outside > 0 && bad == 0);
    if (bad || !inside || !outside)
        fprintf(stderr, "  control %u: %zu points in its support, %zu outside, %zu bad\n", v,
                inside, outside, bad);
    CHECK(worst <= 1e-12 * diag_of(t));
    free(cols);
    free(w);
    free(J);
    free(x);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

static void test_partition_of_unity(void)
{
    ffd_mesh *m = load("cow.off");
    if (!m)
        return;
    ffd_tsv *t = make(m, 5, 6, 4);
    random_refine(t, 12);
    double worst = 0;
    for (int i = 0; i < 3000; i++) {
        double stu[3] = {check_rand01(), check_rand01(), check_rand01()};
        if (i < 8)
            for (int a = 0; a < 3; a++)
                stu[a] = (i >> a) & 1;
        worst = fmax(worst, fabs(ffd_tsv_weight_sum(t, stu) - 1));
    }
    CHECK(worst <= 1e-13);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

/* Refinement invariance: every point's deformed position is unchanged. */
static void test_refinement_invariance(void)
{
    ffd_mesh *m = load("bunny.obj");
    if (!m)
        return;
    size_t n = ffd_mesh_vertex_count(m);
    for (int round = 0; round < 4; round++) {
        ffd_tsv *t = make(m, 5 + round % 2, 6, 5);
        perturb(t, 0.1);
        double *before = eval_all(t);
        random_refine(t, 5 + 5 * (size_t)round);
        double *after = eval_all(t);
        CHECK(max_dist(before, after, n) <= 1e-12 * diag_of(t));
        /* and through the point evaluator at random parameters */
        for (int i = 0; i < 200; i++) {
            double stu[3] = {check_rand01(), check_rand01(), check_rand01()}, y[3];
            ffd_tsv_eval_params(t, stu, y, NULL);
            CHECK(isfinite(y[0]) && isfinite(y[1]) && isfinite(y[2]));
        }
        /* linear precision: the rest lattice maps every point to itself (through
         * the point evaluator, which sums W B P: ffd_tsv_eval adds displacements
         * to the points and is exact at rest by construction) */
        ffd_tsv_reset(t);
        double *rest = eval_all(t);
        CHECK(memcmp(rest, ffd_mesh_positions(m), 3 * n * sizeof *rest) == 0);
        for (size_t i = 0; i < n; i++) {
            double stu[3];
            ffd_tsv_point_params(t, i, stu);
            ffd_tsv_eval_params(t, stu, rest + 3 * i, NULL);
        }
        CHECK(max_dist(rest, ffd_mesh_positions(m), n) <= 1e-12 * diag_of(t));
        free(rest);
        free(before);
        free(after);
        ffd_tsv_destroy(t);
    }
    ffd_mesh_destroy(m);
}

/* A batch octree split of every cell of the proxy keeps the map (Fig. 6). */
static void test_batch_octree(void)
{
    ffd_mesh *m = load("elephant.off");
    if (!m)
        return;
    ffd_tsv *t = make(m, 5, 5, 5);
    perturb(t, 0.05);
    double *before = eval_all(t);
    ffd_tsv_proxy proxy;
    ffd_tsv_get_proxy(t, &proxy);
    size_t nf = proxy.face_count;
    ffd_tsv_insertion *ins = malloc(nf * sizeof *ins);
    size_t k = 0;
    for (size_t f = 0; f < nf; f++) {
        int dup = 0, thick = 0;
        for (size_t j = 0; j < k; j++)
            dup |= ins[j].id == proxy.face_cells[f];
        double lo[3], hi[3];
        CHECK_OK(ffd_tsv_element_box(t, FFD_TSV_CELL, proxy.face_cells[f], lo, hi, NULL));
        for (int a = 0; a < 3; a++)
            thick |= hi[a] > lo[a];
        if (!dup && thick) /* a corner cell of the end layers has nothing to split */
            ins[k++] = (ffd_tsv_insertion){FFD_TSV_CELL, proxy.face_cells[f], 0};
    }
    size_t cp = ffd_tsv_control_count(t);
    ffd_tsv_refine_report rr;
    ffd_error err = {{0}};
    ffd_status st = ffd_tsv_refine(t, ins, k, &rr, &err);
    CHECK(st == FFD_OK);
    if (st)
        fprintf(stderr, "  %s\n", err.message);
    CHECK(ffd_tsv_control_count(t) > cp);
    CHECK(rr.added_points == ffd_tsv_control_count(t) - cp);
    double *after = eval_all(t);
    CHECK(max_dist(before, after, ffd_tsv_point_count(t)) <= 1e-12 * diag_of(t));
    free(ins);
    free(before);
    free(after);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

/* Ray parity from p along a fixed oblique direction against the proxy's
 * triangles (fan-triangulated, rest positions): 1 when inside. */
static int inside_proxy(const ffd_tsv *t, const ffd_tsv_proxy *px, const double p[3])
{
    const double d[3] = {0.5773, 0.5774, 0.5775};
    double rest_a[3], rest_b[3], rest_c[3];
    int crossings = 0;
    for (size_t f = 0; f < px->face_count; f++) {
        uint32_t a0 = px->face_offsets[f], a1 = px->face_offsets[f + 1];
        ffd_tsv_rest_point(t, px->face_indices[a0], rest_a, NULL);
        for (uint32_t k = a0 + 1; k + 1 < a1; k++) {
            ffd_tsv_rest_point(t, px->face_indices[k], rest_b, NULL);
            ffd_tsv_rest_point(t, px->face_indices[k + 1], rest_c, NULL);
            /* Moller-Trumbore */
            double e1[3], e2[3], h[3], s[3], q[3];
            for (int i = 0; i < 3; i++) {
                e1[i] = rest_b[i] - rest_a[i];
                e2[i] = rest_c[i] - rest_a[i];
                s[i] = p[i] - rest_a[i];
            }
            h[0] = d[1] * e2[2] - d[2] * e2[1];
            h[1] = d[2] * e2[0] - d[0] * e2[2];
            h[2] = d[0] * e2[1] - d[1] * e2[0];
            double det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
            if (fabs(det) < 1e-300)
                continue;
            double u = (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]) / det;
            q[0] = s[1] * e1[2] - s[2] * e1[1];
            q[1] = s[2] * e1[0] - s[0] * e1[2];
            q[2] = s[0] * e1[1] - s[1] * e1[0];
            double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
            double w = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
            if (u >= 0 && v >= 0 && u + v <= 1 && w > 0)
                crossings++;
        }
    }
    return crossings & 1;
}

/* 1 when q, or q moved by tol along one of 26 directions, is inside. */
static int inside_near(const ffd_tsv *t, const ffd_tsv_proxy *px, const double q[3], double tol)
{
    if (inside_proxy(t, px, q))
        return 1;
    for (int d = 0; d < 27 && tol > 0; d++) {
        double o[3] = {d % 3 - 1, d / 3 % 3 - 1, d / 9 - 1}, r[3];
        double len = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
        if (len == 0)
            continue;
        for (int a = 0; a < 3; a++)
            r[a] = q[a] + tol * o[a] / len;
        if (inside_proxy(t, px, r))
            return 1;
    }
    return 0;
}

/* Closed (every directed edge has its reverse), outward (positive volume),
 * enclosing every vertex (slightly shrunk towards the centre, so points on
 * the proxy count as inside). Occupancy is decided on the Greville grid;
 * after refinement the proxy's rest points are the refined control points,
 * which sit near (not on) that grid, so a vertex next to a proxy face may
 * be outside the rest proxy by a fraction of a knot interval: tol (relative
 * to the box diagonal) allows that. */
static void check_proxy_tol(const ffd_tsv *t, const ffd_mesh *m, double tol)
{
    ffd_tsv_proxy px;
    ffd_tsv_get_proxy(t, &px);
    CHECK(px.face_count > 0);
    size_t corners = px.face_offsets[px.face_count];
    size_t unmatched = 0, nonmanifold = 0;
    for (size_t f = 0; f < px.face_count; f++)
        for (uint32_t k = px.face_offsets[f]; k < px.face_offsets[f + 1]; k++) {
            uint32_t a = px.face_indices[k];
            uint32_t b = px.face_indices[k + 1 < px.face_offsets[f + 1] ? k + 1 : px.face_offsets[f]];
            size_t reverse = 0, same = 0;
            for (size_t g = 0; g < px.face_count; g++)
                for (uint32_t j = px.face_offsets[g]; j < px.face_offsets[g + 1]; j++) {
                    uint32_t c = px.face_indices[j];
                    uint32_t d = px.face_indices[j + 1 < px.face_offsets[g + 1] ? j + 1
                                                                            : px.face_offsets[g]];
                    reverse += c == b && d == a;
                    same += c == a && d == b;
                }
            unmatched += reverse != same;
            nonmanifold += same > 1;
        }
    CHECK(unmatched == 0);
    (void)corners;
    /* outward: the divergence theorem gives a positive volume */
    double vol = 0, pa[3], pb[3], pc[3];
    for (size_t f = 0; f < px.face_count; f++) {
        uint32_t a0 = px.face_offsets[f];
        ffd_tsv_rest_point(t, px.face_indices[a0], pa, NULL);
        for (uint32_t k = a0 + 1; k + 1 < px.face_offsets[f + 1]; k++) {
            ffd_tsv_rest_point(t, px.face_indices[k], pb, NULL);
            ffd_tsv_rest_point(t, px.face_indices[k + 1], pc, NULL);
            vol += (pa[0] * (pb[1] * pc[2] - pb[2] * pc[1]) - pa[1] * (pb[0] * pc[2] - pb[2] * pc[0]) +
                    pa[2] * (pb[0] * pc[1] - pb[1] * pc[0])) / 6;
        }
    }
    CHECK(vol > 0);
    const double *P = ffd_mesh_positions(m);
    size_t n = ffd_mesh_vertex_count(m), outside = 0;
    double mn[3], mx[3], c[3];
    ffd_tsv_box(t, mn, mx);
    for (int a = 0; a < 3; a++)
        c[a] = (mn[a] + mx[a]) / 2;
    for (size_t i = 0; i < n; i += 3) {
        double q[3];
        for (int a = 0; a < 3; a++)
            q[a] = P[3 * i + a] + 1e-7 * (c[a] - P[3 * i + a]);
        outside += !inside_near(t, &px, q, tol * diag_of(t));
    }
    CHECK(outside == 0);
    if (outside)
        fprintf(stderr, "  %zu vertices outside the proxy (tolerance %g of the diagonal)\n",
                outside, tol);
}

static void check_proxy(const ffd_tsv *t, const ffd_mesh *m)
{
    check_proxy_tol(t, m, 0);
}

static void test_proxy(void)
{
    ffd_mesh *m = load("bunny.obj");
    if (!m)
        return;
    ffd_tsv *t = make(m, 6, 7, 5);
    check_proxy(t, m);
    ffd_tsv_proxy px;
    ffd_tsv_get_proxy(t, &px);
    CHECK(px.vertex_count < ffd_tsv_control_count(t)); /* the proxy hides the outer points */
    CHECK(px.inside_cells >= px.occupied_cells);
    /* refined: n-gons with hanging points appear and it stays closed and enclosing */
    random_refine(t, 10);
    check_proxy_tol(t, m, TOL_REFINED);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

/* Proxy points of t and their count. */
static uint32_t *proxy_points(const ffd_tsv *t, size_t *k)
{
    ffd_tsv_proxy px;
    ffd_tsv_get_proxy(t, &px);
    uint32_t *ids = malloc(px.vertex_count * sizeof *ids);
    memcpy(ids, px.vertices, px.vertex_count * sizeof *ids);
    *k = px.vertex_count;
    return ids;
}

/* Moving every proxy point rigidly moves the object rigidly. */
static void test_arap_rigid(void)
{
    ffd_mesh *m = load("cow.off");
    if (!m)
        return;
    ffd_tsv *t = make(m, 6, 5, 5);
    size_t n = ffd_mesh_vertex_count(m), k;
    uint32_t *h = proxy_points(t, &k);
    const double *P = ffd_tsv_control_points(t);
    double *q = malloc(3 * k * sizeof *q);
    /* translation: exact */
    for (size_t i = 0; i < k; i++)
        for (int a = 0; a < 3; a++)
            q[3 * i + a] = P[3 * (size_t)h[i] + a] + (a == 1 ? 0.3 : 0.1);
    ffd_tsv_arap *arap = NULL;
    CHECK_OK(ffd_tsv_arap_begin(t, h, k, NULL, &arap, NULL));
    ffd_tsv_arap_report ar;
    CHECK_OK(ffd_tsv_arap_solve(arap, q, &ar, NULL));
    CHECK(ar.iterations == 5 && ar.max_handle_error == 0);
    ffd_tsv_arap_destroy(arap);
    double *x = eval_all(t), *expect = malloc(3 * n * sizeof *expect);
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            expect[3 * i + a] = ffd_mesh_positions(m)[3 * i + a] + (a == 1 ? 0.3 : 0.1);
    CHECK(max_dist(x, expect, n) <= 1e-9 * diag_of(t));
    free(x);
    /* rotation by 30 degrees about z: rigid after enough iterations */
    ffd_tsv_reset(t);
    double c = cos(0.5236), s = sin(0.5236);
    for (size_t i = 0; i < k; i++) {
        const double *p = P + 3 * (size_t)h[i];
        q[3 * i] = c * p[0] - s * p[1];
        q[3 * i + 1] = s * p[0] + c * p[1];
        q[3 * i + 2] = p[2];
    }
    ffd_tsv_arap_options o = {0};
    o.iterations = 60;
    CHECK_OK(ffd_tsv_arap_begin(t, h, k, &o, &arap, NULL));
    CHECK_OK(ffd_tsv_arap_solve(arap, q, NULL, NULL));
    ffd_tsv_arap_destroy(arap);
    x = eval_all(t);
    for (size_t i = 0; i < n; i++) {
        const double *p = ffd_mesh_positions(m) + 3 * i;
        expect[3 * i] = c * p[0] - s * p[1];
        expect[3 * i + 1] = s * p[0] + c * p[1];
        expect[3 * i + 2] = p[2];
    }
    double e = max_dist(x, expect, n) / diag_of(t);
    CHECK(e <= 1e-3);
    if (e > 1e-3)
        fprintf(stderr, "  rotation: max deviation %.3g of the diagonal\n", e);
    free(x);
    free(expect);
    free(q);
    free(h);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

/* only_target: soft handles with the other terms ~0 reach their targets;
 * frozen points do not move (bitwise); a drag step reuses the factor. */
static void test_arap_targets_frozen(void)
{
    ffd_mesh *m = load("elephant.off");
    if (!m)
        return;
    ffd_tsv *t = make(m, 5, 6, 5);
    size_t k;
    uint32_t *h = proxy_points(t, &k);
    const double *P = ffd_tsv_control_points(t);
    /* freeze the lower half of the proxy, drag three top points */
    double mn[3], mx[3];
    ffd_tsv_box(t, mn, mx);
    size_t nv = ffd_tsv_control_count(t);
    double *frozen_before = malloc(3 * nv * sizeof *frozen_before);
    memcpy(frozen_before, P, 3 * nv * sizeof *frozen_before);
    uint32_t handles[3];
    size_t nh = 0;
    for (size_t i = 0; i < k; i++) {
        const double *p = P + 3 * (size_t)h[i];
        if (p[1] < (mn[1] + mx[1]) / 2)
            CHECK_OK(ffd_tsv_set_frozen(t, h[i], 1, NULL));
        else if (nh < 3 && p[1] >= mx[1] - 1e-12)
            handles[nh++] = h[i];
    }
    CHECK(nh == 3);
    double q[9];
    for (size_t i = 0; i < nh; i++)
        for (int a = 0; a < 3; a++)
            q[3 * i + a] = P[3 * (size_t)handles[i] + a] + (a == 0 ? 0.2 : 0.05);
    ffd_tsv_arap_options o = {0};
    o.only_target = 1;
    ffd_tsv_arap *arap = NULL;
    CHECK_OK(ffd_tsv_arap_begin(t, handles, nh, &o, &arap, NULL));
    ffd_tsv_arap_report ar;
    CHECK_OK(ffd_tsv_arap_solve(arap, q, &ar, NULL));
    CHECK(ar.max_handle_error < 1e-6);
    ffd_tsv_arap_destroy(arap);
    for (size_t v = 0; v < nv; v++)
        if (ffd_tsv_frozen(t, (uint32_t)v))
            CHECK(memcmp(P + 3 * v, frozen_before + 3 * v, 3 * sizeof(double)) == 0);
    /* the default energy, a drag of two steps, frozen still fixed */
    CHECK_OK(ffd_tsv_arap_begin(t, handles, nh, NULL, &arap, NULL));
    CHECK_OK(ffd_tsv_arap_solve(arap, q, NULL, NULL));
    for (size_t i = 0; i < 9; i++)
        q[i] += 0.01;
    CHECK_OK(ffd_tsv_arap_solve(arap, q, &ar, NULL));
    CHECK(ar.max_handle_error == 0);
    for (size_t v = 0; v < nv; v++)
        if (ffd_tsv_frozen(t, (uint32_t)v))
            CHECK(memcmp(P + 3 * v, frozen_before + 3 * v, 3 * sizeof(double)) == 0);
    /* a refinement during the drag makes it stale */
    ffd_tsv_insertion ins = {FFD_TSV_CELL, 40, 0};
    CHECK_OK(ffd_tsv_refine(t, &ins, 1, NULL, NULL));
    ffd_error err = {{0}};
    CHECK(ffd_tsv_arap_solve(arap, q, NULL, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "refined") != NULL);
    ffd_tsv_arap_destroy(arap);
    free(frozen_before);
    free(h);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

/* Refinement after a deformation keeps the deformed shape. */
static void test_refine_after_deformation(void)
{
    ffd_mesh *m = load("bunny.obj");
    if (!m)
        return;
    ffd_tsv *t = make(m, 6, 7, 5);
    size_t k;
    uint32_t *h = proxy_points(t, &k);
    const double *P = ffd_tsv_control_points(t);
    double *q = malloc(3 * k * sizeof *q);
    for (size_t i = 0; i < k; i++) {
        const double *p = P + 3 * (size_t)h[i];
        q[3 * i] = p[0] + 0.05 * p[1] * p[1];
        q[3 * i + 1] = p[1];
        q[3 * i + 2] = p[2];
    }
    ffd_tsv_arap *arap = NULL;
    CHECK_OK(ffd_tsv_arap_begin(t, h, k, NULL, &arap, NULL));
    CHECK_OK(ffd_tsv_arap_solve(arap, q, NULL, NULL));
    ffd_tsv_arap_destroy(arap);
    double *before = eval_all(t);
    CHECK(max_dist(before, ffd_mesh_positions(m), ffd_mesh_vertex_count(m)) > 0.1);
    random_refine(t, 15);
    double *after = eval_all(t);
    CHECK(max_dist(before, after, ffd_mesh_vertex_count(m)) <= 1e-12 * diag_of(t));
    check_proxy_tol(t, m, TOL_REFINED);
    free(q);
    free(h);
    free(before);
    free(after);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

/* Direct manipulation through the core solver reaches vertex targets. */
static void test_direct_manipulation(void)
{
    ffd_mesh *m = load("cow.off");
    if (!m)
        return;
    ffd_tsv *t = make(m, 6, 5, 5);
    ffd_tsv_insertion ins = {FFD_TSV_CELL, 30, 0};
    CHECK_OK(ffd_tsv_refine(t, &ins, 1, NULL, NULL));
    ffd_linear_map map;
    CHECK_OK(ffd_tsv_linear_map(t, &map, NULL));
    size_t rows[2] = {10, 2000};
    double cur[6], tgt[6];
    double *x = eval_all(t);
    for (int c = 0; c < 2; c++)
        for (int a = 0; a < 3; a++) {
            cur[3 * c + a] = x[3 * rows[c] + a];
            tgt[3 * c + a] = cur[3 * c + a] + (a == 2 ? 0.05 : 0.02);
        }
    double *delta = calloc(3 * map.variable_count, sizeof *delta);
    ffd_manip_result mr;
    CHECK_OK(ffd_manip_solve(&map, rows, 2, cur, tgt, NULL, delta, NULL, &mr, NULL));
    for (size_t v = 0; v < map.column_count; v++)
        if (map.tie[v] != FFD_TIE_FIXED)
            CHECK_OK(ffd_tsv_move(t, (uint32_t)v, delta + 3 * (size_t)map.tie[v], NULL));
    free(x);
    x = eval_all(t);
    for (int c = 0; c < 2; c++)
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(x[3 * rows[c] + a], tgt[3 * c + a], 1e-10);
    free(x);
    free(delta);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

static void test_fold_check(void)
{
    ffd_mesh *m = load("bunny.obj");
    if (!m)
        return;
    ffd_tsv *t = make(m, 5, 5, 5);
    ffd_tsv_fold_report fr;
    CHECK_OK(ffd_tsv_check_folds(t, 0, &fr, NULL));
    CHECK(fr.folded_cell_count == 0 && fr.inverted_face_count == 0);
    CHECK(fabs(fr.min_det - 1) < 1e-9);
    CHECK(fr.cells_checked == 2 * 2 * 2); /* the end layers have no parameter volume */
    ffd_tsv_fold_report_free(&fr);
    /* push the middle layer of control points through its neighbours in x */
    size_t nv = ffd_tsv_control_count(t);
    double mn[3], mx[3];
    ffd_tsv_box(t, mn, mx);
    for (size_t v = 0; v < nv; v++) {
        double r[3], sg[3];
        CHECK_OK(ffd_tsv_rest_point(t, (uint32_t)v, r, NULL));
        CHECK_OK(ffd_tsv_control_info(t, (uint32_t)v, NULL, sg, NULL));
        if (sg[0] == 0.5) {
            double d[3] = {-0.9 * (mx[0] - mn[0]), 0, 0};
            CHECK_OK(ffd_tsv_move(t, (uint32_t)v, d, NULL));
        }
    }
    CHECK_OK(ffd_tsv_check_folds(t, 0, &fr, NULL));
    CHECK(fr.folded_cell_count > 0 && fr.min_det < 0);
    CHECK(fr.inverted_face_count > 0);
    ffd_tsv_fold_report_free(&fr);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

static void test_bad_input(void)
{
    ffd_mesh *m = load("bunny.obj");
    if (!m)
        return;
    uint32_t res[3] = {3, 6, 6};
    ffd_tsv *t = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_tsv_create(ffd_mesh_positions(m), ffd_mesh_vertex_count(m), NULL, NULL, 0, res, NULL,
                         &t, &err) == FFD_ERR_INVALID);
    CHECK(t == NULL && strstr(err.message, "at least 4"));
    t = make(m, 5, 5, 5);
    ffd_tsv_insertion ins = {FFD_TSV_CELL, 64, 0};
    CHECK(ffd_tsv_refine(t, &ins, 1, NULL, &err) == FFD_ERR_RANGE);
    CHECK(strstr(err.message, "cell 64: there are 64 cells") != NULL);
    /* edge 0 runs along s from sigma -1 to 0: an end layer, zero knot interval */
    uint32_t ends[2];
    int axis;
    CHECK_OK(ffd_tsv_edge(t, 0, ends, &axis, NULL));
    double lo[3], hi[3];
    CHECK_OK(ffd_tsv_element_box(t, FFD_TSV_EDGE, 0, lo, hi, NULL));
    if (hi[axis] == lo[axis]) {
        ins = (ffd_tsv_insertion){FFD_TSV_EDGE, 0, 0};
        size_t before = ffd_tsv_control_count(t);
        CHECK(ffd_tsv_refine(t, &ins, 1, NULL, &err) == FFD_ERR_INVALID);
        CHECK(strstr(err.message, "zero knot interval") != NULL);
        CHECK(ffd_tsv_control_count(t) == before);
    }
    ins = (ffd_tsv_insertion){FFD_TSV_EDGE, 5, 1.5};
    CHECK(ffd_tsv_refine(t, &ins, 1, NULL, &err) == FFD_ERR_INVALID);
    /* ARAP: nothing constrained; a frozen handle; a repeated handle; a bad id */
    ffd_tsv_arap *arap = (ffd_tsv_arap *)1;
    CHECK(ffd_tsv_arap_begin(t, NULL, 0, NULL, &arap, &err) == FFD_ERR_INVALID);
    CHECK(arap == NULL && strstr(err.message, "nothing constrained"));
    uint32_t h[2] = {7, 7};
    CHECK(ffd_tsv_arap_begin(t, h, 2, NULL, &arap, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "twice") != NULL);
    CHECK_OK(ffd_tsv_set_frozen(t, 7, 1, NULL));
    CHECK(ffd_tsv_arap_begin(t, h, 1, NULL, &arap, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "frozen") != NULL);
    h[0] = 100000;
    CHECK(ffd_tsv_arap_begin(t, h, 1, NULL, &arap, &err) == FFD_ERR_RANGE);
    double d[3] = {NAN, 0, 0};
    CHECK(ffd_tsv_move(t, 3, d, &err) == FFD_ERR_NONFINITE);
    ffd_tsv_destroy(t);
    /* non-finite input */
    double pts[6] = {0, 0, 0, 1, INFINITY, 0};
    uint32_t r4[3] = {4, 4, 4};
    CHECK(ffd_tsv_create(pts, 2, NULL, NULL, 0, r4, NULL, &t, &err) == FFD_ERR_NONFINITE);
    /* a flat object gets a padded axis and still works */
    double flat[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    CHECK_OK(ffd_tsv_create(flat, 3, NULL, NULL, 0, r4, NULL, &t, NULL));
    double *x = eval_all(t);
    CHECK(max_dist(x, flat, 3) < 1e-12);
    free(x);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

static void test_allocation_failures(void)
{
    ffd_mesh *m = load("bunny.obj");
    if (!m)
        return;
    for (long k = 0; k < 4000; k += 7) {
        fail_alloc fa = {k, 0};
        ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&a);
        uint32_t res[3] = {5, 5, 5};
        ffd_tsv *t = NULL;
        ffd_status s = ffd_tsv_create(ffd_mesh_positions(m), ffd_mesh_vertex_count(m),
                                      ffd_mesh_face_offsets(m), ffd_mesh_face_indices(m),
                                      ffd_mesh_face_count(m), res, NULL, &t, NULL);
        if (s == FFD_OK) {
            ffd_tsv_insertion ins = {FFD_TSV_CELL, 31, 0};
            double before = ffd_tsv_control_count(t);
            s = ffd_tsv_refine(t, &ins, 1, NULL, NULL);
            CHECK(s == FFD_OK || (s == FFD_ERR_NOMEM && ffd_tsv_control_count(t) == before));
            uint32_t h = 0;
            ffd_tsv_arap *arap = NULL;
            if (ffd_tsv_arap_begin(t, &h, 1, NULL, &arap, NULL) == FFD_OK) {
                double q[3] = {1, 2, 3};
                ffd_tsv_arap_solve(arap, q, NULL, NULL);
                ffd_tsv_arap_destroy(arap);
            }
        } else {
            CHECK(s == FFD_ERR_NOMEM && t == NULL);
        }
        ffd_tsv_destroy(t);
        ffd_set_allocator(NULL);
        if (fa.left > 0)
            break; /* everything succeeded with allocations to spare */
    }
    ffd_mesh_destroy(m);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"identity_at_rest", test_identity_at_rest},
        {"exact_identity_and_partial_move", test_exact_identity_and_partial_move},
        {"partition_of_unity", test_partition_of_unity},
        {"refinement_invariance", test_refinement_invariance},
        {"batch_octree", test_batch_octree},
        {"proxy", test_proxy},
        {"arap_rigid", test_arap_rigid},
        {"arap_targets_frozen", test_arap_targets_frozen},
        {"refine_after_deformation", test_refine_after_deformation},
        {"direct_manipulation", test_direct_manipulation},
        {"fold_check", test_fold_check},
        {"bad_input", test_bad_input},
        {"allocation_failures", test_allocation_failures},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
