/* Benchmark: cage deformation (docs/cage.md): binding points to mean value
 * coordinates (Ju et al. 2005) and to harmonic coordinates (Joshi et al.
 * 2007: the grid solve, then trilinear interpolation), and evaluating a
 * moved cage, for 1M points inside an icosphere cage of 42 vertices.
 * Usage: bench_cage [--points N] [--resolution R]   (results go to
 * docs/benchmarks.md by hand). */
#include "ffd.h"
#include "bench_util.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng = 0x9E3779B97F4A7C15ull;

/* The icosphere subdivided once: 42 vertices on the unit sphere, 80 triangles. */
static size_t icosphere(double *v, uint32_t *t)
{
    const double g = (1 + sqrt(5.0)) / 2;
    const double b[12][3] = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0},
                             {0, -1, g}, {0, 1, g}, {0, -1, -g}, {0, 1, -g},
                             {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
    const uint32_t f[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                               {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                               {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                               {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    size_t nv = 12, nt = 0;
    memcpy(v, b, sizeof b);
    uint32_t mid[42][42];
    memset(mid, 0xff, sizeof mid);
    for (int k = 0; k < 20; k++) {
        uint32_t m[3];
        for (int e = 0; e < 3; e++) {
            uint32_t a = f[k][e], c = f[k][(e + 1) % 3];
            if (mid[a][c] == UINT32_MAX) {
                for (int x = 0; x < 3; x++)
                    v[3 * nv + x] = 0.5 * (v[3 * a + x] + v[3 * c + x]);
                mid[a][c] = mid[c][a] = (uint32_t)nv++;
            }
            m[e] = mid[a][c];
        }
        const uint32_t q[4][3] = {{f[k][0], m[0], m[2]}, {f[k][1], m[1], m[0]},
                                  {f[k][2], m[2], m[1]}, {m[0], m[1], m[2]}};
        memcpy(t + 3 * nt, q, sizeof q);
        nt += 4;
    }
    for (size_t i = 0; i < nv; i++) {
        double r = sqrt(v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] +
                        v[3 * i + 2] * v[3 * i + 2]);
        for (int x = 0; x < 3; x++)
            v[3 * i + x] /= r;
    }
    return nt;
}

int main(int argc, char **argv)
{
    size_t n = 1000000;
    uint32_t resolution = 32;
    for (int i = 1; i + 1 < argc; i++) {
        if (!strcmp(argv[i], "--points"))
            n = (size_t)strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--resolution"))
            resolution = (uint32_t)strtoul(argv[++i], NULL, 10);
    }
    double v[42 * 3], moved[42 * 3];
    uint32_t t[80 * 3];
    size_t nt = icosphere(v, t);
    double *p = malloc(n * 3 * sizeof *p), *out = malloc(n * 3 * sizeof *out);
    if (!p || !out)
        return 1;
    for (size_t i = 0; i < n; i++) { /* uniform in the ball of radius 0.9 */
        double x[3], r2;
        do {
            for (int c = 0; c < 3; c++)
                x[c] = 2 * bench_rnd(&rng) - 1;
            r2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
        } while (r2 > 1);
        for (int c = 0; c < 3; c++)
            p[3 * i + c] = 0.9 * x[c];
    }
    for (int i = 0; i < 42 * 3; i++)
        moved[i] = v[i] * (1 + 0.2 * bench_rnd(&rng));
    printf("cage: 42 vertices, %zu triangles; %zu points; %d threads\n", nt, n,
           omp_get_max_threads());
    for (int kind = 0; kind < 2; kind++) {
        ffd_cage_options o = {(ffd_cage_coordinates)kind, resolution, 0};
        ffd_cage *cage = NULL;
        ffd_cage_binding *b = NULL;
        ffd_error err = {{0}};
        double t0 = bench_now();
        if (ffd_cage_create(v, 42, t, nt, NULL, &o, &cage, &err)) {
            fprintf(stderr, "%s\n", err.message);
            return 1;
        }
        double t1 = bench_now();
        if (ffd_cage_bind(cage, p, n, &b, &err)) {
            fprintf(stderr, "%s\n", err.message);
            return 1;
        }
        double t2 = bench_now();
        ffd_cage_set_vertices(cage, moved, &err);
        ffd_cage_eval(cage, b, out, &err);
        double t3 = bench_now();
        printf("%-10s create %.3f s (grid %u)  bind %.3f s (%.0f ns/point)  eval %.3f s "
               "(%.0f ns/point)\n",
               kind ? "harmonic" : "mean_value", t1 - t0, kind ? resolution : 0, t2 - t1,
               1e9 * (t2 - t1) / (double)n, t3 - t2, 1e9 * (t3 - t2) / (double)n);
        ffd_cage_binding_destroy(b);
        ffd_cage_destroy(cage);
    }
    free(p);
    free(out);
    return 0;
}
