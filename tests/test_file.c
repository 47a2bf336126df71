/* Tests of core's whole-file writing (src/core/file.c): no partial file is
 * ever visible in the directory, a writer killed with SIGKILL leaves no
 * partial file and nothing after the next save, stale temporary files of
 * dead writers are removed and everything else is kept. */
#include "check.h"
#include "core/core.h"

#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define DIR_NAME "test_file_dir"

/* An empty directory DIR_NAME. */
static void fresh_dir(void)
{
    DIR *d = opendir(DIR_NAME);
    if (d) {
        struct dirent *e;
        char path[1400];
        while ((e = readdir(d)) != NULL) {
            if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
                continue;
            snprintf(path, sizeof path, DIR_NAME "/%s", e->d_name);
            unlink(path);
        }
        closedir(d);
    }
    mkdir(DIR_NAME, 0755);
}

static void touch(const char *name)
{
    char path[1400];
    snprintf(path, sizeof path, DIR_NAME "/%s", name);
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        fputs("leftover", f);
        fclose(f);
    }
}

static int exists(const char *name)
{
    char path[1400];
    struct stat st;
    snprintf(path, sizeof path, DIR_NAME "/%s", name);
    return lstat(path, &st) == 0;
}

/* Entries of DIR_NAME other than "." and ".."; *bad counts those whose size
 * is not one of the complete sizes a and b (a partial file). */
static int list_dir(size_t a, size_t b, int *bad, char *first, size_t cap)
{
    DIR *d = opendir(DIR_NAME);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        struct stat st;
        char path[1400];
        snprintf(path, sizeof path, DIR_NAME "/%s", e->d_name);
        if (stat(path, &st) != 0)
            continue; /* renamed meanwhile */
        n++;
        if ((size_t)st.st_size != a && (size_t)st.st_size != b) {
            if (!*bad && first)
                snprintf(first, cap, "%s (%lld bytes)", e->d_name, (long long)st.st_size);
            (*bad)++;
        }
    }
    closedir(d);
    return n;
}

/* A PID that no longer runs: a child that has exited and been reaped. */
static pid_t dead_pid(void)
{
    pid_t pid = fork();
    if (pid == 0)
        _exit(0);
    waitpid(pid, NULL, 0);
    return pid;
}

/* Leftovers "<name>.tmp<PID>.<N>" of dead writers go on the next save to
 * that name; a live writer's, another target's and other names stay. */
static void test_stale_temps_removed(void)
{
    fresh_dir();
    long dead = (long)dead_pid(), live = (long)getppid();
    char name[128];
    const char *removed[2], *kept[6];
    static char buf[8][128];
    snprintf(buf[0], 128, "t.obj.tmp%ld.0", dead);
    snprintf(buf[1], 128, "t.obj.tmp%ld.17", dead);
    snprintf(buf[2], 128, "t.obj.tmp%ld.0", live);           /* a live writer */
    snprintf(buf[3], 128, "t.obj.tmp%ld.0", (long)getpid()); /* this process */
    snprintf(buf[4], 128, "u.obj.tmp%ld.0", dead);           /* another target */
    snprintf(buf[5], 128, "t.obj.tmp%ld.x", dead);           /* not the pattern */
    snprintf(buf[6], 128, "t.obj.tmp%ld.0.bak", dead);
    snprintf(buf[7], 128, "xt.obj.tmp%ld.0", dead);
    removed[0] = buf[0];
    removed[1] = buf[1];
    for (int i = 0; i < 6; i++)
        kept[i] = buf[2 + i];
    for (int i = 0; i < 8; i++)
        touch(buf[i]);
    snprintf(name, sizeof name, DIR_NAME "/t.obj");
    CHECK_OK(ffd_write_file_atomic(name, "data\n", 5, &check_err_));
    for (int i = 0; i < 2; i++)
        CHECK(!exists(removed[i]));
    for (int i = 0; i < 6; i++)
        CHECK(exists(kept[i]));
    CHECK(exists("t.obj"));
    fresh_dir();
}

/* Data of size n with a recognisable pattern. */
static unsigned char *pattern(size_t n, unsigned char seed)
{
    unsigned char *p = malloc(n);
    for (size_t i = 0; p && i < n; i++)
        p[i] = (unsigned char)(seed + i * 31);
    return p;
}

/* While a child writes (a new file, then overwrites with other sizes), the
 * directory never shows a file of a size other than a complete one. */
static void test_no_partial_file_visible(void)
{
    fresh_dir();
    const size_t a = 24u << 20, b = (24u << 20) + 4099;
    unsigned char *da = pattern(a, 1), *db = pattern(b, 7);
    CHECK(da && db);
    if (!da || !db) {
        free(da);
        free(db);
        return;
    }
    pid_t pid = fork();
    if (pid == 0) {
        ffd_error err = {{0}};
        int failed = 0;
        for (int i = 0; i < 6 && !failed; i++)
            failed = ffd_write_file_atomic(DIR_NAME "/big.bin", i % 2 ? db : da, i % 2 ? b : a,
                                           &err) != FFD_OK;
        free(da); /* the child's copies too: valgrind checks the child for leaks */
        free(db);
        _exit(failed);
    }
    int bad = 0, status = 0, polls = 0;
    char first[400] = "";
    for (;;) {
        int done = waitpid(pid, &status, WNOHANG) == pid;
        list_dir(a, b, &bad, first, sizeof first);
        polls++;
        if (done)
            break;
    }
    if (bad)
        fprintf(stderr, "  partial file visible: %s (%d of %d polls)\n", first, bad, polls);
    CHECK(bad == 0);
    CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    int bad_after = 0;
    CHECK(list_dir(a, b, &bad_after, NULL, 0) == 1 && bad_after == 0);
    free(da);
    free(db);
    fresh_dir();
}

/* A writer killed with SIGKILL at random moments: no partial file is ever
 * left, and after the next save the directory holds the target alone. */
static void test_killed_writer(void)
{
    fresh_dir();
    const size_t a = 8u << 20, b = (8u << 20) + 77;
    unsigned char *da = pattern(a, 3), *db = pattern(b, 5);
    CHECK(da && db);
    if (!da || !db) {
        free(da);
        free(db);
        return;
    }
    srand(12345);
    int partial = 0;
    for (int round = 0; round < 12; round++) {
        pid_t pid = fork();
        if (pid == 0) {
            ffd_error err = {{0}};
            for (int i = 0;; i++)
                ffd_write_file_atomic(DIR_NAME "/out.bin", i % 2 ? db : da, i % 2 ? b : a, &err);
        }
        struct timespec ts = {0, (long)(rand() % 40 + 1) * 1000000L};
        nanosleep(&ts, NULL);
        kill(pid, SIGKILL);
        waitpid(pid, NULL, 0);
        char first[400] = "";
        int bad = 0;
        list_dir(a, b, &bad, first, sizeof first);
        if (bad && !partial)
            fprintf(stderr, "  round %d: partial file left: %s\n", round, first);
        partial += bad;
    }
    CHECK(partial == 0);
    CHECK_OK(ffd_write_file_atomic(DIR_NAME "/out.bin", da, a, &check_err_));
    int bad = 0;
    CHECK(list_dir(a, b, &bad, NULL, 0) == 1 && bad == 0 && exists("out.bin"));
    free(da);
    free(db);
    fresh_dir();
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"stale_temps_removed", test_stale_temps_removed},
        {"no_partial_file_visible", test_no_partial_file_visible},
        {"killed_writer", test_killed_writer},
    };
    int r = check_run(tests, sizeof tests / sizeof *tests, argc, argv);
    rmdir(DIR_NAME);
    return r;
}
