#include "dm_work.h"

#include <stdio.h>

/* Is `need` beyond a limit of this kind (0: not judged)? NaN is. */
static int beyond(double need, double limit)
{
    return limit > 0 && !(need <= limit);
}

int dm_work_check(const char *what, dm_work need, dm_work limit, const char *hint,
                  int force_long, dm_error *err)
{
    int slow = beyond(need.seconds, limit.seconds), big = beyond(need.bytes, limit.bytes),
        many = beyond(need.files, limit.files);
    if (force_long || !(slow || big || many))
        return DM_OK;
    char t[96] = "", m[96] = "", f[96] = "";
    if (slow)
        snprintf(t, sizeof t, "about %.3g hours of work (the limit is %g)", need.seconds / 3600,
                 limit.seconds / 3600);
    if (big)
        snprintf(m, sizeof m, "%s%.3g GB of memory (the limit is %g)", slow ? " and " : "about ",
                 need.bytes / 1e9, limit.bytes / 1e9);
    if (many)
        snprintf(f, sizeof f, "%s%.3g files (the limit is %.3g)", slow || big ? " and " : "about ",
                 need.files, limit.files);
    return dm_fail(err, DM_ETOOBIG, "%s: %s%s%s: %s, or force it", what, t, m, f, hint);
}
