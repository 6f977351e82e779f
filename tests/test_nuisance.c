/* A tracker run as a lab records it (issue 36, item 1): the reflector off
 * the platform centre, the tracker's frame a little off the base frame (or
 * its own frame altogether), its clock shifted. Synthetic runs with known
 * nuisances: with no effect no cause is named and the nuisances come back
 * within their reported uncertainty; with a hidden effect it is still
 * named and fitted; a model that fits only because its nuisances moved
 * far from the baseline's is flagged and never the verdict (issue 36).
 * Bad header lines are refused naming file and line. */
#include "dm_test.h"

#include <stdlib.h>
#include <unistd.h>

#include "dm_diagnose.h"
#include "dm_nuisance.h"
#include "dm_rng.h"
#include "dm_synth.h"
#include "dm_trajectory.h"

#define CIRCLE "circle:centre=0,0,-0.4;radius=0.05;rate=12.566;duration=0.1"
#define NOISE 2e-6

typedef struct {
    double phi[3];    /* the base frame as found: small rotation (rad) ... */
    double d[3];      /* ... and translation (m) of the file's positions */
    double refl[3];   /* the reflector's true offset (m) */
    double nominal[3];/* the offset the file states */
    double tau, rho;  /* clock offset (s) and rate error */
    int tracker;      /* positions in a far-off tracker frame (R0, D0) */
    double noise;     /* per coordinate (m); 0: NOISE */
    double scale;     /* the tracker's length scale error: it measures (1 + scale) m */
} truth;

static const double R0[9] = {0.7660444431, -0.6427876097, 0, /* 40 deg about z, then 10 about x */
                             0.6330222216, 0.7544065067, -0.1736481777,
                             0.1116174131, 0.1330222216, 0.9848077530};
static const double D0[3] = {1.5, -0.8, 0.3};

/* Catmull-Rom through the 1 ms samples of component c of the elastic
 * error e (3 per time) at time t: its error is O(dt^4), far below the
 * noise for the presets' modes. */
static double error_at(const dm_dataset *d, const double *e, int c, double t)
{
    int nt = d->n / 3;
    double dt = d->s[3].t - d->s[0].t, u = t / dt;
    int j = (int)floor(u);
    u -= j;
    if (j >= nt - 1) /* past the last sample: hold it (a few 0.1 ms at most) */
        return e[3 * (nt - 1) + c];
    if (u == 0 || j < 1 || j > nt - 3) /* on a sample, or next to an end: linear */
        return (1 - u) * e[3 * j + c] + u * e[3 * (j + 1) + c];
    double p0 = e[3 * (j - 1) + c], p1 = e[3 * j + c], p2 = e[3 * (j + 1) + c],
           p3 = e[3 * (j + 2) + c];
    return 0.5 * (2 * p1 + (-p0 + p2) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u * u +
                  (-p0 + 3 * p1 - 3 * p2 + p3) * u * u * u);
}

/* p' = (I + [phi]x + [phi]x^2 / 2) p: the rotation to second order, far
 * below the noise for phi of 1e-3 rad. */
static void rotate_small(const double phi[3], const double p[3], double out[3])
{
    double a[3] = {phi[1] * p[2] - phi[2] * p[1], phi[2] * p[0] - phi[0] * p[2],
                   phi[0] * p[1] - phi[1] * p[0]};
    double b[3] = {phi[1] * a[2] - phi[2] * a[1], phi[2] * a[0] - phi[0] * a[2],
                   phi[0] * a[1] - phi[1] * a[0]};
    for (int k = 0; k < 3; k++)
        out[k] = p[k] + a[k] + 0.5 * b[k];
}

/* The run a lab would record from `real` along path: a CSV file (path
 * returned in file) with the nuisance header lines. */
static void record_run(const dm_robot *real, const char *path, const truth *tr, uint64_t seed,
                       char *file)
{
    dm_synth_opts so = {.kind = DM_DATA_TRACKER, .path = path, .na = 1, .nb = 1};
    dm_dataset d;
    dm_trajectory traj;
    assert_int_equal(dm_synthesize(real, &so, &d, NULL), 0);
    assert_int_equal(dm_traj_make(path, real, &traj, NULL), 0);
    if (traj.kind == DM_PATH_CIRCLE) /* the clock runs past the last command: keep going round */
        traj.duration_s += 1;
    double *e = malloc(sizeof(double) * d.n);
    for (int i = 0; i < d.n; i++)
        e[i] = d.s[i].value;
    snprintf(file, 64, "/tmp/dm_nuisance_XXXXXX");
    int fd = mkstemp(file);
    assert_true(fd >= 0);
    FILE *f = fdopen(fd, "w");
    fprintf(f, "# robot: %s\n# frame: %s\n# reflector: %.17g, %.17g, %.17g\n# clock: %s\n",
            real->name, tr->tracker ? "tracker" : "base", tr->nominal[0], tr->nominal[1],
            tr->nominal[2], tr->rho ? "rate" : "offset");
    fprintf(f, "t,x_cmd,y_cmd,z_cmd,x_meas,y_meas,z_meas\n");
    dm_rng rng = {seed};
    for (int j = 0; j < d.n / 3; j++) {
        const dm_sample *s = &d.s[3 * j];
        double t = s->t, ts = t + tr->tau + tr->rho * t, P[3], v[3], a[3], p[3], m[3];
        dm_traj_eval(&traj, ts, P, v, a);
        for (int c = 0; c < 3; c++) /* the reflector at the shifted time, base frame */
            p[c] = P[c] + error_at(&d, e, c, ts) + tr->refl[c];
        if (tr->tracker) { /* m = R0' (p - D0): base = R0 m + D0 */
            for (int r = 0; r < 3; r++) {
                m[r] = 0;
                for (int c = 0; c < 3; c++)
                    m[r] += R0[c * 3 + r] * (p[c] - D0[c]);
            }
        } else {
            rotate_small(tr->phi, p, m);
            for (int c = 0; c < 3; c++)
                m[c] += tr->d[c];
        }
        fprintf(f, "%.9g,%.17g,%.17g,%.17g", t, s->P[0], s->P[1], s->P[2]);
        for (int c = 0; c < 3; c++) /* about its own origin, as a tracker's distance meter errs */
            m[c] *= 1 + tr->scale;
        for (int c = 0; c < 3; c++)
            fprintf(f, ",%.17g", m[c] + (tr->noise ? tr->noise : NOISE) * dm_rng_normal(&rng));
        fprintf(f, "\n");
    }
    assert_int_equal(fclose(f), 0);
    free(e);
    dm_traj_free(&traj);
    dm_dataset_free(&d);
}

/* Diagnose a recorded run whose noise is sigma (single effects only). */
static void diagnose_run(const dm_robot *rb, const char *file, double sigma, dm_dataset *d,
                         dm_diagnosis *dg)
{
    dm_error err;
    int rc = dm_dataset_read(file, d, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    for (int i = 0; i < d->n; i++)
        d->s[i].sigma = sigma;
    dm_diagnose_opts o = {.na = 1, .nb = 1, .pairs = 0, .threads = 2};
    rc = dm_diagnose(rb, d, &o, dg, &err);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
}

static void diagnose_file(const dm_robot *rb, const char *file, dm_dataset *d, dm_diagnosis *dg)
{
    diagnose_run(rb, file, NOISE, d, dg);
}

/* What the fitted nuisances should be: the translation is the frame's
 * plus the reflector's error plus the rotation's lever to the run's
 * centroid (the fit's rotations turn about it). */
static void expected(const dm_dataset *d, const truth *tr, double want[8])
{
    double c[3] = {0}, lever[3], o[3];
    for (int i = 0; i < d->n; i++)
        c[d->s[i].comp] += d->s[i].P[d->s[i].comp] / (d->n / 3);
    for (int k = 0; k < 3; k++)
        lever[k] = c[k] + tr->refl[k];
    rotate_small(tr->phi, lever, o);
    for (int k = 0; k < 3; k++) {
        want[k] = tr->d[k] + (o[k] - lever[k]) + tr->refl[k] - tr->nominal[k];
        want[3 + k] = tr->phi[k];
    }
    want[6] = tr->tau;
    want[7] = tr->rho;
}

static const truth LAB = {.phi = {2e-4, -3e-4, 4e-4}, /* 0.01-0.02 deg */
                          .d = {3e-5, -2e-5, 4e-5},
                          .refl = {0.0301, -0.0102, 0.0205},
                          .nominal = {0.03, -0.01, 0.02},
                          .tau = 2.5e-4};

/* No effect: nothing named, every nuisance within 3 of its reported sigma
 * (a 0.3 % chance each for an exact Gaussian estimate), and their gain
 * reported apart from the effects'. */
static void nuisances_alone_name_no_cause(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    for (uint64_t seed = 1; seed <= 2; seed++) {
        truth tr = LAB;
        tr.rho = seed == 2 ? 2e-4 : 0; /* the second run with a clock-rate error */
        char file[64];
        record_run(&rb, CIRCLE, &tr, seed, file);
        dm_dataset d;
        dm_diagnosis dg;
        diagnose_file(&rb, file, &d, &dg);
        unlink(file);
        assert_int_equal(dg.nnuisance, tr.rho ? 8 : 7);
        double want[8];
        expected(&d, &tr, want);
        if (dg.found) {
            print_error("seed %d: found %s; raw chi2/N %g, baseline %g, best %g\n", (int)seed,
                        dg.best.cand[0]->name, dg.raw_held_chi2 / dg.n_held,
                        dg.base_held_chi2 / dg.n_held, dg.best.held_chi2 / dg.n_held);
            for (int k = 0; k < dg.nnuisance; k++)
                print_error("  %s = %g +- %g, true %g\n", dm_nuisance_name(k),
                            dg.nuisance.value[k], dg.nuisance.sigma[k], want[k]);
        }
        assert_false(dg.found);
        for (int k = 0; k < dg.nnuisance; k++) {
            double err = fabs(dg.nuisance.value[k] - want[k]), s = dg.nuisance.sigma[k];
            if (!(err <= 3 * s))
                print_error("seed %d: %s = %g +- %g, true %g\n", (int)seed, dm_nuisance_name(k),
                            dg.nuisance.value[k], s, want[k]);
            assert_true(err <= 3 * s);
        }
        /* the nuisances explain the raw misfit; the baseline with them is noise */
        assert_true(dg.raw_held_chi2 > 10 * dg.n_held);
        assert_true(dg.base_held_chi2 < dg.n_held + 4 * sqrt(2.0 * dg.n_held));
        assert_true(dg.nuisance_gain_percent > 95);
        dm_dataset_free(&d);
    }
}

/* The same run in the tracker's own frame, far from the base frame: the
 * reader places it (Kabsch) and the fit refines it; nothing is named. */
static void tracker_frame_is_placed(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    truth tr = LAB;
    tr.tracker = 1;
    char file[64];
    record_run(&rb, CIRCLE, &tr, 3, file);
    dm_dataset d;
    dm_diagnosis dg;
    diagnose_file(&rb, file, &d, &dg);
    unlink(file);
    assert_true(d.nuisance.tracker_frame);
    assert_false(dg.found);
    /* the frame: the reader's alignment turned back by the fitted small
     * rotation (which moves the measured points onto the model's),
     * (I - [phi]x) A, is R0, within 3 of each rotation's sigma (on a circle a turn about its
     * axis and the clock offset look alike, so that one is loose) */
    const double *A = d.nuisance.R, *phi = dg.nuisance.value + 3;
    double T[9], delta[3];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            double skew[3] = {r == 1 ? phi[2] : r == 2 ? -phi[1] : 0,
                              r == 0 ? -phi[2] : r == 2 ? phi[0] : 0,
                              r == 0 ? phi[1] : r == 1 ? -phi[0] : 0};
            T[r * 3 + c] = A[r * 3 + c];
            for (int k = 0; k < 3; k++)
                T[r * 3 + c] -= skew[k] * A[k * 3 + c];
        }
    for (int k = 0; k < 3; k++) { /* T R0' = I + [delta]x */
        int a = (k + 1) % 3, b = (k + 2) % 3;
        double ab = 0, ba = 0;
        for (int j = 0; j < 3; j++) {
            ab += T[b * 3 + j] * R0[a * 3 + j];
            ba += T[a * 3 + j] * R0[b * 3 + j];
        }
        delta[k] = 0.5 * (ab - ba);
        assert_abs(delta[k], 0, 3 * dg.nuisance.sigma[3 + k] + 1e-6, "frame rotation %d", k);
    }
    assert_true(dg.base_held_chi2 < dg.n_held + 4 * sqrt(2.0 * dg.n_held));
    assert_abs(dg.nuisance.value[6], tr.tau, 3 * dg.nuisance.sigma[6], "clock offset");
    dm_dataset_free(&d);
}

/* A hidden effect under the nuisances is still named and fitted. */
static void hidden_effect_is_still_named(void **state)
{
    (void)state;
    /* a circle in one plane leaves too little of an arm-length error once the
     * frame is free (a rigid motion of the plane takes most of it): the lab
     * case for geometry is a path through space, a pick move */
    static const struct {
        const char *name;
        double v[3];
        const char *path;
    } cases[] = {
        {"error_arm_length", {2e-4, -1.5e-4, 2.5e-4}, "pick:start=-0.03,0,-0.42;duration=0.3"},
        {"clearance", {3e-5}, CIRCLE},
        {"base_stiffness", {2e6},
         "p2p:from=-0.03,-0.02,-0.41;to=0.03,0.02,-0.39;duration=0.05;law=bangbang;dwell=0.05"},
    };
    dm_robot rb;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        dm_robot real = rb;
        assert_int_equal(dm_effects_apply(&real, cases[c].name, cases[c].v, NULL), 0);
        char file[64];
        /* the clock's offset enters linearised: its acceleration term |a| tau^2 / 2
         * must stay below the noise, which a bang-bang move's 120 m/s^2 allows
         * for tau up to about 50 us (0.15 um) */
        truth tr = LAB;
        if (strncmp(cases[c].path, "circle", 6))
            tr.tau = 5e-5;
        /* nor can a linear clock term shift a clearance's jumps: a run with
         * clearance needs its clocks synchronised (the limitation of
         * dm_nuisance.h) */
        if (!strcmp(cases[c].name, "clearance"))
            tr.tau = 0;
        record_run(&real, cases[c].path, &tr, 10 + c, file);
        dm_dataset d;
        dm_diagnosis dg;
        diagnose_file(&rb, file, &d, &dg);
        unlink(file);
        const char *found = dg.found ? dg.best.cand[0]->name : "nothing";
        if (strcmp(found, cases[c].name)) {
            print_error("hidden %s: found %s (explained %d); ties:", cases[c].name, found,
                        dg.explained);
            for (int t = 0; t < dg.ntie; t++)
                print_error(" %s", dg.rank[dg.tie[t]].cand[0]->name);
            for (int r = 0; r < 5 && r < dg.nrank; r++)
                print_error("\n  %s score %g held chi2/N %g", dg.rank[r].cand[0]->name,
                            dg.rank[r].score, dg.rank[r].held_chi2 / dg.n_held);
            print_error("\n  baseline score %g; determined %d of %d\n", dg.base_score,
                        dg.ident.ndetermined, dg.ident.n);
        }
        assert_string_equal(found, cases[c].name);
        const dm_effect *e = dm_effects_find(cases[c].name);
        /* within 10 %, or within 3 of the reported sigma where the nuisances leave
         * less of the effect to see (a clearance's constant offset is a translation) */
        for (int k = 0; k < e->nparam; k++) {
            double v = dg.best.value[0][k], want = cases[c].v[k], s = dg.best.sigma[0][k];
            if (!(fabs(v - want) <= fmax(0.10 * fabs(want), 3 * s)))
                print_error("%s[%d] = %g +- %g, true %g\n", e->name, k, v, s, want);
            assert_true(fabs(v - want) <= fmax(0.10 * fabs(want), 3 * s));
        }
        if (!dg.explained)
            print_error("%s: not explained: held-out chi2 %g against %g (%d samples)\n",
                        e->name, dg.noise.chi2, dg.noise.limit, dg.noise.n);
        assert_true(dg.explained);
        dm_dataset_free(&d);
    }
}

/* A full turn of a plane circle, five turns a second: a turn about its
 * axis and a clock offset move every sample alike (phi_z x r and tau v
 * are both tangential, phi_z = omega tau). */
#define FAST_CIRCLE "circle:centre=0,0,-0.4;radius=0.05;rate=31.416;duration=0.2"

/* The combination of clock offset and z rotation is what is reported
 * determined, and it comes back within 3 of its reported sigma; neither
 * part is claimed. The baseline with the nuisances is the noise (a wrong
 * split of the pair misfits the run's end: issue 36). */
static void circle_reports_clock_rotation_combination(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    truth tr = LAB;
    tr.phi[2] = 1.2e-3; /* 38 us of the circle's turn */
    tr.tau = 4e-5;      /* |a| tau^2 / 2 = 0.04 um: the linear clock term holds */
    char file[64];
    record_run(&rb, FAST_CIRCLE, &tr, 21, file);
    dm_dataset d;
    dm_diagnosis dg;
    diagnose_file(&rb, file, &d, &dg);
    unlink(file);
    const dm_nuisance_fit *nf = &dg.nuisance;
    assert_false(dg.found);
    assert_false(isfinite(nf->sigma[5])); /* frame_rotation_z */
    assert_false(isfinite(nf->sigma[6])); /* clock_offset */
    assert_int_equal(nf->ncombination, 1);
    const dm_nuisance_combination *cb = &nf->combination[0];
    double want[8], got = cb->value, expect = 0;
    expected(&d, &tr, want);
    for (int k = 0; k < nf->n; k++) {
        /* only the pair, in the ratio 1 / omega */
        if (k != 5 && k != 6)
            assert_abs(cb->coef[k], 0, 1e-3 * fabs(cb->coef[5] * cb->coef[6]) + 1e-12, "coef %d", k);
        expect += cb->coef[k] * want[k];
    }
    double ratio = cb->ref == 6 ? cb->coef[5] : 1 / cb->coef[6]; /* d clock / d phi_z */
    assert_abs(ratio, 1 / 31.416, 0.01 / 31.416, "the pair's ratio, 1 / omega");
    if (!(fabs(got - expect) <= 3 * cb->sigma))
        print_error("combination %g +- %g, true %g\n", got, cb->sigma, expect);
    assert_true(fabs(got - expect) <= 3 * cb->sigma);
    /* determined well below either part: a 1-sigma under 2 us of clock */
    assert_true(cb->sigma * (cb->ref == 6 ? 1 : ratio) < 2e-6);
    assert_true(dg.base_held_chi2 < dg.n_held + 4 * sqrt(2.0 * dg.n_held));
    dm_dataset_free(&d);
}

/* In the tracker's own frame: with the nuisances fitted on the training
 * part and applied unchanged, the held-out samples are no worse than with
 * the frame placed without them on the same training part (the reader
 * places it on every sample, the held-out ones too: judged on that, the
 * baseline without nuisances has seen its held-out data). With nuisances
 * only, the held-out samples are the noise; with the robot's geometry
 * wrong as well (Zheng's lab run, docs/diagnosis.md §8) the nuisances
 * must not absorb it and extrapolate it worse. */
static void nuisances_do_not_worsen_held_out(void **state)
{
    (void)state;
    dm_robot rb;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    truth tr = LAB;
    tr.tracker = 1;
    tr.tau = 4e-5;
    for (int c = 0; c < 3; c++) {
        dm_robot real = rb;
        const double arms[3] = {2e-4, -1.5e-4, 2.5e-4};
        if (c == 2)
            assert_int_equal(dm_effects_apply(&real, "error_arm_length", arms, NULL), 0);
        const char *path = c == 1 ? CIRCLE : FAST_CIRCLE;
        char file[64];
        record_run(&real, path, &tr, 22 + c, file);
        dm_dataset d;
        dm_diagnosis dg;
        diagnose_file(&rb, file, &d, &dg);
        unlink(file);
        if (!(dg.base_held_rms <= dg.raw_held_rms) ||
            (c < 2 && dg.base_held_chi2 >= dg.n_held + 4 * sqrt(2.0 * dg.n_held)))
            print_error("%s (%s): held-out RMS %g with the nuisances, %g without, chi2/N %g\n",
                        path, c == 2 ? "arm lengths wrong" : "nuisances only", dg.base_held_rms,
                        dg.raw_held_rms, dg.base_held_chi2 / dg.n_held);
        assert_true(dg.base_held_rms <= dg.raw_held_rms);
        assert_true(dg.nuisance_gain_percent >= 0);
        if (c < 2) {
            assert_true(dg.base_held_chi2 < dg.n_held + 4 * sqrt(2.0 * dg.n_held));
            assert_false(dg.found);
        }
        dm_dataset_free(&d);
    }
}

/* Is f's nuisance shift what dm_nuisance_shift says makes a model
 * compensating? Checked from its parts, so that a flag set or cleared by
 * anything else fails. */
static int moves_too_far(const dm_diagnosis *dg, const dm_fit *f)
{
    return f->shift.rms_m > dg->compensating_m && f->shift.at_baseline_chi2 >= dg->base_train_chi2;
}

static void print_shift(const char *what, const dm_diagnosis *dg, const dm_fit *f)
{
    print_error("%s %s%s%s: compensating %d, moved %g m RMS (%g sigma), at the baseline's "
                "nuisances chi2 %g against the baseline's %g; limit %g m\n", what,
                f->cand[0]->name, f->ncand > 1 ? " + " : "", f->ncand > 1 ? f->cand[1]->name : "",
                f->shift.compensating, f->shift.rms_m, f->shift.sigmas, f->shift.at_baseline_chi2,
                dg->base_train_chi2, dg->compensating_m);
}

/* A compensating model is flagged and never the verdict; the genuine
 * effect beside it is not flagged. A compliant frame hidden in a ring-down
 * move (base frame, the lab's nuisances): the verdict names it, its
 * nuisances barely move (a stiffness has no rigid part), while the
 * arm-length candidate reaches its fit only by moving the frame
 * centimetres — flagged, still ranked, not the verdict, not a tie. */
static void genuine_effect_is_not_compensating(void **state)
{
    (void)state;
    dm_robot rb, real;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    real = rb;
    const double k[1] = {2e6};
    assert_int_equal(dm_effects_apply(&real, "base_stiffness", k, NULL), 0);
    truth tr = LAB;
    tr.tau = 5e-5; /* the ring-down's 120 m/s^2 (hidden_effect_is_still_named) */
    char file[64];
    record_run(&real,
               "p2p:from=-0.03,-0.02,-0.41;to=0.03,0.02,-0.39;duration=0.05;law=bangbang;dwell=0.05",
               &tr, 31, file);
    dm_dataset d;
    dm_diagnosis dg;
    diagnose_file(&rb, file, &d, &dg);
    unlink(file);
    assert_true(dg.found);
    assert_string_equal(dg.best.cand[0]->name, "base_stiffness");
    if (dg.best.shift.compensating || moves_too_far(&dg, &dg.best))
        print_shift("verdict", &dg, &dg.best);
    assert_int_equal(dg.best.shift.n, 7);
    assert_false(dg.best.shift.compensating);
    assert_false(moves_too_far(&dg, &dg.best));
    int arm = -1, flagged = 0;
    for (int r = 0; r < dg.nrank; r++) {
        const dm_fit *f = &dg.rank[r];
        if (f->ok && f->shift.compensating != moves_too_far(&dg, f))
            print_shift("ranked", &dg, f);
        assert_true(!f->ok || f->shift.compensating == moves_too_far(&dg, f));
        flagged += f->ok && f->shift.compensating;
        if (!strcmp(f->cand[0]->name, "error_arm_length"))
            arm = r;
    }
    assert_true(arm >= 0);
    if (!dg.rank[arm].shift.compensating)
        print_shift("arm lengths", &dg, &dg.rank[arm]);
    assert_true(dg.rank[arm].shift.compensating);
    /* far beyond its statistical reach too: the baseline's nuisances are known to microns */
    assert_true(dg.rank[arm].shift.sigmas > 100);
    assert_true(flagged < dg.nrank);
    for (int t = 0; t < dg.ntie; t++)
        assert_false(dg.rank[dg.tie[t]].shift.compensating);
    assert_int_equal(dg.nset_aside, 0); /* the flagged ones would not have been the verdict */
    dm_dataset_free(&d);
}

/* A compensating candidate that would have been the verdict is set aside.
 * A rod-end clearance hidden in a fast circle recorded in the tracker's
 * frame by a tracker whose distances read 1 % long: a distortion neither
 * the nuisances (rigid) nor any candidate models. Rod-length errors fit
 * most of it, best of all single effects, but only by moving the frame
 * millimetres; the verdict is the clearance, itself not compensating
 * (its value takes part of the distortion: 0.13 mm for 0.045), and the
 * residual is not called noise. */
static void compensating_candidate_is_set_aside(void **state)
{
    (void)state;
    dm_robot rb, real;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    real = rb;
    const double c[1] = {4.5e-5};
    assert_int_equal(dm_effects_apply(&real, "clearance", c, NULL), 0);
    truth tr = {.refl = {0.03004, -0.010025, 0.02003}, .nominal = {0.03, -0.01, 0.02},
                .tracker = 1, .noise = 1e-5, .scale = 1e-2}; /* clocks synchronised: a clearance */
    char file[64];
    record_run(&real, "circle:centre=0,0,-0.4;radius=0.05;rate=31.6227766;duration=0.199;plane=xy",
               &tr, 2, file);
    dm_dataset d;
    dm_diagnosis dg;
    diagnose_run(&rb, file, tr.noise, &d, &dg);
    unlink(file);
    if (dg.nset_aside != 1 || !dg.found || dg.best.shift.compensating)
        print_error("set aside %d, found %d (%s)\n", dg.nset_aside, dg.found,
                    dg.best.cand[0]->name);
    assert_int_equal(dg.nset_aside, 1);
    const dm_fit *aside = &dg.set_aside[0];
    if (!moves_too_far(&dg, aside))
        print_shift("set aside", &dg, aside);
    assert_true(aside->shift.compensating && moves_too_far(&dg, aside));
    assert_true(aside->score < dg.best.score); /* it would have been the verdict */
    assert_true(dg.found);
    assert_string_equal(dg.best.cand[0]->name, "clearance");
    if (dg.best.shift.compensating || moves_too_far(&dg, &dg.best))
        print_shift("verdict", &dg, &dg.best);
    assert_false(dg.best.shift.compensating);
    assert_false(moves_too_far(&dg, &dg.best));
    assert_false(dg.explained); /* the tracker's scale error remains */
    for (int t = 0; t < dg.ntie; t++)
        assert_false(dg.rank[dg.tie[t]].shift.compensating);
    dm_dataset_free(&d);
}

static void write_file(const char *text, char *file)
{
    snprintf(file, 64, "/tmp/dm_nuisance_XXXXXX");
    int fd = mkstemp(file);
    assert_true(fd >= 0);
    assert_true(write(fd, text, strlen(text)) == (ssize_t)strlen(text));
    close(fd);
}

static void expect_refused(const char *text, const char *what)
{
    char file[64];
    dm_dataset d;
    dm_error err;
    write_file(text, file);
    assert_int_equal(dm_dataset_read(file, &d, &err), DM_EINVAL);
    unlink(file);
    if (!strstr(err.msg, what) || !strstr(err.msg, file))
        print_error("expected '%s' naming the file, got: %s\n", what, err.msg);
    assert_non_null(strstr(err.msg, what));
    assert_non_null(strstr(err.msg, file));
}

static void bad_header_lines_are_refused(void **state)
{
    (void)state;
    const char *rows = "t,x_cmd,y_cmd,z_cmd,x_meas,y_meas,z_meas\n0,0,0,-0.4,0,0,-0.4\n"
                       "0.001,0.001,0,-0.4,0.001,0,-0.4\n0.002,0.002,0,-0.4,0.002,0,-0.4\n";
    char text[512];
    snprintf(text, sizeof text, "# frame: sideways\n%s", rows);
    expect_refused(text, ":1: '# frame: sideways': the frame is base or tracker");
    snprintf(text, sizeof text, "# frame: base\n# reflector: 0.01, 0.02\n%s", rows);
    expect_refused(text, ":2: '# reflector: 0.01, 0.02' is not three numbers");
    snprintf(text, sizeof text, "# reflector: 0, 0, 0.03\n%s", rows);
    expect_refused(text, ":1: '# reflector:' and '# clock:' need '# frame:");
    expect_refused("# frame: tracker\nx,y,z,mode,freq_hz\n0,0,-0.4,1,80\n",
                   ":1: '# frame:', '# reflector:' and '# clock:' are for tracker runs");
    snprintf(text, sizeof text, "# frame: tracker\n%s", rows); /* a line cannot place a frame */
    expect_refused(text, ":1: '# frame: tracker': the commanded path lies on a line");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(bad_header_lines_are_refused),
        cmocka_unit_test(nuisances_alone_name_no_cause),
        cmocka_unit_test(tracker_frame_is_placed),
        cmocka_unit_test(hidden_effect_is_still_named),
        cmocka_unit_test(circle_reports_clock_rotation_combination),
        cmocka_unit_test(nuisances_do_not_worsen_held_out),
        cmocka_unit_test(genuine_effect_is_not_compensating),
        cmocka_unit_test(compensating_candidate_is_set_aside),
    };
    return cmocka_run_group_tests_name("nuisance", tests, NULL, NULL);
}
