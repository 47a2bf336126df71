/* Tests of the cage deformer (include/ffd_cage.h, src/cage/): mean value
 * coordinates (Ju, Schaefer & Warren 2005) against the vector form of
 * Floater, Kos & Reimers 2005 written out here, partition of unity, linear
 * precision, points on the cage, harmonic coordinates (Joshi et al. 2007)
 * non-negative and discretely harmonic, rigid motions, identity, threads,
 * direct manipulation, and the refused cages. */
#include "check.h"

#include "ffd.h"
#include "cage/cage.h"
#include "math/spatial.h"

#include <omp.h>
#include <stdint.h>

/* ---- cages ---- */

/* The octahedron with vertices at +-1 on each axis (outward). */
static const double octa_v[] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
static const uint32_t octa_t[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4,
                                  2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};

/* A unit cube [0,1]^3 whose top face is dented: its centre vertex (8) at z = 0.6. */
static const double dent_v[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0,
                                0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1, 0.5, 0.5, 0.6};
static const uint32_t dent_t[] = {
    0, 2, 1, 0, 3, 2,                   /* bottom */
    0, 1, 5, 0, 5, 4, 1, 2, 6, 1, 6, 5, /* sides */
    2, 3, 7, 2, 7, 6, 3, 0, 4, 3, 4, 7,
    4, 5, 8, 5, 6, 8, 6, 7, 8, 7, 4, 8, /* top, dented */
};

static ffd_cage *make(const double *v, size_t nv, const uint32_t *t, size_t nt,
                      ffd_cage_coordinates kind, uint32_t res, ffd_cage_outside outside)
{
    ffd_cage_options o = {kind, res, outside};
    ffd_cage *c = NULL;
    ffd_error err = {{0}};
    if (ffd_cage_create(v, nv, t, nt, NULL, &o, &c, &err))
        fprintf(stderr, "cage: %s\n", err.message);
    return c;
}

#define OCTA octa_v, 6, octa_t, 8
#define DENT dent_v, 9, dent_t, 14

/* Random points in [lo, hi]^3. */
static void random_points(double *p, size_t n, double lo, double hi)
{
    for (size_t i = 0; i < 3 * n; i++)
        p[i] = lo + (hi - lo) * check_rand01();
}

/* max over points of |sum_j w_j - 1| and |sum_j w_j v_j - x|. */
static void reproduction(const ffd_cage *c, const ffd_cage_binding *b, const double *p, size_t n,
                         double *unity, double *linear)
{
    size_t nv = ffd_cage_vertex_count(c);
    const double *v = ffd_cage_rest_vertices(c);
    *unity = *linear = 0;
    for (size_t i = 0; i < n; i++) {
        const double *w = ffd_cage_binding_weights(b, i);
        double s = 0, x[3] = {0, 0, 0};
        for (size_t j = 0; j < nv; j++) {
            s += w[j];
            for (int a = 0; a < 3; a++)
                x[a] += w[j] * v[3 * j + a];
        }
        *unity = fmax(*unity, fabs(s - 1));
        for (int a = 0; a < 3; a++)
            *linear = fmax(*linear, fabs(x[a] - p[3 * i + a]));
    }
}

/* ---- mean value coordinates ---- */

static void test_mvc_reproduction(void)
{
    enum { N = 400 };
    double p[3 * N];
    ffd_error err = {{0}};
    for (int which = 0; which < 2; which++) {
        ffd_cage *c = which ? make(DENT, FFD_CAGE_MEAN_VALUE, 0, 0)
                            : make(OCTA, FFD_CAGE_MEAN_VALUE, 0, 0);
        CHECK(c != NULL);
        if (!c)
            continue;
        /* inside: to rounding; outside (the coordinates extend), where the
         * closed form's front and back faces cancel, to ~1e-10 */
        for (int outside = 0; outside < 2; outside++) {
            size_t got = 0;
            while (got < N) {
                double *x = p + 3 * got;
                random_points(x, 1, which ? -0.5 : -1.5, 1.5);
                double l1 = fabs(x[0]) + fabs(x[1]) + fabs(x[2]);
                int in = which ? x[0] > 1e-3 && x[0] < 1 - 1e-3 && x[1] > 1e-3 &&
                                     x[1] < 1 - 1e-3 && x[2] > 1e-3 && x[2] < 0.6 - 1e-3
                               : l1 < 1 - 1e-3;
                int out = which ? x[0] < -1e-2 || x[0] > 1.01 || x[1] < -1e-2 || x[1] > 1.01 ||
                                      x[2] < -1e-2 || x[2] > 1.01
                                : l1 > 1.01;
                got += outside ? out : in;
            }
            ffd_cage_binding *b = NULL;
            CHECK_OK(ffd_cage_bind(c, p, N, &b, &err));
            double unity, linear;
            reproduction(c, b, p, N, &unity, &linear);
            CHECK_NEAR(unity, 0, 1e-12);
            CHECK_NEAR(linear, 0, outside ? 1e-9 : 1e-12);
            CHECK(ffd_cage_binding_inside_count(b) == (outside ? 0 : N));
            ffd_cage_binding_destroy(b);
        }
        ffd_cage_destroy(c);
    }
}

/* Points on cage vertices, edges and faces get the cage's linear
 * interpolation there: the hat functions. */
static void test_mvc_on_cage(void)
{
    ffd_cage *c = make(DENT, FFD_CAGE_MEAN_VALUE, 0, FFD_CAGE_OUTSIDE_FIXED);
    CHECK(c != NULL);
    if (!c)
        return;
    /* vertex 6, the midpoint of edge (0, 1), a point on the bottom face
     * (0, 3, 2) and one on the dented face (4, 5, 8) */
    double p[3 * 4] = {1, 1, 1, 0.5, 0, 0, 0.25, 0.5, 0, 0, 0, 0};
    double bary[3] = {0.2, 0.3, 0.5};
    for (int a = 0; a < 3; a++)
        p[9 + a] = bary[0] * dent_v[12 + a] + bary[1] * dent_v[15 + a] + bary[2] * dent_v[24 + a];
    ffd_cage_binding *b = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_cage_bind(c, p, 4, &b, &err));
    if (!b) {
        ffd_cage_destroy(c);
        return;
    }
    CHECK(ffd_cage_binding_inside_count(b) == 4);
    double want[4][9] = {{0, 0, 0, 0, 0, 0, 1, 0, 0},
                         {0.5, 0.5, 0, 0, 0, 0, 0, 0, 0},
                         {0.5, 0, 0.25, 0.25, 0, 0, 0, 0, 0},
                         {0, 0, 0, 0, 0.2, 0.3, 0, 0, 0.5}};
    for (int i = 0; i < 4; i++) {
        const double *w = ffd_cage_binding_weights(b, (size_t)i);
        for (int j = 0; j < 9; j++)
            CHECK_NEAR(w[j], want[i][j], 1e-12);
    }
    ffd_cage_binding_destroy(b);
    ffd_cage_destroy(c);
}

/* The independent formula: the vector form of Floater, Kos & Reimers
 * (2005, "Mean value coordinates in 3D", §2): the mean vector of a
 * triangle's spherical projection m = 1/2 sum_i beta_i N_i (beta_i the arc
 * opposite e_i, N_i the unit normal of the plane through the other two),
 * written as sum_i lambda_i e_i with lambda_i = (m . N_i) / (e_i . N_i),
 * and w_i += lambda_i / |v_i - x|, normalised. */
static void fkr_weights(const double *v, size_t nv, const uint32_t *t, size_t nt,
                        const double x[3], double *w)
{
    for (size_t j = 0; j < nv; j++)
        w[j] = 0;
    for (size_t f = 0; f < nt; f++) {
        double e[3][3], d[3], N[3][3], beta[3], m[3] = {0, 0, 0};
        for (int i = 0; i < 3; i++) {
            const double *q = v + 3 * (size_t)t[3 * f + i];
            d[i] = sqrt((q[0] - x[0]) * (q[0] - x[0]) + (q[1] - x[1]) * (q[1] - x[1]) +
                        (q[2] - x[2]) * (q[2] - x[2]));
            for (int a = 0; a < 3; a++)
                e[i][a] = (q[a] - x[a]) / d[i];
        }
        for (int i = 0; i < 3; i++) {
            const double *a = e[(i + 1) % 3], *b = e[(i + 2) % 3];
            double cr[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                            a[0] * b[1] - a[1] * b[0]};
            double len = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
            beta[i] = atan2(len, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
            for (int k = 0; k < 3; k++)
                N[i][k] = cr[k] / len;
        }
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                m[k] += 0.5 * beta[i] * N[i][k];
        for (int i = 0; i < 3; i++) {
            double lambda = (m[0] * N[i][0] + m[1] * N[i][1] + m[2] * N[i][2]) /
                            (e[i][0] * N[i][0] + e[i][1] * N[i][1] + e[i][2] * N[i][2]);
            w[t[3 * f + i]] += lambda / d[i];
        }
    }
    double s = 0;
    for (size_t j = 0; j < nv; j++)
        s += w[j];
    for (size_t j = 0; j < nv; j++)
        w[j] /= s;
}

static void test_mvc_independent_formula(void)
{
    enum { N = 200 };
    double p[3 * N], w[9];
    ffd_error err = {{0}};
    for (int which = 0; which < 2; which++) {
        const double *v = which ? dent_v : octa_v;
        const uint32_t *t = which ? dent_t : octa_t;
        size_t nv = which ? 9 : 6, nt = which ? 14 : 8;
        ffd_cage *c = make(v, nv, t, nt, FFD_CAGE_MEAN_VALUE, 0, 0);
        CHECK(c != NULL);
        if (!c)
            continue;
        random_points(p, N, which ? -0.3 : -1.2, which ? 1.3 : 1.2);
        ffd_cage_binding *b = NULL;
        CHECK_OK(ffd_cage_bind(c, p, N, &b, &err));
        double worst = 0;
        for (size_t i = 0; b && i < N; i++) {
            fkr_weights(v, nv, t, nt, p + 3 * i, w);
            const double *got = ffd_cage_binding_weights(b, i);
            for (size_t j = 0; j < nv; j++)
                worst = fmax(worst, fabs(got[j] - w[j]));
        }
        CHECK_NEAR(worst, 0, 1e-10);
        ffd_cage_binding_destroy(b);
        ffd_cage_destroy(c);
    }
}

/* Inside a convex cage the coordinates are positive (Ju et al. §3.2);
 * near a face they tend to its barycentric coordinates. */
static void test_mvc_near_face(void)
{
    ffd_cage *c = make(OCTA, FFD_CAGE_MEAN_VALUE, 0, 0);
    CHECK(c != NULL);
    if (!c)
        return;
    double p[3 * 6];
    /* toward the centroid of face (0, 2, 4) from inside, then outside */
    const double dist[6] = {1e-3, 1e-6, 1e-9, -1e-3, -1e-6, -1e-9};
    for (int i = 0; i < 6; i++)
        for (int a = 0; a < 3; a++)
            p[3 * i + a] = (1.0 / 3) * (1 - dist[i] * sqrt(3.0));
    ffd_cage_binding *b = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_cage_bind(c, p, 6, &b, &err));
    double unity, linear;
    reproduction(c, b, p, 6, &unity, &linear);
    CHECK_NEAR(unity, 0, 1e-12);
    /* to rounding down to 1e-6 of the diagonal; nearer (pi - h below
     * FFD_TOL_CAGE_FACE: ~3e-8) the point counts as on the face, and its
     * error is its distance */
    CHECK_NEAR(linear, 0, 1e-9);
    double near_err = 0;
    for (int i = 0; b && i < 6; i++) {
        if (fabs(dist[i]) < 1e-8)
            continue;
        const double *w = ffd_cage_binding_weights(b, (size_t)i);
        double x = 0;
        for (int j = 0; j < 6; j++)
            x += w[j] * octa_v[3 * j];
        near_err = fmax(near_err, fabs(x - p[3 * i]));
    }
    CHECK_NEAR(near_err, 0, 1e-14);
    for (int i = 0; b && i < 3; i++) {
        const double *w = ffd_cage_binding_weights(b, (size_t)i);
        for (int j = 0; j < 6; j++)
            CHECK(w[j] > 0 || (j != 0 && j != 2 && j != 4 && w[j] >= 0));
        CHECK_NEAR(w[0], 1.0 / 3, 10 * dist[i]);
    }
    ffd_cage_binding_destroy(b);
    ffd_cage_destroy(c);
}

/* ---- harmonic coordinates ---- */

static void test_harmonic_properties(void)
{
    enum { N = 300 };
    double p[3 * N];
    ffd_error err = {{0}};
    double previous = INFINITY;
    for (uint32_t res = 8; res <= 16; res *= 2) {
        ffd_cage *c = make(DENT, FFD_CAGE_HARMONIC, res, 0);
        CHECK(c != NULL);
        if (!c)
            continue;
        check_rng_state = 12345;
        random_points(p, N, 0.02, 0.98);
        for (size_t i = 0; i < N; i++) /* under the dent */
            p[3 * i + 2] *= 0.58;
        ffd_cage_binding *b = NULL;
        CHECK_OK(ffd_cage_bind(c, p, N, &b, &err));
        if (!b) {
            ffd_cage_destroy(c);
            continue;
        }
        CHECK(ffd_cage_binding_inside_count(b) == N);
        double unity, linear, lowest = INFINITY;
        reproduction(c, b, p, N, &unity, &linear);
        for (size_t i = 0; i < N; i++)
            for (size_t j = 0; j < 9; j++)
                lowest = fmin(lowest, ffd_cage_binding_weights(b, i)[j]);
        CHECK_NEAR(unity, 0, 1e-12);
        CHECK(lowest >= -1e-14);
        /* linear precision to the grid's accuracy, improving with it */
        double h = 1.0 / res;
        CHECK(linear <= h);
        CHECK(linear < previous);
        previous = linear;
        /* discretely harmonic: the 7-point Laplacian of every coordinate
         * vanishes at the interior nodes */
        const cage_grid *g = c->grid;
        size_t sj = g->dims[2], si = (size_t)g->dims[1] * g->dims[2], count = si * g->dims[0];
        double worst = 0;
        size_t interior = 0;
        for (size_t id = si; id + si < count; id++) {
            if (!g->inside[id])
                continue;
            interior++;
            const size_t nb[6] = {id - 1, id + 1, id - sj, id + sj, id - si, id + si};
            for (size_t j = 0; j < 9; j++) {
                double lap = 6 * g->values[(size_t)g->slot[id] * 9 + j];
                for (int q = 0; q < 6; q++)
                    lap -= g->values[(size_t)g->slot[nb[q]] * 9 + j];
                worst = fmax(worst, fabs(lap));
            }
        }
        CHECK(interior == g->unknowns && interior > 100);
        CHECK_NEAR(worst, 0, 1e-12);
        ffd_cage_binding_destroy(b);
        ffd_cage_destroy(c);
    }
}

/* On the cage, harmonic coordinates are the hat functions exactly. */
static void test_harmonic_on_cage(void)
{
    ffd_cage *c = make(DENT, FFD_CAGE_HARMONIC, 8, 0);
    CHECK(c != NULL);
    if (!c)
        return;
    double p[3 * 3] = {1, 1, 1, 0.5, 0, 0, 0.25, 0.5, 0};
    ffd_cage_binding *b = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_cage_bind(c, p, 3, &b, &err));
    double want[3][9] = {{0, 0, 0, 0, 0, 0, 1, 0, 0},
                         {0.5, 0.5, 0, 0, 0, 0, 0, 0, 0},
                         {0.5, 0, 0.25, 0.25, 0, 0, 0, 0, 0}};
    for (int i = 0; b && i < 3; i++)
        for (int j = 0; j < 9; j++)
            CHECK_NEAR(ffd_cage_binding_weights(b, (size_t)i)[j], want[i][j], 1e-12);
    CHECK(b && ffd_cage_binding_inside_count(b) == 3);
    ffd_cage_binding_destroy(b);
    ffd_cage_destroy(c);
}

/* ---- the deformation ---- */

/* A cage at rest gives every point back bitwise (also -0.0), and a point
 * outside a "fixed" cage keeps its bits whatever moves. */
static void test_identity_and_fixed(void)
{
    double p[3 * 4] = {-0.0, 0.2, 0.3, 0.1, -0.0, 0.1, 3, 3, 3, -2, 0.5, -0.0};
    for (int kind = 0; kind < 2; kind++) {
        ffd_cage *c = make(OCTA, (ffd_cage_coordinates)kind, 8, FFD_CAGE_OUTSIDE_FIXED);
        CHECK(c != NULL);
        if (!c)
            continue;
        ffd_cage_binding *b = NULL;
        ffd_error err = {{0}};
        double out[12];
        CHECK_OK(ffd_cage_bind(c, p, 4, &b, &err));
        CHECK_OK(ffd_cage_eval(c, b, out, &err));
        CHECK(memcmp(out, p, sizeof out) == 0);
        CHECK(ffd_cage_binding_inside_count(b) == 2);
        double d[3] = {0.1, 0.2, -0.3};
        CHECK_OK(ffd_cage_move(c, 4, d, &err));
        CHECK_OK(ffd_cage_eval(c, b, out, &err));
        CHECK(memcmp(out + 6, p + 6, 6 * sizeof *out) == 0);
        CHECK(out[2] != p[2]);
        ffd_cage_reset(c);
        CHECK_OK(ffd_cage_eval(c, b, out, &err));
        CHECK(memcmp(out, p, sizeof out) == 0);
        ffd_cage_binding_destroy(b);
        ffd_cage_destroy(c);
    }
}

/* x -> R x + t applied to the cage moves the points by it: exactly (to
 * rounding) for mean value coordinates, to the grid's accuracy for harmonic
 * ones, whose translations are exact (partition of unity). */
static void test_rigid_motion(void)
{
    enum { N = 100 };
    double p[3 * N], out[3 * N], v[3 * 9];
    const double angle = 0.7, axis[3] = {1 / sqrt(3.0), 1 / sqrt(3.0), 1 / sqrt(3.0)};
    const double tr[3] = {0.3, -1.2, 2.5};
    double R[3][3];
    double cs = cos(angle), sn = sin(angle);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            R[i][j] = (1 - cs) * axis[i] * axis[j] + (i == j ? cs : 0);
    R[0][1] -= sn * axis[2], R[0][2] += sn * axis[1], R[1][0] += sn * axis[2];
    R[1][2] -= sn * axis[0], R[2][0] -= sn * axis[1], R[2][1] += sn * axis[0];
    for (int kind = 0; kind < 2; kind++)
        for (int rotate = 0; rotate < 2; rotate++) {
            ffd_cage *c = make(DENT, (ffd_cage_coordinates)kind, 16, 0);
            CHECK(c != NULL);
            if (!c)
                continue;
            random_points(p, N, 0.05, 0.95);
            for (size_t i = 0; i < N; i++)
                p[3 * i + 2] *= 0.55;
            ffd_cage_binding *b = NULL;
            ffd_error err = {{0}};
            CHECK_OK(ffd_cage_bind(c, p, N, &b, &err));
            for (size_t j = 0; j < 9; j++)
                for (int a = 0; a < 3; a++) {
                    const double *q = dent_v + 3 * j;
                    v[3 * j + a] = tr[a] + (rotate ? R[a][0] * q[0] + R[a][1] * q[1] +
                                                         R[a][2] * q[2]
                                                   : q[a]);
                }
            CHECK_OK(ffd_cage_set_vertices(c, v, &err));
            CHECK_OK(ffd_cage_eval(c, b, out, &err));
            double worst = 0;
            for (size_t i = 0; i < N; i++)
                for (int a = 0; a < 3; a++) {
                    const double *q = p + 3 * i;
                    double want = tr[a] + (rotate ? R[a][0] * q[0] + R[a][1] * q[1] +
                                                        R[a][2] * q[2]
                                                  : q[a]);
                    worst = fmax(worst, fabs(out[3 * i + a] - want));
                }
            CHECK_NEAR(worst, 0, kind == FFD_CAGE_MEAN_VALUE || !rotate ? 1e-12 : 0.1);
            ffd_cage_binding_destroy(b);
            ffd_cage_destroy(c);
        }
}

/* Binding is bitwise the same for 1 and 4 threads. */
static void test_threads(void)
{
    enum { N = 500 };
    double p[3 * N];
    random_points(p, N, -0.2, 1.2);
    for (int kind = 0; kind < 2; kind++) {
        ffd_cage *c = make(DENT, (ffd_cage_coordinates)kind, 8, FFD_CAGE_OUTSIDE_CLAMP);
        CHECK(c != NULL);
        if (!c)
            continue;
        ffd_cage_binding *one = NULL, *four = NULL;
        ffd_error err = {{0}};
        int threads = omp_get_max_threads();
        omp_set_num_threads(1);
        CHECK_OK(ffd_cage_bind(c, p, N, &one, &err));
        omp_set_num_threads(4);
        CHECK_OK(ffd_cage_bind(c, p, N, &four, &err));
        omp_set_num_threads(threads);
        for (size_t i = 0; one && four && i < N; i++)
            CHECK(memcmp(ffd_cage_binding_weights(one, i), ffd_cage_binding_weights(four, i),
                         9 * sizeof(double)) == 0);
        ffd_cage_binding_destroy(one);
        ffd_cage_binding_destroy(four);
        ffd_cage_destroy(c);
    }
}

/* "clamp": a point outside moves with its nearest cage point; continuous. */
static void test_clamp(void)
{
    ffd_cage *c = make(DENT, FFD_CAGE_HARMONIC, 8, FFD_CAGE_OUTSIDE_CLAMP);
    CHECK(c != NULL);
    if (!c)
        return;
    double p[3 * 2] = {0.5, 0.5, -0.5, 0.5, -2, 0.5}; /* under the bottom face, beside a side */
    ffd_cage_binding *b = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_cage_bind(c, p, 2, &b, &err));
    if (b) {
        const double *w = ffd_cage_binding_weights(b, 0);
        CHECK_NEAR(w[0] + w[2], 1, 1e-12); /* (0.5, 0.5, 0): the bottom face's diagonal */
        CHECK(ffd_cage_binding_inside_count(b) == 0);
        w = ffd_cage_binding_weights(b, 1);
        CHECK_NEAR(w[0] + w[1] + w[4] + w[5], 1, 1e-12);
    }
    ffd_cage_binding_destroy(b);
    ffd_cage_destroy(c);
}

/* Direct manipulation through the linear map reaches its targets. */
static void test_direct_manipulation(void)
{
    for (int kind = 0; kind < 2; kind++) {
        ffd_cage *c = make(DENT, (ffd_cage_coordinates)kind, 8, 0);
        CHECK(c != NULL);
        if (!c)
            continue;
        double pins[3 * 3] = {0.5, 0.5, 0.3, 0.2, 0.2, 0.2, 0.8, 0.3, 0.4};
        double targets[3 * 3] = {0.6, 0.5, 0.35, 0.2, 0.1, 0.2, 0.8, 0.3, 0.5};
        double current[9], delta[3 * 9], res[3], v[3 * 9];
        ffd_cage_binding *b = NULL;
        ffd_error err = {{0}};
        CHECK_OK(ffd_cage_bind(c, pins, 3, &b, &err));
        ffd_linear_map map;
        ffd_cage_linear_map(c, b, &map);
        size_t rows[3] = {0, 1, 2};
        ffd_manip_result r;
        CHECK_OK(ffd_cage_eval(c, b, current, &err));
        CHECK_OK(ffd_manip_solve(&map, rows, 3, current, targets, NULL, delta, res, &r, &err));
        for (int i = 0; i < 27; i++)
            v[i] = ffd_cage_vertices(c)[i] + delta[i];
        CHECK_OK(ffd_cage_set_vertices(c, v, &err));
        CHECK_OK(ffd_cage_eval(c, b, current, &err));
        for (int i = 0; i < 9; i++)
            CHECK_NEAR(current[i], targets[i], 1e-12);
        ffd_cage_binding_destroy(b);
        ffd_cage_destroy(c);
    }
}

/* ---- refused cages: each names the first bad face, edge or vertex ---- */

static void refused(const double *v, size_t nv, const uint32_t *t, size_t nt, ffd_status want,
                    const char *words)
{
    ffd_cage *c = NULL;
    ffd_error err = {{0}};
    ffd_status s = ffd_cage_create(v, nv, t, nt, NULL, NULL, &c, &err);
    CHECK(s == want);
    CHECK(c == NULL);
    if (!strstr(err.message, words))
        fprintf(stderr, "message: %s (expected \"%s\")\n", err.message, words);
    CHECK(strstr(err.message, words) != NULL);
}

static void test_refused(void)
{
    uint32_t t[3 * 16];
    /* open: the octahedron without its last face */
    refused(octa_v, 6, octa_t, 7, FFD_ERR_INVALID, "is on no other face: the cage is not closed");
    /* inconsistent: one face flipped */
    memcpy(t, octa_t, sizeof octa_t);
    t[1] = 0, t[0] = 2;
    refused(octa_v, 6, t, 8, FFD_ERR_INVALID, "faces 0 and 4 run it in the same direction");
    /* degenerate: a face with a repeated vertex */
    memcpy(t, octa_t, sizeof octa_t);
    t[5] = 2;
    refused(octa_v, 6, t, 8, FFD_ERR_INVALID, "face 1: degenerate triangle");
    /* out of range */
    memcpy(t, octa_t, sizeof octa_t);
    t[7] = 6;
    refused(octa_v, 6, t, 8, FFD_ERR_RANGE, "face 2: vertex index 6 out of range");
    /* an unused vertex */
    double v7[3 * 7];
    memcpy(v7, octa_v, sizeof octa_v);
    v7[18] = 5, v7[19] = 5, v7[20] = 5;
    refused(v7, 7, octa_t, 8, FFD_ERR_INVALID, "vertex 6 is on no face");
    /* two octahedra sharing vertex 0: not manifold at it */
    double v11[3 * 11];
    uint32_t t2[3 * 16];
    memcpy(v11, octa_v, sizeof octa_v);
    for (int i = 1; i < 6; i++)
        for (int a = 0; a < 3; a++)
            v11[3 * (5 + i) + a] = octa_v[3 * i + a] + (a == 0 ? 2 : 0);
    /* the second octahedron's vertex 1 (-1,0,0)+2 = (1,0,0) is vertex 0 */
    memcpy(t2, octa_t, sizeof octa_t);
    for (int i = 0; i < 24; i++) {
        uint32_t k = octa_t[i];
        t2[24 + i] = k == 1 ? 0 : k == 0 ? 6 : 5 + k;
    }
    refused(v11, 11, t2, 16, FFD_ERR_INVALID, "vertex 0: its 8 faces do not form one fan");
    /* an edge on four faces: the octahedron twice */
    memcpy(t2, octa_t, sizeof octa_t);
    memcpy(t2 + 24, octa_t, sizeof octa_t);
    refused(octa_v, 6, t2, 16, FFD_ERR_INVALID, "is on 4 faces");
    /* harmonic coordinates outside the cage */
    ffd_cage_options o = {FFD_CAGE_HARMONIC, 8, FFD_CAGE_OUTSIDE_EXTEND};
    ffd_cage *c = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_cage_create(octa_v, 6, octa_t, 8, NULL, &o, &c, &err) == FFD_ERR_INVALID);
    o.outside = 0, o.resolution = 1000;
    CHECK(ffd_cage_create(octa_v, 6, octa_t, 8, NULL, &o, &c, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "resolution 1000") != NULL);
}

/* An inward cage is turned outwards: the same coordinates. */
static void test_inward(void)
{
    uint32_t t[3 * 8];
    for (int f = 0; f < 8; f++)
        t[3 * f] = octa_t[3 * f], t[3 * f + 1] = octa_t[3 * f + 2], t[3 * f + 2] = octa_t[3 * f + 1];
    ffd_cage *a = make(OCTA, FFD_CAGE_MEAN_VALUE, 0, 0), *b = make(octa_v, 6, t, 8, 0, 0, 0);
    CHECK(a && b);
    if (a && b) {
        double p[3] = {0.1, 0.2, -0.3};
        ffd_cage_binding *x = NULL, *y = NULL;
        ffd_error err = {{0}};
        CHECK_OK(ffd_cage_bind(a, p, 1, &x, &err));
        CHECK_OK(ffd_cage_bind(b, p, 1, &y, &err));
        for (int j = 0; x && y && j < 6; j++)
            CHECK_NEAR(ffd_cage_binding_weights(x, 0)[j], ffd_cage_binding_weights(y, 0)[j],
                       1e-15);
        ffd_cage_binding_destroy(x);
        ffd_cage_binding_destroy(y);
    }
    ffd_cage_destroy(a);
    ffd_cage_destroy(b);
}

/* The ray-parity inside test (spatial.c) with its +z ray through a vertex
 * (the dent's centre, the column of grid nodes under it) and along an edge's
 * projection: one crossing, not none (every node of that column was
 * outside, and the harmonic coordinates wrong near it, before). */
static void test_inside_through_vertex(void)
{
    ffd_inside_index *ix = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_inside_index_create(dent_v, 9, dent_t, 14, &ix, &err));
    const double below[3] = {0.5, 0.5, 0.3}, above[3] = {0.5, 0.5, 0.7};
    const double edge[3] = {0.25, 0.25, 0.3}, side[3] = {0.75, 0.5, 0.2};
    CHECK(ffd_inside_index_test(ix, below) == 1);
    CHECK(ffd_inside_index_test(ix, above) == 0);
    CHECK(ffd_inside_index_test(ix, edge) == 1);
    CHECK(ffd_inside_index_test(ix, side) == 1);
    ffd_inside_index_destroy(ix);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"mvc_reproduction", test_mvc_reproduction},
        {"mvc_on_cage", test_mvc_on_cage},
        {"mvc_independent_formula", test_mvc_independent_formula},
        {"mvc_near_face", test_mvc_near_face},
        {"harmonic_properties", test_harmonic_properties},
        {"harmonic_on_cage", test_harmonic_on_cage},
        {"identity_and_fixed", test_identity_and_fixed},
        {"rigid_motion", test_rigid_motion},
        {"threads", test_threads},
        {"clamp", test_clamp},
        {"direct_manipulation", test_direct_manipulation},
        {"refused", test_refused},
        {"inward", test_inward},
        {"inside_through_vertex", test_inside_through_vertex},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
