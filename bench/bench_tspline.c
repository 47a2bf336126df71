/* bench_tspline — proxy-driven T-spline FFD (Zhang, Zheng & Cai 2020)
 * timings set beside the paper's Table 1 and Fig. 10.
 *
 * Part 1, per example: the meshes of data/ with the lattice sizes of
 * Table 1; set-up (lattice, binding, proxy) + one refinement edit (an octree
 * split of the proxy cells in the upper third of the box, all in one batch)
 * + a 5-iteration ARAP deformation (the proxy points of the lower quarter
 * frozen, those of the top eighth moved). Target: <= 50 ms per example.
 *
 * Part 2, a drag: a 12 x 12 x 12 lattice (1728 control points) on
 * refined_elephant.off subdivided 1 -> 4 (about 178K vertices), and on its
 * first 100,000 vertices with the faces among them; one drag
 * step = ARAP solve (5 iterations, cached factor) + re-evaluation of every
 * vertex. Target: <= 16 ms per step.
 *
 * Usage: bench_tspline [data_dir] (default: the repository's data/). Prints a
 * Markdown table. */
#include "ffd.h"
#include "bench_mesh.h"
#include "bench_util.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double now(void)
{
    return omp_get_wtime();
}

/* One example of Table 1 on a shared mesh: returns 0 on success. */
static int example(const char *dir, const char *file, uint32_t a, uint32_t b, uint32_t c,
                   const char *paper)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &m, &err) != FFD_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    const int reps = 5;
    double best_setup = 1e9, best_refine = 1e9, best_arap = 1e9, best_total = 1e9;
    size_t cp0 = 0, cp1 = 0, pv0 = 0, pf0 = 0, pv1 = 0, pf1 = 0;
    for (int r = 0; r < reps; r++) {
        uint32_t res[3] = {a, b, c};
        double t0 = now();
        ffd_tsv *t = NULL;
        if (ffd_tsv_create(ffd_mesh_positions(m), ffd_mesh_vertex_count(m),
                           ffd_mesh_face_offsets(m), ffd_mesh_face_indices(m),
                           ffd_mesh_face_count(m), res, NULL, &t, &err) != FFD_OK) {
            fprintf(stderr, "%s: %s\n", file, err.message);
            ffd_mesh_destroy(m);
            return 1;
        }
        double t1 = now();
        ffd_tsv_proxy px;
        ffd_tsv_get_proxy(t, &px);
        cp0 = ffd_tsv_control_count(t);
        pv0 = px.vertex_count;
        pf0 = px.face_count;
        /* octree-split the proxy's cells in the upper third (y) of the box */
        ffd_tsv_insertion *ins = malloc(px.face_count * sizeof *ins);
        size_t k = 0;
        for (size_t f = 0; f < px.face_count; f++) {
            uint32_t cell = px.face_cells[f];
            double lo[3], hi[3];
            ffd_tsv_element_box(t, FFD_TSV_CELL, cell, lo, hi, NULL);
            int dup = 0, thick = 0;
            for (size_t j = 0; j < k && !dup; j++)
                dup = ins[j].id == cell;
            for (int d = 0; d < 3; d++)
                thick |= hi[d] > lo[d]; /* a corner cell of the end layers cannot split */
            if (!dup && thick && lo[1] >= 2.0 / 3.0 - 1e-12)
                ins[k++] = (ffd_tsv_insertion){FFD_TSV_CELL, cell, 0};
        }
        if (ffd_tsv_refine(t, ins, k, NULL, &err) != FFD_OK) {
            fprintf(stderr, "%s: refine: %s\n", file, err.message);
            free(ins);
            ffd_tsv_destroy(t);
            ffd_mesh_destroy(m);
            return 1;
        }
        free(ins);
        double t2 = now();
        ffd_tsv_get_proxy(t, &px);
        cp1 = ffd_tsv_control_count(t);
        pv1 = px.vertex_count;
        pf1 = px.face_count;
        /* freeze the lower quarter of the proxy, move its top eighth */
        double mn[3], mx[3];
        ffd_tsv_box(t, mn, mx);
        const double *P = ffd_tsv_control_points(t);
        uint32_t *h = malloc(px.vertex_count * sizeof *h);
        size_t nh = 0;
        for (size_t i = 0; i < px.vertex_count; i++) {
            uint32_t v = px.vertices[i];
            double y = (P[3 * (size_t)v + 1] - mn[1]) / (mx[1] - mn[1]);
            if (y < 0.25)
                ffd_tsv_set_frozen(t, v, 1, NULL);
            else if (y > 0.875)
                h[nh++] = v;
        }
        double *q = malloc(3 * (nh ? nh : 1) * sizeof *q);
        for (size_t i = 0; i < nh; i++)
            for (int d = 0; d < 3; d++)
                q[3 * i + d] = P[3 * (size_t)h[i] + d] + (d == 0 ? 0.15 * (mx[0] - mn[0]) : 0);
        ffd_tsv_arap *arap = NULL;
        double *x = malloc(3 * ffd_mesh_vertex_count(m) * sizeof *x);
        if (ffd_tsv_arap_begin(t, h, nh, NULL, &arap, &err) != FFD_OK ||
            ffd_tsv_arap_solve(arap, q, NULL, &err) != FFD_OK ||
            ffd_tsv_eval(t, x, &err) != FFD_OK) {
            fprintf(stderr, "%s: arap: %s\n", file, err.message);
            return 1;
        }
        double t3 = now();
        ffd_tsv_arap_destroy(arap);
        free(x);
        free(q);
        free(h);
        ffd_tsv_destroy(t);
        if (t1 - t0 < best_setup)
            best_setup = t1 - t0;
        if (t2 - t1 < best_refine)
            best_refine = t2 - t1;
        if (t3 - t2 < best_arap)
            best_arap = t3 - t2;
        if (t3 - t0 < best_total)
            best_total = t3 - t0;
    }
    printf("| %s (%zu) | %ux%ux%u (%zu) | %zu / %zu | %zu | %zu / %zu | %.1f | %.1f | %.1f | "
           "**%.1f** | %s |\n",
           file, ffd_mesh_vertex_count(m), a, b, c, cp0, pv0, pf0, cp1, pv1, pf1,
           1e3 * best_setup, 1e3 * best_refine, 1e3 * best_arap, 1e3 * best_total, paper);
    ffd_mesh_destroy(m);
    return 0;
}

static int drag(const char *dir, size_t limit)
{
    double *P;
    uint32_t *off, *idx;
    size_t nv, nf;
    ffd_error err = {{0}};
    if (bench_elephant(dir, limit, &P, &nv, &off, &idx, &nf))
        return 1;
    uint32_t res[3] = {12, 12, 12};
    ffd_tsv *t = NULL;
    double t0 = now();
    if (ffd_tsv_create(P, nv, off, idx, nf, res, NULL, &t, &err) != FFD_OK) {
        fprintf(stderr, "drag: %s\n", err.message);
        return 1;
    }
    double t1 = now();
    ffd_tsv_proxy px;
    ffd_tsv_get_proxy(t, &px);
    double mn[3], mx[3];
    ffd_tsv_box(t, mn, mx);
    const double *C = ffd_tsv_control_points(t);
    uint32_t *h = malloc(px.vertex_count * sizeof *h);
    size_t nh = 0;
    for (size_t i = 0; i < px.vertex_count; i++) {
        uint32_t v = px.vertices[i];
        double y = (C[3 * (size_t)v + 1] - mn[1]) / (mx[1] - mn[1]);
        if (y < 0.2)
            ffd_tsv_set_frozen(t, v, 1, NULL);
        else if (y > 0.9)
            h[nh++] = v;
    }
    double *base = malloc(3 * nh * sizeof *base), *q = malloc(3 * nh * sizeof *q);
    for (size_t i = 0; i < nh; i++)
        memcpy(base + 3 * i, C + 3 * (size_t)h[i], 3 * sizeof(double));
    ffd_tsv_arap *arap = NULL;
    double t2 = now();
    if (ffd_tsv_arap_begin(t, h, nh, NULL, &arap, &err) != FFD_OK) {
        fprintf(stderr, "drag: %s\n", err.message);
        return 1;
    }
    double t3 = now();
    double *x = malloc(3 * nv * sizeof *x);
    enum { STEPS = 30 };
    double solve[STEPS], eval[STEPS], step[STEPS];
    for (int s = 0; s < STEPS; s++) {
        for (size_t i = 0; i < nh; i++)
            for (int d = 0; d < 3; d++)
                q[3 * i + d] = base[3 * i + d] + (d == 0 ? 0.01 * (s + 1) * (mx[0] - mn[0]) : 0);
        double a = now();
        if (ffd_tsv_arap_solve(arap, q, NULL, &err) != FFD_OK) {
            fprintf(stderr, "drag: %s\n", err.message);
            return 1;
        }
        double b = now();
        ffd_tsv_eval(t, x, NULL);
        double c = now();
        solve[s] = b - a;
        eval[s] = c - b;
        step[s] = c - a;
    }
    qsort(solve, STEPS, sizeof(double), bench_cmp_double);
    qsort(eval, STEPS, sizeof(double), bench_cmp_double);
    qsort(step, STEPS, sizeof(double), bench_cmp_double);
    printf("\n| drag: 12x12x12 (%zu control points), %zu vertices, %zu faces, %zu proxy points, "
           "%zu handles, threads %d | ms |\n|---|---:|\n",
           ffd_tsv_control_count(t), nv, nf, px.vertex_count, nh, omp_get_max_threads());
    printf("| set-up (lattice, binding, proxy; Phi is built by the first evaluation) | %.1f |\n",
           1e3 * (t1 - t0));
    printf("| drag start (graphs, CHOLMOD factorisation) | %.1f |\n", 1e3 * (t3 - t2));
    printf("| ARAP solve, 5 iterations (median) | %.2f |\n", 1e3 * solve[STEPS / 2]);
    printf("| re-evaluate %zu vertices (median) | %.2f |\n", nv, 1e3 * eval[STEPS / 2]);
    printf("| **drag step** (median; min %.2f, max %.2f) | **%.2f** |\n", 1e3 * step[0],
           1e3 * step[STEPS - 1], 1e3 * step[STEPS / 2]);
    ffd_tsv_arap_destroy(arap);
    ffd_tsv_destroy(t);
    free(x);
    free(q);
    free(base);
    free(h);
    free(P);
    free(off);
    free(idx);
    return 0;
}

int main(int argc, char **argv)
{
    char data_dir[1024];
    const char *dir = argc > 1 ? argv[1] : bench_data_dir(data_dir, sizeof data_dir);
    printf("| mesh (#v) | lattice (#cp) | proxy #v / #f | refined #cp | proxy after #v / #f | "
           "set-up ms | refine ms | ARAP+eval ms | total ms | paper (Table 1) |\n"
           "|---|---|---|---|---|---:|---:|---:|---:|---|\n");
    int bad = 0;
    bad |= example(dir, "bunny.obj", 6, 7, 5, "Rabbit 6x7x5: 1.376 s");
    bad |= example(dir, "elephant.off", 5, 8, 6, "Lamp 5x8x6: 0.988 s");
    bad |= example(dir, "cow.off", 7, 5, 6, "Face 7x5x6: 1.571 s");
    bad |= example(dir, "hinge.stl", 5, 8, 7, "Chair 5x8x7: 0.49 s");
    bad |= example(dir, "teapot.obj", 8, 6, 6, "Cup 8x6x6: 1.134 s");
    bad |= example(dir, "double-torus-example.off", 7, 8, 6, "Bottle 7x8x6: 0.392 s");
    bad |= example(dir, "elephant.off", 5, 5, 9, "Dolphin 5x5x9: 0.616 s");
    bad |= drag(dir, 100000);
    bad |= drag(dir, 0);
    return bad;
}
