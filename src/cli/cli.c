/* The deltamap command line (see dm_cli.h). */
#include "dm_cli.h"

#include <assert.h>
#include <getopt.h>
#include <jansson.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dm_analysis.h"
#include "dm_coupling.h"
#include "dm_isa.h"
#include "cli_impl.h"
#include "cli_shapes.h"
#include "dm_vtk.h"


static const char MAIN_HELP[] =
    "usage: deltamap COMMAND [options]\n"
    "\n"
    "Elastodynamics of Delta parallel robots (see README.md, docs/).\n"
    "\n"
    "commands:\n"
    "  modes       natural frequencies, mode shapes, static gravity error and\n"
    "              platform stiffness at one pose\n"
    "  trajectory  6-D elastic error of the platform along a trajectory\n"
    "  sweep       workspace maps (frequencies, errors, stiffness) into a store\n"
    "  info        what a map store holds, its completeness and checksums\n"
    "  study       mean trajectory error over one or two robot parameters\n"
    "  tolerance   Monte Carlo of the platform error over tolerances and clearance\n"
    "  compare     residuals of the model against measured data\n"
    "  diagnose    name the physical effect behind the residuals, fit it\n"
    "  synth       synthetic measured data from an extended robot\n"
    "  plan        the poses (or path) of an experiment that identifies named effects\n"
    "  robot       check a robot file or preset and print it in full\n"
    "  presets     list the built-in robots\n"
    "\n"
    "`deltamap COMMAND --help` describes a command's options.\n"
    "\n"
    "exit codes: 0 success, 1 usage error, 2 bad input (robot file, option\n"
    "value), 3 unreachable pose, 4 numerical failure (singular structure),\n"
    "5 i/o error, 6 out of memory, 7 interrupted, 8 refused as too much work\n"
    "(estimated beyond the command's limit of hours, memory or files;\n"
    "--force-long runs it)\n"
    "\n"
    "environment:\n"
    "  DELTAMAP_ISA    the kernels' instruction-set path: default (SSE2 on\n"
    "                  x86-64, NEON on aarch64), avx2 or avx512; unset, the\n"
    "                  best the CPU has. Every path gives the same bits; a path\n"
    "                  the CPU lacks is refused. `deltamap --version` names the\n"
    "                  path in use and those this CPU has.\n";

static const char MODES_HELP[] =
    "usage: deltamap modes --robot R [--at X,Y,Z] [--modes K] [--mesh NA,NB]\n"
    "                      [--method partial|dense|all|members] [--set SECTION.KEY=V]...\n"
    "                      [--json]\n"
    "                      [--vtk FILE.vtu]\n"
    "\n"
    "Frozen-configuration modal analysis at one platform pose (docs/model.md §2-5).\n"
    "\n"
    "  --robot R       preset name (chen2018, zheng2017, han2011) or robot file\n"
    "  --at X,Y,Z      platform centre in m (default: the robot's [workspace] home)\n"
    "  --modes K       number of modes to compute and print (default 10)\n"
    "  --mesh NA,NB    elements per arm and per rod (default: the robot file's\n"
    "                  [mesh], 4,4 for the presets; 1,1 is Chen's 48-DOF model)\n"
    "  --method M      eigen solver: partial (default: the k lowest modes by\n"
    "                  subspace iteration on the factor of K, proven complete\n"
    "                  by a Sturm count), dense (the k lowest by LAPACK on the\n"
    "                  dense matrices), all (every mode, dsygvd) or members (the\n"
    "                  member bases, component modes once per robot: statics\n"
    "                  exact through the joints, each frequency with a certified\n"
    "                  bound by Wittrick-Williams counts of the whole model; the\n"
    "                  full model where the members cannot serve, said in the\n"
    "                  output; docs/model-choices.md \"Member bases\")\n"
    "  --set K=V       override a robot-file key, e.g. arm.side=0.025 (repeatable)\n"
    "  --json          one JSON object on stdout instead of the table\n"
    "  --vtk FILE.vtu  also write the robot, its mode shapes and static deflection\n"
    "                  for ParaView (docs/shapes.md)\n";

static const char ROBOT_HELP[] =
    "usage: deltamap robot R\n"
    "\n"
    "Parse robot file or preset R, check it, and print it with every default\n"
    "filled in (the format of docs/robot-file.md).\n";

/* ---- modes ------------------------------------------------------------- */

typedef struct {
    dm_cli_shared sh; /* --robot, --set, --mesh, --json, --at */
    const char *vtk;
    int k;
    dm_eigen_method method;
    int members; /* --method members */
    dm_robot rb; /* loaded by parse_modes_opts */
} modes_opts;

static int parse_modes_opts(int argc, char **argv, modes_opts *o)
{
    static const struct option own[] = {
        {"modes", required_argument, 0, 'k'},
        {"method", required_argument, 0, 'M'}, {"vtk", required_argument, 0, 'V'}, {0, 0, 0, 0}};
    int c, rc;
    memset(o, 0, sizeof *o);
    dm_cli_begin(&o->sh, "modes", MODES_HELP, own,
                 DM_CLI_ROBOT | DM_CLI_SET | DM_CLI_MESH | DM_CLI_JSON | DM_CLI_AT,
                 DM_CLI_PROGRESS_NONE);
    o->k = 10;
    while ((c = dm_cli_getopt(argc, argv, &o->sh, &rc))) {
        switch (c) {
        case 'k':
            if (dm_cli_parse_int(optarg, 1, 100000, &o->k))
                return dm_cli_usage("modes", "--modes takes a whole number >= 1", optarg);
            break;
        case 'M':
            o->members = 0; /* the last --method counts */
            if (!strcmp(optarg, "partial"))
                o->method = DM_EIGEN_PARTIAL;
            else if (!strcmp(optarg, "all"))
                o->method = DM_EIGEN_ALL;
            else if (!strcmp(optarg, "dense"))
                o->method = DM_EIGEN_DENSE;
            else if (!strcmp(optarg, "members"))
                o->members = 1, o->method = DM_EIGEN_PARTIAL;
            else
                return dm_cli_usage("modes", "--method is partial, dense, all or members",
                                    optarg);
            break;
        case 'V': o->vtk = optarg; break;
        default: assert(0);
        }
    }
    if (rc)
        return rc;
    if (!o->sh.robot)
        return dm_cli_usage("modes", "--robot is required", NULL);
    return dm_cli_start(&o->sh, NULL, &o->rb);
}

/* What served the pose, for --method members: the member bases with each
 * frequency's certified relative bound, or the full model and why. */
typedef struct {
    int asked;              /* --method members */
    const double *freq_rel; /* per mode (NULL: the full model served) */
    char why[256];          /* why the full model served */
} engine_note;

static void print_modes_table(const dm_robot *rb, const dm_analysis *an,
                              const dm_pose_result *res, double nominal_log10,
                              const engine_note *en)
{
    const dm_pose *p = &res->pose;
    const dm_modes *mo = res->modes;
    printf("robot   %s (%s)\n", rb->name, rb->source);
    printf("pose    P = (%g, %g, %g) m   arm angles (%.3f, %.3f, %.3f) deg   cond(J) %.3g%s\n",
           p->P[0] - p->offset[0], p->P[1] - p->offset[1], p->P[2] - p->offset[2], p->alpha[0] * 180 / M_PI, p->alpha[1] * 180 / M_PI,
           p->alpha[2] * 180 / M_PI, p->cond, res->near_singular ? "  NEAR-SINGULAR" : "");
    if (dm_effects_geometry_errors(&rb->effects))
        printf("real    geometry errors/clearance put the platform at commanded + (%.4g, %.4g, "
               "%.4g) m\n",
               p->offset[0], p->offset[1], p->offset[2]);
    printf("model   mesh %d,%d: %d DOF\n", an->model->na, an->model->nb, an->model->n);
    if (en->asked && en->freq_rel)
        printf("engine  member bases: %d reduced DOF, completeness proven by a count of the "
               "whole model\n", dm_boundary_reduced_size(an->boundary));
    else if (en->asked)
        printf("engine  the full model (%s)\n", en->why);
    printf("\n mode   freq (Hz)   platform share   direction%s\n",
           en->freq_rel ? "   bound (rel.)" : "");
    for (int j = 0; j < mo->k; j++) {
        printf(" %4d %11.4f %14.1f %%   %s", j + 1, mo->freq_hz[j],
               100.0 * mo->platform_share[j], dm_direction_name(mo->direction[j]));
        if (en->freq_rel)
            printf("%*s%.1e", 12 - (int)strlen(dm_direction_name(mo->direction[j])), "",
                   en->freq_rel[j]);
        putchar('\n');
    }
    const double *u = res->static_error;
    printf("\nstatic elastic error under gravity (platform centre)\n");
    printf("  dx %+.5e m   dy %+.5e m   dz %+.5e m\n", u[0], u[1], u[2]);
    printf("  ex %+.5e rad ey %+.5e rad ez %+.5e rad\n", u[3], u[4], u[5]);
    printf("\nplatform compliance (translation)\n");
    printf("  worst direction (%.4f, %.4f, %.4f): %.5e m/N  -> stiffness %.5e N/m\n",
           res->compliance_dir[0], res->compliance_dir[1], res->compliance_dir[2],
           res->compliance_max_m_per_n, res->stiffness_min_n_per_m);
    printf("  diagonal: cxx %.5e  cyy %.5e  czz %.5e m/N\n", res->compliance[0],
           res->compliance[7], res->compliance[14]);
    printf("\ncoupling index (Zheng eq. 33, product of the singular values of K)\n");
    printf("  log10 = %.10g   change from the nominal robot (no effects) = %+.6g\n"
           "  (depends on the mesh and the DOF units: compare at the same mesh only)\n",
           res->coupling_index_log10, res->coupling_index_log10 - nominal_log10);
}

static json_t *json_array_of(const double *v, int n)
{
    json_t *a = json_array();
    for (int i = 0; i < n; i++)
        json_array_append_new(a, json_real(v[i]));
    return a;
}

static int print_modes_json(const dm_robot *rb, const dm_analysis *an,
                            const dm_pose_result *res, double nominal_log10,
                            const dm_shape_set *shapes, const engine_note *en)
{
    const dm_modes *mo = res->modes;
    json_t *o = json_object(), *modes = json_array(), *C = json_array();
    json_object_set_new(o, "robot", json_string(rb->name));
    json_object_set_new(o, "source", json_string(rb->source));
    double cmd[3] = {res->pose.P[0] - res->pose.offset[0], res->pose.P[1] - res->pose.offset[1],
                     res->pose.P[2] - res->pose.offset[2]};
    json_object_set_new(o, "pose_m", json_array_of(cmd, 3));
    json_object_set_new(o, "arm_angles_rad", json_array_of(res->pose.alpha, 3));
    json_object_set_new(o, "platform_offset_m", json_array_of(res->pose.offset, 3));
    json_object_set_new(o, "condition_number", json_real(res->pose.cond));
    json_object_set_new(o, "near_singular", json_boolean(res->near_singular));
    json_object_set_new(o, "mesh", json_pack("[ii]", an->model->na, an->model->nb));
    json_object_set_new(o, "dof", json_integer(an->model->n));
    json_object_set_new(o, "frequencies_hz", json_array_of(mo->freq_hz, mo->k));
    json_object_set_new(o, "engine", json_string(res->engine == DM_ENGINE_MEMBERS ? "members"
                                                                                 : "full"));
    if (en->asked && !en->freq_rel)
        json_object_set_new(o, "engine_reason", json_string(en->why));
    for (int j = 0; j < mo->k; j++) {
        json_t *m = json_pack("{s:i, s:f, s:f, s:s}", "mode", j + 1, "freq_hz", mo->freq_hz[j],
                              "platform_share", mo->platform_share[j], "direction",
                              dm_direction_name(mo->direction[j]));
        if (en->freq_rel)
            json_object_set_new(m, "freq_bound_rel", json_real(en->freq_rel[j]));
        json_array_append_new(modes, m);
    }
    json_object_set_new(o, "modes", modes);
    json_object_set_new(o, "static_error", json_array_of(res->static_error, 6));
    for (int r = 0; r < 6; r++) {
        double row[6];
        for (int c = 0; c < 6; c++)
            row[c] = res->compliance[6 * c + r];
        json_array_append_new(C, json_array_of(row, 6));
    }
    json_object_set_new(o, "compliance", C);
    json_object_set_new(o, "compliance_max_m_per_n", json_real(res->compliance_max_m_per_n));
    json_object_set_new(o, "compliance_max_direction", json_array_of(res->compliance_dir, 3));
    json_object_set_new(o, "stiffness_min_n_per_m", json_real(res->stiffness_min_n_per_m));
    json_object_set_new(o, "coupling_index_log10", json_real(res->coupling_index_log10));
    json_object_set_new(o, "coupling_index_change_log10",
                        json_real(res->coupling_index_log10 - nominal_log10));
    dm_cli_shapes_json(o, modes, shapes);
    int rc = json_dumpf(o, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(17));
    putchar('\n');
    json_decref(o);
    return rc ? DM_EIO : 0;
}

/* --method members: the member bases for the analysis (the model built
 * too: the shapes' outputs read it), or NULL and why the full model serves. */
static dm_members *use_members(dm_analysis *an, int na, int nb, int k, engine_note *en)
{
    dm_error why;
    dm_members *ms = dm_analysis_members(an->robot, na, nb, k, &why);
    if (ms && dm_analysis_use_members(an, ms, &why)) {
        dm_members_free(ms);
        ms = NULL;
    }
    if (!ms)
        snprintf(en->why, sizeof en->why, "the member bases cannot serve: %.200s", why.msg);
    an->want_model = 1;
    return ms;
}

/* Each frequency's certified relative bound where the members served (a
 * bound b on lambda = omega^2 is b / (2 lambda) on the frequency, to
 * first order), or why the full model served the pose. */
static int member_bounds(dm_analysis *an, const dm_pose_result *res, int k, engine_note *en,
                         double **freq_rel, dm_error *err)
{
    if (res->engine != DM_ENGINE_MEMBERS) {
        if (!en->why[0])
            snprintf(en->why, sizeof en->why, "the members could not serve this pose: %.200s",
                     an->member_error.code ? an->member_error.msg : "(no reason given)");
        return DM_OK;
    }
    double *b = malloc(sizeof(double) * k);
    if (!b)
        return dm_fail(err, DM_ENOMEM, "out of memory");
    int rc = dm_analysis_bounds(an, k, b, err);
    for (int j = 0; !rc && j < k; j++)
        b[j] /= 2 * res->modes->omega_rad_s[j] * res->modes->omega_rad_s[j];
    if (rc) {
        free(b);
        return rc;
    }
    *freq_rel = b;
    en->freq_rel = b;
    return DM_OK;
}

static int cmd_modes(int argc, char **argv)
{
    modes_opts o;
    int rc = parse_modes_opts(argc, argv, &o);
    if (rc)
        return rc;
    dm_robot *rb = &o.rb;
    dm_error err;
    if (o.vtk && dm_vtk_check_dir(o.vtk, &err))
        return dm_cli_report(&err);
    int na = o.sh.na ? o.sh.na : rb->na, nb = o.sh.nb ? o.sh.nb : rb->nb;
    dm_analysis *an = dm_analysis_alloc(rb, na, nb, o.k, o.method, &err);
    if (!an)
        return dm_cli_report(&err);
    if (o.k > an->model->n) {
        fprintf(stderr, "deltamap modes: --modes %d exceeds the model's %d DOF\n", o.k,
                an->model->n);
        dm_analysis_free(an);
        return DM_EINVAL;
    }
    dm_pose_result res;
    const double *P = o.sh.have_at ? o.sh.at : rb->home_m;
    double nominal = 0, *freq_rel = NULL;
    dm_coupling *cw = NULL;
    dm_shape_set *shapes = NULL;
    engine_note en = {o.members, NULL, ""};
    dm_members *ms = o.members ? use_members(an, na, nb, o.k, &en) : NULL;
    rc = dm_analysis_run(an, P, o.k, &res, &err);
    if (!rc && o.members)
        rc = member_bounds(an, &res, o.k, &en, &freq_rel, &err);
    if (!rc && (o.sh.json || o.vtk) &&
        !(shapes = dm_shape_set_make(an, &res, dm_shape_default_max(rb), &err)))
        rc = err.code;
    if (!rc && !(cw = dm_coupling_alloc(rb, na, nb, &err)))
        rc = err.code;
    if (!rc)
        rc = dm_coupling_nominal_log10(cw, P, &nominal, &err);
    if (!rc && !dm_effects_any(&rb->effects)) /* the robot is its own nominal: 0 exactly, */
        nominal = res.coupling_index_log10;   /* whichever model served */
    if (!rc && o.sh.json && (rc = print_modes_json(rb, an, &res, nominal, shapes, &en)))
        dm_fail(&err, rc, "modes --json: the JSON could not be made or written (out of "
                "memory, or stdout failed)");
    else if (!rc && !o.sh.json)
        print_modes_table(rb, an, &res, nominal, &en);
    if (!rc && o.vtk) /* files last: a failure before leaves none behind */
        rc = dm_cli_modes_vtk(o.vtk, shapes, res.modes->platform_share, res.modes->freq_hz, &err);
    if (rc)
        dm_cli_report(&err);
    dm_coupling_free(cw);
    dm_shape_set_free(shapes);
    dm_analysis_free(an);
    dm_members_free(ms);
    free(freq_rel);
    return rc;
}

/* ---- robot, presets ------------------------------------------------------ */

static int cmd_robot(int argc, char **argv)
{
    if (argc == 2 && !strcmp(argv[1], "--help")) {
        fputs(ROBOT_HELP, stdout);
        return 0;
    }
    if (argc != 2)
        return dm_cli_usage("robot", "expects one robot file or preset name", NULL);
    dm_robot rb;
    dm_error err;
    if (dm_robot_load(argv[1], &rb, &err))
        return dm_cli_report(&err);
    printf("# %s: valid; every default filled in\n", rb.source);
    return dm_robot_write(&rb, stdout);
}

static int cmd_presets(void)
{
    for (const char *const *n = dm_robot_preset_names(); *n; n++) {
        dm_robot rb;
        dm_error err;
        if (dm_robot_load(*n, &rb, &err))
            return dm_cli_report(&err);
        printf("%-10s R %.3f m, r %.3f m, la %.3f m, lb %.3f m, home (%g, %g, %g) m\n", *n,
               rb.base_radius_m, rb.platform_radius_m, rb.arm_length_m, rb.rod_length_m,
               rb.home_m[0], rb.home_m[1], rb.home_m[2]);
    }
    return 0;
}

/* The version, the CPU and the kernels' path (dm_isa.h): a figure or a
 * report quoted from a run says where it came from. */
static int print_version(dm_isa isa)
{
    char cpu[128];
    dm_isa_cpu_model(cpu, sizeof cpu);
    printf("deltamap %s\nCPU: %s\nkernels: %s (%s)\npaths on this CPU:", DM_VERSION, cpu,
           dm_isa_name(isa), dm_isa_describe(isa));
    for (int i = 0; i < DM_ISA_COUNT; i++)
        if (dm_isa_available((dm_isa)i))
            printf(" %s", dm_isa_name((dm_isa)i));
    printf("\n");
    return 0;
}

int dm_cli_main(int argc, char **argv)
{
    if (argc < 2) {
        fputs(MAIN_HELP, stderr);
        return EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help")) {
        fputs(MAIN_HELP, stdout);
        return 0;
    }
    dm_error err;
    dm_isa isa;
    if (dm_isa_from_env(&isa, &err))
        return dm_cli_report(&err);
    if (!strcmp(cmd, "--version"))
        return print_version(isa);
    if (!strcmp(cmd, "modes"))
        return cmd_modes(argc - 1, argv + 1);
    if (!strcmp(cmd, "trajectory"))
        return dm_cli_trajectory(argc - 1, argv + 1);
    if (!strcmp(cmd, "sweep"))
        return dm_cli_sweep(argc - 1, argv + 1);
    if (!strcmp(cmd, "info"))
        return dm_cli_info(argc - 1, argv + 1);
    if (!strcmp(cmd, "compare"))
        return dm_cli_compare(argc - 1, argv + 1);
    if (!strcmp(cmd, "diagnose"))
        return dm_cli_diagnose(argc - 1, argv + 1);
    if (!strcmp(cmd, "synth"))
        return dm_cli_synth(argc - 1, argv + 1);
    if (!strcmp(cmd, "plan"))
        return dm_cli_plan(argc - 1, argv + 1);
    if (!strcmp(cmd, "tolerance"))
        return dm_cli_tolerance(argc - 1, argv + 1);
    if (!strcmp(cmd, "study"))
        return dm_cli_study(argc - 1, argv + 1);
    if (!strcmp(cmd, "robot"))
        return cmd_robot(argc - 1, argv + 1);
    if (!strcmp(cmd, "presets"))
        return cmd_presets();
    fprintf(stderr, "deltamap: unknown command '%s' (see `deltamap --help`)\n", cmd);
    return EXIT_USAGE;
}
