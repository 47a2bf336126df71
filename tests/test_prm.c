/* Tests for the PyGeM .prm reader (src/lattice/lattice_prm.c): the parsed rig, and
 * ffd_rig_apply on it against an independent transcription of PyGeM's FFD
 * (mathLab/PyGeM pygem/ffd.py FFD.__call__, pygem/utils.py angles2matrix),
 * points outside the box included; bad inputs; every truncated prefix. */
#include "check.h"
#include "ffd.h"
#include "rig/rig.h"

#include <stdarg.h>
#include <stdint.h>

#define EXAMPLE FFD_SOURCE_DIR "/examples/lattice/pygem/ffd.prm"
#define REL_TOL 1e-12
#define PI_ 3.14159265358979323846

static int near_rel(double a, double b, double tol)
{
    double m = fabs(a) > fabs(b) ? fabs(a) : fabs(b);
    return fabs(a - b) <= tol * (m > 1 ? m : 1);
}

/* ======================================================================
 * A PyGeM parameter set, written as PyGeM's FFD.write_parameters does
 * ====================================================================== */

typedef struct spec {
    uint32_t res[3];
    double length[3], origin[3], angle[3]; /* angles in degrees */
    double *mu;                            /* res0*res1*res2 by 3: mu[3*((i*m+j)*n+k) + axis] */
} spec;

static size_t spec_count(const spec *s)
{
    return (size_t)s->res[0] * s->res[1] * s->res[2];
}

typedef struct text {
    char *p;
    size_t n, cap;
} text;

static void put(text *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    char buf[256];
    int k = vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    if (t->n + (size_t)k + 1 > t->cap) {
        t->cap = 2 * (t->n + (size_t)k + 1);
        t->p = realloc(t->p, t->cap);
    }
    memcpy(t->p + t->n, buf, (size_t)k + 1);
    t->n += (size_t)k;
}

static char *spec_write(const spec *s, size_t *size)
{
    text t = {0};
    const char *axis = "xyz";
    put(&t, "\n[Box info]\n# written by test_prm.c in PyGeM's layout\n");
    for (int a = 0; a < 3; a++)
        put(&t, "n control points %c: %u\n", axis[a], s->res[a]);
    for (int a = 0; a < 3; a++)
        put(&t, "box length %c: %.17g\n", axis[a], s->length[a]);
    for (int a = 0; a < 3; a++)
        put(&t, "box origin %c: %.17g\n", axis[a], s->origin[a]);
    for (int a = 0; a < 3; a++)
        put(&t, "rotation angle %c: %.17g\n", axis[a], s->angle[a]);
    put(&t, "\n\n[Parameters weights]\n");
    for (int a = 0; a < 3; a++) {
        put(&t, "\n# parameter %c collects the displacements along %c.\nparameter %c:", axis[a],
            axis[a], axis[a]);
        int offset = 1;
        for (uint32_t i = 0; i < s->res[0]; i++)
            for (uint32_t j = 0; j < s->res[1]; j++)
                for (uint32_t k = 0; k < s->res[2]; k++) {
                    size_t p = ((size_t)i * s->res[1] + j) * s->res[2] + k;
                    put(&t, "%*s%u   %u   %u   %.17g\n", offset, "", i, j, k, s->mu[3 * p + a]);
                    offset = 13;
                }
    }
    *size = t.n;
    return t.p;
}

/* ======================================================================
 * PyGeM's FFD, transcribed independently of the library
 * ====================================================================== */

static void mat_mul(const double a[3][3], const double b[3][3], double c[3][3])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            c[i][j] = 0;
            for (int l = 0; l < 3; l++)
                c[i][j] += a[i][l] * b[l][j];
        }
}

/* angles2matrix(rz, ry, rx) = reduce(np.dot, [Rz, Ry, Rx][::-1]) = Rx Ry Rz. */
static void pygem_rotation(const double deg[3], double r[3][3])
{
    double x = deg[0] * PI_ / 180, y = deg[1] * PI_ / 180, z = deg[2] * PI_ / 180;
    double rx[3][3] = {{1, 0, 0}, {0, cos(x), -sin(x)}, {0, sin(x), cos(x)}};
    double ry[3][3] = {{cos(y), 0, sin(y)}, {0, 1, 0}, {-sin(y), 0, cos(y)}};
    double rz[3][3] = {{cos(z), -sin(z), 0}, {sin(z), cos(z), 0}, {0, 0, 1}};
    double ryz[3][3];
    mat_mul((const double(*)[3])ry, (const double(*)[3])rz, ryz);
    mat_mul((const double(*)[3])rx, (const double(*)[3])ryz, r);
}

/* position_vertices - box_origin = (R diag(L)).T: columns of a are the box edges. */
static void pygem_frame(const spec *s, double a[3][3])
{
    double r[3][3];
    pygem_rotation(s->angle, r);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            a[i][j] = r[i][j] * s->length[j];
}

static double det3(const double a[3][3])
{
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
           a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
}

/* psi: solves a y = v by Cramer's rule (PyGeM fits the same affine map by lstsq). */
static void pygem_psi(const double a[3][3], const double v[3], double y[3])
{
    double d = det3(a);
    for (int c = 0; c < 3; c++) {
        double b[3][3];
        memcpy(b, a, sizeof b);
        for (int r = 0; r < 3; r++)
            b[r][c] = v[r];
        y[c] = det3((const double(*)[3])b) / d;
    }
}

static double binomial(unsigned n, unsigned k)
{
    double b = 1;
    for (unsigned i = 1; i <= k; i++)
        b = b * (n - k + i) / i;
    return b;
}

/* FFD.__call__: psi, is_inside on [0,1]^3 (closed), T (explicit Bernstein sums), psi^-1.
 * Returns 1 when the point was inside. */
static int pygem_deform(const spec *s, const double p[3], double out[3])
{
    double a[3][3], v[3], y[3];
    pygem_frame(s, a);
    for (int i = 0; i < 3; i++)
        v[i] = p[i] - s->origin[i];
    pygem_psi((const double(*)[3])a, v, y);
    if (!(y[0] >= 0 && y[0] <= 1 && y[1] >= 0 && y[1] <= 1 && y[2] >= 0 && y[2] <= 1)) {
        memcpy(out, p, 3 * sizeof *p);
        return 0;
    }
    double shift[3] = {0, 0, 0};
    for (uint32_t i = 0; i < s->res[0]; i++)
        for (uint32_t j = 0; j < s->res[1]; j++)
            for (uint32_t k = 0; k < s->res[2]; k++) {
                unsigned l = s->res[0] - 1, m = s->res[1] - 1, n = s->res[2] - 1;
                double bx = binomial(l, i) * pow(1 - y[0], l - i) * pow(y[0], i);
                double by = binomial(m, j) * pow(1 - y[1], m - j) * pow(y[1], j);
                double bz = binomial(n, k) * pow(1 - y[2], n - k) * pow(y[2], k);
                size_t q = ((size_t)i * s->res[1] + j) * s->res[2] + k;
                for (int c = 0; c < 3; c++)
                    shift[c] += bx * by * bz * s->mu[3 * q + c];
            }
    for (int r = 0; r < 3; r++) {
        out[r] = s->origin[r];
        for (int c = 0; c < 3; c++)
            out[r] += a[r][c] * (y[c] + shift[c]);
    }
    return 1;
}

/* ======================================================================
 * Fixtures
 * ====================================================================== */

/* The parameters examples/lattice/pygem/ffd.prm holds: only inner control
 * points move, so the map is continuous across the box faces. */
static double example_mu[3 * 4 * 3 * 3];
static spec example_spec(void)
{
    spec s = {{3, 4, 3}, {12.0, 7.0, 10.0}, {-6.0, 4.0, -5.0}, {4.0, -6.5, 10.0}, example_mu};
    memset(example_mu, 0, sizeof example_mu);
#define MU(i, j, k, axis, v) example_mu[3 * (((i)*4 + (j)) * 3 + (k)) + (axis)] = (v)
    MU(1, 2, 1, 0, 0.08);
    MU(1, 1, 1, 1, 0.1);
    MU(1, 2, 1, 1, 0.2);
    MU(1, 2, 1, 2, -0.1);
    MU(1, 1, 1, 2, 0.05);
#undef MU
    return s;
}

static ffd_rig *parse(const char *t, size_t n, ffd_status *status, ffd_error *err)
{
    ffd_rig *rig = NULL;
    *status = ffd_rig_parse_prm(t, n, "t.prm", &rig, err);
    return rig;
}

/* Points with reference coordinates in [-0.4, 1.4]^3, none within 1e-6 of a
 * face (where PyGeM's lstsq rounding decides inside/outside). */
static double *sample_points(const spec *s, size_t n, size_t *inside)
{
    double a[3][3];
    pygem_frame(s, a);
    double *p = malloc(3 * n * sizeof *p);
    *inside = 0;
    for (size_t i = 0; i < n; i++) {
        double y[3];
        int in = 1;
        for (int c = 0; c < 3; c++) {
            do
                y[c] = -0.4 + 1.8 * check_rand01();
            while (fabs(y[c]) < 1e-6 || fabs(y[c] - 1) < 1e-6);
            in &= y[c] > 0 && y[c] < 1;
        }
        *inside += (size_t)in;
        for (int r = 0; r < 3; r++)
            p[3 * i + r] = s->origin[r] + a[r][0] * y[0] + a[r][1] * y[1] + a[r][2] * y[2];
    }
    return p;
}

/* Applies rig to n sampled points and compares with pygem_deform. */
static void compare_with_pygem(const spec *s, const ffd_rig *rig, size_t n)
{
    size_t inside;
    double *p = sample_points(s, n, &inside);
    CHECK(inside > n / 10 && inside < n - n / 10); /* both kinds present */
    ffd_mesh *mesh = NULL;
    CHECK_OK(ffd_mesh_create(p, n, NULL, NULL, 0, &mesh, NULL));
    if (!mesh) {
        free(p);
        return;
    }
    ffd_rig_report report;
    ffd_error err = {{0}};
    ffd_status st = ffd_rig_apply(rig, mesh, &report, &err);
    CHECK(st == FFD_OK);
    if (st)
        fprintf(stderr, "  ffd_rig_apply: %s\n", err.message);
    else
        CHECK(report.outside_count == n - inside);
    const double *q = ffd_mesh_positions(mesh);
    size_t bad = 0, moved = 0;
    for (size_t i = 0; i < n && !st; i++) {
        double ref[3];
        int in = pygem_deform(s, p + 3 * i, ref);
        for (int c = 0; c < 3; c++) {
            if (!near_rel(q[3 * i + c], ref[c], REL_TOL) && bad++ < 5)
                fprintf(stderr, "  point %zu (%s) coord %d: ffd %.17g, pygem %.17g\n", i,
                        in ? "inside" : "outside", c, q[3 * i + c], ref[c]);
            if (!in)
                CHECK(q[3 * i + c] == p[3 * i + c]); /* outside: bit-for-bit unchanged */
        }
        moved += in && (ref[0] != p[3 * i] || ref[1] != p[3 * i + 1] || ref[2] != p[3 * i + 2]);
    }
    CHECK(bad == 0);
    CHECK(st || moved > 0);
    ffd_rig_report_free(&report);
    ffd_mesh_destroy(mesh);
    free(p);
}

/* ======================================================================
 * Tests
 * ====================================================================== */

static void test_example_fields(void)
{
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    ffd_status st = ffd_rig_read(EXAMPLE, &rig, &err);
    CHECK(st == FFD_OK);
    if (st) {
        fprintf(stderr, "  %s\n", err.message);
        return;
    }
    spec s = example_spec();
    double a[3][3], r[3][3];
    pygem_frame(&s, a);
    pygem_rotation(s.angle, r);
    CHECK(rig->basis == FFD_BASIS_BERNSTEIN);
    CHECK(rig->box_auto == 0);
    CHECK(rig->outside == FFD_OUTSIDE_FIXED);
    CHECK(rig->constraint_count == 0);
    for (int i = 0; i < 3; i++) {
        CHECK(rig->resolution[i] == s.res[i]);
        CHECK(rig->box.origin[i] == s.origin[i]);
        for (int c = 0; c < 3; c++)
            CHECK_NEAR(rig->box.axes[i][c], a[c][i], 1e-15);
    }
    /* one move per displaced control point, delta = R (mu (.) L) */
    size_t displaced = 0;
    for (size_t q = 0; q < spec_count(&s); q++)
        displaced += s.mu[3 * q] != 0 || s.mu[3 * q + 1] != 0 || s.mu[3 * q + 2] != 0;
    CHECK(rig->move_count == displaced && displaced == 2);
    for (size_t m = 0; m < rig->move_count; m++) {
        const ffd_rig_move *mv = &rig->moves[m];
        CHECK(mv->index[0] < 3 && mv->index[1] < 4 && mv->index[2] < 3);
        size_t q = ((size_t)mv->index[0] * 4 + mv->index[1]) * 3 + mv->index[2];
        for (int row = 0; row < 3; row++) {
            double d = 0;
            for (int c = 0; c < 3; c++)
                d += r[row][c] * s.mu[3 * q + c] * s.length[c];
            CHECK_NEAR(mv->delta[row], d, 1e-15);
        }
    }
    ffd_rig_destroy(rig);
}

/* The example file and the same parameters written by spec_write parse alike. */
static void test_example_matches_spec(void)
{
    ffd_rig *from_file = NULL, *from_spec = NULL;
    CHECK_OK(ffd_rig_read(EXAMPLE, &from_file, NULL));
    spec s = example_spec();
    size_t n;
    char *t = spec_write(&s, &n);
    ffd_status st;
    from_spec = parse(t, n, &st, NULL);
    CHECK(st == FFD_OK);
    if (from_file && from_spec) {
        CHECK(from_file->move_count == from_spec->move_count);
        for (size_t m = 0; m < from_file->move_count && m < from_spec->move_count; m++) {
            CHECK(memcmp(from_file->moves[m].index, from_spec->moves[m].index,
                         sizeof from_file->moves[m].index) == 0);
            for (int c = 0; c < 3; c++)
                CHECK(from_file->moves[m].delta[c] == from_spec->moves[m].delta[c]);
        }
        CHECK(memcmp(&from_file->box, &from_spec->box, sizeof from_file->box) == 0);
    }
    ffd_rig_destroy(from_file);
    ffd_rig_destroy(from_spec);
    free(t);
}

/* PyGeM's own test values: tests/test_ffd.py test_read_parameters_rotation_matrix and
 * test_read_parameters_position_vertex_0 for tests/test_datasets/parameters_sphere.prm. */
static void test_pygem_sphere_box(void)
{
    static double mu[3 * 2 * 2 * 3];
    const double mx[12] = {0.2, 0., 0., 0., 0.5, 0., 0., 0., 1., 0., 0., 0.};
    const double my[12] = {0., 0., 0.5555555555, 0., 0., 0., 0., 0., -1., 0., 0., 0.};
    const double mz[12] = {0., -0.2, 0., -0.45622985, 0., 0., 0., 0., -1.22, 0., -1., 0.};
    for (int q = 0; q < 12; q++) {
        mu[3 * q] = mx[q];
        mu[3 * q + 1] = my[q];
        mu[3 * q + 2] = mz[q];
    }
    spec s = {{3, 2, 2}, {45.0, 90.0, 90.0}, {-20.0, -55.0, -45.0}, {20.3, 11.0, 0.0}, mu};
    size_t n;
    char *t = spec_write(&s, &n);
    ffd_status st;
    ffd_error err = {{0}};
    ffd_rig *rig = parse(t, n, &st, &err);
    free(t);
    CHECK(st == FFD_OK);
    if (!rig)
        return;
    const double vertices[4][3] = {{-20.0, -55.0, -45.0},
                                   {24.17322326, -52.02107006, -53.05309404},
                                   {-20.0, 29.41000412, -13.77579136},
                                   {-2.82719042, -85.65053198, 37.85915459}};
    const double rotation[3][3] = {{0.98162718, 0.0, 0.190809},
                                   {0.06619844, 0.93788893, -0.34056147},
                                   {-0.17895765, 0.34693565, 0.92065727}};
    for (int c = 0; c < 3; c++) {
        CHECK_NEAR(rig->box.origin[c], vertices[0][c], 1e-8);
        for (int i = 0; i < 3; i++) {
            CHECK_NEAR(rig->box.origin[c] + rig->box.axes[i][c], vertices[i + 1][c], 1e-7);
            CHECK_NEAR(rig->box.axes[i][c] / s.length[i], rotation[c][i], 1e-8);
        }
    }
    CHECK(rig->move_count == 7); /* control points with some non-zero weight */
    compare_with_pygem(&s, rig, 2000);
    ffd_rig_destroy(rig);
}

static void test_example_against_pygem(void)
{
    ffd_rig *rig = NULL;
    CHECK_OK(ffd_rig_read(EXAMPLE, &rig, NULL));
    if (!rig)
        return;
    spec s = example_spec();
    compare_with_pygem(&s, rig, 4000);
    ffd_rig_destroy(rig);
}

/* Random resolutions, boxes, rotations on all three axes, weights. */
static void test_random_against_pygem(void)
{
    for (int trial = 0; trial < 12; trial++) {
        spec s;
        for (int a = 0; a < 3; a++) {
            s.res[a] = 2 + (uint32_t)(check_rand01() * 5);
            s.length[a] = 0.2 + 5 * check_rand01();
            s.origin[a] = -3 + 6 * check_rand01();
            s.angle[a] = -180 + 360 * check_rand01();
        }
        if (trial == 0) /* a plain axis-aligned box too */
            s.angle[0] = s.angle[1] = s.angle[2] = 0;
        size_t count = spec_count(&s);
        s.mu = calloc(3 * count, sizeof *s.mu);
        for (size_t q = 0; q < 3 * count; q++)
            if (check_rand01() < 0.4)
                s.mu[q] = -0.4 + 0.8 * check_rand01();
        size_t n;
        char *t = spec_write(&s, &n);
        ffd_status st;
        ffd_error err = {{0}};
        ffd_rig *rig = parse(t, n, &st, &err);
        CHECK(st == FFD_OK);
        if (rig)
            compare_with_pygem(&s, rig, 1500);
        ffd_rig_destroy(rig);
        free(t);
        free(s.mu);
    }
}

/* What configparser accepts and PyGeM reads, in every spelling. */
static void test_syntax_variants(void)
{
    const char *t = "\xEF\xBB\xBF; a comment before the first section\r\n"
                    "[DEFAULT]\r\n"
                    "rotation angle z = 0\r\n"
                    "[Box info]\r\n"
                    "N Control Points X = 2\r\n"
                    "n control points y:2\r\n"
                    "n control points z :\r\n"
                    "    2\r\n"
                    "conversion unit: 1.0\r\n" /* unknown keys are ignored, as in PyGeM */
                    "box lenght x: 2\r\n"      /* PyGeM 1.x spelling */
                    "box length y: 1e0\r\n"
                    "box length z: +1.\r\n"
                    "box origin x: -.5\r\n"
                    "box origin y: 0\r\n"
                    "box origin z: 0\r\n"
                    "rotation mode: 0\r\n"
                    "rotation angle x: 0\r\n"
                    "rotation angle y: 0\r\n"
                    "[Something else]\r\n"
                    "whatever: [not, read]\r\n"
                    "  continued\r\n"
                    "[Parameters weights]\r\n"
                    "parameter x:\r\n"
                    "   1 0 0 0.25\r\n"
                    "# a comment inside the value\r\n"
                    "\r\n"
                    "\t1 1 1\t0.5\r\n"
                    "   1 0 0 0.5\r\n" /* assigned again: the last one wins */
                    "parameter y = 0 0 0 0.0\r"
                    "parameter z: 0 1 1 -0.125\n";
    ffd_status st;
    ffd_error err = {{0}};
    ffd_rig *rig = parse(t, strlen(t), &st, &err);
    CHECK(st == FFD_OK);
    if (!rig) {
        fprintf(stderr, "  %s\n", err.message);
        return;
    }
    CHECK(rig->resolution[0] == 2 && rig->resolution[1] == 2 && rig->resolution[2] == 2);
    CHECK(rig->box.origin[0] == -0.5);
    CHECK(rig->box.axes[0][0] == 2 && rig->box.axes[1][1] == 1 && rig->box.axes[2][2] == 1);
    CHECK(rig->move_count == 3);
    /* sorted by control point: (0,1,1), (1,0,0), (1,1,1) */
    if (rig->move_count == 3) {
        CHECK(rig->moves[0].index[0] == 0 && rig->moves[0].index[1] == 1 &&
              rig->moves[0].index[2] == 1);
        CHECK(rig->moves[0].delta[2] == -0.125);
        CHECK(rig->moves[1].index[0] == 1 && rig->moves[1].index[1] == 0);
        CHECK(rig->moves[1].delta[0] == 1.0); /* 0.5 * box length 2 */
        CHECK(rig->moves[2].delta[0] == 1.0 && rig->moves[2].delta[1] == 0);
    }
    ffd_rig_destroy(rig);
}

#define BOX "[Box info]\n"
#define COUNTS "n control points x: 2\nn control points y: 2\nn control points z: 2\n"
#define LENGTHS "box length x: 1\nbox length y: 1\nbox length z: 1\n"
#define ORIGIN "box origin x: 0\nbox origin y: 0\nbox origin z: 0\n"
#define ANGLES "rotation angle x: 0\nrotation angle y: 0\nrotation angle z: 0\n"
#define WEIGHTS_HEAD "[Parameters weights]\n"
#define WEIGHTS "parameter x: 0 0 0 0.5\nparameter y: 1 1 1 0.0\nparameter z: 0 1 0 -0.25\n"

typedef struct bad_case {
    const char *text;
    ffd_status status;
    const char *fragment;
} bad_case;

static void test_bad_inputs(void)
{
    static const bad_case cases[] = {
        {BOX "n control points x: 1\nn control points y: 2\nn control points z: 2\n" LENGTHS ORIGIN
             ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_INVALID,
         "t.prm:2: n control points x: lattice resolution 1 is below the minimum 2"},
        {BOX "n control points x: 2\nn control points y: 0\nn control points z: 2\n" LENGTHS ORIGIN
             ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_INVALID,
         "t.prm:3: n control points y: lattice resolution 0 is below the minimum 2"},
        {BOX
         "n control points x: 2\nn control points y: 2\nn control points z: 1025\n" LENGTHS ORIGIN
             ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_INVALID,
         "t.prm:4: n control points z: lattice resolution 1025 is above the maximum 1024"},
        {BOX "n control points x: 99999999999999999999\nn control points y: 2\nn control points z: "
             "2\n" LENGTHS ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_RANGE,
         "t.prm:2: n control points x: integer '99999999999999999999' is out of range"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 0 0 0.5\nparameter y: 1 -99999999999999999999 1 0.0\nparameter z: 0 1 0 "
         "-0.25\n",
         FFD_ERR_RANGE, "t.prm:16: parameter y: integer '-99999999999999999999' is out of range"},
        {BOX
         "n control points x: two\nn control points y: 2\nn control points z: 2\n" LENGTHS ORIGIN
             ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_PARSE, "t.prm:2: n control points x: expected an integer, got 'two'"},
        {BOX
         "n control points x: 2.0\nn control points y: 2\nn control points z: 2\n" LENGTHS ORIGIN
             ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_PARSE, "t.prm:2: n control points x: expected an integer"},
        {BOX COUNTS
         "box length x: 1\nbox length y: 0\nbox length z: 1\n" ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_INVALID, "t.prm:6: box length y = 0: zero-volume box"},
        {BOX COUNTS
         "box length x: -2\nbox length y: 1\nbox length z: 1\n" ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_INVALID, "t.prm:5: box length x = -2: zero-volume box"},
        {BOX COUNTS LENGTHS
         "box origin x: nan\nbox origin y: 0\nbox origin z: 0\n" ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_NONFINITE, "t.prm:8: box origin x: 'nan' is not a finite number"},
        {BOX COUNTS LENGTHS ORIGIN "rotation angle x: 0\nrotation angle y: -Infinity\nrotation "
                                   "angle z: 0\n" WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_NONFINITE, "t.prm:12: rotation angle y: '-Infinity' is not a finite number"},
        {BOX COUNTS LENGTHS
         "box origin x: 0\nbox origin y: 1e999\nbox origin z: 0\n" ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_NONFINITE, "t.prm:9: box origin y: '1e999' overflows a double"},
        {BOX COUNTS LENGTHS
         "box origin x: 0x10\nbox origin y: 0\nbox origin z: 0\n" ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_PARSE, "t.prm:8: box origin x: expected a number, got '0x10'"},
        {BOX COUNTS "box length x: 1.0 # metres\nbox length y: 1\nbox length z: 1\n" ORIGIN ANGLES
             WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_PARSE, "t.prm:5: box length x: expected a number, got '1.0 # metres'"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 0 2 0.5\nparameter y: 1 1 1 0.0\nparameter z: 0 1 0 -0.25\n",
         FFD_ERR_RANGE,
         "t.prm:15: parameter x: control point (0, 0, 2) out of range (lattice is 2 x 2 x 2"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 0 0 0.5\nparameter y: 1 1 1 0.0\n             -1 0 0 0.5\nparameter "
         "z: 0 1 0 -0.25\n",
         FFD_ERR_RANGE, "t.prm:17: parameter y: control point (-1, 0, 0) out of range"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 0 0\nparameter y: 1 1 1 0.0\nparameter z: 0 1 0 -0.25\n",
         FFD_ERR_PARSE, "t.prm:15: parameter x: expected 'i j k weight', got '0 0 0'"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 0 0 0.5 7\nparameter y: 1 1 1 0.0\nparameter z: 0 1 0 -0.25\n",
         FFD_ERR_PARSE, "t.prm:15: parameter x: expected 'i j k weight', got '0 0 0 0.5 7'"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 0 0 0.5\nparameter y: 1 1 1 zero\nparameter z: 0 1 0 -0.25\n",
         FFD_ERR_PARSE, "t.prm:16: parameter y: expected a number, got 'zero'"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 0 0 0.5\nparameter y: 1 1 1 0.0\nparameter z: 0 1 0 NaN\n",
         FFD_ERR_NONFINITE, "t.prm:17: parameter z: 'NaN' is not a finite number"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 a 0 0.5\nparameter y: 1 1 1 0.0\nparameter z: 0 1 0 -0.25\n",
         FFD_ERR_PARSE, "t.prm:15: parameter x: expected an integer, got 'a'"},
        {BOX COUNTS
         "box length x: 1e300\nbox length y: 1\nbox length z: 1\n" ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 0 0 1e300\nparameter y: 1 1 1 0.0\nparameter z: 0 1 "
         "0 -0.25\n",
         FFD_ERR_NONFINITE, "t.prm:15: control point (0, 0, 0): weight times box length overflows"},
        {BOX COUNTS LENGTHS "box origin x: 0\nbox origin z: 0\n" ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_PARSE, "t.prm:1: [Box info] has no key 'box origin y'"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD
         "parameter x: 0 0 0 0.5\nparameter z: 0 1 0 -0.25\n",
         FFD_ERR_PARSE, "t.prm:14: [Parameters weights] has no key 'parameter y'"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES, FFD_ERR_PARSE,
         "t.prm: missing section [Parameters weights]"},
        {"", FFD_ERR_PARSE, "t.prm: missing section [Box info]"},
        {"[box info]\n" COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS, FFD_ERR_PARSE,
         "t.prm: missing section [Box info]"},
        {COUNTS BOX LENGTHS ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS, FFD_ERR_PARSE,
         "t.prm:1: 'n control points x: 2' before the first [section] header"},
        {BOX COUNTS "this line is not a key\n" LENGTHS ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_PARSE,
         "t.prm:5: expected 'key: value', a [section] header or a comment, got "
         "'this line is not a key'"},
        {"[Box info\n" COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS, FFD_ERR_PARSE,
         "t.prm:1: malformed section header '[Box info'"},
        {"[Box info] # box\n" COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS, FFD_ERR_PARSE,
         "t.prm:1: malformed section header"},
        {"[]\n", FFD_ERR_PARSE, "t.prm:1: empty section name"},
        {BOX ": 5\n", FFD_ERR_PARSE, "t.prm:2: empty key before ':'"},
        {BOX COUNTS LENGTHS
         "box origin x: 0\nbox origin y: 0\nbox origin x: 1\nbox origin z: 0\n" ANGLES WEIGHTS_HEAD
             WEIGHTS,
         FFD_ERR_PARSE, "t.prm:10: duplicate key 'box origin x' in [Box info] (first at line 8)"},
        {BOX COUNTS LENGTHS ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS BOX, FFD_ERR_PARSE,
         "t.prm:18: duplicate section [Box info] (first at line 1)"},
        {BOX COUNTS LENGTHS "box lenght y: 1\n" ORIGIN ANGLES WEIGHTS_HEAD WEIGHTS, FFD_ERR_PARSE,
         "t.prm:6: both 'box length y' and 'box lenght y' (line 8) given"},
        {BOX COUNTS LENGTHS ORIGIN "rotation mode: 1\n" ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_UNSUPPORTED, "t.prm:11: rotation mode 1: only 0"},
        {BOX COUNTS LENGTHS
         "box origin x:\nbox origin y: 0\nbox origin z: 0\n" ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_PARSE, "t.prm:8: box origin x: empty value"},
        {BOX COUNTS LENGTHS
         "box origin x: 0\n  1\nbox origin y: 0\nbox origin z: 0\n" ANGLES WEIGHTS_HEAD WEIGHTS,
         FFD_ERR_PARSE,
         "t.prm:8: box origin x: expected one number, the value continues on line 9"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        ffd_error err = {{0}};
        ffd_rig *rig = (ffd_rig *)&err; /* must be reset to NULL */
        ffd_status st =
            ffd_rig_parse_prm(cases[c].text, strlen(cases[c].text), "t.prm", &rig, &err);
        int ok = st == cases[c].status && rig == NULL && strstr(err.message, cases[c].fragment);
        CHECK(ok);
        if (!ok)
            fprintf(stderr, "  case %zu: status %d (want %d), message \"%s\"\n  wanted \"%s\"\n", c,
                    (int)st, (int)cases[c].status, err.message, cases[c].fragment);
        if (st == FFD_OK)
            ffd_rig_destroy(rig);
    }
    /* API misuse */
    ffd_rig *rig = NULL;
    CHECK(ffd_rig_parse_prm(NULL, 3, "t.prm", &rig, NULL) == FFD_ERR_INVALID && rig == NULL);
    CHECK(ffd_rig_parse_prm("", 0, "t.prm", NULL, NULL) == FFD_ERR_INVALID);
}

static char *read_example(size_t *size)
{
    FILE *f = fopen(EXAMPLE, "rb");
    if (!f)
        return NULL;
    char *buf = malloc(1 << 16);
    *size = fread(buf, 1, 1 << 16, f);
    fclose(f);
    return buf;
}

/* Every prefix fails cleanly or parses; the full file parses. Then single-byte edits. */
static void test_truncated_and_mutated(void)
{
    size_t size;
    char *full = read_example(&size);
    CHECK(full != NULL);
    if (!full)
        return;
    size_t ok = 0;
    for (size_t n = 0; n <= size; n++) {
        char *copy = malloc(n ? n : 1); /* exact size: ASan sees any over-read */
        memcpy(copy, full, n);
        ffd_error err = {{0}};
        ffd_rig *rig = NULL;
        ffd_status st = ffd_rig_parse_prm(copy, n, "ffd.prm", &rig, &err);
        if (st == FFD_OK) {
            ok++;
            CHECK(rig != NULL);
            ffd_rig_destroy(rig);
        } else {
            CHECK(rig == NULL);
            CHECK(strncmp(err.message, "ffd.prm", 7) == 0);
        }
        free(copy);
    }
    CHECK(ok >= 1); /* at least the whole file (and its prefixes that only drop trailing lines) */
    const char edits[] = {' ', '\n', '\r', '[', ']', ':', '=', '#', '\0', 'x', '-', '9', '\t'};
    for (size_t i = 0; i < size; i++)
        for (size_t e = 0; e < sizeof edits; e++) {
            char *copy = malloc(size);
            memcpy(copy, full, size);
            copy[i] = edits[e];
            ffd_rig *rig = NULL;
            ffd_error err = {{0}};
            ffd_status st = ffd_rig_parse_prm(copy, size, "ffd.prm", &rig, &err);
            CHECK((st == FFD_OK) == (rig != NULL));
            ffd_rig_destroy(rig);
            free(copy);
        }
    free(full);
}

/* Every allocation failure is reported as FFD_ERR_NOMEM and leaks nothing. */
typedef struct alloc_counter {
    long budget; /* allocations left before failing; < 0: unlimited */
    long live;
} alloc_counter;

static void *count_malloc(size_t size, void *user)
{
    alloc_counter *c = user;
    if (c->budget == 0)
        return NULL;
    if (c->budget > 0)
        c->budget--;
    c->live++;
    return malloc(size);
}

static void *count_realloc(void *ptr, size_t size, void *user)
{
    alloc_counter *c = user;
    if (c->budget == 0)
        return NULL;
    if (c->budget > 0)
        c->budget--;
    void *p = realloc(ptr, size);
    if (p && !ptr)
        c->live++;
    return p;
}

static void count_free(void *ptr, void *user)
{
    alloc_counter *c = user;
    c->live--;
    free(ptr);
}

static void test_allocation_failures(void)
{
    size_t size;
    char *full = read_example(&size);
    if (!full)
        return;
    alloc_counter counter;
    ffd_allocator a = {count_malloc, count_realloc, count_free, &counter};
    int succeeded = 0;
    for (long budget = 0; budget < 200 && !succeeded; budget++) {
        counter.budget = budget;
        counter.live = 0;
        ffd_set_allocator(&a);
        ffd_rig *rig = NULL;
        ffd_error err = {{0}};
        ffd_status st = ffd_rig_parse_prm(full, size, "ffd.prm", &rig, &err);
        if (st == FFD_OK) {
            succeeded = 1;
            ffd_rig_destroy(rig);
        } else {
            CHECK(st == FFD_ERR_NOMEM);
            CHECK(rig == NULL);
        }
        ffd_set_allocator(NULL);
        CHECK(counter.live == 0);
    }
    CHECK(succeeded);
    free(full);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"example_fields", test_example_fields},
        {"example_matches_spec", test_example_matches_spec},
        {"pygem_sphere_box", test_pygem_sphere_box},
        {"example_against_pygem", test_example_against_pygem},
        {"random_against_pygem", test_random_against_pygem},
        {"syntax_variants", test_syntax_variants},
        {"bad_inputs", test_bad_inputs},
        {"truncated_and_mutated", test_truncated_and_mutated},
        {"allocation_failures", test_allocation_failures},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
