/* core — status strings and error messages. */
#include "core.h"

#include <stdio.h>

const char *ffd_status_string(ffd_status status)
{
    switch (status) {
    case FFD_OK: return "ok";
    case FFD_ERR_IO: return "i/o error";
    case FFD_ERR_PARSE: return "parse error";
    case FFD_ERR_INVALID: return "invalid argument";
    case FFD_ERR_RANGE: return "index out of range";
    case FFD_ERR_NONFINITE: return "non-finite number";
    case FFD_ERR_NOMEM: return "out of memory";
    case FFD_ERR_NUMERIC: return "numerical failure";
    case FFD_ERR_UNSUPPORTED: return "unsupported";
    }
    return "unknown status";
}

ffd_status ffd_fail(ffd_error *err, ffd_status status, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
    }
    return status;
}
