/* Helpers shared by the deltamap commands. */
#include "cli_impl.h"

#include <cblas.h>

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <errno.h>
#include <string.h>
#include <unistd.h>

int dm_cli_report(const dm_error *err)
{
    fprintf(stderr, "deltamap: %s\n", err->msg);
    if (err->code == DM_ETOOBIG)
        fprintf(stderr, "deltamap: --force-long runs it anyway\n");
    return err->code;
}

void dm_cli_deprecated(const char *cmd, const char *old, const char *now)
{
    fprintf(stderr, "deltamap %s: %s is deprecated: it is spelled %s now\n", cmd, old, now);
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

int dm_cli_threads(int requested)
{
    int all_cores = omp_get_max_threads(); /* read first: serial BLAS may set it to 1 */
    dm_cli_serial_blas();
    return requested > 0 ? requested : all_cores;
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

/* ---- progress ------------------------------------------------------------------- */

int dm_cli_parse_progress(const char *cmd, const char *arg, int *mode)
{
    if (!strcmp(arg, "bar"))
        *mode = DM_CLI_PROGRESS_BAR;
    else if (!strcmp(arg, "lines"))
        *mode = DM_CLI_PROGRESS_LINES;
    else if (!strcmp(arg, "none"))
        *mode = DM_CLI_PROGRESS_NONE;
    else
        return dm_cli_usage(cmd, "--progress is bar, lines or none", arg);
    return 0;
}

int dm_cli_progress_default(int otherwise)
{
    return isatty(STDERR_FILENO) ? DM_CLI_PROGRESS_BAR : otherwise;
}

void dm_cli_progress_init(dm_cli_progress *v, const char *cmd, int mode)
{
    memset(v, 0, sizeof *v);
    v->cmd = cmd;
    v->mode = mode;
    v->index = -1;
    v->last = -1e9;
}

void dm_cli_progress_draw(dm_cli_progress *v, int index, const char *stage, long done,
                          long total, const char *unit, const char *rate, double seconds,
                          int final)
{
    if (v->mode == DM_CLI_PROGRESS_NONE)
        return;
    if (index != v->index) { /* a new stage: drawn at once, its clock starts */
        if (v->open)
            dm_cli_progress_finish(v);
        v->index = index;
        v->stage_start = seconds;
    } else if (!final && seconds - v->last < (v->mode == DM_CLI_PROGRESS_BAR ? 0.25 : 10.0)) {
        return;
    }
    v->last = seconds;
    double el = seconds - v->stage_start;
    int pct = total > 0 ? (int)(100.0 * done / total) : 100;
    char what[192], eta[48] = "";
    if (done > 0 && !final) /* the stage's, from its work done so far */
        snprintf(eta, sizeof eta, "  ETA %.0f s", el * (total - done) / done);
    snprintf(what, sizeof what, "%s%s%ld/%ld%s%s%s%s%s", stage ? stage : "", stage ? " " : "",
             done, total, unit ? " " : "", unit ? unit : "", rate ? "  " : "", rate ? rate : "",
             eta);
    if (v->mode == DM_CLI_PROGRESS_BAR) {
        char bar[31];
        for (int i = 0; i < 30; i++)
            bar[i] = i < pct * 30 / 100 ? '#' : '.';
        bar[30] = '\0';
        fprintf(stderr, "\r[%s] %3d%%  %s  (%.0f s)   %s", bar, pct, what, seconds,
                final ? "\n" : "");
        v->open = !final;
    } else {
        fprintf(stderr, "%s: %s (%d%%), %.0f s\n", v->cmd, what, pct, seconds);
    }
    fflush(stderr);
}

void dm_cli_progress_report(void *user, const dm_progress *p)
{
    dm_cli_progress_draw(user, p->index, p->stage, p->done, p->total, p->unit, NULL, p->seconds,
                         p->final);
}

void dm_cli_progress_finish(dm_cli_progress *v)
{
    if (v->open) {
        fputc('\n', stderr);
        fflush(stderr);
        v->open = 0;
    }
}
