/* serve_http — the HTTP server of `ffd serve` on libmicrohttpd: routes the
 * editor's API (docs/editor.md) to one editing session under one lock,
 * serves the page's files, and opens and saves files under one root
 * directory. It parses requests, calls the session and the library, and
 * passes their replies through: no deformation logic lives here. */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* realpath */
#endif
#include "serve_http.h"
#include "serve_autosave.h"

#include "cli.h"
#include "core/core.h"

/* microhttpd.h needs these first */
#include <stdint.h>
#include <sys/socket.h>
#include <sys/types.h>

#include <microhttpd.h>

#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#define JSON_LIMIT ((size_t)1 << 20)       /* JSON request bodies */
#define RIG_FILE_LIMIT ((size_t)16 << 20)  /* rigs read from the root */
#define PATH_LEN 4096
#define CLIENT_PATH_LEN 1024
#define LIST_LIMIT 500    /* meshes and rigs listed, each */
#define LIST_VISITS 20000 /* directory entries looked at by one listing */
#define MSG_LEN 1400
#define CONNECTION_LIMIT 256 /* connections at a time, all clients together */

struct serve_server {
    struct MHD_Daemon *daemon;
    /* every API request but GET /api/state runs under it: the session is not thread-safe */
    pthread_mutex_t lock;
    ffd_session *session;
    /* The state as of the last change, for GET /api/state without the lock:
     * published (under the lock) by every request that changes the session;
     * NULL after a drag step (republished before the next request that may
     * take long). Taken after lock, never before it. */
    pthread_mutex_t published_lock;
    char *published; /* ffd_malloc'd JSON, or NULL */
    size_t published_size;
    /* The running request's progress (GET /api/progress), under published_lock:
     * its op, the library's stage (static string, NULL before the first) and
     * fraction (ffd_set_progress), and when each began. */
    char progress_op[40];
    const char *progress_stage;
    double progress_fraction, progress_started, progress_stage_started;
    char *mesh_path;      /* resolved file the session was opened from (never overwritten); NULL after an upload */
    char root[PATH_LEN];  /* resolved, no trailing slash unless "/" */
    char web[PATH_LEN];   /* resolved, "" when the page is missing */
    char host[INET_ADDRSTRLEN];
    size_t max_upload;
    serve_autosave *autosave; /* NULL: off (serve_autosave.h) */
    unsigned port;
    int verbose;
};

typedef enum route {
    ROUTE_NONE = 0,
    ROUTE_STATIC,
    ROUTE_STATE,
    ROUTE_PROGRESS,
    ROUTE_FRAME,
    ROUTE_TOPOLOGY,
    ROUTE_RIG,
    ROUTE_EXPORT,
    ROUTE_FILES,
    ROUTE_OPEN,
    ROUTE_UPLOAD,
    ROUTE_RIG_LOAD,
    ROUTE_RIG_UPLOAD,
    ROUTE_RIG_SAVE,
    ROUTE_EXPORT_SAVE,
    ROUTE_WEIGHTS_LOAD,
    ROUTE_HISTORY,
    ROUTE_AUTOSAVE_RESUME,
    ROUTE_OP
} route;

/* One request's state between MHD's calls (its con_cls). */
typedef struct request {
    route route;
    char op[33];
    const char *method, *url; /* MHD's, valid until the request completes */
    char *body;               /* NUL-terminated */
    size_t size, cap, limit;
    int answered;  /* a response is queued: the rest of the body is dropped */
    int too_large; /* the body passed limit: dropped, answered 413 at its end */
    int no_memory;
    int close;     /* the reply closes the connection (the request's framing is in doubt) */
    double start;
} request;

/* The API's fixed URLs; every other /api/NAME with NAME in [a-z_]{1,32} is a session op. */
static const struct api_route {
    const char *path;
    route get, post;
    const char *allow;
} api_routes[] = {
    {"/api/state", ROUTE_STATE, ROUTE_NONE, "GET, HEAD"},
    {"/api/progress", ROUTE_PROGRESS, ROUTE_NONE, "GET, HEAD"},
    {"/api/frame", ROUTE_FRAME, ROUTE_OP, "GET, HEAD, POST"}, /* POST: a method's "frame" op */
    {"/api/topology", ROUTE_TOPOLOGY, ROUTE_NONE, "GET, HEAD"},
    {"/api/rig", ROUTE_RIG, ROUTE_NONE, "GET, HEAD"},
    {"/api/export", ROUTE_EXPORT, ROUTE_NONE, "GET, HEAD"},
    {"/api/files", ROUTE_FILES, ROUTE_NONE, "GET, HEAD"},
    {"/api/open", ROUTE_NONE, ROUTE_OPEN, "POST"},
    {"/api/upload", ROUTE_NONE, ROUTE_UPLOAD, "POST"},
    {"/api/rig/load", ROUTE_NONE, ROUTE_RIG_LOAD, "POST"},
    {"/api/rig/upload", ROUTE_NONE, ROUTE_RIG_UPLOAD, "POST"},
    {"/api/rig/save", ROUTE_NONE, ROUTE_RIG_SAVE, "POST"},
    {"/api/export/save", ROUTE_NONE, ROUTE_EXPORT_SAVE, "POST"},
    {"/api/weights/load", ROUTE_NONE, ROUTE_WEIGHTS_LOAD, "POST"},
    {"/api/history", ROUTE_HISTORY, ROUTE_NONE, "GET, HEAD"},
    {"/api/history/goto", ROUTE_NONE, ROUTE_OP, "POST"}, /* the "history_goto" op */
    {"/api/autosave/resume", ROUTE_NONE, ROUTE_AUTOSAVE_RESUME, "POST"},
};

/* ======================================================================
 * Replies
 * ====================================================================== */

static void free_cjson(void *p)
{
    cJSON_free(p);
}

static void free_ffd(void *p)
{
    ffd_free(p);
}

/* Adds the common headers, queues resp with code, logs the request. Takes resp. */
static enum MHD_Result answer(const serve_server *srv, struct MHD_Connection *c, request *r,
                              unsigned code, struct MHD_Response *resp, const char *type,
                              size_t size)
{
    if (!resp)
        return MHD_NO; /* out of memory: MHD closes the connection */
    if (type)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, type);
    MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    MHD_add_response_header(resp, "X-Content-Type-Options", "nosniff");
    if (r->close)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONNECTION, "close");
    enum MHD_Result ret = MHD_queue_response(c, code, resp);
    MHD_destroy_response(resp);
    r->answered = 1;
    if (srv->verbose)
        fprintf(stderr, "ffd serve: %s %s %u (%zu bytes, %.1f ms)\n", r->method, r->url, code, size,
                1e3 * (cli_now() - r->start));
    return ret;
}

/* Bytes the library allocated (ffd_free'd by MHD once sent). */
static enum MHD_Result answer_data(const serve_server *srv, struct MHD_Connection *c, request *r,
                                   void *data, size_t size, const char *type,
                                   const char *disposition)
{
    struct MHD_Response *resp = MHD_create_response_from_buffer_with_free_callback(
        size, data, free_ffd);
    if (!resp) {
        ffd_free(data);
        return MHD_NO;
    }
    if (disposition)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_DISPOSITION, disposition);
    return answer(srv, c, r, MHD_HTTP_OK, resp, type, size);
}

/* A cJSON document as the reply (deleted here). */
static enum MHD_Result answer_json(const serve_server *srv, struct MHD_Connection *c, request *r,
                                   unsigned code, cJSON *doc, const char *allow)
{
    char *text = doc ? cJSON_PrintUnformatted(doc) : NULL;
    cJSON_Delete(doc);
    struct MHD_Response *resp;
    size_t size;
    if (text) {
        size = strlen(text);
        resp = MHD_create_response_from_buffer_with_free_callback(size, text, free_cjson);
        if (!resp)
            cJSON_free(text);
    } else {
        static const char nomem[] = "{\"error\":\"out of memory\",\"status\":\"nomem\"}";
        code = MHD_HTTP_INTERNAL_SERVER_ERROR;
        allow = NULL;
        size = sizeof nomem - 1;
        resp = MHD_create_response_from_buffer(size, (void *)nomem, MHD_RESPMEM_PERSISTENT);
    }
    if (resp && allow)
        MHD_add_response_header(resp, MHD_HTTP_HEADER_ALLOW, allow);
    return answer(srv, c, r, code, resp, "application/json", size);
}

static enum MHD_Result answer_error_v(const serve_server *srv, struct MHD_Connection *c,
                                      request *r, unsigned code, const char *word,
                                      const char *allow, const char *fmt, va_list ap)
{
    char msg[MSG_LEN];
    vsnprintf(msg, sizeof msg, fmt, ap);
    cJSON *doc = cJSON_CreateObject();
    if (doc && (!cJSON_AddStringToObject(doc, "error", msg) ||
                !cJSON_AddStringToObject(doc, "status", word))) {
        cJSON_Delete(doc);
        doc = NULL;
    }
    return answer_json(srv, c, r, code, doc, allow);
}

/* {"error": message, "status": word} with HTTP code. */
static enum MHD_Result answer_error(const serve_server *srv, struct MHD_Connection *c, request *r,
                                    unsigned code, const char *word, const char *fmt, ...)
    CLI_PRINTF(6, 7);
static enum MHD_Result answer_error(const serve_server *srv, struct MHD_Connection *c, request *r,
                                    unsigned code, const char *word, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    enum MHD_Result ret = answer_error_v(srv, c, r, code, word, NULL, fmt, ap);
    va_end(ap);
    return ret;
}

static enum MHD_Result answer_405(const serve_server *srv, struct MHD_Connection *c, request *r,
                                  const char *allow)
{
    cJSON *doc = cJSON_CreateObject();
    char msg[MSG_LEN];
    snprintf(msg, sizeof msg, "%s %s: method not allowed (allowed: %s)", r->method, r->url, allow);
    if (doc && (!cJSON_AddStringToObject(doc, "error", msg) ||
                !cJSON_AddStringToObject(doc, "status", "method_not_allowed"))) {
        cJSON_Delete(doc);
        doc = NULL;
    }
    return answer_json(srv, c, r, MHD_HTTP_METHOD_NOT_ALLOWED, doc, allow);
}

/* A library failure: the HTTP code and word for its status. The session marks
 * requests its state refuses with a "conflict: " prefix (409, prefix dropped). */
static enum MHD_Result answer_status(const serve_server *srv, struct MHD_Connection *c,
                                     request *r, ffd_status status, const char *message)
{
    static const char conflict[] = "conflict: ";
    if (strncmp(message, conflict, sizeof conflict - 1) == 0)
        return answer_error(srv, c, r, MHD_HTTP_CONFLICT, "conflict", "%s",
                            message + sizeof conflict - 1);
    unsigned code = MHD_HTTP_INTERNAL_SERVER_ERROR;
    const char *word = "error";
    switch (status) {
    case FFD_OK: break;
    case FFD_ERR_PARSE: code = MHD_HTTP_BAD_REQUEST, word = "parse"; break;
    case FFD_ERR_INVALID: code = MHD_HTTP_BAD_REQUEST, word = "invalid"; break;
    case FFD_ERR_RANGE: code = MHD_HTTP_BAD_REQUEST, word = "range"; break;
    case FFD_ERR_NONFINITE: code = MHD_HTTP_BAD_REQUEST, word = "nonfinite"; break;
    case FFD_ERR_UNSUPPORTED:
        /* an op: no such op; a file a request names (a rig's STL skeleton): its format */
        if (r->route == ROUTE_OP)
            code = MHD_HTTP_NOT_FOUND, word = "unsupported";
        else
            code = MHD_HTTP_UNSUPPORTED_MEDIA_TYPE, word = "unsupported_format";
        break;
    case FFD_ERR_IO:
        /* A file the client named (a rig's skeleton file, or a path that
         * raced a change) is missing, not a regular file (a FIFO, device or
         * directory: ffd_read_file refuses it without opening it) or not
         * readable: the client's error. A failed read or write of a regular
         * file is the server's (500). The words are core/file.c's. */
        if (strstr(message, strerror(ENOENT)))
            code = MHD_HTTP_NOT_FOUND, word = "not_found";
        else if (strstr(message, ": not a regular file") || strstr(message, ": is a directory"))
            code = MHD_HTTP_BAD_REQUEST, word = "invalid";
        else if (strstr(message, strerror(EACCES)))
            code = MHD_HTTP_FORBIDDEN, word = "forbidden";
        else
            word = "io";
        break;
    case FFD_ERR_NOMEM: word = "nomem"; break;
    case FFD_ERR_NUMERIC: word = "numeric"; break;
    }
    return answer_error(srv, c, r, code, word, "%s", message);
}

/* ======================================================================
 * Paths: everything a client names lies under the root (or the page's directory)
 * ====================================================================== */

static int under(const char *dir, const char *path)
{
    if (strcmp(dir, "/") == 0)
        return path[0] == '/';
    size_t n = strlen(dir);
    return strncmp(path, dir, n) == 0 && (path[n] == 0 || path[n] == '/');
}

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    return n >= k && strcasecmp(s + n - k, suffix) == 0;
}

/* A relative path's shape: no absolute path, backslash, control character,
 * "..", hidden or empty component. Returns 0 or the HTTP code (msg says why). */
static unsigned check_relative(const char *rel, char *msg, size_t size)
{
    if (!*rel) {
        snprintf(msg, size, "empty path");
        return MHD_HTTP_BAD_REQUEST;
    }
    if (strlen(rel) >= CLIENT_PATH_LEN) {
        snprintf(msg, size, "path longer than %d bytes", CLIENT_PATH_LEN - 1);
        return MHD_HTTP_BAD_REQUEST;
    }
    if (rel[0] == '/') {
        snprintf(msg, size, "%s: absolute paths are refused (paths are relative to the root)", rel);
        return MHD_HTTP_FORBIDDEN;
    }
    for (const unsigned char *p = (const unsigned char *)rel; *p; p++) {
        if (*p == '\\' || *p < 0x20 || *p == 0x7f) {
            snprintf(msg, size, "%s: backslashes and control characters are refused", rel);
            return MHD_HTTP_FORBIDDEN;
        }
    }
    for (const char *p = rel;;) {
        const char *end = strchr(p, '/');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len == 0) {
            snprintf(msg, size, "%s: empty path component", rel);
            return MHD_HTTP_BAD_REQUEST;
        }
        if (p[0] == '.') {
            snprintf(msg, size, "%s: '..' and components starting with '.' are refused", rel);
            return MHD_HTTP_FORBIDDEN;
        }
        if (!end)
            return 0;
        p = end + 1;
    }
}

/* Resolves a client's path under the root into out: its directory must exist
 * and lie under the root after symbolic links, and so must the file when it
 * is a link; an existing file must be a regular file. for_write: the file may
 * be missing. Returns 0
 * or the HTTP code (403 outside, 404 missing, 400 bad shape); *word and msg say why. */
static unsigned resolve(const serve_server *srv, const char *rel, int for_write,
                        char out[PATH_LEN], const char **word, char *msg, size_t size)
{
    *word = "forbidden";
    unsigned code = check_relative(rel, msg, size);
    if (code) {
        if (code != MHD_HTTP_FORBIDDEN)
            *word = "invalid";
        return code;
    }
    char dir[PATH_LEN];
    const char *slash = strrchr(rel, '/');
    const char *base = slash ? slash + 1 : rel;
    int n = snprintf(dir, sizeof dir, "%s/%.*s", srv->root, slash ? (int)(slash - rel) : 0, rel);
    if (n < 0 || (size_t)n >= sizeof dir) {
        *word = "invalid";
        snprintf(msg, size, "%s: path too long", rel);
        return MHD_HTTP_BAD_REQUEST;
    }
    char *real = realpath(dir, NULL);
    if (!real) {
        int e = errno;
        if (e == ENOENT || e == ENOTDIR) {
            *word = "not_found";
            snprintf(msg, size, "%s: no such directory", rel);
            return MHD_HTTP_NOT_FOUND;
        }
        if (e == EACCES) {
            snprintf(msg, size, "%s: %s", rel, strerror(e));
            return MHD_HTTP_FORBIDDEN;
        }
        *word = "io";
        snprintf(msg, size, "%s: %s", rel, strerror(e));
        return MHD_HTTP_INTERNAL_SERVER_ERROR;
    }
    int inside = under(srv->root, real);
    n = snprintf(out, PATH_LEN, "%s/%s", strcmp(real, "/") == 0 ? "" : real, base);
    free(real);
    if (!inside) {
        snprintf(msg, size, "%s: outside the root directory (through a symbolic link)", rel);
        return MHD_HTTP_FORBIDDEN;
    }
    if (n < 0 || n >= PATH_LEN) {
        *word = "invalid";
        snprintf(msg, size, "%s: path too long", rel);
        return MHD_HTTP_BAD_REQUEST;
    }
    struct stat st;
    if (lstat(out, &st) != 0) {
        if (errno == ENOENT && for_write)
            return 0;
        *word = errno == ENOENT ? "not_found" : "io";
        snprintf(msg, size, "%s: %s", rel, strerror(errno));
        return errno == ENOENT ? MHD_HTTP_NOT_FOUND : MHD_HTTP_INTERNAL_SERVER_ERROR;
    }
    if (S_ISLNK(st.st_mode)) {
        real = realpath(out, NULL);
        if (!real || !under(srv->root, real) || strlen(real) >= PATH_LEN) {
            snprintf(msg, size, "%s: a symbolic link %s", rel,
                     real ? "leaving the root directory" : "to nothing");
            free(real);
            return MHD_HTTP_FORBIDDEN;
        }
        strcpy(out, real);
        free(real);
        if (stat(out, &st) != 0) {
            *word = "io";
            snprintf(msg, size, "%s: %s", rel, strerror(errno));
            return MHD_HTTP_INTERNAL_SERVER_ERROR;
        }
    }
    /* a FIFO, device or socket is neither read (opening a FIFO waits for a
     * writer) nor replaced by a save */
    if (!S_ISREG(st.st_mode)) {
        *word = "invalid";
        snprintf(msg, size, "%s: not a regular file", rel);
        return MHD_HTTP_BAD_REQUEST;
    }
    return 0;
}

/* The file name part of a client's name, for labels and downloads. */
static const char *base_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

/* "<stem><suffix>" for Content-Disposition: the session's mesh name without
 * its extension, reduced to [A-Za-z0-9._-]. */
static void attachment_named(const char *label, const char *suffix, char *out, size_t size)
{
    char stem[96];
    const char *name = label ? base_name(label) : "mesh";
    size_t n = 0;
    for (const char *p = name; *p && n + 1 < sizeof stem; p++) {
        char ch = *p;
        int ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') ||
                 ch == '.' || ch == '_' || ch == '-';
        stem[n++] = ok ? ch : '_';
    }
    stem[n] = 0;
    char *dot = strrchr(stem, '.');
    if (dot && dot != stem)
        *dot = 0;
    if (!stem[0] || stem[0] == '.')
        snprintf(stem, sizeof stem, "mesh");
    snprintf(out, size, "attachment; filename=\"%s%s\"", stem, suffix);
}

static void attachment(const ffd_session *s, const char *suffix, char *out, size_t size)
{
    attachment_named(ffd_session_name(s), suffix, out, size);
}

/* ======================================================================
 * Request bodies of the server's own routes
 * ====================================================================== */

/* Parses the body as a JSON object whose keys are among keys (n of them), all
 * strings: values[i] borrows from *doc. Returns 0 or 400 (msg says why).
 * Runs under the lock: cJSON records parse errors in a global. */
static unsigned parse_body(const request *r, const char *const *keys, size_t n,
                           const char **values, cJSON **doc, char *msg, size_t size)
{
    *doc = NULL;
    for (size_t i = 0; i < n; i++)
        values[i] = NULL;
    if (r->size == 0) {
        snprintf(msg, size, "empty body: expected a JSON object");
        return MHD_HTTP_BAD_REQUEST;
    }
    /* cJSON would cut a key or string at a NUL ("a.obj\u0000/../x" read as "a.obj") */
    ffd_error nul = {{0}};
    if (ffd_json_refuse_nul(r->body, r->size, "body", &nul) != FFD_OK) {
        snprintf(msg, size, "%s", nul.message);
        return MHD_HTTP_BAD_REQUEST;
    }
    /* body[size] is its NUL: cJSON wants the terminator inside the length */
    const char *end = NULL;
    cJSON *j = cJSON_ParseWithLengthOpts(r->body, r->size + 1, &end, 1);
    if (!j) {
        size_t at = end && end >= r->body ? (size_t)(end - r->body) : 0;
        snprintf(msg, size, "malformed JSON at byte %zu", at);
        return MHD_HTTP_BAD_REQUEST;
    }
    if (!cJSON_IsObject(j)) {
        cJSON_Delete(j);
        snprintf(msg, size, "expected a JSON object");
        return MHD_HTTP_BAD_REQUEST;
    }
    for (const cJSON *item = j->child; item; item = item->next) {
        size_t k = 0;
        while (k < n && strcmp(item->string, keys[k]) != 0)
            k++;
        if (k == n) {
            snprintf(msg, size, "unknown key \"%.64s\"", item->string);
            cJSON_Delete(j);
            return MHD_HTTP_BAD_REQUEST;
        }
        if (values[k]) {
            snprintf(msg, size, "\"%s\" given twice", keys[k]);
            cJSON_Delete(j);
            return MHD_HTTP_BAD_REQUEST;
        }
        if (!cJSON_IsString(item)) {
            snprintf(msg, size, "\"%s\": expected a string", keys[k]);
            cJSON_Delete(j);
            return MHD_HTTP_BAD_REQUEST;
        }
        values[k] = item->valuestring;
    }
    if (!values[0]) {
        snprintf(msg, size, "missing \"%s\"", keys[0]);
        cJSON_Delete(j);
        return MHD_HTTP_BAD_REQUEST;
    }
    *doc = j;
    return 0;
}

/* "ascii" | "binary" | "binary-be" (NULL: as the source). -1 when unknown. */
static int parse_encoding(const char *s, ffd_encoding *out)
{
    if (!s || !*s)
        *out = FFD_ENCODING_SAME;
    else if (strcmp(s, "ascii") == 0)
        *out = FFD_ENCODING_ASCII;
    else if (strcmp(s, "binary") == 0)
        *out = FFD_ENCODING_BINARY_LE;
    else if (strcmp(s, "binary-be") == 0)
        *out = FFD_ENCODING_BINARY_BE;
    else
        return -1;
    return 0;
}

/* ======================================================================
 * The API (all under srv->lock)
 * ====================================================================== */

/* ---- the published state (see struct serve_server) ---- */

/* Puts json (taken over; NULL: none, made again under the lock when asked for). */
static void publish(serve_server *srv, char *json, size_t size)
{
    pthread_mutex_lock(&srv->published_lock);
    ffd_free(srv->published);
    srv->published = json;
    srv->published_size = json ? size : 0;
    pthread_mutex_unlock(&srv->published_lock);
}

/* Publishes a copy of a state reply (under the lock). */
static void publish_copy(serve_server *srv, const void *json, size_t size)
{
    char *copy = ffd_malloc(size + 1);
    if (copy) {
        memcpy(copy, json, size);
        copy[size] = 0;
    }
    publish(srv, copy, size);
}

/* Under the lock: publishes the session's state unless it is published. */
static void ensure_published(serve_server *srv)
{
    pthread_mutex_lock(&srv->published_lock);
    int missing = srv->published == NULL;
    pthread_mutex_unlock(&srv->published_lock);
    char *json = NULL;
    size_t size = 0;
    if (missing && ffd_session_state(srv->session, &json, &size, NULL) == FFD_OK)
        publish(srv, json, size);
}

/* The session's state as the reply, published (under the lock). */
static enum MHD_Result reply_state(serve_server *srv, struct MHD_Connection *c, request *r)
{
    ffd_error err = {{0}};
    char *json = NULL;
    size_t size = 0;
    ffd_status st = ffd_session_state(srv->session, &json, &size, &err);
    if (st != FFD_OK)
        return answer_status(srv, c, r, st, err.message);
    publish_copy(srv, json, size);
    return answer_data(srv, c, r, json, size, "application/json", NULL);
}

/* GET /api/state: the published state, without waiting for the lock; only
 * when none is published (after a drag step, or out of memory) does it take
 * the lock and make one. */
static enum MHD_Result get_state(serve_server *srv, struct MHD_Connection *c, request *r)
{
    pthread_mutex_lock(&srv->published_lock);
    char *copy = srv->published ? ffd_malloc(srv->published_size + 1) : NULL;
    size_t size = srv->published_size;
    if (copy)
        memcpy(copy, srv->published, size + 1);
    pthread_mutex_unlock(&srv->published_lock);
    if (copy)
        return answer_data(srv, c, r, copy, size, "application/json", NULL);
    pthread_mutex_lock(&srv->lock);
    enum MHD_Result ret = reply_state(srv, c, r);
    pthread_mutex_unlock(&srv->lock);
    return ret;
}


/* ---------- progress of the running request (GET /api/progress) ---------- */

/* ffd_set_progress's hook while serving: called on the request's thread
 * (which holds srv->lock) for each stage of a long operation. */
static void progress_hook(void *user, const char *stage, double fraction)
{
    serve_server *srv = user;
    pthread_mutex_lock(&srv->published_lock);
    if (stage != srv->progress_stage || fraction == 0)
        srv->progress_stage_started = cli_now();
    srv->progress_stage = stage;
    srv->progress_fraction = fraction;
    pthread_mutex_unlock(&srv->published_lock);
}

/* Marks the start (r) or the end (NULL) of a request under srv->lock. */
static void progress_request(serve_server *srv, const request *r)
{
    pthread_mutex_lock(&srv->published_lock);
    if (r)
        snprintf(srv->progress_op, sizeof srv->progress_op, "%s",
                 r->route == ROUTE_OP ? r->op : r->url + (strncmp(r->url, "/api/", 5) ? 0 : 5));
    else
        srv->progress_op[0] = 0;
    srv->progress_stage = NULL;
    srv->progress_fraction = 0;
    srv->progress_started = srv->progress_stage_started = cli_now();
    pthread_mutex_unlock(&srv->published_lock);
}

/* {"op": running request or null, "seconds": its time so far, "stage": the
 * library's stage or null, "fraction": of that stage, "stage_seconds"}:
 * answered without the session's lock, like GET /api/state. */
static enum MHD_Result get_progress(serve_server *srv, struct MHD_Connection *c, request *r)
{
    char json[256];
    double now = cli_now();
    pthread_mutex_lock(&srv->published_lock);
    if (!srv->progress_op[0])
        snprintf(json, sizeof json, "{\"op\": null, \"stage\": null}");
    else if (!srv->progress_stage)
        snprintf(json, sizeof json, "{\"op\": \"%s\", \"seconds\": %.3f, \"stage\": null}",
                 srv->progress_op, now - srv->progress_started);
    else
        snprintf(json, sizeof json,
                 "{\"op\": \"%s\", \"seconds\": %.3f, \"stage\": \"%s\", \"fraction\": %.4f, "
                 "\"stage_seconds\": %.3f}",
                 srv->progress_op, now - srv->progress_started, srv->progress_stage,
                 srv->progress_fraction, now - srv->progress_stage_started);
    pthread_mutex_unlock(&srv->published_lock);
    size_t n = strlen(json);
    char *copy = ffd_malloc(n + 1);
    if (!copy)
        return answer_error(srv, c, r, MHD_HTTP_INTERNAL_SERVER_ERROR, "nomem", "out of memory");
    memcpy(copy, json, n + 1);
    return answer_data(srv, c, r, copy, n, "application/json", NULL);
}

static enum MHD_Result get_rig(const serve_server *srv, struct MHD_Connection *c, request *r)
{
    ffd_error err = {{0}};
    char *json = NULL;
    size_t size = 0;
    ffd_status st = ffd_session_rig(srv->session, &json, &size, &err);
    if (st != FFD_OK)
        return answer_status(srv, c, r, st, err.message);
    char disposition[160];
    attachment(srv->session, "-rig.json", disposition, sizeof disposition);
    return answer_data(srv, c, r, json, size, "application/json", disposition);
}

static const char *const format_names[] = {"", "obj", "ply", "off", "stl", "gltf"};

/* The name of mesh text (a decimal index) of the session, its index in
 * *index; NULL when text is not the index of one of its meshes. */
static const char *mesh_of(const ffd_session *s, const char *text, size_t *index)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 10);
    if (errno || end == text || *end || *text < '0' || *text > '9' ||
        v >= ffd_session_mesh_count(s))
        return NULL;
    *index = (size_t)v;
    return ffd_session_mesh_name(s, *index);
}

static enum MHD_Result get_export(const serve_server *srv, struct MHD_Connection *c, request *r)
{
    const char *format = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "format");
    const char *encoding = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "encoding");
    ffd_write_options options = {FFD_FORMAT_AUTO, FFD_ENCODING_SAME, 0};
    if (format && *format) {
        int f = FFD_FORMAT_OBJ;
        while (f <= FFD_FORMAT_GLTF && strcmp(format, format_names[f]) != 0)
            f++;
        if (f > FFD_FORMAT_GLTF)
            return answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                                "format '%.32s': expected obj, ply, off, stl or gltf", format);
        options.format = (ffd_format)f;
    }
    if (parse_encoding(encoding, &options.encoding) != 0)
        return answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                            "encoding '%.32s': expected ascii, binary or binary-be", encoding);
    /* ?mesh=I: that mesh of several alone (ffd_session_export_mesh) */
    const char *mesh = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "mesh");
    size_t index = 0;
    const char *mesh_name = NULL;
    if (mesh && !(mesh_name = mesh_of(srv->session, mesh, &index)))
        return answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                            "mesh '%.32s': expected the index of one of the session's %zu meshes",
                            mesh, ffd_session_mesh_count(srv->session));
    ffd_format shown = options.format;
    if (shown == FFD_FORMAT_AUTO)
        shown = mesh_name ? ffd_format_from_path(mesh_name)
                          : ffd_mesh_source_format(ffd_session_mesh(srv->session));
    if (shown < FFD_FORMAT_OBJ || shown > FFD_FORMAT_GLTF)
        shown = FFD_FORMAT_OBJ;
    ffd_error err = {{0}};
    void *data = NULL;
    size_t size = 0;
    ffd_status st = mesh_name ? ffd_session_export_mesh(srv->session, index, &options, &data,
                                                        &size, &err)
                              : ffd_session_export(srv->session, &options, &data, &size, &err);
    if (st == FFD_ERR_UNSUPPORTED) /* an encoding the format does not have */
        st = FFD_ERR_INVALID;
    if (st != FFD_OK)
        return answer_status(srv, c, r, st, err.message);
    char suffix[32], disposition[160];
    /* glTF's binary encoding is a .glb (it starts with the GLB magic) */
    bool glb = shown == FFD_FORMAT_GLTF && size >= 4 && memcmp(data, "glTF", 4) == 0;
    snprintf(suffix, sizeof suffix, "-deformed.%s", glb ? "glb" : format_names[shown]);
    attachment_named(mesh_name ? mesh_name : ffd_session_name(srv->session), suffix, disposition,
                     sizeof disposition);
    return answer_data(srv, c, r, data, size, "application/octet-stream", disposition);
}

/* GET /api/frame?base=REV, POST /api/drag?base=REV: the revision of the
 * frame the client holds, for a delta frame (docs/editor.md "Delta frames"),
 * "none" when it holds none (UINT32_MAX). 0: none asked, 1: *base set, -1:
 * not a revision. */
static int frame_base(struct MHD_Connection *c, const request *r, uint32_t *base)
{
    const char *q = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "base");
    if (!q || (r->route != ROUTE_FRAME && strcmp(r->op, "drag") != 0))
        return 0;
    if (strcmp(q, "none") == 0) {
        *base = UINT32_MAX;
        return 1;
    }
    char *end = NULL;
    errno = 0;
    unsigned long v = strtoul(q, &end, 10);
    if (!*q || *end || errno || v >= UINT32_MAX || *q == '-' || *q == '+' || *q == ' ')
        return -1;
    *base = (uint32_t)v;
    return 1;
}

/* Replaces a drag step's full frame by its delta against base where the session holds base. */
static void to_delta(const serve_server *srv, uint32_t base, void **reply, size_t *size)
{
    void *delta = NULL;
    size_t delta_size = 0;
    if (ffd_session_delta_frame(srv->session, base, *reply, *size, &delta, &delta_size, NULL) ==
            FFD_OK &&
        delta) {
        ffd_free(*reply);
        *reply = delta;
        *size = delta_size;
    }
}

static enum MHD_Result get_binary(const serve_server *srv, struct MHD_Connection *c, request *r)
{
    ffd_error err = {{0}};
    void *data = NULL;
    size_t size = 0;
    uint32_t base = 0;
    int delta = frame_base(c, r, &base);
    if (delta < 0)
        return answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                            "frame: base: expected the revision of the client's frame (0 to %u) "
                            "or none", UINT32_MAX - 1);
    ffd_status st = r->route == ROUTE_FRAME
                        ? ffd_session_frame(srv->session, &data, &size, &err)
                        : ffd_session_topology(srv->session, &data, &size, &err);
    if (st != FFD_OK)
        return answer_status(srv, c, r, st, err.message);
    if (delta)
        to_delta(srv, base, &data, &size);
    return answer_data(srv, c, r, data, size, "application/octet-stream", NULL);
}

static enum MHD_Result post_op(serve_server *srv, struct MHD_Connection *c, request *r)
{
    ffd_error err = {{0}};
    void *reply = NULL;
    size_t size = 0;
    int binary = 0;
    uint32_t base = 0;
    int delta = frame_base(c, r, &base);
    if (delta < 0)
        return answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                            "drag: base: expected the revision of the client's frame (0 to %u) "
                            "or none", UINT32_MAX - 1);
    ffd_status st = ffd_session_command(srv->session, r->op, r->body ? r->body : "", r->size,
                                        &reply, &size, &binary, &err);
    if (st != FFD_OK)
        return answer_status(srv, c, r, st, err.message);
    if (delta && binary)
        to_delta(srv, base, &reply, &size);
    /* a JSON reply is the new state; a binary one (a drag step's frame)
     * leaves the state to be made when next needed */
    if (binary)
        publish(srv, NULL, 0);
    else
        publish_copy(srv, reply, size);
    if (!binary) /* a drag step is not a change to save: its drag_end is */
        serve_autosave_changed(srv->autosave);
    return answer_data(srv, c, r, reply, size,
                       binary ? "application/octet-stream" : "application/json", NULL);
}

/* ?add=1 on /api/open and /api/upload: the mesh joins the session
 * (ffd_session_add_mesh) instead of replacing it. */
static int adding(struct MHD_Connection *c)
{
    const char *add = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "add");
    return add && strcmp(add, "1") == 0;
}

static enum MHD_Result add_mesh(serve_server *srv, struct MHD_Connection *c, request *r,
                                ffd_mesh *mesh, const char *name)
{
    ffd_error err = {{0}};
    ffd_status st = ffd_session_add_mesh(srv->session, mesh, name, &err);
    if (st != FFD_OK) {
        ffd_mesh_destroy(mesh);
        return answer_status(srv, c, r, st, err.message);
    }
    return reply_state(srv, c, r);
}

/* Makes a session of mesh (taken over) and puts it in place of the old one. */
static enum MHD_Result replace_session(serve_server *srv, struct MHD_Connection *c, request *r,
                                       ffd_mesh *mesh, const char *name, const char *path)
{
    if (adding(c))
        return add_mesh(srv, c, r, mesh, name);
    ffd_error err = {{0}};
    ffd_session *s = NULL;
    char *copy = NULL;
    if (path && !(copy = ffd_strdup(path))) {
        ffd_mesh_destroy(mesh);
        return answer_error(srv, c, r, MHD_HTTP_INTERNAL_SERVER_ERROR, "nomem", "out of memory");
    }
    ffd_status st = ffd_session_create(mesh, name, NULL, &s, &err);
    if (st != FFD_OK) {
        ffd_mesh_destroy(mesh);
        ffd_free(copy);
        return answer_status(srv, c, r, st, err.message);
    }
    serve_autosave_flush(srv->autosave); /* the old session's last change */
    ffd_session_destroy(srv->session);
    srv->session = s;
    ffd_free(srv->mesh_path);
    srv->mesh_path = copy;
    serve_autosave_opened(srv->autosave, s, copy, 0); /* keeps an earlier record aside */
    return reply_state(srv, c, r);
}

static enum MHD_Result post_open(serve_server *srv, struct MHD_Connection *c, request *r)
{
    static const char *const keys[] = {"path"};
    const char *path;
    cJSON *doc;
    char msg[MSG_LEN], abs[PATH_LEN];
    const char *word;
    unsigned code = parse_body(r, keys, 1, &path, &doc, msg, sizeof msg);
    if (code)
        return answer_error(srv, c, r, code, "parse", "%s", msg);
    if ((code = resolve(srv, path, 0, abs, &word, msg, sizeof msg)) != 0) {
        cJSON_Delete(doc);
        return answer_error(srv, c, r, code, word, "%s", msg);
    }
    if (ffd_format_from_path(abs) == FFD_FORMAT_AUTO) {
        enum MHD_Result ret = answer_error(srv, c, r, MHD_HTTP_UNSUPPORTED_MEDIA_TYPE,
                                           "unsupported_format",
                                           "%s: unknown mesh format (expected .obj, .ply, .off, .stl, .gltf or .glb)",
                                           path);
        cJSON_Delete(doc);
        return ret;
    }
    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    ffd_status st = ffd_mesh_read(abs, &mesh, &err);
    if (st != FFD_OK) {
        cJSON_Delete(doc);
        return answer_status(srv, c, r, st, err.message);
    }
    enum MHD_Result ret = replace_session(srv, c, r, mesh, base_name(path), abs);
    cJSON_Delete(doc);
    return ret;
}

static enum MHD_Result post_upload(serve_server *srv, struct MHD_Connection *c, request *r)
{
    const char *name = base_name(MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "name"));
    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    ffd_status st = ffd_mesh_read_memory(r->body ? r->body : "", r->size,
                                         ffd_format_from_path(name), name, &mesh, &err);
    if (st != FFD_OK)
        return answer_status(srv, c, r, st, err.message);
    return replace_session(srv, c, r, mesh, name, NULL);
}

/* What a file under the root is loaded into the session as (a rig, a
 * weights file): text of size bytes read from abs, named path in messages. */
typedef ffd_status (*root_file_loader)(serve_server *srv, const char *path, const char *abs,
                                       const char *text, size_t size, ffd_error *err);

static ffd_status load_rig_file(serve_server *srv, const char *path, const char *abs,
                                const char *text, size_t size, ffd_error *err)
{
    (void)path;
    return ffd_session_load_rig(srv->session, text, size, abs, srv->root, err);
}

static ffd_status load_weights_file(serve_server *srv, const char *path, const char *abs,
                                    const char *text, size_t size, ffd_error *err)
{
    (void)abs;
    return ffd_session_load_weights(srv->session, text, size, path, err);
}

/* POST {"path": ...}: a file under the root (at most 16 MiB) loaded by load,
 * one undo step; the state, or the error and nothing changed. */
static enum MHD_Result post_root_file(serve_server *srv, struct MHD_Connection *c, request *r,
                                      const char *what, root_file_loader load)
{
    static const char *const keys[] = {"path"};
    const char *path;
    cJSON *doc;
    char msg[MSG_LEN], abs[PATH_LEN];
    const char *word;
    unsigned code = parse_body(r, keys, 1, &path, &doc, msg, sizeof msg);
    if (code)
        return answer_error(srv, c, r, code, "parse", "%s", msg);
    enum MHD_Result ret;
    struct stat st;
    if ((code = resolve(srv, path, 0, abs, &word, msg, sizeof msg)) != 0) {
        ret = answer_error(srv, c, r, code, word, "%s", msg);
    } else if (stat(abs, &st) == 0 && (uintmax_t)st.st_size > RIG_FILE_LIMIT) {
        ret = answer_error(srv, c, r, MHD_HTTP_CONTENT_TOO_LARGE, "too_large",
                           "%s: a %s larger than 16 MiB", path, what);
    } else {
        ffd_error err = {{0}};
        unsigned char *text = NULL;
        size_t size = 0;
        ffd_status s = ffd_read_file(abs, &text, &size, &err);
        if (s == FFD_OK)
            s = load(srv, path, abs, (const char *)text, size, &err);
        ffd_free(text);
        if (s == FFD_OK)
            serve_autosave_changed(srv->autosave);
        ret = s == FFD_OK ? reply_state(srv, c, r) : answer_status(srv, c, r, s, err.message);
    }
    cJSON_Delete(doc);
    return ret;
}

static enum MHD_Result post_rig_upload(serve_server *srv, struct MHD_Connection *c, request *r)
{
    const char *name = base_name(MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "name"));
    ffd_error err = {{0}};
    ffd_status st = ffd_session_load_rig(srv->session, r->body ? r->body : "", r->size, name,
                                         NULL, &err);
    if (st != FFD_OK)
        return answer_status(srv, c, r, st, err.message);
    serve_autosave_changed(srv->autosave);
    return reply_state(srv, c, r);
}

/* GET /api/history: the named steps and the present one (ffd_session_history). */
static enum MHD_Result get_history(const serve_server *srv, struct MHD_Connection *c, request *r)
{
    ffd_error err = {{0}};
    char *json = NULL;
    size_t size = 0;
    ffd_status st = ffd_session_history(srv->session, &json, &size, &err);
    if (st != FFD_OK)
        return answer_status(srv, c, r, st, err.message);
    return answer_data(srv, c, r, json, size, "application/json", NULL);
}

/* POST /api/autosave/resume: the earlier session of this mesh kept at open. */
static enum MHD_Result post_autosave_resume(serve_server *srv, struct MHD_Connection *c,
                                            request *r)
{
    ffd_error err = {{0}};
    ffd_status st = serve_autosave_resume_previous(srv->autosave, &srv->session, srv->mesh_path,
                                                   &err);
    if (st != FFD_OK)
        return answer_status(srv, c, r, st, err.message);
    return reply_state(srv, c, r);
}

/* {"path": rel, "bytes": n}: what a save wrote. */
static enum MHD_Result answer_saved(const serve_server *srv, struct MHD_Connection *c,
                                    request *r, const char *rel, const char *abs)
{
    struct stat st;
    double bytes = stat(abs, &st) == 0 ? (double)st.st_size : 0;
    cJSON *doc = cJSON_CreateObject();
    if (doc && (!cJSON_AddStringToObject(doc, "path", rel) ||
                !cJSON_AddNumberToObject(doc, "bytes", bytes))) {
        cJSON_Delete(doc);
        doc = NULL;
    }
    return answer_json(srv, c, r, MHD_HTTP_OK, doc, NULL);
}

static enum MHD_Result post_rig_save(serve_server *srv, struct MHD_Connection *c, request *r)
{
    static const char *const keys[] = {"path"};
    const char *path;
    cJSON *doc;
    char msg[MSG_LEN], abs[PATH_LEN];
    const char *word;
    unsigned code = parse_body(r, keys, 1, &path, &doc, msg, sizeof msg);
    if (code)
        return answer_error(srv, c, r, code, "parse", "%s", msg);
    enum MHD_Result ret;
    if (!ends_with(path, ".json")) {
        ret = answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                           "%s: a rig is saved as .json", path);
    } else if ((code = resolve(srv, path, 1, abs, &word, msg, sizeof msg)) != 0) {
        ret = answer_error(srv, c, r, code, word, "%s", msg);
    } else {
        ffd_error err = {{0}};
        char *json = NULL;
        size_t size = 0;
        ffd_status st = ffd_session_rig(srv->session, &json, &size, &err);
        if (st == FFD_OK)
            st = ffd_write_file_atomic(abs, json, size, &err);
        ffd_free(json);
        ret = st == FFD_OK ? answer_saved(srv, c, r, path, abs)
                           : answer_status(srv, c, r, st, err.message);
    }
    cJSON_Delete(doc);
    return ret;
}

static enum MHD_Result post_export_save(serve_server *srv, struct MHD_Connection *c, request *r)
{
    static const char *const keys[] = {"path", "encoding"};
    const char *values[2];
    cJSON *doc;
    char msg[MSG_LEN], abs[PATH_LEN];
    const char *word;
    unsigned code = parse_body(r, keys, 2, values, &doc, msg, sizeof msg);
    if (code)
        return answer_error(srv, c, r, code, "parse", "%s", msg);
    const char *path = values[0];
    ffd_write_options options = {FFD_FORMAT_AUTO, FFD_ENCODING_SAME, 0};
    enum MHD_Result ret;
    if (parse_encoding(values[1], &options.encoding) != 0) {
        ret = answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                           "encoding '%.32s': expected ascii, binary or binary-be", values[1]);
    } else if (ffd_format_from_path(path) == FFD_FORMAT_AUTO) {
        ret = answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                           "%s: unknown mesh format (expected .obj, .ply, .off, .stl, .gltf or .glb)", path);
    } else if ((code = resolve(srv, path, 1, abs, &word, msg, sizeof msg)) != 0) {
        ret = answer_error(srv, c, r, code, word, "%s", msg);
    } else if (srv->mesh_path && cli_same_file(abs, srv->mesh_path)) {
        ret = answer_error(srv, c, r, MHD_HTTP_CONFLICT, "conflict",
                           "%s: is the opened mesh: save the deformed mesh under another name",
                           path);
    } else {
        ffd_error err = {{0}};
        ffd_mesh *deformed = NULL;
        ffd_status st = ffd_session_deformed(srv->session, &deformed, &err);
        if (st == FFD_OK)
            st = ffd_mesh_write(deformed, abs, &options, &err);
        if (st == FFD_ERR_UNSUPPORTED)
            st = FFD_ERR_INVALID;
        ffd_mesh_destroy(deformed);
        ret = st == FFD_OK ? answer_saved(srv, c, r, path, abs)
                           : answer_status(srv, c, r, st, err.message);
    }
    cJSON_Delete(doc);
    return ret;
}

static enum MHD_Result api(serve_server *srv, struct MHD_Connection *c, request *r)
{
    switch (r->route) {
    case ROUTE_FRAME:
    case ROUTE_TOPOLOGY: return get_binary(srv, c, r);
    case ROUTE_RIG: return get_rig(srv, c, r);
    case ROUTE_EXPORT: return get_export(srv, c, r);
    case ROUTE_OP: return post_op(srv, c, r);
    case ROUTE_OPEN: return post_open(srv, c, r);
    case ROUTE_UPLOAD: return post_upload(srv, c, r);
    case ROUTE_RIG_LOAD: return post_root_file(srv, c, r, "rig", load_rig_file);
    case ROUTE_RIG_UPLOAD: return post_rig_upload(srv, c, r);
    case ROUTE_RIG_SAVE: return post_rig_save(srv, c, r);
    case ROUTE_EXPORT_SAVE: return post_export_save(srv, c, r);
    case ROUTE_WEIGHTS_LOAD: return post_root_file(srv, c, r, "weights file", load_weights_file);
    case ROUTE_HISTORY: return get_history(srv, c, r);
    case ROUTE_AUTOSAVE_RESUME: return post_autosave_resume(srv, c, r);
    default: break;
    }
    return answer_error(srv, c, r, MHD_HTTP_INTERNAL_SERVER_ERROR, "error", "unrouted request");
}

/* ======================================================================
 * Listing the root's files (no lock: the session is not involved)
 * ====================================================================== */

typedef struct name_list {
    char **v;
    size_t n, cap;
    int truncated;
} name_list;

static int push_name(name_list *l, const char *name)
{
    if (l->n == LIST_LIMIT) {
        l->truncated = 1;
        return 0;
    }
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 32;
        char **v = realloc(l->v, cap * sizeof *v);
        if (!v)
            return -1;
        l->v = v;
        l->cap = cap;
    }
    if (!(l->v[l->n] = ffd_strdup(name)))
        return -1;
    l->n++;
    return 0;
}

static void free_names(name_list *l)
{
    for (size_t i = 0; i < l->n; i++)
        ffd_free(l->v[i]);
    free(l->v);
}

static int compare_names(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Files under dir (rel: its path under the root, "" or ending in '/'), two
 * directory levels down, skipping hidden entries, node_modules and links that
 * leave the root or name directories. -1 on allocation failure. */
static int scan(const serve_server *srv, const char *dir, const char *rel, int depth,
                name_list *meshes, name_list *rigs, size_t *visits)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0; /* unreadable directories are left out */
    int result = 0;
    struct dirent *e;
    while (result == 0 && (e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.' || strcmp(e->d_name, "node_modules") == 0)
            continue;
        if (++*visits > LIST_VISITS) {
            meshes->truncated = rigs->truncated = 1;
            break;
        }
        char path[PATH_LEN], name[PATH_LEN];
        int n1 = snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        int n2 = snprintf(name, sizeof name, "%s%s", rel, e->d_name);
        if (n1 < 0 || n2 < 0 || (size_t)n1 >= sizeof path || (size_t)n2 >= CLIENT_PATH_LEN)
            continue;
        struct stat st;
        if (lstat(path, &st) != 0)
            continue;
        if (S_ISLNK(st.st_mode)) {
            char *real = realpath(path, NULL);
            int ok = real && under(srv->root, real) && stat(real, &st) == 0 && S_ISREG(st.st_mode);
            free(real);
            if (!ok)
                continue;
        }
        if (S_ISDIR(st.st_mode)) {
            if (depth < 2 && (size_t)n2 + 1 < CLIENT_PATH_LEN) {
                strcat(name, "/");
                result = scan(srv, path, name, depth + 1, meshes, rigs, visits);
            }
        } else if (S_ISREG(st.st_mode)) {
            if (ffd_format_from_path(name) != FFD_FORMAT_AUTO)
                result = push_name(meshes, name);
            else if (ends_with(name, ".json") || ends_with(name, ".prm"))
                result = push_name(rigs, name);
        }
    }
    closedir(d);
    return result;
}

static cJSON *name_array(name_list *l)
{
    if (l->n)
        qsort(l->v, l->n, sizeof *l->v, compare_names);
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < l->n; i++) {
        cJSON *s = cJSON_CreateString(l->v[i]);
        if (!s || !cJSON_AddItemToArray(a, s)) {
            cJSON_Delete(s);
            cJSON_Delete(a);
            return NULL;
        }
    }
    return a;
}

static enum MHD_Result get_files(const serve_server *srv, struct MHD_Connection *c, request *r)
{
    name_list meshes = {0}, rigs = {0};
    size_t visits = 0;
    char root[PATH_LEN + 1];
    snprintf(root, sizeof root, "%s%s", srv->root, strcmp(srv->root, "/") == 0 ? "" : "/");
    cJSON *doc = NULL;
    if (scan(srv, srv->root, "", 0, &meshes, &rigs, &visits) == 0 &&
        (doc = cJSON_CreateObject()) != NULL) {
        cJSON *m = name_array(&meshes), *g = m ? name_array(&rigs) : NULL;
        if (!g || !cJSON_AddStringToObject(doc, "root", root) ||
            !cJSON_AddItemToObject(doc, "meshes", m) || (m = NULL, 0) ||
            !cJSON_AddItemToObject(doc, "rigs", g) || (g = NULL, 0) ||
            !cJSON_AddBoolToObject(doc, "truncated", meshes.truncated || rigs.truncated)) {
            cJSON_Delete(m);
            cJSON_Delete(g);
            cJSON_Delete(doc);
            doc = NULL;
        }
    }
    free_names(&meshes);
    free_names(&rigs);
    return answer_json(srv, c, r, MHD_HTTP_OK, doc, NULL);
}

/* ======================================================================
 * The page's files
 * ====================================================================== */

static const char *content_type(const char *path)
{
    static const char *const types[][2] = {
        {".html", "text/html; charset=utf-8"},
        {".js", "text/javascript; charset=utf-8"},
        {".css", "text/css; charset=utf-8"},
        {".map", "application/json"},
        {".png", "image/png"},
        {".svg", "image/svg+xml"},
        {".json", "application/json"},
        {".wasm", "application/wasm"},
    };
    for (size_t i = 0; i < sizeof types / sizeof *types; i++)
        if (ends_with(path, types[i][0]))
            return types[i][1];
    return NULL;
}

static enum MHD_Result get_static(const serve_server *srv, struct MHD_Connection *c, request *r)
{
    const char *rel = r->url[0] == '/' ? r->url + 1 : r->url;
    if (!*rel)
        rel = "index.html";
    char msg[MSG_LEN];
    unsigned code = check_relative(rel, msg, sizeof msg);
    if (code == MHD_HTTP_FORBIDDEN)
        return answer_error(srv, c, r, code, "forbidden", "%s", msg);
    char path[PATH_LEN];
    int n = snprintf(path, sizeof path, "%s/%s", srv->web, rel);
    char *real = NULL;
    const char *type = NULL;
    if (code == 0 && srv->web[0] && n > 0 && (size_t)n < sizeof path &&
        (real = realpath(path, NULL)) != NULL) {
        if (!under(srv->web, real)) {
            free(real);
            return answer_error(srv, c, r, MHD_HTTP_FORBIDDEN, "forbidden",
                                "%s: outside the page's directory", rel);
        }
        type = content_type(real);
    }
    int fd = type ? open(real, O_RDONLY) : -1;
    free(real);
    struct stat st;
    if (fd < 0 || fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        if (fd >= 0)
            close(fd);
        if (!srv->web[0] && strcmp(rel, "index.html") == 0)
            return answer_error(srv, c, r, MHD_HTTP_NOT_FOUND, "not_found",
                                "the page is not built (see docs/editor.md); the API works");
        return answer_error(srv, c, r, MHD_HTTP_NOT_FOUND, "not_found", "%s: not found", r->url);
    }
    fcntl(fd, F_SETFD, FD_CLOEXEC);
    struct MHD_Response *resp = MHD_create_response_from_fd((uint64_t)st.st_size, fd);
    if (!resp) {
        close(fd);
        return MHD_NO;
    }
    return answer(srv, c, r, MHD_HTTP_OK, resp, type, (size_t)st.st_size);
}

/* ======================================================================
 * Requests
 * ====================================================================== */

static int is_op_name(const char *s)
{
    size_t n = 0;
    for (; s[n]; n++)
        if (!((s[n] >= 'a' && s[n] <= 'z') || s[n] == '_') || n >= 32)
            return 0;
    return n > 0;
}

/* Sets r->route (and r->op) from the URL and method. Returns 0, 404 or 405 (*allow set). */
static unsigned classify(request *r, int get, int post, const char **allow)
{
    const char *url = r->url;
    if (strncmp(url, "/api/", 5) != 0 && strcmp(url, "/api") != 0) {
        *allow = "GET, HEAD";
        if (!get)
            return MHD_HTTP_METHOD_NOT_ALLOWED;
        r->route = ROUTE_STATIC;
        return 0;
    }
    for (size_t i = 0; i < sizeof api_routes / sizeof *api_routes; i++) {
        const struct api_route *a = &api_routes[i];
        if (strcmp(url, a->path) != 0)
            continue;
        *allow = a->allow;
        r->route = get ? a->get : post ? a->post : ROUTE_NONE;
        if (r->route == ROUTE_OP)
            snprintf(r->op, sizeof r->op, "%s", url + 5);
        for (char *q = r->op; *q; q++) /* history/goto: the "history_goto" op */
            *q = *q == '/' ? '_' : *q;
        return r->route == ROUTE_NONE ? MHD_HTTP_METHOD_NOT_ALLOWED : 0;
    }
    const char *op = url + 5;
    if (strncmp(url, "/api/", 5) != 0 || !is_op_name(op))
        return MHD_HTTP_NOT_FOUND;
    *allow = "POST";
    if (post) {
        r->route = ROUTE_OP;
        snprintf(r->op, sizeof r->op, "%s", op);
        return 0;
    }
    if (!get)
        return MHD_HTTP_METHOD_NOT_ALLOWED;
    /* the session's ops (docs/editor.md): a GET of one is a 405, of another name a 404 */
    for (size_t i = 0; ffd_session_op_name(i); i++)
        if (strcmp(op, ffd_session_op_name(i)) == 0)
            return MHD_HTTP_METHOD_NOT_ALLOWED;
    return MHD_HTTP_NOT_FOUND;
}

typedef struct header_count {
    const char *name;
    unsigned count;
} header_count;

static enum MHD_Result count_header(void *cls, enum MHD_ValueKind kind, const char *key,
                                    const char *value)
{
    (void)kind, (void)value;
    header_count *h = cls;
    if (key && strcasecmp(key, h->name) == 0)
        h->count++;
    return MHD_YES;
}

/* How many times the request carries the header name (any case). */
static unsigned header_times(struct MHD_Connection *c, const char *name)
{
    header_count h = {name, 0};
    MHD_get_connection_values(c, MHD_HEADER_KIND, count_header, &h);
    return h.count;
}

/* The first call for a request: route it and refuse what can be refused
 * before its body is read (an ambiguous body length, wrong URL or method, a
 * declared size over the limit, an upload's unknown format). */
static enum MHD_Result begin(serve_server *srv, struct MHD_Connection *c, request *r)
{
    /* libmicrohttpd 0.9.75 reads the body by the first of two Content-Length
     * headers and takes the rest for the next request: a client (or a proxy
     * in front) that reads the other one sees different requests (request
     * smuggling, RFC 9112 section 6.3). Refused, and the connection closed. */
    unsigned lengths = header_times(c, MHD_HTTP_HEADER_CONTENT_LENGTH);
    if (lengths > 1 ||
        (lengths == 1 && header_times(c, MHD_HTTP_HEADER_TRANSFER_ENCODING) > 0)) {
        r->close = 1;
        if (lengths > 1)
            return answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                                "%u Content-Length headers: the body's length is ambiguous",
                                lengths);
        return answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                            "Content-Length and Transfer-Encoding together: the body's length "
                            "is ambiguous");
    }
    int get = strcmp(r->method, MHD_HTTP_METHOD_GET) == 0 ||
              strcmp(r->method, MHD_HTTP_METHOD_HEAD) == 0;
    int post = strcmp(r->method, MHD_HTTP_METHOD_POST) == 0;
    const char *allow = NULL;
    unsigned code = classify(r, get, post, &allow);
    if (code == MHD_HTTP_NOT_FOUND)
        return answer_error(srv, c, r, code, "not_found", "%s: no such resource", r->url);
    if (code == MHD_HTTP_METHOD_NOT_ALLOWED)
        return answer_405(srv, c, r, allow);
    int upload = r->route == ROUTE_UPLOAD || r->route == ROUTE_RIG_UPLOAD;
    r->limit = upload ? srv->max_upload : JSON_LIMIT;
    if (upload) {
        const char *name = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "name");
        if (!name || !*base_name(name))
            return answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                                "missing ?name=FILE (its extension gives the format)");
        int known = r->route == ROUTE_UPLOAD
                        ? ffd_format_from_path(name) != FFD_FORMAT_AUTO
                        : ends_with(name, ".json") || ends_with(name, ".prm");
        if (!known)
            return answer_error(srv, c, r, MHD_HTTP_UNSUPPORTED_MEDIA_TYPE, "unsupported_format",
                                "%.200s: unknown %s", name,
                                r->route == ROUTE_UPLOAD
                                    ? "mesh format (expected .obj, .ply, .off, .stl, .gltf or .glb)"
                                    : "rig format (expected .json or .prm)");
    }
    const char *length = MHD_lookup_connection_value(c, MHD_HEADER_KIND,
                                                     MHD_HTTP_HEADER_CONTENT_LENGTH);
    if (length) {
        char *end;
        errno = 0;
        unsigned long long declared = strtoull(length, &end, 10);
        if (errno || end == length || declared > r->limit)
            return answer_error(srv, c, r, MHD_HTTP_CONTENT_TOO_LARGE, "too_large",
                                "body of %s bytes: larger than the limit of %zu bytes", length,
                                r->limit);
        /* one allocation for the declared size, up to 16 MiB: a client that
         * declares more and sends nothing does not hold more memory */
        size_t cap = declared < RIG_FILE_LIMIT ? (size_t)declared + 1 : RIG_FILE_LIMIT;
        if (declared > 0) {
            r->body = malloc(cap);
            if (!r->body)
                return answer_error(srv, c, r, MHD_HTTP_INTERNAL_SERVER_ERROR, "nomem",
                                    "out of memory for a body of %s bytes", length);
            r->cap = cap;
        }
    }
    return MHD_YES;
}

/* Appends a piece of the body; past the limit, drops it all (answered 413 at the end). */
static void take(request *r, const char *data, size_t size)
{
    if (r->too_large || r->no_memory)
        return;
    if (size > r->limit - r->size) {
        r->too_large = 1;
    } else if (r->size + size + 1 > r->cap) {
        size_t cap = r->cap ? r->cap : 4096;
        while (cap < r->size + size + 1)
            cap = cap > r->limit / 2 ? r->limit + 1 : 2 * cap;
        char *body = realloc(r->body, cap);
        if (!body) {
            r->no_memory = 1;
        } else {
            r->body = body;
            r->cap = cap;
        }
    }
    if (r->too_large || r->no_memory) {
        free(r->body);
        r->body = NULL;
        r->size = r->cap = 0;
        return;
    }
    memcpy(r->body + r->size, data, size);
    r->size += size;
    r->body[r->size] = 0;
}

/* MHD decodes %00 in the path and the query into a NUL and hands out C
 * strings, so "/a.obj%00/../x" would read as "/a.obj". Only the raw URI, seen
 * here before decoding, tells: the request's context starts as this mark. */
static const char NUL_IN_URI = 0;
#define NUL_IN_URI_MARK ((void *)&NUL_IN_URI)

static void *log_uri(void *cls, const char *uri, struct MHD_Connection *c)
{
    (void)cls;
    (void)c;
    return uri && strstr(uri, "%00") ? NUL_IN_URI_MARK : NULL;
}

static enum MHD_Result handle(void *cls, struct MHD_Connection *c, const char *url,
                              const char *method, const char *version, const char *upload_data,
                              size_t *upload_data_size, void **con_cls)
{
    serve_server *srv = cls;
    request *r = *con_cls;
    if (!r || r == NUL_IN_URI_MARK) {
        int nul = r == NUL_IN_URI_MARK;
        if (!(r = calloc(1, sizeof *r)))
            return MHD_NO;
        *con_cls = r;
        r->method = method;
        r->url = url;
        r->start = cli_now();
        if (nul)
            return answer_error(srv, c, r, MHD_HTTP_BAD_REQUEST, "invalid",
                                "%s: a NUL character (%%00) in the URL is not allowed", url);
        return begin(srv, c, r);
    }
    if (*upload_data_size > 0) {
        if (!r->answered)
            take(r, upload_data, *upload_data_size);
        *upload_data_size = 0;
        return MHD_YES;
    }
    if (r->answered)
        return MHD_YES;
    if (r->too_large)
        return answer_error(srv, c, r, MHD_HTTP_CONTENT_TOO_LARGE, "too_large",
                            "body larger than the limit of %zu bytes", r->limit);
    if (r->no_memory)
        return answer_error(srv, c, r, MHD_HTTP_INTERNAL_SERVER_ERROR, "nomem",
                            "out of memory reading the body");
    if (r->route == ROUTE_STATIC)
        return get_static(srv, c, r);
    if (r->route == ROUTE_FILES)
        return get_files(srv, c, r);
    if (r->route == ROUTE_STATE)
        return get_state(srv, c, r);
    if (r->route == ROUTE_PROGRESS)
        return get_progress(srv, c, r);
    pthread_mutex_lock(&srv->lock);
    /* a request that may take long starts with the state published, so that
     * GET /api/state meanwhile answers without waiting for it; drag steps
     * and reading a frame stay as cheap as they are */
    int quick = r->route == ROUTE_FRAME || r->route == ROUTE_TOPOLOGY ||
                (r->route == ROUTE_OP &&
                 (strcmp(r->op, "drag") == 0 || strcmp(r->op, "drag_end") == 0 ||
                  strcmp(r->op, "drag_cancel") == 0 || strcmp(r->op, "influence") == 0));
    if (!quick)
        ensure_published(srv);
    progress_request(srv, r);
    enum MHD_Result ret = api(srv, c, r);
    progress_request(srv, NULL);
    pthread_mutex_unlock(&srv->lock);
    return ret;
}

static void completed(void *cls, struct MHD_Connection *c, void **con_cls,
                      enum MHD_RequestTerminationCode toe)
{
    request *r = *con_cls;
    if (r && r != NUL_IN_URI_MARK) {
        free(r->body);
        free(r);
        *con_cls = NULL;
    }
}

/* ======================================================================
 * Starting and stopping
 * ====================================================================== */

static int parse_host(const char *host, struct in_addr *addr)
{
    if (strcmp(host, "localhost") == 0)
        host = "127.0.0.1";
    return inet_pton(AF_INET, host, addr) == 1;
}

int serve_is_loopback(const char *host)
{
    struct in_addr addr;
    if (!parse_host(host, &addr))
        return -1;
    return (ntohl(addr.s_addr) >> 24) == 127;
}

/* realpath into a PATH_LEN buffer. */
static int resolve_dir(const char *path, char out[PATH_LEN])
{
    char *real = realpath(path, NULL);
    if (!real)
        return -1;
    struct stat st;
    int ok = strlen(real) < PATH_LEN && stat(real, &st) == 0 && S_ISDIR(st.st_mode);
    if (ok)
        strcpy(out, real);
    else
        errno = ENOTDIR;
    free(real);
    return ok ? 0 : -1;
}

int serve_start(ffd_session *session, const serve_options *o, serve_server **out, char *msg,
                size_t msg_size)
{
    *out = NULL;
    serve_server *srv = calloc(1, sizeof *srv);
    if (!srv) {
        snprintf(msg, msg_size, "out of memory");
        return -1;
    }
    int fd = -1;
    struct in_addr addr;
    if (!parse_host(o->host, &addr)) {
        snprintf(msg, msg_size, "--host %s: expected an IPv4 address or localhost", o->host);
        goto fail;
    }
    inet_ntop(AF_INET, &addr, srv->host, sizeof srv->host);
    if (resolve_dir(o->root, srv->root) != 0) {
        snprintf(msg, msg_size, "--root %s: %s", o->root, strerror(errno));
        goto fail;
    }
    if (!o->web || resolve_dir(o->web, srv->web) != 0)
        srv->web[0] = 0;
    if (o->mesh_path) {
        char *real = realpath(o->mesh_path, NULL);
        srv->mesh_path = real ? ffd_strdup(real) : NULL;
        free(real);
    }
    srv->max_upload = o->max_upload;
    srv->verbose = o->verbose;

    /* our own socket: bind's errno says why listening failed */
    fd = socket(AF_INET, SOCK_STREAM, 0);
    int one = 1;
    struct sockaddr_in sa;
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    sa.sin_port = htons((uint16_t)o->port);
    sa.sin_addr = addr;
    socklen_t len = sizeof sa;
    if (fd < 0 || fcntl(fd, F_SETFD, FD_CLOEXEC) != 0 ||
        setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0 ||
        bind(fd, (struct sockaddr *)&sa, sizeof sa) != 0 || listen(fd, 64) != 0 ||
        getsockname(fd, (struct sockaddr *)&sa, &len) != 0) {
        snprintf(msg, msg_size, "cannot listen on %s:%u: %s", srv->host, o->port, strerror(errno));
        goto fail;
    }
    srv->port = ntohs(sa.sin_port);
    if (pthread_mutex_init(&srv->lock, NULL) != 0) {
        snprintf(msg, msg_size, "cannot create a lock");
        goto fail;
    }
    if (pthread_mutex_init(&srv->published_lock, NULL) != 0) {
        pthread_mutex_destroy(&srv->lock);
        snprintf(msg, msg_size, "cannot create a lock");
        goto fail;
    }
    srv->session = session;
    if (o->autosave && !(srv->autosave = serve_autosave_start(srv->root, &srv->lock,
                                                              &srv->session, msg, msg_size))) {
        srv->session = NULL;
        pthread_mutex_destroy(&srv->published_lock);
        pthread_mutex_destroy(&srv->lock);
        goto fail;
    }
    serve_autosave_opened(srv->autosave, session, srv->mesh_path, 1); /* resumes its autosave */
    ensure_published(srv);
    /* no MHD_USE_ERROR_LOG: MHD never prints on its own. Of the 256
     * connections, one client address holds at most client_connections (MHD
     * closes its next ones at once), and a connection silent for
     * idle_timeout seconds is closed: slow or idle clients cannot shut the
     * others out (docs/editor.md, "Safety"). */
    unsigned clients = o->client_connections ? o->client_connections : SERVE_CLIENT_CONNECTIONS;
    unsigned idle = o->idle_timeout ? o->idle_timeout : SERVE_IDLE_TIMEOUT;
    srv->daemon = MHD_start_daemon(MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_THREAD_PER_CONNECTION,
                                   0, NULL, NULL, handle, srv, MHD_OPTION_LISTEN_SOCKET, fd,
                                   MHD_OPTION_NOTIFY_COMPLETED, completed, srv,
                                   MHD_OPTION_URI_LOG_CALLBACK, log_uri, srv,
                                   MHD_OPTION_CONNECTION_TIMEOUT, idle,
                                   MHD_OPTION_PER_IP_CONNECTION_LIMIT, clients,
                                   MHD_OPTION_CONNECTION_LIMIT, (unsigned)CONNECTION_LIMIT,
                                   MHD_OPTION_END);
    if (!srv->daemon) {
        serve_autosave_stop(srv->autosave);
        srv->session = NULL;
        publish(srv, NULL, 0);
        pthread_mutex_destroy(&srv->published_lock);
        pthread_mutex_destroy(&srv->lock);
        snprintf(msg, msg_size, "cannot start the HTTP server on %s:%u", srv->host, srv->port);
        goto fail;
    }
    ffd_set_progress(progress_hook, srv);
    *out = srv;
    return 0;
fail:
    if (fd >= 0)
        close(fd);
    ffd_free(srv->mesh_path);
    free(srv);
    return -1;
}

unsigned serve_port(const serve_server *srv)
{
    return srv->port;
}

const char *serve_root(const serve_server *srv)
{
    return srv->root;
}

const char *serve_host(const serve_server *srv)
{
    return srv->host;
}

void serve_stop(serve_server *srv)
{
    if (!srv)
        return;
    MHD_stop_daemon(srv->daemon); /* waits for the connections' threads, closes the socket */
    ffd_set_progress(NULL, NULL);
    serve_autosave_stop(srv->autosave); /* writes a pending change */
    ffd_session_destroy(srv->session);
    publish(srv, NULL, 0);
    pthread_mutex_destroy(&srv->published_lock);
    pthread_mutex_destroy(&srv->lock);
    ffd_free(srv->mesh_path);
    free(srv);
}
