/* Tailored cubic T-spline volume (Zhang, Zheng & Cai 2020): lattice, ray
 * casting, evaluation and exact local refinement — the verification recipe
 * of design §4 items 1-7. */
#include "check.h"
#include "tspline/tsv.h"

#include <stdint.h>
#include <time.h>
#ifdef _OPENMP
#include <omp.h>
#endif

static double rnd(double a, double b)
{
    return a + (b - a) * check_rand01();
}

static uint32_t rndi(size_t n)
{
    uint32_t i = (uint32_t)(check_rand01() * (double)n);
    return i >= n ? (uint32_t)n - 1 : i;
}

static const double BOX_MIN[3] = {-1.0, 0.5, 2.0};
static const double BOX_MAX[3] = {2.0, 1.5, 4.5};

static double box_diag(void)
{
    double s = 0.0;
    for (int a = 0; a < 3; a++)
        s += (BOX_MAX[a] - BOX_MIN[a]) * (BOX_MAX[a] - BOX_MIN[a]);
    return sqrt(s);
}

static tsv_lattice *make_lattice(uint32_t r0, uint32_t r1, uint32_t r2)
{
    uint32_t res[3] = {r0, r1, r2};
    tsv_lattice *L = NULL;
    CHECK_OK(ffd_tsv_lattice_create(BOX_MIN, BOX_MAX, res, &L, NULL));
    return L;
}

/* CURRENT = rest + noise of 10% of the cell size (so the map is not affine). */
static void add_noise(tsv_lattice *L)
{
    for (size_t v = 0; v < L->nv; v++)
        for (int a = 0; a < 3; a++) {
            double h = (BOX_MAX[a] - BOX_MIN[a]) / (double)(L->res[a] - 3);
            L->verts[v].P[TSV_CURRENT][a] = L->verts[v].P[TSV_REST][a] + rnd(-0.1, 0.1) * h;
        }
}

/* ---------------------------------------------------------------------
 * An independent clamped uniform tensor B-spline (Piegl & Tiller A2.1/A2.2)
 * --------------------------------------------------------------------- */

static void bspline_knots(uint32_t n, double *U)
{
    /* n control points, degree 3: n + 4 knots 0,0,0,0,k,...,1,1,1,1 */
    uint32_t m = n + 4;
    for (uint32_t i = 0; i < m; i++) {
        if (i < 4)
            U[i] = 0.0;
        else if (i >= n)
            U[i] = 1.0;
        else
            U[i] = (double)(i - 3) / (double)(n - 3);
    }
}

static uint32_t find_span(uint32_t n, const double *U, double u)
{
    if (u >= U[n])
        return n - 1;
    uint32_t lo = 3, hi = n;
    uint32_t mid = (lo + hi) / 2;
    while (u < U[mid] || u >= U[mid + 1]) {
        if (u < U[mid])
            hi = mid;
        else
            lo = mid;
        mid = (lo + hi) / 2;
    }
    return mid;
}

static void basis_funs(uint32_t i, double u, const double *U, double N[4])
{
    double left[4], right[4];
    N[0] = 1.0;
    for (int j = 1; j <= 3; j++) {
        left[j] = u - U[i + 1 - j];
        right[j] = U[i + j] - u;
        double saved = 0.0;
        for (int r = 0; r < j; r++) {
            double tmp = N[r] / (right[r + 1] + left[j - r]);
            N[r] = saved + right[r + 1] * tmp;
            saved = left[j - r] * tmp;
        }
        N[j] = saved;
    }
}

static void tensor_eval(const tsv_lattice *L, const double stu[3], double out[3])
{
    uint32_t n[3] = {L->res[0], L->res[1], L->res[2]};
    double U[3][300], N[3][4];
    uint32_t span[3];
    for (int a = 0; a < 3; a++) {
        bspline_knots(n[a], U[a]);
        span[a] = find_span(n[a], U[a], stu[a]);
        basis_funs(span[a], stu[a], U[a], N[a]);
    }
    out[0] = out[1] = out[2] = 0.0;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            for (int l = 0; l < 4; l++) {
                uint32_t I = span[0] - 3 + i, J = span[1] - 3 + j, K = span[2] - 3 + l;
                const double *P = L->verts[((size_t)I * n[1] + J) * n[2] + K].P[TSV_CURRENT];
                double b = N[0][i] * N[1][j] * N[2][l];
                for (int r = 0; r < 3; r++)
                    out[r] += b * P[r];
            }
}

/* ---------------------------------------------------------------------
 * 1. Piece split (design §3.2)
 * --------------------------------------------------------------------- */

static void test_piece_split(void)
{
    double worst = 0.0;
    for (int trial = 0; trial < 400; trial++) {
        double p[5];
        int kind = trial % 4;
        if (kind == 0) { /* clamped left: (-3,-2,-1,0,k) */
            p[0] = -3;
            p[1] = -2;
            p[2] = -1;
            p[3] = 0;
            p[4] = rnd(0.05, 1.0);
        } else if (kind == 1) { /* clamped right: (k,1,1,1,1) in sigma (k,1,2,3,4) */
            p[0] = rnd(0.0, 0.95);
            p[1] = 1;
            p[2] = 2;
            p[3] = 3;
            p[4] = 4;
        } else if (kind == 2) { /* (-2,-1,0,a,b) */
            p[0] = -2;
            p[1] = -1;
            p[2] = 0;
            p[3] = rnd(0.05, 0.5);
            p[4] = rnd(p[3] + 0.01, 1.0);
        } else {
            double a[5];
            for (int i = 0; i < 5; i++)
                a[i] = rnd(0.0, 1.0);
            for (int i = 0; i < 5; i++)
                for (int j = i + 1; j < 5; j++)
                    if (a[j] < a[i]) {
                        double t = a[i];
                        a[i] = a[j];
                        a[j] = t;
                    }
            memcpy(p, a, sizeof p);
        }
        /* a legal k: strictly inside (p0,p4), not a knot, nonzero-interval side */
        double k;
        do {
            double lo = tsv_kappa(p[0]), hi = tsv_kappa(p[4]);
            k = rnd(lo, hi);
        } while (!(k > 0.0 && k < 1.0) || k == p[0] || k == p[1] || k == p[2] || k == p[3] ||
                 k == p[4] || !(k > p[0] && k < p[4]));
        double q[6];
        int m = 0;
        for (int j = 0; j < 5; j++) {
            if (m == j && k < p[j])
                q[m++] = k;
            q[m++] = p[j];
        }
        if (m == 5)
            q[m++] = k;
        double cL = k >= p[3] ? 1.0
                              : (tsv_kappa(k) - tsv_kappa(p[0])) / (tsv_kappa(p[3]) - tsv_kappa(p[0]));
        double cR = k <= p[1] ? 1.0
                              : (tsv_kappa(p[4]) - tsv_kappa(k)) / (tsv_kappa(p[4]) - tsv_kappa(p[1]));
        for (int s = 0; s <= 1000; s++) {
            double x = s / 1000.0, d0, dl, dr;
            double N = ffd_tsv_basis(p, x, &d0);
            double r = N - cL * ffd_tsv_basis(q, x, &dl) - cR * ffd_tsv_basis(q + 1, x, &dr);
            if (fabs(r) > worst)
                worst = fabs(r);
            CHECK(N >= 0.0);
        }
    }
    CHECK_NEAR(worst, 0.0, 1e-14);
}

/* ---------------------------------------------------------------------
 * 2. Initial lattice = clamped uniform B-spline
 * --------------------------------------------------------------------- */

static void test_initial_bspline(void)
{
    const uint32_t R[3][3] = {{4, 4, 4}, {5, 6, 7}, {9, 5, 4}};
    for (int t = 0; t < 3; t++) {
        tsv_lattice *L = make_lattice(R[t][0], R[t][1], R[t][2]);
        if (!L)
            return;
        CHECK_OK(ffd_tsv_lattice_validate(L, NULL));
        uint32_t *n = L->res;
        CHECK(L->nc == (size_t)(n[0] - 1) * (n[1] - 1) * (n[2] - 1));
        /* knot windows: plane i sits at registry index i + 2 */
        int bad = 0;
        for (uint32_t i = 0; i < n[0]; i++)
            for (uint32_t j = 0; j < n[1]; j++)
                for (uint32_t l = 0; l < n[2]; l++) {
                    uint32_t v = (i * n[1] + j) * n[2] + l, idx[3] = {i, j, l};
                    double K[3][5];
                    ffd_tsv_infer_knots(L, v, K);
                    for (int a = 0; a < 3; a++)
                        for (int q = 0; q < 5; q++)
                            bad += K[a][q] != L->reg[a].v[idx[a] + q];
                    CHECK(ffd_tsv_vertex_find(L, L->verts[v].sg) == v);
                }
        CHECK(bad == 0);
        /* cell ids (i*(n_t-1)+j)*(n_u-1)+k */
        const tsv_cell *C = &L->cells[(1 * (n[1] - 1) + 2) * (n[2] - 1) + 1];
        CHECK(C->lo[0] == L->reg[0].v[3] && C->lo[1] == L->reg[1].v[4] && C->lo[2] == L->reg[2].v[3]);
        add_noise(L);
        tsv_support *S = NULL;
        CHECK_OK(ffd_tsv_support_build(L, &S, NULL));
        if (!S) {
            ffd_tsv_lattice_destroy(L);
            return;
        }
        double worst = 0.0, wjac = 0.0;
        size_t np = 3000;
        double *pts = malloc(3 * np * sizeof *pts);
        for (size_t p = 0; p < np; p++)
            for (int a = 0; a < 3; a++) {
                double r = check_rand01();
                pts[3 * p + a] = p % 7 == 0 ? 0.0 : (p % 7 == 1 ? 1.0 : (p % 7 == 2 ? (double)rndi(n[a] - 2) / (n[a] - 3) : r));
            }
        for (size_t p = 0; p < np; p++) {
            double F[3], G[3], jac[9];
            ffd_tsv_eval_point(L, S, TSV_CURRENT, pts + 3 * p, F, jac);
            tensor_eval(L, pts + 3 * p, G);
            for (int a = 0; a < 3; a++)
                if (fabs(F[a] - G[a]) > worst)
                    worst = fabs(F[a] - G[a]);
            /* Jacobian against central differences (interior points) */
            const double *x = pts + 3 * p;
            if (x[0] > 1e-3 && x[0] < 1 - 1e-3 && x[1] > 1e-3 && x[1] < 1 - 1e-3 && x[2] > 1e-3 &&
                x[2] < 1 - 1e-3 && p % 5 == 4) {
                for (int c = 0; c < 3; c++) {
                    double xp[3] = {x[0], x[1], x[2]}, xm[3] = {x[0], x[1], x[2]}, Fp[3], Fm[3];
                    xp[c] += 1e-6;
                    xm[c] -= 1e-6;
                    ffd_tsv_eval_point(L, S, TSV_CURRENT, xp, Fp, NULL);
                    ffd_tsv_eval_point(L, S, TSV_CURRENT, xm, Fm, NULL);
                    for (int r = 0; r < 3; r++) {
                        double fd = (Fp[r] - Fm[r]) / 2e-6;
                        if (fabs(fd - jac[r * 3 + c]) > wjac)
                            wjac = fabs(fd - jac[r * 3 + c]);
                    }
                }
            }
        }
        CHECK_NEAR(worst, 0.0, 1e-14 * box_diag());
        CHECK_NEAR(wjac, 0.0, 1e-5);
        /* the same through Phi */
        tsv_phi phi;
        CHECK_OK(ffd_tsv_phi_build(L, S, pts, np, &phi, NULL));
        double *out = malloc(3 * np * sizeof *out);
        ffd_tsv_phi_apply(&phi, L, TSV_CURRENT, out);
        double wphi = 0.0;
        for (size_t p = 0; p < np; p++) {
            double G[3];
            tensor_eval(L, pts + 3 * p, G);
            for (int a = 0; a < 3; a++)
                if (fabs(out[3 * p + a] - G[a]) > wphi)
                    wphi = fabs(out[3 * p + a] - G[a]);
        }
        CHECK_NEAR(wphi, 0.0, 1e-14 * box_diag());
        free(out);
        ffd_tsv_phi_free(&phi);
        free(pts);
        ffd_tsv_support_destroy(S);
        ffd_tsv_lattice_destroy(L);
    }
}

static void test_basis_right_closed(void)
{
    double k1[5] = {-3, -2, -1, 0, 0.5}, k2[5] = {0.5, 1, 2, 3, 4}, k3[5] = {0, 0.25, 0.5, 0.75, 1};
    double d;
    CHECK_NEAR(ffd_tsv_basis(k1, 0.0, &d), 1.0, 0);
    CHECK_NEAR(d, -6.0, 1e-12);
    CHECK_NEAR(ffd_tsv_basis(k2, 1.0, &d), 1.0, 0);
    CHECK_NEAR(d, 6.0, 1e-12);
    CHECK_NEAR(ffd_tsv_basis(k3, 1.0, NULL), 0.0, 0);
    CHECK_NEAR(ffd_tsv_basis(k3, 0.5, NULL), 2.0 / 3.0, 1e-15);
    CHECK_NEAR(ffd_tsv_basis(k3, 1.5, &d), 0.0, 0);
}

/* ---------------------------------------------------------------------
 * 3-7. Exactness, partition of unity, linear precision, consistency
 * --------------------------------------------------------------------- */

static double max_w_dev_seen;

/* Random insertion, ids before the edit; end-layer elements included. */
static ffd_tsv_insertion random_insertion(const tsv_lattice *L)
{
    ffd_tsv_insertion in;
    memset(&in, 0, sizeof in);
    for (;;) {
        int kind = rndi(3);
        in.kind = (ffd_tsv_element)kind;
        in.ratio = check_rand01() < 0.3 ? rnd(0.1, 0.9) : 0.0;
        if (kind == 0) {
            in.id = rndi(L->ne);
            const tsv_edge *E = &L->edges[in.id];
            if (tsv_kappa(E->lo) != tsv_kappa(E->hi))
                return in;
        } else if (kind == 1) {
            in.id = rndi(L->nf);
            const tsv_face *F = &L->faces[in.id];
            in.ratio = 0.0;
            if (tsv_kappa(F->lo[0]) != tsv_kappa(F->hi[0]) || tsv_kappa(F->lo[1]) != tsv_kappa(F->hi[1]))
                return in;
        } else {
            in.id = rndi(L->nc);
            in.ratio = 0.0;
            const tsv_cell *C = &L->cells[in.id];
            for (int a = 0; a < 3; a++)
                if (tsv_kappa(C->lo[a]) != tsv_kappa(C->hi[a]))
                    return in;
        }
    }
}

/* Checks the lattice state after an edit: validate, weights, Greville points. */
static void check_consistency(const tsv_lattice *L)
{
    ffd_error err = {{0}};
    ffd_status st = ffd_tsv_lattice_validate(L, &err);
    if (st != FFD_OK)
        fprintf(stderr, "validate: %s\n", err.message);
    CHECK(st == FFD_OK);
    double dev = 0.0;
    int wbad = 0, gbad = 0;
    for (size_t v = 0; v < L->nv; v++) {
        const tsv_vertex *V = &L->verts[v];
        wbad += !(V->W > TSV_MIN_WEIGHT);
        if (fabs(V->W - 1.0) > dev)
            dev = fabs(V->W - 1.0);
    }
    CHECK(wbad == 0);
    if (dev > max_w_dev_seen)
        max_w_dev_seen = dev;
    if (dev <= 1e-12) {
        /* rest position = Greville point of its own knots (design §4.5) */
        for (size_t v = 0; v < L->nv; v++) {
            double K[3][5];
            ffd_tsv_infer_knots(L, (uint32_t)v, K);
            for (int a = 0; a < 3; a++) {
                double g = (tsv_kappa(K[a][1]) + tsv_kappa(K[a][2]) + tsv_kappa(K[a][3])) / 3.0;
                double x = BOX_MIN[a] + g * (BOX_MAX[a] - BOX_MIN[a]);
                gbad += fabs(x - L->verts[v].P[TSV_REST][a]) > 1e-12 * box_diag();
            }
        }
        CHECK(gbad == 0);
    }
}

typedef struct sample_set {
    double *p;
    size_t n;
} sample_set;

/* 10^4 random points, registry values (kappa) combinations and the corners. */
static sample_set make_samples(const tsv_lattice *L, size_t nrand)
{
    sample_set S;
    size_t nreg = 2000;
    S.n = nrand + nreg + 8;
    S.p = malloc(3 * S.n * sizeof *S.p);
    size_t k = 0;
    for (size_t i = 0; i < nrand; i++, k++)
        for (int a = 0; a < 3; a++)
            S.p[3 * k + a] = check_rand01();
    for (size_t i = 0; i < nreg; i++, k++)
        for (int a = 0; a < 3; a++) {
            const tsv_registry *r = &L->reg[a];
            double s = r->v[rndi(r->n)];
            S.p[3 * k + a] = i % 3 == 0 ? check_rand01() : tsv_kappa(s);
        }
    for (int c = 0; c < 8; c++, k++)
        for (int a = 0; a < 3; a++)
            S.p[3 * k + a] = (c >> a) & 1 ? 1.0 : 0.0;
    return S;
}

/* Compares the map of L1 against L0 at the samples (support and Phi),
 * partition of unity, positivity, linear precision of the rest channel. */
static void compare_maps(const tsv_lattice *L0, const tsv_lattice *L1, const sample_set *X,
                         double *worst_out)
{
    tsv_support *S0 = NULL, *S1 = NULL;
    CHECK_OK(ffd_tsv_support_build(L0, &S0, NULL));
    CHECK_OK(ffd_tsv_support_build(L1, &S1, NULL));
    if (!S0 || !S1) {
        ffd_tsv_support_destroy(S0);
        ffd_tsv_support_destroy(S1);
        return;
    }
    size_t mx = ffd_tsv_support_max(S1);
    uint32_t *ids = malloc(mx * sizeof *ids);
    double *w = malloc(mx * sizeof *w), *g = malloc(3 * mx * sizeof *g);
    double diag = box_diag(), worst = 0.0, pu = 0.0, lin = 0.0, gsum = 0.0;
    int neg = 0;
    for (size_t i = 0; i < X->n; i++) {
        const double *x = X->p + 3 * i;
        double F0[3], F1[3], R[3];
        ffd_tsv_eval_point(L0, S0, TSV_CURRENT, x, F0, NULL);
        ffd_tsv_eval_point(L1, S1, TSV_CURRENT, x, F1, NULL);
        ffd_tsv_eval_point(L1, S1, TSV_REST, x, R, NULL);
        for (int a = 0; a < 3; a++) {
            if (fabs(F0[a] - F1[a]) > worst)
                worst = fabs(F0[a] - F1[a]);
            double want = BOX_MIN[a] + x[a] * (BOX_MAX[a] - BOX_MIN[a]);
            if (fabs(R[a] - want) > lin)
                lin = fabs(R[a] - want);
        }
        size_t m = ffd_tsv_support_eval(S1, x, ids, w, g);
        double sum = 0.0, gs[3] = {0, 0, 0};
        for (size_t k = 0; k < m; k++) {
            sum += w[k];
            neg += w[k] < 0.0;
            for (int a = 0; a < 3; a++)
                gs[a] += g[3 * k + a];
        }
        if (fabs(sum - 1.0) > pu)
            pu = fabs(sum - 1.0);
        for (int a = 0; a < 3; a++)
            if (fabs(gs[a]) > gsum)
                gsum = fabs(gs[a]);
    }
    CHECK_NEAR(worst, 0.0, 1e-12 * diag);
    CHECK_NEAR(pu, 0.0, 1e-13);
    CHECK_NEAR(gsum, 0.0, 1e-10);
    CHECK_NEAR(lin, 0.0, 1e-12 * diag);
    CHECK(neg == 0);
    /* Phi: the same map, rows sum to 1 */
    tsv_phi phi;
    CHECK_OK(ffd_tsv_phi_build(L1, S1, X->p, X->n, &phi, NULL));
    double *out = malloc(3 * X->n * sizeof *out);
    ffd_tsv_phi_apply(&phi, L1, TSV_CURRENT, out);
    double wphi = 0.0, rows = 0.0;
    for (size_t i = 0; i < X->n; i++) {
        double F0[3], rs = 0.0;
        ffd_tsv_eval_point(L0, S0, TSV_CURRENT, X->p + 3 * i, F0, NULL);
        for (int a = 0; a < 3; a++)
            if (fabs(F0[a] - out[3 * i + a]) > wphi)
                wphi = fabs(F0[a] - out[3 * i + a]);
        for (size_t k = phi.rowptr[i]; k < phi.rowptr[i + 1]; k++)
            rs += phi.val[k];
        if (fabs(rs - 1.0) > rows)
            rows = fabs(rs - 1.0);
    }
    CHECK_NEAR(wphi, 0.0, 1e-12 * diag);
    CHECK_NEAR(rows, 0.0, 1e-13);
    if (worst_out && worst > *worst_out)
        *worst_out = worst;
    free(out);
    ffd_tsv_phi_free(&phi);
    free(ids);
    free(w);
    free(g);
    ffd_tsv_support_destroy(S0);
    ffd_tsv_support_destroy(S1);
}

static void test_exactness(void)
{
    double worst = 0.0;
    size_t total_edits = 0;
    for (int trial = 0; trial < 12; trial++) {
        tsv_lattice *L = make_lattice(4 + rndi(4), 4 + rndi(4), 4 + rndi(4));
        if (!L)
            return;
        add_noise(L);
        tsv_lattice *L0 = ffd_tsv_lattice_clone(L);
        int nedits = 1 + (int)rndi(trial < 4 ? 10 : 50);
        for (int e = 0; e < nedits; e++) {
            ffd_tsv_insertion ins[8];
            size_t n = 1;
            double r = check_rand01();
            if (r < 0.15) { /* batch octree split of several cells */
                n = 2 + rndi(6);
                for (size_t i = 0; i < n; i++)
                    do
                        ins[i] = random_insertion(L);
                    while (ins[i].kind != FFD_TSV_CELL);
            } else if (r < 0.3) { /* a mixed batch with a repeat */
                n = 2 + rndi(4);
                for (size_t i = 0; i + 1 < n; i++)
                    ins[i] = random_insertion(L);
                ins[n - 1] = ins[0];
            } else {
                ins[0] = random_insertion(L);
            }
            tsv_refine_stats st;
            ffd_error err = {{0}};
            ffd_status s = ffd_tsv_lattice_refine(L, ins, n, &st, &err);
            if (s != FFD_OK) {
                fprintf(stderr, "refine failed (trial %d edit %d): %s\n", trial, e, err.message);
                CHECK(s == FFD_OK);
                break;
            }
            CHECK(st.added_points == 0 || st.topology_steps > 0);
            total_edits++;
            check_consistency(L);
            if (e % 8 == 7) {
                sample_set X = make_samples(L, 500);
                compare_maps(L0, L, &X, &worst);
                free(X.p);
            }
        }
        sample_set X = make_samples(L, trial < 3 ? 10000 : 2000);
        compare_maps(L0, L, &X, &worst);
        free(X.p);
        ffd_tsv_lattice_destroy(L0);
        ffd_tsv_lattice_destroy(L);
    }
    printf("    exactness: %zu edits, max |F_after - F_before| = %.3g, max |W-1| = %.3g\n",
           total_edits, worst, max_w_dev_seen);
}

/* Each insertion type alone, on interior and end-layer elements. */
static void test_each_type(void)
{
    for (int kind = 0; kind < 3; kind++)
        for (int trial = 0; trial < 6; trial++) {
            tsv_lattice *L = make_lattice(6, 5, 7);
            if (!L)
                return;
            add_noise(L);
            tsv_lattice *L0 = ffd_tsv_lattice_clone(L);
            ffd_tsv_insertion in = random_insertion(L);
            while ((int)in.kind != kind)
                in = random_insertion(L);
            size_t nv = L->nv;
            tsv_refine_stats st;
            ffd_error err = {{0}};
            ffd_status s = ffd_tsv_lattice_refine(L, &in, 1, &st, &err);
            if (s != FFD_OK)
                fprintf(stderr, "%s\n", err.message);
            CHECK(s == FFD_OK);
            CHECK(L->nv > nv);
            CHECK(st.added_points == L->nv - nv);
            check_consistency(L);
            sample_set X = make_samples(L, 3000);
            compare_maps(L0, L, &X, NULL);
            free(X.p);
            ffd_tsv_lattice_destroy(L0);
            ffd_tsv_lattice_destroy(L);
        }
}

static void test_idempotence(void)
{
    tsv_lattice *L = make_lattice(6, 6, 6);
    if (!L)
        return;
    add_noise(L);
    ffd_tsv_insertion in = {FFD_TSV_CELL, 62, 0.0};
    CHECK_OK(ffd_tsv_lattice_refine(L, &in, 1, NULL, NULL));
    tsv_lattice *L1 = ffd_tsv_lattice_clone(L);
    /* an empty edit and an edge point that lands on an existing knot */
    tsv_refine_stats st;
    CHECK_OK(ffd_tsv_lattice_refine(L, NULL, 0, &st, NULL));
    CHECK(st.added_points == 0 && st.moved_points == 0);
    uint32_t e = 0;
    for (e = 0; e < L->ne; e++)
        if (L->edges[e].lo == 0.0 && L->edges[e].hi > 0.0)
            break;
    ffd_tsv_insertion snap = {FFD_TSV_EDGE, e, 1e-15};
    CHECK_OK(ffd_tsv_lattice_refine(L, &snap, 1, &st, NULL));
    CHECK(st.added_points == 0 && st.moved_points == 0);
    CHECK(L->nv == L1->nv && L->ne == L1->ne && L->nf == L1->nf && L->nc == L1->nc);
    CHECK(L->version == L1->version);
    int diff = 0;
    for (size_t v = 0; v < L->nv && v < L1->nv; v++)
        diff += memcmp(L->verts[v].P, L1->verts[v].P, sizeof L->verts[v].P) != 0 ||
                L->verts[v].W != L1->verts[v].W;
    CHECK(diff == 0);
    /* the octree split of the same region again (its lower part): the map stays */
    CHECK_OK(ffd_tsv_lattice_refine(L, &in, 1, NULL, NULL));
    sample_set X = make_samples(L, 2000);
    compare_maps(L1, L, &X, NULL);
    free(X.p);
    check_consistency(L);
    ffd_tsv_lattice_destroy(L1);
    ffd_tsv_lattice_destroy(L);
}

static void test_bad_input(void)
{
    tsv_lattice *L = make_lattice(4, 4, 5);
    if (!L)
        return;
    CHECK(L->nc == 36);
    tsv_lattice *L0 = ffd_tsv_lattice_clone(L);
    ffd_error err = {{0}};
    ffd_tsv_insertion in = {FFD_TSV_CELL, 40, 0.0};
    CHECK(ffd_tsv_lattice_refine(L, &in, 1, NULL, &err) == FFD_ERR_RANGE);
    CHECK(strcmp(err.message, "cell 40: there are 36 cells") == 0);
    in.kind = FFD_TSV_EDGE;
    in.id = (uint32_t)L->ne;
    CHECK(ffd_tsv_lattice_refine(L, &in, 1, NULL, &err) == FFD_ERR_RANGE);
    CHECK(strstr(err.message, "edge") != NULL);
    in.kind = FFD_TSV_FACE;
    in.id = (uint32_t)L->nf + 3;
    CHECK(ffd_tsv_lattice_refine(L, &in, 1, NULL, &err) == FFD_ERR_RANGE);
    /* edge 0 runs from sigma -1 to 0: zero knot interval */
    in.kind = FFD_TSV_EDGE;
    in.id = 0;
    CHECK(ffd_tsv_lattice_refine(L, &in, 1, NULL, &err) == FFD_ERR_INVALID);
    CHECK(strcmp(err.message, "edge 0: zero knot interval") == 0);
    /* face 0 (normal s at -1, t and u in [-1,0]) and the corner cell 0 */
    in.kind = FFD_TSV_FACE;
    CHECK(ffd_tsv_lattice_refine(L, &in, 1, NULL, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "zero knot interval") != NULL);
    in.kind = FFD_TSV_CELL;
    CHECK(ffd_tsv_lattice_refine(L, &in, 1, NULL, &err) == FFD_ERR_INVALID);
    /* bad ratios on an interior edge */
    uint32_t e = 0;
    while (tsv_kappa(L->edges[e].lo) == tsv_kappa(L->edges[e].hi))
        e++;
    const double bad[4] = {1.0, -0.5, 1.5, NAN};
    for (int i = 0; i < 4; i++) {
        ffd_tsv_insertion b = {FFD_TSV_EDGE, e, bad[i]};
        CHECK(ffd_tsv_lattice_refine(L, &b, 1, NULL, &err) == FFD_ERR_INVALID);
    }
    /* a batch with one bad element: all or nothing */
    ffd_tsv_insertion batch[2] = {{FFD_TSV_CELL, 13, 0.0}, {FFD_TSV_CELL, 99, 0.0}};
    CHECK(ffd_tsv_lattice_refine(L, batch, 2, NULL, &err) == FFD_ERR_RANGE);
    CHECK(L->nv == L0->nv && L->nc == L0->nc && L->version == L0->version);
    /* a face across an end layer splits 1 -> 2 */
    for (uint32_t f = 0; f < L->nf; f++) {
        const tsv_face *F = &L->faces[f];
        if (F->normal == 2 && F->lo[0] == -1.0 && F->lo[1] == 0.0 && F->c == 0.0) {
            size_t nf = L->nf;
            ffd_tsv_insertion fi = {FFD_TSV_FACE, f, 0.0};
            CHECK_OK(ffd_tsv_lattice_refine(L, &fi, 1, NULL, NULL));
            CHECK(L->nf >= nf + 1);
            check_consistency(L);
            break;
        }
    }
    ffd_tsv_lattice_destroy(L0);
    ffd_tsv_lattice_destroy(L);
}

/* Out of memory anywhere in an edit rolls back to the old lattice. */
static void test_nomem_rollback(void)
{
    tsv_lattice *L = make_lattice(5, 5, 5);
    if (!L)
        return;
    add_noise(L);
    tsv_lattice *L0 = ffd_tsv_lattice_clone(L);
    ffd_tsv_insertion ins[2] = {{FFD_TSV_CELL, 31, 0.0}, {FFD_TSV_FACE, 40, 0.0}};
    int nomem = 0, ok = 0;
    for (long k = 0; k < 4000 && !ok; k += (k < 200 ? 1 : 37)) {
        fail_alloc fa = {k, 0};
        ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&a);
        ffd_status s = ffd_tsv_lattice_refine(L, ins, 2, NULL, NULL);
        ffd_set_allocator(NULL);
        if (s == FFD_OK) {
            ok = 1;
            break;
        }
        CHECK(s == FFD_ERR_NOMEM);
        nomem++;
        CHECK(L->nv == L0->nv && L->ne == L0->ne && L->nf == L0->nf && L->nc == L0->nc);
        CHECK_OK(ffd_tsv_lattice_validate(L, NULL));
    }
    CHECK(ok);
    CHECK(nomem > 10);
    check_consistency(L);
    ffd_tsv_lattice_destroy(L0);
    ffd_tsv_lattice_destroy(L);
}

/* One refinement round: a random insertion of each kind at once. */
static void refine_one_of_each_kind(tsv_lattice *L)
{
    ffd_tsv_insertion ins[3];
    for (int i = 0; i < 3; i++)
        do
            ins[i] = random_insertion(L);
        while ((int)ins[i].kind != i);
    CHECK_OK(ffd_tsv_lattice_refine(L, ins, 3, NULL, NULL));
}

static void test_phi_threads(void)
{
#ifdef _OPENMP
    tsv_lattice *L = make_lattice(7, 6, 5);
    if (!L)
        return;
    add_noise(L);
    refine_one_of_each_kind(L);
    tsv_support *S = NULL;
    CHECK_OK(ffd_tsv_support_build(L, &S, NULL));
    sample_set X = make_samples(L, 5000);
    double *o1 = malloc(3 * X.n * sizeof *o1), *o2 = malloc(3 * X.n * sizeof *o2);
    int nt = omp_get_max_threads();
    tsv_phi p1, p2;
    omp_set_num_threads(1);
    CHECK_OK(ffd_tsv_phi_build(L, S, X.p, X.n, &p1, NULL));
    ffd_tsv_phi_apply(&p1, L, TSV_CURRENT, o1);
    omp_set_num_threads(nt > 1 ? nt : 3);
    CHECK_OK(ffd_tsv_phi_build(L, S, X.p, X.n, &p2, NULL));
    ffd_tsv_phi_apply(&p2, L, TSV_CURRENT, o2);
    omp_set_num_threads(nt);
    CHECK(memcmp(o1, o2, 3 * X.n * sizeof *o1) == 0);
    CHECK(p1.rowptr[X.n] == p2.rowptr[X.n]);
    free(o1);
    free(o2);
    free(X.p);
    ffd_tsv_phi_free(&p1);
    ffd_tsv_phi_free(&p2);
    ffd_tsv_support_destroy(S);
    ffd_tsv_lattice_destroy(L);
#endif
}

/* The support's per-bin tables (each distinct univariate basis of a bin
 * evaluated once per point) give, bit for bit, what each vertex's own
 * W_v N(s) N(t) N(u) gives (ffd_tsv_basis on its ray-cast knots, the
 * products in the same order): entries, order, values and gradients, at
 * random points and on knots, after refinements of every kind. */
static void test_support_tables_bitwise(void)
{
    tsv_lattice *L = make_lattice(7, 6, 5);
    if (!L)
        return;
    add_noise(L);
    for (int round = 0; round < 3; round++) {
        refine_one_of_each_kind(L);
    }
    tsv_support *S = NULL;
    CHECK_OK(ffd_tsv_support_build(L, &S, NULL));
    if (!S) {
        ffd_tsv_lattice_destroy(L);
        return;
    }
    sample_set X = make_samples(L, 3000);
    size_t mx = ffd_tsv_support_max(S);
    uint32_t *ids = malloc(mx * sizeof *ids);
    double *w = malloc(mx * sizeof *w), *g = malloc(3 * mx * sizeof *g);
    double(*knots)[3][5] = malloc(L->nv * sizeof *knots);
    for (size_t v = 0; v < L->nv; v++)
        ffd_tsv_infer_knots(L, (uint32_t)v, knots[v]);
    size_t mismatches = 0, entries = 0;
    for (size_t i = 0; i < X.n; i++) {
        const double *x = X.p + 3 * i;
        size_t m = ffd_tsv_support_eval(S, x, ids, w, g), k = 0;
        for (size_t v = 0; v < L->nv; v++) {
            double N[3], dN[3], kap[3][2];
            int inside = 1;
            for (int d = 0; d < 3; d++) {
                kap[d][0] = tsv_kappa(knots[v][d][0]);
                kap[d][1] = tsv_kappa(knots[v][d][4]);
                inside &= !(x[d] < kap[d][0] || x[d] > kap[d][1]);
            }
            if (!inside)
                continue;
            for (int d = 0; d < 3; d++)
                N[d] = ffd_tsv_basis(knots[v][d], x[d], &dN[d]);
            double W = L->verts[v].W, val = W * N[0] * N[1] * N[2];
            double gv[3] = {W * dN[0] * N[1] * N[2], W * N[0] * dN[1] * N[2],
                            W * N[0] * N[1] * dN[2]};
            if (val == 0.0 && gv[0] == 0.0 && gv[1] == 0.0 && gv[2] == 0.0)
                continue;
            entries++;
            if (k >= m || ids[k] != v || memcmp(&w[k], &val, sizeof val) != 0 ||
                memcmp(g + 3 * k, gv, sizeof gv) != 0)
                mismatches++;
            k++;
        }
        mismatches += k != m;
    }
    CHECK(entries > 64 * X.n / 2);
    CHECK(mismatches == 0);
    free(knots);
    free(ids);
    free(w);
    free(g);
    free(X.p);
    ffd_tsv_support_destroy(S);
    ffd_tsv_lattice_destroy(L);
}

/* The rig's one-pass evaluation (ffd_tsv_eval_jacobian, no Phi) gives the
 * bits of ffd_tsv_eval (through Phi) and ffd_tsv_jacobian; the fold check
 * gives the same report whether Phi was built or not; a refinement drops
 * Phi and the next evaluation rebuilds it for the new lattice. */
static void test_one_pass_evaluation(void)
{
    const size_t n = 4000, nf = n / 3;
    double *P = malloc(3 * n * sizeof *P);
    uint32_t *off = malloc((nf + 1) * sizeof *off), *idx = malloc(3 * nf * sizeof *idx);
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            P[3 * i + a] = i < 8 ? BOX_MIN[a] + (double)((i >> a) & 1) * (BOX_MAX[a] - BOX_MIN[a])
                                 : rnd(BOX_MIN[a], BOX_MAX[a]);
    for (size_t f = 0; f <= nf; f++)
        off[f] = (uint32_t)(3 * f);
    for (size_t k = 0; k < 3 * nf; k++)
        idx[k] = (uint32_t)k;
    uint32_t res[3] = {6, 5, 7};
    ffd_tsv *t = NULL;
    CHECK_OK(ffd_tsv_create(P, n, off, idx, nf, res, NULL, &t, NULL));
    if (!t)
        goto done;
    for (int round = 0; round < 2; round++) {
        /* a cell of volume (an end layer's cells of zero knot interval cannot split) */
        ffd_tsv_insertion ins = {FFD_TSV_CELL, 0, 0};
        double lo[3], hi[3];
        do {
            ins.id = rndi(ffd_tsv_element_count(t, FFD_TSV_CELL));
            ffd_tsv_element_box(t, FFD_TSV_CELL, ins.id, lo, hi, NULL);
        } while (!(hi[0] > lo[0] && hi[1] > lo[1] && hi[2] > lo[2]));
        CHECK_OK(ffd_tsv_refine(t, &ins, 1, NULL, NULL));
        for (size_t v = 0; v < ffd_tsv_control_count(t); v += 3) {
            double d[3] = {rnd(-0.2, 0.2), rnd(-0.1, 0.1), rnd(-0.2, 0.2)};
            CHECK_OK(ffd_tsv_move(t, (uint32_t)v, d, NULL));
        }
        double *x1 = malloc(3 * n * sizeof *x1), *x2 = malloc(3 * n * sizeof *x2);
        double *J1 = malloc(9 * n * sizeof *J1), *J2 = malloc(9 * n * sizeof *J2);
        ffd_tsv_fold_report f1, f2;
        CHECK(!t->has_phi);
        CHECK_OK(ffd_tsv_check_folds(t, 2, &f1, NULL));
        CHECK(!t->has_phi);
        CHECK_OK(ffd_tsv_eval_jacobian(t, x1, J1, NULL));
        CHECK(!t->has_phi);
        CHECK_OK(ffd_tsv_eval(t, x2, NULL));
        CHECK(t->has_phi);
        CHECK_OK(ffd_tsv_jacobian(t, J2, NULL));
        CHECK_OK(ffd_tsv_check_folds(t, 2, &f2, NULL));
        CHECK(memcmp(x1, x2, 3 * n * sizeof *x1) == 0);
        CHECK(memcmp(J1, J2, 9 * n * sizeof *J1) == 0);
        CHECK(memcmp(&f1.min_det, &f2.min_det, sizeof f1.min_det) == 0);
        CHECK(f1.folded_cell_count == f2.folded_cell_count);
        CHECK(f1.inverted_face_count == f2.inverted_face_count);
        CHECK(f1.inverted_face_count == 0 ||
              memcmp(f1.inverted_faces, f2.inverted_faces,
                     f1.inverted_face_count * sizeof *f1.inverted_faces) == 0);
        /* Phi against the points' own evaluation (ffd_tsv_eval_params, eq. 1 directly) */
        double worst = 0.0;
        for (size_t i = 0; i < n; i += 7) {
            double stu[3], y[3];
            ffd_tsv_point_params(t, i, stu);
            ffd_tsv_eval_params(t, stu, y, NULL);
            for (int a = 0; a < 3; a++)
                worst = fmax(worst, fabs(y[a] - x2[3 * i + a]));
        }
        CHECK_NEAR(worst, 0.0, 1e-12 * box_diag());
        ffd_tsv_fold_report_free(&f1);
        ffd_tsv_fold_report_free(&f2);
        free(x1);
        free(x2);
        free(J1);
        free(J2);
    }
done:
    ffd_tsv_destroy(t);
    free(P);
    free(off);
    free(idx);
}

static void test_lattice_queries(void)
{
    tsv_lattice *L = make_lattice(5, 5, 5);
    if (!L)
        return;
    /* face ring of an interior face: 4 corners, starting at (lo,lo) */
    uint32_t *ids = NULL;
    size_t n = 0;
    uint32_t f = 0;
    while (!(L->faces[f].normal == 2 && L->faces[f].c > 0.0 && L->faces[f].lo[0] > 0.0 &&
             L->faces[f].lo[1] > 0.0))
        f++;
    CHECK_OK(ffd_tsv_face_ring(L, f, &ids, &n, NULL));
    CHECK(n == 4);
    if (n == 4) {
        const tsv_face *F = &L->faces[f];
        CHECK(L->verts[ids[0]].sg[0] == F->lo[0] && L->verts[ids[0]].sg[1] == F->lo[1]);
        CHECK(L->verts[ids[1]].sg[0] == F->hi[0] && L->verts[ids[1]].sg[1] == F->lo[1]);
        CHECK(L->verts[ids[2]].sg[0] == F->hi[0] && L->verts[ids[2]].sg[1] == F->hi[1]);
    }
    ffd_free(ids);
    /* split a neighbour cell: the shared face gets a T (ring of 5 or more) */
    tsv_cell C = L->cells[f % L->nc];
    (void)C;
    uint32_t c = (uint32_t)((2 * 4 + 2) * 4 + 2);
    CHECK_OK(ffd_tsv_cell_points(L, c, &ids, &n, NULL));
    CHECK(n == 8);
    ffd_free(ids);
    ffd_tsv_insertion in = {FFD_TSV_CELL, c, 0.0};
    CHECK_OK(ffd_tsv_lattice_refine(L, &in, 1, NULL, NULL));
    /* the neighbour above in u: its cell points include the hanging ones */
    uint32_t up = c + 1;
    CHECK_OK(ffd_tsv_cell_points(L, up, &ids, &n, NULL));
    CHECK(n >= 9);
    ffd_free(ids);
    /* side cells of all faces stay right (validate), gamma is monotone */
    check_consistency(L);
    for (int a = 0; a < 3; a++) {
        CHECK_NEAR(ffd_tsv_gamma(L, a, -1.0), 0.0, 0);
        CHECK_NEAR(ffd_tsv_gamma(L, a, 2.0), 1.0, 0);
        double prev = -1.0;
        for (size_t i = 2; i + 2 < L->reg[a].n; i++) {
            double g = ffd_tsv_gamma(L, a, L->reg[a].v[i]);
            CHECK(g >= prev);
            prev = g;
        }
    }
    /* locate: a vertex, an edge interior, a cell interior */
    int dim;
    uint32_t id;
    ffd_tsv_lattice_locate(L, L->verts[7].sg, &dim, &id);
    CHECK(dim == 0 && id == 7);
    double q[3] = {0.2, 0.3, 0.1};
    ffd_tsv_lattice_locate(L, q, &dim, &id);
    CHECK(dim == 3);
    ffd_tsv_lattice_destroy(L);
}

/* Not a timed test: prints the cost of a 12^3 lattice octree split of 50 cells. */
static void test_octree_batch_cost(void)
{
    tsv_lattice *L = make_lattice(12, 12, 12);
    if (!L)
        return;
    add_noise(L);
    ffd_tsv_insertion ins[50];
    for (int i = 0; i < 50; i++) {
        /* a compact block of interior cells, as a proxy selection would give */
        uint32_t ci = 3 + (uint32_t)(i % 5), cj = 3 + (uint32_t)((i / 5) % 5), ck = 3 + (uint32_t)(i / 25);
        ins[i].kind = FFD_TSV_CELL;
        ins[i].id = (ci * 11 + cj) * 11 + ck;
        ins[i].ratio = 0.0;
    }
    tsv_lattice *L0 = ffd_tsv_lattice_clone(L);
    tsv_refine_stats st;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    CHECK_OK(ffd_tsv_lattice_refine(L, ins, 50, &st, NULL));
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double ms = (double)(t1.tv_sec - t0.tv_sec) * 1e3 + (double)(t1.tv_nsec - t0.tv_nsec) * 1e-6;
    printf("    12^3 octree of 50 cells: %.2f ms, %zu points added, %zu moved, %zu steps, "
           "max|W-1| %.3g\n",
           ms, st.added_points, st.moved_points, st.topology_steps, st.max_weight_deviation);
    check_consistency(L);
    sample_set X = make_samples(L, 2000);
    compare_maps(L0, L, &X, NULL);
    free(X.p);
    ffd_tsv_lattice_destroy(L0);
    ffd_tsv_lattice_destroy(L);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"piece_split", test_piece_split},
        {"basis_right_closed", test_basis_right_closed},
        {"initial_bspline", test_initial_bspline},
        {"lattice_queries", test_lattice_queries},
        {"each_type", test_each_type},
        {"exactness", test_exactness},
        {"idempotence", test_idempotence},
        {"bad_input", test_bad_input},
        {"nomem_rollback", test_nomem_rollback},
        {"phi_threads", test_phi_threads},
        {"support_tables_bitwise", test_support_tables_bitwise},
        {"one_pass_evaluation", test_one_pass_evaluation},
        {"octree_batch_cost", test_octree_batch_cost},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
