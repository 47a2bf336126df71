/* Tests of PB-FFD automatic placement (McDonnell & Qin §3.2.1, §3.2.3): the
 * Voronoi wrapper against brute-force empty spheres, the k-d tree against
 * brute force, octree decimation, and ffd_pbffd_place on the meshes of data/
 * (exact counts, coverage by direct sphere tests, interior points inside by
 * ray-casting parity, open-surface fallback, error messages). */
#include "check.h"
#include "ffd.h"
#include "math/spatial.h"
#include "math/voronoi.h"
#include "pbffd/placement.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define SHARED FFD_DATA_DIR "/"

static ffd_mesh *read_shared(const char *name)
{
    char path[512];
    snprintf(path, sizeof path, SHARED "%s", name);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &m, &err) != FFD_OK) {
        fprintf(stderr, "read %s: %s\n", path, err.message);
        CHECK(!"cannot read a mesh of data/");
    }
    return m;
}

static double d2(const double *a, const double *b)
{
    double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return x * x + y * y + z * z;
}

/* ---- stdout/stderr capture: the library must never print ---- */

typedef struct capture {
    int saved_out, saved_err;
    FILE *file;
} capture;

static void capture_begin(capture *c)
{
    fflush(stdout);
    fflush(stderr);
    c->file = tmpfile();
    c->saved_out = dup(1);
    c->saved_err = dup(2);
    dup2(fileno(c->file), 1);
    dup2(fileno(c->file), 2);
}

/* Returns the number of bytes printed while capturing. */
static long capture_end(capture *c)
{
    fflush(stdout);
    fflush(stderr);
    dup2(c->saved_out, 1);
    dup2(c->saved_err, 2);
    close(c->saved_out);
    close(c->saved_err);
    fseek(c->file, 0, SEEK_END);
    long size = ftell(c->file);
    fclose(c->file);
    return size;
}

/* ---- Voronoi vertices against brute force ---- */

/* Circumcentre of tetrahedron (a, b, c, d) by Cramer's rule; 0 when flat. */
static int circumcentre(const double *a, const double *b, const double *c, const double *d,
                        double out[3])
{
    double u[3][3], rhs[3];
    const double *q[3] = {b, c, d};
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < 3; k++)
            u[i][k] = q[i][k] - a[k];
        rhs[i] = 0.5 * (u[i][0] * u[i][0] + u[i][1] * u[i][1] + u[i][2] * u[i][2]);
    }
    double det = u[0][0] * (u[1][1] * u[2][2] - u[1][2] * u[2][1]) -
                 u[0][1] * (u[1][0] * u[2][2] - u[1][2] * u[2][0]) +
                 u[0][2] * (u[1][0] * u[2][1] - u[1][1] * u[2][0]);
    if (fabs(det) < 1e-12)
        return 0;
    for (int k = 0; k < 3; k++) {
        double m[3][3];
        memcpy(m, u, sizeof m);
        for (int i = 0; i < 3; i++)
            m[i][k] = rhs[i];
        double dk = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                    m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                    m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        out[k] = a[k] + dk / det;
    }
    return 1;
}

/* Every empty-circumsphere tetrahedron of the points (general position)
 * gives one Voronoi vertex; each one Qhull returns must be one of them. */
static void check_against_brute_force(const double *p, size_t n)
{
    double *v = NULL;
    size_t count = 0;
    ffd_error err = {{0}};
    CHECK_OK(ffd_voronoi_vertices(p, n, 0, &v, &count, &err));
    size_t brute = 0;
    int *matched = calloc(count ? count : 1, sizeof *matched);
    for (size_t a = 0; a < n; a++)
        for (size_t b = a + 1; b < n; b++)
            for (size_t c = b + 1; c < n; c++)
                for (size_t d = c + 1; d < n; d++) {
                    double o[3];
                    if (!circumcentre(p + 3 * a, p + 3 * b, p + 3 * c, p + 3 * d, o))
                        continue;
                    double r2 = d2(o, p + 3 * a);
                    int empty = 1;
                    for (size_t e = 0; e < n && empty; e++)
                        if (e != a && e != b && e != c && e != d && d2(o, p + 3 * e) < r2)
                            empty = 0;
                    if (!empty)
                        continue;
                    brute++;
                    size_t best = SIZE_MAX;
                    double bd = INFINITY;
                    for (size_t k = 0; k < count; k++)
                        if (d2(o, v + 3 * k) < bd) {
                            bd = d2(o, v + 3 * k);
                            best = k;
                        }
                    CHECK(best != SIZE_MAX && sqrt(bd) <= 1e-9 * (1 + sqrt(r2)));
                    if (best != SIZE_MAX)
                        matched[best]++;
                }
    CHECK(brute == count);
    for (size_t k = 0; k < count; k++)
        CHECK(matched[k] == 1);
    /* and each one is equidistant from its four nearest sites, none closer */
    for (size_t k = 0; k < count; k++) {
        double best[4] = {INFINITY, INFINITY, INFINITY, INFINITY};
        for (size_t i = 0; i < n; i++) {
            double d = sqrt(d2(v + 3 * k, p + 3 * i));
            for (int s = 0; s < 4; s++)
                if (d < best[s]) {
                    for (int t = 3; t > s; t--)
                        best[t] = best[t - 1];
                    best[s] = d;
                    break;
                }
        }
        CHECK_NEAR(best[0], best[3], 1e-9 * (1 + best[3]));
    }
    free(matched);
    ffd_free(v);
}

static void test_voronoi_brute_force(void)
{
    /* random points, and jittered cube corners plus the centre */
    for (int trial = 0; trial < 4; trial++) {
        double p[3 * 14];
        for (int i = 0; i < 3 * 14; i++)
            p[i] = 10 * check_rand01() - 5;
        check_against_brute_force(p, 14);
    }
    double cube[3 * 9];
    for (int i = 0; i < 8; i++)
        for (int a = 0; a < 3; a++)
            cube[3 * i + a] = ((i >> a) & 1 ? 1.0 : -1.0) + 0.05 * (check_rand01() - 0.5);
    cube[24] = 0.01;
    cube[25] = -0.02;
    cube[26] = 0.015;
    check_against_brute_force(cube, 9);
    check_against_brute_force(cube, 8);
}

static void test_voronoi_regular_cases(void)
{
    /* a regular tetrahedron and a far point: the Voronoi vertex of the
     * tetrahedron's own cell is its circumcentre, the origin */
    double s = 1 / sqrt(3.0);
    double p[] = {s, s, s, s, -s, -s, -s, s, -s, -s, -s, s, 0.3, 0.2, 40};
    double *v = NULL;
    size_t count = 0;
    CHECK_OK(ffd_voronoi_vertices(p, 5, 0, &v, &count, NULL));
    int found = 0;
    for (size_t k = 0; k < count; k++)
        if (sqrt(d2(v + 3 * k, (double[3]){0, 0, 0})) < 1e-12)
            found = 1;
    CHECK(found);
    ffd_free(v);

    /* exact cube corners are cospherical: every Voronoi vertex is the centre */
    double cube[24];
    for (int i = 0; i < 8; i++)
        for (int a = 0; a < 3; a++)
            cube[3 * i + a] = (i >> a) & 1 ? 3.0 : 1.0;
    capture cap;
    capture_begin(&cap);
    ffd_status st = ffd_voronoi_vertices(cube, 8, 0, &v, &count, NULL);
    long printed = capture_end(&cap);
    CHECK(printed == 0);
    CHECK(st == FFD_OK);
    CHECK(count >= 1);
    for (size_t k = 0; k < count; k++)
        CHECK(sqrt(d2(v + 3 * k, (double[3]){2, 2, 2})) < 1e-9);
    ffd_free(v);
}

static void test_voronoi_degenerate(void)
{
    capture cap;
    capture_begin(&cap);
    /* coplanar sites */
    double plane[3 * 30];
    for (int i = 0; i < 30; i++) {
        plane[3 * i] = check_rand01();
        plane[3 * i + 1] = check_rand01();
        plane[3 * i + 2] = 0.5 * plane[3 * i] - 0.25 * plane[3 * i + 1];
    }
    double *v = (double *)1;
    size_t count = 7;
    ffd_error e1 = {{0}}, e2 = {{0}}, e3 = {{0}}, e4 = {{0}};
    ffd_status s1 = ffd_voronoi_vertices(plane, 30, 0, &v, &count, &e1);
    double *v1 = v;
    size_t c1 = count;
    /* too few sites */
    ffd_status s2 = ffd_voronoi_vertices(plane, 4, 0, &v, &count, &e2);
    /* collinear */
    double line[3 * 10];
    for (int i = 0; i < 10; i++)
        line[3 * i] = line[3 * i + 1] = line[3 * i + 2] = i;
    ffd_status s3 = ffd_voronoi_vertices(line, 10, 0, &v, &count, &e3);
    /* non-finite */
    double bad[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, NAN, 1, 1};
    ffd_status s4 = ffd_voronoi_vertices(bad, 5, 0, &v, &count, &e4);
    long printed = capture_end(&cap);
    CHECK(printed == 0);
    CHECK(s1 == FFD_ERR_NUMERIC);
    CHECK(v1 == NULL && c1 == 0);
    CHECK(strstr(e1.message, "Qhull") != NULL);
    CHECK(strchr(e1.message, '\n') == NULL);
    CHECK(s2 == FFD_ERR_INVALID);
    CHECK(s3 == FFD_ERR_NUMERIC || s3 == FFD_ERR_INVALID);
    CHECK(s4 == FFD_ERR_NONFINITE);
    CHECK(v == NULL && count == 0);
    printf("     coplanar: %s\n", e1.message);
}

/* ---- k-d tree against brute force ---- */

static void test_kdtree_brute_force(void)
{
    size_t n = 3000;
    double *p = malloc(3 * n * sizeof *p);
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) /* a coarse grid: many ties and duplicates */
            p[3 * i + a] = i % 7 == 0 ? floor(8 * check_rand01()) : check_rand01() * 8;
    ffd_kdtree *t = NULL;
    CHECK_OK(ffd_kdtree_create(p, n, &t, NULL));
    CHECK(ffd_kdtree_count(t) == n);
    for (int trial = 0; trial < 400; trial++) {
        double q[3];
        if (trial % 3 == 0)
            memcpy(q, p + 3 * (size_t)(check_rand01() * (double)n), sizeof q);
        else
            for (int a = 0; a < 3; a++)
                q[a] = trial % 3 == 1 ? floor(9 * check_rand01()) : 10 * check_rand01() - 1;
        size_t best = SIZE_MAX, bestd = SIZE_MAX;
        double bd = INFINITY, bdd = INFINITY;
        for (size_t i = 0; i < n; i++) {
            double d = d2(q, p + 3 * i);
            if (d < bd) {
                bd = d;
                best = i;
            }
            if (d > 0 && d < bdd) {
                bdd = d;
                bestd = i;
            }
        }
        double got = -1;
        CHECK(ffd_kdtree_nearest(t, q, &got) == best);
        CHECK(got == bd);
        CHECK(ffd_kdtree_nearest_distinct(t, q, &got) == bestd);
        CHECK(got == bdd);
        size_t idx[5];
        double dd[5];
        CHECK(ffd_kdtree_k_nearest(t, q, 5, idx, dd) == 5);
        CHECK(idx[0] == best);
        for (int k = 1; k < 5; k++) {
            CHECK(dd[k] >= dd[k - 1]);
            CHECK(dd[k] > dd[k - 1] || idx[k] > idx[k - 1]);
            /* nothing outside the list is closer than its last entry */
            size_t closer = 0;
            for (size_t i = 0; i < n; i++)
                closer += d2(q, p + 3 * i) < dd[k];
            CHECK(closer <= (size_t)k);
        }
    }
    ffd_kdtree_destroy(t);
    /* empty and tiny trees */
    CHECK_OK(ffd_kdtree_create(NULL, 0, &t, NULL));
    CHECK(ffd_kdtree_nearest(t, (double[3]){0, 0, 0}, NULL) == SIZE_MAX);
    ffd_kdtree_destroy(t);
    CHECK_OK(ffd_kdtree_create(p, 1, &t, NULL));
    CHECK(ffd_kdtree_nearest_distinct(t, p, NULL) == SIZE_MAX);
    size_t idx[3];
    CHECK(ffd_kdtree_k_nearest(t, p, 3, idx, NULL) == 1);
    ffd_kdtree_destroy(t);
    free(p);
}

/* ---- octree decimation ---- */

static void test_decimate_counts_deterministic(void)
{
    size_t n = 6000;
    double *p = malloc(3 * n * sizeof *p);
    for (size_t i = 0; i < n; i++) {
        /* a dense ball and a sparse shell, plus exact duplicates */
        double r = i % 3 ? 0.2 * check_rand01() : 1 + check_rand01();
        double u = 2 * check_rand01() - 1, ph = 6.283185307179586 * check_rand01();
        double s = sqrt(1 - u * u);
        p[3 * i] = r * s * cos(ph);
        p[3 * i + 1] = r * s * sin(ph);
        p[3 * i + 2] = r * u;
        if (i % 50 == 1)
            memcpy(p + 3 * i, p + 3 * (i - 1), 3 * sizeof *p);
    }
    const size_t targets[] = {1, 2, 7, 50, 500, 3000, 5999, 6000};
    for (size_t t = 0; t < sizeof targets / sizeof *targets; t++) {
        size_t k = targets[t];
        double *a = malloc(3 * k * sizeof *a), *b = malloc(3 * k * sizeof *b);
        CHECK_OK(ffd_decimate_points(p, n, k, a, NULL));
        CHECK_OK(ffd_decimate_points(p, n, k, b, NULL));
        CHECK(memcmp(a, b, 3 * k * sizeof *a) == 0);
        for (size_t i = 0; i < 3 * k; i++)
            CHECK(isfinite(a[i]) && fabs(a[i]) <= 2.0);
        free(a);
        free(b);
    }
    double one[3];
    ffd_error err = {{0}};
    CHECK(ffd_decimate_points(p, n, 0, one, &err) == FFD_ERR_INVALID);
    CHECK(ffd_decimate_points(p, 3, 4, one, &err) == FFD_ERR_INVALID);
    free(p);
}

static void test_decimate_clusters(void)
{
    /* 12 tight, well separated clusters of different sizes: decimating to 12
     * leaves one point per cluster, inside the cluster */
    size_t n = 0, sizes[12];
    for (int c = 0; c < 12; c++)
        n += sizes[c] = 20 + 150 * (size_t)c;
    double *p = malloc(3 * n * sizeof *p), centre[12][3];
    size_t at = 0;
    for (int c = 0; c < 12; c++) {
        for (int a = 0; a < 3; a++)
            centre[c][a] = 10.0 * (double)((c >> a) & 1) + 20.0 * (a == 0) * (double)(c >> 3);
        for (size_t i = 0; i < sizes[c]; i++, at++)
            for (int a = 0; a < 3; a++)
                p[3 * at + a] = centre[c][a] + 0.3 * (check_rand01() - 0.5);
    }
    double out[3 * 12];
    CHECK_OK(ffd_decimate_points(p, n, 12, out, NULL));
    int hit[12] = {0};
    for (int k = 0; k < 12; k++)
        for (int c = 0; c < 12; c++)
            if (sqrt(d2(out + 3 * k, centre[c])) < 0.3)
                hit[c]++;
    for (int c = 0; c < 12; c++)
        CHECK(hit[c] == 1);
    free(p);
}

/* ---- placement on meshes ---- */

/* Ray-casting parity of x against the mesh's faces (fanned), voted over three
 * fixed, generic directions. */
static int ray_hits(const ffd_mesh *m, const double *x, const double dir[3])
{
    const double *P = ffd_mesh_positions(m);
    const uint32_t *off = ffd_mesh_face_offsets(m), *idx = ffd_mesh_face_indices(m);
    int hits = 0;
    for (size_t f = 0; f < ffd_mesh_face_count(m); f++)
        for (uint32_t k = off[f] + 1; k + 1 < off[f + 1]; k++) {
            const double *a = P + 3 * idx[off[f]], *b = P + 3 * idx[k], *c = P + 3 * idx[k + 1];
            double e1[3], e2[3], s[3], h[3], q[3];
            for (int i = 0; i < 3; i++) {
                e1[i] = b[i] - a[i];
                e2[i] = c[i] - a[i];
                s[i] = x[i] - a[i];
            }
            h[0] = dir[1] * e2[2] - dir[2] * e2[1];
            h[1] = dir[2] * e2[0] - dir[0] * e2[2];
            h[2] = dir[0] * e2[1] - dir[1] * e2[0];
            double det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
            if (det == 0)
                continue;
            double u = (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]) / det;
            if (u < 0 || u > 1)
                continue;
            q[0] = s[1] * e1[2] - s[2] * e1[1];
            q[1] = s[2] * e1[0] - s[0] * e1[2];
            q[2] = s[0] * e1[1] - s[1] * e1[0];
            double v = (dir[0] * q[0] + dir[1] * q[1] + dir[2] * q[2]) / det;
            if (v < 0 || u + v > 1)
                continue;
            double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
            if (t > 0)
                hits++;
        }
    return hits;
}

static int inside_mesh(const ffd_mesh *m, const double *x)
{
    static const double dirs[3][3] = {
        {0.5773, 0.5812, 0.5735}, {-0.2673, 0.8018, -0.5345}, {0.8729, -0.2182, -0.4364}};
    int votes = 0;
    for (int d = 0; d < 3; d++)
        votes += ray_hits(m, x, dirs[d]) & 1;
    return votes >= 2;
}

/* Checks what every placement must satisfy and returns the number of
 * vertices under fewer than two ROIs. */
static size_t check_controls(const ffd_mesh *m, const ffd_ebf *c, size_t count)
{
    for (size_t j = 0; j < count; j++) {
        CHECK(!c[j].disabled);
        for (int a = 0; a < 3; a++) {
            CHECK(isfinite(c[j].center[a]));
            CHECK(c[j].radius[a] > 0 && isfinite(c[j].radius[a]));
            CHECK(c[j].radius[a] == c[j].radius[0]);
            for (int b = 0; b < 3; b++)
                CHECK(c[j].frame[a][b] == (a == b ? c[j].radius[0] : 0.0));
        }
    }
    const double *x = ffd_mesh_positions(m);
    size_t under = 0;
    for (size_t i = 0; i < ffd_mesh_vertex_count(m); i++) {
        size_t s = 0;
        for (size_t j = 0; j < count; j++)
            s += d2(x + 3 * i, c[j].center) < c[j].radius[0] * c[j].radius[0];
        under += s < 2;
    }
    return under;
}

static void place_closed(const char *name, size_t interior, size_t exterior)
{
    ffd_mesh *m = read_shared(name);
    if (!m)
        return;
    ffd_placement_options o = {0};
    o.interior_count = interior;
    o.exterior_count = exterior;
    ffd_ebf *c = NULL;
    size_t count = 0;
    ffd_placement_report rep;
    ffd_error err = {{0}};
    capture cap;
    capture_begin(&cap);
    ffd_status st = ffd_pbffd_place(m, &o, &c, &count, &rep, &err);
    long printed = capture_end(&cap);
    CHECK(printed == 0);
    CHECK(st == FFD_OK);
    if (st != FFD_OK) {
        fprintf(stderr, "%s: %s\n", name, err.message);
        ffd_mesh_destroy(m);
        return;
    }
    CHECK(count == interior + exterior);
    CHECK(rep.interior_count == interior && rep.exterior_count == exterior);
    CHECK(!rep.open && !rep.fell_back && rep.note[0] == '\0');
    CHECK(rep.voronoi_sites == (ffd_mesh_vertex_count(m) < 8000 ? ffd_mesh_vertex_count(m) : 8000));
    CHECK(rep.voronoi_vertices > rep.inside_vertices && rep.inside_vertices >= interior);
    CHECK(rep.seconds_total >= rep.seconds_voronoi && rep.seconds_voronoi > 0);
    CHECK(check_controls(m, c, count) == 0);
    /* every interior point of the small meshes, a sample of 25 on big ones */
    size_t outside = 0, step = ffd_mesh_face_count(m) > 20000 ? (interior + 24) / 25 : 1;
    for (size_t j = 0; j < interior; j += step)
        outside += !inside_mesh(m, c[j].center);
    CHECK(outside == 0);
    printf("     %s: %zu Voronoi vertices, %zu inside, %zu radii grown, %.3f s (Qhull %.3f s), "
           "%zu interior points outside\n",
           name, rep.voronoi_vertices, rep.inside_vertices, rep.grown_radii, rep.seconds_total,
           rep.seconds_voronoi, outside);
    ffd_free(c);
    ffd_mesh_destroy(m);
}

static void test_place_cow(void)
{
    place_closed("cow.off", 100, 100);
    place_closed("cow.off", 60, 60);
}

static void test_place_elephant(void)
{
    place_closed("elephant.off", 50, 80);
}

static void test_place_refined_elephant(void)
{
    place_closed("refined_elephant.off", 100, 100);
}

static void test_place_defaults_and_no_cover(void)
{
    ffd_mesh *m = read_shared("cow.off");
    if (!m)
        return;
    ffd_ebf *c = NULL;
    size_t count = 0;
    CHECK_OK(ffd_pbffd_place(m, NULL, &c, &count, NULL, NULL));
    CHECK(count == 120);
    CHECK(check_controls(m, c, count) == 0);
    ffd_free(c);
    ffd_placement_options o = {0};
    o.no_cover = 1;
    ffd_placement_report rep;
    CHECK_OK(ffd_pbffd_place(m, &o, &c, &count, &rep, NULL));
    CHECK(count == 120 && rep.grown_radii == 0);
    /* radius = 1.5 x distance to the nearest other control */
    for (size_t j = 0; j < count; j++) {
        double best = INFINITY;
        for (size_t k = 0; k < count; k++)
            if (k != j)
                best = fmin(best, sqrt(d2(c[j].center, c[k].center)));
        CHECK_NEAR(c[j].radius[0], 1.5 * best, 1e-12 * best);
    }
    ffd_free(c);
    ffd_mesh_destroy(m);
}

static void test_place_deterministic_threads(void)
{
    ffd_mesh *m = read_shared("elephant.off");
    if (!m)
        return;
    ffd_placement_options o = {0};
    o.interior_count = 70;
    o.exterior_count = 90;
    ffd_ebf *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    CHECK_OK(ffd_pbffd_place(m, &o, &a, &na, NULL, NULL));
    omp_set_num_threads(threads > 1 ? threads : 3);
    CHECK_OK(ffd_pbffd_place(m, &o, &b, &nb, NULL, NULL));
    omp_set_num_threads(threads);
    CHECK(na == nb && na == 160);
    CHECK(a && b && memcmp(a, b, na * sizeof *a) == 0);
    ffd_free(a);
    ffd_free(b);
    ffd_mesh_destroy(m);
}

/* The cow with every face reversed (first corner kept, so every fan
 * triangle's cross product is exactly negated): the signed volume is
 * negative, the normals are flipped back, and the result is the same. */
static void test_place_inside_out(void)
{
    ffd_mesh *m = read_shared("cow.off");
    if (!m)
        return;
    size_t nf = ffd_mesh_face_count(m);
    const uint32_t *off = ffd_mesh_face_offsets(m), *idx = ffd_mesh_face_indices(m);
    uint32_t *rev = malloc(off[nf] * sizeof *rev);
    for (size_t f = 0; f < nf; f++)
        for (uint32_t k = off[f]; k < off[f + 1]; k++)
            rev[k] = k == off[f] ? idx[k] : idx[off[f + 1] - (k - off[f])];
    ffd_mesh *r = NULL;
    CHECK_OK(ffd_mesh_create(ffd_mesh_positions(m), ffd_mesh_vertex_count(m), off, rev, nf, &r,
                             NULL));
    ffd_placement_options o = {0};
    o.interior_count = 80;
    o.exterior_count = 80;
    ffd_ebf *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    CHECK_OK(ffd_pbffd_place(m, &o, &a, &na, NULL, NULL));
    CHECK_OK(ffd_pbffd_place(r, &o, &b, &nb, NULL, NULL));
    CHECK(na == 160 && nb == 160);
    for (size_t j = 0; j < 80 && b; j++)
        CHECK(inside_mesh(m, b[j].center));
    /* the same points: reversing the winding only flips the normals */
    CHECK(a && b && memcmp(a, b, na * sizeof *a) == 0);
    ffd_free(a);
    ffd_free(b);
    free(rev);
    ffd_mesh_destroy(r);
    ffd_mesh_destroy(m);
}

static void test_place_open_teapot(void)
{
    ffd_mesh *m = read_shared("teapot.obj");
    if (!m)
        return;
    ffd_placement_options o = {0};
    o.interior_count = 40; /* ignored */
    o.exterior_count = 90;
    ffd_ebf *c = NULL;
    size_t count = 0;
    ffd_placement_report rep;
    CHECK_OK(ffd_pbffd_place(m, &o, &c, &count, &rep, NULL));
    CHECK(count == 90);
    CHECK(rep.open == 1 && rep.fell_back == 1);
    CHECK(rep.interior_count == 0 && rep.exterior_count == 90);
    CHECK(rep.voronoi_sites == 0 && rep.voronoi_vertices == 0);
    CHECK(strstr(rep.note, "boundary") != NULL && strstr(rep.note, "without interior points") != NULL);
    CHECK(check_controls(m, c, count) == 0);
    printf("     teapot: %s\n", rep.note);
    ffd_free(c);

    /* CLOSED on an open mesh falls back */
    o.surface = FFD_SURFACE_CLOSED;
    CHECK_OK(ffd_pbffd_place(m, &o, &c, &count, &rep, NULL));
    CHECK(count == 90 && rep.open && rep.fell_back);
    CHECK(strstr(rep.note, "a closed surface was asked for") != NULL);
    ffd_free(c);

    /* OPEN asked: no fallback, still a note */
    o.surface = FFD_SURFACE_OPEN;
    CHECK_OK(ffd_pbffd_place(m, &o, &c, &count, &rep, NULL));
    CHECK(count == 90 && rep.open && !rep.fell_back && rep.note[0] != '\0');
    ffd_free(c);
    ffd_mesh_destroy(m);

    /* OPEN on a closed mesh: points on both sides of the surface */
    m = read_shared("cow.off");
    if (!m)
        return;
    o.exterior_count = 150;
    CHECK_OK(ffd_pbffd_place(m, &o, &c, &count, &rep, NULL));
    CHECK(count == 150 && rep.open && !rep.fell_back && rep.interior_count == 0);
    size_t in = 0;
    for (size_t j = 0; j < count; j++)
        in += inside_mesh(m, c[j].center);
    CHECK(in > 20 && in < 130);
    CHECK(check_controls(m, c, count) == 0);
    ffd_free(c);
    ffd_mesh_destroy(m);
}

static void test_place_errors(void)
{
    ffd_mesh *m = read_shared("cow.off");
    if (!m)
        return;
    ffd_ebf *c = (ffd_ebf *)1;
    size_t count = 5;
    ffd_error err = {{0}};
    ffd_placement_options o = {0};
    ffd_placement_report rep;
    o.interior_count = 5000000;
    CHECK(ffd_pbffd_place(m, &o, &c, &count, &rep, &err) == FFD_ERR_INVALID);
    CHECK(c == NULL && count == 0);
    char expect[128];
    snprintf(expect, sizeof expect, "5000000 interior points asked for: only %zu Voronoi vertices",
             rep.inside_vertices);
    CHECK(rep.inside_vertices > 0 && strstr(err.message, expect) != NULL);
    printf("     %s\n", err.message);

    o.interior_count = 0;
    o.exterior_count = 2905;
    CHECK(ffd_pbffd_place(m, &o, &c, &count, NULL, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "2905 exterior points asked for: only 2904") != NULL);
    printf("     %s\n", err.message);

    o.exterior_count = 0;
    o.offset = -1;
    CHECK(ffd_pbffd_place(m, &o, &c, &count, NULL, &err) == FFD_ERR_INVALID);
    o.offset = 0;
    o.radius_factor = NAN;
    CHECK(ffd_pbffd_place(m, &o, &c, &count, NULL, &err) == FFD_ERR_INVALID);
    o.radius_factor = 0;
    o.voronoi_sites = 3;
    CHECK(ffd_pbffd_place(m, &o, &c, &count, NULL, &err) == FFD_ERR_INVALID);
    CHECK(ffd_pbffd_place(NULL, NULL, &c, &count, NULL, &err) == FFD_ERR_INVALID);
    ffd_mesh_destroy(m);

    /* no faces */
    double pts[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    uint32_t zero = 0;
    ffd_mesh *cloud = NULL;
    CHECK_OK(ffd_mesh_create(pts, 5, &zero, NULL, 0, &cloud, NULL));
    CHECK(ffd_pbffd_place(cloud, NULL, &c, &count, NULL, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "no faces") != NULL);
    ffd_mesh_destroy(cloud);

    /* a flat closed mesh (a hexagon, both sides): nothing has an inside */
    double hex[3 * 7] = {0, 0, 0};
    for (int i = 0; i < 6; i++) {
        hex[3 + 3 * i] = cos(i * 1.0471975511965976);
        hex[4 + 3 * i] = sin(i * 1.0471975511965976);
    }
    uint32_t offs[13], idx[36];
    for (uint32_t f = 0; f < 6; f++) {
        uint32_t a = 1 + f, b = 1 + (f + 1) % 6;
        idx[3 * f] = 0, idx[3 * f + 1] = a, idx[3 * f + 2] = b;
        idx[18 + 3 * f] = 0, idx[18 + 3 * f + 1] = b, idx[18 + 3 * f + 2] = a;
    }
    for (uint32_t f = 0; f <= 12; f++)
        offs[f] = 3 * f;
    ffd_mesh *flat = NULL;
    CHECK_OK(ffd_mesh_create(hex, 7, offs, idx, 12, &flat, NULL));
    capture cap;
    capture_begin(&cap);
    ffd_status st = ffd_pbffd_place(flat, NULL, &c, &count, NULL, &err);
    long printed = capture_end(&cap);
    CHECK(printed == 0);
    CHECK(st == FFD_ERR_INVALID || st == FFD_ERR_NUMERIC);
    CHECK(c == NULL && count == 0);
    printf("     flat: %s\n", err.message);
    /* the same hexagon, one side only, is open: offsets both ways work */
    ffd_mesh *disk = NULL;
    CHECK_OK(ffd_mesh_create(hex, 7, offs, idx, 6, &disk, NULL));
    ffd_placement_options so = {0};
    so.exterior_count = 10;
    CHECK_OK(ffd_pbffd_place(disk, &so, &c, &count, NULL, NULL));
    CHECK(count == 10);
    CHECK(check_controls(disk, c, count) == 0);
    ffd_free(c);
    ffd_mesh_destroy(disk);
    ffd_mesh_destroy(flat);
}

/* ---- generated closed meshes ---- */

typedef struct shape_builder {
    double *x;
    size_t n, cap;
    uint32_t *idx, *off;
    size_t ni, nf, icap, fcap;
} shape_builder;

static uint32_t sb_vertex(shape_builder *b, double x, double y, double z)
{
    if (b->n == b->cap) {
        b->cap = b->cap ? 2 * b->cap : 64;
        b->x = realloc(b->x, 3 * b->cap * sizeof *b->x);
    }
    b->x[3 * b->n] = x;
    b->x[3 * b->n + 1] = y;
    b->x[3 * b->n + 2] = z;
    return (uint32_t)b->n++;
}

static void sb_face(shape_builder *b, int k, uint32_t v0, uint32_t v1, uint32_t v2, uint32_t v3)
{
    if (b->ni + 4 > b->icap) {
        b->icap = b->icap ? 2 * b->icap : 256;
        b->idx = realloc(b->idx, b->icap * sizeof *b->idx);
    }
    if (b->nf + 2 > b->fcap) {
        b->fcap = b->fcap ? 2 * b->fcap : 64;
        b->off = realloc(b->off, b->fcap * sizeof *b->off);
    }
    if (b->nf == 0)
        b->off[0] = 0;
    b->idx[b->ni++] = v0;
    b->idx[b->ni++] = v1;
    b->idx[b->ni++] = v2;
    if (k == 4)
        b->idx[b->ni++] = v3;
    b->off[++b->nf] = (uint32_t)b->ni;
}

static ffd_mesh *sb_finish(shape_builder *b)
{
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_create(b->x, b->n, b->off, b->idx, b->nf, &m, &err) != FFD_OK)
        fprintf(stderr, "shape: %s\n", err.message);
    free(b->x);
    free(b->idx);
    free(b->off);
    return m;
}

/* UV sphere of radius r about c: poles on z, rings of segs vertices. */
static ffd_mesh *make_uv_sphere(int segs, int rings, double r, const double c[3])
{
    shape_builder b = {0};
    const double pi = 3.14159265358979323846;
    uint32_t north = sb_vertex(&b, c[0], c[1], c[2] + r);
    for (int i = 1; i < rings; i++) {
        double th = pi * i / rings;
        for (int j = 0; j < segs; j++) {
            double ph = 2 * pi * j / segs;
            sb_vertex(&b, c[0] + r * sin(th) * cos(ph), c[1] + r * sin(th) * sin(ph),
                      c[2] + r * cos(th));
        }
    }
    uint32_t south = sb_vertex(&b, c[0], c[1], c[2] - r);
#define RV(i, j) (1 + (uint32_t)((i) - 1) * segs + (uint32_t)((j) % segs))
    for (int j = 0; j < segs; j++)
        sb_face(&b, 3, north, RV(1, j), RV(1, j + 1), 0);
    for (int i = 1; i + 1 < rings; i++)
        for (int j = 0; j < segs; j++)
            sb_face(&b, 4, RV(i, j), RV(i + 1, j), RV(i + 1, j + 1), RV(i, j + 1));
    for (int j = 0; j < segs; j++)
        sb_face(&b, 3, south, RV(rings - 1, j + 1), RV(rings - 1, j), 0);
#undef RV
    return sb_finish(&b);
}

/* Icosphere: the icosahedron subdivided sub times, projected on the sphere. */
static ffd_mesh *make_icosphere(int sub, double r, const double c[3])
{
    const double t = (1 + sqrt(5.0)) / 2;
    double v[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                       {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    static const uint32_t f0[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    size_t nv = 12, nf = 20;
    double *x = malloc(3 * nv * sizeof *x);
    uint32_t *f = malloc(3 * nf * sizeof *f);
    for (int i = 0; i < 12; i++) {
        double l = sqrt(v[i][0] * v[i][0] + v[i][1] * v[i][1] + v[i][2] * v[i][2]);
        for (int a = 0; a < 3; a++)
            x[3 * i + a] = v[i][a] / l;
    }
    memcpy(f, f0, sizeof f0);
    for (int s = 0; s < sub; s++) {
        size_t nfn = 4 * nf, ne = 0;
        uint32_t *g = malloc(3 * nfn * sizeof *g);
        uint32_t(*edge)[3] = malloc(3 * nf * sizeof *edge); /* a < b, midpoint */
        x = realloc(x, 3 * (nv + 3 * nf) * sizeof *x);
        for (size_t k = 0; k < nf; k++) {
            uint32_t m[3];
            for (int e = 0; e < 3; e++) {
                uint32_t a = f[3 * k + e], b = f[3 * k + (e + 1) % 3];
                if (a > b) {
                    uint32_t tmp = a;
                    a = b;
                    b = tmp;
                }
                size_t q = 0;
                while (q < ne && !(edge[q][0] == a && edge[q][1] == b))
                    q++;
                if (q == ne) {
                    double p[3], l = 0;
                    for (int d = 0; d < 3; d++) {
                        p[d] = x[3 * a + d] + x[3 * b + d];
                        l += p[d] * p[d];
                    }
                    l = sqrt(l);
                    for (int d = 0; d < 3; d++)
                        x[3 * nv + d] = p[d] / l;
                    edge[ne][0] = a;
                    edge[ne][1] = b;
                    edge[ne][2] = (uint32_t)nv++;
                    ne++;
                }
                m[e] = edge[q][2];
            }
            uint32_t a = f[3 * k], b = f[3 * k + 1], cc = f[3 * k + 2];
            uint32_t tri[4][3] = {{a, m[0], m[2]}, {b, m[1], m[0]}, {cc, m[2], m[1]}, {m[0], m[1], m[2]}};
            memcpy(g + 12 * k, tri, sizeof tri);
        }
        free(edge);
        free(f);
        f = g;
        nf = nfn;
    }
    uint32_t *off = malloc((nf + 1) * sizeof *off);
    for (size_t k = 0; k <= nf; k++)
        off[k] = (uint32_t)(3 * k);
    for (size_t i = 0; i < nv; i++)
        for (int a = 0; a < 3; a++)
            x[3 * i + a] = c[a] + r * x[3 * i + a];
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_create(x, nv, off, f, nf, &mesh, &err) != FFD_OK)
        fprintf(stderr, "icosphere: %s\n", err.message);
    free(x);
    free(f);
    free(off);
    return mesh;
}

/* Closed cylinder about the z axis: radius r, z in [0, h], segs around,
 * rows bands along z, each cap a centre vertex and caprings concentric rings
 * (the outermost is the side's end ring). */
static ffd_mesh *make_cylinder(int segs, int rows, int caprings, double r, double h)
{
    shape_builder b = {0};
    const double pi = 3.14159265358979323846;
    for (int i = 0; i <= rows; i++)
        for (int j = 0; j < segs; j++)
            sb_vertex(&b, r * cos(2 * pi * j / segs), r * sin(2 * pi * j / segs), h * i / rows);
#define SV(i, j) ((uint32_t)(i) * segs + (uint32_t)((j) % segs))
    for (int i = 0; i < rows; i++)
        for (int j = 0; j < segs; j++)
            sb_face(&b, 4, SV(i, j), SV(i, j + 1), SV(i + 1, j + 1), SV(i + 1, j));
    for (int top = 0; top < 2; top++) {
        double z = top ? h : 0;
        uint32_t centre = sb_vertex(&b, 0, 0, z);
        uint32_t first = (uint32_t)b.n; /* inner rings 1 .. caprings-1 */
        for (int k = 1; k < caprings; k++)
            for (int j = 0; j < segs; j++)
                sb_vertex(&b, r * k / caprings * cos(2 * pi * j / segs),
                          r * k / caprings * sin(2 * pi * j / segs), z);
#define CV(k, j) ((k) == caprings ? SV(top ? rows : 0, j) : first + (uint32_t)((k) - 1) * segs + (uint32_t)((j) % segs))
        for (int j = 0; j < segs; j++) {
            if (top)
                sb_face(&b, 3, centre, CV(1, j), CV(1, j + 1), 0);
            else
                sb_face(&b, 3, centre, CV(1, j + 1), CV(1, j), 0);
        }
        for (int k = 1; k < caprings; k++)
            for (int j = 0; j < segs; j++) {
                if (top)
                    sb_face(&b, 4, CV(k, j), CV(k + 1, j), CV(k + 1, j + 1), CV(k, j + 1));
                else
                    sb_face(&b, 4, CV(k, j + 1), CV(k + 1, j + 1), CV(k + 1, j), CV(k, j));
            }
#undef CV
    }
#undef SV
    return sb_finish(&b);
}

/* The cube [0, s]^3 with each face an n by n grid of quads. */
static ffd_mesh *make_box(int n, double s)
{
    shape_builder b = {0};
    size_t N = (size_t)n + 1;
    uint32_t *id = malloc(N * N * N * sizeof *id);
    for (size_t i = 0; i < N; i++)
        for (size_t j = 0; j < N; j++)
            for (size_t k = 0; k < N; k++) {
                int surf = i == 0 || j == 0 || k == 0 || i == N - 1 || j == N - 1 || k == N - 1;
                id[(i * N + j) * N + k] =
                    surf ? sb_vertex(&b, s * i / n, s * j / n, s * k / n) : UINT32_MAX;
            }
    for (int a = 0; a < 3; a++)
        for (int side = 0; side < 2; side++)
            for (int p = 0; p < n; p++)
                for (int q = 0; q < n; q++) {
                    uint32_t v[4];
                    static const int corner[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
                    for (int t = 0; t < 4; t++) {
                        size_t ijk[3];
                        ijk[a] = side ? (size_t)n : 0;
                        ijk[(a + 1) % 3] = (size_t)(p + corner[t][0]);
                        ijk[(a + 2) % 3] = (size_t)(q + corner[t][1]);
                        v[t] = id[(ijk[0] * N + ijk[1]) * N + ijk[2]];
                    }
                    if (side)
                        sb_face(&b, 4, v[0], v[1], v[2], v[3]);
                    else
                        sb_face(&b, 4, v[3], v[2], v[1], v[0]);
                }
    free(id);
    return sb_finish(&b);
}

/* ---- degenerate Voronoi inputs: generated spheres, cylinders, boxes ---- */

/* Places with the defaults (60 + 60) on a generated closed mesh: succeeds,
 * deterministic (twice, and with one thread), every vertex under two ROIs,
 * every interior point inside; returns the interior count and the first
 * interior centre. */
static size_t place_shape(const char *name, ffd_mesh *m, double first[3])
{
    size_t interior = 0;
    if (!m) {
        CHECK(!"shape not built");
        return 0;
    }
    ffd_ebf *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    ffd_placement_report rep;
    ffd_error err = {{0}};
    capture cap;
    capture_begin(&cap);
    ffd_status st = ffd_pbffd_place(m, NULL, &a, &na, &rep, &err);
    long printed = capture_end(&cap);
    CHECK(printed == 0);
    CHECK(st == FFD_OK);
    if (st != FFD_OK) {
        fprintf(stderr, "     %s: %s\n", name, err.message);
        ffd_mesh_destroy(m);
        return 0;
    }
    interior = rep.interior_count;
    CHECK(!rep.open && rep.exterior_count == 60 && interior >= 1 && interior <= 60);
    CHECK(na == interior + 60);
    CHECK((interior < 60) == (strstr(rep.note, "distinct interior point") != NULL));
    CHECK(check_controls(m, a, na) == 0);
    size_t outside = 0;
    for (size_t j = 0; j < interior; j++)
        outside += !inside_mesh(m, a[j].center);
    CHECK(outside == 0);
    memcpy(first, a[0].center, sizeof a[0].center);
    int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    CHECK_OK(ffd_pbffd_place(m, NULL, &b, &nb, NULL, NULL));
    omp_set_num_threads(threads);
    CHECK(na == nb && a && b && memcmp(a, b, na * sizeof *a) == 0);
    printf("     %s: %zu vertices, %zu Voronoi vertices, %zu inside, %zu interior points%s%s\n",
           name, ffd_mesh_vertex_count(m), rep.voronoi_vertices, rep.inside_vertices, interior,
           rep.note[0] ? ": " : "", rep.note);
    ffd_free(a);
    ffd_free(b);
    ffd_mesh_destroy(m);
    return interior;
}

/* Cospherical vertices made Qhull merge everything into one Delaunay region:
 * one Voronoi vertex, "only 0 Voronoi vertices lie inside". The jittered
 * sites give every cell; the sphere's medial axis is its centre, so one
 * interior point is placed there. */
static void test_place_spheres(void)
{
    static const double o[3] = {0.3, -0.2, 0.1};
    double c[3];
    struct { const char *name; ffd_mesh *m; double r; } cases[] = {
        {"uv sphere 32x16", make_uv_sphere(32, 16, 1.0, o), 1.0},
        {"uv sphere 64x32", make_uv_sphere(64, 32, 2.5, o), 2.5},
        {"icosphere 2", make_icosphere(2, 1.0, o), 1.0},
        {"icosphere 3", make_icosphere(3, 40.0, o), 40.0},
        {"icosphere 4", make_icosphere(4, 1e-3, o), 1e-3}};
    for (size_t t = 0; t < sizeof cases / sizeof cases[0]; t++) {
        CHECK(place_shape(cases[t].name, cases[t].m, c) == 1);
        CHECK(sqrt(d2(c, o)) < 1e-4 * cases[t].r);
    }
    /* the exact sites: Qhull returns the centre once (what placement used to get) */
    ffd_mesh *m = make_icosphere(2, 1.0, o);
    double *v = NULL;
    size_t count = 0;
    CHECK_OK(ffd_voronoi_vertices(ffd_mesh_positions(m), ffd_mesh_vertex_count(m), 0, &v,
                                  &count, NULL));
    CHECK(count == 1 && v && sqrt(d2(v, o)) < 1e-9);
    ffd_free(v);
    ffd_mesh_destroy(m);
}

static void test_place_cylinders_and_boxes(void)
{
    double c[3];
    size_t k = place_shape("cylinder 32x8, caps of 3 rings", make_cylinder(32, 8, 3, 1.0, 3.0), c);
    CHECK(k > 1);
    k = place_shape("cylinder 24x20, fan caps", make_cylinder(24, 20, 1, 0.5, 6.0), c);
    CHECK(k > 1);
    k = place_shape("box 6x6", make_box(6, 2.0), c);
    CHECK(k > 1);
    k = place_shape("box 12x12", make_box(12, 1.0), c);
    CHECK(k > 1);
}

/* Slivers (flat Delaunay cells of four nearly cocircular sites) give no
 * Voronoi vertex when a quality is asked for: the square's four corners
 * with a tiny lift and a far point. */
static void test_voronoi_slivers(void)
{
    double p[] = {0, 0, 0, 1, 0, 0, 1, 1, 1e-9, 0, 1, 0, 0.5, 0.5, 3, 0.5, 0.5, -3};
    double *v = NULL;
    size_t all = 0, kept = 0;
    CHECK_OK(ffd_voronoi_vertices(p, 6, 0, &v, &all, NULL));
    ffd_free(v);
    CHECK_OK(ffd_voronoi_vertices(p, 6, 1e-4, &v, &kept, NULL));
    CHECK(kept < all && kept >= 1);
    /* what is kept is a well-shaped cell's centre: on the square's axis, near its plane */
    for (size_t k = 0; k < kept; k++)
        CHECK(fabs(v[3 * k] - 0.5) < 1e-6 && fabs(v[3 * k + 1] - 0.5) < 1e-6 &&
              fabs(v[3 * k + 2]) < 2);
    ffd_free(v);
}

/* ---- failing allocations ---- */

static void failing_sweep(const ffd_mesh *m, size_t expect)
{
    ffd_placement_options o = {0};
    o.interior_count = 20;
    o.exterior_count = 20;
    o.voronoi_sites = 300;
    for (long k = 0;; k += check_sweep_step()) {
        fail_alloc fa = {k, 0};
        ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&a);
        ffd_ebf *c = NULL;
        size_t count = 0;
        ffd_status s = ffd_pbffd_place(m, &o, &c, &count, NULL, NULL);
        ffd_set_allocator(NULL);
        CHECK(s == FFD_OK || s == FFD_ERR_NOMEM);
        CHECK(s == FFD_OK || (c == NULL && count == 0));
        ffd_free(c);
        if (s == FFD_OK) {
            CHECK(count == expect);
            break;
        }
        if (k > 1000) {
            CHECK(!"allocation sweep did not finish");
            break;
        }
    }
}

static void test_failing_allocations(void)
{
    for (int open = 0; open < 2; open++) {
        ffd_mesh *m = read_shared(open ? "teapot.obj" : "elephant.off");
        if (!m)
            return;
        failing_sweep(m, open ? 20 : 40);
        ffd_mesh_destroy(m);
    }
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"voronoi_brute_force", test_voronoi_brute_force},
        {"voronoi_regular_cases", test_voronoi_regular_cases},
        {"voronoi_degenerate", test_voronoi_degenerate},
        {"kdtree_brute_force", test_kdtree_brute_force},
        {"decimate_counts_deterministic", test_decimate_counts_deterministic},
        {"decimate_clusters", test_decimate_clusters},
        {"place_cow", test_place_cow},
        {"place_elephant", test_place_elephant},
        {"place_refined_elephant", test_place_refined_elephant},
        {"place_defaults_and_no_cover", test_place_defaults_and_no_cover},
        {"place_deterministic_threads", test_place_deterministic_threads},
        {"place_inside_out", test_place_inside_out},
        {"place_open_teapot", test_place_open_teapot},
        {"place_errors", test_place_errors},
        {"voronoi_slivers", test_voronoi_slivers},
        {"place_spheres", test_place_spheres},
        {"place_cylinders_and_boxes", test_place_cylinders_and_boxes},
        {"failing_allocations", test_failing_allocations},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
