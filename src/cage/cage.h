/* cage — the cage deformer's internals (include/ffd_cage.h): the handle,
 * shared by its files, one concept each: cage.c (the handle, the cage's
 * checks, binding, evaluation, linear map), cage_mean_value.c (Ju, Schaefer
 * & Warren 2005), cage_harmonic.c (Joshi et al. 2007: the grid, its Laplace
 * solve with CHOLMOD, trilinear interpolation), cage_hat.c (the cage's
 * piecewise-linear hat functions at the nearest point of the cage). */
#ifndef FFD_CAGE_H
#define FFD_CAGE_H

#include "core/core.h"
#include "math/spatial.h"

/* The harmonic coordinates' grid: nodes origin + h (i, j, k), dims[a] nodes
 * along axis a; node (i, j, k) is (i dims[1] + j) dims[2] + k. A node with
 * a value has slot >= 0: its row of nv coordinates in values (an interior
 * unknown of the Laplace equation, or a Dirichlet node outside the cage
 * next to it, valued by the hat functions at its nearest cage point). */
typedef struct cage_grid {
    double origin[3];
    double h;
    uint32_t dims[3];
    int32_t *slot;      /* dims[0] dims[1] dims[2] */
    uint8_t *inside;    /* per node: 1 inside the cage (an unknown) */
    double *values;     /* rows by nv */
    size_t rows;        /* valued nodes */
    size_t unknowns;    /* interior nodes (the Laplace equation's unknowns) */
} cage_grid;

struct ffd_cage {
    size_t nv, nt;
    double *rest;       /* nv by 3 */
    double *current;    /* nv by 3 */
    uint32_t *tri;      /* nt by 3, outward */
    ffd_cage_coordinates kind;
    ffd_cage_outside outside;  /* never DEFAULT */
    double lo[3], hi[3], diag;
    ffd_inside_index *inside;  /* ray parity over the rest cage */
    cage_grid *grid;           /* harmonic only */
};

/* Mean value coordinates of x (Ju et al. 2005, Fig. 4) into w (nv);
 * scratch holds 4 nv doubles. Returns 1 when x is on the cage (a vertex,
 * an edge or a face: w is the cage's linear interpolation there). */
int ffd_cage_mean_value(const ffd_cage *cage, const double x[3], double *w, double *scratch);

/* The hat functions of the cage at the point of the cage nearest to x
 * (barycentric coordinates of that point in its triangle; ties go to the
 * lower triangle) into w (nv, zeroed first); returns the squared distance. */
double ffd_cage_hat(const ffd_cage *cage, const double x[3], double *w);

/* Harmonic coordinates: builds cage->grid (resolution cells along the
 * longest side) and solves the Laplace equation for every vertex. */
ffd_status ffd_cage_harmonic_solve(ffd_cage *cage, uint32_t resolution, ffd_error *err);
void ffd_cage_grid_free(cage_grid *g);
/* Trilinear interpolation of the grid at x into w (nv); 0 (w untouched)
 * when x's cell has a corner without a value (x is outside the cage); *all_inside
 * set when all eight corners are interior nodes. */
int ffd_cage_harmonic_weights(const ffd_cage *cage, const double x[3], double *w,
                              int *all_inside);

#endif
