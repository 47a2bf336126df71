/* rig_points — what the scattered-control-point methods (RBF, IDW) share:
 * the rig's control points ("control_points", "deformed_control_points",
 * "moves"), the rows of their linear map, and one application of such a rig
 * to a mesh (ffd_rig_apply_points) driven by the method's operations
 * (ffd_point_morph_ops). The session side is session/session_points.h. */
#ifndef FFD_RIG_POINTS_H
#define FFD_RIG_POINTS_H

#include "deformer/method.h"
#include "rig/rig_json.h"

/* The control points of a rig section (docs/rbf-idw.md). */
typedef struct ffd_rig_points {
    double *control_points;    /* count by 3: the rest control points */
    size_t count;
    double *deformed;          /* count by 3, or NULL: "deformed_control_points" */
    ffd_rig_point_move *moves; /* applied after deformed */
    size_t move_count;
} ffd_rig_points;

/* Reads root's "control_points" (required, at least one), its
 * "deformed_control_points" (one per control point, or deformed NULL) and
 * its "moves" (indices below count) into pts (rig_json.c). */
ffd_status ffd_rig_read_control_points(const ffd_rig_parser *p, const cJSON *root,
                                       ffd_rig_points *pts);
/* The moved control points (count by 3, ffd_malloc'd): deformed (or the
 * rest points), then the moves; NULL when out of memory. */
double *ffd_rig_points_moved(const ffd_rig_points *pts);
/* Writes "control_points" / "deformed_control_points" and "moves" into root;
 * 0 when out of memory. */
int ffd_rig_points_write_rest(const ffd_rig_points *pts, cJSON *root);
int ffd_rig_points_write_moves(const ffd_rig_points *pts, cJSON *root);
void ffd_rig_points_release(ffd_rig_points *pts);

/* The linear map of points (borrowed, n by 3) under a morph: dense rows
 * a_j(x) over its control points (no tie); rows must outlive the map. */
typedef struct ffd_point_rows {
    const void *morph; /* the method's object (ffd_rbf_morph, ffd_idw) */
    const double *points;
} ffd_point_rows;

/* A method whose deformed points are x' = x + sum_j a_j(x) (p_j - c_j) over
 * scattered control points: its object behind a void pointer. */
typedef struct ffd_point_morph_ops {
    const char *label;         /* "RBF": in messages */
    const char *control_label; /* the report's: "RBF control points" */
    /* The section's control points, and the morph at rest on them. */
    const ffd_rig_points *(*points_of)(const ffd_rig *rig);
    ffd_status (*create)(const ffd_rig *rig, void **morph, ffd_error *err);
    void (*destroy)(void *morph);
    size_t (*count)(const void *morph);
    const double *(*points)(const void *morph);
    const double *(*rest)(const void *morph);
    ffd_status (*set_points)(void *morph, const double *points, ffd_error *err);
    ffd_status (*eval)(const void *morph, const double *x, size_t n, double *out, ffd_error *err);
    ffd_status (*jacobian)(const void *morph, const double *x, size_t n, double *out,
                           ffd_error *err);
    void (*linear_map)(const ffd_point_rows *rows, size_t n, ffd_linear_map *map);
    /* Sensitivities d x'/d p applied to v (3 count) and transposed to w
     * (3 n); NULL when the method has none. */
    ffd_status (*product)(const void *morph, const double *x, size_t n, const double *v,
                          double *out, ffd_error *err);
    ffd_status (*transpose_product)(const void *morph, const double *x, size_t n,
                                    const double *w, double *out, ffd_error *err);
    /* The budget of applying the rig to n vertices, and the report's details. */
    ffd_status (*charge)(const ffd_rig *rig, size_t n, ffd_budget *budget, ffd_error *err);
    void (*details)(const ffd_rig *rig, const void *morph, cJSON *details);
} ffd_point_morph_ops;

/* The method's rig applied to a mesh (ffd_method.apply): the morph on the
 * rig's control points, moved by "deformed_control_points" and "moves", then
 * direct manipulation of the constrained points over the a_j (Hsu et al.
 * 1992, eq. 2-7, through ffd_manip_solve), then the mesh's positions and
 * normals in one ffd_mesh_set_positions (all or nothing). */
ffd_status ffd_rig_apply_points(const ffd_point_morph_ops *ops, const ffd_rig *rig,
                                ffd_mesh *mesh, ffd_rig_report *report, ffd_budget *budget,
                                ffd_error *err);

#endif
