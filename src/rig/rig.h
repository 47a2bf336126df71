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

/* A direct-manipulation pin the editor kept (docs/rig.md "pins"): a mesh
 * vertex held at a target. A record of the editing session: the rig's
 * moves already hold the deformation, so pins change no deform. */
typedef struct ffd_rig_pin {
    uint32_t vertex;
    double target[3];
} ffd_rig_pin;

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
    ffd_rig_pin *pins;       /* "pins" (rig_pins.c), in the order given */
    size_t pin_count;
    struct ffd_rig_layers *layers; /* the generic layers every method shares: weights,
                                      strength, constraints, fold policy (rig_layers.c);
                                      NULL when the rig has none */
    char **input_files;      /* the files the rig read besides itself (ffd_rig_input_path) */
    size_t input_file_count;
};

/* "NAME: CONTEXT: inner message" with the inner status (rig_apply.c). */
ffd_status ffd_rig_wrap(ffd_error *err, ffd_status status, const char *name, const char *context,
                        const ffd_error *inner);

/* Rodrigues: v rotated by angle (radians) about the unit axis k (rig_apply.c). */
void ffd_rig_rotate(const double k[3], double angle, const double v[3], double out[3]);

/* Rest positions of the constrained points (k by 3): vertex ids checked
 * against n (FFD_ERR_RANGE, named). */
ffd_status ffd_rig_constraint_points(const ffd_rig *rig, const double *positions, size_t n,
                                     double *points, ffd_error *err);
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

/* ======================================================================
 * The generic layers (rig_layers.c, docs/constraints.md): keys every
 * method's rig may hold, read before the method's own reader sees the rig
 * and applied around every method's deformer (deformer/layers.c).
 * ====================================================================== */
enum { FFD_WEIGHTS_NONE = 0, FFD_WEIGHTS_ATTRIBUTE, FFD_WEIGHTS_FILE, FFD_WEIGHTS_VALUES };
enum { FFD_PRESERVE_VOLUME = 1, FFD_PRESERVE_BARYCENTRE = 2 };
enum { FFD_FOLD_ALLOW = 0, FFD_FOLD_REFUSE, FFD_FOLD_SHORTEN };
enum { FFD_LINEAR_OVER_POINTS = 0, FFD_LINEAR_OVER_CONTROLS };

/* sum_t coef[t] * X[index[t]][axis[t]] = value, X the deformed points or the controls. */
typedef struct ffd_rig_linear_constraint {
    int over;            /* FFD_LINEAR_OVER_* */
    size_t term_count;
    uint32_t *index;
    uint8_t *axis;
    double *coef;
    double value;
} ffd_rig_linear_constraint;

typedef struct ffd_rig_layers {
    double strength;          /* "strength" (default 1) */
    int weights_kind;         /* FFD_WEIGHTS_* */
    char *weights_name;       /* the attribute, or the file as written */
    char *weights_path;       /* the file resolved against the rig's directory */
    double *weights;          /* FILE, VALUES: weight_count values; ATTRIBUTE: NULL */
    size_t weight_count;
    unsigned preserve;        /* FFD_PRESERVE_* bits */
    ffd_rig_linear_constraint *linear;
    size_t linear_count;
    int mask_axes[3];         /* "constraint_mask": which coordinates may change (default all) */
    uint32_t *mask_controls;  /* which controls may change (NULL: all) */
    size_t mask_control_count;
    int fold_policy;          /* FFD_FOLD_* */
} ffd_rig_layers;

/* The generic keys, NULL-terminated (a method's reader never sees them). */
extern const char *const ffd_rig_layer_keys[];
/* 1 when the layers change nothing (NULL, or strength 1 and nothing else). */
int ffd_rig_layers_trivial(const ffd_rig_layers *layers);
/* The text of a weights file (rig_layers.c; docs/constraints.md): one
 * number per line in vertex order, blank and '#' lines skipped; file names
 * it in messages ("w.txt:3: the weight is not finite (nan)"). *out
 * (ffd_free; NULL when empty) holds *count values. FFD_ERR_PARSE,
 * NONFINITE, NOMEM. */
ffd_status ffd_rig_parse_weights(const char *text, size_t size, const char *file, double **out,
                                 size_t *count, ffd_error *err);
void ffd_rig_layers_free(ffd_rig_layers *layers);
/* A deep copy (NULL when out of memory; NULL for NULL). */
ffd_rig_layers *ffd_rig_layers_copy(const ffd_rig_layers *layers);

/* A zeroed rig of the registry's default method with its defaults (bspline,
 * 5x5x5, auto box, margin 0.05). NULL on OOM. */
ffd_rig *ffd_rig_new(const char *name);

/* FFD_ERR_RANGE when a pin's vertex is not one of a mesh of n vertices:
 * "NAME: pins[i].vertex: V out of range: the mesh has n vertices". */
ffd_status ffd_rig_check_pins(const ffd_rig *rig, size_t n, ffd_error *err);

#endif
