/* math — named tolerances. Relative ones are scaled by the quantity they compare. */
#ifndef FFD_TOLERANCE_H
#define FFD_TOLERANCE_H

/* Local coordinate slack: a point whose local coordinate lies within this of
 * [0,1] is on the boundary of the control volume and deforms with it (no
 * seam). */
#define FFD_TOL_BOUNDARY 1e-12

/* A box whose |det(axes)| is below this times |a||b||c| has zero volume. */
#define FFD_TOL_VOLUME 1e-12

/* Extents a fitted box (a rig's "auto" box, a method's parameter box) may
 * have: its volume (a product of three extents) and the inverse of its axes
 * stay normal doubles. Bounding boxes outside are refused, not fitted. */
#define FFD_BOX_MIN_EXTENT 1e-100
#define FFD_BOX_MAX_EXTENT 1e100

/* Default relative singular-value threshold of the least-squares solves. */
#define FFD_TOL_RCOND 1e-10

/* Direct manipulation: hard constraints (pins) count as met when each one's
 * residual is within this times the size of the positions involved (the
 * largest coordinate of the current positions and targets, at least 1). */
#define FFD_TOL_REACH 1e-9

/* Newton iterations of the outer-segment cubic solve stop at this step in t. */
#define FFD_TOL_CUBIC 1e-15

/* Voronoi placement: each Voronoi site moves by up to this times the
 * bounding-box diagonal, along each axis, by a fixed hash of its vertex index
 * (deterministic), so that cospherical or cocircular vertices (spheres,
 * cylinders, boxes) are in general position for Qhull. */
#define FFD_TOL_SITE_JITTER 1e-9

/* Voronoi placement: Delaunay cells whose shape quality 6|V|/L^3 is below
 * this give no Voronoi vertex (a sliver's circumcentre is set by the jitter). */
#define FFD_TOL_SLIVER 1e-4

/* Voronoi placement: interior points closer than this times the bounding-box
 * diagonal are one medial point (a sphere's Voronoi vertices all lie at its
 * centre, within the jitter's reach). */
#define FFD_TOL_MEDIAL_WELD 1e-3

/* Cage deformation (mean value coordinates, Ju, Schaefer & Warren 2005,
 * Fig. 4): a point within FFD_TOL_CAGE_VERTEX times the cage's diagonal of a
 * cage vertex is on it; a triangle whose projection on the unit sphere
 * around the point spans pi - h < FFD_TOL_CAGE_FACE holds the point (on its
 * face or an edge; pi - h shrinks as the square of the distance, so a point
 * within ~3e-8 of the diagonal from a face counts as on it); one with |s_i| <= FFD_TOL_CAGE_PLANE has the point in
 * its plane, outside it, and adds nothing. A cage triangle whose area is
 * below FFD_TOL_CAGE_AREA times the squared diagonal is degenerate. */
#define FFD_TOL_CAGE_VERTEX 1e-12
#define FFD_TOL_CAGE_FACE 1e-15
#define FFD_TOL_CAGE_PLANE 1e-12
#define FFD_TOL_CAGE_AREA 1e-14

#endif
