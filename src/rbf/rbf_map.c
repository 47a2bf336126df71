/* rbf_map — the RBF map of PyGeM's RBF (pygem/rbf.py, _get_weights and
 * __call__; Forti & Rozza 2014, eq. of M(x) = p(x) + sum_i gamma_i
 * phi(|x - x_Ci|)) in displacement form (include/ffd_rbf_morph.h): the system
 * factored once (dsytrf through math/dense.c), one solve per control change,
 * and the cardinal functions for the linear map. */
#include "ffd.h"
#include "math/dense.h"
#include "rbf/rbf.h"

#include <math.h>
#include <string.h>

/* Below this reciprocal condition number the system is refused as singular. */
#define RBF_MIN_RCOND 1e-15

/* r(x): the row [phi(|x - c_j|), 1, x] of the system's basis (N + 4). */
static void basis_row(const ffd_rbf_morph *rbf, const double x[3], double *row)
{
    const size_t N = rbf->count;
    for (size_t j = 0; j < N; j++) {
        const double *c = rbf->rest + 3 * j;
        double d0 = x[0] - c[0], d1 = x[1] - c[1], d2 = x[2] - c[2];
        row[j] = ffd_rbf_phi(rbf->kernel, rbf->radius, rbf->power, sqrt(d0 * d0 + d1 * d1 + d2 * d2),
                             NULL);
    }
    row[N] = 1.0;
    memcpy(row + N + 1, x, 3 * sizeof *x);
}

static ffd_status check_points(const double *p, size_t n, const char *what, ffd_error *err)
{
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(p[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "rbf: %s[%zu]: not finite", what, i / 3);
    return FFD_OK;
}

/* Two control points at the same place make two equal rows: named here,
 * before the factorisation could only say "singular". Pairs in order, so
 * the first pair is named (quadratic: a millisecond for 5000 points). */
ffd_status ffd_rbf_check_distinct(const double *p, size_t n, const char *method, ffd_error *err)
{
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n; j++)
            if (p[3 * i] == p[3 * j] && p[3 * i + 1] == p[3 * j + 1] && p[3 * i + 2] == p[3 * j + 2])
                return ffd_fail(err, FFD_ERR_INVALID,
                                "%s: control_points[%zu] and control_points[%zu] coincide "
                                "([%.17g, %.17g, %.17g]): the system is singular",
                                method, i, j, p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    return FFD_OK;
}

void ffd_rbf_morph_destroy(ffd_rbf_morph *rbf)
{
    if (!rbf)
        return;
    ffd_free(rbf->rest);
    ffd_free(rbf->points);
    ffd_free(rbf->factor);
    ffd_free(rbf->ipiv);
    ffd_free(rbf->coef);
    ffd_rbf_grid_destroy(rbf->grid);
    ffd_rbf_sparse_destroy(rbf->sparse);
    ffd_free(rbf);
}

/* H X = B for nrhs columns ((N+4) by nrhs column-major, in place). */
static ffd_status system_solve(const ffd_rbf_morph *rbf, size_t nrhs, double *B, ffd_error *err)
{
    return rbf->sparse ? ffd_rbf_sparse_solve(rbf, nrhs, B, err)
                       : ffd_dense_sym_solve(rbf->count + 4, nrhs, rbf->factor, rbf->ipiv, B, err);
}

ffd_status ffd_rbf_morph_create(const double *control_points, size_t count,
                          const ffd_rbf_options *options, ffd_rbf_morph **out, ffd_error *err)
{
    ffd_rbf_options o = options ? *options : (ffd_rbf_options){0};
    *out = NULL;
    if (!control_points || count == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "rbf: no control points");
    if ((unsigned)o.kernel >= FFD_RBF_KERNEL_COUNT)
        return ffd_fail(err, FFD_ERR_INVALID, "rbf: unknown kernel %d", (int)o.kernel);
    if (o.radius == 0)
        o.radius = 0.5;
    if (!(o.radius > 0) || !isfinite(o.radius))
        return ffd_fail(err, FFD_ERR_INVALID, "rbf: radius %g: expected a finite number > 0",
                        o.radius);
    if (o.power == 0)
        o.power = 2;
    if ((unsigned)o.solver > FFD_RBF_SOLVER_SPARSE)
        return ffd_fail(err, FFD_ERR_INVALID, "rbf: unknown solver %d", (int)o.solver);
    if (o.solver == FFD_RBF_SOLVER_SPARSE && o.kernel != FFD_RBF_WENDLAND_C2)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "rbf: the sparse solver needs the compactly supported kernel "
                        "beckert_wendland_c2_basis (this rig's kernel is %s)",
                        ffd_rbf_kernel_name(o.kernel));
    const int sparse = o.solver == FFD_RBF_SOLVER_SPARSE ||
                       (o.solver == FFD_RBF_SOLVER_AUTO && o.kernel == FFD_RBF_WENDLAND_C2 &&
                        count > 2000);
    ffd_status s = check_points(control_points, count, "control_points", err);
    if (s || (s = ffd_rbf_check_distinct(control_points, count, "rbf", err)))
        return s;
    const size_t M = count + 4;
    if (!sparse && M > 46340) /* (N+4)^2 doubles and LAPACK's int sizes */
        return ffd_fail(err, FFD_ERR_INVALID,
                        "rbf: %zu control points: the dense system is limited to 46336 (the "
                        "sparse solver, with beckert_wendland_c2_basis, is not)",
                        count);
    if (M > 0x7fffffff)
        return ffd_fail(err, FFD_ERR_INVALID, "rbf: %zu control points are too many", count);
    ffd_rbf_morph *rbf = ffd_calloc(1, sizeof *rbf);
    if (!rbf)
        return ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory");
    rbf->count = count;
    rbf->kernel = o.kernel;
    rbf->radius = o.radius;
    rbf->power = o.power;
    rbf->rest = ffd_malloc_array(count, 3 * sizeof(double));
    rbf->points = ffd_malloc_array(count, 3 * sizeof(double));
    rbf->factor = sparse ? NULL : ffd_calloc(M * M, sizeof(double));
    rbf->ipiv = sparse ? NULL : ffd_malloc_array(M, sizeof(int));
    rbf->coef = ffd_calloc(M * 3, sizeof(double));
    if (!rbf->rest || !rbf->points || (!sparse && (!rbf->factor || !rbf->ipiv)) || !rbf->coef) {
        ffd_rbf_morph_destroy(rbf);
        return ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory for %zu control points", count);
    }
    memcpy(rbf->rest, control_points, count * 3 * sizeof(double));
    memcpy(rbf->points, control_points, count * 3 * sizeof(double));
    if (o.kernel == FFD_RBF_WENDLAND_C2)
        s = ffd_rbf_grid_create(rbf, err);
    if (!s && sparse)
        s = ffd_rbf_sparse_factor(rbf, err);
    if (s || sparse) {
        if (s)
            ffd_rbf_morph_destroy(rbf);
        else
            *out = rbf;
        return s;
    }
    /* H (PyGeM's _get_weights): column j of the lower triangle is r(c_j) below the diagonal */
    double *H = rbf->factor;
    for (size_t j = 0; j < count; j++)
        basis_row(rbf, rbf->rest + 3 * j, H + j * M); /* symmetric: column j = row j */
    for (size_t j = 0; j < count; j++) /* [1 C] in the upper block too (the norm reads both) */
        for (size_t k = 0; k < 4; k++)
            H[(count + k) * M + j] = H[j * M + count + k];
    /* rows and columns N..N+3 of the polynomial block stay 0 */
    double anorm = ffd_dense_sym_norm1(M, H);
    int singular = 0;
    ffd_error inner = {{0}};
    if ((s = ffd_dense_sym_factor(M, H, rbf->ipiv, &singular, &inner)) == FFD_OK && !singular)
        s = ffd_dense_sym_rcond(M, H, rbf->ipiv, anorm, &rbf->rcond, &inner);
    if (s) {
        ffd_rbf_morph_destroy(rbf);
        return ffd_fail(err, s, "rbf: %s", inner.message);
    }
    if (singular || !(rbf->rcond >= RBF_MIN_RCOND)) {
        double rc = singular ? 0 : rbf->rcond;
        ffd_rbf_morph_destroy(rbf);
        return ffd_fail(err, FFD_ERR_INVALID,
                        "rbf: the system of %zu control points is singular (reciprocal condition "
                        "number %.3g): the linear part needs four control points not in one "
                        "plane, and the kernel's radius must suit their spacing",
                        count, rc);
    }
    *out = rbf;
    return FFD_OK;
}

size_t ffd_rbf_morph_control_count(const ffd_rbf_morph *rbf)
{
    return rbf->count;
}

const double *ffd_rbf_morph_control_points(const ffd_rbf_morph *rbf)
{
    return rbf->points;
}

const double *ffd_rbf_morph_rest_points(const ffd_rbf_morph *rbf)
{
    return rbf->rest;
}

/* The coefficients [w; w_c; W_Q] for displacements v (N by 3) into coef
 * ((N+4) by 3 column-major). */
static ffd_status solve_coef(const ffd_rbf_morph *rbf, const double *v, double *coef, ffd_error *err)
{
    const size_t N = rbf->count, M = N + 4;
    memset(coef, 0, M * 3 * sizeof *coef);
    for (size_t j = 0; j < N; j++)
        for (int a = 0; a < 3; a++)
            coef[a * M + j] = v[3 * j + a];
    return system_solve(rbf, 3, coef, err);
}

ffd_status ffd_rbf_morph_set_control_points(ffd_rbf_morph *rbf, const double *points, ffd_error *err)
{
    const size_t N = rbf->count, M = N + 4;
    ffd_status s = check_points(points, N, "control point", err);
    if (s)
        return s;
    double *d = ffd_malloc_array(N, 3 * sizeof *d), *coef = ffd_malloc_array(M, 3 * sizeof *coef);
    if (!d || !coef) {
        ffd_free(d);
        ffd_free(coef);
        return ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory");
    }
    int moved = 0;
    for (size_t i = 0; i < 3 * N; i++) {
        d[i] = points[i] - rbf->rest[i];
        moved |= points[i] != rbf->rest[i];
    }
    if (moved)
        s = solve_coef(rbf, d, coef, err);
    else
        memset(coef, 0, M * 3 * sizeof *coef);
    if (!s) {
        memcpy(rbf->points, points, N * 3 * sizeof *points);
        memcpy(rbf->coef, coef, M * 3 * sizeof *coef);
        rbf->moved = moved;
    }
    ffd_free(d);
    ffd_free(coef);
    return s;
}

/* The displacement sum r(x) coef at x (and its gradient when g != NULL:
 * g[a][b] = d disp_a / d x_b), one fixed order per point. */
static void displacement(const ffd_rbf_morph *rbf, const double *coef, const double x[3], double d[3],
                         double g[3][3])
{
    const size_t N = rbf->count, M = N + 4;
    double s[3] = {0, 0, 0};
    if (g)
        memset(g, 0, 9 * sizeof(double));
    /* Wendland: only the control points of the 27 cells around x can be
     * within the radius (the others' terms are 0); else every one */
    const rbf_grid *grid = rbf->grid;
    size_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, cells = 0;
    if (grid && ffd_rbf_grid_range(grid, x, lo, hi))
        cells = (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1);
    for (size_t cell = 0, q = 0, end = grid ? 0 : N;;) {
        if (q == end) { /* the next cell */
            if (!grid || cell == cells)
                break;
            size_t dz = hi[2] - lo[2] + 1, dy = hi[1] - lo[1] + 1;
            size_t a = lo[0] + cell / (dy * dz), b = lo[1] + cell / dz % dy, c = lo[2] + cell % dz;
            size_t id = (a * grid->dim[1] + b) * grid->dim[2] + c;
            q = grid->start[id];
            end = grid->start[id + 1];
            cell++;
            continue;
        }
        const size_t j = grid ? grid->points[q] : q;
        q++;
        const double *c = rbf->rest + 3 * j;
        double e[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]};
        double r = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), dphi;
        double phi = ffd_rbf_phi(rbf->kernel, rbf->radius, rbf->power, r, g ? &dphi : NULL);
        for (int a = 0; a < 3; a++)
            s[a] += phi * coef[a * M + j];
        if (g && r > 0 && dphi != 0)
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    g[a][b] += dphi * e[b] / r * coef[a * M + j];
    }
    for (int a = 0; a < 3; a++) {
        const double *q = coef + a * M + N;
        d[a] = s[a] + (q[0] + q[1] * x[0] + q[2] * x[1] + q[3] * x[2]);
        if (g)
            for (int b = 0; b < 3; b++)
                g[a][b] += q[1 + b];
    }
}

ffd_status ffd_rbf_morph_eval(const ffd_rbf_morph *rbf, const double *points, size_t n, double *out,
                        ffd_error *err)
{
    (void)err;
    if (!rbf->moved) {
        memmove(out, points, n * 3 * sizeof *out);
        return FFD_OK;
    }
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        double d[3];
        displacement(rbf, rbf->coef, points + 3 * i, d, NULL);
        for (int a = 0; a < 3; a++)
            out[3 * i + a] = points[3 * i + a] + d[a];
    }
    return FFD_OK;
}

ffd_status ffd_rbf_morph_jacobian(const ffd_rbf_morph *rbf, const double *points, size_t n, double *out,
                            ffd_error *err)
{
    (void)err;
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        double d[3], g[3][3] = {{0}};
        if (rbf->moved)
            displacement(rbf, rbf->coef, points + 3 * i, d, g);
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                out[9 * i + 3 * a + b] = (a == b) + g[a][b];
    }
    return FFD_OK;
}

/* a(x) = (H^-1 r(x))[0..N): H is symmetric, so the cardinal functions are
 * one solve with the basis row as right-hand side. */
void ffd_rbf_morph_cardinal(const ffd_rbf_morph *rbf, const double x[3], double *weights)
{
    const size_t M = rbf->count + 4;
    basis_row(rbf, x, weights);
    if (system_solve(rbf, 1, weights, NULL))
        memset(weights, 0, M * sizeof *weights); /* sizes were checked at creation */
}

ffd_status ffd_rbf_morph_product(const ffd_rbf_morph *rbf, const double *points, size_t n, const double *v,
                           double *out, ffd_error *err)
{
    const size_t M = rbf->count + 4;
    double *coef = ffd_malloc_array(M, 3 * sizeof *coef);
    if (!coef)
        return ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory");
    ffd_status s = solve_coef(rbf, v, coef, err);
    if (!s) {
#pragma omp parallel for schedule(static)
        for (size_t i = 0; i < n; i++)
            displacement(rbf, coef, points + 3 * i, out + 3 * i, NULL);
    }
    ffd_free(coef);
    return s;
}

/* W^T w = E^T H^-1 R^T w (H symmetric): the basis rows weighted by w summed
 * in point order, one solve, the first N rows. */
ffd_status ffd_rbf_morph_transpose_product(const ffd_rbf_morph *rbf, const double *points, size_t n,
                                     const double *w, double *out, ffd_error *err)
{
    const size_t N = rbf->count, M = N + 4;
    double *g = ffd_calloc(M, 3 * sizeof *g), *row = ffd_malloc_array(M, sizeof *row);
    ffd_status s = FFD_OK;
    if (!g || !row) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "rbf: out of memory");
        goto done;
    }
    for (size_t i = 0; i < n; i++) {
        basis_row(rbf, points + 3 * i, row);
        for (int a = 0; a < 3; a++)
            for (size_t j = 0; j < M; j++)
                g[a * M + j] += row[j] * w[3 * i + a];
    }
    if ((s = system_solve(rbf, 3, g, err)))
        goto done;
    for (size_t j = 0; j < N; j++)
        for (int a = 0; a < 3; a++)
            out[3 * j + a] = g[a * M + j];
done:
    ffd_free(g);
    ffd_free(row);
    return s;
}

/* Row i of the linear map: the cardinal functions at point i, computed in
 * the caller's weights (max_row_nnz = N + 4 doubles: the solve's room). */
static size_t cardinal_row(const void *self, size_t i, uint32_t *columns, double *weights)
{
    const ffd_point_rows *rows = self;
    const ffd_rbf_morph *rbf = rows->morph;
    const size_t N = rbf->count;
    ffd_rbf_morph_cardinal(rbf, rows->points + 3 * i, weights);
    for (size_t j = 0; j < N; j++)
        columns[j] = (uint32_t)j;
    return N;
}

void ffd_rbf_morph_linear_map(const ffd_point_rows *rows, size_t n, ffd_linear_map *map)
{
    const ffd_rbf_morph *rbf = rows->morph;
    memset(map, 0, sizeof *map);
    map->self = rows;
    map->point_count = n;
    map->column_count = rbf->count;
    map->variable_count = rbf->count;
    map->max_row_nnz = rbf->count + 4;
    map->row = cardinal_row;
}
