/* session_moves.c — a drag step given per control: {"moves": [[id, dx, dy,
 * dz], ...]}, each the total change of one dragged control since
 * drag_begin. The editor's transforms that are not one rigid motion of the
 * whole selection send it: mirror editing (the counterpart moves mirrored),
 * proportional editing (neighbours move by a falloff of their distance) and
 * individual origins (each control about its own centre). */
#include "session/session.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct id_slot {
    uint32_t id;
    size_t slot; /* index in the drag's ids */
} id_slot;

static int by_id(const void *a, const void *b)
{
    uint32_t x = ((const id_slot *)a)->id, y = ((const id_slot *)b)->id;
    return (x > y) - (x < y);
}

static const char moves_what[] = "an array of [control id, dx, dy, dz]";

ffd_status ffd_sess_moves_targets(const ffd_rig_parser *p, const cJSON *body, const uint32_t *ids,
                                  size_t k, size_t count, const double *start, double *targets)
{
    static const char *const keys[] = {"moves", NULL};
    ffd_status st = ffd_rig_check_keys(p, body, "body", keys, "moves");
    if (st)
        return st;
    const cJSON *moves = cJSON_GetObjectItemCaseSensitive(body, "moves");
    if (!cJSON_IsArray(moves))
        return ffd_rig_expected(p, "moves", moves_what);
    /* a control not named stays where it was at drag_begin */
    memcpy(targets, start, k * 3 * sizeof *targets);
    id_slot *order = ffd_malloc_array(k, sizeof *order);
    unsigned char *seen = ffd_calloc(k, 1);
    if (!order || !seen) {
        ffd_free(order);
        ffd_free(seen);
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: moves: out of memory", p->name);
    }
    for (size_t i = 0; i < k; i++)
        order[i] = (id_slot){ids[i], i};
    qsort(order, k, sizeof *order, by_id);
    int i = 0;
    const cJSON *move;
    cJSON_ArrayForEach(move, moves)
    {
        char path[48];
        snprintf(path, sizeof path, "moves[%d]", i++);
        if (!cJSON_IsArray(move) || cJSON_GetArraySize(move) != 4) {
            st = ffd_rig_expected(p, path, "[control id, dx, dy, dz]");
            break;
        }
        const cJSON *id = move->child;
        if (!ffd_rig_is_uint32(id)) {
            st = ffd_rig_expected(p, path, "[control id, dx, dy, dz] with a control id first");
            break;
        }
        if ((size_t)id->valuedouble >= count) {
            st = ffd_fail(p->err, FFD_ERR_RANGE, "%s: %s: control %.0f out of range (%zu controls)",
                          p->name, path, id->valuedouble, count);
            break;
        }
        id_slot key = {(uint32_t)id->valuedouble, 0};
        const id_slot *hit = bsearch(&key, order, k, sizeof *order, by_id);
        if (!hit) {
            st = ffd_fail(p->err, FFD_ERR_INVALID,
                          "%s: %s: control %u is not dragged (name it in drag_begin's points)",
                          p->name, path, key.id);
            break;
        }
        if (seen[hit->slot]) {
            st = ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: control %u given twice", p->name, path,
                          key.id);
            break;
        }
        seen[hit->slot] = 1;
        double d[3];
        const cJSON *v = id->next;
        for (int a = 0; a < 3 && !st; a++, v = v->next) {
            char leaf[64];
            snprintf(leaf, sizeof leaf, "%s[%d]", path, a + 1);
            st = ffd_rig_read_number(p, v, leaf, &d[a]);
        }
        if (st)
            break;
        for (int a = 0; a < 3; a++)
            targets[3 * hit->slot + a] = start[3 * hit->slot + a] + d[a];
    }
    ffd_free(order);
    ffd_free(seen);
    return st;
}
