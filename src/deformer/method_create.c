/* method_create — the editor's "create" body is the creation part of a rig
 * (issue 15, "one schema per method"): the keys a rig of the method uses to
 * say how its deformer is built, read by the same reader as a rig file
 * (ffd_rig_parse_tree, the method's ffd_method.parse) and built by the same
 * constructor as a loaded rig (ffd_method.load). What differs at create
 * time — the editor's defaults, the old body forms, what an editing session
 * refuses — is the method's create_body hook. docs/editor.md "Operations". */
#include "deformer/method.h"

#include <stdio.h>
#include <string.h>

#define CREATE_MAX_KEYS 32

ffd_status ffd_method_of_body(const ffd_rig_parser *p, const cJSON *body, const ffd_method **out)
{
    const cJSON *deformer = cJSON_GetObjectItemCaseSensitive(body, "deformer");
    const cJSON *old = cJSON_GetObjectItemCaseSensitive(body, "method");
    char names[256];
    ffd_method_names(names, sizeof names - 16);
    *out = NULL;
    if (deformer && old && cJSON_IsString(deformer) && cJSON_IsString(old) &&
        strcmp(deformer->valuestring, old->valuestring) != 0)
        return ffd_fail(p->err, FFD_ERR_PARSE,
                        "%s: method: \"%.64s\" and deformer: \"%.64s\" name different methods "
                        "(\"method\" is the old name of \"deformer\": give one)",
                        p->name, old->valuestring, deformer->valuestring);
    const char *key = deformer || !old ? "deformer" : "method";
    const cJSON *item = deformer ? deformer : old;
    if (!item)
        return ffd_rig_expected(p, key, strcat(names, " (missing)"));
    if (deformer && old && !cJSON_IsString(old))
        return ffd_rig_expected(p, "method", names);
    const ffd_method *method = cJSON_IsString(item) ? ffd_method_find(item->valuestring) : NULL;
    if (!method)
        return ffd_rig_expected(p, key, names);
    *out = method;
    return FFD_OK;
}

/* A key given twice (cJSON keeps both; the rig reader refuses it too, but
 * "method" is removed before it reads). */
static ffd_status check_repeats(const ffd_rig_parser *p, const cJSON *body)
{
    const cJSON *a;
    cJSON_ArrayForEach(a, body)
    {
        for (const cJSON *b = body->child; b != a; b = b->next)
            if (strcmp(a->string, b->string) == 0)
                return ffd_fail(p->err, FFD_ERR_PARSE, "%s: %.64s: key given twice", p->name,
                                a->string);
    }
    return FFD_OK;
}

/* Every key is "version", "deformer" or one of the method's creation keys;
 * the message lists them and says where the rest of a rig goes. */
static ffd_status check_creation_keys(const ffd_rig_parser *p, const ffd_method *method,
                                      const cJSON *body)
{
    const char *allowed[CREATE_MAX_KEYS + 3] = {"version", "deformer"};
    size_t n = 2;
    for (const char *const *k = method->create_keys; k && *k && n < CREATE_MAX_KEYS + 2; k++)
        allowed[n++] = *k;
    allowed[n] = NULL;
    char text[640];
    size_t used = 0;
    for (size_t i = 0; i < n && used < sizeof text; i++) {
        int w = snprintf(text + used, sizeof text - used, "%s\"%s\"", i ? ", " : "", allowed[i]);
        used += w > 0 ? (size_t)w : 0;
    }
    if (used < sizeof text)
        snprintf(text + used, sizeof text - used,
                 " (a create body builds the deformer at rest; a rig's moves, constraints, "
                 "edits and steps are loaded with rig/load)");
    return ffd_rig_check_keys(p, body, "", allowed, text);
}

ffd_status ffd_method_create(const ffd_method *method, const sess_ctx *ctx, const cJSON *body,
                             sess_method **out, ffd_error *err)
{
    ffd_rig_parser p = {"create", err, NULL};
    *out = NULL;
    if (!cJSON_IsObject(body))
        return ffd_rig_expected(&p, "body", "a JSON object");
    ffd_status s = check_repeats(&p, body);
    if (s)
        return s;
    if (cJSON_GetObjectItemCaseSensitive(body, "deformer") ||
        cJSON_GetObjectItemCaseSensitive(body, "method")) {
        const ffd_method *named = NULL;
        if ((s = ffd_method_of_body(&p, body, &named)))
            return s;
        if (named != method)
            return ffd_fail(err, FFD_ERR_INVALID, "create: deformer: \"%s\": this creates a \"%s\"",
                            named->name, method->name);
    }
    /* the session's copy: "deformer" (not its old name "method") names the method */
    unsigned long oom = ffd_json_alloc_failures();
    const ffd_rig_files no_files = {NULL}; /* a create body reads no file */
    cJSON *copy = cJSON_Duplicate(body, 1);
    ffd_rig *rig = NULL;
    int has_name = 0;
    if (copy) {
        cJSON_DeleteItemFromObjectCaseSensitive(copy, "method");
        cJSON_DeleteItemFromObjectCaseSensitive(copy, "deformer");
        has_name = cJSON_AddStringToObject(copy, "deformer", method->name) != NULL;
    }
    if (!has_name || ffd_json_alloc_failures() != oom) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "create: out of memory");
        goto done;
    }
    if (method->create_body && (s = method->create_body(ctx, copy, &p)))
        goto done;
    if (ffd_json_alloc_failures() != oom) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "create: out of memory");
        goto done;
    }
    if ((s = check_creation_keys(&p, method, copy)) ||
        (s = ffd_rig_parse_tree(copy, "create", &no_files, &rig, err)))
        goto done;
    s = ffd_method_load(method, ctx, rig, out, err);
done:
    ffd_rig_destroy(rig);
    cJSON_Delete(copy);
    return s;
}
