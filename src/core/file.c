/* core — whole-file reading and atomic writing (an unnamed file linked in
 * when complete, or a temporary file + rename). */
#ifndef _GNU_SOURCE
#define _GNU_SOURCE /* O_TMPFILE, realpath, linkat */
#endif
#include "core.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

ffd_status ffd_read_file(const char *path, unsigned char **data, size_t *size, ffd_error *err)
{
    *data = NULL;
    *size = 0;
    struct stat st;
    if (stat(path, &st) != 0)
        return ffd_fail(err, FFD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode))
        return ffd_fail(err, FFD_ERR_IO, "%s: is a directory, expected a file", path);
    if (!S_ISREG(st.st_mode))
        return ffd_fail(err, FFD_ERR_IO, "%s: not a regular file", path);
    /* Opened without waiting (opening a FIFO waits for a writer) and checked
     * again on the descriptor: a file replaced by a FIFO after the stat above
     * cannot hang the reader. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return ffd_fail(err, FFD_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        return ffd_fail(err, FFD_ERR_IO, "%s: not a regular file", path);
    }
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        int e = errno;
        close(fd);
        return ffd_fail(err, FFD_ERR_IO, "%s: cannot open: %s", path, strerror(e));
    }
    size_t cap = (size_t)st.st_size + 1, n = 0;
    unsigned char *buf = ffd_malloc(cap);
    if (!buf) {
        fclose(f);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory reading %zu bytes", path, cap);
    }
    for (;;) {
        if (n + 1 >= cap) {
            if (!ffd_grow((void **)&buf, &cap, cap + 1, 1)) {
                ffd_free(buf);
                fclose(f);
                return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
            }
        }
        size_t got = fread(buf + n, 1, cap - 1 - n, f);
        n += got;
        if (got == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        ffd_free(buf);
        return ffd_fail(err, FFD_ERR_IO, "%s: read error", path);
    }
    buf[n] = 0;
    *data = buf;
    *size = n;
    return FFD_OK;
}

/* ======================================================================
 * Atomic writing (docs/cli.md, "Output files")
 *
 * The data goes to an unnamed file in the target's directory (O_TMPFILE),
 * is fsynced, and only then gets a name: linkat(2) of /proc/self/fd/N to the
 * target when it does not exist, otherwise to "<name>.tmp<PID>.<N>" and
 * rename(2) over the target (linkat cannot replace a file). A writer killed
 * at any point leaves no partial file; at worst, killed between linkat and
 * rename, a complete temporary file. Where the file system has no O_TMPFILE
 * (or /proc is missing) the data goes to the named temporary file directly,
 * which a killed writer leaves behind. Every save first removes such
 * leftovers for its own target: "<name>.tmp<PID>.<N>" whose PID is not a
 * running process.
 * ====================================================================== */

/* Writes all of data to fd and fsyncs it; 0, or -1 with errno. */
static int write_all(int fd, const void *data, size_t size)
{
    const unsigned char *p = data;
    while (size > 0) {
        ssize_t w = write(fd, p, size);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return -1;
        }
        p += w;
        size -= (size_t)w;
    }
    if (fsync(fd) != 0 && errno != EINVAL && errno != EROFS)
        return -1;
    return 0;
}

/* The PID of a temporary name "<base>.tmp<PID>.<N>" (decimal digits), or 0. */
static long temp_name_pid(const char *name, const char *base)
{
    size_t n = strlen(base);
    if (strncmp(name, base, n) != 0 || strncmp(name + n, ".tmp", 4) != 0)
        return 0;
    const char *p = name + n + 4;
    long pid = 0;
    if (!isdigit((unsigned char)*p))
        return 0;
    for (; isdigit((unsigned char)*p); p++) {
        if (pid > 100000000)
            return 0;
        pid = 10 * pid + (*p - '0');
    }
    if (*p++ != '.' || !isdigit((unsigned char)*p))
        return 0;
    while (isdigit((unsigned char)*p))
        p++;
    return *p ? 0 : pid;
}

/* Removes "<base>.tmp<PID>.<N>" in dir whose writer PID no longer runs (a
 * killed save); live writers' files, this process's own and other names stay.
 * Best effort: an unreadable directory is left alone. */
static void remove_stale_temps(const char *dir, const char *base)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        long pid = temp_name_pid(e->d_name, base);
        if (pid > 0 && pid != (long)getpid() && kill((pid_t)pid, 0) != 0 && errno == ESRCH)
            unlinkat(dirfd(d), e->d_name, 0);
    }
    closedir(d);
}

/* Creates a fresh "<path>.tmp<PID>.<N>" into tmp (size cap): by linking the
 * unnamed file fd when fd >= 0, else as a new empty file whose descriptor is
 * returned. Returns the new descriptor (fd >= 0: fd itself), or -1 with errno. */
static int create_temp_name(const char *path, int fd, char *tmp, size_t cap)
{
    char proc[64];
    if (fd >= 0)
        snprintf(proc, sizeof proc, "/proc/self/fd/%d", fd);
    for (int attempt = 0; attempt < 100; attempt++) {
        snprintf(tmp, cap, "%s.tmp%ld.%d", path, (long)getpid(), attempt);
        if (fd >= 0) {
            if (linkat(AT_FDCWD, proc, AT_FDCWD, tmp, AT_SYMLINK_FOLLOW) == 0)
                return fd;
        } else {
            int t = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
            if (t >= 0)
                return t;
        }
        if (errno != EEXIST)
            return -1;
    }
    errno = EEXIST;
    return -1;
}

/* The O_TMPFILE way. Returns 1 when written, 0 when the system cannot do it
 * this way (the caller falls back to a named temporary file), -1 on a real
 * failure (errno set; *what names the step). */
static int write_unnamed(const char *path, const char *dir, int exists, mode_t mode,
                         const void *data, size_t size, char *tmp, size_t cap, const char **what)
{
#ifdef O_TMPFILE
    int fd = open(dir, O_TMPFILE | O_WRONLY | O_CLOEXEC, 0644);
    if (fd < 0) {
        *what = "cannot create temporary file";
        return errno == EOPNOTSUPP || errno == EISDIR || errno == EINVAL ? 0 : -1;
    }
    *what = "cannot write";
    /* an existing file keeps its permissions (a private file stays private) */
    if ((exists && fchmod(fd, mode) != 0) || write_all(fd, data, size) != 0) {
        int e = errno;
        close(fd);
        errno = e;
        return -1;
    }
    char proc[64];
    snprintf(proc, sizeof proc, "/proc/self/fd/%d", fd);
    int done = !exists && linkat(AT_FDCWD, proc, AT_FDCWD, path, AT_SYMLINK_FOLLOW) == 0;
    if (!done && (exists || errno == EEXIST)) {
        if (create_temp_name(path, fd, tmp, cap) < 0) {
            int e = errno;
            close(fd);
            errno = e;
            return e == EEXIST ? -1 : 0; /* no /proc, or linkat refused: the named way */
        }
        if (rename(tmp, path) != 0) {
            int e = errno;
            unlink(tmp);
            close(fd);
            errno = e;
            return -1;
        }
        done = 1;
    }
    int e = errno;
    close(fd);
    errno = e;
    return done ? 1 : 0;
#else
    (void)path, (void)dir, (void)exists, (void)mode, (void)data, (void)size, (void)tmp, (void)cap;
    *what = "cannot create temporary file";
    return 0;
#endif
}

ffd_status ffd_write_file_atomic(const char *path, const void *data, size_t size, ffd_error *err)
{
    const char *shown = path; /* messages name the path the caller gave */
    char *target = NULL;
    struct stat lst;
    /* write through a symbolic link: replace the file it points to, keep the link */
    if (lstat(path, &lst) == 0 && S_ISLNK(lst.st_mode)) {
        target = realpath(path, NULL);
        if (!target)
            return ffd_fail(err, FFD_ERR_IO, "%s: cannot resolve symbolic link: %s", path,
                            strerror(errno));
        path = target;
    }
    struct stat st;
    int exists = stat(path, &st) == 0;
    if (exists && S_ISDIR(st.st_mode)) {
        free(target);
        return ffd_fail(err, FFD_ERR_IO, "%s: is a directory, expected a file path", shown);
    }
    size_t len = strlen(path), cap = len + 32;
    char *tmp = ffd_malloc(cap), *dir = ffd_malloc(len + 2);
    if (!tmp || !dir) {
        ffd_free(tmp);
        ffd_free(dir);
        free(target);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", shown);
    }
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    if (!slash)
        strcpy(dir, ".");
    else if (slash == path)
        strcpy(dir, "/");
    else
        snprintf(dir, len + 2, "%.*s", (int)(slash - path), path);
    remove_stale_temps(dir, base);

    const char *what = "cannot write";
    int fd = -1;
    int r = write_unnamed(path, dir, exists, st.st_mode & 07777, data, size, tmp, cap, &what);
    if (r < 0)
        goto fail;
    if (r == 0) { /* the named temporary file */
        what = "cannot create temporary file";
        if ((fd = create_temp_name(path, -1, tmp, cap)) < 0)
            goto fail;
        what = "cannot write";
        if ((exists && fchmod(fd, st.st_mode & 07777) != 0) || write_all(fd, data, size) != 0)
            goto fail_unlink;
        int c = close(fd);
        fd = -1;
        if (c != 0 || rename(tmp, path) != 0)
            goto fail_unlink;
    }
    ffd_free(tmp);
    ffd_free(dir);
    free(target);
    return FFD_OK;
fail_unlink:;
    int e = errno;
    if (fd >= 0)
        close(fd);
    unlink(tmp);
    errno = e;
fail:;
    e = errno;
    ffd_status s = ffd_fail(err, FFD_ERR_IO, "%s: %s: %s", shown, what, strerror(e));
    ffd_free(tmp);
    ffd_free(dir);
    free(target);
    return s;
}

double ffd_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
