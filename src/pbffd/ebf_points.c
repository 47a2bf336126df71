/* pbffd — other point sets bound to a deformer after its creation (the
 * public ffd_deformer_bind): each point gets the row W_i, D_i of PB-FFD
 * eq. 7 it would have got as one of the points given to ffd_pbffd_create,
 * i.e. parameterised (eq. 3-5) against level 0's base state at its own
 * position, and is evaluated by the same displacement form
 *   x' = x + W_i (P - P_base) + D_i (A - A_base)
 * (ffd_pb_eval_rows). That holds while no control-set edit has rebased the
 * deformer (ebf_edit.c: a rebase re-parameterises some points in a deformed
 * state, which only the points present then went through). */
#include "pbffd/pbffd.h"

#include <string.h>

static ffd_status rebased(const ffd_pbffd *pb, const char *what, ffd_error *err)
{
    return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                    "%s: the control set was edited in a deformed state (%llu rebasing "
                    "edits): points other than those bound at creation cannot be bound as "
                    "they would have been",
                    what, (unsigned long long)pb->rebase_count);
}

ffd_status ffd_pb_points_bind(const ffd_pbffd *pb, const double *points, size_t n,
                              ffd_pb_points *out, ffd_error *err)
{
    memset(out, 0, sizeof *out);
    if (pb->rebase_count)
        return rebased(pb, "bind", err);
    const ffd_pb_level *L0 = &pb->levels[0];
    ffd_ebf_space s;
    out->x = ffd_malloc_array(n ? n : 1, 3 * sizeof *out->x);
    if (!out->x)
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    if (n)
        memcpy(out->x, points, 3 * n * sizeof *out->x);
    /* as ffd_pbffd_create binds its points (with the grid) */
    ffd_status st = ffd_ebf_space_init(&s, L0->base, L0->count, pb->has_master ? &pb->master : NULL,
                                       pb->master_weight, pb->sigma, 1);
    if (!st) {
        st = ffd_ebf_rows_bind(&s, points, n, 0, 0, &out->rows);
        ffd_ebf_space_free(&s);
    }
    if (st) {
        ffd_pb_points_free(out);
        return ffd_fail(err, FFD_ERR_NOMEM, "bind: out of memory for %zu points", n);
    }
    out->n = n;
    out->edit_count = pb->edit_count;
    return FFD_OK;
}

void ffd_pb_points_free(ffd_pb_points *p)
{
    if (!p)
        return;
    ffd_free(p->x);
    ffd_ebf_rows_free(&p->rows);
    memset(p, 0, sizeof *p);
}

ffd_status ffd_pb_points_current(const ffd_pbffd *pb, const ffd_pb_points *p,
                                 ffd_pb_points *fresh, const ffd_pb_points **use, ffd_error *err)
{
    memset(fresh, 0, sizeof *fresh);
    *use = p;
    if (p->edit_count == pb->edit_count)
        return FFD_OK;
    /* an edit of disabled controls renumbered the columns (a rebase is refused) */
    ffd_status st = ffd_pb_points_bind(pb, p->x, p->n, fresh, err);
    if (!st)
        *use = fresh;
    return st;
}

ffd_status ffd_pb_points_eval(const ffd_pbffd *pb, const ffd_pb_points *p, double *out,
                              ffd_error *err)
{
    ffd_pb_points fresh;
    const ffd_pb_points *use;
    ffd_status st = ffd_pb_points_current(pb, p, &fresh, &use, err);
    if (!st)
        st = ffd_pb_eval_rows(pb, &use->rows, use->x, use->n, out, err);
    ffd_pb_points_free(&fresh);
    return st;
}

ffd_status ffd_pb_points_jacobian(const ffd_pbffd *pb, const ffd_pb_points *p, double *out,
                                  ffd_error *err)
{
    ffd_pb_points fresh;
    const ffd_pb_points *use;
    ffd_status st = ffd_pb_points_current(pb, p, &fresh, &use, err);
    if (st)
        return st;
    const ffd_pb_level *L0 = &pb->levels[0];
    ffd_ebf_kernel *K = ffd_malloc_array(L0->count ? L0->count : 1, sizeof *K);
    if (!K) {
        ffd_pb_points_free(&fresh);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory computing Jacobians");
    }
    /* the kernels the rows were made against (ffd_pb_version_kernels' weights) */
    for (size_t j = 0; j < L0->count; j++)
        ffd_ebf_kernel_init(&L0->base[j], L0->base[j].disabled ? 0.0 : 1.0, &K[j]);
    ffd_ebf_kernel master;
    ffd_ebf_kernel_init(&pb->master, pb->master_weight, &master);
    const ffd_ebf_kernel *mk = pb->has_master ? &master : NULL;
    const long long n = (long long)use->n;
#pragma omp parallel for schedule(static, 1024)
    for (long long i = 0; i < n; i++)
        ffd_pb_jacobian_row(pb, K, L0->base, mk, &use->rows, (size_t)i, use->x + 3 * (size_t)i,
                            NULL, out + 9 * (size_t)i);
    ffd_free(K);
    ffd_pb_points_free(&fresh);
    return FFD_OK;
}
