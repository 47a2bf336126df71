/* session_points — the deformer (sess_vtable) of a scattered-control-point
 * method (RBF, IDW): the controls are the method's control points, dragged
 * directly or through direct manipulation over its a_j(x); its rig is the
 * control points at rest plus one move per displaced point. A method gives
 * its operations (rig/rig_points.h) and a sess_points_kind; its vtable is
 * FFD_SESS_POINTS_VTABLE(name) with the generic functions below. */
#ifndef FFD_SESSION_POINTS_H
#define FFD_SESSION_POINTS_H

#include "rig/rig_points.h"
#include "session/session.h"

typedef struct sess_points_kind {
    const ffd_point_morph_ops *ops;
    const sess_vtable *vtable;
    size_t options_size;
    /* The rig section's options (options_size bytes, copied at load). */
    const void *(*options_of)(const ffd_rig *rig);
    /* The state's parameters of the options; 0 when out of memory. */
    int (*describe)(const void *options, cJSON *params, cJSON *controls);
    /* A rig of the method with these options and points into root; 0 when out of memory. */
    int (*write_rig)(const void *options, const ffd_rig_points *points, cJSON *root);
} sess_points_kind;

/* The deformer of a rig: the morph on its control points, then the rig
 * replayed as ffd deform applies it (moves, deformed points, constraints)
 * and the control points set where the replay left them. */
ffd_status ffd_sess_points_load(const sess_points_kind *kind, const sess_ctx *ctx,
                                const ffd_rig *rig, sess_method **out, ffd_error *err);
/* The editor's default control points for a "create" body without
 * "control_points": the 27 points of a 3 x 3 x 3 grid over the mesh's
 * bounding box grown by a tenth of its diagonal. */
ffd_status ffd_sess_points_default_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p);

void ffd_sess_points_destroy(sess_method *m);
ffd_status ffd_sess_points_eval(sess_method *m, double *out, ffd_error *err);
size_t ffd_sess_points_count(const sess_method *m);
void ffd_sess_points_controls(const sess_method *m, double *out);
ffd_status ffd_sess_points_describe(const sess_method *m, cJSON *params, cJSON *controls,
                                    ffd_error *err);
ffd_status ffd_sess_points_begin(sess_method *m, const uint32_t *ids, size_t k, int arap,
                                 ffd_error *err);
ffd_status ffd_sess_points_set_controls(sess_method *m, const uint32_t *ids, size_t k,
                                        const double *targets, ffd_error *err);
ffd_status ffd_sess_points_linear_map(sess_method *m, ffd_linear_map *map, ffd_error *err);
ffd_status ffd_sess_points_set_variables(sess_method *m, const double *dv, ffd_error *err);
void ffd_sess_points_end(sess_method *m, int commit);
ffd_status ffd_sess_points_snapshot(const sess_method *m, void **blob, ffd_error *err);
ffd_status ffd_sess_points_restore(sess_method *m, const void *blob, ffd_error *err);
ffd_status ffd_sess_points_reset(sess_method *m, ffd_error *err);
ffd_status ffd_sess_points_rig(const sess_method *m, cJSON *root, ffd_error *err);
ffd_status ffd_sess_points_influence(sess_method *m, const uint32_t *ids, size_t k, float *w,
                                     ffd_error *err);
ffd_status ffd_sess_points_op(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                              ffd_error *err);
ffd_status ffd_sess_points_bind(sess_method *m, const double *points, size_t n,
                                sess_binding **out, ffd_error *err);
void ffd_sess_points_binding_free(sess_binding *b);
ffd_status ffd_sess_points_eval_points(sess_method *m, const sess_binding *b, double *out,
                                       ffd_error *err);
ffd_status ffd_sess_points_jacobian_points(sess_method *m, const sess_binding *b, double *out,
                                           ffd_error *err);
ffd_status ffd_sess_points_map_points(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                                      ffd_error *err);
ffd_status ffd_sess_points_sensitivity_product(sess_method *m, const sess_binding *b,
                                               const double *v, double *out, ffd_error *err);
ffd_status ffd_sess_points_sensitivity_transpose(sess_method *m, const sess_binding *b,
                                                 const double *w, double *out, ffd_error *err);
void *ffd_sess_points_handle(sess_method *m);

/* The vtable of every scattered-point method; one with sensitivity products
 * adds .sensitivity_product and .sensitivity_transpose_product. */
#define FFD_SESS_POINTS_VTABLE(NAME)                                                               \
    .name = NAME, .destroy = ffd_sess_points_destroy, .eval = ffd_sess_points_eval,                \
    .control_count = ffd_sess_points_count, .controls = ffd_sess_points_controls,                  \
    .describe = ffd_sess_points_describe, .begin = ffd_sess_points_begin,                          \
    .set_controls = ffd_sess_points_set_controls, .linear_map = ffd_sess_points_linear_map,        \
    .set_variables = ffd_sess_points_set_variables, .end = ffd_sess_points_end,                    \
    .snapshot = ffd_sess_points_snapshot, .restore = ffd_sess_points_restore,                      \
    .snapshot_free = ffd_free, .reset = ffd_sess_points_reset, .rig = ffd_sess_points_rig,         \
    .influence = ffd_sess_points_influence, .op = ffd_sess_points_op,                              \
    .bind = ffd_sess_points_bind, .binding_free = ffd_sess_points_binding_free,                    \
    .eval_points = ffd_sess_points_eval_points,                                                    \
    .jacobian_points = ffd_sess_points_jacobian_points,                                            \
    .map_points = ffd_sess_points_map_points, .handle = ffd_sess_points_handle

#endif
