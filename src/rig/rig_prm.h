/* rig_prm — the syntax of PyGeM's parameter files (.prm), read as Python's
 * configparser.RawConfigParser reads them, for the methods whose parameter
 * files are not the lattice's (rig_prm.c; the lattice's own reader is
 * src/lattice/lattice_prm.c). ffd_rig_parse_prm dispatches on the file's
 * section names (ffd_method.prm_section). */
#ifndef FFD_RIG_PRM_H
#define FFD_RIG_PRM_H

#include "rig/rig.h"

/* One non-blank value line, stripped (not NUL-terminated). */
typedef struct ffd_prm_line {
    const char *text;
    size_t size;
    size_t line;
} ffd_prm_line;

/* One "key: value" (or "key = value") and its continuation lines. */
typedef struct ffd_prm_entry {
    const char *section, *key; /* spans into the text */
    size_t section_size, key_size;
    size_t line;               /* of the key */
    size_t first, count;       /* its value lines: lines[first .. first+count) */
} ffd_prm_entry;

typedef struct ffd_prm {
    const char *name;
    ffd_prm_entry *entries;
    size_t entry_count, entry_cap;
    ffd_prm_line *lines;
    size_t line_count, line_cap;
} ffd_prm;

/* Reads text: [section] headers, "key: value" / "key = value" lines,
 * indented continuation lines, full-line '#'/';' comments, blank lines
 * (skipped), a UTF-8 BOM, \n, \r\n or \r line ends; a key twice in a
 * section is FFD_ERR_PARSE ("NAME:LINE: ..."). ffd_prm_free after. */
ffd_status ffd_prm_read(const char *text, size_t size, const char *name, ffd_prm *out,
                        ffd_error *err);
void ffd_prm_free(ffd_prm *prm);
/* The entry of key (compared case-insensitively, as configparser's
 * lower-cased keys) in section; NULL when absent. */
const ffd_prm_entry *ffd_prm_get(const ffd_prm *prm, const char *section, const char *key);
/* 1 when text has a header line "[section]" (the dispatch's test). */
int ffd_prm_has_section(const char *text, size_t size, const char *section);
/* The entry key of [section], or FFD_ERR_PARSE "[section] has no key 'key'". */
ffd_status ffd_prm_required(const ffd_prm *prm, const char *section, const char *key,
                            const ffd_prm_entry **out, ffd_error *err);
/* PyGeM's [Control points] section of the RBF and IDW files: "original
 * control points" into *points and "deformed control points" into
 * *deformed (*count by 3 each; FFD_ERR_INVALID naming the line when their
 * counts differ). */
ffd_status ffd_prm_control_points(const ffd_prm *prm, double **points, size_t *count,
                                  double **deformed, ffd_error *err);
/* Reads an entry's lines as points "x y z" (blank-separated finite
 * numbers, three a line) into *points (ffd_malloc'd, *count by 3).
 * FFD_ERR_PARSE / FFD_ERR_NONFINITE naming the line; FFD_ERR_NOMEM. */
ffd_status ffd_prm_points(const ffd_prm *prm, const ffd_prm_entry *e, double **points,
                          size_t *count, ffd_error *err);
/* One finite number (the entry's only token). */
ffd_status ffd_prm_number(const ffd_prm *prm, const ffd_prm_entry *e, double *out, ffd_error *err);

/* Appends printf-formatted text to a growing buffer (*size used, *cap
 * allocated); 0 when out of memory. */
int ffd_prm_append(char **text, size_t *size, size_t *cap, const char *fmt, ...) FFD_PRINTF(4, 5);
/* Writes points as PyGeM's writers do: "key: x   y   z" then each further
 * point on a line indented by 25 spaces; numbers in %.17g. 0 when out of memory. */
int ffd_prm_append_points(char **text, size_t *size, size_t *cap, const char *key,
                          const double *points, size_t count);

#endif
