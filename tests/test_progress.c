/* Tests of the progress hook (ffd_set_progress): for a PB-FFD placement and a
 * T-spline set-up (and the mesh read before them) every stage reports 0
 * first, then growing fractions, and 1 exactly once at its end; reports come
 * at most about 20 times a second, from the calling thread, never from an
 * OpenMP worker; no hook, no calls; a failing stage does not report 1. */
#include "check.h"
#include "ffd.h"

#include <omp.h>
#include <string.h>
#include <time.h>

#define MAX_EVENTS 4096

typedef struct event {
    const char *stage;
    double fraction;
    int thread; /* omp_get_thread_num() at the call */
    int in_parallel;
} event;

typedef struct recorder {
    event events[MAX_EVENTS];
    size_t count;
} recorder;

static void record(void *user, const char *stage, double fraction)
{
    recorder *r = user;
    if (r->count < MAX_EVENTS)
        r->events[r->count++] = (event){stage, fraction, omp_get_thread_num(), omp_in_parallel()};
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Checks the reports of stage in r: 0 first, non-decreasing, one 1 at the
 * end, no more than the rate allows over seconds; returns how many. */
static size_t check_stage(const recorder *r, const char *stage, double seconds)
{
    size_t n = 0, ones = 0;
    double last = -1;
    for (size_t i = 0; i < r->count; i++) {
        const event *e = &r->events[i];
        if (strcmp(e->stage, stage) != 0)
            continue;
        CHECK(e->thread == 0 && !e->in_parallel);
        if (n == 0)
            CHECK(e->fraction == 0);
        CHECK(e->fraction >= last && e->fraction >= 0 && e->fraction <= 1);
        if (e->fraction == 1)
            ones++;
        else
            CHECK(ones == 0); /* nothing after the 1 */
        last = e->fraction;
        n++;
    }
    if (n == 0)
        fprintf(stderr, "stage '%s' never reported\n", stage);
    CHECK(n >= 2);
    CHECK(ones == 1);
    CHECK(last == 1);
    /* begin, end, and at most one report per 0.05 s between them */
    CHECK((double)n <= 2 + seconds / 0.05 + 1);
    return n;
}

static ffd_mesh *load(const char *relative)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", FFD_SOURCE_DIR, relative);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &m, &err) != FFD_OK) {
        fprintf(stderr, "%s\n", err.message);
        CHECK(!"cannot read a test mesh");
    }
    return m;
}

static recorder rec;

static void test_placement_progress(void)
{
    memset(&rec, 0, sizeof rec);
    ffd_set_progress(record, &rec);
    double t0 = now();
    ffd_mesh *m = load("examples/pbffd/elephant.off");
    ffd_ebf *controls = NULL;
    size_t count = 0;
    if (m)
        CHECK_OK(ffd_pbffd_place(m, NULL, &controls, &count, NULL, NULL));
    double seconds = now() - t0;
    ffd_set_progress(NULL, NULL);
    check_stage(&rec, "reading", seconds);
    check_stage(&rec, "placement", seconds);
    ffd_free(controls);
    ffd_mesh_destroy(m);
}

static void test_tspline_progress(void)
{
    memset(&rec, 0, sizeof rec);
    ffd_set_progress(record, &rec);
    ffd_mesh *m = load("examples/pbffd/cow.off");
    double t0 = now();
    uint32_t res[3] = {6, 6, 6};
    ffd_tsv *t = NULL;
    if (m)
        CHECK_OK(ffd_tsv_create(ffd_mesh_positions(m), ffd_mesh_vertex_count(m),
                                ffd_mesh_face_offsets(m), ffd_mesh_face_indices(m),
                                ffd_mesh_face_count(m), res, NULL, &t, NULL));
    uint32_t handle = 0;
    ffd_tsv_arap *arap = NULL;
    if (t)
        CHECK_OK(ffd_tsv_arap_begin(t, &handle, 1, NULL, &arap, NULL));
    double seconds = now() - t0;
    ffd_set_progress(NULL, NULL);
    check_stage(&rec, "T-spline set-up", seconds);
    check_stage(&rec, "ARAP", seconds);
    ffd_tsv_arap_destroy(arap);
    ffd_tsv_destroy(t);
    ffd_mesh_destroy(m);
}

static void test_no_hook_no_calls(void)
{
    memset(&rec, 0, sizeof rec);
    ffd_set_progress(record, &rec);
    ffd_set_progress(NULL, &rec); /* removed */
    ffd_mesh *m = load("tests/data/rig/cube.obj");
    CHECK(rec.count == 0);
    ffd_mesh_destroy(m);
}

static void test_failed_stage_has_no_end(void)
{
    memset(&rec, 0, sizeof rec);
    ffd_set_progress(record, &rec);
    ffd_mesh *m = NULL;
    const char bad[] = "v 0 0 0\nf 1 2 3\n"; /* face index out of range */
    CHECK(ffd_mesh_read_memory(bad, sizeof bad - 1, FFD_FORMAT_OBJ, "bad.obj", &m, NULL) ==
          FFD_ERR_RANGE);
    ffd_set_progress(NULL, NULL);
    CHECK(m == NULL);
    CHECK(rec.count == 1 && rec.events[0].fraction == 0);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"placement_progress", test_placement_progress},
        {"tspline_progress", test_tspline_progress},
        {"no_hook_no_calls", test_no_hook_no_calls},
        {"failed_stage_has_no_end", test_failed_stage_has_no_end},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
