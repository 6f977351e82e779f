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
    free(d->shape);
    d->s = NULL;
    d->shape = NULL;
    d->shape_cap = d->nsensor = d->pair = 0;
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

/* A modal row's `dir` cell (x, y, z, rx, ry, rz) into *dir (+1; 0 without
 * the column). */
static int direction_cell(const csv_ctx *c, int *dir)
{
    static const char *const names[6] = {"x", "y", "z", "rx", "ry", "rz"};
    int i = dm_csv_column(&c->in, "dir");
    *dir = 0;
    if (i < 0)
        return DM_OK;
    const char *v = i < c->in.ncells ? c->in.cells[i] : "";
    for (int k = 0; k < 6; k++)
        if (!strcmp(v, names[k]))
            *dir = k + 1;
    return *dir ? DM_OK : bad(c, "dir", "not a direction x, y, z, rx, ry, rz");
}

/* The last sample's shape values: column shape_NAME of each sensor. */
static int shape_cells(const csv_ctx *c, dm_dataset *d)
{
    if (!d->nsensor)
        return DM_OK;
    if (d->n * d->nsensor > d->shape_cap) {
        int cap = 2 * d->n * d->nsensor;
        double *g = realloc(d->shape, sizeof *g * cap);
        if (!g)
            return dm_fail(c->err, DM_ENOMEM, "%s: out of memory for the shapes", d->source);
        d->shape = g, d->shape_cap = cap;
    }
    double *row = d->shape + (size_t)(d->n - 1) * d->nsensor;
    for (int k = 0; k < d->nsensor; k++) {
        char name[40];
        snprintf(name, sizeof name, "shape_%s", d->sensor[k].name);
        int rc = dm_csv_number(&c->in, dm_csv_column(&c->in, name), &row[k], c->err);
        if (rc)
            return rc;
    }
    return DM_OK;
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
        if ((rc = direction_cell(c, &s.dir)))
            return rc;
        if (d->n == 0 || memcmp(s.P, last_P, sizeof s.P))
            d->npose++;
        memcpy(last_P, s.P, sizeof s.P);
        s.pose_id = d->npose - 1;
        rc = dm_dataset_push(d, &s, c->err);
        return rc ? rc : shape_cells(c, d);
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

/* The body a sensor is on: arm1..arm3, rod1a..rod3b, platform; -1: none. */
static int body_of(const char *name)
{
    if (!strcmp(name, "platform"))
        return DM_BODY_PLATFORM;
    if (!strncmp(name, "arm", 3) && name[3] >= '1' && name[3] <= '3' && !name[4])
        return name[3] - '1';
    if (!strncmp(name, "rod", 3) && name[3] >= '1' && name[3] <= '3' &&
        (name[4] == 'a' || name[4] == 'b') && !name[5])
        return 3 + 2 * (name[3] - '1') + (name[4] - 'a');
    return -1;
}

/* A '# sensor: NAME, BODY, AT, DX, DY, DZ' line (AT: a fraction of an arm
 * or a rod, or X, Y, Z for the platform) appended to d's sensors. */
static int sensor_line(const csv_ctx *c, const char *text, dm_dataset *d)
{
    char buf[512], *f[9];
    int n = 0, line = c->in.line;
    snprintf(buf, sizeof buf, "%.*s", (int)strcspn(text, "\r\n"), text);
    for (char *p = buf, *end; n < 9; p = end + 1) {
        end = p + strcspn(p, ",");
        int last = !*end;
        *end = '\0';
        p += strspn(p, " \t");
        for (char *q = end; q > p && strchr(" \t", q[-1]); q--)
            q[-1] = '\0';
        f[n++] = p;
        if (last)
            break;
    }
    if (d->nsensor == DM_MAX_SENSORS)
        return dm_fail(c->err, DM_EINVAL, "%s:%d: more than %d sensors", c->in.path, line,
                       DM_MAX_SENSORS);
    dm_sensor *sn = &d->sensor[d->nsensor];
    memset(sn, 0, sizeof *sn);
    sn->line = line;
    if (n < 2 || !*f[0] || strlen(f[0]) >= sizeof sn->name)
        return dm_fail(c->err, DM_EINVAL, "%s:%d: '# sensor:' needs NAME, BODY, AT, DX, DY, DZ "
                       "(a name of at most 31 characters first)", c->in.path, line);
    snprintf(sn->name, sizeof sn->name, "%s", f[0]);
    if ((sn->body = body_of(f[1])) < 0)
        return dm_fail(c->err, DM_EINVAL, "%s:%d: '# sensor:' column 2 (body): '%s' is no body "
                       "of the robot (arm1..arm3, rod1a..rod3b, platform)", c->in.path, line, f[1]);
    int nat = sn->body == DM_BODY_PLATFORM ? 3 : 1;
    if (n != 2 + nat + 3)
        return dm_fail(c->err, DM_EINVAL, "%s:%d: '# sensor:' on %s needs %d fields: NAME, BODY, "
                       "%s, DX, DY, DZ", c->in.path, line, f[1], 5 + nat,
                       nat == 3 ? "X, Y, Z (offset from the centre, m)" : "AT (fraction 0..1)");
    double v[6];
    for (int k = 0; k < nat + 3; k++) {
        char *end;
        v[k] = strtod(f[2 + k], &end);
        if (end == f[2 + k] || *end || !isfinite(v[k]))
            return dm_fail(c->err, DM_EINVAL, "%s:%d: '# sensor:' column %d: '%s' is not a "
                           "number", c->in.path, line, 3 + k, f[2 + k]);
    }
    memcpy(sn->at, v, sizeof(double) * nat);
    double nd = sqrt(v[nat] * v[nat] + v[nat + 1] * v[nat + 1] + v[nat + 2] * v[nat + 2]);
    if (nat == 1 && !(v[0] >= 0 && v[0] <= 1))
        return dm_fail(c->err, DM_EINVAL, "%s:%d: '# sensor:' column 3 (at): %g is not a "
                       "fraction 0..1 of the member", c->in.path, line, v[0]);
    if (!(nd > 0))
        return dm_fail(c->err, DM_EINVAL, "%s:%d: '# sensor:' columns %d-%d: the direction is "
                       "zero", c->in.path, line, 3 + nat, 5 + nat);
    for (int k = 0; k < 3; k++)
        sn->dir[k] = v[nat + k] / nd;
    for (int k = 0; k < d->nsensor; k++)
        if (!strcmp(d->sensor[k].name, sn->name))
            return dm_fail(c->err, DM_EINVAL, "%s:%d: sensor '%s' named twice (also line %d)",
                           c->in.path, line, sn->name, d->sensor[k].line);
    d->nsensor++;
    return DM_OK;
}

/* Shapes and directions belong to modal surveys; every shape column needs
 * a sensor placed before the header, every sensor its column. */
static int check_shapes(const csv_ctx *c, dm_dataset *d)
{
    if (d->nsensor && d->kind != DM_DATA_MODAL)
        return dm_fail(c->err, DM_EINVAL, "%s:%d: '# sensor:' is for modal surveys, not %s data",
                       c->in.path, d->sensor[0].line, dm_data_kind_name(d->kind));
    for (int i = 0; i < c->in.ncol && d->kind == DM_DATA_MODAL; i++) {
        const char *name = c->in.names[i];
        int k;
        for (k = 0; k < d->nsensor && strcmp(name + 6, d->sensor[k].name); k++)
            ;
        if (!strncmp(name, "shape_", 6) && k == d->nsensor)
            return dm_fail(c->err, DM_EINVAL, "%s:%d: column %d (%s): no '# sensor: %s, BODY, "
                           "AT, DX, DY, DZ' line before the header gives this sensor's position",
                           c->in.path, c->in.line, i + 1, name, name + 6);
    }
    for (int k = 0; k < d->nsensor; k++) {
        char name[40];
        snprintf(name, sizeof name, "shape_%s", d->sensor[k].name);
        if (dm_csv_column(&c->in, name) < 0)
            return dm_fail(c->err, DM_EINVAL, "%s:%d: sensor '%s' has no column %s",
                           c->in.path, d->sensor[k].line, d->sensor[k].name, name);
    }
    d->pair = d->kind == DM_DATA_MODAL && (d->nsensor || dm_csv_column(&c->in, "dir") >= 0);
    return DM_OK;
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
    int header_seen = 0;
    while (!rc && !(rc = dm_csv_next(&c.in, &kind, err)) && kind != DM_CSV_END) {
        const char *robot = c.in.comment;
        if (kind == DM_CSV_COMMENT && nuisance_line(&c, robot, &ns, &rc)) {
            nuisance_at = nuisance_at ? nuisance_at : c.in.line;
        } else if (kind == DM_CSV_COMMENT && !strncmp(robot, " sensor:", 8)) {
            rc = header_seen
                     ? dm_fail(err, DM_EINVAL, "%s:%d: '# sensor:' lines come before the header",
                               path, c.in.line)
                     : sensor_line(&c, robot + 8, d);
        } else if (kind == DM_CSV_COMMENT && !strncmp(robot, " robot:", 7) && !d->robot[0]) {
            robot += 7 + strspn(robot + 7, " \t");
            snprintf(d->robot, sizeof d->robot, "%.*s", (int)strcspn(robot, "\r\n"), robot);
        } else if (kind == DM_CSV_HEADER) {
            header_seen = 1;
            if (!(rc = detect_kind(&c, d)))
                rc = check_shapes(&c, d);
        } else if (kind == DM_CSV_ROW)
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

static void write_sensor(const dm_sensor *sn, FILE *out)
{
    static const char *const bodies[] = {"arm1",  "arm2",  "arm3",  "rod1a", "rod1b",
                                         "rod2a", "rod2b", "rod3a", "rod3b", "platform"};
    assert(sn->body >= 0 && sn->body <= DM_BODY_PLATFORM);
    fprintf(out, "# sensor: %s, %s, %.9g", sn->name, bodies[sn->body], sn->at[0]);
    if (sn->body == DM_BODY_PLATFORM)
        fprintf(out, ", %.9g, %.9g", sn->at[1], sn->at[2]);
    fprintf(out, ", %.9g, %.9g, %.9g\n", sn->dir[0], sn->dir[1], sn->dir[2]);
}

/* A modal survey; the sensors, `dir` and shape columns when it pairs. */
static void write_modal(const dm_dataset *d, int sigma, FILE *out)
{
    static const char *const dirs[] = {"x", "y", "z", "rx", "ry", "rz"};
    int dir = d->n > 0;
    for (int i = 0; i < d->n; i++)
        dir &= d->s[i].dir > 0;
    for (int k = 0; k < d->nsensor; k++)
        write_sensor(&d->sensor[k], out);
    fprintf(out, "x,y,z,mode,freq_hz%s%s", sigma ? ",sigma_hz" : "", dir ? ",dir" : "");
    for (int k = 0; k < d->nsensor; k++)
        fprintf(out, ",shape_%s", d->sensor[k].name);
    fputc('\n', out);
    for (int i = 0; i < d->n; i++) {
        const dm_sample *s = &d->s[i];
        fprintf(out, "%.9g,%.9g,%.9g,%d,%.12g", s->P[0], s->P[1], s->P[2], s->mode, s->value);
        if (sigma)
            fprintf(out, ",%.6g", s->sigma);
        if (dir)
            fprintf(out, ",%s", dirs[s->dir - 1]);
        for (int k = 0; k < d->nsensor; k++)
            fprintf(out, ",%.9g", d->shape[(size_t)i * d->nsensor + k]);
        fputc('\n', out);
    }
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
        write_modal(d, sigma, out);
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
