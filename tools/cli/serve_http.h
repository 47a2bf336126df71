/* serve_http — the HTTP server of `ffd serve` (docs/editor.md): routes the
 * editor's API to one editing session, serves the page's files and opens and
 * saves files under one root directory. The only file that includes
 * libmicrohttpd. */
#ifndef FFD_SERVE_HTTP_H
#define FFD_SERVE_HTTP_H

#include "ffd.h"

#include <stddef.h>

typedef struct serve_options {
    const char *host;      /* dotted IPv4 address to listen on ("localhost" is 127.0.0.1) */
    unsigned port;         /* 0: an ephemeral port (serve_port says which) */
    const char *root;      /* the directory files are opened from and saved to (must exist) */
    const char *web;       /* the page's files (may be missing: then GET / is a 404) */
    const char *mesh_path; /* the file the session was opened from (never overwritten), or NULL */
    size_t max_upload;     /* bytes; largest uploaded mesh or rig */
    int verbose;           /* one line per request on stderr */
    unsigned client_connections; /* connections from one client address at a time; 0: 32 */
    unsigned idle_timeout;       /* seconds a silent connection is kept; 0: 30 */
    int autosave;                /* 1: autosave the session under root/.ffd and resume it
                                    (serve_autosave.h) */
} serve_options;

#define SERVE_CLIENT_CONNECTIONS 32 /* a browser opens about 6 per server */
#define SERVE_IDLE_TIMEOUT 30       /* seconds */

typedef struct serve_server serve_server;

/* Starts listening and serving session, which the server takes over on
 * success (destroyed by serve_stop; untouched on failure). On failure
 * returns -1 and writes a message (without "ffd: ") into msg: "cannot
 * listen on 127.0.0.1:8080: Address already in use", a bad --root. */
int serve_start(ffd_session *session, const serve_options *options, serve_server **out,
                char *msg, size_t msg_size);
/* The port it listens on. */
unsigned serve_port(const serve_server *server);
/* The listening address, dotted ("localhost" gives 127.0.0.1). */
const char *serve_host(const serve_server *server);
/* The root directory, resolved (no trailing slash). */
const char *serve_root(const serve_server *server);
/* Stops serving (waits for requests in progress), destroys the session. NULL-safe. */
void serve_stop(serve_server *server);

/* 1 when host is a loopback address (127.0.0.0/8, "localhost"), 0 another
 * IPv4 address, -1 not an IPv4 address. */
int serve_is_loopback(const char *host);

#endif
