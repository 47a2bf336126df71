/* bench_peers — ffdkit's side of the side-by-side comparison with Blender's
 * Lattice modifier and PyGeM's FFD (bench/peers.sh runs all three, interleaved).
 *
 *   bench_peers gen N DIR      writes DIR/points.f64 (N x 3 little-endian
 *                              doubles, uniform in the unit cube), the same
 *                              points as DIR/points.ply (binary, vertices
 *                              only), DIR/deltas.f64 (one displacement per
 *                              control point of a 5^3 lattice on the unit
 *                              cube) and DIR/rig-{bspline,bernstein}.json
 *                              (that lattice with those moves)
 *   bench_peers time DIR BASIS R
 *                              library timings on those points, median of R:
 *                              "bind+eval MS eval_after_move MS"
 *   bench_peers path           the lattice evaluation's SIMD path on this CPU
 *
 * Every control point moves (the same deltas for every tool), so no tool can
 * skip points whose support did not change. */
#include "ffd.h"
#include "lattice/lattice.h" /* the evaluation's SIMD path */
#include "bench_util.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define RES 5u
#define CONTROLS (RES * RES * RES)

static uint64_t rng = 0x2545F4914F6CDD1Dull;
static double rnd(void) { return bench_rnd(&rng); }

static FILE *open_in(const char *dir, const char *name, const char *mode)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, mode);
    if (!f) {
        perror(path);
        exit(1);
    }
    return f;
}

static void write_rig(const char *dir, const char *basis, const double *delta)
{
    char name[64];
    snprintf(name, sizeof name, "rig-%s.json", basis);
    FILE *f = open_in(dir, name, "w");
    fprintf(f, "{\"version\": 1, \"deformer\": \"lattice\", \"basis\": \"%s\", "
               "\"resolution\": [%u, %u, %u],\n \"box\": {\"origin\": [0, 0, 0], "
               "\"axes\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]},\n \"moves\": [",
            basis, RES, RES, RES);
    for (unsigned c = 0; c < CONTROLS; c++)
        fprintf(f, "%s\n  {\"index\": [%u, %u, %u], \"delta\": [%.17g, %.17g, %.17g]}",
                c ? "," : "", c / (RES * RES), c / RES % RES, c % RES, delta[3 * c],
                delta[3 * c + 1], delta[3 * c + 2]);
    fprintf(f, "]}\n");
    fclose(f);
}

static int gen(size_t n, const char *dir)
{
    double *p = malloc(3 * n * sizeof *p);
    float *pf = malloc(3 * n * sizeof *pf);
    if (!p || !pf)
        return 1;
    for (size_t i = 0; i < 3 * n; i++) {
        p[i] = rnd();
        pf[i] = (float)p[i];
        p[i] = pf[i]; /* the PLY holds floats: every tool starts from the same values */
    }
    FILE *f = open_in(dir, "points.f64", "wb");
    fwrite(p, sizeof *p, 3 * n, f);
    fclose(f);
    f = open_in(dir, "points.ply", "wb");
    fprintf(f, "ply\nformat binary_little_endian 1.0\nelement vertex %zu\nproperty float x\n"
               "property float y\nproperty float z\nend_header\n", n);
    fwrite(pf, sizeof *pf, 3 * n, f);
    fclose(f);
    double delta[3 * CONTROLS];
    for (unsigned i = 0; i < 3 * CONTROLS; i++)
        delta[i] = 0.1 * (rnd() - 0.5);
    f = open_in(dir, "deltas.f64", "wb");
    fwrite(delta, sizeof *delta, 3 * CONTROLS, f);
    fclose(f);
    write_rig(dir, "bspline", delta);
    write_rig(dir, "bernstein", delta);
    free(p);
    free(pf);
    return 0;
}

static int time_library(const char *dir, const char *basis_name, int rounds)
{
    FILE *f = open_in(dir, "points.f64", "rb");
    fseek(f, 0, SEEK_END);
    size_t n = (size_t)ftell(f) / (3 * sizeof(double));
    rewind(f);
    double *p = malloc(3 * n * sizeof *p), *q = malloc(3 * n * sizeof *q);
    double delta[3 * CONTROLS];
    if (!p || !q || fread(p, sizeof *p, 3 * n, f) != 3 * n)
        return 1;
    fclose(f);
    f = open_in(dir, "deltas.f64", "rb");
    if (fread(delta, sizeof *delta, 3 * CONTROLS, f) != 3 * CONTROLS)
        return 1;
    fclose(f);
    ffd_basis basis = strcmp(basis_name, "bernstein") == 0 ? FFD_BASIS_BERNSTEIN : FFD_BASIS_BSPLINE;
    ffd_box box = {{0, 0, 0}, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    const uint32_t res[3] = {RES, RES, RES};
    ffd_lattice *lat = NULL;
    ffd_error err = {0};
    if (ffd_lattice_create(basis, &box, res, &lat, &err) || ffd_lattice_add(lat, delta, &err)) {
        fprintf(stderr, "bench_peers: %s\n", err.message);
        return 1;
    }
    double *t_bind = malloc((size_t)rounds * sizeof *t_bind);
    double *t_move = malloc((size_t)rounds * sizeof *t_move);
    for (int r = 0; r < rounds; r++) {
        /* bind + evaluate: what a batch deformation of new points costs */
        ffd_lattice_binding *b = NULL;
        double t0 = bench_now();
        if (ffd_lattice_bind(lat, p, n, FFD_OUTSIDE_FIXED, &b, &err) ||
            ffd_lattice_eval(lat, b, q, &err)) {
            fprintf(stderr, "bench_peers: %s\n", err.message);
            return 1;
        }
        t_bind[r] = bench_now() - t0;
        /* a move of every control point, then evaluate: an interactive drag */
        for (unsigned i = 0; i < 3 * CONTROLS; i++)
            delta[i] = -delta[i];
        t0 = bench_now();
        ffd_lattice_add(lat, delta, &err);
        ffd_lattice_eval(lat, b, q, &err);
        t_move[r] = bench_now() - t0;
        ffd_lattice_binding_destroy(b);
    }
    qsort(t_bind, (size_t)rounds, sizeof *t_bind, bench_cmp_double);
    qsort(t_move, (size_t)rounds, sizeof *t_move, bench_cmp_double);
    printf("bind+eval %.3f eval_after_move %.3f\n", 1e3 * t_bind[rounds / 2],
           1e3 * t_move[rounds / 2]);
    ffd_lattice_destroy(lat);
    free(p);
    free(q);
    free(t_bind);
    free(t_move);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "path") == 0) {
        printf("%s\n", ffd_simd_path_name(ffd_lattice_simd_path()));
        return 0;
    }
    if (argc == 4 && strcmp(argv[1], "gen") == 0)
        return gen(strtoull(argv[2], NULL, 10), argv[3]);
    if (argc == 5 && strcmp(argv[1], "time") == 0)
        return time_library(argv[2], argv[3], atoi(argv[4]) > 0 ? atoi(argv[4]) : 1);
    fprintf(stderr, "usage: bench_peers gen N DIR | time DIR bspline|bernstein ROUNDS | path\n");
    return 2;
}
