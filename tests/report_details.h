/* Reading a rig report's details (ffd_rig_report.details, one JSON object)
 * in tests: a value by its dotted path ("resample.added_vertices"). */
#ifndef FFD_TEST_REPORT_DETAILS_H
#define FFD_TEST_REPORT_DETAILS_H

#include "ffd.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <string.h>

/* The item at path in details (a parsed object), or NULL. */
static inline const cJSON *detail_item(const cJSON *details, const char *path)
{
    const cJSON *item = details;
    char key[64];
    while (item && *path) {
        size_t len = strcspn(path, ".");
        if (len >= sizeof key)
            return NULL;
        memcpy(key, path, len);
        key[len] = 0;
        item = cJSON_GetObjectItemCaseSensitive(item, key);
        path += len + (path[len] == '.');
    }
    return item;
}

/* The number at path (a bool: 0 or 1; an array: its length); NaN when the
 * report has no such value. */
static inline double detail(const ffd_rig_report *report, const char *path)
{
    cJSON *details = cJSON_Parse(report->details ? report->details : "");
    const cJSON *item = detail_item(details, path);
    double v = NAN;
    if (cJSON_IsNumber(item))
        v = item->valuedouble;
    else if (cJSON_IsBool(item))
        v = cJSON_IsTrue(item);
    else if (cJSON_IsArray(item))
        v = cJSON_GetArraySize(item);
    cJSON_Delete(details);
    return v;
}

/* Element i of the array at path; NaN past its end or when absent. */
static inline double detail_at(const ffd_rig_report *report, const char *path, size_t i)
{
    cJSON *details = cJSON_Parse(report->details ? report->details : "");
    const cJSON *item = cJSON_GetArrayItem(detail_item(details, path), (int)i);
    double v = cJSON_IsNumber(item) ? item->valuedouble : NAN;
    cJSON_Delete(details);
    return v;
}

/* 1 when the report's details have a value at path. */
static inline int detail_has(const ffd_rig_report *report, const char *path)
{
    cJSON *details = cJSON_Parse(report->details ? report->details : "");
    int has = detail_item(details, path) != NULL;
    cJSON_Delete(details);
    return has;
}

#endif
