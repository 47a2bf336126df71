/* bench_mpi — weak scaling of a distributed morph (ffd.h "Distributed runs",
 * docs/scaling.md): every rank holds the same number of points, so the whole
 * mesh grows with the ranks, and each phase is timed on its own.
 *
 *   mpirun -np P bench_mpi [--points N] [--reps R] [--case lattice|pbffd] [--surface K]
 *                          [--dir DIR]
 *
 * Rank r's piece: N points uniform in the slab [r, r+1] x [0, 1] x [0, 1]
 * (global ids r*N .. r*N+N-1, a point's position a hash of its id, so any
 * rank can name any point's target), and for --case pbffd also a triangulated
 * K x K sheet in the slab (its faces: the boundary surface the method reads;
 * PB-FFD's automatic placement runs on the gathered surface). The rig: the
 * lattice case a uniform cubic B-spline 8x8x8 with an auto box and 16 vertex
 * constraints on points spread over the ranks; the pbffd case automatic
 * placement (interior 40, exterior 40) and the same 16 constraints.
 *
 * Phases (seconds, the slowest rank's, MPI_Wtime): write the piece as .npy
 * (setup, not timed), read it back (read), ffd_rig_apply_distributed split by
 * its report's timings and by the communicator's callbacks (each global
 * step's message: what it carries and its time, waits for slower ranks
 * included), then ffd_deformer_create_distributed once and R evaluations of
 * the bound points after a control move (the design loop's step: median),
 * and writing the deformed piece (write).
 * Prints one table (rank 0). bench/mpi_weak.sh runs it for 1..4 ranks. */
#include <mpi.h>

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ffd.h"

/* ---------- the communicator over MPI, its calls timed ---------- */

typedef struct {
    char kind[48]; /* "allreduce 6 f64 max", "allgatherv" */
    double begin, end; /* MPI_Wtime() - the origin */
    size_t count; /* allreduce: values; allgatherv: every rank's bytes */
    size_t bytes; /* allreduce: count*8; allgatherv: every rank's bytes */
} call_log;

typedef struct {
    MPI_Comm comm;
    call_log *log;
    size_t count, cap;
    int logging;
    double origin;
} timed_comm;

static void log_call(timed_comm *c, const char *kind, double t0, size_t count, size_t bytes)
{
    if (!c->logging)
        return;
    if (c->count == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 64;
        call_log *l = realloc(c->log, cap * sizeof *l);
        if (!l)
            return;
        c->log = l;
        c->cap = cap;
    }
    call_log *e = &c->log[c->count++];
    snprintf(e->kind, sizeof e->kind, "%s", kind);
    e->begin = t0 - c->origin;
    e->end = MPI_Wtime() - c->origin;
    e->count = count;
    e->bytes = bytes;
}

static int mpi_allreduce(void *user, void *data, size_t count, ffd_reduce_type type, ffd_reduce_op op)
{
    timed_comm *c = user;
    static const char *const ops[] = {"sum", "min", "max", "or"};
    if (count > 0x7fffffff)
        return -1;
    MPI_Op o = op == FFD_REDUCE_SUM ? MPI_SUM
             : op == FFD_REDUCE_MIN ? MPI_MIN
             : op == FFD_REDUCE_MAX ? MPI_MAX
                                    : MPI_BOR;
    MPI_Datatype t = type == FFD_REDUCE_DOUBLE ? MPI_DOUBLE : MPI_UINT64_T;
    double t0 = MPI_Wtime();
    int rc = MPI_Allreduce(MPI_IN_PLACE, data, (int)count, t, o, c->comm);
    char kind[48];
    snprintf(kind, sizeof kind, "allreduce %zu %s %s", count, type == FFD_REDUCE_DOUBLE ? "f64" : "u64",
             ops[op]);
    log_call(c, kind, t0, count, count * 8);
    return rc != MPI_SUCCESS;
}

static int mpi_allgatherv(void *user, const void *mine, size_t bytes, void *all, const size_t *sizes)
{
    timed_comm *c = user;
    int p;
    MPI_Comm_size(c->comm, &p);
    int *counts = malloc((size_t)p * sizeof *counts), *displs = malloc((size_t)p * sizeof *displs);
    size_t total = 0;
    int ok = counts && displs;
    for (int r = 0; ok && r < p; r++) {
        if (sizes[r] > 0x7fffffff || total > 0x7fffffff)
            ok = 0;
        else {
            counts[r] = (int)sizes[r];
            displs[r] = (int)total;
            total += sizes[r];
        }
    }
    int rc = 1;
    if (ok && total <= 0x7fffffff) {
        double t0 = MPI_Wtime();
        rc = MPI_Allgatherv(mine, (int)bytes, MPI_BYTE, all, counts, displs, MPI_BYTE, c->comm) != MPI_SUCCESS;
        log_call(c, "allgatherv", t0, total, total);
    }
    free(counts);
    free(displs);
    return rc;
}

/* ---------- the piece ---------- */

static uint64_t mix(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

static double unit(uint64_t x) { return (double)(mix(x) >> 11) * (1.0 / 9007199254740992.0); }

/* the position of volume point g (of n per rank) */
static void point_of(uint64_t g, size_t n, double *p)
{
    p[0] = (double)(g / n) + unit(3 * g);
    p[1] = unit(3 * g + 1);
    p[2] = unit(3 * g + 2);
}

static double max_over_ranks(double v)
{
    MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    return v;
}

static int fail(int rank, const char *what, const ffd_error *err)
{
    fprintf(stderr, "bench_mpi: rank %d: %s: %s\n", rank, what, err ? err->message : "");
    MPI_Abort(MPI_COMM_WORLD, 1);
    return 1;
}

int main(int argc, char **argv)
{
    MPI_Init(&argc, &argv);
    int rank, size;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    size_t n = 1000000, k = 0;
    int reps = 5, pbffd = 0;
    const char *dir = "/tmp";
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--points") && i + 1 < argc)
            n = strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--case") && i + 1 < argc)
            pbffd = !strcmp(argv[++i], "pbffd");
        else if (!strcmp(argv[i], "--surface") && i + 1 < argc)
            k = strtoull(argv[++i], NULL, 10);
        else if (!strcmp(argv[i], "--dir") && i + 1 < argc)
            dir = argv[++i];
        else {
            if (!rank)
                fprintf(stderr, "usage: mpirun -np P bench_mpi [--points N] [--reps R] "
                                "[--case lattice|pbffd] [--surface K] [--dir DIR]\n");
            MPI_Finalize();
            return 2;
        }
    }
    if (n < 16)
        n = 16;
    if (reps < 1)
        reps = 1;
    if (pbffd && k < 2)
        k = 100;
    if (!pbffd)
        k = 0;
    ffd_error err = {{0}};

    /* the piece: n volume points, then a K x K sheet (pbffd) */
    size_t nv = n + k * k, nf = k ? 2 * (k - 1) * (k - 1) : 0;
    double *pos = malloc(nv * 3 * sizeof *pos);
    uint64_t *ids = malloc(nv * sizeof *ids);
    uint32_t *foff = malloc((nf + 1) * sizeof *foff), *fidx = malloc((3 * nf + 1) * sizeof *fidx);
    if (!pos || !ids || !foff || !fidx)
        return fail(rank, "allocation", NULL);
    for (size_t i = 0; i < n; i++) {
        ids[i] = (uint64_t)rank * n + i;
        point_of(ids[i], n, pos + 3 * i);
    }
    /* sheet vertices: ids after every rank's volume points */
    for (size_t a = 0; a < k; a++) {
        for (size_t b = 0; b < k; b++) {
            size_t v = n + a * k + b;
            ids[v] = (uint64_t)size * n + (uint64_t)rank * k * k + a * k + b;
            pos[3 * v] = rank + 0.1 + 0.8 * (double)a / (double)(k - 1);
            pos[3 * v + 1] = 0.1 + 0.8 * (double)b / (double)(k - 1);
            pos[3 * v + 2] = 0.5 + 0.05 * unit(ids[v]);
        }
    }
    foff[0] = 0;
    for (size_t a = 0, f = 0; a + 1 < k; a++) {
        for (size_t b = 0; b + 1 < k; b++) {
            uint32_t v00 = (uint32_t)(n + a * k + b), v10 = v00 + (uint32_t)k, v01 = v00 + 1, v11 = v10 + 1;
            uint32_t tri[2][3] = {{v00, v10, v11}, {v00, v11, v01}};
            for (int t = 0; t < 2; t++, f++) {
                memcpy(fidx + 3 * f, tri[t], sizeof tri[t]);
                foff[f + 1] = (uint32_t)(3 * (f + 1));
            }
        }
    }
    ffd_mesh *made = NULL;
    if (ffd_mesh_create(pos, nv, nf ? foff : NULL, nf ? fidx : NULL, nf, &made, &err))
        return fail(rank, "ffd_mesh_create", &err);
    char in_path[512], out_path[512];
    snprintf(in_path, sizeof in_path, "%s/bench_mpi_%d_%d.%s", dir, (int)getpid(), rank, nf ? "ply" : "npy");
    snprintf(out_path, sizeof out_path, "%s/bench_mpi_%d_%d_out.%s", dir, (int)getpid(), rank, nf ? "ply" : "npy");
    ffd_write_options wo = {0};
    wo.encoding = FFD_ENCODING_BINARY_LE;
    if (ffd_mesh_write(made, in_path, &wo, &err))
        return fail(rank, "writing the piece", &err);
    ffd_mesh_destroy(made);

    /* the rig: 16 constraints spread over the whole id range */
    char rig_text[8192];
    size_t at = (size_t)snprintf(rig_text, sizeof rig_text,
                                 pbffd ? "{\"version\": 1, \"deformer\": \"pbffd\", "
                                         "\"controls\": {\"interior\": 40, \"exterior\": 40}, \"constraints\": ["
                                       : "{\"version\": 1, \"deformer\": \"lattice\", \"basis\": \"bspline\", "
                                         "\"resolution\": [8, 8, 8], \"box\": \"auto\", \"margin\": 0.02, "
                                         "\"constraints\": [");
    uint64_t total = (uint64_t)size * n;
    for (int c = 0; c < 16; c++) {
        uint64_t g = (uint64_t)c * (total / 16) + 7;
        double p[3];
        point_of(g, n, p);
        at += (size_t)snprintf(rig_text + at, sizeof rig_text - at,
                               "%s{\"vertex\": %llu, \"target\": [%.17g, %.17g, %.17g]}", c ? ", " : "",
                               (unsigned long long)g, p[0], p[1] + 0.02, p[2]);
    }
    at += (size_t)snprintf(rig_text + at, sizeof rig_text - at, "]}");
    ffd_rig *rig = NULL;
    if (ffd_rig_parse_json(rig_text, at, "bench_mpi rig", &rig, &err))
        return fail(rank, "the rig", &err);

    timed_comm tc = {MPI_COMM_WORLD, NULL, 0, 0, 0, 0.0};
    ffd_comm comm = {rank, size, mpi_allreduce, mpi_allgatherv, &tc};
    ffd_limits unlimited = {0};
    unlimited.unlimited = 1;
    ffd_partition part = {&comm, ids, &unlimited};

    /* read */
    MPI_Barrier(MPI_COMM_WORLD);
    double t0 = MPI_Wtime();
    ffd_mesh *piece = NULL;
    if (ffd_mesh_read(in_path, &piece, &err))
        return fail(rank, "reading the piece", &err);
    double t_read = MPI_Wtime() - t0;

    /* apply, its callbacks logged */
    ffd_rig_report rep;
    memset(&rep, 0, sizeof rep);
    MPI_Barrier(MPI_COMM_WORLD);
    tc.logging = 1;
    t0 = tc.origin = MPI_Wtime();
    if (ffd_rig_apply_distributed(rig, piece, &part, &rep, &err))
        return fail(rank, "ffd_rig_apply_distributed", &err);
    double t_apply = MPI_Wtime() - t0;
    tc.logging = 0;

    /* write */
    MPI_Barrier(MPI_COMM_WORLD);
    t0 = MPI_Wtime();
    if (ffd_mesh_write(piece, out_path, &wo, &err))
        return fail(rank, "writing the deformed piece", &err);
    double t_write = MPI_Wtime() - t0;

    /* the design loop: a deformer built once, then move + evaluate */
    MPI_Barrier(MPI_COMM_WORLD);
    t0 = MPI_Wtime();
    ffd_deformer *d = NULL;
    if (ffd_deformer_create_distributed(rig, piece, &part, &d, &err))
        return fail(rank, "ffd_deformer_create_distributed", &err);
    double t_create = MPI_Wtime() - t0;
    size_t C = ffd_deformer_control_count(d), M = ffd_deformer_point_count(d);
    double *delta = calloc(3 * C, sizeof *delta), *x = malloc(3 * M * sizeof *x);
    double *t_eval = malloc((size_t)reps * sizeof *t_eval);
    if (!delta || !x || !t_eval)
        return fail(rank, "allocation", NULL);
    for (int r = 0; r < reps; r++) {
        for (size_t j = 0; j < 3 * C; j++)
            delta[j] = 1e-3 * (unit(j + 1000 * (uint64_t)r) - 0.5);
        if (ffd_deformer_move_controls(d, NULL, C, delta, &err))
            return fail(rank, "ffd_deformer_move_controls", &err);
        MPI_Barrier(MPI_COMM_WORLD);
        t0 = MPI_Wtime();
        if (ffd_deformer_eval(d, x, &err))
            return fail(rank, "ffd_deformer_eval", &err);
        t_eval[r] = max_over_ranks(MPI_Wtime() - t0);
    }
    for (int i = 1; i < reps; i++) /* insertion sort: median */
        for (int j = i; j > 0 && t_eval[j] < t_eval[j - 1]; j--) {
            double s = t_eval[j];
            t_eval[j] = t_eval[j - 1];
            t_eval[j - 1] = s;
        }
    double eval_median = t_eval[reps / 2];

    /* every rank's numbers: the slowest rank's */
    double read_max = max_over_ranks(t_read), apply_max = max_over_ranks(t_apply);
    double write_max = max_over_ranks(t_write), create_max = max_over_ranks(t_create);
    /* the callbacks: the same sequence on every rank. Per step: the local
     * work before it (the slowest rank's), and its time in the callback: the
     * least over the ranks is the message itself (the last rank to arrive
     * waits for nobody), the most adds waiting for slower ranks. */
    size_t calls = tc.count;
    double *work = malloc((calls + 1) * sizeof *work), *in_min = malloc((calls + 1) * sizeof *in_min);
    double *in_max = malloc((calls + 1) * sizeof *in_max);
    if (!work || !in_min || !in_max)
        return fail(rank, "allocation", NULL);
    double comm_min = 0.0, comm_max = 0.0;
    for (size_t i = 0; i <= calls; i++) {
        double before = i ? tc.log[i - 1].end : 0.0;
        double begin = i < calls ? tc.log[i].begin : t_apply;
        work[i] = max_over_ranks(begin - before);
        double in = i < calls ? tc.log[i].end - tc.log[i].begin : 0.0;
        in_max[i] = max_over_ranks(in);
        in_min[i] = -max_over_ranks(-in);
        comm_min += in_min[i];
        comm_max += in_max[i];
    }
    size_t C0 = rep.control_count;
    if (!rank) {
        printf("bench_mpi: %d rank%s, %zu points per rank (%llu in all), %s\n", size, size > 1 ? "s" : "",
               n, (unsigned long long)total,
               pbffd ? "PB-FFD placement 40+40, 16 vertex constraints"
                     : "B-spline 8x8x8 auto box, 16 vertex constraints");
        if (k)
            printf("  + a %zux%zu sheet per rank: %zu faces per rank, %zu in all\n", k, k, nf, nf * (size_t)size);
        printf("  %-46s %10s\n", "phase (slowest rank; OMP_NUM_THREADS per rank)", "seconds");
        printf("  %-46s %10.4f\n", "read piece (ffd_mesh_read)", read_max);
        printf("  %-46s %10.4f\n", "ffd_rig_apply_distributed", apply_max);
        printf("  %-46s %10.4f\n", "  in the callbacks: messages (least rank)", comm_min);
        printf("  %-46s %10.4f\n", "  in the callbacks: with waiting (slowest)", comm_max);
        printf("  %-46s %10.4f\n", "write piece (ffd_mesh_write)", write_max);
        printf("  %-46s %10.4f\n", "ffd_deformer_create_distributed", create_max);
        printf("  %-46s %10.4f\n", "evaluate after a move (median)", eval_median);
        printf("  %-46s %10.2f\n", "  ns per point per rank", 1e9 * eval_median / (double)nv);
        printf("  the steps of ffd_rig_apply_distributed: %zu callbacks (%zu controls)\n", calls, C0);
        printf("    %-3s %-34s %12s %10s %10s %10s\n", "#", "message", "bytes", "work", "msg", "wait");
        for (size_t i = 0; i <= calls; i++) {
            char what[64];
            if (i == calls)
                snprintf(what, sizeof what, "(after the last: positions)");
            else if (!strncmp(tc.log[i].kind, "allreduce", 9) && tc.log[i].count == (size_t)size &&
                     strstr(tc.log[i].kind, "u64 sum"))
                snprintf(what, sizeof what, "agree (%s)", tc.log[i].kind);
            else if (!strncmp(tc.log[i].kind, "allreduce", 9) && tc.log[i].count == (size_t)size + 1)
                snprintf(what, sizeof what, "counts (%s)", tc.log[i].kind);
            else if (strstr(tc.log[i].kind, "6 f64 max"))
                snprintf(what, sizeof what, "extent (%s)", tc.log[i].kind);
            else if (!strcmp(tc.log[i].kind, "allgatherv") && C0 && tc.log[i].count == 24 * C0)
                snprintf(what, sizeof what, "rank 0's controls (allgatherv)");
            else
                snprintf(what, sizeof what, "%s", tc.log[i].kind);
            printf("    %-3zu %-34s %12zu %10.6f %10.6f %10.6f\n", i, what, i < calls ? tc.log[i].bytes : 0,
                   work[i], in_min[i], in_max[i]);
        }
        fflush(stdout);
    }
    free(work);
    free(in_min);
    free(in_max);
    unlink(in_path);
    unlink(out_path);
    free(t_eval);
    free(x);
    free(delta);
    ffd_deformer_destroy(d);
    ffd_rig_report_free(&rep);
    ffd_mesh_destroy(piece);
    ffd_rig_destroy(rig);
    free(pos);
    free(ids);
    free(foff);
    free(fidx);
    free(tc.log);
    MPI_Finalize();
    return 0;
}
