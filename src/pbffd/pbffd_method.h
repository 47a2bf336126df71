/* pbffd_method — what PB-FFD method gives the generic layers (the
 * registry's descriptor in pbffd_method.c): its rig section reader and
 * release (pbffd_rig_json.c), its rig application, its editor deformer
 * (pbffd_session.c), and the helpers its files share. */
#ifndef FFD_PBFFD_METHOD_H
#define FFD_PBFFD_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"

void ffd_rig_release_pbffd(ffd_rig *rig);

ffd_status ffd_sess_pbffd_create(const sess_ctx *ctx, const cJSON *body, sess_method **out,
                             ffd_error *err);
/* The descriptor's create_body: the editor's defaults and old body forms
 * (pbffd_session.c). */
ffd_status ffd_sess_pbffd_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p);

ffd_status ffd_sess_pbffd_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                           ffd_error *err);

/* PB-FFD application (pbffd_rig.c); constraints as for the lattice. */
ffd_status ffd_rig_apply_pbffd(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                               ffd_budget *budget, ffd_error *err);

/* The PB-FFD rig's steps, shared with the editor session (pbffd_rig.c). */
/* The frame edit e asks for, from the control's current frame. */
void ffd_rig_pb_edited_frame(const ffd_rig_pb_edit *e, const double current[3][3],
                             double out[3][3]);
/* The control edit e (entry i of the list key) names: its index, or the
 * enabled control of its level whose current centre is nearest to its
 * "near" point (ties: lowest index). FFD_ERR_RANGE, FFD_ERR_INVALID. */
ffd_status ffd_rig_pb_edit_target(const ffd_rig *rig, const ffd_pbffd *pb, const char *key,
                                  size_t i, const ffd_rig_pb_edit *e, size_t *index,
                                  ffd_error *err);
/* Applies the rig's moves in file order, then its frame edits (step 3).
 * resolved (may be NULL) receives the control index each move and then each
 * frame edit used (move_count + frame_count entries); frames (may be NULL)
 * the frame each frame edit set (frame_count). */
ffd_status ffd_rig_pb_apply_edits(const ffd_rig *rig, ffd_pbffd *pb, size_t *resolved,
                                  double (*frames)[3][3], ffd_error *err);
/* The minimum-norm change of the controls of constraint_level (delta: their
 * count by 3) that brings the constraints' bound points rows[c] from current
 * (all bound points) to their targets (§3.3); nothing is moved. */
ffd_status ffd_rig_pb_constraint_delta(const ffd_rig *rig, ffd_pbffd *pb, const size_t *rows,
                                       const double *current, double *delta,
                                       ffd_manip_result *result, ffd_error *err);

ffd_status ffd_rig_parse_pbffd(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);

#endif
