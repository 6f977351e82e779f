/* Nominal trajectories (see dm_trajectory.h). */
#include "dm_trajectory.h"

#include "dm_csv.h"

#include <errno.h>
#include <float.h>
#include <lapacke.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dm_kinematics.h"
#include "dm_vec3.h"

/* ---- motion laws ------------------------------------------------------- */

void dm_motion_law_eval(dm_motion_law law, double x, double *s, double *ds, double *dds)
{
    x = fmin(1.0, fmax(0.0, x));
    switch (law) {
    case DM_LAW_CYCLOIDAL:
        *s = x - sin(2 * M_PI * x) / (2 * M_PI);
        *ds = 1 - cos(2 * M_PI * x);
        *dds = 2 * M_PI * sin(2 * M_PI * x);
        return;
    case DM_LAW_TRAPEZOIDAL: /* a = 4.5 on [0,1/3], cruise 1.5, a = -4.5 on [2/3,1] */
        if (x < 1.0 / 3) {
            *s = 2.25 * x * x; *ds = 4.5 * x; *dds = 4.5;
        } else if (x < 2.0 / 3) {
            *s = 0.25 + 1.5 * (x - 1.0 / 3); *ds = 1.5; *dds = 0;
        } else {
            double y = 1 - x;
            *s = 1 - 2.25 * y * y; *ds = 4.5 * y; *dds = -4.5;
        }
        return;
    case DM_LAW_POLY7: {
        double x2 = x * x, x3 = x2 * x, x4 = x3 * x;
        *s = x4 * (35 - 84 * x + 70 * x2 - 20 * x3);
        *ds = x3 * (140 - 420 * x + 420 * x2 - 140 * x3);
        *dds = x2 * (420 - 1680 * x + 2100 * x2 - 840 * x3);
        return;
    }
    case DM_LAW_BANGBANG:
        if (x < 0.5) {
            *s = 2 * x * x; *ds = 4 * x; *dds = 4;
        } else {
            double y = 1 - x;
            *s = 1 - 2 * y * y; *ds = 4 * y; *dds = -4;
        }
        return;
    }
}

/* ---- evaluation -------------------------------------------------------- */

static void eval_circle(const dm_trajectory *tr, double t, double P[3], double v[3], double a[3])
{
    double phi = tr->phase_rad + tr->rate_rad_s * t, R = tr->radius_m, w = tr->rate_rad_s;
    double c = cos(phi), s = sin(phi);
    for (int k = 0; k < 3; k++) {
        P[k] = tr->centre_m[k] + R * (c * tr->u[k] + s * tr->w[k]);
        v[k] = R * w * (-s * tr->u[k] + c * tr->w[k]);
        a[k] = -R * w * w * (c * tr->u[k] + s * tr->w[k]);
    }
}

static void eval_segments(const dm_trajectory *tr, double t, double P[3], double v[3], double a[3])
{
    int j = 0;
    while (j + 1 < tr->nseg && t >= tr->seg[j + 1].t0_s)
        j++;
    const dm_segment *sg = &tr->seg[j];
    double T = sg->duration_s, s, ds, dds;
    dm_motion_law_eval(sg->law, (t - sg->t0_s) / T, &s, &ds, &dds);
    for (int k = 0; k < 3; k++) {
        double D = sg->to_m[k] - sg->from_m[k];
        P[k] = sg->from_m[k] + s * D;
        v[k] = ds * D / T;
        a[k] = dds * D / (T * T);
    }
}

static void eval_samples(const dm_trajectory *tr, double t, double P[3], double v[3], double a[3])
{
    int lo = 0, hi = tr->nsamp - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (tr->t_s[mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    double h = tr->t_s[hi] - tr->t_s[lo], A = (tr->t_s[hi] - t) / h, B = 1 - A;
    for (int k = 0; k < 3; k++) {
        double y0 = tr->xyz_m[3 * lo + k], y1 = tr->xyz_m[3 * hi + k];
        double m0 = tr->m2[3 * lo + k], m1 = tr->m2[3 * hi + k];
        P[k] = A * y0 + B * y1 + ((A * A * A - A) * m0 + (B * B * B - B) * m1) * h * h / 6;
        v[k] = (y1 - y0) / h - (3 * A * A - 1) * h * m0 / 6 + (3 * B * B - 1) * h * m1 / 6;
        a[k] = A * m0 + B * m1;
    }
}

void dm_traj_eval(const dm_trajectory *tr, double t, double P[3], double v[3], double a[3])
{
    t = fmin(fmax(t, 0.0), tr->duration_s);
    switch (tr->kind) {
    case DM_PATH_CIRCLE: eval_circle(tr, t, P, v, a); break;
    case DM_PATH_SEGMENTS: eval_segments(tr, t, P, v, a); break;
    case DM_PATH_SAMPLES: eval_samples(tr, t, P, v, a); break;
    }
}

/* ---- construction ------------------------------------------------------ */

static void set_circle(dm_trajectory *tr, const char *name, const double c[3], double R,
                       double rate, double T, const char *plane, double phase)
{
    memset(tr, 0, sizeof *tr);
    snprintf(tr->name, sizeof tr->name, "%s", name);
    tr->kind = DM_PATH_CIRCLE;
    dm_copy3(c, tr->centre_m);
    tr->radius_m = R;
    tr->rate_rad_s = rate;
    tr->duration_s = T;
    tr->phase_rad = phase;
    /* xy: (cos, sin) on (x, y); yz: Han's vertical circle, cos on z, sin on y;
     * xz: cos on x, sin on z */
    int iu = !strcmp(plane, "yz") ? 2 : 0, iw = !strcmp(plane, "xz") ? 2 : 1;
    tr->u[iu] = 1;
    tr->w[iw] = 1;
}

static int preset_path(const char *spec, dm_trajectory *tr)
{
    const double chen[3] = {0, 0, -0.5}, zheng[3] = {0, 0, -0.4}, han[3] = {0, 0, 0.96};
    if (!strcmp(spec, "chen2018"))
        set_circle(tr, spec, chen, 0.1, 6 * M_PI, 3.0, "xy", 0);
    else if (!strcmp(spec, "zheng2017"))
        set_circle(tr, spec, zheng, 0.05, 2 * M_PI, 1.0, "xy", 0);
    else if (!strcmp(spec, "han2011"))
        set_circle(tr, spec, han, 0.24, 12.0, M_PI / 3, "xy", 0);
    else if (!strcmp(spec, "han2011-vertical"))
        set_circle(tr, spec, han, 0.05, 12.0, M_PI / 3, "yz", 0);
    else if (!strcmp(spec, "han2011-vertical-printed"))
        set_circle(tr, spec, han, 0.24, 12.0, M_PI / 3, "yz", 0);
    else
        return 0;
    return 1;
}

/* Look up "key=value" in a ';'-separated list; returns value or NULL. */
static const char *field(const char *list, const char *key, char *buf, size_t len)
{
    size_t kl = strlen(key);
    for (const char *p = list; p && *p; p = strchr(p, ';') ? strchr(p, ';') + 1 : NULL) {
        if (!strncmp(p, key, kl) && p[kl] == '=') {
            const char *v = p + kl + 1, *end = strchr(v, ';');
            size_t n = end ? (size_t)(end - v) : strlen(v);
            if (n >= len)
                n = len - 1;
            memcpy(buf, v, n);
            buf[n] = '\0';
            return buf;
        }
    }
    return NULL;
}

static int check_fields(const char *list, const char *const allowed[], const char *spec,
                        dm_error *err)
{
    for (const char *p = list; p && *p; p = strchr(p, ';') ? strchr(p, ';') + 1 : NULL) {
        size_t kl = strcspn(p, "=;");
        int ok = 0;
        for (int i = 0; allowed[i]; i++)
            ok |= strlen(allowed[i]) == kl && !strncmp(p, allowed[i], kl);
        if (!ok || p[kl] != '=')
            return dm_fail(err, DM_EINVAL, "path '%s': unknown or empty field '%.*s'", spec,
                           (int)kl, p);
    }
    return DM_OK;
}

static int num_field(const char *list, const char *key, const char *spec, int n, double *out,
                     int required, dm_error *err)
{
    char buf[128];
    if (!field(list, key, buf, sizeof buf))
        return required ? dm_fail(err, DM_EINVAL, "path '%s': missing %s=", spec, key) : DM_OK;
    char *p = buf;
    for (int i = 0; i < n; i++) {
        char *end;
        out[i] = strtod(p, &end);
        if (end == p || !isfinite(out[i]) || (i < n - 1 && *end != ','))
            return dm_fail(err, DM_EINVAL, "path '%s': %s needs %d number%s", spec, key, n,
                           n > 1 ? "s separated by ','" : "");
        p = end + (i < n - 1);
    }
    if (*p)
        return dm_fail(err, DM_EINVAL, "path '%s': %s needs %d number(s)", spec, key, n);
    return DM_OK;
}

static int law_field(const char *list, const char *spec, dm_motion_law *law, dm_error *err)
{
    static const char *const names[] = {"cycloidal", "trapezoidal", "poly7", "bangbang"};
    char buf[64];
    *law = DM_LAW_CYCLOIDAL;
    if (!field(list, "law", buf, sizeof buf))
        return DM_OK;
    for (int i = 0; i < 4; i++)
        if (!strcmp(buf, names[i])) {
            *law = (dm_motion_law)i;
            return DM_OK;
        }
    if (!strcmp(buf, "jerk-limited")) {
        *law = DM_LAW_POLY7;
        return DM_OK;
    }
    return dm_fail(err, DM_EINVAL,
                   "path '%s': law '%s' is not cycloidal, trapezoidal, poly7 (jerk-limited) or bangbang",
                   spec, buf);
}

static int positive(double v, const char *what, const char *spec, dm_error *err)
{
    return v > 0 ? DM_OK : dm_fail(err, DM_EINVAL, "path '%s': %s must be > 0", spec, what);
}

/* The motion must be finite everywhere: positions, speeds, accelerations
 * and the phase angle (huge or subnormal values that each parse make
 * infinities or NaN when combined). */
static int circle_finite(const double c[3], double R, double w, double T, double ph,
                         const char *spec, dm_error *err)
{
    int ok = isfinite(fabs(w) * T) && isfinite(R * w * w) && isfinite(R * fabs(w)) &&
             isfinite(ph * M_PI / 180 + fabs(w) * T);
    for (int k = 0; k < 3; k++)
        ok &= isfinite(fabs(c[k]) + R);
    return ok ? DM_OK
              : dm_fail(err, DM_EINVAL, "path '%s': centre, radius, rate, phase and duration "
                        "give a motion that overflows (radius * rate^2 = %g m/s^2, rate * "
                        "duration = %g rad)", spec, R * w * w, w * T);
}

/* Every segment's speed and acceleration (at most 2 pi |D| / T^2 for the
 * laws here) and the total duration finite. */
static int segments_finite(const dm_trajectory *tr, const char *spec, dm_error *err)
{
    for (int j = 0; j < tr->nseg; j++) {
        const dm_segment *sg = &tr->seg[j];
        double T2 = sg->duration_s * sg->duration_s;
        int ok = T2 >= DBL_MIN;
        for (int k = 0; k < 3 && ok; k++) {
            double D = fabs(sg->to_m[k] - sg->from_m[k]);
            ok = isfinite(D) && isfinite(8 * D / T2) && isfinite(fabs(sg->from_m[k]) + D);
        }
        if (!ok)
            return dm_fail(err, DM_EINVAL, "path '%s': segment %d (%g s from %g, %g, %g to %g, "
                           "%g, %g m): its speed or acceleration overflows (duration too short "
                           "or distance too large)", spec, j + 1, sg->duration_s, sg->from_m[0],
                           sg->from_m[1], sg->from_m[2], sg->to_m[0], sg->to_m[1], sg->to_m[2]);
    }
    if (!isfinite(tr->duration_s))
        return dm_fail(err, DM_EINVAL, "path '%s': the total duration overflows", spec);
    return DM_OK;
}

static int make_circle(const char *spec, const char *list, dm_trajectory *tr, dm_error *err)
{
    static const char *const allowed[] = {"centre", "radius", "rate", "duration", "plane", "phase", NULL};
    double c[3], R = 0, w = 0, T = 0, ph = 0;
    char plane[8] = "xy";
    int rc = check_fields(list, allowed, spec, err);
    if (!rc) rc = num_field(list, "centre", spec, 3, c, 1, err);
    if (!rc) rc = num_field(list, "radius", spec, 1, &R, 1, err);
    if (!rc) rc = num_field(list, "rate", spec, 1, &w, 1, err);
    if (!rc) rc = num_field(list, "duration", spec, 1, &T, 1, err);
    if (!rc) rc = num_field(list, "phase", spec, 1, &ph, 0, err);
    if (!rc) rc = positive(R, "radius", spec, err);
    if (!rc) rc = positive(T, "duration", spec, err);
    if (!rc) rc = circle_finite(c, R, w, T, ph, spec, err);
    if (rc)
        return rc;
    field(list, "plane", plane, sizeof plane);
    if (strcmp(plane, "xy") && strcmp(plane, "yz") && strcmp(plane, "xz"))
        return dm_fail(err, DM_EINVAL, "path '%s': plane is xy, yz or xz", spec);
    set_circle(tr, spec, c, R, w, T, plane, ph * M_PI / 180);
    return DM_OK;
}

static void add_segment(dm_trajectory *tr, const double from[3], const double to[3], double T,
                        dm_motion_law law)
{
    dm_segment *s = &tr->seg[tr->nseg++];
    s->t0_s = tr->duration_s;
    s->duration_s = T;
    dm_copy3(from, s->from_m);
    dm_copy3(to, s->to_m);
    s->law = law;
    tr->duration_s += T;
}

/* dwell=S (optional, >= 0): hold still at the end, where a move's residual
 * vibration rings down. */
static int dwell_field(const char *list, const char *spec, double *dwell, dm_error *err)
{
    int rc = num_field(list, "dwell", spec, 1, dwell, 0, err);
    if (!rc && !(*dwell >= 0))
        rc = dm_fail(err, DM_EINVAL, "path '%s': dwell must be >= 0 s", spec);
    return rc;
}

static int make_p2p(const char *spec, const char *list, dm_trajectory *tr, dm_error *err)
{
    static const char *const allowed[] = {"from", "to", "duration", "law", "dwell", NULL};
    double a[3], b[3], T = 0, dwell = 0;
    dm_motion_law law;
    int rc = check_fields(list, allowed, spec, err);
    if (!rc) rc = num_field(list, "from", spec, 3, a, 1, err);
    if (!rc) rc = num_field(list, "to", spec, 3, b, 1, err);
    if (!rc) rc = num_field(list, "duration", spec, 1, &T, 1, err);
    if (!rc) rc = positive(T, "duration", spec, err);
    if (!rc) rc = law_field(list, spec, &law, err);
    if (!rc) rc = dwell_field(list, spec, &dwell, err);
    if (rc)
        return rc;
    memset(tr, 0, sizeof *tr);
    snprintf(tr->name, sizeof tr->name, "%s", spec);
    tr->kind = DM_PATH_SEGMENTS;
    add_segment(tr, a, b, T, law);
    if (dwell > 0)
        add_segment(tr, b, b, dwell, law);
    return segments_finite(tr, spec, err);
}

/* 25 mm up, 305 mm across, 25 mm down; times in proportion to sqrt(length)
 * so that every segment has the same peak acceleration. */
static int make_pick(const char *spec, const char *list, const dm_robot *rb,
                     dm_trajectory *tr, dm_error *err)
{
    static const char *const allowed[] = {"start", "duration", "law", "axis", "dwell", NULL};
    double p0[3] = {0, 0, 0}, T = 0, dwell = 0;
    char axis[8] = "x";
    dm_motion_law law;
    if (rb) {
        dm_copy3(rb->home_m, p0);
        p0[0] -= 0.1525;
    }
    int rc = check_fields(list, allowed, spec, err);
    if (!rc) rc = num_field(list, "start", spec, 3, p0, !rb, err);
    if (!rc) rc = num_field(list, "duration", spec, 1, &T, 1, err);
    if (!rc) rc = positive(T, "duration", spec, err);
    if (!rc) rc = law_field(list, spec, &law, err);
    if (!rc) rc = dwell_field(list, spec, &dwell, err);
    if (rc)
        return rc;
    field(list, "axis", axis, sizeof axis);
    if (strcmp(axis, "x") && strcmp(axis, "y"))
        return dm_fail(err, DM_EINVAL, "path '%s': axis is x or y", spec);
    int ax = axis[0] == 'y';
    memset(tr, 0, sizeof *tr);
    snprintf(tr->name, sizeof tr->name, "%s", spec);
    tr->kind = DM_PATH_SEGMENTS;
    double p1[3], p2[3], p3[3], up = 0.025, across = 0.305;
    double wsum = 2 * sqrt(up) + sqrt(across);
    dm_copy3(p0, p1);
    p1[2] += up;
    dm_copy3(p1, p2);
    p2[ax] += across;
    dm_copy3(p2, p3);
    p3[2] -= up;
    add_segment(tr, p0, p1, T * sqrt(up) / wsum, law);
    add_segment(tr, p1, p2, T * sqrt(across) / wsum, law);
    add_segment(tr, p2, p3, T * sqrt(up) / wsum, law);
    tr->duration_s = T;
    if (dwell > 0)
        add_segment(tr, p3, p3, dwell, law);
    return segments_finite(tr, spec, err);
}

/* ---- CSV samples --------------------------------------------------------- */

static int spline(dm_trajectory *tr, dm_error *err)
{
    int n = tr->nsamp;
    tr->m2 = calloc(3 * (size_t)n, sizeof *tr->m2);
    double *dl = malloc(sizeof(double) * n), *d = malloc(sizeof(double) * n);
    double *du = malloc(sizeof(double) * n), *rhs = malloc(sizeof(double) * n);
    int rc = (!tr->m2 || !dl || !d || !du || !rhs) ? DM_ENOMEM : DM_OK;
    for (int k = 0; k < 3 && !rc && n > 2; k++) {
        int m = n - 2; /* natural spline: m2 = 0 at both ends */
        for (int i = 1; i <= m; i++) {
            double h0 = tr->t_s[i] - tr->t_s[i - 1], h1 = tr->t_s[i + 1] - tr->t_s[i];
            const double *y = tr->xyz_m;
            d[i - 1] = (h0 + h1) / 3;
            dl[i - 1] = du[i - 1] = h1 / 6;
            rhs[i - 1] = (y[3 * (i + 1) + k] - y[3 * i + k]) / h1 - (y[3 * i + k] - y[3 * (i - 1) + k]) / h0;
        }
        if (LAPACKE_dgtsv(LAPACK_COL_MAJOR, m, 1, dl, d, du, rhs, m))
            rc = DM_ENUMERIC;
        for (int i = 1; i <= m && !rc; i++)
            tr->m2[3 * i + k] = rhs[i - 1];
    }
    free(dl);
    free(d);
    free(du);
    free(rhs);
    if (rc)
        return dm_fail(err, rc, "%s: cannot fit a spline through the samples", tr->name);
    /* bounds of every term of eval_samples finite, or the motion overflows
     * (positions too large, or samples too close in time for their distance) */
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            int j = i + 1 < n ? i + 1 : i;
            double h = tr->t_s[j] - tr->t_s[i], y0 = tr->xyz_m[3 * i + k];
            double y1 = tr->xyz_m[3 * j + k];
            double m = fabs(tr->m2[3 * i + k]) + fabs(tr->m2[3 * j + k]);
            double slope = j > i ? (y1 - y0) / h : 0;
            if (!isfinite(slope) || !isfinite(fabs(y0) + fabs(y1) + m * h * h) ||
                !isfinite(fabs(slope) + m * h) || !isfinite(tr->t_s[i]))
                return dm_fail(err, DM_EINVAL,
                               "%s: sample %d (t = %g s): the path's speed or acceleration "
                               "overflows (positions too large or samples too close in time)",
                               tr->name, i + 1, tr->t_s[i]);
        }
    return DM_OK;
}

/* The header's t, x, y, z columns. */
static int sample_columns(const dm_csv *in, int col[4], dm_error *err)
{
    static const char *const want[4] = {"t", "x", "y", "z"};
    for (int k = 0; k < 4; k++)
        if ((col[k] = dm_csv_column(in, want[k])) < 0)
            return dm_fail(err, DM_EINVAL, "%s:%d: header lacks column '%s' (need t,x,y,z)",
                           in->path, in->line, want[k]);
    return DM_OK;
}

static int sample_row(const dm_csv *in, const int col[4], double row[4], dm_error *err)
{
    for (int k = 0; k < 4; k++) {
        if (col[k] >= in->ncells)
            return dm_fail(err, DM_EINVAL, "%s:%d: row has %d columns, too few for t,x,y,z",
                           in->path, in->line, in->ncells);
        int rc = dm_csv_number(in, col[k], &row[k], err);
        if (rc)
            return rc;
    }
    return DM_OK;
}

/* Room for one more sample. */
static int grow_samples(dm_trajectory *tr, int *cap)
{
    if (tr->nsamp < *cap)
        return DM_OK;
    int n = *cap ? 2 * *cap : 256;
    double *t = realloc(tr->t_s, sizeof(double) * n);
    if (t)
        tr->t_s = t;
    double *x = realloc(tr->xyz_m, 3 * sizeof(double) * n);
    if (x)
        tr->xyz_m = x;
    if (!t || !x)
        return DM_ENOMEM;
    *cap = n;
    return DM_OK;
}

static int make_samples(const char *path, dm_trajectory *tr, dm_error *err)
{
    memset(tr, 0, sizeof *tr);
    snprintf(tr->name, sizeof tr->name, "%s", path);
    tr->kind = DM_PATH_SAMPLES;
    dm_csv in;
    int col[4], cap = 0, rc = dm_csv_open(&in, path, err);
    if (rc)
        return rc;
    dm_csv_line kind;
    while (!rc && !(rc = dm_csv_next(&in, &kind, err)) && kind != DM_CSV_END) {
        double row[4];
        if (kind == DM_CSV_HEADER)
            rc = sample_columns(&in, col, err);
        if (kind != DM_CSV_ROW || rc || (rc = sample_row(&in, col, row, err)))
            continue;
        if (tr->nsamp && !(row[0] > tr->t_s[tr->nsamp - 1]))
            rc = dm_fail(err, DM_EINVAL, "%s:%d: column %d (t): times must increase strictly",
                         path, in.line, col[0] + 1);
        else if (grow_samples(tr, &cap))
            rc = dm_fail(err, DM_ENOMEM, "%s: out of memory", path);
        else {
            tr->t_s[tr->nsamp] = row[0];
            memcpy(tr->xyz_m + 3 * tr->nsamp, row + 1, 3 * sizeof(double));
            tr->nsamp++;
        }
    }
    dm_csv_close(&in);
    if (!rc && tr->nsamp < 3)
        rc = dm_fail(err, DM_EINVAL, "%s: needs a header t,x,y,z and at least 3 samples", path);
    if (!rc && fabs(tr->t_s[0]) > 1e-12)
        rc = dm_fail(err, DM_EINVAL, "%s: the first sample must be at t = 0", path);
    if (!rc) {
        tr->duration_s = tr->t_s[tr->nsamp - 1];
        rc = spline(tr, err);
    }
    if (rc)
        dm_traj_free(tr);
    return rc;
}

int dm_traj_from_samples(const double *t, const double *xyz, int n, const char *name,
                         dm_trajectory *tr, dm_error *err)
{
    memset(tr, 0, sizeof *tr);
    snprintf(tr->name, sizeof tr->name, "%s", name);
    tr->kind = DM_PATH_SAMPLES;
    if (n < 3 || fabs(t[0]) > 1e-12)
        return dm_fail(err, DM_EINVAL, "%s: needs at least 3 samples starting at t = 0", name);
    for (int i = 1; i < n; i++)
        if (!(t[i] > t[i - 1]))
            return dm_fail(err, DM_EINVAL, "%s: times must increase strictly", name);
    tr->t_s = malloc(sizeof(double) * n);
    tr->xyz_m = malloc(3 * sizeof(double) * n);
    if (!tr->t_s || !tr->xyz_m) {
        dm_traj_free(tr);
        return dm_fail(err, DM_ENOMEM, "out of memory");
    }
    memcpy(tr->t_s, t, sizeof(double) * n);
    memcpy(tr->xyz_m, xyz, 3 * sizeof(double) * n);
    tr->nsamp = n;
    tr->duration_s = t[n - 1];
    int rc = spline(tr, err);
    if (rc)
        dm_traj_free(tr);
    return rc;
}

int dm_traj_make(const char *spec, const dm_robot *rb, dm_trajectory *tr, dm_error *err)
{
    memset(tr, 0, sizeof *tr);
    if (preset_path(spec, tr))
        return DM_OK;
    const char *colon = strchr(spec, ':');
    if (colon && !strncmp(spec, "circle:", 7))
        return make_circle(spec, colon + 1, tr, err);
    if (colon && !strncmp(spec, "p2p:", 4))
        return make_p2p(spec, colon + 1, tr, err);
    if (colon && !strncmp(spec, "pick:", 5))
        return make_pick(spec, colon + 1, rb, tr, err);
    if (!strcmp(spec, "pick") && rb)
        return make_pick(spec, "duration=0.5", rb, tr, err);
    size_t n = strlen(spec);
    if (n > 4 && !strcmp(spec + n - 4, ".csv"))
        return make_samples(spec, tr, err);
    return dm_fail(err, DM_EINVAL,
                   "path '%s' is not a preset (chen2018, zheng2017, han2011, han2011-vertical, "
                   "han2011-vertical-printed), a circle:/p2p:/pick: spec or a .csv file",
                   spec);
}

void dm_traj_free(dm_trajectory *tr)
{
    free(tr->t_s);
    free(tr->xyz_m);
    free(tr->m2);
    tr->t_s = tr->xyz_m = tr->m2 = NULL;
    tr->nsamp = 0;
}

int dm_traj_check_reachable(const dm_trajectory *tr, const dm_robot *rb, double dt, dm_error *err)
{
    long n = (long)ceil(tr->duration_s / dt - 1e-9);
    for (long j = 0; j <= n; j++) {
        double t = fmin(j * dt, tr->duration_s), P[3], v[3], a[3];
        dm_pose pose;
        dm_traj_eval(tr, t, P, v, a);
        if (dm_kin_inverse(rb, P, &pose, NULL))
            return dm_fail(err, DM_EUNREACHABLE,
                           "path %s leaves the workspace of %s: first unreachable at t = %.6g s, "
                           "P = (%.6g, %.6g, %.6g) m",
                           tr->name, rb->name, t, P[0], P[1], P[2]);
    }
    return DM_OK;
}
