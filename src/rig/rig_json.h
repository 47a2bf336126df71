/* rig_json — the JSON value readers shared by the rig parsers (rig_json.c,
 * rig_json_tspline.c, the only files that include cJSON). Each names the JSON
 * path of what it rejects: "rig.json: steps[1].deform.handles[0].delta:
 * expected an array of 3 finite numbers". */
#ifndef FFD_RIG_JSON_H
#define FFD_RIG_JSON_H

#include "rig/rig.h"

#include <cjson/cJSON.h>

#define RIG_PATH_MAX 96

typedef struct parser {
    const char *name;
    ffd_error *err;
} parser;

ffd_status ffd_rig_expected(const parser *p, const char *path, const char *what);
ffd_status ffd_rig_read_number(const parser *p, const cJSON *item, const char *path, double *out);
/* An array of exactly 3 finite numbers. */
ffd_status ffd_rig_read_vec3(const parser *p, const cJSON *item, const char *path, double out[3]);
int ffd_rig_is_uint32(const cJSON *item);
/* An array of exactly 3 non-negative integers. */
ffd_status ffd_rig_read_uint3(const parser *p, const cJSON *item, const char *path, uint32_t out[3]);
/* Index of s in the NULL-terminated list, or -1. */
int ffd_rig_lookup(const char *s, const char *const *names);
/* One of a fixed set of strings; what describes the set for the message. */
ffd_status ffd_rig_read_enum(const parser *p, const cJSON *item, const char *path,
                         const char *const *names, const char *what, int *out);
/* Rejects keys outside allowed (NULL-terminated) and keys given twice. */
ffd_status ffd_rig_check_keys(const parser *p, const cJSON *object, const char *path,
                          const char *const *allowed, const char *allowed_text);
/* A non-negative integer that fits uint32_t. */
ffd_status ffd_rig_read_index(const parser *p, const cJSON *item, const char *path, const char *what,
                          uint32_t *out);
ffd_status ffd_rig_read_positive(const parser *p, const cJSON *item, const char *path, double *out);
/* {"axis": [x,y,z], "angle": radians} and, when center is not NULL, an
 * optional "center": [x,y,z] (*has_center set when given). */
ffd_status ffd_rig_read_rotation(const parser *p, const cJSON *item, const char *path,
                             double axis[3], double *angle, double center[3], int *has_center);
/* An array of {"vertex": id, "target": [x,y,z]} or {"point": [x,y,z], "target": [..]}. */
ffd_status ffd_rig_read_constraints(const parser *p, const cJSON *item, const char *where,
                                ffd_rig_constraint **out, size_t *count);

/* A GFFD skeleton primitive (docs/rig.md "GFFD rigs"); a "file" is read
 * relative to p->name's directory. On error prim may hold partial arrays
 * (ffd_rig_primitive_free). */
ffd_status ffd_rig_read_primitive(const parser *p, const cJSON *item, const char *path,
                              ffd_rig_primitive *prim);
/* An array of at least one primitive; *count is set as soon as *out is
 * allocated, so that the caller frees what was read even on error. */
ffd_status ffd_rig_read_skeleton(const parser *p, const cJSON *item, const char *key,
                             ffd_rig_primitive **out, size_t *count);

/* "version", if given, is 1. */
ffd_status ffd_rig_read_version(const parser *p, const cJSON *root);
/* The top-level keys of a one-deformer rig: each in keys (else "NAME: KEY: not
 * a key of "deformer": "DEFORMER" rigs, expected one of KEYS_TEXT"), none
 * twice; and the version. */
ffd_status ffd_rig_check_deformer_root(const parser *p, const cJSON *root, const char *deformer,
                                   const char *const *keys, const char *keys_text);

/* A refine step's insertions (rig_json_tspline.c; the editor's "refine" op too). */
ffd_status ffd_rig_read_tsv_refinements(const parser *p, const cJSON *item, const char *path,
                                    ffd_rig_tsv_step *st);
/* The "deformer": "tspline" root (rig_json_tspline.c). */
ffd_status ffd_rig_read_tspline_root(const parser *p, const cJSON *root, ffd_rig *rig);

#endif
