/* pbffd — a control set prepared for parameterisation: the kernels of its
 * EBFs and master (PB-FFD eq. 1, §3.2.2), a uniform grid over the ROIs'
 * bounding boxes that answers "which ROIs may hold this point" (the paper
 * scans all M controls per vertex, §5; with a million vertices and hundreds
 * of controls the grid keeps binding linear in the vertices), and the
 * normalised weights of eq. 5 with the parameters of eq. 3. */
#include "pbffd/pbffd.h"

#include <math.h>
#include <string.h>

#define GRID_MAX_DIM 512u
#define GRID_MAX_CELLS (1u << 21)
#define GRID_MAX_ENTRIES (1u << 24)

void ffd_ebf_space_free(ffd_ebf_space *s)
{
    if (!s)
        return;
    ffd_free(s->kernel);
    ffd_free(s->cell_start);
    ffd_free(s->cell_ctl);
    memset(s, 0, sizeof *s);
}

static uint32_t cell_coord(const ffd_ebf_space *s, int c, double x)
{
    double t = (x - s->lo[c]) * s->inv_h;
    if (!(t > 0))
        return 0;
    if (t >= (double)(s->dim[c] - 1))
        return s->dim[c] - 1;
    return (uint32_t)t;
}

/* Cells meet by control j's ROI box, as ranges per axis. */
static void control_cells(const ffd_ebf_space *s, const ffd_ebf_kernel *k, uint32_t a[3],
                          uint32_t b[3])
{
    for (int c = 0; c < 3; c++) {
        a[c] = cell_coord(s, c, k->lo[c]);
        b[c] = cell_coord(s, c, k->hi[c]);
    }
}

static ffd_status build_grid(ffd_ebf_space *s)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double width = 0;
    size_t enabled = 0;
    for (size_t j = 0; j < s->count; j++) {
        const ffd_ebf_kernel *k = &s->kernel[j];
        if (k->weight == 0.0)
            continue;
        enabled++;
        double w = 0;
        for (int c = 0; c < 3; c++) {
            lo[c] = fmin(lo[c], k->lo[c]);
            hi[c] = fmax(hi[c], k->hi[c]);
            w = fmax(w, k->hi[c] - k->lo[c]);
        }
        width += w;
    }
    if (enabled == 0)
        return FFD_OK; /* no grid: every control is skipped anyway */
    /* cells about half the mean ROI width: each ROI meets a few cells, each cell few ROIs */
    double h = 0.25 * width / (double)enabled;
    for (;;) {
        size_t cells = 1;
        int ok = 1;
        for (int c = 0; c < 3; c++) {
            double d = ceil((hi[c] - lo[c]) / h);
            if (!(d >= 1))
                d = 1;
            if (d > GRID_MAX_DIM) {
                ok = 0;
                break;
            }
            s->dim[c] = (uint32_t)d;
            cells *= s->dim[c];
        }
        if (ok && cells <= GRID_MAX_CELLS) {
            memcpy(s->lo, lo, sizeof lo);
            s->inv_h = 1.0 / h;
            for (int c = 0; c < 3; c++) /* the grid's far edge, once instead of per point */
                s->hi[c] = s->lo[c] + s->dim[c] / s->inv_h;
            size_t entries = 0;
            for (size_t j = 0; j < s->count && entries <= GRID_MAX_ENTRIES; j++) {
                if (s->kernel[j].weight == 0.0)
                    continue;
                uint32_t a[3], b[3];
                control_cells(s, &s->kernel[j], a, b);
                entries += (size_t)(b[0] - a[0] + 1) * (b[1] - a[1] + 1) * (b[2] - a[2] + 1);
            }
            if (entries <= GRID_MAX_ENTRIES)
                break;
        }
        h *= 2.0;
    }
    size_t cells = (size_t)s->dim[0] * s->dim[1] * s->dim[2];
    s->cell_start = ffd_calloc(cells + 1, sizeof *s->cell_start);
    if (!s->cell_start)
        return FFD_ERR_NOMEM;
    for (int pass = 0; pass < 2; pass++) {
        for (size_t j = 0; j < s->count; j++) {
            if (s->kernel[j].weight == 0.0)
                continue;
            uint32_t a[3], b[3];
            control_cells(s, &s->kernel[j], a, b);
            for (uint32_t x = a[0]; x <= b[0]; x++)
                for (uint32_t y = a[1]; y <= b[1]; y++)
                    for (uint32_t z = a[2]; z <= b[2]; z++) {
                        size_t cell = ((size_t)x * s->dim[1] + y) * s->dim[2] + z;
                        if (pass == 0)
                            s->cell_start[cell + 1]++;
                        else
                            s->cell_ctl[s->cell_start[cell]++] = (uint32_t)j;
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < cells; c++)
                s->cell_start[c + 1] += s->cell_start[c];
            s->cell_ctl = ffd_malloc_array(s->cell_start[cells] ? s->cell_start[cells] : 1,
                                           sizeof *s->cell_ctl);
            if (!s->cell_ctl)
                return FFD_ERR_NOMEM;
        } else {
            /* the fill advanced every start to the next cell's: shift back */
            for (size_t c = cells; c > 0; c--)
                s->cell_start[c] = s->cell_start[c - 1];
            s->cell_start[0] = 0;
        }
    }
    return FFD_OK;
}

ffd_status ffd_ebf_space_init(ffd_ebf_space *s, const ffd_ebf *controls, size_t count,
                              const ffd_ebf *master, double master_weight, double sigma, int grid)
{
    memset(s, 0, sizeof *s);
    s->count = count;
    s->inv2s2 = 1.0 / (2.0 * sigma * sigma);
    s->kernel = ffd_malloc_array(count ? count : 1, sizeof *s->kernel);
    if (!s->kernel)
        return FFD_ERR_NOMEM;
    for (size_t j = 0; j < count; j++)
        ffd_ebf_kernel_init(&controls[j], controls[j].disabled ? 0.0 : 1.0, &s->kernel[j]);
    if (master) {
        s->has_master = 1;
        ffd_ebf_kernel_init(master, master_weight, &s->master);
    }
    if (grid && count > 0) {
        ffd_status st = build_grid(s);
        if (st != FFD_OK) {
            ffd_ebf_space_free(s);
            return st;
        }
    }
    return FFD_OK;
}

/* The controls whose ROI box may hold x: a grid cell's list, or all (*cand NULL). */
static size_t candidates(const ffd_ebf_space *s, const double x[3], const uint32_t **cand)
{
    *cand = NULL;
    if (!s->dim[0])
        return s->count;
    for (int c = 0; c < 3; c++)
        if (!(x[c] >= s->lo[c]) || x[c] > s->hi[c])
            return 0;
    size_t cell =
        ((size_t)cell_coord(s, 0, x[0]) * s->dim[1] + cell_coord(s, 1, x[1])) * s->dim[2] +
        cell_coord(s, 2, x[2]);
    *cand = s->cell_ctl + s->cell_start[cell];
    return s->cell_start[cell + 1] - s->cell_start[cell];
}

/* rho^2 of x in an enabled control's ROI (eq. 1), v = x - center; 0 when x is
 * outside the ROI's box or the control is disabled. */
static inline int roi_rho2(const ffd_ebf_kernel *k, const double x[3], double v[3], double *rho2)
{
    /* one branch for the box: most candidates fail it unpredictably (bench_pbffd) */
    if ((k->weight == 0.0) | (x[0] < k->lo[0]) | (x[0] > k->hi[0]) | (x[1] < k->lo[1]) |
        (x[1] > k->hi[1]) | (x[2] < k->lo[2]) | (x[2] > k->hi[2]))
        return 0;
    for (int c = 0; c < 3; c++)
        v[c] = x[c] - k->center[c];
    double r2 = 0;
    for (int a = 0; a < 3; a++) {
        double r = k->q[a][0] * v[0] + k->q[a][1] * v[1] + k->q[a][2] * v[2];
        r2 += r * r;
    }
    *rho2 = r2;
    return 1;
}

/* Whether a control enters the row: phi > 0. Below this 1/(2 sigma^2) that is
 * rho < 1 (exp(-rho^2/(2 sigma^2)) (1 - rho^2)^3 >= e^-300 (1e-16)^3 does not
 * underflow), so counting needs no exp. */
#define NO_UNDERFLOW_INV2S2 300.0

static inline int accept(const ffd_ebf_space *s, double rho2)
{
    return rho2 < 1.0 &&
           (s->inv2s2 <= NO_UNDERFLOW_INV2S2 || ffd_ebf_phi_of(rho2, s->inv2s2) > 0.0);
}

size_t ffd_ebf_space_count(const ffd_ebf_space *s, const double x[3], uint64_t *accepted)
{
    const uint32_t *cand;
    size_t nc = candidates(s, x, &cand), m = 0;
    uint64_t mask = 0;
    /* without branches on the data: whether a candidate enters is a coin toss
     * for the branch predictor (bench_pbffd, callgrind --branch-sim) */
    for (size_t e = 0; e < nc; e++) {
        const ffd_ebf_kernel *k = &s->kernel[cand ? cand[e] : e];
        int in = (k->weight != 0.0) & (x[0] >= k->lo[0]) & (x[0] <= k->hi[0]) &
                 (x[1] >= k->lo[1]) & (x[1] <= k->hi[1]) & (x[2] >= k->lo[2]) & (x[2] <= k->hi[2]);
        double v[3] = {x[0] - k->center[0], x[1] - k->center[1], x[2] - k->center[2]}, rho2 = 0;
        for (int a = 0; a < 3; a++) { /* as roi_rho2 */
            double r = k->q[a][0] * v[0] + k->q[a][1] * v[1] + k->q[a][2] * v[2];
            rho2 += r * r;
        }
        in &= rho2 < 1.0;
        if (s->inv2s2 > NO_UNDERFLOW_INV2S2 && in) /* as accept */
            in = ffd_ebf_phi_of(rho2, s->inv2s2) > 0.0;
        m += (size_t)in;
        if (e < 64)
            mask |= (uint64_t)in << e;
    }
    if (accepted)
        *accepted = nc <= 64 ? mask : FFD_EBF_TEST_ALL;
    return m;
}

/* The index of the lowest set bit of b (b != 0). */
static inline size_t lowest_bit(uint64_t b)
{
#if defined(__GNUC__) || defined(__clang__)
    return (size_t)__builtin_ctzll(b);
#else
    size_t e = 0;
    while (!(b & 1)) {
        b >>= 1;
        e++;
    }
    return e;
#endif
}

size_t ffd_ebf_space_weights(const ffd_ebf_space *s, const double x[3], uint64_t accepted,
                             uint32_t *col, double *w, double *d, double *master_w)
{
    const uint32_t *cand;
    size_t nc = candidates(s, x, &cand), m = 0;
    double sum = 0.0;
    /* with the count's mask only its candidates are visited (in ascending order,
     * as a full scan would), skipping the box tests most candidates fail; each is
     * still tested, so a mask that says too much changes nothing */
    const int masked = nc <= 64 && accepted != FFD_EBF_TEST_ALL;
    uint64_t bits = masked ? accepted & (nc < 64 ? ((uint64_t)1 << nc) - 1 : ~(uint64_t)0) : 0;
    for (size_t e = 0; masked ? bits != 0 : e < nc; e++) {
        if (masked) {
            e = lowest_bit(bits);
            bits &= bits - 1;
        }
        uint32_t j = cand ? cand[e] : (uint32_t)e;
        const ffd_ebf_kernel *k = &s->kernel[j];
        double v[3], rho2;
        if (!roi_rho2(k, x, v, &rho2) || !accept(s, rho2))
            continue;
        double phi = ffd_ebf_phi_of(rho2, s->inv2s2); /* eq. 1 over tau, windowed */
        col[m] = j;
        w[m] = phi;
        for (int a = 0; a < 3; a++) /* eq. 3: v = alpha a + beta b + gamma c */
            d[3 * m + a] = k->dual[a][0] * v[0] + k->dual[a][1] * v[1] + k->dual[a][2] * v[2];
        sum += phi;
        m++;
    }
    double pm = s->has_master ? ffd_ebf_phi(&s->master, s->inv2s2, x, NULL, NULL) : 0.0;
    double total = sum + pm; /* the denominator of eq. 5, master included (§3.2.2) */
    if (!(total > 0.0)) {
        *master_w = 1.0; /* under nothing: held where it is */
        return 0;
    }
    for (size_t e = 0; e < m; e++) {
        double we = w[e] / total; /* eq. 5 */
        w[e] = we;
        d[3 * e] *= we; /* eq. 7: E, F, G = w alpha, w beta, w gamma */
        d[3 * e + 1] *= we;
        d[3 * e + 2] *= we;
    }
    *master_w = pm / total;
    return m;
}
