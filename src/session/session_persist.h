/* session_persist — the session's history as named steps, its record
 * (each step as rig text with pins) and the autosave that writes it and
 * resumes it (ffd_session_history, ffd_session_autosave,
 * ffd_session_resume; docs/editor.md "Work is never lost"). session.c owns
 * the undo stacks; these are its entry points for session_persist.c. */
#ifndef FFD_SESSION_PERSIST_H
#define FFD_SESSION_PERSIST_H

#include "session/session.h"

/* The longest step name kept (bytes, with the NUL). */
#define SESS_STEP_NAME 80

/* Step names (session_persist.c): "Create lattice 5×5×5", "Drag 3
 * controls", "Refine T-spline", "Load rig bunny-rig.json" ... */
void sess_name_create(char *buf, size_t size, const char *method, const cJSON *body);
void sess_name_drag(char *buf, size_t size, int mode, const uint32_t *ids, size_t k);
void sess_name_op(char *buf, size_t size, const char *method, const char *op, const cJSON *body);
/* "VERB BASENAME" */
void sess_name_file(char *buf, size_t size, const char *verb, const char *path);

/* session.c: the state as rig text with its pins (NULL without a deformer). */
ffd_status sess_state_rig(const ffd_session *s, char **text, ffd_error *err);
/* The steps: 0 .. count-1, the present one current (= the undo depth). */
size_t sess_history_count(const ffd_session *s);
size_t sess_history_current(const ffd_session *s);
const char *sess_history_name(const ffd_session *s, size_t i);
/* Step i as rig text with pins (*text NULL: no deformer then; ffd_free). */
ffd_status sess_history_rig(const ffd_session *s, size_t i, char **text, ffd_error *err);
int sess_dragging(const ffd_session *s);
size_t sess_autosave_max_bytes(const ffd_session *s);
/* The "history_goto" op: {"index": i}, as many undo or redo as it takes. */
ffd_status sess_op_history_goto(ffd_session *s, const ffd_rig_parser *p, const cJSON *body,
                                ffd_error *err);
/* Replaces a bare session's (no deformer, no history) state by a stored
 * history: count steps named names, each rigs[i] (NULL: no deformer), the
 * present one current. On error nothing changed. */
ffd_status sess_history_restore(ffd_session *s, const char *const *names, const char *const *rigs,
                                size_t count, size_t current, ffd_error *err);
/* The state's "autosave" object (JSON text taken over; NULL: none). */
const char *sess_autosave_note(const ffd_session *s);
void sess_set_autosave_note(ffd_session *s, char *json);

/* session_persist.c: adds "history" and "autosave" to the state; 0 when out
 * of memory. */
int sess_persist_state(const ffd_session *s, cJSON *root);

#endif
