/* mesh_vtu.c — VTU codec: placeholder until V2 lands it (issue 19). */
#include "mesh_cells.h"
#include "mesh_codec.h"

static ffd_status read_vtu(ffd_mesh *m, const char *name, ffd_error *err)
{
    (void)m;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: VTU reading is not built yet", name);
}

static ffd_status write_vtu(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    (void)m;
    (void)enc;
    (void)b;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "VTU writing is not built yet");
}

static const char *const vtu_extensions[] = {"vtu", NULL};

const ffd_mesh_codec ffd_mesh_codec_vtu = {
    .format = FFD_FORMAT_VTU,
    .name = "VTU",
    .extensions = vtu_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII) | FFD_CODEC_ENCODING(FFD_ENCODING_BASE64) | FFD_CODEC_ENCODING(FFD_ENCODING_RAW),
    .read = read_vtu,
    .patch = ffd_mesh_patch_spans,
    .write = write_vtu,
};
