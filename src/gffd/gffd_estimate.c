/* gffd — estimates of a field fit's cost before it runs (ffd_limits,
 * docs/rig.md "Limits"): the samples of the rules in ffd.h, the dense
 * interpolation matrix of the variational interpolant (Turk & O'Brien 1999)
 * and its factorisation. Measured: 4,000 samples fit in 0.5 s
 * (docs/benchmarks.md); 20,000 samples took 74 s and 3 GB. */
#include "gffd/gffd.h"

#include <math.h>

#define SHELLS 4.0

double ffd_gffd_estimate_samples(const ffd_gffd_primitive *p, size_t max_samples)
{
    double n = 0, r = p->radius > 0 ? p->radius : 1;
    switch (p->kind) {
    case FFD_GFFD_POINT:
        n = 1 + 14 * SHELLS;
        break;
    case FFD_GFFD_POLYLINE: {
        double stations = 1;
        for (size_t i = 0; i + 1 < p->vertex_count; i++) {
            const double *a = p->vertices + 3 * i, *b = a + 3;
            double len = sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) +
                              (b[2] - a[2]) * (b[2] - a[2]));
            double k = ceil(len / (0.5 * r));
            stations += k < 1 ? 1 : (isfinite(k) ? k : 1e18);
        }
        /* a ring per station, the two ends' caps */
        n = stations * (1 + 6 * SHELLS) + 2 * 5 * SHELLS;
        break;
    }
    default: { /* stations at vertices and at the fan triangles of the faces: both
                  normals; boundary vertices: the outward direction too */
        double fc = (double)p->face_count, tris = fc;
        if (p->face_offsets) {
            double corners = (double)p->face_offsets[p->face_count];
            tris = corners - 2 * fc > fc ? corners - 2 * fc : fc;
        }
        n = ((double)p->vertex_count + tris) * (1 + 2 * SHELLS) + (double)p->vertex_count * SHELLS;
        break;
    }
    }
    if (max_samples > 0 && n > (double)max_samples)
        n = (double)max_samples;
    return n;
}

void ffd_gffd_estimate_fit(double m, size_t face_count, double *bytes, double *work)
{
    double d = m + 4;
    *bytes = 8.0 * d * d + 100.0 * d;
    *work = 0.1 * d * d * d / 3.0 + 30.0 * m * ((double)face_count + 1) + 20.0 * d * d;
}
