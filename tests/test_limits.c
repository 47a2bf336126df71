/* Tests of the limits on the work of a request (ffd_limits, docs/rig.md
 * "Limits"): the estimators against what the steps really make (cells of a
 * refinement, samples of a field), the budget's arithmetic and messages,
 * refusals of ffd_rig_apply_limited that leave the mesh unchanged, and an
 * editor session whose refused operation leaves it exactly as it was. */
#include "check.h"
#include "report_details.h"
#include "core/core.h"
#include "gffd/gffd.h"
#include "tspline/tsv.h"

#include <ffd.h>

static ffd_mesh *load(const char *name)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", FFD_SOURCE_DIR, name);
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read(path, &m, NULL));
    return m;
}

static ffd_tsv *make(const ffd_mesh *m, uint32_t r)
{
    uint32_t res[3] = {r, r, r};
    ffd_tsv *t = NULL;
    CHECK_OK(ffd_tsv_create(ffd_mesh_positions(m), ffd_mesh_vertex_count(m),
                            ffd_mesh_face_offsets(m), ffd_mesh_face_indices(m),
                            ffd_mesh_face_count(m), res, NULL, &t, NULL));
    return t;
}

/* Estimated cells of one edit against the cells it made. exact: the closure
 * adds no cell, so the two agree; else the estimate is a lower bound within
 * 25 % (the closure's extra splits). */
static void refine_and_compare(ffd_tsv *t, const ffd_tsv_insertion *ins, size_t count, int exact)
{
    tsv_estimate e;
    ffd_tsv_estimate_refine(t->L, ins, count, &e);
    CHECK_OK(ffd_tsv_refine(t, ins, count, NULL, NULL));
    double cells = (double)ffd_tsv_element_count(t, FFD_TSV_CELL);
    if (exact) {
        CHECK_NEAR(e.cells, cells, 0);
    } else {
        CHECK(e.cells <= cells);
        CHECK(cells <= 1.25 * e.cells);
    }
    CHECK(e.bytes > 0 && e.work > 0);
}

/* Every cell of nonzero volume, or those inside the proxy. */
static size_t thick_cells(const ffd_tsv *t, int proxy_only, ffd_tsv_insertion *out)
{
    size_t k = 0;
    for (size_t c = 0; c < t->L->nc; c++) {
        const tsv_cell *C = &t->L->cells[c];
        int thick = 1;
        for (int a = 0; a < 3; a++)
            thick &= tsv_kappa(C->hi[a]) > tsv_kappa(C->lo[a]);
        if (thick && (!proxy_only || !C->outside))
            out[k++] = (ffd_tsv_insertion){FFD_TSV_CELL, (uint32_t)c, 0};
    }
    return k;
}

static void test_estimate_refine_cells(void)
{
    ffd_mesh *m = load("examples/tspline/bunny.obj");
    ffd_tsv_insertion ins[4096];
    /* a uniform split of every cell: nothing for the closure to add */
    ffd_tsv *t = make(m, 5);
    size_t k = thick_cells(t, 0, ins);
    CHECK(k == 8);
    refine_and_compare(t, ins, k, 1);
    /* a second uniform split (64 -> 512 thick cells) */
    k = thick_cells(t, 0, ins);
    CHECK(k == 64);
    refine_and_compare(t, ins, k, 1);
    ffd_tsv_destroy(t);
    /* a face or edge insertion makes no cell of its own */
    t = make(m, 6);
    ffd_tsv_insertion mixed[2] = {{FFD_TSV_FACE, 3, 0}, {FFD_TSV_EDGE, 7, 0}};
    tsv_estimate e;
    ffd_tsv_estimate_refine(t->L, mixed, 2, &e);
    CHECK_NEAR(e.cells, (double)t->L->nc, 0);
    ffd_tsv_destroy(t);
    /* proxy refinements (the Fig. 6-7 octree split): the closure adds a few */
    t = make(m, 6);
    for (int round = 0; round < 2; round++) {
        k = thick_cells(t, 1, ins);
        CHECK(k > 0 && k < 4096);
        refine_and_compare(t, ins, k, 0);
    }
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

/* The sample bound of each kind against the samples the rules place. */
static void test_estimate_samples(void)
{
    double pt[3] = {0.5, 0.25, 1};
    double line[9] = {0, 0, 0, 3, 0, 0, 3, 2.5, 0};
    double quad[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    uint32_t offsets[2] = {0, 4}, corners[4] = {0, 1, 2, 3}, tris[6] = {0, 1, 2, 0, 2, 3};
    struct {
        ffd_gffd_primitive p;
        ffd_gffd_geometry g;
        int exact;
    } cases[] = {
        {{FFD_GFFD_POINT, pt, 1, NULL, NULL, 0, 0.5}, {FFD_GFFD_POINT, 1, pt, 0, NULL, 0.5}, 1},
        {{FFD_GFFD_POLYLINE, line, 3, NULL, NULL, 0, 0.4},
         {FFD_GFFD_POLYLINE, 3, line, 0, NULL, 0.4}, 1},
        {{FFD_GFFD_PATCH, quad, 4, offsets, corners, 1, 0.3}, {FFD_GFFD_PATCH, 4, quad, 2, tris, 0.3},
         1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        double *samples = NULL, *values = NULL;
        size_t count = 0;
        CHECK_OK(ffd_gffd_samples(&cases[i].g, 0, &samples, &values, &count, NULL));
        double est = ffd_gffd_estimate_samples(&cases[i].p, 0);
        if (getenv("LIMITS_VERBOSE"))
            fprintf(stderr, "case %zu: estimate %g, samples %zu\n", i, est, count);
        if (cases[i].exact)
            CHECK_NEAR(est, (double)count, 0);
        else
            CHECK(est >= (double)count);
        CHECK_NEAR(ffd_gffd_estimate_samples(&cases[i].p, 10), 10, 0); /* capped */
        ffd_free(samples);
        ffd_free(values);
    }
    double bytes, work;
    ffd_gffd_estimate_fit(20000, 0, &bytes, &work);
    CHECK(bytes > 3.2e9 && bytes < 3.3e9); /* (m+4)^2 doubles */
    CHECK(work > 2.6e11);
}

static void test_budget(void)
{
    ffd_budget b;
    ffd_error err = {{0}};
    ffd_budget_init(&b, NULL);
    CHECK_NEAR(b.max_memory, 2147483648.0, 0);
    CHECK_NEAR(b.max_work, 3e10, 0);
    CHECK_OK(ffd_budget_charge(&b, 1e9, 2e10, &err, "first"));
    /* over the work left: refused, nothing charged */
    CHECK(ffd_budget_charge(&b, 1e3, 2e10, &err, "steps[%d].refine", 2) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "steps[2].refine: that is about 2e+10 operations more (work limit "
                              "3e+10") != NULL);
    CHECK_NEAR(b.work, 2e10, 0);
    CHECK(ffd_budget_charge(&b, 3e9, 0, &err, "big") == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "big: that needs about 3 GB of memory (limit 2 GiB;") != NULL);
    ffd_limits l = {.max_memory = (size_t)512 << 20};
    ffd_budget_init(&b, &l);
    CHECK(ffd_budget_charge(&b, 6e8, 0, &err, "x") == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "(limit 512 MiB;") != NULL);
    l.unlimited = 1;
    ffd_budget_init(&b, &l);
    CHECK_OK(ffd_budget_charge(&b, 1e30, 1e30, &err, "anything"));
    char buf[32];
    CHECK(strcmp(ffd_format_count(2400000, buf, sizeof buf), "2,400,000") == 0);
    CHECK(strcmp(ffd_format_count(999, buf, sizeof buf), "999") == 0);
    CHECK(strcmp(ffd_format_count(1000, buf, sizeof buf), "1,000") == 0);
}

/* ffd_rig_apply refuses with the defaults; the mesh is untouched; a raised
 * limit lets the same rig through. */
static void test_rig_refused_mesh_unchanged(void)
{
    static const char fold[] = "{\"version\": 1, \"deformer\": \"tspline\", \"fold_samples\": 64}";
    static const char refine[] =
        "{\"version\": 1, \"deformer\": \"tspline\", \"resolution\": [5, 5, 5], \"steps\": "
        "[{\"refine\": [{\"cells\": \"proxy\"}]}, {\"refine\": [{\"cells\": \"proxy\"}]}]}";
    ffd_mesh *m = load("examples/tspline/bunny.obj");
    size_t n = ffd_mesh_vertex_count(m);
    double *before = malloc(n * 3 * sizeof(double));
    memcpy(before, ffd_mesh_positions(m), n * 3 * sizeof(double));
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_rig_parse_json(fold, sizeof fold - 1, "fold.json", &rig, NULL));
    double t0 = ffd_now();
    CHECK(ffd_rig_apply(rig, m, NULL, &err) == FFD_ERR_INVALID);
    CHECK(ffd_now() - t0 < 5); /* refused before the check, not after */
    CHECK(strstr(err.message, "fold.json: fold_samples: 64: the fold check of") != NULL);
    CHECK(memcmp(before, ffd_mesh_positions(m), n * 3 * sizeof(double)) == 0);
    ffd_rig_destroy(rig);
    rig = NULL;
    CHECK_OK(ffd_rig_parse_json(refine, sizeof refine - 1, "refine.json", &rig, NULL));
    ffd_limits small = {.max_memory = (size_t)4 << 20};
    CHECK(ffd_rig_apply_limited(rig, m, &small, NULL, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "refine.json: steps[1].refine: refining") != NULL);
    CHECK(strstr(err.message, "(limit 4 MiB;") != NULL);
    CHECK(memcmp(before, ffd_mesh_positions(m), n * 3 * sizeof(double)) == 0);
    ffd_rig_report report = {0};
    CHECK_OK(ffd_rig_apply_limited(rig, m, NULL, &report, NULL));
    CHECK(detail(&report, "refinements") == 2);
    ffd_rig_report_free(&report);
    ffd_rig_destroy(rig);
    free(before);
    ffd_mesh_destroy(m);
}

static ffd_status run(ffd_session *s, const char *op, const char *body, ffd_error *err)
{
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    ffd_status st = ffd_session_command(s, op, body, body ? strlen(body) : 0, &reply, &size,
                                        &binary, err);
    ffd_free(reply);
    return st;
}

/* The state without "busy_ms" (how long the last operation took). */
static void drop_busy(char *state)
{
    char *b = state ? strstr(state, "\"busy_ms\":") : NULL;
    if (!b)
        return;
    char *e = b + 10;
    while (*e && *e != ',' && *e != '}')
        e++;
    if (*e == ',')
        e++;
    memmove(b, e, strlen(e) + 1);
}

/* A refused refinement and a refused rig load leave the session as it was:
 * state (revision, undo depth, lattice), frame and rig. */
static void test_session_refusal_unchanged(void)
{
    ffd_mesh *m = load("examples/tspline/bunny.obj");
    ffd_session *s = NULL;
    ffd_session_options o = {.limits = {.max_memory = (size_t)4 << 20}};
    CHECK_OK(ffd_session_create(m, "bunny.obj", &o, &s, NULL));
    if (!s)
        return;
    ffd_error err = {{0}};
    CHECK_OK(run(s, "create", "{\"method\": \"tspline\", \"resolution\": [5, 5, 5]}", &err));
    CHECK_OK(run(s, "refine", "{\"insertions\": [{\"cells\": \"proxy\"}]}", &err));
    char *state0 = NULL, *rig0 = NULL, *state1 = NULL, *rig1 = NULL;
    void *frame0 = NULL, *frame1 = NULL;
    size_t n0 = 0, n1 = 0, f0 = 0, f1 = 0, r0 = 0, r1 = 0;
    CHECK_OK(ffd_session_state(s, &state0, &n0, NULL));
    CHECK_OK(ffd_session_frame(s, &frame0, &f0, NULL));
    CHECK_OK(ffd_session_rig(s, &rig0, &r0, NULL));
    /* 1,500 cells: about 12 MB estimated, over the session's 4 MiB */
    CHECK(run(s, "refine", "{\"insertions\": [{\"cells\": \"proxy\"}]}", &err) ==
          FFD_ERR_INVALID);
    CHECK(strstr(err.message, "refine: refining") != NULL);
    CHECK(strstr(err.message, "(limit 4 MiB;") != NULL);
    /* a rig load that would need the same */
    static const char rig[] =
        "{\"version\": 1, \"deformer\": \"tspline\", \"resolution\": [5, 5, 5], \"steps\": "
        "[{\"refine\": [{\"cells\": \"proxy\"}]}, {\"refine\": [{\"cells\": \"proxy\"}]}]}";
    CHECK(ffd_session_load_rig(s, rig, sizeof rig - 1, "big.json", NULL, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "(limit 4 MiB;") != NULL);
    CHECK_OK(ffd_session_state(s, &state1, &n1, NULL));
    CHECK_OK(ffd_session_frame(s, &frame1, &f1, NULL));
    CHECK_OK(ffd_session_rig(s, &rig1, &r1, NULL));
    drop_busy(state0);
    drop_busy(state1);
    CHECK(state0 && state1 && strcmp(state0, state1) == 0);
    if (getenv("LIMITS_VERBOSE"))
        fprintf(stderr, "%s\n%s\n", state0, state1);
    CHECK(f0 == f1 && frame0 && frame1 && memcmp(frame0, frame1, f0) == 0);
    CHECK(r0 == r1 && rig0 && rig1 && strcmp(rig0, rig1) == 0);
    /* and it still works */
    CHECK_OK(run(s, "undo", NULL, &err));
    ffd_free(state0);
    ffd_free(state1);
    ffd_free(frame0);
    ffd_free(frame1);
    ffd_free(rig0);
    ffd_free(rig1);
    ffd_session_destroy(s);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"estimate_refine_cells", test_estimate_refine_cells},
        {"estimate_samples", test_estimate_samples},
        {"budget", test_budget},
        {"rig_refused_mesh_unchanged", test_rig_refused_mesh_unchanged},
        {"session_refusal_unchanged", test_session_refusal_unchanged},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
