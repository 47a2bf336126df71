/* session — the editor's model (ffd_session, ffd.h): one rest mesh, one
 * deformer ("method"), pins, undo/redo and the drag in progress. session.c
 * is generic; each method is one file implementing sess_vtable
 * (src/<method>/<method>_session.c, found through the registry, deformer/method.h).
 * Invariant: a method's rig (vt->rig) replayed by ffd_rig_apply on the rest
 * mesh gives the positions vt->eval gives. */
#ifndef FFD_SESSION_H
#define FFD_SESSION_H

#include "core/core.h"
#include "rig/rig_json.h"

#include <cjson/cJSON.h>

/* What a method sees of the session: the rest mesh. */
typedef struct sess_ctx {
    const ffd_mesh *mesh;
    size_t n;                /* vertices */
    const double *rest;      /* n by 3 */
    double min[3], max[3];   /* bounding box of the rest mesh */
    double diag;             /* its diagonal (> 0; 1 for a degenerate mesh) */
    size_t max_controls;     /* deformers with more control points are refused before building */
    ffd_limits limits;       /* bounds on the work of one operation (ffd_session_options) */
} sess_ctx;

/* Coordinates a request may ask for (targets, centres, moved controls):
 * beyond this the float32 frame would overflow or the solve lose all
 * precision. */
#define SESS_COORD_MAX 1e15

/* Fills ctx for mesh (borrowed: it must outlive ctx): its vertices, their
 * bounding box and diagonal; max_controls 0: no bound but the limits. */
void ffd_sess_ctx_init(sess_ctx *ctx, const ffd_mesh *mesh, size_t max_controls,
                   const ffd_limits *limits);

/* FFD_ERR_INVALID when count (a product of resolutions, computed without
 * overflow by the caller) exceeds ctx->max_controls. */
ffd_status ffd_sess_check_controls(const sess_ctx *ctx, double count, const char *what,
                               ffd_error *err);

typedef struct sess_method sess_method; /* each method's own struct begins with this */
typedef struct sess_binding sess_binding; /* a method's binding of any point set */
typedef struct sess_vtable sess_vtable;
struct sess_method {
    const sess_vtable *vt;
    const sess_ctx *ctx;
};

/* Errors: messages start with the op ("create: resolution: expected ...").
 * State conflicts (a request that is well-formed but does not fit the
 * state) are FFD_ERR_INVALID with a message starting "conflict: " — the
 * server answers them 409. */
#define SESS_CONFLICT "conflict: "

enum { SESS_UNDO_NONE = 0, SESS_UNDO_STATE, SESS_UNDO_REBUILD };

struct sess_vtable {
    const char *name; /* the method's name (the rig's "deformer") */
    void (*destroy)(sess_method *m);
    /* Deformed vertex positions, ctx->n by 3. */
    ffd_status (*eval)(sess_method *m, double *out, ffd_error *err);
    /* The controls shown and dragged (ids 0..count-1) and their current positions. */
    size_t (*control_count)(const sess_method *m);
    void (*controls)(const sess_method *m, double *out);
    /* Adds "params" (the creation parameters) and the method's fields of
     * "controls" (docs/editor.md: resolution, ebfs, primitives, proxy, ...,
     * and "edges"; "count" is added by the caller). */
    ffd_status (*describe)(const sess_method *m, cJSON *params, cJSON *controls, ffd_error *err);

    /* Drags. begin remembers the state; set_controls puts controls ids[0..k)
     * at targets (k by 3) measured from that state (ARAP for T-spline
     * handles when arap); set_variables puts the linear map's variables at
     * begin + dv (map->variable_count by 3); end(commit = 0) restores the
     * begin state. A method without a linear map has linear_map NULL. */
    ffd_status (*begin)(sess_method *m, const uint32_t *ids, size_t k, int arap, ffd_error *err);
    ffd_status (*set_controls)(sess_method *m, const uint32_t *ids, size_t k,
                               const double *targets, ffd_error *err);
    ffd_status (*linear_map)(sess_method *m, ffd_linear_map *map, ffd_error *err);
    ffd_status (*set_variables)(sess_method *m, const double *dv, ffd_error *err);
    /* 1: ffd_deformer_move_controls adds its deltas to the variables
     * (set_variables) instead of placing the controls at their positions
     * plus the deltas: where a variable is not a position (a nested
     * lattice's child variables are its own displacements, lattice_nested.h),
     * so that a solve's delta over the linear map moves what the map says. */
    int move_by_variables;
    void (*end)(sess_method *m, int commit);
    /* Optional (NULL: set_controls): a translate or rotate drag step given
     * as its rigid motion as well, x -> center + R(axis, angle) (x - center)
     * + delta (angle 0 for a translation), with the targets set_controls
     * would get. A method whose controls carry frames uses it (a point's turn). */
    ffd_status (*set_motion)(sess_method *m, const uint32_t *ids, size_t k, const double *targets,
                             const double axis[3], double angle, const double center[3],
                             const double delta[3], ffd_error *err);

    /* Undo of control edits: an opaque copy of the editable state
     * (control positions, logs, frames); restore brings it back exactly.
     * Structural changes (refine, primitive edits, curves) are undone by
     * rebuilding from the rig instead (ffd_session keeps the rig text). */
    ffd_status (*snapshot)(const sess_method *m, void **blob, ffd_error *err);
    ffd_status (*restore)(sess_method *m, const void *blob, ffd_error *err);
    void (*snapshot_free)(void *blob);
    /* Every control back at rest (the structure kept). */
    ffd_status (*reset)(sess_method *m, ffd_error *err);

    /* Writes the rig's keys (after "version" and "deformer") into root. */
    ffd_status (*rig)(const sess_method *m, cJSON *root, ffd_error *err);
    /* Per-vertex weight in [0, 1] of controls ids (n floats). */
    ffd_status (*influence)(sess_method *m, const uint32_t *ids, size_t k, float *w,
                            ffd_error *err);
    /* Method-specific ops ("refine", "freeze", "level", "frame", "curve",
     * "primitive"): FFD_ERR_UNSUPPORTED for an op the method does not know
     * (the session turns it into a conflict). *undo_kind says what undo
     * needs: SESS_UNDO_NONE (a view setting), SESS_UNDO_STATE (the snapshot
     * taken before the op restores it), SESS_UNDO_REBUILD (the structure
     * changed: undo rebuilds from the rig text taken before the op). The
     * session takes both before calling. On error nothing changed. */
    ffd_status (*op)(sess_method *m, const char *op, const cJSON *body, int *undo_kind,
                     ffd_error *err);

    /* Any point set (ffd_deformer_bind): binds n points given at rest (n
     * by 3; the method copies what it keeps), so that eval_points gives
     * what eval would give for the same points as vertices of the mesh.
     * The binding stays valid across control changes (set_controls, reset,
     * restore) and method ops, which the method must see at evaluation. */
    ffd_status (*bind)(sess_method *m, const double *points, size_t n, sess_binding **out,
                       ffd_error *err);
    void (*binding_free)(sess_binding *b);
    ffd_status (*eval_points)(sess_method *m, const sess_binding *b, double *out, ffd_error *err);
    /* d(x')/d(x) at the bound points, n by 9 row-major; NULL: unsupported. */
    ffd_status (*jacobian_points)(sess_method *m, const sess_binding *b, double *out,
                                  ffd_error *err);
    /* The bound points as a linear map of the controls: the tie maps every
     * column to a control id (no FFD_TIE_FIXED), variable_count ==
     * control_count. Borrows m and b. NULL: not linear in the controls. */
    ffd_status (*map_points)(sess_method *m, const sess_binding *b, ffd_linear_map *map,
                             ffd_error *err);
    /* The method's public handle (its ffd_<method> object, ffd.h). */
    void *(*handle)(sess_method *m);

    /* Optional sensitivity products (ffd_deformer_sensitivity_product and
     * _transpose_product, ffd.h "Sensitivities"): out (b's n by 3) = W v
     * for v (control_count by 3), and out (control_count by 3) = W^T w for w
     * (n by 3), W = dX/dP at the bound points. When present they are used
     * instead of the generic path through map_points (a method whose
     * variables are composed with a solve, or that has no linear map). */
    ffd_status (*sensitivity_product)(sess_method *m, const sess_binding *b, const double *v,
                                      double *out, ffd_error *err);
    ffd_status (*sensitivity_transpose_product)(sess_method *m, const sess_binding *b,
                                                const double *w, double *out, ffd_error *err);
    /* The fold-over check of the current map (ffd_deformer_fold_check);
     * NULL: unsupported. */
    ffd_status (*fold_check)(sess_method *m, ffd_fold_report *out, ffd_error *err);
};

/* What the method offers (which entries are not NULL) and its name: its
 * own vtable, also when the generic layers wrap it (deformer/layers.c).
 * Test capabilities through it; call through m->vt. */
const sess_vtable *ffd_sess_caps(const sess_method *m);

/* Constructors. create: from the body of the "create" op, which is a rig's
 * creation part (ffd_method_create, deformer/method.h: the rig reader, the
 * method's create_body defaults, then load). load: from a parsed rig of this method
 * (the whole rig replayed; the result must describe the same positions as
 * ffd_rig_apply of that rig). */
/* Shared helpers (session_util.c). */
/* A JSON array of uint32 control ids, each < count, no repeats; *ids is
 * ffd_malloc'd (NULL when k == 0). */
ffd_status ffd_sess_read_ids(const ffd_rig_parser *p, const cJSON *item, const char *path, size_t count,
                         uint32_t **ids, size_t *k);
/* A drag step's per-control form (session_moves.c): body {"moves": [[id,
 * dx, dy, dz], ...]}, each id one of the drag's ids (k of them, of count
 * controls) at most once, with its total change since drag_begin; targets
 * (k by 3) = start + change, start for a control not named. FFD_ERR_PARSE
 * (shape, key), FFD_ERR_NONFINITE, FFD_ERR_RANGE (id >= count),
 * FFD_ERR_INVALID (a control not dragged, or named twice). */
ffd_status ffd_sess_moves_targets(const ffd_rig_parser *p, const cJSON *body, const uint32_t *ids,
                                  size_t k, size_t count, const double *start, double *targets);
/* cJSON builders that report allocation failure (NULL). Numbers are exact
 * (17 digits, raw items: print them, do not read them back). */
cJSON *ffd_sess_number(double v);
cJSON *ffd_sess_array(const double *v, size_t n);
cJSON *ffd_sess_vec3(const double v[3]);
cJSON *ffd_sess_matrix3(const double m[3][3]);
cJSON *ffd_sess_uint_array(const uint32_t *v, size_t n);
/* Adds item (which may be NULL: an allocation failed) to an object or an
 * array; on failure deletes it and returns 0. */
int ffd_sess_add_item(cJSON *object, const char *key, cJSON *item);
int ffd_sess_add_to_array(cJSON *array, cJSON *item);
/* Adds [a, b] to an edge array. */
int ffd_sess_add_edge(cJSON *edges, uint32_t a, uint32_t b);
/* Linear-map influence: per row (vertex) the sum of the weights of the
 * controls in ids (clamped to [0, 1]); the controls are the map's columns
 * (by_column) or the variables the columns are tied to (the B-spline
 * lattice's tripled border). */
ffd_status ffd_sess_map_influence(const ffd_linear_map *map, int by_column, size_t n,
                              const uint32_t *ids, size_t k, float *w, ffd_error *err);

/* A deep copy of a mesh (through its own format in memory). */
ffd_status ffd_sess_clone_mesh(const ffd_mesh *mesh, ffd_mesh **out, ffd_error *err);
/* Applies rig, without its generic layers (rig->layers), to a copy of the
 * rest mesh (the report says what it did): a method's load replays its part. */
ffd_status ffd_sess_apply_rig(const sess_ctx *ctx, const ffd_rig *rig, ffd_rig_report *report,
                          ffd_error *err);
/* The method's state as rig text (JSON, "version" and "deformer" first; ffd_free). */
ffd_status ffd_sess_rig_text(const sess_method *m, char **text, ffd_error *err);
/* Reads an operation's body: size bytes of one JSON object (no NUL; white
 * space after it allowed), or {} when size is 0. FFD_ERR_PARSE naming op and
 * the byte offset; *doc (cJSON_Delete) only on success. */
ffd_status ffd_sess_parse_body(const char *op, const char *body, size_t size, cJSON **doc,
                               ffd_error *err);

/* The "weights" op's body (session_weights.c): {"values": [w, ...]} (every
 * vertex), {"vertices": {"17": w, ...}} (some: w holds the current weights
 * on entry and gets the new ones) or {"clear": true} (*clear: no weights);
 * weights are finite numbers in [0, 1]; an optional "stroke": k (a positive
 * integer) names the brush stroke (*stroke, 0 without). FFD_ERR_PARSE,
 * NONFINITE, RANGE (a weight outside [0, 1], a vertex out of range),
 * INVALID (a count other than n) naming the key, PARSE for a vertex given
 * twice; w unchanged on error. */
ffd_status ffd_sess_read_weights(const ffd_rig_parser *p, const cJSON *body, size_t n, double *w,
                                 int *clear, double *stroke);
/* The weights as a binary reply: "FFDW", uint32 revision, uint32 n, uint32
 * 0, then n float32 (*data ffd_free'd by the caller). */
ffd_status ffd_sess_weights_reply(const double *w, size_t n, uint32_t revision, void **data,
                                  size_t *size, ffd_error *err);
/* Several meshes in one session (session_meshes.c): a character and its
 * clothes deformed by one deformer. The session's point set is the
 * concatenation of the meshes' vertices, mesh i owning the vertex range
 * [first, first + count); the deformer binds them all. */
typedef struct sess_mesh_part {
    ffd_mesh *mesh;  /* as read (owned) */
    char *name;      /* its label, the file name (owned) */
    size_t first, count;
} sess_mesh_part;

typedef struct sess_meshes {
    sess_mesh_part *parts; /* count == 0: one mesh, the session's own */
    size_t count;
} sess_meshes;

/* The concatenation of the parts (vertices in order, each part's faces
 * shifted by its first vertex), made from arrays; first and count of each
 * part are set. FFD_ERR_INVALID for a volume mesh or too many vertices. */
ffd_status ffd_sess_meshes_concat(sess_meshes *m, ffd_mesh **out, ffd_error *err);
/* Frees the parts, their meshes and names; m is then empty. */
void ffd_sess_meshes_free(sess_meshes *m);
/* "meshes": [{name, first, vertices, faces}] of the parts, or of the one
 * mesh (name, mesh) when m is empty. 0 on allocation failure. */
int ffd_sess_meshes_json(const sess_meshes *m, const char *name, const ffd_mesh *mesh,
                         cJSON *root);
/* Part index's mesh with a rig (text; NULL: none) replayed on it alone:
 * what ffd deform writes for that mesh's file. */
ffd_status ffd_sess_meshes_deformed(const sess_meshes *m, size_t index, const char *rig,
                                    const ffd_limits *limits, ffd_mesh **out, ffd_error *err);
/* Delta frames (session_frame.c, docs/editor.md): the float32 positions of
 * the last frame sent to a client asking for deltas, and the triangles
 * around each vertex. make builds *f on first use (FFD_ERR_NOMEM, *f NULL).
 * delta turns a full frame (ffd_session_frame's layout) into a delta frame
 * against base (UINT32_MAX: the client holds none), or leaves *delta NULL
 * (send the full frame) when f does not hold base or the delta would not
 * be smaller; either way the frame becomes the base of the next call.
 * FFD_ERR_NOMEM changes nothing held. */
typedef struct sess_frames sess_frames;
ffd_status ffd_sess_frames_make(sess_frames **f, const ffd_mesh *mesh, size_t n, ffd_error *err);
ffd_status ffd_sess_frames_delta(sess_frames *f, uint32_t base, const void *frame, size_t size,
                                 void **delta, size_t *delta_size, ffd_error *err);
void ffd_sess_frames_free(sess_frames *f);

#endif
