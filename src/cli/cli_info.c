/* deltamap info: what a map store holds, how complete, which shards have
 * work left. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_impl.h"
#include "dm_file.h"
#include "dm_shard.h"
#include "dm_store.h"
#include "dm_sweep.h"
#include "dm_version.h"

#define MAX_SHARDS 1000000

static const char INFO_HELP[] =
    "usage: deltamap info maps/NAME [--shards N] [--repair]\n"
    "\n"
    "What a map store holds, how complete it is and whether every file is what\n"
    "its sweep writes: the metadata and coordinates against the sweep the store\n"
    "records, every chunk against its checksum (each damaged file named; exit 5\n"
    "when one is); which tiles are still to compute and, given --shards N, which\n"
    "of the N shards of a sharded sweep (sweep --shard K/N) still have work.\n"
    "\n"
    "  --repair        rewrite the files derived from the sweep's command (arrays'\n"
    "                  metadata, coordinate and label chunks) that are damaged;\n"
    "                  damaged data chunks are recomputed by the sweep command\n";

static void print_corrupt(void *user, const char *msg)
{
    (void)user;
    printf("  corrupt: %s\n", msg);
}

/* A file that is not what the store's sweep writes (dm_sweep_check_open). */
static void print_damage(void *user, const char *file, const char *problem, int repaired)
{
    (void)user;
    printf("  %s %s: %s\n", repaired ? "repaired:" : "damaged: ", file, problem);
}

/* A string the store records, as printable text: a store of another
 * version or a damaged one may hold anything (or nothing) there. */
static const char *attr_text(json_t *obj, const char *key, char *buf, size_t len)
{
    const char *s = json_string_value(json_object_get(obj, key));
    dm_printable(buf, len, s ? s : "(not recorded)");
    return buf;
}

static void print_dims(const dm_array_spec *a)
{
    printf("(");
    for (int d = 0; d < a->ndim; d++)
        printf("%s%s=%lld", d ? ", " : "", a->dims[d], (long long)a->shape[d]);
    printf(")");
}

/* v[0..n-1] ascending as "0-3,7,9-12" */
static void print_ranges(const long *v, long n)
{
    for (long i = 0; i < n;) {
        long j = i;
        while (j + 1 < n && v[j + 1] == v[j] + 1)
            j++;
        printf(i ? ",%ld" : "%ld", v[i]);
        if (j > i)
            printf(j == i + 1 ? ",%ld" : "-%ld", v[j]);
        i = j + 1;
    }
}

static void print_missing(const dm_sweep_census *tc)
{
    long left = tc->tiles - tc->complete, shown = 0;
    if (!left)
        return;
    printf("missing %ld tile%s (i,j,k):", left, left == 1 ? "" : "s");
    for (long t = 0; t < tc->tiles && shown < 12; t++)
        if (!tc->done[t]) {
            printf(" %ld,%ld,%ld", t / (tc->nt[1] * tc->nt[2]), (t / tc->nt[2]) % tc->nt[1],
                   t % tc->nt[2]);
            shown++;
        }
    printf(left > shown ? " ... and %ld more\n" : "\n", left - shown);
}

/* Which shards of a sweep split n ways still have tiles to compute, and
 * how to rerun just those. */
static int print_shards(const dm_sweep_census *tc, long n)
{
    long *busy = malloc(sizeof(long) * n), nbusy = 0;
    char *work = calloc((size_t)n, 1);
    if (!busy || !work) {
        free(busy);
        free(work);
        return -1;
    }
    for (long t = 0; t < tc->tiles; t++)
        if (!tc->done[t])
            work[dm_shard_of(t, n)] = 1;
    for (long k = 0; k < n; k++)
        if (work[k])
            busy[nbusy++] = k;
    if (!nbusy)
        printf("shards  none of %ld has work left\n", n);
    else {
        printf("shards  %ld of %ld still have work: ", nbusy, n);
        print_ranges(busy, nbusy);
        printf("\nrerun   sbatch --array=");
        print_ranges(busy, nbusy);
        printf(" --export=ALL,SHARDS=%ld tools/slurm/sweep.sbatch SWEEP-OPTIONS\n", n);
        printf("        (or deltamap sweep SWEEP-OPTIONS --shard K/%ld for each K above)\n", n);
    }
    free(busy);
    free(work);
    return 0;
}

static int parse_info(int argc, char **argv, const char **store, long *shards, int *repair)
{
    static const struct option lo[] = {{"shards", 1, 0, 'n'}, {"repair", 0, 0, 'r'},
                                       {"help", 0, 0, 'h'}, {0, 0, 0, 0}};
    int c, n;
    *store = NULL;
    *shards = 0;
    *repair = 0;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "", lo, NULL)) != -1) {
        if (c == 'h') {
            fputs(INFO_HELP, stdout);
            exit(0);
        }
        if (c == 'r') {
            *repair = 1;
            continue;
        }
        if (c != 'n')
            return dm_cli_usage("info", "unknown or incomplete option", argv[optind - 1]);
        if (dm_cli_parse_int(optarg, 1, MAX_SHARDS, &n))
            return dm_cli_usage("info", "--shards takes a whole number 1..1000000", optarg);
        *shards = n;
    }
    if (optind != argc - 1)
        return dm_cli_usage("info", optind < argc ? "one store only" : "which store?",
                            optind < argc ? argv[optind + 1] : NULL);
    *store = argv[optind];
    return 0;
}

/* What the check found of the files around the data, in a line. */
static void print_files(const dm_sweep_check *chk)
{
    long left = chk->problems - chk->repaired;
    if (!chk->verified)
        printf("files   not compared with what this version writes (another version's store, "
               "or no sweep this version makes)%s\n", chk->problems ? "; damage above" : "");
    else if (!chk->problems)
        printf("files   every metadata %s is what the recorded %s writes\n",
               chk->trajectory ? "file" : "and coordinate file", chk->trajectory ? "run" : "sweep");
    else {
        printf("files   %ld not what the recorded %s writes (above)", chk->problems,
               chk->trajectory ? "run" : "sweep");
        if (chk->repaired)
            printf(", %ld rewritten", chk->repaired);
        if (!left)
            printf("\n");
        else if (chk->trajectory)
            printf(": deltamap info --repair rewrites the arrays' metadata; other files need "
                   "the trajectory command again\n");
        else
            printf(": deltamap info --repair, or the sweep command, rewrites those it can\n");
    }
}

/* A trajectory run's store: written once, whole; every chunk was read. */
static int trajectory_summary(dm_sweep_check *chk)
{
    long damaged = chk->problems - chk->repaired;
    printf("\nsamples %lld\n", chk->store.narr ? (long long)chk->store.arr[0].shape[0] : 0LL);
    print_files(chk);
    printf("checksums %s\n", chk->chunk_problems ? "FAILED: run the trajectory command again" : "ok");
    dm_sweep_check_close(chk);
    return damaged ? DM_EIO : 0;
}


/* A sweep's settings from its fingerprint: the mesh, the modes, the
 * standard moves and which model served the points (a store says how it
 * was made; nothing printed where the fingerprint lacks them). */
static void print_sweep_settings(json_t *fp)
{
    json_t *mesh = json_object_get(fp, "mesh"), *modes = json_object_get(fp, "modes");
    json_t *dynamic = json_object_get(fp, "dynamic");
    const char *method = json_string_value(json_object_get(fp, "method"));
    if (!json_is_integer(json_array_get(mesh, 0)) || !json_is_integer(json_array_get(mesh, 1)) ||
        !json_is_integer(modes) || !json_is_boolean(dynamic))
        return;
    printf("model   mesh %d,%d, %d modes, %s, %s\n",
           (int)json_integer_value(json_array_get(mesh, 0)),
           (int)json_integer_value(json_array_get(mesh, 1)), (int)json_integer_value(modes),
           json_is_true(dynamic) ? "standard moves" : "no standard moves",
           method && !strcmp(method, "members") ? "member bases (--method members)"
                                                : "the full model");
}

int dm_cli_info(int argc, char **argv)
{
    const char *path;
    long shards;
    int repair;
    int rc = parse_info(argc, argv, &path, &shards, &repair);
    if (rc)
        return rc;
    dm_sweep_check chk;
    dm_error err;
    printf("store   %s\n", path);
    if (dm_sweep_check_open(path, repair, print_damage, NULL, &chk, &err))
        return dm_cli_report(&err);
    dm_store st = chk.store;
    json_t *dm = json_object_get(st.group_attributes, "deltamap");
    char a1[1024], a2[256];
    printf("robot   %s\n", attr_text(dm, "robot", a1, sizeof a1));
    if (chk.trajectory)
        printf("path    %s (a trajectory run)\n", attr_text(dm, "path", a1, sizeof a1));
    else
        printf("grid    %s (%s)\n", attr_text(dm, "grid", a1, sizeof a1),
               attr_text(dm, "grid_kind", a2, sizeof a2));
    printf("tool    %s\n", attr_text(dm, "tool", a1, sizeof a1));
    if (!chk.trajectory)
        print_sweep_settings(json_object_get(dm, "fingerprint"));
    if (chk.other_version)
        printf("        made by version %s; this is %s: read as its metadata says, not "
               "compared with what this version writes; a sweep does not resume it (--replace "
               "replaces it)\n", chk.made_by, "deltamap " DM_VERSION);
    printf("\narrays\n");
    for (int a = 0; a < st.narr; a++) {
        const dm_array_spec *s = &st.arr[a];
        printf("  %-24s ", s->name);
        print_dims(s);
        printf("  %s\n", attr_text(s->attributes, "units", a1, sizeof a1));
    }
    if (chk.trajectory)
        return trajectory_summary(&chk);
    dm_sweep_census tc;
    if ((rc = dm_sweep_census_take(&st, &tc, print_corrupt, NULL, &err))) {
        dm_sweep_check_close(&chk);
        return dm_cli_report(&err);
    }
    long corrupt = tc.corrupt + chk.chunk_problems;
    printf("\ntiles   %ld of %ld complete (%.1f %%); %ld chunk files missing, %ld corrupt\n",
           tc.complete, tc.tiles, 100.0 * tc.complete / tc.tiles, tc.missing_chunks, tc.corrupt);
    printf("points  %ld ok, %ld near-singular, %ld unreachable, %ld solver failure\n",
           tc.counts[0], tc.counts[2], tc.counts[1], tc.counts[3]);
    print_files(&chk);
    printf("checksums %s\n", corrupt ? "FAILED: re-run the sweep command to recompute" : "ok");
    print_missing(&tc);
    rc = shards ? print_shards(&tc, shards) : 0;
    long temps = dm_file_count_temps(path);
    if (temps)
        printf("temps   %ld temporary files, of writers at work or killed (readers ignore "
               "them; a sweep removes dead writers' ones beside the tiles it recomputes; with "
               "no sweep running: find %s -name '*.tmp.*' -delete)\n",
               temps, path);
    dm_sweep_census_free(&tc);
    long damaged = chk.problems - chk.repaired;
    dm_sweep_check_close(&chk);
    if (rc) {
        fprintf(stderr, "deltamap: out of memory\n");
        return DM_ENOMEM;
    }
    return tc.corrupt || damaged ? DM_EIO : 0;
}
