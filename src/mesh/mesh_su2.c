/* mesh_su2.c — SU2 codec: placeholder until V4 lands it (issue 19). */
#include "mesh_cells.h"
#include "mesh_codec.h"

static ffd_status read_su2(ffd_mesh *m, const char *name, ffd_error *err)
{
    (void)m;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: SU2 reading is not built yet", name);
}

static ffd_status write_su2(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    (void)m;
    (void)enc;
    (void)b;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "SU2 writing is not built yet");
}

static const char *const su2_extensions[] = {"su2", NULL};

const ffd_mesh_codec ffd_mesh_codec_su2 = {
    .format = FFD_FORMAT_SU2,
    .name = "SU2",
    .extensions = su2_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII),
    .read = read_su2,
    .patch = ffd_mesh_patch_spans,
    .write = write_su2,
};
