/* lattice — Bernstein polynomials of the Sederberg-Parry FFD. */
#include "lattice/lattice.h"

#include <math.h>

void ffd_bernstein_basis(uint32_t deg, double s, double *b, double *d)
{
    /* b_i = C(deg,i) s^i (1-s)^(deg-i), by the stable triangle recurrence */
    double r = 1.0 - s;
    if (deg == 0) {
        b[0] = 1.0;
        if (d)
            d[0] = 0.0;
        return;
    }
    /* degree deg-1 values first (for the derivative), then one more step */
    b[0] = 1.0;
    for (uint32_t k = 1; k < deg; k++) {
        b[k] = s * b[k - 1];
        for (uint32_t i = k - 1; i > 0; i--)
            b[i] = r * b[i] + s * b[i - 1];
        b[0] = r * b[0];
    }
    if (d) {
        /* B'_{i,deg} = deg (B_{i-1,deg-1} - B_{i,deg-1}) */
        d[deg] = deg * b[deg - 1];
        for (uint32_t i = deg - 1; i > 0; i--)
            d[i] = deg * (b[i - 1] - b[i]);
        d[0] = -(double)deg * b[0];
    }
    b[deg] = s * b[deg - 1];
    for (uint32_t i = deg - 1; i > 0; i--)
        b[i] = r * b[i] + s * b[i - 1];
    b[0] = r * b[0];
}
