/* pbffd — evaluation of the bound points, V = W P + D A (PB-FFD eq. 7). The
 * master is immovable, so its term is constant, and the rows reproduce the
 * points at the base state: V = V_base + W (P - P_base) + D (A - A_base).
 * Evaluated this way the identity is exact (bitwise) and points whose
 * controls did not move keep their positions bitwise. Each point is summed
 * independently in a fixed order: results do not depend on the thread count. */
#include "pbffd/pbffd.h"

#include <string.h>

/* 12 per control (dP, da, db, dc) into t; flags[j]: 1 moved, 2 frame changed.
 * Returns the OR of the flags. */
unsigned ffd_pb_delta_table(const ffd_pbffd *pb, double *t, unsigned char *flags)
{
    const ffd_pb_level *L = &pb->levels[0];
    unsigned any = 0;
    for (size_t j = 0; j < L->count; j++) {
        const ffd_ebf *c = &L->cur[j], *b = &L->base[j];
        double *d = t + 12 * j;
        unsigned f = 0;
        for (int k = 0; k < 3; k++) {
            d[k] = c->center[k] - b->center[k];
            d[3 + k] = c->frame[0][k] - b->frame[0][k];
            d[6 + k] = c->frame[1][k] - b->frame[1][k];
            d[9 + k] = c->frame[2][k] - b->frame[2][k];
            f |= d[k] != 0.0;
            f |= (d[3 + k] != 0.0 || d[6 + k] != 0.0 || d[9 + k] != 0.0) ? 3u : 0u;
        }
        flags[j] = (unsigned char)f;
        any |= f;
    }
    return any;
}

ffd_status ffd_pbffd_eval(const ffd_pbffd *pb, double *out, ffd_error *err)
{
    if (!out && pb->n)
        return ffd_fail(err, FFD_ERR_INVALID, "out is NULL");
    return ffd_pb_eval_rows(pb, &pb->mesh, pb->x_base, pb->n, out, err);
}

ffd_status ffd_pb_eval_rows(const ffd_pbffd *pb, const ffd_ebf_rows *rows, const double *x_base,
                            size_t count, double *out, ffd_error *err)
{
    const size_t m = pb->levels[0].count;
    double *table = ffd_malloc_array(m ? m : 1, 12 * sizeof *table);
    unsigned char *flags = ffd_malloc(m ? m : 1);
    if (!table || !flags) {
        ffd_free(table);
        ffd_free(flags);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory evaluating the deformer");
    }
    const unsigned any = ffd_pb_delta_table(pb, table, flags);
    const size_t *start = rows->start;
    const uint32_t *col = rows->col;
    const double *W = rows->w, *D = rows->d, *xb = x_base;
    const long long n = (long long)count;
    if (!any) {
        if (n)
            memcpy(out, xb, 3 * (size_t)n * sizeof *out);
    } else {
        /* Entries of controls that did not move add exact zeros: skipping them (and
         * the D terms when no frame changed) gives the same sums bitwise and reads
         * only the column indices of most entries. */
        const int frames = (any & 2u) != 0;
#pragma omp parallel for schedule(static, 1024)
        for (long long ii = 0; ii < n; ii++) {
            size_t i = (size_t)ii;
            double x = 0.0, y = 0.0, z = 0.0;
            for (size_t k = start[i]; k < start[i + 1]; k++) {
                const uint32_t j = col[k];
                if (!flags[j])
                    continue;
                const double *t = table + 12 * (size_t)j;
                const double w = W[k];
                /* PB-FFD eq. 7: w dp + (w alpha) da + (w beta) db + (w gamma) dc */
                if (frames) {
                    const double *q = D + 3 * k;
                    x += w * t[0] + q[0] * t[3] + q[1] * t[6] + q[2] * t[9];
                    y += w * t[1] + q[0] * t[4] + q[1] * t[7] + q[2] * t[10];
                    z += w * t[2] + q[0] * t[5] + q[1] * t[8] + q[2] * t[11];
                } else {
                    x += w * t[0];
                    y += w * t[1];
                    z += w * t[2];
                }
            }
            const double *b = xb + 3 * i;
            double *o = out + 3 * i;
            /* adding a zero displacement keeps the point bitwise (even -0.0) */
            o[0] = x != 0.0 ? b[0] + x : b[0];
            o[1] = y != 0.0 ? b[1] + y : b[1];
            o[2] = z != 0.0 ? b[2] + z : b[2];
        }
    }
    ffd_free(table);
    ffd_free(flags);
    return FFD_OK;
}
