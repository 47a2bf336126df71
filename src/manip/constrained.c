/* constrained — constrained FFD over any linear deformer (PyGeM's CFFD,
 * with its volume (VFFD) and barycentre (BFFD) cases; Sieger, Menzel &
 * Botsch, "Constrained space deformation for design optimization", 2014):
 * the minimal change of the requested control points P_req that satisfies
 * constraints g(P) = 0 on the deformed points X(P) = X_req + W (P - P_req)
 * or on the controls. Linear constraints are met in one step; the enclosed
 * volume is cubic in X, so the linearised constraints are iterated (Newton
 * on the Lagrange system reduced to its minimum-norm form):
 *   P_{k+1} = P_req + G_k^+ (G_k (P_k - P_req) - g(P_k)),  G_k = dg/dP (P_k)
 * which is the exact projection when g is linear and converges
 * quadratically to the nearest feasible P otherwise. */
#include "manip/manip.h"
#include "math/dense.h"

#include <math.h>
#include <string.h>

#define CFFD_TOL 1e-13       /* relative constraint residual reached */
#define CFFD_TOL_ROUNDING 1e-12 /* accepted when a Newton step no longer halves it */
#define CFFD_MAX_ITERATIONS 30

double ffd_cffd_volume(const double *x, const uint32_t *off, const uint32_t *idx, size_t nf)
{
    double v = 0;
    for (size_t f = 0; f < nf; f++) {
        const double *a = x + 3 * (size_t)idx[off[f]];
        for (uint32_t k = off[f] + 1; k + 1 < off[f + 1]; k++) {
            const double *b = x + 3 * (size_t)idx[k], *c = x + 3 * (size_t)idx[k + 1];
            v += a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) +
                 a[2] * (b[0] * c[1] - b[1] * c[0]);
        }
    }
    return v / 6.0;
}

/* dV/dx (n by 3, zeroed first): the triangle (a, b, c) adds (b x c)/6 to a,
 * (c x a)/6 to b and (a x b)/6 to c. */
static void volume_gradient(const double *x, const uint32_t *off, const uint32_t *idx, size_t nf,
                            size_t n, double *g)
{
    memset(g, 0, n * 3 * sizeof *g);
    for (size_t f = 0; f < nf; f++) {
        uint32_t ia = idx[off[f]];
        for (uint32_t k = off[f] + 1; k + 1 < off[f + 1]; k++) {
            uint32_t ib = idx[k], ic = idx[k + 1];
            const double *a = x + 3 * (size_t)ia, *b = x + 3 * (size_t)ib, *c = x + 3 * (size_t)ic;
            double bc[3] = {b[1] * c[2] - b[2] * c[1], b[2] * c[0] - b[0] * c[2],
                            b[0] * c[1] - b[1] * c[0]};
            double ca[3] = {c[1] * a[2] - c[2] * a[1], c[2] * a[0] - c[0] * a[2],
                            c[0] * a[1] - c[1] * a[0]};
            double ab[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                            a[0] * b[1] - a[1] * b[0]};
            for (int d = 0; d < 3; d++) {
                g[3 * (size_t)ia + d] += bc[d] / 6.0;
                g[3 * (size_t)ib + d] += ca[d] / 6.0;
                g[3 * (size_t)ic + d] += ab[d] / 6.0;
            }
        }
    }
}

/* W in compressed rows over controls (tied columns merged, fixed dropped). */
typedef struct {
    size_t *ptr;
    uint32_t *col;
    double *val;
} rows;

static ffd_status gather_rows(const ffd_linear_map *map, size_t controls, rows *w, ffd_error *err)
{
    size_t n = map->point_count, cap = map->max_row_nnz ? map->max_row_nnz : 1;
    uint32_t *cols = ffd_malloc_array(cap, sizeof *cols);
    double *ws = ffd_malloc_array(cap, sizeof *ws);
    w->ptr = ffd_malloc_array(n + 1, sizeof *w->ptr);
    w->col = ffd_malloc_array(n ? n : 1, cap * sizeof *w->col);
    w->val = ffd_malloc_array(n ? n : 1, cap * sizeof *w->val);
    if (!cols || !ws || !w->ptr || !w->col || !w->val) {
        ffd_free(cols);
        ffd_free(ws);
        return ffd_fail(err, FFD_ERR_NOMEM, "constrained FFD: out of memory for %zu rows", n);
    }
    size_t nnz = 0;
    w->ptr[0] = 0;
    for (size_t i = 0; i < n; i++) {
        size_t k = map->row(map->self, i, cols, ws);
        for (size_t e = 0; e < k; e++) {
            uint32_t c = map->tie ? map->tie[cols[e]] : cols[e];
            if (c == FFD_TIE_FIXED || ws[e] == 0.0)
                continue;
            if (c >= controls) {
                ffd_free(cols);
                ffd_free(ws);
                return ffd_fail(err, FFD_ERR_RANGE,
                                "constrained FFD: row %zu names control %u (%zu controls)", i, c,
                                controls);
            }
            size_t f = w->ptr[i];
            while (f < nnz && w->col[f] != c)
                f++;
            if (f == nnz) {
                w->col[nnz] = c;
                w->val[nnz++] = 0.0;
            }
            w->val[f] += ws[e];
        }
        w->ptr[i + 1] = nnz;
    }
    ffd_free(cols);
    ffd_free(ws);
    return FFD_OK;
}

static void rows_free(rows *w)
{
    ffd_free(w->ptr);
    ffd_free(w->col);
    ffd_free(w->val);
}

/* out (controls by 3) = W^T g for g (n by 3), per axis. */
static void transpose_product(const rows *w, size_t n, size_t controls, const double *g,
                              double *out)
{
    memset(out, 0, controls * 3 * sizeof *out);
    for (size_t i = 0; i < n; i++)
        for (size_t e = w->ptr[i]; e < w->ptr[i + 1]; e++)
            for (int d = 0; d < 3; d++)
                out[3 * (size_t)w->col[e] + d] += w->val[e] * g[3 * i + d];
}

ffd_status ffd_cffd_solve(const ffd_cffd_problem *pb, double *p_out, double *x_out,
                          double *residuals, ffd_cffd_result *result, ffd_error *err)
{
    const ffd_linear_map *map = pb->map;
    size_t n = map->point_count, nc = pb->control_count;
    size_t m = (pb->preserve_volume ? 1 : 0) + (pb->preserve_barycentre ? 3 : 0) + pb->linear_count;
    double scale = pb->scale > 0 ? pb->scale : 1.0;
    ffd_cffd_result res = {m, 0.0, 0.0, 0, 0};
    memcpy(p_out, pb->controls, nc * 3 * sizeof *p_out);
    memcpy(x_out, pb->points, n * 3 * sizeof *x_out);
    if (result)
        *result = res;
    if (m == 0)
        return FFD_OK;
    if (pb->preserve_volume && pb->face_count == 0)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "preserve: \"volume\": the mesh has no faces to enclose a volume");
    if (pb->preserve_barycentre && n == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "preserve: \"barycentre\": no points");
    for (size_t c = 0; c < pb->linear_count; c++)
        for (size_t t = 0; t < pb->linear[c].term_count; t++) {
            size_t bound = pb->linear[c].over == FFD_CFFD_OVER_CONTROLS ? nc : n;
            if (pb->linear[c].index[t] >= bound)
                return ffd_fail(err, FFD_ERR_RANGE,
                                "linear_constraints[%zu].terms[%zu]: %s %u out of range (%zu)", c,
                                t, pb->linear[c].over == FFD_CFFD_OVER_CONTROLS ? "control" : "point",
                                pb->linear[c].index[t], bound);
        }
    /* the free coordinates, in control-major order */
    size_t nv = 0;
    uint32_t *var = ffd_malloc_array(nc ? nc : 1, 3 * sizeof *var);
    double *cscale = ffd_malloc_array(m, sizeof *cscale), *g = ffd_malloc_array(m, sizeof *g);
    double *gx = ffd_malloc_array(n ? n : 1, 3 * sizeof *gx);
    double *gp = ffd_malloc_array(nc ? nc : 1, 3 * sizeof *gp);
    rows w = {NULL, NULL, NULL};
    double *G = NULL, *rhs = NULL;
    ffd_status st = FFD_OK;
    if (!var || !cscale || !g || !gx || !gp) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "constrained FFD: out of memory");
        goto done;
    }
    for (size_t v = 0; v < 3 * nc; v++)
        if (!pb->free || pb->free[v])
            var[nv++] = (uint32_t)v;
    if ((st = gather_rows(map, nc, &w, err)))
        goto done;
    size_t ld = m > nv ? m : nv;
    G = ffd_malloc_array(m, (nv ? nv : 1) * sizeof *G);
    rhs = ffd_malloc_array(ld ? ld : 1, sizeof *rhs);
    if (!G || !rhs) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "constrained FFD: out of memory for %zu by %zu", m, nv);
        goto done;
    }
    /* the scale of each constraint, for the relative residual */
    {
        size_t r = 0;
        if (pb->preserve_volume)
            cscale[r++] = fmax(fabs(pb->volume), scale * scale * scale * 1e-12);
        if (pb->preserve_barycentre)
            for (int d = 0; d < 3; d++)
                cscale[r++] = scale;
        for (size_t c = 0; c < pb->linear_count; c++) {
            double s = fabs(pb->linear[c].value);
            for (size_t t = 0; t < pb->linear[c].term_count; t++)
                s += fabs(pb->linear[c].coef[t]) * scale;
            cscale[r++] = s > 0 ? s : 1.0;
        }
    }
    for (size_t it = 0;; it++) {
        /* X(P) = X_req + W (P - P_req) */
        if (it > 0)
            for (size_t i = 0; i < n; i++)
                for (int d = 0; d < 3; d++) {
                    double s = pb->points[3 * i + d];
                    for (size_t e = w.ptr[i]; e < w.ptr[i + 1]; e++)
                        s += w.val[e] * (p_out[3 * (size_t)w.col[e] + d] -
                                         pb->controls[3 * (size_t)w.col[e] + d]);
                    x_out[3 * i + d] = s;
                }
        /* g(P) and the relative residual */
        size_t r = 0;
        if (pb->preserve_volume)
            g[r++] = ffd_cffd_volume(x_out, pb->face_offsets, pb->face_indices, pb->face_count) -
                     pb->volume;
        if (pb->preserve_barycentre) {
            double b[3] = {0, 0, 0};
            for (size_t i = 0; i < n; i++)
                for (int d = 0; d < 3; d++)
                    b[d] += x_out[3 * i + d];
            for (int d = 0; d < 3; d++)
                g[r++] = b[d] / (double)n - pb->barycentre[d];
        }
        for (size_t c = 0; c < pb->linear_count; c++) {
            const ffd_cffd_linear *L = &pb->linear[c];
            const double *X = L->over == FFD_CFFD_OVER_CONTROLS ? p_out : x_out;
            double s = -L->value;
            for (size_t t = 0; t < L->term_count; t++)
                s += L->coef[t] * X[3 * (size_t)L->index[t] + L->axis[t]];
            g[r++] = s;
        }
        double worst = 0;
        for (size_t c = 0; c < m; c++)
            worst = fmax(worst, fabs(g[c]) / cscale[c]);
        /* quadratic convergence ends in rounding: stop there */
        int stalled = it > 0 && worst <= CFFD_TOL_ROUNDING && worst > 0.5 * res.max_residual;
        res.max_residual = worst;
        res.iterations = it;
        if (worst <= CFFD_TOL || stalled)
            break;
        if (it == CFFD_MAX_ITERATIONS) {
            st = ffd_fail(err, FFD_ERR_NUMERIC,
                          "constrained FFD: the constraints are not met after %d Newton steps "
                          "(relative residual %.3g)",
                          CFFD_MAX_ITERATIONS, worst);
            goto done;
        }
        /* G = dg/dP over the free coordinates (m by nv, column-major) */
        r = 0;
        if (pb->preserve_volume) {
            volume_gradient(x_out, pb->face_offsets, pb->face_indices, pb->face_count, n, gx);
            transpose_product(&w, n, nc, gx, gp);
            for (size_t v = 0; v < nv; v++)
                G[v * m + r] = gp[var[v]];
            r++;
        }
        if (pb->preserve_barycentre) {
            for (int d = 0; d < 3; d++) {
                memset(gx, 0, n * 3 * sizeof *gx);
                for (size_t i = 0; i < n; i++)
                    gx[3 * i + d] = 1.0 / (double)n;
                transpose_product(&w, n, nc, gx, gp);
                for (size_t v = 0; v < nv; v++)
                    G[v * m + r] = gp[var[v]];
                r++;
            }
        }
        for (size_t c = 0; c < pb->linear_count; c++) {
            const ffd_cffd_linear *L = &pb->linear[c];
            memset(gp, 0, nc * 3 * sizeof *gp);
            if (L->over == FFD_CFFD_OVER_CONTROLS) {
                for (size_t t = 0; t < L->term_count; t++)
                    gp[3 * (size_t)L->index[t] + L->axis[t]] += L->coef[t];
            } else {
                for (size_t t = 0; t < L->term_count; t++) {
                    size_t i = L->index[t];
                    for (size_t e = w.ptr[i]; e < w.ptr[i + 1]; e++)
                        gp[3 * (size_t)w.col[e] + L->axis[t]] += L->coef[t] * w.val[e];
                }
            }
            for (size_t v = 0; v < nv; v++)
                G[v * m + r] = gp[var[v]];
            r++;
        }
        /* rhs = G (P_k - P_req) - g(P_k); the step d = G^+ rhs */
        for (size_t c = 0; c < m; c++) {
            double s = -g[c];
            for (size_t v = 0; v < nv; v++)
                s += G[v * m + c] * (p_out[var[v]] - pb->controls[var[v]]);
            rhs[c] = s;
        }
        for (size_t c = m; c < ld; c++)
            rhs[c] = 0;
        size_t rank = 0;
        if (nv == 0) {
            st = ffd_fail(err, FFD_ERR_NUMERIC,
                          "constrained FFD: constraint_mask leaves no coordinate free");
            goto done;
        }
        if ((st = ffd_dense_lstsq(m, nv, 1, G, rhs, 1e-12, &rank, err)))
            goto done;
        res.rank = rank;
        if (rank == 0) {
            st = ffd_fail(err, FFD_ERR_NUMERIC,
                          "constrained FFD: no free control coordinate moves the constrained "
                          "quantities (check constraint_mask)");
            goto done;
        }
        for (size_t v = 0; v < nv; v++)
            p_out[var[v]] = pb->controls[var[v]] + rhs[v];
    }
    if (residuals) {
        for (size_t c = 0; c < m; c++)
            residuals[c] = fabs(g[c]) / cscale[c];
    }
    {
        double s = 0;
        for (size_t v = 0; v < 3 * nc; v++) {
            double d = p_out[v] - pb->controls[v];
            s += d * d;
        }
        res.change_norm = sqrt(s);
    }
done:
    if (result)
        *result = res;
    ffd_free(var);
    ffd_free(cscale);
    ffd_free(g);
    ffd_free(gx);
    ffd_free(gp);
    ffd_free(G);
    ffd_free(rhs);
    rows_free(&w);
    return st;
}
