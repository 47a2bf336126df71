/* pbffd — evaluation of the bound points, V = W P + D A (PB-FFD eq. 7). The
 * master is immovable, so its term is constant, and the rows reproduce the
 * points at the base state: V = V_base + W (P - P_base) + D (A - A_base).
 * Evaluated this way the identity is exact (bitwise) and points whose
 * controls did not move keep their positions bitwise. Each point is summed
 * independently in a fixed order: results do not depend on the thread count. */
#include "pbffd/pbffd.h"

#include <string.h>

void ffd_pb_delta_table(const ffd_pbffd *pb, double *t)
{
    const ffd_pb_level *L = &pb->levels[0];
    for (size_t j = 0; j < L->count; j++) {
        const ffd_ebf *c = &L->cur[j], *b = &L->base[j];
        double *d = t + 12 * j;
        for (int k = 0; k < 3; k++) {
            d[k] = c->center[k] - b->center[k];
            d[3 + k] = c->frame[0][k] - b->frame[0][k];
            d[6 + k] = c->frame[1][k] - b->frame[1][k];
            d[9 + k] = c->frame[2][k] - b->frame[2][k];
        }
    }
}

ffd_status ffd_pbffd_eval(const ffd_pbffd *pb, double *out, ffd_error *err)
{
    if (!out && pb->n)
        return ffd_fail(err, FFD_ERR_INVALID, "out is NULL");
    const size_t m = pb->levels[0].count;
    double *table = ffd_malloc_array(m ? m : 1, 12 * sizeof *table);
    if (!table)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory evaluating the deformer");
    ffd_pb_delta_table(pb, table);
    const size_t *start = pb->mesh.start;
    const uint32_t *col = pb->mesh.col;
    const double *wd = pb->mesh.wd, *xb = pb->x_base;
    const long long n = (long long)pb->n;
#pragma omp parallel for schedule(static, 1024)
    for (long long ii = 0; ii < n; ii++) {
        size_t i = (size_t)ii;
        double x = 0.0, y = 0.0, z = 0.0;
        for (size_t k = start[i]; k < start[i + 1]; k++) {
            const double *t = table + 12 * (size_t)col[k];
            const double *q = wd + 4 * k;
            /* w dp + (w alpha) da + (w beta) db + (w gamma) dc */
            x += q[0] * t[0] + q[1] * t[3] + q[2] * t[6] + q[3] * t[9];
            y += q[0] * t[1] + q[1] * t[4] + q[2] * t[7] + q[3] * t[10];
            z += q[0] * t[2] + q[1] * t[5] + q[2] * t[8] + q[3] * t[11];
        }
        const double *b = xb + 3 * i;
        double *o = out + 3 * i;
        /* adding a zero displacement keeps the point bitwise (even -0.0) */
        o[0] = x != 0.0 ? b[0] + x : b[0];
        o[1] = y != 0.0 ? b[1] + y : b[1];
        o[2] = z != 0.0 ? b[2] + z : b[2];
    }
    ffd_free(table);
    return FFD_OK;
}
