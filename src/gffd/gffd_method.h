/* gffd_method — what GFFD method gives the generic layers (the
 * registry's descriptor in gffd_method.c): its rig section reader and
 * release (gffd_rig_json.c), its rig application, its editor deformer
 * (gffd_session.c), and the helpers its files share. */
#ifndef FFD_GFFD_METHOD_H
#define FFD_GFFD_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"

/* The method's descriptor (gffd_method.c; listed in deformer/registry.c). */
extern const ffd_method ffd_method_gffd;

/* The method's top-level rig keys (ffd_method.rig_keys; gffd_rig_json.c). */
extern const char *const ffd_rig_keys_gffd[];

/* The rig section (docs/rig.md "GFFD rigs"). */
/* GFFD: one skeleton primitive, owned. */
typedef struct ffd_rig_primitive {
    ffd_gffd_kind kind;
    double *vertices;     /* vertex_count by 3 */
    size_t vertex_count;
    uint32_t *face_offsets; /* face_count + 1 (patch, polyhedron) */
    uint32_t *face_indices;
    size_t face_count;
    double radius;
} ffd_rig_primitive;

typedef enum ffd_rig_gffd_edit_kind {
    FFD_RIG_EDIT_TRANSLATE = 0, /* every vertex += delta */
    FFD_RIG_EDIT_ROTATE,        /* about axis through center by angle (radians) */
    FFD_RIG_EDIT_SCALE,         /* about center by scale[3] */
    FFD_RIG_EDIT_MOVE,          /* one vertex += delta */
    FFD_RIG_EDIT_VERTICES       /* all vertices replaced */
} ffd_rig_gffd_edit_kind;

/* GFFD: one skeleton edit (§5, first way). */
typedef struct ffd_rig_gffd_edit {
    ffd_rig_gffd_edit_kind kind;
    int all;              /* 1: every primitive (primitive ignored) */
    uint32_t primitive;
    uint32_t vertex;      /* MOVE */
    double delta[3];      /* TRANSLATE, MOVE */
    double axis[3];       /* ROTATE (any length) */
    double angle;
    double scale[3];      /* SCALE */
    int has_center;       /* 0: the centroid of the vertices edited */
    double center[3];
    double *vertices;     /* VERTICES: vertex_count by 3 */
    size_t vertex_count;
} ffd_rig_gffd_edit;

typedef struct ffd_rig_gffd {
    ffd_rig_primitive *skeleton;
    size_t skeleton_count;
    ffd_rig_primitive *replace;   /* §5, second way; NULL when none */
    size_t replace_count;
    ffd_rig_gffd_edit *edits;
    size_t edit_count;
    double *corr_from, *corr_to;  /* user correspondences, corr_count by 3 each */
    size_t corr_count;
    ffd_gffd_options options;
    int resample;
    ffd_gffd_resample_options resample_options;
} ffd_rig_gffd;

/* The GFFD section of a rig whose method is gffd (rig->section). */
static inline ffd_rig_gffd *ffd_rig_gffd_of(const ffd_rig *rig)
{
    return (ffd_rig_gffd *)rig->section;
}

void ffd_rig_release_gffd(ffd_rig *rig);
/* The writer (ffd_method.write): the section as its reader reads it, into
 * root; 0 when out of memory. */
int ffd_rig_write_gffd(const ffd_rig *rig, cJSON *root);
/* A primitive's "type", and its faces as JSON with vertex ids + offset
 * (the editor's state shares them). */
const char *ffd_rig_gffd_kind_name(ffd_gffd_kind kind);
cJSON *ffd_rig_gffd_faces_json(const ffd_rig_primitive *p, size_t offset);

/* A skeleton primitive (docs/rig.md "GFFD rigs"); a "file" is read
 * relative to p->name's directory. On error prim may hold partial arrays
 * (ffd_rig_primitive_free). */
ffd_status ffd_rig_read_primitive(const ffd_rig_parser *p, const cJSON *item, const char *path,
                              ffd_rig_primitive *prim);
/* An array of at least one primitive (ffd_rig_read_array: on error nothing
 * is left to free). */
ffd_status ffd_rig_read_skeleton(const ffd_rig_parser *p, const cJSON *item, const char *key,
                             ffd_rig_primitive **out, size_t *count);

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
