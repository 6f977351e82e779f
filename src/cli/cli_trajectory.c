/* deltamap trajectory: 6-D elastic error of the platform along a path. */
#include <assert.h>
#include <getopt.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_impl.h"
#include "cli_shapes.h"
#include "dm_budget.h"
#include "dm_integrate.h"
#include "dm_trajstore.h"

static const char HELP[] =
    "usage: deltamap trajectory --robot R --path P [--modes K|all] [--dt S]\n"
    "                           [--integrator cvode|closed-form|full] [--rtol X] [--atol X]\n"
    "                           [--no-quasi-static] [--from-rest] [--no-reference]\n"
    "                           [--mesh NA,NB] [--tool X,Y,Z] [--load FX,FY,FZ]\n"
    "                           [--set SECTION.KEY=V]... [--force-long] [--rigid] [--no-budget]\n"
    "                           [--axes-rotation DEG[,DEG...]] [--threads N]\n"
    "                           [--method auto|partial]\n"
    "                           [--out FILE.csv] [--json]\n"
    "                           [--vtk DIR [--vtk-every N] [--vtk-magnify F]]\n"
    "\n"
    "Normal-coordinate integration along a trajectory (docs/model.md §4): the\n"
    "robot is frozen per step, the modal equations are integrated with SUNDIALS\n"
    "CVODE.\n"
    "\n"
    "  --robot R        preset or robot file\n"
    "  --path P         chen2018 | zheng2017 | han2011 | han2011-vertical |\n"
    "                   han2011-vertical-printed (leaves the workspace), or\n"
    "                   circle:centre=X,Y,Z;radius=R;rate=W;duration=T[;plane=xy|yz|xz]\n"
    "                   p2p:from=X,Y,Z;to=X,Y,Z;duration=T[;law=cycloidal|trapezoidal|poly7|bangbang]\n"
    "                      [;dwell=S]  (then S seconds still: the ring-down)\n"
    "                   pick:duration=T[;start=X,Y,Z][;law=..][;axis=x|y][;dwell=S]\n"
    "                      (25 mm up, 305 across, 25 down)\n"
    "                   FILE.csv with columns t,x,y,z (m, s)\n"
    "  --modes K        retained modes (default 10); 'all' keeps every mode\n"
    "  --dt S           frozen-step length in s (default 1e-3)\n"
    "  --integrator M   cvode (default), closed-form (exact per step, cross-check) or\n"
    "                   full (full model with CVODE, validation)\n"
    "  --rtol, --atol   CVODE tolerances (default 1e-8, 1e-14 in sqrt(kg)*m)\n"
    "  --no-quasi-static  leave out the static response of the dropped modes (on by\n"
    "                   default: 10 modes then give the all-modes answer for the slow\n"
    "                   part; --quasi-static is accepted and is the default)\n"
    "  --from-rest      start undeformed (default: static equilibrium under gravity)\n"
    "  --no-reference   skip the all-modes run that measures the truncation error\n"
    "                   (for an undamped robot both runs of that figure get a light\n"
    "                   damping, beta = 1e-4 s, and the output says so)\n"
    "  --threads N      threads (default: all cores): the all-modes reference's\n"
    "                   eigen solves of the next steps run beside the current ones;\n"
    "                   without it, one thread solves each step's modes while\n"
    "                   another integrates the step before; the result does not\n"
    "                   depend on N\n"
    "  --method M       each step's eigen engine: auto (default) takes the modes\n"
    "                   from member bases built once for the run where they serve\n"
    "                   the robot (not with joint clearance or geometric stiffness)\n"
    "                   and it has at least 25 steps to repay them, else the full\n"
    "                   model; partial: the full model at every step. The two agree\n"
    "                   to the solvers' accuracy (docs/model-choices.md)\n"
    "  --mesh NA,NB     elements per arm and rod (default: the robot file's)\n"
    "  --set K=V        override a robot-file key (repeatable)\n"
    "  --load FX,FY,FZ  constant external force at the platform centre, N (also in\n"
    "                   the initial static equilibrium; --force FX,FY,FZ, its old\n"
    "                   spelling, still works)\n"
    "  --tool X,Y,Z     tool point offset from the platform centre in m (default 0)\n"
    "  --out FILE       per-step CSV: t, pose, six error components, |error|, tool\n"
    "                   error, first three frequencies, coupling index log10 det K\n"
    "                   (Zheng eq. 33, of the step's frozen K) and its change against the\n"
    "                   nominal robot (every [effects] off) at the same pose and mesh; a\n"
    "                   name ending in .zarr writes the same as a Zarr v3 group (the map\n"
    "                   store's format)\n"
    "  --force-long     run even when the estimated work exceeds 4 hours (refused\n"
    "                   before it starts otherwise)\n"
    "  --vtk DIR        the deformed robot for ParaView (docs/shapes.md): every N-th\n"
    "                   sample (--vtk-every, default 10) as DIR/frame_NNNNNN.vtu with\n"
    "                   its nodes moved by F times the elastic displacement\n"
    "                   (--vtk-magnify, default 100), and DIR/trajectory.pvd, the\n"
    "                   time series; DIR must exist\n"
    "  --json           summary as JSON: mean_error_m, peak_error_m, truncation_error,\n"
    "                   member_steps (steps whose modes the member bases gave),\n"
    "                   coupling_index_log10 and coupling_index_change_log10 {mean, min, max},\n"
    "                   budget\n"
    "\n"
    "Error budget (Zheng §5): when the robot's [effects] hold geometry errors or\n"
    "clearances, the run also gives the platform error of each source alone\n"
    "(geometry errors, clearance, flexibility), their simple sum, the combined\n"
    "model and combined - sum (CSV columns geometry_*, clearance_*,\n"
    "flexibility_*, sum_*, combined_*, coupling_*; the summary's means and peaks).\n"
    "  --rigid          kinematic sources only: no flexible model (flexibility alone\n"
    "                   is zero, combined is the rigid closure); implies the budget\n"
    "  --no-budget      the combined run only (its CSV columns as without errors)\n"
    "  --axes-rotation B[,B...]  also report the mean |error| components along the\n"
    "                   base axes rotated about z by each angle B (deg, up to 8;\n"
    "                   Zheng fig. 15); not with --rigid\n";

typedef struct {
    dm_cli_shared sh; /* --robot, --set, --mesh, --threads, --json, --out, --force-long */
    const char *path;
    int rigid, no_budget;
    dm_integ_opts o;
    dm_cli_traj_vtk vtk;
    dm_robot rb; /* loaded by parse */
} traj_opts;

static int parse(int argc, char **argv, traj_opts *t)
{
    static const struct option own[] = {
        {"path", 1, 0, 'p'}, {"modes", 1, 0, 'k'}, {"dt", 1, 0, 'd'},
        {"integrator", 1, 0, 'i'}, {"rtol", 1, 0, 'R'}, {"atol", 1, 0, 'A'},
        {"quasi-static", 0, 0, 'q'}, {"no-quasi-static", 0, 0, 'Q'}, {"from-rest", 0, 0, 'z'},
        {"no-reference", 0, 0, 'n'}, {"tool", 1, 0, 't'}, {"load", 1, 0, 'F'},
        {"rigid", 0, 0, 'G'}, {"no-budget", 0, 0, 'B'}, {"axes-rotation", 1, 0, 'X'},
        {"vtk", 1, 0, 'V'}, {"vtk-every", 1, 0, 'E'}, {"vtk-magnify", 1, 0, 'M'},
        {"force", 1, 0, 'f'}, {"method", 1, 0, 'e'}, {0, 0, 0, 0}};
    int c, rc;
    memset(t, 0, sizeof *t);
    dm_cli_begin(&t->sh, "trajectory", HELP, own,
                 DM_CLI_ROBOT | DM_CLI_SET | DM_CLI_MESH | DM_CLI_THREADS | DM_CLI_JSON |
                     DM_CLI_OUT | DM_CLI_FORCE_LONG,
                 DM_CLI_PROGRESS_NONE);
    dm_integ_opts_default(&t->o);
    t->vtk.every = 10;
    t->vtk.magnify = 100;
    while ((c = dm_cli_getopt(argc, argv, &t->sh, &rc))) {
        switch (c) {
        case 'p': t->path = optarg; break;
        case 'q': t->o.quasi_static = 1; break;
        case 'Q': t->o.quasi_static = 0; break;
        case 'G': t->rigid = 1; break;
        case 'B': t->no_budget = 1; break;
        case 'X': {
            const char *p = optarg;
            t->o.naxes = 0;
            for (;;) {
                char *end;
                double b = strtod(p, &end);
                if (end == p || !isfinite(b) || t->o.naxes == DM_INTEG_MAXAXES || (*end && *end != ','))
                    return dm_cli_usage("trajectory", "--axes-rotation takes up to 8 angles in degrees, B[,B...]", optarg);
                t->o.axes_rotation_rad[t->o.naxes++] = b * M_PI / 180;
                if (!*end)
                    break;
                p = end + 1;
            }
            break;
        }
        case 'z': t->o.from_rest = 1; break;
        case 'n': t->o.reference = 0; break;
        case 'k':
            if (!strcmp(optarg, "all"))
                t->o.k = 0;
            else if (dm_cli_parse_int(optarg, 1, 100000, &t->o.k))
                return dm_cli_usage("trajectory", "--modes takes a whole number >= 1 or 'all'", optarg);
            break;
        case 'd':
            if ((rc = dm_cli_parse_positive("trajectory", "--dt takes a time step > 0 in s", optarg,
                                            &t->o.dt_s)))
                return rc;
            break;
        case 'R':
        case 'A':
            if ((rc = dm_cli_parse_positive("trajectory", "tolerances must be > 0", optarg,
                                            c == 'R' ? &t->o.rtol : &t->o.atol)))
                return rc;
            break;
        case 'i':
            if (!strcmp(optarg, "cvode"))
                t->o.method = DM_ODE_CVODE;
            else if (!strcmp(optarg, "closed-form"))
                t->o.method = DM_ODE_CLOSED_FORM;
            else if (!strcmp(optarg, "full"))
                t->o.method = DM_ODE_FULL;
            else
                return dm_cli_usage("trajectory", "--integrator is cvode, closed-form or full", optarg);
            break;
        case 'e':
            if (strcmp(optarg, "auto") && strcmp(optarg, "partial"))
                return dm_cli_usage("trajectory", "--method is auto or partial", optarg);
            t->o.full_model = !strcmp(optarg, "partial");
            break;
        case 'f': dm_cli_deprecated("trajectory", "--force FX,FY,FZ", "--load"); /* fall through */
        case 'F':
            if (dm_cli_parse_list(optarg, t->o.force_n, 3))
                return dm_cli_usage("trajectory", "--load takes FX,FY,FZ in N", optarg);
            break;
        case 't':
            if (dm_cli_parse_list(optarg, t->o.tool_m, 3))
                return dm_cli_usage("trajectory", "--tool takes X,Y,Z in m", optarg);
            break;
        case 'V': t->vtk.dir = optarg; break;
        case 'E':
            if (dm_cli_parse_int(optarg, 1, 1000000000, &t->vtk.every))
                return dm_cli_usage("trajectory", "--vtk-every takes a whole number >= 1", optarg);
            break;
        case 'M':
            if (dm_cli_parse_list(optarg, &t->vtk.magnify, 1))
                return dm_cli_usage("trajectory", "--vtk-magnify takes a number", optarg);
            break;
        default: assert(0);
        }
    }
    if (rc)
        return rc;
    if (!t->sh.robot || !t->path)
        return dm_cli_usage("trajectory", "--robot and --path are required", NULL);
    t->o.na = t->sh.na;
    t->o.nb = t->sh.nb;
    t->o.force_long = t->sh.force_long;
    if (t->o.method == DM_ODE_FULL)
        t->o.k = 0;
    if (t->rigid && t->o.naxes)
        return dm_cli_usage("trajectory", "--axes-rotation reports the flexible run: not with --rigid", NULL);
    if (t->rigid && t->no_budget)
        return dm_cli_usage("trajectory", "--rigid is a budget run: it cannot go with --no-budget", NULL);
    return dm_cli_start(&t->sh, &t->o.threads, &t->rb);
}

/* What the sinks write to: CSV rows or kept samples, and the coupling
 * index's change against the nominal robot, tracked over the samples. */
typedef struct {
    FILE *csv;
    dm_trajstore_samples *kept;
    dm_cli_traj_vtk *vtk; /* --vtk: its frames (failures: failed, err) */
    dm_coupling_change cc;
    int failed;   /* the coupling change's error (in err) stopped the run */
    dm_error err;
} run_out;

/* The next sample's coupling change; on failure the run stops (the sink
 * returns non-zero) and the error is kept. */
static int next_change(run_out *ro, const dm_integ_sample *s, double *change)
{
    ro->failed = dm_coupling_change_next(&ro->cc, s, change, &ro->err);
    return ro->failed;
}

/* The columns every trajectory CSV row has (without the newline). */
static void csv_base(FILE *f, const dm_integ_sample *s, double change)
{
    const double *e = s->error;
    fprintf(f, "%.9g,%.9g,%.9g,%.9g", s->t_s, s->P_m[0], s->P_m[1], s->P_m[2]);
    for (int k = 0; k < 6; k++)
        fprintf(f, ",%.9e", e[k]);
    fprintf(f, ",%.9e", sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]));
    for (int k = 0; k < 3; k++)
        fprintf(f, ",%.9e", s->tool_error_m[k]);
    for (int j = 0; j < 3; j++)
        if (j < s->nfreq)
            fprintf(f, ",%.9g", s->freq_hz[j]);
        else
            fprintf(f, ",");
    if (isnan(s->coupling_index_log10))
        fprintf(f, ",");
    else
        fprintf(f, ",%.12g", s->coupling_index_log10);
    if (isnan(change))
        fprintf(f, ",");
    else
        fprintf(f, ",%.12g", change);
}


static int run_sample(void *user, const dm_integ_sample *s)
{
    run_out *ro = user;
    double change;
    if (next_change(ro, s, &change))
        return 1;
    if (ro->vtk && (ro->failed = dm_cli_traj_vtk_frame(ro->vtk, s, &ro->err)))
        return 1;
    if (ro->kept)
        return dm_trajstore_keep(ro->kept, s, change);
    if (!ro->csv)
        return 0;
    csv_base(ro->csv, s, change);
    fputc('\n', ro->csv);
    return ferror(ro->csv) ? 1 : 0;
}

static const char BUDGET_COLUMNS[] =
    ",geometry_dx_m,geometry_dy_m,geometry_dz_m,geometry_m"
    ",clearance_dx_m,clearance_dy_m,clearance_dz_m,clearance_m"
    ",flexibility_dx_m,flexibility_dy_m,flexibility_dz_m,flexibility_m"
    ",sum_dx_m,sum_dy_m,sum_dz_m,sum_m"
    ",combined_dx_m,combined_dy_m,combined_dz_m,combined_m"
    ",coupling_dx_m,coupling_dy_m,coupling_dz_m,coupling_m";

static void csv_vec(FILE *f, const double v[3])
{
    fprintf(f, ",%.9e,%.9e,%.9e,%.9e", v[0], v[1], v[2], sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]));
}

static int csv_budget_row(FILE *f, const dm_budget_sample *b, double change)
{
    csv_base(f, &b->run, change);
    for (int src = 0; src < DM_BUDGET_NSRC; src++)
        csv_vec(f, b->alone_m[src]);
    csv_vec(f, b->sum_m);
    csv_vec(f, b->combined_m);
    csv_vec(f, b->coupling_m);
    fputc('\n', f);
    return ferror(f) ? 1 : 0;
}

/* ---- the map store's format (--out NAME.zarr) ---------------------------- */

/* A budget run's sink: CSV rows, or the combined run's samples for Zarr. */
static int budget_sample(void *user, const dm_budget_sample *b)
{
    run_out *ro = user;
    double change;
    if (next_change(ro, &b->run, &change))
        return 1;
    if (ro->vtk && (ro->failed = dm_cli_traj_vtk_frame(ro->vtk, &b->run, &ro->err)))
        return 1;
    if (ro->csv)
        return csv_budget_row(ro->csv, b, change);
    return ro->kept ? dm_trajstore_keep(ro->kept, &b->run, change) : 0;
}

static int ends_with(const char *s, const char *tail)
{
    size_t n = strlen(s), m = strlen(tail);
    return n >= m && !strcmp(s + n - m, tail);
}

static json_t *budget_json(const dm_budget_summary *b)
{
    json_t *o = json_object();
    for (int src = 0; src < DM_BUDGET_NSRC; src++)
        json_object_set_new(o, dm_budget_source_name(src),
                            json_pack("{s:f, s:f}", "mean_m", b->mean_alone_m[src], "peak_m",
                                      b->peak_alone_m[src]));
    json_object_set_new(o, "sum", json_pack("{s:f, s:f}", "mean_m", b->mean_sum_m, "peak_m", b->peak_sum_m));
    json_object_set_new(o, "combined", json_pack("{s:f, s:f}", "mean_m", b->mean_combined_m,
                                                 "peak_m", b->peak_combined_m));
    json_object_set_new(o, "coupling", json_pack("{s:f, s:f}", "mean_m", b->mean_coupling_m,
                                                 "peak_m", b->peak_coupling_m));
    json_object_set_new(o, "flexibility_on", json_boolean(b->flexibility));
    return o;
}

static void print_budget(const dm_budget_summary *b)
{
    printf("\nerror budget (Zheng §5; Chen eq. 27 mean and peak of |e|, m)\n");
    printf("  %-26s %14s %14s\n", "source", "mean", "peak");
    for (int src = 0; src < DM_BUDGET_NSRC; src++)
        printf("  %-26s %14.6e %14.6e\n", dm_budget_source_name(src), b->mean_alone_m[src],
               b->peak_alone_m[src]);
    printf("  %-26s %14.6e %14.6e\n", "sum (b)", b->mean_sum_m, b->peak_sum_m);
    printf("  %-26s %14.6e %14.6e\n", "combined (c)", b->mean_combined_m, b->peak_combined_m);
    printf("  %-26s %14.6e %14.6e\n", "coupling (c) - (b)", b->mean_coupling_m, b->peak_coupling_m);
    if (!b->flexibility)
        printf("  (--rigid: kinematic sources only)\n");
}

static json_t *num_or_null(double v) { return isnan(v) ? json_null() : json_real(v); }

static void print_summary(const traj_opts *t, const dm_robot *rb, const dm_trajectory *tr,
                          const dm_integ_summary *s, const dm_budget_summary *b,
                          const dm_coupling_change *cc)
{
    double cmean, cmin, cmax;
    dm_coupling_change_summary(cc, &cmean, &cmin, &cmax);
    static const char *const methods[] = {"CVODE", "closed form", "full model (CVODE)"};
    if (t->sh.json && b && !b->flexibility) {
        json_t *o = json_pack("{s:s, s:s, s:f, s:o}", "robot", rb->name, "path", tr->name,
                              "dt_s", t->o.dt_s, "budget", budget_json(b));
        json_dumpf(o, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(17));
        putchar('\n');
        json_decref(o);
        return;
    }
    if (!t->sh.json && b && !b->flexibility) {
        printf("robot       %s, rigid (kinematic error sources only)\n", rb->name);
        printf("path        %s, %.6g s in steps of %g s\n", tr->name, tr->duration_s, t->o.dt_s);
        print_budget(b);
        if (t->sh.out)
            printf("written     %s\n", t->sh.out);
        return;
    }
    if (t->sh.json) {
        json_t *o = json_pack("{s:s, s:s, s:i, s:i, s:I, s:f, s:f, s:f, s:f, s:s, s:b}",
                              "robot", rb->name, "path", tr->name, "dof", s->n, "modes", s->k,
                              "steps", (json_int_t)s->steps, "duration_s", s->duration_s,
                              "dt_s", t->o.dt_s, "mean_error_m", s->mean_error_m,
                              "peak_error_m", s->peak_error_m, "integrator",
                              methods[t->o.method], "aliasing_risk", s->aliasing_risk);
        json_object_set_new(o, "truncation_error",
                            isnan(s->truncation_error) ? json_null() : json_real(s->truncation_error));
        json_object_set_new(o, "reference_mean_error_m",
                            isnan(s->reference_mean_error_m) ? json_null()
                                                             : json_real(s->reference_mean_error_m));
        json_object_set_new(o, "quasi_static", json_boolean(t->o.quasi_static));
        json_object_set_new(o, "member_steps", json_integer(s->member_steps));
        json_object_set_new(o, "coupling_index_log10",
                            json_pack("{s:f, s:f, s:f}", "mean", s->coupling_mean_log10, "min",
                                      s->coupling_min_log10, "max", s->coupling_max_log10));
        json_object_set_new(o, "coupling_index_change_log10",
                            json_pack("{s:o, s:o, s:o}", "mean", num_or_null(cmean), "min",
                                      num_or_null(cmin), "max", num_or_null(cmax)));
        if (b)
            json_object_set_new(o, "budget", budget_json(b));
        if (t->o.naxes) {
            json_t *ax = json_array();
            for (int a = 0; a < t->o.naxes; a++)
                json_array_append_new(ax, json_pack("{s:f, s:f, s:f, s:f}", "rotation_deg",
                                                    t->o.axes_rotation_rad[a] * 180 / M_PI,
                                                    "mean_abs_x_m", s->mean_axes_m[a][0],
                                                    "mean_abs_y_m", s->mean_axes_m[a][1],
                                                    "mean_abs_z_m", s->mean_axes_m[a][2]));
            json_object_set_new(o, "axes_rotation", ax);
        }
        json_object_set_new(o, "truncation_damping_beta_s",
                            s->truncation_beta_s > 0 ? json_real(s->truncation_beta_s) : json_null());
        json_dumpf(o, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(17));
        putchar('\n');
        json_decref(o);
        return;
    }
    printf("robot       %s, %d DOF, %d modes retained, %s\n", rb->name, s->n, s->k,
           methods[t->o.method]);
    printf("path        %s, %.6g s in %ld steps of %g s\n", tr->name, s->duration_s, s->steps,
           t->o.dt_s);
    if (s->member_steps == s->steps)
        printf("modes       from member bases at every step\n");
    else if (s->member_steps)
        printf("modes       from member bases at %ld of %ld steps, the full model's at the "
               "rest\n", s->member_steps, s->steps);
    else
        printf("modes       from the full model at every step\n");
    printf("mean error  %.6e m   (Chen eq. 27: (1/T) sum dt |Delta|)\n", s->mean_error_m);
    printf("peak error  %.6e m\n", s->peak_error_m);
    printf("coupling    log10 lambda_s (Zheng eq. 33) mean %.10g, min %.10g, max %.10g\n",
           s->coupling_mean_log10, s->coupling_min_log10, s->coupling_max_log10);
    printf("            change against the nominal robot mean %.6g, min %.6g, max %.6g\n", cmean,
           cmin, cmax);
    if (!isnan(s->truncation_error) && s->truncation_beta_s > 0)
        printf("truncation  %.3f %% (RMS of Delta_k - Delta_all over RMS of Delta_all, both with "
               "Rayleigh beta = %g s: undamped, the all-modes run is not converged in dt; all %d "
               "modes so damped: mean error %.6e m)\n",
               100 * s->truncation_error, s->truncation_beta_s, s->n, s->reference_mean_error_m);
    else if (!isnan(s->truncation_error))
        printf("truncation  %.3f %% (RMS of Delta_k - Delta_all over RMS of Delta_all; all %d "
               "modes: mean error %.6e m)\n",
               100 * s->truncation_error, s->n, s->reference_mean_error_m);
    if (b)
        print_budget(b);
    if (t->o.naxes) {
        printf("\nmean |error| along axes rotated about z by beta (Zheng fig. 15), m\n");
        printf("  %10s %14s %14s %14s\n", "beta (deg)", "x'", "y'", "z");
        for (int a = 0; a < t->o.naxes; a++)
            printf("  %10.4g %14.6e %14.6e %14.6e\n", t->o.axes_rotation_rad[a] * 180 / M_PI,
                   s->mean_axes_m[a][0], s->mean_axes_m[a][1], s->mean_axes_m[a][2]);
    }
    if (t->sh.out)
        printf("written     %s\n", t->sh.out);
}

int dm_cli_trajectory(int argc, char **argv)
{
    traj_opts t;
    int rc = parse(argc, argv, &t);
    if (rc)
        return rc;
    dm_trajectory tr;
    dm_error err;
    if (dm_traj_make(t.path, &t.rb, &tr, &err))
        return dm_cli_report(&err);
    if (t.vtk.dir && dm_cli_traj_vtk_check(&t.vtk, &err)) {
        dm_traj_free(&tr);
        return dm_cli_report(&err);
    }
    dm_file_out out = {0};
    int zarr = t.sh.out && ends_with(t.sh.out, ".zarr");
    dm_trajstore_samples kept = {0};
    if (t.sh.out && !zarr && (rc = dm_file_out_open(&out, t.sh.out, &err))) {
        dm_traj_free(&tr);
        return dm_cli_report(&err);
    }
    int budget = !t.no_budget && (t.rigid || dm_effects_geometry_errors(&t.rb.effects));
    if (out.f)
        fprintf(out.f, "t_s,x_m,y_m,z_m,dx_m,dy_m,dz_m,ex_rad,ey_rad,ez_rad,error_m,"
                       "tool_dx_m,tool_dy_m,tool_dz_m,f1_hz,f2_hz,f3_hz,coupling_index_log10,"
                       "coupling_index_change_log10%s\n",
                budget ? BUDGET_COLUMNS : "");
    dm_integ_summary sum;
    dm_budget_summary bsum;
    run_out ro = {.csv = out.f, .kept = zarr ? &kept : NULL, .vtk = t.vtk.dir ? &t.vtk : NULL};
    rc = dm_coupling_change_init(&ro.cc, &t.rb, t.o.na, t.o.nb, &err);
    if (!rc && budget) {
        rc = dm_budget_trajectory(&t.rb, &tr, &t.o, !t.rigid, budget_sample, &ro, &bsum, &err);
        sum = bsum.run;
    } else if (!rc)
        rc = dm_integrate_trajectory(&t.rb, &tr, &t.o, run_sample, &ro, &sum, &err);
    if (!rc && out.f)
        rc = dm_file_out_commit(&out, &err);
    if (!rc && zarr)
        rc = dm_trajstore_write(t.sh.out, t.rb.name, tr.name, &kept, &err);
    if (ro.vtk) {
        int vrc = dm_cli_traj_vtk_finish(ro.vtk, !rc, &err);
        rc = rc ? rc : vrc;
    }
    dm_trajstore_samples_free(&kept);
    if (rc) {
        if (out.f)
            dm_file_out_abort(&out);
        if (rc == DM_EINTERRUPT && ro.failed)
            err = ro.err;
        else if (rc == DM_EINTERRUPT)
            dm_fail(&err, DM_EIO, "%s: write failed", t.sh.out);
        dm_coupling_change_free(&ro.cc);
        dm_traj_free(&tr);
        return dm_cli_report(&err);
    }
    if (!(budget && t.rigid) && sum.aliasing_risk)
        fprintf(stderr,
                "deltamap: warning: undamped run with more than 20 modes and dt %g s > 1.25e-4 "
                "s: step-boundary projections can alias into high modes and grow (docs/model.md "
                "§4). Add damping, keep <= 20 modes, or use --dt 1.25e-4.\n",
                t.o.dt_s);
    print_summary(&t, &t.rb, &tr, &sum, budget ? &bsum : NULL, &ro.cc);
    dm_coupling_change_free(&ro.cc);
    dm_traj_free(&tr);
    return 0;
}
