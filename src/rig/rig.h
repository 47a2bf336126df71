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

struct ffd_rig {
    char *name;              /* file name for messages */
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
};

/* A zeroed rig with defaults (bspline, 5x5x5, auto box, margin 0.05). NULL on OOM. */
ffd_rig *ffd_rig_new(const char *name);

#endif
