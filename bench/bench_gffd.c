/* bench_gffd — GFFD (Qin et al. 2003) timings: building the skeleton's
 * fields and binding, and re-tracking after a skeleton edit, for 10^4, 10^5
 * and 10^6 influenced points and skeletons of 1, 10 and 50 primitives.
 *
 * The points lie on a tube of radius 1 around a chain of polylines along x
 * (length 10); every point is inside some primitive's influence. The edit
 * bends the chain: each primitive's vertices are lifted by 0.05 x^2 / 10,
 * so the field changes under every point. Usage: bench_gffd [max_points]
 * [--curve]: --curve prints only the 10^4 -> 10^6 points curve of 10
 * primitives (gradient tracking), medians of 5 rounds, time per point. */
#include "ffd.h"
#include "bench_util.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static double now(void)
{
    return omp_get_wtime();
}

static double lcg01(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) * (1.0 / 9007199254740992.0);
}

static double bend(double x)
{
    return 0.05 * x * x / 10;
}

/* Times of one run (seconds): fields + bind, edit, re-track. */
typedef struct timing {
    double bind, edit, track;
} timing;

static timing run(size_t n, size_t k, ffd_gffd_tracking mode, int quiet)
{
    const double len = 10, tube = 1;
    double *pts = malloc(n * 3 * sizeof(double));
    uint64_t seed = 42;
    for (size_t i = 0; i < n; i++) {
        double x = len * lcg01(&seed), a = 2 * M_PI * lcg01(&seed);
        pts[3 * i] = x;
        pts[3 * i + 1] = tube * cos(a);
        pts[3 * i + 2] = tube * sin(a);
    }
    /* k polylines of 3 vertices each, end to end along x */
    double *verts = malloc(k * 9 * sizeof(double)), *moved = malloc(k * 9 * sizeof(double));
    ffd_gffd_primitive *prims = calloc(k, sizeof *prims);
    for (size_t j = 0; j < k; j++) {
        for (int v = 0; v < 3; v++) {
            double x = len * (j + v / 2.0) / k;
            verts[9 * j + 3 * v] = x;
            verts[9 * j + 3 * v + 1] = 0;
            verts[9 * j + 3 * v + 2] = 0;
            moved[9 * j + 3 * v] = x;
            moved[9 * j + 3 * v + 1] = bend(x);
            moved[9 * j + 3 * v + 2] = 0;
        }
        prims[j].kind = FFD_GFFD_POLYLINE;
        prims[j].vertices = verts + 9 * j;
        prims[j].vertex_count = 3;
        prims[j].radius = 1.6;
    }
    ffd_gffd_options o = {0};
    o.tracking = mode;
    ffd_gffd *g = NULL;
    ffd_error err = {{0}};
    double t0 = now();
    if (ffd_gffd_create(prims, k, pts, n, &o, &g, &err) != FFD_OK) {
        fprintf(stderr, "create: %s\n", err.message);
        exit(1);
    }
    double t1 = now();
    for (size_t j = 0; j < k; j++)
        if (ffd_gffd_set_vertices(g, j, moved + 9 * j, &err) != FFD_OK) {
            fprintf(stderr, "edit: %s\n", err.message);
            exit(1);
        }
    double t2 = now();
    double *out = malloc(n * 3 * sizeof(double));
    ffd_gffd_track_report r;
    if (ffd_gffd_track(g, out, &r, &err) != FFD_OK) {
        fprintf(stderr, "track: %s\n", err.message);
        exit(1);
    }
    double t3 = now();
    timing tm = {t1 - t0, t2 - t1, t3 - t2};
    if (!quiet)
        printf("| %zu | %zu | %s | %zu | %.1f | %.1f | %.1f | %zu | %.1f |\n", n, k,
           mode == FFD_GFFD_TRACK_WARP ? "warp" : "gradient", ffd_gffd_influenced_count(g),
           1e3 * (t1 - t0), 1e3 * (t2 - t1), 1e3 * (t3 - t2), r.failed_count,
           r.tracked ? (double)r.iterations / (double)r.tracked : 0.0);
    fflush(stdout);
    ffd_gffd_track_report_free(&r);
    ffd_gffd_destroy(g);
    free(out);
    free(pts);
    free(verts);
    free(moved);
    free(prims);
    return tm;
}

static void curve(size_t max_points)
{
    static const size_t sizes[] = {10000, 30000, 100000, 300000, 1000000};
    enum { ROUNDS = 5 };
    printf("| points | primitives | fields + bind (ms) | ns/point | re-track (ms) | ns/point |\n");
    printf("|---:|---:|---:|---:|---:|---:|\n");
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0] && sizes[s] <= max_points; s++) {
        double b[ROUNDS], t[ROUNDS];
        for (int r = 0; r < ROUNDS; r++) {
            timing tm = run(sizes[s], 10, FFD_GFFD_TRACK_GRADIENT, 1);
            b[r] = tm.bind;
            t[r] = tm.track;
        }
        double mb = bench_median(b, ROUNDS), mt = bench_median(t, ROUNDS);
        printf("| %zu | 10 | %.1f | %.0f | %.1f | %.0f |\n", sizes[s], 1e3 * mb,
               1e9 * mb / (double)sizes[s], 1e3 * mt, 1e9 * mt / (double)sizes[s]);
        fflush(stdout);
    }
}

int main(int argc, char **argv)
{
    size_t max_points = argc > 1 ? (size_t)atoll(argv[1]) : 1000000;
    printf("threads: %d\n\n", omp_get_max_threads());
    if (argc > 2 && strcmp(argv[2], "--curve") == 0) {
        curve(max_points);
        return 0;
    }
    printf("| points | primitives | tracking | influenced | fields + bind (ms) | edit: refit "
           "(ms) | re-track (ms) | not converged | steps per point |\n");
    printf("|---:|---:|---|---:|---:|---:|---:|---:|---:|\n");
    size_t ns[3] = {10000, 100000, 1000000}, ks[3] = {1, 10, 50};
    for (int a = 0; a < 3; a++) {
        if (ns[a] > max_points)
            break;
        for (int b = 0; b < 3; b++)
            run(ns[a], ks[b], FFD_GFFD_TRACK_GRADIENT, 0);
    }
    run(100000 <= max_points ? 100000 : max_points, 10, FFD_GFFD_TRACK_WARP, 0);
    return 0;
}
