/* Benchmark: sensitivities of a lattice deformer on 1M points
 * (ffd.h "Sensitivities"): one evaluation against the product W v, the
 * adjoint product W^T w and forming W, through the public ffd_deformer.
 * Usage: bench_sensitivities [--quick]   (median of 3; --quick: 100k points;
 * results go to docs/benchmarks.md by hand)
 *
 * Points are one jittered point per cell of a 100^3 grid in scan order
 * (bench_lattice's "grid" order, like a structured volume mesh's nodes). */
#include "ffd.h"
#include "bench_util.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double median_ms(double *t, int reps)
{
    return 1e3 * bench_median(t, reps);
}

int main(int argc, char **argv)
{
    int quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
    const size_t n = quick ? 100000 : 1000000;
    const int reps = 3;
    const char *bases[] = {"bspline", "bernstein"};
    const unsigned res[] = {5, 8};
    uint64_t rng = 0x9E3779B97F4A7C15ull;
    size_t k = 1;
    while (k * k * k < n)
        k++;
    double *pts = malloc(3 * n * sizeof *pts), *out = malloc(3 * n * sizeof *out);
    double *w = malloc(3 * n * sizeof *w);
    for (size_t i = 0; i < n; i++) {
        size_t g[3] = {i / (k * k), (i / k) % k, i % k};
        for (int c = 0; c < 3; c++) {
            pts[3 * i + c] = ((double)g[c] + bench_rnd(&rng)) / (double)k;
            w[3 * i + c] = bench_rnd(&rng) - 0.5;
        }
    }
    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    if (ffd_mesh_create(pts, n, NULL, NULL, 0, &mesh, &err)) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    printf("threads: %d, points: %zu, median of %d\n", omp_get_max_threads(), n, reps);
    printf("| basis | lattice | evaluate ms | W v ms | W^T w ms | form W ms | nnz(W) |\n");
    printf("|---|---:|---:|---:|---:|---:|---:|\n");
    for (int b = 0; b < 2; b++)
        for (int r = 0; r < 2; r++) {
            char rig[512];
            snprintf(rig, sizeof rig,
                     "{\"version\": 1, \"deformer\": \"lattice\", \"basis\": \"%s\","
                     " \"resolution\": [%u, %u, %u], \"box\": {\"origin\": [0, 0, 0],"
                     " \"axes\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]},"
                     " \"moves\": [{\"index\": [1, 1, 1], \"delta\": [0.1, 0.05, 0]}]}",
                     bases[b], res[r], res[r], res[r]);
            ffd_deformer *d = NULL;
            if (ffd_deformer_create_json(rig, strlen(rig), "bench.json", mesh, NULL, &d, &err)) {
                fprintf(stderr, "%s\n", err.message);
                return 1;
            }
            size_t controls = ffd_deformer_control_count(d);
            double *v = malloc(3 * controls * sizeof *v), *g = malloc(3 * controls * sizeof *g);
            for (size_t c = 0; c < 3 * controls; c++)
                v[c] = bench_rnd(&rng) - 0.5;
            double te[16], tv[16], tt[16], tf[16];
            size_t nnz = 0;
            for (int q = 0; q < reps; q++) {
                double t0 = bench_now();
                ffd_status st = ffd_deformer_eval(d, out, &err);
                double t1 = bench_now();
                st |= ffd_deformer_sensitivity_product(d, v, out, &err);
                double t2 = bench_now();
                st |= ffd_deformer_sensitivity_transpose_product(d, w, g, &err);
                double t3 = bench_now();
                /* a Bernstein W is dense (every point weighs every control:
                 * 0.5-6 GB here): not formed */
                ffd_sparse W = {0};
                if (b == 0)
                    st |= ffd_deformer_sensitivities(d, &W, &err);
                double t4 = bench_now();
                nnz = W.nnz;
                ffd_sparse_free(&W);
                if (st) {
                    fprintf(stderr, "%s\n", err.message);
                    return 1;
                }
                te[q] = t1 - t0, tv[q] = t2 - t1, tt[q] = t3 - t2, tf[q] = t4 - t3;
            }
            char form[64] = "not formed", count[32] = "dense";
            if (b == 0) {
                snprintf(form, sizeof form, "%.1f", median_ms(tf, reps));
                snprintf(count, sizeof count, "%zu", nnz);
            }
            printf("| %s | %u^3 | %.1f | %.1f | %.1f | %s | %s |\n", bases[b], res[r],
                   median_ms(te, reps), median_ms(tv, reps), median_ms(tt, reps), form, count);
            fflush(stdout);
            free(v);
            free(g);
            ffd_deformer_destroy(d);
        }
    ffd_mesh_destroy(mesh);
    free(pts);
    free(out);
    free(w);
    return 0;
}
