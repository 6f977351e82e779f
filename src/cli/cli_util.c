/* Helpers shared by the deltamap commands. */
#include "cli_impl.h"
#include "dm_predict.h"

#include <cblas.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <errno.h>
#include <string.h>
#include <unistd.h>

int dm_cli_report(const dm_error *err)
{
    fprintf(stderr, "deltamap: %s\n", err->msg);
    return err->code;
}

int dm_cli_report_size(const dm_error *err)
{
    dm_cli_report(err);
    if (dm_size_refused(err))
        fprintf(stderr, "deltamap: --force-long runs it anyway\n");
    return err->code;
}

int dm_cli_usage(const char *cmd, const char *msg, const char *arg)
{
    fprintf(stderr, "deltamap %s: %s%s%s\n(see `deltamap %s --help`)\n", cmd, msg,
            arg ? ": " : "", arg ? arg : "", cmd);
    return EXIT_USAGE;
}

/* "a,b,c" with exactly n finite numbers */
int dm_cli_parse_list(const char *s, double *out, int n)
{
    const char *p = s;
    for (int i = 0; i < n; i++) {
        char *end;
        out[i] = strtod(p, &end);
        if (end == p || !isfinite(out[i]))
            return -1;
        p = end;
        if (i < n - 1) {
            if (*p != ',')
                return -1;
            p++;
        }
    }
    return *p ? -1 : 0;
}

int dm_cli_parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    long v = strtol(s, &end, 10);
    if (end == s || *end || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

int dm_cli_parse_count(const char *s, int lo, int hi, int *out)
{
    char *end;
    double v = strtod(s, &end);
    if (end == s || *end || !(v >= lo && v <= hi) || v != floor(v))
        return -1;
    *out = (int)v;
    return 0;
}


void dm_cli_serial_blas(void)
{
    if (!getenv("OPENBLAS_NUM_THREADS"))
        openblas_set_num_threads(1);
}

int dm_cli_parse_mesh(const char *s, int *na, int *nb)
{
    double v[2];
    if (dm_cli_parse_list(s, v, 2) || v[0] != floor(v[0]) || v[1] != floor(v[1]) || v[0] < 1 ||
        v[1] < 1 || v[0] > 64 || v[1] > 64)
        return -1;
    *na = (int)v[0];
    *nb = (int)v[1];
    return 0;
}

int dm_cli_add_set(const char *cmd, const char **sets, int *nset, const char *arg)
{
    if (*nset == DM_CLI_MAXSET)
        return dm_cli_usage(cmd, "at most 16 --set options", arg);
    sets[(*nset)++] = arg;
    return 0;
}

int dm_cli_load_robot(const char *spec, const char *const *sets, int nset, dm_robot *rb,
                      dm_error *err)
{
    int rc = dm_robot_load(spec, rb, err);
    for (int i = 0; i < nset && !rc; i++)
        rc = dm_robot_set(rb, sets[i], err);
    return rc;
}
