/* Benchmark: Kelvinlet brushes (de Goes and James 2017) — evaluation and
 * Jacobians of N points (default 1M) under 1 and 10 brushes, superposed,
 * in a sequence of 4 RK4 steps, and with the tri-scale falloff; and the
 * "bind" of a deformer (a copy of the points: the brushes need no binding).
 * Usage: bench_kelvinlet [N]   (results go to docs/benchmarks.md by hand) */
#include "ffd.h"
#include "bench_util.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng = 0x9E3779B97F4A7C15ull;

/* g brushes in the unit cube cycling through grab, twist, scale, pinch. */
static void make_brushes(ffd_kelvinlet_brush *b, size_t g)
{
    for (size_t j = 0; j < g; j++) {
        memset(&b[j], 0, sizeof b[j]);
        b[j].type = (ffd_kelvinlet_type)(j % 4);
        for (int a = 0; a < 3; a++) {
            b[j].center[a] = bench_rnd(&rng);
            b[j].displacement[a] = 0.05 * (bench_rnd(&rng) - 0.5);
        }
        b[j].radius = 0.1 + 0.1 * bench_rnd(&rng);
        b[j].axis[2] = 1;
        b[j].angle = 0.3;
        b[j].factor = 1.1;
        b[j].pinch[0][0] = 0.1, b[j].pinch[1][1] = -0.1;
    }
}

static double time_eval(const ffd_kelvinlet *k, const double *p, double *out, size_t n, int jac)
{
    double ts[3];
    ffd_error err = {{0}};
    for (int r = 0; r < 3; r++) {
        double t0 = bench_now();
        ffd_status st = jac ? ffd_kelvinlet_jacobian(k, p, n, out, &err)
                            : ffd_kelvinlet_eval(k, p, n, out, &err);
        ts[r] = bench_now() - t0;
        if (st) {
            fprintf(stderr, "bench_kelvinlet: %s\n", err.message);
            exit(1);
        }
    }
    return bench_median(ts, 3);
}

int main(int argc, char **argv)
{
    size_t n = argc > 1 ? (size_t)atoll(argv[1]) : 1000000;
    double *p = malloc(3 * n * sizeof *p), *out = malloc(9 * n * sizeof *out);
    if (!p || !out)
        return 1;
    for (size_t i = 0; i < 3 * n; i++)
        p[i] = bench_rnd(&rng);
    ffd_kelvinlet_brush brushes[10];
    make_brushes(brushes, 10);
    printf("bench_kelvinlet: %zu points, %d threads\n", n, omp_get_max_threads());
    printf("%-10s %-8s %-10s %8s %8s %10s\n", "brushes", "falloff", "combine", "eval s",
           "jac s", "Mpts/s");
    const size_t counts[2] = {1, 10};
    for (int c = 0; c < 2; c++)
        for (int mode = 0; mode < 3; mode++) {
            ffd_kelvinlet_options o = {0};
            o.poisson_ratio = 0.45;
            o.combine = mode == 1 ? FFD_KELVINLET_SEQUENCE : FFD_KELVINLET_SUPERPOSE;
            o.steps = mode == 1 ? 4 : 1;
            o.multiscale = mode == 2 ? FFD_KELVINLET_TRISCALE : FFD_KELVINLET_SINGLE;
            ffd_kelvinlet *k = NULL;
            ffd_error err = {{0}};
            if (ffd_kelvinlet_create(brushes, counts[c], &o, &k, &err)) {
                fprintf(stderr, "bench_kelvinlet: %s\n", err.message);
                return 1;
            }
            double te = time_eval(k, p, out, n, 0), tj = time_eval(k, p, out, n, 1);
            printf("%-10zu %-8s %-10s %8.3f %8.3f %10.1f\n", counts[c],
                   mode == 2 ? "tri" : "single", mode == 1 ? "sequence4" : "superpose", te, tj,
                   (double)n / te / 1e6);
            ffd_kelvinlet_destroy(k);
        }
    /* a deformer's bind: through ffd_deformer_bind (the points copied) */
    double tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    uint32_t off[2] = {0, 3}, idx[3] = {0, 1, 2};
    ffd_mesh *mesh = NULL;
    ffd_rig *rig = NULL;
    ffd_deformer *d = NULL;
    ffd_error err = {{0}};
    const char *text = "{\"deformer\": \"kelvinlet\", \"brushes\": [{\"type\": \"grab\", "
                       "\"center\": [0.5, 0.5, 0.5], \"radius\": 0.2, \"displacement\": [0, 0, 0.1]}]}";
    if (ffd_mesh_create(tri, 3, off, idx, 1, &mesh, &err) ||
        ffd_rig_parse_json(text, strlen(text), "bench", &rig, &err) ||
        ffd_deformer_create(rig, mesh, NULL, &d, &err)) {
        fprintf(stderr, "bench_kelvinlet: %s\n", err.message);
        return 1;
    }
    double t0 = bench_now();
    if (ffd_deformer_bind(d, p, n, &err))
        return 1;
    double tb = bench_now() - t0;
    t0 = bench_now();
    if (ffd_deformer_eval(d, out, &err))
        return 1;
    printf("deformer: bind %.3f s, evaluate %.3f s (1 grab)\n", tb, bench_now() - t0);
    ffd_deformer_destroy(d);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
    free(p);
    free(out);
    return 0;
}
