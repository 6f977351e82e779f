/* deltamap sweep: workspace maps into a store (deltamap info: cli_info.c). */
#include <assert.h>
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli_impl.h"
#include "dm_shard.h"
#include "dm_store.h"
#include "dm_sweep.h"

static const char SWEEP_HELP[] =
    "usage: deltamap sweep --robot R --grid SPEC --out maps/NAME [--modes K]\n"
    "                      [--mesh NA,NB] [--tile A,B,C] [--threads N] [--no-dynamic]\n"
    "                      [--method auto|members|partial]\n"
    "                      [--amax A] [--tau T] [--replace] [--force-long]\n"
    "                      [--progress bar|lines|none]\n"
    "                      [--shard K/N|slurm|slurm/N] [--set SECTION.KEY=V]...\n"
    "                      [--tolerance-samples N [--tolerance-seed S] [--spec M]\n"
    "                       [--tol NAME=V]... [--tolerance-dist uniform|normal]]\n"
    "\n"
    "Frequencies, static gravity error, stiffness, singularity and the dynamic\n"
    "error of the standard move (docs/model.md §5) on a grid of poses, in parallel,\n"
    "into a Zarr v3 store (docs/store.md). Re-running the same command resumes:\n"
    "finished, checksum-valid tiles are kept. Ctrl-C finishes the tiles in\n"
    "flight and exits with code 7.\n"
    "\n"
    "  --grid SPEC     x=A:B:N,y=A:B:N,z=A:B:N (m) or r=A:B:N,phi=A:B:N,z=A:B:N\n"
    "                  (phi in degrees); one value (z=-0.5) fixes an axis\n"
    "  --modes K       frequencies per point (default 10, at most " DM_MAX_MODES_TEXT ")\n"
    "  --tile A,B,C    points per tile along the three axes (default 16,16,1)\n"
    "  --threads N     worker threads (default: OpenMP's, all cores)\n"
    "  --no-dynamic    skip the standard moves (X, Y, Z)\n"
    "  --method M      the eigen engine, part of the store's settings: members\n"
    "                  (the member bases, built once and shared by the threads:\n"
    "                  statics exact through the joints, the modes proven\n"
    "                  complete by a count of the whole model, within 1e-9 of\n"
    "                  the full model's; the standard moves on the reduced model\n"
    "                  too; 1.1-4.2x faster in every preset, mesh and kernel\n"
    "                  path measured (docs/performance.md);\n"
    "                  refused for a robot they cannot serve, such as geometric\n"
    "                  stiffness), partial (the full model at every point, as\n"
    "                  `deltamap modes`) or auto (default: a store of this very\n"
    "                  sweep keeps the engine it was made with; else members\n"
    "                  where they serve the robot, mesh and modes, partial\n"
    "                  where not; the output's `engine` line says which)\n"
    "  --amax A        standard move acceleration, m/s^2 (default 50)\n"
    "  --tau T         standard move duration, s (default 0.05)\n"
    "  --replace       replace a store of another robot, grid or options (a store\n"
    "                  of this very sweep is always resumed, never replaced;\n"
    "                  --force, its old spelling, still works)\n"
    "  --force-long    run even when the sweep is estimated at more than 24 hours\n"
    "                  of work on its threads, or its store at more than 2e6 files\n"
    "                  (refused before any work otherwise)\n"
    "  --progress M    bar (default on a terminal), lines (default otherwise), none\n"
    "  --shard K/N     compute only shard K (0..N-1) of N: run N such processes, at\n"
    "                  once or not, on any hosts, into one store; together they make\n"
    "                  the store one process makes (docs/cluster.md)\n"
    "  --shard slurm   K and N from a Slurm job array: K = SLURM_ARRAY_TASK_ID -\n"
    "                  SLURM_ARRAY_TASK_MIN, N = SLURM_ARRAY_TASK_COUNT\n"
    "  --shard slurm/N K = SLURM_ARRAY_TASK_ID, N given: for rerunning some tasks of\n"
    "                  an array indexed 0..N-1 (sbatch --array=3,7)\n"
    "\n"
    "Tolerance maps: the Monte Carlo of `deltamap tolerance` at every point, into\n"
    "error_mean_m, error_p95_m, error_max_m, dominant_source and, with --spec,\n"
    "p_exceed_spec. A point's values are those of `deltamap tolerance --at` its\n"
    "position with the same samples, seed, tolerances and --mesh; its settings are\n"
    "the store's: resuming with others is refused.\n"
    "  --tolerance-samples N  samples per point (1..1e7); costs about N times one\n"
    "                  static solve per point, counted in the 24-hour estimate\n"
    "  --tolerance-seed S  seed (a whole number >= 0, default 1)\n"
    "  --spec M        accuracy spec in m (> 0): the map P(|error| > spec)\n"
    "  --tol NAME=V    +- tolerance of a geometry error, as `deltamap tolerance`'s:\n"
    "                  arm_length, rod_length, base_radius, platform_radius (m),\n"
    "                  theta_deg, alpha0_deg (deg); repeatable; default 0\n"
    "  --tolerance-dist D  uniform in +-tol (default) or normal (sigma tol/3)\n";

static volatile sig_atomic_t stop_requested;

/* A file of the store that the resume rewrote (dm_sweep_opts.on_repair). */
static void print_repair(void *user, const char *file, const char *problem, int repaired)
{
    (void)user;
    printf("%s %s: %s\n", repaired ? "repaired" : "damaged ", file, problem);
}

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

typedef struct {
    dm_cli_shared sh;   /* --robot, --set, --mesh, --threads, --progress (bar on a terminal,
                           else lines), --out, --force-long */
    const char *grid, *shard;
    dm_sweep_opts o;
    int tol_options;    /* --tolerance-seed, --spec, --tol or --tolerance-dist given */
} sweep_args;

/* --tolerance-samples N: a whole number 1..1e7 (a usage error when not a
 * number; DM_EINVAL, naming the flag, when out of range). */
static int parse_samples(const char *arg, long *samples)
{
    double v;
    if (dm_cli_parse_list(arg, &v, 1) || v != floor(v) || fabs(v) > 1e12)
        return dm_cli_usage("sweep", "--tolerance-samples takes a whole number", arg);
    if (v < 1 || v > 1e7) {
        fprintf(stderr, "deltamap sweep: --tolerance-samples: must be 1..1e7, got %s\n", arg);
        return DM_EINVAL;
    }
    *samples = (long)v;
    return 0;
}

static int parse_sweep(int argc, char **argv, sweep_args *a)
{
    static const struct option own[] = {
        {"grid", 1, 0, 'g'}, {"modes", 1, 0, 'k'}, {"tile", 1, 0, 't'},
        {"no-dynamic", 0, 0, 'D'}, {"amax", 1, 0, 'A'}, {"tau", 1, 0, 'U'}, {"replace", 0, 0, 'R'},
        {"shard", 1, 0, 'S'}, {"tolerance-samples", 1, 0, 'N'},
        {"tolerance-seed", 1, 0, 'E'}, {"spec", 1, 0, 'P'}, {"tol", 1, 0, 'O'},
        {"tolerance-dist", 1, 0, 'I'}, {"force", 0, 0, 'f'}, {"method", 1, 0, 'M'},
        {0, 0, 0, 0}};
    int rc;
    dm_tolerance_spec *tol = &a->o.tolerance_spec;
    int c;
    double v[3];
    memset(a, 0, sizeof *a);
    dm_sweep_opts_default(&a->o);
    dm_cli_begin(&a->sh, "sweep", SWEEP_HELP, own,
                 DM_CLI_ROBOT | DM_CLI_SET | DM_CLI_MESH | DM_CLI_THREADS | DM_CLI_PROGRESS |
                     DM_CLI_OUT | DM_CLI_FORCE_LONG,
                 DM_CLI_PROGRESS_LINES);
    while ((c = dm_cli_getopt(argc, argv, &a->sh, &rc))) {
        switch (c) {
        case 'g': a->grid = optarg; break;
        case 'S': a->shard = optarg; break;
        case 'f': dm_cli_deprecated("sweep", "--force", "--replace"); /* fall through */
        case 'R': a->o.replace = 1; break;
        case 'D': a->o.dynamic = 0; break;
        case 'M':
            if (!strcmp(optarg, "auto"))
                a->o.members = DM_SWEEP_AUTO;
            else if (!strcmp(optarg, "members") || !strcmp(optarg, "partial"))
                a->o.members = !strcmp(optarg, "members") ? DM_SWEEP_MEMBERS : DM_SWEEP_FULL_MODEL;
            else
                return dm_cli_usage("sweep", "--method is auto, members or partial", optarg);
            break;
        case 'k':
            if (dm_cli_parse_int(optarg, 1, DM_MAX_MODES, &a->o.k))
                return dm_cli_usage("sweep", "--modes takes a whole number 1.." DM_MAX_MODES_TEXT, optarg);
            break;
        case 't':
            if (dm_cli_parse_list(optarg, v, 3) || v[0] < 1 || v[1] < 1 || v[2] < 1 ||
                v[0] != floor(v[0]) || v[1] != floor(v[1]) || v[2] != floor(v[2]) ||
                v[0] * v[1] * v[2] > 1e6)
                return dm_cli_usage("sweep", "--tile takes A,B,C, whole numbers >= 1", optarg);
            for (int d = 0; d < 3; d++)
                a->o.tile[d] = (int)v[d];
            break;
        case 'A':
        case 'U':
            if ((rc = dm_cli_parse_positive("sweep", "--amax and --tau take a value > 0", optarg,
                                            c == 'A' ? &a->o.move.amax_ms2 : &a->o.move.tau_s)))
                return rc;
            break;
        case 'N':
            if ((rc = parse_samples(optarg, &tol->samples)))
                return rc;
            a->o.tolerance = 1;
            break;
        case 'E': /* the Monte Carlo's settings, parsed as `tolerance` parses them */
        case 'P':
        case 'O':
        case 'I':
            rc = c == 'E'   ? dm_cli_tolerance_seed("sweep", "--tolerance-seed", optarg, tol)
                 : c == 'P' ? dm_cli_tolerance_spec("sweep", optarg, tol)
                 : c == 'O' ? dm_cli_tolerance_tol("sweep", optarg, tol)
                            : dm_cli_tolerance_dist("sweep", "--tolerance-dist", optarg, tol);
            if (rc)
                return rc;
            a->tol_options = 1;
            break;
        default: assert(0);
        }
    }
    if (rc)
        return rc;
    if (!a->sh.robot || !a->grid || !a->sh.out)
        return dm_cli_usage("sweep", "--robot, --grid and --out are required", NULL);
    a->o.na = a->sh.na;
    a->o.nb = a->sh.nb;
    a->o.threads = a->sh.threads;
    a->o.force_long = a->sh.force_long;
    if (a->tol_options && !a->o.tolerance)
        return dm_cli_usage("sweep",
                            "--tolerance-seed, --spec, --tol and --tolerance-dist need "
                            "--tolerance-samples",
                            NULL);
    return 0;
}

/* ---- --shard ------------------------------------------------------------- */

#define MAX_SHARDS 1000000

/* "K/N" with 0 <= K < N */
static int parse_fraction(const char *s, int *k, int *n)
{
    const char *slash = strchr(s, '/');
    char kt[32];
    if (!slash || slash == s || (size_t)(slash - s) >= sizeof kt)
        return -1;
    snprintf(kt, sizeof kt, "%.*s", (int)(slash - s), s);
    return dm_cli_parse_int(kt, 0, MAX_SHARDS - 1, k) ||
           dm_cli_parse_int(slash + 1, 1, MAX_SHARDS, n) || *k >= *n ? -1 : 0;
}

/* A Slurm variable as a whole number >= 0. */
static int slurm_var(const char *name, long *v, dm_error *err)
{
    const char *s = getenv(name);
    char *end;
    if (!s || !*s)
        return dm_fail(err, DM_EINVAL,
                       "--shard slurm: %s is not set (run it as a task of a job array: "
                       "sbatch --array=0-7 ...)",
                       name);
    *v = strtol(s, &end, 10);
    if (*end || *v < 0 || *v > MAX_SHARDS)
        return dm_fail(err, DM_EINVAL, "--shard slurm: %s is not a whole number 0..%d: %s",
                       name, MAX_SHARDS, s);
    return DM_OK;
}

/* --shard slurm: K relative to the array's first task, N its task count,
 * for an array of consecutive tasks (a partial rerun, --array=3,7, would
 * renumber the shards: it needs slurm/N). --shard slurm/N: K is the task
 * id itself. */
static int slurm_shard(const char *spec, int *k, int *n, dm_error *err)
{
    long id, lo, hi, count;
    int rc = slurm_var("SLURM_ARRAY_TASK_ID", &id, err);
    if (!rc && spec[5] == '/') {
        if (dm_cli_parse_int(spec + 6, 1, MAX_SHARDS, n))
            return dm_fail(err, DM_EINVAL, "--shard slurm/N: N must be a whole number 1..%d: %s",
                           MAX_SHARDS, spec);
        if (id >= *n)
            return dm_fail(err, DM_EINVAL,
                           "--shard %s: SLURM_ARRAY_TASK_ID=%ld is not a shard 0..%d", spec, id,
                           *n - 1);
        *k = (int)id;
        return DM_OK;
    }
    if (!rc)
        rc = slurm_var("SLURM_ARRAY_TASK_MIN", &lo, err);
    if (!rc)
        rc = slurm_var("SLURM_ARRAY_TASK_COUNT", &count, err);
    if (!rc)
        rc = slurm_var("SLURM_ARRAY_TASK_MAX", &hi, err);
    if (!rc && (hi - lo + 1 != count || id < lo || id > hi || count < 1))
        rc = dm_fail(err, DM_EINVAL,
                     "--shard slurm: the array's tasks %ld..%ld are not %ld consecutive ones "
                     "(a rerun of some tasks? use --shard slurm/N with the sweep's N)",
                     lo, hi, count);
    if (!rc) {
        *k = (int)(id - lo);
        *n = (int)count;
    }
    return rc;
}

/* The sweep's progress (dm_cli_progress_draw): the anchors, then the tiles
 * with the points computed per second. */
static void draw_progress(void *user, const dm_sweep_progress *p)
{
    dm_cli_progress *v = user;
    char rate[48];
    int anchors = p->phase == DM_SWEEP_ANCHORS;
    if (!anchors) {
        double el = p->phase == v->index ? p->seconds - v->stage_start : 0;
        snprintf(rate, sizeof rate, "%.0f points/s",
                 el > 0 ? p->done * p->points_per_tile / el : 0.0);
    }
    dm_cli_progress_draw(v, p->phase, anchors ? "mode-tracking anchors" : NULL, p->done, p->total,
                         anchors ? NULL : "tiles", anchors ? NULL : rate, p->seconds, p->final);
}

/* Resolve --shard into opts (a usage error: 1; bad environment: 2). */
static int resolve_shard(const char *spec, dm_sweep_opts *o)
{
    dm_error err;
    if (!spec)
        return 0;
    if (!strncmp(spec, "slurm", 5) && (!spec[5] || spec[5] == '/'))
        return slurm_shard(spec, &o->shard, &o->shards, &err) ? dm_cli_report(&err) : 0;
    if (parse_fraction(spec, &o->shard, &o->shards))
        return dm_cli_usage("sweep", "--shard takes K/N (0 <= K < N), slurm or slurm/N", spec);
    return 0;
}

int dm_cli_sweep(int argc, char **argv)
{
    sweep_args a;
    int rc = parse_sweep(argc, argv, &a);
    dm_robot rb;
    if (!rc)
        rc = resolve_shard(a.shard, &a.o);
    if (rc || (rc = dm_cli_start(&a.sh, &a.o.threads, &rb)))
        return rc;
    dm_grid grid;
    dm_error err;
    if (dm_grid_parse(a.grid, &grid, &err))
        return dm_cli_report(&err);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    a.o.on_repair = print_repair;
    dm_sweep_stats st;
    dm_cli_progress view;
    dm_cli_progress_init(&view, "sweep", a.sh.progress);
    if (a.sh.progress) {
        a.o.progress = draw_progress;
        a.o.progress_user = &view;
    }
    rc = dm_sweep_run(&rb, &grid, &a.o, a.sh.out, &stop_requested, &st, &err);
    dm_cli_progress_finish(&view);
    if (rc && rc != DM_EINTERRUPT) {
        dm_cli_report(&err);
        if (st.store_refused)
            fprintf(stderr, "deltamap: --replace replaces it; --out names another store\n");
        return rc;
    }
    printf("sweep   %s on %s: %ld points in %ld tiles", rb.name, a.grid, st.points_total,
           st.tiles_total);
    if (a.o.shards > 1)
        printf(", shard %d of %d: %ld tiles", a.o.shard, a.o.shards, st.tiles_mine);
    printf(" (%ld already done, %ld computed) in %.1f s\n", st.tiles_present, st.tiles_computed,
           st.seconds);
    printf("points  computed now: %ld ok, %ld near-singular, %ld unreachable, %ld failed\n",
           st.points_ok, st.points_near_singular, st.points_unreachable, st.points_failed);
    if (st.members)
        printf("engine  members (the member bases)\n");
    else
        printf("engine  partial (the full model)%s%s\n", st.engine_why[0] ? ": " : "",
               st.engine_why);
    if (st.points_full_model)
        printf("members %ld points served by the full model, the member bases could not "
               "(their frequencies are the full model's, their families untracked)\n",
               st.points_full_model);
    if (a.o.tolerance) {
        const dm_tolerance_spec *t = &a.o.tolerance_spec;
        printf("tolerance %ld samples per point, seed %llu", t->samples,
               (unsigned long long)t->seed);
        if (t->spec_m > 0)
            printf(", spec %g m", t->spec_m);
        printf("\n");
    }
    printf("store   %s\n", a.sh.out);
    if (rc)
        return dm_cli_report(&err);
    return 0;
}
