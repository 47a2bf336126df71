/* lattice — evaluation of the trivariate map (Hsu et al. 1992, eq. 1; Sederberg &
 * Parry 1986), its Jacobian, and its weight rows for direct manipulation.
 *
 * The hot path evaluates blocks of points that share one cell: the 64 control
 * points of the cell are gathered once and the basis values are kept in small
 * arrays, so the inner loops run across points (SIMD). Each point is computed
 * independently in a fixed order: results do not depend on the thread count. */
#include "lattice/lattice.h"

#include <math.h>
#include <string.h>

#define BLK 256

/* ---- scalar evaluation at global parameters ---- */

void ffd_axis_basis(ffd_basis basis, uint32_t res, double S, uint32_t *first, double *b, double *d)
{
    if (basis == FFD_BASIS_BSPLINE) {
        uint32_t sigma = ffd_bspline_segment(S, res);
        ffd_bspline_basis(S - sigma, b, d);
        *first = sigma;
    } else {
        ffd_bernstein_basis(res - 1, S, b, d);
        *first = 0;
    }
}

/* Sum of the basis (and its derivatives) against a net laid out like P_ext. */
static void eval_net(const ffd_lattice *lat, const double *net, const double stu[3], double q[3],
                     double dq[3][3])
{
    double bb[3][FFD_BERNSTEIN_MAX_RES], dd[3][FFD_BERNSTEIN_MAX_RES];
    uint32_t first[3], cnt[3];
    for (int c = 0; c < 3; c++) {
        ffd_axis_basis(lat->basis, lat->res[c], stu[c], &first[c], bb[c], dd[c]);
        cnt[c] = lat->basis == FFD_BASIS_BSPLINE ? 4 : lat->res[c];
    }
    double acc[4][3] = {{0}};
    for (uint32_t a = 0; a < cnt[0]; a++)
        for (uint32_t b = 0; b < cnt[1]; b++)
            for (uint32_t k = 0; k < cnt[2]; k++) {
                size_t e = (((size_t)(first[0] + a)) * lat->ext[1] + first[1] + b) * lat->ext[2] +
                           first[2] + k;
                const double *p = net + 3 * e;
                double w = bb[0][a] * bb[1][b] * bb[2][k];
                double w0 = dd[0][a] * bb[1][b] * bb[2][k];
                double w1 = bb[0][a] * dd[1][b] * bb[2][k];
                double w2 = bb[0][a] * bb[1][b] * dd[2][k];
                for (int r = 0; r < 3; r++) {
                    acc[0][r] += w * p[r];
                    acc[1][r] += w0 * p[r];
                    acc[2][r] += w1 * p[r];
                    acc[3][r] += w2 * p[r];
                }
            }
    memcpy(q, acc[0], 3 * sizeof(double));
    if (dq)
        for (int a = 0; a < 3; a++)
            memcpy(dq[a], acc[a + 1], 3 * sizeof(double));
}

void ffd_lattice_eval_at(const ffd_lattice *lat, const double stu[3], double q[3], double dq[3][3])
{
    eval_net(lat, lat->P_ext, stu, q, dq);
}

void ffd_lattice_displacement_at(const ffd_lattice *lat, const double stu[3], double d[3],
                                 double dd[3][3])
{
    eval_net(lat, lat->D_ext, stu, d, dd);
}

void ffd_lattice_eval_params(const ffd_lattice *lat, const double stu[3], double out[3])
{
    if (lat->gen) {
        ffd_lattice_general_eval_params(lat, stu, out);
        return;
    }
    ffd_lattice_eval_at(lat, stu, out, NULL);
}

void ffd_lattice_rest_at(const ffd_lattice *lat, const double stu[3], double x[3])
{
    double loc[3];
    for (int c = 0; c < 3; c++)
        loc[c] = lat->basis == FFD_BASIS_BSPLINE ? ffd_bspline_rest_map(lat->res[c], stu[c], NULL)
                                                 : stu[c];
    for (int r = 0; r < 3; r++)
        x[r] = lat->box.origin[r] + loc[0] * lat->box.axes[0][r] + loc[1] * lat->box.axes[1][r] +
               loc[2] * lat->box.axes[2][r];
}

/* ---- block kernels, one copy per instruction set ---- */

/* The copies are chosen from the CPU's features (cpuid), not its model:
 * GCC's target_clones("arch=...") resolver tests Intel model numbers, so an
 * AMD CPU with AVX-512 ran the SSE2 copy. -ffp-contract=fast (CMakeLists.txt)
 * lets the AVX2 and AVX-512 copies fuse multiply-adds: their last bits differ
 * from the SSE2 copy's, but every thread of a process runs the same copy, so
 * results stay independent of the thread count. */
#define KERNEL(name) name##_default
#define KERNEL_TARGET
#include "lattice/lattice_kernels.h"
#undef KERNEL
#undef KERNEL_TARGET

#if FFD_SIMD_DISPATCH
#define KERNEL(name) name##_avx2
#define KERNEL_TARGET __attribute__((target("avx2,fma")))
#include "lattice/lattice_kernels.h"
#undef KERNEL
#undef KERNEL_TARGET

#define KERNEL(name) name##_avx512
#define KERNEL_TARGET __attribute__((target("avx512f,avx2,fma")))
#include "lattice/lattice_kernels.h"
#undef KERNEL
#undef KERNEL_TARGET
#endif

ffd_simd_path ffd_lattice_simd_path(void)
{
#if FFD_SIMD_DISPATCH
    __builtin_cpu_init(); /* idempotent; libgcc's cpuid and XGETBV (OS state) checks */
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx2") &&
        __builtin_cpu_supports("fma"))
        return FFD_SIMD_AVX512;
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
        return FFD_SIMD_AVX2;
#endif
    return FFD_SIMD_DEFAULT;
}

const char *ffd_simd_path_name(ffd_simd_path path)
{
    switch (path) {
    case FFD_SIMD_AVX512:
        return "avx512";
    case FFD_SIMD_AVX2:
        return "avx2";
    default:
        return "default";
    }
}

typedef void (*bspline_kernel)(const double *restrict, const double *restrict,
                               const double *restrict, size_t, const double *restrict,
                               double *restrict, double *restrict, double *restrict);
typedef void (*bernstein_kernel)(const ffd_lattice *, const double *restrict,
                                 const double *restrict, const double *restrict,
                                 const double *restrict, size_t,
                                 double *restrict, double *restrict, double *restrict,
                                 double *restrict);

static void pick_kernels(bspline_kernel *bk, bernstein_kernel *ek)
{
    *bk = bspline_block_default;
    *ek = bernstein_block_default;
#if FFD_SIMD_DISPATCH
    switch (ffd_lattice_simd_path()) {
    case FFD_SIMD_AVX512:
        *bk = bspline_block_avx512;
        *ek = bernstein_block_avx512;
        break;
    case FFD_SIMD_AVX2:
        *bk = bspline_block_avx2;
        *ek = bernstein_block_avx2;
        break;
    default:
        break;
    }
#endif
}

/* The cell's 64 entries of net (laid out like D_ext). */
static void gather_cell(const ffd_lattice *lat, const double *net, const uint32_t cell[3],
                        double *cp)
{
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++)
            for (int c = 0; c < 4; c++) {
                size_t e = (((size_t)(cell[0] + a)) * lat->ext[1] + cell[1] + b) * lat->ext[2] +
                           cell[2] + c;
                memcpy(cp + 3 * ((a * 4 + b) * 4 + c), net + 3 * e, 3 * sizeof(double));
            }
}

ffd_status ffd_lattice_check_binding(const ffd_lattice *lat, const ffd_lattice_binding *b,
                                     ffd_error *err)
{
    if (b->basis != lat->basis || memcmp(b->res, lat->res, sizeof b->res) != 0 ||
        b->general != lat->gen)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "binding was made for another lattice basis or resolution");
    return FFD_OK;
}

/* out_i = x_i + sum B net (points) when points, else sum B net alone (the
 * sensitivity product, net = v on the slots): the blocks, then the outside
 * points (fixed ones: x_i, or 0 without points). */
static ffd_status eval_blocks(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                              const double *net, int points, double *out, ffd_error *err)
{
    const size_t nin = bind->inside_count;
    const double *S = bind->local, *T = bind->local + nin, *U = bind->local + 2 * nin;
    const int bspline = lat->basis == FFD_BASIS_BSPLINE;
    bspline_kernel bspline_block;
    bernstein_kernel bernstein_block;
    pick_kernels(&bspline_block, &bernstein_block);
    size_t scratch_n = bspline ? 0 : ((size_t)lat->res[0] + lat->res[1] + lat->res[2] + 6) * BLK;
    int failed = 0;
    const long long nb = (long long)bind->block_count;
#pragma omp parallel reduction(| : failed)
    {
        double x[BLK], y[BLK], z[BLK], cp[64 * 3];
        double *scratch = scratch_n ? ffd_malloc_array(scratch_n, sizeof(double)) : NULL;
        if (scratch_n && !scratch)
            failed = 1;
#pragma omp for schedule(dynamic, 4)
        for (long long bi = 0; bi < nb; bi++) {
            if (scratch_n && !scratch)
                continue;
            const ffd_lattice_block *blk = &bind->blocks[bi];
            size_t p0 = blk->begin, np = blk->end - blk->begin;
            if (bspline) {
                gather_cell(lat, net, blk->cell, cp);
                bspline_block(S + p0, T + p0, U + p0, np, cp, x, y, z);
            } else {
                bernstein_block(lat, net, S + p0, T + p0, U + p0, np, x, y, z, scratch);
            }
            const double *rest = bind->rest + 3 * p0;
            if (!points) {
                for (size_t p = 0; p < np; p++) {
                    double *o = out + 3 * (size_t)bind->order[p0 + p];
                    o[0] = x[p], o[1] = y[p], o[2] = z[p];
                }
                continue;
            }
            for (size_t p = 0; p < np; p++) { /* the point plus the displacement sum B D */
                double *o = out + 3 * (size_t)bind->order[p0 + p];
                const double *r = rest + 3 * p;
                /* a zero displacement leaves the point bitwise (-0.0 + 0.0 would be +0.0) */
                o[0] = x[p] != 0.0 ? r[0] + x[p] : r[0];
                o[1] = y[p] != 0.0 ? r[1] + y[p] : r[1];
                o[2] = z[p] != 0.0 ? r[2] + z[p] : r[2];
            }
        }
        ffd_free(scratch);
    }
    if (failed)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory evaluating the lattice");
    const size_t nout = bind->n - nin;
    for (size_t o = 0; o < nout; o++) {
        double *dst = out + 3 * (size_t)bind->out_index[o];
        const double *x = bind->out_point + 3 * o;
        if (bind->outside == FFD_OUTSIDE_FIXED) {
            if (points)
                memcpy(dst, x, 3 * sizeof(double));
            else
                dst[0] = dst[1] = dst[2] = 0.0;
            continue;
        }
        /* clamp: the displacement of the nearest boundary point; Bernstein
         * extrapolation: of the polynomials at the raw parameters */
        double d[3];
        eval_net(lat, net, bind->out_params + 3 * o, d, NULL);
        if (bind->falloff) /* FFD_OUTSIDE_FALLOFF: the clamped displacement times f */
            for (int c = 0; c < 3; c++)
                d[c] *= bind->falloff[bind->out_index[o]];
        for (int c = 0; c < 3; c++)
            dst[c] = !points ? d[c] : d[c] != 0.0 ? x[c] + d[c] : x[c];
    }
    return FFD_OK;
}

ffd_status ffd_lattice_eval(const ffd_lattice *lat, const ffd_lattice_binding *bind, double *out,
                            ffd_error *err)
{
    ffd_status st = ffd_lattice_check_binding(lat, bind, err);
    if (st != FFD_OK)
        return st;
    if (lat->gen)
        return ffd_lattice_general_eval(lat, bind, NULL, out, err);
    return eval_blocks(lat, bind, lat->D_ext, 1, out, err);
}

/* W v is the evaluation of the displacement sum with v in place of the
 * displacements (Hsu et al. eq. 1 is linear in the net): v spread onto the
 * slots through the tie (S v, eq. 6), then the evaluation's own blocks. */
ffd_status ffd_lattice_sensitivity_product(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                           const double *v, double *out, ffd_error *err)
{
    ffd_status st = ffd_lattice_check_binding(lat, bind, err);
    if (st != FFD_OK)
        return st;
    if (lat->gen)
        return ffd_lattice_general_eval(lat, bind, v, out, err);
    if (lat->basis != FFD_BASIS_BSPLINE)
        return eval_blocks(lat, bind, v, 0, out, err);
    size_t slots = (size_t)lat->ext[0] * lat->ext[1] * lat->ext[2];
    double *net = ffd_malloc_array(slots, 3 * sizeof *net);
    if (!net)
        return ffd_fail(err, FFD_ERR_NOMEM, "sensitivity product: out of memory for %zu slots",
                        slots);
    for (size_t e = 0; e < slots; e++)
        memcpy(net + 3 * e, v + 3 * (size_t)lat->tie[e], 3 * sizeof *net);
    st = eval_blocks(lat, bind, net, 0, out, err);
    ffd_free(net);
    return st;
}
