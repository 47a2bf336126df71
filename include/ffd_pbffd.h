/*
 * ffd_pbffd.h — the PB-FFD method (point-based FFD): its public API.
 *
 * Part of the public API of libffd: ffd.h includes this header (through
 * ffd_methods.h), so `#include <ffd.h>` gives it; ffd.h's conventions hold here.
 */
#ifndef FFD_PBFFD_API_H
#define FFD_PBFFD_API_H

#include "ffd.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================
 * PB-FFD: point-based FFD with ellipsoidal basis functions
 * (McDonnell & Qin, "PB-FFD: A Point-based Technique for Free-Form Deformation")
 * ====================================================================== */

/* One control point: an ellipsoidal basis function (EBF, eq. 1) centred at
 * center, with the reference frame (a, b, c) = frame[0], frame[1], frame[2]
 * (any lengths; linearly independent, else FFD_ERR_INVALID "degenerate
 * frame") and its region of influence (ROI): the ellipsoid
 * {center + G t : |t| < 1}, G's columns g_k = radius[k] a_k / |a_k|, whose
 * conjugate semi-diameters are the g_k (its principal semi-axes when the
 * frame is orthogonal): center + g_k lies on the boundary. Parameters
 * u = (alpha, beta, gamma) solve v - center = alpha a + beta b + gamma c,
 * which is eq. 3 for orthogonal frames and keeps rest reproduction exact
 * for oblique ones. */
typedef struct ffd_ebf {
    double center[3];
    double frame[3][3];
    double radius[3];
    int disabled; /* 1: takes no part in the deformation (its index is kept): the
                     result is bitwise the same as without it (it is not in the
                     master's bounding box or sphere, not merged into level 1,
                     never in a weight row, FFD_TIE_FIXED in the linear map) */
} ffd_ebf;

/* The kernel (eq. 1 made continuous): with rho the ROI-normalised distance,
 * rho^2 = sum_k (u_k |a_k| / radius[k])^2 = |G^-1 (x - center)|^2 (u the
 * parameters above, G as above; rho = 1 on the ROI boundary), which is eq. 1's
 * (x-mu)^T R S^-2 R^T (x-mu) for an orthogonal frame (R^T (x-mu) =
 * (u_k |a_k|)_k by eq. 3) and, for an oblique one, eq. 1 applied in the
 * frame's parameter domain, as eq. 5 writes phi_j(u_ij) (pbffd.md, "The
 * kernel"); phi(rho) = exp(-rho^2 / (2 sigma^2)) * (1 - rho^2)^3
 * for rho < 1 and 0 beyond. The first factor is eq. 1 divided by tau, so
 * phi(0) = 1. Cut off literally, eq. 1 with sigma = 3 is still 0.95 on the
 * boundary: the normalised weights (eq. 5) would jump there and the mesh
 * would crack when a control point moves. The window (1 - rho^2)^3 makes phi
 * and its first two derivatives vanish on the boundary, so the weights are
 * C2 everywhere. */

/* Zero means default for every field. */
typedef struct ffd_pbffd_options {
    double sigma;          /* eq. 1 standard deviation; default 3 */
    int no_master;         /* 1: no master control point (default: one per level, §3.2.2) */
    double master_radius;  /* master ROI radius, multiple of the bounding-sphere radius R:
                              the largest distance from the master's centre (the centre of
                              the bounding box of the bound points and the enabled
                              controls' centres) to any bound point or enabled control
                              centre; default 2 (>= 1) */
    double master_weight;  /* factor on the master's kernel value; default 1 */
    uint32_t levels;       /* control-set levels (§3.4), 1 = no hierarchy; default 1 */
} ffd_pbffd_options;

typedef struct ffd_pbffd ffd_pbffd;

/* Creates a PB-FFD deformer: the control set (copied) becomes level 0, the
 * finest; levels 1..levels-1 are built by pairwise merging of the closest
 * points (each half the size of the level below, §3.4), and each level's
 * points are parameterised in the next coarser level (eq. 10). The n points
 * (#n by 3, usually the mesh vertices) are bound to level 0 (W and D of
 * eq. 7, sparse). Every level has an immovable master control point at the
 * centre of the bounding box of the points and the enabled controls' centres
 * (a sphere of options->master_radius times R, above; fixed at creation:
 * later control-set edits do not move it), unless options->no_master. Level 1 merges the enabled controls of level 0 (the
 * disabled ones are still parameterised in level 1); a merged point gets a
 * spherical ROI about the midpoint that encloses both ROIs, with an
 * axis-aligned frame of that radius. A point under no kernel at all (no
 * control, outside the master) stays where it is. n may be 0 (points NULL).
 * Errors name the control ("controls[3]: radius 0: expected > 0"):
 * FFD_ERR_INVALID (count == 0, zero or negative radius, degenerate frame,
 * levels such that a level would have fewer than one control: each level
 * holds ceil(half) of the one below and a level of one control cannot be
 * halved; options: sigma < 0, master_radius in (0, 1), master_weight < 0),
 * FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_pbffd_create(const ffd_ebf *controls, size_t count, const double *points, size_t n,
                                    const ffd_pbffd_options *options, ffd_pbffd **out, ffd_error *err);
FFD_API void ffd_pbffd_destroy(ffd_pbffd *pb);

FFD_API size_t ffd_pbffd_point_count(const ffd_pbffd *pb);     /* bound points n */
        FFD_API size_t ffd_pbffd_level_count(const ffd_pbffd *pb);
/* Controls at level (0 = finest); 0 for a level out of range. */
FFD_API size_t ffd_pbffd_control_count(const ffd_pbffd *pb, size_t level);
/* The current state of control index at level. FFD_ERR_RANGE. */
FFD_API ffd_status ffd_pbffd_control(const ffd_pbffd *pb, size_t level, size_t index, ffd_ebf *out,
                                     ffd_error *err);
/* The master control point of level; 0 when there is none. */
FFD_API int ffd_pbffd_master(const ffd_pbffd *pb, size_t level, ffd_ebf *out);
/* Bound points under no control point but the master (they move only
 * through the master, i.e. not at all), and under fewer than two. */
FFD_API size_t ffd_pbffd_uncovered_count(const ffd_pbffd *pb);
FFD_API size_t ffd_pbffd_single_covered_count(const ffd_pbffd *pb);
/* Number of control points (master excluded) whose ROI holds bound point i. */
FFD_API size_t ffd_pbffd_point_support(const ffd_pbffd *pb, size_t i);

/* Moves control index of level by delta (an edit at that level, §3.4): the
 * finer levels and the bound points follow (eq. 9-10); the coarser levels
 * do not move: the point is re-parameterised in the next coarser level at
 * its new position (against that level's current state, which reproduces
 * it). The cascade moves the centres of the finer control points whose rows
 * name a changed point; their frames are kept. A point moved outside every
 * ROI of the next coarser level no longer follows it (§3.4). FFD_ERR_RANGE,
 * FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_pbffd_move(ffd_pbffd *pb, size_t level, size_t index, const double delta[3],
                                  ffd_error *err);
/* Replaces the frame (the matrix A of eq. 7) of control index of level:
 * rotating it twists, scaling it stretches the space around the point.
 * The parameterisation is kept (no re-binding). FFD_ERR_RANGE,
 * FFD_ERR_NONFINITE, FFD_ERR_INVALID (degenerate frame). */
FFD_API ffd_status ffd_pbffd_set_frame(ffd_pbffd *pb, size_t level, size_t index,
                                       const double frame[3][3], ffd_error *err);
/* Puts every control point of every level back where it was created
 * (or where the last control-set edit left it), and undoes the
 * re-parameterisations made by moves since. */
FFD_API void ffd_pbffd_reset(ffd_pbffd *pb);

/* Control-set edits on level 0, made in the current (possibly deformed)
 * state: the bound points whose parameterisation the edit changes (those
 * whose weights name the control, i.e. in its old ROI when they were bound,
 * and those inside its new ROI at their current positions) are
 * re-parameterised at their current positions, no others; the deformation
 * seen so far is kept (eval returns the same positions bitwise), and it
 * becomes the state ffd_pbffd_reset returns to. The level-0 point itself is
 * (re-)parameterised in level 1; the coarser levels are not rebuilt. add
 * returns the new index; remove shifts the later indices down by one (the
 * only control cannot be removed: FFD_ERR_INVALID); set_enabled(0) keeps the
 * index. An edit of a control that is disabled before and after it (add
 * with control->disabled, remove or redefine of a disabled one) changes no
 * position and does not rebase: reset still returns where it did and later
 * results are bitwise those without the edit. Errors: FFD_ERR_RANGE,
 * FFD_ERR_INVALID and FFD_ERR_NONFINITE for a bad control ("control[4]:
 * ..."), FFD_ERR_NOMEM; on error nothing changes. */
FFD_API ffd_status ffd_pbffd_add(ffd_pbffd *pb, const ffd_ebf *control, size_t *index, ffd_error *err);
FFD_API ffd_status ffd_pbffd_remove(ffd_pbffd *pb, size_t index, ffd_error *err);
FFD_API ffd_status ffd_pbffd_set_enabled(ffd_pbffd *pb, size_t index, int enabled, ffd_error *err);
/* Redefines control index (centre, frame, radius) in the current state; its
 * enabled state is kept (control->disabled is ignored: use set_enabled). */
FFD_API ffd_status ffd_pbffd_redefine(ffd_pbffd *pb, size_t index, const ffd_ebf *control,
                                      ffd_error *err);

/* Deformed positions of the bound points, n by 3: V = W P + D A (eq. 7),
 * evaluated as rest + W dP + D dA, so that at rest it is exact (bitwise). */
FFD_API ffd_status ffd_pbffd_eval(const ffd_pbffd *pb, double *out, ffd_error *err);
/* Jacobians d(x')/d(x) of the deformation at the bound points, n by 9
 * row-major, with respect to the points as bound (after a control-set edit,
 * a re-parameterised point's Jacobian composes with the one it had then). */
FFD_API ffd_status ffd_pbffd_jacobian(const ffd_pbffd *pb, double *out, ffd_error *err);

/* The bound points as a linear map of the control points of level (0 =
 * finest; coarser levels compose eq. 10), for ffd_manip_solve (§3.3): the
 * master is not a column (it is fixed), disabled controls are tied
 * FFD_TIE_FIXED. Apply the solution with ffd_pbffd_move per control (moves
 * at one level keep the map exact). The map borrows pb and owns scratch
 * inside it (composed rows): it is not thread-safe; a control-set edit, or a
 * new map of the same level, invalidates it. */
FFD_API ffd_status ffd_pbffd_linear_map(ffd_pbffd *pb, size_t level, ffd_linear_map *map, ffd_error *err);

/* --- Frame sensitivities (docs/sensitivities.md, "PB-FFD frames") ---
 * The bound points' derivatives with respect to the frames of the controls
 * of level (0 = finest). Each control q has six design variables, taken at
 * its current frame A_q = (a, b, c): a rotation vector omega (radians; the
 * frame turned about the control's centre, axis m becoming
 * exp([omega]x) A_q[m]) in columns 6q, 6q+1, 6q+2, and scalings s (axis m
 * becoming s_m A_q[m]; the derivative is at s = 1, i.e. per unit of
 * relative stretch) in columns 6q+3+m. Eq. 7 is linear in the frames with
 * the parameterisation kept, so with g = D_iq (w_iq times the parameters)
 * and v = g_0 a + g_1 b + g_2 c: d x'_i / d omega_q = -[v]x and
 * d x'_i / d s_qm = g_m A_q[m]; a coarser level's frame moves the finer
 * centres through eq. 10 and then the points through eq. 9 (ffd_pbffd_set_frame's
 * cascade). Rows are 3i + coordinate (3n rows, 6 x count columns); the
 * master is no column; a disabled control's columns are empty. The
 * centres' derivatives are ffd_deformer_sensitivities (generic W) or
 * ffd_pbffd_linear_map. */
/* The matrix, 3n by 6 count, in out (overwritten; free with
 * ffd_sparse_free; zeroed on error). Columns are in order within each
 * row. FFD_ERR_RANGE (level), FFD_ERR_INVALID (NULL, more than 2^32/6
 * controls), FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_pbffd_frame_sensitivities(const ffd_pbffd *pb, size_t level, ffd_sparse *out,
                                                 ffd_error *err);
/* out (n by 3) = the matrix times v (6 per control of level), without
 * forming it. Errors as above. */
FFD_API ffd_status ffd_pbffd_frame_sensitivity_product(const ffd_pbffd *pb, size_t level,
                                                       const double *v, double *out, ffd_error *err);
/* out (6 per control of level) = the matrix's transpose times w (n by 3):
 * dJ/d(omega, s) = (dX/d(omega, s))^T dJ/dX. Errors as above. */
FFD_API ffd_status ffd_pbffd_frame_sensitivity_transpose_product(const ffd_pbffd *pb, size_t level,
                                                                 const double *w, double *out,
                                                                 ffd_error *err);

/* --- Automatic placement (§3.2.1, Figure 2) --- */

typedef enum ffd_surface_kind {
    FFD_SURFACE_AUTO = 0, /* closed when the mesh has no boundary and no non-manifold edge */
    FFD_SURFACE_CLOSED,   /* interior (Voronoi) and exterior points */
    FFD_SURFACE_OPEN      /* §3.2.3: offsets along both normal directions only */
} ffd_surface_kind;

/* Zero means default for every field. */
typedef struct ffd_placement_options {
    size_t interior_count;  /* interior (medial) points; default 60 */
    size_t exterior_count;  /* exterior points (open surfaces: all points); default 60 */
    double offset;          /* exterior offset along the normal, as a fraction of the
                               bounding-box diagonal; default 0.1 x 0.5 = 5% of the diagonal
                               (the paper's 10%, of the bounding sphere's radius) */
    double radius_factor;   /* radius and frame lengths = factor x nearest-neighbour
                               distance; default 1.5 */
    ffd_surface_kind surface;
    size_t voronoi_sites;   /* at most this many mesh vertices (an even subsample) go into
                               the Voronoi diagram; default 8000; SIZE_MAX: all */
    int no_cover;           /* 1: do not grow radii so that every vertex is under two points */
} ffd_placement_options;

typedef struct ffd_placement_report {
    int open;                  /* 1: the open-surface path was taken */
    int fell_back;             /* 1: CLOSED was asked or AUTO found defects: took the open path */
    size_t interior_count;     /* placed interior points (fewer than asked when the medial
                                  axis is degenerate, see note) */
    size_t exterior_count;     /* placed exterior points */
    size_t voronoi_sites;      /* vertices given to Qhull */
    size_t voronoi_vertices;   /* Voronoi vertices Qhull returned */
    size_t inside_vertices;    /* of those, kept as inside the mesh */
    size_t grown_radii;        /* controls whose radius grew to cover vertices */
    double seconds_voronoi;    /* Qhull */
    double seconds_total;
    char note[256];            /* why the open path was taken, or why fewer interior points
                                  than asked were placed, or "" */
} ffd_placement_report;

/* Places control points for the mesh (Figure 2): the requested counts of
 * interior points (Voronoi vertices inside the mesh, octree decimation by
 * merging closest pairs) and exterior points (vertices offset along their
 * normals, decimated), each an EBF with an axis-aligned frame and radius =
 * radius_factor x nearest-neighbour distance. The Voronoi sites are the
 * vertices moved by a fixed hash of their index (1e-9 of the bounding-box
 * diagonal; deterministic), so that cospherical or cocircular vertices
 * (spheres, cylinders, boxes) are in general position; interior points
 * within 1e-3 of the diagonal of each other are one point, so a degenerate
 * medial axis (a sphere's is its centre) gives fewer interior points than
 * asked for: report->interior_count and *count say how many, report->note
 * says why. The master is not included
 * (ffd_pbffd_create adds it). *controls is freed with ffd_free. Errors:
 * FFD_ERR_INVALID (no faces; more points requested than candidates exist:
 * the message says how many there are), FFD_ERR_NUMERIC (Qhull failed: its
 * message is captured, never printed), FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_pbffd_place(const ffd_mesh *mesh, const ffd_placement_options *options,
                                   ffd_ebf **controls, size_t *count, ffd_placement_report *report,
                                   ffd_error *err);

/* --- Curve-based deformation (§3.5) --- */

typedef struct ffd_pbffd_curve ffd_pbffd_curve;

/* A Catmull-Rom spline (centripetal, interpolating) through count >= 2
 * control points, discretised into samples EBFs (0: one per radius/4 of
 * arc length, at least 8) with ROI radius radius and rotation-minimising
 * frames; the n points inside the union of the ROIs are parameterised in
 * them; a master of weight options->master_weight (default here 0.05)
 * fades the motion to zero at the ROI boundary, so points outside never
 * move. Samples are even in arc length on the curve as created and keep
 * their curve parameter when it moves; options->levels is ignored (one
 * level). FFD_ERR_INVALID (count < 2, radius <= 0, samples 1 or above
 * 100000, coincident consecutive control points), FFD_ERR_NONFINITE. */
FFD_API ffd_status ffd_pbffd_curve_create(const double *control_points, size_t count, double radius,
                                          size_t samples, const double *points, size_t n,
                                          const ffd_pbffd_options *options, ffd_pbffd_curve **out,
                                          ffd_error *err);
FFD_API void ffd_pbffd_curve_destroy(ffd_pbffd_curve *curve);
FFD_API size_t ffd_pbffd_curve_control_count(const ffd_pbffd_curve *curve);
/* Current curve control points, count by 3. */
FFD_API const double *ffd_pbffd_curve_control_points(const ffd_pbffd_curve *curve);
/* Moves curve control point index by delta: the samples and their frames
 * (rotation-minimising from the first sample's, turned with its tangent; the
 * tangent axis scaled by the local stretch) follow the new curve.
 * FFD_ERR_RANGE, FFD_ERR_NONFINITE, FFD_ERR_INVALID (consecutive control
 * points would coincide); on error nothing changes. */
FFD_API ffd_status ffd_pbffd_curve_move(ffd_pbffd_curve *curve, size_t index, const double delta[3],
                                        ffd_error *err);
/* Deformed positions of the n points (points outside every ROI unchanged, bitwise). */
FFD_API ffd_status ffd_pbffd_curve_eval(const ffd_pbffd_curve *curve, double *out, ffd_error *err);
/* 1 when point i lies in the curve's ROI. */
FFD_API int ffd_pbffd_curve_point_inside(const ffd_pbffd_curve *curve, size_t i);

/* --- The control set as a rig --- */

/* Writes a PB-FFD rig holding this explicit control set (and nothing else)
 * as JSON, atomically: what `ffd pbffd place` writes, ready to edit and to
 * replay with ffd_rig_read. options (may be NULL) adds "sigma", "master" and
 * "levels" when they differ from the defaults. */
FFD_API ffd_status ffd_rig_write_pbffd_controls(const char *path, const ffd_ebf *controls, size_t count,
                                                const ffd_pbffd_options *options, ffd_error *err);

/* --- Behind the generic interfaces (ffd.h) ---
 * ffd_deformer_handle(d, "pbffd") is the ffd_pbffd; ffd_deformer_create
 * reads the mesh for automatic placement. In a rig report (ffd_rig_report):
 * outside_count counts the vertices under no control point but the master;
 * control_points are the finest level's centres (ffd_rig_report_write_lattice
 * writes the points only); no control mesh; notes carry the placement
 * notes; details hold levels, uncovered, placement (docs/rig.md, "The
 * report"). */

#ifdef __cplusplus
}
#endif
#endif /* FFD_PBFFD_API_H */
