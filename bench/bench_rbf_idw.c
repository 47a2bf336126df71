/* bench_rbf_idw — RBF morphing and IDW (docs/rbf-idw.md): for each method
 * and each control-point count, the time to bind (RBF: build and factor the
 * (N+4)^2 system, or with the Wendland kernel beyond 2000 control points its
 * sparse CHOLMOD factor; IDW: copy the control points), to move the control points
 * (RBF: one solve), and to evaluate N_POINTS points (median of 3), on random
 * points in the unit cube with control points spread over it.
 *
 * usage: bench_rbf_idw [POINTS] [CONTROLS...]   (default 1000000 50 5000) */
#include "bench_util.h"

#include "ffd.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void fill(double *p, size_t n, uint64_t *state, double lo, double hi)
{
    for (size_t i = 0; i < 3 * n; i++)
        p[i] = lo + (hi - lo) * bench_rnd(state);
}

int main(int argc, char **argv)
{
    size_t n = argc > 1 ? strtoull(argv[1], NULL, 10) : 1000000;
    size_t counts[8] = {50, 5000};
    int ncounts = 2;
    if (argc > 2) {
        ncounts = 0;
        for (int i = 2; i < argc && ncounts < 8; i++)
            counts[ncounts++] = strtoull(argv[i], NULL, 10);
    }
    uint64_t state = 0x9E3779B97F4A7C15ull;
    double *points = malloc(3 * n * sizeof *points), *out = malloc(3 * n * sizeof *out);
    if (!points || !out)
        return 1;
    fill(points, n, &state, 0, 1);
    printf("{\"points\": %zu, \"runs\": [\n", n);
    for (int c = 0; c < ncounts; c++) {
        size_t N = counts[c];
        double *cp = malloc(3 * N * sizeof *cp), *moved = malloc(3 * N * sizeof *moved);
        if (!cp || !moved)
            return 1;
        fill(cp, N, &state, -0.1, 1.1);
        for (size_t i = 0; i < 3 * N; i++)
            moved[i] = cp[i] + 0.02 * (bench_rnd(&state) - 0.5);
        for (int method = 0; method < 3; method++) { /* rbf multiquadric, idw, rbf wendland */
            ffd_error err = {{0}};
            ffd_rbf_morph *rbf = NULL;
            ffd_idw *idw = NULL;
            ffd_rbf_options ro = {method == 2 ? FFD_RBF_WENDLAND_C2 : FFD_RBF_MULTIQUADRIC, 0.3, 2,
                                  FFD_RBF_SOLVER_AUTO};
            double t0 = bench_now();
            ffd_status s = method != 1 ? ffd_rbf_morph_create(cp, N, &ro, &rbf, &err)
                                       : ffd_idw_create(cp, N, NULL, &idw, &err);
            double t1 = bench_now();
            if (!s)
                s = method != 1 ? ffd_rbf_morph_set_control_points(rbf, moved, &err)
                                : ffd_idw_set_control_points(idw, moved, &err);
            double t2 = bench_now(), ev[3];
            for (int r = 0; r < 3 && !s; r++) {
                double a = bench_now();
                s = method != 1 ? ffd_rbf_morph_eval(rbf, points, n, out, &err)
                                : ffd_idw_eval(idw, points, n, out, &err);
                ev[r] = bench_now() - a;
            }
            if (s) {
                fprintf(stderr, "bench_rbf_idw: %s\n", err.message);
                return 1;
            }
            printf("  {\"method\": \"%s\", \"controls\": %zu, \"bind_s\": %.6f, \"move_s\": %.6f, "
                   "\"eval_s\": %.6f, \"points_per_s\": %.4g}%s\n",
                   method == 0 ? "rbf multiquadric" : method == 1 ? "idw" : "rbf wendland", N, t1 - t0, t2 - t1, bench_median(ev, 3),
                   (double)n / bench_median(ev, 3), c + 1 == ncounts && method == 2 ? "" : ",");
            ffd_rbf_morph_destroy(rbf);
            ffd_idw_destroy(idw);
        }
        free(cp);
        free(moved);
    }
    printf("]}\n");
    free(points);
    free(out);
    return 0;
}
