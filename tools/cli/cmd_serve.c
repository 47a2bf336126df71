/* ffd serve — the editor: opens a mesh in an editing session and serves it
 * and the page over HTTP (serve_http.c) until interrupted. docs/editor.md. */
#include "cli.h"
#include "serve_http.h"

#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <unistd.h>

#ifndef FFD_SOURCE_DIR
#define FFD_SOURCE_DIR "."
#endif
/* the installed share/ffd seen from the installed ffd's directory (CMakeLists.txt) */
#ifndef FFD_DATA_FROM_BIN
#define FFD_DATA_FROM_BIN "../share/ffd"
#endif

static const char usage[] =
    "usage: ffd serve [MESH] [options]\n"
    "\n"
    "Starts the editor: a local web server around an editing session of MESH\n"
    "(default: the bundled bunny, examples/lattice/bunny.obj). Prints 'ffd serve: http://HOST:PORT/' once\n"
    "it listens and runs until interrupted. See docs/editor.md.\n"
    "\n"
    "options:\n"
    "  --port N          TCP port (default 8080; 0 picks a free one)\n"
    "  --host ADDR       IPv4 address to listen on (default 127.0.0.1); anything but\n"
    "                    loopback is reachable by others: the editor has no authentication\n"
    "  --root DIR        the only directory files are opened from and saved to\n"
    "                    (default: the directory of MESH)\n"
    "  --web DIR         the page's files (default: share/ffd/web beside the installed\n"
    "                    ffd, else the source tree's built page, web/dist)\n"
    "  --max-upload MB   largest uploaded mesh or rig (default 256)\n"
    "  --client-connections N\n"
    "                    connections one client address may hold at a time (default 32;\n"
    "                    a browser opens about 6); more are closed at once\n"
    "  --idle-timeout S  seconds a connection may stay silent before it is closed\n"
    "                    (default 30)\n"
    "  --no-autosave     do not save the session under ROOT/.ffd after each change,\n"
    "                    nor resume a saved one (by default a restarted server resumes\n"
    "                    where you were: state, pins and undo history)\n"
    "  --verbose         one line per request on stderr\n"
    "  -h, --help        this help\n";

/* The bundled file or directory `rel` (under share/ffd once installed): first
 * FFD_DATA_FROM_BIN/installed_rel from the directory of the running ffd
 * (/proc/self/exe), then FFD_SOURCE_DIR/source_rel of the build tree it came
 * from. Writes the first that exists to out (the last tried when none does)
 * and the candidates to tried ("A, B"). Returns 1 when one exists. */
static int find_bundled(const char *installed_rel, const char *source_rel, char *out, size_t size,
                        char *tried, size_t tried_size)
{
    char exe[4096];
    const char *dirs[2], *rels[2];
    int count = 0;
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    char *slash = n > 0 ? (exe[n] = 0, strrchr(exe, '/')) : NULL;
    if (slash) {
        *slash = 0;
        dirs[count] = exe;
        rels[count++] = installed_rel;
    }
    dirs[count] = FFD_SOURCE_DIR;
    rels[count++] = source_rel;
    size_t used = 0;
    tried[0] = 0;
    for (int i = 0; i < count; i++) {
        int len = i == 0 && slash ? snprintf(out, size, "%s/%s/%s", dirs[i], FFD_DATA_FROM_BIN, rels[i])
                                  : snprintf(out, size, "%s/%s", dirs[i], rels[i]);
        int t = snprintf(tried + used, tried_size - used, "%s%s", i ? ", " : "", out);
        if (t > 0 && (size_t)t < tried_size - used)
            used += (size_t)t;
        if (len > 0 && (size_t)len < size && access(out, F_OK) == 0)
            return 1;
    }
    return 0;
}

/* A whole number in [lo, hi]; -1 when s is not one. */
static long parse_number(const char *s, long lo, long hi)
{
    if (*s < '0' || *s > '9')
        return -1;
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    return errno || *end || v < lo || v > hi ? -1 : v;
}

int cmd_serve(int argc, char **argv)
{
    const char *mesh_path = NULL, *port_text = NULL, *host = NULL, *root = NULL, *web = NULL,
               *upload_text = NULL, *clients_text = NULL, *timeout_text = NULL;
    int verbose = 0, autosave = 1;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        int e;
        if (cli_is_help(arg)) {
            fputs(usage, stdout);
            return CLI_EXIT_OK;
        } else if ((e = cli_option_value(argc, argv, &i, "--port", NULL, &port_text)) != 0 ||
                   (e = cli_option_value(argc, argv, &i, "--host", NULL, &host)) != 0 ||
                   (e = cli_option_value(argc, argv, &i, "--root", NULL, &root)) != 0 ||
                   (e = cli_option_value(argc, argv, &i, "--web", NULL, &web)) != 0 ||
                   (e = cli_option_value(argc, argv, &i, "--max-upload", NULL, &upload_text)) !=
                       0 ||
                   (e = cli_option_value(argc, argv, &i, "--client-connections", NULL,
                                         &clients_text)) != 0 ||
                   (e = cli_option_value(argc, argv, &i, "--idle-timeout", NULL, &timeout_text)) !=
                       0) {
            if (e < 0)
                return cli_option_error("serve", arg, e);
        } else if (strcmp(arg, "--verbose") == 0) {
            verbose = 1;
        } else if (strcmp(arg, "--no-autosave") == 0) {
            autosave = 0;
        } else if (arg[0] == '-' && arg[1] != 0) {
            return cli_usage_error("serve", "unknown option '%s'", arg);
        } else if (!mesh_path) {
            mesh_path = arg;
        } else {
            return cli_usage_error("serve", "unexpected argument '%s' (one mesh only)", arg);
        }
    }
    long port = 8080, upload_mb = 256, clients = SERVE_CLIENT_CONNECTIONS,
         timeout = SERVE_IDLE_TIMEOUT;
    if (port_text && (port = parse_number(port_text, 0, 65535)) < 0)
        return cli_usage_error("serve", "--port '%s': expected a port number, 0 to 65535",
                               port_text);
    if (upload_text && (upload_mb = parse_number(upload_text, 1, 1L << 20)) < 0)
        return cli_usage_error("serve", "--max-upload '%s': expected megabytes, at least 1",
                               upload_text);
    if (clients_text && (clients = parse_number(clients_text, 1, 256)) < 0)
        return cli_usage_error("serve", "--client-connections '%s': expected a count, 1 to 256",
                               clients_text);
    if (timeout_text && (timeout = parse_number(timeout_text, 1, 86400)) < 0)
        return cli_usage_error("serve", "--idle-timeout '%s': expected seconds, 1 to 86400",
                               timeout_text);
    if (!host)
        host = "127.0.0.1";
    int loopback = serve_is_loopback(host);
    if (loopback < 0)
        return cli_usage_error("serve", "--host '%s': expected an IPv4 address or localhost", host);
    char bundled_mesh[4096], tried[8400];
    if (!mesh_path) {
        if (!find_bundled("examples/lattice/bunny.obj", "examples/lattice/bunny.obj", bundled_mesh,
                          sizeof bundled_mesh, tried, sizeof tried))
            return cli_error(CLI_EXIT_INPUT,
                             "serve: no MESH given and the bundled bunny is not installed (tried %s)",
                             tried);
        mesh_path = bundled_mesh;
    }
    char root_default[4096];
    if (!root) {
        const char *slash = strrchr(mesh_path, '/');
        if (!slash)
            snprintf(root_default, sizeof root_default, ".");
        else if (slash == mesh_path)
            snprintf(root_default, sizeof root_default, "/");
        else
            snprintf(root_default, sizeof root_default, "%.*s", (int)(slash - mesh_path), mesh_path);
        root = root_default;
    }
    int web_given = web != NULL;
    char bundled_web[4096], web_tried[8400];
    int web_found = 1;
    if (!web) {
        web_found = find_bundled("web/index.html", "web/dist/index.html", bundled_web,
                                 sizeof bundled_web, web_tried, sizeof web_tried);
        *strrchr(bundled_web, '/') = 0; /* the directory of index.html */
        web = bundled_web;
    }

    ffd_error err = {{0}};
    ffd_mesh *mesh = NULL;
    ffd_session *session = NULL;
    if (ffd_mesh_read(mesh_path, &mesh, &err) != FFD_OK)
        return cli_error(CLI_EXIT_INPUT, "%s", err.message);
    const char *name = strrchr(mesh_path, '/') ? strrchr(mesh_path, '/') + 1 : mesh_path;
    if (ffd_session_create(mesh, name, NULL, &session, &err) != FFD_OK) {
        ffd_mesh_destroy(mesh);
        return cli_error(CLI_EXIT_INPUT, "%s", err.message);
    }

    /* SIGINT and SIGTERM wait for sigwait below: blocked before the server's
     * threads start, so they inherit the mask */
    sigset_t stop;
    sigemptyset(&stop);
    sigaddset(&stop, SIGINT);
    sigaddset(&stop, SIGTERM);
    sigset_t old;
    pthread_sigmask(SIG_BLOCK, &stop, &old);
    signal(SIGPIPE, SIG_IGN); /* a client gone mid-reply is not our death */

    serve_options options = {host, (unsigned)port, root, web, mesh_path,
                             (size_t)upload_mb << 20, verbose, (unsigned)clients,
                             (unsigned)timeout, autosave};
    serve_server *server = NULL;
    char msg[1024];
    if (serve_start(session, &options, &server, msg, sizeof msg) != 0) {
        ffd_session_destroy(session);
        pthread_sigmask(SIG_SETMASK, &old, NULL);
        return cli_error(CLI_EXIT_INPUT, "serve: %s", msg);
    }
    if (!loopback)
        fprintf(stderr,
                "ffd: warning: listening on %s: the editor has no authentication; anyone who "
                "can reach this port can read and write files under %s\n",
                serve_host(server), serve_root(server));
    if (web_given && strcmp(web, "") != 0) {
        FILE *f = NULL;
        char index[4200];
        snprintf(index, sizeof index, "%s/index.html", web);
        if (!(f = fopen(index, "r")))
            fprintf(stderr, "ffd: warning: --web %s: no index.html there\n", web);
        else
            fclose(f);
    }
    if (!web_found)
        fprintf(stderr,
                "ffd: warning: the editor's page is not installed (no index.html at %s): the API "
                "answers but / is a 404; build it (cd web && npm run build) or pass --web DIR\n",
                web_tried);
    printf("ffd serve: http://%s:%u/\n", serve_host(server), serve_port(server));
    fflush(stdout);

    int sig = 0;
    while (sigwait(&stop, &sig) != 0 || (sig != SIGINT && sig != SIGTERM))
        ;
    serve_stop(server); /* destroys the session */
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    return CLI_EXIT_OK;
}
