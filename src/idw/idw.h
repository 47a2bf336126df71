/* idw — inverse-distance weighting (include/ffd_idw.h; idw_weights.c). */
#ifndef FFD_IDW_H
#define FFD_IDW_H

#include "core/core.h"
#include "rig/rig_points.h"

struct ffd_idw {
    size_t count;
    ffd_idw_options options; /* defaults filled */
    double *rest;            /* count by 3: c_j */
    double *points;          /* count by 3: p_j */
    double *displacement;    /* count by 3: p_j - c_j */
    int moved;               /* 0: every p_j == c_j bitwise, x' = x exactly */
};

/* The linear map of rows->points (n by 3) under the IDW rows->morph: dense
 * rows a_j(x) over the control points (no tie). */
void ffd_idw_linear_map(const ffd_point_rows *rows, size_t n, ffd_linear_map *map);

#endif
