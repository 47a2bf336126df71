/* Benchmark: PB-FFD binding (parameterisation), re-evaluation after a move
 * (eq. 7) and a direct-manipulation drag step, on refined_elephant.off
 * (44,460 vertices) and on 1M points sampled around it.
 * Usage: bench_pbffd DATA_DIR [--quick | --curve [MAX_POINTS [REPS]]]
 * (results go to docs/benchmarks.md by hand)
 * Last: the 10^4 -> 10^6 points curve (time per point of bind and eval).
 * Placement itself is timed by bench_placement. */
#include "ffd.h"
#include "bench_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int run(const char *label, const ffd_ebf *controls, size_t count, const double *points,
               size_t n, uint32_t levels, int reps)
{
    ffd_error err = {{0}};
    ffd_pbffd_options options = {0};
    options.levels = levels;
    ffd_pbffd *pb = NULL;
    double t0 = bench_now();
    if (ffd_pbffd_create(controls, count, points, n, &options, &pb, &err) != FFD_OK) {
        fprintf(stderr, "bench_pbffd: %s\n", err.message);
        return 1;
    }
    double bind = bench_now() - t0;
    double *out = malloc(n * 3 * sizeof *out);
    double times[64], drag[64];
    for (int r = 0; r < reps; r++) {
        double d[3] = {1e-3, 0, 0};
        ffd_pbffd_move(pb, 0, (size_t)r % count, d, &err);
        double t = bench_now();
        ffd_pbffd_eval(pb, out, &err);
        times[r] = bench_now() - t;
    }
    /* a drag step: 10 vertex constraints solved through the generic solver, then eval */
    ffd_linear_map map;
    size_t rows[10];
    double cur[30], tgt[30];
    double *delta = malloc(count * 3 * sizeof *delta);
    for (int r = 0; r < reps; r++) {
        double t = bench_now();
        ffd_pbffd_eval(pb, out, &err);
        ffd_pbffd_linear_map(pb, 0, &map, &err);
        for (int c = 0; c < 10; c++) {
            rows[c] = (size_t)c * (n / 10);
            memcpy(cur + 3 * c, out + 3 * rows[c], 3 * sizeof(double));
            memcpy(tgt + 3 * c, cur + 3 * c, 3 * sizeof(double));
            tgt[3 * c + 1] += 1e-3 * (r + 1);
        }
        ffd_manip_solve(&map, rows, 10, cur, tgt, NULL, delta, NULL, NULL, &err);
        for (size_t j = 0; j < count; j++)
            if (delta[3 * j] != 0 || delta[3 * j + 1] != 0 || delta[3 * j + 2] != 0)
                ffd_pbffd_move(pb, 0, j, delta + 3 * j, &err);
        ffd_pbffd_eval(pb, out, &err);
        drag[r] = bench_now() - t;
    }
    double ev = bench_median(times, reps), dr = bench_median(drag, reps);
    printf("| %s | %zu | %zu | %u | %.1f | %.2f | %.2f | %.1f |\n", label, n, count, levels,
           bind * 1e3, ev * 1e3, ev * 1e3 * 1e5 / (double)n, dr * 1e3);
    free(delta);
    free(out);
    ffd_pbffd_destroy(pb);
    return 0;
}

/* Time per point against the point count (PB-FFD should be linear): bind
 * (ffd_pbffd_create) and an evaluation after a move, medians of reps, on the
 * first n of the jittered points. */
static int curve(const ffd_ebf *controls, size_t count, const double *p, size_t big, int reps)
{
    static const size_t sizes[] = {10000, 30000, 100000, 300000, 1000000};
    printf("\n| n | bind ms | bind ns/point | eval ms | eval ns/point |\n|---:|---:|---:|---:|---:|\n");
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0] && sizes[s] <= big; s++) {
        size_t n = sizes[s];
        double tb[64], te[64];
        double *out = malloc(n * 3 * sizeof *out);
        for (int r = 0; r < reps; r++) {
            ffd_error err = {{0}};
            ffd_pbffd *pb = NULL;
            double t0 = bench_now();
            if (ffd_pbffd_create(controls, count, p, n, NULL, &pb, &err) != FFD_OK) {
                fprintf(stderr, "bench_pbffd: %s\n", err.message);
                free(out);
                return 1;
            }
            tb[r] = bench_now() - t0;
            double d[3] = {1e-3, 0, 0};
            ffd_pbffd_move(pb, 0, (size_t)r % count, d, &err);
            t0 = bench_now();
            ffd_pbffd_eval(pb, out, &err);
            te[r] = bench_now() - t0;
            ffd_pbffd_destroy(pb);
        }
        double b = bench_median(tb, reps), e = bench_median(te, reps);
        printf("| %zu | %.2f | %.1f | %.3f | %.2f |\n", n, b * 1e3, b * 1e9 / (double)n, e * 1e3,
               e * 1e9 / (double)n);
        free(out);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_pbffd DATA_DIR [--quick]\n");
        return 2;
    }
    int quick = argc > 2 && strcmp(argv[2], "--quick") == 0;
    /* --curve: only the 10^4 -> 10^6 points curve (bind and eval per point) */
    int only_curve = argc > 2 && strcmp(argv[2], "--curve") == 0;
    int reps = quick ? 3 : 15;
    char path[4096];
    snprintf(path, sizeof path, "%s/refined_elephant.off", argv[1]);
    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    if (ffd_mesh_read(path, &mesh, &err) != FFD_OK) {
        fprintf(stderr, "bench_pbffd: %s\n", err.message);
        return 1;
    }
    ffd_placement_options po = {0};
    po.interior_count = 100;
    po.exterior_count = 100;
    ffd_ebf *controls = NULL;
    size_t count = 0;
    if (ffd_pbffd_place(mesh, &po, &controls, &count, NULL, &err) != FFD_OK) {
        fprintf(stderr, "bench_pbffd: %s\n", err.message);
        return 1;
    }
    size_t n = ffd_mesh_vertex_count(mesh);
    const double *v = ffd_mesh_positions(mesh);
    int bad = 0;
    if (!only_curve) {
        printf("| points | n | controls | levels | bind ms | eval ms | eval ms per 100K | drag step "
               "ms |\n");
        printf("|---|---:|---:|---:|---:|---:|---:|---:|\n");
        bad |= run("refined_elephant vertices", controls, count, v, n, 1, reps);
        bad |= run("refined_elephant vertices", controls, count, v, n, 3, reps);
    }
    /* 1M points: the vertices jittered by up to 1% of the bounding box */
    size_t big = quick ? 200000 : 1000000;
    double *p = malloc(big * 3 * sizeof *p);
    unsigned long long rng = 0x9E3779B97F4A7C15ull;
    ffd_mesh_info info;
    ffd_mesh_compute_info(mesh, &info, &err);
    for (size_t i = 0; i < big; i++)
        for (int a = 0; a < 3; a++) {
            rng ^= rng >> 12;
            rng ^= rng << 25;
            rng ^= rng >> 27;
            double u = (double)((rng * 2685821657736338717ull) >> 11) / 9007199254740992.0;
            p[3 * i + a] = v[3 * (i % n) + a] + (u - 0.5) * 0.01 * (info.bbox_max[a] - info.bbox_min[a]);
        }
    if (!only_curve)
        bad |= run(quick ? "200K jittered copies" : "1M jittered copies", controls, count, p, big,
                   1, reps);
    /* --curve [MAX_POINTS [REPS]]: a shorter curve (e.g. under callgrind) */
    size_t top = only_curve && argc > 3 ? (size_t)atoll(argv[3]) : big;
    int curve_reps = only_curve && argc > 4 ? atoi(argv[4]) : (quick ? 3 : 7);
    if (curve_reps < 1 || curve_reps > 64)
        curve_reps = 7;
    bad |= curve(controls, count, p, top < big ? top : big, curve_reps);
    free(p);
    ffd_free(controls);
    ffd_mesh_destroy(mesh);
    return bad;
}
