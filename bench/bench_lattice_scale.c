/* Benchmark: lattice bind and evaluate from 10^5 to 10^7 (or 10^8) generated
 * points, time and memory per point, to show each step linear.
 * Usage: bench_lattice_scale [--max N] [--basis bspline|bernstein] [--res R]
 *                            [--order random|grid] [--reps K] [--sizes N1,N2,...]
 * Defaults: --max 10000000 --basis bspline --res 5 --order random --reps 5.
 * 10^8 points need ~2.4 GB for the points, ~2.4 GB for the output and ~6 GB
 * for the binding (--max 100000000).
 *
 * Bytes per point: the binding's own arrays (counted from its layout, see
 * src/lattice/lattice.h) and the growth of the resident set across the first
 * bind (the binding's pages plus transient buffers). Medians of K rounds; bind rounds
 * destroy and rebuild the binding, so they include its page faults. The last
 * column hashes the evaluated bits (FNV-1a): two builds that agree bitwise
 * print the same hash. */
#include "ffd.h"
#include "lattice/lattice.h"
#include "bench_util.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* resident set in bytes (/proc/self/statm, second field, pages) */
static double rss_bytes(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    long pages = 0, resident = 0;
    if (f) {
        if (fscanf(f, "%ld %ld", &pages, &resident) != 2)
            resident = 0;
        fclose(f);
    }
    return (double)resident * 4096.0;
}

/* point i of a random (hashed) or grid (jittered scan order) cloud in the unit cube */
static double coord(size_t i, int c, int grid, size_t k)
{
    unsigned long long h = (unsigned long long)i * 3 + (unsigned long long)c + 1;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    double r = (double)(h >> 11) * (1.0 / 9007199254740992.0);
    if (!grid)
        return r;
    size_t g = c == 0 ? i / (k * k) : c == 1 ? (i / k) % k : i % k;
    return ((double)g + r) / (double)k;
}

int main(int argc, char **argv)
{
    size_t max = 10000000, sizes[16], nsizes = 0;
    int basis = FFD_BASIS_BSPLINE, grid = 0, reps = 5;
    uint32_t r = 5;
    for (int a = 1; a + 1 < argc; a += 2) {
        if (!strcmp(argv[a], "--max"))
            max = (size_t)strtod(argv[a + 1], NULL);
        else if (!strcmp(argv[a], "--basis"))
            basis = !strcmp(argv[a + 1], "bernstein") ? FFD_BASIS_BERNSTEIN : FFD_BASIS_BSPLINE;
        else if (!strcmp(argv[a], "--res"))
            r = (uint32_t)atoi(argv[a + 1]);
        else if (!strcmp(argv[a], "--order"))
            grid = !strcmp(argv[a + 1], "grid");
        else if (!strcmp(argv[a], "--reps"))
            reps = atoi(argv[a + 1]);
        else if (!strcmp(argv[a], "--sizes")) {
            char *s = argv[a + 1];
            while (*s && nsizes < 16) {
                sizes[nsizes++] = (size_t)strtod(s, &s);
                if (*s == ',')
                    s++;
            }
        } else {
            fprintf(stderr, "bench_lattice_scale: unknown option %s\n", argv[a]);
            return 2;
        }
    }
    if (reps < 1 || reps > 63)
        reps = 5;
    if (!nsizes)
        for (size_t n = 100000; n <= max && nsizes < 16; n *= 10)
            sizes[nsizes++] = n;
#ifndef FFD_BENCH_NO_SIMD_PATH
    const char *path = ffd_simd_path_name(ffd_lattice_simd_path());
#else
    const char *path = "(not reported)";
#endif
    printf("threads %d, evaluation kernels %s, %s %u^3, %s order, median of %d\n",
           omp_get_max_threads(), path, basis == FFD_BASIS_BSPLINE ? "bspline" : "bernstein", r,
           grid ? "grid" : "random", reps);
    printf("| points | bind ms | bind ns/point | evaluate ms | evaluate ns/point | binding B/point "
           "| RSS growth at bind B/point | output hash |\n|---:|---:|---:|---:|---:|---:|---:|---|\n");
    ffd_box box = {{0, 0, 0}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    uint32_t res[3] = {r, r, r};
    for (size_t si = 0; si < nsizes; si++) {
        size_t n = sizes[si], k = 1;
        while (k * k * k < n)
            k++;
        double *p = malloc(3 * n * sizeof *p), *q = malloc(3 * n * sizeof *q);
        if (!p || !q) {
            fprintf(stderr, "bench_lattice_scale: no memory for %zu points\n", n);
            return 1;
        }
#pragma omp parallel for schedule(static)
        for (long long i = 0; i < (long long)n; i++)
            for (int c = 0; c < 3; c++)
                p[3 * (size_t)i + c] = coord((size_t)i, c, grid, k);
        memset(q, 0, 3 * n * sizeof *q);
        ffd_lattice *lat = NULL;
        if (ffd_lattice_create((ffd_basis)basis, &box, res, &lat, NULL) != FFD_OK)
            return 1;
        size_t nc = ffd_lattice_control_count(lat);
        double *d = malloc(3 * nc * sizeof *d);
        for (size_t i = 0; i < 3 * nc; i++)
            d[i] = 0.05 * (coord(i, 0, 0, 1) - 0.5);
        ffd_lattice_add(lat, d, NULL);
        free(d);
        double tb[64], te[64], grow = 0;
        ffd_lattice_binding *b = NULL;
        for (int i = 0; i < reps; i++) {
            ffd_lattice_binding_destroy(b);
            b = NULL;
            double r0 = rss_bytes(), t0 = bench_now();
            if (ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL) != FFD_OK)
                return 1;
            tb[i] = bench_now() - t0;
            if (i == 0) /* later rounds reuse the freed pages */
                grow = rss_bytes() - r0;
        }
        for (int i = 0; i < reps; i++) {
            double t0 = bench_now();
            ffd_lattice_eval(lat, b, q, NULL);
            te[i] = bench_now() - t0;
        }
        qsort(tb, (size_t)reps, sizeof(double), bench_cmp_double);
        qsort(te, (size_t)reps, sizeof(double), bench_cmp_double);
        size_t nin = ffd_lattice_binding_inside_count(b);
        unsigned long long hash = 0xcbf29ce484222325ull;
        const unsigned char *bytes_out = (const unsigned char *)q;
        for (size_t i = 0; i < 3 * n * sizeof *q; i++)
            hash = (hash ^ bytes_out[i]) * 0x100000001b3ull;
        /* params 24 + inside 1 per point; order 4 + local 24 + rest 24 per inside point */
        double bytes = 25.0 * (double)n + 52.0 * (double)nin;
        printf("| %zu | %.2f | %.2f | %.2f | %.2f | %.0f | %.0f | %016llx |\n", n, tb[reps / 2] * 1e3,
               tb[reps / 2] * 1e9 / (double)n, te[reps / 2] * 1e3, te[reps / 2] * 1e9 / (double)n,
               bytes / (double)n, grow / (double)n, hash);
        fflush(stdout);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
        free(p);
        free(q);
    }
    return 0;
}
