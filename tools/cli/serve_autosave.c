/* serve_autosave — see serve_autosave.h. One writer thread waits for a
 * change, then for SERVE_AUTOSAVE_DELAY_MS without another, then takes the
 * session's lock and writes the record. */
#include "serve_autosave.h"

#include "cli.h"
#include "core/core.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

struct serve_autosave {
    pthread_t thread;
    pthread_mutex_t mutex; /* guards the fields below but path (the session lock) */
    pthread_cond_t cond;
    int dirty, stopping;
    struct timespec changed;   /* CLOCK_MONOTONIC of the last change */
    pthread_mutex_t *lock;     /* the session's */
    ffd_session **session;
    char root[4096];
    char *path;                /* the record of the current session (NULL: none); under *lock */
    char *mesh_rel;            /* its mesh, relative to the root */
    char *name;                /* mesh_rel with '/' as '_': the record's name */
    char *failed;              /* the last write's error, printed once */
};

static int before(const struct timespec *a, const struct timespec *b)
{
    return a->tv_sec < b->tv_sec || (a->tv_sec == b->tv_sec && a->tv_nsec < b->tv_nsec);
}

/* Under the session lock. */
static void write_record(serve_autosave *a)
{
    if (!a->path || !*a->session)
        return;
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/.ffd", a->root);
    ffd_error err = {{0}};
    ffd_status st = FFD_OK;
    if (mkdir(dir, 0777) != 0 && errno != EEXIST)
        st = ffd_fail(&err, FFD_ERR_IO, "%s: %s", dir, strerror(errno));
    if (!st)
        st = ffd_session_autosave(*a->session, a->path, a->mesh_rel, &err);
    if (st && strncmp(err.message, "conflict: ", 10) == 0)
        return; /* a drag in progress: its drag_end writes */
    if (st && (!a->failed || strcmp(a->failed, err.message) != 0)) {
        fprintf(stderr, "ffd: warning: autosave: %s\n", err.message);
        ffd_free(a->failed);
        a->failed = ffd_strdup(err.message);
        /* the page says so too (the state's autosave.error, from the next change on) */
        cJSON *msg = cJSON_CreateString(err.message);
        char *printed = msg ? cJSON_PrintUnformatted(msg) : NULL;
        if (printed)
            ffd_session_note_autosave(*a->session, "error", printed);
        cJSON_free(printed);
        cJSON_Delete(msg);
    } else if (!st && a->failed) {
        ffd_free(a->failed);
        a->failed = NULL;
        ffd_session_note_autosave(*a->session, "error", NULL);
    }
}

static void *writer(void *arg)
{
    serve_autosave *a = arg;
    pthread_mutex_lock(&a->mutex);
    for (;;) {
        while (!a->dirty && !a->stopping)
            pthread_cond_wait(&a->cond, &a->mutex);
        if (!a->dirty)
            break;
        /* debounce: quiet for the delay since the last change */
        struct timespec due;
        for (;;) {
            due = a->changed;
            due.tv_sec += SERVE_AUTOSAVE_DELAY_MS / 1000;
            due.tv_nsec += (SERVE_AUTOSAVE_DELAY_MS % 1000) * 1000000L;
            if (due.tv_nsec >= 1000000000L) {
                due.tv_sec++;
                due.tv_nsec -= 1000000000L;
            }
            struct timespec now;
            clock_gettime(CLOCK_MONOTONIC, &now);
            if (a->stopping || !before(&now, &due))
                break;
            pthread_cond_timedwait(&a->cond, &a->mutex, &due);
        }
        a->dirty = 0;
        pthread_mutex_unlock(&a->mutex);
        pthread_mutex_lock(a->lock);
        write_record(a);
        pthread_mutex_unlock(a->lock);
        pthread_mutex_lock(&a->mutex);
    }
    pthread_mutex_unlock(&a->mutex);
    return NULL;
}

serve_autosave *serve_autosave_start(const char *root, pthread_mutex_t *lock,
                                     ffd_session **session, char *msg, size_t msg_size)
{
    serve_autosave *a = calloc(1, sizeof *a);
    if (!a) {
        snprintf(msg, msg_size, "autosave: out of memory");
        return NULL;
    }
    snprintf(a->root, sizeof a->root, "%s", root);
    a->lock = lock;
    a->session = session;
    pthread_condattr_t attr;
    int ok = pthread_condattr_init(&attr) == 0;
    ok = ok && pthread_condattr_setclock(&attr, CLOCK_MONOTONIC) == 0 &&
         pthread_cond_init(&a->cond, &attr) == 0;
    if (ok && pthread_mutex_init(&a->mutex, NULL) != 0) {
        pthread_cond_destroy(&a->cond);
        ok = 0;
    }
    if (ok && pthread_create(&a->thread, NULL, writer, a) != 0) {
        pthread_mutex_destroy(&a->mutex);
        pthread_cond_destroy(&a->cond);
        ok = 0;
    }
    pthread_condattr_destroy(&attr);
    if (!ok) {
        snprintf(msg, msg_size, "autosave: cannot start its writer thread");
        free(a);
        return NULL;
    }
    return a;
}

/* ROOT/.ffd/autosave-NAME<suffix> (absolute) or .ffd/autosave-NAME<suffix>
 * (as shown); ffd_free it. */
static char *record_path(const serve_autosave *a, const char *suffix, int absolute)
{
    size_t n = strlen(a->root) + strlen(a->name) + strlen(suffix) + 32;
    char *p = ffd_malloc(n);
    if (p)
        snprintf(p, n, "%s%s.ffd/autosave-%s%s", absolute ? a->root : "", absolute ? "/" : "",
                 a->name, suffix);
    return p;
}

/* Notes an earlier record kept aside ("previous": its file, when, steps). */
static void note_previous(ffd_session *s, const char *shown, const unsigned char *text, size_t size)
{
    cJSON *doc = cJSON_ParseWithLength((const char *)text, size);
    cJSON *prev = cJSON_CreateObject();
    const cJSON *saved = cJSON_GetObjectItemCaseSensitive(doc, "saved");
    const cJSON *unix_time = cJSON_GetObjectItemCaseSensitive(doc, "saved_unix");
    const cJSON *steps = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(doc, "history"), "steps");
    int ok = prev && cJSON_AddStringToObject(prev, "file", shown) &&
             (!cJSON_IsString(saved) || cJSON_AddStringToObject(prev, "saved", saved->valuestring)) &&
             (!cJSON_IsNumber(unix_time) ||
              cJSON_AddNumberToObject(prev, "saved_unix", unix_time->valuedouble)) &&
             cJSON_AddNumberToObject(prev, "steps", (double)cJSON_GetArraySize(steps));
    char *printed = ok ? cJSON_PrintUnformatted(prev) : NULL;
    if (printed)
        ffd_session_note_autosave(s, "previous", printed);
    cJSON_free(printed);
    cJSON_Delete(prev);
    cJSON_Delete(doc);
}

void serve_autosave_opened(serve_autosave *a, ffd_session *s, const char *mesh_path, int resume)
{
    if (!a)
        return;
    ffd_free(a->path);
    ffd_free(a->mesh_rel);
    ffd_free(a->name);
    a->path = a->mesh_rel = a->name = NULL;
    size_t rl = strlen(a->root);
    int at_top = strcmp(a->root, "/") == 0;
    if (!mesh_path || strncmp(mesh_path, a->root, rl) != 0 || (mesh_path[rl] != '/' && !at_top))
        return; /* an upload: not autosaved (the page says so) */
    const char *rel = mesh_path + (at_top ? 1 : rl + 1);
    /* one record per mesh file: its path under the root, '/' as '_' */
    a->mesh_rel = ffd_strdup(rel);
    a->name = ffd_strdup(rel);
    for (char *c = a->name; c && *c; c++)
        *c = *c == '/' ? '_' : *c;
    char *shown = a->name ? record_path(a, ".json", 0) : NULL;
    char *kept = a->name ? record_path(a, resume ? ".not-applied.json" : ".previous.json", 1) : NULL;
    char *kept_shown = a->name ? record_path(a, resume ? ".not-applied.json" : ".previous.json", 0) : NULL;
    a->path = a->name ? record_path(a, ".json", 1) : NULL;
    unsigned char *text = NULL;
    size_t size = 0;
    ffd_error err = {{0}};
    struct stat sb;
    ffd_status st = FFD_OK;
    if (!a->mesh_rel || !shown || !kept || !kept_shown || !a->path) {
        ffd_free(a->path);
        a->path = NULL; /* out of memory: no autosave */
    } else if (stat(a->path, &sb) != 0) {
        /* nothing saved yet */
    } else if (!resume) {
        /* opened from the page: a new session; the earlier one is kept aside
         * (the next autosave would overwrite it) and the page offers it */
        if (ffd_read_file(a->path, &text, &size, &err) == FFD_OK && rename(a->path, kept) == 0)
            note_previous(s, kept_shown, text, size);
        else
            fprintf(stderr, "ffd: warning: autosave: cannot keep %s as %s: %s\n", a->path, kept,
                    strerror(errno));
    } else if ((st = ffd_read_file(a->path, &text, &size, &err)) ||
               (st = ffd_session_resume(s, (const char *)text, size, shown, kept_shown, &err))) {
        /* kept aside: the next autosave must not overwrite the work it holds */
        if (rename(a->path, kept) != 0)
            fprintf(stderr, "ffd: warning: autosave: cannot keep %s as %s: %s\n", a->path, kept,
                    strerror(errno));
        fprintf(stderr, "ffd serve: your autosaved session was not applied: %s\n", err.message);
    } else {
        char *state = NULL;
        size_t state_size = 0;
        cJSON *doc = NULL;
        if (ffd_session_state(s, &state, &state_size, NULL) == FFD_OK)
            doc = cJSON_ParseWithLength(state, state_size);
        const cJSON *note = cJSON_GetObjectItemCaseSensitive(doc, "autosave");
        const cJSON *when = cJSON_GetObjectItemCaseSensitive(note, "saved");
        const cJSON *steps = cJSON_GetObjectItemCaseSensitive(note, "steps");
        fprintf(stderr, "ffd serve: resumed your session of %s from %s (%d history steps; %s)\n",
                rel, cJSON_IsString(when) ? when->valuestring : "?",
                cJSON_IsNumber(steps) ? (int)steps->valuedouble : 0, shown);
        cJSON_Delete(doc);
        ffd_free(state);
    }
    if (a->path)
        ffd_session_set_autosave_file(s, shown);
    ffd_free(text);
    ffd_free(shown);
    ffd_free(kept);
    ffd_free(kept_shown);
}

ffd_status serve_autosave_resume_previous(serve_autosave *a, ffd_session **session,
                                          const char *mesh_path, ffd_error *err)
{
    if (!a || !a->path || !mesh_path)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "conflict: autosave/resume: this session is not autosaved");
    char *prev = record_path(a, ".previous.json", 1), *shown = record_path(a, ".previous.json", 0);
    unsigned char *text = NULL;
    size_t size = 0;
    ffd_mesh *mesh = NULL;
    ffd_session *s = NULL;
    struct stat sb;
    ffd_status st = FFD_OK;
    if (!prev || !shown)
        st = ffd_fail(err, FFD_ERR_NOMEM, "autosave/resume: out of memory");
    else if (stat(prev, &sb) != 0)
        st = ffd_fail(err, FFD_ERR_INVALID,
                      "conflict: autosave/resume: no earlier session of %s is kept (%s)",
                      ffd_session_name(*session), shown);
    /* a new session on the mesh file, the record resumed into it: nothing
     * changes unless all of it works */
    if (!st && !(st = ffd_read_file(prev, &text, &size, err)) &&
        !(st = ffd_mesh_read(mesh_path, &mesh, err)) &&
        !(st = ffd_session_create(mesh, ffd_session_name(*session), NULL, &s, err)))
        mesh = NULL;
    if (!st)
        st = ffd_session_resume(s, (const char *)text, size, shown, NULL, err);
    if (!st) {
        pthread_mutex_lock(&a->mutex);
        a->dirty = 0; /* the replaced session's pending change goes with it */
        pthread_mutex_unlock(&a->mutex);
        ffd_session_destroy(*session);
        *session = s;
        s = NULL;
        char *own = record_path(a, ".json", 0);
        if (own)
            ffd_session_set_autosave_file(*session, own);
        ffd_free(own);
        if (unlink(prev) != 0)
            fprintf(stderr, "ffd: warning: autosave: cannot remove %s: %s\n", prev,
                    strerror(errno));
        fprintf(stderr, "ffd serve: resumed your earlier session of %s (%s)\n", a->mesh_rel, shown);
        serve_autosave_changed(a); /* it is the session now: its record */
    }
    ffd_session_destroy(s);
    ffd_mesh_destroy(mesh);
    ffd_free(text);
    ffd_free(prev);
    ffd_free(shown);
    return st;
}

void serve_autosave_flush(serve_autosave *a)
{
    if (!a)
        return;
    pthread_mutex_lock(&a->mutex);
    int pending = a->dirty;
    a->dirty = 0;
    pthread_mutex_unlock(&a->mutex);
    if (pending)
        write_record(a);
}

void serve_autosave_changed(serve_autosave *a)
{
    if (!a)
        return;
    pthread_mutex_lock(&a->mutex);
    a->dirty = 1;
    clock_gettime(CLOCK_MONOTONIC, &a->changed);
    pthread_cond_signal(&a->cond);
    pthread_mutex_unlock(&a->mutex);
}

void serve_autosave_stop(serve_autosave *a)
{
    if (!a)
        return;
    pthread_mutex_lock(&a->mutex);
    a->stopping = 1;
    pthread_cond_signal(&a->cond);
    pthread_mutex_unlock(&a->mutex);
    pthread_join(a->thread, NULL); /* it writes what is pending first */
    pthread_mutex_destroy(&a->mutex);
    pthread_cond_destroy(&a->cond);
    ffd_free(a->path);
    ffd_free(a->mesh_rel);
    ffd_free(a->name);
    ffd_free(a->failed);
    free(a);
}
