/* Tests of the proxy-driven ARAP solve (tsv_arap.c, design §6 and §4 item 8)
 * on synthetic regular grid graphs. */
#include "ffd.h"
#include "check.h"
#include "tspline/tsv.h"

#include <stdint.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* A regular grid graph: lattice edges along the axes, the 26-neighbourhood
 * as volumetric graph, the boundary quads as proxy (uv = in-plane grid
 * coordinates). With merge_hex, pairs of boundary quads on the z = max face
 * become hexagons with a hanging vertex on two sides. */
typedef struct grid {
    size_t nx, ny, nz, n;
    double h[3];
    double *p;
    uint32_t *edges, *vol, *poff, *pidx;
    double *puv;
    size_t ne, nvol, nf, ncorner;
    tsv_arap_graph g;
} grid;

static size_t gid(const grid *G, size_t i, size_t j, size_t k)
{
    return (i * G->ny + j) * G->nz + k;
}

static void grid_face(grid *G, const size_t *ids, const double *uv, size_t k)
{
    for (size_t c = 0; c < k; c++) {
        G->pidx[G->ncorner] = (uint32_t)ids[c];
        G->puv[2 * G->ncorner] = uv[2 * c];
        G->puv[2 * G->ncorner + 1] = uv[2 * c + 1];
        G->ncorner++;
    }
    G->nf++;
    G->poff[G->nf] = (uint32_t)G->ncorner;
}

static grid *grid_make(size_t nx, size_t ny, size_t nz, const double h[3], int merge_hex)
{
    grid *G = calloc(1, sizeof *G);
    G->nx = nx;
    G->ny = ny;
    G->nz = nz;
    G->n = nx * ny * nz;
    memcpy(G->h, h, sizeof G->h);
    G->p = malloc(3 * G->n * sizeof *G->p);
    G->edges = malloc(6 * G->n * sizeof *G->edges);
    G->vol = malloc(26 * G->n * sizeof *G->vol);
    size_t nres[3] = {nx, ny, nz};
    for (size_t i = 0; i < nx; i++)
        for (size_t j = 0; j < ny; j++)
            for (size_t k = 0; k < nz; k++) {
                size_t v = gid(G, i, j, k);
                size_t ijk[3] = {i, j, k};
                for (int a = 0; a < 3; a++)
                    G->p[3 * v + a] = h[a] * (double)ijk[a];
                for (int a = 0; a < 3; a++)
                    if (ijk[a] + 1 < nres[a]) {
                        size_t o[3] = {i, j, k};
                        o[a]++;
                        G->edges[2 * G->ne] = (uint32_t)v;
                        G->edges[2 * G->ne + 1] = (uint32_t)gid(G, o[0], o[1], o[2]);
                        G->ne++;
                    }
                for (int dx = -1; dx <= 1; dx++)
                    for (int dy = -1; dy <= 1; dy++)
                        for (int dz = -1; dz <= 1; dz++) {
                            int lex = dx != 0 ? dx : (dy != 0 ? dy : dz);
                            if (lex <= 0)
                                continue;
                            long a = (long)i + dx, b = (long)j + dy, c = (long)k + dz;
                            if (a < 0 || b < 0 || c < 0 || a >= (long)nx || b >= (long)ny ||
                                c >= (long)nz)
                                continue;
                            G->vol[2 * G->nvol] = (uint32_t)v;
                            G->vol[2 * G->nvol + 1] =
                                (uint32_t)gid(G, (size_t)a, (size_t)b, (size_t)c);
                            G->nvol++;
                        }
            }
    size_t maxf = 2 * (nx * ny + ny * nz + nx * nz);
    G->poff = malloc((maxf + 1) * sizeof *G->poff);
    G->pidx = malloc(6 * maxf * sizeof *G->pidx);
    G->puv = malloc(12 * maxf * sizeof *G->puv);
    G->poff[0] = 0;
    /* the six boundary faces: normal axis a, side s */
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        if (b > c) {
            int t = b;
            b = c;
            c = t;
        }
        for (int s = 0; s < 2; s++) {
            size_t fixed = s ? nres[a] - 1 : 0;
            int hex = merge_hex && a == 2 && s == 1;
            for (size_t u = 0; u + 1 < nres[b]; u++) {
                if (hex && u + 2 < nres[b] && u % 2 == 0) {
                    for (size_t w = 0; w + 1 < nres[c]; w++) {
                        size_t ids[6];
                        double uv[12];
                        const size_t cu[6] = {u, u + 1, u + 2, u + 2, u + 1, u};
                        const size_t cw[6] = {w, w, w, w + 1, w + 1, w + 1};
                        for (int q = 0; q < 6; q++) {
                            size_t ijk[3];
                            ijk[a] = fixed;
                            ijk[b] = cu[q];
                            ijk[c] = cw[q];
                            ids[q] = gid(G, ijk[0], ijk[1], ijk[2]);
                            uv[2 * q] = (double)cu[q];
                            uv[2 * q + 1] = (double)cw[q];
                        }
                        grid_face(G, ids, uv, 6);
                    }
                    continue;
                }
                if (hex && u % 2 == 1)
                    continue; /* covered by the hexagon started at u - 1 */
                for (size_t w = 0; w + 1 < nres[c]; w++) {
                    size_t ids[4];
                    double uv[8];
                    const size_t cu[4] = {u, u + 1, u + 1, u};
                    const size_t cw[4] = {w, w, w + 1, w + 1};
                    for (int q = 0; q < 4; q++) {
                        size_t ijk[3];
                        ijk[a] = fixed;
                        ijk[b] = cu[q];
                        ijk[c] = cw[q];
                        ids[q] = gid(G, ijk[0], ijk[1], ijk[2]);
                        uv[2 * q] = (double)cu[q];
                        uv[2 * q + 1] = (double)cw[q];
                    }
                    grid_face(G, ids, uv, 4);
                }
            }
        }
    }
    G->g.n = G->n;
    G->g.ref = G->p;
    G->g.edges = G->edges;
    G->g.edge_count = G->ne;
    G->g.vol = G->vol;
    G->g.vol_count = G->nvol;
    G->g.proxy_offsets = G->poff;
    G->g.proxy_indices = G->pidx;
    G->g.proxy_face_count = G->nf;
    G->g.proxy_uv = G->puv;
    return G;
}

static void grid_free(grid *G)
{
    if (!G)
        return;
    free(G->p);
    free(G->edges);
    free(G->vol);
    free(G->poff);
    free(G->pidx);
    free(G->puv);
    free(G);
}

static int on_boundary(const grid *G, size_t v)
{
    size_t k = v % G->nz, j = (v / G->nz) % G->ny, i = v / (G->nz * G->ny);
    return i == 0 || j == 0 || k == 0 || i + 1 == G->nx || j + 1 == G->ny || k + 1 == G->nz;
}

static const tsv_arap_weights paper_weights = {1.0, 2.0 / 3.0, 0.5, 1.0};

static double max_diff(const double *a, const double *b, size_t n)
{
    double m = 0.0;
    for (size_t i = 0; i < n; i++)
        m = fmax(m, fabs(a[i] - b[i]));
    return m;
}

/* Rotation by angle about unit axis through centre c. */
static void rotate(const double axis[3], double angle, const double c[3], const double *in,
                   double *out)
{
    double x = axis[0], y = axis[1], z = axis[2], cs = cos(angle), sn = sin(angle), t = 1 - cs;
    double R[9] = {t * x * x + cs,     t * x * y - sn * z, t * x * z + sn * y,
                   t * x * y + sn * z, t * y * y + cs,     t * y * z - sn * x,
                   t * x * z - sn * y, t * y * z + sn * x, t * z * z + cs};
    double d[3] = {in[0] - c[0], in[1] - c[1], in[2] - c[2]};
    for (int r = 0; r < 3; r++)
        out[r] = c[r] + R[3 * r] * d[0] + R[3 * r + 1] * d[1] + R[3 * r + 2] * d[2];
}

/* ---- (1) targets = positions reproduce the reference ---- */
static void test_identity(void)
{
    const double h[3] = {1.0, 0.8, 1.3};
    for (int hex = 0; hex < 2; hex++)
        for (int mode = 0; mode < 3; mode++) {
            grid *G = grid_make(6, 5, 4, h, hex);
            uint8_t *roles = calloc(G->n, 1);
            /* boundary hard / a few soft handles / mixed */
            for (size_t v = 0; v < G->n; v++)
                if (mode == 0)
                    roles[v] = on_boundary(G, v) ? TSV_HARD : TSV_FREE;
                else if (mode == 1)
                    roles[v] = v % 7 == 0 ? TSV_SOFT : TSV_FREE;
                else
                    roles[v] = v % 11 == 0 ? TSV_HARD : (v % 5 == 0 ? TSV_SOFT : TSV_FREE);
            tsv_arap *a = NULL;
            CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL));
            double *x = malloc(3 * G->n * sizeof *x);
            memcpy(x, G->p, 3 * G->n * sizeof *x);
            CHECK_OK(ffd_tsv_arap_solver_solve(a, G->p, x, 5, NULL));
            CHECK(max_diff(x, G->p, 3 * G->n) <= 1e-10);
            ffd_tsv_arap_solver_destroy(a);
            free(x);
            free(roles);
            grid_free(G);
        }
}

/* ---- (2) translating all handles translates the whole lattice ---- */
static void test_translation(void)
{
    const double h[3] = {1.0, 0.8, 1.3}, t[3] = {0.7, -1.9, 0.25};
    for (int hex = 0; hex < 2; hex++)
        for (int soft = 0; soft < 2; soft++) {
            grid *G = grid_make(6, 5, 4, h, hex);
            uint8_t *roles = calloc(G->n, 1);
            double *q = malloc(3 * G->n * sizeof *q), *x = malloc(3 * G->n * sizeof *x);
            for (size_t v = 0; v < G->n; v++) {
                roles[v] = on_boundary(G, v) ? (soft ? TSV_SOFT : TSV_HARD) : TSV_FREE;
                for (int c = 0; c < 3; c++)
                    q[3 * v + c] = G->p[3 * v + c] + t[c];
            }
            tsv_arap *a = NULL;
            CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL));
            memcpy(x, G->p, 3 * G->n * sizeof *x);
            CHECK_OK(ffd_tsv_arap_solver_solve(a, q, x, 5, NULL));
            CHECK(max_diff(x, q, 3 * G->n) <= 1e-10);
            ffd_tsv_arap_solver_destroy(a);
            free(roles);
            free(q);
            free(x);
            grid_free(G);
        }
}

/* ---- (3) a rigid rotation of all boundary handles gives a near-rigid lattice ---- */
static void test_rigid_rotation(void)
{
    const double h[3] = {1.0, 0.8, 1.3};
    double axis[3] = {1.0, 2.0, 0.5};
    double na = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    for (int c = 0; c < 3; c++)
        axis[c] /= na;
    /* handles: the whole boundary, or only the 8 corners (the proxy Laplacian,
     * hexagons included, then acts on the free boundary) */
    for (int run = 0; run < 4; run++) {
        int hex = run & 1, corners = run >> 1;
        grid *G = grid_make(6, 5, 4, h, hex);
        const double ctr[3] = {2.5, 1.6, 1.95};
        uint8_t *roles = calloc(G->n, 1);
        double *q = malloc(3 * G->n * sizeof *q), *x = malloc(3 * G->n * sizeof *x);
        for (size_t v = 0; v < G->n; v++) {
            size_t k = v % G->nz, j = (v / G->nz) % G->ny, i = v / (G->nz * G->ny);
            int corner = (i == 0 || i + 1 == G->nx) && (j == 0 || j + 1 == G->ny) &&
                         (k == 0 || k + 1 == G->nz);
            roles[v] = (corners ? corner : on_boundary(G, v)) ? TSV_HARD : TSV_FREE;
            rotate(axis, 40.0 * M_PI / 180.0, ctr, G->p + 3 * v, q + 3 * v);
        }
        tsv_arap *a = NULL;
        CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL));
        memcpy(x, G->p, 3 * G->n * sizeof *x);
        CHECK_OK(ffd_tsv_arap_solver_solve(a, q, x, 1, NULL));
        double first = max_diff(x, q, 3 * G->n);
        CHECK_OK(ffd_tsv_arap_solver_solve(a, q, x, corners ? 99 : 29, NULL)); /* warm start */
        double after = max_diff(x, q, 3 * G->n);
        CHECK(first > 1e-2); /* the first solve (R = I) is not rigid */
        CHECK(after <= 1e-6);
        ffd_tsv_arap_solver_destroy(a);
        free(roles);
        free(q);
        free(x);
        grid_free(G);
    }
}

/* Dense reference of one solve with R = I, from the energy written out
 * independently: quads of a rectangular grid have cotangent weight b/(2a)
 * on an edge of length a with the other side b (diagonals 0). */
static void dense_reference(const grid *G, const uint8_t *roles, const tsv_arap_weights *w,
                            const double *q, double *x)
{
    size_t n = G->n;
    double *A = calloc(n * n, sizeof *A), *B = calloc(3 * n, sizeof *B);
    double *row = calloc(n, sizeof *row), *Lp = malloc(3 * sizeof *Lp);
    /* one-form: each directed edge */
    for (size_t e = 0; e < G->ne; e++)
        for (int dir = 0; dir < 2; dir++) {
            size_t i = G->edges[2 * e + dir], j = G->edges[2 * e + 1 - dir];
            A[i * n + i] += w->one_form;
            A[j * n + j] += w->one_form;
            A[i * n + j] -= w->one_form;
            A[j * n + i] -= w->one_form;
            for (int c = 0; c < 3; c++) {
                double t = G->p[3 * j + c] - G->p[3 * i + c];
                B[3 * j + c] += w->one_form * t;
                B[3 * i + c] -= w->one_form * t;
            }
        }
    /* Laplacian rows: 0 = proxy (M \ C), 1 = volumetric */
    double *W = calloc(n * n, sizeof *W);
    for (int op = 0; op < 2; op++) {
        memset(W, 0, n * n * sizeof *W);
        double wt = op == 0 ? w->proxy : w->volume;
        if (op == 0) {
            for (size_t f = 0; f < G->nf; f++) {
                const uint32_t *id = G->pidx + G->poff[f];
                for (int k = 0; k < 4; k++) {
                    size_t i = id[k], j = id[(k + 1) % 4], o = id[(k + 2) % 4];
                    double la = 0, lb = 0;
                    for (int c = 0; c < 3; c++) {
                        la += (G->p[3 * j + c] - G->p[3 * i + c]) * (G->p[3 * j + c] - G->p[3 * i + c]);
                        lb += (G->p[3 * o + c] - G->p[3 * j + c]) * (G->p[3 * o + c] - G->p[3 * j + c]);
                    }
                    double cw = 0.5 * sqrt(lb) / sqrt(la);
                    W[i * n + j] += cw;
                    W[j * n + i] += cw;
                }
            }
        } else {
            for (size_t e = 0; e < G->nvol; e++) {
                size_t i = G->vol[2 * e], j = G->vol[2 * e + 1];
                double l = 0;
                for (int c = 0; c < 3; c++)
                    l += (G->p[3 * j + c] - G->p[3 * i + c]) * (G->p[3 * j + c] - G->p[3 * i + c]);
                W[i * n + j] = W[j * n + i] = 1.0 / sqrt(l);
            }
        }
        for (size_t i = 0; i < n; i++) {
            if (op == 0 && roles[i] != TSV_FREE)
                continue;
            double s = 0;
            for (size_t j = 0; j < n; j++)
                s += W[i * n + j];
            if (s == 0)
                continue;
            for (size_t j = 0; j < n; j++)
                row[j] = (j == i ? 1.0 : 0.0) - W[i * n + j] / s;
            for (int c = 0; c < 3; c++) {
                Lp[c] = 0;
                for (size_t j = 0; j < n; j++)
                    Lp[c] += row[j] * G->p[3 * j + c];
            }
            for (size_t j = 0; j < n; j++) {
                if (row[j] == 0)
                    continue;
                for (size_t k = 0; k < n; k++)
                    A[j * n + k] += wt * row[j] * row[k];
                for (int c = 0; c < 3; c++)
                    B[3 * j + c] += wt * row[j] * Lp[c];
            }
        }
    }
    for (size_t i = 0; i < n; i++)
        if (roles[i] == TSV_SOFT) {
            A[i * n + i] += w->target;
            for (int c = 0; c < 3; c++)
                B[3 * i + c] += w->target * q[3 * i + c];
        }
    /* hard rows: eliminate, then Gaussian elimination on the free block */
    for (size_t i = 0; i < n; i++)
        if (roles[i] == TSV_HARD)
            for (size_t j = 0; j < n; j++) {
                if (roles[j] == TSV_HARD)
                    continue;
                for (int c = 0; c < 3; c++)
                    B[3 * j + c] -= A[j * n + i] * q[3 * i + c];
            }
    for (size_t i = 0; i < n; i++)
        if (roles[i] == TSV_HARD) {
            for (size_t j = 0; j < n; j++)
                A[i * n + j] = A[j * n + i] = 0;
            A[i * n + i] = 1;
            for (int c = 0; c < 3; c++)
                B[3 * i + c] = q[3 * i + c];
        }
    for (size_t k = 0; k < n; k++) {
        for (size_t i = k + 1; i < n; i++) {
            double f = A[i * n + k] / A[k * n + k];
            if (f == 0)
                continue;
            for (size_t j = k; j < n; j++)
                A[i * n + j] -= f * A[k * n + j];
            for (int c = 0; c < 3; c++)
                B[3 * i + c] -= f * B[3 * k + c];
        }
    }
    for (size_t k = n; k-- > 0;)
        for (int c = 0; c < 3; c++) {
            double s = B[3 * k + c];
            for (size_t j = k + 1; j < n; j++)
                s -= A[k * n + j] * x[3 * j + c];
            x[3 * k + c] = s / A[k * n + k];
        }
    free(A);
    free(B);
    free(W);
    free(row);
    free(Lp);
}

/* ---- (4) the cached factor equals a fresh create + solve; one solve equals the dense energy ---- */
static void test_cached_equals_fresh(void)
{
    const double h[3] = {1.0, 0.8, 1.3};
    grid *G = grid_make(6, 5, 4, h, 0);
    size_t n = G->n;
    uint8_t *roles = calloc(n, 1);
    double *q0 = malloc(3 * n * sizeof *q0), *q1 = malloc(3 * n * sizeof *q1);
    double *xa = malloc(3 * n * sizeof *xa), *xb = malloc(3 * n * sizeof *xb);
    double *xd = malloc(3 * n * sizeof *xd);
    for (size_t v = 0; v < n; v++) {
        roles[v] = v % 13 == 0 ? TSV_HARD : (v % 17 == 0 ? TSV_SOFT : TSV_FREE);
        for (int c = 0; c < 3; c++) {
            q0[3 * v + c] = G->p[3 * v + c] + 0.3 * (check_rand01() - 0.5);
            q1[3 * v + c] = G->p[3 * v + c] + 0.6 * (check_rand01() - 0.5);
        }
    }
    /* one solve with R = I against the dense reference */
    tsv_arap *a = NULL, *b = NULL;
    CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL));
    memcpy(xa, G->p, 3 * n * sizeof *xa);
    CHECK_OK(ffd_tsv_arap_solver_solve(a, q0, xa, 1, NULL));
    dense_reference(G, roles, &paper_weights, q0, xd);
    CHECK(max_diff(xa, xd, 3 * n) <= 1e-10);
    /* a: q0 then q1 on the cached factor; b: a fresh object through the same sequence */
    CHECK_OK(ffd_tsv_arap_solver_solve(a, q0, xa, 4, NULL));
    CHECK_OK(ffd_tsv_arap_solver_solve(a, q1, xa, 5, NULL));
    CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &b, NULL));
    memcpy(xb, G->p, 3 * n * sizeof *xb);
    CHECK_OK(ffd_tsv_arap_solver_solve(b, q0, xb, 5, NULL));
    CHECK_OK(ffd_tsv_arap_solver_solve(b, q1, xb, 5, NULL));
    CHECK(max_diff(xa, xb, 3 * n) <= 1e-12);
    ffd_tsv_arap_solver_destroy(a);
    ffd_tsv_arap_solver_destroy(b);
    free(roles);
    free(q0);
    free(q1);
    free(xa);
    free(xb);
    free(xd);
    grid_free(G);
}

/* ---- (5) soft mode with only the target term reaches the targets ---- */
static void test_soft_targets(void)
{
    const double h[3] = {1.0, 0.8, 1.3};
    grid *G = grid_make(6, 5, 4, h, 0);
    size_t n = G->n;
    uint8_t *roles = malloc(n);
    double *q = malloc(3 * n * sizeof *q), *x = malloc(3 * n * sizeof *x);
    for (size_t v = 0; v < n; v++) {
        roles[v] = TSV_SOFT;
        for (int c = 0; c < 3; c++)
            q[3 * v + c] = G->p[3 * v + c] + (check_rand01() - 0.5);
    }
    const tsv_arap_weights w = {1e-9, 1e-9, 1e-9, 1.0};
    tsv_arap *a = NULL;
    CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &w, &a, NULL));
    memcpy(x, G->p, 3 * n * sizeof *x);
    CHECK_OK(ffd_tsv_arap_solver_solve(a, q, x, 3, NULL));
    CHECK(max_diff(x, q, 3 * n) <= 1e-7);
    ffd_tsv_arap_solver_destroy(a);
    /* with the paper's weights a soft handle lags its target but moves towards it */
    for (size_t v = 0; v < n; v++)
        roles[v] = v == 0 ? TSV_SOFT : (v + 1 == n ? TSV_HARD : TSV_FREE);
    for (size_t v = 0; v < n; v++)
        for (int c = 0; c < 3; c++)
            q[3 * v + c] = G->p[3 * v + c] + (v == 0 ? -0.5 : 0.0);
    CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL));
    memcpy(x, G->p, 3 * n * sizeof *x);
    CHECK_OK(ffd_tsv_arap_solver_solve(a, q, x, 5, NULL));
    for (int c = 0; c < 3; c++) {
        CHECK(x[c] < G->p[c] - 1e-3);
        CHECK(x[c] > q[c] + 1e-3);
    }
    ffd_tsv_arap_solver_destroy(a);
    free(roles);
    free(q);
    free(x);
    grid_free(G);
}

/* ---- (6) invalid input ---- */
static void test_invalid(void)
{
    const double h[3] = {1.0, 1.0, 1.0};
    grid *G = grid_make(4, 4, 4, h, 0);
    uint8_t *roles = calloc(G->n, 1);
    tsv_arap *a = NULL;
    ffd_error e = {{0}};
    CHECK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, &e) == FFD_ERR_INVALID);
    CHECK(a == NULL);
    CHECK(strstr(e.message, "nothing constrained") != NULL);
    roles[3] = 7;
    CHECK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL) == FFD_ERR_INVALID);
    roles[3] = TSV_SOFT;
    tsv_arap_weights w = paper_weights;
    w.target = 0.0;
    CHECK(ffd_tsv_arap_solver_create(&G->g, roles, &w, &a, NULL) == FFD_ERR_INVALID);
    w.volume = -1.0;
    CHECK(ffd_tsv_arap_solver_create(&G->g, roles, &w, &a, NULL) == FFD_ERR_INVALID);
    G->edges[5] = (uint32_t)G->n;
    CHECK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL) == FFD_ERR_RANGE);
    G->edges[5] = 0;
    G->p[7] = NAN;
    CHECK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL) == FFD_ERR_NONFINITE);
    G->p[7] = 1.0;
    /* a component without any constraint: not positive definite */
    const tsv_arap_weights only_edges = {1.0, 0.0, 0.0, 1.0};
    tsv_arap_graph g2 = G->g;
    g2.edge_count = 1; /* only one edge: most points are disconnected */
    g2.vol_count = 0;
    g2.proxy_face_count = 0;
    memset(roles, 0, G->n);
    roles[G->edges[0]] = TSV_HARD;
    CHECK(ffd_tsv_arap_solver_create(&g2, roles, &only_edges, &a, &e) == FFD_ERR_NUMERIC);
    CHECK(strstr(e.message, "positive definite") != NULL);
    /* all hard: the targets come back */
    memset(roles, TSV_HARD, G->n);
    CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL));
    double *q = malloc(3 * G->n * sizeof *q), *x = calloc(3 * G->n, sizeof *x);
    for (size_t i = 0; i < 3 * G->n; i++)
        q[i] = check_rand01();
    CHECK_OK(ffd_tsv_arap_solver_solve(a, q, x, 5, NULL));
    CHECK(memcmp(x, q, 3 * G->n * sizeof *x) == 0);
    q[4] = INFINITY;
    CHECK(ffd_tsv_arap_solver_solve(a, q, x, 5, NULL) == FFD_ERR_NONFINITE);
    ffd_tsv_arap_solver_destroy(a);
    ffd_tsv_arap_solver_destroy(NULL);
    free(q);
    free(x);
    free(roles);
    grid_free(G);
}

/* ---- (7) hard rows equal their targets exactly ---- */
static void test_hard_exact(void)
{
    const double h[3] = {1.0, 0.8, 1.3};
    grid *G = grid_make(6, 5, 4, h, 1);
    size_t n = G->n;
    uint8_t *roles = calloc(n, 1);
    double *q = malloc(3 * n * sizeof *q), *x = malloc(3 * n * sizeof *x);
    for (size_t v = 0; v < n; v++) {
        roles[v] = v % 9 == 0 ? TSV_HARD : (v % 10 == 0 ? TSV_SOFT : TSV_FREE);
        for (int c = 0; c < 3; c++)
            q[3 * v + c] = G->p[3 * v + c] + 0.7 * (check_rand01() - 0.5);
    }
    tsv_arap *a = NULL;
    CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL));
    memcpy(x, G->p, 3 * n * sizeof *x);
    CHECK_OK(ffd_tsv_arap_solver_solve(a, q, x, 5, NULL));
    for (size_t v = 0; v < n; v++)
        if (roles[v] == TSV_HARD)
            for (int c = 0; c < 3; c++)
                CHECK(x[3 * v + c] == q[3 * v + c]);
    ffd_tsv_arap_solver_destroy(a);
    free(roles);
    free(q);
    free(x);
    grid_free(G);
}

/* ---- (8) a drag: one corner handle, the opposite face frozen ---- */
static void test_drag_symmetric(void)
{
    const double h[3] = {1.0, 1.0, 0.7}; /* x <-> y mirror symmetric */
    grid *G = grid_make(5, 5, 4, h, 0);
    size_t n = G->n;
    uint8_t *roles = calloc(n, 1);
    double *q = malloc(3 * n * sizeof *q), *x = malloc(3 * n * sizeof *x);
    memcpy(q, G->p, 3 * n * sizeof *q);
    size_t handle = gid(G, 4, 4, 3);
    for (size_t i = 0; i < 5; i++)
        for (size_t j = 0; j < 5; j++)
            roles[gid(G, i, j, 0)] = TSV_HARD;
    roles[handle] = TSV_HARD;
    q[3 * handle] += 0.8;
    q[3 * handle + 1] += 0.8;
    q[3 * handle + 2] += 1.1;
    tsv_arap *a = NULL;
    CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL));
    memcpy(x, G->p, 3 * n * sizeof *x);
    CHECK_OK(ffd_tsv_arap_solver_solve(a, q, x, 5, NULL));
    int finite = 1;
    for (size_t k = 0; k < 3 * n; k++)
        finite &= isfinite(x[k]) != 0;
    CHECK(finite);
    /* mean displacement per layer grows towards the handle */
    double layer[4] = {0};
    for (size_t i = 0; i < 5; i++)
        for (size_t j = 0; j < 5; j++)
            for (size_t k = 0; k < 4; k++) {
                size_t v = gid(G, i, j, k);
                double d = 0;
                for (int c = 0; c < 3; c++)
                    d += (x[3 * v + c] - G->p[3 * v + c]) * (x[3 * v + c] - G->p[3 * v + c]);
                layer[k] += sqrt(d) / 25.0;
            }
    CHECK(layer[0] == 0.0);
    CHECK(layer[1] > 1e-3);
    CHECK(layer[3] > layer[2] && layer[2] > layer[1]);
    /* the far corner of the top face moves less than the handle's neighbours */
    size_t far = gid(G, 0, 0, 3), near = gid(G, 3, 4, 3);
    double dfar = 0, dnear = 0;
    for (int c = 0; c < 3; c++) {
        dfar += pow(x[3 * far + c] - G->p[3 * far + c], 2);
        dnear += pow(x[3 * near + c] - G->p[3 * near + c], 2);
    }
    CHECK(dnear > dfar);
    /* mirror x <-> y */
    double asym = 0;
    for (size_t i = 0; i < 5; i++)
        for (size_t j = 0; j < 5; j++)
            for (size_t k = 0; k < 4; k++) {
                size_t v = gid(G, i, j, k), m = gid(G, j, i, k);
                asym = fmax(asym, fabs(x[3 * v] - x[3 * m + 1]));
                asym = fmax(asym, fabs(x[3 * v + 1] - x[3 * m]));
                asym = fmax(asym, fabs(x[3 * v + 2] - x[3 * m + 2]));
            }
    CHECK(asym <= 1e-9);
    ffd_tsv_arap_solver_destroy(a);
    free(roles);
    free(q);
    free(x);
    grid_free(G);
}

/* ---- hexagons (ear clipping, hanging vertices) give the quads' cotangent Laplacian on a rectangular grid ---- */
static void test_hexagon_proxy(void)
{
    const double h[3] = {1.0, 0.8, 1.3};
    double *xs[2];
    size_t n = 0;
    for (int hex = 0; hex < 2; hex++) {
        grid *G = grid_make(6, 5, 4, h, hex);
        n = G->n;
        uint8_t *roles = calloc(n, 1);
        double *q = malloc(3 * n * sizeof *q);
        xs[hex] = malloc(3 * n * sizeof *xs[hex]);
        memcpy(q, G->p, 3 * n * sizeof *q);
        for (size_t i = 0; i < 6; i++)
            for (size_t j = 0; j < 5; j++)
                roles[gid(G, i, j, 0)] = TSV_HARD;
        size_t hd = gid(G, 2, 2, 3);
        roles[hd] = TSV_HARD;
        q[3 * hd] += 0.4;
        q[3 * hd + 2] += 0.9;
        tsv_arap *a = NULL;
        CHECK_OK(ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, NULL));
        memcpy(xs[hex], G->p, 3 * n * sizeof *q);
        CHECK_OK(ffd_tsv_arap_solver_solve(a, q, xs[hex], 5, NULL));
        ffd_tsv_arap_solver_destroy(a);
        free(roles);
        free(q);
        grid_free(G);
    }
    CHECK(max_diff(xs[0], xs[1], 3 * n) <= 1e-12);
    free(xs[0]);
    free(xs[1]);
}

/* ---- (9) allocation failures: FFD_ERR_NOMEM and no leaks (CHOLMOD included) ---- */
static void test_out_of_memory(void)
{
    const double h[3] = {1.0, 0.8, 1.3};
    grid *G = grid_make(4, 4, 3, h, 1);
    size_t n = G->n;
    uint8_t *roles = calloc(n, 1);
    double *q = malloc(3 * n * sizeof *q), *x = malloc(3 * n * sizeof *x);
    for (size_t v = 0; v < n; v++) {
        roles[v] = v % 5 == 0 ? TSV_HARD : (v % 7 == 0 ? TSV_SOFT : TSV_FREE);
        for (int c = 0; c < 3; c++)
            q[3 * v + c] = G->p[3 * v + c] + 0.2 * (check_rand01() - 0.5);
    }
    long failures = 0, in_cholmod = 0;
    for (long k = 0;; k++) {
        fail_alloc fa = {k, 0};
        ffd_allocator al = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&al);
        tsv_arap *a = NULL;
        ffd_error e = {{0}};
        ffd_status st = ffd_tsv_arap_solver_create(&G->g, roles, &paper_weights, &a, &e);
        memcpy(x, G->p, 3 * n * sizeof *x);
        if (st == FFD_OK)
            st = ffd_tsv_arap_solver_solve(a, q, x, 3, &e);
        in_cholmod += st == FFD_ERR_NOMEM && strstr(e.message, "CHOLMOD") != NULL;
        ffd_tsv_arap_solver_destroy(a);
        ffd_set_allocator(NULL);
        CHECK(st == FFD_OK || st == FFD_ERR_NOMEM);
        if (st == FFD_OK)
            break;
        failures++;
        if (k > 100000) {
            CHECK(0);
            break;
        }
    }
    CHECK(failures > 40);
    /* CHOLMOD allocates through the library allocator too */
    CHECK(in_cholmod > 10);
    free(roles);
    free(q);
    free(x);
    grid_free(G);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"identity", test_identity},
        {"translation", test_translation},
        {"rigid_rotation", test_rigid_rotation},
        {"cached_equals_fresh", test_cached_equals_fresh},
        {"soft_targets", test_soft_targets},
        {"invalid", test_invalid},
        {"hard_exact", test_hard_exact},
        {"drag_symmetric", test_drag_symmetric},
        {"hexagon_proxy", test_hexagon_proxy},
        {"out_of_memory", test_out_of_memory},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
