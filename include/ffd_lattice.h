/*
 * ffd_lattice.h — the lattice method (Sederberg-Parry, Hsu et al.): its public API.
 *
 * Part of the public API of libffd: ffd.h includes this header (through
 * ffd_methods.h), so `#include <ffd.h>` gives it; ffd.h's conventions hold here.
 */
#ifndef FFD_LATTICE_API_H
#define FFD_LATTICE_API_H

#include "ffd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================
 * Lattice FFD: Bernstein (Sederberg-Parry) and uniform cubic B-spline (Hsu et al.)
 * ====================================================================== */

typedef struct ffd_lattice ffd_lattice;
typedef struct ffd_lattice_binding ffd_lattice_binding;

typedef enum ffd_basis {
    FFD_BASIS_BSPLINE = 0, /* uniform cubic B-spline, outer control points of multiplicity three */
    FFD_BASIS_BERNSTEIN    /* one Bezier volume of degree (l-1, m-1, n-1) */
} ffd_basis;

/* Points outside the parallelepiped. Points on its boundary are inside. */
typedef enum ffd_outside {
    FFD_OUTSIDE_FIXED = 0,   /* keep their position (default) */
    FFD_OUTSIDE_CLAMP,       /* move with the nearest boundary point: continuous across the boundary */
    FFD_OUTSIDE_EXTRAPOLATE, /* Bernstein: evaluate the polynomials outside [0,1];
                                B-spline: same as CLAMP. (PyGeM keeps outside points FIXED.) */
    FFD_OUTSIDE_FALLOFF      /* CLAMP's displacement times a falloff curve of the distance to
                                the box, 0 beyond the falloff distance (Blender, Maya): bind
                                with ffd_lattice_bind_falloff, which gives the distance */
} ffd_outside;

/* The falloff curve f(r), r = d / D: d the point's distance to the box (to
 * its clamped point: origin + A clamp(local)), D the falloff distance; f = 0
 * for r >= 1. Blender's proportional-editing curves (t = 1 - r). */
typedef enum ffd_falloff_curve {
    FFD_FALLOFF_SMOOTH = 0, /* 1 - (10 r^3 - 15 r^4 + 6 r^5): C2 smootherstep (default) */
    FFD_FALLOFF_LINEAR,     /* 1 - r */
    FFD_FALLOFF_SPHERE,     /* sqrt(1 - r^2) */
    FFD_FALLOFF_SHARP       /* (1 - r)^2 */
} ffd_falloff_curve;

/* Parallelepiped: x = origin + s*axes[0] + t*axes[1] + u*axes[2], (s,t,u) in [0,1]^3. */
typedef struct ffd_box {
    double origin[3];
    double axes[3][3];
} ffd_box;

/* Axis-aligned bounding box of n points grown by margin times its extent on
 * each side (an axis of zero extent gets margin times the diagonal, or 1 for
 * a single point). margin >= 0. FFD_ERR_INVALID when n == 0 or when the
 * largest extent of the points is above 1e100 or nonzero and below 1e-100
 * (the message gives the extents), FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_box_fit(const double *points, size_t n, double margin, ffd_box *box, ffd_error *err);

/* Minimum control points per direction for a basis (2 for both). */
FFD_API uint32_t ffd_basis_min_resolution(ffd_basis basis);

/* Creates a lattice of res[0] x res[1] x res[2] control points at rest,
 * evenly spaced on the box. Errors: FFD_ERR_INVALID (resolution below the
 * minimum or above 1024, zero or negative volume box), FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_lattice_create(ffd_basis basis, const ffd_box *box, const uint32_t res[3],
                                      ffd_lattice **out, ffd_error *err);
FFD_API void ffd_lattice_destroy(ffd_lattice *lattice);

FFD_API ffd_basis ffd_lattice_basis(const ffd_lattice *lattice);
FFD_API void ffd_lattice_box(const ffd_lattice *lattice, ffd_box *box);
FFD_API void ffd_lattice_resolution(const ffd_lattice *lattice, uint32_t res[3]);
/* l*m*n; control point (i,j,k) has index (i*m + j)*n + k. */
FFD_API size_t ffd_lattice_control_count(const ffd_lattice *lattice);
/* Current control points, count by 3. */
FFD_API const double *ffd_lattice_control_points(const ffd_lattice *lattice);
/* Rest position of control point (i,j,k). */
FFD_API void ffd_lattice_rest_point(const ffd_lattice *lattice, uint32_t i, uint32_t j, uint32_t k,
                                    double out[3]);
/* Replaces all control points (count by 3, finite). */
FFD_API ffd_status ffd_lattice_set_control_points(ffd_lattice *lattice, const double *points, ffd_error *err);
/* Adds delta to control point (i,j,k). FFD_ERR_RANGE, FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_lattice_move(ffd_lattice *lattice, const uint32_t index[3], const double delta[3],
                                    ffd_error *err);
/* Adds delta (count by 3) to every control point. */
FFD_API ffd_status ffd_lattice_add(ffd_lattice *lattice, const double *delta, ffd_error *err);
/* Puts every control point back at rest. */
FFD_API void ffd_lattice_reset(ffd_lattice *lattice);

/* Local coordinates of n points (paper §2: inverting the rest map, directly
 * in the inner segments, by a cubic root solve in the two outer segments of
 * the B-spline). The binding is valid for this lattice's box, resolution and
 * basis; moving control points never re-binds. FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_lattice_bind(const ffd_lattice *lattice, const double *points, size_t n,
                                    ffd_outside outside, ffd_lattice_binding **out, ffd_error *err);
/* Binds as ffd_lattice_bind with FFD_OUTSIDE_FALLOFF: an outside point
 * moves by the displacement of its clamped point times curve(d / distance)
 * (ffd_falloff_curve): continuous across the boundary (f(0) = 1) and
 * bitwise unchanged from d >= distance on. The Jacobian, the linear map's
 * rows and the sensitivity products carry the factor (rows scaled by f; the
 * Jacobian adds the displacement times grad f). distance > 0 and finite
 * (world units). FFD_ERR_INVALID (distance, curve), FFD_ERR_NONFINITE,
 * FFD_ERR_NOMEM. (lattice_falloff.c) */
FFD_API ffd_status ffd_lattice_bind_falloff(const ffd_lattice *lattice, const double *points,
                                            size_t n, double distance, ffd_falloff_curve curve,
                                            ffd_lattice_binding **out, ffd_error *err);
/* The falloff factor of curve at r (>= 0), and its derivative df/dr when dfdr != NULL. */
FFD_API double ffd_falloff_value(ffd_falloff_curve curve, double r, double *dfdr);
FFD_API void ffd_lattice_binding_destroy(ffd_lattice_binding *binding);
FFD_API size_t ffd_lattice_binding_count(const ffd_lattice_binding *binding);
FFD_API size_t ffd_lattice_binding_inside_count(const ffd_lattice_binding *binding);
/* Spline parameters of point i: B-spline: in [0, l+1] x [0, m+1] x [0, n+1]
 * (integer part = segment); Bernstein: in [0,1]^3 (outside for outside points).
 * Returns 1 when the point is inside the box, 0 otherwise. */
FFD_API int ffd_lattice_binding_params(const ffd_lattice_binding *binding, size_t i, double stu[3]);

/* Deformed positions of the bound points, n by 3 (paper eq. 1, evaluated as
 * the point plus sum_j B_j (P_j - P_rest,j): a point whose support holds no
 * moved control point keeps its bits). */
FFD_API ffd_status ffd_lattice_eval(const ffd_lattice *lattice, const ffd_lattice_binding *binding,
                                    double *out, ffd_error *err);
/* Jacobians d(x')/d(x) of the deformation at the bound points, n by 9
 * row-major (I plus the displacement's derivative: exactly I where nothing
 * moved; a clamped outside point does not vary along its clamped axes). */
FFD_API ffd_status ffd_lattice_jacobian(const ffd_lattice *lattice, const ffd_lattice_binding *binding,
                                        double *out, ffd_error *err);
/* Evaluates the map at spline parameters directly (no binding), 3 doubles. */
FFD_API void ffd_lattice_eval_params(const ffd_lattice *lattice, const double stu[3], double out[3]);

/* The binding as a linear map for ffd_manip_solve. Columns are the raw
 * control slots: for the B-spline the (l+4)(m+4)(n+4) tripled-border net,
 * tied by S to the l*m*n distinct control points; for Bernstein the l*m*n
 * control points. The map borrows lattice and binding. */
FFD_API void ffd_lattice_linear_map(const ffd_lattice *lattice, const ffd_lattice_binding *binding,
                                    ffd_linear_map *map);

/* --- Lattice variants: interpolation per axis, cylindrical and spherical
 * lattices (docs/lattice-variants.md). A zeroed ffd_lattice_shape is the
 * lattice of ffd_lattice_create. --- */

/* Interpolation along one axis (Blender's U/V/W interpolation, 3ds Max's
 * tension/continuity). DEFAULT: the basis given to ffd_lattice_create_shaped. */
typedef enum ffd_interp {
    FFD_INTERP_DEFAULT = 0,
    FFD_INTERP_LINEAR,      /* piecewise linear between neighbouring control points */
    FFD_INTERP_CARDINAL,    /* Kochanek-Bartels cubic Hermite: tension, continuity (bias 0) */
    FFD_INTERP_CATMULL_ROM, /* cardinal with tension 0 and continuity 0 */
    FFD_INTERP_BSPLINE,     /* uniform cubic B-spline (tripled border; periodic on a closed axis) */
    FFD_INTERP_BERNSTEIN    /* Bernstein polynomials of degree res-1 (never periodic) */
} ffd_interp;

typedef enum ffd_coordinates {
    FFD_COORDINATES_CARTESIAN = 0, /* the box (default) */
    FFD_COORDINATES_CYLINDRICAL,   /* axes (r, theta, z) */
    FFD_COORDINATES_SPHERICAL      /* axes (r, theta azimuth, phi polar from the axis) */
} ffd_coordinates;

/* Frame of a cylindrical or spherical lattice: a point is
 * centre + r (cos theta e1 + sin theta e2) + z e3 (cylindrical) or
 * centre + r (sin phi cos theta e1 + sin phi sin theta e2 + cos phi e3)
 * (spherical), e3 = axis/|axis|, e1 = the reference direction made orthogonal
 * to e3, e2 = e3 x e1. range[0] = [r0, r1] (0 <= r0 < r1), range[1] = theta
 * [t0, t1] (t0 < t1 <= t0 + 2 pi; a span of 2 pi, within 1e-12, is a closed,
 * periodic axis), range[2] = z [z0, z1] or phi [p0, p1] (0 <= p0 < p1 <= pi). */
typedef struct ffd_lattice_frame {
    double centre[3];
    double axis[3];
    double reference[3];
    double range[3][2];
} ffd_lattice_frame;

typedef struct ffd_lattice_shape {
    ffd_interp interp[3];  /* per axis; DEFAULT: the basis */
    double tension[3];     /* CARDINAL: in [-1, 1) (0: Catmull-Rom) */
    double continuity[3];  /* CARDINAL: in [-1, 1] */
    ffd_coordinates coordinates;
    ffd_lattice_frame frame; /* cylindrical and spherical lattices */
} ffd_lattice_shape;

/* A lattice with an interpolation per axis and/or cylindrical or spherical
 * coordinates. shape NULL or zeroed (all axes DEFAULT, cartesian) is
 * ffd_lattice_create(basis, box, res); so is a cartesian shape whose axes all
 * use one of bspline/bernstein. Others take the general tensor-product path:
 * the control points stay l*m*n Cartesian points with index (i*m + j)*n + k,
 * displacements are Cartesian vectors, and each axis' rest map is inverted
 * exactly. Interpolating axes (linear, cardinal) use linearly extrapolated
 * phantom points at their ends (p_-1 = 2 p_0 - p_1), so a cartesian rest
 * lattice reproduces every point. Cylindrical/spherical: box is ignored; the
 * theta axis is periodic when it spans 2 pi; the control points of the axis
 * (r0 = 0) and of each pole (phi 0 or pi) are tied: one control point (the
 * lowest index of the group, its representative, which the linear map's tie
 * names); ffd_lattice_move of any member moves the group, while
 * _set_control_points and _add take the representative's value for the
 * followers (the map has no variable for them). On these lattices FFD_OUTSIDE_EXTRAPOLATE is CLAMP.
 * docs/lattice-variants.md. Errors: FFD_ERR_INVALID naming the axis and the range
 * (resolution below 2, or 3 on a periodic axis; Bernstein above 64 or on a
 * periodic axis; tension outside [-1, 1), continuity outside [-1, 1]; a
 * degenerate frame or range), FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_lattice_create_shaped(ffd_basis basis, const ffd_box *box, const uint32_t res[3],
                                             const ffd_lattice_shape *shape, ffd_lattice **out,
                                             ffd_error *err);
/* The lattice's shape (zeroed for a lattice of ffd_lattice_create). */
FFD_API void ffd_lattice_get_shape(const ffd_lattice *lattice, ffd_lattice_shape *shape);
/* Fits a frame to n points: centre the bounding box's centre, axis +z,
 * reference +x; r from 0 to the largest distance from the axis (cylindrical)
 * or the centre (spherical), grown by margin times itself; theta a full turn; z the bounding box's
 * extent along the axis grown by margin (cylindrical), phi [0, pi]
 * (spherical). FFD_ERR_INVALID (n == 0, no extent), FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_lattice_frame_fit(ffd_coordinates coordinates, const double *points, size_t n,
                                         double margin, ffd_lattice_frame *frame, ffd_error *err);

/* --- Behind the generic interfaces (ffd.h) ---
 * ffd_deformer_handle(d, "lattice") is the ffd_lattice. In a rig report
 * (ffd_rig_report): outside_count counts the vertices outside the lattice;
 * control_points are the lattice's points, index (i*m + j)*n + k, with
 * resolution l, m, n (ffd_rig_report_write_lattice draws the grid's lines);
 * no control mesh.
 * A rig with "children" (nested lattices, docs/lattice-variants.md): the
 * controls are the root lattice's points, then each child's depth-first
 * (a child before its children, siblings in rig order); a child's points
 * sit at its parent's map of their rest positions plus its own
 * displacement. The linear map's variables (ffd_deformer_linear_map,
 * sensitivities, ffd_deformer_move_controls) are the root's positions and
 * the children's own displacements: rows compose, W_child = B_child (I +
 * W_parent at the child's rest points). Setting a child control's position
 * (ffd_deformer_set_controls) sets its own displacement to the position
 * minus its parent's map. The report's control_points are all of them and
 * control_edges every lattice's grid lines; the handle is the root
 * ffd_lattice. */

#ifdef __cplusplus
}
#endif
#endif /* FFD_LATTICE_API_H */
