/* Benchmark: nested lattices and the falloff outside the lattice
 * (docs/lattice-variants.md): bind and evaluate N points (default 1M) through
 * the generic deformer, against the plain lattice with the same root.
 * Usage: bench_lattice_nested [POINTS] [--quick]   (numbers go to docs/benchmarks.md by hand)
 *
 * Cases: "plain" (a 5^3 B-spline root, outside "clamp"), "falloff" (the same
 * root, "outside": "falloff" over 0.25; points fill [-0.2, 1.2]^3 so about
 * 64% lie outside the box), "nested-2" (a child over [0.25, 0.75]^3 and a
 * grandchild over [0.4, 0.6]^3: 1/8 and 1/125 of the points), and
 * "nested-8" (eight sibling children, one per octant, each with a child).
 * Each row: bind (ffd_deformer_bind), evaluate (ffd_deformer_eval) and one
 * control move + evaluate, medians. */
#include "ffd.h"
#include "bench_util.h"

#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng = 0x243F6A8885A308D3ull;

static const char *child(double lo, double size, const char *inner)
{
    static char buf[8][512];
    static int k;
    char *b = buf[k++ % 8];
    snprintf(b, 512,
             "{\"box\": {\"origin\": [%g, %g, %g], \"axes\": [[%g, 0, 0], [0, %g, 0], [0, 0, %g]]},"
             " \"resolution\": [4, 4, 4], \"moves\": [{\"index\": [1, 2, 1], \"delta\": [0.01, 0, "
             "0]}]%s%s%s}",
             lo, lo, lo, size, size, size, inner ? ", \"children\": [" : "", inner ? inner : "",
             inner ? "]" : "");
    return b;
}

int main(int argc, char **argv)
{
    size_t n = 1000000;
    int quick = 0;
    for (int a = 1; a < argc; a++) {
        if (strcmp(argv[a], "--quick") == 0)
            quick = 1;
        else
            n = (size_t)strtoull(argv[a], NULL, 10);
    }
    const int reps = quick ? 3 : 9;
    double *pts = malloc(3 * n * sizeof *pts), *out = malloc(3 * n * sizeof *out);
    for (size_t i = 0; i < 3 * n; i++)
        pts[i] = -0.2 + 1.4 * bench_rnd(&rng);
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    if (!pts || !out || ffd_mesh_create(pts, n, NULL, NULL, 0, &mesh, &err)) {
        fprintf(stderr, "setup: %s\n", err.message);
        return 1;
    }
    const char *root = "\"resolution\": [5, 5, 5], \"box\": {\"origin\": [0, 0, 0], \"axes\": "
                       "[[1, 0, 0], [0, 1, 0], [0, 0, 1]]}, \"moves\": [{\"index\": [2, 2, 2], "
                       "\"delta\": [0.05, 0, 0]}]";
    static char rigs[4][8192];
    snprintf(rigs[0], sizeof rigs[0], "{%s, \"outside\": \"clamp\"}", root);
    snprintf(rigs[1], sizeof rigs[1], "{%s, \"outside\": \"falloff\", \"falloff\": 0.25}", root);
    snprintf(rigs[2], sizeof rigs[2], "{%s, \"outside\": \"clamp\", \"children\": [%s]}", root,
             child(0.25, 0.5, child(0.4, 0.2, NULL)));
    int len = snprintf(rigs[3], sizeof rigs[3], "{%s, \"outside\": \"clamp\", \"children\": [", root);
    for (int o = 0; o < 8; o++) {
        double x = (o & 1) * 0.5, y = (o >> 1 & 1) * 0.5, z = (o >> 2 & 1) * 0.5;
        len += snprintf(rigs[3] + len, sizeof rigs[3] - (size_t)len,
                        "%s{\"box\": {\"origin\": [%g, %g, %g], \"axes\": [[0.5, 0, 0], [0, 0.5, "
                        "0], [0, 0, 0.5]]}, \"children\": [{\"box\": {\"origin\": [%g, %g, %g], "
                        "\"axes\": [[0.2, 0, 0], [0, 0.2, 0], [0, 0, 0.2]]}}]}",
                        o ? ", " : "", x, y, z, x + 0.15, y + 0.15, z + 0.15);
    }
    snprintf(rigs[3] + len, sizeof rigs[3] - (size_t)len, "]}");
    const char *names[] = {"plain", "falloff", "nested-2", "nested-8"};
    printf("threads: %d, %zu points\n", omp_get_max_threads(), n);
    printf("| rig | controls | bind ms | evaluate ms | move + evaluate ms |\n|---|---:|---:|---:|---:|\n");
    for (int c = 0; c < 4; c++) {
        ffd_deformer *d = NULL;
        if (ffd_deformer_create_json(rigs[c], strlen(rigs[c]), names[c], mesh, NULL, &d, &err)) {
            fprintf(stderr, "%s: %s\n", names[c], err.message);
            return 1;
        }
        double tb[16], te[16], tm[16];
        for (int r = 0; r < reps; r++) {
            double t0 = bench_now();
            if (ffd_deformer_bind(d, pts, n, &err))
                return 1;
            double t1 = bench_now();
            if (ffd_deformer_eval(d, out, &err))
                return 1;
            double t2 = bench_now();
            uint32_t id = 62;
            const double delta[3] = {r % 2 ? -0.01 : 0.01, 0, 0};
            if (ffd_deformer_move_controls(d, &id, 1, delta, &err) || ffd_deformer_eval(d, out, &err))
                return 1;
            tb[r] = t1 - t0, te[r] = t2 - t1, tm[r] = bench_now() - t2;
        }
        qsort(tb, (size_t)reps, sizeof *tb, bench_cmp_double);
        qsort(te, (size_t)reps, sizeof *te, bench_cmp_double);
        qsort(tm, (size_t)reps, sizeof *tm, bench_cmp_double);
        printf("| %s | %zu | %.2f | %.2f | %.2f |\n", names[c], ffd_deformer_control_count(d),
               1e3 * tb[reps / 2], 1e3 * te[reps / 2], 1e3 * tm[reps / 2]);
        ffd_deformer_destroy(d);
    }
    ffd_mesh_destroy(mesh);
    free(pts);
    free(out);
    return 0;
}
