/* bench_mesh_io — mesh I/O throughput (issue 17): MB/s reading and writing
 * per format on a generated mesh, and the bytes of bookkeeping the mesh
 * keeps per vertex beyond its positions.
 *
 * usage: bench_mesh_io [VERTICES] [ROUNDS]   (default 1000000 vertices, 7 rounds)
 *
 * The mesh is a wavy grid of VERTICES vertices (two triangles per cell) with
 * coordinates that need 15-17 significant digits, made with ffd_mesh_create
 * and written in each format (binary PLY, binary STL, ascii PLY, OBJ, OFF).
 * For each format it reports the median over ROUNDS of:
 *   read       ffd_mesh_read_memory of the file (MB of file per second);
 *   write      ffd_mesh_write_memory from data (the first encoding);
 *   untouched  the lossless write of the mesh read back, nothing moved;
 *   moved      the same after every position moved (every value rewritten,
 *              what `ffd deform` and GFFD write).
 * Times are process CPU time (one thread). Peak RSS of `ffd deform` is
 * measured by bench/bench_deform_rss.sh. */
#include "ffd.h"
#include "mesh/mesh.h"
#include "bench_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* CPU time of this process: the I/O here is one thread, and on a shared
 * machine CPU time is what other processes disturb least. */
static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void die(const char *what, const ffd_error *err)
{
    fprintf(stderr, "bench_mesh_io: %s: %s\n", what, err->message);
    exit(1);
}

/* A wavy side x side grid, two triangles per cell. */
static ffd_mesh *make_mesh(size_t want)
{
    size_t side = (size_t)sqrt((double)want);
    if (side < 2)
        side = 2;
    size_t nv = side * side, nf = 2 * (side - 1) * (side - 1);
    double *P = malloc(3 * nv * sizeof *P);
    uint32_t *off = malloc((nf + 1) * sizeof *off), *idx = malloc(3 * nf * sizeof *idx);
    if (!P || !off || !idx)
        exit(1);
    for (size_t j = 0; j < side; j++)
        for (size_t i = 0; i < side; i++) {
            double *p = P + 3 * (j * side + i);
            p[0] = (double)i / (double)side;
            p[1] = (double)j / (double)side;
            p[2] = 0.1 * sin(7.0 * p[0]) * cos(5.0 * p[1]);
        }
    size_t f = 0;
    off[0] = 0;
    for (size_t j = 0; j + 1 < side; j++)
        for (size_t i = 0; i + 1 < side; i++) {
            uint32_t a = (uint32_t)(j * side + i), b = a + 1, c = a + (uint32_t)side, d = c + 1;
            uint32_t t[6] = {a, b, d, a, d, c};
            for (int k = 0; k < 6; k++)
                idx[3 * f + (size_t)k] = t[k];
            off[f + 1] = (uint32_t)(3 * (f + 1));
            off[f + 2] = (uint32_t)(3 * (f + 2));
            f += 2;
        }
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_create(P, nv, off, idx, nf, &m, &err) != FFD_OK)
        die("create", &err);
    free(P);
    free(off);
    free(idx);
    return m;
}

typedef struct {
    const char *label;
    ffd_format format;
    ffd_encoding encoding;
} target;

int main(int argc, char **argv)
{
    size_t nv = argc > 1 ? (size_t)strtoull(argv[1], NULL, 10) : 1000000;
    int rounds = argc > 2 ? atoi(argv[2]) : 7;
    if (rounds < 1 || rounds > 99)
        rounds = 7;
    ffd_mesh *base = make_mesh(nv);
    nv = ffd_mesh_vertex_count(base);
    double *moved = malloc(3 * nv * sizeof *moved);
    if (!moved)
        return 1;
    const double *P0 = ffd_mesh_positions(base);
    for (size_t i = 0; i < 3 * nv; i++)
        moved[i] = P0[i] * 1.0000001 + 1e-7;
    printf("bench_mesh_io: %zu vertices, %zu faces, median of %d rounds\n", nv,
           ffd_mesh_face_count(base), rounds);
    printf("span record %zu bytes: %zu bytes of bookkeeping per vertex (3 position spans)\n",
           sizeof(ffd_span), 3 * sizeof(ffd_span));
    printf("%-11s %9s %9s %9s %9s %9s\n", "format", "MB", "read", "write", "untouched", "moved");
    printf("%-11s %9s %9s %9s %9s %9s\n", "", "", "MB/s", "MB/s", "MB/s", "MB/s");
    const target targets[] = {
        {"ply binary", FFD_FORMAT_PLY, FFD_ENCODING_BINARY_LE},
        {"stl binary", FFD_FORMAT_STL, FFD_ENCODING_BINARY_LE},
        {"ply ascii", FFD_FORMAT_PLY, FFD_ENCODING_ASCII},
        {"obj", FFD_FORMAT_OBJ, FFD_ENCODING_ASCII},
        {"off", FFD_FORMAT_OFF, FFD_ENCODING_ASCII},
    };
    ffd_error err = {{0}};
    for (size_t t = 0; t < sizeof targets / sizeof *targets; t++) {
        ffd_write_options opt = {targets[t].format, targets[t].encoding, 0};
        double tr[99], tw[99], tu[99], tm[99];
        unsigned char *file = NULL;
        size_t size = 0;
        for (int r = 0; r < rounds; r++) {
            unsigned char *data;
            size_t n;
            double t0 = now();
            if (ffd_mesh_write_memory(base, &opt, &data, &n, &err) != FFD_OK)
                die("write", &err);
            tw[r] = now() - t0;
            if (!file) {
                file = data;
                size = n;
            } else {
                ffd_free(data);
            }
            ffd_mesh *m = NULL;
            t0 = now();
            if (ffd_mesh_read_memory(file, size, targets[t].format, "bench", &m, &err) != FFD_OK)
                die("read", &err);
            tr[r] = now() - t0;
            ffd_write_options same = {targets[t].format, FFD_ENCODING_SAME, 0};
            t0 = now();
            if (ffd_mesh_write_memory(m, &same, &data, &n, &err) != FFD_OK)
                die("untouched write", &err);
            tu[r] = now() - t0;
            if (n != size || memcmp(data, file, n) != 0) {
                fprintf(stderr, "bench_mesh_io: %s: untouched write differs\n", targets[t].label);
                return 1;
            }
            ffd_free(data);
            /* STL welds nothing: its vertices are the corners, so move those */
            size_t mv = ffd_mesh_vertex_count(m);
            double *Q = moved;
            double *own = NULL;
            if (mv != nv) {
                own = malloc(3 * mv * sizeof *own);
                const double *S = ffd_mesh_positions(m);
                for (size_t i = 0; i < 3 * mv; i++)
                    own[i] = S[i] * 1.0000001 + 1e-7;
                Q = own;
            }
            if (ffd_mesh_set_positions(m, Q, NULL, &err) != FFD_OK)
                die("set_positions", &err);
            free(own);
            t0 = now();
            if (ffd_mesh_write_memory(m, &same, &data, &n, &err) != FFD_OK)
                die("moved write", &err);
            tm[r] = now() - t0;
            ffd_free(data);
            ffd_mesh_destroy(m);
        }
        double mb = (double)size / 1e6;
        printf("%-11s %9.1f %9.0f %9.0f %9.0f %9.0f\n", targets[t].label, mb,
               mb / bench_median(tr, rounds), mb / bench_median(tw, rounds), mb / bench_median(tu, rounds),
               mb / bench_median(tm, rounds));
        fflush(stdout);
        ffd_free(file);
    }
    free(moved);
    ffd_mesh_destroy(base);
    return 0;
}
