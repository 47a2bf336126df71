/* lattice — the block kernels of the evaluation (Hsu et al. 1992, eq. 1;
 * Sederberg & Parry 1986, eq. 2), written once and compiled once per
 * instruction set: lattice_eval.c includes this file three times with
 * KERNEL(name) naming the copy and KERNEL_TARGET its target attribute, and
 * picks a copy per call from the CPU's features (ffd_lattice_simd_path).
 *
 * A block is np <= BLK points of one cell; the inner loops run across points
 * (the compiler vectorises them). Each point goes through one fixed sequence
 * of operations, so a point's result does not depend on its block or thread. */

/* Uniform cubic B-spline: x = sum_abc B_a(s) B_b(t) B_c(u) D_abc over the
 * cell's 64 gathered displacements cp (4 x 4 x 4 by 3). */
KERNEL_TARGET static void KERNEL(bspline_block)(const double *restrict s, const double *restrict t,
                                                const double *restrict u, size_t np,
                                                const double *restrict cp, double *restrict x,
                                                double *restrict y, double *restrict z)
{
    double bs[4][BLK], bt[4][BLK], bu[4][BLK], wab[BLK];
    for (size_t p = 0; p < np; p++) {
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
        x[p] = y[p] = z[p] = 0.0;
    }
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++) {
            for (size_t p = 0; p < np; p++)
                wab[p] = bs[a][p] * bt[b][p];
            for (int c = 0; c < 4; c++) {
                const double *q = cp + 3 * ((a * 4 + b) * 4 + c);
                const double qx = q[0], qy = q[1], qz = q[2];
                for (size_t p = 0; p < np; p++) {
                    double w = wab[p] * bu[c][p];
                    x[p] += w * qx;
                    y[p] += w * qy;
                    z[p] += w * qz;
                }
            }
        }
}

/* Bernstein: x = sum_abc B_a(s) B_b(t) B_c(u) D_abc over the whole net;
 * scratch holds (l + m + n + 1) * BLK doubles. */
KERNEL_TARGET static void KERNEL(bernstein_block)(const ffd_lattice *lat, const double *restrict s,
                                                  const double *restrict t,
                                                  const double *restrict u, size_t np,
                                                  double *restrict x, double *restrict y,
                                                  double *restrict z, double *restrict scratch)
{
    const uint32_t l = lat->res[0], m = lat->res[1], n = lat->res[2];
    double *bs = scratch, *bt = bs + (size_t)l * BLK, *bu = bt + (size_t)m * BLK;
    double *wab = bu + (size_t)n * BLK;
    double tmp[FFD_BERNSTEIN_MAX_RES];
    for (size_t p = 0; p < np; p++) {
        ffd_bernstein_basis(l - 1, s[p], tmp, NULL);
        for (uint32_t i = 0; i < l; i++)
            bs[(size_t)i * BLK + p] = tmp[i];
        ffd_bernstein_basis(m - 1, t[p], tmp, NULL);
        for (uint32_t i = 0; i < m; i++)
            bt[(size_t)i * BLK + p] = tmp[i];
        ffd_bernstein_basis(n - 1, u[p], tmp, NULL);
        for (uint32_t i = 0; i < n; i++)
            bu[(size_t)i * BLK + p] = tmp[i];
        x[p] = y[p] = z[p] = 0.0;
    }
    for (uint32_t a = 0; a < l; a++)
        for (uint32_t b = 0; b < m; b++) {
            const double *ba = bs + (size_t)a * BLK, *bb = bt + (size_t)b * BLK;
            for (size_t p = 0; p < np; p++)
                wab[p] = ba[p] * bb[p];
            for (uint32_t c = 0; c < n; c++) {
                const double *q = lat->D_ext + 3 * (((size_t)a * m + b) * n + c);
                const double qx = q[0], qy = q[1], qz = q[2];
                const double *bc = bu + (size_t)c * BLK;
                for (size_t p = 0; p < np; p++) {
                    double w = wab[p] * bc[p];
                    x[p] += w * qx;
                    y[p] += w * qy;
                    z[p] += w * qz;
                }
            }
        }
}
