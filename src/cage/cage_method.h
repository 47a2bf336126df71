/* cage_method — what the cage method gives the generic layers (the
 * registry's descriptor in cage_method.c): its rig section reader, writer
 * and release (cage_rig_json.c), its rig application (cage_rig.c), its
 * deformer (cage_session.c), and the helpers its files share. */
#ifndef FFD_CAGE_METHOD_H
#define FFD_CAGE_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"

/* The method's descriptor (cage_method.c; listed in deformer/registry.c). */
extern const ffd_method ffd_method_cage;

/* The method's top-level rig keys (ffd_method.rig_keys; cage_rig_json.c). */
extern const char *const ffd_rig_keys_cage[];

/* A cage vertex moved by delta. */
typedef ffd_rig_point_move ffd_rig_cage_move; /* rig_json.h */

/* The rig section (docs/cage.md "Rigs"). */
typedef struct ffd_rig_cage {
    int cage_auto;             /* "cage": "auto": the mesh's bounding box grown by margin */
    double margin;             /* of the diagonal, per side; default 0.05 */
    double *vertices;          /* the cage at rest (vertex_count by 3), NULL for "auto" */
    size_t vertex_count;
    uint32_t *triangles;       /* triangle_count by 3 (polygons fan-triangulated) */
    size_t triangle_count;
    uint32_t *face_of;         /* per triangle, the face it came from (messages) */
    char *file;                /* "cage": PATH as written, NULL otherwise */
    ffd_cage_options options;
    ffd_rig_cage_move *moves;  /* "moves", or "deformed" read as moves */
    size_t move_count;
} ffd_rig_cage;

static inline ffd_rig_cage *ffd_rig_cage_of(const ffd_rig *rig)
{
    return (ffd_rig_cage *)rig->section;
}

ffd_status ffd_rig_parse_cage(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);
int ffd_rig_write_cage(const ffd_rig *rig, cJSON *root);
void ffd_rig_release_cage(ffd_rig *rig);

/* The auto cage's vertices and triangles (8 and 12): the bounding box of
 * points (n by 3) grown by margin times its diagonal on every side. */
#define CAGE_AUTO_VERTICES 8
#define CAGE_AUTO_TRIANGLES 12
ffd_status ffd_rig_cage_auto(const double *points, size_t n, double margin,
                             double vertices[3 * CAGE_AUTO_VERTICES],
                             uint32_t triangles[3 * CAGE_AUTO_TRIANGLES], ffd_error *err);
/* The rig's cage at rest (its "auto" cage fitted to points, n by 3),
 * moves not applied; messages start with the rig's name. */
ffd_status ffd_rig_cage_create(const ffd_rig *rig, const double *points, size_t n,
                               ffd_cage **out, ffd_error *err);

/* Cage application (cage_rig.c): moves, then direct manipulation. */
ffd_status ffd_rig_apply_cage(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                              ffd_budget *budget, ffd_error *err);
/* Limits: binding n points to the cage of the rig (and its harmonic solve). */
ffd_status ffd_rig_cage_charge(const ffd_rig *rig, size_t n, size_t nv, size_t nt,
                               ffd_budget *budget, ffd_error *err);

ffd_status ffd_sess_cage_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                              ffd_error *err);

#endif
