/* Allocation-failure sweep: every library allocation goes through
 * ffd_set_allocator (cJSON's too while an allocator is set; CHOLMOD's
 * through SuiteSparse_config), so a scenario can be run once with a counting
 * allocator to learn its allocation count A, then again for N = 0..A-1 with
 * the N-th allocation failing (every N when A <= SWEEP_ALL, else the first
 * and last SWEEP_EDGE and a deterministic jittered stride in between).
 * Each failing run must return a clean status (FFD_ERR_NOMEM; a scenario may
 * name another documented status a failed allocation legitimately becomes),
 * a non-empty message, NULL/untouched outputs, and leave no block allocated
 * through the allocator (a live count; under the ASan build LeakSanitizer
 * also reports anything that escaped the allocator at exit).
 *
 * Only the N-th allocation fails; later ones succeed, so cleanup and error
 * paths that allocate are exercised too. Runs single-threaded (allocation
 * order is then deterministic). `test_alloc_sweep NAME` runs the scenarios
 * whose name contains NAME; FFD_SWEEP_VERBOSE=1 prints every failing N;
 * FFD_SWEEP_SCENARIO=TEXT runs the scenarios whose name contains TEXT and
 * FFD_SWEEP_ONLY=N only that N (a reproducer; `break sweep_inject_point`). */
#define _GNU_SOURCE /* dladdr */
#include "check.h"
#include "ffd.h"

#include <dirent.h>
#include <dlfcn.h>
#include <execinfo.h>
#include <omp.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <time.h>
#include <unistd.h>

#define DATA FFD_SOURCE_DIR "/tests/data/mesh/"
#define EXAMPLES FFD_SOURCE_DIR "/examples/"

enum { SWEEP_ALL = 3000, SWEEP_EDGE = 200 };

/* ---------------------------------------------------------------------
 * The counting, failing allocator
 * --------------------------------------------------------------------- */

typedef struct sweep_alloc {
    int armed;      /* allocations are counted (and may fail) only when armed */
    long fail_at;   /* index of the armed allocation to fail; -1: none */
    long count;     /* armed allocations so far */
    long live;      /* blocks handed out and not yet freed (armed or not) */
    int injected;   /* the failure happened */
    int absorbable; /* ... where failing may legitimately change nothing: a shrinking
                       realloc (the block is kept), or inside CHOLMOD (which skips an
                       ordering method that runs out of memory) */
} sweep_alloc;

static sweep_alloc sw;

/* A place for a debugger's breakpoint: `break sweep_inject_point`. */
__attribute__((noinline)) void sweep_inject_point(void);
__attribute__((noinline)) void sweep_inject_point(void)
{
    __asm__ volatile("");
}

/* 1 when a frame of the current call stack lies in CHOLMOD (or SuiteSparse_config). */
static int called_from_cholmod(void)
{
    void *frames[64];
    int n = backtrace(frames, 64);
    for (int i = 0; i < n; i++) {
        Dl_info info;
        if (dladdr(frames[i], &info) && info.dli_fname &&
            (strstr(info.dli_fname, "libcholmod") || strstr(info.dli_fname, "libsuitesparse")))
            return 1;
    }
    return 0;
}

static int sweep_should_fail(int shrinking)
{
    if (!sw.armed)
        return 0;
    long i = __atomic_fetch_add(&sw.count, 1, __ATOMIC_RELAXED);
    if (i == sw.fail_at) {
        sw.injected = 1;
        sw.absorbable = shrinking || called_from_cholmod();
        sweep_inject_point();
        return 1;
    }
    return 0;
}

/* Each block carries its size (so that a shrinking realloc is recognised);
 * a block freed with plain free() instead of ffd_free crashes the test. */
typedef union sw_head {
    size_t size;
    max_align_t align;
} sw_head;

static void *sw_malloc(size_t n, void *u)
{
    (void)u;
    if (sweep_should_fail(0))
        return NULL;
    sw_head *h = malloc(sizeof *h + n);
    if (!h)
        return NULL;
    h->size = n;
    __atomic_fetch_add(&sw.live, 1, __ATOMIC_RELAXED);
    return h + 1;
}

static void *sw_realloc(void *p, size_t n, void *u)
{
    if (!p)
        return sw_malloc(n, u);
    sw_head *old = (sw_head *)p - 1;
    if (sweep_should_fail(n <= old->size))
        return NULL;
    sw_head *h = realloc(old, sizeof *h + n);
    if (!h)
        return NULL;
    h->size = n;
    return h + 1;
}

static void sw_free(void *p, void *u)
{
    (void)u;
    if (!p)
        return;
    __atomic_fetch_sub(&sw.live, 1, __ATOMIC_RELAXED);
    free((sw_head *)p - 1);
}

/* Scenarios call arm() once their fixtures are built: allocations before it
 * are counted as live but are never failed. */
static void arm(void)
{
    sw.armed = 1;
}

/* ---------------------------------------------------------------------
 * The sweep driver
 * --------------------------------------------------------------------- */

typedef ffd_status (*scenario_fn)(const void *ctx, ffd_error *err);

typedef struct scenario {
    const char *name;
    scenario_fn fn;
    const void *ctx;
    unsigned other_ok;  /* bit s: status s is also accepted for a failed allocation */
    long max_runs;      /* cap on failing runs when A > SWEEP_ALL (0: 2000) */
} scenario;

static int sweep_verbose;
static long sweep_total_runs;

static ffd_status run_once(const scenario *sc, long fail_at, ffd_error *err)
{
    memset(&sw, 0, sizeof sw);
    sw.fail_at = fail_at;
    memset(err, 0, sizeof *err);
    ffd_allocator a = {sw_malloc, sw_realloc, sw_free, NULL};
    ffd_set_allocator(&a);
    ffd_status st = sc->fn(sc->ctx, err);
    ffd_set_allocator(NULL);
    return st;
}

static uint64_t sweep_rng = 0x9e3779b97f4a7c15ull;
static uint64_t sweep_next(void)
{
    sweep_rng ^= sweep_rng >> 12;
    sweep_rng ^= sweep_rng << 25;
    sweep_rng ^= sweep_rng >> 27;
    return sweep_rng * 2685821657736338717ull;
}

static void sweep(const scenario *sc)
{
    const char *pick = getenv("FFD_SWEEP_SCENARIO");
    if (pick && !strstr(sc->name, pick))
        return;
    ffd_error err;
    double t0 = (double)clock() / CLOCKS_PER_SEC;
    ffd_status st = run_once(sc, -1, &err);
    if (st != FFD_OK) {
        fprintf(stderr, "%s: the scenario fails without injection: %s (%s)\n", sc->name,
                ffd_status_string(st), err.message);
        check_failures++;
        return;
    }
    long total = sw.count;
    if (sw.live != 0) {
        fprintf(stderr, "%s: %ld blocks leaked without injection\n", sc->name, sw.live);
        check_failures++;
    }
    /* which N to fail */
    long *ns = malloc(sizeof *ns * (size_t)(total ? total : 1));
    long runs = 0;
    long cap = sc->max_runs ? sc->max_runs : 2000;
    if (total <= SWEEP_ALL || total <= cap) {
        for (long n = 0; n < total; n++)
            ns[runs++] = n;
    } else {
        long edge = SWEEP_EDGE;
        if (2 * edge > cap / 2)
            edge = cap / 4;
        for (long n = 0; n < edge; n++)
            ns[runs++] = n;
        long lo = edge, hi = total - edge, mid = cap - 2 * edge;
        double stride = (double)(hi - lo) / (double)mid;
        for (long b = 0; b < mid; b++) {
            long a0 = lo + (long)(b * stride), a1 = lo + (long)((b + 1) * stride);
            if (a1 <= a0)
                continue;
            ns[runs++] = a0 + (long)(sweep_next() % (uint64_t)(a1 - a0));
        }
        for (long n = hi; n < total; n++)
            ns[runs++] = n;
    }
    long nomem = 0, other = 0, absorbed = 0, not_reached = 0, bad = 0;
    const char *only = getenv("FFD_SWEEP_ONLY");
    for (long r = 0; r < runs; r++) {
        long n = ns[r];
        if (only && atol(only) != n)
            continue;
        st = run_once(sc, n, &err);
        sweep_total_runs++;
        int ok = 1;
        if (!sw.injected) {
            not_reached++; /* the run made fewer allocations (possible after an earlier change) */
            if (st != FFD_OK) {
                fprintf(stderr, "%s: N=%ld not reached but status %s (%s)\n", sc->name, n,
                        ffd_status_string(st), err.message);
                ok = 0;
            }
        } else if (st == FFD_ERR_NOMEM) {
            nomem++;
        } else if (st == FFD_OK && sw.absorbable) {
            absorbed++;
            if (sweep_verbose)
                fprintf(stderr, "%s: N=%ld absorbed (shrinking realloc or CHOLMOD)\n", sc->name, n);
        } else if (st != FFD_OK && (sc->other_ok & (1u << st))) {
            other++;
            if (sweep_verbose)
                fprintf(stderr, "%s: N=%ld -> %s (%s)\n", sc->name, n, ffd_status_string(st),
                        err.message);
        } else {
            fprintf(stderr, "%s: allocation %ld of %ld failed: got %s (%s)\n", sc->name, n, total,
                    st == FFD_OK ? "FFD_OK" : ffd_status_string(st), err.message);
            ok = 0;
        }
        if (st != FFD_OK && !err.message[0]) {
            fprintf(stderr, "%s: allocation %ld: %s with an empty message\n", sc->name, n,
                    ffd_status_string(st));
            ok = 0;
        }
        if (sw.live != 0) {
            fprintf(stderr, "%s: allocation %ld failed: %ld blocks leaked\n", sc->name, n,
                    sw.live);
            ok = 0;
        }
        if (sweep_verbose && st == FFD_ERR_NOMEM)
            fprintf(stderr, "%s: N=%ld -> nomem (%s)\n", sc->name, n, err.message);
        if (!ok) {
            check_failures++;
            if (++bad >= 10) {
                fprintf(stderr, "%s: stopping after 10 failures\n", sc->name);
                break;
            }
        }
    }
    free(ns);
    double t1 = (double)clock() / CLOCKS_PER_SEC;
    printf("  %-24s A=%-6ld swept=%-5ld nomem=%-5ld other=%-3ld absorbed=%-3ld unreached=%-3ld "
           "%.2fs\n", sc->name, total, runs, nomem, other, absorbed, not_reached, t1 - t0);
    fflush(stdout);
}

/* ---------------------------------------------------------------------
 * Fixtures
 * --------------------------------------------------------------------- */

static unsigned char *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *d = malloc((size_t)n + 1);
    if (d && fread(d, 1, (size_t)n, f) != (size_t)n) {
        free(d);
        d = NULL;
    }
    fclose(f);
    if (d)
        d[n] = 0;
    *size = (size_t)n;
    return d;
}

/* A closed UV sphere (radius 1): 2 poles and rings x segs vertices. */
enum { RINGS = 5, SEGS = 8, SPHERE_V = 2 + RINGS * SEGS, SPHERE_F = 2 * SEGS * RINGS };
static double sphere_pos[3 * SPHERE_V];
static uint32_t sphere_off[SPHERE_F + 1], sphere_idx[3 * SPHERE_F];

static void make_sphere(void)
{
    const double pi = 3.14159265358979323846;
    size_t v = 0;
    sphere_pos[0] = 0, sphere_pos[1] = 0, sphere_pos[2] = 1;
    v = 1;
    for (int r = 0; r < RINGS; r++) {
        double th = pi * (r + 1) / (RINGS + 1);
        for (int s = 0; s < SEGS; s++, v++) {
            double ph = 2 * pi * s / SEGS;
            sphere_pos[3 * v] = 1.2 * sin(th) * cos(ph);
            sphere_pos[3 * v + 1] = 0.9 * sin(th) * sin(ph);
            sphere_pos[3 * v + 2] = cos(th);
        }
    }
    sphere_pos[3 * v] = 0, sphere_pos[3 * v + 1] = 0, sphere_pos[3 * v + 2] = -1;
    uint32_t south = (uint32_t)v;
    size_t f = 0, k = 0;
#define RING(r, s) (uint32_t)(1 + (r) * SEGS + ((s) % SEGS))
#define TRI(a, b, c) (sphere_idx[k++] = (a), sphere_idx[k++] = (b), sphere_idx[k++] = (c), \
                      sphere_off[++f] = (uint32_t)k)
    for (int s = 0; s < SEGS; s++)
        TRI(0, RING(0, s), RING(0, s + 1));
    for (int r = 0; r + 1 < RINGS; r++)
        for (int s = 0; s < SEGS; s++) {
            TRI(RING(r, s), RING(r + 1, s), RING(r + 1, s + 1));
            TRI(RING(r, s), RING(r + 1, s + 1), RING(r, s + 1));
        }
    for (int s = 0; s < SEGS; s++)
        TRI(south, RING(RINGS - 1, s + 1), RING(RINGS - 1, s));
#undef TRI
#undef RING
    sphere_off[0] = 0;
}

static ffd_status sphere_mesh(ffd_mesh **out, ffd_error *err)
{
    return ffd_mesh_create(sphere_pos, SPHERE_V, sphere_off, sphere_idx, SPHERE_F, out, err);
}

/* ---------------------------------------------------------------------
 * Scenarios: meshes
 * --------------------------------------------------------------------- */

typedef struct mesh_fixture {
    const char *file;
    ffd_format format;
    unsigned char *data;
    size_t size;
} mesh_fixture;

static mesh_fixture fixtures[] = {
    {"all_forms.obj", FFD_FORMAT_OBJ, NULL, 0}, {"cube_ascii.ply", FFD_FORMAT_PLY, NULL, 0},
    {"cube_ble.ply", FFD_FORMAT_PLY, NULL, 0},  {"cube_bbe.ply", FFD_FORMAT_PLY, NULL, 0},
    {"comments.off", FFD_FORMAT_OFF, NULL, 0},  {"normals.off", FFD_FORMAT_OFF, NULL, 0},
    {"tri_ascii.stl", FFD_FORMAT_STL, NULL, 0}, {"tri_binary.stl", FFD_FORMAT_STL, NULL, 0},
    {"cube_nodes.glb", FFD_FORMAT_GLTF, NULL, 0}, {"cube_embedded.gltf", FFD_FORMAT_GLTF, NULL, 0},
    {"grid_tangents.glb", FFD_FORMAT_GLTF, NULL, 0},
};
enum { FIXTURE_COUNT = sizeof fixtures / sizeof fixtures[0] };

static ffd_status sc_mesh_read(const void *ctx, ffd_error *err)
{
    const mesh_fixture *fx = ctx;
    arm();
    ffd_mesh *m = NULL;
    ffd_status st = ffd_mesh_read_memory(fx->data, fx->size, fx->format, fx->file, &m, err);
    if (st) {
        CHECK(m == NULL);
        return st;
    }
    ffd_mesh_info info;
    st = ffd_mesh_compute_info(m, &info, err);
    ffd_mesh_destroy(m);
    return st;
}

/* Reads from the file system (ffd_read_file) too. */
static ffd_status sc_mesh_read_file(const void *ctx, ffd_error *err)
{
    const mesh_fixture *fx = ctx;
    char path[512];
    snprintf(path, sizeof path, "%s%s", DATA, fx->file);
    arm();
    ffd_mesh *m = NULL;
    ffd_status st = ffd_mesh_read(path, &m, err);
    if (st)
        CHECK(m == NULL);
    ffd_mesh_destroy(m);
    return st;
}

static const ffd_write_options write_targets[] = {
    {FFD_FORMAT_OBJ, FFD_ENCODING_SAME, 0},      {FFD_FORMAT_PLY, FFD_ENCODING_ASCII, 0},
    {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_LE, 0}, {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_BE, 0},
    {FFD_FORMAT_OFF, FFD_ENCODING_SAME, 0},      {FFD_FORMAT_STL, FFD_ENCODING_ASCII, 0},
    {FFD_FORMAT_STL, FFD_ENCODING_BINARY_LE, 0}, {FFD_FORMAT_GLTF, FFD_ENCODING_ASCII, 0},
    {FFD_FORMAT_GLTF, FFD_ENCODING_BINARY_LE, 0},
};

/* The shear x' = S x + 0.125 of pass 2 (row-major; normals and tangents turn). */
static const double shear[9] = {1.25, 0.25, 0, 0, 1.25, 0, 0.125, 0, 1.25};

/* Moves the mesh: pass 1 scales it (normals recomputed from the faces,
 * tangents projected), pass 2 shears it with its Jacobians. */
static ffd_status move_mesh(ffd_mesh *m, int pass, double *moved, double *jac, ffd_error *err)
{
    size_t nv = ffd_mesh_vertex_count(m);
    const double *P = ffd_mesh_positions(m);
    for (size_t v = 0; v < nv; v++)
        for (int r = 0; r < 3; r++)
            moved[3 * v + r] = pass == 1 ? P[3 * v + r] * 1.25 + 0.125
                                         : shear[3 * r] * P[3 * v] + shear[3 * r + 1] * P[3 * v + 1] +
                                               shear[3 * r + 2] * P[3 * v + 2] + 0.125;
    for (size_t v = 0; v < nv; v++)
        memcpy(jac + 9 * v, shear, sizeof shear);
    return ffd_mesh_set_positions(m, moved, pass == 1 ? NULL : jac, err);
}

/* Writes the fixture in every format, unchanged and with moved positions. */
static ffd_status sc_mesh_write(const void *ctx, ffd_error *err)
{
    const mesh_fixture *fx = ctx;
    ffd_mesh *m = NULL;
    ffd_status st = ffd_mesh_read_memory(fx->data, fx->size, fx->format, fx->file, &m, err);
    if (st)
        return st;
    size_t nv = ffd_mesh_vertex_count(m);
    double *moved = malloc(sizeof *moved * 3 * (nv ? nv : 1));
    double *jac = malloc(sizeof *jac * 9 * (nv ? nv : 1));
    arm();
    for (int pass = 0; pass < 3 && !st; pass++) {
        if (pass > 0 && (st = move_mesh(m, pass, moved, jac, err)))
            break;
        ffd_write_options same = {fx->format, FFD_ENCODING_SAME, 0};
        for (size_t t = 0; t <= sizeof write_targets / sizeof write_targets[0] && !st; t++) {
            const ffd_write_options *o = t ? &write_targets[t - 1] : &same;
            unsigned char *data = NULL;
            size_t size = 0;
            st = ffd_mesh_write_memory(m, o, &data, &size, err);
            if (st)
                CHECK(data == NULL);
            ffd_free(data);
        }
    }
    free(moved);
    free(jac);
    ffd_mesh_destroy(m);
    return st;
}

/* A .gltf with an external buffer read by path (ffd_read_file of the .bin
 * too) and written by path after a move (the .gltf and its .bin as
 * temporary files, then renamed): a failure leaves no temporary file. */
static char gltf_out_dir[64];

static bool no_part_files(void)
{
    DIR *d = opendir(gltf_out_dir);
    if (!d)
        return false;
    bool clean = true;
    for (struct dirent *e; (e = readdir(d));)
        clean &= strstr(e->d_name, ".ffd-part") == NULL;
    closedir(d);
    return clean;
}

static ffd_status sc_gltf_write_file(const void *ctx, ffd_error *err)
{
    (void)ctx;
    arm();
    ffd_mesh *m = NULL;
    ffd_status st = ffd_mesh_read(DATA "cube_nodes.gltf", &m, err);
    if (st) {
        CHECK(m == NULL);
        return st;
    }
    size_t nv = ffd_mesh_vertex_count(m);
    double *moved = malloc(sizeof *moved * 3 * nv), *jac = malloc(sizeof *jac * 9 * nv);
    char path[128];
    snprintf(path, sizeof path, "%s/moved.gltf", gltf_out_dir);
    st = move_mesh(m, 2, moved, jac, err);
    if (!st)
        st = ffd_mesh_write(m, path, NULL, err);
    CHECK(no_part_files());
    free(moved);
    free(jac);
    ffd_mesh_destroy(m);
    return st;
}

/* ---------------------------------------------------------------------
 * Scenarios: deformers
 * --------------------------------------------------------------------- */

static ffd_status sc_lattice(const void *ctx, ffd_error *err)
{
    (void)ctx;
    arm();
    ffd_status st;
    ffd_box box;
    ffd_lattice *lat = NULL;
    ffd_lattice_binding *bind = NULL;
    double out[3 * SPHERE_V], jac[9 * SPHERE_V];
    if ((st = ffd_box_fit(sphere_pos, SPHERE_V, 0.05, &box, err)))
        return st;
    for (int basis = 0; basis < 2; basis++) {
        uint32_t res[3] = {4, 5, 4};
        st = ffd_lattice_create(basis ? FFD_BASIS_BERNSTEIN : FFD_BASIS_BSPLINE, &box, res, &lat,
                                err);
        if (st) {
            CHECK(lat == NULL);
            break;
        }
        st = ffd_lattice_bind(lat, sphere_pos, SPHERE_V, FFD_OUTSIDE_CLAMP, &bind, err);
        if (st) {
            CHECK(bind == NULL);
            goto next;
        }
        if ((st = ffd_lattice_move(lat, (uint32_t[3]){1, 2, 1}, (double[3]){0.1, 0.2, 0}, err)))
            goto next;
        if ((st = ffd_lattice_eval(lat, bind, out, err)))
            goto next;
        if ((st = ffd_lattice_jacobian(lat, bind, jac, err)))
            goto next;
        ffd_linear_map map;
        ffd_lattice_linear_map(lat, bind, &map);
        size_t pts[3] = {0, 7, SPHERE_V - 1};
        double cur[9], tgt[9], res3[3];
        for (int i = 0; i < 3; i++)
            for (int a = 0; a < 3; a++) {
                cur[3 * i + a] = out[3 * pts[i] + a];
                tgt[3 * i + a] = cur[3 * i + a] + (a == i ? 0.1 : 0);
            }
        double *delta = malloc(sizeof *delta * 3 * map.variable_count);
        ffd_manip_result r;
        st = ffd_manip_solve(&map, pts, 3, cur, tgt, NULL, delta, res3, &r, err);
        free(delta);
    next:
        ffd_lattice_binding_destroy(bind);
        ffd_lattice_destroy(lat);
        bind = NULL;
        lat = NULL;
        if (st)
            break;
    }
    return st;
}

static ffd_status sc_pbffd(const void *ctx, ffd_error *err)
{
    (void)ctx;
    ffd_mesh *m = NULL;
    ffd_status st = sphere_mesh(&m, err);
    if (st)
        return st;
    arm();
    ffd_placement_options po = {0};
    po.interior_count = 2;
    po.exterior_count = 8;
    ffd_ebf *controls = NULL;
    size_t count = 0;
    ffd_pbffd *pb = NULL;
    ffd_pbffd_curve *cv = NULL;
    double out[3 * SPHERE_V], jac[9 * SPHERE_V];
    st = ffd_pbffd_place(m, &po, &controls, &count, NULL, err);
    if (st) {
        CHECK(controls == NULL && count == 0);
        goto done;
    }
    ffd_pbffd_options o = {0};
    o.levels = 2;
    st = ffd_pbffd_create(controls, count, sphere_pos, SPHERE_V, &o, &pb, err);
    if (st) {
        CHECK(pb == NULL);
        goto done;
    }
    if ((st = ffd_pbffd_move(pb, 0, 1, (double[3]){0.1, 0, 0.05}, err)))
        goto done;
    if ((st = ffd_pbffd_move(pb, 1, 0, (double[3]){0, 0.1, 0}, err)))
        goto done;
    if ((st = ffd_pbffd_eval(pb, out, err)) || (st = ffd_pbffd_jacobian(pb, jac, err)))
        goto done;
    ffd_linear_map map;
    if ((st = ffd_pbffd_linear_map(pb, 1, &map, err)))
        goto done;
    {
        size_t pts[2] = {0, 9};
        double cur[6], tgt[6];
        for (int i = 0; i < 2; i++)
            for (int a = 0; a < 3; a++) {
                cur[3 * i + a] = out[3 * pts[i] + a];
                tgt[3 * i + a] = cur[3 * i + a] + 0.05;
            }
        double *delta = malloc(sizeof *delta * 3 * (map.variable_count ? map.variable_count : 1));
        st = ffd_manip_solve(&map, pts, 2, cur, tgt, NULL, delta, NULL, NULL, err);
        free(delta);
        if (st)
            goto done;
    }
    {
        ffd_ebf extra = controls[0];
        extra.center[0] += 0.2;
        size_t index = 0;
        if ((st = ffd_pbffd_add(pb, &extra, &index, err)))
            goto done;
        if ((st = ffd_pbffd_set_enabled(pb, 0, 0, err)))
            goto done;
        if ((st = ffd_pbffd_redefine(pb, 1, &extra, err)))
            goto done;
        if ((st = ffd_pbffd_remove(pb, index, err)))
            goto done;
        if ((st = ffd_pbffd_eval(pb, out, err)))
            goto done;
    }
    {
        double cp[9] = {-1.5, 0, 0, 0, 0.2, 0, 1.5, 0, 0};
        st = ffd_pbffd_curve_create(cp, 3, 0.6, 0, sphere_pos, SPHERE_V, NULL, &cv, err);
        if (st) {
            CHECK(cv == NULL);
            goto done;
        }
        if ((st = ffd_pbffd_curve_move(cv, 1, (double[3]){0, 0.3, 0}, err)))
            goto done;
        st = ffd_pbffd_curve_eval(cv, out, err);
    }
done:
    ffd_pbffd_curve_destroy(cv);
    ffd_pbffd_destroy(pb);
    ffd_free(controls);
    ffd_mesh_destroy(m);
    return st;
}

static ffd_status sc_gffd(const void *ctx, ffd_error *err)
{
    (void)ctx;
    ffd_mesh *m = NULL;
    ffd_status st = sphere_mesh(&m, err);
    if (st)
        return st;
    arm();
    double line[9] = {-1.0, 0, 0, 0, 0.1, 0, 1.0, 0, 0};
    double pt[3] = {0, 0, 0.8};
    ffd_gffd_primitive sk[2] = {
        {FFD_GFFD_POLYLINE, line, 3, NULL, NULL, 0, 0.8},
        {FFD_GFFD_POINT, pt, 1, NULL, NULL, 0, 0.5},
    };
    ffd_gffd *g = NULL;
    ffd_mesh *res = NULL;
    double out[3 * SPHERE_V];
    ffd_gffd_track_report rep;
    memset(&rep, 0, sizeof rep);
    ffd_gffd_resample_report rr;
    memset(&rr, 0, sizeof rr);
    for (int mode = 0; mode < 2 && !st; mode++) {
        ffd_gffd_options o = {0};
        o.tracking = mode ? FFD_GFFD_TRACK_WARP : FFD_GFFD_TRACK_GRADIENT;
        o.max_samples = 400;
        st = ffd_gffd_create(sk, 2, sphere_pos, SPHERE_V, &o, &g, err);
        if (st) {
            CHECK(g == NULL);
            break;
        }
        double moved[9] = {-1.0, 0, 0, 0, 0.3, 0.1, 1.0, 0.2, 0};
        if ((st = ffd_gffd_set_vertices(g, 0, moved, err)))
            goto next;
        st = ffd_gffd_track(g, out, &rep, err);
        ffd_gffd_track_report_free(&rep);
        if (st)
            goto next;
        if (mode == 1) {
            ffd_gffd_resample_options ro = {0};
            ro.ratio = 1.05;
            ro.max_rounds = 2;
            st = ffd_gffd_resample(g, m, &ro, &res, &rr, err);
            if (st)
                CHECK(res == NULL);
            ffd_gffd_resample_report_free(&rr);
            ffd_mesh_destroy(res);
            res = NULL;
            if (st)
                goto next;
            double arched[9] = {-1.0, 0.2, 0, 0, 0.4, 0, 1.0, 0.2, 0};
            ffd_gffd_primitive rp = {FFD_GFFD_POLYLINE, arched, 3, NULL, NULL, 0, 0.8};
            if ((st = ffd_gffd_replace(g, &rp, 1, err)))
                goto next;
            if ((st = ffd_gffd_set_correspondences(g, line, arched, 3, err)))
                goto next;
            st = ffd_gffd_track(g, out, NULL, err);
        }
    next:
        ffd_gffd_destroy(g);
        g = NULL;
    }
    ffd_mesh_destroy(m);
    return st;
}

static ffd_status sc_tspline(const void *ctx, ffd_error *err)
{
    (void)ctx;
    arm();
    ffd_tsv *t = NULL;
    ffd_tsv_arap *arap = NULL;
    ffd_tsv_fold_report folds;
    memset(&folds, 0, sizeof folds);
    double out[3 * SPHERE_V], jac[9 * SPHERE_V];
    uint32_t res[3] = {4, 4, 5};
    ffd_status st = ffd_tsv_create(sphere_pos, SPHERE_V, sphere_off, sphere_idx, SPHERE_F, res,
                                   NULL, &t, err);
    if (st) {
        CHECK(t == NULL);
        return st;
    }
    ffd_tsv_insertion ins[2] = {{FFD_TSV_CELL, 4, 0}, {FFD_TSV_FACE, 0, 0}};
    if ((st = ffd_tsv_locate(t, FFD_TSV_FACE, (double[3]){0.1, 0.05, 0.02}, &ins[1].id, err)))
        goto done;
    if ((st = ffd_tsv_refine(t, ins, 2, NULL, err)))
        goto done;
    if ((st = ffd_tsv_set_frozen(t, 0, 1, err)))
        goto done;
    uint32_t handles[2] = {(uint32_t)ffd_tsv_control_count(t) - 1, 40};
    st = ffd_tsv_arap_begin(t, handles, 2, NULL, &arap, err);
    if (st) {
        CHECK(arap == NULL);
        goto done;
    }
    {
        double tgt[6];
        const double *cp = ffd_tsv_control_points(t);
        for (int i = 0; i < 2; i++)
            for (int a = 0; a < 3; a++)
                tgt[3 * i + a] = cp[3 * handles[i] + a] + (a == 1 ? 0.2 : 0);
        ffd_tsv_arap_report r;
        if ((st = ffd_tsv_arap_solve(arap, tgt, &r, err)))
            goto done;
    }
    if ((st = ffd_tsv_eval(t, out, err)) || (st = ffd_tsv_jacobian(t, jac, err)))
        goto done;
    {
        ffd_linear_map map;
        if ((st = ffd_tsv_linear_map(t, &map, err)))
            goto done;
        size_t pts[1] = {3};
        double cur[3] = {out[9], out[10], out[11]}, tgt[3] = {out[9] + 0.1, out[10], out[11]};
        double *delta = malloc(sizeof *delta * 3 * map.variable_count);
        st = ffd_manip_solve(&map, pts, 1, cur, tgt, NULL, delta, NULL, NULL, err);
        free(delta);
        if (st)
            goto done;
    }
    st = ffd_tsv_check_folds(t, 2, &folds, err);
    if (st)
        CHECK(folds.folded_cells == NULL && folds.inverted_faces == NULL);
done:
    ffd_tsv_fold_report_free(&folds);
    ffd_tsv_arap_destroy(arap);
    ffd_tsv_destroy(t);
    return st;
}

/* ---------------------------------------------------------------------
 * Scenarios: rigs (examples/), and the editor session
 * --------------------------------------------------------------------- */

typedef struct rig_fixture {
    const char *rig;
    const char *mesh;
    ffd_format format;
    unsigned char *data;
    size_t size;
} rig_fixture;

static rig_fixture rigs[] = {
    {EXAMPLES "lattice/bend.json", EXAMPLES "lattice/bunny.obj", FFD_FORMAT_OBJ, NULL, 0},
    {EXAMPLES "pbffd/cow-head.json", EXAMPLES "pbffd/cow.off", FFD_FORMAT_OFF, NULL, 0},
    {EXAMPLES "gffd/twist.json", EXAMPLES "gffd/bunny.obj", FFD_FORMAT_OBJ, NULL, 0},
    {EXAMPLES "tspline/bunny-ears.json", EXAMPLES "tspline/bunny.obj", FFD_FORMAT_OBJ, NULL, 0},
    {EXAMPLES "rbf/bunny-pins.json", EXAMPLES "lattice/bunny.obj", FFD_FORMAT_OBJ, NULL, 0},
    {EXAMPLES "idw/bunny-pins.json", EXAMPLES "lattice/bunny.obj", FFD_FORMAT_OBJ, NULL, 0},
    {EXAMPLES "rbf/cube.prm", EXAMPLES "lattice/bunny.obj", FFD_FORMAT_OBJ, NULL, 0},
    {EXAMPLES "idw/cube.prm", EXAMPLES "lattice/bunny.obj", FFD_FORMAT_OBJ, NULL, 0},
    /* the general lattice path (lattice_general.c): a spherical lattice with
     * an interpolation per axis, tied centre and poles, a constraint */
    {EXAMPLES "lattice/sphere.json", EXAMPLES "lattice/bunny.obj", FFD_FORMAT_OBJ, NULL, 0},
};

/* Reads the rig file and applies it; on failure the mesh is unchanged. */
static ffd_status sc_rig(const void *ctx, ffd_error *err)
{
    const rig_fixture *fx = ctx;
    ffd_mesh *m = NULL;
    ffd_status st = ffd_mesh_read_memory(fx->data, fx->size, fx->format, fx->mesh, &m, err);
    if (st)
        return st;
    size_t nv = ffd_mesh_vertex_count(m);
    double *before = malloc(sizeof *before * 3 * nv);
    memcpy(before, ffd_mesh_positions(m), sizeof *before * 3 * nv);
    arm();
    ffd_rig *rig = NULL;
    ffd_rig_report rep;
    memset(&rep, 0, sizeof rep);
    st = ffd_rig_read(fx->rig, &rig, err);
    if (st) {
        CHECK(rig == NULL);
    } else {
        st = ffd_rig_apply(rig, m, &rep, err);
        if (st) {
            CHECK(ffd_mesh_vertex_count(m) == nv);
            CHECK(ffd_mesh_vertex_count(m) != nv ||
                  memcmp(before, ffd_mesh_positions(m), sizeof *before * 3 * nv) == 0);
        }
    }
    ffd_rig_report_free(&rep);
    ffd_rig_destroy(rig);
    free(before);
    ffd_mesh_destroy(m);
    return st;
}

static ffd_status sess_run(ffd_session *s, const char *op, const char *body, ffd_error *err)
{
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    ffd_status st = ffd_session_command(s, op, body, body ? strlen(body) : 0, &reply, &size,
                                        &binary, err);
    if (st)
        CHECK(reply == NULL);
    ffd_free(reply);
    return st;
}

static const char *const session_lattice_ops[][2] = {
    {"create", "{\"method\":\"lattice\",\"resolution\":[4,4,4]}"},
    {"move", "{\"points\":[5],\"delta\":[0,0.2,0]}"},
    {"pin", "{\"vertex\":4}"},
    {"drag_begin", "{\"vertex\":12}"},
    {"drag", "{\"target\":[0.5,0.5,0.5]}"},
    {"drag_end", "{}"},
    {"undo", NULL},
    {"redo", NULL},
    {NULL, NULL},
};

static const char *const session_tspline_ops[][2] = {
    {"create", "{\"method\":\"tspline\",\"resolution\":[4,4,4]}"},
    {"freeze", "{\"points\":[0,1,2]}"},
    {"refine", "{\"insertions\":[{\"cell\":4},{\"face\":{\"near\":[0,0,0]}}]}"},
    {"drag_begin", "{\"points\":[63]}"},
    {"drag", "{\"delta\":[0.1,0.2,0]}"},
    {"drag_end", "{}"},
    {"undo", NULL},
    {"undo", NULL},
    {"redo", NULL},
    {NULL, NULL},
};

static const char *const session_rbf_ops[][2] = {
    {"create", "{\"method\":\"rbf\",\"kernel\":\"thin_plate_spline\"}"},
    {"move", "{\"points\":[5],\"delta\":[0,0.2,0]}"},
    {"pin", "{\"vertex\":4}"},
    {"drag_begin", "{\"vertex\":12}"},
    {"drag", "{\"target\":[0.5,0.5,0.5]}"},
    {"drag_end", "{}"},
    {"undo", NULL},
    {"redo", NULL},
    {NULL, NULL},
};

static const char *const session_idw_ops[][2] = {
    {"create", "{\"method\":\"idw\",\"power\":3}"},
    {"drag_begin", "{\"points\":[13]}"},
    {"drag", "{\"delta\":[0.1,0.2,0]}"},
    {"drag_end", "{}"},
    {"pin", "{\"vertex\":4}"},
    {"undo", NULL},
    {"redo", NULL},
    {NULL, NULL},
};

/* Creates a session on the sphere and runs the ops, then reads its state,
 * frame, topology, rig and export. */
static ffd_status sc_session(const void *ctx, ffd_error *err)
{
    const char *const(*ops)[2] = (const char *const(*)[2])ctx;
    ffd_mesh *m = NULL;
    ffd_status st = sphere_mesh(&m, err);
    if (st)
        return st;
    arm();
    ffd_session *s = NULL;
    st = ffd_session_create(m, "sphere.obj", NULL, &s, err);
    if (st) {
        CHECK(s == NULL);
        ffd_mesh_destroy(m); /* untouched on error */
        return st;
    }
    for (size_t i = 0; ops[i][0] && !st; i++)
        st = sess_run(s, ops[i][0], ops[i][1], err);
    void *data = NULL;
    size_t size = 0;
    char *json = NULL;
    if (!st) {
        st = ffd_session_state(s, &json, &size, err);
        if (st)
            CHECK(json == NULL);
        ffd_free(json);
        json = NULL;
    }
    if (!st) {
        st = ffd_session_frame(s, &data, &size, err);
        if (st)
            CHECK(data == NULL);
        ffd_free(data);
        data = NULL;
    }
    if (!st) {
        st = ffd_session_topology(s, &data, &size, err);
        if (st)
            CHECK(data == NULL);
        ffd_free(data);
        data = NULL;
    }
    if (!st) {
        st = ffd_session_rig(s, &json, &size, err);
        if (st)
            CHECK(json == NULL);
    }
    if (!st) {
        /* the rig loads back as an undoable step */
        st = ffd_session_load_rig(s, json, size, "session.json", NULL, err);
    }
    ffd_free(json);
    if (!st) {
        ffd_write_options wo = {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_LE, 0};
        st = ffd_session_export(s, &wo, &data, &size, err);
        if (st)
            CHECK(data == NULL);
        ffd_free(data);
        data = NULL;
    }
    if (!st) {
        ffd_mesh *d = NULL;
        st = ffd_session_deformed(s, &d, err);
        if (st)
            CHECK(d == NULL);
        ffd_mesh_destroy(d);
    }
    ffd_session_destroy(s);
    return st;
}

/* ---------------------------------------------------------------------
 * Tests
 * --------------------------------------------------------------------- */

#define OTHER(s) (1u << (s))

static void test_mesh_read(void)
{
    for (int i = 0; i < FIXTURE_COUNT; i++) {
        char name[64];
        snprintf(name, sizeof name, "read %s", fixtures[i].file);
        scenario sc = {name, sc_mesh_read, &fixtures[i], 0, 0};
        sweep(&sc);
    }
    char name[64] = "read file all_forms.obj";
    scenario sc = {name, sc_mesh_read_file, &fixtures[0], 0, 0};
    sweep(&sc);
}

static void test_mesh_write(void)
{
    for (int i = 0; i < FIXTURE_COUNT; i++) {
        char name[64];
        snprintf(name, sizeof name, "write %s", fixtures[i].file);
        scenario sc = {name, sc_mesh_write, &fixtures[i], 0, 0};
        sweep(&sc);
    }
    strcpy(gltf_out_dir, "/tmp/ffd_sweep_XXXXXX");
    CHECK(mkdtemp(gltf_out_dir) != NULL);
    scenario sc = {"write file cube_nodes.gltf", sc_gltf_write_file, NULL, 0, 0};
    sweep(&sc);
    char path[128];
    snprintf(path, sizeof path, "%s/moved.gltf", gltf_out_dir);
    unlink(path);
    snprintf(path, sizeof path, "%s/cube_nodes.bin", gltf_out_dir);
    unlink(path);
    CHECK(rmdir(gltf_out_dir) == 0);
}

/* The cage deformer: an octahedron cage, mean value and harmonic
 * coordinates (the grid, CHOLMOD), binding, moves, evaluation. */
static ffd_status sc_cage(const void *ctx, ffd_error *err)
{
    (void)ctx;
    static const double v[] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    static const uint32_t t[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4,
                                 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    const double p[3 * 4] = {0.1, 0.2, 0.1, -0.3, 0, 0.2, 2, 2, 2, 0, 0, -0.5};
    const double d[3] = {0.1, 0, 0.2};
    double out[12];
    arm();
    ffd_status st = FFD_OK;
    for (int kind = 0; kind < 2 && !st; kind++) {
        ffd_cage_options o = {(ffd_cage_coordinates)kind, 6, FFD_CAGE_OUTSIDE_CLAMP};
        ffd_cage *c = NULL;
        ffd_cage_binding *b = NULL;
        st = ffd_cage_create(v, 6, t, 8, NULL, &o, &c, err);
        if (!st)
            st = ffd_cage_bind(c, p, 4, &b, err);
        if (!st)
            st = ffd_cage_move(c, 4, d, err);
        if (!st)
            st = ffd_cage_eval(c, b, out, err);
        CHECK(st || b != NULL);
        ffd_cage_binding_destroy(b);
        ffd_cage_destroy(c);
    }
    return st;
}

static void test_cage(void)
{
    scenario sc = {"cage", sc_cage, NULL, 0, 0};
    sweep(&sc);
}

static void test_lattice(void)
{
    scenario sc = {"lattice+manip", sc_lattice, NULL, 0, 0};
    sweep(&sc);
}

static void test_pbffd(void)
{
    scenario sc = {"pbffd place+edit", sc_pbffd, NULL, 0, 0};
    sweep(&sc);
}

static void test_gffd(void)
{
    scenario sc = {"gffd", sc_gffd, NULL, 0, 0};
    sweep(&sc);
}

static void test_tspline(void)
{
    scenario sc = {"tspline+arap", sc_tspline, NULL, 0, 0};
    sweep(&sc);
}

static void test_rigs(void)
{
    static const long caps[] = {0, 400, 0, 600, 0, 0, 0, 0, 0};
    for (size_t i = 0; i < sizeof rigs / sizeof rigs[0]; i++) {
        const char *base = strstr(rigs[i].rig, "examples/");
        scenario sc = {base ? base + 9 : rigs[i].rig, sc_rig, &rigs[i], 0, caps[i]};
        sweep(&sc);
    }
}

static void test_session(void)
{
    scenario a = {"session lattice", sc_session, session_lattice_ops, 0, 0};
    sweep(&a);
    scenario b = {"session tspline", sc_session, session_tspline_ops, 0, 0};
    sweep(&b);
    scenario c = {"session rbf", sc_session, session_rbf_ops, 0, 0};
    sweep(&c);
    scenario d = {"session idw", sc_session, session_idw_ops, 0, 0};
    sweep(&d);
}

int main(int argc, char **argv)
{
    omp_set_num_threads(1);
    void *warm[4];
    backtrace(warm, 4); /* loads the unwinder before any sweep */
    sweep_verbose = getenv("FFD_SWEEP_VERBOSE") && atoi(getenv("FFD_SWEEP_VERBOSE"));
    make_sphere();
    for (int i = 0; i < FIXTURE_COUNT; i++) {
        char path[512];
        snprintf(path, sizeof path, "%s%s", DATA, fixtures[i].file);
        fixtures[i].data = slurp(path, &fixtures[i].size);
        if (!fixtures[i].data) {
            fprintf(stderr, "cannot read %s\n", path);
            return 1;
        }
    }
    for (size_t i = 0; i < sizeof rigs / sizeof rigs[0]; i++) {
        rigs[i].data = slurp(rigs[i].mesh, &rigs[i].size);
        if (!rigs[i].data) {
            fprintf(stderr, "cannot read %s\n", rigs[i].mesh);
            return 1;
        }
    }
    static const check_test tests[] = {
        {"mesh_read", test_mesh_read}, {"mesh_write", test_mesh_write},
        {"lattice", test_lattice},     {"pbffd", test_pbffd},
        {"gffd", test_gffd},           {"tspline", test_tspline},
        {"cage", test_cage},
        {"rigs", test_rigs},           {"session", test_session},
    };
    int rc = check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
    printf("%ld failing runs in all\n", sweep_total_runs);
    for (int i = 0; i < FIXTURE_COUNT; i++)
        free(fixtures[i].data);
    for (size_t i = 0; i < sizeof rigs / sizeof rigs[0]; i++)
        free(rigs[i].data);
    return rc;
}
