/* Measured data: kinds, reading, validating and writing datasets (see
 * dm_measure.h). */
#include "dm_measure.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_csv.h"
#include "dm_modal.h"
#include "dm_nuisance.h"

/* ---- kinds ---------------------------------------------------------------- */

static const char *const KIND_NAMES[] = {"modal", "static", "tracker"};
static const char *const COLUMNS[3][10] = {
    {"x", "y", "z", "mode", "freq_hz", NULL},
    {"x", "y", "z", "fx", "fy", "fz", "dx", "dy", "dz", NULL},
    {"t", "x_cmd", "y_cmd", "z_cmd", "x_meas", "y_meas", "z_meas", NULL}};

const char *dm_data_kind_name(dm_data_kind k)
{
    assert(k >= DM_DATA_MODAL && k <= DM_DATA_TRACKER);
    return KIND_NAMES[k];
}

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
    assert(d->n >= 0 && d->n <= d->cap && (d->s || !d->cap));
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
    assert(d->kind >= DM_DATA_MODAL && d->kind <= DM_DATA_TRACKER);
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
        if (v[3] != floor(v[3]) || v[3] < 1 || v[3] > DM_MAX_MODES)
            return bad(c, "mode", "not a mode rank 1.." DM_MAX_MODES_TEXT " (1 = lowest)");
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

/* A tracker run's header lines (docs/measured-data.md): '# frame: base|tracker',
 * '# reflector: X, Y, Z' (m), '# clock: offset|rate'. 1: the comment was one
 * of them (*rc set on a bad value); 0: another comment. */
static int nuisance_line(const csv_ctx *c, const char *text, dm_nuisance_spec *ns, int *rc)
{
    static const char *const keys[] = {" frame:", " reflector:", " clock:"};
    int k = 0;
    while (k < 3 && strncmp(text, keys[k], strlen(keys[k])))
        k++;
    if (k == 3)
        return 0;
    char v[128];
    const char *p = text + strlen(keys[k]);
    p += strspn(p, " \t");
    snprintf(v, sizeof v, "%.*s", (int)strcspn(p, "\r\n"), p);
    while (*v && strchr(" \t", v[strlen(v) - 1]))
        v[strlen(v) - 1] = '\0';
    int line = c->in.line;
    if (k == 0 && (!strcmp(v, "base") || !strcmp(v, "tracker"))) {
        ns->on = 1, ns->line = line, ns->tracker_frame = !strcmp(v, "tracker");
    } else if (k == 1) {
        char *end = v;
        for (int i = 0; i < 3 && *rc == DM_OK; i++) {
            char *start = end + (i ? 1 : 0);
            ns->reflector[i] = strtod(start, &end);
            if (end == start || !isfinite(ns->reflector[i]) || *end != (i < 2 ? ',' : '\0'))
                *rc = dm_fail(c->err, DM_EINVAL, "%s:%d: '# reflector: %s' is not three numbers "
                              "X, Y, Z (m)", c->in.path, line, v);
        }
    } else if (k == 2 && (!strcmp(v, "offset") || !strcmp(v, "rate"))) {
        ns->clock_rate = !strcmp(v, "rate");
    } else {
        *rc = dm_fail(c->err, DM_EINVAL, "%s:%d: '#%s %s': %s", c->in.path, line, keys[k], v,
                      k == 0 ? "the frame is base or tracker" : "the clock is offset or rate");
    }
    return 1;
}

/* The nuisance header lines make sense only with a tracker run's measured
 * positions, and '# reflector:' and '# clock:' only with '# frame:'. */
static int check_nuisance(const dm_dataset *d, const dm_nuisance_spec *ns, int any, dm_error *err)
{
    if (!any)
        return DM_OK;
    if (d->kind != DM_DATA_TRACKER)
        return dm_fail(err, DM_EINVAL, "%s:%d: '# frame:', '# reflector:' and '# clock:' are for "
                       "tracker runs (t, x_cmd..z_cmd, x_meas..z_meas): %s data have no measured "
                       "positions", d->source, any, dm_data_kind_name(d->kind));
    if (!ns->on)
        return dm_fail(err, DM_EINVAL, "%s:%d: '# reflector:' and '# clock:' need '# frame: "
                       "base' or '# frame: tracker' (the nuisances are fitted only then)",
                       d->source, any);
    return DM_OK;
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
    dm_nuisance_spec ns = {0};
    int nuisance_at = 0; /* line of the first nuisance header */
    while (!rc && !(rc = dm_csv_next(&c.in, &kind, err)) && kind != DM_CSV_END) {
        const char *robot = c.in.comment;
        if (kind == DM_CSV_COMMENT && nuisance_line(&c, robot, &ns, &rc)) {
            nuisance_at = nuisance_at ? nuisance_at : c.in.line;
        } else if (kind == DM_CSV_COMMENT && !strncmp(robot, " robot:", 7) && !d->robot[0]) {
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
    if (!rc && !(rc = check_nuisance(d, &ns, nuisance_at, err))) {
        d->nuisance = ns;
        rc = dm_nuisance_prepare(d, err);
    }
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
    /* static and tracker rows are three samples each */
    assert(d->n >= 0 && (d->kind == DM_DATA_MODAL || d->n % 3 == 0));
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
        /* a run with nuisances as read: in the base frame (a tracker frame's
         * alignment applied), the reflector where it was measured */
        const dm_nuisance_spec *ns = &d->nuisance;
        double o[3] = {-0.0, -0.0, -0.0}; /* x + -0.0 is x, -0.0 included */
        if (ns->on)
            memcpy(o, ns->reflector, sizeof o);
        if (ns->on)
            fprintf(out, "# frame: base\n# reflector: %.12g, %.12g, %.12g\n# clock: %s\n", o[0],
                    o[1], o[2], ns->clock_rate ? "rate" : "offset");
        fprintf(out, "t,x_cmd,y_cmd,z_cmd,x_meas,y_meas,z_meas\n");
        for (int i = 0; i + 2 < d->n; i += 3) {
            const dm_sample *s = &d->s[i];
            fprintf(out, "%.9g,%.12g,%.12g,%.12g,%.12g,%.12g,%.12g\n", s->t, s->P[0], s->P[1],
                    s->P[2], s->P[0] + s->value + o[0], s->P[1] + d->s[i + 1].value + o[1],
                    s->P[2] + d->s[i + 2].value + o[2]);
        }
    }
    return ferror(out) ? DM_EIO : DM_OK;
}
