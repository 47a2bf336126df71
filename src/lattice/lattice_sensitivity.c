/* lattice — the adjoint sensitivity product g = W^T w (docs/sensitivities.md):
 * with x'_i = x_i + sum_e B_e(s_i,t_i,u_i) (P_tie(e) - P0_tie(e)) (Hsu et al.
 * 1992, eq. 1 in displacement form, slots e tied to controls by the
 * selection matrix S of eq. 6), dJ/dP_j = sum_i sum_{e: tie(e) = j}
 * B_e(s_i,t_i,u_i) dJ/dx'_i.
 *
 * The binding's blocks (points of one cell, lattice_bind.c) make it cost
 * about one evaluation: a block's B-spline basis is computed once across its
 * points and summed against w into the cell's 64 slots, the same work as
 * the evaluation kernel's; the Bernstein basis is summed one axis at a time
 * (tensor factorisation, as bernstein_block). Determinism: every block sums
 * its points in order into its own 64 x 3 partial (B-spline) and the
 * partials are scattered onto the controls in block order; Bernstein blocks
 * (one cell: every point weighs every control) sum into one dense partial per
 * fixed range of blocks, the ranges added in order. Neither depends on the
 * thread count. */
#include "lattice/lattice.h"

#include <string.h>

#define BLK 256

/* B-spline: the 64 x 3 sums G_abc = sum_p B_a(s_p) B_b(t_p) B_c(u_p) w_p of
 * one block (w gathered per point in sorted order: wx, wy, wz). */
static void bspline_block_transpose(const double *s, const double *t, const double *u, size_t np,
                                    const double *wx, const double *wy, const double *wz,
                                    double *g)
{
    double bs[4][BLK], bt[4][BLK], bu[4][BLK];
    for (size_t p = 0; p < np; p++) { /* the uniform cubic basis, as bspline_block */
        double a = s[p], a2 = a * a, a3 = a2 * a, r = 1.0 - a;
        bs[0][p] = r * r * r * (1.0 / 6.0);
        bs[1][p] = (3.0 * a3 - 6.0 * a2 + 4.0) * (1.0 / 6.0);
        bs[2][p] = (-3.0 * a3 + 3.0 * a2 + 3.0 * a + 1.0) * (1.0 / 6.0);
        bs[3][p] = a3 * (1.0 / 6.0);
        a = t[p], a2 = a * a, a3 = a2 * a, r = 1.0 - a;
        bt[0][p] = r * r * r * (1.0 / 6.0);
        bt[1][p] = (3.0 * a3 - 6.0 * a2 + 4.0) * (1.0 / 6.0);
        bt[2][p] = (-3.0 * a3 + 3.0 * a2 + 3.0 * a + 1.0) * (1.0 / 6.0);
        bt[3][p] = a3 * (1.0 / 6.0);
        a = u[p], a2 = a * a, a3 = a2 * a, r = 1.0 - a;
        bu[0][p] = r * r * r * (1.0 / 6.0);
        bu[1][p] = (3.0 * a3 - 6.0 * a2 + 4.0) * (1.0 / 6.0);
        bu[2][p] = (-3.0 * a3 + 3.0 * a2 + 3.0 * a + 1.0) * (1.0 / 6.0);
        bu[3][p] = a3 * (1.0 / 6.0);
    }
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++) {
            double acc[4][3] = {{0}};
            for (size_t p = 0; p < np; p++) {
                double w = bs[a][p] * bt[b][p];
                double px = w * wx[p], py = w * wy[p], pz = w * wz[p];
                for (int c = 0; c < 4; c++) {
                    acc[c][0] += bu[c][p] * px;
                    acc[c][1] += bu[c][p] * py;
                    acc[c][2] += bu[c][p] * pz;
                }
            }
            memcpy(g + 3 * (a * 4 + b) * 4, acc, sizeof acc);
        }
}

/* Bernstein: adds sum_p B_a(s_p) B_b(t_p) B_c(u_p) w_p of one block to the
 * dense l m n x 3 partial g, one axis at a time. scratch holds
 * (l + m + n + 6) * BLK doubles. */
static void bernstein_block_transpose(const uint32_t res[3], const double *s, const double *t,
                                      const double *u, size_t np, const double *wx,
                                      const double *wy, const double *wz, double *g,
                                      double *scratch)
{
    const uint32_t l = res[0], m = res[1], n = res[2];
    double *bs = scratch, *bt = bs + (size_t)l * BLK, *bu = bt + (size_t)m * BLK;
    double *ax = bu + (size_t)n * BLK, *ay = ax + BLK, *az = ay + BLK;
    double *bx = az + BLK, *by = bx + BLK, *bz = by + BLK;
    double tmp[FFD_BERNSTEIN_MAX_RES];
    for (size_t p = 0; p < np; p++) {
        ffd_bernstein_basis(l - 1, s[p], tmp, NULL);
        for (uint32_t a = 0; a < l; a++)
            bs[(size_t)a * BLK + p] = tmp[a];
        ffd_bernstein_basis(m - 1, t[p], tmp, NULL);
        for (uint32_t b = 0; b < m; b++)
            bt[(size_t)b * BLK + p] = tmp[b];
        ffd_bernstein_basis(n - 1, u[p], tmp, NULL);
        for (uint32_t c = 0; c < n; c++)
            bu[(size_t)c * BLK + p] = tmp[c];
    }
    for (uint32_t a = 0; a < l; a++) {
        const double *ba = bs + (size_t)a * BLK;
        for (size_t p = 0; p < np; p++) {
            ax[p] = ba[p] * wx[p];
            ay[p] = ba[p] * wy[p];
            az[p] = ba[p] * wz[p];
        }
        for (uint32_t b = 0; b < m; b++) {
            const double *bb = bt + (size_t)b * BLK;
            for (size_t p = 0; p < np; p++) {
                bx[p] = bb[p] * ax[p];
                by[p] = bb[p] * ay[p];
                bz[p] = bb[p] * az[p];
            }
            double *gab = g + 3 * ((size_t)a * m + b) * n;
            for (uint32_t c = 0; c < n; c++) {
                const double *bc = bu + (size_t)c * BLK;
                double sx = 0, sy = 0, sz = 0;
                for (size_t p = 0; p < np; p++) {
                    sx += bc[p] * bx[p];
                    sy += bc[p] * by[p];
                    sz += bc[p] * bz[p];
                }
                gab[3 * c] += sx;
                gab[3 * c + 1] += sy;
                gab[3 * c + 2] += sz;
            }
        }
    }
}

/* w of a block's points (original order through bind->order) as three arrays. */
static void gather_w(const ffd_lattice_binding *bind, const double *w, size_t p0, size_t np,
                     double *wx, double *wy, double *wz)
{
    for (size_t p = 0; p < np; p++) {
        const double *src = w + 3 * (size_t)bind->order[p0 + p];
        wx[p] = src[0];
        wy[p] = src[1];
        wz[p] = src[2];
    }
}

/* Blocks of a Bernstein binding per fixed range: a count from the sizes
 * alone, at most 16, the dense partials under 256 MiB. */
static size_t bernstein_ranges(size_t blocks, size_t controls)
{
    size_t r = blocks < 16 ? blocks : 16;
    while (r > 1 && (double)r * (double)controls * 24.0 > 256.0 * 1024 * 1024)
        r--;
    return r ? r : 1;
}

ffd_status ffd_lattice_sensitivity_transpose(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                             const double *w, double *out, ffd_error *err)
{
    ffd_status st = ffd_lattice_check_binding(lat, bind, err);
    if (st != FFD_OK)
        return st;
    if (lat->gen)
        return ffd_lattice_general_transpose(lat, bind, w, out, err);
    const size_t controls = (size_t)lat->res[0] * lat->res[1] * lat->res[2];
    const size_t nin = bind->inside_count, nb = bind->block_count;
    const double *S = bind->local, *T = bind->local + nin, *U = bind->local + 2 * nin;
    const int bspline = lat->basis == FFD_BASIS_BSPLINE;
    memset(out, 0, controls * 3 * sizeof *out);
    int failed = 0;
    if (bspline) {
        double *partial = ffd_malloc_array(nb ? nb : 1, 64 * 3 * sizeof *partial);
        if (!partial)
            return ffd_fail(err, FFD_ERR_NOMEM, "sensitivity transpose product: out of memory "
                                                "for %zu blocks",
                            nb);
#pragma omp parallel
        {
            double wx[BLK], wy[BLK], wz[BLK];
#pragma omp for schedule(dynamic, 4)
            for (size_t bi = 0; bi < nb; bi++) {
                const ffd_lattice_block *blk = &bind->blocks[bi];
                size_t p0 = blk->begin, np = blk->end - blk->begin;
                gather_w(bind, w, p0, np, wx, wy, wz);
                bspline_block_transpose(S + p0, T + p0, U + p0, np, wx, wy, wz,
                                        partial + 64 * 3 * bi);
            }
        }
        for (size_t bi = 0; bi < nb; bi++) { /* in block order: S^T of eq. 6 */
            const uint32_t *cell = bind->blocks[bi].cell;
            const double *g = partial + 64 * 3 * bi;
            for (int a = 0; a < 4; a++)
                for (int b = 0; b < 4; b++)
                    for (int c = 0; c < 4; c++) {
                        size_t e = (((size_t)(cell[0] + a)) * lat->ext[1] + cell[1] + b)
                                       * lat->ext[2]
                                   + cell[2] + c;
                        double *o = out + 3 * (size_t)lat->tie[e];
                        const double *q = g + 3 * ((a * 4 + b) * 4 + c);
                        o[0] += q[0];
                        o[1] += q[1];
                        o[2] += q[2];
                    }
        }
        ffd_free(partial);
    } else {
        const size_t ranges = bernstein_ranges(nb, controls);
        const size_t scratch_n = ((size_t)lat->res[0] + lat->res[1] + lat->res[2] + 6) * BLK;
        double *partial = ranges > 1 ? ffd_calloc(ranges - 1, controls * 3 * sizeof *partial)
                                     : NULL;
        if (ranges > 1 && !partial)
            return ffd_fail(err, FFD_ERR_NOMEM, "sensitivity transpose product: out of memory "
                                                "for %zu controls",
                            controls);
#pragma omp parallel for schedule(dynamic, 1) reduction(| : failed)
        for (size_t r = 0; r < ranges; r++) {
            double wx[BLK], wy[BLK], wz[BLK];
            double *scratch = ffd_malloc_array(scratch_n, sizeof *scratch);
            if (!scratch) {
                failed = 1;
                continue;
            }
            double *g = r ? partial + (r - 1) * controls * 3 : out;
            for (size_t bi = nb * r / ranges; bi < nb * (r + 1) / ranges; bi++) {
                const ffd_lattice_block *blk = &bind->blocks[bi];
                size_t p0 = blk->begin, np = blk->end - blk->begin;
                gather_w(bind, w, p0, np, wx, wy, wz);
                bernstein_block_transpose(lat->res, S + p0, T + p0, U + p0, np, wx, wy, wz, g,
                                          scratch);
            }
            ffd_free(scratch);
        }
        for (size_t r = 1; r < ranges && !failed; r++)
            for (size_t c = 0; c < 3 * controls; c++)
                out[c] += partial[(r - 1) * controls * 3 + c];
        ffd_free(partial);
        if (failed)
            return ffd_fail(err, FFD_ERR_NOMEM, "sensitivity transpose product: out of memory");
    }
    /* outside points that follow the lattice (clamp, extrapolate) at the
     * parameters the evaluation uses, in their order */
    const size_t nout = bind->n - nin;
    if (bind->outside == FFD_OUTSIDE_FIXED)
        return FFD_OK;
    for (size_t o = 0; o < nout; o++) {
        const double *stu = bind->out_params + 3 * o, *wi = w + 3 * (size_t)bind->out_index[o];
        double bb[3][FFD_BERNSTEIN_MAX_RES > 4 ? FFD_BERNSTEIN_MAX_RES : 4];
        uint32_t first[3], cnt[3];
        for (int c = 0; c < 3; c++) {
            ffd_axis_basis(lat->basis, lat->res[c], stu[c], &first[c], bb[c], NULL);
            cnt[c] = bspline ? 4 : lat->res[c];
        }
        for (uint32_t a = 0; a < cnt[0]; a++)
            for (uint32_t b = 0; b < cnt[1]; b++)
                for (uint32_t c = 0; c < cnt[2]; c++) {
                    size_t e = (((size_t)(first[0] + a)) * lat->ext[1] + first[1] + b) * lat->ext[2]
                               + first[2] + c;
                    double wt = bb[0][a] * bb[1][b] * bb[2][c];
                    if (bind->falloff) /* FFD_OUTSIDE_FALLOFF: W's row scaled by f */
                        wt *= bind->falloff[bind->out_index[o]];
                    double *dst = out + 3 * (size_t)(bspline ? lat->tie[e] : e);
                    dst[0] += wt * wi[0];
                    dst[1] += wt * wi[1];
                    dst[2] += wt * wi[2];
                }
    }
    return FFD_OK;
}
