/* fuzz_http — libFuzzer target for ffd serve's request handling as a
 * client reaches it: the input is sent as raw bytes (an HTTP request, or
 * garbage) over a TCP connection to a real server (libmicrohttpd and
 * tools/cli/serve_http.c, in this process, on 127.0.0.1) around a session on
 * a cube; the response is read to the end. The sanitizers watch the server's
 * threads; a server that stops answering aborts. */
#include "serve_http.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static serve_server *server;
static char root[64];

static void stop(void)
{
    serve_stop(server);
}

static int start(void)
{
    static const char cube[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\n"
                               "v 1 1 1\nv 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\n"
                               "f 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    snprintf(root, sizeof root, "/tmp/ffd-fuzz-http-XXXXXX");
    if (!mkdtemp(root))
        return -1;
    char path[128];
    snprintf(path, sizeof path, "%s/cube.obj", root);
    FILE *f = fopen(path, "w");
    if (!f)
        return -1;
    fputs(cube, f);
    fclose(f);
    ffd_mesh *mesh = NULL;
    ffd_session *session = NULL;
    ffd_session_options options = {.max_undo = 20, .max_controls = 4096};
    if (ffd_mesh_read(path, &mesh, NULL) != FFD_OK ||
        ffd_session_create(mesh, "cube.obj", &options, &session, NULL) != FFD_OK)
        return -1;
    serve_options o = {"127.0.0.1", 0, root, root, path, 1 << 20, 0, 0, 0, 0}; /* default limits, no autosave */
    char msg[256];
    if (serve_start(session, &o, &server, msg, sizeof msg) != 0) {
        fprintf(stderr, "fuzz_http: %s\n", msg);
        return -1;
    }
    atexit(stop);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!server && start() != 0)
        abort();
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0)
        return 0;
    struct sockaddr_in a = {0};
    a.sin_family = AF_INET;
    a.sin_port = htons((uint16_t)serve_port(server));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    struct timeval tv = {5, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    /* A refused connection is retried for 5 s (the listen backlog may be full
     * while earlier connections' threads finish); after that the server has
     * stopped listening. */
    int tries = 0;
    while (connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        if (++tries == 50) {
            perror("fuzz_http: connect");
            abort();
        }
        close(fd);
        nanosleep(&(struct timespec){0, 100000000}, NULL);
        if ((fd = socket(AF_INET, SOCK_STREAM, 0)) < 0)
            return 0;
        setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
        setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    }
    /* close with a reset: no TIME_WAIT, so a long run does not run out of ports */
    struct linger lg = {1, 0};
    setsockopt(fd, SOL_SOCKET, SO_LINGER, &lg, sizeof lg);
    for (size_t sent = 0; sent < size;) {
        ssize_t w = send(fd, data + sent, size - sent, MSG_NOSIGNAL);
        if (w <= 0)
            break;
        sent += (size_t)w;
    }
    shutdown(fd, SHUT_WR);
    char buf[65536];
    while (recv(fd, buf, sizeof buf, 0) > 0)
        ;
    close(fd);
    return 0;
}
