/* Nested lattices and the falloff outside the lattice (src/lattice/
 * lattice_nested*.c, lattice_falloff.c; docs/lattice-variants.md): a child
 * reproduces an affine parent; a child's own moves stay inside its box;
 * the boundary of a child; direct manipulation over parent and child
 * controls; identity bitwise; rigid motions; the composed linear map
 * against the evaluation; the rig writer's round trip; the falloff's
 * continuity, Jacobian, rows and curves against Blender's formulas. */
#include "check.h"

#include "ffd.h"

#include <stdint.h>

/* A root box [0,4]^3 holding a child [1,3]^3, a grandchild [1.5,2.5]^3
 * and a great-grandchild [1.8,2.2]^3 (depth 3); extra is spliced into the
 * root object (moves, constraints, "outside"). */
static char *nested_rig(const char *root_basis, const char *extra, const char *child_moves)
{
    static char buf[8192];
    snprintf(buf, sizeof buf,
             "{\"deformer\": \"lattice\", \"basis\": \"%s\", \"resolution\": [4, 4, 4],"
             " \"box\": {\"origin\": [0, 0, 0], \"axes\": [[4, 0, 0], [0, 4, 0], [0, 0, 4]]}%s,"
             " \"children\": [{\"box\": {\"origin\": [1, 1, 1], \"axes\": [[2, 0, 0], [0, 2, 0], "
             "[0, 0, 2]]}, \"resolution\": [4, 5, 4], \"moves\": [%s],"
             "  \"children\": [{\"box\": {\"origin\": [1.5, 1.5, 1.5], \"axes\": [[1, 0, 0], [0, 1, "
             "0], [0, 0, 1]]}, \"basis\": \"bernstein\", \"resolution\": [3, 3, 3],"
             "   \"children\": [{\"box\": {\"origin\": [1.8, 1.8, 1.8], \"axes\": [[0.4, 0, 0], [0, "
             "0.4, 0], [0, 0, 0.4]]}}]}]}]}",
             root_basis, extra, child_moves);
    return buf;
}

/* n points on a jittered grid over [-0.5, 4.5]^3 plus points on the child's faces. */
static double *cloud(size_t *n)
{
    const int g = 11;
    size_t total = (size_t)g * g * g + 200;
    double *p = malloc(3 * total * sizeof *p);
    size_t k = 0;
    for (int i = 0; i < g; i++)
        for (int j = 0; j < g; j++)
            for (int l = 0; l < g; l++) {
                p[3 * k] = -0.5 + 5.0 * i / (g - 1) + 0.01 * check_rand01();
                p[3 * k + 1] = -0.5 + 5.0 * j / (g - 1) + 0.01 * check_rand01();
                p[3 * k + 2] = -0.5 + 5.0 * l / (g - 1) + 0.01 * check_rand01();
                k++;
            }
    for (int f = 0; f < 200; f++, k++) { /* on the child box's x = 1 face */
        p[3 * k] = 1.0;
        p[3 * k + 1] = 1.0 + 2.0 * check_rand01();
        p[3 * k + 2] = 1.0 + 2.0 * check_rand01();
    }
    *n = k;
    return p;
}

static ffd_deformer *make(const char *json, const double *pts, size_t n, ffd_mesh **mesh)
{
    ffd_error err = {{0}};
    ffd_deformer *d = NULL;
    CHECK_OK(ffd_mesh_create(pts, n, NULL, NULL, 0, mesh, &err));
    if (ffd_deformer_create_json(json, strlen(json), "nested.json", *mesh, NULL, &d, &err))
        fprintf(stderr, "%s\n", err.message);
    CHECK(d != NULL);
    return d;
}

static int in_box(const double *x, double lo, double hi)
{
    return x[0] >= lo && x[0] <= hi && x[1] >= lo && x[1] <= hi && x[2] >= lo && x[2] <= hi;
}

/* An affine map of every root control point; no own moves: the children's
 * points sit on the affine map, so every point (any depth) moves affinely. */
static void test_affine_parent_reproduced(void)
{
    const char *bases[] = {"bspline", "bernstein"};
    for (int b = 0; b < 2; b++) {
        size_t n;
        double *pts = cloud(&n);
        ffd_mesh *mesh = NULL;
        ffd_deformer *d = make(nested_rig(bases[b], "", ""), pts, n, &mesh);
        if (!d)
            continue;
        size_t c = ffd_deformer_control_count(d);
        CHECK(c == 64 + 80 + 27 + 64);
        double *ctl = malloc(3 * c * sizeof *ctl), *out = malloc(3 * n * sizeof *out);
        ffd_deformer_controls(d, ctl);
        const double A[3][3] = {{1.1, 0.2, 0.0}, {-0.1, 0.9, 0.3}, {0.05, 0.0, 1.2}};
        const double t[3] = {0.3, -0.2, 0.5};
        uint32_t ids[64];
        double pos[3 * 64];
        for (uint32_t j = 0; j < 64; j++) {
            ids[j] = j;
            for (int r = 0; r < 3; r++)
                pos[3 * j + r] = t[r] + A[r][0] * ctl[3 * j] + A[r][1] * ctl[3 * j + 1] +
                                 A[r][2] * ctl[3 * j + 2];
        }
        ffd_error err = {{0}};
        CHECK_OK(ffd_deformer_set_controls(d, ids, 64, pos, &err));
        CHECK_OK(ffd_deformer_eval(d, out, &err));
        double worst = 0;
        for (size_t i = 0; i < n; i++)
            for (int r = 0; r < 3; r++) {
                const double *x = pts + 3 * i;
                double want = t[r] + A[r][0] * x[0] + A[r][1] * x[1] + A[r][2] * x[2];
                if (!in_box(x, 0, 4))
                    want = x[r]; /* "outside": "fixed" */
                worst = fmax(worst, fabs(out[3 * i + r] - want));
            }
        CHECK_NEAR(worst, 0, 1e-12);
        /* the children's control points followed: the great-grandchild's too */
        ffd_deformer_controls(d, ctl);
        const double *g = ctl + 3 * (c - 1); /* its last point, rest (2.2, 2.2, 2.2) */
        CHECK_NEAR(g[0], t[0] + (A[0][0] + A[0][1] + A[0][2]) * 2.2, 1e-12);
        free(ctl);
        free(out);
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(mesh);
        free(pts);
    }
}

/* A child's own move changes only points inside the child's box (bitwise
 * elsewhere), and, on an interior control point, leaves the child's faces
 * where the parent puts them (the seam is closed); a move of a face
 * control point opens it (documented). */
static void test_child_moves_local(void)
{
    size_t n;
    double *pts = cloud(&n);
    ffd_mesh *m0 = NULL, *m1 = NULL, *m2 = NULL;
    ffd_deformer *d0 = make(nested_rig("bspline", "", ""), pts, n, &m0);
    ffd_deformer *d1 =
        make(nested_rig("bspline", "", "{\"index\": [1, 2, 1], \"delta\": [0.2, 0.1, -0.1]}"), pts,
             n, &m1);
    ffd_deformer *d2 =
        make(nested_rig("bspline", "", "{\"index\": [0, 2, 1], \"delta\": [0.2, 0.1, -0.1]}"), pts,
             n, &m2);
    if (!d0 || !d1 || !d2)
        return;
    double *o0 = malloc(3 * n * sizeof *o0), *o1 = malloc(3 * n * sizeof *o1);
    double *o2 = malloc(3 * n * sizeof *o2);
    ffd_error err = {{0}};
    CHECK_OK(ffd_deformer_eval(d0, o0, &err));
    CHECK_OK(ffd_deformer_eval(d1, o1, &err));
    CHECK_OK(ffd_deformer_eval(d2, o2, &err));
    size_t moved_in = 0, moved_out = 0;
    double face_gap_interior = 0, face_gap_border = 0;
    for (size_t i = 0; i < n; i++) {
        const double *x = pts + 3 * i;
        int differs = memcmp(o0 + 3 * i, o1 + 3 * i, 3 * sizeof *o0) != 0;
        if (in_box(x, 1, 3))
            moved_in += differs;
        else
            moved_out += differs;
        if (x[0] == 1.0 && x[1] > 1 && x[1] < 3 && x[2] > 1 && x[2] < 3)
            for (int r = 0; r < 3; r++) {
                face_gap_interior = fmax(face_gap_interior, fabs(o1[3 * i + r] - o0[3 * i + r]));
                face_gap_border = fmax(face_gap_border, fabs(o2[3 * i + r] - o0[3 * i + r]));
            }
    }
    CHECK(moved_in > 0);
    CHECK(moved_out == 0);
    CHECK_NEAR(face_gap_interior, 0, 1e-14);
    CHECK(face_gap_border > 1e-3);
    free(o0);
    free(o1);
    free(o2);
    ffd_deformer_destroy(d0);
    ffd_deformer_destroy(d1);
    ffd_deformer_destroy(d2);
    ffd_mesh_destroy(m0);
    ffd_mesh_destroy(m1);
    ffd_mesh_destroy(m2);
    free(pts);
}

/* Constraints in the parent's region, the child's and the grandchild's:
 * the solve over the composed map reaches every target. */
static void test_direct_manipulation(void)
{
    size_t n;
    double *pts = cloud(&n);
    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_mesh_create(pts, n, NULL, NULL, 0, &mesh, &err));
    const char *cons =
        ", \"constraints\": ["
        "{\"point\": [0.5, 0.6, 0.7], \"target\": [0.6, 0.5, 0.8]},"
        "{\"point\": [3.5, 3.4, 0.5], \"target\": [3.4, 3.6, 0.4]},"
        "{\"point\": [1.2, 2.0, 2.5], \"target\": [1.3, 2.2, 2.4]},"
        "{\"point\": [1.7, 2.3, 1.6], \"target\": [1.6, 2.4, 1.7]},"
        "{\"point\": [2.0, 2.1, 1.9], \"target\": [2.1, 2.0, 1.95]}]";
    const char *json = nested_rig("bspline", cons, "");
    ffd_rig *rig = NULL;
    CHECK_OK(ffd_rig_parse_json(json, strlen(json), "dm.json", &rig, &err));
    ffd_rig_report report = {0};
    if (rig && ffd_rig_apply(rig, mesh, &report, &err))
        fprintf(stderr, "%s\n", err.message);
    CHECK(report.constraint_count == 5);
    CHECK_NEAR(report.max_residual, 0, 1e-10);
    ffd_rig_report_free(&report);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
    free(pts);
}

/* Nothing moved: every point keeps its bits, every Jacobian is I exactly
 * (outside the root: "clamp", and "falloff"). */
static void test_identity_bitwise(void)
{
    for (int f = 0; f < 2; f++) {
        size_t n;
        double *pts = cloud(&n);
        pts[0] = -0.0;
        ffd_mesh *mesh = NULL;
        ffd_deformer *d = make(nested_rig("bspline", f ? ", \"outside\": \"falloff\", \"falloff\": 0.4"
                                                       : ", \"outside\": \"clamp\"",
                                          ""),
                               pts, n, &mesh);
        if (!d)
            continue;
        double *out = malloc(3 * n * sizeof *out), *J = malloc(9 * n * sizeof *J);
        ffd_error err = {{0}};
        CHECK_OK(ffd_deformer_eval(d, out, &err));
        CHECK(memcmp(out, pts, 3 * n * sizeof *out) == 0);
        CHECK_OK(ffd_deformer_jacobian(d, J, &err));
        int ident = 1;
        for (size_t i = 0; i < n; i++)
            for (int e = 0; e < 9; e++)
                ident &= J[9 * i + e] == (e % 4 == 0 ? 1.0 : 0.0);
        CHECK(ident);
        free(out);
        free(J);
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(mesh);
        free(pts);
    }
}

/* Every control (root and children) moved by one rigid motion: every
 * point inside the root moves rigidly. */
static void test_rigid_motion(void)
{
    size_t n;
    double *pts = cloud(&n);
    ffd_mesh *mesh = NULL;
    ffd_deformer *d = make(nested_rig("bspline", "", "{\"index\": [1, 1, 1], \"delta\": [0.1, 0, "
                                                     "0]}"),
                           pts, n, &mesh);
    if (!d)
        return;
    ffd_error err = {{0}};
    CHECK_OK(ffd_deformer_reset(d, &err));
    size_t c = ffd_deformer_control_count(d);
    double *ctl = malloc(3 * c * sizeof *ctl), *out = malloc(3 * n * sizeof *out);
    ffd_deformer_controls(d, ctl);
    const double th = 0.7, R[3][3] = {{cos(th), -sin(th), 0}, {sin(th), cos(th), 0}, {0, 0, 1}};
    const double t[3] = {1.0, -2.0, 0.5};
    for (size_t j = 0; j < c; j++) {
        double p[3] = {ctl[3 * j], ctl[3 * j + 1], ctl[3 * j + 2]};
        for (int r = 0; r < 3; r++)
            ctl[3 * j + r] = t[r] + R[r][0] * p[0] + R[r][1] * p[1] + R[r][2] * p[2];
    }
    CHECK_OK(ffd_deformer_set_controls(d, NULL, c, ctl, &err));
    CHECK_OK(ffd_deformer_eval(d, out, &err));
    double worst = 0;
    for (size_t i = 0; i < n; i++) {
        const double *x = pts + 3 * i;
        if (!in_box(x, 0, 4))
            continue;
        for (int r = 0; r < 3; r++)
            worst = fmax(worst, fabs(out[3 * i + r] - (t[r] + R[r][0] * x[0] + R[r][1] * x[1] +
                                                       R[r][2] * x[2])));
    }
    CHECK_NEAR(worst, 0, 1e-12);
    free(ctl);
    free(out);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
    free(pts);
}

/* The composed rows against the evaluation: one variable moved at a time
 * (a root control carries the children along; a child's own displacement),
 * exact because the map is linear. */
static void test_linear_map_composed(void)
{
    size_t n;
    double *pts = cloud(&n);
    ffd_mesh *mesh = NULL;
    ffd_deformer *d = make(nested_rig("bspline", ", \"outside\": \"clamp\"",
                                      "{\"index\": [2, 2, 2], \"delta\": [0.1, 0.2, 0]}"),
                           pts, n, &mesh);
    if (!d)
        return;
    ffd_error err = {{0}};
    size_t c = ffd_deformer_control_count(d);
    ffd_linear_map map;
    CHECK_OK(ffd_deformer_linear_map(d, &map, &err));
    CHECK(map.variable_count == c);
    double *W = calloc(n * c, sizeof *W), *sum = calloc(n, sizeof *sum);
    uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
    double *w = malloc(map.max_row_nnz * sizeof *w);
    for (size_t i = 0; i < n; i++) {
        size_t k = map.row(map.self, i, cols, w);
        CHECK(k <= map.max_row_nnz);
        for (size_t e = 0; e < k; e++) {
            uint32_t v = map.tie ? map.tie[cols[e]] : cols[e];
            W[i * c + v] += w[e];
            sum[i] += w[e];
        }
    }
    /* partition of unity over the root's variables: the children's own
     * slots add sum w_j (e_j + ...), so rows sum to 1 + (own weights) */
    double *before = malloc(3 * n * sizeof *before), *after = malloc(3 * n * sizeof *after);
    double *ctl = malloc(3 * c * sizeof *ctl);
    CHECK_OK(ffd_deformer_eval(d, before, &err));
    double worst = 0;
    const uint32_t probe[] = {5, 21, 42, 64 + 7, 64 + 40, 64 + 80 + 13, 64 + 80 + 27 + 30};
    for (size_t q = 0; q < sizeof probe / sizeof *probe; q++) {
        uint32_t j = probe[q];
        const double delta[3] = {0.05, -0.03, 0.02};
        CHECK_OK(ffd_deformer_move_controls(d, &j, 1, delta, &err));
        CHECK_OK(ffd_deformer_eval(d, after, &err));
        for (size_t i = 0; i < n; i++)
            for (int r = 0; r < 3; r++)
                worst = fmax(worst, fabs(after[3 * i + r] - before[3 * i + r] -
                                         W[i * c + j] * delta[r]));
        const double back[3] = {-0.05, 0.03, -0.02};
        CHECK_OK(ffd_deformer_move_controls(d, &j, 1, back, &err));
    }
    CHECK_NEAR(worst, 0, 1e-12);
    free(W);
    free(sum);
    free(cols);
    free(w);
    free(before);
    free(after);
    free(ctl);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
    free(pts);
}

/* The deformer's rig, read back on the same points, gives the same points. */
static void test_rig_round_trip(void)
{
    size_t n;
    double *pts = cloud(&n);
    ffd_mesh *mesh = NULL;
    ffd_deformer *d = make(nested_rig("bernstein", ", \"moves\": [{\"index\": [3, 3, 3], "
                                                   "\"delta\": [0.3, 0, 0]}]",
                                      "{\"index\": [2, 2, 2], \"delta\": [0.1, 0.2, 0]}"),
                           pts, n, &mesh);
    if (!d)
        return;
    ffd_error err = {{0}};
    uint32_t id = 64 + 80 + 3; /* a grandchild control */
    const double delta[3] = {0.01, 0.02, 0.03};
    CHECK_OK(ffd_deformer_move_controls(d, &id, 1, delta, &err));
    char *json = NULL;
    size_t size = 0;
    CHECK_OK(ffd_deformer_rig(d, &json, &size, &err));
    CHECK(json && strstr(json, "\"children\""));
    ffd_deformer *e = NULL;
    if (json && ffd_deformer_create_json(json, size, "again.json", mesh, NULL, &e, &err))
        fprintf(stderr, "%s\n", err.message);
    CHECK(e != NULL);
    if (e) {
        double *a = malloc(3 * n * sizeof *a), *b = malloc(3 * n * sizeof *b);
        CHECK_OK(ffd_deformer_eval(d, a, &err));
        CHECK_OK(ffd_deformer_eval(e, b, &err));
        double worst = 0;
        for (size_t i = 0; i < 3 * n; i++)
            worst = fmax(worst, fabs(a[i] - b[i]));
        CHECK_NEAR(worst, 0, 1e-13);
        free(a);
        free(b);
        ffd_deformer_destroy(e);
    }
    ffd_free(json);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
    free(pts);
}

/* Refusals: a child box sticking out of its parent, the depth limit, the
 * control-point limit, a key a child does not have. */
static void test_refusals(void)
{
    ffd_error err = {{0}};
    ffd_rig *rig = NULL;
    const char *out_of_parent =
        "{\"box\": {\"origin\": [0,0,0], \"axes\": [[1,0,0],[0,1,0],[0,0,1]]}, \"children\": "
        "[{\"box\": {\"origin\": [0.5,0.5,0.5], \"axes\": [[1,0,0],[0,0.2,0],[0,0,0.2]]}}]}";
    double p[3] = {0.5, 0.5, 0.5};
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_mesh_create(p, 1, NULL, NULL, 0, &mesh, &err));
    ffd_deformer *d = NULL;
    CHECK(ffd_deformer_create_json(out_of_parent, strlen(out_of_parent), "r.json", mesh, NULL, &d,
                                   &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "children[0].box") && strstr(err.message, "outside the parent"));
    /* depth 9: nine nested "children" */
    char deep[4096] = "{\"children\": [";
    for (int i = 0; i < 8; i++)
        strcat(deep, "{\"box\": {\"origin\": [0,0,0], \"axes\": [[1,0,0],[0,1,0],[0,0,1]]}, "
                     "\"children\": [");
    strcat(deep, "{\"box\": {\"origin\": [0,0,0], \"axes\": [[1,0,0],[0,1,0],[0,0,1]]}}");
    for (int i = 0; i < 8; i++)
        strcat(deep, "]}");
    strcat(deep, "]}");
    CHECK(ffd_rig_parse_json(deep, strlen(deep), "deep.json", &rig, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "limit of 8 levels") != NULL);
    const char *many = "{\"resolution\": [1000, 1000, 2], \"children\": [{\"box\": {\"origin\": "
                       "[0,0,0], \"axes\": [[1,0,0],[0,1,0],[0,0,1]]}}]}";
    CHECK(ffd_rig_parse_json(many, strlen(many), "many.json", &rig, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "limit of 1048576") != NULL);
    const char *key = "{\"children\": [{\"box\": {\"origin\": [0,0,0], \"axes\": "
                      "[[1,0,0],[0,1,0],[0,0,1]]}, \"outsde\": 1}]}";
    CHECK(ffd_rig_parse_json(key, strlen(key), "key.json", &rig, &err) != FFD_OK);
    CHECK(strstr(err.message, "children[0]") && strstr(err.message, "outsde"));
    ffd_mesh_destroy(mesh);
}

/* ---- falloff ---- */

static const char *falloff_rig(const char *curve)
{
    static char buf[1024];
    snprintf(buf, sizeof buf,
             "{\"basis\": \"bspline\", \"resolution\": [4, 4, 4], \"box\": {\"origin\": [0, 0, 0], "
             "\"axes\": [[4, 0, 0], [0, 3, 0], [0.5, 0, 4]]}, \"outside\": \"falloff\", "
             "\"falloff\": 1.5, \"falloff_curve\": \"%s\", \"moves\": ["
             "{\"index\": [3, 1, 1], \"delta\": [0.4, 0.2, -0.1]},"
             "{\"index\": [3, 3, 2], \"delta\": [0.1, 0.3, 0.2]},"
             "{\"index\": [0, 0, 0], \"delta\": [-0.2, 0.1, 0.3]}]}",
             curve);
    return buf;
}

/* Points just inside and just outside a face: the map is continuous; a
 * point beyond the distance keeps its bits. */
static void test_falloff_continuity(void)
{
    const char *curves[] = {"smooth", "linear", "sphere", "sharp"};
    for (int c = 0; c < 4; c++) {
        double pts[3 * 6] = {4.0 + 0.25, 1.2, 2.0, 4.0 + 0.25 + 1e-9, 1.2, 2.0, /* x face at u=.5 */
                             2.0, 3.0 - 1e-9, 1.0, 2.0, 3.0 + 1e-9, 1.0,
                             6.0, 1.0, 1.0, /* beyond the distance */
                             4.6, 3.5, 4.8};
        ffd_mesh *mesh = NULL;
        ffd_deformer *d = make(falloff_rig(curves[c]), pts, 6, &mesh);
        if (!d)
            continue;
        double out[18];
        ffd_error err = {{0}};
        CHECK_OK(ffd_deformer_eval(d, out, &err));
        for (int r = 0; r < 3; r++) {
            CHECK_NEAR(out[r] - pts[r], out[3 + r] - pts[3 + r], 1e-7);
            CHECK_NEAR(out[6 + r] - pts[6 + r], out[9 + r] - pts[9 + r], 1e-7);
        }
        CHECK(fabs(out[0] - pts[0]) > 1e-3); /* the face moved */
        CHECK(memcmp(out + 12, pts + 12, 3 * sizeof *out) == 0);
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(mesh);
    }
}

/* The Jacobian of outside points against central differences of the map,
 * and the rows: scaled by f (they sum to f), and equal to the change of the
 * evaluation when one control moves. */
static void test_falloff_jacobian_and_rows(void)
{
    const char *curves[] = {"smooth", "linear", "sphere", "sharp"};
    for (int c = 0; c < 4; c++) {
        enum { N = 40 };
        double pts[3 * N];
        for (int i = 0; i < N; i++) { /* around the box, within the falloff distance mostly */
            pts[3 * i] = -1.2 + 6.9 * check_rand01();
            pts[3 * i + 1] = -1.2 + 5.4 * check_rand01();
            pts[3 * i + 2] = -1.2 + 6.4 * check_rand01();
        }
        ffd_mesh *mesh = NULL;
        ffd_deformer *d = make(falloff_rig(curves[c]), pts, N, &mesh);
        if (!d)
            continue;
        ffd_error err = {{0}};
        double J[9 * N], out[3 * N], worst = 0;
        CHECK_OK(ffd_deformer_jacobian(d, J, &err));
        const double h = 1e-6;
        for (int a = 0; a < 3; a++) {
            double plus[3 * N], minus[3 * N], xp[3 * N], xm[3 * N];
            memcpy(xp, pts, sizeof xp);
            memcpy(xm, pts, sizeof xm);
            for (int i = 0; i < N; i++) {
                xp[3 * i + a] += h;
                xm[3 * i + a] -= h;
            }
            CHECK_OK(ffd_deformer_bind(d, xp, N, &err));
            CHECK_OK(ffd_deformer_eval(d, plus, &err));
            CHECK_OK(ffd_deformer_bind(d, xm, N, &err));
            CHECK_OK(ffd_deformer_eval(d, minus, &err));
            for (int i = 0; i < N; i++)
                for (int r = 0; r < 3; r++)
                    worst = fmax(worst, fabs((plus[3 * i + r] - minus[3 * i + r]) / (2 * h) -
                                             J[9 * i + 3 * r + a]));
        }
        /* the sphere curve's slope is unbounded at r = 1: allow its steepness */
        CHECK_NEAR(worst, 0, c == 2 ? 1e-3 : 1e-5);
        CHECK_OK(ffd_deformer_bind(d, pts, N, &err));
        ffd_linear_map map;
        CHECK_OK(ffd_deformer_linear_map(d, &map, &err));
        double before[3 * N], after[3 * N];
        CHECK_OK(ffd_deformer_eval(d, before, &err));
        uint32_t j = (3 * 4 + 1) * 4 + 1; /* control (3,1,1) */
        const double delta[3] = {0.1, -0.2, 0.05};
        CHECK_OK(ffd_deformer_move_controls(d, &j, 1, delta, &err));
        CHECK_OK(ffd_deformer_eval(d, after, &err));
        uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
        double *w = malloc(map.max_row_nnz * sizeof *w), rw = 0;
        for (int i = 0; i < N; i++) {
            size_t k = map.row(map.self, (size_t)i, cols, w);
            double wj = 0;
            for (size_t e = 0; e < k; e++)
                if ((map.tie ? map.tie[cols[e]] : cols[e]) == j)
                    wj += w[e];
            for (int r = 0; r < 3; r++)
                rw = fmax(rw, fabs(after[3 * i + r] - before[3 * i + r] - wj * delta[r]));
        }
        CHECK_NEAR(rw, 0, 1e-13);
        free(cols);
        free(w);
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(mesh);
        (void)out;
    }
}

/* The curves against Blender's proportional-editing formulas in t = 1 - r
 * (smooth: the smootherstep 6t^5 - 15t^4 + 10t^3; sphere: sqrt(2t - t^2);
 * sharp: t^2; linear: t), and their derivatives by differences. */
static void test_falloff_curves(void)
{
    for (int k = 0; k <= 20; k++) {
        double r = k / 20.0, t = 1 - r, d;
        CHECK_NEAR(ffd_falloff_value(FFD_FALLOFF_SMOOTH, r, &d), t * t * t * (t * (6 * t - 15) + 10),
                   1e-15);
        CHECK_NEAR(ffd_falloff_value(FFD_FALLOFF_LINEAR, r, NULL), t, 1e-15);
        CHECK_NEAR(ffd_falloff_value(FFD_FALLOFF_SPHERE, r, NULL), sqrt(2 * t - t * t), 1e-15);
        CHECK_NEAR(ffd_falloff_value(FFD_FALLOFF_SHARP, r, NULL), t * t, 1e-15);
        if (k > 0 && k < 20)
            for (int c = 0; c < 4; c++) {
                double h = 1e-6, dd;
                ffd_falloff_value((ffd_falloff_curve)c, r, &dd);
                double fd = (ffd_falloff_value((ffd_falloff_curve)c, r + h, NULL) -
                             ffd_falloff_value((ffd_falloff_curve)c, r - h, NULL)) /
                            (2 * h);
                CHECK_NEAR(dd, fd, 1e-6 * fmax(1, fabs(fd)));
            }
    }
    CHECK(ffd_falloff_value(FFD_FALLOFF_SMOOTH, 1.0, NULL) == 0.0);
    CHECK(ffd_falloff_value(FFD_FALLOFF_SMOOTH, 2.0, NULL) == 0.0);
    CHECK(ffd_falloff_value(FFD_FALLOFF_SMOOTH, 0.0, NULL) == 1.0);
}

/* Falloff in a nested rig's root, and round trip of its keys. */
static void test_falloff_round_trip(void)
{
    double pts[6] = {5.0, 1.0, 1.0, 2.0, 1.0, 1.0};
    ffd_mesh *mesh = NULL;
    ffd_deformer *d = make(falloff_rig("sharp"), pts, 2, &mesh);
    if (!d)
        return;
    ffd_error err = {{0}};
    char *json = NULL;
    size_t size = 0;
    CHECK_OK(ffd_deformer_rig(d, &json, &size, &err));
    CHECK(json && strstr(json, "\"falloff\"") && strstr(json, "\"sharp\""));
    ffd_deformer *e = NULL;
    CHECK_OK(ffd_deformer_create_json(json, size, "again.json", mesh, NULL, &e, &err));
    double a[6], b[6];
    CHECK_OK(ffd_deformer_eval(d, a, &err));
    if (e)
        CHECK_OK(ffd_deformer_eval(e, b, &err));
    CHECK(e && memcmp(a, b, sizeof a) == 0);
    CHECK(a[0] != pts[0]);
    ffd_free(json);
    ffd_deformer_destroy(e);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"affine_parent_reproduced", test_affine_parent_reproduced},
        {"child_moves_local", test_child_moves_local},
        {"direct_manipulation", test_direct_manipulation},
        {"identity_bitwise", test_identity_bitwise},
        {"rigid_motion", test_rigid_motion},
        {"linear_map_composed", test_linear_map_composed},
        {"rig_round_trip", test_rig_round_trip},
        {"refusals", test_refusals},
        {"falloff_continuity", test_falloff_continuity},
        {"falloff_jacobian_and_rows", test_falloff_jacobian_and_rows},
        {"falloff_curves", test_falloff_curves},
        {"falloff_round_trip", test_falloff_round_trip},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
