/* Tests for the generic layers every method shares (docs/constraints.md):
 * per-vertex weights and a global strength (x' = x + s w (f(x) - x), its
 * Jacobian I + s w (J_f - I), scaled linear-map rows and sensitivity
 * products, identity bit for bit), their sources (inline values, a file,
 * an OBJ "#NAME" block, a PLY vertex property), constrained FFD (a linear
 * constraint against the closed-form minimum-norm projection written here,
 * the volume by the divergence theorem written differently, the
 * barycentre, the mask), the fold policy (refuse, shorten) for rigs and
 * control moves, and the editor session and ffd_rig_apply agreeing with
 * ffd_deformer. One rig of each method (check_deformer.h's first of each). */
#include "check.h"
#include "check_deformer.h"

#include "ffd.h"

#include <cjson/cJSON.h>
#include <unistd.h>

#define BUNNY EX "lattice/bunny.obj"
#define BEND EX "lattice/bend.json"
#define EARS EX "lattice/ears.json" /* changes the volume (the bend shears) */

/* The first case of each method. */
static size_t method_cases(const rig_case **out)
{
    static rig_case firsts[ALL_CASES];
    size_t k = 0;
    for (size_t i = 0; i < ALL_CASES; i++) {
        int seen = 0;
        for (size_t j = 0; j < i; j++)
            seen |= strcmp(cases[j].method, cases[i].method) == 0;
        if (!seen)
            firsts[k++] = cases[i];
    }
    *out = firsts;
    return k;
}

static char *slurp_text(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *t = malloc((size_t)n + 1);
    if (t && fread(t, 1, (size_t)n, f) != (size_t)n) {
        free(t);
        t = NULL;
    }
    if (t)
        t[n] = 0;
    fclose(f);
    return t;
}

/* The rig file with the keys of extra (a JSON object's text) added. */
static char *rig_with(const char *rig_path, const char *extra)
{
    char *text = slurp_text(rig_path);
    cJSON *root = text ? cJSON_Parse(text) : NULL, *add = cJSON_Parse(extra);
    free(text);
    if (!root || !add) {
        cJSON_Delete(root);
        cJSON_Delete(add);
        return NULL;
    }
    cJSON *item = add->child;
    while (item) {
        cJSON *next = item->next;
        cJSON_DeleteItemFromObjectCaseSensitive(root, item->string);
        cJSON_AddItemToObject(root, item->string, cJSON_Duplicate(item, 1));
        item = next;
    }
    char *out = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    cJSON_Delete(add);
    return out;
}

static ffd_deformer *make_with(const char *rig_path, const ffd_mesh *mesh, const char *extra,
                               ffd_error *err)
{
    char *text = rig_with(rig_path, extra);
    ffd_deformer *d = NULL;
    if (!text || ffd_deformer_create_json(text, strlen(text), rig_path, mesh, NULL, &d, err)) {
        if (text)
            fprintf(stderr, "%s: %s\n", rig_path, err->message);
        d = NULL;
    }
    free(text);
    return d;
}

static double *eval_all(ffd_deformer *d)
{
    size_t n = ffd_deformer_point_count(d);
    double *x = malloc(3 * n * sizeof *x);
    ffd_error err = {{0}};
    CHECK_OK(ffd_deformer_eval(d, x, &err));
    return x;
}

/* "values": [w_0, ...] for n vertices, w_i in [0, 1] from i. */
static char *weights_json(size_t n, double strength)
{
    cJSON *root = cJSON_CreateObject(), *w = cJSON_AddObjectToObject(root, "weights");
    cJSON *a = cJSON_AddArrayToObject(w, "values");
    for (size_t i = 0; i < n; i++)
        cJSON_AddItemToArray(a, cJSON_CreateNumber((double)((i * 7919) % 101) / 100.0));
    cJSON_AddNumberToObject(root, "strength", strength);
    char *t = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    return t;
}

static double weight_of(size_t i)
{
    return (double)((i * 7919) % 101) / 100.0;
}

/* ---- weights and strength ---- */

/* Strength 0 and all weights 0 give the rest positions bit for bit; all
 * weights 1 at strength 1 give the method's positions bit for bit. */
static void test_identity_bitwise(void)
{
    const rig_case *rc;
    size_t k = method_cases(&rc);
    for (size_t c = 0; c < k; c++) {
        ffd_mesh *mesh = read_mesh(rc[c].mesh);
        CHECK(mesh != NULL);
        if (!mesh)
            continue;
        size_t n = ffd_mesh_vertex_count(mesh);
        const double *rest = ffd_mesh_positions(mesh);
        ffd_error err = {{0}};
        ffd_deformer *plain = make(&rc[c], mesh);
        ffd_deformer *zero = make_with(rc[c].rig, mesh, "{\"strength\": 0}", &err);
        char *ones = malloc(32 + 4 * n), *zeros = malloc(32 + 4 * n);
        strcpy(ones, "{\"weights\": {\"values\": [");
        strcpy(zeros, ones);
        for (size_t i = 0; i < n; i++) {
            strcat(ones, i ? ",1" : "1");
            strcat(zeros, i ? ",0" : "0");
        }
        strcat(ones, "]}}");
        strcat(zeros, "]}}");
        ffd_deformer *one = make_with(rc[c].rig, mesh, ones, &err);
        ffd_deformer *none = make_with(rc[c].rig, mesh, zeros, &err);
        CHECK(plain && zero && one && none);
        if (plain && zero && one && none) {
            double *xp = eval_all(plain), *xz = eval_all(zero), *xo = eval_all(one),
                   *xn = eval_all(none);
            CHECK(memcmp(xz, rest, 3 * n * sizeof *xz) == 0);
            CHECK(memcmp(xn, rest, 3 * n * sizeof *xn) == 0);
            CHECK(memcmp(xo, xp, 3 * n * sizeof *xo) == 0);
            CHECK(max_diff(xp, rest, 3 * n) > 0); /* the rig moves something */
            free(xp);
            free(xz);
            free(xo);
            free(xn);
        }
        free(ones);
        free(zeros);
        ffd_deformer_destroy(plain);
        ffd_deformer_destroy(zero);
        ffd_deformer_destroy(one);
        ffd_deformer_destroy(none);
        ffd_mesh_destroy(mesh);
    }
}

/* x' = x + s w (f(x) - x), for every method, and the Jacobian
 * I + s w (J_f - I) where the method has one. */
static void test_weighted_blend(void)
{
    const rig_case *rc;
    size_t k = method_cases(&rc);
    const double s = 0.7;
    for (size_t c = 0; c < k; c++) {
        ffd_mesh *mesh = read_mesh(rc[c].mesh);
        if (!mesh)
            continue;
        size_t n = ffd_mesh_vertex_count(mesh);
        const double *x = ffd_mesh_positions(mesh);
        double diag = diagonal(x, n);
        char *extra = weights_json(n, s);
        ffd_error err = {{0}};
        ffd_deformer *plain = make(&rc[c], mesh), *w = make_with(rc[c].rig, mesh, extra, &err);
        CHECK(plain && w);
        if (plain && w) {
            double *f = eval_all(plain), *got = eval_all(w);
            double worst = 0;
            for (size_t i = 0; i < n; i++)
                for (int a = 0; a < 3; a++)
                    worst = fmax(worst, fabs(got[3 * i + a] -
                                             (x[3 * i + a] + s * weight_of(i) *
                                                                 (f[3 * i + a] - x[3 * i + a]))));
            CHECK(worst <= 1e-14 * diag);
            double *jf = malloc(9 * n * sizeof *jf), *jw = malloc(9 * n * sizeof *jw);
            ffd_status st = ffd_deformer_jacobian(plain, jf, &err);
            CHECK(st == ffd_deformer_jacobian(w, jw, &err));
            if (st == FFD_OK) {
                double jworst = 0;
                for (size_t i = 0; i < n; i++)
                    for (int e = 0; e < 9; e++) {
                        double id = e % 4 == 0 ? 1.0 : 0.0;
                        jworst = fmax(jworst, fabs(jw[9 * i + e] -
                                                   (id + s * weight_of(i) * (jf[9 * i + e] - id))));
                    }
                CHECK(jworst <= 1e-13);
            } else {
                CHECK(st == FFD_ERR_UNSUPPORTED); /* a method without Jacobians (GFFD, cage) */
            }
            free(jf);
            free(jw);
            free(f);
            free(got);
        }
        cJSON_free(extra);
        ffd_deformer_destroy(plain);
        ffd_deformer_destroy(w);
        ffd_mesh_destroy(mesh);
    }
}

/* The scaled Jacobian against central differences of the deformed points
 * (strength only: a binding of other points carries no vertex weights). */
static void test_scaled_jacobian_fd(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    CHECK(mesh != NULL);
    if (!mesh)
        return;
    ffd_error err = {{0}};
    ffd_deformer *d = make_with(BEND, mesh, "{\"strength\": 0.6}", &err);
    CHECK(d != NULL);
    if (!d) {
        ffd_mesh_destroy(mesh);
        return;
    }
    const double *rest = ffd_mesh_positions(mesh);
    double diag = diagonal(rest, ffd_mesh_vertex_count(mesh)), h = 1e-6 * diag;
    enum { K = 20 };
    double pts[7 * 3 * K], out[7 * 3 * K], jac[9 * 7 * K];
    for (size_t p = 0; p < K; p++)
        for (int v = 0; v < 7; v++)
            for (int a = 0; a < 3; a++) {
                double base = rest[3 * (p * 83) + a];
                int axis = (v - 1) / 2, sign = (v - 1) % 2 ? -1 : 1;
                pts[3 * (7 * p + v) + a] = base + (v > 0 && a == axis ? sign * h : 0);
            }
    CHECK_OK(ffd_deformer_bind(d, pts, 7 * K, &err));
    CHECK_OK(ffd_deformer_eval(d, out, &err));
    CHECK_OK(ffd_deformer_jacobian(d, jac, &err));
    double worst = 0;
    for (size_t p = 0; p < K; p++)
        for (int b = 0; b < 3; b++)
            for (int a = 0; a < 3; a++) {
                double fd = (out[3 * (7 * p + 1 + 2 * b) + a] - out[3 * (7 * p + 2 + 2 * b) + a]) /
                            (2 * h);
                worst = fmax(worst, fabs(fd - jac[9 * 7 * p + 3 * a + b]));
            }
    CHECK(worst <= 1e-6);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* Linear map rows and sensitivity products are s w_i times the method's,
 * and a change of the controls moves the points by exactly that. */
static void test_scaled_rows_fd(void)
{
    const rig_case *rc;
    size_t k = method_cases(&rc);
    for (size_t c = 0; c < k; c++) {
        ffd_mesh *mesh = read_mesh(rc[c].mesh);
        if (!mesh)
            continue;
        size_t n = ffd_mesh_vertex_count(mesh);
        char *extra = weights_json(n, 0.8);
        ffd_error err = {{0}};
        ffd_deformer *d = make_with(rc[c].rig, mesh, extra, &err);
        CHECK(d != NULL);
        if (d) {
            size_t nc = ffd_deformer_control_count(d);
            double diag = diagonal(ffd_mesh_positions(mesh), n), h = 1e-3 * diag;
            double *v = calloc(3 * nc, sizeof *v), *wv = malloc(3 * n * sizeof *wv);
            uint32_t id = (uint32_t)(nc / 2);
            v[3 * id] = h;
            v[3 * id + 2] = -0.5 * h;
            ffd_status st = ffd_deformer_sensitivity_product(d, v, wv, &err);
            if (st == FFD_ERR_UNSUPPORTED) { /* no linear map: GFFD, Kelvinlet */
                free(v);
                free(wv);
                cJSON_free(extra);
                ffd_deformer_destroy(d);
                ffd_mesh_destroy(mesh);
                continue;
            }
            CHECK_OK(st);
            ffd_sparse W = {0};
            CHECK_OK(ffd_deformer_sensitivities(d, &W, &err));
            double *before = eval_all(d);
            CHECK_OK(ffd_deformer_move_controls(d, &id, 1, v + 3 * id, &err));
            double *after = eval_all(d), worst = 0, worst_rows = 0, moved = 0;
            for (size_t i = 0; i < n; i++) {
                double wij = 0;
                for (size_t e = W.row_ptr ? W.row_ptr[i] : 0; W.row_ptr && e < W.row_ptr[i + 1]; e++)
                    if (W.col[e] == id)
                        wij = W.val[e];
                for (int a = 0; a < 3; a++) {
                    worst = fmax(worst, fabs(after[3 * i + a] - before[3 * i + a] - wv[3 * i + a]));
                    worst_rows = fmax(worst_rows, fabs(wij * v[3 * id + a] - wv[3 * i + a]));
                    moved = fmax(moved, fabs(wv[3 * i + a]));
                }
            }
            CHECK(moved > 0);
            CHECK(worst <= 1e-9 * diag);
            CHECK(worst_rows <= 1e-12 * diag);
            /* the adjoint: <W v, u> == <v, W^T u> */
            double *u = malloc(3 * n * sizeof *u), *wtu = malloc(3 * nc * sizeof *wtu);
            for (size_t i = 0; i < 3 * n; i++)
                u[i] = check_rand01() - 0.5;
            CHECK_OK(ffd_deformer_sensitivity_transpose_product(d, u, wtu, &err));
            double lhs = 0, rhs = 0;
            for (size_t i = 0; i < 3 * n; i++)
                lhs += wv[i] * u[i];
            for (size_t j = 0; j < 3 * nc; j++)
                rhs += v[j] * wtu[j];
            CHECK_NEAR(lhs, rhs, 1e-10 * (fabs(lhs) + 1e-300) + 1e-14 * diag);
            free(u);
            free(wtu);
            ffd_sparse_free(&W);
            free(v);
            free(wv);
            free(before);
            free(after);
        }
        cJSON_free(extra);
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(mesh);
    }
}

/* Direct manipulation through the weighted linear map reaches its targets. */
static void test_weighted_direct_manipulation(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh);
    char *extra = weights_json(n, 0.9);
    ffd_error err = {{0}};
    ffd_deformer *d = make_with(EX "lattice/bernstein.json", mesh, extra, &err);
    CHECK(d != NULL);
    if (d) {
        ffd_linear_map map;
        CHECK_OK(ffd_deformer_linear_map(d, &map, &err));
        double *x = eval_all(d), diag = diagonal(ffd_mesh_positions(mesh), n);
        size_t pts[2] = {17, 1200};
        CHECK(weight_of(17) > 0 && weight_of(1200) > 0);
        double cur[6], tgt[6];
        for (int c = 0; c < 2; c++)
            for (int a = 0; a < 3; a++) {
                cur[3 * c + a] = x[3 * pts[c] + a];
                tgt[3 * c + a] = cur[3 * c + a] + (a == 1 ? 0.05 : 0.02) * diag;
            }
        double *delta = malloc(3 * map.variable_count * sizeof *delta);
        CHECK_OK(ffd_manip_solve(&map, pts, 2, cur, tgt, NULL, delta, NULL, NULL, &err));
        CHECK_OK(ffd_deformer_move_controls(d, NULL, ffd_deformer_control_count(d), delta, &err));
        double *y = eval_all(d);
        for (int c = 0; c < 2; c++)
            for (int a = 0; a < 3; a++)
                CHECK_NEAR(y[3 * pts[c] + a], tgt[3 * c + a], 1e-9 * diag);
        free(delta);
        free(x);
        free(y);
    }
    cJSON_free(extra);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* ---- the sources of the weights ---- */

static const char cube_obj[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                               "v 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n"
                               "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";

static const char bernstein_rig[] =
    "{\"deformer\": \"lattice\", \"basis\": \"bernstein\", \"resolution\": [2, 2, 2],"
    " \"box\": {\"origin\": [-0.5, -0.5, -0.5], \"axes\": [[2, 0, 0], [0, 2, 0], [0, 0, 2]]},"
    " \"moves\": [{\"index\": [1, 1, 1], \"delta\": [0.3, 0.2, 0.1]}]";

/* The cube deformed by a rig with extra (text after the rig's keys). */
static ffd_status cube_deform(ffd_mesh *mesh, const char *extra, double *out, ffd_error *err)
{
    char text[1024];
    snprintf(text, sizeof text, "%s%s}", bernstein_rig, extra);
    ffd_deformer *d = NULL;
    ffd_status st = ffd_deformer_create_json(text, strlen(text), "cube.json", mesh, NULL, &d, err);
    if (!st)
        st = ffd_deformer_eval(d, out, err);
    ffd_deformer_destroy(d);
    return st;
}

static void check_cube_weights(ffd_mesh *mesh, const char *extra, const double w[8])
{
    double plain[24], got[24];
    ffd_error err = {{0}};
    const double *x = ffd_mesh_positions(mesh);
    CHECK_OK(cube_deform(mesh, "", plain, &err));
    ffd_status st = cube_deform(mesh, extra, got, &err);
    CHECK(st == FFD_OK);
    if (st)
        fprintf(stderr, "%s\n", err.message);
    for (int i = 0; !st && i < 8; i++)
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(got[3 * i + a], x[3 * i + a] + w[i] * (plain[3 * i + a] - x[3 * i + a]),
                       1e-15);
}

static void test_weights_from_obj_comments(void)
{
    static const double w[8] = {0, 0.25, 0.5, 1, 0, 0.75, 1, 0.125};
    char obj[1024];
    snprintf(obj, sizeof obj,
             "%s#w 0\n#w 0.25\n#w 0.5\n#w 1\n# a comment\n#w 0\n#w 0.75\n#w 1\n#w 0.125\n",
             cube_obj);
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read_memory(obj, strlen(obj), FFD_FORMAT_OBJ, "cube.obj", &mesh, &err));
    if (!mesh)
        return;
    check_cube_weights(mesh, ", \"weights\": {\"attribute\": \"w\"}", w);
    /* an attribute the mesh does not have; too few values, naming the count */
    double out[24];
    CHECK(cube_deform(mesh, ", \"weights\": {\"attribute\": \"mask\"}", out, &err) ==
          FFD_ERR_INVALID);
    CHECK(strstr(err.message, "\"mask\"") != NULL);
    ffd_mesh_destroy(mesh);
    snprintf(obj, sizeof obj, "%s#w 0\n#w 0.25\n", cube_obj);
    CHECK_OK(ffd_mesh_read_memory(obj, strlen(obj), FFD_FORMAT_OBJ, "cube.obj", &mesh, &err));
    CHECK(cube_deform(mesh, ", \"weights\": {\"attribute\": \"w\"}", out, &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "2 values for 8 vertices") != NULL);
    ffd_mesh_destroy(mesh);
    snprintf(obj, sizeof obj, "%s#w 0\n#w nan\n", cube_obj);
    CHECK_OK(ffd_mesh_read_memory(obj, strlen(obj), FFD_FORMAT_OBJ, "cube.obj", &mesh, &err));
    CHECK(cube_deform(mesh, ", \"weights\": {\"attribute\": \"w\"}", out, &err) != FFD_OK);
    CHECK(strstr(err.message, "mesh:16") != NULL);
    ffd_mesh_destroy(mesh);
}

static void test_weights_from_ply_property(void)
{
    static const double w[8] = {1, 0.5, 0, 0.25, 1, 0.5, 0, 0.25};
    const char *encodings[] = {"ascii", "binary_little_endian"};
    for (int e = 0; e < 2; e++) {
        char ply[2048];
        size_t len = (size_t)snprintf(ply, sizeof ply,
                                      "ply\nformat %s 1.0\nelement vertex 8\nproperty float x\n"
                                      "property float y\nproperty float z\nproperty double weight\n"
                                      "property uchar red\nelement face 6\n"
                                      "property list uchar int vertex_indices\nend_header\n",
                                      encodings[e]);
        static const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                        {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
        for (int i = 0; i < 8; i++) {
            float p[3] = {(float)(i & 1), (float)((i >> 1) & 1), (float)((i >> 2) & 1)};
            if (e == 0) {
                len += (size_t)snprintf(ply + len, sizeof ply - len, "%g %g %g %.17g 7\n", p[0],
                                        p[1], p[2], w[i]);
            } else {
                memcpy(ply + len, p, sizeof p);
                memcpy(ply + len + sizeof p, &w[i], sizeof w[i]);
                ply[len + sizeof p + sizeof w[i]] = 7;
                len += sizeof p + sizeof w[i] + 1;
            }
        }
        for (int f = 0; f < 6; f++) {
            if (e == 0) {
                len += (size_t)snprintf(ply + len, sizeof ply - len, "4 %d %d %d %d\n",
                                        quads[f][0], quads[f][1], quads[f][2], quads[f][3]);
            } else {
                ply[len++] = 4;
                memcpy(ply + len, quads[f], sizeof quads[f]);
                len += sizeof quads[f];
            }
        }
        ffd_mesh *mesh = NULL;
        ffd_error err = {{0}};
        CHECK_OK(ffd_mesh_read_memory(ply, len, FFD_FORMAT_PLY, "cube.ply", &mesh, &err));
        if (!mesh)
            continue;
        check_cube_weights(mesh, ", \"weights\": {\"attribute\": \"weight\"}", w);
        ffd_mesh_destroy(mesh);
    }
}

static void test_weights_file(void)
{
    static const double w[8] = {0.5, 0.5, 0, 0, 1, 1, 0.5, 0.5};
    char path[64] = "/tmp/ffd_weightsXXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd < 0)
        return;
    FILE *f = fdopen(fd, "w");
    fprintf(f, "# per vertex\n0.5\n0.5\n0\n0\n\n1\n1\n0.5\n0.5\n");
    fclose(f);
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read_memory(cube_obj, strlen(cube_obj), FFD_FORMAT_OBJ, "cube.obj", &mesh, &err));
    char extra[160];
    snprintf(extra, sizeof extra, ", \"weights\": {\"file\": \"%s\"}", path);
    check_cube_weights(mesh, extra, w);
    /* one weight too many, and a NaN: refused naming the file (and line) */
    f = fopen(path, "w");
    fprintf(f, "0\n0\n0\n0\n0\n0\n0\n0\n0\n");
    fclose(f);
    double out[24];
    CHECK(cube_deform(mesh, extra, out, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, path) && strstr(err.message, "9 weights for 8 vertices"));
    f = fopen(path, "w");
    fprintf(f, "0\n0\nnan\n");
    fclose(f);
    CHECK(cube_deform(mesh, extra, out, &err) == FFD_ERR_NONFINITE);
    char where[96];
    snprintf(where, sizeof where, "%s:3:", path);
    CHECK(strstr(err.message, where) != NULL);
    unlink(path);
    ffd_mesh_destroy(mesh);
}

/* ---- constrained FFD ---- */

/* Volume by the divergence theorem written as a sum over faces of
 * (1/3) centroid . area normal (fanned triangles). */
static double divergence_volume(const ffd_mesh *mesh, const double *x)
{
    const uint32_t *off = ffd_mesh_face_offsets(mesh), *idx = ffd_mesh_face_indices(mesh);
    double v = 0;
    for (size_t f = 0; f < ffd_mesh_face_count(mesh); f++)
        for (uint32_t k = off[f] + 1; k + 1 < off[f + 1]; k++) {
            const double *a = x + 3 * idx[off[f]], *b = x + 3 * idx[k], *c = x + 3 * idx[k + 1];
            double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
            double w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            double nrm[3] = {0.5 * (u[1] * w[2] - u[2] * w[1]), 0.5 * (u[2] * w[0] - u[0] * w[2]),
                             0.5 * (u[0] * w[1] - u[1] * w[0])};
            for (int d = 0; d < 3; d++)
                v += (a[d] + b[d] + c[d]) / 3.0 * nrm[d] / 3.0;
        }
    return v;
}

static void test_preserve_volume_and_barycentre(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh);
    const double *rest = ffd_mesh_positions(mesh);
    double v0 = divergence_volume(mesh, rest), b0[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            b0[a] += rest[3 * i + a] / (double)n;
    double diag = diagonal(rest, n);
    ffd_error err = {{0}};
    ffd_deformer *plain = make_with(EARS, mesh, "{}", &err);
    ffd_deformer *d = make_with(EARS, mesh, "{\"preserve\": [\"volume\", \"barycentre\"]}", &err);
    CHECK(plain && d);
    if (plain && d) {
        double *xp = eval_all(plain), *x = eval_all(d);
        CHECK(fabs(divergence_volume(mesh, xp) - v0) > 1e-3 * fabs(v0)); /* the ears change it */
        CHECK_NEAR(divergence_volume(mesh, x), v0, 1e-12 * fabs(v0));
        double b[3] = {0, 0, 0};
        for (size_t i = 0; i < n; i++)
            for (int a = 0; a < 3; a++)
                b[a] += x[3 * i + a] / (double)n;
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(b[a], b0[a], 1e-12 * diag);
        /* the report names the constraints' residual and the change */
        char *rep = NULL;
        CHECK_OK(ffd_deformer_report(d, &rep, NULL, &err));
        cJSON *r = rep ? cJSON_Parse(rep) : NULL;
        cJSON *c = cJSON_GetObjectItem(cJSON_GetObjectItem(r, "layers"), "constraints");
        CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(c, "count")) == 4);
        CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(c, "max_residual")) <= 1e-12);
        CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(c, "change_norm")) > 0);
        cJSON_Delete(r);
        ffd_free(rep);
        /* the rig of the deformer replays to the same positions */
        char *json = NULL;
        size_t size = 0;
        ffd_deformer *again = NULL;
        CHECK_OK(ffd_deformer_rig(d, &json, &size, &err));
        CHECK(json && strstr(json, "\"preserve\""));
        CHECK_OK(ffd_deformer_create_json(json, size, "again", mesh, NULL, &again, &err));
        if (again) {
            double *y = eval_all(again);
            CHECK(max_diff(x, y, 3 * n) <= 1e-12 * diag);
            free(y);
        }
        ffd_deformer_destroy(again);
        ffd_free(json);
        /* a committed control move is constrained too */
        uint32_t id = 3;
        double dv[3] = {0, 0.2 * diag, 0};
        CHECK_OK(ffd_deformer_move_controls(d, &id, 1, dv, &err));
        double *z = eval_all(d);
        CHECK_NEAR(divergence_volume(mesh, z), v0, 1e-12 * fabs(v0));
        free(z);
        free(xp);
        free(x);
    }
    ffd_deformer_destroy(plain);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* One linear constraint a . X = b over the points: the projection is
 * P = P_req + (b - a . X_req) g / |g|^2, g = W^T a (the closed form). */
static void test_linear_constraint_closed_form(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh);
    ffd_error err = {{0}};
    ffd_deformer *plain = make_with(BEND, mesh, "{}", &err);
    /* 0.5 x_10 + 2 y_900 - z_1500 = 0.3 */
    const char *extra = "{\"linear_constraints\": [{\"terms\": [[10, 0, 0.5], [900, 1, 2], "
                        "[1500, 2, -1]], \"value\": 0.3}]}";
    ffd_deformer *d = make_with(BEND, mesh, extra, &err);
    CHECK(plain && d);
    if (plain && d) {
        size_t nc = ffd_deformer_control_count(plain);
        double *xr = eval_all(plain), *preq = malloc(3 * nc * sizeof *preq);
        double *p = malloc(3 * nc * sizeof *p);
        ffd_deformer_controls(plain, preq);
        ffd_deformer_controls(d, p);
        double ax = 0.5 * xr[3 * 10] + 2 * xr[3 * 900 + 1] - xr[3 * 1500 + 2];
        double *a = calloc(3 * n, sizeof *a), *g = malloc(3 * nc * sizeof *g);
        a[3 * 10] = 0.5;
        a[3 * 900 + 1] = 2;
        a[3 * 1500 + 2] = -1;
        CHECK_OK(ffd_deformer_sensitivity_transpose_product(plain, a, g, &err));
        double gg = 0;
        for (size_t j = 0; j < 3 * nc; j++)
            gg += g[j] * g[j];
        double worst = 0;
        for (size_t j = 0; j < 3 * nc; j++)
            worst = fmax(worst, fabs(p[j] - (preq[j] + (0.3 - ax) * g[j] / gg)));
        CHECK(worst <= 1e-12);
        double *x = eval_all(d);
        CHECK_NEAR(0.5 * x[3 * 10] + 2 * x[3 * 900 + 1] - x[3 * 1500 + 2], 0.3, 1e-12);
        free(x);
        free(a);
        free(g);
        free(xr);
        free(preq);
        free(p);
    }
    ffd_deformer_destroy(plain);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* A constraint over the controls, with a mask: only z of controls 0..4 may
 * change; the projection spreads the change over those. */
static void test_control_constraint_and_mask(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    ffd_error err = {{0}};
    ffd_deformer *plain = make_with(BEND, mesh, "{}", &err);
    const char *extra =
        "{\"linear_constraints\": [{\"over\": \"controls\", \"terms\": [[0, 2, 1], [1, 2, 1], "
        "[7, 2, 1]], \"value\": 0}], \"constraint_mask\": {\"axes\": [false, false, true], "
        "\"controls\": [0, 1, 2, 3, 4]}}";
    ffd_deformer *d = make_with(BEND, mesh, extra, &err);
    CHECK(plain && d);
    if (plain && d) {
        size_t nc = ffd_deformer_control_count(plain);
        double *preq = malloc(3 * nc * sizeof *preq), *p = malloc(3 * nc * sizeof *p);
        ffd_deformer_controls(plain, preq);
        ffd_deformer_controls(d, p);
        /* closed form over the free coordinates z_0, z_1 (z_7 is fixed) */
        double r = -(preq[2] + preq[5] + preq[23]);
        for (size_t j = 0; j < 3 * nc; j++) {
            double want = preq[j] + ((j == 2 || j == 5) ? r / 2 : 0);
            CHECK_NEAR(p[j], want, 1e-14 * (1 + fabs(want)));
        }
        CHECK_NEAR(p[2] + p[5] + p[23], 0, 1e-14);
        free(preq);
        free(p);
    }
    /* a mask that frees nothing the constraint sees: refused */
    ffd_deformer *none = make_with(
        BEND, mesh,
        "{\"linear_constraints\": [{\"over\": \"controls\", \"terms\": [[7, 2, 1]], \"value\": 0}],"
        " \"constraint_mask\": {\"controls\": [0]}}",
        &err);
    CHECK(none == NULL);
    CHECK(strstr(err.message, "constraint_mask") != NULL);
    ffd_deformer_destroy(plain);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* ---- fold policy ---- */

/* An interior control pushed through its neighbour folds the lattice. */
#define FOLDING_MOVE                                                                              \
    "{\"deformer\": \"lattice\", \"basis\": \"bspline\", \"resolution\": [4, 4, 4], "           \
    "\"moves\": [{\"index\": [1, 1, 1], \"delta\": [%g, 0, 0]}]%s}"

static ffd_status fold_deformer(const ffd_mesh *mesh, double dx, const char *extra,
                                ffd_deformer **d, ffd_error *err)
{
    char text[512];
    snprintf(text, sizeof text, FOLDING_MOVE, dx, extra);
    return ffd_deformer_create_json(text, strlen(text), "fold.json", mesh, NULL, d, err);
}

static size_t folded_cells(ffd_deformer *d)
{
    ffd_fold_report r;
    ffd_error err = {{0}};
    CHECK_OK(ffd_deformer_fold_check(d, &r, &err));
    size_t k = r.folded;
    ffd_fold_report_free(&r);
    return k;
}

static void test_fold_policy(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    double diag = diagonal(ffd_mesh_positions(mesh), ffd_mesh_vertex_count(mesh));
    double big = 0.9 * diag;
    ffd_deformer *d = NULL;
    ffd_error err = {{0}};
    CHECK_OK(fold_deformer(mesh, big, "", &d, &err));
    CHECK(d && folded_cells(d) > 0); /* the move folds without a policy */
    ffd_deformer_destroy(d);
    d = NULL;
    CHECK(fold_deformer(mesh, big, ", \"fold_policy\": \"refuse\"", &d, &err) == FFD_ERR_INVALID);
    CHECK(d == NULL && strstr(err.message, "fold_policy") != NULL);
    CHECK_OK(fold_deformer(mesh, big, ", \"fold_policy\": \"shorten\"", &d, &err));
    if (d) {
        CHECK(folded_cells(d) == 0);
        double p[3 * 64];
        CHECK(ffd_deformer_control_count(d) == 64);
        ffd_deformer_controls(d, p);
        /* control (1,1,1) = 1 + 4 (1 + 4 * 1) = 21: moved, but less than asked */
        ffd_deformer *rest = NULL;
        CHECK_OK(fold_deformer(mesh, 0, "", &rest, &err));
        double p0[3 * 64];
        ffd_deformer_controls(rest, p0);
        double moved = p[3 * 21] - p0[3 * 21];
        CHECK(moved > 0.05 * big && moved < big);
        ffd_deformer_destroy(rest);
        /* a control move that would fold is shortened */
        uint32_t id = 42;
        double dv[3] = {-big, -big, 0};
        CHECK_OK(ffd_deformer_move_controls(d, &id, 1, dv, &err));
        CHECK(folded_cells(d) == 0);
    }
    ffd_deformer_destroy(d);
    d = NULL;
    /* refuse: a small move is made; a folding one is refused and changes nothing */
    CHECK_OK(fold_deformer(mesh, 0.01 * diag, ", \"fold_policy\": \"refuse\"", &d, &err));
    if (d) {
        double before[3 * 64], after[3 * 64];
        ffd_deformer_controls(d, before);
        uint32_t id = 21;
        double dv[3] = {big, 0, 0};
        CHECK(ffd_deformer_move_controls(d, &id, 1, dv, &err) == FFD_ERR_INVALID);
        CHECK(strstr(err.message, "refuse") != NULL);
        ffd_deformer_controls(d, after);
        CHECK(memcmp(before, after, sizeof before) == 0);
        CHECK(folded_cells(d) == 0);
    }
    ffd_deformer_destroy(d);
    /* a method without a fold check refuses the key */
    d = make_with(EX "pbffd/cow-drag.json", mesh, "{\"fold_policy\": \"shorten\"}", &err);
    CHECK(d == NULL && strstr(err.message, "no fold check") != NULL);
    ffd_mesh_destroy(mesh);
}

/* The editor's drags go through the same policy: a folding drag step is
 * refused (a conflict) and the controls stay at the last step; shortened,
 * the step is made in part and nothing folds. */
static void test_session_drag_fold_policy(void)
{
    const char *policies[] = {"refuse", "shorten"};
    for (int p = 0; p < 2; p++) {
        ffd_mesh *mesh = read_mesh(BUNNY);
        if (!mesh)
            return;
        double diag = diagonal(ffd_mesh_positions(mesh), ffd_mesh_vertex_count(mesh));
        ffd_session *s = NULL;
        ffd_error err = {{0}};
        CHECK_OK(ffd_session_create(mesh, "bunny.obj", NULL, &s, &err));
        if (!s) {
            ffd_mesh_destroy(mesh);
            continue;
        }
        char rig[256];
        snprintf(rig, sizeof rig,
                 "{\"deformer\": \"lattice\", \"resolution\": [4, 4, 4], \"fold_policy\": \"%s\"}",
                 policies[p]);
        CHECK_OK(ffd_session_load_rig(s, rig, strlen(rig), "rig.json", NULL, &err));
        void *reply = NULL;
        size_t size = 0;
        int binary = 0;
        const char *begin = "{\"points\": [21]}";
        CHECK_OK(ffd_session_command(s, "drag_begin", begin, strlen(begin), &reply, &size, &binary,
                                     &err));
        ffd_free(reply);
        char step[128];
        snprintf(step, sizeof step, "{\"delta\": [%.17g, 0, 0]}", 0.01 * diag);
        CHECK_OK(ffd_session_command(s, "drag", step, strlen(step), &reply, &size, &binary, &err));
        ffd_free(reply);
        reply = NULL;
        snprintf(step, sizeof step, "{\"delta\": [%.17g, 0, 0]}", 0.9 * diag);
        ffd_status st = ffd_session_command(s, "drag", step, strlen(step), &reply, &size, &binary,
                                            &err);
        ffd_free(reply);
        reply = NULL;
        if (p == 0) {
            CHECK(st == FFD_ERR_INVALID && strstr(err.message, "conflict: fold_policy"));
        } else {
            CHECK(st == FFD_OK);
        }
        CHECK_OK(ffd_session_command(s, "drag_end", "{}", 2, &reply, &size, &binary, &err));
        ffd_free(reply);
        /* the session's rig replays without a fold and names the policy */
        char *json = NULL;
        CHECK_OK(ffd_session_rig(s, &json, &size, &err));
        CHECK(json && strstr(json, policies[p]));
        ffd_mesh *copy = read_mesh(BUNNY);
        ffd_deformer *d = NULL;
        CHECK_OK(ffd_deformer_create_json(json, size, "session", copy, NULL, &d, &err));
        if (d) {
            CHECK(folded_cells(d) == 0);
            double p21[3 * 64], p0[3 * 64];
            ffd_deformer_controls(d, p21);
            CHECK_OK(ffd_deformer_reset(d, &err));
            ffd_deformer_controls(d, p0);
            double moved = p21[3 * 21] - p0[3 * 21];
            if (p == 0)
                CHECK_NEAR(moved, 0.01 * diag, 1e-12 * diag);
            else
                CHECK(moved > 0.01 * diag && moved < 0.9 * diag);
        }
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(copy);
        ffd_free(json);
        ffd_session_destroy(s);
    }
}

/* ---- rig apply, deformer and session agree ---- */

static void test_rig_apply_and_session_agree(void)
{
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    size_t n = ffd_mesh_vertex_count(mesh);
    char *w = weights_json(n, 0.75);
    cJSON *extra = cJSON_Parse(w);
    cJSON_free(w);
    cJSON *pres = cJSON_AddArrayToObject(extra, "preserve");
    cJSON_AddItemToArray(pres, cJSON_CreateString("volume"));
    char *extra_text = cJSON_PrintUnformatted(extra);
    cJSON_Delete(extra);
    char *text = rig_with(BEND, extra_text);
    ffd_error err = {{0}};
    ffd_deformer *d = NULL;
    CHECK_OK(ffd_deformer_create_json(text, strlen(text), BEND, mesh, NULL, &d, &err));
    ffd_rig *rig = NULL;
    CHECK_OK(ffd_rig_parse_json(text, strlen(text), BEND, &rig, &err));
    ffd_mesh *applied = read_mesh(BUNNY);
    ffd_rig_report report;
    CHECK_OK(ffd_rig_apply(rig, applied, &report, &err));
    double diag = diagonal(ffd_mesh_positions(mesh), n);
    if (d && applied) {
        double *x = eval_all(d);
        CHECK(max_diff(x, ffd_mesh_positions(applied), 3 * n) == 0);
        CHECK(report.details && strstr(report.details, "\"layers\""));
        CHECK_NEAR(divergence_volume(mesh, x), divergence_volume(mesh, ffd_mesh_positions(mesh)),
                   1e-12 * fabs(divergence_volume(mesh, ffd_mesh_positions(mesh))));
        /* the session loads the rig, shows the same positions and writes a rig
         * that replays to them */
        ffd_session *s = NULL;
        CHECK_OK(ffd_session_create(read_mesh(BUNNY), "bunny.obj", NULL, &s, &err));
        CHECK_OK(ffd_session_load_rig(s, text, strlen(text), "rig.json", NULL, &err));
        ffd_mesh *shown = NULL;
        CHECK_OK(ffd_session_deformed(s, &shown, &err));
        if (shown)
            CHECK(max_diff(x, ffd_mesh_positions(shown), 3 * n) <= 1e-12 * diag);
        char *json = NULL;
        size_t size = 0;
        CHECK_OK(ffd_session_rig(s, &json, &size, &err));
        CHECK(json && strstr(json, "\"weights\"") && strstr(json, "\"strength\""));
        ffd_mesh_destroy(shown);
        ffd_free(json);
        ffd_session_destroy(s);
        free(x);
    }
    ffd_rig_report_free(&report);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(applied);
    ffd_deformer_destroy(d);
    cJSON_free(text);
    cJSON_free(extra_text);
    ffd_mesh_destroy(mesh);
}

/* ---- bad input ---- */

static void test_bad_keys(void)
{
    static const struct {
        const char *extra, *message;
    } bad[] = {
        {"{\"strength\": \"half\"}", "strength"},
        {"{\"weights\": [1, 2]}", "weights"},
        {"{\"weights\": {\"attribute\": \"w\", \"file\": \"x\"}}", "weights"},
        {"{\"weights\": {\"values\": [1, null]}}", "weights.values[1]"},
        {"{\"preserve\": [\"area\"]}", "preserve[0]"},
        {"{\"preserve\": [\"volume\", \"volume\"]}", "given twice"},
        {"{\"linear_constraints\": [{\"terms\": [[0, 3, 1]], \"value\": 0}]}", "terms[0]"},
        {"{\"linear_constraints\": [{\"terms\": [], \"value\": 0}]}", "terms"},
        {"{\"linear_constraints\": [{\"terms\": [[0, 0, 1]]}]}", "value"},
        {"{\"constraint_mask\": {\"axes\": [true, true, true]}}", "nothing to constrain"},
        {"{\"fold_policy\": \"maybe\"}", "fold_policy"},
    };
    ffd_mesh *mesh = read_mesh(BUNNY);
    if (!mesh)
        return;
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        ffd_error err = {{0}};
        char *text = rig_with(BEND, bad[i].extra);
        ffd_rig *rig = NULL;
        ffd_status st = ffd_rig_parse_json(text, strlen(text), "bad.json", &rig, &err);
        CHECK(st != FFD_OK && rig == NULL);
        if (!strstr(err.message, bad[i].message)) {
            fprintf(stderr, "case %zu: %s\n", i, err.message);
            CHECK(0);
        }
        cJSON_free(text);
    }
    /* weights of the wrong count, a point index out of range */
    ffd_error err = {{0}};
    ffd_deformer *d = make_with(BEND, mesh, "{\"weights\": {\"values\": [1, 0.5]}}", &err);
    CHECK(d == NULL && strstr(err.message, "2 weights for 1839 vertices"));
    d = make_with(BEND, mesh,
                  "{\"linear_constraints\": [{\"terms\": [[5000, 0, 1]], \"value\": 0}]}", &err);
    CHECK(d == NULL && strstr(err.message, "point 5000 out of range"));
    ffd_mesh_destroy(mesh);
}

int main(int argc, char **argv)
{
    choose_cases();
    static const check_test tests[] = {
        {"identity_bitwise", test_identity_bitwise},
        {"weighted_blend", test_weighted_blend},
        {"scaled_jacobian_fd", test_scaled_jacobian_fd},
        {"scaled_rows_fd", test_scaled_rows_fd},
        {"weighted_direct_manipulation", test_weighted_direct_manipulation},
        {"weights_from_obj_comments", test_weights_from_obj_comments},
        {"weights_from_ply_property", test_weights_from_ply_property},
        {"weights_file", test_weights_file},
        {"preserve_volume_and_barycentre", test_preserve_volume_and_barycentre},
        {"linear_constraint_closed_form", test_linear_constraint_closed_form},
        {"control_constraint_and_mask", test_control_constraint_and_mask},
        {"fold_policy", test_fold_policy},
        {"session_drag_fold_policy", test_session_drag_fold_policy},
        {"rig_apply_and_session_agree", test_rig_apply_and_session_agree},
        {"bad_keys", test_bad_keys},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
