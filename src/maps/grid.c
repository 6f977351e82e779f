/* Grid specifications of workspace sweeps (see dm_grid.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dm_grid.h"

static int parse_axis(const char *text, dm_grid_axis *ax, const char *spec, dm_error *err)
{
    char buf[128];
    snprintf(buf, sizeof buf, "%s", text);
    char *eq = strchr(buf, '=');
    if (!eq)
        return dm_fail(err, DM_EINVAL, "grid '%s': '%s' is not NAME=A:B:N or NAME=V", spec, text);
    *eq = '\0';
    if (strlen(buf) >= sizeof ax->name)
        return dm_fail(err, DM_EINVAL, "grid '%s': '%s' is not an axis name", spec, buf);
    memcpy(ax->name, buf, strlen(buf) + 1);
    char *p = eq + 1, *end;
    double v[3];
    int nv = 0;
    while (nv < 3) {
        v[nv] = strtod(p, &end);
        if (end == p || !isfinite(v[nv]))
            return dm_fail(err, DM_EINVAL, "grid '%s': axis %s: '%s' is not A:B:N or one value",
                           spec, ax->name, eq + 1);
        nv++;
        if (*end != ':')
            break;
        p = end + 1;
    }
    if (*end)
        return dm_fail(err, DM_EINVAL, "grid '%s': axis %s: '%s' is not A:B:N or one value", spec,
                       ax->name, eq + 1);
    if (nv == 2)
        return dm_fail(err, DM_EINVAL, "grid '%s': axis %s: '%s' is not A:B:N or one value", spec,
                       ax->name, eq + 1);
    if (nv == 1) {
        ax->from = ax->to = v[0];
        ax->count = 1;
    } else if (nv == 3 && v[2] == floor(v[2]) && v[2] >= 1 && v[2] <= 1e6) {
        ax->from = v[0];
        ax->to = v[1];
        ax->count = (int)v[2];
        if (!isfinite((ax->to - ax->from) * (ax->count - 1))) /* dm_grid_value's product */
            return dm_fail(err, DM_EINVAL, "grid '%s': axis %s: range %g:%g is too large", spec,
                           ax->name, ax->from, ax->to);
        if (ax->count > 1 && ax->from == ax->to)
            return dm_fail(err, DM_EINVAL, "grid '%s': axis %s has %d points on an empty range",
                           spec, ax->name, ax->count);
        if (ax->count == 1 && ax->from != ax->to)
            return dm_fail(err, DM_EINVAL, "grid '%s': axis %s: one point cannot span %g:%g",
                           spec, ax->name, ax->from, ax->to);
        if (ax->count == 1)
            ax->to = ax->from; /* 0:-0:1 is the one point 0, as "0" reads */
    } else {
        return dm_fail(err, DM_EINVAL, "grid '%s': axis %s: N must be a whole number 1..1000000",
                       spec, ax->name);
    }
    return DM_OK;
}

int dm_grid_parse(const char *spec, dm_grid *g, dm_error *err)
{
    static const char *const names[2][3] = {{"x", "y", "z"}, {"r", "phi", "z"}};
    dm_grid_axis parsed[3];
    int n = 0;
    memset(parsed, 0, sizeof parsed);
    char buf[512];
    memset(g, 0, sizeof *g);
    if (strlen(spec) >= sizeof buf)
        return dm_fail(err, DM_EINVAL, "grid spec too long");
    strcpy(buf, spec);
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        if (n == 3)
            return dm_fail(err, DM_EINVAL, "grid '%s': more than three axes", spec);
        int rc = parse_axis(tok, &parsed[n++], spec, err);
        if (rc)
            return rc;
    }
    int kind = -1;
    for (int i = 0; i < n && kind < 0; i++)
        kind = !strcmp(parsed[i].name, "x") || !strcmp(parsed[i].name, "y") ? 0
               : !strcmp(parsed[i].name, "r") || !strcmp(parsed[i].name, "phi") ? 1 : -1;
    if (kind < 0)
        return dm_fail(err, DM_EINVAL,
                       "grid '%s': give x=,y=,z= (Cartesian) or r=,phi=,z= (cylindrical)", spec);
    g->kind = (dm_grid_kind)kind;
    for (int i = 0; i < n; i++) {
        int ok = 0;
        for (int a = 0; a < 3; a++)
            ok |= !strcmp(parsed[i].name, names[kind][a]);
        if (!ok)
            return dm_fail(err, DM_EINVAL, "grid '%s': axis %s does not belong to a %s grid", spec,
                           parsed[i].name, kind ? "cylindrical" : "Cartesian");
    }
    for (int a = 0; a < 3; a++) {
        int found = 0;
        for (int i = 0; i < n; i++) {
            if (strcmp(parsed[i].name, names[kind][a]))
                continue;
            if (found++)
                return dm_fail(err, DM_EINVAL, "grid '%s': axis %s given twice", spec, names[kind][a]);
            g->axis[a] = parsed[i];
        }
        if (!found)
            return dm_fail(err, DM_EINVAL, "grid '%s': axis %s missing (%s grids need %s, %s, %s)",
                           spec, names[kind][a], kind ? "cylindrical" : "Cartesian",
                           names[kind][0], names[kind][1], names[kind][2]);
    }
    if (kind == 1 && (g->axis[0].from < 0 || g->axis[0].to < 0))
        return dm_fail(err, DM_EINVAL, "grid '%s': radius r must be >= 0", spec);
    if (dm_grid_points(g) > DM_GRID_MAX_POINTS)
        return dm_fail(err, DM_EINVAL, "grid '%s': %ld points is more than %ld", spec,
                       dm_grid_points(g), DM_GRID_MAX_POINTS);
    return DM_OK;
}

double dm_grid_value(const dm_grid_axis *ax, int i)
{
    return ax->count == 1 ? ax->from : ax->from + (ax->to - ax->from) * i / (ax->count - 1);
}

void dm_grid_position(const dm_grid *g, const int idx[3], double P[3])
{
    double a = dm_grid_value(&g->axis[0], idx[0]), b = dm_grid_value(&g->axis[1], idx[1]);
    P[2] = dm_grid_value(&g->axis[2], idx[2]);
    if (g->kind == DM_GRID_CARTESIAN) {
        P[0] = a;
        P[1] = b;
    } else {
        P[0] = a * cos(b * M_PI / 180.0);
        P[1] = a * sin(b * M_PI / 180.0);
    }
}

long dm_grid_points(const dm_grid *g)
{
    return (long)g->axis[0].count * g->axis[1].count * g->axis[2].count;
}

/* Shortest of %.15g / %.17g that reads back as the same double. */
static const char *num(double v, char buf[32])
{
    snprintf(buf, 32, "%.15g", v);
    if (strtod(buf, NULL) != v)
        snprintf(buf, 32, "%.17g", v);
    return buf;
}

void dm_grid_format(const dm_grid *g, char *out, size_t len)
{
    char a[32], b[32];
    size_t n = 0;
    for (int i = 0; i < 3 && n < len; i++) {
        const dm_grid_axis *ax = &g->axis[i];
        if (ax->count == 1)
            n += (size_t)snprintf(out + n, len - n, "%s%s=%s", i ? "," : "", ax->name,
                                  num(ax->from, a));
        else
            n += (size_t)snprintf(out + n, len - n, "%s%s=%s:%s:%d", i ? "," : "", ax->name,
                                  num(ax->from, a), num(ax->to, b), ax->count);
    }
}
