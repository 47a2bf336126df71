/* Point sets as text (src/mesh/mesh_xyz.c, docs/volume.md "Point sets"):
 * .xyz and .csv samples read as vertices only, extra columns as point
 * fields; untouched writes byte-identical, deformed ones differ only in
 * the coordinates; .xyz <-> .csv by path; a point set written to OBJ and
 * PLY gives its vertices; a surface and a volume mesh written as points;
 * bad inputs refused with their messages; truncated prefixes fail cleanly. */
#include "check.h"

#include <stdbool.h>
#include <string.h>
#include <unistd.h>

#include <ffd.h>
#include "check_volume.h"

#define VOL FFD_DATA_DIR "/volume/"

static void test_read_samples(void)
{
    ffd_mesh *obj = read_ok(FFD_DATA_DIR "/bunny.obj");
    ffd_mesh *x = read_ok(VOL "bunny_points.xyz");
    ffd_mesh *c = read_ok(VOL "bunny_points.csv");
    if (obj && x && c) {
        CHECK(same_nodes(obj, x));
        CHECK(same_nodes(obj, c));
        CHECK(ffd_mesh_face_count(x) == 0 && ffd_mesh_cell_count(x) == 0);
        CHECK(ffd_mesh_face_count(c) == 0 && ffd_mesh_cell_count(c) == 0);
        CHECK(ffd_mesh_source_format(x) == FFD_FORMAT_XYZ);
        CHECK(ffd_mesh_field_count(x) == 0);
        const double *id = field(c, "id"); /* the CSV header names the extra column */
        CHECK(id && id[0] == 0 && id[1838] == 1838);
    }
    ffd_mesh_destroy(obj);
    ffd_mesh_destroy(x);
    ffd_mesh_destroy(c);
}

static void test_untouched_and_deformed(void)
{
    const char *files[] = {VOL "bunny_points.xyz", VOL "bunny_points.csv"};
    for (int f = 0; f < 2; f++) {
        size_t n, k;
        unsigned char *src = slurp(files[f], &n);
        ffd_mesh *m = read_ok(files[f]);
        if (!m || !src) {
            free(src);
            continue;
        }
        unsigned char *out = write_mem(m, FFD_FORMAT_XYZ, &k);
        CHECK(out && k == n && memcmp(out, src, n) == 0);
        free(out);
        /* move every other point: only those lines change, and only their coordinates */
        size_t nv = ffd_mesh_vertex_count(m);
        double *p = malloc(3 * nv * sizeof(double));
        memcpy(p, ffd_mesh_positions(m), 3 * nv * sizeof(double));
        for (size_t i = 0; i < nv; i += 2)
            p[3 * i + 1] += 0.125;
        CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
        out = write_mem(m, FFD_FORMAT_XYZ, &k);
        ffd_mesh *back = NULL;
        CHECK_OK(ffd_mesh_read_memory(out, k, FFD_FORMAT_XYZ, "back", &back, NULL));
        if (back) {
            CHECK(memcmp(ffd_mesh_positions(back), p, 3 * nv * sizeof(double)) == 0);
            CHECK(ffd_mesh_field_count(back) == ffd_mesh_field_count(m));
        }
        /* line by line: the same lines, and in each only the y word may differ */
        const char *x = (const char *)src, *y = out ? (const char *)out : "";
        size_t lines = 0, changed = 0;
        while (*x && *y) {
            size_t xl = strcspn(x, "\n"), yl = strcspn(y, "\n");
            char lx[256], ly[256], *wx[8], *wy[8], *sx, *sy;
            snprintf(lx, sizeof lx, "%.*s", (int)xl, x);
            snprintf(ly, sizeof ly, "%.*s", (int)yl, y);
            int nx = 0, ny = 0;
            for (char *w = strtok_r(lx, " ,", &sx); w && nx < 8; w = strtok_r(NULL, " ,", &sx))
                wx[nx++] = w;
            for (char *w = strtok_r(ly, " ,", &sy); w && ny < 8; w = strtok_r(NULL, " ,", &sy))
                wy[ny++] = w;
            CHECK(nx == ny);
            for (int w = 0; w < nx && w < ny; w++)
                if (w != 1)
                    CHECK(strcmp(wx[w], wy[w]) == 0);
            changed += xl != yl || memcmp(x, y, xl) != 0;
            lines++;
            x += xl + (x[xl] == '\n');
            y += yl + (y[yl] == '\n');
        }
        CHECK(!*x && !*y);
        CHECK(changed == nv / 2 + nv % 2 && lines > nv);
        ffd_mesh_destroy(back);
        free(out);
        free(p);
        ffd_mesh_destroy(m);
        free(src);
    }
}

/* .xyz written as .csv (and back) by the path's extension: from data, the
 * points and the extra columns kept. */
static void test_xyz_csv_by_path(void)
{
    char dir[] = "/tmp/ffd_xyz_XXXXXX";
    if (!mkdtemp(dir)) {
        CHECK(!"mkdtemp");
        return;
    }
    char a[64], b[64];
    snprintf(a, sizeof a, "%s/p.xyz", dir);
    snprintf(b, sizeof b, "%s/p.csv", dir);
    ffd_mesh *c = read_ok(VOL "bunny_points.csv");
    if (c) {
        CHECK_OK(ffd_mesh_write(c, a, NULL, NULL));
        ffd_mesh *x = read_ok(a);
        if (x) {
            CHECK(same_nodes(c, x));
            const double *id = field(x, "column_4");
            CHECK(id && id[1838] == 1838);
            CHECK_OK(ffd_mesh_write(x, b, NULL, NULL));
            ffd_mesh *c2 = read_ok(b);
            if (c2) {
                CHECK(same_nodes(c, c2));
                CHECK(field(c2, "column_4") && field(c2, "column_4")[7] == 7);
            }
            ffd_mesh_destroy(c2);
            size_t n;
            unsigned char *t = slurp(b, &n);
            CHECK(t && strncmp((char *)t, "x,y,z,column_4\n1.301895,0.122622,2.550061,0\n", 44) == 0);
            free(t);
        }
        ffd_mesh_destroy(x);
    }
    ffd_mesh_destroy(c);
    unlink(a);
    unlink(b);
    rmdir(dir);
}

/* A point set into the surface formats: its vertices, no faces. */
static void test_points_to_surfaces(void)
{
    ffd_mesh *x = read_ok(VOL "bunny_points.xyz");
    if (!x)
        return;
    const ffd_format fs[] = {FFD_FORMAT_OBJ, FFD_FORMAT_PLY, FFD_FORMAT_OFF};
    for (int f = 0; f < 3; f++) {
        size_t k;
        unsigned char *out = write_mem(x, fs[f], &k);
        ffd_mesh *back = NULL;
        ffd_error err = {{0}};
        if (out && ffd_mesh_read_memory(out, k, fs[f], "points", &back, &err) != FFD_OK)
            fprintf(stderr, "format %d: %s\n", (int)fs[f], err.message);
        CHECK(back != NULL);
        if (back) {
            CHECK(same_nodes(x, back));
            CHECK(ffd_mesh_face_count(back) == 0);
        }
        ffd_mesh_destroy(back);
        free(out);
    }
    ffd_mesh_destroy(x);
}

/* A surface and a volume mesh written as points: every node. */
static void test_meshes_to_points(void)
{
    static const double pts[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    static const uint8_t types[] = {FFD_CELL_TETRA, FFD_CELL_TETRA};
    static const uint64_t off[] = {0, 4, 8};
    static const uint32_t idx[] = {0, 1, 2, 3, 1, 4, 2, 3};
    ffd_mesh *v = NULL, *obj = read_ok(FFD_DATA_DIR "/bunny.obj");
    CHECK_OK(ffd_mesh_create_cells(pts, 5, types, off, idx, 2, &v, NULL));
    ffd_mesh *ms[] = {obj, v};
    for (int i = 0; i < 2; i++) {
        if (!ms[i])
            continue;
        size_t k;
        unsigned char *out = write_mem(ms[i], FFD_FORMAT_XYZ, &k);
        ffd_mesh *back = NULL;
        CHECK_OK(ffd_mesh_read_memory(out, k, FFD_FORMAT_XYZ, "points", &back, NULL));
        CHECK(back && same_nodes(ms[i], back));
        ffd_mesh_destroy(back);
        free(out);
    }
    ffd_mesh_destroy(v);
    ffd_mesh_destroy(obj);
}

static void test_comments_and_extras(void)
{
    const char *t = "# points\n1 2 3 7 alpha\n\n  # indented comment\n4 5 6 8 beta # tail\r\n";
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read_memory(t, strlen(t), FFD_FORMAT_XYZ, "p.xyz", &m, NULL));
    if (m) {
        CHECK(ffd_mesh_vertex_count(m) == 2 && ffd_mesh_positions(m)[5] == 6);
        CHECK(ffd_mesh_field_count(m) == 0); /* a text column: not numeric, no fields */
        size_t k;
        unsigned char *out = write_mem(m, FFD_FORMAT_XYZ, &k);
        CHECK(out && k == strlen(t) && memcmp(out, t, k) == 0);
        free(out);
    }
    ffd_mesh_destroy(m);
    const char *c = "a,b,c,w\n1, 2 ,3,0.5\n4,5,6,1.5\n";
    CHECK_OK(ffd_mesh_read_memory(c, strlen(c), FFD_FORMAT_XYZ, "p.csv", &m, NULL));
    if (m) {
        CHECK(ffd_mesh_positions(m)[1] == 2 && field(m, "w") && field(m, "w")[1] == 1.5);
        double p[6] = {1, 2.5, 3, 4, 5, 6};
        CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
        size_t k;
        unsigned char *out = write_mem(m, FFD_FORMAT_XYZ, &k);
        CHECK(out && strcmp((char *)out, "a,b,c,w\n1, 2.5 ,3,0.5\n4,5,6,1.5\n") == 0);
        free(out);
    }
    ffd_mesh_destroy(m);
}

typedef struct {
    const char *text;
    ffd_status status;
    const char *message;
} bad_case;

static const bad_case bad[] = {
    {"1 2 3\n4 5\n", FFD_ERR_PARSE, "bad.xyz:2: expected x y z, found 2 values"},
    {"1 2 3\n4 5 x\n", FFD_ERR_PARSE, "bad.xyz:2: expected z, found 'x'"},
    {"1 2 3\n4 nan 6\n", FFD_ERR_NONFINITE, "bad.xyz:2: coordinate y of point 2 is not finite"},
    {"1 2 3\ninf 5 6\n", FFD_ERR_NONFINITE, "bad.xyz:2: coordinate x of point 2 is not finite"},
    {"# nothing\n\n", FFD_ERR_PARSE, "bad.xyz:2: expected a point (x y z), found none"},
    {"x,y,z\n", FFD_ERR_PARSE, "bad.xyz:1: expected a point (x,y,z), found none"},
    {"x,y,z\n1,2\n", FFD_ERR_PARSE, "bad.xyz:2: expected x,y,z, found 2 values"},
    {"1,2,3\nx,y,z\n", FFD_ERR_PARSE, "bad.xyz:2: expected x, found 'x'"},
    {"1,2,3\n1,,3\n", FFD_ERR_PARSE, "bad.xyz:2: expected y, found an empty field"},
    {"1 2 3x\n", FFD_ERR_PARSE, "bad.xyz:1: expected z, found '3x'"},
};

static void test_bad_inputs(void)
{
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        ffd_status s = ffd_mesh_read_memory(bad[i].text, strlen(bad[i].text), FFD_FORMAT_XYZ,
                                            "bad.xyz", &m, &err);
        if (s != bad[i].status || !strstr(err.message, bad[i].message))
            fprintf(stderr, "case %zu: status %d, message '%s'\n", i, (int)s, err.message);
        CHECK(s == bad[i].status);
        CHECK(strstr(err.message, bad[i].message) != NULL);
        CHECK(m == NULL);
    }
}

static void test_truncated_prefixes(void)
{
    size_t n;
    unsigned char *src = slurp(VOL "bunny_points.csv", &n);
    CHECK(src != NULL);
    for (size_t len = 1; src && len < 400; len++) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        ffd_status s = ffd_mesh_read_memory(src, len, FFD_FORMAT_XYZ, "cut.csv", &m, &err);
        CHECK(s == FFD_OK || strncmp(err.message, "cut.csv", 7) == 0);
        ffd_mesh_destroy(m);
    }
    free(src);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"read_samples", test_read_samples},
        {"untouched_and_deformed", test_untouched_and_deformed},
        {"xyz_csv_by_path", test_xyz_csv_by_path},
        {"points_to_surfaces", test_points_to_surfaces},
        {"meshes_to_points", test_meshes_to_points},
        {"comments_and_extras", test_comments_and_extras},
        {"bad_inputs", test_bad_inputs},
        {"truncated_prefixes", test_truncated_prefixes},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
