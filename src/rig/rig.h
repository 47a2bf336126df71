/* rig — the in-memory form of a rig file (JSON, or PyGeM .prm) and its application. */
#ifndef FFD_RIG_H
#define FFD_RIG_H

#include "core/core.h"

typedef struct ffd_rig_move {
    uint32_t index[3]; /* control point (i,j,k) */
    double delta[3];   /* world-space displacement */
} ffd_rig_move;

typedef enum ffd_rig_constraint_kind {
    FFD_RIG_CONSTRAINT_VERTEX = 0, /* a mesh vertex id */
    FFD_RIG_CONSTRAINT_POINT       /* an arbitrary point (rest position) inside the lattice */
} ffd_rig_constraint_kind;

typedef struct ffd_rig_constraint {
    ffd_rig_constraint_kind kind;
    uint32_t vertex;   /* kind == VERTEX */
    double point[3];   /* kind == POINT: the point at rest */
    double target[3];
} ffd_rig_constraint;

typedef enum ffd_rig_deformer {
    FFD_RIG_LATTICE = 0,
    FFD_RIG_PBFFD,
    FFD_RIG_GFFD,
    FFD_RIG_TSPLINE
} ffd_rig_deformer;

/* PB-FFD: a move or a frame edit of one control point at one level. */
typedef struct ffd_rig_pb_edit {
    uint32_t level;
    uint32_t control;
    int by_near;          /* 1: the control whose centre is nearest to near[] */
    double near[3];
    int has_delta;
    double delta[3];      /* moves: world-space displacement */
    int frame_kind;       /* frames: 1 = frame given, 2 = rotate/scale */
    double frame[3][3];   /* frame_kind 1: the new frame */
    double axis[3];       /* frame_kind 2: rotation axis (any length) and angle (radians) */
    double angle;
    double scale[3];      /* frame_kind 2: scale factors along the frame's own axes */
} ffd_rig_pb_edit;

typedef struct ffd_rig_curve_move {
    uint32_t index;
    double delta[3];
} ffd_rig_curve_move;

typedef struct ffd_rig_curve {
    double *points;       /* point_count by 3 */
    size_t point_count;
    double radius;
    uint32_t samples;     /* 0: automatic */
    ffd_rig_curve_move *moves;
    size_t move_count;
} ffd_rig_curve;

typedef struct ffd_rig_pbffd {
    int controls_auto;                 /* 1: ffd_pbffd_place with placement */
    ffd_placement_options placement;
    ffd_ebf *controls;                 /* controls_auto == 0 */
    size_t control_count;
    ffd_pbffd_options options;         /* sigma, master, levels */
    uint32_t constraint_level;
    ffd_rig_pb_edit *moves;
    size_t move_count;
    ffd_rig_pb_edit *frames;
    size_t frame_count;
    ffd_rig_curve *curves;
    size_t curve_count;
} ffd_rig_pbffd;

/* GFFD: one skeleton primitive, owned. */
typedef struct ffd_rig_primitive {
    ffd_gffd_kind kind;
    double *vertices;     /* vertex_count by 3 */
    size_t vertex_count;
    uint32_t *face_offsets; /* face_count + 1 (patch, polyhedron) */
    uint32_t *face_indices;
    size_t face_count;
    double radius;
} ffd_rig_primitive;

typedef enum ffd_rig_gffd_edit_kind {
    FFD_RIG_EDIT_TRANSLATE = 0, /* every vertex += delta */
    FFD_RIG_EDIT_ROTATE,        /* about axis through center by angle (radians) */
    FFD_RIG_EDIT_SCALE,         /* about center by scale[3] */
    FFD_RIG_EDIT_MOVE,          /* one vertex += delta */
    FFD_RIG_EDIT_VERTICES       /* all vertices replaced */
} ffd_rig_gffd_edit_kind;

/* GFFD: one skeleton edit (§5, first way). */
typedef struct ffd_rig_gffd_edit {
    ffd_rig_gffd_edit_kind kind;
    int all;              /* 1: every primitive (primitive ignored) */
    uint32_t primitive;
    uint32_t vertex;      /* MOVE */
    double delta[3];      /* TRANSLATE, MOVE */
    double axis[3];       /* ROTATE (any length) */
    double angle;
    double scale[3];      /* SCALE */
    int has_center;       /* 0: the centroid of the vertices edited */
    double center[3];
    double *vertices;     /* VERTICES: vertex_count by 3 */
    size_t vertex_count;
} ffd_rig_gffd_edit;

typedef struct ffd_rig_gffd {
    ffd_rig_primitive *skeleton;
    size_t skeleton_count;
    ffd_rig_primitive *replace;   /* §5, second way; NULL when none */
    size_t replace_count;
    ffd_rig_gffd_edit *edits;
    size_t edit_count;
    double *corr_from, *corr_to;  /* user correspondences, corr_count by 3 each */
    size_t corr_count;
    ffd_gffd_options options;
    int resample;
    ffd_gffd_resample_options resample_options;
} ffd_rig_gffd;


/* T-spline: a set of control points, by one of several selectors. */
typedef enum ffd_rig_tsv_select {
    FFD_RIG_SELECT_POINTS = 0, /* control point ids */
    FFD_RIG_SELECT_NEAR,       /* the proxy point nearest to a position (current positions) */
    FFD_RIG_SELECT_BOX,        /* every control point whose current position is in a box */
    FFD_RIG_SELECT_EDGES,      /* the ends of edges */
    FFD_RIG_SELECT_FACES,      /* the points on faces' boundaries */
    FFD_RIG_SELECT_CELLS       /* the points on cells' boundaries */
} ffd_rig_tsv_select;

typedef struct ffd_rig_tsv_selection {
    ffd_rig_tsv_select kind;
    uint32_t *ids;            /* POINTS, EDGES, FACES, CELLS */
    size_t id_count;
    double near[3];           /* NEAR */
    double box_min[3], box_max[3]; /* BOX */
} ffd_rig_tsv_selection;

/* A selection moved by a delta or rotated about an axis through a centre. */
typedef struct ffd_rig_tsv_handle {
    ffd_rig_tsv_selection sel;
    int has_delta;
    double delta[3];
    int has_rotate;
    double axis[3];           /* any length */
    double angle;             /* radians */
    int has_center;           /* 0: the centroid of the selection */
    double center[3];
} ffd_rig_tsv_handle;

/* One requested insertion: by id, or the element nearest a position; or
 * every cell inside the proxy (octree split of the proxy, Fig. 6-7). */
typedef struct ffd_rig_tsv_refinement {
    ffd_tsv_element kind;
    uint32_t id;
    int by_near;
    double near[3];
    int proxy_cells;
    double ratio;             /* edges: 0 = midpoint */
} ffd_rig_tsv_refinement;

typedef enum ffd_rig_tsv_step_kind {
    FFD_RIG_STEP_REFINE = 0,  /* one refinement edit */
    FFD_RIG_STEP_DEFORM,      /* proxy-driven ARAP solve (§3.4) */
    FFD_RIG_STEP_MOVE,        /* control points moved directly */
    FFD_RIG_STEP_CONSTRAIN    /* direct manipulation of object vertices (core solver) */
} ffd_rig_tsv_step_kind;

typedef struct ffd_rig_tsv_step {
    ffd_rig_tsv_step_kind kind;
    ffd_rig_tsv_refinement *refinements;
    size_t refinement_count;
    ffd_rig_tsv_handle *handles;       /* DEFORM handles, MOVE moves */
    size_t handle_count;
    ffd_rig_tsv_selection *freeze;     /* DEFORM, CONSTRAIN */
    size_t freeze_count;
    ffd_tsv_arap_options arap;         /* DEFORM */
    ffd_rig_constraint *constraints;   /* CONSTRAIN (vertex constraints) */
    size_t constraint_count;
} ffd_rig_tsv_step;

typedef struct ffd_rig_tspline {
    uint32_t resolution[3];
    ffd_tsv_options options;
    ffd_rig_tsv_step *steps;
    size_t step_count;
    uint32_t fold_samples;             /* 0: default */
} ffd_rig_tspline;

struct ffd_rig {
    char *name;              /* file name for messages */
    ffd_rig_deformer deformer;
    ffd_rig_pbffd pb;        /* deformer == FFD_RIG_PBFFD */
    ffd_rig_gffd gffd;       /* deformer == FFD_RIG_GFFD */
    ffd_rig_tspline tsv;     /* deformer == FFD_RIG_TSPLINE */
    ffd_basis basis;
    uint32_t resolution[3];
    int box_auto;            /* 1: fit the mesh bounding box grown by margin */
    double margin;           /* default 0.05 */
    ffd_box box;             /* when box_auto == 0 */
    ffd_outside outside;     /* default FFD_OUTSIDE_FIXED */
    double rcond;            /* 0: solver default */
    ffd_rig_move *moves;
    size_t move_count;
    ffd_rig_constraint *constraints;
    size_t constraint_count;
    char **input_files;      /* the files the rig read besides itself (ffd_rig_input_path) */
    size_t input_file_count;
};

/* "NAME: CONTEXT: inner message" with the inner status (rig_apply.c). */
ffd_status ffd_rig_wrap(ffd_error *err, ffd_status status, const char *name, const char *context,
                        const ffd_error *inner);

/* Rodrigues: v rotated by angle (radians) about the unit axis k (rig_apply.c). */
void ffd_rig_rotate(const double k[3], double angle, const double v[3], double out[3]);

/* residuals[c] = |reached_c - target_c| for k constraints (k by 3 each);
 * returns the largest (0 when k == 0). */
double ffd_rig_residuals(size_t k, const double *reached, const double *targets,
                         double *residuals);

/* The method's part of a report (rig_apply.c). ffd_rig_details_create: an
 * empty JSON object for the report's details (NULL when out of memory) and
 * the mark of cJSON's failed allocations; add the method's keys with cJSON,
 * then ffd_rig_report_set_details stores its text in report->details and
 * deletes it (FFD_ERR_NOMEM when an allocation failed since mark).
 * ffd_rig_report_note appends one line ("note: ..." or "warning: ...") to
 * report->notes. */
struct cJSON *ffd_rig_details_create(unsigned long *mark);
ffd_status ffd_rig_report_set_details(ffd_rig_report *report, struct cJSON *details,
                                      unsigned long mark, const char *name, ffd_error *err);
ffd_status ffd_rig_report_note(ffd_rig_report *report, const char *name, ffd_error *err,
                               const char *fmt, ...) FFD_PRINTF(4, 5);

/* Limits: the dense k x (variables) least-squares matrix of a
 * direct-manipulation solve of k constraints through map (rig_apply.c). */
ffd_status ffd_rig_charge_manip(const ffd_linear_map *map, size_t k, ffd_budget *budget,
                                ffd_error *err);
void ffd_rig_tspline_free(ffd_rig_tspline *t);
/* A refine step's insertions resolved against the lattice: "near" located,
 * {"cells": "proxy"} expanded (*out ffd_free'd by the caller). */
ffd_status ffd_rig_tsv_resolve(ffd_tsv *t, const ffd_rig_tsv_step *st, ffd_tsv_insertion **out,
                               size_t *out_count, ffd_error *err);

/* A zeroed rig with defaults (bspline, 5x5x5, auto box, margin 0.05). NULL on OOM. */
ffd_rig *ffd_rig_new(const char *name);

#endif
