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
    } else if (!st && a->failed) {
        ffd_free(a->failed);
        a->failed = NULL;
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

void serve_autosave_opened(serve_autosave *a, ffd_session *s, const char *mesh_path)
{
    if (!a)
        return;
    ffd_free(a->path);
    ffd_free(a->mesh_rel);
    a->path = a->mesh_rel = NULL;
    size_t rl = strlen(a->root);
    if (!mesh_path || strncmp(mesh_path, a->root, rl) != 0 ||
        (mesh_path[rl] != '/' && strcmp(a->root, "/") != 0))
        return;
    const char *rel = mesh_path + (strcmp(a->root, "/") == 0 ? 1 : rl + 1);
    char name[4200], kept[4300], shown[4300], kept_shown[4300];
    /* one record per mesh file: its path under the root, '/' as '_' */
    int n = snprintf(name, sizeof name, "%s", rel);
    for (int i = 0; i < n && name[i]; i++)
        if (name[i] == '/')
            name[i] = '_';
    size_t plen = strlen(a->root) + strlen(name) + 32;
    a->path = ffd_malloc(plen);
    a->mesh_rel = ffd_strdup(rel);
    if (!a->path || !a->mesh_rel) {
        ffd_free(a->path);
        a->path = NULL;
        return;
    }
    snprintf(a->path, plen, "%s/.ffd/autosave-%s.json", a->root, name);
    snprintf(shown, sizeof shown, ".ffd/autosave-%s.json", name);
    snprintf(kept, sizeof kept, "%s/.ffd/autosave-%s.not-applied.json", a->root, name);
    snprintf(kept_shown, sizeof kept_shown, ".ffd/autosave-%s.not-applied.json", name);
    unsigned char *text = NULL;
    size_t size = 0;
    ffd_error err = {{0}};
    struct stat sb;
    if (stat(a->path, &sb) != 0) {
        ffd_session_set_autosave_file(s, shown);
        return; /* nothing saved yet */
    }
    ffd_status st = ffd_read_file(a->path, &text, &size, &err);
    if (!st)
        st = ffd_session_resume(s, (const char *)text, size, shown, kept_shown, &err);
    ffd_free(text);
    if (st) {
        /* kept aside: the next autosave must not overwrite the work it holds */
        if (rename(a->path, kept) != 0)
            fprintf(stderr, "ffd: warning: autosave: cannot keep %s as %s: %s\n", a->path, kept,
                    strerror(errno));
        fprintf(stderr, "ffd serve: your autosaved session was not applied: %s\n", err.message);
        ffd_session_set_autosave_file(s, shown);
        return;
    }
    char *state = NULL;
    size_t state_size = 0;
    const char *saved = "";
    cJSON *doc = NULL;
    if (ffd_session_state(s, &state, &state_size, NULL) == FFD_OK)
        doc = cJSON_ParseWithLength(state, state_size);
    const cJSON *note = cJSON_GetObjectItemCaseSensitive(doc, "autosave");
    const cJSON *when = cJSON_GetObjectItemCaseSensitive(note, "saved");
    const cJSON *steps = cJSON_GetObjectItemCaseSensitive(note, "steps");
    if (cJSON_IsString(when))
        saved = when->valuestring;
    fprintf(stderr, "ffd serve: resumed your session of %s from %s (%d history steps; %s)\n", rel,
            saved, cJSON_IsNumber(steps) ? (int)steps->valuedouble : 0, shown);
    cJSON_Delete(doc);
    ffd_free(state);
    ffd_session_set_autosave_file(s, shown);
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
    ffd_free(a->failed);
    free(a);
}
