/* core — facts about text input shared by every reader: the UTF-8 byte order
 * mark, line and column of a byte offset, and the NUL characters that JSON
 * can smuggle into a string.
 *
 * Why NUL is refused: cJSON decodes the escape \u0000 into a NUL byte and
 * hands out C strings, so {"margin\u0000x": 1} would read as the key "margin"
 * and the path "a.obj\u0000/../x" as "a.obj". A raw NUL byte is no better
 * (cJSON skips it as whitespace between tokens and copies it into strings).
 * No text the project reads has a use for NUL, so every JSON parse site
 * calls ffd_json_refuse_nul before cJSON sees the text. */
#include "core.h"

#include <string.h>

size_t ffd_utf8_bom_length(const void *text, size_t size)
{
    return size >= 3 && memcmp(text, "\xEF\xBB\xBF", 3) == 0 ? 3 : 0;
}

void ffd_text_line_col(const char *text, size_t offset, size_t *line, size_t *col)
{
    size_t l = 1, c = 1;
    for (size_t i = 0; i < offset; i++) {
        if (text[i] == '\n') {
            l++;
            c = 1;
        } else {
            c++;
        }
    }
    *line = l;
    *col = c;
}

size_t ffd_json_nul_at(const char *text, size_t size, bool *escaped)
{
    bool in_string = false;
    for (size_t i = 0; i < size; i++) {
        char ch = text[i];
        if (ch == '\0') {
            if (escaped)
                *escaped = false;
            return i;
        }
        if (!in_string) {
            in_string = ch == '"';
        } else if (ch == '"') {
            in_string = false;
        } else if (ch == '\\' && i + 1 < size) {
            /* An escape is two characters, so "\\u0000" (an escaped
             * backslash, then text) is no NUL. */
            if (text[i + 1] == 'u' && size - i >= 6 && memcmp(text + i + 2, "0000", 4) == 0) {
                if (escaped)
                    *escaped = true;
                return i;
            }
            if (text[i + 1] != '\0')
                i++;
        }
    }
    return size;
}

ffd_status ffd_json_refuse_nul(const char *text, size_t size, const char *name, ffd_error *err)
{
    bool escaped = false;
    size_t at = ffd_json_nul_at(text, size, &escaped);
    if (at == size)
        return FFD_OK;
    size_t line, col;
    ffd_text_line_col(text, at, &line, &col);
    return ffd_fail(err, FFD_ERR_PARSE,
                    escaped ? "%s:%zu:%zu: a NUL character (\\u0000) in a string is not allowed"
                            : "%s:%zu:%zu: a NUL byte is not allowed in JSON text",
                    ffd_name_or(name, "JSON"), line, col);
}
