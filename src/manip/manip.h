/* manip — direct manipulation, generic over linear deformers (ffd_linear_map),
 * and constrained FFD (constrained.c). */
#ifndef FFD_MANIP_H
#define FFD_MANIP_H

#include "core/core.h"

/* ======================================================================
 * Constrained FFD (constrained.c; PyGeM's VFFD, BFFD and CFFD): the
 * minimal change of the requested controls that keeps the enclosed volume,
 * the barycentre of the points, or linear constraints exactly.
 * ====================================================================== */

enum { FFD_CFFD_OVER_POINTS = 0, FFD_CFFD_OVER_CONTROLS = 1 };

/* sum_t coef[t] * X[index[t]][axis[t]] = value, X the deformed points
 * (over == FFD_CFFD_OVER_POINTS) or the controls. */
typedef struct ffd_cffd_linear {
    int over;
    size_t term_count;
    const uint32_t *index;
    const uint8_t *axis;
    const double *coef;
    double value;
} ffd_cffd_linear;

typedef struct ffd_cffd_problem {
    /* The deformed points as a linear map of the controls: every column
     * tied to a control id (or FFD_TIE_FIXED), map->point_count points. */
    const ffd_linear_map *map;
    size_t control_count;
    const double *controls;   /* control_count by 3: the requested controls P_req */
    const double *points;     /* map->point_count by 3: the points X(P_req) */
    /* which coordinates may change (control_count by 3, 1: free); NULL: all */
    const unsigned char *free;
    /* volume: the surface enclosing it (faces oriented outwards, polygons
     * fanned from their first corner) and the volume to keep */
    int preserve_volume;
    double volume;
    const uint32_t *face_offsets, *face_indices;
    size_t face_count;
    int preserve_barycentre;  /* the mean of the points */
    double barycentre[3];
    const ffd_cffd_linear *linear;
    size_t linear_count;
    double scale;             /* a length of the problem (the bounding-box diagonal) */
} ffd_cffd_problem;

typedef struct ffd_cffd_result {
    size_t constraint_count;  /* scalar constraints: volume 1, barycentre 3, one per linear */
    double max_residual;      /* the largest |g_c| / scale_c (relative) */
    double change_norm;       /* |P - P_req| (Frobenius) */
    size_t iterations;        /* Newton steps taken */
    size_t rank;              /* rank of the last constraint Jacobian */
} ffd_cffd_result;

/* The volume enclosed by the faces (divergence theorem over the fanned
 * triangles: V = 1/6 sum a . (b x c)). */
double ffd_cffd_volume(const double *points, const uint32_t *face_offsets,
                       const uint32_t *face_indices, size_t face_count);

/* Solves min |P - P_req|^2 over the free coordinates subject to the
 * constraints g(P) = 0, by Newton steps on the linearised constraints
 * (each the minimum-norm step through LAPACK dgelsd), the volume's exact
 * gradient chained through the map: dV/dP_j = sum_i w_ij dV/dx_i.
 * controls_out (control_count by 3) and points_out (point_count by 3)
 * receive P and X(P); residuals (constraint_count, may be NULL) |g_c|
 * relative to its scale. FFD_ERR_NUMERIC when the constraints cannot be
 * met (no free coordinate reaches them, or Newton does not converge to
 * 1e-12), FFD_ERR_INVALID (volume without faces), FFD_ERR_RANGE (an index). */
ffd_status ffd_cffd_solve(const ffd_cffd_problem *pb, double *controls_out, double *points_out,
                          double *residuals, ffd_cffd_result *result, ffd_error *err);

#endif
