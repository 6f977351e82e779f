/* deltamap tolerance: Monte Carlo of the platform error at one pose over
 * tolerance bands and random clearance states (dm_tolerance). */
#include <assert.h>
#include <getopt.h>
#include <jansson.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_impl.h"
#include "dm_tolerance.h"

static const char HELP[] =
    "usage: deltamap tolerance --robot R [--at X,Y,Z] --samples N --seed S\n"
    "                          [--tol NAME=VALUE]... [--dist uniform|normal] [--spec M]\n"
    "                          [--rigid] [--mesh NA,NB] [--threads T] [--set SECTION.KEY=V]...\n"
    "                          [--force-long] [--json] [--progress bar|lines|none]\n"
    "\n"
    "Monte Carlo of the platform error at one commanded pose (Zheng & Zhang 2017):\n"
    "each sample draws every geometry error within +- its tolerance and each\n"
    "joint's clearance state in its dead band (the robot file's clearances), closes\n"
    "the real chains and adds the static elastic error under gravity. Reports the\n"
    "mean, P95 and maximum error, the share above the spec, the linearised\n"
    "prediction and the first-order sensitivity to each tolerance, and the\n"
    "dominant source. Seeded: the same numbers for any thread count; each position\n"
    "(to 1 nm) draws its own states, and `sweep --tolerance-samples` gives at a grid\n"
    "point exactly what this gives there.\n"
    "\n"
    "  --robot R        preset or robot file ([effects] errors are the mean)\n"
    "  --at X,Y,Z       commanded platform centre, m (default: the robot's home)\n"
    "  --samples N      number of samples (>= 1)\n"
    "  --seed S         seed (a whole number >= 0)\n"
    "  --tol NAME=V     +- tolerance of a geometry error, the same for each chain:\n"
    "                   arm_length, rod_length, base_radius, platform_radius (m),\n"
    "                   theta_deg, alpha0_deg (deg); repeatable; default 0\n"
    "  --dist D         uniform in +-tol (default) or normal (sigma tol/3, cut at +-tol)\n"
    "  --spec M         accuracy spec in m (> 0): report P(|error| > spec)\n"
    "  --rigid          kinematic errors only (no elastic error)\n"
    "  --mesh NA,NB     mesh of the flexible model (default: the robot file's)\n"
    "  --threads T      OpenMP threads (default: all)\n"
    "  --force-long     run even when the estimate exceeds 1 hour of work (refused\n"
    "                   before any otherwise; --force, its old spelling, still works)\n"
    "  --json           the result as JSON\n"
    "  --progress M     how far it is (the linearisation, then the samples), on\n"
    "                   stderr with an ETA: bar (the default when stderr is a\n"
    "                   terminal), lines, or none (the default otherwise)\n";

typedef struct {
    dm_cli_shared sh; /* --robot, --set, --mesh, --threads, --progress, --json, --force-long,
                         --at */
    int have_samples, have_seed;
    dm_tolerance_spec spec;
    dm_robot rb; /* loaded by parse */
} tol_opts;

int dm_cli_parse_tol(const char *arg, dm_tolerance_spec *sp)
{
    const char *eq = strchr(arg, '=');
    if (!eq)
        return -1;
    for (int c = 0; c < DM_TOL_NGEOM; c++) {
        const char *name = dm_tolerance_class_name(c);
        if (strlen(name) == (size_t)(eq - arg) && !strncmp(arg, name, eq - arg)) {
            double v;
            if (dm_cli_parse_list(eq + 1, &v, 1))
                return -1;
            sp->tol[c] = (c == DM_TOL_THETA || c == DM_TOL_ALPHA0) ? v * M_PI / 180 : v;
            return 0;
        }
    }
    return -1;
}

int dm_cli_tolerance_tol(const char *cmd, const char *arg, dm_tolerance_spec *sp)
{
    if (dm_cli_parse_tol(arg, sp))
        return dm_cli_usage(cmd,
                            "--tol takes NAME=VALUE with NAME arm_length, rod_length, "
                            "base_radius, platform_radius, theta_deg or alpha0_deg",
                            arg);
    for (int k = 0; k < DM_TOL_NGEOM; k++)
        if (sp->tol[k] < 0) {
            fprintf(stderr, "deltamap %s: --tol %s: must be >= 0, got %s\n", cmd,
                    dm_tolerance_class_name(k), arg);
            return DM_EINVAL;
        }
    return 0;
}

int dm_cli_tolerance_spec(const char *cmd, const char *arg, dm_tolerance_spec *sp)
{
    if (dm_cli_parse_list(arg, &sp->spec_m, 1))
        return dm_cli_usage(cmd, "--spec takes an error in m", arg);
    if (!(sp->spec_m > 0)) {
        fprintf(stderr, "deltamap %s: --spec: must be > 0 m, got %s\n", cmd, arg);
        return DM_EINVAL;
    }
    return 0;
}

int dm_cli_tolerance_seed(const char *cmd, const char *flag, const char *arg,
                          dm_tolerance_spec *sp)
{
    char *end, msg[64];
    unsigned long long v = strtoull(arg, &end, 10);
    if (end == arg || *end || arg[0] == '-') {
        snprintf(msg, sizeof msg, "%s takes a whole number >= 0", flag);
        return dm_cli_usage(cmd, msg, arg);
    }
    sp->seed = v;
    return 0;
}

int dm_cli_tolerance_dist(const char *cmd, const char *flag, const char *arg,
                          dm_tolerance_spec *sp)
{
    char msg[64];
    if (!strcmp(arg, "uniform"))
        sp->dist = DM_TOL_UNIFORM;
    else if (!strcmp(arg, "normal"))
        sp->dist = DM_TOL_NORMAL;
    else {
        snprintf(msg, sizeof msg, "%s is uniform or normal", flag);
        return dm_cli_usage(cmd, msg, arg);
    }
    return 0;
}

static int parse(int argc, char **argv, tol_opts *t)
{
    static const struct option own[] = {
        {"samples", 1, 0, 'n'}, {"seed", 1, 0, 'S'},  {"tol", 1, 0, 't'},
        {"dist", 1, 0, 'd'}, {"spec", 1, 0, 'p'},    {"rigid", 0, 0, 'G'}, {"force", 0, 0, 'f'},
        {0, 0, 0, 0}};
    int c, rc;
    memset(t, 0, sizeof *t);
    dm_tolerance_spec_default(&t->spec);
    dm_cli_begin(&t->sh, "tolerance", HELP, own,
                 DM_CLI_ROBOT | DM_CLI_SET | DM_CLI_MESH | DM_CLI_THREADS | DM_CLI_PROGRESS |
                     DM_CLI_JSON | DM_CLI_FORCE_LONG | DM_CLI_AT,
                 DM_CLI_PROGRESS_NONE);
    while ((c = dm_cli_getopt(argc, argv, &t->sh, &rc))) {
        switch (c) {
        case 'n': {
            double v;
            /* bad values (0, negative) are checked with the rest of the spec */
            if (dm_cli_parse_list(optarg, &v, 1) || v != floor(v) || fabs(v) > 1e12)
                return dm_cli_usage("tolerance", "--samples takes a whole number", optarg);
            t->spec.samples = (long)v;
            t->have_samples = 1;
            break;
        }
        case 'S':
            if ((rc = dm_cli_tolerance_seed("tolerance", "--seed", optarg, &t->spec)))
                return rc;
            t->have_seed = 1;
            break;
        case 't':
            if ((rc = dm_cli_tolerance_tol("tolerance", optarg, &t->spec)))
                return rc;
            break;
        case 'd':
            if ((rc = dm_cli_tolerance_dist("tolerance", "--dist", optarg, &t->spec)))
                return rc;
            break;
        case 'p':
            if ((rc = dm_cli_tolerance_spec("tolerance", optarg, &t->spec)))
                return rc;
            break;
        case 'G': t->spec.flexibility = 0; break;
        case 'f':
            dm_cli_deprecated("tolerance", "--force", "--force-long");
            t->sh.force_long = 1;
            break;
        default: assert(0);
        }
    }
    if (rc)
        return rc;
    if (!t->sh.robot || !t->have_samples || !t->have_seed)
        return dm_cli_usage("tolerance", "--robot, --samples and --seed are required", NULL);
    t->spec.na = t->sh.na;
    t->spec.nb = t->sh.nb;
    t->spec.force_long = t->sh.force_long;
    return dm_cli_start(&t->sh, &t->sh.threads, &t->rb);
}

static json_t *num(double v) { return isnan(v) ? json_null() : json_real(v); }

static void print_result(const tol_opts *t, const dm_robot *rb, const double P[3],
                         const dm_tolerance_result *r)
{
    const dm_tolerance_spec *sp = &t->spec;
    if (t->sh.json) {
        json_t *o = json_object(), *sens = json_object(), *tol = json_object();
        json_object_set_new(o, "robot", json_string(rb->name));
        json_object_set_new(o, "pose_m", json_pack("[fff]", P[0], P[1], P[2]));
        json_object_set_new(o, "samples", json_integer(r->samples));
        json_object_set_new(o, "seed", json_integer((json_int_t)sp->seed));
        json_object_set_new(o, "distribution", json_string(sp->dist == DM_TOL_UNIFORM ? "uniform" : "normal"));
        json_object_set_new(o, "flexibility", json_boolean(sp->flexibility));
        for (int c = 0; c < DM_TOL_NGEOM; c++)
            json_object_set_new(tol, dm_tolerance_class_name(c),
                                json_real(c == DM_TOL_THETA || c == DM_TOL_ALPHA0
                                              ? sp->tol[c] * 180 / M_PI : sp->tol[c]));
        json_object_set_new(o, "tolerances", tol);
        json_object_set_new(o, "mean_error_m", json_real(r->mean_error_m));
        json_object_set_new(o, "std_error_m", json_real(r->std_error_m));
        json_object_set_new(o, "standard_error_of_mean_m", json_real(r->stderr_mean_m));
        json_object_set_new(o, "p95_error_m", json_real(r->p95_error_m));
        json_object_set_new(o, "max_error_m", json_real(r->max_error_m));
        json_object_set_new(o, "spec_m", sp->spec_m > 0 ? json_real(sp->spec_m) : json_null());
        json_object_set_new(o, "p_exceed_spec", num(r->p_exceed_spec));
        json_object_set_new(o, "mean_m", json_pack("[fff]", r->mean_m[0], r->mean_m[1], r->mean_m[2]));
        json_object_set_new(o, "std_m", json_pack("[fff]", r->std_m[0], r->std_m[1], r->std_m[2]));
        json_object_set_new(o, "deterministic_m", json_pack("[fff]", r->deterministic_m[0],
                                                            r->deterministic_m[1], r->deterministic_m[2]));
        json_object_set_new(o, "deterministic_error_m", json_real(r->deterministic_error_m));
        json_object_set_new(o, "predicted_std_m", json_pack("[fff]", r->predicted_std_m[0],
                                                            r->predicted_std_m[1], r->predicted_std_m[2]));
        json_object_set_new(o, "predicted_std_error_m", num(r->predicted_std_error_m));
        for (int c = 0; c < DM_TOL_NCLASS; c++)
            json_object_set_new(sens, dm_tolerance_class_name(c),
                                json_pack("{s:f, s:f}", "rms_error_per_unit", r->sensitivity[c],
                                          "std_contribution_m", r->std_contribution_m[c]));
        json_object_set_new(o, "sensitivity", sens);
        json_object_set_new(o, "dominant_source",
                            r->dominant >= 0 ? json_string(dm_tolerance_class_name(r->dominant)) : json_null());
        json_dumpf(o, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(17));
        putchar('\n');
        json_decref(o);
        return;
    }
    printf("robot       %s at commanded (%g, %g, %g) m, %s model\n", rb->name, P[0], P[1], P[2],
           sp->flexibility ? "flexible (static error under gravity added)" : "rigid");
    printf("samples     %ld, seed %llu, geometry errors %s within +- tolerance\n", r->samples,
           (unsigned long long)sp->seed, sp->dist == DM_TOL_UNIFORM ? "uniform" : "normal (sigma tol/3)");
    printf("|error|     mean %.6e m (+- %.2e standard error), std %.6e m\n", r->mean_error_m,
           r->stderr_mean_m, r->std_error_m);
    printf("            P95 %.6e m, max %.6e m\n", r->p95_error_m, r->max_error_m);
    if (sp->spec_m > 0)
        printf("spec        %.6g m: P(|error| > spec) = %.4f\n", sp->spec_m, r->p_exceed_spec);
    printf("mean state  error (%.6e, %.6e, %.6e) m, |error| %.6e m\n", r->deterministic_m[0],
           r->deterministic_m[1], r->deterministic_m[2], r->deterministic_error_m);
    printf("components  std (%.4e, %.4e, %.4e) m, linearised (%.4e, %.4e, %.4e) m\n", r->std_m[0],
           r->std_m[1], r->std_m[2], r->predicted_std_m[0], r->predicted_std_m[1], r->predicted_std_m[2]);
    printf("\n %-26s %12s %20s %18s\n", "source", "tolerance", "rms error per unit", "std contribution");
    for (int c = 0; c < DM_TOL_NCLASS; c++) {
        const dm_effects *e = &rb->effects;
        double tol = c < DM_TOL_NGEOM ? sp->tol[c] * (c == DM_TOL_THETA || c == DM_TOL_ALPHA0 ? 180 / M_PI : 1)
                   : c == DM_TOL_CLEARANCE ? e->clearance_m
                   : c == DM_TOL_ACT_AXIAL ? e->actuator_clearance_axial_m
                                           : e->actuator_clearance_radial_m;
        const char *unit = c == DM_TOL_THETA || c == DM_TOL_ALPHA0 ? "m/deg" : "m/m";
        printf(" %-26s %12.4g %14.4e %-5s %16.4e m\n", dm_tolerance_class_name(c), tol,
               r->sensitivity[c], unit, r->std_contribution_m[c]);
    }
    printf("dominant    %s\n", r->dominant >= 0 ? dm_tolerance_class_name(r->dominant) : "none (no tolerance)");
}

int dm_cli_tolerance(int argc, char **argv)
{
    tol_opts t;
    int rc = parse(argc, argv, &t);
    if (rc)
        return rc;
    const double *P = t.sh.have_at ? t.sh.at : t.rb.home_m;
    dm_error err;
    if (dm_tolerance_check(&t.rb, &t.spec, &err))
        return dm_cli_report(&err);
    dm_tolerance_result res;
    dm_cli_progress view;
    t.spec.progress = dm_cli_progress_init(&view, "tolerance", t.sh.progress);
    t.spec.progress_user = &view;
    rc = dm_tolerance_pose(&t.rb, &t.spec, P, t.sh.threads, &res, &err);
    dm_cli_progress_finish(&view);
    if (rc)
        return dm_cli_report(&err);
    print_result(&t, &t.rb, P, &res);
    return 0;
}
