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
    FFD_RIG_CONSTRAINT_POINT       /* an arbitrary point (rest position) inside the control volume */
} ffd_rig_constraint_kind;

typedef struct ffd_rig_constraint {
    ffd_rig_constraint_kind kind;
    uint32_t vertex;   /* kind == VERTEX */
    double point[3];   /* kind == POINT: the point at rest */
    double target[3];
} ffd_rig_constraint;

struct ffd_rig {
    char *name;              /* file name for messages */
    const struct ffd_method *method; /* the rig's "deformer" (deformer/method.h) */
    void *section;           /* the method's own part, owned (the method's
                              * <method>_method.h; NULL for a method without one) */
    ffd_basis basis;
    uint32_t resolution[3];
    int box_auto;            /* 1: fit the mesh bounding box grown by margin */
    double margin;           /* default 0.05 */
    ffd_box box;             /* when box_auto == 0 */
    ffd_outside outside;     /* default FFD_OUTSIDE_FIXED */
    ffd_lattice_shape shape; /* lattice: "basis" per axis, "tension", "continuity",
                                "coordinates", "frame" (zeroed: the basis, cartesian) */
    int frame_auto;          /* lattice "frame": "auto": fitted to the mesh (margin) */
    double rcond;            /* 0: solver default */
    int limit_step;          /* "limit_step": shrink the constraint solve's step by bisection
                                until no cell inverts and the map does not fold (lattice) */
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

/* A zeroed rig of the registry's default method with its defaults (bspline,
 * 5x5x5, auto box, margin 0.05). NULL on OOM. */
ffd_rig *ffd_rig_new(const char *name);

#endif
