/* Tests for the public deformer interface (ffd.h "Deformers"), the same for
 * every method and written only against that interface: a deformer built
 * from each method's example rigs deforms the mesh as ffd_rig_apply does; a
 * second point set bound to it deforms as the same points would as vertices
 * of the mesh; the Jacobian and the linear map agree with finite
 * differences; control edits, reset (identity: the same bits), the report,
 * the method handle, the method's own operations, the rig of the state and
 * bad input. */
#include "check.h"
#include "check_deformer.h"

#include "ffd.h"

#include <cjson/cJSON.h>

/* The deformer on its mesh gives what ffd_rig_apply gives. */
static void test_matches_rig_apply(void)
{
    for (size_t c = 0; c < CASE_COUNT; c++) {
        ffd_mesh *mesh = read_mesh(case_table[c].mesh), *applied = read_mesh(case_table[c].mesh);
        ffd_rig *rig = NULL;
        ffd_error err = {{0}};
        CHECK(mesh && applied);
        if (!mesh || !applied)
            continue;
        CHECK_OK(ffd_rig_read(case_table[c].rig, &rig, &err));
        CHECK_OK(ffd_rig_apply(rig, applied, NULL, &err));
        ffd_deformer *d = make(&case_table[c], mesh);
        CHECK(d != NULL);
        if (d) {
            size_t n = ffd_mesh_vertex_count(mesh);
            CHECK(ffd_deformer_point_count(d) == n);
            CHECK(strcmp(ffd_deformer_method(d), case_table[c].method) == 0);
            double *out = malloc(3 * n * sizeof *out);
            CHECK_OK(ffd_deformer_eval(d, out, &err));
            check_agree(out, ffd_mesh_positions(applied), 3 * n,
                        diagonal(ffd_mesh_positions(mesh), n), case_table[c].rig,
                        "deformer vs rig_apply");
            free(out);
        }
        ffd_deformer_destroy(d);
        ffd_rig_destroy(rig);
        ffd_mesh_destroy(mesh);
        ffd_mesh_destroy(applied);
    }
}

/* A second point set: (1) the mesh's own vertices, permuted and repeated,
 * give exactly their rows; (2) points that are not vertices (face
 * centroids) give what the deformer built on the mesh with those points
 * appended as extra vertices gives them. */
static void test_second_point_set(void)
{
    for (size_t c = 0; c < CASE_COUNT; c++) {
        ffd_mesh *mesh = read_mesh(case_table[c].mesh);
        CHECK(mesh != NULL);
        if (!mesh)
            continue;
        ffd_deformer *d = make(&case_table[c], mesh);
        CHECK(d != NULL);
        if (!d) {
            ffd_mesh_destroy(mesh);
            continue;
        }
        ffd_error err = {{0}};
        const size_t n = ffd_mesh_vertex_count(mesh), f = ffd_mesh_face_count(mesh);
        const double *rest = ffd_mesh_positions(mesh);
        const double diag = diagonal(rest, n);
        double *full = malloc(3 * n * sizeof *full);
        CHECK_OK(ffd_deformer_eval(d, full, &err));

        /* (1) every third vertex backwards, then vertex 0 twice */
        size_t q = 0, *pick = malloc((n / 3 + 3) * sizeof *pick);
        for (size_t i = n; i-- > 0;)
            if (i % 3 == 0)
                pick[q++] = i;
        pick[q++] = 0;
        pick[q++] = 0;
        double *points = malloc(3 * q * sizeof *points), *out = malloc(3 * q * sizeof *out);
        for (size_t i = 0; i < q; i++)
            memcpy(points + 3 * i, rest + 3 * pick[i], 3 * sizeof *points);
        CHECK_OK(ffd_deformer_bind(d, points, q, &err));
        CHECK(ffd_deformer_point_count(d) == q);
        CHECK_OK(ffd_deformer_eval(d, out, &err));
        double worst = 0;
        for (size_t i = 0; i < q; i++)
            worst = fmax(worst, max_diff(out + 3 * i, full + 3 * pick[i], 3));
        if (worst > 1e-12 * diag)
            fprintf(stderr, "%s: vertices rebound: %.3g\n", case_table[c].rig, worst);
        CHECK(worst <= 1e-12 * diag);

        /* (2) face centroids, and the mesh with them as extra vertices */
        const uint32_t *off = ffd_mesh_face_offsets(mesh), *idx = ffd_mesh_face_indices(mesh);
        size_t m = f < 500 ? f : 500;
        double *all = malloc(3 * (n + m) * sizeof *all);
        memcpy(all, rest, 3 * n * sizeof *all);
        for (size_t j = 0; j < m; j++) {
            size_t face = j * f / m;
            double *p = all + 3 * (n + j);
            p[0] = p[1] = p[2] = 0;
            for (uint32_t k = off[face]; k < off[face + 1]; k++)
                for (int a = 0; a < 3; a++)
                    p[a] += rest[3 * (size_t)idx[k] + a] / (off[face + 1] - off[face]);
        }
        ffd_mesh *bigger = NULL;
        CHECK_OK(ffd_mesh_create(all, n + m, off, idx, f, &bigger, &err));
        ffd_deformer *e = bigger ? make(&case_table[c], bigger) : NULL;
        CHECK(e != NULL);
        if (e) {
            double *ref = malloc(3 * (n + m) * sizeof *ref), *got = malloc(3 * m * sizeof *got);
            CHECK_OK(ffd_deformer_eval(e, ref, &err));
            CHECK_OK(ffd_deformer_bind(d, all + 3 * n, m, &err));
            CHECK_OK(ffd_deformer_eval(d, got, &err));
            check_agree(got, ref + 3 * n, 3 * m, diag, case_table[c].rig,
                        "centroids vs as vertices");
            free(ref);
            free(got);
        }
        ffd_deformer_destroy(e);
        ffd_mesh_destroy(bigger);
        free(all);
        free(pick);
        free(points);
        free(out);
        free(full);
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(mesh);
    }
}

/* Jacobian against central differences of the evaluation. */
static void check_jacobian_fd(const rig_case *rc, const ffd_mesh *mesh, ffd_deformer *d)
{
    ffd_error err = {{0}};
    double points[3 * 40], jac[9 * 40], plus[3 * 40], minus[3 * 40], moved[3 * 40];
    size_t s = bind_sample(d, mesh, 40, points);
    double diag = diagonal(ffd_mesh_positions(mesh), ffd_mesh_vertex_count(mesh));
    ffd_status st = ffd_deformer_jacobian(d, jac, &err);
    if (st == FFD_ERR_UNSUPPORTED) {
        CHECK(strstr(err.message, "Jacobian") != NULL);
    } else {
        CHECK(st == FFD_OK);
        const double h = 1e-6 * diag;
        double worst = 0;
        for (int b = 0; b < 3; b++) {
            memcpy(moved, points, 3 * s * sizeof *moved);
            for (size_t i = 0; i < s; i++)
                moved[3 * i + b] += h;
            CHECK_OK(ffd_deformer_bind(d, moved, s, &err));
            CHECK_OK(ffd_deformer_eval(d, plus, &err));
            for (size_t i = 0; i < s; i++)
                moved[3 * i + b] -= 2 * h;
            CHECK_OK(ffd_deformer_bind(d, moved, s, &err));
            CHECK_OK(ffd_deformer_eval(d, minus, &err));
            for (size_t i = 0; i < s; i++)
                for (int a = 0; a < 3; a++) {
                    double fd = (plus[3 * i + a] - minus[3 * i + a]) / (2 * h);
                    worst = fmax(worst, fabs(fd - jac[9 * i + 3 * a + b]));
                }
        }
        if (worst > 1e-5)
            fprintf(stderr, "%s: Jacobian vs finite differences: %.3g\n", (*rc).rig, worst);
        CHECK(worst <= 1e-5);
    }
}

static void test_jacobian_fd(void)
{
    for_each_case(check_jacobian_fd);
}

/* The linear map's weights against differences of the evaluation when one
 * control moves (the map is linear in the controls: central differences
 * are exact up to rounding), for a sample of controls. */
static void check_linear_map_fd(const rig_case *rc, const ffd_mesh *mesh, ffd_deformer *d)
{
    ffd_error err = {{0}};
    double points[3 * 60];
    size_t s = bind_sample(d, mesh, 60, points);
    size_t count = ffd_deformer_control_count(d);
    ffd_linear_map map;
    ffd_status st = ffd_deformer_linear_map(d, &map, &err);
    if (st == FFD_ERR_UNSUPPORTED) {
        CHECK(strstr(err.message, "linear map") != NULL);
    } else if (st != FFD_OK || map.variable_count != count || map.point_count != s) {
        CHECK(st == FFD_OK);
        CHECK(map.variable_count == count);
        CHECK(map.point_count == s);
    } else {
        /* dense weights of the sampled points over the controls */
        double *w = calloc(s * count, sizeof *w);
        uint32_t *cols = malloc(map.max_row_nnz * sizeof *cols);
        double *wt = malloc(map.max_row_nnz * sizeof *wt);
        int tie_ok = 1;
        for (size_t i = 0; i < s; i++) {
            size_t nnz = map.row(map.self, i, cols, wt);
            for (size_t e = 0; e < nnz; e++) {
                uint32_t v = map.tie ? map.tie[cols[e]] : cols[e];
                if (v >= count) {
                    tie_ok = 0;
                    continue;
                }
                w[i * count + v] += wt[e];
            }
        }
        CHECK(tie_ok);
        double *ctl = malloc(3 * count * sizeof *ctl), plus[3 * 60], minus[3 * 60];
        ffd_deformer_controls(d, ctl);
        double diag = diagonal(ffd_mesh_positions(mesh), ffd_mesh_vertex_count(mesh));
        const double h = 1e-3 * diag;
        double worst = 0;
        size_t samples = getenv("FFD_TEST_QUICK") ? 6 : 25;
        size_t step = count / samples ? count / samples : 1;
        for (size_t j0 = 0; j0 < count; j0 += step) {
            uint32_t j = (uint32_t)j0;
            for (int a = 0; a < 3; a++) {
                double p[3];
                memcpy(p, ctl + 3 * j, sizeof p);
                p[a] += h;
                CHECK_OK(ffd_deformer_set_controls(d, &j, 1, p, &err));
                CHECK_OK(ffd_deformer_eval(d, plus, &err));
                p[a] -= 2 * h;
                CHECK_OK(ffd_deformer_set_controls(d, &j, 1, p, &err));
                CHECK_OK(ffd_deformer_eval(d, minus, &err));
                CHECK_OK(ffd_deformer_set_controls(d, &j, 1, ctl + 3 * j, &err));
                for (size_t i = 0; i < s; i++)
                    for (int b = 0; b < 3; b++) {
                        double fd = (plus[3 * i + b] - minus[3 * i + b]) / (2 * h);
                        double want = b == a ? w[i * count + j] : 0;
                        worst = fmax(worst, fabs(fd - want));
                    }
            }
        }
        if (worst > 1e-8)
            fprintf(stderr, "%s: linear map vs finite differences: %.3g\n", (*rc).rig,
                    worst);
        CHECK(worst <= 1e-8);
        free(w);
        free(cols);
        free(wt);
        free(ctl);
    }
}

static void test_linear_map_fd(void)
{
    for_each_case(check_linear_map_fd);
}

/* Controls: setting them where they are changes nothing; a move and its
 * opposite come back; reset is the identity, bit for bit. */
static void check_controls_and_reset(const rig_case *rc, const ffd_mesh *mesh, ffd_deformer *d)
{
    ffd_error err = {{0}};
    size_t n = ffd_mesh_vertex_count(mesh), count = ffd_deformer_control_count(d);
    const double *rest = ffd_mesh_positions(mesh);
    double diag = diagonal(rest, n);
    CHECK(count > 0);
    double *before = malloc(3 * n * sizeof *before), *after = malloc(3 * n * sizeof *after);
    double *ctl = malloc(3 * count * sizeof *ctl);
    CHECK_OK(ffd_deformer_eval(d, before, &err));
    ffd_deformer_controls(d, ctl);
    CHECK_OK(ffd_deformer_set_controls(d, NULL, count, ctl, &err));
    CHECK_OK(ffd_deformer_eval(d, after, &err));
    CHECK(max_diff(before, after, 3 * n) <= 1e-12 * diag);

    uint32_t id = (uint32_t)(count / 2);
    double delta[3] = {0.05 * diag, -0.02 * diag, 0.01 * diag};
    double back[3] = {-delta[0], -delta[1], -delta[2]};
    CHECK_OK(ffd_deformer_move_controls(d, &id, 1, delta, &err));
    double *moved = malloc(3 * count * sizeof *moved);
    ffd_deformer_controls(d, moved);
    CHECK_NEAR(moved[3 * id] - ctl[3 * id], delta[0], 1e-12 * diag);
    CHECK_OK(ffd_deformer_move_controls(d, &id, 1, back, &err));
    CHECK_OK(ffd_deformer_eval(d, after, &err));
    /* to rounding of the nonlinear methods: GFFD's gradient field comes back
     * to 1.3e-9 of the diagonal with some BLAS kernels */
    CHECK(max_diff(before, after, 3 * n) <= 1e-8 * diag);

    CHECK_OK(ffd_deformer_reset(d, &err));
    CHECK_OK(ffd_deformer_eval(d, after, &err));
    size_t differ = 0;
    for (size_t i = 0; i < 3 * n; i++)
        differ += after[i] != rest[i];
    if (differ)
        fprintf(stderr, "%s: reset: %zu coordinates differ from rest\n", (*rc).rig, differ);
    CHECK(differ == 0);
    free(before);
    free(after);
    free(ctl);
    free(moved);
}

static void test_controls_and_reset(void)
{
    for_each_case(check_controls_and_reset);
}

/* The report is JSON naming the method and the counts; the handle is the
 * method's own and no other method's. */
static void test_report_and_handle(void)
{
    static const char *const methods[] = {"lattice", "pbffd", "gffd", "tspline", "cage"};
    for (size_t c = 0; c < CASE_COUNT; c++) {
        ffd_mesh *mesh = read_mesh(case_table[c].mesh);
        ffd_deformer *d = mesh ? make(&case_table[c], mesh) : NULL;
        CHECK(d != NULL);
        if (!d) {
            ffd_mesh_destroy(mesh);
            continue;
        }
        ffd_error err = {{0}};
        char *json = NULL;
        size_t size = 0;
        CHECK_OK(ffd_deformer_report(d, &json, &size, &err));
        cJSON *root = json ? cJSON_ParseWithLength(json, size) : NULL;
        CHECK(root != NULL);
        const cJSON *method = cJSON_GetObjectItemCaseSensitive(root, "method");
        const cJSON *controls = cJSON_GetObjectItemCaseSensitive(root, "controls");
        const cJSON *count = cJSON_GetObjectItemCaseSensitive(controls, "count");
        const cJSON *points = cJSON_GetObjectItemCaseSensitive(root, "points");
        CHECK(cJSON_IsString(method) && strcmp(method->valuestring, case_table[c].method) == 0);
        CHECK(cJSON_IsNumber(count)
              && (size_t)count->valuedouble == ffd_deformer_control_count(d));
        CHECK(cJSON_IsNumber(points) && (size_t)points->valuedouble == ffd_mesh_vertex_count(mesh));
        CHECK(cJSON_IsObject(cJSON_GetObjectItemCaseSensitive(root, "params")));
        cJSON_Delete(root);
        ffd_free(json);
        for (size_t m = 0; m < sizeof methods / sizeof *methods; m++)
            CHECK((ffd_deformer_handle(d, methods[m]) != NULL)
                  == (strcmp(methods[m], case_table[c].method) == 0));
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(mesh);
    }
}

/* Bad input: a NaN point, an id out of range, a wrong count: refused, and
 * the deformer is as it was. */
static void test_bad_input(void)
{
    ffd_mesh *mesh = read_mesh(case_table[0].mesh);
    ffd_deformer *d = mesh ? make(&case_table[0], mesh) : NULL;
    CHECK(d != NULL);
    if (!d) {
        ffd_mesh_destroy(mesh);
        return;
    }
    ffd_error err = {{0}};
    size_t n = ffd_mesh_vertex_count(mesh), count = ffd_deformer_control_count(d);
    double *before = malloc(3 * n * sizeof *before), *after = malloc(3 * n * sizeof *after);
    CHECK_OK(ffd_deformer_eval(d, before, &err));
    double bad[6] = {0, 0, 0, 0, NAN, 0};
    CHECK(ffd_deformer_bind(d, bad, 2, &err) == FFD_ERR_NONFINITE);
    CHECK(strstr(err.message, "point 1") != NULL);
    CHECK(ffd_deformer_point_count(d) == n);
    uint32_t id = (uint32_t)count;
    double p[3] = {0, 0, 0};
    CHECK(ffd_deformer_set_controls(d, &id, 1, p, &err) == FFD_ERR_RANGE);
    CHECK(ffd_deformer_set_controls(d, NULL, 1, p, &err) == FFD_ERR_RANGE);
    double inf[3] = {0, INFINITY, 0};
    id = 0;
    CHECK(ffd_deformer_move_controls(d, &id, 1, inf, &err) == FFD_ERR_NONFINITE);
    CHECK_OK(ffd_deformer_eval(d, after, &err));
    CHECK(memcmp(before, after, 3 * n * sizeof *after) == 0);
    free(before);
    free(after);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* The method's own operations through the generic interface: a T-spline
 * refinement keeps the shape (the deformed points before and after agree)
 * and adds controls; an op of another method, a malformed body and a wrong
 * key are refused with nothing changed. */
static void test_command(void)
{
    const rig_case *tc = NULL;
    for (size_t c = 0; c < CASE_COUNT && !tc; c++)
        if (!strcmp(case_table[c].method, "tspline"))
            tc = &case_table[c];
    CHECK(tc != NULL);
    ffd_mesh *mesh = tc ? read_mesh(tc->mesh) : NULL;
    ffd_deformer *d = mesh ? make(tc, mesh) : NULL;
    CHECK(d != NULL);
    if (!d) {
        ffd_mesh_destroy(mesh);
        return;
    }
    ffd_error err = {{0}};
    size_t n = ffd_mesh_vertex_count(mesh), count = ffd_deformer_control_count(d);
    double *before = malloc(3 * n * sizeof *before), *after = malloc(3 * n * sizeof *after);
    CHECK_OK(ffd_deformer_eval(d, before, &err));
    static const char *const refused[][2] = {
        {"level", "{\"level\": 1}"},          /* PB-FFD's */
        {"refine", "{\"insertions\": ["},     /* malformed */
        {"refine", "{\"insertion\": []}"},    /* wrong key */
        {"refine", "[]"},                      /* not an object */
    };
    for (size_t i = 0; i < sizeof refused / sizeof *refused; i++) {
        ffd_status st = ffd_deformer_command(d, refused[i][0], refused[i][1],
                                             strlen(refused[i][1]), &err);
        CHECK(st == (i == 0 ? FFD_ERR_UNSUPPORTED : FFD_ERR_PARSE));
        CHECK(i != 0 || strstr(err.message, "\"refine\"") != NULL);
        CHECK(ffd_deformer_control_count(d) == count);
    }
    CHECK_OK(ffd_deformer_eval(d, after, &err));
    CHECK(memcmp(before, after, 3 * n * sizeof *after) == 0);
    const char *refine = "{\"insertions\": [{\"cells\": \"proxy\"}]}";
    CHECK_OK(ffd_deformer_command(d, "refine", refine, strlen(refine), &err));
    CHECK(ffd_deformer_control_count(d) > count);
    CHECK(ffd_deformer_point_count(d) == n);
    CHECK_OK(ffd_deformer_eval(d, after, &err));
    check_agree(after, before, 3 * n, diagonal(before, n), tc->rig, "refine changed the shape");
    free(before);
    free(after);
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(mesh);
}

/* ffd_deformer_rig: the rig it writes builds a deformer that deforms the
 * mesh as this one does now (after a control move), for every method. */
static void check_rig_round_trip(const rig_case *rc, const ffd_mesh *mesh, ffd_deformer *d)
{
    ffd_deformer *again = NULL;
    ffd_error err = {{0}};
    size_t n = ffd_mesh_vertex_count(mesh);
    uint32_t id = 0;
    double delta[3] = {0.01, -0.02, 0.015};
    CHECK_OK(ffd_deformer_move_controls(d, &id, 1, delta, &err));
    char *json = NULL;
    size_t size = 0;
    CHECK_OK(ffd_deformer_rig(d, &json, &size, &err));
    CHECK(json && size == strlen(json));
    if (json)
        CHECK_OK(ffd_deformer_create_json(json, size, rc->rig, mesh, NULL, &again, &err));
    if (again) {
        double *a = malloc(3 * n * sizeof *a), *b = malloc(3 * n * sizeof *b);
        CHECK_OK(ffd_deformer_eval(d, a, &err));
        CHECK_OK(ffd_deformer_eval(again, b, &err));
        check_agree(b, a, 3 * n, diagonal(a, n), rc->rig, "rebuilt from its rig");
        free(a);
        free(b);
    }
    ffd_free(json);
    ffd_deformer_destroy(again);
}

static void test_rig_round_trip(void)
{
    for_each_case(check_rig_round_trip);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"matches_rig_apply", test_matches_rig_apply},
        {"second_point_set", test_second_point_set},
        {"jacobian_fd", test_jacobian_fd},
        {"linear_map_fd", test_linear_map_fd},
        {"controls_and_reset", test_controls_and_reset},
        {"report_and_handle", test_report_and_handle},
        {"bad_input", test_bad_input},
        {"command", test_command},
        {"rig_round_trip", test_rig_round_trip},
    };
    choose_cases();
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
