/* Rig test helpers shared by test_rig.c and test_rig_pbffd.c: parse a rig
 * expecting success, or expecting a status and a message fragment. */
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

#endif
