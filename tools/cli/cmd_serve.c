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

#ifndef FFD_SOURCE_DIR
#define FFD_SOURCE_DIR "."
#endif

static const char usage[] =
    "usage: ffd serve [MESH] [options]\n"
    "\n"
    "Starts the editor: a local web server around an editing session of MESH\n"
    "(default: the bundled bunny). Prints 'ffd serve: http://HOST:PORT/' once\n"
    "it listens and runs until interrupted. See docs/editor.md.\n"
    "\n"
    "options:\n"
    "  --port N          TCP port (default 8080; 0 picks a free one)\n"
    "  --host ADDR       IPv4 address to listen on (default 127.0.0.1); anything but\n"
    "                    loopback is reachable by others: the editor has no authentication\n"
    "  --root DIR        the only directory files are opened from and saved to\n"
    "                    (default: the directory of MESH)\n"
    "  --web DIR         the page's files (default: the built page, web/dist)\n"
    "  --max-upload MB   largest uploaded mesh or rig (default 256)\n"
    "  --client-connections N\n"
    "                    connections one client address may hold at a time (default 32;\n"
    "                    a browser opens about 6); more are closed at once\n"
    "  --idle-timeout S  seconds a connection may stay silent before it is closed\n"
    "                    (default 30)\n"
    "  --verbose         one line per request on stderr\n"
    "  -h, --help        this help\n";

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
    int verbose = 0;
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
    if (!mesh_path)
        mesh_path = FFD_SOURCE_DIR "/examples/lattice/bunny.obj";
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
    if (!web)
        web = FFD_SOURCE_DIR "/web/dist";

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
                             (unsigned)timeout};
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
    printf("ffd serve: http://%s:%u/\n", serve_host(server), serve_port(server));
    fflush(stdout);

    int sig = 0;
    while (sigwait(&stop, &sig) != 0 || (sig != SIGINT && sig != SIGTERM))
        ;
    serve_stop(server); /* destroys the session */
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    return CLI_EXIT_OK;
}
