/* Monte Carlo of the platform error over tolerance bands and random
 * clearance states, and its linearisation (dm_tolerance.h). */
#include "dm_tolerance.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dm_model.h"
#include "dm_kinematics.h"
#include "dm_static.h"
#include "dm_threads.h"
#include "dm_vec3.h"
#include "dm_work.h"

const char *dm_tolerance_class_name(int c)
{
    static const char *const names[DM_TOL_NCLASS] = {
        "arm_length", "rod_length", "base_radius", "platform_radius", "theta_deg",
        "alpha0_deg", "clearance", "actuator_clearance_axial", "actuator_clearance_radial"};
    return c >= 0 && c < DM_TOL_NCLASS ? names[c] : "?";
}

void dm_tolerance_spec_default(dm_tolerance_spec *s)
{
    memset(s, 0, sizeof *s);
    s->dist = DM_TOL_UNIFORM;
    s->samples = 1000;
    s->seed = 1;
    s->flexibility = 1;
}

/* ---- counter-based random numbers -------------------------------------- */

static uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

typedef struct { uint64_t s; } rng;

/* The stream of sample i of seed: a function of (seed, i) only. */
static void rng_init(rng *r, uint64_t seed, uint64_t i)
{
    uint64_t a = seed, b = i ^ 0x6a09e667f3bcc909ULL;
    r->s = splitmix64(&a) ^ (splitmix64(&b) * 0xff51afd7ed558ccdULL);
}

uint64_t dm_tolerance_pose_seed(uint64_t seed, const double P[3])
{
    uint64_t h = seed;
    for (int k = 0; k < 3; k++) {
        /* whole nanometres: -0.0, 0.0 and any rounding of the last digits
         * below 0.5 nm agree (beyond 1e9 m, where no chain closes, one key) */
        double nm = fabs(P[k]) < 1e9 ? round(P[k] * 1e9) : 0.0;
        uint64_t q = (uint64_t)(int64_t)nm;
        h = splitmix64(&h) ^ q;
    }
    return splitmix64(&h);
}

static double uniform01(rng *r) /* [0, 1) */
{
    return (splitmix64(&r->s) >> 11) * 0x1.0p-53;
}

static double normal_trunc3(rng *r) /* N(0, 1) restricted to [-3, 3] */
{
    for (;;) {
        double u1 = 1.0 - uniform01(r), u2 = uniform01(r);
        double z = sqrt(-2.0 * log(u1)) * cos(2.0 * M_PI * u2);
        if (fabs(z) <= 3.0)
            return z;
    }
}

/* E[z^2] of the standard normal restricted to [-3, 3]:
 * 1 - 2 * 3 phi(3) / (2 Phi(3) - 1). */
static double trunc3_var(void)
{
    double phi3 = exp(-4.5) / sqrt(2 * M_PI), mass = erf(3.0 / M_SQRT2);
    return 1.0 - 6.0 * phi3 / mass;
}

/* ---- one state of the robot -------------------------------------------- */

enum { NP_GEOM = DM_TOL_NGEOM * 3, NP = NP_GEOM + 3 + 3 + 6 };

/* The drawn parameters of one sample: geometry deviations [class][chain],
 * then per chain the rod-length play, the axial play, the two radial
 * components (along e_i and e_z). */
typedef struct { double p[NP]; } state;

static int class_of(int p)
{
    if (p < NP_GEOM)
        return p / 3;
    if (p < NP_GEOM + 3)
        return DM_TOL_CLEARANCE;
    if (p < NP_GEOM + 6)
        return DM_TOL_ACT_AXIAL;
    return DM_TOL_ACT_RADIAL;
}

typedef struct {
    const dm_robot *file;
    const dm_tolerance_spec *spec;
    dm_robot rb;          /* the sample's robot (the model points here) */
    dm_model *md;
    dm_static *st;
    double e_axis[3][3], t_axis[3][3];
} tol_ws;

static void ws_free(tol_ws *w)
{
    dm_static_free(w->st);
    dm_model_free(w->md);
}

static int ws_init(tol_ws *w, const dm_robot *rb, const dm_tolerance_spec *spec, dm_error *err)
{
    memset(w, 0, sizeof *w);
    w->file = rb;
    w->spec = spec;
    w->rb = *rb;
    for (int i = 0; i < 3; i++) {
        double th = rb->theta0_rad + i * 2.0 * M_PI / 3.0;
        double e[3] = {cos(th), sin(th), 0}, t[3] = {-sin(th), cos(th), 0};
        dm_copy3(e, w->e_axis[i]);
        dm_copy3(t, w->t_axis[i]);
    }
    if (!spec->flexibility)
        return DM_OK;
    w->md = dm_model_alloc(&w->rb, spec->na ? spec->na : rb->na, spec->nb ? spec->nb : rb->nb, err);
    w->st = w->md ? dm_static_alloc(w->md, err) : NULL;
    if (!w->st) {
        ws_free(w);
        return err ? err->code : DM_ENOMEM;
    }
    return DM_OK;
}

static double *geom_field(dm_effects *e, int cls)
{
    switch (cls) {
    case DM_TOL_ARM_LENGTH: return e->err_arm_length_m;
    case DM_TOL_ROD_LENGTH: return e->err_rod_length_m;
    case DM_TOL_BASE_RADIUS: return e->err_base_radius_m;
    case DM_TOL_PLATFORM_RADIUS: return e->err_platform_radius_m;
    case DM_TOL_THETA: return e->err_theta_rad;
    default: return e->err_alpha0_rad;
    }
}

/* Error (real - commanded translation, m) of the robot in state s at P. */
static int evaluate(tol_ws *w, const double P[3], const state *s, double out[3], dm_error *err)
{
    dm_effects *ef = &w->rb.effects;
    const dm_effects *f0 = &w->file->effects;
    for (int c = 0; c < DM_TOL_NGEOM; c++) {
        double *d = geom_field(ef, c);
        const double *d0 = geom_field((dm_effects *)f0, c);
        for (int i = 0; i < 3; i++)
            d[i] = d0[i] + s->p[3 * c + i];
    }
    dm_kin_play play;
    for (int i = 0; i < 3; i++) {
        play.dlb[i] = s->p[NP_GEOM + i];
        for (int k = 0; k < 3; k++)
            play.shift[i][k] = s->p[NP_GEOM + 3 + i] * w->t_axis[i][k] +
                               s->p[NP_GEOM + 6 + 2 * i] * w->e_axis[i][k] +
                               s->p[NP_GEOM + 7 + 2 * i] * (k == 2 ? 1.0 : 0.0);
    }
    dm_pose pose;
    int rc = dm_kin_pose_play(&w->rb, P, &play, &pose, err);
    if (rc)
        return rc;
    dm_copy3(pose.offset, out);
    if (!w->spec->flexibility)
        return DM_OK;
    double u6[6];
    rc = dm_model_build(w->md, &pose, err);
    if (!rc)
        rc = dm_static_factor(w->st, w->md, err);
    if (!rc)
        rc = dm_static_platform_error(w->st, w->md, w->md->F_gravity, u6, err);
    if (!rc)
        for (int k = 0; k < 3; k++)
            out[k] += u6[k];
    return rc;
}

/* Sample i's state from the pose's streams (pose_seed: dm_tolerance_pose_seed). */
static void draw(const tol_ws *w, uint64_t pose_seed, long i, state *s)
{
    const dm_tolerance_spec *sp = w->spec;
    const dm_effects *ef = &w->file->effects;
    rng r;
    rng_init(&r, pose_seed, (uint64_t)i);
    for (int c = 0; c < DM_TOL_NGEOM; c++)
        for (int ch = 0; ch < 3; ch++) {
            double x = sp->dist == DM_TOL_UNIFORM ? 2.0 * uniform01(&r) - 1.0 : normal_trunc3(&r) / 3.0;
            s->p[3 * c + ch] = sp->tol[c] * x;
        }
    double c = ef->clearance_m, v = ef->actuator_clearance_axial_m, cr = ef->actuator_clearance_radial_m;
    for (int ch = 0; ch < 3; ch++) {
        double dl = 0;
        for (int end = 0; end < 4; end++) { /* two rods, two balls each */
            double rho = c * fabs(normal_trunc3(&r)) / 3.0, u = 2.0 * uniform01(&r) - 1.0;
            dl += rho * u;
        }
        s->p[NP_GEOM + ch] = 0.5 * dl; /* mean over the two rods */
        s->p[NP_GEOM + 3 + ch] = v * uniform01(&r);
        double rho = cr * fabs(normal_trunc3(&r)) / 3.0, phi = 2.0 * M_PI * uniform01(&r);
        s->p[NP_GEOM + 6 + 2 * ch] = rho * cos(phi);
        s->p[NP_GEOM + 7 + 2 * ch] = rho * sin(phi);
    }
}

/* Mean state and the variance of each parameter about it. */
static void moments(const tol_ws *w, state *mean, double var[NP], double var_unit[NP])
{
    const dm_tolerance_spec *sp = w->spec;
    const dm_effects *ef = &w->file->effects;
    double T = trunc3_var();
    double g = sp->dist == DM_TOL_UNIFORM ? 1.0 / 3.0 : T / 9.0;
    memset(mean, 0, sizeof *mean);
    for (int p = 0; p < NP_GEOM; p++) {
        var_unit[p] = g;
        var[p] = g * sp->tol[p / 3] * sp->tol[p / 3];
    }
    double erho2 = T / 9.0; /* E[rho^2] per unit clearance */
    for (int ch = 0; ch < 3; ch++) {
        int a = NP_GEOM + ch, x = NP_GEOM + 3 + ch, r0 = NP_GEOM + 6 + 2 * ch;
        var_unit[a] = erho2 / 3.0; /* (1/4) 4 E[rho^2] E[u^2] */
        var[a] = var_unit[a] * ef->clearance_m * ef->clearance_m;
        mean->p[x] = 0.5 * ef->actuator_clearance_axial_m;
        var_unit[x] = 1.0 / 12.0;
        var[x] = var_unit[x] * ef->actuator_clearance_axial_m * ef->actuator_clearance_axial_m;
        for (int k = 0; k < 2; k++) {
            var_unit[r0 + k] = erho2 / 2.0;
            var[r0 + k] = var_unit[r0 + k] * ef->actuator_clearance_radial_m *
                          ef->actuator_clearance_radial_m;
        }
    }
}

/* ---- checks and cost ---------------------------------------------------- */

double dm_tolerance_estimate_s(const dm_robot *rb, const dm_tolerance_spec *sp)
{
    /* measured on one thread of the development machine: the closure 8 us;
     * assembly + factor + one solve 0.24 ms at 210 DOF, 0.62 ms at 426 */
    double per = 8e-6;
    if (sp->flexibility) {
        double s = dm_model_dofs(rb, sp->na ? sp->na : rb->na, sp->nb ? sp->nb : rb->nb) / 210.0;
        per += 2.5e-4 * pow(s, 1.5);
    }
    return (double)sp->samples * per + 2.0 * NP * per;
}

int dm_tolerance_check(const dm_robot *rb, const dm_tolerance_spec *sp, dm_error *err)
{
    for (int c = 0; c < DM_TOL_NGEOM; c++)
        if (!(sp->tol[c] >= 0) || !isfinite(sp->tol[c]))
            return dm_fail(err, DM_EINVAL, "tolerance %s: must be >= 0, got %g",
                           dm_tolerance_class_name(c), sp->tol[c]);
    if (sp->samples < 1)
        return dm_fail(err, DM_EINVAL, "samples: must be >= 1, got %ld", sp->samples);
    if (sp->samples > 10000000L) /* 24 bytes of results each: at most 240 MB */
        return dm_fail(err, DM_EINVAL, "samples: at most 1e7, got %ld", sp->samples);
    if (!(sp->spec_m >= 0) || !isfinite(sp->spec_m))
        return dm_fail(err, DM_EINVAL, "spec: must be > 0 m, got %g", sp->spec_m);
    double est = dm_tolerance_estimate_s(rb, sp);
    char what[64];
    snprintf(what, sizeof what, "samples: %ld samples on one thread", sp->samples);
    return dm_work_check(what, (dm_work){est, 0, 0}, (dm_work){DM_TOLERANCE_MAX_SECONDS, 0, 0},
                         "fewer samples, a coarser mesh, no flexible model", sp->force_long, err);
}

/* ---- the run ----------------------------------------------------------- */

int dm_tolerance_samples(const dm_robot *rb, const dm_tolerance_spec *sp, const double P[3],
                         long first, long count, double *e, dm_error *err)
{
    tol_ws w;
    int rc = dm_tolerance_check(rb, sp, err);
    if (!rc)
        rc = ws_init(&w, rb, sp, err);
    if (rc)
        return rc;
    uint64_t pose_seed = dm_tolerance_pose_seed(sp->seed, P);
    for (long i = 0; !rc && i < count; i++) {
        state s;
        draw(&w, pose_seed, first + i, &s);
        rc = evaluate(&w, P, &s, e + 3 * i, err);
    }
    ws_free(&w);
    return rc;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The linearisation: the mean state's error and the sensitivities (1 +
 * 2 NP evaluations, each a unit of its progress stage). */
static int linearise(const dm_robot *rb, const dm_tolerance_spec *sp, const double P[3],
                     dm_tolerance_result *res, dm_progress_meter *pm, dm_error *err)
{
    tol_ws w;
    int rc = ws_init(&w, rb, sp, err);
    if (rc)
        return rc;
    state mean;
    double var[NP], var_unit[NP], cov[9] = {0}, cls[DM_TOL_NCLASS] = {0}, cls_unit[DM_TOL_NCLASS] = {0};
    moments(&w, &mean, var, var_unit);
    dm_progress_begin(pm, "linearisation", "evaluations", 1 + 2 * NP);
    rc = evaluate(&w, P, &mean, res->deterministic_m, err);
    dm_progress_add(pm, 1);
    for (int p = 0; p < NP && !rc; p++) {
        /* steps: 1 um on 0.1-1 m links, 1e-5 rad: truncation O(h^2/L^2) ~ 1e-11,
         * round-off eps L / h ~ 1e-10 of the derivative */
        int cl = class_of(p);
        double h = cl == DM_TOL_THETA || cl == DM_TOL_ALPHA0 ? 1e-5 : 1e-6, ep[3], em[3], S[3];
        state s = mean;
        s.p[p] = mean.p[p] + h;
        rc = evaluate(&w, P, &s, ep, err);
        s.p[p] = mean.p[p] - h;
        if (!rc)
            rc = evaluate(&w, P, &s, em, err);
        if (rc)
            break;
        dm_progress_add(pm, 2);
        for (int k = 0; k < 3; k++)
            S[k] = (ep[k] - em[k]) / (2 * h);
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                cov[3 * a + b] += S[a] * S[b] * var[p];
        cls[cl] += dm_dot3(S, S) * var[p];
        cls_unit[cl] += dm_dot3(S, S) * var_unit[p];
    }
    ws_free(&w);
    if (rc)
        return rc;
    dm_progress_end(pm);
    res->deterministic_error_m = dm_norm3(res->deterministic_m);
    for (int k = 0; k < 3; k++)
        res->predicted_std_m[k] = sqrt(cov[4 * k]);
    if (res->deterministic_error_m > 0) {
        double u[3], Cu[3];
        dm_scale3(1.0 / res->deterministic_error_m, res->deterministic_m, u);
        for (int a = 0; a < 3; a++)
            Cu[a] = cov[3 * a] * u[0] + cov[3 * a + 1] * u[1] + cov[3 * a + 2] * u[2];
        res->predicted_std_error_m = sqrt(dm_dot3(u, Cu));
    } else
        res->predicted_std_error_m = NAN;
    res->dominant = -1;
    double best = 0;
    for (int c = 0; c < DM_TOL_NCLASS; c++) {
        double unit = c == DM_TOL_THETA || c == DM_TOL_ALPHA0 ? M_PI / 180 : 1.0; /* per degree */
        res->sensitivity[c] = sqrt(cls_unit[c]) * unit;
        res->std_contribution_m[c] = sqrt(cls[c]);
        if (res->std_contribution_m[c] > best) {
            best = res->std_contribution_m[c];
            res->dominant = c;
        }
    }
    return DM_OK;
}

static int tolerance_pose(const dm_robot *rb, const dm_tolerance_spec *sp, const double P[3],
                          int threads, dm_tolerance_result *res, dm_error *err);

/* Samples a thread counts before it reports them (one lock each time). */
#define PROGRESS_BATCH 8

/* BLAS on one thread while the samples run (dm_threads.h: one thread and
 * several must give the same result; inside a sweep's threads it is so
 * already). */
int dm_tolerance_pose(const dm_robot *rb, const dm_tolerance_spec *sp, const double P[3],
                      int threads, dm_tolerance_result *res, dm_error *err)
{
    dm_threads_saved saved = dm_threads_serial_blas();
    int rc = tolerance_pose(rb, sp, P, threads, res, err);
    dm_threads_restore(saved);
    return rc;
}

static int tolerance_pose(const dm_robot *rb, const dm_tolerance_spec *sp, const double P[3],
                          int threads, dm_tolerance_result *res, dm_error *err)
{
    int rc = dm_tolerance_check(rb, sp, err);
    if (rc)
        return rc;
    memset(res, 0, sizeof *res);
    long n = sp->samples;
    double *e = malloc(sizeof(double) * 3 * n), *norm = malloc(sizeof(double) * n);
    if (!e || !norm) {
        free(e);
        free(norm);
        return dm_fail(err, DM_ENOMEM, "out of memory for %ld samples", n);
    }
    dm_progress_meter pm;
    dm_progress_meter_init(&pm, sp->progress, sp->progress_user);
    rc = linearise(rb, sp, P, res, &pm, err);
    int nt = threads > 0 ? threads : 1;
    uint64_t pose_seed = dm_tolerance_pose_seed(sp->seed, P);
    long bad = n; /* the first failing sample, whatever the thread count */
    dm_error first_err;
    dm_error_clear(&first_err);
    if (!rc) {
        dm_progress_begin(&pm, "Monte Carlo", "samples", n);
#pragma omp parallel num_threads(nt)
        {
            tol_ws w;
            dm_error my;
            int mrc = ws_init(&w, rb, sp, &my);
            long mybad = n, unreported = 0;
#pragma omp for schedule(dynamic, 64)
            for (long i = 0; i < n; i++) {
                if (mrc || i > mybad)
                    continue;
                state s;
                draw(&w, pose_seed, i, &s);
                if (evaluate(&w, P, &s, e + 3 * i, &my))
                    mybad = i;
                if (pm.fn && ++unreported == PROGRESS_BATCH) { /* a lock per 8 samples */
                    dm_progress_add(&pm, unreported);
                    unreported = 0;
                }
            }
            if (mrc)
                mybad = 0;
            if (!mrc)
                ws_free(&w);
#pragma omp critical
            if (mybad < bad) {
                bad = mybad;
                first_err = my;
            }
        }
        if (bad < n) {
            if (err)
                *err = first_err;
            rc = first_err.code ? first_err.code : DM_ENUMERIC;
        } else {
            dm_progress_end(&pm);
        }
    }
    if (!rc) {
        /* moments about the first sample: when every sample is the same
         * the mean is that value and the spread exactly zero */
        double s1 = 0, s2 = 0, m[3] = {0}, q[3] = {0}, x0 = 0, c0[3];
        long over = 0;
        for (long i = 0; i < n; i++) {
            norm[i] = dm_norm3(e + 3 * i);
            if (sp->spec_m > 0 && norm[i] > sp->spec_m)
                over++;
        }
        x0 = norm[0];
        dm_copy3(e, c0);
        for (long i = 0; i < n; i++) {
            s1 += norm[i] - x0;
            for (int k = 0; k < 3; k++)
                m[k] += e[3 * i + k] - c0[k];
        }
        double d1 = s1 / n, dm[3];
        for (int k = 0; k < 3; k++)
            dm[k] = m[k] / n;
        for (long i = 0; i < n; i++) {
            double d = norm[i] - x0 - d1;
            s2 += d * d;
            for (int k = 0; k < 3; k++) {
                double dk = e[3 * i + k] - c0[k] - dm[k];
                q[k] += dk * dk;
            }
        }
        res->samples = n;
        res->mean_error_m = x0 + d1;
        for (int k = 0; k < 3; k++)
            res->mean_m[k] = c0[k] + dm[k];
        res->std_error_m = n > 1 ? sqrt(s2 / (n - 1)) : 0.0;
        for (int k = 0; k < 3; k++)
            res->std_m[k] = n > 1 ? sqrt(q[k] / (n - 1)) : 0.0;
        res->stderr_mean_m = res->std_error_m / sqrt((double)n);
        res->p_exceed_spec = sp->spec_m > 0 ? (double)over / n : NAN;
        qsort(norm, n, sizeof *norm, cmp_double);
        double pos = 0.95 * (n - 1);
        long lo = (long)floor(pos);
        long hi = lo + 1 < n ? lo + 1 : lo;
        res->p95_error_m = norm[lo] + (pos - lo) * (norm[hi] - norm[lo]);
        res->max_error_m = norm[n - 1];
    }
    free(e);
    free(norm);
    return rc;
}
