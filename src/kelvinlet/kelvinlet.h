/* kelvinlet — the Kelvinlet brushes (de Goes and James 2017, "Regularized
 * Kelvinlets"): the internal part of the module shared by its files. The
 * mathematics is kelvinlet.c behind the public ffd_kelvinlet_* (ffd_kelvinlet.h). */
#ifndef FFD_KELVINLET_H
#define FFD_KELVINLET_H

#include "core/core.h"

/* A pinch matrix is symmetric and traceless when its asymmetry and trace
 * are within this times max(1, its largest entry). */
#define FFD_KELVINLET_TOL_PINCH 1e-12

/* Most sub-steps of a brush in a sequence (the rig's "steps"). */
#define FFD_KELVINLET_MAX_STEPS 10000u

/* The brush's names in rigs ("grab", "twist", "scale", "pinch"), indexed by
 * ffd_kelvinlet_type, NULL-terminated. */
extern const char *const ffd_kelvinlet_type_names[];
extern const char *const ffd_kelvinlet_combine_names[];
extern const char *const ffd_kelvinlet_multiscale_names[];

/* Checks one brush for the Poisson ratio nu; messages "WHERE.key: ...". */
ffd_status ffd_kelvinlet_check_brush(const ffd_kelvinlet_brush *brush, double nu,
                                     const char *where, ffd_error *err);
/* Checks the options (nu, steps, ratio); messages "WHERE: key: ...". */
ffd_status ffd_kelvinlet_check_options(const ffd_kelvinlet_options *options, const char *where,
                                       ffd_error *err);

/* 1 when the brush moves nothing (grab 0, angle 0, factor 1, pinch 0). */
int ffd_kelvinlet_brush_inert(const ffd_kelvinlet_brush *brush);
/* The brush made inert, its center, radius and axis kept. */
void ffd_kelvinlet_brush_make_inert(ffd_kelvinlet_brush *brush);

#endif
