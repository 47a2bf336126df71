/* serve_autosave — `ffd serve`'s autosave (docs/editor.md "Work is never
 * lost"): after each change (debounced; drag steps are not changes, their
 * drag_end is) the session's record (ffd_session_autosave) is written
 * atomically to ROOT/.ffd/autosave-<mesh path under the root>.json; a
 * session opened on the same mesh resumes it (ffd_session_resume). */
#ifndef FFD_SERVE_AUTOSAVE_H
#define FFD_SERVE_AUTOSAVE_H

#include "ffd.h"

#include <pthread.h>

/* Quiet time after the last change before the record is written. */
#define SERVE_AUTOSAVE_DELAY_MS 300

typedef struct serve_autosave serve_autosave;

/* The autosave of the sessions *session (changed by the caller under
 * *lock, which the writer takes); NULL when out of memory or when the
 * writer thread does not start (msg says why). */
serve_autosave *serve_autosave_start(const char *root, pthread_mutex_t *lock,
                                     ffd_session **session, char *msg, size_t msg_size);
/* Under the lock: the session was just made on mesh_path (resolved, under
 * the root; NULL: an upload, not autosaved). resume (the server's start):
 * resumes its record if there is one (stderr says what happened; the
 * state's "autosave" says it to the page); a record not applied is kept as
 * .not-applied.json. Else (opened from the page: a new session) a record
 * is kept as .previous.json and the state's "autosave" offers it
 * ("previous"). */
void serve_autosave_opened(serve_autosave *a, ffd_session *s, const char *mesh_path, int resume);
/* Under the lock (POST /api/autosave/resume): *session replaced by a new
 * session on mesh_path that resumes the kept .previous.json (then removed).
 * On error nothing changes. */
ffd_status serve_autosave_resume_previous(serve_autosave *a, ffd_session **session,
                                          const char *mesh_path, ffd_error *err);
/* Under the lock, before the session is replaced: writes a pending change now. */
void serve_autosave_flush(serve_autosave *a);
/* The session changed: write it once it has been quiet for a while. */
void serve_autosave_changed(serve_autosave *a);
/* Writes what is pending and stops the writer (without the lock held). NULL-safe. */
void serve_autosave_stop(serve_autosave *a);

#endif
