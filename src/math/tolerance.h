/* math — named tolerances. Relative ones are scaled by the quantity they compare. */
#ifndef FFD_TOLERANCE_H
#define FFD_TOLERANCE_H

/* Local coordinate slack: a point whose local coordinate lies within this of
 * [0,1] is on the lattice boundary and deforms with it (no seam). */
#define FFD_TOL_BOUNDARY 1e-12

/* A box whose |det(axes)| is below this times |a||b||c| has zero volume. */
#define FFD_TOL_VOLUME 1e-12

/* Extents a fitted box (lattice "auto" box, T-spline parameter box) may
 * have: its volume (a product of three extents) and the inverse of its axes
 * stay normal doubles. Bounding boxes outside are refused, not fitted. */
#define FFD_BOX_MIN_EXTENT 1e-100
#define FFD_BOX_MAX_EXTENT 1e100

/* Default relative singular-value threshold of the least-squares solves. */
#define FFD_TOL_RCOND 1e-10

/* Newton iterations of the outer-segment cubic solve stop at this step in t. */
#define FFD_TOL_CUBIC 1e-15

#endif
