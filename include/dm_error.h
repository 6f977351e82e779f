/* dm_error — one way to report failure across deltamap.
 *
 * Every library function that can fail returns an int status (DM_OK == 0)
 * and, when given a non-NULL dm_error, writes a message that names what
 * went wrong (file, line and key for input errors). There is no global
 * error state: each caller (and each thread) owns its dm_error. */
#ifndef DM_ERROR_H
#define DM_ERROR_H

#include <stddef.h>

enum dm_status {
    DM_OK = 0,
    DM_EINVAL = 2,       /* bad input: file, option or value */
    DM_EUNREACHABLE = 3, /* pose outside the workspace */
    DM_ENUMERIC = 4,     /* singular matrix, LAPACK/SUNDIALS failure */
    DM_EIO = 5,          /* file system error */
    DM_ENOMEM = 6,
    DM_EINTERRUPT = 7,   /* stopped by a signal; finished work is kept */
    DM_ETOOBIG = 8       /* refused before any work as too long or too large
                            (dm_work_check); forcing it runs it */
};

#define DM_ERROR_MSG_LEN 1024

typedef struct dm_error {
    int code;
    char msg[DM_ERROR_MSG_LEN];
} dm_error;

void dm_error_clear(dm_error *err);

/* Record code and a printf-style message in err (if not NULL); returns code
 * so that `return dm_fail(err, DM_EINVAL, "...")` reads naturally. The
 * message is made printable (dm_printable): it may quote bytes of a
 * damaged or foreign file. */
int dm_fail(dm_error *err, int code, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Copy src into dst (cap bytes, cap >= 1), NUL-terminated, as printable
 * UTF-8: well-formed UTF-8 characters, tabs and newlines are kept, every
 * other byte (a control character, a byte of no or of a truncated
 * UTF-8 sequence) becomes the four characters \xNN. Messages quote input
 * (a damaged store's bytes, a field of a measured file) and must not put
 * raw bytes on a terminal or into a reader that decodes UTF-8. Truncates
 * at a character boundary; returns the length written. */
size_t dm_printable(char *dst, size_t cap, const char *src);

/* Short name of a status code ("bad input", "unreachable pose", ...). */
const char *dm_status_name(int code);

#endif
