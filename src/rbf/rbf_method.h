/* rbf_method — what the RBF method gives the generic layers (the registry's
 * descriptor in rbf_method.c): its rig section reader, writer and release
 * (rbf_rig_json.c), its rig application (rbf_rig.c), its deformer
 * (rbf_session.c) and its PyGeM parameter files (rbf_prm.c). */
#ifndef FFD_RBF_METHOD_H
#define FFD_RBF_METHOD_H

#include "deformer/method.h"
#include "rig/rig_points.h"

/* The method's descriptor (rbf_method.c; listed in deformer/registry.c). */
extern const ffd_method ffd_method_rbf;

/* The method's top-level rig keys (ffd_method.rig_keys; rbf_rig_json.c). */
extern const char *const ffd_rig_keys_rbf[];

/* The rig section (docs/rbf-idw.md). */
typedef struct ffd_rig_rbf {
    ffd_rbf_options options;
    ffd_rig_points points; /* the control points and their moves (rig_points.h) */
} ffd_rig_rbf;

static inline ffd_rig_rbf *ffd_rig_rbf_of(const ffd_rig *rig)
{
    return (ffd_rig_rbf *)rig->section;
}

ffd_status ffd_rig_parse_rbf(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);
int ffd_rig_write_rbf(const ffd_rig *rig, cJSON *root);
void ffd_rig_release_rbf(ffd_rig *rig);

ffd_status ffd_rig_apply_rbf(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                             ffd_budget *budget, ffd_error *err);
/* The editor's defaults for a "create" body (rbf_session.c). */
ffd_status ffd_sess_rbf_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p);
ffd_status ffd_sess_rbf_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err);

/* PyGeM's RBF parameter file ([Radial Basis Functions], [Control points];
 * rbf_prm.c): read into a rig of this method (messages "NAME:LINE: ..."),
 * and the rig written back in PyGeM's layout (*text ffd_free'd). */
ffd_status ffd_rig_parse_prm_rbf(const char *text, size_t size, const char *name, ffd_rig **out,
                                 ffd_error *err);
ffd_status ffd_rig_write_prm_rbf(const ffd_rig *rig, char **text, ffd_error *err);

#endif
