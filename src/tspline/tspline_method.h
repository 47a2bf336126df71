/* tspline_method — what the T-spline method gives the generic layers (the
 * registry's descriptor in tspline_method.c): its rig section reader and
 * release (tspline_rig_json.c), its rig application, its editor deformer
 * (tspline_session.c), and the helpers its files share. */
#ifndef FFD_TSPLINE_METHOD_H
#define FFD_TSPLINE_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"

/* The method's descriptor (tspline_method.c; listed in deformer/registry.c). */
extern const ffd_method ffd_method_tspline;

/* The method's top-level rig keys (ffd_method.rig_keys; tspline_rig_json.c). */
extern const char *const ffd_rig_keys_tspline[];

/* The rig section (docs/rig.md "T-spline rigs"). */
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

/* The T-spline section of a rig whose method is tspline (rig->section). */
static inline ffd_rig_tspline *ffd_rig_tspline_of(const ffd_rig *rig)
{
    return (ffd_rig_tspline *)rig->section;
}

void ffd_rig_tspline_free(ffd_rig_tspline *t);
/* A refine step's insertions resolved against the lattice: "near" located,
 * {"cells": "proxy"} expanded (*out ffd_free'd by the caller). */
ffd_status ffd_rig_tsv_resolve(ffd_tsv *t, const ffd_rig_tsv_step *st, ffd_tsv_insertion **out,
                               size_t *out_count, ffd_error *err);

void ffd_rig_release_tspline(ffd_rig *rig);
/* The writer (ffd_method.write): the section as its reader reads it, into
 * root; 0 when out of memory. */
int ffd_rig_write_tspline(const ffd_rig *rig, cJSON *root);

ffd_status ffd_sess_tspline_create(const sess_ctx *ctx, const cJSON *body, sess_method **out,
                               ffd_error *err);

ffd_status ffd_sess_tspline_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err);

/* T-spline application (tspline_rig.c). */
ffd_status ffd_rig_apply_tspline(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                                 ffd_budget *budget, ffd_error *err);
/* Limits (ffd_limits): charge a refinement of the resolved insertions, and
 * an ARAP drag on the current lattice, to budget before running them. */
ffd_status ffd_rig_tsv_charge_refine(const ffd_tsv *t, const ffd_tsv_insertion *ins, size_t count,
                                     ffd_budget *budget, ffd_error *err);
ffd_status ffd_rig_tsv_charge_arap(const ffd_tsv *t, uint32_t iterations, ffd_budget *budget,
                                   ffd_error *err);

ffd_status ffd_rig_parse_tspline(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);

/* A refine step's insertions (tspline_rig_json.c; the editor's "refine" op too). */
ffd_status ffd_rig_read_tsv_refinements(const ffd_rig_parser *p, const cJSON *item, const char *path,
                                    ffd_rig_tsv_step *st);

#endif
