/* gffd_method — what GFFD method gives the generic layers (the
 * registry's descriptor in gffd_method.c): its rig section reader and
 * release (gffd_rig_json.c), its rig application, its editor deformer
 * (gffd_session.c), and the helpers its files share. */
#ifndef FFD_GFFD_METHOD_H
#define FFD_GFFD_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"

void ffd_rig_release_gffd(ffd_rig *rig);

ffd_status ffd_sess_gffd_create(const sess_ctx *ctx, const cJSON *body, sess_method **out,
                            ffd_error *err);
/* The descriptor's create_body: the editor's defaults and old body forms
 * (gffd_session.c). */
ffd_status ffd_sess_gffd_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p);

ffd_status ffd_sess_gffd_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                          ffd_error *err);

/* GFFD application (gffd_rig.c). */
ffd_status ffd_rig_apply_gffd(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                              ffd_budget *budget, ffd_error *err);
/* Reads a skeleton primitive's geometry from a file: a polyline from an OBJ
 * file's v and l lines (one l statement, or none: the v lines in order), a
 * patch or polyhedron from a mesh file (OBJ, PLY, OFF). */
ffd_status ffd_rig_load_primitive(const char *path, ffd_rig_primitive *prim, ffd_error *err);
void ffd_rig_primitive_free(ffd_rig_primitive *prim);
/* Limits (ffd_limits): charges the field fits of prims (the rig's "skeleton",
 * with a refit per edit, or its "replace") to budget; the message names
 * key[i] and max_samples. */
ffd_status ffd_rig_gffd_charge(const ffd_rig *rig, const ffd_rig_primitive *prims, size_t count,
                               const char *key, ffd_budget *budget, ffd_error *err);
/* The primitive as the library's ffd_gffd_primitive (borrowing its arrays). */
void ffd_rig_primitive_public(const ffd_rig_primitive *r, ffd_gffd_primitive *p);
/* Applies edit i of the rig to the current skeleton of g (step 2): a
 * rotation or translation through ffd_gffd_transform, the others through
 * ffd_gffd_set_vertices, for each primitive it touches. */
/* The centre of edit e on g: its "center", or the centroid of every vertex it touches. */
void ffd_rig_gffd_edit_center(const ffd_rig_gffd_edit *e, const ffd_gffd *g, double center[3]);
ffd_status ffd_rig_gffd_apply_edit(const ffd_rig *rig, ffd_gffd *g, size_t i, ffd_error *err);

ffd_status ffd_rig_parse_gffd(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);

#endif
