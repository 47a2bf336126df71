/* pbffd_method — what PB-FFD method gives the generic layers (the
 * registry's descriptor in pbffd_method.c): its rig section reader and
 * release (pbffd_rig_json.c), its rig application, its editor deformer
 * (pbffd_session.c), and the helpers its files share. */
#ifndef FFD_PBFFD_METHOD_H
#define FFD_PBFFD_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"

/* The method's descriptor (pbffd_method.c; listed in deformer/registry.c). */
extern const ffd_method ffd_method_pbffd;

/* The method's top-level rig keys (ffd_method.rig_keys; pbffd_rig_json.c). */
extern const char *const ffd_rig_keys_pbffd[];

/* The rig section (docs/rig.md "PB-FFD rigs"). */
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

/* The PB-FFD section of a rig whose method is pbffd (rig->section). */
static inline ffd_rig_pbffd *ffd_rig_pbffd_of(const ffd_rig *rig)
{
    return (ffd_rig_pbffd *)rig->section;
}

void ffd_rig_release_pbffd(ffd_rig *rig);
/* The writer (ffd_method.write): the section as its reader reads it, into
 * root; 0 when out of memory. */
int ffd_rig_write_pbffd(const ffd_rig *rig, cJSON *root);

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
