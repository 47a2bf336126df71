/* rig_pins — the rig's "pins" (docs/rig.md): the direct-manipulation pins
 * of the editing session the rig was saved from, each a mesh vertex and
 * the target it is held at. They are a record, not a deformation: the
 * rig's moves (or its method's state) already hold the result, so applying
 * a rig only checks that each pinned vertex exists in the mesh. */
#include "rig/rig.h"
#include "rig/rig_json.h"
#include "session/session.h"

#include <stdio.h>
#include <string.h>

ffd_status ffd_rig_read_pins(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig)
{
    static const char *const keys[] = {"vertex", "target", NULL};
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, "pins", "an array of {\"vertex\": id, \"target\": [x, y, z]}");
    size_t n = (size_t)cJSON_GetArraySize(item);
    ffd_rig_pin *pins = n ? ffd_malloc_array(n, sizeof *pins) : NULL;
    if (n && !pins)
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: pins: out of memory", p->name);
    ffd_status s = FFD_OK;
    size_t i = 0;
    const cJSON *pin;
    char path[64];
    cJSON_ArrayForEach(pin, item)
    {
        snprintf(path, sizeof path, "pins[%zu]", i);
        if (!cJSON_IsObject(pin)) {
            s = ffd_rig_expected(p, path, "an object {\"vertex\": id, \"target\": [x, y, z]}");
            break;
        }
        if ((s = ffd_rig_check_keys(p, pin, path, keys, "\"vertex\", \"target\"")))
            break;
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(pin, "vertex");
        const cJSON *t = cJSON_GetObjectItemCaseSensitive(pin, "target");
        snprintf(path, sizeof path, "pins[%zu].vertex", i);
        if (!v) {
            s = ffd_rig_expected(p, path, "a vertex id (missing)");
            break;
        }
        if ((s = ffd_rig_read_index(p, v, path, "a vertex id", &pins[i].vertex)))
            break;
        snprintf(path, sizeof path, "pins[%zu].target", i);
        if (!t) {
            s = ffd_rig_expected(p, path, "an array of 3 finite numbers (missing)");
            break;
        }
        if ((s = ffd_rig_read_vec3(p, t, path, pins[i].target)))
            break;
        for (size_t j = 0; j < i; j++)
            if (pins[j].vertex == pins[i].vertex) {
                s = ffd_fail(p->err, FFD_ERR_PARSE,
                             "%s: pins[%zu].vertex: vertex %u is pinned twice (pins[%zu] too)",
                             p->name, i, pins[i].vertex, j);
                break;
            }
        if (s)
            break;
        i++;
    }
    if (s) {
        ffd_free(pins);
        return s;
    }
    ffd_free(rig->pins);
    rig->pins = pins;
    rig->pin_count = n;
    return FFD_OK;
}

cJSON *ffd_rig_pins_json(const ffd_rig_pin *pins, size_t count)
{
    cJSON *arr = cJSON_CreateArray();
    for (size_t i = 0; arr && i < count; i++) {
        cJSON *o = cJSON_CreateObject();
        if (!ffd_sess_add_to_array(arr, o) ||
            !cJSON_AddNumberToObject(o, "vertex", pins[i].vertex) ||
            !ffd_sess_add_item(o, "target", ffd_sess_vec3(pins[i].target))) {
            cJSON_Delete(arr);
            return NULL;
        }
    }
    return arr;
}

ffd_status ffd_rig_check_pins(const ffd_rig *rig, size_t n, ffd_error *err)
{
    for (size_t i = 0; i < rig->pin_count; i++)
        if (rig->pins[i].vertex >= n)
            return ffd_fail(err, FFD_ERR_RANGE,
                            "%s: pins[%zu].vertex: %u out of range: the mesh has %zu vertices "
                            "(ids 0 to %zu)",
                            rig->name ? rig->name : "rig", i, rig->pins[i].vertex, n,
                            n ? n - 1 : 0);
    return FFD_OK;
}
