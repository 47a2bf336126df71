/* tsv — estimates of what a refinement, an ARAP drag and the fold check will
 * cost, before they run (ffd_limits, docs/rig.md "Limits").
 *
 * Calibration (Release build, one core, examples/tspline/bunny.obj at the
 * default 6x6x6): successive {"cells": "proxy"} refinements made 386, 1,537,
 * 7,706 and 46,872 cells; the fourth took 32 s and the process grew to
 * 350 MB (about 7 KB per cell: the lattice, its roll-back snapshot and the
 * closure's pieces). An ARAP drag on 2,736 and 14,499 control points took
 * 0.9 s and 15 s and 33 MB and 315 MB. The fold check costs about 6 us per
 * Jacobian sample. */
#include "tspline/tsv.h"

#include <math.h>

#define BYTES_PER_CELL 8000.0     /* lattice + snapshot + closure pieces, per cell after */
#define REFINE_OPS 4000.0         /* per added cell x sqrt(cells after): the closure's rounds */
#define REFINE_OPS_PER_POINT 200.0 /* knot inference over every point, per round */
#define ARAP_BYTES 1000.0         /* x nv^(4/3): the factor */
#define ARAP_OPS 1300.0           /* x nv^1.7: the factorisation */
#define ARAP_SOLVE_OPS 200.0      /* x nv^(4/3) per iteration: two triangular solves, 3 columns */
#define FOLD_OPS 6000.0           /* per Jacobian sample */

static int thick_axes(const double lo[3], const double hi[3])
{
    int a3 = 0;
    for (int a = 0; a < 3; a++)
        a3 += tsv_kappa(hi[a]) > tsv_kappa(lo[a]);
    return a3;
}

void ffd_tsv_estimate_refine(const tsv_lattice *L, const ffd_tsv_insertion *ins, size_t count,
                         tsv_estimate *out)
{
    double cells = (double)L->nc;
    for (size_t i = 0; i < count; i++) {
        if (ins[i].kind != FFD_TSV_CELL || ins[i].id >= L->nc)
            continue;
        const tsv_cell *C = &L->cells[ins[i].id];
        cells += (double)((1u << thick_axes(C->lo, C->hi)) - 1u);
    }
    double added = cells - (double)L->nc;
    out->cells = cells;
    out->bytes = BYTES_PER_CELL * cells;
    out->work = REFINE_OPS * (added + (double)count) * sqrt(cells) +
                REFINE_OPS_PER_POINT * 2.0 * cells;
}

void ffd_tsv_estimate_arap(size_t nv, uint32_t iterations, tsv_estimate *out)
{
    double n = (double)nv, fill = pow(n, 4.0 / 3.0);
    out->cells = 0;
    out->bytes = ARAP_BYTES * fill;
    out->work = ARAP_OPS * pow(n, 1.7) + ARAP_SOLVE_OPS * fill * (iterations ? iterations : 5);
}

void ffd_tsv_estimate_folds(const tsv_lattice *L, uint32_t samples, tsv_estimate *out)
{
    double s = samples ? samples : 3, volume_cells = 0;
    for (size_t c = 0; c < L->nc; c++)
        volume_cells += thick_axes(L->cells[c].lo, L->cells[c].hi) == 3;
    out->cells = (double)L->nc;
    out->bytes = 9.0 * (double)L->nc;
    out->work = FOLD_OPS * volume_cells * s * s * s;
}
