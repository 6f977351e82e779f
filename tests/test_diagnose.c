/* Diagnosis: an effect hidden in synthetic data, at a magnitude drawn from
 * a seeded generator over a range where it moves the data by at least five
 * times the noise (checked), with realistic noise (0.02 Hz on frequencies,
 * 50 nm on deflections), must be ranked first, named as the cause (its
 * held-out residual passes the noise test), recovered within 10 % and give
 * a held-out gain (in amplitude) of at least 80 %. Noise alone must give no
 * verdict; two effects must both be found, a global one as global. A
 * truth outside the candidates (a material constant, a section, an arm
 * length) must give no cause and leave "something else". Several geometry
 * families at once: the combinations the data determine are recovered, the
 * rest are reported as not determined. */
#include "dm_test.h"

#include <stdlib.h>

#include "dm_diagnose.h"
#include "dm_predict.h"
#include "dm_rng.h"
#include "dm_synth.h"

typedef struct {
    const char *name;
    double lo, hi; /* magnitudes drawn log-uniformly here (visible on zheng2017) */
} hidden;

static const hidden HIDDEN[] = {
    {"actuator_stiffness", 2e3, 2e5},  {"joint_stiffness", 2e5, 2e7},
    {"base_stiffness", 2e5, 2e7},      {"base_stiffness_0", 2e5, 2e7},
    {"base_stiffness_2", 2e5, 2e7},    {"payload_mass", 0.1, 3.0},
    {"elbow_mass", 1.0, 5.0},          {"geometric_stiffness", 1, 1},
    {"clearance", 5e-6, 5e-5},         {"actuator_clearance_axial", 5e-6, 5e-5},
};
#define NHIDDEN (int)(sizeof HIDDEN / sizeof HIDDEN[0])

/* Measurement noise on synthetic data d made by the extended robot: the
 * effect (RMS of d against the baseline `base`) must be at least five times
 * `noise` (checked); for a switch (geometric stiffness), which has no
 * magnitude to draw, the noise is an eighth of what the switch does.
 * *ratio: effect RMS / noise. */
static void add_noise(const dm_robot *base, const char *name, double value, double noise,
                      uint64_t seed, dm_dataset *d, double *ratio)
{
    double *pred = malloc(sizeof(double) * d->n), ms = 0;
    assert_int_equal(dm_predict(base, d, 1, 1, pred, NULL), 0);
    for (int i = 0; i < d->n; i++)
        ms += (d->s[i].value - pred[i]) * (d->s[i].value - pred[i]);
    double effect = sqrt(ms / d->n);
    if (!strcmp(name, "geometric_stiffness"))
        noise = effect / 8;
    *ratio = effect / noise;
    if (*ratio < 5.0)
        print_error("%s = %g moves the %s data by only %.2g x the noise\n", name, value,
                    dm_data_kind_name(d->kind), *ratio);
    assert_true(*ratio >= 5.0); /* the drawn magnitude is in the visible range */
    dm_rng rng = {seed * 977 + 13};
    for (int i = 0; i < d->n; i++) {
        d->s[i].value += noise * dm_rng_normal(&rng);
        d->s[i].sigma = noise;
    }
    free(pred);
}

/* Surveys (12 poses, 6 modes) with effects names[i] = values[i] and noise
 * 0.02 Hz on frequencies, 50 nm on deflections. */
static void make_data(dm_data_kind kind, const char *const *names, const double *values, int n,
                      uint64_t seed, dm_dataset *d, double *ratio)
{
    dm_robot base, rb;
    dm_error err;
    assert_int_equal(dm_robot_load("zheng2017", &base, NULL), 0);
    rb = base;
    for (int i = 0; i < n; i++) {
        double v[3] = {values[i], values[i], values[i]};
        assert_int_equal(dm_effects_apply(&rb, names[i], v, &err), 0);
    }
    dm_synth_opts o = {.kind = kind, .npose = 12, .modes = 6, .noise = 0, .seed = seed, .na = 1, .nb = 1};
    assert_int_equal(dm_synthesize(&rb, &o, d, &err), 0);
    add_noise(&base, names[0], values[0], kind == DM_DATA_MODAL ? 0.02 : 5e-8, seed, d, ratio);
}

/* Tracker data along `path` with effect `name` = v (per chain for three
 * parameters) and noise 2 um. */
static void make_tracker_data(const char *name, const double v[3], const char *path,
                              uint64_t seed, dm_dataset *d, double *ratio)
{
    dm_robot base, rb;
    assert_int_equal(dm_robot_load("zheng2017", &base, NULL), 0);
    rb = base;
    assert_int_equal(dm_effects_apply(&rb, name, v, NULL), 0);
    dm_synth_opts o = {.kind = DM_DATA_TRACKER, .noise = 0, .seed = seed, .na = 1, .nb = 1,
                       .path = path};
    assert_int_equal(dm_synthesize(&rb, &o, d, NULL), 0);
    add_noise(&base, name, v[0], 2e-6, seed, d, ratio);
}

/* The stated uncertainty means something: the fitted value k of the first
 * effect lies within 5 sigma of the truth (noise is Gaussian and the model
 * exact, so |error| / sigma is about normal), and sigma is finite. */
static void assert_calibrated(const dm_fit *f, int k, const double *truth)
{
    double s = f->sigma[0][k], e = fabs(f->value[0][k] - *truth);
    if (!(isfinite(s) && e <= 5 * s))
        print_error("%s: fitted %g +- %g, truth %g (%.1f sigma)\n", f->cand[0]->name,
                    f->value[0][k], s, *truth, e / s);
    assert_true(isfinite(s) && e <= 5 * s);
}

/* The verdict names a cause: its held-out residual is consistent with the
 * noise (the noise test errs on an exact model 0.1 % of the time). */
static void assert_explained(const dm_diagnosis *dg)
{
    if (!dg->explained)
        print_error("%s found but not explained: held-out prediction chi2 %.1f for %d samples "
                    "(limit %.1f)\n",
                    dg->best.cand[0]->name, dg->noise.chi2, dg->noise.n, dg->noise.limit);
    assert_true(dg->explained);
}

static void diagnose_on(const dm_dataset *d, int pairs, int threads, dm_diagnosis *dg)
{
    dm_robot base;
    dm_error err;
    dm_diagnose_opts o = {.na = 1, .nb = 1, .pairs = pairs, .threads = threads};
    assert_int_equal(dm_robot_load("zheng2017", &base, NULL), 0);
    int rc = dm_diagnose(&base, d, &o, dg, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
}

/* Two threads: the result does not depend on it (tested below). */
static void diagnose(const dm_dataset *d, int pairs, dm_diagnosis *dg)
{
    diagnose_on(d, pairs, 2, dg);
}

static void run_kind(dm_data_kind kind)
{
    for (int h = 0; h < NHIDDEN; h++) {
        const dm_effect *c = dm_effects_find(HIDDEN[h].name);
        if (!(c->kinds & (1u << kind)))
            continue; /* e.g. masses are invisible to deflection surveys */
        for (uint64_t seed = 1; seed <= 3; seed++) {
            dm_rng rng = {seed * 7919 + (uint64_t)h};
            double v = HIDDEN[h].lo * pow(HIDDEN[h].hi / HIDDEN[h].lo, dm_rng_uniform(&rng)), ratio;
            dm_dataset d;
            dm_diagnosis dg;
            make_data(kind, &HIDDEN[h].name, &v, 1, seed + 10 * h, &d, &ratio);
            diagnose(&d, 0, &dg);
            if (!dg.found || strcmp(dg.best.cand[0]->name, HIDDEN[h].name))
                print_error("%s data, hidden %s = %g (effect %.1f x noise), seed %d: found %s\n",
                            dm_data_kind_name(kind), HIDDEN[h].name, v, ratio, (int)seed,
                            dg.found ? dg.best.cand[0]->name : "nothing");
            assert_true(dg.found);
            assert_string_equal(dg.best.cand[0]->name, HIDDEN[h].name);
            assert_explained(&dg);
            if (c->hi > c->lo) {
                assert_rel(dg.best.value[0][0], v, 0.10, "%s recovered", HIDDEN[h].name);
                assert_calibrated(&dg.best, 0, &v);
            }
            assert_true(dg.best.gain_percent >= 80.0);
            dm_dataset_free(&d);
        }
    }
}

static void hidden_effects_in_modal_surveys(void **state)
{
    (void)state;
    run_kind(DM_DATA_MODAL);
}

static void hidden_effects_in_static_surveys(void **state)
{
    (void)state;
    run_kind(DM_DATA_STATIC);
}

/* Noise only: no significant discrepancy, no cause. */
static void noise_alone_gives_no_verdict(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 3; seed++) {
        dm_robot base;
        dm_dataset d;
        dm_diagnosis dg;
        assert_int_equal(dm_robot_load("zheng2017", &base, NULL), 0);
        dm_synth_opts o = {.kind = seed == 2 ? DM_DATA_STATIC : DM_DATA_MODAL, .npose = 12,
                           .modes = 6, .noise = seed == 2 ? 1e-7 : 0.05, .seed = seed, .na = 1, .nb = 1};
        assert_int_equal(dm_synthesize(&base, &o, &d, NULL), 0);
        diagnose(&d, 1, &dg);
        assert_false(dg.found); /* no cause, and no partial claim either */
        assert_false(dg.explained);
        dm_dataset_free(&d);
    }
}

/* Two effects at once: forward selection finds both. */
static void two_effects_are_both_found(void **state)
{
    (void)state;
    const char *names[2] = {"payload_mass", "joint_stiffness"};
    const double values[2] = {1.2, 8e5};
    dm_dataset d;
    dm_diagnosis dg;
    double ratio;
    make_data(DM_DATA_MODAL, names, values, 2, 99, &d, &ratio);
    diagnose(&d, 1, &dg);
    assert_true(dg.found);
    assert_int_equal(dg.best.ncand, 2);
    int got[2] = {0, 0};
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++)
            if (!strcmp(dg.best.cand[i]->name, names[j])) {
                got[j] = 1;
                assert_rel(dg.best.value[i][0], values[j], 0.10, "%s in the pair", names[j]);
            }
    assert_true(got[0] && got[1]);
    assert_explained(&dg);
    assert_true(dg.best.gain_percent >= 80.0);
    dm_dataset_free(&d);
}

/* Radial play c_r of the actuator joints shifts each arm along the rods'
 * pull: to first order rod-end clearance c_r / 2, the candidate that
 * stands for it (docs/model-choices.md). */
static void radial_actuator_play_reads_as_clearance(void **state)
{
    (void)state;
    const char *name = "actuator_clearance_radial";
    const double cr = 2e-5;
    dm_dataset d;
    dm_diagnosis dg;
    double ratio;
    make_data(DM_DATA_STATIC, &name, &cr, 1, 31, &d, &ratio);
    diagnose(&d, 0, &dg);
    assert_true(dg.found);
    assert_string_equal(dg.best.cand[0]->name, "clearance");
    assert_explained(&dg);
    assert_rel(dg.best.value[0][0], cr / 2, 0.10, "clearance standing for radial play");
    assert_true(dg.best.gain_percent >= 80.0);
    dm_dataset_free(&d);
}

/* Fits run in parallel; every number of the diagnosis, ranking and pair
 * included, is the same on one thread and on three. */
static void diagnosis_does_not_depend_on_threads(void **state)
{
    (void)state;
    const char *names[2] = {"payload_mass", "joint_stiffness"};
    const double values[2] = {0.7, 2e6};
    dm_dataset d;
    dm_diagnosis one, three;
    double ratio;
    make_data(DM_DATA_MODAL, names, values, 2, 7, &d, &ratio);
    diagnose_on(&d, 1, 1, &one);
    diagnose_on(&d, 1, 3, &three);
    assert_int_equal(one.nrank, three.nrank);
    for (int r = 0; r < one.nrank; r++) {
        assert_ptr_equal(one.rank[r].cand[0], three.rank[r].cand[0]);
        assert_memory_equal(&one.rank[r].score, &three.rank[r].score, sizeof(double));
        assert_memory_equal(one.rank[r].value, three.rank[r].value, sizeof one.rank[r].value);
    }
    assert_int_equal(one.best.ncand, three.best.ncand);
    assert_memory_equal(one.best.value, three.best.value, sizeof one.best.value);
    assert_memory_equal(&one.best.score, &three.best.score, sizeof(double));
    dm_dataset_free(&d);
}

/* Tracker data (noise 2 um on positions, 0.1 s at 1 kHz) see every
 * candidate: geometry errors per chain (signed values drawn per chain) and
 * clearance along a circle; springs, masses, stress stiffening and
 * Rayleigh damping in a fast diagonal bang-bang move (x, y and z, so that
 * several modes ring) that then rings down: a steady circle hardly excites
 * the structure, and a move along one axis leaves a small payload and a
 * softer joint nearly alike. Two seeds per effect.
 * Base and platform radius errors move the platform alike (only R - r
 * enters the kinematics), and when one mode rings Rayleigh alpha and beta
 * both just set its damping ratio: the diagnosis may name either twin, and
 * must then report the other as indistinguishable. */
#define CIRCLE "circle:centre=0,0,-0.4;radius=0.05;rate=12.566;duration=0.1"
#define RINGDOWN "p2p:from=-0.03,-0.02,-0.41;to=0.03,0.02,-0.39;duration=0.05;law=bangbang;dwell=0.05"

typedef struct {
    const char *name;
    double lo, hi;    /* per chain: |value| uniform in [lo, hi], either sign; else log-uniform */
    const char *path;
    const char *twin; /* an effect these data may not tell from this one */
} tracked;

static const tracked TRACKED[] = {
    {"error_alpha0_deg", 0.02, 0.08, CIRCLE, NULL},
    {"error_theta_deg", 0.03, 0.08, CIRCLE, NULL},
    {"error_arm_length", 1e-4, 3e-4, CIRCLE, NULL},
    {"error_rod_length", 1e-4, 3e-4, CIRCLE, NULL},
    {"error_base_radius", 1e-4, 3e-4, CIRCLE, "error_platform_radius"},
    {"error_platform_radius", 1e-4, 3e-4, CIRCLE, "error_base_radius"},
    {"clearance", 1e-5, 4e-5, CIRCLE, NULL},
    {"actuator_clearance_axial", 2e-4, 5e-4, CIRCLE, NULL}, /* seen through the rods' small tilt along the axis */
    {"actuator_stiffness", 2e3, 2e5, RINGDOWN, NULL},
    {"joint_stiffness", 2e5, 2e7, RINGDOWN, NULL},
    {"base_stiffness", 2e5, 2e7, RINGDOWN, NULL},
    {"base_stiffness_1", 2e5, 5e6, RINGDOWN, NULL},
    {"payload_mass", 0.1, 3.0, RINGDOWN, NULL},
    {"elbow_mass", 2.0, 5.0, RINGDOWN, NULL},
    {"geometric_stiffness", 1, 1, RINGDOWN, NULL},
    {"damping_alpha", 20, 300, RINGDOWN, "damping_beta"},
    {"damping_beta", 6e-4, 3e-3, RINGDOWN, "damping_alpha"},
};
#define NTRACKED (int)(sizeof TRACKED / sizeof TRACKED[0])

static void draw_tracked(const tracked *t, const dm_effect *c, dm_rng *rng, double v[3])
{
    for (int k = 0; k < 3; k++)
        v[k] = c->nparam == 3 ? (dm_rng_uniform(rng) < 0.5 ? -1 : 1) *
                                    (t->lo + (t->hi - t->lo) * dm_rng_uniform(rng))
                              : t->lo * pow(t->hi / t->lo, dm_rng_uniform(rng));
}

static int is_tie(const dm_diagnosis *dg, const char *name)
{
    for (int t = 0; t < dg->ntie; t++)
        if (!strcmp(dg->rank[dg->tie[t]].cand[0]->name, name))
            return 1;
    return 0;
}

static const dm_fit *fit_of(const dm_diagnosis *dg, const char *name)
{
    for (int r = 0; r < dg->nrank; r++)
        if (!strcmp(dg->rank[r].cand[0]->name, name))
            return &dg->rank[r];
    return NULL;
}

/* The hidden effect is named first, or its twin is and the diagnosis says
 * the two tie; either way the hidden effect's own fit recovers it. */
static void tracker_case(const tracked *t, uint64_t seed)
{
    const dm_effect *c = dm_effects_find(t->name);
    dm_rng rng = {seed * 7919 + 17};
    double v[3], ratio;
    dm_dataset d;
    dm_diagnosis dg;
    draw_tracked(t, c, &rng, v);
    make_tracker_data(t->name, v, t->path, seed, &d, &ratio);
    diagnose(&d, 0, &dg);
    const char *found = dg.found ? dg.best.cand[0]->name : "nothing";
    int twin_named = t->twin && !strcmp(found, t->twin);
    if (strcmp(found, t->name) && !twin_named)
        print_error("tracker, hidden %s = %g (effect %.1f x noise), seed %d: found %s\n", t->name,
                    v[0], ratio, (int)seed, found);
    assert_true(dg.found);
    if (twin_named)
        assert_true(is_tie(&dg, t->name));
    else
        assert_string_equal(found, t->name);
    assert_explained(&dg);
    const dm_fit *own = fit_of(&dg, t->name);
    assert_non_null(own);
    for (int k = 0; k < c->nparam; k++) {
        assert_rel(own->value[0][k], v[k], 0.10, "%s (%d of %d)", t->name, k + 1, c->nparam);
        assert_calibrated(own, k, &v[k]);
    }
    assert_true(own->gain_percent >= 80.0 && dg.best.gain_percent >= 80.0);
    dm_dataset_free(&d);
}

static void hidden_effects_in_tracker_runs(void **state)
{
    (void)state;
    for (int h = 0; h < NTRACKED; h++)
        for (uint64_t seed = 1; seed <= 2; seed++) /* drawn values and noise differ */
            tracker_case(&TRACKED[h], 100 * seed + (uint64_t)h);
}

/* ---- what the candidates cannot explain ----------------------------------------- */

/* A robot that differs from the file in something no candidate models.
 * Not the rods' Young's modulus in a deflection survey: the rods are
 * two-force members in statics, and joint springs in series with them
 * make exactly a lower EA (the diagnosis rightly names joint_stiffness). */
typedef struct {
    const char *robot;
    dm_data_kind kind;
    const char *set;
} outside;

static const outside OUTSIDE[] = {
    {"zheng2017", DM_DATA_MODAL, "rod.youngs_modulus=63e9"},   /* rods' E 10 % low */
    {"zheng2017", DM_DATA_STATIC, "arm.diameter=0.047"},       /* arm section 6 % thinner */
    {"zheng2017", DM_DATA_MODAL, "geometry.arm_length=0.204"}, /* arms 2 % long */
    {"chen2018", DM_DATA_MODAL, "rod.side=0.0095"},            /* rod section 5 % smaller */
    {"chen2018", DM_DATA_STATIC, "arm.side=0.019"},            /* arm section 5 % smaller */
};
#define NOUTSIDE (int)(sizeof OUTSIDE / sizeof OUTSIDE[0])

/* Found (something beats the baseline) but not explained: no cause, and
 * the residual still beyond the noise, on every seed. */
static void truth_outside_the_candidates(void **state)
{
    (void)state;
    for (int c = 0; c < NOUTSIDE; c++)
        for (uint64_t seed = 1; seed <= 3; seed++) {
            const outside *o = &OUTSIDE[c];
            dm_robot base, real;
            dm_dataset d;
            dm_diagnosis dg;
            dm_error err;
            assert_int_equal(dm_robot_load(o->robot, &base, NULL), 0);
            real = base;
            assert_int_equal(dm_robot_set(&real, o->set, &err), 0);
            dm_synth_opts so = {.kind = o->kind, .npose = 12, .modes = 6, .seed = seed, .na = 1,
                                .nb = 1, .noise = o->kind == DM_DATA_MODAL ? 0.02 : 5e-8};
            assert_int_equal(dm_synthesize(&real, &so, &d, NULL), 0);
            dm_diagnose_opts opts = {.na = 1, .nb = 1, .pairs = 1, .threads = 2};
            assert_int_equal(dm_diagnose(&base, &d, &opts, &dg, &err), 0);
            if (!dg.found || dg.explained)
                print_error("%s %s with %s, seed %d: found %d, explained %d (%s, %.1f sigma)\n",
                            o->robot, dm_data_kind_name(o->kind), o->set, (int)seed, dg.found,
                            dg.explained, dg.best.cand[0]->name, dg.noise.sigmas);
            assert_true(dg.sigma_known && dg.found);
            assert_false(dg.explained);
            assert_true(dg.noise.chi2 > dg.noise.limit); /* the whole residual, not one group */
            dm_dataset_free(&d);
        }
}

/* A global effect (the frame under all three chains) and a second one:
 * both found, the global one as global, both within 10 %. */
static void global_effect_and_a_second(void **state)
{
    (void)state;
    static const struct {
        dm_data_kind kind;
        const char *second;
        double value;
    } CASES[] = {{DM_DATA_MODAL, "payload_mass", 0.8},
                 {DM_DATA_STATIC, "actuator_stiffness", 5e4},
                 {DM_DATA_STATIC, "clearance", 2e-5}};
    for (int c = 0; c < 3; c++)
        for (uint64_t seed = 1; seed <= 2; seed++) {
            const char *names[2] = {"base_stiffness", CASES[c].second};
            const double values[2] = {3e6, CASES[c].value};
            dm_dataset d;
            dm_diagnosis dg;
            double ratio;
            make_data(CASES[c].kind, names, values, 2, 40 + 10 * c + seed, &d, &ratio);
            diagnose(&d, 1, &dg);
            if (dg.best.ncand != 2)
                print_error("base_stiffness + %s, seed %d: found %s\n", names[1], (int)seed,
                            dg.best.cand[0]->name);
            assert_true(dg.found);
            assert_int_equal(dg.best.ncand, 2);
            for (int j = 0; j < 2; j++) {
                int i = !strcmp(dg.best.cand[0]->name, names[j]) ? 0 : 1;
                if (strcmp(dg.best.cand[i]->name, names[j]))
                    print_error("seed %d: %s + %s found for %s + %s\n", (int)seed,
                                dg.best.cand[0]->name, dg.best.cand[1]->name, names[0], names[1]);
                assert_string_equal(dg.best.cand[i]->name, names[j]);
                assert_rel(dg.best.value[i][0], values[j], 0.10, "%s with %s", names[j],
                           names[1 - j]);
            }
            assert_explained(&dg);
            dm_dataset_free(&d);
        }
}

/* Three geometry families at once on one circle: only their union
 * explains the data; of its 18 parameters the data determine a few
 * combinations, recovered within 10 % (as a vector), and cannot tell a
 * chain's base radius from its platform radius (only R - r enters). */
/* The scan that starts a lone log parameter's fit runs at half the mesh
 * (dm_diagnose_opts.scan_na): at the default mesh 4,4 its start leads the
 * fit to the one the full mesh's scan leads to, within a hundredth of
 * the fit's 1-sigma, and both within 5 sigma of the truth; a modal survey
 * (12 poses, 6 modes, 0.02 Hz) and a tracker run (a 0.05 s move and its
 * ring-down, 2 um, at 1 kHz; a jerk-limited one at 250 Hz, where the
 * scan also integrates at 2 ms instead of 1, and the path through the
 * samples is still the move), made at 4,4 with a hidden payload or joint
 * stiffness. */
static void half_mesh_scan_fits_as_the_mesh(void **state)
{
    (void)state;
    static const struct {
        dm_data_kind kind;
        const char *name;
        double value;
        int every; /* keep every such time of a tracker run */
        const char *path;
    } CASES[] = {{DM_DATA_MODAL, "payload_mass", 0.8, 1, NULL},
                 {DM_DATA_MODAL, "joint_stiffness", 3e6, 1, NULL},
                 {DM_DATA_TRACKER, "payload_mass", 0.8, 1,
                  "p2p:from=-0.03,-0.02,-0.41;to=0.03,0.02,-0.39;duration=0.05;law=bangbang;"
                  "dwell=0.05"},
                 {DM_DATA_TRACKER, "payload_mass", 0.8, 4,
                  "p2p:from=-0.03,-0.02,-0.41;to=0.03,0.02,-0.39;duration=0.05;law=poly7;"
                  "dwell=0.1"}};
    for (size_t c = 0; c < sizeof CASES / sizeof CASES[0]; c++) {
        dm_robot base, rb;
        dm_dataset d;
        dm_error err;
        assert_int_equal(dm_robot_load("zheng2017", &base, NULL), 0);
        rb = base;
        double v[3] = {CASES[c].value, CASES[c].value, CASES[c].value}, noise;
        assert_int_equal(dm_effects_apply(&rb, CASES[c].name, v, NULL), 0);
        dm_synth_opts so = {.kind = CASES[c].kind, .npose = 12, .modes = 6, .seed = 5 + c,
                            .na = 4, .nb = 4, .path = CASES[c].path};
        assert_int_equal(dm_synthesize(&rb, &so, &d, &err), 0);
        int m = 0;
        for (int i = 0; i < d.n; i++) /* a tracker run's times: three samples each */
            if (d.kind != DM_DATA_TRACKER || d.s[i].pose_id % CASES[c].every == 0) {
                d.s[m] = d.s[i];
                d.s[m++].pose_id /= d.kind == DM_DATA_TRACKER ? CASES[c].every : 1;
            }
        d.n = m;
        d.npose = d.kind == DM_DATA_TRACKER ? m / 3 : d.npose;
        noise = CASES[c].kind == DM_DATA_MODAL ? 0.02 : 2e-6;
        dm_rng rng = {977 + c};
        for (int i = 0; i < d.n; i++) {
            d.s[i].value += noise * dm_rng_normal(&rng);
            d.s[i].sigma = noise;
        }
        const char *names[1] = {CASES[c].name};
        dm_fit half, full;
        dm_diagnose_opts o = {.na = 4, .nb = 4, .threads = 1};
        assert_int_equal(dm_fit_effects(&base, &d, names, 1, NULL, &o, &half, &err), 0);
        o.scan_na = o.scan_nb = 4;
        assert_int_equal(dm_fit_effects(&base, &d, names, 1, NULL, &o, &full, &err), 0);
        assert_true(half.ok && full.ok);
        double s = full.sigma[0][0];
        assert_true(isfinite(s) && s > 0);
        if (!(fabs(half.value[0][0] - full.value[0][0]) <= 0.01 * s))
            print_error("%s: %g from the half mesh's scan, %g +- %g from the mesh's\n",
                        CASES[c].name, half.value[0][0], full.value[0][0], s);
        assert_true(fabs(half.value[0][0] - full.value[0][0]) <= 0.01 * s);
        assert_calibrated(&half, 0, &CASES[c].value);
        dm_dataset_free(&d);
    }
}

static void several_geometry_families_at_once(void **state)
{
    (void)state;
    static const char *const FAMILY[3] = {"error_arm_length", "error_theta_deg", "error_base_radius"};
    static const int OFFSET[3] = {0, 12, 6}; /* their places in geometry_errors */
    static const double TRUTH[3][3] = {{2e-4, -1e-4, 1.5e-4}, {0.04, -0.05, 0.03}, {-1e-4, 2e-4, 1e-4}};
    const dm_effect *u = dm_effects_find("geometry_errors");
    for (uint64_t seed = 1; seed <= 2; seed++) {
        dm_robot base, rb;
        dm_dataset d;
        dm_diagnosis dg;
        double ratio, truth[18] = {0};
        assert_int_equal(dm_robot_load("zheng2017", &base, NULL), 0);
        rb = base;
        for (int f = 0; f < 3; f++) {
            assert_int_equal(dm_effects_apply(&rb, FAMILY[f], TRUTH[f], NULL), 0);
            for (int k = 0; k < 3; k++)
                truth[OFFSET[f] + k] = TRUTH[f][k];
        }
        dm_synth_opts o = {.kind = DM_DATA_TRACKER, .seed = seed, .na = 1, .nb = 1, .path = CIRCLE};
        assert_int_equal(dm_synthesize(&rb, &o, &d, NULL), 0);
        add_noise(&base, "geometry_errors", 1, 2e-6, seed, &d, &ratio);
        diagnose(&d, 0, &dg);
        assert_true(dg.found);
        assert_string_equal(dg.best.cand[0]->name, "geometry_errors");
        assert_explained(&dg);
        const dm_ident *id = &dg.ident;
        assert_int_equal(id->n, 18);
        assert_true(id->ndetermined >= 3 && id->ndetermined < 18);
        double err = 0, ref = 0;
        for (int k = 0; k < id->ndetermined; k++) { /* in scaled units */
            double e = 0, t = 0;
            for (int j = 0; j < 18; j++) {
                double sc = dm_effects_param_scale(u, j);
                e += id->weight[k][j] * (dg.best.value[0][j] - truth[j]) / sc;
                t += id->weight[k][j] * truth[j] / sc;
            }
            err += e * e;
            ref += t * t;
        }
        print_message("seed %d: %d of 18 combinations determined, error %.3g of their norm\n",
                      (int)seed, id->ndetermined, sqrt(err / ref));
        assert_true(sqrt(err) <= 0.10 * sqrt(ref));
        for (int chain = 0; chain < 3; chain++) { /* R_i + r_i: outside what is determined */
            double in = 0;
            for (int k = 0; k < id->ndetermined; k++) {
                double w = (id->weight[k][6 + chain] + id->weight[k][9 + chain]) / sqrt(2.0);
                in += w * w;
            }
            assert_true(in < 0.01);
        }
        dm_dataset_free(&d);
    }
}

int main(int argc, char **argv)
{
    if (argc > 1) /* e.g. test_diagnose '*tracker*' runs those alone */
        cmocka_set_test_filter(argv[1]);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(noise_alone_gives_no_verdict),
        cmocka_unit_test(two_effects_are_both_found),
        cmocka_unit_test(hidden_effects_in_modal_surveys),
        cmocka_unit_test(hidden_effects_in_static_surveys),
        cmocka_unit_test(radial_actuator_play_reads_as_clearance),
        cmocka_unit_test(diagnosis_does_not_depend_on_threads),
        cmocka_unit_test(truth_outside_the_candidates),
        cmocka_unit_test(global_effect_and_a_second),
        cmocka_unit_test(several_geometry_families_at_once),
        cmocka_unit_test(half_mesh_scan_fits_as_the_mesh),
        cmocka_unit_test(hidden_effects_in_tracker_runs),
    };
    return cmocka_run_group_tests_name("diagnose", tests, NULL, NULL);
}
