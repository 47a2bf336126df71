/* ffd-mpi — `ffd deform` of a partitioned mesh under MPI (docs/mpi.md):
 * every rank reads its own piece, the library's distributed core runs the
 * few global steps through the ffd_comm below (MPI_Allreduce and
 * MPI_Allgatherv over MPI_COMM_WORLD), and every rank writes its own
 * deformed piece. Every failure is agreed on (ffd_comm_agree), so that all
 * ranks exit with it and none waits in a collective call. */
#include "cli.h"       /* cli_print_report, shared with `ffd deform --report` */
#include "core/core.h" /* ffd_fail */
#include "partition.h" /* the partition formats */

#include <mpi.h>

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char usage[] =
    "usage: mpirun -np N ffd-mpi deform PARTS -o OUT --rig RIG [options]\n"
    "\n"
    "Deforms a partitioned mesh with a rig (JSON or PyGeM .prm, docs/rig.md), each\n"
    "of the N ranks reading and writing only its own piece; the result is the one\n"
    "`ffd deform` gives the whole mesh, bitwise per vertex (docs/mpi.md).\n"
    "\n"
    "PARTS (piece r is rank r's; the number of pieces must be N):\n"
    "  mesh.pvtu         a ParaView index of .vtu pieces (<Piece Source=\"...\"/>);\n"
    "                    OUT is a .pvtu: rank 0 writes it, rank r writes OUT_r.vtu\n"
    "  mesh.msh          Gmsh's split pieces mesh_1.msh .. mesh_N.msh next to it\n"
    "                    (`gmsh -part N -part_split`, MSH 4.1 or 2.2); OUT.msh names\n"
    "                    the outputs OUT_1.msh .. OUT_N.msh (OUT.msh itself is not written)\n"
    "  piece_%d.vtu      one file per rank, any format ffd reads (%d, %Nd or %0Nd is\n"
    "                    the rank 0 .. N-1); OUT holds a %d too\n"
    "Global vertex ids (what a rig's vertex ids name): Gmsh node tags minus one, or\n"
    "the point field (PLY property, OBJ \"#NAME\" lines) GlobalNodeID, GlobalNodeIds\n"
    "or vtkGlobalIds; without one, rank-major order (rank 0's vertices first).\n"
    "\n"
    "options:\n"
    "  -o, --output OUT  the deformed pieces (written when every rank succeeded;\n"
    "                    on failure no output file is left)\n"
    "  -r, --rig RIG     the rig file (every rank reads it)\n"
    "  --report          rank 0 prints the report as JSON on stdout, as `ffd deform\n"
    "                    --report` (without \"folds\"): residuals, the method's details\n"
    "                    (with \"distributed\"), and the inverted cells and flipped faces\n"
    "                    of all pieces (\"inversions\"; cell and face ids are rank 0's)\n"
    "  --fail-on-inversion  exit 1 writing nothing when a cell of any piece inverted\n"
    "                    or a face flipped\n"
    "  --max-memory SIZE raise the limits (docs/rig.md \"Limits\"; K, M, G, T suffixes)\n"
    "  --no-limits       no limits on memory or work\n"
    "  -q, --quiet       no notes on stderr\n"
    "  -h, --help        this help\n"
    "Errors are printed once, by rank 0, naming the rank they happened on.\n"
    "Exit status: 0 success, 1 bad or unreadable input (or a failed write), 2 usage error.\n";

/* ======================================================================
 * The communicator: MPI collectives behind ffd_comm
 * ====================================================================== */

typedef struct mpi_user {
    MPI_Comm comm;
    char message[256]; /* why the last callback failed */
} mpi_user;

static int mpi_failed(mpi_user *u, int code, const char *call)
{
    char text[MPI_MAX_ERROR_STRING];
    int len = 0;
    if (MPI_Error_string(code, text, &len) != MPI_SUCCESS)
        snprintf(text, sizeof text, "error %d", code);
    snprintf(u->message, sizeof u->message, "%s: %.200s", call, text);
    return 1;
}

/* MPI_Allreduce in place, in pieces of at most INT_MAX values. Every rank
 * calls it with the same count, type and op, so every rank takes the same
 * branches. */
static int mpi_allreduce(void *user, void *data, size_t count, ffd_reduce_type type,
                         ffd_reduce_op op)
{
    mpi_user *u = user;
    MPI_Datatype t = type == FFD_REDUCE_DOUBLE ? MPI_DOUBLE : MPI_UINT64_T;
    MPI_Op o;
    switch (op) {
    case FFD_REDUCE_SUM: o = MPI_SUM; break;
    case FFD_REDUCE_MIN: o = MPI_MIN; break;
    case FFD_REDUCE_MAX: o = MPI_MAX; break;
    case FFD_REDUCE_OR:
        if (type != FFD_REDUCE_UINT64) {
            snprintf(u->message, sizeof u->message, "allreduce: bitwise or of doubles");
            return 1;
        }
        o = MPI_BOR;
        break;
    default:
        snprintf(u->message, sizeof u->message, "allreduce: unknown operation %d", (int)op);
        return 1;
    }
    for (size_t done = 0; done < count;) {
        size_t n = count - done < (size_t)INT_MAX ? count - done : (size_t)INT_MAX;
        int rc = MPI_Allreduce(MPI_IN_PLACE, (char *)data + done * 8, (int)n, t, o, u->comm);
        if (rc != MPI_SUCCESS)
            return mpi_failed(u, rc, "MPI_Allreduce");
        done += n;
    }
    return 0;
}

/* MPI_Allgatherv of bytes. Its counts and displacements are ints: a
 * gather of more than INT_MAX bytes in all is refused (on every rank, as
 * sizes is the same on each). */
static int mpi_allgatherv(void *user, const void *mine, size_t bytes, void *all,
                          const size_t *sizes)
{
    mpi_user *u = user;
    int size = 0;
    MPI_Comm_size(u->comm, &size);
    size_t total = 0;
    for (int r = 0; r < size; r++) {
        total += sizes[r];
        if (sizes[r] > (size_t)INT_MAX || total > (size_t)INT_MAX) {
            snprintf(u->message, sizeof u->message,
                     "allgatherv: more than %d bytes to gather (MPI's int counts)", INT_MAX);
            return 1;
        }
    }
    int *counts = malloc(2 * (size_t)size * sizeof *counts);
    if (!counts) /* a rank that cannot take part would leave the others waiting */
        MPI_Abort(u->comm, 1);
    int *displs = counts + size;
    for (int r = 0, at = 0; r < size; r++) {
        counts[r] = (int)sizes[r];
        displs[r] = at;
        at += counts[r];
    }
    static const unsigned char none = 0;
    int rc = MPI_Allgatherv(bytes ? mine : &none, (int)bytes, MPI_BYTE, all ? all : (void *)&none,
                            counts, displs, MPI_BYTE, u->comm);
    free(counts);
    return rc == MPI_SUCCESS ? 0 : mpi_failed(u, rc, "MPI_Allgatherv");
}

/* ======================================================================
 * Messages: rank 0 prints, the others stay quiet
 * ====================================================================== */

static int g_rank;
static int g_quiet;

static int fail(int code, const char *fmt, ...) CLI_PRINTF(2, 3);
static int fail(int code, const char *fmt, ...)
{
    if (g_rank == 0) {
        va_list ap;
        va_start(ap, fmt);
        fputs("ffd-mpi: ", stderr);
        vfprintf(stderr, fmt, ap);
        fputc('\n', stderr);
        va_end(ap);
    }
    return code;
}

static int usage_error(const char *fmt, ...) CLI_PRINTF(1, 2);
static int usage_error(const char *fmt, ...)
{
    if (g_rank == 0) {
        va_list ap;
        va_start(ap, fmt);
        fputs("ffd-mpi: ", stderr);
        vfprintf(stderr, fmt, ap);
        fputs("\nTry 'ffd-mpi --help'.\n", stderr);
        va_end(ap);
    }
    return CLI_EXIT_USAGE;
}

static void note(const char *fmt, ...) CLI_PRINTF(1, 2);
static void note(const char *fmt, ...)
{
    if (g_rank != 0 || g_quiet)
        return;
    va_list ap;
    va_start(ap, fmt);
    fputs("ffd-mpi: ", stderr);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
}

/* After a step every rank ran: when the ranks' statuses differ, agree on
 * the lowest failing rank's (its message "rank R: ..." on every rank); a
 * status already the same everywhere (the library's collective calls agree
 * themselves) keeps each rank's own message. */
static ffd_status agree(const ffd_comm *comm, ffd_status local, ffd_error *err)
{
    uint64_t v[2] = {(uint64_t)local, UINT64_MAX - (uint64_t)local};
    if (comm->allreduce(comm->user, v, 2, FFD_REDUCE_UINT64, FFD_REDUCE_MAX)) {
        snprintf(err->message, sizeof err->message, "%s",
                 ((mpi_user *)comm->user)->message);
        return FFD_ERR_IO;
    }
    if (v[0] == UINT64_MAX - v[1])
        return local;
    return ffd_comm_agree(comm, local, err);
}

/* ======================================================================
 * Writing: every rank's piece to a temporary file, agreed, then renamed
 * ====================================================================== */

static ffd_status write_temp(const char *path, const void *data, size_t size, char **tmp_out,
                             ffd_error *err)
{
    size_t n = strlen(path) + 32;
    char *tmp = malloc(n);
    if (!tmp)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
    snprintf(tmp, n, "%s.tmp%ld", path, (long)getpid());
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC, 0666);
    if (fd < 0) {
        ffd_status st = ffd_fail(err, FFD_ERR_IO, "%s: %s (its temporary file %s)", path,
                                 strerror(errno), tmp);
        free(tmp);
        return st;
    }
    const unsigned char *p = data;
    size_t left = size;
    while (left > 0) {
        ssize_t w = write(fd, p, left);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            break;
        p += w;
        left -= (size_t)w;
    }
    int bad = left > 0 || fsync(fd) != 0;
    int saved = errno;
    if (close(fd) != 0 && !bad) {
        bad = 1;
        saved = errno;
    }
    if (bad) {
        unlink(tmp);
        ffd_status st = ffd_fail(err, FFD_ERR_IO, "%s: %s", path, strerror(saved ? saved : EIO));
        free(tmp);
        return st;
    }
    *tmp_out = tmp;
    return FFD_OK;
}

/* "--name VALUE" or "--name=VALUE" (short: "-o VALUE"). 1 matched, 0 not, -1 value missing. */
static int option_value(int argc, char **argv, int *i, const char *name, const char *short_name,
                        const char **value)
{
    const char *arg = argv[*i];
    size_t n = strlen(name);
    if (strncmp(arg, name, n) == 0 && arg[n] == '=') {
        *value = arg + n + 1;
        return 1;
    }
    if (strcmp(arg, name) != 0 && !(short_name && strcmp(arg, short_name) == 0))
        return 0;
    if (*i + 1 >= argc)
        return -1;
    *value = argv[++*i];
    return 1;
}

/* ======================================================================
 * deform
 * ====================================================================== */

static int mpi_deform(const ffd_comm *comm, int argc, char **argv)
{
    const char *parts = NULL, *out = NULL, *rig_path = NULL, *max_memory = NULL;
    int want_report = 0, fail_on_inversion = 0;
    ffd_limits limits = {0};
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        int e;
        if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            if (g_rank == 0)
                fputs(usage, stdout);
            return CLI_EXIT_OK;
        } else if ((e = option_value(argc, argv, &i, "--output", "-o", &out)) != 0) {
            if (e < 0)
                return usage_error("deform: %s needs a value", arg);
        } else if ((e = option_value(argc, argv, &i, "--rig", "-r", &rig_path)) != 0) {
            if (e < 0)
                return usage_error("deform: %s needs a value", arg);
        } else if ((e = option_value(argc, argv, &i, "--max-memory", NULL, &max_memory)) != 0) {
            if (e < 0)
                return usage_error("deform: %s needs a value", arg);
            if (!(limits.max_memory = cli_parse_size(max_memory)))
                return usage_error("deform: --max-memory '%s': expected a size such as 8G, "
                                   "512M or a number of bytes", max_memory);
            double scale = (double)limits.max_memory / 2147483648.0;
            limits.max_work = 3e10 * (scale > 1 ? scale : 1);
        } else if (strcmp(arg, "--no-limits") == 0) {
            limits.unlimited = 1;
        } else if (strcmp(arg, "--report") == 0) {
            want_report = 1;
        } else if (strcmp(arg, "--fail-on-inversion") == 0) {
            fail_on_inversion = 1;
        } else if (strcmp(arg, "-q") == 0 || strcmp(arg, "--quiet") == 0) {
            g_quiet = 1;
        } else if (arg[0] == '-' && arg[1] != 0) {
            return usage_error("deform: unknown option '%s'", arg);
        } else if (!parts) {
            parts = arg;
        } else {
            return usage_error("deform: unexpected argument '%s' (one PARTS only)", arg);
        }
    }
    if (!parts)
        return usage_error("deform: missing PARTS (a .pvtu, a Gmsh .msh or a name with %%d)");
    if (!rig_path)
        return usage_error("deform: missing --rig RIG");
    if (!out)
        return usage_error("deform: missing -o OUT");
    if (strcmp(parts, "-") == 0 || strcmp(out, "-") == 0 || strcmp(rig_path, "-") == 0)
        return usage_error("deform: ffd-mpi reads and writes files, not standard input or output");

    ffd_error err = {{0}};
    part_plan plan = {0};
    ffd_mesh *piece = NULL;
    ffd_rig *rig = NULL;
    uint64_t *ids = NULL;
    const char *id_source = "none";
    double *rest = NULL;
    unsigned char *bytes = NULL;
    size_t nbytes = 0;
    char *tmp_piece = NULL, *tmp_index = NULL;
    int piece_existed = 0, index_existed = 0, renamed = 0;
    ffd_rig_report report = {0};
    ffd_inversion_report inv = {0};
    int have_inv = 0;
    int code = CLI_EXIT_INPUT;

    /* 1. the plan and this rank's piece: every rank reads its own, then all agree */
    ffd_status st = part_plan_make(parts, out, comm->rank, comm->size, &plan, &err);
    if (st == FFD_OK && (strcmp(plan.piece, plan.out_piece) == 0 ||
                         (plan.out_index && strcmp(plan.out_index, parts) == 0)))
        st = ffd_fail(&err, FFD_ERR_INVALID, "-o %s would overwrite the input %s", out,
                      strcmp(plan.piece, plan.out_piece) == 0 ? plan.piece : parts);
    if (st == FFD_OK)
        st = ffd_mesh_read(plan.piece, &piece, &err);
    if (st == FFD_OK)
        st = part_global_ids(piece, plan.piece, &ids, &id_source, &err);
    if (st == FFD_OK)
        st = ffd_rig_read(rig_path, &rig, &err);
    if ((st = ffd_comm_agree(comm, st, &err)) != FFD_OK) {
        fail(code, "%s", err.message);
        goto done;
    }
    /* every rank's pieces must agree on having global ids */
    uint64_t with_ids[2] = {ids != NULL, ids == NULL};
    if (comm->allreduce(comm->user, with_ids, 2, FFD_REDUCE_UINT64, FFD_REDUCE_SUM)) {
        fail(code, "%s", ((mpi_user *)comm->user)->message);
        goto done;
    }
    if (with_ids[0] && with_ids[1]) {
        fail(code, "%llu piece%s have global ids and %llu have none: every piece needs them "
                   "(GlobalNodeID, Gmsh node tags) or none does (rank-major order)",
             (unsigned long long)with_ids[0], with_ids[0] == 1 ? "" : "s",
             (unsigned long long)with_ids[1]);
        goto done;
    }
    if (!ids)
        note("the pieces have no global ids: rank-major numbering (rank 0's vertices first)\n");

    /* 2. the deformation, collective */
    size_t nv = ffd_mesh_vertex_count(piece);
    if (want_report || fail_on_inversion) {
        rest = malloc((nv ? nv : 1) * 3 * sizeof *rest);
        st = rest ? FFD_OK : ffd_fail(&err, FFD_ERR_NOMEM, "%s: out of memory", plan.piece);
        if ((st = agree(comm, st, &err)) != FFD_OK) {
            fail(code, "%s", err.message);
            goto done;
        }
        memcpy(rest, ffd_mesh_positions(piece), nv * 3 * sizeof *rest);
    }
    ffd_partition part = {comm, ids, &limits};
    st = ffd_rig_apply_distributed(rig, piece, &part, &report, &err);
    if ((st = agree(comm, st, &err)) != FFD_OK) {
        fail(code, "%s", err.message);
        goto done;
    }
    if (rest) {
        st = ffd_mesh_check_inversions(piece, rest, 0, &inv, &err);
        if ((st = agree(comm, st, &err)) == FFD_OK)
            st = ffd_inversion_report_reduce(comm, &inv, &err);
        if ((st = agree(comm, st, &err)) != FFD_OK) {
            fail(code, "inversion check: %s", err.message);
            goto done;
        }
        have_inv = 1;
        if (fail_on_inversion && (inv.inverted || inv.flipped_faces)) {
            fail(code, "%s: %zu cell%s inverted (worst det J %.6g), %zu face%s flipped, over "
                       "all pieces: nothing written (--fail-on-inversion)",
                 parts, inv.inverted, inv.inverted == 1 ? "" : "s", inv.worst_det,
                 inv.flipped_faces, inv.flipped_faces == 1 ? "" : "s");
            goto done;
        }
    }

    /* 3. every piece made in memory, then written to a temporary file, all
     * agreed, then renamed: on any failure before the renames no output is
     * left and existing files are untouched */
    ffd_write_options options = {ffd_format_from_path(plan.out_piece), FFD_ENCODING_SAME, 0};
    if (options.format == FFD_FORMAT_AUTO)
        st = ffd_fail(&err, FFD_ERR_INVALID, "%s: unknown mesh extension", plan.out_piece);
    else
        st = ffd_mesh_write_memory(piece, &options, &bytes, &nbytes, &err);
    if (st != FFD_OK) {
        char message[sizeof err.message];
        snprintf(message, sizeof message, "%s", err.message);
        if (strncmp(message, plan.out_piece, strlen(plan.out_piece)) != 0)
            ffd_fail(&err, st, "%s: %s", plan.out_piece, message);
    }
    if (st == FFD_OK)
        st = write_temp(plan.out_piece, bytes, nbytes, &tmp_piece, &err);
    if (st == FFD_OK && plan.out_index)
        st = write_temp(plan.out_index, plan.index_text, plan.index_size, &tmp_index, &err);
    if ((st = ffd_comm_agree(comm, st, &err)) != FFD_OK) {
        fail(code, "%s: nothing written", err.message);
        goto done;
    }
    piece_existed = access(plan.out_piece, F_OK) == 0;
    index_existed = plan.out_index && access(plan.out_index, F_OK) == 0;
    st = rename(tmp_piece, plan.out_piece) == 0
             ? FFD_OK
             : ffd_fail(&err, FFD_ERR_IO, "%s: %s", plan.out_piece, strerror(errno));
    renamed = st == FFD_OK;
    if ((st = ffd_comm_agree(comm, st, &err)) != FFD_OK) {
        /* a rank could not rename: the pieces this run created go again
         * (pieces that replaced older files stay: docs/mpi.md, "Outputs") */
        if (renamed && !piece_existed)
            unlink(plan.out_piece);
        fail(code, "%s", err.message);
        goto done;
    }
    free(tmp_piece);
    tmp_piece = NULL;
    if (tmp_index) { /* the index last, once every piece is in place */
        st = rename(tmp_index, plan.out_index) == 0
                 ? FFD_OK
                 : ffd_fail(&err, FFD_ERR_IO, "%s: %s", plan.out_index, strerror(errno));
        if (st == FFD_OK) {
            free(tmp_index);
            tmp_index = NULL;
        }
    }
    if ((st = ffd_comm_agree(comm, st, &err)) != FFD_OK) {
        if (!index_existed && !piece_existed)
            unlink(plan.out_piece);
        fail(code, "%s", err.message);
        goto done;
    }

    /* 4. the notes and the report, rank 0's (the report is the same on every rank) */
    for (const char *line = report.notes; line && *line;) {
        const char *eol = strchr(line, '\n');
        int len = eol ? (int)(eol - line) : (int)strlen(line);
        note("%.*s\n", len, line);
        line += len + (eol != NULL);
    }
    if (want_report && g_rank == 0) {
        cli_print_report(&report, have_inv ? &inv : NULL, NULL);
        fflush(stdout);
    }
    uint64_t totals[2] = {nv, ffd_mesh_face_count(piece)};
    if (comm->allreduce(comm->user, totals, 2, FFD_REDUCE_UINT64, FFD_REDUCE_SUM) == 0)
        note("wrote %s (%d piece%s, %llu vertices with the shared ones on each piece, %llu "
             "faces)\n",
             plan.out_index ? plan.out_index : out, comm->size, comm->size == 1 ? "" : "s",
             (unsigned long long)totals[0], (unsigned long long)totals[1]);
    code = CLI_EXIT_OK;
done:
    if (tmp_piece) {
        unlink(tmp_piece);
        free(tmp_piece);
    }
    if (tmp_index) {
        unlink(tmp_index);
        free(tmp_index);
    }
    ffd_free(bytes);
    free(rest);
    free(ids);
    ffd_inversion_report_free(&inv);
    ffd_rig_report_free(&report);
    ffd_rig_destroy(rig);
    ffd_mesh_destroy(piece);
    part_plan_free(&plan);
    return code;
}

int main(int argc, char **argv)
{
    if (MPI_Init(&argc, &argv) != MPI_SUCCESS) {
        fputs("ffd-mpi: MPI_Init failed\n", stderr);
        return CLI_EXIT_INPUT;
    }
    mpi_user user = {MPI_COMM_WORLD, ""};
    /* MPI errors come back as codes: the callbacks report them to the library */
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    ffd_comm comm = {0, 1, mpi_allreduce, mpi_allgatherv, &user};
    MPI_Comm_rank(MPI_COMM_WORLD, &comm.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &comm.size);
    g_rank = comm.rank;
    int code;
    if (argc < 2) {
        code = usage_error("missing command (deform)");
    } else if (strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0) {
        if (g_rank == 0)
            fputs(usage, stdout);
        code = CLI_EXIT_OK;
    } else if (strcmp(argv[1], "deform") == 0) {
        code = mpi_deform(&comm, argc - 1, argv + 1);
    } else {
        code = usage_error("unknown command '%s' (ffd-mpi has: deform)", argv[1]);
    }
    fflush(stdout);
    fflush(stderr);
    MPI_Finalize();
    return code;
}
