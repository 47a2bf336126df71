/* core — the work budget of one request (ffd_limits): estimated peak memory
 * and estimated operations, checked before a step allocates or runs, so that
 * an extreme but valid request is refused in milliseconds instead of running
 * for minutes (docs/rig.md "Limits"). */
#include "core.h"

#include <math.h>
#include <stdio.h>

void ffd_budget_init(ffd_budget *b, const ffd_limits *limits)
{
    ffd_limits l = limits ? *limits : (ffd_limits){0};
    b->work = 0;
    if (l.unlimited) {
        b->max_memory = 0;
        b->max_work = 0;
        return;
    }
    b->max_memory = (double)(l.max_memory ? l.max_memory : FFD_DEFAULT_MAX_MEMORY);
    b->max_work = l.max_work > 0 ? l.max_work : FFD_DEFAULT_MAX_WORK;
}

const char *ffd_format_count(double n, char *buf, size_t size)
{
    char digits[32];
    if (!(n < 1e18)) {
        snprintf(buf, size, "%.3g", n);
        return buf;
    }
    int len = snprintf(digits, sizeof digits, "%.0f", n < 0 ? 0 : n);
    size_t o = 0;
    for (int i = 0; i < len && o + 2 < size; i++) {
        if (i > 0 && (len - i) % 3 == 0)
            buf[o++] = ',';
        buf[o++] = digits[i];
    }
    buf[o] = 0;
    return buf;
}

/* "3.2 GB", "512 MB" (decimal units: an estimate, not an accounting). */
static void format_bytes(double bytes, char *buf, size_t size)
{
    if (bytes >= 1e9)
        snprintf(buf, size, "%.3g GB", bytes / 1e9);
    else if (bytes >= 1e6)
        snprintf(buf, size, "%.3g MB", bytes / 1e6);
    else
        snprintf(buf, size, "%.0f bytes", bytes);
}

/* The limit as given: "2 GiB" for whole binary units. */
static void format_limit(double bytes, char *buf, size_t size)
{
    double gib = bytes / 1073741824.0, mib = bytes / 1048576.0;
    if (gib >= 1 && gib == floor(gib))
        snprintf(buf, size, "%.0f GiB", gib);
    else if (mib >= 1 && mib == floor(mib))
        snprintf(buf, size, "%.0f MiB", mib);
    else
        format_bytes(bytes, buf, size);
}

ffd_status ffd_budget_charge(ffd_budget *b, double bytes, double work, ffd_error *err,
                             const char *what, ...)
{
    if (!b)
        return FFD_OK;
    int over_memory = b->max_memory > 0 && !(bytes <= b->max_memory);
    int over_work = b->max_work > 0 && !(b->work + work <= b->max_work);
    if (!over_memory && !over_work) {
        b->work += work;
        return FFD_OK;
    }
    char head[256], have[32], limit[32];
    va_list ap;
    va_start(ap, what);
    vsnprintf(head, sizeof head, what, ap);
    va_end(ap);
    if (over_memory) {
        format_bytes(bytes, have, sizeof have);
        format_limit(b->max_memory, limit, sizeof limit);
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: that needs about %s of memory (limit %s; --max-memory or "
                        "--no-limits to raise)",
                        head, have, limit);
    }
    return ffd_fail(err, FFD_ERR_INVALID,
                    "%s: that is about %.2g operations%s (work limit %.2g for the request, about "
                    "%.0f s; --max-memory or --no-limits to raise)",
                    head, work, b->work > 0 ? " more" : "", b->max_work, b->max_work / 1e9);
}
