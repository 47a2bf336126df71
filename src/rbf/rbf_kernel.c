/* rbf_kernel — the radial kernels of PyGeM's RBFFactory (pygem/rbf_factory.py),
 * evaluated with PyGeM's own sequence of operations so that the numbers
 * agree with PyGeM's to rounding, and their derivatives for the Jacobian. */
#include "ffd.h"
#include "rbf/rbf.h"

#include <math.h>

static const char *const kernel_names[FFD_RBF_KERNEL_COUNT] = {
    "gaussian_spline",   "multi_quadratic_biharmonic_spline", "inv_multi_quadratic_biharmonic_spline",
    "thin_plate_spline", "beckert_wendland_c2_basis",         "polyharmonic_spline"};

const char *ffd_rbf_kernel_name(ffd_rbf_kernel kernel)
{
    return (unsigned)kernel < FFD_RBF_KERNEL_COUNT ? kernel_names[kernel] : NULL;
}

/* a^k for a >= 0 and a small integer k, as numpy's power of a float. */
static double ipow(double a, unsigned k)
{
    return pow(a, (double)k);
}

double ffd_rbf_phi(ffd_rbf_kernel kernel, double r, unsigned k, double x, double *dphi)
{
    double a = x / r, phi = 0, d = 0;
    switch (kernel) {
    case FFD_RBF_GAUSSIAN: /* exp(-x^2 / r^2) */
        phi = exp(-(x * x) / (r * r));
        d = -2 * x / (r * r) * phi;
        break;
    case FFD_RBF_MULTIQUADRIC: /* sqrt(x^2 + r^2) */
        phi = sqrt(x * x + r * r);
        d = x / phi;
        break;
    case FFD_RBF_INV_MULTIQUADRIC: /* (x^2 + r^2)^(-1/2) */
        phi = 1.0 / sqrt(x * x + r * r);
        d = -x * phi * phi * phi;
        break;
    case FFD_RBF_THIN_PLATE: /* a^k ln a, a^k where a = 0 */
        phi = ipow(a, k);
        if (a > 0) {
            phi *= log(a);
            d = (k * ipow(a, k - 1) * log(a) + ipow(a, k - 1)) / r;
        }
        break;
    case FFD_RBF_WENDLAND_C2: /* (1 - a)_+^4 (4a + 1) */
        phi = (1 - a > 0 ? ipow(1 - a, 4) : 0) * (4 * a + 1);
        d = 1 - a > 0 ? -20 * a * ipow(1 - a, 3) / r : 0;
        break;
    case FFD_RBF_POLYHARMONIC:
        if (k & 1) {
            phi = ipow(a, k);
            d = k == 1 ? (x > 0 ? 1 / r : 0) : k * ipow(a, k - 1) / r;
        } else {
            phi = a < 1 ? ipow(a, k - 1) * log(pow(a, a)) : ipow(a, k) * log(a);
            if (a > 0)
                d = (k * ipow(a, k - 1) * log(a) + ipow(a, k - 1)) / r;
        }
        break;
    default:
        break;
    }
    if (dphi)
        *dphi = d;
    return phi;
}
