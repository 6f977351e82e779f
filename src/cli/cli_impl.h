/* Private to the command line: helpers shared by the command files. */
#ifndef DM_CLI_IMPL_H
#define DM_CLI_IMPL_H

#include "dm_error.h"

#include "dm_version.h"
#define EXIT_USAGE 1

/* Print "deltamap: MESSAGE" and return the error's code (the exit code);
 * for work refused as too big (DM_ETOOBIG, dm_work.h) also the one option
 * that forces it, --force-long. */
int dm_cli_report(const dm_error *err);

/* An option's old spelling, still accepted: say so on stderr. */
void dm_cli_deprecated(const char *cmd, const char *old, const char *now);

/* Print a usage error for `cmd` and return EXIT_USAGE. */
int dm_cli_usage(const char *cmd, const char *msg, const char *arg);

/* "a,b,c": exactly n finite numbers. */
int dm_cli_parse_list(const char *s, double *out, int n);

/* s as one value > 0 into *out: 0, or the usage error "cmd: msg" (dm_cli_usage). */
int dm_cli_parse_positive(const char *cmd, const char *msg, const char *s, double *out);
int dm_cli_parse_int(const char *s, int lo, int hi, int *out);
/* A whole number lo..hi, written as such or in exponent form (1e6). */
int dm_cli_parse_count(const char *s, int lo, int hi, int *out);

/* "NA,NB": elements per arm and per rod, whole numbers 1..64. */
int dm_cli_parse_mesh(const char *s, int *na, int *nb);

/* Collect one --set SECTION.KEY=VALUE (at most DM_CLI_MAXSET). */
#define DM_CLI_MAXSET 16
int dm_cli_add_set(const char *cmd, const char **sets, int *nset, const char *arg);

/* Load a preset or robot file and apply the --set overrides in order. */
#include "dm_robot.h"
int dm_cli_load_robot(const char *spec, const char *const *sets, int nset, dm_robot *robot,
                      dm_error *err);

/* One --tol NAME=VALUE of the tolerance Monte Carlo into sp (degrees for
 * theta_deg and alpha0_deg): -1 when NAME or VALUE is not one. */
#include "dm_tolerance.h"
int dm_cli_parse_tol(const char *arg, dm_tolerance_spec *sp);

/* The Monte Carlo's options, for `tolerance` and `sweep` alike (cmd and
 * flag name them in messages): --tol NAME=V (>= 0), --spec M (> 0), the
 * seed (a whole number >= 0) and the distribution (uniform or normal).
 * 0, a usage error, or DM_EINVAL naming the flag. */
int dm_cli_tolerance_tol(const char *cmd, const char *arg, dm_tolerance_spec *sp);
int dm_cli_tolerance_spec(const char *cmd, const char *arg, dm_tolerance_spec *sp);
int dm_cli_tolerance_seed(const char *cmd, const char *flag, const char *arg,
                          dm_tolerance_spec *sp);
int dm_cli_tolerance_dist(const char *cmd, const char *flag, const char *arg,
                          dm_tolerance_spec *sp);

/* Output files appear whole or not at all: dm_file_out (dm_file.h). */
#include "dm_file.h"

/* Every command runs BLAS on one thread (unless OPENBLAS_NUM_THREADS
 * says otherwise): our matrices are small (48-900 DOF), where threaded
 * BLAS only adds overhead, and the parallel commands parallelise over
 * poses, steps or fits instead. A serial command calls dm_cli_serial_blas;
 * a parallel one calls dm_cli_threads instead, which returns its thread
 * count (--threads when > 0, else OpenMP's default: OMP_NUM_THREADS or all
 * cores), read before BLAS is made serial: in OpenBLAS's OpenMP build that
 * also sets OpenMP's count to 1. */
void dm_cli_serial_blas(void);
int dm_cli_threads(int requested);

/* ---- progress on stderr (--progress), one drawing for every long command ----
 *
 * A bar redrawn at most 4 times a second, or a line at most every 10 s
 * ("CMD: STAGE DONE/TOTAL UNIT ..."); each stage's start and end show at
 * once, a bar's end with its line's end. The ETA is the stage's: elapsed *
 * (total - done) / done, from the work done so far. */
#include "dm_progress.h"

enum { DM_CLI_PROGRESS_NONE = 0, DM_CLI_PROGRESS_BAR = 1, DM_CLI_PROGRESS_LINES = 2 };

/* --progress bar|lines|none into *mode: 0, or a usage error of cmd. */
int dm_cli_parse_progress(const char *cmd, const char *arg, int *mode);

/* Without --progress: a bar when stderr is a terminal, else `otherwise`
 * (the sweep: lines, for its logs; the other commands: none). */
int dm_cli_progress_default(int otherwise);

typedef struct dm_cli_progress {
    const char *cmd;       /* names the lines: "diagnose: ..." */
    int mode;              /* DM_CLI_PROGRESS_* */
    int index;             /* the stage drawn last (-1: none yet) */
    double last, stage_start; /* seconds of the last drawing and of the stage's start */
    int open;              /* a bar is drawn whose line has not ended */
} dm_cli_progress;

/* Returns the dm_progress_fn drawing a library's reports on v
 * (dm_cli_progress_report), NULL when mode is none. */
dm_progress_fn dm_cli_progress_init(dm_cli_progress *v, const char *cmd, int mode);

/* Draw one report of stage number `index` (a new number: a new stage,
 * drawn at once): "[STAGE ]DONE/TOTAL[ UNIT][  RATE]  ETA E s". stage,
 * unit and rate may be NULL. */
void dm_cli_progress_draw(dm_cli_progress *v, int index, const char *stage, long done,
                          long total, const char *unit, const char *rate, double seconds,
                          int final);

/* A dm_progress_fn drawing a library's reports: user is a dm_cli_progress. */
void dm_cli_progress_report(void *user, const dm_progress *p);

/* End a bar's line left open (the work stopped mid-stage, on an error):
 * call before printing anything else. */
void dm_cli_progress_finish(dm_cli_progress *v);

/* ---- the options every command spells alike ----
 *
 * One table (cli_util.c) of --robot, --set, --mesh, --threads, --progress,
 * --json, --out, --force-long, --at and --help: a command names those it takes,
 * dm_cli_options merges them into its own getopt table, and
 * dm_cli_shared_option handles them (its own switch never sees them). */
#include <getopt.h>

enum {
    DM_CLI_ROBOT = 1 << 0,      /* --robot R */
    DM_CLI_SET = 1 << 1,        /* --set SECTION.KEY=V, repeatable */
    DM_CLI_MESH = 1 << 2,       /* --mesh NA,NB */
    DM_CLI_THREADS = 1 << 3,    /* --threads N, 1..1024 */
    DM_CLI_PROGRESS = 1 << 4,   /* --progress bar|lines|none */
    DM_CLI_JSON = 1 << 5,       /* --json */
    DM_CLI_OUT = 1 << 6,        /* --out FILE */
    DM_CLI_FORCE_LONG = 1 << 7, /* --force-long (dm_work.h) */
    DM_CLI_AT = 1 << 8,         /* --at X,Y,Z in m: the pose (modes, tolerance) */
};

#define DM_CLI_MAXOPT 48
typedef struct dm_cli_shared {
    const char *cmd, *help; /* the command's name (messages) and --help text */
    struct option opts[DM_CLI_MAXOPT]; /* the command's getopt table (dm_cli_begin) */
    const char *robot;
    const char *sets[DM_CLI_MAXSET];
    int nset;
    int na, nb;             /* 0: the robot's */
    int threads;            /* 0: not given */
    int progress;           /* DM_CLI_PROGRESS_*: set the command's default first */
    int json, force_long;
    const char *out;
    double at[3];           /* --at, when have_at */
    int have_at;
} dm_cli_shared;

/* The start of every command's parsing: sh cleared for command cmd (its
 * --help text help), its getopt table the command's `own` (ended by a zero
 * entry) followed by the shared options in `which` and --help, its progress
 * dm_cli_progress_default(progress); and getopt set to read a command line
 * from its start, silently. */
void dm_cli_begin(dm_cli_shared *sh, const char *cmd, const char *help,
                  const struct option *own, unsigned which, int progress);

/* The next of the command's own options (getopt_long over sh->opts, its
 * argument in optarg), the shared ones handled on the way into sh (--help
 * prints sh->help and exits). 0 at the end, *rc then 0 or the usage error
 * to return: a shared option's bad value, an unknown option, an argument
 * that is no option. */
int dm_cli_getopt(int argc, char **argv, dm_cli_shared *sh, int *rc);

/* The start-up every robot command shares once its options are parsed:
 * the threads it runs on (*threads = the --threads choice, dm_cli_threads;
 * threads NULL: a serial command, dm_cli_serial_blas) and sh's robot loaded
 * with its --set overrides. 0, or the error reported (dm_cli_report) and its
 * exit code. */
int dm_cli_start(const dm_cli_shared *sh, int *threads, dm_robot *robot);

/* Commands. */
int dm_cli_trajectory(int argc, char **argv);
int dm_cli_study(int argc, char **argv);
int dm_cli_tolerance(int argc, char **argv);
int dm_cli_sweep(int argc, char **argv);
int dm_cli_info(int argc, char **argv);
int dm_cli_compare(int argc, char **argv);
int dm_cli_diagnose(int argc, char **argv);
int dm_cli_synth(int argc, char **argv);
int dm_cli_plan(int argc, char **argv);

#endif
