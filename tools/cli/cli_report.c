/* What `ffd deform` and ffd-mpi (tools/mpi/ffd_mpi.c) share: the report of
 * a rig's application as JSON (`--report`), the JSON values it is made of,
 * and the size `--max-memory` takes. */
#include "cli.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void cli_json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\')
            fprintf(f, "\\%c", *p);
        else if (*p < 0x20)
            fprintf(f, "\\u%04x", *p);
        else
            fputc(*p, f);
    }
    fputc('"', f);
}

void cli_json_number(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.17g", v);
    else
        fputs("null", f);
}

/* One JSON value of the details, in the report's own style (", " and ": "
 * separators, numbers as cli_json_number). */
static void print_json(const cJSON *v)
{
    if (cJSON_IsObject(v) || cJSON_IsArray(v)) {
        int object = cJSON_IsObject(v);
        putchar(object ? '{' : '[');
        for (const cJSON *c = v->child; c; c = c->next) {
            if (c != v->child)
                printf(", ");
            if (object) {
                cli_json_string(stdout, c->string);
                printf(": ");
            }
            print_json(c);
        }
        putchar(object ? '}' : ']');
    } else if (cJSON_IsNumber(v)) {
        cli_json_number(stdout, v->valuedouble);
    } else if (cJSON_IsString(v)) {
        cli_json_string(stdout, v->valuestring);
    } else if (cJSON_IsBool(v)) {
        printf(cJSON_IsTrue(v) ? "true" : "false");
    } else {
        printf("null");
    }
}

/* The shared part of the report, then the method's details as more keys of
 * the same object, whatever they are. */
static void print_ids(const uint32_t *ids, size_t n)
{
    printf("[");
    for (size_t i = 0; i < n; i++)
        printf("%s%u", i ? ", " : "", ids[i]);
    printf("]");
}

void cli_print_report(const ffd_rig_report *report, const ffd_inversion_report *inv,
                         const ffd_fold_report *folds)
{
    printf("{\"constraints\": [");
    for (size_t c = 0; c < report->constraint_count; c++) {
        printf("%s{\"index\": %zu, \"residual\": ", c ? ", " : "", c);
        cli_json_number(stdout, report->residuals[c]);
        printf(", \"reached\": [");
        for (int a = 0; a < 3; a++) {
            printf(a ? ", " : "");
            cli_json_number(stdout, report->reached[3 * c + a]);
        }
        printf("]}");
    }
    printf("], \"max_residual\": ");
    cli_json_number(stdout, report->max_residual);
    printf(", \"rank\": %zu, \"outside\": %zu, \"controls\": %zu, \"method\": ", report->rank,
           report->outside_count, report->control_count);
    cli_json_string(stdout, report->method ? report->method : "");
    cJSON *details = report->details ? cJSON_Parse(report->details) : NULL;
    for (const cJSON *c = details ? details->child : NULL; c; c = c->next) {
        printf(", ");
        cli_json_string(stdout, c->string);
        printf(": ");
        print_json(c);
    }
    cJSON_Delete(details);
    if (inv) {
        printf(", \"inversions\": {\"cells_checked\": %zu, \"inverted\": %zu, \"worst_det\": ",
               inv->cells_checked, inv->inverted);
        cli_json_number(stdout, inv->worst_det);
        printf(", \"worst_scaled_jacobian\": ");
        cli_json_number(stdout, inv->worst_scaled_jacobian);
        printf(", \"cell_ids\": ");
        print_ids(inv->cell_ids, inv->cell_id_count);
        printf(", \"faces_checked\": %zu, \"flipped_faces\": %zu, \"face_ids\": ",
               inv->faces_checked, inv->flipped_faces);
        print_ids(inv->face_ids, inv->face_id_count);
        printf("}");
    }
    if (folds) {
        printf(", \"folds\": {\"cells\": ");
        cli_json_string(stdout, folds->cells ? folds->cells : "");
        printf(", \"cells_checked\": %zu, \"samples\": %zu, \"folded\": %zu, \"min_det\": ",
               folds->cells_checked, folds->samples, folds->folded);
        cli_json_number(stdout, folds->min_det);
        printf(", \"cell_ids\": ");
        print_ids(folds->cell_ids, folds->folded);
        printf("}");
    }
    printf("}\n");
}

/* "8G", "512M", "3000000000": bytes; 0 on a malformed or zero size. */
size_t cli_parse_size(const char *text)
{
    char *end = NULL;
    double v = strtod(text, &end);
    if (end == text || !(v > 0))
        return 0;
    double unit = 1;
    switch (*end) {
    case 'k': case 'K': unit = 1024.0; end++; break;
    case 'm': case 'M': unit = 1048576.0; end++; break;
    case 'g': case 'G': unit = 1073741824.0; end++; break;
    case 't': case 'T': unit = 1099511627776.0; end++; break;
    default: break;
    }
    if (unit > 1 && (strcmp(end, "iB") == 0 || strcmp(end, "B") == 0))
        end += strlen(end);
    if (*end || !(v * unit < 1e18))
        return 0;
    return (size_t)(v * unit);
}
