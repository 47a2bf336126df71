/* bench_scale_tspline — the T-spline rig path (Zhang, Zheng & Cai 2020) as
 * the mesh grows: bind (ffd_tsv_create: lattice, support bins, Phi, proxy),
 * then after a move of the top layer of control points the rig's evaluation
 * (ffd_tsv_eval + ffd_tsv_jacobian + ffd_tsv_check_folds at 3^3 samples per
 * cell), on refined_elephant.off subdivided 1 -> 4 until it has N vertices
 * and cut to its first N (with the faces among them).
 *
 * Then the same through the rig (ffd_rig_apply of a "tspline" rig of one
 * "move" step, the top layer up; its report's bind and evaluate timings:
 * evaluate = the deformed points and Jacobians from one pass over the
 * blending functions, plus the fold check) and the process CPU time of the
 * whole ffd_rig_apply (all threads: steadier than wall time on a shared
 * machine).
 *
 * Prints time per vertex at each N (10^4 -> 10^6), which is flat when every
 * step is linear. Issue 17's "437K-vertex scan" is N = 437000 here. The
 * last column hashes the deformed points, Jacobians and fold report: two
 * builds that print the same hash computed the same bits.
 *
 * Usage: bench_scale_tspline [data_dir] [N ...] [--res R] [--rounds K]
 *        bench_scale_tspline [data_dir] --write N FILE
 * (default N: 10^4, 3*10^4, 10^5, 3*10^5, 437000, 10^6; R = 12; K = 3,
 * the median of K rounds is printed). --write only writes the N-vertex mesh
 * to FILE (any format ffd writes), e.g. to time `ffd tspline proxy` on it. */
#include "ffd.h"
#include "bench_mesh.h"
#include "bench_util.h"

#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* The elephant subdivided until it has at least n vertices, cut to n. */
static int mesh_of(const char *dir, size_t n, double **P, size_t *nv, uint32_t **off,
                   uint32_t **idx, size_t *nf)
{
    if (bench_elephant(dir, 0, P, nv, off, idx, nf))
        return 1;
    while (*nv < n) {
        double *Q;
        uint32_t *o, *ix;
        size_t m, g;
        subdivide(*P, *nv, *off, *idx, *nf, &Q, &m, &o, &ix, &g);
        free(*P);
        free(*off);
        free(*idx);
        *P = Q, *nv = m, *off = o, *idx = ix, *nf = g;
    }
    size_t kept = 0;
    for (size_t f = 0; f < *nf; f++) {
        const uint32_t *v = *idx + (*off)[f];
        if (v[0] < n && v[1] < n && v[2] < n) {
            memmove(*idx + 3 * kept, v, 3 * sizeof(uint32_t));
            kept++;
            (*off)[kept] = (uint32_t)(3 * kept);
        }
    }
    *nf = kept;
    *nv = n;
    return 0;
}

/* FNV-1a over the bytes of n doubles: equal outputs across builds print equal sums. */
static uint64_t checksum(const double *x, size_t n, uint64_t h)
{
    const unsigned char *b = (const unsigned char *)x;
    for (size_t i = 0; i < n * sizeof(double); i++)
        h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

static int run(const char *dir, size_t n, uint32_t r, int rounds)
{
    double *P;
    uint32_t *off, *idx;
    size_t nv, nf;
    if (mesh_of(dir, n, &P, &nv, &off, &idx, &nf))
        return 1;
    double *x = malloc(3 * nv * sizeof *x), *J = malloc(9 * nv * sizeof *J);
    double bind[16], eval[16], jac[16], fold[16], total[16], rbind[16], reval[16], rcpu[16];
    ffd_mesh *mesh = NULL;
    ffd_rig *rig = NULL;
    ffd_error rerr = {{0}};
    char json[512];
    snprintf(json, sizeof json,
             "{\"version\": 1, \"deformer\": \"tspline\", \"resolution\": [%u, %u, %u], "
             "\"steps\": [{\"move\": [{\"box\": {\"min\": [-1e9, 0.4, -1e9], \"max\": [1e9, 1e9, 1e9]}, "
             "\"delta\": [0, 0.05, 0]}]}]}",
             r, r, r);
    if (ffd_mesh_create(P, nv, off, idx, nf, &mesh, &rerr) != FFD_OK ||
        ffd_rig_parse_json(json, strlen(json), "scale.json", &rig, &rerr) != FFD_OK) {
        fprintf(stderr, "%zu: %s\n", n, rerr.message);
        return 1;
    }
    size_t cells = 0;
    uint64_t sum = 0;
    for (int k = 0; k < rounds; k++) {
        ffd_error err = {{0}};
        uint32_t res[3] = {r, r, r};
        ffd_tsv *t = NULL;
        double t0 = omp_get_wtime();
        if (ffd_tsv_create(P, nv, off, idx, nf, res, NULL, &t, &err) != FFD_OK) {
            fprintf(stderr, "%zu: %s\n", n, err.message);
            return 1;
        }
        double t1 = omp_get_wtime();
        /* move the top layer (y) of control points up by 5 % of the box */
        double mn[3], mx[3];
        ffd_tsv_box(t, mn, mx);
        const double *C = ffd_tsv_control_points(t);
        size_t nc = ffd_tsv_control_count(t);
        for (size_t v = 0; v < nc; v++)
            if (C[3 * v + 1] > mn[1] + 0.8 * (mx[1] - mn[1])) {
                double d[3] = {0, 0.05 * (mx[1] - mn[1]), 0};
                ffd_tsv_move(t, (uint32_t)v, d, NULL);
            }
        double t2 = omp_get_wtime();
        ffd_tsv_eval(t, x, NULL);
        double t3 = omp_get_wtime();
        ffd_tsv_jacobian(t, J, NULL);
        double t4 = omp_get_wtime();
        ffd_tsv_fold_report fr;
        if (ffd_tsv_check_folds(t, 3, &fr, &err) != FFD_OK) {
            fprintf(stderr, "%zu: %s\n", n, err.message);
            return 1;
        }
        double t5 = omp_get_wtime();
        cells = fr.cells_checked;
        sum = checksum(x, 3 * nv, 1469598103934665603ull);
        sum = checksum(J, 9 * nv, sum);
        sum = checksum(&fr.min_det, 1, sum);
        sum ^= (uint64_t)fr.folded_cell_count << 32 ^ (uint64_t)fr.inverted_face_count;
        ffd_tsv_fold_report_free(&fr);
        ffd_tsv_destroy(t);
        bind[k] = t1 - t0;
        eval[k] = t3 - t2;
        jac[k] = t4 - t3;
        fold[k] = t5 - t4;
        total[k] = (t1 - t0) + (t5 - t2);
        ffd_mesh *copy = NULL;
        ffd_rig_report rep;
        ffd_limits lim = {0};
        lim.unlimited = 1;
        clock_t c0 = 0;
        if (ffd_mesh_create(P, nv, off, idx, nf, &copy, &rerr) != FFD_OK ||
            (c0 = clock(), ffd_rig_apply_limited(rig, copy, &lim, &rep, &rerr)) != FFD_OK) {
            fprintf(stderr, "%zu: rig: %s\n", n, rerr.message);
            return 1;
        }
        rcpu[k] = (double)(clock() - c0) / CLOCKS_PER_SEC;
        rbind[k] = rep.timings.bind;
        reval[k] = rep.timings.evaluate;
        ffd_rig_report_free(&rep);
        ffd_mesh_destroy(copy);
    }
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(mesh);
    double *all[] = {bind, eval, jac, fold, total, rbind, reval, rcpu};
    for (int i = 0; i < 8; i++)
        qsort(all[i], (size_t)rounds, sizeof(double), bench_cmp_double);
    int m = rounds / 2;
    printf("| %zu | %zu | %zu | %.1f | %.1f | %.1f | %.1f | **%.1f** | %.2f | %016llx | %.1f | "
           "%.1f | **%.1f** | %.2f | %.1f |\n",
           nv, nf, cells, 1e3 * bind[m], 1e3 * eval[m], 1e3 * jac[m], 1e3 * fold[m],
           1e3 * total[m], 1e6 * total[m] / (double)nv, (unsigned long long)sum, 1e3 * rbind[m],
           1e3 * reval[m], 1e3 * (rbind[m] + reval[m]), 1e6 * (rbind[m] + reval[m]) / (double)nv,
           1e3 * rcpu[m]);
    fflush(stdout);
    free(x);
    free(J);
    free(P);
    free(off);
    free(idx);
    return 0;
}

/* --write N FILE: the N-vertex mesh of the table, written by the library. */
static int write_mesh(const char *dir, size_t n, const char *path)
{
    double *P;
    uint32_t *off, *idx;
    size_t nv, nf;
    if (mesh_of(dir, n, &P, &nv, &off, &idx, &nf))
        return 1;
    ffd_mesh *m = NULL;
    ffd_error err = {0};
    int bad = ffd_mesh_create(P, nv, off, idx, nf, &m, &err) != FFD_OK ||
              ffd_mesh_write(m, path, NULL, &err) != FFD_OK;
    if (bad)
        fprintf(stderr, "bench_scale_tspline: %s\n", err.message);
    ffd_mesh_destroy(m);
    free(P);
    free(off);
    free(idx);
    return bad;
}

int main(int argc, char **argv)
{
    char data_dir[1024];
    const char *dir = bench_data_dir(data_dir, sizeof data_dir);
    size_t sizes[32], ns = 0;
    uint32_t res = 12;
    int rounds = 3;
    const char *write_path = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--write") && i + 2 < argc) {
            sizes[ns++] = (size_t)strtod(argv[++i], NULL);
            write_path = argv[++i];
        } else if (!strcmp(argv[i], "--res") && i + 1 < argc)
            res = (uint32_t)atoi(argv[++i]);
        else if (!strcmp(argv[i], "--rounds") && i + 1 < argc)
            rounds = atoi(argv[++i]);
        else if (argv[i][0] >= '0' && argv[i][0] <= '9' && ns < 32)
            sizes[ns++] = (size_t)strtod(argv[i], NULL);
        else
            dir = argv[i];
    }
    if (rounds < 1 || rounds > 16)
        rounds = 3;
    if (write_path)
        return write_mesh(dir, sizes[0], write_path);
    if (!ns) {
        size_t def[] = {10000, 30000, 100000, 300000, 437000, 1000000};
        memcpy(sizes, def, sizeof def);
        ns = sizeof def / sizeof *def;
    }
    printf("| T-spline %ux%ux%u, threads %d: vertices | faces | cells checked | bind ms | "
           "eval ms | Jacobian ms | fold check ms | bind + evaluate ms | us per vertex | "
           "checksum of x, J, folds | "
           "rig bind ms | rig evaluate ms | rig bind + evaluate ms | rig us per vertex | "
           "rig CPU ms (all threads, whole ffd_rig_apply) |\n"
           "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|\n",
           res, res, res, omp_get_max_threads());
    int bad = 0;
    for (size_t i = 0; i < ns; i++)
        bad |= run(dir, sizes[i], res, rounds);
    return bad;
}
