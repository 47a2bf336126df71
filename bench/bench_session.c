/* bench_session — the editor's drag step without the network and the
 * browser: one `drag` op through ffd_session_command (solve, evaluate,
 * encode the float32 frame) on refined_elephant.off subdivided and cut to
 * 100K vertices, for each method. bench/editor_drag.mjs measures the same
 * step through HTTP and the page.
 *
 * usage: bench_session [DATA_DIR] [--write MESH.ply] [--steps N]
 * DATA_DIR: where refined_elephant.off is; default the repository's data/.
 * --write: also writes the 100K mesh (binary PLY) for editor_drag.mjs. */
#include "ffd.h"
#include "bench_mesh.h"
#include "bench_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static int command(ffd_session *s, const char *op, const char *body, double *ms)
{
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    ffd_error err = {{0}};
    double t0 = now();
    ffd_status st = ffd_session_command(s, op, body, strlen(body), &reply, &size, &binary, &err);
    if (ms)
        *ms = 1e3 * (now() - t0);
    ffd_free(reply);
    if (st)
        fprintf(stderr, "%s %s: %s\n", op, body, err.message);
    return st != FFD_OK;
}

/* Runs `create`, `drag_begin`, then steps drag steps; prints median and p90. */
static int measure(ffd_session *s, const char *label, const char *create, const char *begin,
                   int vertex_drag, int steps)
{
    double setup = 0, start = 0;
    if (command(s, "create", create, &setup) || command(s, "drag_begin", begin, &start))
        return 1;
    double *t = malloc(steps * sizeof *t);
    for (int i = 0; i < steps; i++) {
        char body[128];
        double a = 0.002 * (i + 1);
        if (vertex_drag)
            snprintf(body, sizeof body, "{\"target\":[%g,%g,%g]}", 0.1 + a, 0.2 + a, 0.05);
        else
            snprintf(body, sizeof body, "{\"delta\":[%g,%g,0]}", a, a / 2);
        if (command(s, "drag", body, &t[i])) {
            free(t);
            return 1;
        }
    }
    command(s, "drag_end", "{}", NULL);
    qsort(t, steps, sizeof *t, bench_cmp_double);
    printf("| %s | %.0f | %.1f | %.2f | %.2f | %.0f |\n", label, setup, start, t[steps / 2],
           t[steps * 9 / 10], 1e3 / t[steps / 2]);
    free(t);
    return 0;
}

int main(int argc, char **argv)
{
    char data_dir[1024];
    const char *dir = bench_data_dir(data_dir, sizeof data_dir), *write = NULL;
    int steps = 60;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--write") && i + 1 < argc)
            write = argv[++i];
        else if (!strcmp(argv[i], "--steps") && i + 1 < argc)
            steps = atoi(argv[++i]);
        else
            dir = argv[i];
    }
    if (steps < 10)
        steps = 10;
    double *P;
    uint32_t *off, *idx;
    size_t nv, nf;
    ffd_error err = {{0}};
    if (bench_elephant(dir, 100000, &P, &nv, &off, &idx, &nf))
        return 1;
    ffd_mesh *big = NULL;
    if (ffd_mesh_create(P, nv, off, idx, nf, &big, &err) != FFD_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    free(P);
    free(off);
    free(idx);
    if (write) {
        ffd_write_options o = {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_LE, 0};
        if (ffd_mesh_write(big, write, &o, &err) != FFD_OK) {
            fprintf(stderr, "%s\n", err.message);
            return 1;
        }
    }
    ffd_session *s = NULL;
    if (ffd_session_create(big, "elephant-100k", NULL, &s, &err) != FFD_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    printf("%zu vertices, %zu triangles; %d drag steps per row\n\n", nv, nf, steps);
    printf("| drag | create ms | drag_begin ms | step median ms | step p90 ms | steps/s |\n");
    printf("|---|---|---|---|---|---|\n");
    int bad = 0;
    bad |= measure(s, "lattice 5x5x5, 8 control points", "{\"method\":\"lattice\"}",
                   "{\"points\":[0,1,5,6,25,26,30,31]}", 0, steps);
    bad |= measure(s, "lattice 8x8x8, 1 control point", "{\"method\":\"lattice\",\"resolution\":[8,8,8]}",
                   "{\"points\":[300]}", 0, steps);
    bad |= measure(s, "lattice 6x6x6, mesh point (direct manipulation)",
                   "{\"method\":\"lattice\",\"resolution\":[6,6,6]}", "{\"vertex\":1000}", 1, steps);
    bad |= measure(s, "T-spline 12x12x12, ARAP, 1 proxy point",
                   "{\"method\":\"tspline\",\"resolution\":[12,12,12]}", "{\"points\":[20]}", 0,
                   steps);
    bad |= measure(s, "PB-FFD 120 EBFs, 1 control point",
                   "{\"method\":\"pbffd\",\"interior\":60,\"exterior\":60}", "{\"points\":[3]}", 0,
                   steps);
    bad |= measure(s, "GFFD default polyline skeleton, 1 vertex (re-tracking)",
                   "{\"method\":\"gffd\"}", "{\"points\":[2]}", 0, 10);
    ffd_session_destroy(s);
    return bad;
}
