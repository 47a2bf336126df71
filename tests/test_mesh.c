/* Tests of the mesh module: lossless round trips, deformed writes, cross-format
 * conversion, topology info, bad inputs, truncated prefixes, failing allocations. */
#include "check.h"
#include "ffd.h"
#include "mesh/mesh.h"
#include "mesh/mesh_codec.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define FIX FFD_SOURCE_DIR "/tests/data/mesh/"
#define SHARED FFD_DATA_DIR "/"

static const char *const shared_files[] = {
    "bunny.obj", "teapot.obj", "elephant.off", "hinge.stl", "double-torus-example.off",
    "cow.off",   "refined_elephant.off",
};

static const char *const fixtures[] = {
    "all_forms.obj", "cube_ascii.ply", "cube_ble.ply",  "cube_bbe.ply",
    "comments.off",  "normals.off",    "tri_ascii.stl", "tri_binary.stl",
};

static unsigned char *load(const char *path, size_t *size)
{
    unsigned char *d = NULL;
    ffd_error err = {{0}};
    if (ffd_read_file(path, &d, size, &err) != FFD_OK) {
        fprintf(stderr, "cannot load %s: %s\n", path, err.message);
        return NULL;
    }
    return d;
}

static ffd_mesh *read_path(const char *path)
{
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    ffd_status s = ffd_mesh_read(path, &m, &err);
    if (s != FFD_OK)
        fprintf(stderr, "read %s: %s\n", path, err.message);
    return m;
}

static unsigned char *write_mem(const ffd_mesh *m, ffd_format f, ffd_encoding e, size_t *size)
{
    ffd_write_options o = {f, e, 0};
    unsigned char *d = NULL;
    ffd_error err = {{0}};
    ffd_status s = ffd_mesh_write_memory(m, &o, &d, size, &err);
    if (s != FFD_OK)
        fprintf(stderr, "write: %s\n", err.message);
    return d;
}

/* ---------------------------------------------------------------------- */

static void check_round_trip(const char *path)
{
    size_t size = 0, out_size = 0;
    unsigned char *src = load(path, &size);
    ffd_mesh *m = read_path(path);
    CHECK(src && m);
    if (src && m) {
        unsigned char *out = write_mem(m, ffd_mesh_source_format(m), FFD_ENCODING_SAME, &out_size);
        CHECK(out && out_size == size && memcmp(out, src, size) == 0);
        if (!(out && out_size == size && memcmp(out, src, size) == 0))
            fprintf(stderr, "  round trip differs: %s\n", path);
        ffd_free(out);
    }
    ffd_free(src);
    ffd_mesh_destroy(m);
}

static void test_round_trip_shared(void)
{
    char path[512];
    for (size_t i = 0; i < sizeof shared_files / sizeof *shared_files; i++) {
        snprintf(path, sizeof path, SHARED "%s", shared_files[i]);
        check_round_trip(path);
    }
}

static void test_round_trip_fixtures(void)
{
    char path[512];
    for (size_t i = 0; i < sizeof fixtures / sizeof *fixtures; i++) {
        snprintf(path, sizeof path, FIX "%s", fixtures[i]);
        check_round_trip(path);
    }
}

static void test_obj_contents(void)
{
    ffd_mesh *m = read_path(FIX "all_forms.obj");
    CHECK(m);
    if (!m)
        return;
    CHECK(ffd_mesh_vertex_count(m) == 8);
    CHECK(ffd_mesh_face_count(m) == 6);
    CHECK(ffd_mesh_normal_count(m) == 7);
    ffd_mesh_info info;
    CHECK_OK(ffd_mesh_compute_info(m, &info, NULL));
    CHECK(info.texcoord_count == 4);
    CHECK(info.corner_count == 24);
    CHECK(info.closed == 1);
    CHECK(info.edge_count == 12);
    const uint32_t *off = ffd_mesh_face_offsets(m), *ix = ffd_mesh_face_indices(m);
    /* f -8//-5 -7//-5 -3//-5 -4//-5 after 8 vertices: 0 1 5 4 */
    CHECK(off[2] == 8 && ix[8] == 0 && ix[9] == 1 && ix[10] == 5 && ix[11] == 4);
    /* f -5/-4/-2 -1/-3/-2 -4/-2/-2 1/-1/-2: 3 7 4 0 */
    CHECK(ix[20] == 3 && ix[21] == 7 && ix[22] == 4 && ix[23] == 0);
    const uint32_t *anchor = ffd_mesh_normal_anchors(m);
    CHECK(anchor[2] == 0);             /* vn 3 first used by vertex 1 (index 0) */
    CHECK(anchor[3] == 1);             /* vn 4 first used by 2/2/4 */
    CHECK(anchor[5] == 3);             /* vn 6 (-2) first used by -5 = vertex 4 (index 3) */
    CHECK(anchor[6] == FFD_NO_ANCHOR); /* vn 7 unused */
    const double *p = ffd_mesh_positions(m);
    CHECK(p[3] == 1.0 && p[10] == 1.0);
    ffd_mesh_destroy(m);
}

static void test_ply_contents_and_transcode(void)
{
    static const char *const names[3] = {"cube_ascii.ply", "cube_ble.ply", "cube_bbe.ply"};
    static const ffd_encoding encs[3] = {FFD_ENCODING_ASCII, FFD_ENCODING_BINARY_LE,
                                         FFD_ENCODING_BINARY_BE};
    for (int a = 0; a < 3; a++) {
        char path[512];
        snprintf(path, sizeof path, FIX "%s", names[a]);
        ffd_mesh *m = read_path(path);
        CHECK(m);
        if (!m)
            continue;
        CHECK(ffd_mesh_vertex_count(m) == 8 && ffd_mesh_face_count(m) == 6);
        CHECK(ffd_mesh_normal_count(m) == 8);
        CHECK(ffd_mesh_normals(m)[0] == -0.5 && ffd_mesh_normal_anchors(m)[5] == 5);
        for (int b = 0; b < 3; b++) {
            /* The three fixtures hold the same values: re-encoding one gives the other. */
            snprintf(path, sizeof path, FIX "%s", names[b]);
            size_t want_size = 0, got_size = 0;
            unsigned char *want = load(path, &want_size);
            unsigned char *got = write_mem(m, FFD_FORMAT_PLY, encs[b], &got_size);
            CHECK(want && got && want_size == got_size && memcmp(want, got, got_size) == 0);
            ffd_free(want);
            ffd_free(got);
        }
        ffd_mesh_destroy(m);
    }
}

static void test_info_shared(void)
{
    static const struct {
        const char *name;
        size_t v, welded, f;
        int closed;
        size_t boundary;
    } want[] = {
        {"bunny.obj", 1839, 1839, 3674, 1, 0},
        {"teapot.obj", 792, 0, 992, 0, 528},
        {"elephant.off", 2775, 2775, 5558, 1, 0},
        {"hinge.stl", 3636, 598, 1212, 1, 0},
        {"double-torus-example.off", 231, 231, 220, 1, 0},
        {"cow.off", 2904, 0, 5804, 1, 0},
        {"refined_elephant.off", 44460, 0, 88928, 1, 0},
    };
    for (size_t i = 0; i < sizeof want / sizeof *want; i++) {
        char path[512];
        snprintf(path, sizeof path, SHARED "%s", want[i].name);
        double t0 = ffd_now();
        ffd_mesh *m = read_path(path);
        double t1 = ffd_now();
        CHECK(m);
        if (!m)
            continue;
        ffd_mesh_info info;
        CHECK_OK(ffd_mesh_compute_info(m, &info, NULL));
        printf("     %-26s V %zu welded %zu F %zu E %zu boundary %zu nonmanifold %zu closed %d"
               " (read %.1f ms)\n",
               want[i].name, info.vertex_count, info.welded_vertex_count, info.face_count,
               info.edge_count, info.boundary_edge_count, info.nonmanifold_edge_count, info.closed,
               1e3 * (t1 - t0));
        CHECK(info.vertex_count == want[i].v);
        if (want[i].welded)
            CHECK(info.welded_vertex_count == want[i].welded);
        CHECK(info.face_count == want[i].f);
        CHECK(info.closed == want[i].closed);
        CHECK(info.boundary_edge_count == want[i].boundary);
        if (want[i].closed) /* closed manifold triangle meshes: E = 3F/2 */
            CHECK(info.face_count != info.corner_count / 3 || 2 * info.edge_count == 3 * info.face_count);
        ffd_mesh_destroy(m);
    }
}

/* ---------------------------------------------------------------------- */

/* All spans of a mesh (positions and normals) in file order. */
static ffd_span *sorted_spans(const ffd_mesh *m, size_t *n)
{
    size_t np = m->position_spans ? 3 * m->vertex_count : 0;
    size_t nn = m->normal_spans ? 3 * m->normal_count : 0;
    ffd_span *s = malloc((np + nn + 1) * sizeof *s);
    size_t i = 0, j = 0, k = 0;
    while (i < np || j < nn) {
        if (j >= nn || (i < np && m->position_spans[i].offset < m->normal_spans[j].offset))
            s[k++] = m->position_spans[i++];
        else
            s[k++] = m->normal_spans[j++];
    }
    *n = k;
    return s;
}

/* The bytes between spans are identical in both meshes' sources. */
static int same_outside_spans(const ffd_mesh *a, const ffd_mesh *b)
{
    size_t na, nb;
    ffd_span *sa = sorted_spans(a, &na), *sb = sorted_spans(b, &nb);
    int ok = na == nb;
    size_t pa = 0, pb = 0;
    for (size_t i = 0; ok && i <= na; i++) {
        size_t ea = i < na ? sa[i].offset : a->src_size, eb = i < nb ? sb[i].offset : b->src_size;
        if (ea - pa != eb - pb || memcmp(a->src + pa, b->src + pb, ea - pa) != 0)
            ok = 0;
        if (i < na) {
            pa = sa[i].offset + ffd_span_length(a, &sa[i]);
            pb = sb[i].offset + ffd_span_length(b, &sb[i]);
        }
    }
    free(sa);
    free(sb);
    return ok;
}

static void deform(const double *p, double *q, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        double x = p[3 * i], y = p[3 * i + 1], z = p[3 * i + 2];
        q[3 * i] = 1.1 * x + 0.2 * y + 0.1 * sin(z) + 1.0 / 3.0;
        q[3 * i + 1] = y - 0.3 * x * z;
        q[3 * i + 2] = 0.9 * z + 0.05 * x * x + 1e-3 * check_rand01();
    }
}

static void check_deformed_write(const char *path)
{
    ffd_mesh *m = read_path(path);
    CHECK(m);
    if (!m)
        return;
    size_t nv = ffd_mesh_vertex_count(m);
    double *q = malloc((3 * nv + 1) * sizeof *q);
    deform(ffd_mesh_positions(m), q, nv);
    CHECK_OK(ffd_mesh_set_positions(m, q, NULL, &check_err_));
    size_t size = 0;
    unsigned char *out = write_mem(m, ffd_mesh_source_format(m), FFD_ENCODING_SAME, &size);
    ffd_mesh *r = NULL;
    ffd_error err = {{0}};
    CHECK(out && ffd_mesh_read_memory(out, size, ffd_mesh_source_format(m), "deformed", &r, &err) ==
                     FFD_OK);
    if (r) {
        CHECK(ffd_mesh_vertex_count(r) == nv);
        size_t bad = 0;
        for (size_t i = 0; i < 3 * nv && ffd_mesh_vertex_count(r) == nv; i++) {
            double want = r->position_spans[i].kind == FFD_SPAN_F32 ? (double)(float)q[i] : q[i];
            bad += ffd_mesh_positions(r)[i] != want;
        }
        CHECK(bad == 0);
        if (bad)
            fprintf(stderr, "  %s: %zu positions differ\n", path, bad);
        /* Normals written are the ones set_positions computed. */
        size_t nn = ffd_mesh_normal_count(m);
        CHECK(ffd_mesh_normal_count(r) == nn);
        for (size_t i = 0; i < 3 * nn && ffd_mesh_normal_count(r) == nn; i++) {
            double w = ffd_mesh_normals(m)[i];
            if (r->normal_spans[i].kind == FFD_SPAN_F32)
                w = (double)(float)w;
            bad += ffd_mesh_normals(r)[i] != w;
            if (ffd_mesh_normals(r)[i] != w && bad < 5)
                fprintf(stderr, "  %s: normal %zu: %.17g != %.17g\n", path, i, ffd_mesh_normals(r)[i], w);
        }
        CHECK(bad == 0);
        CHECK(same_outside_spans(m, r));
        CHECK(ffd_mesh_face_count(r) == ffd_mesh_face_count(m));
        CHECK(memcmp(ffd_mesh_face_indices(r), ffd_mesh_face_indices(m),
                     sizeof(uint32_t) * ffd_mesh_face_offsets(m)[ffd_mesh_face_count(m)]) == 0);
    }
    ffd_mesh_destroy(r);
    ffd_free(out);
    free(q);
    ffd_mesh_destroy(m);
}

static void test_deformed_write(void)
{
    char path[512];
    for (size_t i = 0; i < sizeof fixtures / sizeof *fixtures; i++) {
        snprintf(path, sizeof path, FIX "%s", fixtures[i]);
        check_deformed_write(path);
    }
    for (size_t i = 0; i < sizeof shared_files / sizeof *shared_files; i++) {
        snprintf(path, sizeof path, SHARED "%s", shared_files[i]);
        check_deformed_write(path);
    }
}

static void test_set_positions_normals(void)
{
    /* Jacobian path: diag(2,1,1) maps normal (1,1,0) to cofactor diag(1,2,2) (1,1,0) = (1,2,0). */
    ffd_mesh *m = read_path(FIX "cube_ascii.ply");
    CHECK(m);
    if (!m)
        return;
    size_t nv = ffd_mesh_vertex_count(m);
    double *p = malloc(3 * nv * sizeof *p), *J = calloc(9 * nv, sizeof *J);
    double n0[24];
    memcpy(n0, ffd_mesh_normals(m), sizeof n0);
    for (size_t i = 0; i < nv; i++) {
        const double *x = ffd_mesh_positions(m) + 3 * i;
        p[3 * i] = 2 * x[0];
        p[3 * i + 1] = x[1];
        p[3 * i + 2] = x[2];
        J[9 * i] = 2;
        J[9 * i + 4] = 1;
        J[9 * i + 8] = 1;
    }
    CHECK_OK(ffd_mesh_set_positions(m, p, J, &check_err_));
    for (size_t i = 0; i < nv; i++) {
        const double *n = ffd_mesh_normals(m) + 3 * i, *o = n0 + 3 * i;
        double t[3] = {o[0], 2 * o[1], 2 * o[2]};
        double lt = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
        double lo = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
        for (int d = 0; d < 3; d++)
            CHECK_NEAR(n[d], t[d] * lo / lt, 1e-15);
    }
    /* NaN: refused, nothing changes. */
    double keep = ffd_mesh_positions(m)[0];
    p[5] = NAN;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_set_positions(m, p, NULL, &err) == FFD_ERR_NONFINITE);
    CHECK(ffd_mesh_positions(m)[0] == keep && strstr(err.message, "finite"));
    /* Recomputed from faces: the cube corner 0 gets -(1,1,1)/sqrt3 times its old length. */
    memcpy(p, ffd_mesh_positions(m), 3 * nv * sizeof *p);
    for (size_t i = 0; i < nv; i++)
        p[3 * i] /= 2; /* back to the unit cube */
    for (size_t i = 0; i < 3 * nv; i++)
        p[i] = 3 * p[i] + 1;
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, &check_err_));
    double len = sqrt(0.75);
    for (int d = 0; d < 3; d++)
        CHECK_NEAR(ffd_mesh_normals(m)[d], -len / sqrt(3.0), 1e-12);
    ffd_mesh_destroy(m);
    free(p);
    free(J);

    /* STL: facet normals recomputed from the deformed triangle; zero area gives 0 0 0. */
    m = read_path(FIX "tri_ascii.stl");
    CHECK(m);
    if (!m)
        return;
    nv = ffd_mesh_vertex_count(m);
    CHECK(nv == 12 && ffd_mesh_normal_count(m) == 4 && ffd_mesh_normal_anchors(m)[3] == 9);
    p = malloc(3 * nv * sizeof *p);
    memcpy(p, ffd_mesh_positions(m), 3 * nv * sizeof *p);
    for (size_t i = 0; i < nv; i++)
        p[3 * i + 2] *= -1; /* mirror in z */
    p[3 * 10] = p[3 * 9];   /* collapse the last triangle */
    p[3 * 10 + 1] = p[3 * 9 + 1];
    p[3 * 10 + 2] = p[3 * 9 + 2];
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, &check_err_));
    const double *n = ffd_mesh_normals(m);
    CHECK(n[0] == 0 && n[1] == 0 && n[2] == -1); /* planes z = const keep their normals */
    CHECK(n[3] == 0 && n[4] == 0 && n[5] == -1);
    CHECK(n[6] == 0 && n[7] == 0 && n[8] == 1);
    CHECK(n[9] == 0 && n[10] == 0 && n[11] == 0);
    ffd_mesh_destroy(m);
    free(p);
}

/* ---- identity at the level of the file's bytes (docs/cli.md, ffd deform) ---- */

/* Signed zeros, seven-digit values, texture coordinates, a quad; vn 2 is
 * anchored at vertex 5 (its first use), vn 3 at vertex 6 of a triangle far
 * from the rest, vn 4 at nothing. */
static const char identity_obj[] = "# signed zeros\n"
                                   "v -0.000000 0.0165005 0\n"
                                   "v 1 -0.0000 0.0\n"
                                   "v 1 1.0000 -0.000000\n"
                                   "v 0 1 0.3\n"
                                   "v 0.2 0.3 1.0000\n"
                                   "v 5 5 5\n"
                                   "v 6 5 5\n"
                                   "v 5 6 5\n"
                                   "vt 0 0\nvt 1 0\nvt 1 1\n"
                                   "vn 0.0086 -0.0000 0.99996\n"
                                   "vn 0.3 0.3 0.3\n"
                                   "vn -0.0000 -0.0000 1.0000\n"
                                   "vn 0 0 -1\n"
                                   "f 1/1/1 2/2/1 3/3/1 4/1/1\n"
                                   "f 5//2 1//2 2//2\n"
                                   "f 6//3 7//3 8//3\n";

/* Writes m as its source format; 1 when the bytes equal want (n bytes). */
static int writes_back(const ffd_mesh *m, const void *want, size_t n)
{
    size_t size = 0;
    unsigned char *out = write_mem(m, ffd_mesh_source_format(m), FFD_ENCODING_SAME, &size);
    int same = out && size == n && memcmp(out, want, n) == 0;
    if (out && !same && ffd_mesh_source_format(m) != FFD_FORMAT_PLY &&
        ffd_mesh_source_format(m) != FFD_FORMAT_STL)
        fprintf(stderr, "  %s: wrote\n%.*s", check_current, (int)size, (const char *)out);
    ffd_free(out);
    return same;
}

/* Line k (0-based) of text, into buf. */
static const char *line_of(const char *text, size_t k, char *buf, size_t cap)
{
    while (k-- && (text = strchr(text, '\n')))
        text++;
    if (!text)
        return "";
    size_t n = strcspn(text, "\n");
    n = n < cap - 1 ? n : cap - 1;
    memcpy(buf, text, n);
    buf[n] = 0;
    return buf;
}

/* The output of m: which of the source's lines changed (bit k of the result). */
static unsigned changed_lines(const ffd_mesh *m, const char *src)
{
    size_t size = 0;
    unsigned char *out = write_mem(m, FFD_FORMAT_OBJ, FFD_ENCODING_SAME, &size);
    unsigned mask = 0;
    if (!out)
        return ~0u;
    char *text = malloc(size + 1);
    memcpy(text, out, size);
    text[size] = 0;
    for (size_t k = 0; k < 32; k++) {
        char a[128], b[128];
        if (strcmp(line_of(src, k, a, sizeof a), line_of(text, k, b, sizeof b)) != 0)
            mask |= 1u << k;
    }
    free(text);
    ffd_free(out);
    return mask;
}

static ffd_mesh *identity_mesh(void)
{
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read_memory(identity_obj, sizeof identity_obj - 1, FFD_FORMAT_OBJ, "id.obj", &m,
                             &err) != FFD_OK) {
        fprintf(stderr, "%s: %s\n", check_current, err.message);
        check_failures++;
    }
    return m;
}

/* Identity Jacobians with negative zeros off the diagonal (what a sum of
 * zero displacement terms gives). */
static double *identity_jacobians(size_t nv)
{
    double *J = malloc(9 * nv * sizeof *J);
    for (size_t i = 0; i < nv; i++)
        for (int k = 0; k < 9; k++)
            J[9 * i + k] = k % 4 == 0 ? 1.0 : -0.0;
    return J;
}

/* A deformation that moves nothing, -0.0 coming back as +0.0: every byte stays
 * ("-0.000000", "0.0165005", "vn 0.0086 -0.0000 ..."), with Jacobians (exactly
 * the identity) and without (area-weighted normals). */
static void test_identity_signed_zero_and_normals(void)
{
    for (int with_jacobians = 0; with_jacobians < 2; with_jacobians++) {
        ffd_mesh *m = identity_mesh();
        if (!m)
            return;
        size_t nv = ffd_mesh_vertex_count(m);
        CHECK(nv == 8 && ffd_mesh_normal_count(m) == 4 && ffd_mesh_normal_anchors(m)[1] == 4);
        double *p = malloc(3 * nv * sizeof *p);
        for (size_t i = 0; i < 3 * nv; i++)
            p[i] = ffd_mesh_positions(m)[i] + 0.0; /* -0.0 + 0.0 = +0.0 */
        CHECK(!signbit(p[0]) && signbit(ffd_mesh_positions(m)[0]));
        double *J = with_jacobians ? identity_jacobians(nv) : NULL;
        CHECK_OK(ffd_mesh_set_positions(m, p, J, &check_err_));
        CHECK(signbit(ffd_mesh_positions(m)[0])); /* the stored value is kept */
        CHECK(signbit(ffd_mesh_normals(m)[1]));
        CHECK(writes_back(m, identity_obj, sizeof identity_obj - 1));
        /* a translation: Jacobians exactly I keep every normal's bytes */
        if (with_jacobians) {
            for (size_t i = 0; i < 3 * nv; i++)
                p[i] += 0.25;
            CHECK_OK(ffd_mesh_set_positions(m, p, J, &check_err_));
            CHECK(changed_lines(m, identity_obj) == 0x1feu); /* lines 1-8: the v lines */
        }
        free(J);
        free(p);
        ffd_mesh_destroy(m);
    }
}

/* One far vertex moves: only its line and the lines of normals anchored
 * where the deformation is not the identity change. */
static void test_identity_partial_move(void)
{
    enum { V6 = 1u << 6, VN1 = 1u << 12, VN3 = 1u << 14 };
    for (int with_jacobians = 0; with_jacobians < 2; with_jacobians++) {
        ffd_mesh *m = identity_mesh();
        if (!m)
            return;
        size_t nv = ffd_mesh_vertex_count(m);
        double *p = malloc(3 * nv * sizeof *p);
        memcpy(p, ffd_mesh_positions(m), 3 * nv * sizeof *p);
        p[3 * 5 + 2] += 0.5; /* vertex 6 up: its triangle tilts */
        double *J = with_jacobians ? identity_jacobians(nv) : NULL;
        if (J)
            J[9 * 5 + 6] = 1.0; /* a shear at vertex 6: z' = z + x */
        CHECK_OK(ffd_mesh_set_positions(m, p, J, &check_err_));
        unsigned mask = changed_lines(m, identity_obj);
        CHECK(mask == (V6 | VN3));
        if (mask != (V6 | VN3))
            fprintf(stderr, "  changed lines %#x, expected %#x\n", mask, V6 | VN3);
        /* area-weighted: moving vertex 4 recomputes vn 1 (anchored at vertex 1,
         * whose quad holds vertex 4) but not vn 2 (its triangle did not move) */
        if (!with_jacobians) {
            p[3 * 3 + 2] += 0.125;
            CHECK_OK(ffd_mesh_set_positions(m, p, NULL, &check_err_));
            mask = changed_lines(m, identity_obj);
            CHECK(mask == (V6 | VN3 | (1u << 4) | VN1));
            if (mask != (V6 | VN3 | (1u << 4) | VN1))
                fprintf(stderr, "  changed lines %#x\n", mask);
        }
        free(J);
        free(p);
        ffd_mesh_destroy(m);
    }
}

/* Binary files: a -0.0 coordinate (PLY double and float, STL float) set to
 * +0.0 keeps its bytes; an unmoved STL facet keeps its normal. */
static void test_identity_binary_signed_zero(void)
{
    const double pos[12] = {-0.0, 0, 0, 1, -0.0, 0, 0, 1, -0.0, 0.1, 0.2, 1};
    const uint32_t off[3] = {0, 3, 6}, idx[6] = {0, 1, 2, 0, 2, 3};
    ffd_mesh *made = NULL;
    CHECK_OK(ffd_mesh_create(pos, 4, off, idx, 2, &made, &check_err_));
    if (!made)
        return;
    const struct {
        ffd_format format;
        ffd_encoding encoding;
    } kinds[] = {{FFD_FORMAT_PLY, FFD_ENCODING_BINARY_LE},
                 {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_BE},
                 {FFD_FORMAT_STL, FFD_ENCODING_BINARY_LE},
                 {FFD_FORMAT_STL, FFD_ENCODING_ASCII},
                 {FFD_FORMAT_OFF, FFD_ENCODING_ASCII}};
    for (size_t k = 0; k < sizeof kinds / sizeof *kinds; k++) {
        size_t size = 0;
        unsigned char *file = write_mem(made, kinds[k].format, kinds[k].encoding, &size);
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        CHECK(file && ffd_mesh_read_memory(file, size, kinds[k].format, "z", &m, &err) == FFD_OK);
        if (m) {
            size_t nv = ffd_mesh_vertex_count(m);
            double *p = malloc(3 * nv * sizeof *p);
            size_t negative = 0;
            for (size_t i = 0; i < 3 * nv; i++) {
                negative += signbit(ffd_mesh_positions(m)[i]) != 0;
                p[i] = ffd_mesh_positions(m)[i] + 0.0;
            }
            CHECK(negative > 0);
            CHECK_OK(ffd_mesh_set_positions(m, p, NULL, &check_err_));
            CHECK(writes_back(m, file, size));
            free(p);
        }
        ffd_mesh_destroy(m);
        ffd_free(file);
    }
    ffd_mesh_destroy(made);
}

static void test_obj_jacobian_and_transcode_deformed(void)
{
    ffd_mesh *m = read_path(FIX "all_forms.obj");
    CHECK(m);
    if (!m)
        return;
    /* Rotation by 90 degrees about z: x' = -y, y' = x. Normals rotate the same way. */
    size_t nv = ffd_mesh_vertex_count(m), nn = ffd_mesh_normal_count(m);
    double *p = malloc(3 * nv * sizeof *p), *J = calloc(9 * nv, sizeof *J);
    double n0[21];
    memcpy(n0, ffd_mesh_normals(m), sizeof n0);
    for (size_t i = 0; i < nv; i++) {
        const double *x = ffd_mesh_positions(m) + 3 * i;
        p[3 * i] = -x[1];
        p[3 * i + 1] = x[0];
        p[3 * i + 2] = x[2];
        double R[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
        memcpy(J + 9 * i, R, sizeof R);
    }
    CHECK_OK(ffd_mesh_set_positions(m, p, J, &check_err_));
    const double *n = ffd_mesh_normals(m);
    for (size_t i = 0; i < nn; i++) {
        bool anchored = ffd_mesh_normal_anchors(m)[i] != FFD_NO_ANCHOR;
        CHECK_NEAR(n[3 * i], anchored ? -n0[3 * i + 1] : n0[3 * i], 1e-15);
        CHECK_NEAR(n[3 * i + 1], anchored ? n0[3 * i] : n0[3 * i + 1], 1e-15);
        CHECK_NEAR(n[3 * i + 2], n0[3 * i + 2], 1e-15);
    }
    /* Singular Jacobian (flatten to a plane; the points move, so the normals go
     * through the cofactor): (0,0,+-1) is kept. */
    memset(J, 0, 9 * nv * sizeof *J);
    for (size_t i = 0; i < nv; i++) {
        J[9 * i] = J[9 * i + 4] = 1;
        p[3 * i] += 0.5;
    }
    double before[21];
    memcpy(before, ffd_mesh_normals(m), sizeof before);
    CHECK_OK(ffd_mesh_set_positions(m, p, J, &check_err_));
    CHECK(ffd_mesh_normals(m)[0] == before[0] && ffd_mesh_normals(m)[2] == before[2]);
    ffd_mesh_destroy(m);
    free(p);
    free(J);

    /* Deformed PLY written in another encoding: values re-encoded, extras intact. */
    m = read_path(FIX "cube_ascii.ply");
    CHECK(m);
    if (!m)
        return;
    nv = ffd_mesh_vertex_count(m);
    p = malloc(3 * nv * sizeof *p);
    for (size_t i = 0; i < 3 * nv; i++)
        p[i] = ffd_mesh_positions(m)[i] * 0.5 + 0.125;
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, &check_err_));
    size_t size = 0;
    unsigned char *out = write_mem(m, FFD_FORMAT_PLY, FFD_ENCODING_BINARY_BE, &size);
    ffd_mesh *r = NULL;
    CHECK(out && ffd_mesh_read_memory(out, size, FFD_FORMAT_PLY, "t.ply", &r, NULL) == FFD_OK);
    if (r) {
        CHECK(memcmp(ffd_mesh_positions(r), p, 3 * nv * sizeof *p) == 0); /* exact in float */
        CHECK(size == 871 && memcmp(out, "ply\nformat binary_big_endian 1.0\n", 33) == 0);
    }
    ffd_mesh_destroy(r);
    ffd_free(out);
    free(p);
    ffd_mesh_destroy(m);
}

/* ---------------------------------------------------------------------- */

static void check_convert(const char *path)
{
    static const struct {
        ffd_format f;
        ffd_encoding e;
    } targets[] = {
        {FFD_FORMAT_OBJ, FFD_ENCODING_SAME},       {FFD_FORMAT_OFF, FFD_ENCODING_SAME},
        {FFD_FORMAT_PLY, FFD_ENCODING_ASCII},      {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_LE},
        {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_BE},  {FFD_FORMAT_STL, FFD_ENCODING_ASCII},
        {FFD_FORMAT_STL, FFD_ENCODING_BINARY_LE},
    };
    ffd_mesh *m = read_path(path);
    CHECK(m);
    if (!m)
        return;
    const double *P = ffd_mesh_positions(m);
    const uint32_t *off = ffd_mesh_face_offsets(m), *ix = ffd_mesh_face_indices(m);
    size_t nf = ffd_mesh_face_count(m), nv = ffd_mesh_vertex_count(m);
    for (size_t t = 0; t < sizeof targets / sizeof *targets; t++) {
        size_t size = 0;
        unsigned char *out = write_mem(m, targets[t].f, targets[t].e, &size);
        ffd_mesh *r = NULL;
        ffd_error err = {{0}};
        CHECK(out && ffd_mesh_read_memory(out, size, targets[t].f, "converted", &r, &err) == FFD_OK);
        if (!r) {
            fprintf(stderr, "  %s -> format %d: %s\n", path, (int)targets[t].f, err.message);
            ffd_free(out);
            continue;
        }
        const double *Q = ffd_mesh_positions(r);
        size_t bad = 0;
        if (targets[t].f == FFD_FORMAT_STL) {
            /* fan triangles, corner by corner */
            bool f32 = targets[t].e == FFD_ENCODING_BINARY_LE;
            size_t tri = 0;
            for (size_t f = 0; f < nf; f++)
                for (uint32_t k = off[f] + 1; k + 1 < off[f + 1]; k++, tri++) {
                    uint32_t c[3] = {ix[off[f]], ix[k], ix[k + 1]};
                    for (int j = 0; j < 3; j++)
                        for (int d = 0; d < 3; d++) {
                            double w = P[3 * c[j] + d];
                            if (f32)
                                w = (double)(float)w;
                            bad += tri < ffd_mesh_face_count(r) && Q[9 * tri + 3 * j + d] != w;
                        }
                }
            CHECK(ffd_mesh_face_count(r) == tri);
        } else {
            CHECK(ffd_mesh_vertex_count(r) == nv && ffd_mesh_face_count(r) == nf);
            for (size_t i = 0; i < 3 * nv && ffd_mesh_vertex_count(r) == nv; i++)
                bad += Q[i] != P[i];
            if (ffd_mesh_face_count(r) == nf)
                bad += memcmp(ffd_mesh_face_offsets(r), off, (nf + 1) * sizeof *off) != 0 ||
                       memcmp(ffd_mesh_face_indices(r), ix, off[nf] * sizeof *ix) != 0;
        }
        CHECK(bad == 0);
        if (bad)
            fprintf(stderr, "  %s -> format %d encoding %d: %zu mismatches\n", path,
                    (int)targets[t].f, (int)targets[t].e, bad);
        ffd_mesh_destroy(r);
        ffd_free(out);
    }
    ffd_mesh_destroy(m);
}

static void test_cross_format(void)
{
    char path[512];
    for (size_t i = 0; i < sizeof fixtures / sizeof *fixtures; i++) {
        snprintf(path, sizeof path, FIX "%s", fixtures[i]);
        check_convert(path);
    }
    for (size_t i = 0; i < 5; i++) {
        snprintf(path, sizeof path, SHARED "%s", shared_files[i]);
        check_convert(path);
    }
    /* Per-vertex normals travel PLY -> OBJ (vn) -> PLY. */
    ffd_mesh *m = read_path(FIX "cube_ble.ply");
    size_t size = 0;
    unsigned char *out = m ? write_mem(m, FFD_FORMAT_OBJ, FFD_ENCODING_SAME, &size) : NULL;
    ffd_mesh *r = NULL;
    CHECK(out && ffd_mesh_read_memory(out, size, FFD_FORMAT_OBJ, "x.obj", &r, NULL) == FFD_OK);
    CHECK(r && ffd_mesh_normal_count(r) == 8 &&
          memcmp(ffd_mesh_normals(r), ffd_mesh_normals(m), 24 * sizeof(double)) == 0);
    ffd_free(out);
    ffd_mesh_destroy(r);
    ffd_mesh_destroy(m);
}

static void test_create_and_info(void)
{
    const double P[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const uint32_t off[5] = {0, 3, 6, 9, 12};
    const uint32_t ix[12] = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create(P, 4, off, ix, 4, &m, &check_err_));
    ffd_mesh_info info;
    CHECK_OK(ffd_mesh_compute_info(m, &info, NULL));
    CHECK(info.welded_vertex_count == 4 && info.edge_count == 6 && info.closed == 1);
    CHECK(info.bbox_max[2] == 1 && info.bbox_min[0] == 0);
    CHECK(ffd_mesh_source_format(m) == FFD_FORMAT_AUTO && ffd_mesh_normals(m) == NULL);
    size_t size = 0;
    unsigned char *out = write_mem(m, FFD_FORMAT_OFF, FFD_ENCODING_SAME, &size);
    CHECK(out && size == strlen("OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n"));
    ffd_free(out);
    /* Three faces on one edge: non-manifold; drop one face: boundary. */
    const uint32_t off2[4] = {0, 3, 6, 9};
    const uint32_t ix2[9] = {0, 1, 2, 0, 1, 3, 1, 0, 3};
    ffd_mesh *m2 = NULL;
    CHECK_OK(ffd_mesh_create(P, 4, off2, ix2, 3, &m2, &check_err_));
    CHECK_OK(ffd_mesh_compute_info(m2, &info, NULL));
    CHECK(info.nonmanifold_edge_count == 1 && info.closed == 0);
    ffd_mesh_destroy(m2);
    ffd_mesh_destroy(m);
    ffd_error err = {{0}};
    const uint32_t badix[3] = {0, 1, 7};
    CHECK(ffd_mesh_create(P, 4, off, badix, 1, &m, &err) == FFD_ERR_RANGE && m == NULL);
    const double nanP[3] = {NAN, 0, 0};
    CHECK(ffd_mesh_create(nanP, 1, NULL, NULL, 0, &m, &err) == FFD_ERR_NONFINITE);
    const uint32_t off_short[2] = {0, 2};
    CHECK(ffd_mesh_create(P, 4, off_short, ix, 1, &m, &err) == FFD_ERR_INVALID);
    CHECK(ffd_format_from_path("a/b.OBJ") == FFD_FORMAT_OBJ && ffd_format_from_path("x.Ply") == FFD_FORMAT_PLY &&
          ffd_format_from_path("x.off") == FFD_FORMAT_OFF && ffd_format_from_path("x.stl") == FFD_FORMAT_STL &&
          ffd_format_from_path("x.txt") == FFD_FORMAT_AUTO && ffd_format_from_path("a.obj/x") == FFD_FORMAT_AUTO);
}

/* ---------------------------------------------------------------------- */

static int has_location(const char *msg, const char *name);

typedef struct {
    const char *text;
    size_t size; /* 0: strlen(text) */
    ffd_format format;
    ffd_status status;
    const char *fragment; /* must occur in the message */
} bad_case;

static void test_bad_inputs(void)
{
    static const char huge_ply[] = "ply\nformat binary_little_endian 1.0\nelement vertex 1099511627776\n"
                                   "property float x\nproperty float y\nproperty float z\nend_header\n";
    static const char trunc_ply[] = "ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
                                    "property float x\nproperty float y\nproperty float z\nend_header\n"
                                    "\0\0\0\0\0\0\0\0\0\0";
    static const bad_case cases[] = {
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 0, FFD_FORMAT_OBJ, FFD_ERR_RANGE, "t:4: vertex index 4 out of range"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", 0, FFD_FORMAT_OBJ, FFD_ERR_RANGE, "t:4: vertex index 0"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", 0, FFD_FORMAT_OBJ, FFD_ERR_RANGE, "t:4:"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", 0, FFD_FORMAT_OBJ, FFD_ERR_RANGE, "texcoord"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//2 2 3\n", 0, FFD_FORMAT_OBJ, FFD_ERR_RANGE, "normal"},
        {"v 0 0 0\nv 1 0 0\nf 1 2\n", 0, FFD_FORMAT_OBJ, FFD_ERR_PARSE, "t:3: face has 2 vertices"},
        {"v 0 0 0\nv 1 inf 0\n", 0, FFD_FORMAT_OBJ, FFD_ERR_NONFINITE, "t:2:"},
        {"v 0 0 0\nv 1 0 nan\n", 0, FFD_FORMAT_OBJ, FFD_ERR_NONFINITE, "t:2:"},
        {"v 0 0\n", 0, FFD_FORMAT_OBJ, FFD_ERR_PARSE, "t:1: expected 3 coordinates"},
        {"v 0 0 0x\n", 0, FFD_FORMAT_OBJ, FFD_ERR_PARSE, "t:1: expected a number"},
        {"v 0 0 0\n\nv 1 0 abc\n", 0, FFD_FORMAT_OBJ, FFD_ERR_PARSE, "t:3: expected a number, found 'abc'"},
        {"v 0 0 0\nf 1 1/x 1\n", 0, FFD_FORMAT_OBJ, FFD_ERR_PARSE, "t:2: expected a face corner"},
        {"vn 0 0\n", 0, FFD_FORMAT_OBJ, FFD_ERR_PARSE, "t:1:"},
        {"", 0, FFD_FORMAT_OBJ, FFD_ERR_PARSE, "empty"},
        {"", 0, FFD_FORMAT_PLY, FFD_ERR_PARSE, "empty"},
        {"", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE, "empty"},
        {"", 0, FFD_FORMAT_STL, FFD_ERR_PARSE, "empty"},
        {"OFF\n5 1 0\n0 0 0\n1 0 0\n0 1 0\n", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE, "t:6: expected vertex 4 of 5"},
        {"OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE, "t:7: expected face 2"},
        {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE,
         "t:7: unexpected data"},
        {"OFF\n3 1 0\n0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE, "t:4: expected"},
        {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", 0, FFD_FORMAT_OFF, FFD_ERR_RANGE, "t:6: face index 3"},
        {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE, "t:6: face 1 has 2"},
        {"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE, "t:6:"},
        {"OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n", 0, FFD_FORMAT_OFF, FFD_ERR_NONFINITE, "t:4:"},
        {"OFF\n3000000000 1 0\n0 0 0\n", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE, "t:4: expected vertex 2 of 3000000000, found end of file"},
        {"OFX\n3 1 0\n", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE, "t:1: expected an OFF header"},
        {"OFF\n3 1 zero\n", 0, FFD_FORMAT_OFF, FFD_ERR_PARSE, "t:2:"},
        {"OFF BINARY\n3 1 0\n", 0, FFD_FORMAT_OFF, FFD_ERR_UNSUPPORTED, "t:1:"},
        {"ply\nformat ascii 2.0\nend_header\n", 0, FFD_FORMAT_PLY, FFD_ERR_PARSE, "t:2:"},
        {"ply\nformat binary_middle_endian 1.0\nend_header\n", 0, FFD_FORMAT_PLY, FFD_ERR_PARSE,
         "t:2: unknown PLY format"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n", 0, FFD_FORMAT_PLY,
         FFD_ERR_PARSE, "t:4: unknown property type 'float128'"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n",
         0, FFD_FORMAT_PLY, FFD_ERR_PARSE, "t:8: header declares 1 'vertex'"},
        {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 0 0\n1 1\n",
         0, FFD_FORMAT_PLY, FFD_ERR_PARSE, "t:"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 0 0\n1 1 1\n",
         0, FFD_FORMAT_PLY, FFD_ERR_PARSE, "t:9: unexpected data"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
         "end_header\n0 nan 0\n",
         0, FFD_FORMAT_PLY, FFD_ERR_NONFINITE, "t:8:"},
        {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
         0, FFD_FORMAT_PLY, FFD_ERR_RANGE, "t:13: face index 3"},
        {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
         0, FFD_FORMAT_PLY, FFD_ERR_PARSE, "t:13: face 0 has 2"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n", 0,
         FFD_FORMAT_PLY, FFD_ERR_PARSE, "lacks x, y and z"},
        {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", 0, FFD_FORMAT_PLY, FFD_ERR_PARSE,
         "t:5: expected 'end_header'"},
        {"plyx\n", 0, FFD_FORMAT_PLY, FFD_ERR_PARSE, "t:1: expected 'ply'"},
        {huge_ply, 0, FFD_FORMAT_PLY, FFD_ERR_PARSE, "header declares 1099511627776"},
        {trunc_ply, sizeof trunc_ply - 1, FFD_FORMAT_PLY, FFD_ERR_PARSE, "t: byte 115: header declares 1 'vertex' elements"},
        {"solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 0\n vertex 1 0 0\n endloop\n", 0,
         FFD_FORMAT_STL, FFD_ERR_PARSE, "t:6: expected 'vertex'"},
        {"solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 0\n vertex 1 0 0\n vertex 1 1 nan\n"
         " endloop\n endfacet\nendsolid x\n",
         0, FFD_FORMAT_STL, FFD_ERR_NONFINITE, "t:6:"},
        {"solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 0\n vertex 1 0 0\n vertex 1 1 0\n"
         " endloop\n endfacet\nendsolid x\ngarbage\n",
         0, FFD_FORMAT_STL, FFD_ERR_PARSE, "t:10:"},
        {"solid x\n facet normal 0 0 1\n", 0, FFD_FORMAT_STL, FFD_ERR_PARSE, "t:3: expected 'outer'"},
        {"binary header too short", 0, FFD_FORMAT_STL, FFD_ERR_PARSE, "byte"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        size_t size = cases[i].size ? cases[i].size : strlen(cases[i].text);
        ffd_mesh *m = (ffd_mesh *)1;
        ffd_error err = {{0}};
        ffd_status s = ffd_mesh_read_memory(cases[i].text, size, cases[i].format, "t", &m, &err);
        bool ok = s == cases[i].status && m == NULL && strstr(err.message, cases[i].fragment) &&
                  (s == FFD_ERR_UNSUPPORTED || has_location(err.message, "t"));
        CHECK(ok);
        if (!ok)
            fprintf(stderr, "  case %zu: status %d (want %d), message '%s' (want '%s')\n", i, (int)s,
                    (int)cases[i].status, err.message, cases[i].fragment);
        ffd_mesh_destroy(m == (ffd_mesh *)1 ? NULL : m);
    }
}

static void test_bad_files(void)
{
    static const struct {
        const char *name;
        ffd_status status;
        const char *fragment;
    } cases[] = {
        {"bad_index.obj", FFD_ERR_RANGE, "bad_index.obj:4: vertex index 9 out of range (3 vertices defined)"},
        {"bad_nan.obj", FFD_ERR_NONFINITE, "bad_nan.obj:2:"},
        {"bad_counts.off", FFD_ERR_PARSE, "bad_counts.off:6: expected vertex 4 of 5"},
        {"bad_format.ply", FFD_ERR_PARSE, "bad_format.ply:2: unknown PLY format"},
        {"bad_huge.ply", FFD_ERR_PARSE, "bad_huge.ply: byte 127: header declares 1099511627776"},
        {"bad_size.stl", FFD_ERR_PARSE, "bad_size.stl: byte 80: binary STL declares 3 triangles"},
        {"empty.obj", FFD_ERR_PARSE, "empty.obj: byte 0: empty file"},
        {"missing.obj", FFD_ERR_IO, "missing.obj"},
        {"", FFD_ERR_INVALID, "extension"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        char path[512];
        snprintf(path, sizeof path, FIX "%s", cases[i].name);
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        double t0 = ffd_now();
        ffd_status s = ffd_mesh_read(path, &m, &err);
        CHECK(ffd_now() - t0 < 0.5);
        bool ok = s == cases[i].status && m == NULL && strstr(err.message, cases[i].fragment);
        CHECK(ok);
        if (!ok)
            fprintf(stderr, "  %s: status %d (want %d), message '%s'\n", cases[i].name, (int)s,
                    (int)cases[i].status, err.message);
        ffd_mesh_destroy(m);
    }
    /* A directory named like a mesh. */
    mkdir("test_mesh_dir.obj", 0755);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_read("test_mesh_dir.obj", &m, &err) == FFD_ERR_IO && strstr(err.message, "directory"));
    rmdir("test_mesh_dir.obj");
}

/* The message names the file, then a line ("name:12:") or a byte offset ("name: byte 80:"). */
static int has_location(const char *msg, const char *name)
{
    size_t n = strlen(name);
    if (strncmp(msg, name, n) != 0)
        return 0;
    msg += n;
    if (msg[0] == ':' && msg[1] >= '0' && msg[1] <= '9')
        return 1;
    return strncmp(msg, ": byte ", 7) == 0 && msg[7] >= '0' && msg[7] <= '9';
}

/* Every prefix of every fixture either parses or fails with a located message. */
static void test_truncated_prefixes(void)
{
    char path[512];
    static const char *const more[] = {"hinge.stl", "bunny.obj", "cow.off"};
    size_t nfix = sizeof fixtures / sizeof *fixtures;
    for (size_t i = 0; i < nfix + 3; i++) {
        if (i < nfix)
            snprintf(path, sizeof path, FIX "%s", fixtures[i]);
        else
            snprintf(path, sizeof path, SHARED "%s", more[i - nfix]);
        size_t size = 0;
        unsigned char *d = load(path, &size);
        CHECK(d);
        if (!d)
            continue;
        if (size > 3000)
            size = 3000;
        ffd_format f = ffd_format_from_path(path);
        size_t parsed = 0, failed = 0;
        for (size_t n = 0; n < size; n++) {
            ffd_mesh *m = NULL;
            ffd_error err = {{0}};
            ffd_status s = ffd_mesh_read_memory(d, n, f, path, &m, &err);
            if (s == FFD_OK) {
                parsed++;
                CHECK(m != NULL);
            } else {
                failed++;
                CHECK(m == NULL && err.message[0] != 0);
                CHECK(has_location(err.message, path));
                if (!has_location(err.message, path))
                    fprintf(stderr, "  prefix %zu of %s: '%s'\n", n, path, err.message);
            }
            ffd_mesh_destroy(m);
        }
        CHECK(failed > 0);
        ffd_free(d);
        (void)parsed;
    }
}

static void test_atomic_write(void)
{
    ffd_mesh *m = read_path(FIX "all_forms.obj");
    CHECK(m);
    if (!m)
        return;
    const char *path = "test_mesh_atomic.obj";
    FILE *f = fopen(path, "wb");
    fputs("keep me", f);
    fclose(f);
    ffd_error err = {{0}};
    ffd_write_options bin = {FFD_FORMAT_OBJ, FFD_ENCODING_BINARY_LE, 0};
    CHECK(ffd_mesh_write(m, path, &bin, &err) == FFD_ERR_UNSUPPORTED && strstr(err.message, path));
    size_t size = 0;
    unsigned char *d = load(path, &size);
    CHECK(d && size == 7 && memcmp(d, "keep me", 7) == 0);
    ffd_free(d);
    CHECK(ffd_mesh_write(m, "no/such/dir/out.obj", NULL, &err) == FFD_ERR_IO);
    CHECK(ffd_mesh_write(m, "out.fbx", NULL, &err) == FFD_ERR_INVALID);
    CHECK_OK(ffd_mesh_write(m, path, NULL, &check_err_));
    d = load(path, &size);
    size_t want_size = 0;
    unsigned char *want = load(FIX "all_forms.obj", &want_size);
    CHECK(d && want && size == want_size && memcmp(d, want, size) == 0);
    ffd_free(d);
    ffd_free(want);
    /* an existing file keeps its permissions; a symbolic link stays a link */
    chmod(path, 0600);
    CHECK_OK(ffd_mesh_write(m, path, NULL, &check_err_));
    struct stat st;
    CHECK(stat(path, &st) == 0 && (st.st_mode & 0777) == 0600);
    const char *link = "test_mesh_atomic_link.obj";
    remove(link);
    CHECK(symlink(path, link) == 0);
    CHECK_OK(ffd_mesh_write(m, link, NULL, &check_err_));
    struct stat lst;
    CHECK(lstat(link, &lst) == 0 && S_ISLNK(lst.st_mode));
    remove(link);
    remove(path);
    ffd_mesh_destroy(m);
}

/* a PLY value outside its declared type is refused, never clamped or overflowed */
static void test_ply_value_range(void)
{
    const char *ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                      "property float y\nproperty float z\nelement face 1\n"
                      "property list uchar int vertex_indices\nend_header\n"
                      "0 0 0\n1 0 1e300\n0 1 0\n3 0 1 2\n";
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_read_memory(ply, strlen(ply), FFD_FORMAT_PLY, "range.ply", &m, &err) ==
          FFD_ERR_RANGE);
    CHECK(m == NULL && strstr(err.message, "range.ply:") && strstr(err.message, "float"));
    /* a deformation that leaves float range cannot be written as binary float */
    const char *ok = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                     "property float y\nproperty float z\nelement face 1\n"
                     "property list uchar int vertex_indices\nend_header\n"
                     "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    CHECK_OK(ffd_mesh_read_memory(ok, strlen(ok), FFD_FORMAT_PLY, "ok.ply", &m, &check_err_));
    if (!m)
        return;
    double p[9] = {0, 0, 0, 1e300, 0, 0, 0, 1, 0};
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, &check_err_));
    ffd_write_options bin = {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_LE, 0};
    unsigned char *data = NULL;
    size_t size = 0;
    CHECK(ffd_mesh_write_memory(m, &bin, &data, &size, &err) == FFD_ERR_RANGE);
    CHECK(data == NULL);
    ffd_mesh_destroy(m);
}

/* ---------------------------------------------------------------------- */

static void test_failing_allocations(void)
{
    char path[512];
    for (size_t i = 0; i < sizeof fixtures / sizeof *fixtures; i++) {
        snprintf(path, sizeof path, FIX "%s", fixtures[i]);
        for (long k = 0;; k += check_sweep_step()) {
            fail_alloc fa = {k, 0};
            ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
            ffd_set_allocator(&a);
            ffd_mesh *m = NULL;
            ffd_error err = {{0}};
            ffd_status s = ffd_mesh_read(path, &m, &err);
            unsigned char *out = NULL;
            size_t size = 0;
            ffd_status w = FFD_OK;
            if (s == FFD_OK) {
                ffd_write_options o = {FFD_FORMAT_PLY, FFD_ENCODING_BINARY_BE, 0};
                w = ffd_mesh_write_memory(m, &o, &out, &size, &err);
            }
            ffd_free(out);
            ffd_mesh_destroy(m);
            ffd_set_allocator(NULL);
            CHECK(s == FFD_OK || s == FFD_ERR_NOMEM);
            CHECK(w == FFD_OK || w == FFD_ERR_NOMEM);
            if (s == FFD_OK && w == FFD_OK)
                break;
            if (k > 10000) {
                CHECK(!"allocation sweep did not finish");
                break;
            }
        }
    }
}

/* ---------------------------------------------------------------------- */

/* A UTF-8 byte order mark before the first line (issue 14: the first 'v' line
 * of an OBJ was lost, every face then pointed one vertex off, and the read
 * succeeded): every text format reads it, keeps it, and writes it back. */
static void check_bom(const char *src, size_t size, ffd_format format, ffd_encoding transcode)
{
    static const double want[9] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_read_memory(src, size, format, "bom", &m, &err) == FFD_OK);
    if (!m) {
        fprintf(stderr, "  %s\n", err.message);
        return;
    }
    CHECK(ffd_mesh_vertex_count(m) == 3 && ffd_mesh_face_count(m) == 1);
    if (ffd_mesh_vertex_count(m) == 3)
        CHECK(memcmp(ffd_mesh_positions(m), want, sizeof want) == 0);
    const uint32_t *ix = ffd_mesh_face_indices(m);
    CHECK(ffd_mesh_face_count(m) == 1 && ix[0] == 0 && ix[1] == 1 && ix[2] == 2);
    /* untouched: byte for byte, the mark included */
    size_t n = 0;
    unsigned char *out = write_mem(m, format, FFD_ENCODING_SAME, &n);
    CHECK(out && n == size && memcmp(out, src, size) == 0);
    ffd_free(out);
    /* moved: the mark stays and the file reads back to the new positions */
    double q[9];
    for (int i = 0; i < 9; i++)
        q[i] = want[i] + 0.5;
    CHECK_OK(ffd_mesh_set_positions(m, q, NULL, NULL));
    out = write_mem(m, format, FFD_ENCODING_SAME, &n);
    CHECK(out && n >= 3 && memcmp(out, "\xEF\xBB\xBF", 3) == 0);
    ffd_mesh *r = NULL;
    CHECK(out && ffd_mesh_read_memory(out, n, format, "bom-out", &r, &err) == FFD_OK);
    CHECK(r && ffd_mesh_vertex_count(r) == 3 && memcmp(ffd_mesh_positions(r), q, sizeof q) == 0);
    ffd_mesh_destroy(r);
    ffd_free(out);
    if (transcode != FFD_ENCODING_SAME) { /* the other encoding keeps the mark too */
        out = write_mem(m, format, transcode, &n);
        r = NULL;
        CHECK(out && n >= 3 && memcmp(out, "\xEF\xBB\xBF", 3) == 0);
        CHECK(out && ffd_mesh_read_memory(out, n, format, "bom-transcoded", &r, &err) == FFD_OK);
        CHECK(r && ffd_mesh_vertex_count(r) == 3);
        if (r && ffd_mesh_vertex_count(r) == 3)
            for (int i = 0; i < 9; i++)
                CHECK_NEAR(ffd_mesh_positions(r)[i], q[i], 1e-6);
        ffd_mesh_destroy(r);
        ffd_free(out);
    }
    /* another format is written from data, without the mark */
    ffd_format other = format == FFD_FORMAT_OBJ ? FFD_FORMAT_OFF : FFD_FORMAT_OBJ;
    out = write_mem(m, other, FFD_ENCODING_SAME, &n);
    r = NULL;
    CHECK(out && ffd_mesh_read_memory(out, n, other, "bom-converted", &r, &err) == FFD_OK);
    CHECK(r && ffd_mesh_vertex_count(r) == 3 && memcmp(ffd_mesh_positions(r), q, sizeof q) == 0);
    ffd_mesh_destroy(r);
    ffd_free(out);
    ffd_mesh_destroy(m);
}

static void test_utf8_bom(void)
{
    static const char obj[] = "\xEF\xBB\xBFv 1 2 3\nv 4 5 6\nv 7 8 9\nf 1 2 3\n";
    check_bom(obj, sizeof obj - 1, FFD_FORMAT_OBJ, FFD_ENCODING_SAME);
    static const char obj_comment[] = "\xEF\xBB\xBF# made on Windows\r\nv 1 2 3\r\nv 4 5 6\r\nv 7 8 9\r\nf 1 2 3\r\n";
    check_bom(obj_comment, sizeof obj_comment - 1, FFD_FORMAT_OBJ, FFD_ENCODING_SAME);
    static const char off[] = "\xEF\xBB\xBFOFF\n3 1 0\n1 2 3\n4 5 6\n7 8 9\n3 0 1 2\n";
    check_bom(off, sizeof off - 1, FFD_FORMAT_OFF, FFD_ENCODING_SAME);
    static const char noff[] = "\xEF\xBB\xBFNOFF 3 1 0\n1 2 3 0 0 1\n4 5 6 0 0 1\n7 8 9 0 0 1\n3 0 1 2\n";
    check_bom(noff, sizeof noff - 1, FFD_FORMAT_OFF, FFD_ENCODING_SAME);
#define BOM_PLY_HEADER(fmt)                                                                        \
    "\xEF\xBB\xBFply\nformat " fmt " 1.0\nelement vertex 3\nproperty float x\nproperty float y\n" \
    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
    static const char ply[] = BOM_PLY_HEADER("ascii") "1 2 3\n4 5 6\n7 8 9\n3 0 1 2\n";
    check_bom(ply, sizeof ply - 1, FFD_FORMAT_PLY, FFD_ENCODING_BINARY_LE);
    /* binary data after a header with a mark */
    char bin[512];
    size_t nb = strlen(BOM_PLY_HEADER("binary_little_endian"));
    memcpy(bin, BOM_PLY_HEADER("binary_little_endian"), nb);
    for (int i = 0; i < 9; i++) {
        float f = (float)(i + 1);
        memcpy(bin + nb, &f, 4); /* the test hosts are little-endian */
        nb += 4;
    }
    bin[nb++] = 3;
    for (int32_t i = 0; i < 3; i++, nb += 4)
        memcpy(bin + nb, &i, 4);
    check_bom(bin, nb, FFD_FORMAT_PLY, FFD_ENCODING_ASCII);
#undef BOM_PLY_HEADER
    static const char stl[] = "\xEF\xBB\xBFsolid t\nfacet normal 0 0 1\nouter loop\nvertex 1 2 3\n"
                              "vertex 4 5 6\nvertex 7 8 9\nendloop\nendfacet\nendsolid t\n";
    check_bom(stl, sizeof stl - 1, FFD_FORMAT_STL, FFD_ENCODING_SAME);
    /* the mark belongs before the first line only: elsewhere it stays an error */
    static const char late[] = "OFF\n\xEF\xBB\xBF" "3 1 0\n1 2 3\n4 5 6\n7 8 9\n3 0 1 2\n";
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_read_memory(late, sizeof late - 1, FFD_FORMAT_OFF, "t", &m, &err) == FFD_ERR_PARSE);
    CHECK(!m && strstr(err.message, "t:2:"));
    static const char ply_late[] = "ply\n\xEF\xBB\xBF" "format ascii 1.0\nend_header\n";
    CHECK(ffd_mesh_read_memory(ply_late, sizeof ply_late - 1, FFD_FORMAT_PLY, "t", &m, &err) == FFD_ERR_PARSE);
    CHECK(!m);
}

/* The codec table (mesh_codec.c) is consistent with the public behaviour:
 * every format has exactly one codec, its extensions map back to it (any
 * case), a write succeeds exactly in the encodings it lists and is
 * FFD_ERR_UNSUPPORTED in the others, and the lists in messages name every
 * codec in table order. */

/* The printf loop that defines the text of a rewritten value: the first of
 * %.15g, %.16g, %.17g (floats: %.6g .. %.9g) that reads back exactly. */
static int format_by_printf(char *buf, double v, bool is_float)
{
    int n = 0;
    for (int prec = is_float ? 6 : 15; prec <= (is_float ? 9 : 17); prec++) {
        n = snprintf(buf, 32, "%.*g", prec, v);
        if (is_float ? strtof(buf, NULL) == (float)v : strtod(buf, NULL) == v)
            break;
    }
    return n;
}

static uint64_t format_rng = 88172645463325252ull;
static uint64_t next_bits(void)
{
    format_rng ^= format_rng << 13;
    format_rng ^= format_rng >> 7;
    format_rng ^= format_rng << 17;
    return format_rng;
}

static int format_mismatches;
static void check_format(double v)
{
    char a[40], b[40];
    int na = ffd_format_double(a, v), nb = format_by_printf(b, v, false);
    if ((na != nb || strcmp(a, b) != 0) && format_mismatches++ < 10)
        fprintf(stderr, "format_double(%a): '%s', printf loop '%s'\n", v, a, b);
    float f = (float)v;
    if (isfinite(v) && !isfinite(f))
        return;
    na = ffd_format_float(a, f);
    nb = format_by_printf(b, (double)f, true);
    if ((na != nb || strcmp(a, b) != 0) && format_mismatches++ < 10)
        fprintf(stderr, "format_float(%a): '%s', printf loop '%s'\n", (double)f, a, b);
}

/* The fast shortest printing gives exactly the printf loop's text: random
 * bit patterns, short decimals, powers of ten and their neighbours, values
 * that round up to a power of ten, ties, zeros, subnormals, huge values. */
static void test_format_matches_printf(void)
{
    format_mismatches = 0;
    /* a tenth of the random values under valgrind (FFD_TEST_QUICK): the
     * formatter's memory use does not depend on the value */
    const int samples = getenv("FFD_TEST_QUICK") ? 30000 : 300000;
    for (int i = 0; i < samples; i++) {
        uint64_t bits = next_bits();
        double v;
        memcpy(&v, &bits, 8);
        if (isfinite(v))
            check_format(v);
        /* the magnitudes meshes have */
        double u = (double)(next_bits() >> 11) / 9007199254740992.0;
        int e = (int)(next_bits() % 40) - 15;
        check_format((i & 1 ? -u : u) * pow(10.0, e));
        check_format((double)(int64_t)(next_bits() % 2000001 - 1000000) / 1000.0);
        check_format((double)(float)u * 3.0);
    }
    for (int e = -330; e <= 310; e++) {
        double p = pow(10.0, e);
        check_format(p);
        check_format(nextafter(p, 0.0));
        check_format(nextafter(p, INFINITY));
        check_format(-p);
        check_format(9.5 * p);
        check_format(0.5 * p);
        check_format(0.99999999999999999 * p);
        check_format(1.25 * p);
    }
    for (int k = 1; k <= 17; k++) /* k nines: rounds up to a power of ten at some precision */
        check_format(1.0 - pow(10.0, -k));
    const double special[] = {0.0, -0.0, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
                              0.1, 0.2, 0.3, 1.0 / 3.0, 2.0 / 3.0, 100.0, 1e15, 1e16, 1e17,
                              123456789012345678.0, 0.000123, 1e-5, 9.999999999999999e22,
                              4503599627370496.5, 9007199254740993.0};
    for (size_t i = 0; i < sizeof special / sizeof *special; i++) {
        check_format(special[i]);
        check_format(-special[i]);
    }
    CHECK(format_mismatches == 0);
}


static int parse_mismatches;
static void check_parse(const char *text)
{
    char *e1, *e2;
    double a = ffd_strtod(text, &e1), b = strtod(text, &e2);
    if ((memcmp(&a, &b, sizeof a) != 0 || e1 != e2) && parse_mismatches++ < 10)
        fprintf(stderr, "ffd_strtod('%s') = %a (end %td), strtod %a (end %td)\n", text, a,
                e1 - text, b, e2 - text);
}

/* ffd_strtod gives strtod's value (bit for bit) and end on plain decimals
 * (the fast path), their boundaries (19 digits, 2^53, 10^+-22) and what the
 * fast path leaves to strtod. */
static void test_strtod_matches(void)
{
    parse_mismatches = 0;
    static const char *const texts[] = {
        "0", "-0", "+0", "0.0", "-0.000000", "1", "1.", ".5", "-.5", "+.5", ".", "-", "+", "",
        "1e5", "1E5", "1e+5", "1e-5", "1e", "1e+", "1.e5", ".e5", "1.5#", "2.5 ", "3.25\n",
        "9007199254740992", "9007199254740993", "9007199254740994", "18014398509481985",
        "1234567890123456789", "12345678901234567890", "0.1234567890123456789",
        "1e22", "1e23", "1e-22", "1e-23", "123456789e-30", "4.9e-324", "1.7976931348623157e308",
        "1e400", "0x1p3", "inf", "-inf", "nan", "infinity", "1x", "1.5.5", "00000000000000000000001",
        "0.00000000000000000000000000001", "123.456e7", "-7.25e-3", "1e999999999999", "1_0"};
    for (size_t i = 0; i < sizeof texts / sizeof *texts; i++)
        check_parse(texts[i]);
    char buf[64];
    const int samples = getenv("FFD_TEST_QUICK") ? 20000 : 200000; /* as above */
    for (int i = 0; i < samples; i++) {
        uint64_t bits = next_bits();
        double v;
        memcpy(&v, &bits, 8);
        if (!isfinite(v))
            continue;
        snprintf(buf, sizeof buf, "%.*g", (int)(bits % 17) + 1, v);
        check_parse(buf);
        snprintf(buf, sizeof buf, "%.*f", (int)(bits % 12), (double)(int64_t)(next_bits() % 2000000001 - 1000000000) / 1e6);
        check_parse(buf);
        snprintf(buf, sizeof buf, "%.*e", (int)(bits % 20), (double)(next_bits() >> 11) * 1e-10);
        check_parse(buf);
    }
    CHECK(parse_mismatches == 0);
}


/* Binary PLY records are read directly until one is not well formed; the
 * general loop then reports it, at the byte of the bad value, as before. */
static void test_ply_binary_direct_path(void)
{
    const char header[] = "ply\nformat binary_little_endian 1.0\nelement vertex 4\n"
                          "property float x\nproperty float y\nproperty float z\n"
                          "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
    size_t hl = sizeof header - 1, size = hl + 4 * 12 + 2 * 13;
    unsigned char *buf = calloc(1, size);
    memcpy(buf, header, hl);
    for (int i = 0; i < 12; i++) {
        float f = (float)(i % 3 == 0 ? i : -0.5 * i);
        memcpy(buf + hl + 4 * (size_t)i, &f, 4);
    }
    const int32_t faces[2][3] = {{0, 1, 2}, {1, 3, 2}};
    for (int f = 0; f < 2; f++) {
        buf[hl + 48 + 13 * (size_t)f] = 3;
        memcpy(buf + hl + 48 + 13 * (size_t)f + 1, faces[f], 12);
    }
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_read_memory(buf, size, FFD_FORMAT_PLY, "p.ply", &m, &err) == FFD_OK);
    if (m) {
        CHECK(ffd_mesh_vertex_count(m) == 4 && ffd_mesh_face_count(m) == 2);
        CHECK(ffd_mesh_positions(m)[3 * 3 + 1] == -5.0);
        CHECK(ffd_mesh_face_indices(m)[4] == 3);
        CHECK(m->position_spans[3 * 2 + 1].offset == hl + 28);
        ffd_mesh_destroy(m);
    }
    /* vertex 2's y is NaN: the error names its byte */
    float nan_f = NAN;
    unsigned char *bad = malloc(size);
    memcpy(bad, buf, size);
    memcpy(bad + hl + 28, &nan_f, 4);
    char want[64];
    snprintf(want, sizeof want, "p.ply: byte %zu: non-finite 'y' of vertex 2", hl + 28);
    CHECK(ffd_mesh_read_memory(bad, size, FFD_FORMAT_PLY, "p.ply", &m, &err) == FFD_ERR_NONFINITE);
    CHECK(strstr(err.message, want) != NULL);
    /* face 1's second index is out of range */
    memcpy(bad, buf, size);
    int32_t big = 4;
    memcpy(bad + hl + 48 + 13 + 1 + 4, &big, 4);
    snprintf(want, sizeof want, "p.ply: byte %zu: face index 4 out of range", hl + 48 + 13 + 5);
    CHECK(ffd_mesh_read_memory(bad, size, FFD_FORMAT_PLY, "p.ply", &m, &err) == FFD_ERR_RANGE);
    CHECK(strstr(err.message, want) != NULL);
    /* face 1 has 2 corners */
    memcpy(bad, buf, size);
    bad[hl + 48 + 13] = 2;
    CHECK(ffd_mesh_read_memory(bad, size - 4, FFD_FORMAT_PLY, "p.ply", &m, &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "face 1 has 2 vertices") != NULL);
    if (check_failures)
        fprintf(stderr, "last message: %s\n", err.message);
    free(bad);
    free(buf);
}

static void test_codec_table(void)
{
    static const double P[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    static const uint32_t off[2] = {0, 3}, idx[3] = {0, 1, 2};
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_create(P, 3, off, idx, 1, &m, &err) == FFD_OK);
    CHECK(ffd_mesh_codec_find(FFD_FORMAT_AUTO) == NULL);
    CHECK(ffd_mesh_codec_find((ffd_format)(FFD_FORMAT_NPY + 1)) == NULL);
    CHECK(ffd_mesh_codec_for_extension("fbx") == NULL);
    for (int f = FFD_FORMAT_OBJ; f <= FFD_FORMAT_GLTF; f++) {
        const ffd_mesh_codec *c = ffd_mesh_codec_find((ffd_format)f);
        CHECK(c && c->format == (ffd_format)f);
        CHECK(c->name && c->extensions && c->extensions[0]);
        CHECK(c->read && c->patch && c->write && c->refine);
        CHECK(c->encodings & FFD_CODEC_ENCODING(FFD_ENCODING_ASCII));
        for (const char *const *e = c->extensions; *e; e++) {
            char path[64], upper[16];
            size_t n = strlen(*e);
            CHECK(n < sizeof upper);
            for (size_t i = 0; i <= n; i++)
                upper[i] = (char)((*e)[i] >= 'a' && (*e)[i] <= 'z' ? (*e)[i] - 'a' + 'A' : (*e)[i]);
            CHECK(ffd_mesh_codec_for_extension(*e) == c);
            CHECK(ffd_mesh_codec_for_extension(upper) == c);
            snprintf(path, sizeof path, "dir.x/mesh.%s", upper);
            CHECK(ffd_format_from_path(path) == (ffd_format)f);
        }
        for (int enc = FFD_ENCODING_ASCII; enc <= FFD_ENCODING_BINARY_BE; enc++) {
            ffd_write_options o = {(ffd_format)f, (ffd_encoding)enc, 0};
            unsigned char *data = NULL;
            size_t size = 0;
            ffd_status st = ffd_mesh_write_memory(m, &o, &data, &size, &err);
            if (c->encodings & FFD_CODEC_ENCODING(enc)) {
                CHECK(st == FFD_OK);
                ffd_mesh *back = NULL;
                CHECK(ffd_mesh_read_memory(data, size, (ffd_format)f, "t", &back, &err) == FFD_OK);
                CHECK(ffd_mesh_vertex_count(back) == 3 && ffd_mesh_face_count(back) == 1);
                ffd_mesh_destroy(back);
            } else {
                CHECK(st == FFD_ERR_UNSUPPORTED);
                CHECK(strstr(err.message, c->name) == err.message);
            }
            ffd_free(data);
        }
    }
    char list[FFD_MESH_CODEC_LIST_SIZE];
    CHECK(strcmp(ffd_mesh_codec_list(false, list, sizeof list), ".obj, .ply, .off, .stl, .gltf, .vtk, .vtu, .msh, .su2, .xyz or .npy") == 0);
    CHECK(strcmp(ffd_mesh_codec_list(true, list, sizeof list), "OBJ, PLY, OFF, STL, glTF, VTK, VTU, MSH, SU2, XYZ or NPY") == 0);
    ffd_mesh_destroy(m);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"round_trip_shared", test_round_trip_shared},
        {"round_trip_fixtures", test_round_trip_fixtures},
        {"obj_contents", test_obj_contents},
        {"ply_contents_and_transcode", test_ply_contents_and_transcode},
        {"info_shared", test_info_shared},
        {"deformed_write", test_deformed_write},
        {"set_positions_normals", test_set_positions_normals},
        {"obj_jacobian_and_transcode_deformed", test_obj_jacobian_and_transcode_deformed},
        {"identity_signed_zero_and_normals", test_identity_signed_zero_and_normals},
        {"identity_partial_move", test_identity_partial_move},
        {"identity_binary_signed_zero", test_identity_binary_signed_zero},
        {"cross_format", test_cross_format},
        {"create_and_info", test_create_and_info},
        {"bad_inputs", test_bad_inputs},
        {"bad_files", test_bad_files},
        {"truncated_prefixes", test_truncated_prefixes},
        {"atomic_write", test_atomic_write},
        {"ply_value_range", test_ply_value_range},
        {"failing_allocations", test_failing_allocations},
        {"utf8_bom", test_utf8_bom},
        {"codec_table", test_codec_table},
        {"format_matches_printf", test_format_matches_printf},
        {"strtod_matches", test_strtod_matches},
        {"ply_binary_direct_path", test_ply_binary_direct_path},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
