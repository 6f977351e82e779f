/* deltamap plan: the experiment that can tell, before it is run. */
#include <assert.h>
#include <getopt.h>
#include <jansson.h>
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_impl.h"
#include "dm_plan.h"

static const char PLAN_HELP[] =
    "usage: deltamap plan --robot R --kind modal|static|tracker --effects NAME[=V],...\n"
    "                     --poses N [--noise S] [--region GRID] [--seed S] [--mesh NA,NB]\n"
    "                     [--modes K] [--threads N] [--set K=V]... [--force-long]\n"
    "                     [--out POSES.csv] [--json] [--progress bar|lines|none]\n"
    "                     [--frame base|tracker [--clock offset|rate]] [--path SPEC]\n"
    "\n"
    "Picks the N poses of a modal or static survey (tracker: one path of a small\n"
    "family of circles and ring-down moves, N samples at 1 ms) that make the named\n"
    "candidate effects identifiable: D-optimal (the largest determinant of the\n"
    "Fisher information of their parameters, from the sensitivities of the\n"
    "predictions), which also separates effects that look alike. Prints per\n"
    "effect the expected 1-sigma at the assumed magnitude (NAME=V, per chain\n"
    "NAME=V0,V1,V2; default a typical one), the same for random poses, the\n"
    "smallest magnitude the experiment would see at 5 sigma, and the pairs that\n"
    "stay indistinguishable. Candidate poses: the reachable, well-conditioned\n"
    "points of --region (a grid as for sweep, e.g. x=-0.1:0.1:9,y=-0.1:0.1:9,z=-0.4),\n"
    "or 256 drawn from the box synth uses (--seed). --noise: Hz or m (default\n"
    "0.02 Hz, 50 nm, 2 um). --out writes the poses as a measurement template\n"
    "(docs/measured-data.md, values empty). Deterministic for a seed, whatever\n"
    "--threads. A plan estimated at more than 4 hours or 2 GB is refused before\n"
    "its predictions unless --force-long. --progress: how far it is, on stderr,\n"
    "with an ETA per stage (sensitivities, choosing poses, assessment): a bar (the\n"
    "default when stderr is a terminal), lines, or none (the default otherwise).\n"
    "Tracker runs: --frame base|tracker plans a run as a lab records it (the\n"
    "'# frame:' header of docs/measured-data.md): the frame, the reflector offset\n"
    "and the clock offset (--clock rate: and rate) are fitted with every model, so\n"
    "the effects are planned for what the run determines beyond them, and the\n"
    "combination of each effect they leave undetermined is printed. --path SPEC\n"
    "assesses that path (a trajectory spec) instead of choosing one.\n";

typedef struct {
    dm_cli_shared sh; /* --robot, --set, --mesh, --threads, --progress, --json, --out, --force-long */
    const char *effects;
    int have_kind, clock_rate;
    dm_plan_opts o;
    dm_plan_effect eff[DM_PLAN_MAXEFF]; /* parsed from effects */
    int neff;
    dm_robot rb; /* loaded by parse */
} plan_args;

static int parse(int argc, char **argv, plan_args *a)
{
    static const struct option own[] = {
        {"kind", 1, 0, 'k'},  {"effects", 1, 0, 'e'}, {"poses", 1, 0, 'p'}, {"noise", 1, 0, 'n'},
        {"region", 1, 0, 'g'}, {"seed", 1, 0, 'S'},   {"modes", 1, 0, 'M'}, {"frame", 1, 0, 'F'},
        {"clock", 1, 0, 'C'}, {"path", 1, 0, 'W'},    {0, 0, 0, 0}};
    int c, rc, seed = 1;
    memset(a, 0, sizeof *a);
    dm_cli_begin(&a->sh, "plan", PLAN_HELP, own,
                 DM_CLI_ROBOT | DM_CLI_SET | DM_CLI_MESH | DM_CLI_THREADS | DM_CLI_PROGRESS |
                     DM_CLI_JSON | DM_CLI_OUT | DM_CLI_FORCE_LONG,
                 DM_CLI_PROGRESS_NONE);
    while ((c = dm_cli_getopt(argc, argv, &a->sh, &rc))) {
        switch (c) {
        case 'e': a->effects = optarg; break;
        case 'g': a->o.region = optarg; break;
        case 'k':
            if (dm_data_kind_parse(optarg, &a->o.kind))
                return dm_cli_usage("plan", "--kind is modal, static or tracker", optarg);
            a->have_kind = 1;
            break;
        case 'p':
            if (dm_cli_parse_count(optarg, 1, INT_MAX, &a->o.npose))
                return dm_cli_usage("plan", "--poses takes a whole number 1..2147483647", optarg);
            break;
        case 'F':
            if (strcmp(optarg, "base") && strcmp(optarg, "tracker"))
                return dm_cli_usage("plan", "--frame is base or tracker", optarg);
            a->o.nuisance = a->o.nuisance ? a->o.nuisance : 1;
            a->o.frame_tracker = !strcmp(optarg, "tracker");
            break;
        case 'C':
            if (strcmp(optarg, "offset") && strcmp(optarg, "rate"))
                return dm_cli_usage("plan", "--clock is offset or rate", optarg);
            a->clock_rate = !strcmp(optarg, "rate");
            break;
        case 'W': a->o.path = optarg; break;
        case 'n':
            if ((rc = dm_cli_parse_positive("plan", "--noise takes a value > 0 (Hz or m)", optarg,
                                            &a->o.noise)))
                return rc;
            break;
        case 'S':
            if (dm_cli_parse_int(optarg, 0, 2147483647, &seed))
                return dm_cli_usage("plan", "--seed takes a whole number >= 0", optarg);
            break;
        case 'M':
            if (dm_cli_parse_int(optarg, 1, DM_MAX_MODES, &a->o.modes))
                return dm_cli_usage("plan", "--modes takes 1.." DM_MAX_MODES_TEXT, optarg);
            break;
        default: assert(0);
        }
    }
    if (rc)
        return rc;
    if (!a->sh.robot || !a->have_kind || !a->effects || !a->o.npose)
        return dm_cli_usage("plan", "--robot, --kind, --effects and --poses are required", NULL);
    if (a->clock_rate && !a->o.nuisance)
        return dm_cli_usage("plan", "--clock needs --frame", NULL);
    a->o.nuisance += a->o.nuisance && a->clock_rate;
    a->o.seed = (uint64_t)seed;
    a->o.na = a->sh.na;
    a->o.nb = a->sh.nb;
    a->o.force_long = a->sh.force_long;
    dm_error err;
    if (dm_plan_parse_effects(a->effects, a->o.kind, a->eff, &a->neff, &err))
        return dm_cli_report(&err);
    return dm_cli_start(&a->sh, &a->o.threads, &a->rb);
}

static const char *unit_of(const dm_plan_result *r)
{
    return r->design.kind == DM_DATA_MODAL ? "Hz" : "m";
}

/* The detectable magnitude, in words fitting the kind of effect. */
static void print_detect(const dm_plan_effect *e, double v)
{
    const dm_effect *c = e->cand;
    if (c->nparam == 0)
        printf("moves the data by %.3g sigma", v);
    else if (!strncmp(c->name, "damping_", 8))
        printf("a change of %.3g %%", 100 * v);
    else if (c->linear)
        printf("from %.2g %s", v, c->unit);
    else if (v == 0 || !isfinite(v))
        printf("never");
    else if (c->lo < c->hi && strstr(c->unit, "N"))
        printf("up to %.2g %s", v, c->unit); /* springs: stiffer ones look rigid */
    else
        printf("from %.2g %s", v, c->unit);
}

/* The nuisances that mimic a confound most (|coefficient| >= 0.3 of the largest). */
static void print_like(const dm_plan_result *r, const double *like, char *buf, size_t len)
{
    size_t at = 0;
    buf[0] = 0;
    for (int k = 0; k < r->nnuisance && at < len; k++)
        if (fabs(like[k]) >= 0.3)
            at += snprintf(buf + at, len - at, "%s%s %+.2f", at ? ", " : "", dm_nuisance_name(k),
                           like[k]);
}

/* Each effect's combination least determined beyond the tracker's nuisances. */
static void print_confounds(const dm_plan_result *r)
{
    printf("\nnuisances %d fitted with every model (frame translation with the reflector offset, "
           "frame rotation,\n          clock offset%s): planned beyond them; per effect its "
           "least determined combination\n", r->nnuisance, r->nnuisance > 7 ? " and rate" : "");
    printf(" %-22s %-24s %10s %10s %7s  %s\n", "effect", "combination", "1-sig alone",
           "beyond", "lost", "mimicked by");
    for (int k = 0; k < r->nconfound; k++) {
        const dm_plan_confound *c = &r->confound[k];
        const dm_effect *e = r->effect[c->effect].cand;
        char combo[96] = "", like[256];
        for (int j = 0, at = 0; j < e->nparam && at < (int)sizeof combo; j++)
            at += snprintf(combo + at, sizeof combo - at, "%s%+.2f", j ? "," : "(", c->combo[j]);
        strncat(combo, ")", sizeof combo - strlen(combo) - 1);
        print_like(r, c->like, like, sizeof like);
        printf(" %-22s %-24s %10.2g %10.2g %6.1f%%  %s\n   %s\n", e->name, combo,
               c->sigma_alone, c->sigma, c->lost_percent, like,
               c->alike ? "-> not separated from the nuisances on this run"
               : c->sigma > DM_DIAG_DETERMINED ? "-> not determined, nuisances or not"
                                               : "-> separated from the nuisances");
    }
}

static void print_plan(const dm_robot *rb, const dm_plan_result *r)
{
    const dm_dataset *d = &r->design;
    int p = r->nparam;
    printf("robot     %s: a %s %s of %d %s planned from %d candidate %s (noise %g %s)\n",
           rb->name, dm_data_kind_name(d->kind), d->kind == DM_DATA_TRACKER ? "run" : "survey",
           d->npose, d->kind == DM_DATA_TRACKER ? "samples" : "poses", r->ncandidates,
           d->kind == DM_DATA_TRACKER ? "paths" : "poses", r->noise, unit_of(r));
    printf("design    D-optimal: information %.3gx that of the median random candidate per "
           "parameter\n          (log det F %.4g against %.4g)\n",
           exp((r->logdet - r->logdet_random) / p), r->logdet, r->logdet_random);
    if (d->kind == DM_DATA_TRACKER)
        printf("path      %s\n", r->path);
    printf("\n %-26s %-22s %-22s %-12s %s\n", "parameter", "assumed", "1-sigma planned",
           "random", "seen at 5 sigma");
    for (int e = 0, j = 0; e < r->neffect; e++) {
        const dm_plan_effect *ef = &r->effect[e];
        int np = ef->cand->nparam;
        for (int k = 0; k < (np ? np : 1); k++, j += np ? 1 : 0) {
            char name[96], assumed[64], planned[64], random[32];
            dm_effects_param_name(ef->cand, k, name, sizeof name);
            if (!np) {
                printf(" %-26s %-22s %-22s %-12s ", name, "on", "-", "-");
            } else {
                snprintf(assumed, sizeof assumed, "%.3g %s", ef->value[k], ef->cand->unit);
                snprintf(planned, sizeof planned, ef->cand->linear ? "%.2g" : "%.2g (%.2g %%)",
                         r->sigma[j], 100 * r->sigma[j] / fabs(ef->value[k]));
                snprintf(random, sizeof random, "%.2g", r->sigma_random[j]);
                printf(" %-26s %-22s %-22s %-12s ", name, assumed, planned, random);
            }
            if (k == 0)
                print_detect(ef, r->detect[e]);
            printf("\n");
        }
    }
    if (r->npair) {
        printf("\n %-50s %10s %14s\n", "pair", "angle", "joint 1-sigma");
        for (int k = 0; k < r->npair; k++) {
            const dm_plan_pair *pr = &r->pair[k];
            char name[128];
            snprintf(name, sizeof name, "%s / %s", r->effect[pr->a].cand->name,
                     r->effect[pr->b].cand->name);
            printf(" %-50s %6.1f deg %14.2g   %s\n", name, pr->angle_deg, pr->sigma,
                   pr->alike ? "indistinguishable on this experiment"
                             : "told apart");
        }
        printf(" (joint 1-sigma: of the pair's least determined combination, relative or in\n"
               "  units of the candidates' scale; above %g they stay look-alikes)\n",
               DM_DIAG_DETERMINED);
    }
    if (r->nnuisance)
        print_confounds(r);
    if (d->kind != DM_DATA_TRACKER) {
        printf("\nposes (x, y, z in m%s)\n", d->kind == DM_DATA_STATIC ? "; force in N" : "");
        for (int i = 0, last = -1; i < d->n; i++) {
            const dm_sample *s = &d->s[i];
            if (s->pose_id == last)
                continue;
            last = s->pose_id;
            printf("  %+.4f %+.4f %+.4f", s->P[0], s->P[1], s->P[2]);
            if (d->kind == DM_DATA_STATIC)
                printf("   F (%+.1f, %+.1f, %+.1f)", s->force[0], s->force[1], s->force[2]);
            printf("\n");
        }
    }
}

static json_t *confounds_json(const dm_plan_result *r)
{
    json_t *names = json_array(), *eff = json_array();
    for (int k = 0; k < r->nnuisance; k++)
        json_array_append_new(names, json_string(dm_nuisance_name(k)));
    for (int k = 0; k < r->nconfound; k++) {
        const dm_plan_confound *c = &r->confound[k];
        json_t *combo = json_array(), *like = json_object();
        for (int j = 0; j < r->effect[c->effect].cand->nparam; j++)
            json_array_append_new(combo, json_real(c->combo[j]));
        for (int j = 0; j < r->nnuisance; j++)
            json_object_set_new(like, dm_nuisance_name(j), json_real(c->like[j]));
        json_array_append_new(
            eff, json_pack("{s:s, s:o, s:o, s:o, s:f, s:o, s:b}", "effect",
                           r->effect[c->effect].cand->name, "combination", combo, "sigma_alone",
                           isfinite(c->sigma_alone) ? json_real(c->sigma_alone) : json_null(),
                           "sigma", isfinite(c->sigma) ? json_real(c->sigma) : json_null(),
                           "lost_percent", c->lost_percent, "mimicked_by", like,
                           "not_separated", c->alike));
    }
    return json_pack("{s:o, s:o}", "marginalised", names, "least_determined", eff);
}

static void print_plan_json(const dm_robot *rb, const dm_plan_result *r)
{
    const dm_dataset *d = &r->design;
    json_t *o = json_object(), *eff = json_array(), *pairs = json_array(), *poses = json_array();
    for (int e = 0, j = 0; e < r->neffect; e++) {
        const dm_plan_effect *ef = &r->effect[e];
        json_t *v = json_array(), *s = json_array(), *sr = json_array();
        for (int k = 0; k < ef->cand->nparam; k++, j++) {
            json_array_append_new(v, json_real(ef->value[k]));
            json_array_append_new(s, isfinite(r->sigma[j]) ? json_real(r->sigma[j]) : json_null());
            json_array_append_new(sr, isfinite(r->sigma_random[j]) ? json_real(r->sigma_random[j])
                                                                   : json_null());
        }
        json_array_append_new(
            eff, json_pack("{s:s, s:s, s:o, s:o, s:o, s:o}", "effect", ef->cand->name, "unit",
                           ef->cand->unit, "assumed", v, "sigma", s, "sigma_random", sr,
                           "detectable", isfinite(r->detect[e]) ? json_real(r->detect[e])
                                                                : json_null()));
    }
    for (int k = 0; k < r->npair; k++) {
        const dm_plan_pair *pr = &r->pair[k];
        json_array_append_new(
            pairs, json_pack("{s:s, s:s, s:o, s:o, s:b}", "a", r->effect[pr->a].cand->name, "b",
                             r->effect[pr->b].cand->name, "angle_deg",
                             isfinite(pr->angle_deg) ? json_real(pr->angle_deg) : json_null(),
                             "joint_sigma", isfinite(pr->sigma) ? json_real(pr->sigma) : json_null(),
                             "indistinguishable", pr->alike));
    }
    for (int i = 0, last = -1; i < d->n; i++) {
        const dm_sample *s = &d->s[i];
        if (s->pose_id == last)
            continue;
        last = s->pose_id;
        json_t *q = json_pack("[f,f,f]", s->P[0], s->P[1], s->P[2]);
        if (d->kind == DM_DATA_STATIC)
            q = json_pack("{s:o, s:[f,f,f]}", "pose", q, "force", s->force[0], s->force[1],
                          s->force[2]);
        else if (d->kind == DM_DATA_TRACKER)
            q = json_pack("{s:f, s:o}", "t", s->t, "pose", q);
        json_array_append_new(poses, q);
    }
    json_object_set_new(o, "robot", json_string(rb->name));
    json_object_set_new(o, "kind", json_string(dm_data_kind_name(d->kind)));
    json_object_set_new(o, "poses", json_integer(d->npose));
    json_object_set_new(o, "noise", json_real(r->noise));
    json_object_set_new(o, "candidates", json_integer(r->ncandidates));
    json_object_set_new(o, "logdet", json_real(r->logdet));
    json_object_set_new(o, "logdet_random", json_real(r->logdet_random));
    json_object_set_new(o, "path", d->kind == DM_DATA_TRACKER ? json_string(r->path) : json_null());
    json_object_set_new(o, "effects", eff);
    json_object_set_new(o, "pairs", pairs);
    json_object_set_new(o, "design", poses);
    if (r->nnuisance) /* absent without: plans without nuisances give what they gave */
        json_object_set_new(o, "nuisances", confounds_json(r));
    json_dumpf(o, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(12));
    putchar('\n');
    json_decref(o);
}

int dm_cli_plan(int argc, char **argv)
{
    plan_args a;
    int rc = parse(argc, argv, &a);
    if (rc)
        return rc;
    dm_error err;
    dm_plan_result r;
    dm_cli_progress view;
    a.o.progress = dm_cli_progress_init(&view, "plan", a.sh.progress);
    a.o.progress_user = &view;
    if ((rc = dm_plan(&a.rb, a.eff, a.neff, &a.o, &r, &err))) {
        dm_cli_progress_finish(&view);
        return dm_cli_report(&err);
    }
    dm_cli_progress_finish(&view);
    if (a.sh.json)
        print_plan_json(&a.rb, &r);
    else
        print_plan(&a.rb, &r);
    if (a.sh.out) {
        dm_file_out out;
        if (!(rc = dm_file_out_open(&out, a.sh.out, &err))) {
            dm_plan_write_template(&r, a.sh.robot, out.f);
            rc = dm_file_out_commit(&out, &err);
        }
        if (rc)
            dm_cli_report(&err);
        else if (!a.sh.json)
            printf("\nwritten   %s: the measurement template (fill in the measured values, then "
                   "deltamap diagnose)\n", a.sh.out);
    }
    dm_plan_free(&r);
    return rc;
}
