/* Benchmark: does OpenBLAS's thread pool slow the lattice evaluation down?
 * Usage: bench_blas_threads [points]   (default 1000000)
 *
 * OpenBLAS (pthread build) starts its worker threads when it is loaded; after
 * a multi-threaded BLAS call they spin for a while (OPENBLAS_THREAD_TIMEOUT)
 * before they sleep, on the same cores as the OpenMP team. The program times
 * the 5^3 B-spline evaluation of random points right after a least-squares
 * solve through LAPACK (as a drag step does: solve, then evaluate), median of
 * 15 rounds. Compare a run with OPENBLAS_NUM_THREADS=1 in the environment with
 * one without: since libffd sets OpenBLAS to one thread on its first BLAS
 * call, the two should match. */
#include "ffd.h"
#include "math/dense.h"
#include "bench_util.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static uint64_t rng = 0x9E3779B97F4A7C15ull;
static double rnd(void) { return bench_rnd(&rng); }

int main(int argc, char **argv)
{
    size_t n = argc > 1 ? (size_t)strtoull(argv[1], NULL, 10) : 1000000;
    const char *env = getenv("OPENBLAS_NUM_THREADS");
    printf("OPENBLAS_NUM_THREADS=%s, OpenMP threads %d, %zu points\n", env ? env : "(unset)",
           omp_get_max_threads(), n);
    ffd_box box = {{0, 0, 0}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    uint32_t res[3] = {5, 5, 5};
    ffd_lattice *lat = NULL;
    ffd_lattice_binding *b = NULL;
    double *p = malloc(3 * n * sizeof *p), *q = malloc(3 * n * sizeof *q);
    for (size_t i = 0; i < 3 * n; i++)
        p[i] = rnd();
    if (ffd_lattice_create(FFD_BASIS_BSPLINE, &box, res, &lat, NULL) ||
        ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL))
        return 1;
    double d[3 * 125];
    for (size_t i = 0; i < 3 * 125; i++)
        d[i] = 0.05 * (rnd() - 0.5);
    ffd_lattice_add(lat, d, NULL);
    /* a least-squares problem the size of a 200-constraint drag on 8^3 (600 by 1536) */
    const size_t m = 600, k = 1536;
    double *A = malloc(m * k * sizeof *A), *B = malloc(k * sizeof *B);
    double ts[15], tl[15];
    for (int r = 0; r < 15; r++) {
        for (size_t i = 0; i < m * k; i++)
            A[i] = rnd();
        for (size_t i = 0; i < k; i++)
            B[i] = rnd();
        size_t rank;
        double t0 = bench_now();
        ffd_dense_lstsq(m, k, 1, A, B, 1e-12, &rank, NULL);
        double t1 = bench_now();
        ffd_lattice_eval(lat, b, q, NULL);
        double t2 = bench_now();
        ts[r] = t1 - t0;
        tl[r] = t2 - t1;
    }
    qsort(ts, 15, sizeof(double), bench_cmp_double);
    qsort(tl, 15, sizeof(double), bench_cmp_double);
    printf("lstsq %zu x %zu: %.2f ms; evaluate right after: %.2f ms (medians of 15)\n", m, k,
           ts[7] * 1e3, tl[7] * 1e3);
    free(A);
    free(B);
    free(p);
    free(q);
    ffd_lattice_binding_destroy(b);
    ffd_lattice_destroy(lat);
    return 0;
}
