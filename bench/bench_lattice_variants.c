/* Benchmark: bind + evaluate of the lattice variants (docs/lattice-variants.md):
 * interpolation per axis and cylindrical / spherical lattices, next to the
 * plain B-spline lattice (the SIMD fast path) for reference.
 * Usage: bench_lattice_variants [POINTS]   (default 1000000; results go to
 * docs/benchmarks.md by hand). Each variant binds POINTS random points inside
 * its lattice, moves every control point a little, and evaluates; the median
 * of 5 runs (3 under 100000 points) is printed, with the evaluation's Jacobian. */
#include "ffd.h"
#include "bench_util.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TWO_PI 6.283185307179586476925286766559
#define PI 3.1415926535897932384626433832795

static uint64_t rng = 0x9E3779B97F4A7C15ull;
static double rnd(void) { return bench_rnd(&rng); }

typedef struct variant {
    const char *name;
    ffd_interp interp[3];
    double tension;
    ffd_coordinates coordinates;
    uint32_t res[3];
} variant;

static const variant variants[] = {
    {"bspline (fast path)", {FFD_INTERP_BSPLINE, FFD_INTERP_BSPLINE, FFD_INTERP_BSPLINE}, 0,
     FFD_COORDINATES_CARTESIAN, {5, 5, 5}},
    {"linear", {FFD_INTERP_LINEAR, FFD_INTERP_LINEAR, FFD_INTERP_LINEAR}, 0,
     FFD_COORDINATES_CARTESIAN, {5, 5, 5}},
    {"catmull-rom", {FFD_INTERP_CATMULL_ROM, FFD_INTERP_CATMULL_ROM, FFD_INTERP_CATMULL_ROM}, 0,
     FFD_COORDINATES_CARTESIAN, {5, 5, 5}},
    {"cardinal T=0.3", {FFD_INTERP_CARDINAL, FFD_INTERP_CARDINAL, FFD_INTERP_CARDINAL}, 0.3,
     FFD_COORDINATES_CARTESIAN, {5, 5, 5}},
    {"linear/cardinal/bspline", {FFD_INTERP_LINEAR, FFD_INTERP_CARDINAL, FFD_INTERP_BSPLINE}, 0.3,
     FFD_COORDINATES_CARTESIAN, {5, 5, 5}},
    {"cylindrical catmull-rom", {FFD_INTERP_CATMULL_ROM, FFD_INTERP_CATMULL_ROM, FFD_INTERP_CATMULL_ROM},
     0, FFD_COORDINATES_CYLINDRICAL, {3, 8, 5}},
    {"spherical bspline", {FFD_INTERP_BSPLINE, FFD_INTERP_BSPLINE, FFD_INTERP_BSPLINE}, 0,
     FFD_COORDINATES_SPHERICAL, {3, 8, 5}},
};

#define MEDIAN_OF(reps, out, stmt)                                                                 \
    do {                                                                                           \
        double ts_[16];                                                                            \
        for (int r_ = 0; r_ < (reps); r_++) {                                                      \
            double t0_ = bench_now();                                                              \
            stmt;                                                                                  \
            ts_[r_] = bench_now() - t0_;                                                           \
        }                                                                                          \
        qsort(ts_, (size_t)(reps), sizeof(double), bench_cmp_double);                              \
        (out) = ts_[(reps) / 2];                                                                   \
    } while (0)

int main(int argc, char **argv)
{
    size_t n = argc > 1 ? (size_t)strtoull(argv[1], NULL, 10) : 1000000;
    if (n == 0)
        n = 1000000;
    const int reps = n < 100000 ? 3 : 5;
    printf("threads: %d, points: %zu\n", omp_get_max_threads(), n);
    printf("| variant | lattice | bind ms | evaluate ms | Jacobian ms | Mpoints/s (eval) |\n");
    printf("|---|---:|---:|---:|---:|---:|\n");
    double *p = malloc(3 * n * sizeof *p), *out = malloc(3 * n * sizeof *out);
    double *jac = malloc(9 * n * sizeof *jac);
    if (!p || !out || !jac) {
        fprintf(stderr, "bench_lattice_variants: out of memory for %zu points\n", n);
        return 1;
    }
    const ffd_box box = {{0, 0, 0}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    for (size_t v = 0; v < sizeof variants / sizeof *variants; v++) {
        const variant *va = &variants[v];
        ffd_lattice_shape sh;
        memset(&sh, 0, sizeof sh);
        for (int a = 0; a < 3; a++) {
            sh.interp[a] = va->interp[a];
            sh.tension[a] = va->interp[a] == FFD_INTERP_CARDINAL ? va->tension : 0;
        }
        sh.coordinates = va->coordinates;
        const double c0[3] = {0.5, 0.5, 0.5}, ax[3] = {0, 0, 1}, rf[3] = {1, 0, 0};
        memcpy(sh.frame.centre, c0, sizeof c0);
        memcpy(sh.frame.axis, ax, sizeof ax);
        memcpy(sh.frame.reference, rf, sizeof rf);
        sh.frame.range[0][1] = 0.5;
        sh.frame.range[1][1] = TWO_PI;
        sh.frame.range[2][0] = va->coordinates == FFD_COORDINATES_SPHERICAL ? 0 : -0.5;
        sh.frame.range[2][1] = va->coordinates == FFD_COORDINATES_SPHERICAL ? PI : 0.5;
        ffd_lattice *lat = NULL;
        ffd_error err = {{0}};
        if (ffd_lattice_create_shaped(FFD_BASIS_BSPLINE, &box, va->res, &sh, &lat, &err)) {
            fprintf(stderr, "%s: %s\n", va->name, err.message);
            return 1;
        }
        for (size_t i = 0; i < n; i++) { /* inside the unit cube, or the ball of radius 0.5 */
            double x, y, z;
            do {
                x = rnd(), y = rnd(), z = rnd();
            } while (va->coordinates == FFD_COORDINATES_SPHERICAL &&
                     (x - 0.5) * (x - 0.5) + (y - 0.5) * (y - 0.5) + (z - 0.5) * (z - 0.5) > 0.25);
            p[3 * i] = x, p[3 * i + 1] = y, p[3 * i + 2] = z;
        }
        size_t nc = ffd_lattice_control_count(lat);
        double *d = malloc(3 * nc * sizeof *d);
        for (size_t j = 0; j < 3 * nc; j++)
            d[j] = 0.02 * (rnd() - 0.5);
        ffd_lattice_add(lat, d, NULL);
        free(d);
        double tb, te, tj;
        ffd_lattice_binding *b = NULL;
        MEDIAN_OF(reps, tb, {
            ffd_lattice_binding_destroy(b);
            b = NULL;
            ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, NULL);
        });
        MEDIAN_OF(reps, te, ffd_lattice_eval(lat, b, out, NULL));
        MEDIAN_OF(reps, tj, ffd_lattice_jacobian(lat, b, jac, NULL));
        printf("| %s | %ux%ux%u | %.1f | %.1f | %.1f | %.1f |\n", va->name, va->res[0], va->res[1],
               va->res[2], 1e3 * tb, 1e3 * te, 1e3 * tj, n / te * 1e-6);
        ffd_lattice_binding_destroy(b);
        ffd_lattice_destroy(lat);
    }
    free(p);
    free(out);
    free(jac);
    return 0;
}
