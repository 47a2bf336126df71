/* mesh_xyz.c — XYZ codec: placeholder until V4 lands it (issue 19). */
#include "mesh_cells.h"
#include "mesh_codec.h"

static ffd_status read_xyz(ffd_mesh *m, const char *name, ffd_error *err)
{
    (void)m;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: XYZ reading is not built yet", name);
}

static ffd_status write_xyz(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    (void)m;
    (void)enc;
    (void)b;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "XYZ writing is not built yet");
}

static const char *const xyz_extensions[] = {"xyz", "csv", NULL};

const ffd_mesh_codec ffd_mesh_codec_xyz = {
    .format = FFD_FORMAT_XYZ,
    .name = "XYZ",
    .extensions = xyz_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII),
    .read = read_xyz,
    .patch = ffd_mesh_patch_spans,
    .write = write_xyz,
};
