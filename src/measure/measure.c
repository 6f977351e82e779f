/* Measured data: reading, writing, model predictions, synthetic data. */
#include "dm_measure.h"

#include <assert.h>
#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_analysis.h"
#include "dm_csv.h"
#include "dm_integrate.h"
#include "dm_trajectory.h"

/* ---- random numbers ------------------------------------------------------- */

static uint64_t splitmix64(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

double dm_rng_uniform(dm_rng *r) { return (splitmix64(&r->state) >> 11) * 0x1.0p-53; }

double dm_rng_normal(dm_rng *r)
{
    double u1 = dm_rng_uniform(r), u2 = dm_rng_uniform(r);
    return sqrt(-2.0 * log(1.0 - u1)) * cos(2 * M_PI * u2);
}

/* ---- kinds ---------------------------------------------------------------- */

static const char *const KIND_NAMES[] = {"modal", "static", "tracker"};
static const char *const COLUMNS[3][10] = {
    {"x", "y", "z", "mode", "freq_hz", NULL},
    {"x", "y", "z", "fx", "fy", "fz", "dx", "dy", "dz", NULL},
    {"t", "x_cmd", "y_cmd", "z_cmd", "x_meas", "y_meas", "z_meas", NULL}};

const char *dm_data_kind_name(dm_data_kind k) { return KIND_NAMES[k]; }

int dm_data_kind_parse(const char *name, dm_data_kind *k)
{
    for (int i = 0; i < 3; i++)
        if (!strcmp(name, KIND_NAMES[i])) {
            *k = (dm_data_kind)i;
            return 0;
        }
    return -1;
}

int dm_dataset_push(dm_dataset *d, const dm_sample *s, dm_error *err)
{
    if (d->n == d->cap) {
        int cap = d->cap ? 2 * d->cap : 256;
        dm_sample *g = realloc(d->s, sizeof *g * cap);
        if (!g)
            return dm_fail(err, DM_ENOMEM, "%s: out of memory for %d samples", d->source, cap);
        d->s = g;
        d->cap = cap;
    }
    d->s[d->n++] = *s;
    return DM_OK;
}

void dm_dataset_free(dm_dataset *d)
{
    free(d->s);
    d->s = NULL;
    d->n = d->cap = d->npose = 0;
}

/* ---- reading ----------------------------------------------------------------- */

typedef struct {
    dm_csv in;
    int template;          /* a measurement template: measured values may be empty */
    dm_error *err;
} csv_ctx;

/* The columns a measurement template leaves empty. */
static int measured_column(const char *name)
{
    static const char *const M[] = {"freq_hz", "dx", "dy", "dz", "x_meas", "y_meas", "z_meas"};
    for (int k = 0; k < 7; k++)
        if (!strcmp(name, M[k]))
            return 1;
    return 0;
}

/* Column `name` of the current row into *out; 1 when an optional column
 * is absent. A template's empty measured value reads as 0. */
static int cell(const csv_ctx *c, const char *name, int required, double *out)
{
    int i = dm_csv_column(&c->in, name);
    if (i < 0)
        return required ? dm_fail(c->err, DM_EINVAL, "%s: no column '%s'", c->in.path, name) : 1;
    if ((i >= c->in.ncells || !*c->in.cells[i]) && c->template && measured_column(name)) {
        *out = 0;
        return DM_OK;
    }
    return dm_csv_number(&c->in, i, out, c->err);
}

static int bad(const csv_ctx *c, const char *name, const char *what)
{
    return dm_fail(c->err, DM_EINVAL, "%s:%d: column %d (%s): %s", c->in.path, c->in.line,
                   dm_csv_column(&c->in, name) + 1, name, what);
}

static int read_row(csv_ctx *c, dm_dataset *d, double *last_t, double last_P[3])
{
    dm_sample s = {0};
    double v[8];
    int rc;
    s.line = c->in.line;
    if (d->kind == DM_DATA_MODAL) {
        for (int k = 0; k < 5; k++)
            if ((rc = cell(c, COLUMNS[0][k], 1, &v[k])))
                return rc;
        rc = cell(c, "sigma_hz", 0, &s.sigma);
        if (rc == DM_EINVAL)
            return rc;
        if (v[3] != floor(v[3]) || v[3] < 1 || v[3] > 64)
            return bad(c, "mode", "not a mode rank 1..64 (1 = lowest)");
        if (!(v[4] > 0) && !(c->template && v[4] == 0))
            return bad(c, "freq_hz", "must be > 0");
        if (rc == DM_OK && !(s.sigma > 0))
            return bad(c, "sigma_hz", "must be > 0");
        memcpy(s.P, v, sizeof s.P);
        s.mode = (int)v[3];
        s.value = v[4];
        if (d->n == 0 || memcmp(s.P, last_P, sizeof s.P))
            d->npose++;
        memcpy(last_P, s.P, sizeof s.P);
        s.pose_id = d->npose - 1;
        return dm_dataset_push(d, &s, c->err);
    }
    if (d->kind == DM_DATA_STATIC) {
        static const char *const names[9] = {"x", "y", "z", "fx", "fy", "fz", "dx", "dy", "dz"};
        double all[9];
        for (int k = 0; k < 9; k++)
            if ((rc = cell(c, names[k], 1, &all[k])))
                return rc;
        rc = cell(c, "sigma_m", 0, &s.sigma);
        if (rc == DM_EINVAL)
            return rc;
        if (rc == DM_OK && !(s.sigma > 0))
            return bad(c, "sigma_m", "must be > 0");
        memcpy(s.P, all, sizeof s.P);
        memcpy(s.force, all + 3, sizeof s.force);
        s.pose_id = d->npose++;
        for (int k = 0; k < 3; k++) {
            s.comp = k;
            s.value = all[6 + k];
            if ((rc = dm_dataset_push(d, &s, c->err)))
                return rc;
        }
        return DM_OK;
    }
    for (int k = 0; k < 7; k++)
        if ((rc = cell(c, COLUMNS[2][k], 1, &v[k])))
            return rc;
    if (d->n && !(v[0] > *last_t))
        return bad(c, "t", "times must increase strictly");
    *last_t = v[0];
    s.t = v[0];
    memcpy(s.P, v + 1, sizeof s.P);
    s.pose_id = d->npose++;
    for (int k = 0; k < 3; k++) {
        s.comp = k;
        s.value = v[4 + k] - v[1 + k];
        if ((rc = dm_dataset_push(d, &s, c->err)))
            return rc;
    }
    return DM_OK;
}

static int detect_kind(csv_ctx *c, dm_dataset *d)
{
    for (int k = 0; k < 3; k++) {
        int ok = 1;
        for (int j = 0; COLUMNS[k][j] && ok; j++)
            ok = dm_csv_column(&c->in, COLUMNS[k][j]) >= 0;
        if (ok) {
            d->kind = (dm_data_kind)k;
            return DM_OK;
        }
    }
    return dm_fail(c->err, DM_EINVAL,
                   "%s:%d: header is none of: modal (x,y,z,mode,freq_hz[,sigma_hz]), static "
                   "(x,y,z,fx,fy,fz,dx,dy,dz[,sigma_m]), tracker "
                   "(t,x_cmd,y_cmd,z_cmd,x_meas,y_meas,z_meas)",
                   c->in.path, c->in.line);
}

static int read_file(const char *path, int template, dm_dataset *d, dm_error *err)
{
    memset(d, 0, sizeof *d);
    snprintf(d->source, sizeof d->source, "%s", path);
    csv_ctx c = {.template = template, .err = err};
    int rc = dm_csv_open(&c.in, path, err);
    if (rc)
        return rc;
    double last_t = 0, last_P[3] = {0};
    dm_csv_line kind;
    while (!rc && !(rc = dm_csv_next(&c.in, &kind, err)) && kind != DM_CSV_END) {
        const char *robot = c.in.comment;
        if (kind == DM_CSV_COMMENT && !strncmp(robot, " robot:", 7) && !d->robot[0]) {
            robot += 7 + strspn(robot + 7, " \t");
            snprintf(d->robot, sizeof d->robot, "%.*s", (int)strcspn(robot, "\r\n"), robot);
        } else if (kind == DM_CSV_HEADER)
            rc = detect_kind(&c, d);
        else if (kind == DM_CSV_ROW)
            rc = read_row(&c, d, &last_t, last_P);
    }
    dm_csv_close(&c.in);
    if (!rc && !d->n)
        rc = dm_fail(err, DM_EINVAL, "%s: no data rows", path);
    if (!rc && d->kind == DM_DATA_TRACKER && fabs(d->s[0].t) > 1e-12)
        rc = dm_fail(err, DM_EINVAL, "%s:%d: column 1 (t): the first sample must be at t = 0",
                     path, d->s[0].line);
    if (rc)
        dm_dataset_free(d);
    return rc;
}

int dm_dataset_read(const char *path, dm_dataset *d, dm_error *err)
{
    return read_file(path, 0, d, err);
}

int dm_dataset_read_template(const char *path, dm_dataset *d, dm_error *err)
{
    return read_file(path, 1, d, err);
}

int dm_dataset_write(const dm_dataset *d, FILE *out)
{
    if (d->robot[0])
        fprintf(out, "# robot: %s\n", d->robot);
    /* the sigma column only when every sample has one (> 0, as the reader
     * requires; 0 means not given: equal weights) */
    int sigma = d->n > 0;
    for (int i = 0; i < d->n; i++)
        sigma &= d->s[i].sigma > 0;
    if (d->kind == DM_DATA_MODAL) {
        fprintf(out, "x,y,z,mode,freq_hz%s\n", sigma ? ",sigma_hz" : "");
        for (int i = 0; i < d->n; i++) {
            const dm_sample *s = &d->s[i];
            fprintf(out, "%.9g,%.9g,%.9g,%d,%.12g", s->P[0], s->P[1], s->P[2], s->mode, s->value);
            if (sigma)
                fprintf(out, ",%.6g", s->sigma);
            fputc('\n', out);
        }
    } else if (d->kind == DM_DATA_STATIC) {
        fprintf(out, "x,y,z,fx,fy,fz,dx,dy,dz%s\n", sigma ? ",sigma_m" : "");
        for (int i = 0; i + 2 < d->n; i += 3) {
            const dm_sample *s = &d->s[i];
            fprintf(out, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.12g,%.12g,%.12g", s->P[0], s->P[1],
                    s->P[2], s->force[0], s->force[1], s->force[2], s->value, d->s[i + 1].value,
                    d->s[i + 2].value);
            if (sigma)
                fprintf(out, ",%.6g", s->sigma);
            fputc('\n', out);
        }
    } else {
        fprintf(out, "t,x_cmd,y_cmd,z_cmd,x_meas,y_meas,z_meas\n");
        for (int i = 0; i + 2 < d->n; i += 3) {
            const dm_sample *s = &d->s[i];
            fprintf(out, "%.9g,%.12g,%.12g,%.12g,%.12g,%.12g,%.12g\n", s->t, s->P[0], s->P[1],
                    s->P[2], s->P[0] + s->value, s->P[1] + d->s[i + 1].value,
                    s->P[2] + d->s[i + 2].value);
        }
    }
    return ferror(out) ? DM_EIO : DM_OK;
}

/* ---- the prediction workspace ------------------------------------------------ */

/* What the model's workspaces are sized by, beyond the mesh: the DOF
 * layout (arm-root, rod-end DOFs), the factor geometric stiffness keeps,
 * the members' sections, and which entries of M and K the assembly adds
 * to (recorded once, at the first build). Runs whose robots agree on
 * these share one analysis workspace. */
typedef struct {
    int root[3], joint_springs, actuator_spring, geometric_stiffness, elbow_masses;
    dm_member arm, rod;
} layout_key;

static void key_of(const dm_robot *rb, layout_key *k)
{
    const dm_effects *fx = &rb->effects;
    memset(k, 0, sizeof *k); /* padding too: keys are compared with memcmp */
    for (int i = 0; i < 3; i++)
        k->root[i] = dm_effects_base_compliant(fx, i);
    k->joint_springs = fx->joint_stiffness_n_per_m > 0;
    k->actuator_spring = fx->actuator_stiffness_nm_per_rad > 0;
    k->geometric_stiffness = fx->geometric_stiffness != 0;
    k->elbow_masses = fx->elbow_mass_kg > 0;
    k->arm = rb->arm;
    k->rod = rb->rod;
}

typedef struct {
    int n, cap;
    double *t, *e; /* e: 3 per sample */
} track;

struct dm_predictor {
    dm_dataset data;   /* the caller's samples (borrowed); n: those predicted */
    int nall;          /* samples in the dataset */
    int na, nb, kmax;
    /* the robot of the current run: the analysis points to this copy, so
     * a run may pass any robot and the workspace still reads the right one */
    dm_robot robot;
    dm_analysis *an;   /* modal/static data: sized for `key` (NULL: not yet) */
    layout_key key;
    /* tracker data: the commanded times and positions of all samples, the
     * path through those predicted (tr_npose of them; 0: none yet) and the
     * integrated error */
    double *t, *xyz;
    dm_trajectory tr;
    int tr_npose;
    track tk;
};

static int max_mode(const dm_dataset *d)
{
    int m = 1;
    for (int i = 0; i < d->n; i++)
        if (d->s[i].mode > m)
            m = d->s[i].mode;
    return m;
}

dm_predictor *dm_predictor_new(const dm_robot *rb, const dm_dataset *d, int na, int nb,
                               dm_error *err)
{
    dm_predictor *p = calloc(1, sizeof *p);
    if (!p) {
        dm_fail(err, DM_ENOMEM, "out of memory");
        return NULL;
    }
    p->data = *d;
    p->nall = d->n;
    p->na = na > 0 ? na : rb->na;
    p->nb = nb > 0 ? nb : rb->nb;
    p->kmax = d->kind == DM_DATA_MODAL ? max_mode(d) : 1;
    if (d->kind == DM_DATA_TRACKER) {
        int m = d->npose;
        p->t = malloc(sizeof(double) * (m ? m : 1));
        p->xyz = malloc(3 * sizeof(double) * (m ? m : 1));
        if (!p->t || !p->xyz) {
            dm_predictor_free(p);
            dm_fail(err, DM_ENOMEM, "out of memory");
            return NULL;
        }
        for (int i = 0; i < m; i++) {
            p->t[i] = d->s[3 * i].t;
            memcpy(p->xyz + 3 * i, d->s[3 * i].P, 3 * sizeof(double));
        }
    }
    return p;
}

void dm_predictor_free(dm_predictor *p)
{
    if (!p)
        return;
    dm_analysis_free(p->an);
    if (p->tr_npose)
        dm_traj_free(&p->tr);
    free(p->t);
    free(p->xyz);
    free(p->tk.t);
    free(p->tk.e);
    free(p);
}

void dm_predictor_window(dm_predictor *p, int n)
{
    assert(n >= 0 && n <= p->nall);
    p->data.n = n;
    p->data.npose = n > 0 ? p->data.s[n - 1].pose_id + 1 : 0;
}

/* The analysis workspace for the current robot: kept while the layout is
 * the same, allocated afresh when an effect changes it. */
static int pose_workspace(dm_predictor *p, dm_error *err)
{
    layout_key key;
    key_of(&p->robot, &key);
    if (p->an && !memcmp(&key, &p->key, sizeof key)) {
        /* cold, as a fresh workspace would start: a run's results must not
         * depend on the runs before it */
        dm_modal_forget(p->an->modal);
        return DM_OK;
    }
    dm_analysis_free(p->an);
    dm_error aerr; /* err may be NULL */
    p->an = dm_analysis_alloc(&p->robot, p->na, p->nb, p->kmax, DM_EIGEN_PARTIAL, &aerr);
    if (!p->an)
        return dm_fail(err, aerr.code, "%s", aerr.msg);
    p->key = key;
    return DM_OK;
}

static int predict_poses(dm_predictor *p, double *pred, dm_error *err)
{
    const dm_robot *rb = &p->robot;
    const dm_dataset *d = &p->data;
    int kmax = p->kmax, n = dm_model_dofs(rb, p->na, p->nb);
    if (kmax > n)
        return dm_fail(err, DM_EINVAL, "%s: mode %d is beyond the model's %d modes", d->source,
                       kmax, n);
    int rc = pose_workspace(p, err);
    if (rc)
        return rc;
    dm_pose_result res;
    dm_pose loaded;
    int last = -1;
    int clearance = d->kind == DM_DATA_STATIC && dm_effects_clearance(&rb->effects);
    for (int i = 0; i < d->n && !rc; i++) {
        const dm_sample *s = &d->s[i];
        if (s->pose_id != last) {
            dm_error perr;
            rc = dm_analysis_run(p->an, s->P, kmax, &res, &perr);
            if (!rc && clearance) { /* the added force may open clearances the other way */
                double W[3];
                dm_kin_platform_force(rb, NULL, s->force, W);
                rc = dm_kin_pose_loaded(rb, s->P, W, &loaded, &perr);
            }
            if (rc)
                rc = dm_fail(err, rc, "%s:%d: %s", d->source, s->line, perr.msg);
            last = s->pose_id;
        }
        if (rc)
            break;
        if (d->kind == DM_DATA_MODAL) {
            pred[i] = res.modes->freq_hz[s->mode - 1];
        } else {
            double v = 0;
            for (int j = 0; j < 3; j++)
                v += res.compliance[6 * j + s->comp] * s->force[j];
            if (clearance)
                v += loaded.offset[s->comp] - res.pose.offset[s->comp];
            pred[i] = v;
        }
    }
    return rc;
}

static int keep(void *user, const dm_integ_sample *s)
{
    track *tk = user;
    if (tk->n == tk->cap) {
        int cap = tk->cap ? 2 * tk->cap : 1024;
        double *t = realloc(tk->t, sizeof(double) * cap), *e;
        if (t)
            tk->t = t;
        e = t ? realloc(tk->e, 3 * sizeof(double) * cap) : NULL;
        if (!e)
            return 1;
        tk->e = e;
        tk->cap = cap;
    }
    tk->t[tk->n] = s->t_s;
    memcpy(tk->e + 3 * tk->n, s->error, 3 * sizeof(double));
    tk->n++;
    return 0;
}

/* Tracker: the elastic error (static + dynamic) along the commanded path,
 * 10 modes with the quasi-static correction, linear between steps. The
 * path is the spline through the samples predicted, made once per window;
 * the integrator sizes its own workspace for each run. */
static int predict_tracker(dm_predictor *p, double *pred, dm_error *err)
{
    const dm_dataset *d = &p->data;
    int m = d->npose, rc = DM_OK;
    const double *t = p->t;
    if (p->tr_npose != m) {
        if (p->tr_npose)
            dm_traj_free(&p->tr);
        p->tr_npose = 0;
        if ((rc = dm_traj_from_samples(t, p->xyz, m, d->source, &p->tr, err)))
            return rc;
        p->tr_npose = m;
    }
    track *tk = &p->tk;
    tk->n = 0;
    dm_integ_opts o;
    dm_integ_summary sum;
    dm_integ_opts_default(&o);
    o.method = DM_ODE_CLOSED_FORM;
    o.quasi_static = 1;
    o.reference = 0;
    o.na = p->na;
    o.nb = p->nb;
    o.dt_s = fmin(1e-3, t[m - 1] / (m - 1));
    o.force = 1; /* the work of the whole command is judged before it (dm_check_size) */
    rc = dm_integrate_trajectory(&p->robot, &p->tr, &o, keep, tk, &sum, err);
    for (int i = 0, j = 0; i < m && !rc; i++) {
        while (j + 2 < tk->n && tk->t[j + 1] < t[i])
            j++;
        double w = tk->n > 1 ? (t[i] - tk->t[j]) / (tk->t[j + 1] - tk->t[j]) : 0;
        w = fmin(1, fmax(0, w));
        for (int k = 0; k < 3; k++)
            pred[3 * i + k] = (1 - w) * tk->e[3 * j + k] + w * tk->e[3 * (j + 1) + k];
    }
    return rc;
}

int dm_predictor_run(dm_predictor *p, const dm_robot *robot, double *pred, dm_error *err)
{
    p->robot = *robot;
    return p->data.kind == DM_DATA_TRACKER ? predict_tracker(p, pred, err)
                                           : predict_poses(p, pred, err);
}

double dm_predict_cost_s(const dm_robot *rb, dm_data_kind kind, double count, int na, int nb)
{
    double s = dm_model_dofs(rb, na > 0 ? na : rb->na, nb > 0 ? nb : rb->nb) / 210.0;
    double per = (kind == DM_DATA_STATIC ? 5e-3 : 2.5e-3) * (0.15 + 0.85 * s * s);
    return count * per;
}

double dm_predict_estimate_s(const dm_robot *rb, const dm_dataset *d, int na, int nb,
                             double *bytes)
{
    double count = d->npose, per_count = 0;
    if (d->kind == DM_DATA_TRACKER && d->n > 0) { /* dm_predict's step: at most 1 ms */
        double T = d->s[d->n - 1].t - d->s[0].t;
        count = fmax(T / 1e-3, d->npose);
        per_count = 4 * sizeof(double); /* the integrated error kept per step */
    }
    if (bytes)
        *bytes = count * per_count + (double)d->n * 2 * sizeof(double);
    return dm_predict_cost_s(rb, d->kind, count, na, nb);
}

int dm_check_size(const char *what, double est_s, double bytes, const char *hint, int force,
                  dm_error *err)
{
    int slow = !(est_s <= DM_MAX_WORK_S), big = !(bytes <= DM_MAX_BYTES);
    if (force || (!slow && !big))
        return DM_OK;
    char t[96] = "", m[96] = "";
    if (slow)
        snprintf(t, sizeof t, "about %.3g hours of work (the limit is %g)", est_s / 3600,
                 DM_MAX_WORK_S / 3600);
    if (big)
        snprintf(m, sizeof m, "%s%.3g GB of memory (the limit is %g)", slow ? " and " : "about ",
                 bytes / 1e9, DM_MAX_BYTES / 1e9);
    return dm_fail(err, DM_EINVAL, "%s: %s%s: %s, or force it", what, t, m, hint);
}

int dm_size_refused(const dm_error *err)
{
    return err->code == DM_EINVAL && (strstr(err->msg, " hours of work (the limit is ") ||
                                      strstr(err->msg, " GB of memory (the limit is "));
}

int dm_predict(const dm_robot *rb, const dm_dataset *d, int na, int nb, double *pred, dm_error *err)
{
    dm_predictor *p = dm_predictor_new(rb, d, na, nb, err);
    if (!p)
        return DM_ENOMEM;
    int rc = dm_predictor_run(p, rb, pred, err);
    dm_predictor_free(p);
    return rc;
}

/* ---- synthetic data ---------------------------------------------------------- */

static int draw_pose(const dm_robot *rb, dm_rng *rng, double P[3])
{
    double h = rb->arm_length_m;
    for (int tries = 0; tries < 1000; tries++) {
        dm_pose pose;
        P[0] = rb->home_m[0] + 0.3 * h * (2 * dm_rng_uniform(rng) - 1);
        P[1] = rb->home_m[1] + 0.3 * h * (2 * dm_rng_uniform(rng) - 1);
        P[2] = rb->home_m[2] + 0.15 * h * (2 * dm_rng_uniform(rng) - 1);
        if (!dm_kin_inverse(rb, P, &pose, NULL) && pose.cond <= rb->singular_cond)
            return DM_OK;
    }
    return DM_EUNREACHABLE;
}

int dm_synthesize(const dm_robot *rb, const dm_synth_opts *o, dm_dataset *d, dm_error *err)
{
    dm_rng rng = {o->seed * 0x2545F4914F6CDD1Dull + 1};
    memset(d, 0, sizeof *d);
    d->kind = o->kind;
    snprintf(d->source, sizeof d->source, "synthetic %s data", dm_data_kind_name(o->kind));
    snprintf(d->robot, sizeof d->robot, "%s", rb->name);
    int rc = DM_OK;
    if (o->kind == DM_DATA_TRACKER) {
        char spec[256];
        dm_trajectory tr;
        const double *h = rb->home_m;
        if (o->path)
            snprintf(spec, sizeof spec, "%s", o->path);
        else
            snprintf(spec, sizeof spec, "circle:centre=%.9g,%.9g,%.9g;radius=%.9g;rate=%.9g;duration=0.5",
                     h[0], h[1], h[2], 0.2 * rb->arm_length_m, 4 * M_PI);
        if ((rc = dm_traj_make(spec, rb, &tr, err)))
            return rc;
        double steps = floor(tr.duration_s / 1e-3 + 1e-9) + 1;
        char what[320];
        snprintf(what, sizeof what, "synth: %s: %.4g s sampled every 1 ms", tr.name,
                 tr.duration_s);
        rc = dm_check_size(what, dm_predict_cost_s(rb, o->kind, steps, o->na, o->nb),
                           steps * (3 * (sizeof(dm_sample) + sizeof(double)) + 4 * sizeof(double)),
                           "a shorter path", o->force_long, err);
        if (!rc && steps > INT_MAX / 3) /* the samples are counted in int */
            rc = dm_fail(err, DM_EINVAL, "%s: %.3g samples, at most %d", what, 3 * steps,
                         INT_MAX);
        if (rc) {
            dm_traj_free(&tr);
            return rc;
        }
        int m = (int)steps;
        for (int i = 0; i < m && !rc; i++) {
            dm_sample s = {0};
            double v[3], a[3];
            s.t = i * 1e-3;
            dm_traj_eval(&tr, s.t, s.P, v, a);
            s.pose_id = d->npose++;
            s.sigma = o->noise;
            for (int k = 0; k < 3 && !rc; k++) {
                s.comp = k;
                rc = dm_dataset_push(d, &s, err);
            }
        }
        dm_traj_free(&tr);
    } else {
        double np = o->npose > 0 ? o->npose : 16;
        double per = o->kind == DM_DATA_MODAL ? (o->modes > 0 ? o->modes : 6) : 3;
        char what[96];
        snprintf(what, sizeof what, "synth: %.0f poses", np);
        if ((rc = dm_check_size(what, dm_predict_cost_s(rb, o->kind, np, o->na, o->nb),
                                np * per * (sizeof(dm_sample) + sizeof(double)),
                                "fewer poses", o->force_long, err)))
            return rc;
        if (np * per > INT_MAX) /* the samples are counted in int */
            return dm_fail(err, DM_EINVAL, "%s: %.3g samples, at most %d", what, np * per,
                           INT_MAX);
        for (int p = 0; p < (o->npose > 0 ? o->npose : 16) && !rc; p++) {
            dm_sample s = {0};
            if (draw_pose(rb, &rng, s.P))
                return dm_fail(err, DM_EUNREACHABLE, "no reachable pose found near home");
            s.pose_id = d->npose++;
            s.sigma = o->noise;
            if (o->kind == DM_DATA_MODAL) {
                for (int j = 1; j <= (o->modes > 0 ? o->modes : 6) && !rc; j++) {
                    s.mode = j;
                    rc = dm_dataset_push(d, &s, err);
                }
            } else {
                double u[3] = {dm_rng_normal(&rng), dm_rng_normal(&rng), dm_rng_normal(&rng)};
                double nu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
                for (int k = 0; k < 3; k++)
                    s.force[k] = (o->force_n > 0 ? o->force_n : 50.0) * u[k] / nu;
                for (int k = 0; k < 3 && !rc; k++) {
                    s.comp = k;
                    rc = dm_dataset_push(d, &s, err);
                }
            }
        }
    }
    double *pred = rc ? NULL : malloc(sizeof(double) * d->n);
    if (!rc && !pred)
        rc = dm_fail(err, DM_ENOMEM, "out of memory");
    if (!rc)
        rc = dm_predict(rb, d, o->na, o->nb, pred, err);
    for (int i = 0; i < d->n && !rc; i++)
        d->s[i].value = pred[i] + o->noise * dm_rng_normal(&rng);
    free(pred);
    if (rc)
        dm_dataset_free(d);
    return rc;
}
