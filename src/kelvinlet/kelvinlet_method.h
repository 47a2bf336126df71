/* kelvinlet_method — what the Kelvinlet method gives the generic layers (the
 * registry's descriptor in kelvinlet_method.c): its rig section, reader,
 * writer and release (kelvinlet_rig_json.c), its rig application and
 * constraint solve (kelvinlet_rig.c) and its deformer (kelvinlet_session.c). */
#ifndef FFD_KELVINLET_METHOD_H
#define FFD_KELVINLET_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"
#include "kelvinlet/kelvinlet.h"

/* The method's descriptor (kelvinlet_method.c; listed in deformer/registry.c). */
extern const ffd_method ffd_method_kelvinlet;

/* A "deformer": "kelvinlet" rig's own part (rig->section). */
typedef struct ffd_rig_kelvinlet {
    ffd_kelvinlet_brush *brushes; /* owned (borrowed in a writer's view) */
    size_t brush_count;
    ffd_kelvinlet_options options;
} ffd_rig_kelvinlet;

static inline ffd_rig_kelvinlet *ffd_rig_kelvinlet_of(const ffd_rig *rig)
{
    return (ffd_rig_kelvinlet *)rig->section;
}

/* kelvinlet_rig_json.c: the schema (docs/kelvinlet.md). */
extern const char *const ffd_rig_keys_kelvinlet[];
ffd_status ffd_rig_parse_kelvinlet(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);
int ffd_rig_write_kelvinlet(const ffd_rig *rig, cJSON *root);
void ffd_rig_release_kelvinlet(ffd_rig *rig);
/* One brush object at path (an ffd_rig_element_reader: element is an
 * ffd_kelvinlet_brush; the checks that need the Poisson ratio are the
 * caller's, ffd_kelvinlet_check_brush). */
ffd_status ffd_rig_read_kelvinlet_brush(const ffd_rig_parser *p, const cJSON *item,
                                        const char *path, void *element, void *ctx);

/* kelvinlet_rig.c: the rig's brushes as a handle, with its constraints
 * solved over the grabs' displacements (points: the mesh's n rest
 * vertices, for vertex constraints). result and the k residuals/reached
 * points (may be NULL) describe the solve. */
ffd_status ffd_kelvinlet_from_rig(const ffd_rig *rig, const double *points, size_t n,
                                  ffd_budget *budget, ffd_kelvinlet **out,
                                  ffd_manip_result *result, double *residuals, double *reached,
                                  ffd_error *err);
ffd_status ffd_rig_apply_kelvinlet(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                                   ffd_budget *budget, ffd_error *err);

/* kelvinlet_session.c */
ffd_status ffd_sess_kelvinlet_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                                   ffd_error *err);

#endif
