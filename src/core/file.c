/* core — whole-file reading and atomic writing (temporary file + rename). */
#ifndef _XOPEN_SOURCE
#define _XOPEN_SOURCE 700 /* realpath */
#endif
#include "core.h"

#include <errno.h>
#include <fcntl.h>
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
    size_t len = strlen(path);
    char *tmp = ffd_malloc(len + 32);
    if (!tmp) {
        free(target);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", shown);
    }
    struct stat st;
    int exists = stat(path, &st) == 0;
    if (exists && S_ISDIR(st.st_mode)) {
        ffd_free(tmp);
        free(target);
        return ffd_fail(err, FFD_ERR_IO, "%s: is a directory, expected a file path", shown);
    }
    int fd = -1;
    for (int attempt = 0; attempt < 100 && fd < 0; attempt++) {
        snprintf(tmp, len + 32, "%s.tmp%ld.%d", path, (long)getpid(), attempt);
        fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL, 0644);
        if (fd < 0 && errno != EEXIST)
            break;
    }
    if (fd < 0) {
        ffd_status s = ffd_fail(err, FFD_ERR_IO, "%s: cannot create temporary file: %s", shown,
                                strerror(errno));
        ffd_free(tmp);
        free(target);
        return s;
    }
    /* an existing file keeps its permissions (a private file stays private) */
    if (exists && fchmod(fd, st.st_mode & 07777) != 0)
        goto fail;
    const unsigned char *p = data;
    size_t left = size;
    while (left > 0) {
        ssize_t w = write(fd, p, left);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            goto fail;
        }
        p += w;
        left -= (size_t)w;
    }
    if (fsync(fd) != 0 && errno != EINVAL && errno != EROFS)
        goto fail;
    if (close(fd) != 0) {
        fd = -1;
        goto fail;
    }
    fd = -1;
    if (rename(tmp, path) != 0)
        goto fail;
    ffd_free(tmp);
    free(target);
    return FFD_OK;
fail:;
    int e = errno;
    if (fd >= 0)
        close(fd);
    unlink(tmp);
    ffd_free(tmp);
    free(target);
    return ffd_fail(err, FFD_ERR_IO, "%s: cannot write: %s", shown, strerror(e));
}

double ffd_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
