/* Test helpers for the public deformer (ffd.h "Deformers"): every
 * method's example rigs as a table of cases (test_deformer.c,
 * test_sensitivities.c), a deformer built from each on its mesh, and a
 * sample of points bound to it. Include after check.h. */
#ifndef FFD_TEST_CHECK_DEFORMER_H
#define FFD_TEST_CHECK_DEFORMER_H

#include "check.h"

#include "ffd.h"

#define EX FFD_SOURCE_DIR "/examples/"
#define DATA FFD_SOURCE_DIR "/tests/data/deformer/"

typedef struct rig_case {
    const char *method;
    const char *mesh;
    const char *rig;
} rig_case;

static const rig_case cases[] = {
    {"lattice", EX "lattice/bunny.obj", EX "lattice/pins.json"},
    {"lattice", EX "lattice/bunny.obj", EX "lattice/bernstein.json"},
    {"lattice", EX "lattice/bunny.obj", EX "lattice/ears.json"},
    {"pbffd", EX "pbffd/cow.off", EX "pbffd/cow-levels.json"},
    {"pbffd", EX "pbffd/cow.off", EX "pbffd/cow-drag.json"},
    {"tspline", EX "tspline/bunny.obj", EX "tspline/bunny-ears.json"},
    /* GFFD on the meshes the example rigs are for (trunk.obj and head.off
     * are skeleton files), without adaptive resampling, which adds vertices
     * (a deformer binds a fixed point set): warp tracking (a vertex edit; a
     * rotation of two primitives), and gradient tracking (two primitives) */
    {"gffd", EX "gffd/elephant.off", DATA "gffd-bend.json"},
    {"gffd", EX "gffd/bunny.obj", DATA "gffd-twist.json"},
    {"gffd", EX "gffd/elephant.off", DATA "gffd-gradient.json"},
    /* the T-spline on the cow, refined then dragged */
    {"tspline", EX "tspline/cow.off", EX "tspline/cow-head.json"},
    /* method-specific: lattice outside policies (an oblique box holding part
     * of the mesh), PB-FFD frames at the finest level, a frame at a coarser
     * level and a curve (§3.5; those two have no linear map) */
    {"lattice", EX "lattice/bunny.obj", FFD_SOURCE_DIR "/tests/data/deformer/bunny-clamp.json"},
    {"lattice", EX "lattice/bunny.obj",
     FFD_SOURCE_DIR "/tests/data/deformer/bunny-extrapolate.json"},
    {"pbffd", EX "pbffd/cow.off", FFD_SOURCE_DIR "/tests/data/deformer/cow-frames.json"},
    {"pbffd", EX "pbffd/cow.off", FFD_SOURCE_DIR "/tests/data/deformer/cow-coarse-frame.json"},
    {"pbffd", EX "pbffd/elephant.off", EX "pbffd/elephant-trunk.json"},
    /* cage: mean value coordinates moved and dragged, harmonic coordinates
     * (a coarse grid) on the file cage and on the "auto" box with "clamp" */
    {"cage", EX "cage/bunny.obj", EX "cage/bunny-mvc.json"},
    {"cage", EX "cage/bunny.obj", EX "cage/bunny-drag.json"},
    {"cage", EX "cage/bunny.obj", EX "cage/bunny-harmonic.json"},
    {"cage", EX "cage/bunny.obj", EX "cage/bunny-auto.json"},
    /* Kelvinlet brushes: the four loads superposed, a multi-scale stroke in
     * sequence, constraints solved over three grabs */
    {"kelvinlet", EX "lattice/bunny.obj", EX "kelvinlet/bunny-brushes.json"},
    {"kelvinlet", EX "lattice/bunny.obj", EX "kelvinlet/bunny-stroke.json"},
    {"kelvinlet", EX "lattice/bunny.obj", EX "kelvinlet/bunny-pins.json"},
    /* RBF and IDW (docs/rbf-idw.md): moves, and constraints solved by direct manipulation */
    {"rbf", EX "lattice/bunny.obj", EX "rbf/bunny-ears.json"},
    {"rbf", EX "lattice/bunny.obj", EX "rbf/bunny-pins.json"},
    {"idw", EX "lattice/bunny.obj", EX "idw/bunny-ears.json"},
    {"idw", EX "lattice/bunny.obj", EX "idw/bunny-pins.json"},
    /* nested lattices (three levels, one Bernstein) and the falloff outside
     * the lattice (docs/lattice-variants.md) */
    {"lattice", EX "lattice/bunny.obj", EX "lattice/nested.json"},
    {"lattice", EX "lattice/bunny.obj", EX "lattice/falloff.json"},
    /* the generic layers around a method (docs/constraints.md): strength and
     * fold policy on the lattice */
    {"lattice", EX "lattice/bunny.obj", FFD_SOURCE_DIR "/tests/data/deformer/bunny-layers.json"},
    /* lattice variants: mixed interpolation, cylindrical, spherical (L1) */
    {"lattice", EX "lattice/bunny.obj", EX "lattice/mixed.json"},
    {"lattice", EX "lattice/bunny.obj", EX "lattice/cylinder.json"},
    {"lattice", EX "lattice/bunny.obj", EX "lattice/sphere.json"},
};
#define ALL_CASES (sizeof cases / sizeof *cases)

/* Under valgrind (scripts/valgrind.sh sets FFD_TEST_QUICK) one rig per
 * method: the first of each; the release and sanitizer builds run all. */
static size_t case_count;
static rig_case quick_cases[ALL_CASES];
static const rig_case *case_table = cases;
#define CASE_COUNT case_count

static inline void choose_cases(void)
{
    case_count = ALL_CASES;
    if (!getenv("FFD_TEST_QUICK"))
        return;
    case_count = 0;
    for (size_t i = 0; i < ALL_CASES; i++) {
        int seen = 0;
        for (size_t j = 0; j < i; j++)
            seen |= strcmp(cases[j].method, cases[i].method) == 0;
        if (!seen)
            quick_cases[case_count++] = cases[i];
    }
    case_table = quick_cases;
}

static inline ffd_mesh *read_mesh(const char *path)
{
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &mesh, &err))
        fprintf(stderr, "%s\n", err.message);
    return mesh;
}

static inline ffd_deformer *make(const rig_case *c, const ffd_mesh *mesh)
{
    ffd_rig *rig = NULL;
    ffd_deformer *d = NULL;
    ffd_error err = {{0}};
    if (ffd_rig_read(c->rig, &rig, &err) || ffd_deformer_create(rig, mesh, NULL, &d, &err))
        fprintf(stderr, "%s: %s\n", c->rig, err.message);
    ffd_rig_destroy(rig);
    return d;
}

static inline double diagonal(const double *p, size_t n)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], p[3 * i + a]);
            hi[a] = fmax(hi[a], p[3 * i + a]);
        }
    return sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1])
                + (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

static inline double max_diff(const double *a, const double *b, size_t count)
{
    double m = 0;
    for (size_t i = 0; i < count; i++)
        m = fmax(m, fabs(a[i] - b[i]));
    return m;
}

/* got and want (count doubles) agree to 1e-9 of diag; what and rig name the
 * comparison in the message printed when they do not. */
static inline void check_agree(const double *got, const double *want, size_t count,
                               double diag, const char *rig, const char *what)
{
    double diff = max_diff(got, want, count);
    if (diff > 1e-9 * diag)
        fprintf(stderr, "%s: %s: %.3g\n", rig, what, diff);
    CHECK(diff <= 1e-9 * diag);
}

/* Runs check on a deformer built from each case's rig on its mesh. */
static inline void for_each_case(void (*check)(const rig_case *rc, const ffd_mesh *mesh,
                                              ffd_deformer *d))
{
    for (size_t c = 0; c < CASE_COUNT; c++) {
        ffd_mesh *mesh = read_mesh(case_table[c].mesh);
        ffd_deformer *d = mesh ? make(&case_table[c], mesh) : NULL;
        CHECK(d != NULL);
        if (d)
            check(&case_table[c], mesh, d);
        ffd_deformer_destroy(d);
        ffd_mesh_destroy(mesh);
    }
}

/* Binds a sample of s points spread over the mesh (every (n/s)th vertex)
 * and returns their count (s, or the vertex count when smaller). */
static inline size_t bind_sample(ffd_deformer *d, const ffd_mesh *mesh, size_t s, double *points)
{
    const size_t n = ffd_mesh_vertex_count(mesh);
    const double *rest = ffd_mesh_positions(mesh);
    if (s > n)
        s = n;
    for (size_t i = 0; i < s; i++)
        memcpy(points + 3 * i, rest + 3 * (i * n / s), 3 * sizeof *points);
    ffd_error err = {{0}};
    CHECK_OK(ffd_deformer_bind(d, points, s, &err));
    return s;
}

#endif
