/* Tests of src/core/text.c: the UTF-8 byte order mark, line:column of an
 * offset, and the scan for NUL in JSON text that every JSON parse site runs
 * before cJSON (issue 14: cJSON cut "margin\u0000x" to "margin"). */
#include "check.h"
#include "core/core.h"

#include <cjson/cJSON.h>

/* ffd_json_nul_at on a NUL-terminated literal. */
static size_t nul_at(const char *text, bool *escaped)
{
    return ffd_json_nul_at(text, strlen(text), escaped);
}

static void test_nul_escapes(void)
{
    bool esc = false;
    /* in a key and in a value: the offset of the backslash */
    CHECK(nul_at("{\"margin\\u0000x\": 0.1}", &esc) == 8 && esc);
    CHECK(nul_at("{\"path\": \"bunny.obj\\u0000/../..\"}", &esc) == 19 && esc);
    CHECK(nul_at("[\"\\u0000\"]", &esc) == 2 && esc);
    /* an escaped backslash and then the text u0000: no NUL */
    CHECK(nul_at("{\"a\": \"\\\\u0000\"}", NULL) == strlen("{\"a\": \"\\\\u0000\"}"));
    /* ... but an escaped backslash, then the escape, is one */
    CHECK(nul_at("{\"a\": \"\\\\\\u0000\"}", &esc) == 9 && esc);
    /* an escaped quote does not end the string */
    CHECK(nul_at("{\"a\": \"\\\"\\u0000\"}", &esc) == 9 && esc);
    /* other escapes and code points are fine */
    const char *ok[] = {"{\"a\": \"\\u0001\\u00e9\\u1000\\ud83d\\ude00\"}", "{\"a\": \"\\n\\t\\/\"}",
                        "{\"u0000\": 1}", "[]", ""};
    for (size_t i = 0; i < sizeof ok / sizeof *ok; i++)
        CHECK(nul_at(ok[i], NULL) == strlen(ok[i]));
    CHECK(nul_at("{\"a\": \"\\u00000\"}", &esc) == 7 && esc); /* \u0000, then 0 */
    /* outside a string the text is not an escape (cJSON refuses it anyway) */
    CHECK(nul_at("[1, \\u0000]", NULL) == strlen("[1, \\u0000]"));
    /* a backslash at the very end, a truncated escape */
    CHECK(nul_at("[\"\\", NULL) == 3);
    CHECK(nul_at("[\"\\u000", NULL) == 7);
}

static void test_raw_nul_bytes(void)
{
    static const char in_string[] = "{\"a\": \"x\0y\"}";
    static const char between[] = "{\"a\": 1}\0 junk";
    static const char after_backslash[] = "[\"\\\0\"]";
    bool esc = true;
    CHECK(ffd_json_nul_at(in_string, sizeof in_string - 1, &esc) == 8 && !esc);
    CHECK(ffd_json_nul_at(between, sizeof between - 1, &esc) == 8 && !esc);
    CHECK(ffd_json_nul_at(after_backslash, sizeof after_backslash - 1, &esc) == 3 && !esc);
}

static void test_refuse_message(void)
{
    ffd_error err = {{0}};
    const char *t = "{\n  \"deformer\": \"lattice\",\n  \"margin\\u0000x\": 0.1\n}";
    CHECK(ffd_json_refuse_nul(t, strlen(t), "rig.json", &err) == FFD_ERR_PARSE);
    CHECK(strcmp(err.message, "rig.json:3:10: a NUL character (\\u0000) in a string is not allowed") == 0);
    static const char raw[] = "{\"a\":\0}";
    CHECK(ffd_json_refuse_nul(raw, sizeof raw - 1, NULL, &err) == FFD_ERR_PARSE);
    CHECK(strcmp(err.message, "JSON:1:6: a NUL byte is not allowed in JSON text") == 0);
    CHECK(ffd_json_refuse_nul("{\"a\": \"\\\\u0000\"}", 16, "x", NULL) == FFD_OK);
    CHECK(ffd_json_refuse_nul(NULL, 0, "x", NULL) == FFD_OK);
}

/* What the scan guards against: cJSON really does cut the string. If a
 * later cJSON refused \u0000 itself, this would tell. */
static void test_cjson_cuts_at_nul(void)
{
    cJSON *doc = cJSON_Parse("{\"margin\\u0000x\": 0.1}");
    CHECK(doc && doc->child && strcmp(doc->child->string, "margin") == 0);
    cJSON_Delete(doc);
}

static void test_bom_and_line_col(void)
{
    CHECK(ffd_utf8_bom_length("\xEF\xBB\xBFv 0 0 0", 10) == 3);
    CHECK(ffd_utf8_bom_length("\xEF\xBB\xBF", 3) == 3);
    CHECK(ffd_utf8_bom_length("\xEF\xBB", 2) == 0);
    CHECK(ffd_utf8_bom_length("v \xEF\xBB\xBF", 5) == 0);
    CHECK(ffd_utf8_bom_length(NULL, 0) == 0);
    size_t line, col;
    ffd_text_line_col("ab\ncd\n", 4, &line, &col);
    CHECK(line == 2 && col == 2);
    ffd_text_line_col("ab", 0, &line, &col);
    CHECK(line == 1 && col == 1);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"nul_escapes", test_nul_escapes},
        {"raw_nul_bytes", test_raw_nul_bytes},
        {"refuse_message", test_refuse_message},
        {"cjson_cuts_at_nul", test_cjson_cuts_at_nul},
        {"bom_and_line_col", test_bom_and_line_col},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
