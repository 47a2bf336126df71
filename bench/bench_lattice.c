/* Benchmark: lattice bind + evaluate throughput and direct-manipulation drag steps.
 * Usage: bench_lattice [--quick] [--json]   (results go to docs/benchmarks.md by hand)
 *
 * Point order matters: binding scatters points into per-cell ranges and evaluation
 * scatters results back to the caller's order, so both run faster when nearby points
 * are nearby in memory. "random" points are i.i.d. uniform (worst case); "grid" points
 * are one jittered point per cell of a k^3 grid in scan order, as a structured mesh or
 * volume would give them. */
#include "ffd.h"
#include "lattice/lattice.h" /* the evaluation's SIMD path */
#include "bench_util.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static uint64_t rng = 0x9E3779B97F4A7C15ull;
static double rnd(void) { return bench_rnd(&rng); }

/* n points in the unit cube: random order, or (grid) one jittered point per cell of
 * the smallest k^3 grid holding n cells, in scan order (x slowest, z fastest). */
static void fill_points(double *p, size_t n, int grid)
{
    size_t k = 1;
    while (k * k * k < n)
        k++;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            size_t g = c == 0 ? i / (k * k) : c == 1 ? (i / k) % k : i % k;
            p[3 * i + c] = grid ? ((double)g + rnd()) / (double)k : rnd();
        }
}

/* median of reps timings of fn */
#define MEDIAN_OF(reps, out, stmt)                                                                 \
    do {                                                                                           \
        double ts_[64];                                                                            \
        for (int r_ = 0; r_ < (reps); r_++) {                                                      \
            double t0_ = bench_now();                                                                    \
            stmt;                                                                                  \
            ts_[r_] = bench_now() - t0_;                                                                 \
        }                                                                                          \
        qsort(ts_, (size_t)(reps), sizeof(double), bench_cmp_double);                                    \
        (out) = ts_[(reps) / 2];                                                                   \
    } while (0)

int main(int argc, char **argv)
{
    int quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
    const size_t sizes[] = {10000, 100000, 1000000};
    const uint32_t lres[] = {3, 5, 8};
    const int reps = quick ? 3 : 11;
    printf("threads: %d, evaluation kernels: %s\n", omp_get_max_threads(),
           ffd_simd_path_name(ffd_lattice_simd_path()));
    printf("| basis | points | order | lattice | bind ms | evaluate ms | Mpoints/s (eval) |\n");
    printf("|---|---:|---|---:|---:|---:|---:|\n");
    ffd_box box = {{0, 0, 0}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    for (int basis = 0; basis < 2; basis++)
        for (size_t si = 0; si < 4; si++) {
            /* the last pass repeats 1M points in grid order */
            int grid = si == 3;
            size_t n = sizes[grid ? 2 : si];
            double *p = malloc(3 * n * sizeof *p), *q = malloc(3 * n * sizeof *q);
            fill_points(p, n, grid);
            for (size_t li = 0; li < 3; li++) {
                uint32_t res[3] = {lres[li], lres[li], lres[li]};
                ffd_lattice *lat = NULL;
                if (ffd_lattice_create((ffd_basis)basis, &box, res, &lat, NULL) != FFD_OK)
                    return 1;
                size_t nc = ffd_lattice_control_count(lat);
                double *d = malloc(3 * nc * sizeof *d);
                for (size_t i = 0; i < 3 * nc; i++)
                    d[i] = 0.05 * (rnd() - 0.5);
                ffd_lattice_add(lat, d, NULL);
                free(d);
                ffd_lattice_binding *b = NULL;
                double tb, te;
                MEDIAN_OF(reps, tb, {
                    ffd_lattice_binding_destroy(b);
                    b = NULL;
                    ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL);
                });
                MEDIAN_OF(reps, te, ffd_lattice_eval(lat, b, q, NULL));
                printf("| %s | %zu | %s | %u^3 | %.2f | %.2f | %.1f |\n",
                       basis ? "bernstein" : "bspline", n, grid ? "grid" : "random", lres[li],
                       tb * 1e3, te * 1e3,
                       n / te * 1e-6);
                fflush(stdout);
                ffd_lattice_binding_destroy(b);
                ffd_lattice_destroy(lat);
            }
            free(p);
            free(q);
        }

    /* drag step: solve k constraints + re-evaluate 1M points, 5^3 B-spline */
    printf("\n| order | constraints | solve ms | solve + re-evaluate 1M ms | max residual |\n");
    printf("|---|---:|---:|---:|---:|\n");
    for (int grid = 0; grid < 2; grid++) {
        size_t n = 1000000;
        double *p = malloc(3 * n * sizeof *p), *q = malloc(3 * n * sizeof *q);
        fill_points(p, n, grid);
        uint32_t res[3] = {5, 5, 5};
        ffd_lattice *lat = NULL;
        ffd_lattice_create(FFD_BASIS_BSPLINE, &box, res, &lat, NULL);
        ffd_lattice_binding *b = NULL;
        ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL);
        const size_t ks[] = {1, 10, 100};
        for (int ki = 0; ki < 3; ki++) {
            size_t k = ks[ki];
            size_t *pts = malloc(k * sizeof *pts);
            double *cp = malloc(3 * k * sizeof *cp), *cur = malloc(3 * k * sizeof *cur),
                   *tgt = malloc(3 * k * sizeof *tgt), *dl = malloc(3 * 125 * sizeof *dl);
            for (size_t i = 0; i < k; i++) {
                pts[i] = (size_t)(rnd() * (double)n);
                memcpy(cp + 3 * i, p + 3 * pts[i], 3 * sizeof(double));
            }
            ffd_lattice_binding *cb = NULL;
            ffd_lattice_bind(lat, cp, k, FFD_OUTSIDE_FIXED, &cb, NULL);
            ffd_linear_map map;
            ffd_lattice_linear_map(lat, cb, &map);
            size_t *idx = malloc(k * sizeof *idx);
            for (size_t i = 0; i < k; i++)
                idx[i] = i;
            double ts, tt;
            ffd_manip_result mr = {0};
            MEDIAN_OF(reps, ts, {
                ffd_lattice_eval(lat, cb, cur, NULL);
                for (size_t i = 0; i < 3 * k; i++)
                    tgt[i] = cur[i] + 0.01 * (rnd() - 0.5);
                ffd_manip_solve(&map, idx, k, cur, tgt, NULL, dl, NULL, &mr, NULL);
            });
            MEDIAN_OF(reps, tt, {
                ffd_lattice_eval(lat, cb, cur, NULL);
                for (size_t i = 0; i < 3 * k; i++)
                    tgt[i] = cur[i] + 0.01 * (rnd() - 0.5);
                ffd_manip_solve(&map, idx, k, cur, tgt, NULL, dl, NULL, &mr, NULL);
                ffd_lattice_add(lat, dl, NULL);
                ffd_lattice_eval(lat, b, q, NULL);
            });
            printf("| %s | %zu | %.3f | %.2f | %.2e |\n", grid ? "grid" : "random", k, ts * 1e3,
                   tt * 1e3, mr.max_residual);
            ffd_lattice_binding_destroy(cb);
            free(pts);
            free(cp);
            free(cur);
            free(tgt);
            free(dl);
            free(idx);
        }
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
        free(p);
        free(q);
    }

    /* the same 5^3 B-spline through the generic deformer (ffd_deformer): the
     * lattice's own evaluation against the interface's, on 1M points; and a
     * drag-like step: move one control, evaluate everything */
    printf("\n| order | lattice eval ms | ffd_deformer_eval ms | move 1 control + ffd_deformer_eval ms |\n");
    printf("|---|---:|---:|---:|\n");
    static const char rig[] =
        "{\"deformer\": \"lattice\", \"resolution\": [5, 5, 5], \"box\": {\"origin\": [0, 0, 0], "
        "\"axes\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}, \"moves\": [{\"index\": [2, 2, 4], "
        "\"delta\": [0.05, 0, 0.1]}]}";
    for (int grid = 0; grid < 2; grid++) {
        size_t n = 1000000;
        double *p = malloc(3 * n * sizeof *p), *q = malloc(3 * n * sizeof *q);
        fill_points(p, n, grid);
        ffd_mesh *mesh = NULL;
        ffd_deformer *d = NULL;
        ffd_error err = {{0}};
        if (ffd_mesh_create(p, n, NULL, NULL, 0, &mesh, &err)
            || ffd_deformer_create_json(rig, sizeof rig - 1, "bench", mesh, NULL, &d, &err)) {
            fprintf(stderr, "bench_lattice: %s\n", err.message);
            return 1;
        }
        ffd_lattice *lat = ffd_deformer_handle(d, "lattice");
        ffd_lattice_binding *b = NULL;
        ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL);
        double tl, td, tm;
        uint32_t id = 62;
        double delta[3] = {0.001, 0, 0};
        MEDIAN_OF(reps, tl, ffd_lattice_eval(lat, b, q, NULL));
        MEDIAN_OF(reps, td, ffd_deformer_eval(d, q, NULL));
        MEDIAN_OF(reps, tm, {
            ffd_deformer_move_controls(d, &id, 1, delta, NULL);
            ffd_deformer_eval(d, q, NULL);
        });
        printf("| %s | %.2f | %.2f | %.2f |\n", grid ? "grid" : "random", tl * 1e3, td * 1e3,
               tm * 1e3);
        fflush(stdout);
        ffd_lattice_binding_destroy(b);
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(mesh);
        free(p);
        free(q);
    }
    return 0;
}
