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
    double bs[4][BLK], bt[4][BLK], bu[4][BLK];
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
    /* the four c terms of a row (a, b) in one pass over the points: the same
     * sums in the same order as one pass per term, with a quarter of the
     * loads and stores of x, y, z */
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++) {
            const double *q = cp + 3 * (a * 4 + b) * 4;
            const double *ba = bs[a], *bb = bt[b];
            for (size_t p = 0; p < np; p++) {
                double w = ba[p] * bb[p];
                double w0 = w * bu[0][p], w1 = w * bu[1][p], w2 = w * bu[2][p], w3 = w * bu[3][p];
                x[p] = x[p] + w0 * q[0] + w1 * q[3] + w2 * q[6] + w3 * q[9];
                y[p] = y[p] + w0 * q[1] + w1 * q[4] + w2 * q[7] + w3 * q[10];
                z[p] = z[p] + w0 * q[2] + w1 * q[5] + w2 * q[8] + w3 * q[11];
            }
        }
}

/* Bernstein polynomials B_{i,deg} of the np parameters s, i = 0..deg, into
 * b[i * BLK + p]: the triangle recurrence of ffd_bernstein_basis run across
 * points (b_i = (1-s) b_i + s b_{i-1}, degree by degree). */
KERNEL_TARGET static void KERNEL(bernstein_axis)(uint32_t deg, const double *restrict s, size_t np,
                                                 double *restrict b)
{
    for (size_t p = 0; p < np; p++)
        b[p] = 1.0;
    for (uint32_t k = 1; k <= deg; k++) {
        double *bk = b + (size_t)k * BLK;
        const double *bk1 = bk - BLK;
        for (size_t p = 0; p < np; p++)
            bk[p] = s[p] * bk1[p];
        for (uint32_t i = k - 1; i > 0; i--) {
            double *bi = b + (size_t)i * BLK;
            const double *bi1 = bi - BLK;
            for (size_t p = 0; p < np; p++)
                bi[p] = (1.0 - s[p]) * bi[p] + s[p] * bi1[p];
        }
        for (size_t p = 0; p < np; p++)
            b[p] = (1.0 - s[p]) * b[p];
    }
}

/* Bernstein: x = sum_a B_a(s) sum_b B_b(t) sum_c B_c(u) D_abc over the whole
 * net D (the displacements D_ext, or any net laid out like them: the
 * sensitivity product W v), summed one axis at a time (tensor
 * factorisation): l m n + l m + l multiply-adds per coordinate instead of
 * 4 l m n for the full products B_a B_b B_c. scratch holds
 * (l + m + n + 6) * BLK doubles. */
KERNEL_TARGET static void KERNEL(bernstein_block)(const ffd_lattice *lat, const double *restrict net,
                                                  const double *restrict s,
                                                  const double *restrict t,
                                                  const double *restrict u, size_t np,
                                                  double *restrict x, double *restrict y,
                                                  double *restrict z, double *restrict scratch)
{
    const uint32_t l = lat->res[0], m = lat->res[1], n = lat->res[2];
    double *restrict bs = scratch, *restrict bt = bs + (size_t)l * BLK;
    double *restrict bu = bt + (size_t)m * BLK;
    double *restrict xc = bu + (size_t)n * BLK, *restrict yc = xc + BLK, *restrict zc = yc + BLK;
    double *restrict xb = zc + BLK, *restrict yb = xb + BLK, *restrict zb = yb + BLK;
    KERNEL(bernstein_axis)(l - 1, s, np, bs);
    KERNEL(bernstein_axis)(m - 1, t, np, bt);
    KERNEL(bernstein_axis)(n - 1, u, np, bu);
    for (size_t p = 0; p < np; p++)
        x[p] = y[p] = z[p] = 0.0;
    for (uint32_t a = 0; a < l; a++) {
        for (size_t p = 0; p < np; p++)
            xb[p] = yb[p] = zb[p] = 0.0;
        for (uint32_t b = 0; b < m; b++) {
            const double *q = net + 3 * ((size_t)a * m + b) * n;
            for (size_t p = 0; p < np; p++)
                xc[p] = yc[p] = zc[p] = 0.0;
            uint32_t c = 0;
            for (; c + 4 <= n; c += 4) { /* four terms per pass, summed in order */
                const double *q0 = q + 3 * c;
                const double *b0 = bu + (size_t)c * BLK, *b1 = b0 + BLK, *b2 = b1 + BLK,
                             *b3 = b2 + BLK;
                for (size_t p = 0; p < np; p++) {
                    xc[p] = xc[p] + b0[p] * q0[0] + b1[p] * q0[3] + b2[p] * q0[6] + b3[p] * q0[9];
                    yc[p] = yc[p] + b0[p] * q0[1] + b1[p] * q0[4] + b2[p] * q0[7] + b3[p] * q0[10];
                    zc[p] = zc[p] + b0[p] * q0[2] + b1[p] * q0[5] + b2[p] * q0[8] + b3[p] * q0[11];
                }
            }
            for (; c < n; c++) {
                const double qx = q[3 * c], qy = q[3 * c + 1], qz = q[3 * c + 2];
                const double *bc = bu + (size_t)c * BLK;
                for (size_t p = 0; p < np; p++) {
                    xc[p] += bc[p] * qx;
                    yc[p] += bc[p] * qy;
                    zc[p] += bc[p] * qz;
                }
            }
            const double *bb = bt + (size_t)b * BLK;
            for (size_t p = 0; p < np; p++) {
                xb[p] += bb[p] * xc[p];
                yb[p] += bb[p] * yc[p];
                zb[p] += bb[p] * zc[p];
            }
        }
        const double *ba = bs + (size_t)a * BLK;
        for (size_t p = 0; p < np; p++) {
            x[p] += ba[p] * xb[p];
            y[p] += ba[p] * yb[p];
            z[p] += ba[p] * zb[p];
        }
    }
}
