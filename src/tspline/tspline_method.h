/* tspline_method — what the T-spline method gives the generic layers (the
 * registry's descriptor in tspline_method.c): its rig section reader and
 * release (tspline_rig_json.c), its rig application, its editor deformer
 * (tspline_session.c), and the helpers its files share. */
#ifndef FFD_TSPLINE_METHOD_H
#define FFD_TSPLINE_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"

void ffd_rig_release_tspline(ffd_rig *rig);

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
