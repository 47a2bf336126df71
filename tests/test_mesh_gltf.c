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
#include <stdbool.h>
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

/* json with the "URI" placeholder replaced by bin as a data: URI. */
static char *with_data_uri(const char *json_with_uri, const unsigned char *bin, size_t n)
{
    char *b64 = base64(bin, n);
    char *uri = malloc(strlen(b64) + 64);
    sprintf(uri, ",\"uri\":\"data:application/octet-stream;base64,%s\"", b64);
    char *j = replace(json_with_uri, "URI", uri);
    free(b64);
    free(uri);
    return j;
}

/* A test scene: JSON text with a "URI" placeholder for its one buffer. */
typedef struct scene {
    const char *json;
    size_t bin_size;
    void (*fill)(unsigned char *bin);
} scene;

static const scene cube_scene = {scene_json, BIN_SIZE, scene_bin};

/* The tangent scene: a 3 x 3 grid in the plane z = 0 (8 triangles, u16
 * indices) with NORMAL (0,0,1) and TANGENT (cos a, sin a, 0, +-1), under a
 * node with T R S (rotation 30 degrees about x, scale (2,1,0.5)) below a
 * parent turned 90 degrees about z. Buffer: positions at 0, normals at
 * 108, tangents at 216, indices at 360; 408 bytes. */
#define TAN_BIN_SIZE 408
#define TAN_AT 216
static const char tangent_json[] =
    "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\n"
    " \"nodes\":[{\"name\":\"turn\",\"rotation\":[0,0,0.7071067811865476,0.7071067811865476],"
    "\"children\":[1]},\n"
    "  {\"name\":\"grid\",\"mesh\":0,\"translation\":[1,2,3],"
    "\"rotation\":[0.25881904510252074,0,0,0.9659258262890683],\"scale\":[2,1,0.5]}],\n"
    " \"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TANGENT\":2},"
    "\"indices\":3}]}],\n"
    " \"accessors\":[\n"
    "  {\"bufferView\":0,\"componentType\":5126,\"count\":9,\"type\":\"VEC3\",\"min\":[-1,-1,0],"
    "\"max\":[1,1,0]},\n"
    "  {\"bufferView\":1,\"componentType\":5126,\"count\":9,\"type\":\"VEC3\"},\n"
    "  {\"bufferView\":2,\"componentType\":5126,\"count\":9,\"type\":\"VEC4\"},\n"
    "  {\"bufferView\":3,\"componentType\":5123,\"count\":24,\"type\":\"SCALAR\"}],\n"
    " \"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":108},\n"
    "  {\"buffer\":0,\"byteOffset\":108,\"byteLength\":108},\n"
    "  {\"buffer\":0,\"byteOffset\":216,\"byteLength\":144},\n"
    "  {\"buffer\":0,\"byteOffset\":360,\"byteLength\":48}],\n"
    " \"buffers\":[{\"byteLength\":408URI}]}";

/* Local tangent of grid vertex k (float values, as stored). */
static void grid_tangent(int k, float t[4])
{
    double a = 0.3 + 0.7 * k;
    t[0] = (float)cos(a);
    t[1] = (float)sin(a);
    t[2] = 0;
    t[3] = k % 2 ? -1.0f : 1.0f;
}

static void tangent_bin(unsigned char *b)
{
    for (int k = 0; k < 9; k++) {
        float p[3] = {(float)(k % 3) - 1, (float)(k / 3) - 1, 0}, n[3] = {0, 0, 1}, t[4];
        grid_tangent(k, t);
        memcpy(b + 12 * k, p, 12);
        memcpy(b + 108 + 12 * k, n, 12);
        memcpy(b + TAN_AT + 16 * k, t, 16);
    }
    for (int r = 0, f = 0; r < 2; r++)
        for (int c = 0; c < 2; c++, f++) {
            uint16_t a = (uint16_t)(3 * r + c);
            uint16_t tri[6] = {a, (uint16_t)(a + 1), (uint16_t)(a + 4),
                               a, (uint16_t)(a + 4), (uint16_t)(a + 3)};
            memcpy(b + 360 + 12 * f, tri, 12);
        }
}

static const scene tangent_scene = {tangent_json, TAN_BIN_SIZE, tangent_bin};

/* The scene as .glb, with json (NULL: the scene's own). */
static unsigned char *glb_of(const scene *sc, const char *json, size_t *size)
{
    unsigned char *bin = calloc(1, sc->bin_size);
    sc->fill(bin);
    unsigned char *g = make_glb(json ? json : sc->json, bin, sc->bin_size, size);
    free(bin);
    return g;
}

/* The scene as .gltf text with its buffer in a data: URI. */
static char *embedded_of(const scene *sc)
{
    unsigned char *bin = calloc(1, sc->bin_size);
    sc->fill(bin);
    char *j = with_data_uri(sc->json, bin, sc->bin_size);
    free(bin);
    return j;
}

static unsigned char *scene_glb(size_t *size)
{
    return glb_of(&cube_scene, NULL, size);
}

/* Reads the scene's .glb with the first from in its JSON replaced by to. */
static ffd_status read_variant(const scene *sc, const char *from, const char *to, ffd_error *err)
{
    char *j = replace(sc->json, from, to);
    size_t n;
    unsigned char *g = glb_of(sc, j, &n);
    ffd_mesh *m = NULL;
    ffd_status st = ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "v.glb", &m, err);
    CHECK((st == FFD_OK) == (m != NULL));
    ffd_mesh_destroy(m);
    free(g);
    free(j);
    return st;
}

static ffd_status read_glb_variant(const char *from, const char *to, ffd_error *err)
{
    return read_variant(&cube_scene, from, to, err);
}

/* The glTF in data read (a failed CHECK and NULL when it is refused). */
static ffd_mesh *read_ok(const void *data, size_t n, const char *name)
{
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    ffd_status st = ffd_mesh_read_memory(data, n, FFD_FORMAT_GLTF, name, &m, &err);
    if (st != FFD_OK)
        fprintf(stderr, "  %s\n", err.message);
    CHECK(st == FFD_OK && m);
    return m;
}

/* m written back as glTF of its own kind (a failed CHECK and NULL on error). */
static unsigned char *write_same(const ffd_mesh *m, size_t *n)
{
    unsigned char *out = NULL;
    ffd_error err = {{0}};
    ffd_write_options o = {FFD_FORMAT_GLTF, FFD_ENCODING_SAME, 0};
    *n = 0;
    CHECK_OK(ffd_mesh_write_memory(m, &o, &out, n, &err));
    return out;
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
    char *text = embedded_of(&cube_scene);
    for (int kind = 0; kind < 2; kind++) {
        ffd_error err = {{0}};
        ffd_mesh *m = kind == 0 ? read_ok(g, n, "s.glb") : read_ok(text, strlen(text), "s.gltf");
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

/* What the scene written after translate(t) holds: the JSON (returned,
 * still with its "URI" placeholder) with the POSITION min/max patched, and
 * bin with the cube and triangle positions moved in local space; normals
 * and indices kept. */
static char *translated_scene(const double t[3], unsigned char bin[BIN_SIZE])
{
    scene_bin(bin);
    for (int i = 0; i < 24; i++) {
        float f = cube_p[i] + (float)(t[i % 3] / 2);
        memcpy(bin + 4 * i, &f, 4);
    }
    for (int i = 0; i < 9; i++) {
        float f = tri_p[i] + (float)t[i % 3];
        memcpy(bin + 168 + 4 * i, &f, 4);
    }
    char *j1 = replace(scene_json, "\"min\":[-1,-1,-1],\"max\":[1,1,1]",
                       "\"min\":[-0.5,0,0.5],\"max\":[1.5,2,2.5]");
    char *j2 = replace(j1, "\"min\":[0,0,0],\"max\":[1,1,0]", "\"min\":[1,2,3],\"max\":[2,3,3]");
    free(j1);
    return j2;
}

static void test_glb_translation(void)
{
    size_t n;
    unsigned char *g = scene_glb(&n);
    ffd_mesh *m = read_ok(g, n, "s.glb");
    free(g);
    if (!m)
        return;
    static const double t[3] = {1, 2, 3};
    translate(m, t);
    size_t on;
    unsigned char *out = write_same(m, &on);
    unsigned char bin[BIN_SIZE];
    char *j = translated_scene(t, bin);
    size_t en;
    unsigned char *expect = make_glb(j, bin, BIN_SIZE, &en);
    CHECK(on == en && out && memcmp(out, expect, en) == 0);
    if (out && on == en)
        for (size_t i = 0; i < en; i++)
            if (out[i] != expect[i]) {
                fprintf(stderr, "first difference at byte %zu\n", i);
                break;
            }
    /* and it reads back at the translated world positions */
    ffd_mesh *back = read_ok(out, on, "o.glb");
    if (back) {
        double w[33];
        expected_world(w);
        for (int i = 0; i < 33; i++)
            CHECK_NEAR(ffd_mesh_positions(back)[i], w[i] + t[i % 3], 0);
    }
    ffd_mesh_destroy(back);
    free(expect);
    free(j);
    ffd_free(out);
    ffd_mesh_destroy(m);
}

/* Untouched (same positions, without and with identity Jacobians): the
 * .glb and the embedded .gltf of both scenes come back byte for byte. */
static void test_identity_round_trips(void)
{
    const scene *scenes[2] = {&cube_scene, &tangent_scene};
    for (int k = 0; k < 4; k++) {
        size_t n;
        unsigned char *src =
            k % 2 ? (unsigned char *)embedded_of(scenes[k / 2]) : glb_of(scenes[k / 2], NULL, &n);
        if (k % 2)
            n = strlen((char *)src);
        ffd_mesh *m = read_ok(src, n, k % 2 ? "s.gltf" : "s.glb");
        if (m) {
            static const double zero[3] = {0, 0, 0};
            translate(m, zero);
            size_t nv = ffd_mesh_vertex_count(m);
            double *J = calloc(9 * nv, sizeof *J);
            for (size_t v = 0; v < nv; v++)
                J[9 * v] = J[9 * v + 4] = J[9 * v + 8] = 1;
            CHECK_OK(ffd_mesh_set_positions(m, ffd_mesh_positions(m), J, NULL));
            free(J);
            size_t on;
            unsigned char *out = write_same(m, &on);
            CHECK(on == n && out && memcmp(out, src, on) == 0);
            ffd_free(out);
        }
        ffd_mesh_destroy(m);
        free(src);
    }
}

static void test_embedded_translation(void)
{
    char *text = embedded_of(&cube_scene);
    ffd_mesh *m = read_ok(text, strlen(text), "s.gltf");
    free(text);
    if (!m)
        return;
    static const double t[3] = {1, 2, 3};
    translate(m, t);
    size_t on;
    unsigned char *out = write_same(m, &on);
    unsigned char bin[BIN_SIZE];
    char *j = translated_scene(t, bin);
    char *expect = with_data_uri(j, bin, BIN_SIZE);
    CHECK(out && on == strlen(expect) && memcmp(out, expect, on) == 0);
    free(j);
    free(expect);
    ffd_free(out);
    ffd_mesh_destroy(m);
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
        size_t mn;
        unsigned char *mem = write_same(m, &mn);
        ffd_mesh *back = read_ok(mem, mn, "/nonexistent/x.gltf");
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
    ffd_mesh *m = read_ok(g, n, "s.glb");
    free(g);
    if (!m)
        return;
    ffd_error err = {{0}};
    double p[33];
    memcpy(p, ffd_mesh_positions(m), sizeof p);
    for (int v = 8; v < 11; v++)
        p[3 * v + 2] += p[3 * v] - 10;
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, &err));
    size_t on;
    unsigned char *out = write_same(m, &on);
    if (!out) {
        ffd_mesh_destroy(m);
        return;
    }
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
    char *j = replace(scene_json, "\"children\":[1,2]", "\"children\":[1,2,3]");
    char *j2 = replace(j, "{\"name\":\"tri\"", "{\"mesh\":0,\"translation\":[0,1,0]},{\"name\":\"tri\"");
    /* nodes: parent, cube, the new instance, tri */
    size_t n;
    unsigned char *g = glb_of(&cube_scene, j2, &n);
    ffd_mesh *m = read_ok(g, n, "i.glb");
    CHECK(m && ffd_mesh_vertex_count(m) == 11 && ffd_mesh_face_count(m) == 25);
    ffd_mesh_destroy(m);
    free(g);
    free(j);
    free(j2);
    /* no scene: every root node */
    char *ns = replace(scene_json, "\"scene\":0,\"scenes\":[{\"nodes\":[0]}],", "");
    g = glb_of(&cube_scene, ns, &n);
    m = read_ok(g, n, "n.glb");
    CHECK(m && ffd_mesh_vertex_count(m) == 11);
    ffd_mesh_destroy(m);
    free(g);
    free(ns);
}

static void check_refused_in(const scene *sc, const char *from, const char *to, ffd_status want,
                             const char *msg)
{
    ffd_error err = {{0}};
    ffd_status st = read_variant(sc, from, to, &err);
    CHECK(st == want);
    if (!strstr(err.message, msg) || !strstr(err.message, "v.glb: ")) {
        fprintf(stderr, "  replacing %s: got \"%s\", expected \"%s\"\n", from, err.message, msg);
        check_failures++;
    }
}

static void check_refused(const char *from, const char *to, ffd_status want, const char *msg)
{
    check_refused_in(&cube_scene, from, to, want, msg);
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
    char *j = replace(scene_json, "\"nodes\":[0]}]", "\"nodes\":[0,1]}]");
    size_t n;
    unsigned char *g = glb_of(&cube_scene, j, &n);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "v.glb", &m, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(!m && strstr(err.message, "$.accessors[0]: POSITION shared by instances with different "
                                    "world transforms (node 1)"));
    free(g);
    free(j);
    /* an index out of range */
    unsigned char bin[BIN_SIZE];
    scene_bin(bin);
    bin[96] = 8;
    g = make_glb(scene_json, bin, BIN_SIZE, &n);
    CHECK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "v.glb", &m, &err) == FFD_ERR_PARSE);
    CHECK(!m && strstr(err.message, "$.accessors[1]: index 8 of element 0 out of range (8 vertices)"));
    free(g);
    /* bad base64 */
    char *t = embedded_of(&cube_scene);
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

/* ---------------------------------------------------------------------- */
/* Tangents */

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* t with its component along n removed, unit length (Gram-Schmidt). */
static void orthonormal_to(const double *t, const double *n, double out[3])
{
    double c = dot3(t, n) / dot3(n, n);
    for (int k = 0; k < 3; k++)
        out[k] = t[k] - c * n[k];
    double l = sqrt(dot3(out, out));
    for (int k = 0; k < 3; k++)
        out[k] /= l;
}

/* Read: tangents in world space by the nodes' linear part (computed here
 * from the angles: parent Rz(90), node Rx(30) S(2,1,0.5)), renormalised,
 * w kept; the normal by the inverse transpose, so the two stay orthogonal. */
static void test_tangent_world_frame(void)
{
    size_t n;
    unsigned char *g = glb_of(&tangent_scene, NULL, &n);
    ffd_mesh *m = read_ok(g, n, "t.glb");
    free(g);
    if (!m)
        return;
    CHECK(m->tangent_count == 9 && m->normal_count == 9);
    double c30 = sqrt(3) / 2, s30 = 0.5;
    for (size_t k = 0; k < m->tangent_count && k < 9; k++) {
        float t[4];
        grid_tangent((int)k, t);
        /* S: (2x, y, 0); Rx(30): (x, y c, y s); Rz(90): (-y, x, z) */
        double w[3] = {-(double)t[1] * c30, 2.0 * t[0], (double)t[1] * s30};
        double l = sqrt(dot3(w, w));
        const double *T = m->tangents + 4 * k, *N = m->normals + 3 * k;
        CHECK(m->tangent_anchors[k] == k);
        for (int d = 0; d < 3; d++)
            CHECK_NEAR(T[d], w[d] / l, 1e-12);
        CHECK(T[3] == t[3]);
        CHECK_NEAR(N[0], s30, 1e-12);
        CHECK_NEAR(N[1], 0, 1e-12);
        CHECK_NEAR(N[2], c30, 1e-12);
        CHECK_NEAR(dot3(T, N), 0, 1e-12);
    }
    ffd_mesh_destroy(m);
}

/* The Jacobian of the lattice map at p by central differences of the
 * deformed positions of p +- h e_d (bound and evaluated as points, not with
 * ffd_lattice_jacobian): row-major, d(x'_r)/d(x_d) at [3r + d]. */
static void finite_difference_jacobian(const ffd_lattice *lat, const double *p, size_t nv, double h,
                                       double *J)
{
    double *q = malloc(6 * 3 * nv * sizeof *q), *f = malloc(6 * 3 * nv * sizeof *f);
    for (size_t v = 0; v < nv; v++)
        for (int d = 0; d < 3; d++)
            for (int sgn = 0; sgn < 2; sgn++) {
                double *x = q + 3 * (6 * v + 2 * (size_t)d + (size_t)sgn);
                memcpy(x, p + 3 * v, 3 * sizeof *x);
                x[d] += sgn ? -h : h;
            }
    ffd_lattice_binding *b = NULL;
    CHECK_OK(ffd_lattice_bind(lat, q, 6 * nv, FFD_OUTSIDE_FIXED, &b, NULL));
    CHECK_OK(ffd_lattice_eval(lat, b, f, NULL));
    for (size_t v = 0; v < nv; v++)
        for (int d = 0; d < 3; d++)
            for (int r = 0; r < 3; r++)
                J[9 * v + 3 * (size_t)r + (size_t)d] =
                    (f[3 * (6 * v + 2 * (size_t)d) + (size_t)r] -
                     f[3 * (6 * v + 2 * (size_t)d + 1) + (size_t)r]) /
                    (2 * h);
    ffd_lattice_binding_destroy(b);
    free(q);
    free(f);
}

/* A lattice deformation of a mesh: the lattice, the deformed positions
 * and their Jacobians. */
typedef struct deformation {
    ffd_lattice *lat;
    double *out, *jac;
} deformation;

/* A Bernstein lattice (3x3x3, two control points moved) around the mesh's
 * world positions; release with deformation_free. */
static deformation lattice_deform(const ffd_mesh *m)
{
    size_t nv = ffd_mesh_vertex_count(m);
    deformation d = {NULL, malloc(3 * nv * sizeof(double)), malloc(9 * nv * sizeof(double))};
    ffd_box box;
    CHECK_OK(ffd_box_fit(ffd_mesh_positions(m), nv, 0.25, &box, NULL));
    CHECK_OK(ffd_lattice_create(FFD_BASIS_BERNSTEIN, &box, (uint32_t[3]){3, 3, 3}, &d.lat, NULL));
    CHECK_OK(ffd_lattice_move(d.lat, (uint32_t[3]){1, 1, 1}, (double[3]){0.3, -0.2, 0.4}, NULL));
    CHECK_OK(ffd_lattice_move(d.lat, (uint32_t[3]){2, 0, 1}, (double[3]){0.1, 0.2, -0.3}, NULL));
    ffd_lattice_binding *b = NULL;
    CHECK_OK(ffd_lattice_bind(d.lat, ffd_mesh_positions(m), nv, FFD_OUTSIDE_FIXED, &b, NULL));
    CHECK_OK(ffd_lattice_eval(d.lat, b, d.out, NULL));
    CHECK_OK(ffd_lattice_jacobian(d.lat, b, d.jac, NULL));
    ffd_lattice_binding_destroy(b);
    return d;
}

static void deformation_free(deformation *d)
{
    ffd_lattice_destroy(d->lat);
    free(d->out);
    free(d->jac);
}

/* The BIN chunk's data of a .glb. */
static const unsigned char *glb_bin(const unsigned char *g)
{
    return g + 20 + rd32(g + 12) + 8;
}

/* The tangent scene's .glb (*glb, caller frees) read, with its 9 normals
 * and 9 tangents; NULL (and a failed CHECK) otherwise. */
static ffd_mesh *read_tangent_scene(unsigned char **glb)
{
    size_t n;
    *glb = glb_of(&tangent_scene, NULL, &n);
    ffd_mesh *m = read_ok(*glb, n, "t.glb");
    CHECK(!m || (m->tangent_count == 9 && m->normal_count == 9));
    if (!m || m->tangent_count != 9 || m->normal_count != 9) {
        ffd_mesh_destroy(m);
        free(*glb);
        return NULL;
    }
    return m;
}

/* A lattice deformation with Jacobians: each tangent becomes J t made
 * orthogonal to the vertex's new normal and unit length, w unchanged (J by
 * finite differences here); written back (local space) and read again, the
 * same up to float storage, orthogonal to the written normal. */
static void test_tangent_lattice(void)
{
    unsigned char *g;
    ffd_mesh *m = read_tangent_scene(&g);
    if (!m)
        return;
    double t0[36], p0[27], Jfd[81];
    memcpy(t0, m->tangents, sizeof t0);
    memcpy(p0, m->positions, sizeof p0);
    deformation def = lattice_deform(m);
    finite_difference_jacobian(def.lat, p0, 9, 1e-4, Jfd);
    for (int i = 0; i < 81; i++)
        CHECK_NEAR(def.jac[i], Jfd[i], 1e-8);
    CHECK_OK(ffd_mesh_set_positions(m, def.out, def.jac, NULL));
    size_t on;
    unsigned char *w = write_same(m, &on);
    ffd_mesh *back = w ? read_ok(w, on, "w.glb") : NULL;
    for (int k = 0; k < 9 && back && back->tangent_count == 9 && back->normal_count == 9; k++) {
        double jt[3], expect[3], expect_back[3];
        for (int r = 0; r < 3; r++)
            jt[r] = dot3(Jfd + 9 * k + 3 * r, t0 + 4 * k);
        orthonormal_to(jt, m->normals + 3 * k, expect);
        const double *T = m->tangents + 4 * k, *B = back->tangents + 4 * k;
        for (int d = 0; d < 3; d++)
            CHECK_NEAR(T[d], expect[d], 1e-9);
        CHECK_NEAR(dot3(T, T), 1, 1e-12);
        CHECK_NEAR(dot3(T, m->normals + 3 * k), 0, 1e-12);
        CHECK(T[3] == t0[4 * k + 3]);
        /* back from the file: against the written normal */
        orthonormal_to(jt, back->normals + 3 * k, expect_back);
        for (int d = 0; d < 3; d++)
            CHECK_NEAR(B[d], expect_back[d], 2e-6);
        CHECK_NEAR(dot3(B, B), 1, 1e-6);
        CHECK_NEAR(dot3(B, back->normals + 3 * k), 0, 1e-6);
        /* w: the same bytes */
        CHECK(memcmp(glb_bin(w) + TAN_AT + 16 * k + 12, glb_bin(g) + TAN_AT + 16 * k + 12, 4) ==
              0);
    }
    CHECK(back && back->tangent_count == 9);
    ffd_mesh_destroy(back);
    ffd_free(w);
    deformation_free(&def);
    ffd_mesh_destroy(m);
    free(g);
}

/* Without Jacobians (GFFD), the fallback: the old tangent projected onto
 * the plane of the recomputed normal, unit length. Moving vertex 0 alone
 * changes the surface at vertices 0, 1, 3, 4 only: the other tangents keep
 * their bytes in the file. */
static void test_tangent_fallback(void)
{
    unsigned char *g;
    ffd_mesh *m = read_tangent_scene(&g);
    if (!m)
        return;
    double t0[36], p[27];
    memcpy(t0, m->tangents, sizeof t0);
    memcpy(p, m->positions, sizeof p);
    p[0] += 0.3;
    p[1] -= 0.2;
    p[2] += 0.5;
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
    size_t on;
    unsigned char *w = write_same(m, &on);
    for (int k = 0; k < 9 && w; k++) {
        const double *T = m->tangents + 4 * k, *N = m->normals + 3 * k;
        bool near = k == 0 || k == 1 || k == 3 || k == 4;
        if (near) {
            double expect[3];
            orthonormal_to(t0 + 4 * k, N, expect);
            for (int d = 0; d < 3; d++)
                CHECK_NEAR(T[d], expect[d], 1e-12);
            CHECK_NEAR(dot3(T, N), 0, 1e-12);
        } else {
            CHECK(memcmp(T, t0 + 4 * k, 4 * sizeof *T) == 0);
        }
        CHECK(T[3] == t0[4 * k + 3]);
        CHECK((memcmp(glb_bin(w) + TAN_AT + 16 * k, glb_bin(g) + TAN_AT + 16 * k, 16) == 0) ==
              !near);
    }
    ffd_free(w);
    ffd_mesh_destroy(m);
    free(g);
}

/* TANGENT without NORMAL is not read (spec: tangents are ignored without
 * normals) and its bytes stay as they are through a deformation. */
static void test_tangent_without_normal(void)
{
    char *j = replace(tangent_json, "\"NORMAL\":1,", "");
    size_t n;
    unsigned char *g = glb_of(&tangent_scene, j, &n);
    ffd_mesh *m = read_ok(g, n, "t.glb");
    if (m) {
        CHECK(m->tangent_count == 0 && m->normal_count == 0);
        deformation def = lattice_deform(m);
        CHECK_OK(ffd_mesh_set_positions(m, def.out, def.jac, NULL));
        size_t on;
        unsigned char *w = write_same(m, &on);
        /* the positions moved; the tangents' bytes did not */
        CHECK(w && memcmp(glb_bin(w), glb_bin(g), 108) != 0);
        CHECK(w && memcmp(glb_bin(w) + TAN_AT, glb_bin(g) + TAN_AT, 144) == 0);
        ffd_free(w);
        deformation_free(&def);
    }
    ffd_mesh_destroy(m);
    free(g);
    free(j);
}

static void test_tangent_refusals(void)
{
    const scene *t = &tangent_scene;
    check_refused_in(t, "\"count\":9,\"type\":\"VEC4\"", "\"count\":9,\"type\":\"VEC3\"",
                     FFD_ERR_UNSUPPORTED, "$.accessors[2]: TANGENT must be FLOAT (5126) VEC4");
    check_refused_in(t, "\"count\":9,\"type\":\"VEC4\"",
                     "\"count\":9,\"type\":\"VEC4\",\"normalized\":true", FFD_ERR_UNSUPPORTED,
                     "$.accessors[2]: normalized TANGENT");
    check_refused_in(t, "\"count\":9,\"type\":\"VEC4\"", "\"count\":8,\"type\":\"VEC4\"",
                     FFD_ERR_PARSE,
                     "$.accessors[2]: TANGENT count 8 differs from POSITION (accessor 0) count 9");
    /* a VEC4 element is 16 bytes: 9 of them do not fit 140 */
    check_refused_in(t, "\"byteOffset\":216,\"byteLength\":144",
                     "\"byteOffset\":216,\"byteLength\":140", FFD_ERR_PARSE,
                     "$.accessors[2]: 9 elements from byte 0 need 144 bytes, bufferView 2 has 140");
    check_refused_in(t, "\"TANGENT\":2", "\"TANGENT\":9", FFD_ERR_PARSE,
                     "$.meshes[0].primitives[0].attributes.TANGENT: not an accessor index");
    /* the normals' bytes read as VEC4: (0,0,1,0), w = 0 */
    check_refused_in(t, "\"byteOffset\":216,\"byteLength\":144",
                     "\"byteOffset\":108,\"byteLength\":144", FFD_ERR_PARSE,
                     "$.accessors[2]: element 0: TANGENT w is 0, expected 1 or -1");
    /* a second primitive on the same POSITION with other NORMAL or TANGENT data */
    check_refused_in(t, "\"indices\":3}]",
                     "\"indices\":3},{\"attributes\":{\"POSITION\":0,"
                     "\"NORMAL\":1,\"TANGENT\":1},\"indices\":3}]",
                     FFD_ERR_UNSUPPORTED,
                     "$.accessors[0]: POSITION shared by primitives with different TANGENT "
                     "(accessor 1; first read with accessor 2)");
    check_refused_in(t, "\"indices\":3}]",
                     "\"indices\":3},{\"attributes\":{\"POSITION\":0,"
                     "\"NORMAL\":2},\"indices\":3}]",
                     FFD_ERR_UNSUPPORTED,
                     "$.accessors[0]: POSITION shared by primitives with different NORMAL "
                     "(accessor 2; first read with accessor 1)");
    /* ... while one that uses fewer of them is fine */
    ffd_error err = {{0}};
    CHECK_OK(read_variant(t, "\"indices\":3}]",
                          "\"indices\":3},{\"attributes\":{\"POSITION\":0},\"indices\":3}]", &err));
    /* a non-finite element */
    unsigned char bin[TAN_BIN_SIZE];
    tangent_bin(bin);
    float nan = NAN;
    memcpy(bin + TAN_AT + 16 * 4 + 4, &nan, 4);
    size_t n;
    unsigned char *g = make_glb(tangent_json, bin, TAN_BIN_SIZE, &n);
    ffd_mesh *m = NULL;
    CHECK(ffd_mesh_read_memory(g, n, FFD_FORMAT_GLTF, "v.glb", &m, &err) == FFD_ERR_PARSE);
    CHECK(!m && strstr(err.message, "v.glb: $.accessors[2]: element 4 is not finite"));
    free(g);
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
    ffd_mesh *m = read_ok(g, n, "s.glb"), *out = NULL;
    ffd_error err = {{0}};
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
        ffd_write_options o = {FFD_FORMAT_GLTF, (ffd_encoding)enc, 0};
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
                                        FIX "cube_embedded.gltf", FIX "grid_tangents.glb"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        CHECK_OK(ffd_mesh_read(files[i], &m, &err));
        if (!m)
            continue;
        size_t on, sn = 0;
        unsigned char *out = write_same(m, &on);
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
        {"tangent_world_frame", test_tangent_world_frame},
        {"tangent_lattice", test_tangent_lattice},
        {"tangent_fallback", test_tangent_fallback},
        {"tangent_without_normal", test_tangent_without_normal},
        {"tangent_refusals", test_tangent_refusals},
        {"modes_and_instances", test_modes_and_instances},
        {"refusals", test_refusals},
        {"glb_container", test_glb_container},
        {"refine_refused", test_refine_refused},
        {"write_from_data", test_write_from_data},
        {"fixtures", test_fixtures},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
