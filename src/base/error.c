#include "dm_error.h"

#include <assert.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

void dm_error_clear(dm_error *err)
{
    if (err) {
        err->code = DM_OK;
        err->msg[0] = '\0';
    }
}

/* The length of the well-formed UTF-8 character at s (RFC 3629: no
 * overlong forms, no surrogates, nothing above U+10FFFF), or 0. */
static size_t utf8_char_len(const unsigned char *s)
{
    unsigned char c = s[0];
    size_t n;
    unsigned char lo = 0x80, hi = 0xBF; /* the second byte's range */
    if (c >= 0x20 && c < 0x7F)
        return 1;
    if (c == '\n' || c == '\t')
        return 1;
    if (c >= 0xC2 && c <= 0xDF)
        n = 2;
    else if (c >= 0xE0 && c <= 0xEF) {
        n = 3;
        lo = c == 0xE0 ? 0xA0 : 0x80;
        hi = c == 0xED ? 0x9F : 0xBF;
    } else if (c >= 0xF0 && c <= 0xF4) {
        n = 4;
        lo = c == 0xF0 ? 0x90 : 0x80;
        hi = c == 0xF4 ? 0x8F : 0xBF;
    } else
        return 0;
    if (s[1] < lo || s[1] > hi)
        return 0;
    for (size_t i = 2; i < n; i++)
        if (s[i] < 0x80 || s[i] > 0xBF)
            return 0;
    return n;
}

size_t dm_printable(char *dst, size_t cap, const char *src)
{
    assert(cap >= 1);
    const unsigned char *s = (const unsigned char *)src;
    size_t out = 0;
    while (*s) {
        size_t n = utf8_char_len(s);
        size_t need = n ? n : 4;
        if (out + need >= cap)
            break;
        if (n)
            memcpy(dst + out, s, n);
        else
            snprintf(dst + out, 5, "\\x%02X", *s);
        out += need;
        s += n ? n : 1;
    }
    dst[out] = '\0';
    return out;
}

int dm_fail(dm_error *err, int code, const char *fmt, ...)
{
    if (err) {
        char raw[DM_ERROR_MSG_LEN];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(raw, sizeof raw, fmt, ap); /* fmt's arguments may be err->msg itself */
        va_end(ap);
        dm_printable(err->msg, sizeof err->msg, raw);
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
