#include "session/session.h"
#define STUB(name) \
ffd_status sess_##name##_create(const sess_ctx *ctx, const cJSON *body, sess_method **out, ffd_error *err) \
{ return ffd_fail(err, FFD_ERR_UNSUPPORTED, "todo"); } \
ffd_status sess_##name##_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out, ffd_error *err) \
{ return ffd_fail(err, FFD_ERR_UNSUPPORTED, "todo"); }
STUB(pbffd)
STUB(gffd)

