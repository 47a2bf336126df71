/* mpi_compare — the union of a distributed run's pieces against the
 * one-process result (tests/mpi/test_mpi.sh): every vertex of every piece has
 * the position of the reference vertex with its global id, bitwise (or within
 * --tol times the reference's bounding-box diagonal), and every reference
 * vertex is on some piece. Global ids as ffd-mpi reads them (tools/mpi/partition.c);
 * a piece without them continues the rank-major numbering of those before it.
 *
 * usage: mpi_compare [--tol T] [--rest REST] REF PIECE...
 *   --rest REST  also require that REF differs from REST (the mesh before the
 *                deformation) somewhere, so that an identity run cannot pass
 * Exit 0 when equal, 1 with the first differences on stderr. */
#include "partition.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct id_index {
    uint64_t id;
    size_t index;
} id_index;

static int by_id(const void *a, const void *b)
{
    const id_index *x = a, *y = b;
    return x->id < y->id ? -1 : x->id > y->id;
}

static ffd_mesh *read_mesh(const char *path)
{
    ffd_mesh *m = NULL;
    ffd_error e = {{0}};
    if (ffd_mesh_read(path, &m, &e) != FFD_OK) {
        fprintf(stderr, "mpi_compare: %s\n", e.message);
        return NULL;
    }
    return m;
}

static uint64_t *ids_of(const ffd_mesh *m, const char *path, int *failed)
{
    uint64_t *ids = NULL;
    const char *source;
    ffd_error e = {{0}};
    *failed = 0;
    if (part_global_ids(m, path, &ids, &source, &e) != FFD_OK) {
        fprintf(stderr, "mpi_compare: %s\n", e.message);
        *failed = 1;
    }
    return ids;
}

int main(int argc, char **argv)
{
    double tol = 0;
    const char *rest_path = NULL;
    int a = 1;
    for (; a < argc && argv[a][0] == '-'; a++) {
        if (strcmp(argv[a], "--tol") == 0 && a + 1 < argc)
            tol = atof(argv[++a]);
        else if (strcmp(argv[a], "--rest") == 0 && a + 1 < argc)
            rest_path = argv[++a];
        else
            break;
    }
    if (argc - a < 2) {
        fputs("usage: mpi_compare [--tol T] [--rest REST] REF PIECE...\n", stderr);
        return 2;
    }
    const char *ref_path = argv[a++];
    ffd_mesh *ref = read_mesh(ref_path);
    if (!ref)
        return 1;
    int failed;
    uint64_t *ref_ids = ids_of(ref, ref_path, &failed);
    if (failed)
        return 1;
    size_t n = ffd_mesh_vertex_count(ref);
    const double *rp = ffd_mesh_positions(ref);
    id_index *map = malloc((n ? n : 1) * sizeof *map);
    unsigned char *seen = calloc(n ? n : 1, 1);
    if (!map || !seen)
        return 1;
    for (size_t i = 0; i < n; i++)
        map[i] = (id_index){ref_ids ? ref_ids[i] : i, i};
    qsort(map, n, sizeof *map, by_id);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], rp[3 * i + k]);
            hi[k] = fmax(hi[k], rp[3 * i + k]);
        }
    double diag = n ? sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                           (hi[2] - lo[2]) * (hi[2] - lo[2]))
                    : 0;
    size_t bad = 0, checked = 0;
    uint64_t rank_major = 0;
    for (; a < argc; a++) {
        ffd_mesh *piece = read_mesh(argv[a]);
        if (!piece)
            return 1;
        uint64_t *ids = ids_of(piece, argv[a], &failed);
        if (failed)
            return 1;
        size_t pn = ffd_mesh_vertex_count(piece);
        const double *pp = ffd_mesh_positions(piece);
        for (size_t i = 0; i < pn; i++) {
            id_index key = {ids ? ids[i] : rank_major + i, 0};
            const id_index *hit = bsearch(&key, map, n, sizeof *map, by_id);
            if (!hit) {
                if (bad++ < 5)
                    fprintf(stderr, "mpi_compare: %s: vertex %zu: global id %llu is not in %s\n",
                            argv[a], i, (unsigned long long)key.id, ref_path);
                continue;
            }
            seen[hit->index] = 1;
            const double *x = pp + 3 * i, *y = rp + 3 * hit->index;
            int same = tol > 0 ? fabs(x[0] - y[0]) <= tol * diag &&
                                     fabs(x[1] - y[1]) <= tol * diag &&
                                     fabs(x[2] - y[2]) <= tol * diag
                               : memcmp(x, y, 3 * sizeof *x) == 0;
            checked++;
            if (!same && bad++ < 5)
                fprintf(stderr, "mpi_compare: %s: vertex %zu (global id %llu): %.17g %.17g %.17g, "
                        "%s: %.17g %.17g %.17g\n", argv[a], i, (unsigned long long)key.id, x[0],
                        x[1], x[2], ref_path, y[0], y[1], y[2]);
        }
        rank_major += pn;
        free(ids);
        ffd_mesh_destroy(piece);
    }
    size_t missing = 0;
    for (size_t i = 0; i < n; i++)
        if (!seen[i] && missing++ < 5)
            fprintf(stderr, "mpi_compare: %s: vertex %zu is on no piece\n", ref_path, i);
    bad += missing;
    if (rest_path) {
        ffd_mesh *rest = read_mesh(rest_path);
        if (!rest)
            return 1;
        if (ffd_mesh_vertex_count(rest) == n &&
            memcmp(ffd_mesh_positions(rest), rp, 3 * n * sizeof *rp) == 0) {
            fprintf(stderr, "mpi_compare: %s is %s: the rig moved nothing\n", ref_path, rest_path);
            bad++;
        }
        ffd_mesh_destroy(rest);
    }
    if (bad)
        fprintf(stderr, "mpi_compare: %zu difference%s (%zu piece vertices checked)\n", bad,
                bad == 1 ? "" : "s", checked);
    free(ref_ids);
    free(map);
    free(seen);
    ffd_mesh_destroy(ref);
    return bad ? 1 : 0;
}
