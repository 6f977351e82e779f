#include "dm_error.h"

#include <stdarg.h>
#include <stdio.h>

void dm_error_clear(dm_error *err)
{
    if (err) {
        err->code = DM_OK;
        err->msg[0] = '\0';
    }
}

int dm_fail(dm_error *err, int code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
        err->code = code;
    }
    return code;
}

const char *dm_status_name(int code)
{
    switch (code) {
    case DM_OK: return "ok";
    case DM_EINVAL: return "bad input";
    case DM_EUNREACHABLE: return "unreachable pose";
    case DM_ENUMERIC: return "numerical failure";
    case DM_EIO: return "i/o error";
    case DM_ENOMEM: return "out of memory";
    case DM_EINTERRUPT: return "interrupted";
    case DM_ETOOBIG: return "refused as too much work";
    default: return "unknown error";
    }
}
