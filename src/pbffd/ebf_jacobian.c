/* pbffd — the Jacobian of the deformation at the bound points (for normals).
 * A point x parameterised against a control state S moves to
 *   x' = x + sum_j w_j(x) (dp_j + dA_j u_j(x)),   w_j = phi_j / (sum_k phi_k + phi_m)
 * (PB-FFD eq. 4-5 in displacement form; dp_j, dA_j: the change of centre and
 * frame since S; the master does not move), so
 *   dx'/dx = I + sum_j [(dp_j + dA_j u_j) grad(w_j)^T + w_j dA_j F_j^-1].
 * S is the snapshot of level 0 the point's row was made against (creation, or
 * the control-set edit that re-parameterised it); a point re-parameterised in
 * a deformed state composes with the Jacobian it had then (J_ref). */
#include "pbffd/pbffd.h"

#include <string.h>

ffd_status ffd_pb_version_kernels(const ffd_pbffd *pb, ffd_ebf_kernel ***out)
{
    ffd_ebf_kernel **vk = ffd_calloc(pb->version_count, sizeof *vk);
    if (!vk)
        return FFD_ERR_NOMEM;
    for (size_t v = 0; v < pb->version_count; v++) {
        const ffd_pb_version *V = &pb->versions[v];
        if (!V->ctl || (V->refs == 0 && v != pb->version_latest))
            continue;
        vk[v] = ffd_malloc_array(V->count ? V->count : 1, sizeof **vk);
        if (!vk[v]) {
            ffd_pb_version_kernels_free(pb, vk);
            return FFD_ERR_NOMEM;
        }
        for (size_t j = 0; j < V->count; j++)
            ffd_ebf_kernel_init(&V->ctl[j], V->ctl[j].disabled ? 0.0 : 1.0, &vk[v][j]);
    }
    *out = vk;
    return FFD_OK;
}

void ffd_pb_version_kernels_free(const ffd_pbffd *pb, ffd_ebf_kernel **vk)
{
    if (!vk)
        return;
    for (size_t v = 0; v < pb->version_count; v++)
        ffd_free(vk[v]);
    ffd_free(vk);
}

void ffd_pb_jacobian_point(const ffd_pbffd *pb, ffd_ebf_kernel *const *vk,
                           const ffd_ebf_kernel *master, size_t i, double J[9])
{
    const uint32_t v = pb->version ? pb->version[i] : 0;
    ffd_pb_jacobian_row(pb, vk[v], pb->versions[v].ctl, master, &pb->mesh, i, pb->x_ref + 3 * i,
                        pb->J_ref ? pb->J_ref + 9 * i : NULL, J);
}

void ffd_pb_jacobian_row(const ffd_pbffd *pb, const ffd_ebf_kernel *K, const ffd_ebf *snap,
                         const ffd_ebf_kernel *master, const ffd_ebf_rows *rows, size_t i,
                         const double x[3], const double *J_ref, double J[9])
{
    const ffd_ebf *cur = pb->levels[0].cur;
    const double inv2s2 = 1.0 / (2.0 * pb->sigma * pb->sigma);
    const size_t b = rows->start[i], e = rows->start[i + 1];
    double F[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    /* the denominator of eq. 5 and its gradient, summed in the binding's order */
    double S = 0.0, gS[3] = {0, 0, 0}, g[3];
    for (size_t k = b; k < e; k++) {
        S += ffd_ebf_phi(&K[rows->col[k]], inv2s2, x, NULL, g);
        for (int c = 0; c < 3; c++)
            gS[c] += g[c];
    }
    if (master) {
        S += ffd_ebf_phi(master, inv2s2, x, NULL, g);
        for (int c = 0; c < 3; c++)
            gS[c] += g[c];
    }
    if (e > b && S > 0.0) {
        for (size_t k = b; k < e; k++) {
            const uint32_t j = rows->col[k];
            double u[3];
            double phi = ffd_ebf_phi(&K[j], inv2s2, x, u, g);
            double w = phi / S, gw[3], disp[3], dA[3][3];
            for (int c = 0; c < 3; c++) {
                gw[c] = (g[c] - w * gS[c]) / S;
                for (int a = 0; a < 3; a++)
                    dA[a][c] = cur[j].frame[a][c] - snap[j].frame[a][c];
                disp[c] = cur[j].center[c] - snap[j].center[c] + u[0] * dA[0][c] + u[1] * dA[1][c] +
                          u[2] * dA[2][c];
            }
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++)
                    F[3 * r + c] += disp[r] * gw[c] +
                                    w * (dA[0][r] * K[j].dual[0][c] + dA[1][r] * K[j].dual[1][c] +
                                         dA[2][r] * K[j].dual[2][c]);
        }
    }
    if (J_ref) {
        const double *R = J_ref;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                J[3 * r + c] = F[3 * r] * R[c] + F[3 * r + 1] * R[3 + c] + F[3 * r + 2] * R[6 + c];
    } else {
        memcpy(J, F, sizeof F);
    }
}

ffd_status ffd_pbffd_jacobian(const ffd_pbffd *pb, double *out, ffd_error *err)
{
    if (!out && pb->n)
        return ffd_fail(err, FFD_ERR_INVALID, "out is NULL");
    ffd_ebf_kernel **vk = NULL;
    if (ffd_pb_version_kernels(pb, &vk) != FFD_OK)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory computing Jacobians");
    ffd_ebf_kernel master;
    ffd_ebf_kernel_init(&pb->master, pb->master_weight, &master);
    const ffd_ebf_kernel *mk = pb->has_master ? &master : NULL;
    const long long n = (long long)pb->n;
#pragma omp parallel for schedule(static, 1024)
    for (long long i = 0; i < n; i++)
        ffd_pb_jacobian_point(pb, vk, mk, (size_t)i, out + 9 * (size_t)i);
    ffd_pb_version_kernels_free(pb, vk);
    return FFD_OK;
}
