/* core — status messages, allocation, whole-file I/O shared by every module. */
#ifndef FFD_CORE_H
#define FFD_CORE_H

#include "ffd.h"

#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>

#if defined(__GNUC__)
#define FFD_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define FFD_PRINTF(a, b)
#endif

/* Fills err (if not NULL) with a printf-style message and returns status. */
ffd_status ffd_fail(ffd_error *err, ffd_status status, const char *fmt, ...) FFD_PRINTF(3, 4);

/* All library allocation goes through these (see ffd_set_allocator). */
/* Asks for transparent huge pages on the 2 MiB-aligned interior of a big
 * block (advice only; ffd_malloc and ffd_realloc do it for every block). */
void ffd_advise_huge(void *p, size_t bytes);
void *ffd_malloc(size_t size);
void *ffd_calloc(size_t count, size_t size);  /* zeroed; NULL on overflow */
void *ffd_realloc(void *ptr, size_t size);
/* count*size with overflow check: returns NULL on overflow or failure. */
void *ffd_malloc_array(size_t count, size_t size);
void *ffd_realloc_array(void *ptr, size_t count, size_t size);
/* cJSON allocations that failed on this thread so far (counted while an
 * allocator is set: then cJSON allocates through ffd_malloc). A parse that
 * returns NULL while this count moved ran out of memory: FFD_ERR_NOMEM, not
 * a syntax error. */
unsigned long ffd_json_alloc_failures(void);
/* Copies a NUL-terminated string (NULL -> NULL). */
char *ffd_strdup(const char *s);

/* Grows *buf (element size elem) so that it holds at least need elements;
 * *cap is updated. Returns false on overflow or allocation failure. */
bool ffd_grow(void **buf, size_t *cap, size_t need, size_t elem);

/* Reads a whole regular file. Refuses directories and missing files with a
 * clear FFD_ERR_IO message. *data is NUL-terminated (one extra byte). */
ffd_status ffd_read_file(const char *path, unsigned char **data, size_t *size, ffd_error *err);

/* Writes bytes atomically (docs/cli.md, "Conventions"): an unnamed
 * O_TMPFILE file in path's directory, fsync, then linked in as path (or as
 * "<path>.tmp<PID>.<N>" renamed over an existing path), so no partial file is
 * ever visible; without O_TMPFILE, the named temporary file, fsync, rename.
 * First removes "<path>.tmp<PID>.<N>" leftovers whose PID does not run.
 * Through a symbolic link the target is replaced and the link kept; an
 * existing file keeps its permissions. FFD_ERR_IO naming path on failure. */
ffd_status ffd_write_file_atomic(const char *path, const void *data, size_t size, ffd_error *err);

/* Progress of one stage of a long operation (progress.c, ffd_set_progress):
 * begin reports 0, update a larger fraction in [0, 1) at most every 0.05 s,
 * end reports 1. Calls from OpenMP worker threads other than the master are
 * ignored; without a hook set each call costs a test. */
typedef struct ffd_progress {
    const char *stage;
    double fraction;  /* the last fraction reported */
    double last_time; /* ffd_now() of the last report */
} ffd_progress;
void ffd_progress_begin(ffd_progress *p, const char *stage);
void ffd_progress_update(ffd_progress *p, double fraction);
void ffd_progress_end(ffd_progress *p);

/* Text input (text.c). Length of a UTF-8 byte order mark at text: 3 or 0. */
size_t ffd_utf8_bom_length(const void *text, size_t size);
/* 1-based line and column (in bytes) of text[offset]. */
void ffd_text_line_col(const char *text, size_t offset, size_t *line, size_t *col);
/* Byte offset of the first NUL in JSON text, or size when none: a raw NUL
 * byte anywhere, or a \u0000 escape inside a string (offset of its
 * backslash; "\\u0000", an escaped backslash and then text, is none).
 * *escaped (may be NULL) tells which. */
size_t ffd_json_nul_at(const char *text, size_t size, bool *escaped);
/* FFD_ERR_PARSE "NAME:LINE:COL: a NUL character (\u0000) in a string is not
 * allowed" (or "a NUL byte ...") when ffd_json_nul_at finds one; else FFD_OK.
 * Every JSON parse site calls it before cJSON: cJSON would cut the string there. */
ffd_status ffd_json_refuse_nul(const char *text, size_t size, const char *name, ffd_error *err);

/* The work budget of one request (ffd_limits, docs/rig.md "Limits"). A step
 * estimates its peak bytes and its operations before it allocates or runs. */
typedef struct ffd_budget {
    double max_memory;  /* bytes; 0: unlimited */
    double max_work;    /* operations for the whole request; 0: unlimited */
    double work;        /* charged so far */
} ffd_budget;
#define FFD_DEFAULT_MAX_MEMORY ((size_t)2 << 30)
#define FFD_DEFAULT_MAX_WORK 3e10
/* Resolves limits (NULL: defaults; zero fields: defaults; unlimited: none). */
void ffd_budget_init(ffd_budget *b, const ffd_limits *limits);
/* Checks a step of peak bytes and work operations against b and charges its
 * work. On refusal FFD_ERR_INVALID: "WHAT would need about 3.2 GB of memory
 * (limit 2 GiB; ...)" where WHAT is the printf-formatted what. Nothing is
 * charged on refusal. */
ffd_status ffd_budget_charge(ffd_budget *b, double bytes, double work, ffd_error *err,
                             const char *what, ...) FFD_PRINTF(5, 6);
/* "2,400,000": n with thousands separators, into buf (at least 32 bytes). */
const char *ffd_format_count(double n, char *buf, size_t size);

/* Monotonic clock in seconds. */
double ffd_now(void);

/* Basename for messages ("dir/a.obj" -> "a.obj" is NOT done: we keep the path the user gave). */
static inline const char *ffd_name_or(const char *name, const char *fallback)
{
    return name ? name : fallback;
}

#endif
