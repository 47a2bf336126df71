/* Tests of the glTF 2.0 codec (src/mesh/mesh_gltf.c): files built here
 * (a cube under two nodes with TRS transforms and a parent, indexed with
 * UNSIGNED_SHORT, and a non-indexed triangle with normals under a matrix
 * node) as .glb, .gltf with a base64 buffer and .gltf with an external
 * .bin; world-space positions, a translation written back in each node's
 * local space (checked byte for byte against floats computed here), the
 * POSITION min/max patched in the JSON text and nothing else changed,
 * identity round trips byte for byte, normals, strips and fans, every
 * refusal, every truncated prefix of a .glb. */
#include "check.h"
#include "ffd.h"
#include "mesh/mesh.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define FIX FFD_SOURCE_DIR "/tests/data/mesh/"

/* ---------------------------------------------------------------------- */
/* The scene. Buffer layout: cube positions (8 x 12 bytes) at 0, cube
 * indices (36 x u16) at 96, triangle positions at 168, triangle normals at
 * 204; 240 bytes. World: cube p -> 2 (p + (0,1,0)) + (10,0,0); triangle
 * p -> p + (10,0,-8) (parent scale 2 times the matrix's 0.5). */

#define BIN_SIZE 240
static const float cube_p[24] = {-1, -1, -1, 1, -1, -1, 1, 1, -1, -1, 1, -1,
                                 -1, -1, 1,  1, -1, 1,  1, 1, 1,  -1, 1, 1};
static const uint16_t cube_i[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                    2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3};
static const float tri_p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
static const float tri_n[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};

static const char scene_json[] =
    "{\"asset\":{\"version\":\"2.0\",\"generator\":\"test\"},\n"
    " \"scene\":0,\"scenes\":[{\"nodes\":[0]}],\n"
    " \"nodes\":[{\"name\":\"parent\",\"translation\":[10,0,0],\"scale\":[2,2,2],\"children\":[1,2]},\n"
    "  {\"name\":\"cube\",\"mesh\":0,\"translation\":[0,1,0]},\n"
    "  {\"name\":\"tri\",\"mesh\":1,\"matrix\":[0.5,0,0,0, 0,0.5,0,0, 0,0,0.5,0, 0,0,-4,1]}],\n"
    " \"materials\":[{\"name\":\"kept\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,0,0,1]}}],\n"
    " \"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0}]},\n"
    "  {\"primitives\":[{\"attributes\":{\"POSITION\":2,\"NORMAL\":3}}]}],\n"
    " \"accessors\":[\n"
    "  {\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\",\"min\":[-1,-1,-1],\"max\":[1,1,1]},\n"
    "  {\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"},\n"
    "  {\"bufferView\":2,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},\n"
    "  {\"bufferView\":3,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],\n"
    " \"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":96},\n"
    "  {\"buffer\":0,\"byteOffset\":96,\"byteLength\":72},\n"
    "  {\"buffer\":0,\"byteOffset\":168,\"byteLength\":36},\n"
    "  {\"buffer\":0,\"byteOffset\":204,\"byteLength\":36}],\n"
    " \"buffers\":[{\"byteLength\":240URI}]}";

static void scene_bin(unsigned char *b)
{
    memcpy(b, cube_p, 96);
    memcpy(b + 96, cube_i, 72);
    memcpy(b + 168, tri_p, 36);
    memcpy(b + 204, tri_n, 36);
}

/* s with the first occurrence of from replaced by to (caller frees). */
static char *replace(const char *s, const char *from, const char *to)
{
    const char *at = strstr(s, from);
    if (!at) {
        fprintf(stderr, "fixture: '%s' not found\n", from);
        abort();
    }
    size_t n = strlen(s) + strlen(to) + 1;
    char *o = malloc(n);
    size_t k = (size_t)(at - s);
    memcpy(o, s, k);
    strcpy(o + k, to);
    strcat(o, at + strlen(from));
    return o;
}

static void le32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v, p[1] = (unsigned char)(v >> 8), p[2] = (unsigned char)(v >> 16),
    p[3] = (unsigned char)(v >> 24);
}
static uint32_t rd32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* A .glb of json (the "URI" placeholder removed) and bin. */
static unsigned char *make_glb(const char *json_with_uri, const unsigned char *bin, size_t bn,
                               size_t *size)
{
    char *json = replace(json_with_uri, "URI", "");
    size_t jn = strlen(json), jp = (jn + 3) / 4 * 4, bp = (bn + 3) / 4 * 4;
    *size = 12 + 8 + jp + 8 + bp;
    unsigned char *g = calloc(1, *size + 1);
    le32(g, 0x46546C67u);
    le32(g + 4, 2);
    le32(g + 8, (uint32_t)*size);
    le32(g + 12, (uint32_t)jp);
    le32(g + 16, 0x4E4F534Au);
    memcpy(g + 20, json, jn);
    memset(g + 20 + jn, ' ', jp - jn);
    le32(g + 20 + jp, (uint32_t)bp);
    le32(g + 24 + jp, 0x004E4942u);
    memcpy(g + 28 + jp, bin, bn);
    free(json);
    return g;
}

static char *base64(const unsigned char *p, size_t n)
{
    static const char t[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *o = malloc(n / 3 * 4 + 8), *q = o;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)p[i] << 16 | (i + 1 < n ? (uint32_t)p[i + 1] << 8 : 0) |
                     (i + 2 < n ? p[i + 2] : 0);
        *q++ = t[v >> 18 & 63];
        *q++ = t[v >> 12 & 63];
        *q++ = i + 1 < n ? t[v >> 6 & 63] : '=';
        *q++ = i + 2 < n ? t[v & 63] : '=';
    }
    *q = 0;
    return o;
}

/* The scene as .gltf text with the buffer in a data: URI. */
static char *make_embedded(const char *json_with_uri)
{
    unsigned char bin[BIN_SIZE];
    scene_bin(bin);
    char *b64 = base64(bin, BIN_SIZE);
    char *uri = malloc(strlen(b64) + 64);
    sprintf(uri, ",\"uri\":\"data:application/octet-stream;base64,%s\"", b64);
    char *j = replace(json_with_uri, "URI", uri);
    free(b64);
    free(uri);
    return j;
}

static unsigned char *scene_glb(size_t *size)
{
    unsigned char bin[BIN_SIZE];
    scene_bin(bin);
    return make_glb(scene_json, bin, BIN_SIZE, size);
}

static ffd_status read_glb_variant(const char *from, const char *to, ffd_error *err)
{
    unsigned char bin[BIN_SIZE];
    scene_bin(bin);
    char *j = replace(scene_json, from, to);
    size_t n;
    unsigned char *g = make_glb(j, bin, BIN_SIZE, &n);
    ffd_mesh *m = NULL;
    ffd_status st = ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "v.glb", &m, err);
    CHECK((st == FFD_OK) == (m != NULL));
    ffd_mesh_destroy(m);
    free(g);
    free(j);
    return st;
}

/* World positions expected for the scene: cube vertices then the triangle's. */
static void expected_world(double *w)
{
    for (int v = 0; v < 8; v++) {
        w[3 * v] = 2 * cube_p[3 * v] + 10;
        w[3 * v + 1] = 2 * (cube_p[3 * v + 1] + 1);
        w[3 * v + 2] = 2 * cube_p[3 * v + 2];
    }
    for (int v = 0; v < 3; v++) {
        w[24 + 3 * v] = tri_p[3 * v] + 10;
        w[24 + 3 * v + 1] = tri_p[3 * v + 1];
        w[24 + 3 * v + 2] = tri_p[3 * v + 2] - 8;
    }
}

/* ---------------------------------------------------------------------- */

static void test_world_positions(void)
{
    size_t n;
    unsigned char *g = scene_glb(&n);
    char *text = make_embedded(scene_json);
    for (int kind = 0; kind < 2; kind++) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        if (kind == 0)
            CHECK_OK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "s.glb", &m, &err));
        else
            CHECK_OK(ffd_mesh_read_memory(text, strlen(text), FFD_FORMAT_GLTF, "s.gltf", &m, &err));
        if (!m)
            continue;
        CHECK(ffd_mesh_vertex_count(m) == 11);
        CHECK(ffd_mesh_face_count(m) == 13);
        double w[33];
        expected_world(w);
        for (int i = 0; i < 33; i++)
            CHECK_NEAR(ffd_mesh_positions(m)[i], w[i], 0);
        const uint32_t *ix = ffd_mesh_face_indices(m);
        CHECK(ix[0] == 0 && ix[1] == 2 && ix[2] == 1 && ix[36] == 8 && ix[38] == 10);
        CHECK(ffd_mesh_normal_count(m) == 3 && ffd_mesh_normal_anchors(m)[0] == 8);
        CHECK_NEAR(ffd_mesh_normals(m)[2], 1, 0);
        ffd_mesh_info info;
        CHECK_OK(ffd_mesh_compute_info(m, &info, &err));
        ffd_mesh_destroy(m);
    }
    free(g);
    free(text);
}

/* Translation by t in world space: local cube = p + t/2, local triangle = p + t. */
static void translate(ffd_mesh *m, const double t[3])
{
    size_t nv = ffd_mesh_vertex_count(m);
    double *p = malloc(3 * nv * sizeof(double));
    memcpy(p, ffd_mesh_positions(m), 3 * nv * sizeof(double));
    for (size_t i = 0; i < 3 * nv; i++)
        p[i] += t[i % 3];
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
    free(p);
}

static void test_glb_translation(void)
{
    size_t n;
    unsigned char *g = scene_glb(&n);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "s.glb", &m, &err));
    if (!m)
        return;
    static const double t[3] = {1, 2, 3};
    translate(m, t);
    unsigned char *out = NULL;
    size_t on = 0;
    ffd_write_options o = {FFD_FORMAT_GLTF, FFD_ENCODING_SAME};
    CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &on, &err));
    /* Expected: the same JSON with the cube's min/max patched; the BIN chunk
     * with the cube and triangle positions moved; normals and indices kept. */
    char *j1 = replace(scene_json, "\"min\":[-1,-1,-1],\"max\":[1,1,1]",
                       "\"min\":[-0.5,0,0.5],\"max\":[1.5,2,2.5]");
    char *j2 = replace(j1, "\"min\":[0,0,0],\"max\":[1,1,0]", "\"min\":[1,2,3],\"max\":[2,3,3]");
    unsigned char bin[BIN_SIZE];
    scene_bin(bin);
    float cp[24], tp[9];
    for (int i = 0; i < 24; i++)
        cp[i] = cube_p[i] + (float)(t[i % 3] / 2);
    for (int i = 0; i < 9; i++)
        tp[i] = tri_p[i] + (float)t[i % 3];
    memcpy(bin, cp, 96);
    memcpy(bin + 168, tp, 36);
    size_t en;
    unsigned char *expect = make_glb(j2, bin, BIN_SIZE, &en);
    CHECK(on == en && out && memcmp(out, expect, en) == 0);
    if (out && on == en)
        for (size_t i = 0; i < en; i++)
            if (out[i] != expect[i]) {
                fprintf(stderr, "first difference at byte %zu\n", i);
                break;
            }
    /* and it reads back at the translated world positions */
    ffd_mesh *back = NULL;
    CHECK_OK(ffd_mesh_read_memory(out, on, FFD_FORMAT_GLTF, "o.glb", &back, &err));
    if (back) {
        double w[33];
        expected_world(w);
        for (int i = 0; i < 33; i++)
            CHECK_NEAR(ffd_mesh_positions(back)[i], w[i] + t[i % 3], 0);
    }
    ffd_mesh_destroy(back);
    free(expect);
    free(j1);
    free(j2);
    ffd_free(out);
    ffd_mesh_destroy(m);
    free(g);
}

static void test_identity_round_trips(void)
{
    size_t n;
    unsigned char *g = scene_glb(&n);
    char *text = make_embedded(scene_json);
    const void *src[2] = {g, text};
    size_t len[2] = {n, strlen(text)};
    for (int k = 0; k < 2; k++) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        CHECK_OK(ffd_mesh_read_memory(src[k], len[k], FFD_FORMAT_GLTF, "s", &m, &err));
        if (!m)
            continue;
        static const double zero[3] = {0, 0, 0};
        translate(m, zero);
        unsigned char *out = NULL;
        size_t on = 0;
        ffd_write_options o = {FFD_FORMAT_GLTF, FFD_ENCODING_SAME};
        CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &on, &err));
        CHECK(on == len[k] && out && memcmp(out, src[k], on) == 0);
        ffd_free(out);
        ffd_mesh_destroy(m);
    }
    free(g);
    free(text);
}

static void test_embedded_translation(void)
{
    char *text = make_embedded(scene_json);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read_memory(text, strlen(text), FFD_FORMAT_GLTF, "s.gltf", &m, &err));
    if (!m)
        return;
    static const double t[3] = {1, 2, 3};
    translate(m, t);
    unsigned char *out = NULL;
    size_t on = 0;
    ffd_write_options o = {FFD_FORMAT_GLTF, FFD_ENCODING_SAME};
    CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &on, &err));
    unsigned char bin[BIN_SIZE];
    scene_bin(bin);
    for (int i = 0; i < 24; i++) {
        float f = cube_p[i] + (float)(t[i % 3] / 2);
        memcpy(bin + 4 * i, &f, 4);
    }
    for (int i = 0; i < 9; i++) {
        float f = tri_p[i] + (float)t[i % 3];
        memcpy(bin + 168 + 4 * i, &f, 4);
    }
    char *b64 = base64(bin, BIN_SIZE);
    char *uri = malloc(strlen(b64) + 64);
    sprintf(uri, ",\"uri\":\"data:application/octet-stream;base64,%s\"", b64);
    char *j0 = replace(scene_json, "URI", uri);
    char *j1 = replace(j0, "\"min\":[-1,-1,-1],\"max\":[1,1,1]",
                       "\"min\":[-0.5,0,0.5],\"max\":[1.5,2,2.5]");
    char *j2 = replace(j1, "\"min\":[0,0,0],\"max\":[1,1,0]", "\"min\":[1,2,3],\"max\":[2,3,3]");
    CHECK(out && on == strlen(j2) && memcmp(out, j2, on) == 0);
    free(b64);
    free(uri);
    free(j0);
    free(j1);
    free(j2);
    ffd_free(out);
    ffd_mesh_destroy(m);
    free(text);
}

static void write_file(const char *path, const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (!f)
        return;
    CHECK(fwrite(p, 1, n, f) == n);
    fclose(f);
}

static unsigned char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long l = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *p = malloc((size_t)l + 1);
    *n = fread(p, 1, (size_t)l, f);
    fclose(f);
    return p;
}

/* External .bin: the .gltf and its .bin written next to the output; the
 * source's own .bin is never replaced by a write elsewhere in its directory. */
static void test_external_buffer(void)
{
    char dir[] = "/tmp/ffd_gltf_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char in[96], bin_path[96], sub[96], out[96], out_bin[96], side[96];
    snprintf(in, sizeof in, "%s/scene.gltf", dir);
    snprintf(bin_path, sizeof bin_path, "%s/cube%%20data.bin", dir);
    snprintf(sub, sizeof sub, "%s/out", dir);
    snprintf(out, sizeof out, "%s/out/moved.gltf", dir);
    snprintf(out_bin, sizeof out_bin, "%s/out/cube%%20data.bin", dir);
    snprintf(side, sizeof side, "%s/side.gltf", dir);
    CHECK(mkdir(sub, 0700) == 0);
    char *json = replace(scene_json, "URI", ",\"uri\":\"cube%20data.bin\"");
    unsigned char bin[BIN_SIZE];
    scene_bin(bin);
    char real_bin[96];
    snprintf(real_bin, sizeof real_bin, "%s/cube data.bin", dir);
    write_file(in, json, strlen(json));
    write_file(real_bin, bin, BIN_SIZE);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read(in, &m, &err));
    if (m) {
        CHECK(ffd_mesh_vertex_count(m) == 11);
        /* untouched: both files byte for byte */
        CHECK_OK(ffd_mesh_write(m, out, NULL, &err));
        size_t n1 = 0, n2 = 0;
        unsigned char *a = slurp(out, &n1);
        snprintf(out_bin, sizeof out_bin, "%s/out/cube data.bin", dir);
        unsigned char *b = slurp(out_bin, &n2);
        CHECK(a && n1 == strlen(json) && memcmp(a, json, n1) == 0);
        CHECK(b && n2 == BIN_SIZE && memcmp(b, bin, n2) == 0);
        free(a);
        free(b);
        /* moved: the .bin next to the output holds the new local positions */
        static const double t[3] = {1, 2, 3};
        translate(m, t);
        CHECK_OK(ffd_mesh_write(m, out, NULL, &err));
        b = slurp(out_bin, &n2);
        float f;
        CHECK(b && n2 == BIN_SIZE);
        if (b) {
            memcpy(&f, b, 4);
            CHECK(f == -0.5f);
            memcpy(&f, b + 168 + 8, 4);
            CHECK(f == 3.0f);
            CHECK(memcmp(b + 96, bin + 96, 72) == 0);
        }
        free(b);
        /* a .gltf beside the source would replace the source's .bin: refused */
        CHECK(ffd_mesh_write(m, side, NULL, &err) == FFD_ERR_UNSUPPORTED);
        CHECK(strstr(err.message, "would replace the source's buffer") != NULL);
        CHECK(access(side, F_OK) != 0);
        b = slurp(real_bin, &n2);
        CHECK(b && n2 == BIN_SIZE && memcmp(b, bin, BIN_SIZE) == 0);
        free(b);
        /* .gltf to .glb is refused (no transcoding) */
        char glb[96];
        snprintf(glb, sizeof glb, "%s/out/x.glb", dir);
        CHECK(ffd_mesh_write(m, glb, NULL, &err) == FFD_ERR_UNSUPPORTED);
        /* in memory the external buffer becomes a data: URI that reads alone */
        unsigned char *mem = NULL;
        size_t mn = 0;
        ffd_write_options o = {FFD_FORMAT_GLTF, FFD_ENCODING_SAME};
        CHECK_OK(ffd_mesh_write_memory(m, &o, &mem, &mn, &err));
        ffd_mesh *back = NULL;
        CHECK_OK(ffd_mesh_read_memory(mem, mn, FFD_FORMAT_GLTF, "/nonexistent/x.gltf", &back, &err));
        if (back)
            for (size_t i = 0; i < 33; i++)
                CHECK_NEAR(ffd_mesh_positions(back)[i], ffd_mesh_positions(m)[i], 0);
        ffd_mesh_destroy(back);
        ffd_free(mem);
        unlink(glb);
    }
    ffd_mesh_destroy(m);
    /* from memory, an external buffer is not looked for beside the name */
    CHECK(ffd_mesh_read_memory(json, strlen(json), FFD_FORMAT_GLTF, in, &m, &err) ==
          FFD_ERR_UNSUPPORTED);
    CHECK(!m && strstr(err.message, "external buffer \"cube%20data.bin\" in a glTF read from memory"));
    /* missing buffer file */
    unlink(real_bin);
    CHECK(ffd_mesh_read(in, &m, &err) == FFD_ERR_IO);
    CHECK(!m && strstr(err.message, "$.buffers[0].uri"));
    unlink(out);
    unlink(out_bin);
    rmdir(sub);
    unlink(in);
    rmdir(dir);
    free(json);
}

/* Normals follow the deformed triangle (area-weighted recompute), in local
 * space, unit length. A shear z += x in world space. */
static void test_normals(void)
{
    size_t n;
    unsigned char *g = scene_glb(&n);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "s.glb", &m, &err));
    if (!m)
        return;
    double p[33];
    memcpy(p, ffd_mesh_positions(m), sizeof p);
    for (int v = 8; v < 11; v++)
        p[3 * v + 2] += p[3 * v] - 10;
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, &err));
    unsigned char *out = NULL;
    size_t on = 0;
    ffd_write_options o = {FFD_FORMAT_GLTF, FFD_ENCODING_SAME};
    CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &on, &err));
    /* the JSON chunk is unchanged in length here (triangle max z 0 -> 1) */
    size_t jl = rd32(out + 12), bin = 20 + jl + 8;
    float nl[9], pl[9];
    memcpy(nl, out + bin + 204, 36);
    memcpy(pl, out + bin + 168, 36);
    /* local triangle (0,0,0) (1,0,1) (0,1,0): normal (-1,0,1)/sqrt2 */
    for (int v = 0; v < 3; v++) {
        CHECK_NEAR(nl[3 * v], -1 / sqrt(2), 1e-7);
        CHECK_NEAR(nl[3 * v + 1], 0, 1e-7);
        CHECK_NEAR(nl[3 * v + 2], 1 / sqrt(2), 1e-7);
    }
    CHECK(pl[5] == 1.0f);
    CHECK(strstr((char *)out + 20, "\"min\":[0,0,0],\"max\":[1,1,1]") != NULL);
    ffd_free(out);
    ffd_mesh_destroy(m);
    free(g);
}

/* Strip and fan modes, a primitive without indices, u8 and u32 indices,
 * two instances of a mesh with the same world transform sharing vertices,
 * a scene-less file (all root nodes). */
static void test_modes_and_instances(void)
{
    ffd_error err = {{0}};
    /* the triangle as a strip and as a fan: one face each */
    CHECK_OK(read_glb_variant("\"NORMAL\":3}}", "\"NORMAL\":3},\"mode\":5}", &err));
    CHECK_OK(read_glb_variant("\"NORMAL\":3}}", "\"NORMAL\":3},\"mode\":6}", &err));
    /* a second instance with the same world transform adds nothing */
    unsigned char bin[BIN_SIZE];
    scene_bin(bin);
    char *j = replace(scene_json, "\"children\":[1,2]", "\"children\":[1,2,3]");
    char *j2 = replace(j, "{\"name\":\"tri\"", "{\"mesh\":0,\"translation\":[0,1,0]},{\"name\":\"tri\"");
    /* nodes: parent, cube, the new instance, tri */
    size_t n;
    unsigned char *g = make_glb(j2, bin, BIN_SIZE, &n);
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "i.glb", &m, &err));
    CHECK(m && ffd_mesh_vertex_count(m) == 11 && ffd_mesh_face_count(m) == 25);
    ffd_mesh_destroy(m);
    free(g);
    free(j);
    free(j2);
    /* no scene: every root node */
    char *ns = replace(scene_json, "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],", "");
    g = make_glb(ns, bin, BIN_SIZE, &n);
    CHECK_OK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "n.glb", &m, &err));
    CHECK(m && ffd_mesh_vertex_count(m) == 11);
    ffd_mesh_destroy(m);
    free(g);
    free(ns);
}

static void check_refused(const char *from, const char *to, ffd_status want, const char *msg)
{
    ffd_error err = {{0}};
    ffd_status st = read_glb_variant(from, to, &err);
    CHECK(st == want);
    if (!strstr(err.message, msg) || !strstr(err.message, "v.glb: ")) {
        fprintf(stderr, "  replacing %s: got \"%s\", expected \"%s\"\n", from, err.message, msg);
        check_failures++;
    }
}

static void test_refusals(void)
{
    check_refused("\"componentType\":5126,\"count\":8", "\"componentType\":5123,\"count\":8",
                  FFD_ERR_UNSUPPORTED, "$.accessors[0]: POSITION must be FLOAT (5126) VEC3");
    check_refused("\"count\":8,\"type\":\"VEC3\"", "\"count\":8,\"type\":\"VEC4\"",
                  FFD_ERR_UNSUPPORTED, "POSITION must be FLOAT");
    check_refused("\"count\":8,", "\"count\":8,\"sparse\":{\"count\":1},", FFD_ERR_UNSUPPORTED,
                  "$.accessors[0]: sparse accessor");
    check_refused("\"scene\":0", "\"extensionsUsed\":[\"KHR_draco_mesh_compression\"],\"scene\":0",
                  FFD_ERR_UNSUPPORTED, "$.extensionsUsed[0]: KHR_draco_mesh_compression");
    check_refused("\"scene\":0", "\"extensionsRequired\":[\"x\",\"EXT_meshopt_compression\"],\"scene\":0",
                  FFD_ERR_UNSUPPORTED, "$.extensionsRequired[1]: EXT_meshopt_compression");
    check_refused("\"scene\":0", "\"extensionsUsed\":[\"KHR_mesh_quantization\"],\"scene\":0",
                  FFD_ERR_UNSUPPORTED, "KHR_mesh_quantization");
    check_refused("\"material\":0}", "\"material\":0,\"extensions\":{\"KHR_draco_mesh_compression\":{}}}",
                  FFD_ERR_UNSUPPORTED, "$.meshes[0].primitives[0].extensions");
    check_refused("\"children\":[1,2]", "\"children\":[1,2,3]", FFD_ERR_PARSE,
                  "node index 3 out of range");
    check_refused("\"matrix\":[", "\"children\":[0],\"matrix\":[", FFD_ERR_PARSE, "cycle");
    check_refused("\"NORMAL\":3}}", "\"NORMAL\":3},\"mode\":1}", FFD_ERR_UNSUPPORTED,
                  "$.meshes[1].primitives[0].mode 1: only triangle modes");
    check_refused("\"count\":8,", "\"count\":9,", FFD_ERR_PARSE,
                  "$.accessors[0]: 9 elements from byte 0 need 108 bytes, bufferView 0 has 96");
    check_refused("\"byteOffset\":204,\"byteLength\":36", "\"byteOffset\":208,\"byteLength\":36",
                  FFD_ERR_PARSE, "$.bufferViews[3]: bytes 208..244 past the end of buffer 0");
    check_refused("\"byteOffset\":0,\"byteLength\":96}", "\"byteOffset\":0,\"byteLength\":96,\"byteStride\":8}",
                  FFD_ERR_PARSE, "byteStride 8 is less than the element");
    check_refused("\"count\":8,", "\"count\":4294967296,", FFD_ERR_PARSE,
                  "$.accessors[0].count: expected an integer in [1, 4294967295)");
    check_refused("\"byteLength\":240", "\"byteLength\":244", FFD_ERR_PARSE,
                  "$.buffers[0].byteLength 244 exceeds the BIN chunk (240 bytes)");
    check_refused("\"version\":\"2.0\"", "\"version\":\"1.0\"", FFD_ERR_UNSUPPORTED,
                  "$.asset.version");
    check_refused("\"translation\":[0,1,0]", "\"scale\":[0,1,1]", FFD_ERR_UNSUPPORTED,
                  "$.nodes[1]: singular world transform");
    /* a mesh instanced under two different transforms shares one POSITION accessor */
    check_refused("\"children\":[1,2]", "\"children\":[1,2,0]", FFD_ERR_PARSE, "cycle");
    unsigned char bin[BIN_SIZE];
    scene_bin(bin);
    char *j = replace(scene_json, "\"nodes\":[0]}]", "\"nodes\":[0,1]}]");
    size_t n;
    unsigned char *g = make_glb(j, bin, BIN_SIZE, &n);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "v.glb", &m, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(!m && strstr(err.message, "$.accessors[0]: POSITION shared by instances with different "
                                    "world transforms (node 1)"));
    free(g);
    free(j);
    /* an index out of range */
    scene_bin(bin);
    bin[96] = 8;
    g = make_glb(scene_json, bin, BIN_SIZE, &n);
    CHECK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "v.glb", &m, &err) == FFD_ERR_PARSE);
    CHECK(!m && strstr(err.message, "$.accessors[1]: index 8 of element 0 out of range (8 vertices)"));
    free(g);
    /* bad base64 */
    char *t = make_embedded(scene_json);
    char *b = strstr(t, "base64,");
    b[20] = '*';
    CHECK(ffd_mesh_read_memory(t, strlen(t), FFD_FORMAT_GLTF, "e.gltf", &m, &err) == FFD_ERR_PARSE);
    CHECK(!m && strstr(err.message, "e.gltf: $.buffers[0].uri: character 13 of the base64 data"));
    free(t);
    /* invalid JSON: byte offset */
    static const char broken[] = "{\"asset\":{\"version\":\"2.0\"},\n \"nodes\":[}";
    CHECK(ffd_mesh_read_memory(broken, sizeof broken - 1, FFD_FORMAT_GLTF, "b.gltf", &m, &err) ==
          FFD_ERR_PARSE);
    CHECK(!m && strstr(err.message, "b.gltf: byte "));
}

static void test_glb_container(void)
{
    size_t n;
    unsigned char *g = scene_glb(&n);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    /* every truncated prefix fails cleanly */
    for (size_t k = 0; k < n; k++) {
        ffd_status st = ffd_mesh_read_memory(g, k, FFD_FORMAT_GLTF, "t.glb", &m, &err);
        CHECK(st != FFD_OK && !m);
    }
    unsigned char *c = malloc(n);
    memcpy(c, g, n);
    le32(c + 12, (uint32_t)n);
    CHECK(ffd_mesh_read_memory(c, n, FFD_FORMAT_GLTF, "t.glb", &m, &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "t.glb: byte 12: JSON chunk length"));
    memcpy(c, g, n);
    size_t jl = rd32(g + 12);
    le32(c + 20 + jl, 1000);
    CHECK(ffd_mesh_read_memory(c, n, FFD_FORMAT_GLTF, "t.glb", &m, &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "BIN chunk length 1000 past the end"));
    memcpy(c, g, n);
    le32(c + 4, 1);
    CHECK(ffd_mesh_read_memory(c, n, FFD_FORMAT_GLTF, "t.glb", &m, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "t.glb: byte 4: GLB version 1"));
    free(c);
    free(g);
}

/* Refinement cannot keep every vertex attribute: refused, naming the format. */
static void test_refine_refused(void)
{
    size_t n;
    unsigned char *g = scene_glb(&n);
    ffd_mesh *m = NULL, *out = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "s.glb", &m, &err));
    if (m) {
        uint32_t par[13];
        for (int f = 0; f < 13; f++)
            par[f] = (uint32_t)f;
        ffd_refine_plan plan = {0, NULL, 13, m->face_offsets, m->face_indices, par};
        CHECK(ffd_mesh_refine(m, &plan, &out, &err) == FFD_ERR_UNSUPPORTED);
        CHECK(!out && strstr(err.message, "glTF: refinement is not supported"));
    }
    ffd_mesh_destroy(m);
    free(g);
}

/* From data (another format): a .glb and a .gltf that read back. */
static void test_write_from_data(void)
{
    static const double P[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0.5};
    static const uint32_t off[2] = {0, 4}, idx[4] = {0, 1, 2, 3};
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK_OK(ffd_mesh_create(P, 4, off, idx, 1, &m, &err));
    for (int enc = FFD_ENCODING_ASCII; enc <= FFD_ENCODING_BINARY_LE; enc++) {
        ffd_write_options o = {FFD_FORMAT_GLTF, (ffd_encoding)enc};
        unsigned char *d = NULL;
        size_t n = 0;
        CHECK_OK(ffd_mesh_write_memory(m, &o, &d, &n, &err));
        ffd_mesh *back = NULL;
        CHECK_OK(ffd_mesh_read_memory(d, n, FFD_FORMAT_GLTF, "w", &back, &err));
        CHECK(back && ffd_mesh_vertex_count(back) == 4 && ffd_mesh_face_count(back) == 2);
        if (back)
            for (int i = 0; i < 12; i++)
                CHECK_NEAR(ffd_mesh_positions(back)[i], P[i], 0);
        ffd_mesh_destroy(back);
        ffd_free(d);
    }
    ffd_mesh_destroy(m);
}

/* The fixtures in tests/data/mesh read and write back byte for byte. */
static void test_fixtures(void)
{
    static const char *const files[] = {FIX "cube_nodes.glb", FIX "cube_nodes.gltf",
                                        FIX "cube_embedded.gltf"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        CHECK_OK(ffd_mesh_read(files[i], &m, &err));
        if (!m)
            continue;
        unsigned char *out = NULL;
        size_t on = 0, sn = 0;
        ffd_write_options o = {FFD_FORMAT_GLTF, FFD_ENCODING_SAME};
        CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &on, &err));
        unsigned char *src = slurp(files[i], &sn);
        if (strstr(files[i], "cube_nodes.gltf") == NULL)
            CHECK(out && src && on == sn && memcmp(out, src, sn) == 0);
        free(src);
        ffd_free(out);
        ffd_mesh_destroy(m);
    }
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"world_positions", test_world_positions},
        {"glb_translation", test_glb_translation},
        {"identity_round_trips", test_identity_round_trips},
        {"embedded_translation", test_embedded_translation},
        {"external_buffer", test_external_buffer},
        {"normals", test_normals},
        {"modes_and_instances", test_modes_and_instances},
        {"refusals", test_refusals},
        {"glb_container", test_glb_container},
        {"refine_refused", test_refine_refused},
        {"write_from_data", test_write_from_data},
        {"fixtures", test_fixtures},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
