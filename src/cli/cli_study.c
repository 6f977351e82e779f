/* deltamap study: mean trajectory error over one or two robot parameters
 * (Chen's cross-section studies, figures 5-7). */
#include <assert.h>
#include <getopt.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_impl.h"
#include "dm_study.h"

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
    dm_cli_shared sh; /* --robot, --set, --mesh, --threads, --progress, --json, --out */
    dm_study st;
    dm_robot rb; /* loaded by parse */
} study_opts;

static int parse(int argc, char **argv, study_opts *t)
{
    static const struct option own[] = {
        {"path", 1, 0, 'p'}, {"vary", 1, 0, 'v'}, {"modes", 1, 0, 'k'}, {"dt", 1, 0, 'd'},
        {0, 0, 0, 0}};
    int c, rc;
    memset(t, 0, sizeof *t);
    dm_cli_begin(&t->sh, "study", HELP, own,
                 DM_CLI_ROBOT | DM_CLI_SET | DM_CLI_MESH | DM_CLI_THREADS | DM_CLI_PROGRESS |
                     DM_CLI_JSON | DM_CLI_OUT,
                 DM_CLI_PROGRESS_NONE);
    dm_integ_opts_default(&t->st.opts);
    t->st.opts.reference = 0;
    while ((c = dm_cli_getopt(argc, argv, &t->sh, &rc))) {
        switch (c) {
        case 'p': t->st.path = optarg; break;
        case 'v':
            if (t->st.naxis == DM_STUDY_MAXAXIS ||
                dm_study_axis_parse(optarg, &t->st.axis[t->st.naxis]))
                return dm_cli_usage("study", "--vary takes SECTION.KEY=FROM:TO:N, at most twice", optarg);
            t->st.naxis++;
            break;
        case 'k':
            if (dm_cli_parse_int(optarg, 1, 100000, &t->st.opts.k))
                return dm_cli_usage("study", "--modes takes a whole number >= 1", optarg);
            break;
        case 'd':
            if ((rc = dm_cli_parse_positive("study", "--dt takes a time step > 0 in s", optarg,
                                            &t->st.opts.dt_s)))
                return rc;
            break;
        default: assert(0);
        }
    }
    t->st.opts.na = t->sh.na;
    t->st.opts.nb = t->sh.nb;
    if (rc)
        return rc;
    if (!t->sh.robot || !t->st.path || !t->st.naxis)
        return dm_cli_usage("study", "--robot, --path and --vary are required", NULL);
    return dm_cli_start(&t->sh, &t->st.threads, &t->rb);
}

static void print_table(const study_opts *t, const dm_study_cell *cells, int n1, int n2)
{
    const dm_study_axis *a = &t->st.axis[0], *b = &t->st.axis[1];
    printf("mean error (mm, Chen eq. 27) on path %s\n\n", t->st.path);
    if (t->st.naxis == 1) {
        printf("%14s  %12s  %12s\n", a->key, "mean (mm)", "peak (mm)");
        for (int i = 0; i < n1; i++)
            printf("%14.6g  %12.6f  %12.6f\n", dm_study_value(a, i), 1e3 * cells[i].mean_error_m,
                   1e3 * cells[i].peak_error_m);
    } else {
        printf("%14s |", "rows: cols:");
        printf(" %s\n%14s |", b->key, a->key);
        for (int j = 0; j < n2; j++)
            printf(" %10.6g", dm_study_value(b, j));
        printf("\n");
        for (int i = 0; i < n1; i++) {
            printf("%14.6g |", dm_study_value(a, i));
            for (int j = 0; j < n2; j++)
                printf(" %10.6f", 1e3 * cells[i * n2 + j].mean_error_m);
            printf("\n");
        }
    }
    for (int c = 0; c < n1 * n2; c++)
        if (cells[c].status)
            fprintf(stderr, "deltamap study: combination %d: %s\n", c + 1, cells[c].msg);
}

static json_t *json_num(double v) { return isnan(v) ? json_null() : json_real(v); }

static int write_outputs(const study_opts *t, const dm_study_cell *cells, int n1, int n2)
{
    if (t->sh.json) {
        json_t *o = json_object(), *params = json_array(), *vals = json_array(),
               *mean = json_array(), *peak = json_array();
        for (int a = 0; a < t->st.naxis; a++) {
            json_t *v = json_array();
            json_array_append_new(params, json_string(t->st.axis[a].key));
            for (int i = 0; i < t->st.axis[a].count; i++)
                json_array_append_new(v, json_real(dm_study_value(&t->st.axis[a], i)));
            json_array_append_new(vals, v);
        }
        for (int i = 0; i < n1; i++) {
            json_t *rm = json_array(), *rp = json_array();
            for (int j = 0; j < n2; j++) {
                json_array_append_new(rm, json_num(cells[i * n2 + j].mean_error_m));
                json_array_append_new(rp, json_num(cells[i * n2 + j].peak_error_m));
            }
            json_array_append_new(mean, rm);
            json_array_append_new(peak, rp);
        }
        json_object_set_new(o, "path", json_string(t->st.path));
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
    if (!t->sh.out)
        return 0;
    dm_file_out out;
    dm_error err;
    if (dm_file_out_open(&out, t->sh.out, &err))
        return dm_cli_report(&err);
    fprintf(out.f, "%s,%s,mean_error_m,peak_error_m,status\n", t->st.axis[0].key,
            t->st.naxis > 1 ? t->st.axis[1].key : "-");
    for (int i = 0; i < n1; i++)
        for (int j = 0; j < n2; j++) {
            const dm_study_cell *c = &cells[i * n2 + j];
            fprintf(out.f, "%.9g,%.9g,%.9e,%.9e,%s\n", dm_study_value(&t->st.axis[0], i),
                    t->st.naxis > 1 ? dm_study_value(&t->st.axis[1], j) : 0.0, c->mean_error_m,
                    c->peak_error_m,
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
    int n1 = t.st.axis[0].count, n2 = t.st.naxis > 1 ? t.st.axis[1].count : 1;
    dm_error err;
    dm_study_cell *cells = calloc((size_t)n1 * n2, sizeof *cells);
    if (!cells)
        return dm_cli_report((dm_fail(&err, DM_ENOMEM, "out of memory"), &err));
    dm_cli_progress view;
    t.st.progress = dm_cli_progress_init(&view, "study", t.sh.progress);
    t.st.progress_user = &view;
    rc = dm_study_run(&t.rb, &t.st, cells, &err);
    dm_cli_progress_finish(&view);
    rc = rc ? dm_cli_report(&err) : write_outputs(&t, cells, n1, n2);
    free(cells);
    return rc;
}
