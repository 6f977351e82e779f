/* deltamap sweep / deltamap info: workspace maps and what a store holds. */
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli_impl.h"
#include "dm_store.h"
#include "dm_sweep.h"

static const char SWEEP_HELP[] =
    "usage: deltamap sweep --robot R --grid SPEC --out maps/NAME [--modes K]\n"
    "                      [--mesh NA,NB] [--tile A,B,C] [--threads N] [--no-dynamic]\n"
    "                      [--amax A] [--tau T] [--force] [--progress bar|lines|none]\n"
    "                      [--set SECTION.KEY=V]...\n"
    "\n"
    "Frequencies, static gravity error, stiffness, singularity and the dynamic\n"
    "error of the standard move (MODEL.md §5) on a grid of poses, in parallel,\n"
    "into a Zarr v3 store (docs/store.md). Re-running the same command resumes:\n"
    "finished, checksum-valid tiles are kept. Ctrl-C finishes the tiles in\n"
    "flight and exits with code 7.\n"
    "\n"
    "  --grid SPEC     x=A:B:N,y=A:B:N,z=A:B:N (m) or r=A:B:N,phi=A:B:N,z=A:B:N\n"
    "                  (phi in degrees); one value (z=-0.5) fixes an axis\n"
    "  --modes K       frequencies per point (default 10, at most 64)\n"
    "  --tile A,B,C    points per tile along the three axes (default 16,16,1)\n"
    "  --threads N     worker threads (default: OpenMP's, all cores)\n"
    "  --no-dynamic    skip the standard moves (X, Y, Z)\n"
    "  --amax A        standard move acceleration, m/s^2 (default 50)\n"
    "  --tau T         standard move duration, s (default 0.05)\n"
    "  --force         overwrite a store of another robot, grid or options\n"
    "  --progress M    bar (default on a terminal), lines (default otherwise), none\n";

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

typedef struct {
    const char *robot, *grid, *out;
    const char *sets[16];
    int nset;
    dm_sweep_opts o;
} sweep_args;

static int parse_sweep(int argc, char **argv, sweep_args *a)
{
    static const struct option lo[] = {
        {"robot", 1, 0, 'r'}, {"grid", 1, 0, 'g'}, {"out", 1, 0, 'o'}, {"modes", 1, 0, 'k'},
        {"mesh", 1, 0, 'm'}, {"tile", 1, 0, 't'}, {"threads", 1, 0, 'T'},
        {"no-dynamic", 0, 0, 'D'}, {"amax", 1, 0, 'A'}, {"tau", 1, 0, 'U'}, {"force", 0, 0, 'f'},
        {"progress", 1, 0, 'p'}, {"set", 1, 0, 's'}, {"help", 0, 0, 'h'}, {0, 0, 0, 0}};
    int c;
    double v[3];
    memset(a, 0, sizeof *a);
    dm_sweep_opts_default(&a->o);
    a->o.progress = isatty(STDERR_FILENO) ? 1 : 2;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "", lo, NULL)) != -1) {
        switch (c) {
        case 'r': a->robot = optarg; break;
        case 'g': a->grid = optarg; break;
        case 'o': a->out = optarg; break;
        case 'f': a->o.force = 1; break;
        case 'D': a->o.dynamic = 0; break;
        case 's':
            if (dm_cli_add_set("sweep", a->sets, &a->nset, optarg))
                return EXIT_USAGE;
            break;
        case 'k':
            if (dm_cli_parse_int(optarg, 1, 64, &a->o.k))
                return dm_cli_usage("sweep", "--modes takes a whole number 1..64", optarg);
            break;
        case 'T':
            if (dm_cli_parse_int(optarg, 1, 1024, &a->o.threads))
                return dm_cli_usage("sweep", "--threads takes a whole number >= 1", optarg);
            break;
        case 'm':
            if (dm_cli_parse_mesh(optarg, &a->o.na, &a->o.nb))
                return dm_cli_usage("sweep", "--mesh takes NA,NB, whole numbers 1..64", optarg);
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
            if (dm_cli_parse_list(optarg, v, 1) || !(v[0] > 0))
                return dm_cli_usage("sweep", "--amax and --tau take a value > 0", optarg);
            *(c == 'A' ? &a->o.move.amax_ms2 : &a->o.move.tau_s) = v[0];
            break;
        case 'p':
            if (!strcmp(optarg, "bar"))
                a->o.progress = 1;
            else if (!strcmp(optarg, "lines"))
                a->o.progress = 2;
            else if (!strcmp(optarg, "none"))
                a->o.progress = 0;
            else
                return dm_cli_usage("sweep", "--progress is bar, lines or none", optarg);
            break;
        case 'h': fputs(SWEEP_HELP, stdout); exit(0);
        default: return dm_cli_usage("sweep", "unknown or incomplete option", argv[optind - 1]);
        }
    }
    if (optind < argc)
        return dm_cli_usage("sweep", "unexpected argument", argv[optind]);
    if (!a->robot || !a->grid || !a->out)
        return dm_cli_usage("sweep", "--robot, --grid and --out are required", NULL);
    return 0;
}

int dm_cli_sweep(int argc, char **argv)
{
    sweep_args a;
    int rc = parse_sweep(argc, argv, &a);
    if (rc)
        return rc;
    dm_robot rb;
    dm_grid grid;
    dm_error err;
    if (dm_cli_load_robot(a.robot, a.sets, a.nset, &rb, &err))
        return dm_cli_report(&err);
    if (dm_grid_parse(a.grid, &grid, &err))
        return dm_cli_report(&err);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    dm_sweep_stats st;
    rc = dm_sweep_run(&rb, &grid, &a.o, a.out, &stop_requested, &st, &err);
    if (rc && rc != DM_EINTERRUPT)
        return dm_cli_report(&err);
    printf("sweep   %s on %s: %ld points in %ld tiles (%ld already done, %ld computed) in %.1f s\n",
           rb.name, a.grid, st.points_total, st.tiles_total, st.tiles_present, st.tiles_computed,
           st.seconds);
    printf("points  computed now: %ld ok, %ld near-singular, %ld unreachable, %ld failed\n",
           st.points_ok, st.points_near_singular, st.points_unreachable, st.points_failed);
    printf("store   %s\n", a.out);
    if (rc)
        return dm_cli_report(&err);
    return 0;
}

/* ---- info ------------------------------------------------------------------ */

static void print_dims(const dm_array_spec *a)
{
    printf("(");
    for (int d = 0; d < a->ndim; d++)
        printf("%s%s=%lld", d ? ", " : "", a->dims[d], (long long)a->shape[d]);
    printf(")");
}

int dm_cli_info(int argc, char **argv)
{
    if (argc != 2 || !strcmp(argv[1], "--help")) {
        printf("usage: deltamap info maps/NAME\n\nWhat a map store holds, how complete it is "
               "and whether its checksums hold.\n");
        return argc == 2 ? 0 : EXIT_USAGE;
    }
    dm_store st;
    dm_error err;
    if (dm_store_read_metadata(argv[1], &st, &err))
        return dm_cli_report(&err);
    json_t *dm = json_object_get(st.group_attributes, "deltamap");
    printf("store   %s (Zarr v3 group)\n", argv[1]);
    printf("robot   %s\n", json_string_value(json_object_get(dm, "robot")));
    printf("grid    %s (%s)\n", json_string_value(json_object_get(dm, "grid")),
           json_string_value(json_object_get(dm, "grid_kind")));
    printf("tool    %s\n\narrays\n", json_string_value(json_object_get(dm, "tool")));
    int status = -1;
    for (int a = 0; a < st.narr; a++) {
        const dm_array_spec *s = &st.arr[a];
        printf("  %-24s ", s->name);
        print_dims(s);
        printf("  %s\n", json_string_value(json_object_get(s->attributes, "units")));
        if (!strcmp(s->name, "status"))
            status = a;
    }
    if (status < 0 || st.arr[status].ndim < 3 || st.arr[status].dtype != DM_DTYPE_UINT8) {
        dm_store_release(&st);
        fprintf(stderr, "deltamap: %s: no status array (uint8, x, y, z): not a map store\n",
                argv[1]);
        return DM_EINVAL;
    }
    /* tiles: the chunk grid of the status array; data arrays share it */
    const dm_array_spec *sa = &st.arr[status];
    long nt[3], tiles = 1, complete = 0, corrupt = 0, missing_chunks = 0, counts[256] = {0};
    for (int d = 0; d < 3; d++) {
        nt[d] = (sa->shape[d] + sa->chunk[d] - 1) / sa->chunk[d];
        tiles *= nt[d];
    }
    size_t maxbytes = 0;
    for (int a = 0; a < st.narr; a++)
        if (dm_store_chunk_elems(&st, a) * dm_dtype_size(st.arr[a].dtype) > maxbytes)
            maxbytes = dm_store_chunk_elems(&st, a) * dm_dtype_size(st.arr[a].dtype);
    unsigned char *buf = malloc(maxbytes);
    if (!buf) {
        dm_store_release(&st);
        fprintf(stderr, "deltamap: %s: out of memory for a chunk of %zu bytes\n", argv[1], maxbytes);
        return DM_ENOMEM;
    }
    for (long t = 0; t < tiles; t++) {
        int64_t tc[4] = {t / (nt[1] * nt[2]), (t / nt[2]) % nt[1], t % nt[2], 0};
        int ok = 1;
        for (int a = 0; a < st.narr; a++) {
            if (st.arr[a].ndim < 3)
                continue; /* coordinates */
            int missing;
            if (dm_store_read_chunk(&st, a, tc, buf, &missing, &err)) {
                ok = 0;
                missing ? missing_chunks++ : corrupt++;
                if (!missing)
                    printf("  corrupt: %s\n", err.msg);
            } else if (a == status) {
                for (int d = 0; d < 3; d++)
                    if (tc[d] * sa->chunk[d] >= sa->shape[d])
                        ok = 0;
                for (int i0 = 0; i0 < sa->chunk[0]; i0++)
                    for (int i1 = 0; i1 < sa->chunk[1]; i1++)
                        for (int i2 = 0; i2 < sa->chunk[2]; i2++)
                            if (tc[0] * sa->chunk[0] + i0 < sa->shape[0] &&
                                tc[1] * sa->chunk[1] + i1 < sa->shape[1] &&
                                tc[2] * sa->chunk[2] + i2 < sa->shape[2])
                                counts[buf[((size_t)i0 * sa->chunk[1] + i1) * sa->chunk[2] + i2]]++;
            }
        }
        complete += ok;
    }
    free(buf);
    printf("\ntiles   %ld of %ld complete (%.1f %%); %ld chunk files missing, %ld corrupt\n",
           complete, tiles, 100.0 * complete / tiles, missing_chunks, corrupt);
    printf("points  %ld ok, %ld near-singular, %ld unreachable, %ld solver failure\n", counts[0],
           counts[2], counts[1], counts[3]);
    printf("checksums %s\n", corrupt ? "FAILED: re-run the sweep command to recompute" : "ok");
    dm_store_release(&st);
    return corrupt ? DM_EIO : 0;
}
