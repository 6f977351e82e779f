/* deltamap compare / diagnose / synth: the model against measured data. */
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
#include "dm_diagnose.h"
#include "dm_measure.h"
#include "dm_predict.h"
#include "dm_plan.h"
#include "dm_synth.h"

static const char COMPARE_HELP[] =
    "usage: deltamap compare --measured FILE [--robot R] [--mesh NA,NB] [--set K=V]...\n"
    "                        [--sigma S] [--out RESIDUALS.csv] [--json] [--after-nuisances]\n"
    "\n"
    "What the simulation gets wrong: residuals (measured - predicted) per sample\n"
    "and in summary (bias, RMS, normalised by sigma), where they are largest\n"
    "(which modes or directions, which poses) and whether they exceed the noise.\n"
    "--robot defaults to the file's '# robot:' line; --sigma gives the noise level\n"
    "(Hz or m) of samples whose file has none (tracker files never do). Plot with\n"
    "tools/plot_compare.py RESIDUALS.csv. --after-nuisances: a tracker run with\n"
    "'# frame:' (docs/measured-data.md) shown after its nuisances (frame, reflector\n"
    "offset, clock) are fitted to the robot file's prediction, and those printed.\n";

static const char DIAGNOSE_HELP[] =
    "usage: deltamap diagnose --measured FILE [--robot R] [--mesh NA,NB] [--set K=V]...\n"
    "                         [--sigma S] [--no-pairs] [--threads N]\n"
    "                         [--write-robot FILE] [--force-long] [--json]\n"
    "                         [--progress bar|lines|none]\n"
    "\n"
    "Fits every candidate effect of docs/model.md §6 (actuator, joint and base\n"
    "springs, payload, elbow masses, geometric stiffness, clearance; for tracker data also\n"
    "geometry errors per chain, their union, and Rayleigh damping alpha, beta) on two\n"
    "thirds of the data, scores it on the held-out third, ranks the effects, tries a\n"
    "second one, and says what is wrong. It names a cause only when the extended\n"
    "model's held-out residual is consistent with the noise (prediction chi-square\n"
    "within its 99.9 % band, and so for every mode or axis); otherwise it says what\n"
    "was found explains the data only in part and where the rest remains. It says\n"
    "which effects or parameter combinations these data cannot tell apart (plan an\n"
    "experiment that can: deltamap plan), or that nothing beats the noise. Without\n"
    "sigma (in the file or --sigma) whether anything remains cannot be judged. Fits\n"
    "run on --threads N (default: all cores; the result does not depend on it).\n"
    "--write-robot writes the extended robot file. Data whose diagnosis is estimated\n"
    "at more than 4 hours on its threads are refused before any fit unless\n"
    "--force-long. --progress: how far the fits are, on stderr, with an ETA per\n"
    "stage (single effects, second effect, verdict checks): a bar (the default\n"
    "when stderr is a terminal), lines, or none (the default otherwise).\n";

static const char SYNTH_HELP[] =
    "usage: deltamap synth --robot R --kind modal|static|tracker [--effect NAME=VALUE]...\n"
    "                      [--noise X] [--poses N] [--modes K] [--seed S] [--path P]\n"
    "                      [--at TEMPLATE] [--mesh NA,NB] [--force-long] [--out FILE]\n"
    "                      [--pairing dir|shapes] [--drop-mode N] [--extra-mode HZ,DIR]\n"
    "\n"
    "Synthetic measured data from the robot extended by the given effects, with\n"
    "Gaussian noise (Hz for modal, m otherwise), in the formats of\n"
    "docs/measured-data.md: check whether an experiment can identify an effect before running it. Poses\n"
    "are drawn about home, or --at takes them (and modes, forces, times) from a\n"
    "measurement template such as `deltamap plan --out` writes (the kind is then\n"
    "the template's). Data that would take more than 4 hours or 2 GB to make are\n"
    "refused before any work unless --force-long.\n"
    "A modal survey as a modal test gives it (docs/measured-data.md, 'Mode shapes\n"
    "and pairing'): --pairing dir writes each mode's dominant direction, shapes\n"
    "also its shape at 19 sensors; --drop-mode N leaves the model's mode N out,\n"
    "--extra-mode HZ,DIR adds a local mode the model lacks (both imply dir).\n"
    "Effects: actuator_stiffness, joint_stiffness, base_stiffness,\n"
    "base_stiffness_0/1/2 (N/m, isotropic), payload_mass, elbow_mass (kg),\n"
    "geometric_stiffness=on, damping_alpha (1/s), damping_beta (s), clearance,\n"
    "actuator_clearance_axial, actuator_clearance_radial (m), and the geometry\n"
    "errors per chain\n"
    "error_arm_length, error_rod_length, error_base_radius, error_platform_radius\n"
    "(m), error_theta_deg, error_alpha0_deg (deg) as =C0,C1,C2.\n";

typedef struct {
    dm_cli_shared sh; /* --robot, --set, --mesh, --threads, --json, --out; diagnose also
                         --progress, --force-long */
    const char *measured, *write_robot;
    int pairs;
    int after_nuisances; /* compare: residuals after the tracker's nuisances */
    double sigma;       /* --sigma: noise level for samples that give none */
} measure_args;

static int parse(const char *cmd, const char *help, int argc, char **argv, measure_args *a)
{
    static const struct option own[] = {
        {"measured", 1, 0, 'd'}, {"write-robot", 1, 0, 'w'}, {"no-pairs", 0, 0, 'P'},
        {"sigma", 1, 0, 'S'},    {"after-nuisances", 0, 0, 'A'}, {0, 0, 0, 0}};
    int c, rc;
    memset(a, 0, sizeof *a);
    dm_cli_begin(&a->sh, cmd, help, own,
                 DM_CLI_ROBOT | DM_CLI_SET | DM_CLI_MESH | DM_CLI_THREADS | DM_CLI_JSON |
                     DM_CLI_OUT |
                     (strcmp(cmd, "diagnose") ? 0 : DM_CLI_PROGRESS | DM_CLI_FORCE_LONG),
                 DM_CLI_PROGRESS_NONE);
    a->pairs = 1;
    while ((c = dm_cli_getopt(argc, argv, &a->sh, &rc))) {
        switch (c) {
        case 'd': a->measured = optarg; break;
        case 'w': a->write_robot = optarg; break;
        case 'P': a->pairs = 0; break;
        case 'A':
            if (strcmp(cmd, "compare"))
                return dm_cli_usage(cmd, "unknown or incomplete option", argv[optind - 1]);
            a->after_nuisances = 1;
            break;
        case 'S':
            if ((rc = dm_cli_parse_positive(cmd, "--sigma takes the noise level > 0 (Hz or m)",
                                            optarg, &a->sigma)))
                return rc;
            break;
        default: assert(0);
        }
    }
    if (rc)
        return rc;
    if (!a->measured)
        return dm_cli_usage(cmd, "--measured is required", NULL);
    return 0;
}

/* Read the data and the robot (the command line wins over the file). */
static int load(const measure_args *a, dm_dataset *d, dm_robot *rb, dm_error *err)
{
    int rc = dm_dataset_read(a->measured, d, err);
    if (rc)
        return rc;
    for (int i = 0; i < d->n && a->sigma > 0; i++)
        if (!(d->s[i].sigma > 0))
            d->s[i].sigma = a->sigma;
    const char *spec = a->sh.robot ? a->sh.robot : d->robot[0] ? d->robot : NULL;
    if (!spec) {
        dm_dataset_free(d);
        return dm_fail(err, DM_EINVAL, "%s names no robot ('# robot: NAME'); give --robot",
                       a->measured);
    }
    rc = dm_cli_load_robot(spec, a->sh.sets, a->sh.nset, rb, err);
    if (rc)
        dm_dataset_free(d);
    return rc;
}

static const char *label(const dm_dataset *d, const dm_sample *s, char *buf, size_t n)
{
    if (d->kind == DM_DATA_MODAL)
        snprintf(buf, n, "mode %d", s->mode);
    else if (d->kind == DM_DATA_TRACKER) /* when, too: a run's error is a story in time */
        snprintf(buf, n, "%c at t = %.4g s", "xyz"[s->comp], s->t);
    else
        snprintf(buf, n, "%c", "xyz"[s->comp]);
    return buf;
}

/* ---- compare ------------------------------------------------------------------ */

static void group_name(const dm_dataset *d, int k, char *buf, size_t n)
{
    if (d->kind == DM_DATA_MODAL)
        snprintf(buf, n, "%d", k + 1);
    else
        snprintf(buf, n, "%c", "xyz"[k]);
}

typedef struct {
    double bias, rms, chi2;
    int n;
} stats;

static void accumulate(stats *st, double r, double sigma)
{
    st->bias += r;
    st->rms += r * r;
    st->chi2 += sigma > 0 ? r * r / (sigma * sigma) : 0;
    st->n++;
}

static void finish(stats *st)
{
    if (st->n) {
        st->bias /= st->n;
        st->rms = sqrt(st->rms / st->n);
    }
}

/* ---- mode pairing (dm_pairing.h) -------------------------------------------- */

static void print_pairing(const dm_pairing *pg)
{
    printf("pairing   %d of %d measured modes paired by %s\n", pg->npaired, pg->n,
           pg->by_mac ? "MAC of the shapes at the sensors" : "frequency and dominant direction");
    printf("  line  pose  mode  measured Hz  dir  -> model  model Hz  dir%s\n",
           pg->by_mac ? "    MAC" : "");
    for (int i = 0; i < pg->n; i++) {
        const dm_pair *p = &pg->pair[i];
        printf("  %4d  %4d  %4d  %11.5g  %-3s", p->line, p->pose_id + 1, p->label,
               p->freq_meas, dm_direction_name(p->dir_meas));
        if (p->model_mode)
            printf("  -> %5d  %8.5g  %-3s", p->model_mode, p->freq_model,
                   dm_direction_name(p->dir_model));
        else
            printf("  -> unpaired (no model mode admissible)");
        printf(pg->by_mac ? "  %5.3f\n" : "\n", p->mac);
    }
    for (int k = 0; k < pg->npose; k++)
        for (int r = 0; r < 64; r++)
            if (pg->skipped[k] >> r & 1)
                printf("  pose %d: model mode %d not measured (skipped)\n", k + 1, r + 1);
}

static json_t *pairing_json(const dm_pairing *pg)
{
    json_t *modes = json_array(), *skipped = json_array();
    for (int i = 0; i < pg->n; i++) {
        const dm_pair *p = &pg->pair[i];
        json_t *m = json_pack("{s:i, s:i, s:i, s:f, s:o}", "line", p->line, "pose",
                              p->pose_id + 1, "mode", p->label, "freq_hz", p->freq_meas, "dir",
                              p->dir_meas >= 0 ? json_string(dm_direction_name(p->dir_meas))
                                               : json_null());
        json_object_set_new(m, "model_mode", p->model_mode ? json_integer(p->model_mode)
                                                           : json_null());
        json_object_set_new(m, "model_freq_hz", p->model_mode ? json_real(p->freq_model)
                                                              : json_null());
        json_object_set_new(m, "model_dir", p->model_mode ? json_string(dm_direction_name(
                                                                p->dir_model))
                                                          : json_null());
        json_object_set_new(m, "mac", pg->by_mac ? json_real(p->mac) : json_null());
        json_array_append_new(modes, m);
    }
    for (int k = 0; k < pg->npose; k++)
        for (int r = 0; r < 64; r++)
            if (pg->skipped[k] >> r & 1)
                json_array_append_new(skipped, json_pack("{s:i, s:i}", "pose", k + 1,
                                                         "model_mode", r + 1));
    return json_pack("{s:s, s:i, s:o, s:o}", "by", pg->by_mac ? "mac" : "direction", "paired",
                     pg->npaired, "modes", modes, "skipped", skipped);
}

/* A survey with shapes or directions: its modes paired with the robot's
 * and *d made the survey of the paired ones; pg->pair NULL for others. */
static int pair_survey(const measure_args *a, const dm_robot *rb, dm_dataset *d, dm_pairing *pg,
                       dm_error *err)
{
    dm_dataset paired;
    memset(pg, 0, sizeof *pg);
    if (d->kind != DM_DATA_MODAL || !d->pair)
        return DM_OK;
    int rc = dm_pairing_make(rb, d, a->sh.na, a->sh.nb, pg, err);
    if (!rc && (rc = dm_pairing_apply(d, pg, &paired, err)))
        dm_pairing_free(pg);
    if (!rc) {
        dm_dataset_free(d);
        *d = paired;
    }
    return rc;
}

/* Fitted nuisances, one a line, then the combinations determined of those
 * that are not (diagnose and compare --after-nuisances). */
static void print_nuisance_values(const dm_nuisance_fit *nf)
{
    for (int k = 0; k < nf->n; k++) {
        printf("          %-20s %12.4g +- ", dm_nuisance_name(k), nf->value[k]);
        if (isfinite(nf->sigma[k]))
            printf("%-9.2g %s\n", nf->sigma[k], dm_nuisance_unit(k));
        else
            printf("%-9s %s (not determined by this path)\n", "inf", dm_nuisance_unit(k));
    }
    for (int c = 0; c < nf->ncombination; c++) {
        const dm_nuisance_combination *cb = &nf->combination[c];
        printf("          determined: %s", dm_nuisance_name(cb->ref));
        for (int k = 0; k < nf->n; k++)
            if (k != cb->ref && cb->coef[k] != 0)
                printf(" %+.4g %s", cb->coef[k], dm_nuisance_name(k));
        printf(" = %.4g +- %.2g %s\n", cb->value, cb->sigma, dm_nuisance_unit(cb->ref));
    }
}

static json_t *nuisance_values_json(const dm_nuisance_fit *nf)
{
    json_t *par = json_object();
    for (int k = 0; k < nf->n; k++)
        json_object_set_new(par, dm_nuisance_name(k),
                            json_pack("{s:f, s:o, s:s}", "value", nf->value[k], "sigma",
                                      isfinite(nf->sigma[k]) ? json_real(nf->sigma[k])
                                                             : json_null(),
                                      "unit", dm_nuisance_unit(k)));
    return par;
}

/* The determined combinations: [{"of": {name: coefficient}, value, sigma, unit}]. */
static json_t *nuisance_combinations_json(const dm_nuisance_fit *nf)
{
    json_t *list = json_array();
    for (int c = 0; c < nf->ncombination; c++) {
        const dm_nuisance_combination *cb = &nf->combination[c];
        json_t *of = json_object();
        for (int k = 0; k < nf->n; k++)
            if (cb->coef[k] != 0)
                json_object_set_new(of, dm_nuisance_name(k), json_real(cb->coef[k]));
        json_array_append_new(list, json_pack("{s:o, s:f, s:f, s:s}", "of", of, "value",
                                              cb->value, "sigma", cb->sigma, "unit",
                                              dm_nuisance_unit(cb->ref)));
    }
    return list;
}

int dm_cli_compare(int argc, char **argv)
{
    dm_cli_serial_blas();
    measure_args a;
    int rc = parse("compare", COMPARE_HELP, argc, argv, &a);
    if (rc)
        return rc;
    dm_dataset d;
    dm_robot rb;
    dm_error err;
    dm_pairing pg;
    if ((rc = load(&a, &d, &rb, &err)))
        return dm_cli_report(&err);
    if ((rc = pair_survey(&a, &rb, &d, &pg, &err))) {
        dm_dataset_free(&d);
        return dm_cli_report(&err);
    }
    double *pred = malloc(sizeof(double) * d.n);
    dm_nuisance_fit nf = {0};
    if (!pred || (rc = dm_predict(&rb, &d, a.sh.na, a.sh.nb, pred, &err)) ||
        (a.after_nuisances && (rc = dm_nuisance_fit_all(&d, pred, &nf, &err)))) {
        free(pred);
        dm_pairing_free(&pg);
        dm_dataset_free(&d);
        return dm_cli_report(rc ? &err : (dm_fail(&err, DM_ENOMEM, "out of memory"), &err));
    }
    int sigma = 1, groups = d.kind == DM_DATA_MODAL ? DM_MAX_MODES : 3, worst[5] = {-1, -1, -1, -1, -1};
    stats all = {0}, by[DM_MAX_MODES] = {{0}};
    for (int i = 0; i < d.n; i++) {
        const dm_sample *s = &d.s[i];
        double r = s->value - pred[i];
        sigma &= s->sigma > 0;
        accumulate(&all, r, s->sigma);
        accumulate(&by[d.kind == DM_DATA_MODAL ? s->mode - 1 : s->comp], r, s->sigma);
        double z = fabs(r) / (s->sigma > 0 ? s->sigma : 1);
        for (int w = 0; w < 5; w++) {
            int j = worst[w];
            if (j < 0 || z > fabs(d.s[j].value - pred[j]) / (d.s[j].sigma > 0 ? d.s[j].sigma : 1)) {
                memmove(worst + w + 1, worst + w, sizeof(int) * (4 - w));
                worst[w] = i;
                break;
            }
        }
    }
    finish(&all);
    for (int g = 0; g < groups; g++)
        finish(&by[g]);
    double limit = all.n + 4 * sqrt(2.0 * all.n);
    int exceeds = sigma && all.chi2 > limit;
    const char *unit = d.kind == DM_DATA_MODAL ? "Hz" : "m";
    if (a.sh.json) {
        json_t *o = json_pack("{s:s, s:s, s:s, s:i, s:f, s:f}", "robot", rb.name, "measured",
                              a.measured, "kind", dm_data_kind_name(d.kind), "samples", d.n,
                              "bias", all.bias, "rms", all.rms);
        json_object_set_new(o, "chi2_per_sample", sigma ? json_real(all.chi2 / all.n) : json_null());
        json_object_set_new(o, "exceeds_noise", sigma ? json_boolean(exceeds) : json_null());
        json_t *g = json_array();
        for (int k = 0; k < groups; k++) {
            char name[16];
            if (!by[k].n)
                continue;
            group_name(&d, k, name, sizeof name);
            json_array_append_new(g, json_pack("{s:s, s:i, s:f, s:f}", "group", name, "samples",
                                               by[k].n, "bias", by[k].bias, "rms", by[k].rms));
        }
        json_object_set_new(o, "groups", g);
        if (pg.pair) /* modal surveys with shapes or directions only */
            json_object_set_new(o, "pairing", pairing_json(&pg));
        if (nf.n) { /* --after-nuisances: the residuals above are after them */
            json_object_set_new(o, "nuisances_fitted", nuisance_values_json(&nf));
            json_object_set_new(o, "nuisance_combinations", nuisance_combinations_json(&nf));
        }
        json_dumpf(o, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(12));
        putchar('\n');
        json_decref(o);
    } else {
        printf("robot     %s against %s (%s data, %d samples)\n", rb.name, a.measured,
               dm_data_kind_name(d.kind), d.n);
        printf("overall   bias %+.4g %s, RMS %.4g %s", all.bias, unit, all.rms, unit);
        if (sigma)
            printf(", chi2/N %.3g (noise alone: 1 +- %.2g)", all.chi2 / all.n, 4 * sqrt(2.0 / all.n));
        if (pg.pair) {
            printf("\n");
            print_pairing(&pg);
        }
        if (nf.n) {
            printf("\nnuisances fitted to the robot file's prediction; the residuals are after "
                   "them:\n");
            print_nuisance_values(&nf);
            printf("          (the translation includes the reflector offset's error; rotations "
                   "about the run's centroid)");
        }
        printf("\n\n %-8s %6s %12s %12s %10s\n", d.kind == DM_DATA_MODAL ? "mode" : "axis", "n",
               "bias", "RMS", sigma ? "chi2/n" : "");
        for (int k = 0; k < groups; k++) {
            char name[16];
            if (!by[k].n)
                continue;
            group_name(&d, k, name, sizeof name);
            printf(" %-8s %6d %+12.4g %12.4g %10.3g\n", name, by[k].n, by[k].bias, by[k].rms,
                   sigma ? by[k].chi2 / by[k].n : 0.0);
        }
        printf("\nlargest residuals (file line, pose, what, measured, predicted)\n");
        for (int w = 0; w < 5 && worst[w] >= 0; w++) {
            const dm_sample *s = &d.s[worst[w]];
            char lb[32];
            printf("  line %-5d (%+.3f, %+.3f, %+.3f) m  %-7s %.6g  %.6g %s\n", s->line, s->P[0],
                   s->P[1], s->P[2], label(&d, s, lb, sizeof lb), s->value, pred[worst[w]], unit);
        }
        printf("\nverdict   %s\n", !sigma ? "no sigma given: cannot tell misfit from noise"
                                   : exceeds ? "the residuals exceed the noise: the model misses something (try deltamap diagnose)"
                                             : "the residuals are within the noise");
    }
    if (a.sh.out) {
        dm_file_out out;
        if ((rc = dm_file_out_open(&out, a.sh.out, &err)) == DM_OK) {
            /* modal: the mode rank; deflections and tracker errors: the axis
             * (0, 1, 2 = x, y, z); tracker data also the time */
            int modal = d.kind == DM_DATA_MODAL, tracker = d.kind == DM_DATA_TRACKER;
            fprintf(out.f, "line,%sx,y,z,%s,measured,predicted,residual,normalised\n",
                    tracker ? "t," : "", modal ? "mode" : "axis");
            for (int i = 0; i < d.n; i++) {
                const dm_sample *s = &d.s[i];
                double r = s->value - pred[i];
                fprintf(out.f, "%d,", s->line);
                if (tracker)
                    fprintf(out.f, "%.9g,", s->t);
                fprintf(out.f, "%.9g,%.9g,%.9g,%d,%.12g,%.12g,%.6g,%.6g\n", s->P[0], s->P[1],
                        s->P[2], modal ? s->mode : s->comp, s->value, pred[i], r,
                        s->sigma > 0 ? r / s->sigma : r);
            }
            rc = dm_file_out_commit(&out, &err);
        }
        if (rc)
            dm_cli_report(&err);
    }
    free(pred);
    dm_pairing_free(&pg);
    dm_dataset_free(&d);
    return rc;
}

/* ---- diagnose ---------------------------------------------------------------- */

static void fit_name(const dm_fit *f, char *buf, size_t n)
{
    snprintf(buf, n, "%s%s%s", f->cand[0]->name, f->ncand > 1 ? " + " : "",
             f->ncand > 1 ? f->cand[1]->name : "");
}

static json_t *list_json(const double *v, int n)
{
    json_t *a = json_array();
    for (int k = 0; k < n; k++)
        json_array_append_new(a, json_real(isfinite(v[k]) ? v[k] : -1.0));
    return a;
}

/* One effect's fitted values: a number, a list per chain, or (the union
 * of the geometry families) a list per family. */
static json_t *values_json(const dm_fit *f, int i, const double *v)
{
    const dm_effect *c = f->cand[i];
    if (c->nparam <= 1)
        return json_real(v[0]);
    if (c->nparam == 3)
        return list_json(v, 3);
    json_t *o = json_object();
    for (int g = 0; g < c->nparam / 3; g++)
        json_object_set_new(o, dm_effects_family(g)->name, list_json(v + 3 * g, 3));
    return o;
}

static json_t *params_json(const dm_fit *f)
{
    json_t *params = json_object();
    for (int i = 0; i < f->ncand; i++)
        json_object_set_new(params, f->cand[i]->name,
                            json_pack("{s:o, s:o, s:s}", "value", values_json(f, i, f->value[i]),
                                      "sigma", values_json(f, i, f->sigma[i]), "unit",
                                      f->cand[i]->unit));
    return params;
}

/* How far a fit's tracker nuisances moved from the baseline's (dm_nuisance_shift). */
static json_t *shift_json(const dm_nuisance_shift *sh)
{
    json_t *delta = json_object();
    for (int k = 0; k < sh->n; k++)
        json_object_set_new(delta, dm_nuisance_name(k), json_real(sh->delta[k]));
    return json_pack("{s:o, s:f, s:f, s:f, s:b}", "delta", delta, "sigmas", sh->sigmas,
                     "rms_m", sh->rms_m, "at_baseline_train_chi2", sh->at_baseline_chi2,
                     "compensating", sh->compensating);
}

static json_t *fit_json(const dm_fit *f)
{
    char name[128];
    fit_name(f, name, sizeof name);
    json_t *o = json_pack("{s:s, s:o, s:b, s:f, s:f, s:f, s:f, s:i}", "effect", name,
                          "parameters", params_json(f), "ok", f->ok, "held_out_chi2",
                          f->held_chi2, "held_out_rms", f->held_rms, "gain_percent",
                          f->gain_percent, "score", f->score, "parameters_fitted", f->nfree);
    if (f->shift.n) /* absent without nuisances: files without them give what they gave */
        json_object_set_new(o, "nuisance_shift", shift_json(&f->shift));
    return o;
}

static void print_triple(const double *v, const double *sg, const char *unit)
{
    for (int k = 0; k < 3; k++)
        printf("%s%.4g +- %.2g", k ? ", " : "(", v[k], sg[k]);
    printf(") %s", unit);
}

static void print_values(const dm_fit *f)
{
    for (int i = 0; i < f->ncand; i++) {
        const dm_effect *c = f->cand[i];
        printf("%s%s", i ? ", " : "", c->name);
        if (c->nparam == 0) {
            printf(" on");
        } else if (c->nparam == 1) {
            printf(" = %.4g +- %.2g %s", f->value[i][0], f->sigma[i][0], c->unit);
        } else if (c->nparam == 3) {
            printf(" = ");
            print_triple(f->value[i], f->sigma[i], c->unit);
        } else {
            for (int g = 0; g < c->nparam / 3; g++) {
                const dm_effect *fam = dm_effects_family(g);
                printf("%s%s = ", g ? ", " : ": ", fam->name);
                print_triple(f->value[i] + 3 * g, f->sigma[i] + 3 * g, fam->unit);
            }
        }
    }
}

/* The best single effect that is not part of the verdict and explains
 * rather than compensates. */
static const dm_fit *runner_up(const dm_diagnosis *dg)
{
    for (int r = 0; r < dg->nrank; r++) {
        int in_verdict = 0;
        for (int i = 0; i < dg->best.ncand; i++)
            in_verdict |= dg->rank[r].cand[0] == dg->best.cand[i];
        if (!in_verdict && dg->rank[r].ok && !dg->rank[r].shift.compensating)
            return &dg->rank[r];
    }
    return NULL;
}

/* Name of parameter j of a fit (its effects' parameters in order). */
static void param_name(const dm_fit *f, int j, char *buf, size_t n)
{
    for (int i = 0; i < f->ncand; j -= f->cand[i]->nparam, i++)
        if (j < f->cand[i]->nparam) {
            dm_effects_param_name(f->cand[i], j, buf, n);
            return;
        }
    snprintf(buf, n, "?");
}

/* Combination k of the identifiability analysis, by its large weights. */
static void print_combination(const dm_fit *f, const dm_ident *id, int k)
{
    for (int j = 0, first = 1; j < id->n; j++)
        if (fabs(id->weight[k][j]) >= 0.3) {
            char pn[96];
            param_name(f, j, pn, sizeof pn);
            printf("%s%.2f %s", first ? "" : id->weight[k][j] < 0 ? " - " : " + ",
                   first ? id->weight[k][j] : fabs(id->weight[k][j]), pn);
            first = 0;
        }
}

static void print_ident(const dm_dataset *d, const dm_robot *rb, const dm_diagnosis *dg)
{
    const dm_ident *id = &dg->ident;
    if (id->n < 2)
        return;
    printf("          Of its %d parameters these data determine %d combination%s (1-sigma <= "
           "%g)",
           id->n, id->ndetermined, id->ndetermined == 1 ? "" : "s", DM_DIAG_DETERMINED);
    if (id->ndetermined == id->n) {
        printf(": all of them.\n");
        return;
    }
    printf("; not determined:\n");
    int mixed = 0;
    for (int k = id->ndetermined, shown = 0; k < id->n && shown < 4; k++, shown++) {
        int big = 0;
        for (int j = 0; j < id->n; j++)
            big += fabs(id->weight[k][j]) >= 0.3;
        mixed |= big > 1;
        printf("            ");
        print_combination(&dg->best, id, k);
        printf("  (1-sigma %.2g)\n", id->sigma[k]);
    }
    if (id->n - id->ndetermined > 4)
        printf("            and %d more\n", id->n - id->ndetermined - 4);
    printf("          (weights on the parameters in units of their scale: relative for springs,\n"
           "          masses and damping, 0.1 mm and 0.05 deg for geometry errors).");
    if (mixed) {
        printf(" To tell them\n          apart, plan an experiment: deltamap plan --robot %s --kind %s "
               "--effects ", rb->name, dm_data_kind_name(d->kind));
        for (int i = 0; i < dg->best.ncand; i++)
            printf("%s%s", i ? "," : "", dg->best.cand[i]->name);
        printf(" --poses N");
    }
    printf("\n");
}

static void group_label(const dm_dataset *d, int g, char *buf, size_t n)
{
    if (d->kind == DM_DATA_MODAL)
        snprintf(buf, n, "mode %d", g);
    else
        snprintf(buf, n, "%c", "xyz"[g]);
}

/* Where the misfit remains: the groups beyond their limit (or, if none
 * is alone, the largest), and the poses or times carrying half of it. */
static void print_remains(const dm_dataset *d, const dm_noise_test *t)
{
    int any = 0, worst = 0;
    for (int k = 0; k < t->ngroup; k++) {
        any |= t->group[k].chi2 > t->group[k].limit;
        if (t->group[k].chi2 / t->group[k].n > t->group[worst].chi2 / t->group[worst].n)
            worst = k;
    }
    printf("          It remains in");
    for (int k = 0, shown = 0; k < t->ngroup; k++)
        if (any ? t->group[k].chi2 > t->group[k].limit : k == worst) {
            char lb[16];
            group_label(d, t->group[k].group, lb, sizeof lb);
            printf("%s%s %s (%s%.3g)", shown ? "," : "", shown && shown % 4 == 0 ? "\n         " : "",
                   lb, shown ? "" : "chi2/n ", t->group[k].chi2 / t->group[k].n);
            shown++;
        }
    if (t->nregion > 0 && d->kind == DM_DATA_TRACKER)
        printf(",\n          most at t = %.4g..%.4g s (%d of %d held-out times carry half of it)",
               t->t_lo, t->t_hi, t->nregion, t->nposes);
    else if (t->nregion > 0)
        printf(",\n          most at x %+.3f..%+.3f, y %+.3f..%+.3f, z %+.3f..%+.3f m\n"
               "          (%d of %d held-out poses carry half of it)",
               t->lo[0], t->hi[0], t->lo[1], t->hi[1], t->lo[2], t->hi[2], t->nregion, t->nposes);
    printf(".\n");
}

static void print_ties(const dm_diagnosis *dg)
{
    if (dg->ntie) {
        printf("          These data cannot tell %s from", dg->best.cand[0]->name);
        for (int t = 0; t < dg->ntie; t++)
            printf("%s %s", t ? (t + 1 < dg->ntie ? "," : " or") : "",
                   dg->rank[dg->tie[t]].cand[0]->name);
        printf("\n          (scores within %g): either explains them; other data must decide\n"
               "          (deltamap plan --effects %s", DM_DIAG_TIE, dg->best.cand[0]->name);
        for (int t = 0; t < dg->ntie; t++)
            printf(",%s", dg->rank[dg->tie[t]].cand[0]->name);
        printf(" says which can).\n");
    }
    if (dg->has_simpler_choice) {
        char a[128], b[128];
        fit_name(&dg->passed_over, a, sizeof a);
        fit_name(&dg->best, b, sizeof b);
        printf("          %s scores %.1f better, not clearly (%g) enough to prefer it to the\n"
               "          simpler %s.\n",
               a, dg->best.score - dg->passed_over.score, DM_DIAG_CLEAR, b);
    }
}

/* A model set aside as compensating: how far its nuisances moved from the
 * baseline's, statistically and physically, and against what. */
static void print_set_aside(const dm_diagnosis *dg, const dm_fit *f)
{
    const dm_nuisance_shift *sh = &f->shift;
    char name[128];
    fit_name(f, name, sizeof name);
    printf("          Set aside: %s (gain %.1f %%) compensates, it does not\n"
           "          explain: its nuisances moved %.3g mm RMS at the samples from the baseline's\n"
           "          (%.3g sigma of theirs; frame translation %+.3g, %+.3g, %+.3g mm, rotation %+.3g,\n"
           "          %+.3g, %+.3g mrad, clock %+.3g us), beyond %.3g mm, and held where the baseline\n"
           "          put them they leave it worse than the baseline (training chi2 x%.3g).\n",
           name, f->gain_percent, 1e3 * sh->rms_m, sh->sigmas, 1e3 * sh->delta[0],
           1e3 * sh->delta[1], 1e3 * sh->delta[2], 1e3 * sh->delta[3], 1e3 * sh->delta[4],
           1e3 * sh->delta[5], 1e6 * sh->delta[6], 1e3 * dg->compensating_m,
           sh->at_baseline_chi2 / dg->base_train_chi2);
}

static void print_verdict(const dm_dataset *d, const dm_robot *rb, const dm_diagnosis *dg)
{
    const char *unit = d->kind == DM_DATA_MODAL ? "Hz" : "m";
    const dm_noise_test *t = &dg->noise;
    char name[128];
    fit_name(&dg->best, name, sizeof name);
    printf("\nverdict   ");
    if (!dg->significant) {
        printf("no significant discrepancy: the baseline fits the held-out data within the "
               "noise; nothing to fix.\n");
    } else if (!dg->found && !dg->sigma_known) {
        printf("no candidate effect explains the residuals (RMS %.4g %s) better than chance.\n"
               "          The file gives no sigma, so whether they exceed the noise is unknown: "
               "give --sigma.\n",
               dg->base_held_rms, unit);
    } else if (!dg->found) {
        printf("the model misses something (held-out chi2/N %.3g), but no candidate effect "
               "beats the noise; the cause is outside the candidates.\n",
               dg->base_held_chi2 / dg->n_held);
    } else if (!dg->sigma_known) {
        printf("%s lowers the held-out RMS %.4g -> %.4g %s (gain %.1f %%): ", name,
               dg->base_held_rms, dg->best.held_rms, unit, dg->best.gain_percent);
        print_values(&dg->best);
        printf(".\n          The file gives no sigma, so whether it explains the data or "
               "something else remains\n          cannot be judged: give --sigma.\n");
    } else if (dg->explained) {
        printf("the model is wrong about the %s data (held-out RMS %.4g %s against noise); the "
               "cause is %s: ",
               dm_data_kind_name(d->kind), dg->base_held_rms, unit, name);
        print_values(&dg->best);
        printf(".\n          Held-out RMS %.4g -> %.4g %s, gain %.1f %%; chi2/N %.3g, within the "
               "noise (<= %.3g).",
               dg->base_held_rms, dg->best.held_rms, unit, dg->best.gain_percent,
               t->chi2 / t->n, t->limit / t->n);
        const dm_fit *ru = runner_up(dg);
        if (ru)
            printf(" Runner-up: %s (gain %.1f %%).", ru->cand[0]->name, ru->gain_percent);
        printf("\n");
    } else {
        printf("partly explained by %s (", name);
        print_values(&dg->best);
        printf(");\n          the residual is still %.3g sigma (held-out chi2/N %.3g, noise "
               "<= %.3g): something outside\n          the candidates remains. Held-out RMS "
               "%.4g -> %.4g %s, gain %.1f %%.\n",
               t->sigmas, t->chi2 / t->n, t->limit / t->n, dg->base_held_rms, dg->best.held_rms,
               unit, dg->best.gain_percent);
        print_remains(d, t);
    }
    if (dg->found) {
        print_ties(dg);
        print_ident(d, rb, dg);
    }
    for (int k = 0; dg->significant && k < dg->nset_aside; k++)
        print_set_aside(dg, &dg->set_aside[k]);
}

/* A tracker run's nuisances: fitted with every model, never a cause. */
static void print_nuisances(const dm_dataset *d, const dm_diagnosis *dg)
{
    printf("nuisances fitted with every model (of the %s; never a cause):\n",
           dg->found ? "verdict's model" : "baseline");
    print_nuisance_values(&dg->nuisance);
    printf("          (the translation is the frame's plus the reflector offset's error: only "
           "their sum is determined; rotations about the run's centroid)\n");
    if (d->nuisance.tracker_frame)
        printf("          tracker frame placed on reading, RMS %.3g m\n", d->nuisance.align_rms);
    printf("          baseline held-out RMS without them %.4g m -> %.4g m with them (gain %.1f "
           "%%, apart from any effect's%s)", dg->raw_held_rms, dg->base_held_rms,
           dg->nuisance_gain_percent,
           d->nuisance.tracker_frame ? "; without them: the frame placed on the training part" : "");
}

static json_t *nuisance_json(const dm_dataset *d, const dm_diagnosis *dg)
{
    json_t *par = nuisance_values_json(&dg->nuisance);
    json_t *o = json_pack("{s:s, s:o, s:b, s:f, s:f, s:f, s:f}", "of",
                          dg->found ? "verdict" : "baseline", "parameters", par,
                          "translation_includes_reflector_offset", 1,
                          "baseline_without_nuisances_held_out_rms", dg->raw_held_rms,
                          "baseline_without_nuisances_held_out_chi2", dg->raw_held_chi2,
                          "gain_percent", dg->nuisance_gain_percent, "compensating_above_m",
                          dg->compensating_m);
    json_object_set_new(o, "determined_combinations", nuisance_combinations_json(&dg->nuisance));
    if (d->nuisance.tracker_frame)
        json_object_set_new(o, "tracker_frame",
                            json_pack("{s:o, s:o, s:f}", "R", list_json(d->nuisance.R, 9), "d",
                                      list_json(d->nuisance.d, 3), "rms", d->nuisance.align_rms));
    return o;
}

static void print_diagnosis(const dm_dataset *d, const dm_robot *rb, const dm_diagnosis *dg)
{
    const char *unit = d->kind == DM_DATA_MODAL ? "Hz" : "m";
    printf("robot     %s against %s (%s data: %d training, %d held-out samples)\n", rb->name,
           d->source, dm_data_kind_name(d->kind), dg->n_train, dg->n_held);
    if (dg->pairing.pair)
        print_pairing(&dg->pairing);
    printf("baseline  held-out RMS %.4g %s", dg->base_held_rms, unit);
    if (dg->sigma_known)
        printf(", chi2/N %.3g (noise alone ~1)", dg->base_held_chi2 / dg->n_held);
    if (dg->nnuisance) {
        printf("\n");
        print_nuisances(d, dg);
    }
    printf("\n\n rank  effect                    held-out RMS   gain    fitted value\n");
    for (int r = 0; r < dg->nrank; r++) {
        const dm_fit *f = &dg->rank[r];
        if (!f->ok) {
            printf(" %4d  %-24s   fit failed (unphysical over the whole range)\n", r + 1,
                   f->cand[0]->name);
            continue;
        }
        printf(" %4d  %-24s %12.4g %6.1f %%   ", r + 1, f->cand[0]->name, f->held_rms,
               f->gain_percent);
        if (f->cand[0]->nparam > 3)
            printf("%d of %d combinations fitted", f->nfree, f->cand[0]->nparam);
        else
            print_values(f);
        if (f->shift.compensating)
            printf("  [compensating: nuisances moved %.3g mm]", 1e3 * f->shift.rms_m);
        printf("\n");
    }
    print_verdict(d, rb, dg);
}

static json_t *noise_json(const dm_dataset *d, const dm_noise_test *t)
{
    json_t *g = json_array();
    for (int k = 0; k < t->ngroup; k++) {
        char lb[16];
        if (d->kind == DM_DATA_MODAL)
            snprintf(lb, sizeof lb, "%d", t->group[k].group);
        else
            snprintf(lb, sizeof lb, "%c", "xyz"[t->group[k].group]);
        json_array_append_new(g, json_pack("{s:s, s:i, s:f, s:f, s:b}", "group", lb, "samples",
                                           t->group[k].n, "chi2", t->group[k].chi2, "limit",
                                           t->group[k].limit,
                                           "beyond", t->group[k].chi2 > t->group[k].limit));
    }
    json_t *o = json_pack("{s:f, s:i, s:f, s:f, s:b, s:o}", "held_out_chi2", t->chi2, "samples",
                          t->n, "limit", t->limit, "excess_sigmas", t->sigmas, "consistent",
                          t->consistent, "groups", g);
    if (t->nregion > 0) {
        json_t *r = json_pack("{s:[f,f], s:[f,f], s:[f,f], s:i, s:i}", "x", t->lo[0], t->hi[0],
                              "y", t->lo[1], t->hi[1], "z", t->lo[2], t->hi[2], "poses",
                              t->nregion, "of", t->nposes);
        if (d->kind == DM_DATA_TRACKER)
            json_object_set_new(r, "t", json_pack("[f,f]", t->t_lo, t->t_hi));
        json_object_set_new(o, "region", r);
    }
    return o;
}

static json_t *ident_json(const dm_diagnosis *dg)
{
    const dm_ident *id = &dg->ident;
    json_t *names = json_array(), *comb = json_array();
    for (int j = 0; j < id->n; j++) {
        char pn[96];
        param_name(&dg->best, j, pn, sizeof pn);
        json_array_append_new(names, json_string(pn));
    }
    for (int k = 0; k < id->n; k++)
        json_array_append_new(comb, json_pack("{s:f, s:b, s:o}", "sigma",
                                              isfinite(id->sigma[k]) ? id->sigma[k] : -1.0,
                                              "determined", id->sigma[k] <= DM_DIAG_DETERMINED,
                                              "weights", list_json(id->weight[k], id->n)));
    return json_pack("{s:o, s:i, s:o}", "parameters", names, "determined", id->ndetermined,
                     "combinations", comb);
}

static void print_diagnosis_json(const dm_dataset *d, const dm_robot *rb, const dm_diagnosis *dg)
{
    json_t *rank = json_array(), *o = json_object(), *causes = json_array();
    json_t *params = json_object(), *ties = json_array();
    char name[128];
    fit_name(&dg->best, name, sizeof name);
    for (int r = 0; r < dg->nrank; r++)
        json_array_append_new(rank, fit_json(&dg->rank[r]));
    for (int i = 0; dg->explained && i < dg->best.ncand; i++) {
        json_array_append_new(causes, json_string(dg->best.cand[i]->name));
        json_object_set_new(params, dg->best.cand[i]->name,
                            values_json(&dg->best, i, dg->best.value[i]));
    }
    for (int t = 0; dg->found && t < dg->ntie; t++)
        json_array_append_new(ties, json_string(dg->rank[dg->tie[t]].cand[0]->name));
    json_object_set_new(o, "robot", json_string(rb->name));
    json_object_set_new(o, "kind", json_string(dm_data_kind_name(d->kind)));
    json_object_set_new(o, "significant", json_boolean(dg->significant));
    json_object_set_new(o, "judged", json_boolean(dg->sigma_known));
    json_object_set_new(o, "found", json_boolean(dg->found));
    json_object_set_new(o, "explained", json_boolean(dg->explained));
    json_object_set_new(o, "cause", dg->explained ? json_string(name) : json_null());
    json_object_set_new(o, "causes", causes);
    json_object_set_new(o, "parameters", params);
    json_object_set_new(o, "gain_percent", json_real(dg->explained ? dg->best.gain_percent : 0));
    json_object_set_new(o, "partial", dg->found && !dg->explained ? fit_json(&dg->best)
                                                                  : json_null());
    json_object_set_new(o, "baseline_held_out_rms", json_real(dg->base_held_rms));
    json_object_set_new(o, "baseline_held_out_chi2", json_real(dg->base_held_chi2));
    json_object_set_new(o, "held_out_rms", json_real(dg->found ? dg->best.held_rms
                                                               : dg->base_held_rms));
    json_object_set_new(o, "held_out_samples", json_integer(dg->n_held));
    json_object_set_new(o, "best", fit_json(&dg->best));
    json_object_set_new(o, "noise_test", dg->found && dg->sigma_known
                                             ? noise_json(d, &dg->noise) : json_null());
    json_object_set_new(o, "identifiable", dg->found && dg->ident.n ? ident_json(dg)
                                                                    : json_null());
    json_object_set_new(o, "indistinguishable_from", ties);
    json_object_set_new(o, "simpler_preferred_to",
                        dg->found && dg->has_simpler_choice ? fit_json(&dg->passed_over)
                                                            : json_null());
    json_object_set_new(o, "ranking", rank);
    if (dg->nnuisance) { /* absent without: files without nuisances give what they gave */
        json_t *aside = json_array();
        for (int k = 0; dg->significant && k < dg->nset_aside; k++)
            json_array_append_new(aside, fit_json(&dg->set_aside[k]));
        json_object_set_new(o, "nuisances", nuisance_json(d, dg));
        json_object_set_new(o, "set_aside", aside);
    }
    if (dg->pairing.pair) /* likewise: only for surveys with shapes or directions */
        json_object_set_new(o, "pairing", pairing_json(&dg->pairing));
    json_dumpf(o, stdout, JSON_INDENT(2) | JSON_REAL_PRECISION(12));
    putchar('\n');
    json_decref(o);
}

static int write_robot(const measure_args *a, const dm_robot *rb, const dm_diagnosis *dg)
{
    dm_file_out out;
    dm_robot fixed;
    dm_error err;
    if (!dg->found)
        fprintf(stderr, "deltamap diagnose: nothing found; %s is the robot unchanged\n",
                a->write_robot);
    else if (!dg->sigma_known)
        fprintf(stderr, "deltamap diagnose: %s has the effect found; without sigma whether it "
                        "explains the data cannot be judged\n", a->write_robot);
    else if (!dg->explained)
        fprintf(stderr, "deltamap diagnose: %s has the effect found, which explains the data "
                        "only in part\n", a->write_robot);
    int rc = dg->found ? dm_fit_apply(rb, &dg->best, &fixed, &err) : (fixed = *rb, DM_OK);
    if (!rc && !(rc = dm_file_out_open(&out, a->write_robot, &err))) {
        fprintf(out.f, "# %s extended by deltamap diagnose on %s%s\n", rb->name, a->measured,
                !dg->found || dg->explained ? ""
                : dg->sigma_known ? " (explains the data only in part)"
                                  : " (no sigma: whether it explains the data cannot be judged)");
        dm_robot_write(&fixed, out.f);
        rc = dm_file_out_commit(&out, &err);
    }
    return rc ? dm_cli_report(&err) : 0;
}

int dm_cli_diagnose(int argc, char **argv)
{
    measure_args a;
    int rc = parse("diagnose", DIAGNOSE_HELP, argc, argv, &a);
    if (rc)
        return rc;
    a.sh.threads = dm_cli_threads(a.sh.threads);
    dm_dataset d;
    dm_robot rb;
    dm_error err;
    dm_diagnosis dg;
    dm_cli_progress view;
    dm_progress_fn draw = dm_cli_progress_init(&view, "diagnose", a.sh.progress);
    dm_diagnose_opts o = {.na = a.sh.na, .nb = a.sh.nb, .pairs = a.pairs, .threads = a.sh.threads,
                          .force_long = a.sh.force_long, .progress = draw, .progress_user = &view};
    if ((rc = load(&a, &d, &rb, &err)))
        return dm_cli_report(&err);
    rc = dm_diagnose(&rb, &d, &o, &dg, &err);
    dm_cli_progress_finish(&view);
    if (rc) {
        dm_dataset_free(&d);
        return dm_cli_report(&err);
    }
    if (a.sh.json)
        print_diagnosis_json(&d, &rb, &dg);
    else
        print_diagnosis(&d, &rb, &dg);
    if (a.write_robot)
        rc = write_robot(&a, &rb, &dg);
    dm_pairing_free(&dg.pairing);
    dm_dataset_free(&d);
    return rc;
}

/* ---- synth ------------------------------------------------------------------- */

int dm_cli_synth(int argc, char **argv)
{
    dm_cli_serial_blas();
    static const struct option own[] = {
        {"kind", 1, 0, 'k'},    {"effect", 1, 0, 'e'},    {"noise", 1, 0, 'n'},
        {"poses", 1, 0, 'p'},   {"modes", 1, 0, 'M'},     {"seed", 1, 0, 'S'},
        {"path", 1, 0, 'P'},    {"at", 1, 0, 'A'},        {"pairing", 1, 0, 'D'},
        {"drop-mode", 1, 0, 'X'}, {"extra-mode", 1, 0, 'E'}, {0, 0, 0, 0}};
    dm_cli_shared sh;
    dm_cli_begin(&sh, "synth", SYNTH_HELP, own,
                 DM_CLI_ROBOT | DM_CLI_SET | DM_CLI_MESH | DM_CLI_OUT | DM_CLI_FORCE_LONG,
                 DM_CLI_PROGRESS_NONE);
    const char *effects[8], *at = NULL;
    int neff = 0, c, rc, have_kind = 0, seed = 1;
    dm_synth_opts o = {0};
    while ((c = dm_cli_getopt(argc, argv, &sh, &rc))) {
        switch (c) {
        case 'P': o.path = optarg; break;
        case 'A': at = optarg; break;
        case 'k':
            if (dm_data_kind_parse(optarg, &o.kind))
                return dm_cli_usage("synth", "--kind is modal, static or tracker", optarg);
            have_kind = 1;
            break;
        case 'e':
            if (neff == 8)
                return dm_cli_usage("synth", "at most 8 --effect options", optarg);
            effects[neff++] = optarg;
            break;
        case 'n':
            if (dm_cli_parse_list(optarg, &o.noise, 1) || o.noise < 0)
                return dm_cli_usage("synth", "--noise takes a value >= 0", optarg);
            break;
        case 'p':
            if (dm_cli_parse_count(optarg, 3, INT_MAX, &o.npose))
                return dm_cli_usage("synth", "--poses takes a whole number 3..2147483647", optarg);
            break;
        case 'M':
            if (dm_cli_parse_int(optarg, 1, DM_MAX_MODES, &o.modes))
                return dm_cli_usage("synth", "--modes takes 1.." DM_MAX_MODES_TEXT, optarg);
            break;
        case 'S':
            if (dm_cli_parse_int(optarg, 0, 2147483647, &seed))
                return dm_cli_usage("synth", "--seed takes a whole number >= 0", optarg);
            break;
        case 'D':
            if (strcmp(optarg, "dir") && strcmp(optarg, "shapes"))
                return dm_cli_usage("synth", "--pairing is dir or shapes", optarg);
            o.pairing = 1, o.sensors = !strcmp(optarg, "shapes");
            break;
        case 'X':
            if (dm_cli_parse_int(optarg, 1, DM_MAX_MODES, &o.drop_mode))
                return dm_cli_usage("synth", "--drop-mode takes a rank 1.." DM_MAX_MODES_TEXT,
                                    optarg);
            o.pairing = 1;
            break;
        case 'E': {
            char *dir = strchr(optarg, ',');
            o.extra_dir = -1;
            for (int k = 0; dir && k < 6; k++)
                o.extra_dir = strcmp(dir + 1, dm_direction_name(k)) ? o.extra_dir : k;
            if (!dir || o.extra_dir < 0 || sscanf(optarg, "%lf", &o.extra_hz) != 1 ||
                !(o.extra_hz > 0))
                return dm_cli_usage("synth", "--extra-mode takes HZ,DIR (HZ > 0; DIR x, y, z, "
                                    "rx, ry or rz)", optarg);
            o.pairing = 1;
            break;
        }
        default: assert(0);
        }
    }
    if (rc)
        return rc;
    if (!sh.robot || !(have_kind || at))
        return dm_cli_usage("synth", "--robot and --kind (or --at) are required", NULL);
    if (o.pairing && (at || o.kind != DM_DATA_MODAL))
        return dm_cli_usage("synth", "--pairing, --drop-mode and --extra-mode make modal "
                            "surveys (--kind modal, without --at)", NULL);
    o.seed = (uint64_t)seed;
    o.na = sh.na;
    o.nb = sh.nb;
    o.force_long = sh.force_long;
    dm_robot rb;
    dm_error err;
    dm_dataset d;
    rc = dm_cli_load_robot(sh.robot, sh.sets, sh.nset, &rb, &err);
    for (int i = 0; i < neff && !rc; i++)
        rc = dm_effects_apply_spec(&rb, effects[i], &err);
    if (!rc && at) { /* the template's poses */
        dm_dataset tpl;
        if (!(rc = dm_dataset_read_template(at, &tpl, &err))) {
            if (have_kind && tpl.kind != o.kind)
                rc = dm_fail(&err, DM_EINVAL, "%s holds %s data, not %s", at,
                             dm_data_kind_name(tpl.kind), dm_data_kind_name(o.kind));
            o.kind = tpl.kind;
            if (!rc)
                rc = dm_synth_at(&rb, &tpl, &o, &d, &err);
            dm_dataset_free(&tpl);
        }
    } else if (!rc) {
        rc = dm_synthesize(&rb, &o, &d, &err);
    }
    if (rc)
        return dm_cli_report(&err);
    snprintf(d.robot, sizeof d.robot, "%s", sh.robot);
    dm_file_out out;
    FILE *f = stdout;
    if (sh.out && (rc = dm_file_out_open(&out, sh.out, &err)))
        return dm_cli_report(&err);
    if (sh.out)
        f = out.f;
    fprintf(f, "# synthetic %s data from deltamap synth: seed %d, noise %g", dm_data_kind_name(o.kind),
            seed, o.noise);
    for (int i = 0; i < neff; i++)
        fprintf(f, ", %s", effects[i]);
    fprintf(f, "\n");
    dm_dataset_write(&d, f);
    if (sh.out && (rc = dm_file_out_commit(&out, &err)))
        dm_cli_report(&err);
    dm_dataset_free(&d);
    return rc;
}
