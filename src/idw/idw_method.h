/* idw_method — what the IDW method gives the generic layers (the registry's
 * descriptor in idw_method.c): its rig section reader, writer and release
 * (idw_rig_json.c), its rig application (idw_rig.c), its deformer
 * (idw_session.c) and its PyGeM parameter files (idw_prm.c). */
#ifndef FFD_IDW_METHOD_H
#define FFD_IDW_METHOD_H

#include "deformer/method.h"
#include "rig/rig_points.h"

/* The method's descriptor (idw_method.c; listed in deformer/registry.c). */
extern const ffd_method ffd_method_idw;

/* The method's top-level rig keys (ffd_method.rig_keys; idw_rig_json.c). */
extern const char *const ffd_rig_keys_idw[];

/* The rig section (docs/idw-idw.md). */
typedef struct ffd_rig_idw {
    ffd_idw_options options; /* power, weighting */
    ffd_rig_points points; /* the control points and their moves (rig_points.h) */
} ffd_rig_idw;

static inline ffd_rig_idw *ffd_rig_idw_of(const ffd_rig *rig)
{
    return (ffd_rig_idw *)rig->section;
}

/* "pygem" or "shepard" (the rig's "weighting"). */
const char *ffd_rig_idw_weighting_name(ffd_idw_weighting w);

ffd_status ffd_rig_parse_idw(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);
int ffd_rig_write_idw(const ffd_rig *rig, cJSON *root);
void ffd_rig_release_idw(ffd_rig *rig);

ffd_status ffd_rig_apply_idw(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                             ffd_budget *budget, ffd_error *err);
/* The editor's defaults for a "create" body (idw_session.c). */
ffd_status ffd_sess_idw_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p);
ffd_status ffd_sess_idw_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err);

/* PyGeM's IDW parameter file ([Inverse Distance Weighting], [Control points];
 * idw_prm.c): read into a rig of this method (messages "NAME:LINE: ..."),
 * and the rig written back in PyGeM's layout (*text ffd_free'd). */
ffd_status ffd_rig_parse_prm_idw(const char *text, size_t size, const char *name, ffd_rig **out,
                                 ffd_error *err);
ffd_status ffd_rig_write_prm_idw(const ffd_rig *rig, char **text, ffd_error *err);

#endif
