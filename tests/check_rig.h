/* Rig test helpers shared by the test_rig*.c files: parse a rig expecting
 * success, or expecting a status and a message fragment; apply a rig
 * expecting a failure that leaves the mesh unchanged. */
#ifndef FFD_TEST_CHECK_RIG_H
#define FFD_TEST_CHECK_RIG_H

#include "check.h"
#include "rig/rig.h"

static ffd_rig *parse_ok(const char *json)
{
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    ffd_status s = ffd_rig_parse_json(json, strlen(json), "rig.json", &rig, &err);
    if (s != FFD_OK) {
        fprintf(stderr, "%s: unexpected failure (%s): %s\n  json: %s\n", check_current,
                ffd_status_string(s), err.message, json);
        check_failures++;
    }
    return rig;
}

/* Parses json expecting status and a message containing fragment. */
static void parse_bad_at(const char *json, ffd_status status, const char *fragment, int line)
{
    ffd_rig *rig = (ffd_rig *)1;
    ffd_error err = {{0}};
    ffd_status s = ffd_rig_parse_json(json, strlen(json), "rig.json", &rig, &err);
    if (s != status || rig != NULL || !strstr(err.message, fragment)) {
        fprintf(stderr,
                "%s:%d: %s: expected %s with \"%s\", got %s \"%s\" (out %s)\n  json: %s\n",
                __FILE__, line, check_current, ffd_status_string(status), fragment,
                ffd_status_string(s), err.message, rig ? "not NULL" : "NULL", json);
        check_failures++;
    }
    if (s == FFD_OK)
        ffd_rig_destroy(rig);
}
#define parse_bad(json, status, fragment) parse_bad_at(json, status, fragment, __LINE__)

static inline double *copy_positions(const ffd_mesh *mesh)
{
    size_t n = ffd_mesh_vertex_count(mesh);
    double *p = malloc((n ? n : 1) * 3 * sizeof *p);
    memcpy(p, ffd_mesh_positions(mesh), n * 3 * sizeof *p);
    return p;
}

static inline ffd_status apply_json(const char *json, ffd_mesh *mesh, ffd_rig_report *report,
                             ffd_error *err)
{
    ffd_rig *rig = NULL;
    ffd_status s = ffd_rig_parse_json(json, strlen(json), "rig.json", &rig, err);
    if (s == FFD_OK)
        s = ffd_rig_apply(rig, mesh, report, err);
    ffd_rig_destroy(rig);
    return s;
}

/* Parses json (which must parse) and applies it expecting status and a
 * message containing fragment; the mesh must be left exactly as it was. */
static inline void apply_bad_at(const char *json, ffd_mesh *mesh, ffd_status status,
                         const char *fragment, int line)
{
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
    ffd_status s = ffd_rig_parse_json(json, strlen(json), "rig.json", &rig, &err);
    if (s != FFD_OK) {
        fprintf(stderr, "%s:%d: %s: the rig should parse, got %s \"%s\"\n  json: %s\n", __FILE__,
                line, check_current, ffd_status_string(s), err.message, json);
        check_failures++;
        return;
    }
    size_t nv = ffd_mesh_vertex_count(mesh), nf = ffd_mesh_face_count(mesh);
    double *before = copy_positions(mesh);
    ffd_rig_report report;
    memset(&report, 0xab, sizeof report); /* must be reset by ffd_rig_apply */
    s = ffd_rig_apply(rig, mesh, &report, &err);
    if (s != status || !strstr(err.message, fragment)) {
        fprintf(stderr, "%s:%d: %s: expected %s with \"%s\", got %s \"%s\"\n  json: %s\n",
                __FILE__, line, check_current, ffd_status_string(status), fragment,
                ffd_status_string(s), err.message, json);
        check_failures++;
    }
    if (ffd_mesh_vertex_count(mesh) != nv || ffd_mesh_face_count(mesh) != nf ||
        memcmp(before, ffd_mesh_positions(mesh), nv * 3 * sizeof *before) != 0) {
        fprintf(stderr, "%s:%d: %s: a failed apply changed the mesh\n  json: %s\n", __FILE__,
                line, check_current, json);
        check_failures++;
    }
    ffd_rig_report_free(&report);
    ffd_rig_destroy(rig);
    free(before);
}
#define apply_bad(json, mesh, status, fragment) \
    apply_bad_at(json, mesh, status, fragment, __LINE__)

#endif
