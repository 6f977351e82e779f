/* Helpers shared by the deltamap commands. */
#include "cli_impl.h"

#include <cblas.h>

#include <assert.h>
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

int dm_cli_start(const dm_cli_shared *sh, int *threads, dm_robot *rb)
{
    dm_error err;
    if (threads)
        *threads = dm_cli_threads(sh->threads);
    else
        dm_cli_serial_blas();
    return dm_cli_load_robot(sh->robot, sh->sets, sh->nset, rb, &err) ? dm_cli_report(&err) : 0;
}

int dm_cli_threads(int requested)
{
    int all_cores = omp_get_max_threads(); /* read first: serial BLAS may set it to 1 */
    dm_cli_serial_blas();
    return requested > 0 ? requested : all_cores;
}

int dm_cli_parse_positive(const char *cmd, const char *msg, const char *s, double *out)
{
    double v;
    if (dm_cli_parse_list(s, &v, 1) || !(v > 0))
        return dm_cli_usage(cmd, msg, s);
    *out = v;
    return 0;
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

dm_progress_fn dm_cli_progress_init(dm_cli_progress *v, const char *cmd, int mode)
{
    memset(v, 0, sizeof *v);
    v->cmd = cmd;
    v->mode = mode;
    v->index = -1;
    v->last = -1e9;
    return mode == DM_CLI_PROGRESS_NONE ? NULL : dm_cli_progress_report;
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

/* ---- the shared options ---------------------------------------------------- */

/* Their getopt codes lie above any character a command's own options use. */
enum { OPT_ROBOT = 256, OPT_SET, OPT_MESH, OPT_THREADS, OPT_PROGRESS, OPT_JSON, OPT_OUT,
       OPT_FORCE_LONG, OPT_AT, OPT_HELP };

static const struct {
    struct option opt;
    unsigned flag; /* 0: every command's */
} SHARED[] = {
    {{"robot", 1, 0, OPT_ROBOT}, DM_CLI_ROBOT},
    {{"set", 1, 0, OPT_SET}, DM_CLI_SET},
    {{"mesh", 1, 0, OPT_MESH}, DM_CLI_MESH},
    {{"threads", 1, 0, OPT_THREADS}, DM_CLI_THREADS},
    {{"progress", 1, 0, OPT_PROGRESS}, DM_CLI_PROGRESS},
    {{"json", 0, 0, OPT_JSON}, DM_CLI_JSON},
    {{"out", 1, 0, OPT_OUT}, DM_CLI_OUT},
    {{"force-long", 0, 0, OPT_FORCE_LONG}, DM_CLI_FORCE_LONG},
    {{"at", 1, 0, OPT_AT}, DM_CLI_AT},
    {{"help", 0, 0, OPT_HELP}, 0},
};

void dm_cli_begin(dm_cli_shared *sh, const char *cmd, const char *help,
                  const struct option *own, unsigned which, int progress)
{
    *sh = (dm_cli_shared){.cmd = cmd, .help = help, .progress = dm_cli_progress_default(progress)};
    struct option *opts = sh->opts;
    int n = 0;
    for (; own[n].name; n++) {
        assert(n < DM_CLI_MAXOPT - 1);
        opts[n] = own[n];
    }
    for (size_t i = 0; i < sizeof SHARED / sizeof *SHARED; i++)
        if (!SHARED[i].flag || (which & SHARED[i].flag)) {
            assert(n < DM_CLI_MAXOPT - 1);
            opts[n++] = SHARED[i].opt;
        }
    opts[n] = (struct option){0, 0, 0, 0};
    optind = 1;
    opterr = 0;
}

/* A shared option's code c: 1 when it is one (*rc 0 or a usage error). */
static int shared_option(dm_cli_shared *sh, int c, const char *arg, int *rc)
{
    *rc = 0;
    switch (c) {
    case OPT_ROBOT: sh->robot = arg; return 1;
    case OPT_SET: *rc = dm_cli_add_set(sh->cmd, sh->sets, &sh->nset, arg); return 1;
    case OPT_MESH:
        if (dm_cli_parse_mesh(arg, &sh->na, &sh->nb))
            *rc = dm_cli_usage(sh->cmd, "--mesh takes NA,NB, whole numbers 1..64", arg);
        return 1;
    case OPT_THREADS:
        if (dm_cli_parse_int(arg, 1, 1024, &sh->threads))
            *rc = dm_cli_usage(sh->cmd, "--threads takes a whole number 1..1024", arg);
        return 1;
    case OPT_PROGRESS: *rc = dm_cli_parse_progress(sh->cmd, arg, &sh->progress); return 1;
    case OPT_JSON: sh->json = 1; return 1;
    case OPT_OUT: sh->out = arg; return 1;
    case OPT_FORCE_LONG: sh->force_long = 1; return 1;
    case OPT_AT:
        if (dm_cli_parse_list(arg, sh->at, 3))
            *rc = dm_cli_usage(sh->cmd, "--at takes X,Y,Z in m", arg);
        sh->have_at = 1;
        return 1;
    case OPT_HELP: fputs(sh->help, stdout); exit(0);
    default: return 0;
    }
}

int dm_cli_getopt(int argc, char **argv, dm_cli_shared *sh, int *rc)
{
    int c;
    *rc = 0;
    while ((c = getopt_long(argc, argv, "", sh->opts, NULL)) != -1) {
        if (c == '?' || c == ':') {
            *rc = dm_cli_usage(sh->cmd, "unknown or incomplete option", argv[optind - 1]);
            return 0;
        }
        if (!shared_option(sh, c, optarg, rc))
            return c;
        if (*rc)
            return 0;
    }
    if (optind < argc)
        *rc = dm_cli_usage(sh->cmd, "unexpected argument", argv[optind]);
    return 0;
}
