/* ffd-mpi's partition formats (tools/mpi/partition.c), without MPI: the
 * .pvtu parser (pieces in order, comments skipped, the output index equal to
 * the input but for its Source names, errors naming file and line), Gmsh's
 * split pieces found by name, %d patterns, pieces != ranks naming both, and
 * global ids (Gmsh node tags, GlobalNodeID point data, OBJ "#GlobalNodeID"
 * lines; values that are not whole numbers refused). Runs in a scratch
 * directory under the build directory. */
#include "check.h"

#include "partition.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define DIR "test_partition_data"

static void put(const char *name, const char *text)
{
    char path[256];
    snprintf(path, sizeof path, DIR "/%s", name);
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* The plan's status; the message in err. */
static ffd_status plan(const char *parts, const char *out, int rank, int size, part_plan *p,
                       ffd_error *err)
{
    memset(err, 0, sizeof *err);
    return part_plan_make(parts, out, rank, size, p, err);
}

static int has(const char *message, const char *part)
{
    if (strstr(message, part))
        return 1;
    fprintf(stderr, "  message '%s' lacks '%s'\n", message, part);
    return 0;
}

static const char pvtu_text[] =
    "<?xml version=\"1.0\"?>\n"
    "<!-- <Piece Source=\"not_a_piece.vtu\"/> -->\n"
    "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\">\n"
    "  <PUnstructuredGrid GhostLevel=\"0\">\n"
    "    <PPoints><PDataArray type=\"Float64\" NumberOfComponents=\"3\"/></PPoints>\n"
    "    <Piece Source=\"a_0.vtu\"/>\n"
    "    <Piece extra='x' Source = 'sub/a_1.vtu' />\n"
    "    <Piece Source=\"/abs/a_2.vtu\"></Piece>\n"
    "  </PUnstructuredGrid>\n"
    "</VTKFile>\n";

/* Pieces in order, relative to the .pvtu's directory; the output names
 * OUT's stem _r with the piece's extension; rank 0's index is the input
 * with only the Source values replaced. */
static void test_pvtu_pieces(void)
{
    put("a.pvtu", pvtu_text);
    part_plan p;
    ffd_error e;
    const char *want[] = {DIR "/a_0.vtu", DIR "/sub/a_1.vtu", "/abs/a_2.vtu"};
    for (int r = 0; r < 3; r++) {
        CHECK(plan(DIR "/a.pvtu", "out/res.pvtu", r, 3, &p, &e) == FFD_OK);
        CHECK(p.kind == PART_PVTU && p.piece_count == 3);
        CHECK(p.piece && strcmp(p.piece, want[r]) == 0);
        char out[64];
        snprintf(out, sizeof out, "out/res_%d.vtu", r);
        CHECK(p.out_piece && strcmp(p.out_piece, out) == 0);
        CHECK((r == 0) == (p.index_text != NULL));
        if (r == 0 && p.index_text) {
            CHECK(strcmp(p.out_index, "out/res.pvtu") == 0);
            const char *expect =
                "<?xml version=\"1.0\"?>\n"
                "<!-- <Piece Source=\"not_a_piece.vtu\"/> -->\n"
                "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\">\n"
                "  <PUnstructuredGrid GhostLevel=\"0\">\n"
                "    <PPoints><PDataArray type=\"Float64\" NumberOfComponents=\"3\"/></PPoints>\n"
                "    <Piece Source=\"res_0.vtu\"/>\n"
                "    <Piece extra='x' Source = 'res_1.vtu' />\n"
                "    <Piece Source=\"res_2.vtu\"></Piece>\n"
                "  </PUnstructuredGrid>\n"
                "</VTKFile>\n";
            CHECK(p.index_size == strlen(expect) && strcmp(p.index_text, expect) == 0);
        }
        part_plan_free(&p);
    }
    /* pieces != ranks: both named */
    CHECK(plan(DIR "/a.pvtu", "res.pvtu", 0, 2, &p, &e) == FFD_ERR_INVALID);
    CHECK(has(e.message, "names 3 pieces but the run has 2 ranks"));
    CHECK(p.piece == NULL);
    /* the output must be a .pvtu */
    CHECK(plan(DIR "/a.pvtu", "res.vtu", 0, 3, &p, &e) == FFD_ERR_INVALID);
    CHECK(has(e.message, "must be one too"));
}

static void test_pvtu_errors(void)
{
    static const struct {
        const char *text, *message;
    } cases[] = {
        {"<VTKFile type=\"PUnstructuredGrid\">\n<PUnstructuredGrid>\n<Piece/>\n",
         "bad.pvtu:3: <Piece> with no Source attribute"},
        {"<VTKFile>\n<PUnstructuredGrid>\n\n<Piece Source=\"a\" Source=\"b\"/>\n",
         "bad.pvtu:4: <Piece> with more than one Source attribute"},
        {"<PUnstructuredGrid>\n<Piece Source=\"a.vtu\"\n", "bad.pvtu:2: unterminated <Piece>"},
        {"<PUnstructuredGrid>\n<Piece Source=a.vtu/>\n", "bad.pvtu:2: <Piece>: expected a quoted"},
        {"<PUnstructuredGrid>\n<Piece Source=\"a&amp;b.vtu\"/>\n",
         "bad.pvtu:2: <Piece Source=\"a&amp;b.vtu\">: expected a file name"},
        {"<PUnstructuredGrid>\n<Piece Source=\"\"/>\n", "bad.pvtu:2: <Piece Source=\"\">"},
        {"<VTKFile type=\"UnstructuredGrid\">\n<Piece Source=\"a.vtu\"/>\n",
         "bad.pvtu:1: expected a VTKFile of type PUnstructuredGrid"},
        {"<PUnstructuredGrid>\n</PUnstructuredGrid>\n", "bad.pvtu:3: no <Piece Source"},
        {"<PUnstructuredGrid>\n<!-- <Piece Source=\"a.vtu\"/>\n", "bad.pvtu:2: unterminated '<!--'"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        put("bad.pvtu", cases[i].text);
        part_plan p;
        ffd_error e;
        CHECK(plan(DIR "/bad.pvtu", "o.pvtu", 0, 1, &p, &e) == FFD_ERR_PARSE);
        CHECK(has(e.message, cases[i].message));
        CHECK(p.piece == NULL && p.index_text == NULL);
    }
    part_plan p;
    ffd_error e;
    CHECK(plan(DIR "/missing.pvtu", "o.pvtu", 0, 1, &p, &e) == FFD_ERR_IO);
    CHECK(has(e.message, "missing.pvtu"));
}

/* Gmsh: NAME_1.msh .. NAME_N.msh next to NAME.msh (which need not exist). */
static void test_msh_pieces(void)
{
    put("g_1.msh", "");
    put("g_2.msh", "");
    put("g_3.msh", "");
    part_plan p;
    ffd_error e;
    CHECK(plan(DIR "/g.msh", "o/r.msh", 2, 3, &p, &e) == FFD_OK);
    CHECK(p.kind == PART_MSH && p.piece_count == 3);
    CHECK(p.piece && strcmp(p.piece, DIR "/g_3.msh") == 0);
    CHECK(p.out_piece && strcmp(p.out_piece, "o/r_3.msh") == 0);
    CHECK(p.out_index == NULL);
    part_plan_free(&p);
    CHECK(plan(DIR "/g.msh", "r.msh", 0, 4, &p, &e) == FFD_ERR_INVALID);
    CHECK(has(e.message, "has 3 pieces (_1.msh .. _3.msh) but the run has 4 ranks"));
    CHECK(plan(DIR "/g.msh", "r.msh", 0, 2, &p, &e) == FFD_ERR_INVALID);
    CHECK(has(e.message, "more than 2 pieces"));
    CHECK(plan(DIR "/g.msh", "r.vtu", 0, 3, &p, &e) == FFD_ERR_INVALID);
    CHECK(has(e.message, "must be a .msh name too"));
    /* no pieces: one rank reads the file itself, more ranks are refused */
    CHECK(plan(DIR "/whole.msh", "w.msh", 0, 1, &p, &e) == FFD_OK);
    CHECK(p.piece && strcmp(p.piece, DIR "/whole.msh") == 0);
    CHECK(p.out_piece && strcmp(p.out_piece, "w.msh") == 0);
    part_plan_free(&p);
    CHECK(plan(DIR "/whole.msh", "w.msh", 0, 2, &p, &e) == FFD_ERR_IO);
    CHECK(has(e.message, "no Gmsh pieces next to it (" DIR "/whole_1.msh"));
}

static void test_patterns(void)
{
    part_plan p;
    ffd_error e;
    CHECK(plan("in_%03d.ply", "o/100%%_%d.obj", 7, 8, &p, &e) == FFD_OK);
    CHECK(p.kind == PART_PATTERN && p.piece_count == 8);
    CHECK(p.piece && strcmp(p.piece, "in_007.ply") == 0);
    CHECK(p.out_piece && strcmp(p.out_piece, "o/100%_7.obj") == 0);
    part_plan_free(&p);
    CHECK(plan("in_%2d.obj", "o_%d.obj", 3, 4, &p, &e) == FFD_OK);
    CHECK(p.piece && strcmp(p.piece, "in_ 3.obj") == 0);
    part_plan_free(&p);
    static const struct {
        const char *in, *out, *message;
    } bad[] = {
        {"a_%d_%d.obj", "o_%d.obj", "PARTS 'a_%d_%d.obj': expected one %d (the rank), found 2"},
        {"a_%s.obj", "o_%d.obj", "only %d, %Nd or %0Nd"},
        {"a_%d.obj", "o.obj", "-o 'o.obj': expected one %d (the rank), found 0"},
        {"a.obj", "o_%d.obj", "a pattern output needs a pattern input"},
        {"a.obj", "o.obj", "a.obj: expected a .pvtu, a Gmsh .msh"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        CHECK(plan(bad[i].in, bad[i].out, 0, 2, &p, &e) == FFD_ERR_INVALID);
        CHECK(has(e.message, bad[i].message));
    }
    /* a file for rank `size`: more pieces than ranks */
    put("q_0.xyz", "0 0 0\n");
    put("q_1.xyz", "1 0 0\n");
    CHECK(plan(DIR "/q_%d.xyz", "o_%d.xyz", 0, 1, &p, &e) == FFD_ERR_INVALID);
    CHECK(has(e.message, DIR "/q_1.xyz exists: the pattern " DIR "/q_%d.xyz names more pieces than "
                         "the 1 rank"));
    CHECK(plan(DIR "/q_%d.xyz", "o_%d.xyz", 1, 2, &p, &e) == FFD_OK);
    part_plan_free(&p);
}

static ffd_mesh *read_text(const char *name, const char *text)
{
    put(name, text);
    char path[256];
    snprintf(path, sizeof path, DIR "/%s", name);
    ffd_mesh *m = NULL;
    ffd_error e = {{0}};
    if (ffd_mesh_read(path, &m, &e) != FFD_OK)
        fprintf(stderr, "  %s\n", e.message);
    CHECK(m != NULL);
    return m;
}

static void test_global_ids(void)
{
    uint64_t *ids = NULL;
    const char *source = NULL;
    ffd_error e = {{0}};
    /* Gmsh: tag - 1 */
    ffd_mesh *m = read_text("t.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n3\n"
                                     "7 0 0 0\n3 1 0 0\n9 0 1 0\n$EndNodes\n$Elements\n1\n"
                                     "1 2 2 0 1 7 3 9\n$EndElements\n");
    if (m) {
        CHECK(part_global_ids(m, "t.msh", &ids, &source, &e) == FFD_OK);
        CHECK(ids && ids[0] == 6 && ids[1] == 2 && ids[2] == 8);
        CHECK(strcmp(source, "node tags") == 0);
        free(ids);
        ffd_mesh_destroy(m);
    }
    /* OBJ "#GlobalNodeID" lines */
    m = read_text("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n#GlobalNodeID 40\n"
                           "#GlobalNodeID 0\n#GlobalNodeID 9007199254740991\n");
    if (m) {
        CHECK(part_global_ids(m, "t.obj", &ids, &source, &e) == FFD_OK);
        CHECK(ids && ids[0] == 40 && ids[1] == 0 && ids[2] == 9007199254740991ull);
        CHECK(strcmp(source, "GlobalNodeID") == 0);
        free(ids);
        ffd_mesh_destroy(m);
    }
    /* none: rank-major */
    m = read_text("n.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    if (m) {
        uint64_t sentinel = 1;
        ids = &sentinel;
        CHECK(part_global_ids(m, "n.obj", &ids, &source, &e) == FFD_OK);
        CHECK(ids == NULL && strcmp(source, "none") == 0);
        ffd_mesh_destroy(m);
    }
    /* not whole numbers, negative, 2^53 */
    static const char *const bad[] = {"1.5", "-1", "9007199254740992"};
    for (size_t i = 0; i < 3; i++) {
        char text[256];
        snprintf(text, sizeof text, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n#GlobalNodeID 0\n"
                                    "#GlobalNodeID %s\n#GlobalNodeID 2\n", bad[i]);
        m = read_text("b.obj", text);
        if (!m)
            continue;
        CHECK(part_global_ids(m, "b.obj", &ids, &source, &e) == FFD_ERR_RANGE);
        CHECK(has(e.message, "b.obj: GlobalNodeID of vertex 1 is"));
        CHECK(has(e.message, "expected a whole number in 0 .. 2^53"));
        CHECK(ids == NULL);
        ffd_mesh_destroy(m);
    }
}

int main(int argc, char **argv)
{
    mkdir(DIR, 0777);
    static const check_test tests[] = {
        {"pvtu_pieces", test_pvtu_pieces}, {"pvtu_errors", test_pvtu_errors},
        {"msh_pieces", test_msh_pieces},   {"patterns", test_patterns},
        {"global_ids", test_global_ids},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
