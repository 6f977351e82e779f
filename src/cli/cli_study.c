/* deltamap study: mean trajectory error over one or two robot parameters
 * (Chen's cross-section studies, figures 5-7). */
#include <getopt.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_impl.h"
#include "dm_integrate.h"

static const char HELP[] =
    "usage: deltamap study --robot R --path P --vary SECTION.KEY=FROM:TO:N [--vary ...]\n"
    "                      [--modes K] [--dt S] [--mesh NA,NB] [--set SECTION.KEY=V]...\n"
    "                      [--threads N] [--out FILE.csv] [--json]\n"
    "                      [--progress bar|lines|none]\n"
    "\n"
    "Runs `deltamap trajectory` for every value (or pair of values) of one or two\n"
    "robot-file keys and tabulates Chen's mean error (eq. 27) and the peak error.\n"
    "Example, Chen fig. 7: --vary arm.side=0.020:0.030:6 --vary rod.side=0.005:0.010:6\n"
    "\n"
    "  --vary K=A:B:N  N evenly spaced values of robot key K from A to B (SI units)\n"
    "  --modes K       retained modes (default 10), --dt step (default 1e-3 s)\n"
    "  --set K=V       fixed override of a robot key (repeatable)\n"
    "  --threads N     parallel runs (default: OpenMP's, i.e. all cores)\n"
    "  --out FILE      CSV: one row per combination\n"
    "  --progress M    how far the runs are (their time steps), on stderr with an\n"
    "                  ETA: bar (the default when stderr is a terminal), lines, or\n"
    "                  none (the default otherwise)\n";

typedef struct {
    char key[64];
    double from, to;
    int count;
} axis;

typedef struct {
    const char *robot, *path, *out;
    const char *sets[16];
    int nset, naxis, json, threads, progress;
    axis ax[2];
    dm_integ_opts o;
} study_opts;

/* Progress: the runs' time steps, counted by each run's sink and reported
 * through one meter for the cells' threads. A cell's share is the steps of
 * the path with the file's robot (1 when that path cannot be made); a run
 * that ends early, or fails, has its share completed when it ends. */
typedef struct {
    dm_progress_meter *pm;
    long counted, share;
} cell_progress;

typedef struct {
    double mean, peak;
    int status;
    char msg[256];
} cell;

static int parse_axis(const char *s, axis *a)
{
    const char *eq = strchr(s, '=');
    if (!eq || eq - s >= (long)sizeof a->key)
        return -1;
    snprintf(a->key, sizeof a->key, "%.*s", (int)(eq - s), s);
    char tail;
    if (sscanf(eq + 1, "%lf:%lf:%d%c", &a->from, &a->to, &a->count, &tail) != 3 ||
        a->count < 1 || a->count > 1000 || !isfinite(a->from) || !isfinite(a->to))
        return -1;
    return 0;
}

static int parse(int argc, char **argv, study_opts *t)
{
    static const struct option lo[] = {
        {"robot", 1, 0, 'r'}, {"path", 1, 0, 'p'}, {"vary", 1, 0, 'v'}, {"modes", 1, 0, 'k'},
        {"dt", 1, 0, 'd'}, {"mesh", 1, 0, 'm'}, {"set", 1, 0, 's'}, {"threads", 1, 0, 'T'},
        {"out", 1, 0, 'o'}, {"json", 0, 0, 'j'}, {"help", 0, 0, 'h'}, {"progress", 1, 0, 'P'},
        {0, 0, 0, 0}};
    int c;
    memset(t, 0, sizeof *t);
    t->progress = dm_cli_progress_default(DM_CLI_PROGRESS_NONE);
    dm_integ_opts_default(&t->o);
    t->o.reference = 0;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "", lo, NULL)) != -1) {
        switch (c) {
        case 'r': t->robot = optarg; break;
        case 'p': t->path = optarg; break;
        case 'o': t->out = optarg; break;
        case 'j': t->json = 1; break;
        case 'P':
            if (dm_cli_parse_progress("study", optarg, &t->progress))
                return EXIT_USAGE;
            break;
        case 'v':
            if (t->naxis == 2 || parse_axis(optarg, &t->ax[t->naxis]))
                return dm_cli_usage("study", "--vary takes SECTION.KEY=FROM:TO:N, at most twice", optarg);
            t->naxis++;
            break;
        case 's':
            if (dm_cli_add_set("study", t->sets, &t->nset, optarg))
                return EXIT_USAGE;
            break;
        case 'k':
            if (dm_cli_parse_int(optarg, 1, 100000, &t->o.k))
                return dm_cli_usage("study", "--modes takes a whole number >= 1", optarg);
            break;
        case 'T':
            if (dm_cli_parse_int(optarg, 1, 1024, &t->threads))
                return dm_cli_usage("study", "--threads takes a whole number >= 1", optarg);
            break;
        case 'd':
            if (dm_cli_parse_list(optarg, &t->o.dt_s, 1) || !(t->o.dt_s > 0))
                return dm_cli_usage("study", "--dt takes a time step > 0 in s", optarg);
            break;
        case 'm':
            if (dm_cli_parse_mesh(optarg, &t->o.na, &t->o.nb))
                return dm_cli_usage("study", "--mesh takes NA,NB, whole numbers 1..64", optarg);
            break;
        case 'h': fputs(HELP, stdout); exit(0);
        default: return dm_cli_usage("study", "unknown or incomplete option", argv[optind - 1]);
        }
    }
    if (optind < argc)
        return dm_cli_usage("study", "unexpected argument", argv[optind]);
    if (!t->robot || !t->path || !t->naxis)
        return dm_cli_usage("study", "--robot, --path and --vary are required", NULL);
    return 0;
}

static double axis_value(const axis *a, int i)
{
    return a->count == 1 ? a->from : a->from + (a->to - a->from) * i / (a->count - 1);
}

/* The run's sink: every sample after the start ends a step. */
static int count_step(void *user, const dm_integ_sample *s)
{
    cell_progress *c = user;
    if (s->t_s > 0 && c->counted < c->share) {
        c->counted++;
        dm_progress_add(c->pm, 1);
    }
    return 0;
}

static void run_cell(const study_opts *t, const dm_robot *base, int i, int j, cell *out,
                     cell_progress *cp)
{
    dm_robot rb = *base;
    dm_trajectory tr;
    dm_integ_summary sum;
    dm_error err = {0};
    char assign[128];
    int rc = DM_OK;
    for (int a = 0; a < t->naxis && !rc; a++) {
        snprintf(assign, sizeof assign, "%s=%.17g", t->ax[a].key, axis_value(&t->ax[a], a ? j : i));
        rc = dm_robot_set(&rb, assign, &err);
    }
    if (!rc)
        rc = dm_traj_make(t->path, &rb, &tr, &err);
    if (!rc) {
        int steps = cp->pm->fn && cp->share > 1; /* counted by steps */
        rc = dm_integrate_trajectory(&rb, &tr, &t->o, steps ? count_step : NULL, cp, &sum, &err);
        dm_traj_free(&tr);
    }
    dm_progress_add(cp->pm, cp->share - cp->counted);
    out->status = rc;
    snprintf(out->msg, sizeof out->msg, "%.255s", rc ? err.msg : "ok");
    out->mean = rc ? NAN : sum.mean_error_m;
    out->peak = rc ? NAN : sum.peak_error_m;
}

static void print_table(const study_opts *t, const cell *cells, int n1, int n2)
{
    const axis *a = &t->ax[0], *b = &t->ax[1];
    printf("mean error (mm, Chen eq. 27) on path %s\n\n", t->path);
    if (t->naxis == 1) {
        printf("%14s  %12s  %12s\n", a->key, "mean (mm)", "peak (mm)");
        for (int i = 0; i < n1; i++)
            printf("%14.6g  %12.6f  %12.6f\n", axis_value(a, i), 1e3 * cells[i].mean,
                   1e3 * cells[i].peak);
    } else {
        printf("%14s |", "rows: cols:");
        printf(" %s\n%14s |", b->key, a->key);
        for (int j = 0; j < n2; j++)
            printf(" %10.6g", axis_value(b, j));
        printf("\n");
        for (int i = 0; i < n1; i++) {
            printf("%14.6g |", axis_value(a, i));
            for (int j = 0; j < n2; j++)
                printf(" %10.6f", 1e3 * cells[i * n2 + j].mean);
            printf("\n");
        }
    }
    for (int c = 0; c < n1 * n2; c++)
        if (cells[c].status)
            fprintf(stderr, "deltamap study: combination %d: %s\n", c + 1, cells[c].msg);
}

static json_t *json_num(double v) { return isnan(v) ? json_null() : json_real(v); }

static int write_outputs(const study_opts *t, const cell *cells, int n1, int n2)
{
    if (t->json) {
        json_t *o = json_object(), *params = json_array(), *vals = json_array(),
               *mean = json_array(), *peak = json_array();
        for (int a = 0; a < t->naxis; a++) {
            json_t *v = json_array();
            json_array_append_new(params, json_string(t->ax[a].key));
            for (int i = 0; i < t->ax[a].count; i++)
                json_array_append_new(v, json_real(axis_value(&t->ax[a], i)));
            json_array_append_new(vals, v);
        }
        for (int i = 0; i < n1; i++) {
            json_t *rm = json_array(), *rp = json_array();
            for (int j = 0; j < n2; j++) {
                json_array_append_new(rm, json_num(cells[i * n2 + j].mean));
                json_array_append_new(rp, json_num(cells[i * n2 + j].peak));
            }
            json_array_append_new(mean, rm);
            json_array_append_new(peak, rp);
        }
        json_object_set_new(o, "path", json_string(t->path));
        json_object_set_new(o, "parameters", params);
        json_object_set_new(o, "values", vals);
        json_object_set_new(o, "mean_error_m", mean);
        json_object_set_new(o, "peak_error_m", peak);
        json_dumpf(o, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(17));
        putchar('\n');
        json_decref(o);
    } else {
        print_table(t, cells, n1, n2);
    }
    if (!t->out)
        return 0;
    dm_file_out out;
    dm_error err;
    if (dm_file_out_open(&out, t->out, &err))
        return dm_cli_report(&err);
    fprintf(out.f, "%s,%s,mean_error_m,peak_error_m,status\n", t->ax[0].key,
            t->naxis > 1 ? t->ax[1].key : "-");
    for (int i = 0; i < n1; i++)
        for (int j = 0; j < n2; j++) {
            const cell *c = &cells[i * n2 + j];
            fprintf(out.f, "%.9g,%.9g,%.9e,%.9e,%s\n", axis_value(&t->ax[0], i),
                    t->naxis > 1 ? axis_value(&t->ax[1], j) : 0.0, c->mean, c->peak,
                    dm_status_name(c->status));
        }
    if (dm_file_out_commit(&out, &err))
        return dm_cli_report(&err);
    return 0;
}

int dm_cli_study(int argc, char **argv)
{
    study_opts t;
    int rc = parse(argc, argv, &t);
    if (rc)
        return rc;
    t.threads = dm_cli_threads(t.threads);
    dm_robot rb;
    dm_error err;
    if (dm_cli_load_robot(t.robot, t.sets, t.nset, &rb, &err))
        return dm_cli_report(&err);
    for (int a = 0; a < t.naxis; a++) { /* validate each key once, up front */
        dm_robot probe = rb;
        char assign[128];
        snprintf(assign, sizeof assign, "%s=%.17g", t.ax[a].key, t.ax[a].from);
        if (dm_robot_set(&probe, assign, &err))
            return dm_cli_report(&err);
    }
    int n1 = t.ax[0].count, n2 = t.naxis > 1 ? t.ax[1].count : 1;
    cell *cells = calloc((size_t)n1 * n2, sizeof *cells);
    if (!cells)
        return DM_ENOMEM;
    dm_cli_progress view;
    dm_progress_meter pm;
    dm_cli_progress_init(&view, "study", t.progress);
    dm_progress_meter_init(&pm, t.progress ? dm_cli_progress_report : NULL, &view);
    long share = 1;
    dm_trajectory tr;
    if (pm.fn && !dm_traj_make(t.path, &rb, &tr, NULL)) { /* its steps, as the runs take them */
        /* (a run of more than 1e9 steps is refused as hours of work: its share is done then) */
        share = (long)fmin(1e9, fmax(1.0, ceil(tr.duration_s / t.o.dt_s - 1e-9)));
        dm_traj_free(&tr);
    }
    dm_progress_begin(&pm, "trajectory runs", share > 1 ? "steps" : "combinations", share * n1 * n2);
#pragma omp parallel for schedule(dynamic) num_threads(t.threads)
    for (int c = 0; c < n1 * n2; c++) {
        cell_progress cp = {&pm, 0, share};
        run_cell(&t, &rb, c / n2, c % n2, &cells[c], &cp);
    }
    dm_progress_end(&pm);
    dm_cli_progress_finish(&view);
    rc = write_outputs(&t, cells, n1, n2);
    free(cells);
    return rc;
}
