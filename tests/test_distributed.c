/* Distributed runs (ffd.h "Distributed runs", docs/mpi.md) without MPI:
 * N threads are N ranks, joined by a communicator of two collectives over
 * shared memory (reductions in rank order). A real mesh is cut into N
 * pieces (faces, or cells, in contiguous ranges; a vertex on two pieces is
 * on both, with one global id), each rank applies the rig to its piece, and
 * every piece's vertices must equal the one-process ffd_rig_apply of the
 * whole mesh bit for bit, for every method's example rigs (those whose
 * global steps read the boundary surface see it in canonical order: the
 * same for every N, and equal to one process to rounding). Also: a rank
 * with no points, vertex constraints held by different ranks, an error on
 * one rank is every rank's error (no rank left waiting), refusals named. */
#include "check.h"
#include "check_deformer.h"

#include "ffd.h"

#include <pthread.h>
#include <unistd.h>

#define MAX_RANKS 4

/* ---- a communicator of threads ---- */

typedef struct world {
    int size;
    pthread_barrier_t barrier;
    void *slot[MAX_RANKS];
    const void *cslot[MAX_RANKS];
    int fail_rank; /* this rank's callbacks fail (-1: none) */
} world;

typedef struct rank_ctx {
    world *w;
    int rank;
} rank_ctx;

static void reduce_one(void *acc, const void *x, size_t count, ffd_reduce_type type,
                       ffd_reduce_op op)
{
    for (size_t i = 0; i < count; i++) {
        if (type == FFD_REDUCE_DOUBLE) {
            double *a = (double *)acc + i, v = ((const double *)x)[i];
            *a = op == FFD_REDUCE_SUM ? *a + v : op == FFD_REDUCE_MIN ? fmin(*a, v) : fmax(*a, v);
        } else {
            uint64_t *a = (uint64_t *)acc + i, v = ((const uint64_t *)x)[i];
            *a = op == FFD_REDUCE_SUM ? *a + v
                 : op == FFD_REDUCE_MIN ? (v < *a ? v : *a)
                 : op == FFD_REDUCE_MAX ? (v > *a ? v : *a)
                                         : (*a | v);
        }
    }
}

static int threads_allreduce(void *user, void *data, size_t count, ffd_reduce_type type,
                             ffd_reduce_op op)
{
    rank_ctx *c = user;
    world *w = c->w;
    size_t bytes = count * 8;
    unsigned char *acc = malloc(bytes ? bytes : 1);
    w->slot[c->rank] = data;
    pthread_barrier_wait(&w->barrier);
    memcpy(acc, w->slot[0], bytes);
    for (int r = 1; r < w->size; r++)
        reduce_one(acc, w->slot[r], count, type, op);
    pthread_barrier_wait(&w->barrier);
    memcpy(data, acc, bytes);
    free(acc);
    return 0;
}

static int threads_allgatherv(void *user, const void *mine, size_t bytes, void *all,
                              const size_t *sizes)
{
    rank_ctx *c = user;
    world *w = c->w;
    (void)bytes;
    w->cslot[c->rank] = mine;
    pthread_barrier_wait(&w->barrier);
    size_t at = 0;
    for (int r = 0; r < w->size; r++) {
        if (sizes[r])
            memcpy((unsigned char *)all + at, w->cslot[r], sizes[r]);
        at += sizes[r];
    }
    pthread_barrier_wait(&w->barrier);
    return 0;
}

/* ---- a mesh cut into pieces ---- */

typedef struct piece {
    ffd_mesh *mesh;
    uint64_t *ids; /* global id of each vertex */
    size_t n;
} piece;

/* Piece r of k: the faces (or 3D cells) in the r-th contiguous range, and
 * their vertices; vertices of no face go to piece 0. empty_last: the last
 * piece has nothing. */
static int cut(const ffd_mesh *whole, int k, int r, int empty_last, piece *out)
{
    memset(out, 0, sizeof *out);
    size_t nv = ffd_mesh_vertex_count(whole);
    int parts = empty_last && k > 1 ? k - 1 : k;
    int cells = ffd_mesh_is_volume(whole);
    size_t total = cells ? ffd_mesh_cell_count(whole) : ffd_mesh_face_count(whole);
    size_t lo = r < parts ? total * (size_t)r / (size_t)parts : total;
    size_t hi = r < parts ? total * (size_t)(r + 1) / (size_t)parts : total;
    const uint32_t *foff = ffd_mesh_face_offsets(whole), *fidx = ffd_mesh_face_indices(whole);
    const uint64_t *coff = ffd_mesh_cell_offsets(whole);
    const uint32_t *cidx = ffd_mesh_cell_indices(whole);
    const uint8_t *ctype = ffd_mesh_cell_types(whole);
    uint32_t *local = malloc(nv * sizeof *local);
    unsigned char *used = calloc(nv, 1);
    for (size_t e = lo; e < hi; e++) {
        size_t a = cells ? (size_t)coff[e] : foff[e], b = cells ? (size_t)coff[e + 1] : foff[e + 1];
        for (size_t q = a; q < b; q++)
            used[cells ? cidx[q] : fidx[q]] = 1;
    }
    if (r == 0) { /* the vertices no face or cell holds */
        unsigned char *any = calloc(nv, 1);
        for (size_t e = 0; e < total; e++) {
            size_t a = cells ? (size_t)coff[e] : foff[e], b = cells ? (size_t)coff[e + 1] : foff[e + 1];
            for (size_t q = a; q < b; q++)
                any[cells ? cidx[q] : fidx[q]] = 1;
        }
        for (size_t v = 0; v < nv; v++)
            used[v] |= !any[v];
        free(any);
    }
    double *x = malloc((nv ? nv : 1) * 3 * sizeof *x);
    out->ids = malloc((nv ? nv : 1) * sizeof *out->ids);
    for (size_t v = 0; v < nv; v++)
        if (used[v]) {
            local[v] = (uint32_t)out->n;
            memcpy(x + 3 * out->n, ffd_mesh_positions(whole) + 3 * v, 3 * sizeof *x);
            out->ids[out->n++] = v;
        }
    size_t corners = cells ? (hi > lo ? (size_t)(coff[hi] - coff[lo]) : 0)
                           : (hi > lo ? foff[hi] - foff[lo] : 0);
    uint32_t *idx = malloc((corners ? corners : 1) * sizeof *idx);
    ffd_error err = {{0}};
    ffd_status st;
    if (cells) {
        uint64_t *off = malloc((hi - lo + 1) * sizeof *off);
        for (size_t e = lo; e <= hi; e++)
            off[e - lo] = coff[e] - coff[lo];
        for (size_t q = 0; q < corners; q++)
            idx[q] = local[cidx[coff[lo] + q]];
        st = ffd_mesh_create_cells(x, out->n, ctype + lo, off, idx, hi - lo, &out->mesh, &err);
        free(off);
    } else {
        uint32_t *off = malloc((hi - lo + 1) * sizeof *off);
        for (size_t e = lo; e <= hi; e++)
            off[e - lo] = foff[e] - foff[lo];
        for (size_t q = 0; q < corners; q++)
            idx[q] = local[fidx[foff[lo] + q]];
        st = ffd_mesh_create(x, out->n, off, idx, hi - lo, &out->mesh, &err);
        free(off);
    }
    if (st)
        fprintf(stderr, "cut: %s\n", err.message);
    free(idx);
    free(x);
    free(local);
    free(used);
    return st == FFD_OK;
}

static void piece_free(piece *p)
{
    ffd_mesh_destroy(p->mesh);
    free(p->ids);
}

/* ---- a run ---- */

typedef struct rank_run {
    rank_ctx ctx;
    ffd_comm comm;
    const ffd_rig *rig;
    piece *piece;
    ffd_status status;
    ffd_error err;
    ffd_rig_report report;
    int use_ids;
    int bad_point; /* 1: this rank's piece gets a NaN */
} rank_run;

static void *run_rank(void *arg)
{
    rank_run *r = arg;
    ffd_partition part = {&r->comm, r->use_ids ? r->piece->ids : NULL, NULL};
    r->status = ffd_rig_apply_distributed(r->rig, r->piece->mesh, &part, &r->report, &r->err);
    return NULL;
}

/* Runs rig on k ranks over whole cut in k pieces; fills out (nv by 3,
 * NaN where no piece wrote) with the pieces' results; returns rank 0's
 * status and the ranks' statuses in statuses. */
typedef struct run_result {
    ffd_status status[MAX_RANKS];
    char message[MAX_RANKS][512];
    double max_residual[MAX_RANKS];
    size_t rank[MAX_RANKS];
    size_t controls[MAX_RANKS];
} run_result;

static void run(const ffd_rig *rig, const ffd_mesh *whole, int k, int empty_last, int use_ids,
                const piece *replace, int replace_rank, double *out, run_result *res)
{
    world w = {.size = k, .fail_rank = -1};
    pthread_barrier_init(&w.barrier, NULL, (unsigned)k);
    piece pieces[MAX_RANKS];
    rank_run runs[MAX_RANKS];
    pthread_t threads[MAX_RANKS];
    memset(runs, 0, sizeof runs);
    for (int r = 0; r < k; r++) {
        if (r == replace_rank && replace)
            pieces[r] = *replace;
        else
            CHECK(cut(whole, k, r, empty_last, &pieces[r]));
        runs[r].ctx = (rank_ctx){&w, r};
        runs[r].comm = (ffd_comm){r, k, threads_allreduce, threads_allgatherv, &runs[r].ctx};
        runs[r].rig = rig;
        runs[r].piece = &pieces[r];
        runs[r].use_ids = use_ids;
        pthread_create(&threads[r], NULL, run_rank, &runs[r]);
    }
    size_t nv = ffd_mesh_vertex_count(whole);
    for (size_t i = 0; out && i < 3 * nv; i++)
        out[i] = NAN;
    for (int r = 0; r < k; r++) {
        pthread_join(threads[r], NULL);
        res->status[r] = runs[r].status;
        snprintf(res->message[r], sizeof res->message[r], "%s", runs[r].err.message);
        res->max_residual[r] = runs[r].report.max_residual;
        res->rank[r] = runs[r].report.rank;
        res->controls[r] = runs[r].report.control_count;
        const double *x = ffd_mesh_positions(pieces[r].mesh);
        for (size_t i = 0; out && !runs[r].status && i < pieces[r].n; i++)
            memcpy(out + 3 * pieces[r].ids[i], x + 3 * i, 3 * sizeof *x);
        ffd_rig_report_free(&runs[r].report);
        if (!(r == replace_rank && replace))
            piece_free(&pieces[r]);
    }
    pthread_barrier_destroy(&w.barrier);
}

static int same_bits(const double *a, const double *b, size_t count)
{
    return memcmp(a, b, count * sizeof *a) == 0;
}

/* Every case's rig on 1..4 ranks (4: with an empty rank) against one process. */
static void check_case(const char *mesh_path, const char *rig_path, int canonical_surface)
{
    ffd_mesh *whole = read_mesh(mesh_path), *applied = read_mesh(mesh_path);
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    CHECK(whole && applied);
    if (!whole || !applied || ffd_rig_read(rig_path, &rig, &err)) {
        fprintf(stderr, "%s: %s\n", rig_path, err.message);
        CHECK(0);
        ffd_mesh_destroy(whole);
        ffd_mesh_destroy(applied);
        return;
    }
    ffd_rig_report one;
    CHECK_OK(ffd_rig_apply(rig, applied, &one, &err));
    size_t nv = ffd_mesh_vertex_count(whole);
    const double *want = ffd_mesh_positions(applied);
    double *got = malloc(3 * nv * sizeof *got), *first = malloc(3 * nv * sizeof *first);
    double diag = diagonal(ffd_mesh_positions(whole), nv);
    for (int k = 1; k <= MAX_RANKS; k++) {
        run_result res;
        run(rig, whole, k, k == MAX_RANKS, 1, NULL, -1, got, &res);
        for (int r = 0; r < k; r++) {
            if (res.status[r])
                fprintf(stderr, "%s on %d ranks: rank %d: %s\n", rig_path, k, r, res.message[r]);
            CHECK(res.status[r] == FFD_OK);
            CHECK(res.controls[r] == res.controls[0]);
            CHECK(res.max_residual[r] == res.max_residual[0]);
        }
        /* the report's constraints as one process reports them */
        if (res.max_residual[0] != one.max_residual || res.rank[0] != one.rank)
            fprintf(stderr, "%s on %d ranks: residual %.17g rank %zu, one process %.17g rank %zu\n",
                    rig_path, k, res.max_residual[0], res.rank[0], one.max_residual, one.rank);
        CHECK(res.max_residual[0] == one.max_residual);
        CHECK(res.rank[0] == one.rank);
        if (k == 1)
            memcpy(first, got, 3 * nv * sizeof *got);
        if (canonical_surface) {
            /* the same bits for any number of ranks, one process to rounding */
            if (!same_bits(got, first, 3 * nv))
                fprintf(stderr, "%s on %d ranks: differs from 1 rank\n", rig_path, k);
            CHECK(same_bits(got, first, 3 * nv));
            check_agree(got, want, 3 * nv, diag, rig_path, "distributed vs one process");
        } else {
            if (!same_bits(got, want, 3 * nv))
                fprintf(stderr, "%s on %d ranks: differs from one process by %.3g\n", rig_path,
                        k, max_diff(got, want, 3 * nv));
            CHECK(same_bits(got, want, 3 * nv));
        }
    }
    free(got);
    free(first);
    ffd_rig_report_free(&one);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(whole);
    ffd_mesh_destroy(applied);
}

static void test_every_method(void)
{
    for (size_t c = 0; c < CASE_COUNT; c++) {
        const rig_case *rc = &case_table[c];
        if (strstr(rc->rig, "layers"))
            continue; /* refused (test_errors) */
        check_case(rc->mesh, rc->rig, 0);
    }
}

static ffd_rig *parse_rig(const char *json)
{
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    if (ffd_rig_parse_json(json, strlen(json), "test.json", &rig, &err))
        fprintf(stderr, "%s\n", err.message);
    return rig;
}

/* A rig given as text, on a mesh file, on 1..4 ranks: bitwise equal to one
 * process. */
static void check_text(const char *mesh_path, const char *json)
{
    char path[] = "/tmp/ffd-test-distributed-XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd < 0)
        return;
    CHECK(write(fd, json, strlen(json)) == (ssize_t)strlen(json));
    close(fd);
    check_case(mesh_path, path, 0);
    unlink(path);
}

/* Vertex constraints held by different ranks (the first piece's vertex 3,
 * the last's), an auto box. */
static void test_constraints_across_ranks(void)
{
    check_text(EX "lattice/bunny.obj",
               "{\"deformer\": \"lattice\", \"basis\": \"bspline\", \"resolution\": [5, 5, 5],"
               " \"box\": \"auto\", \"constraints\": ["
               "{\"vertex\": 3, \"target\": [0.1, 1.2, 0.3]},"
               "{\"vertex\": 900, \"target\": [-0.5, 0.2, 0.1]},"
               "{\"vertex\": 1800, \"target\": [0.4, -0.1, 0.6]}]}");
}

/* A tetrahedral volume mesh cut by cells: pieces share the interface
 * nodes; a lattice with constraints, and the T-spline and PB-FFD's
 * placement, which read the boundary surface (the pieces' interface faces
 * cancel; its interior nodes are not gathered). */
static void test_volume(void)
{
    const char *mesh = FFD_DATA_DIR "/volume/hinge_tet.msh";
    check_text(mesh, "{\"deformer\": \"lattice\", \"resolution\": [4, 4, 4], \"box\": \"auto\","
                     " \"constraints\": [{\"vertex\": 10, \"target\": [1, 2, 3]},"
                     " {\"vertex\": 600, \"target\": [4, 5, 6]}]}");
    check_text(mesh, "{\"deformer\": \"tspline\", \"resolution\": [4, 4, 4], \"steps\": ["
                     "{\"constraints\": {\"targets\": [{\"vertex\": 5, \"target\": [1, 2, 3]}]}}]}");
    /* PB-FFD's placement on the boundary the ranks gather (its coverage
     * grows radii for the boundary's vertices, not the interface nodes) */
    check_text(FFD_DATA_DIR "/volume/box_tet_binary.vtk",
               "{\"deformer\": \"pbffd\", \"controls\": {\"interior\": 12, \"exterior\": 12},"
               " \"moves\": [{\"near\": [2, 1, 1], \"delta\": [0.1, 0.05, 0]}]}");
    /* PB-FFD's placement on the boundary the ranks gather */
    check_text(mesh, "{\"deformer\": \"pbffd\", \"controls\": {\"interior\": 20, \"exterior\": 20},"
                     " \"constraints\": [{\"vertex\": 12, \"target\": [1, 2, 3]}]}");
}

/* Pieces without global ids: rank-major numbering of disjoint pieces. */
static void test_rank_major(void)
{
    ffd_mesh *whole = read_mesh(EX "lattice/bunny.obj");
    ffd_rig *rig = parse_rig("{\"deformer\": \"rbf\", \"control_points\": [[0,0,0],[1,1,1],[-1,2,0],[0.5,-1,1.5]],"
                             " \"deformed_control_points\": [[0,0.2,0],[1,1.3,1],[-1,2,0.4],[0.5,-1,1.5]], \"radius\": 2,"
                             " \"constraints\": [{\"vertex\": 1700, \"target\": [0.2, 0.1, 0]}]}");
    CHECK(whole && rig);
    if (!whole || !rig) {
        ffd_mesh_destroy(whole);
        ffd_rig_destroy(rig);
        return;
    }
    ffd_error err = {{0}};
    size_t nv = ffd_mesh_vertex_count(whole);
    ffd_mesh *applied = NULL;
    CHECK_OK(ffd_mesh_create(ffd_mesh_positions(whole), nv, NULL, NULL, 0, &applied, &err));
    CHECK_OK(ffd_rig_apply(rig, applied, NULL, &err));
    const int k = 3;
    world w = {.size = k, .fail_rank = -1};
    pthread_barrier_init(&w.barrier, NULL, (unsigned)k);
    piece pieces[3];
    rank_run runs[3];
    pthread_t threads[3];
    memset(runs, 0, sizeof runs);
    for (int r = 0; r < k; r++) {
        size_t lo = nv * (size_t)r / k, hi = nv * (size_t)(r + 1) / k;
        memset(&pieces[r], 0, sizeof pieces[r]);
        pieces[r].n = hi - lo;
        CHECK_OK(ffd_mesh_create(ffd_mesh_positions(whole) + 3 * lo, hi - lo, NULL, NULL, 0,
                                 &pieces[r].mesh, &err));
        runs[r].ctx = (rank_ctx){&w, r};
        runs[r].comm = (ffd_comm){r, k, threads_allreduce, threads_allgatherv, &runs[r].ctx};
        runs[r].rig = rig;
        runs[r].piece = &pieces[r];
        pthread_create(&threads[r], NULL, run_rank, &runs[r]);
    }
    for (int r = 0; r < k; r++) {
        pthread_join(threads[r], NULL);
        CHECK_OK(runs[r].status);
        size_t lo = nv * (size_t)r / k;
        CHECK(same_bits(ffd_mesh_positions(pieces[r].mesh), ffd_mesh_positions(applied) + 3 * lo,
                        3 * pieces[r].n));
        CHECK(runs[r].report.constraint_count == 1);
        ffd_rig_report_free(&runs[r].report);
        ffd_mesh_destroy(pieces[r].mesh);
    }
    pthread_barrier_destroy(&w.barrier);
    ffd_mesh_destroy(applied);
    ffd_mesh_destroy(whole);
    ffd_rig_destroy(rig);
}

/* Runs json on bunny over 3 ranks, rank 1's piece replaced by bad when not
 * NULL; every rank must fail with status and a message holding what. */
static void check_all_fail(const char *json, const ffd_mesh *bad, ffd_status status,
                           const char *what)
{
    ffd_mesh *whole = read_mesh(EX "lattice/bunny.obj");
    ffd_rig *rig = parse_rig(json);
    CHECK(whole && rig);
    if (whole && rig) {
        piece replace = {(ffd_mesh *)bad, NULL, bad ? ffd_mesh_vertex_count(bad) : 0};
        uint64_t *ids = NULL;
        if (bad) {
            ids = malloc((replace.n ? replace.n : 1) * sizeof *ids);
            for (size_t i = 0; i < replace.n; i++)
                ids[i] = i;
            replace.ids = ids;
        }
        run_result res;
        run(rig, whole, 3, 0, 1, bad ? &replace : NULL, bad ? 1 : -1, NULL, &res);
        for (int r = 0; r < 3; r++) {
            if (res.status[r] != status || !strstr(res.message[r], what))
                fprintf(stderr, "rank %d: status %d: %s (expected %d, \"%s\")\n", r,
                        (int)res.status[r], res.message[r], (int)status, what);
            CHECK(res.status[r] == status);
            CHECK(strstr(res.message[r], what) != NULL);
            CHECK(strcmp(res.message[r], res.message[0]) == 0);
        }
        free(ids);
    }
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(whole);
}

/* An error on one rank is every rank's (and nothing waits); refusals are
 * named; a vertex no rank holds. */
static void test_errors(void)
{
    ffd_error err = {{0}};
    check_all_fail("{\"deformer\": \"lattice\", \"box\": \"auto\", \"constraints\": "
                   "[{\"vertex\": 4000000, \"target\": [0, 0, 0]}]}",
                   NULL, FFD_ERR_RANGE, "constraints[0].vertex: vertex 4000000 is on no rank");
    check_all_fail("{\"deformer\": \"lattice\", \"weights\": {\"values\": [1, 1]}}", NULL,
                   FFD_ERR_UNSUPPORTED, "\"weights\"");
    check_all_fail("{\"deformer\": \"lattice\", \"preserve\": [\"volume\"]}", NULL,
                   FFD_ERR_UNSUPPORTED, "\"preserve\"");
    /* rank 1 holds a vertex whose global id another rank holds elsewhere */
    double far[3] = {100, 100, 100};
    ffd_mesh *moved = NULL;
    CHECK_OK(ffd_mesh_create(far, 1, NULL, NULL, 0, &moved, &err));
    check_all_fail("{\"deformer\": \"lattice\", \"box\": \"auto\", \"constraints\": "
                   "[{\"vertex\": 0, \"target\": [0, 0, 0]}]}",
                   moved, FFD_ERR_INVALID, "global vertex 0 has different positions");
    ffd_mesh_destroy(moved);
    check_all_fail("{\"deformer\": \"gffd\", \"skeleton\": [{\"type\": \"point\", "
                   "\"position\": [0, 0, 0], \"radius\": 1}], \"resample\": true}",
                   NULL, FFD_ERR_UNSUPPORTED, "\"resample\"");
}

/* A failing callback on one rank: FFD_ERR_IO there, the others see it. */
static int failing_allreduce(void *user, void *data, size_t count, ffd_reduce_type type,
                             ffd_reduce_op op)
{
    (void)user, (void)data, (void)count, (void)type, (void)op;
    return 1;
}

/* ffd_comm_agree alone; the one-process default; inversion counts summed. */
static void test_agree_and_reduce(void)
{
    ffd_error err = {{0}};
    CHECK(ffd_comm_agree(NULL, FFD_OK, &err) == FFD_OK);
    snprintf(err.message, sizeof err.message, "kept");
    CHECK(ffd_comm_agree(NULL, FFD_ERR_PARSE, &err) == FFD_ERR_PARSE);
    CHECK(strcmp(err.message, "kept") == 0);
    ffd_comm bad = {0, 1, failing_allreduce, threads_allgatherv, NULL};
    ffd_inversion_report inv = {0};
    CHECK(ffd_inversion_report_reduce(&bad, &inv, &err) == FFD_ERR_IO);
    ffd_comm broken = {2, 2, failing_allreduce, NULL, NULL};
    CHECK(ffd_comm_agree(&broken, FFD_OK, &err) == FFD_ERR_INVALID);
    inv.cells_checked = 10;
    inv.inverted = 2;
    inv.worst_det = -0.5;
    inv.worst_scaled_jacobian = NAN;
    CHECK_OK(ffd_inversion_report_reduce(NULL, &inv, &err));
    CHECK(inv.cells_checked == 10 && inv.inverted == 2 && inv.worst_det == -0.5);
    CHECK(isnan(inv.worst_scaled_jacobian));
}

/* The deformer of a distributed run: bound to the piece, controls shared. */
static void test_deformer(void)
{
    ffd_mesh *whole = read_mesh(EX "lattice/bunny.obj");
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    CHECK(whole != NULL);
    CHECK_OK(ffd_rig_read(EX "lattice/pins.json", &rig, &err));
    ffd_deformer *d = NULL, *ref = NULL;
    ffd_partition part = {NULL, NULL, NULL};
    CHECK_OK(ffd_deformer_create_distributed(rig, whole, &part, &d, &err));
    CHECK_OK(ffd_deformer_create(rig, whole, NULL, &ref, &err));
    if (d && ref) {
        size_t n = ffd_mesh_vertex_count(whole), c = ffd_deformer_control_count(d);
        CHECK(ffd_deformer_point_count(d) == n);
        CHECK(c == ffd_deformer_control_count(ref));
        double *a = malloc(3 * n * sizeof *a), *b = malloc(3 * n * sizeof *b);
        CHECK_OK(ffd_deformer_eval(d, a, &err));
        CHECK_OK(ffd_deformer_eval(ref, b, &err));
        CHECK(same_bits(a, b, 3 * n));
        double *p = malloc(3 * c * sizeof *p), *q = malloc(3 * c * sizeof *q);
        ffd_deformer_controls(d, p);
        ffd_deformer_controls(ref, q);
        CHECK(same_bits(p, q, 3 * c));
        free(a);
        free(b);
        free(p);
        free(q);
    }
    ffd_deformer_destroy(d);
    ffd_deformer_destroy(ref);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(whole);
}

int main(int argc, char **argv)
{
    choose_cases();
    static const check_test tests[] = {
        {"every_method", test_every_method},
        {"constraints_across_ranks", test_constraints_across_ranks},
        {"volume", test_volume},
        {"rank_major", test_rank_major},
        {"errors", test_errors},
        {"agree_and_reduce", test_agree_and_reduce},
        {"deformer", test_deformer},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
