/* The table of model extensions and what derives from it (see dm_effects.h).
 *
 * Its own module beside robot.c rather than rows inside robot.c's key
 * table: the rows carry what the diagnosis, plan and synth need (search
 * ranges, data kinds, scales), which the robot file does not, and those
 * layers read the table without the file's parser; robot.c takes its
 * [effects] and [damping] keys from here. */
#include "dm_effects.h"

#include <assert.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dm_robot.h"

#define E_OFF(field) offsetof(dm_robot, effects.field)
#define M_ALL (DM_EFFECTS_MODAL | DM_EFFECTS_STATIC | DM_EFFECTS_TRACKER)
#define M_MT (DM_EFFECTS_MODAL | DM_EFFECTS_TRACKER)
#define M_ST (DM_EFFECTS_STATIC | DM_EFFECTS_TRACKER)
#define M_T DM_EFFECTS_TRACKER

/* A spring or mass: fitted in log10 over [lo, hi], one parameter. */
#define LOG1(name, off, value, unit, lo, hi, kinds, typical)                                   \
    {name, "effects", name, off, value, unit, DM_EFFECTS_ROBOT, 0, DM_EFFECTS_WRITE_NONZERO, lo, \
     hi, kinds, 1, 0, 0, typical, NULL}
/* A compliant base: one stiffness on X, Y and Z. */
#define BASE(name, i, scope, write, global)                                                     \
    {name, "effects", name, offsetof(dm_robot, effects.base_stiffness_n_per_m[i]),              \
     DM_EFFECTS_VEC3_NONNEG, "N/m", scope, i, write, 4.0, 10.0, M_ALL, 1, 0, 0, 2e6, global}
/* A geometry error family: three signed per-chain values, fitted as they are. */
#define FAMILY(name, field, value, unit, scale)                                                 \
    {name, "effects", name, E_OFF(field), value, unit, DM_EFFECTS_EACH_CHAIN, 0,                \
     DM_EFFECTS_WRITE_NONZERO, 0, 1, M_T, 3, 1, scale, scale, NULL}

/* Ranges: springs from very soft to far stiffer than the structure. Masses
 * seen by statics cannot be: a deflection survey is relative to the same
 * pose without the force. Typical magnitudes are `plan`'s defaults; the
 * scale of a geometry error is the size worth knowing (0.05 % of a 0.2 m
 * arm; 0.05 deg turns a 0.2 m arm's end by about as much). The [effects]
 * rows are in the order the robot file's writer writes them. */
static const dm_effect TABLE[] = {
    LOG1("actuator_stiffness", E_OFF(actuator_stiffness_nm_per_rad), DM_EFFECTS_POSITIVE,
         "N*m/rad", 2.0, 8.0, M_ALL, 2e4),
    LOG1("joint_stiffness", E_OFF(joint_stiffness_n_per_m), DM_EFFECTS_POSITIVE, "N/m", 4.0,
         10.0, M_ALL, 2e6),
    LOG1("payload_mass", E_OFF(payload_kg), DM_EFFECTS_POSITIVE, "kg", -2.0, 1.5, M_MT, 0.5),
    /* where the payload sits: no candidate (the diagnosis fits a centred
     * mass); written with the mass, as the mass means nothing without it */
    {"payload_offset", "effects", "payload_offset", E_OFF(payload_offset_m), DM_EFFECTS_VEC3,
     "m", DM_EFFECTS_ROBOT, 0, DM_EFFECTS_WRITE_WITH_PREVIOUS, 0, 0, 0, 3, 1, 0.01, 0.01, NULL},
    LOG1("elbow_mass", E_OFF(elbow_mass_kg), DM_EFFECTS_POSITIVE, "kg", -2.0, 1.0, M_MT, 1.0),
    /* the global key fills chains without their own in a file; it is never
     * written: the per-chain keys carry every chain's springs */
    BASE("base_stiffness", 0, DM_EFFECTS_ALL_CHAINS, DM_EFFECTS_WRITE_NEVER, NULL),
    BASE("base_stiffness_0", 0, DM_EFFECTS_ONE_CHAIN, DM_EFFECTS_WRITE_NONZERO, "base_stiffness"),
    BASE("base_stiffness_1", 1, DM_EFFECTS_ONE_CHAIN, DM_EFFECTS_WRITE_NONZERO, "base_stiffness"),
    BASE("base_stiffness_2", 2, DM_EFFECTS_ONE_CHAIN, DM_EFFECTS_WRITE_NONZERO, "base_stiffness"),
    {"geometric_stiffness", "effects", "geometric_stiffness", E_OFF(geometric_stiffness),
     DM_EFFECTS_ONOFF, "", DM_EFFECTS_ROBOT, 0, DM_EFFECTS_WRITE_ALWAYS, 0, 0, M_ALL, 0, 0, 0, 1,
     NULL},
    /* joint clearance: jumps when a force flips a rod's load */
    LOG1("clearance", E_OFF(clearance_m), DM_EFFECTS_POSITIVE, "m", -7.0, -3.0, M_ST, 2e-5),
    LOG1("actuator_clearance_axial", E_OFF(actuator_clearance_axial_m), DM_EFFECTS_POSITIVE, "m",
         -7.0, -3.0, M_ST, 5e-5),
    /* the radial play shifts each arm along the rods' pull, which to first
     * order is rod-end clearance of half its size: `clearance` stands for
     * it in the diagnosis */
    LOG1("actuator_clearance_radial", E_OFF(actuator_clearance_radial_m), DM_EFFECTS_POSITIVE,
         "m", -7.0, -3.0, 0, 5e-5),
    /* geometry errors move the platform: only a tracker sees them */
    FAMILY("error_arm_length", err_arm_length_m, DM_EFFECTS_VEC3, "m", 1e-4),
    FAMILY("error_rod_length", err_rod_length_m, DM_EFFECTS_VEC3, "m", 1e-4),
    FAMILY("error_base_radius", err_base_radius_m, DM_EFFECTS_VEC3, "m", 1e-4),
    FAMILY("error_platform_radius", err_platform_radius_m, DM_EFFECTS_VEC3, "m", 1e-4),
    FAMILY("error_theta_deg", err_theta_rad, DM_EFFECTS_VEC3_DEG, "deg", 0.05),
    FAMILY("error_alpha0_deg", err_alpha0_rad, DM_EFFECTS_VEC3_DEG, "deg", 0.05),
    /* Rayleigh C = alpha M + beta K: the decay of the vibration a tracker
     * sees. Two candidates, so that each fit is one-dimensional and a pair
     * finds both; the ranges span modal damping ratios 1e-4 to 1 at the
     * presets' first modes (50-200 Hz). Keys of [damping], written there. */
    {"damping_alpha", "damping", "alpha", offsetof(dm_robot, rayleigh_alpha), DM_EFFECTS_NONNEG,
     "1/s", DM_EFFECTS_ROBOT, 0, DM_EFFECTS_WRITE_NEVER, -1.0, 3.0, M_T, 1, 0, 0, 50, NULL},
    {"damping_beta", "damping", "beta", offsetof(dm_robot, rayleigh_beta), DM_EFFECTS_NONNEG, "s",
     DM_EFFECTS_ROBOT, 0, DM_EFFECTS_WRITE_NEVER, -6.0, -2.0, M_T, 1, 0, 0, 1e-3, NULL},
    /* the six geometry families at once (in table order, three chains
     * each): on one path several of them look alike, and only their union,
     * fitted in the combinations the data see, says what is determined */
    {"geometry_errors", NULL, NULL, 0, DM_EFFECTS_NO_KEY, "m, deg", DM_EFFECTS_EACH_CHAIN, 0,
     DM_EFFECTS_WRITE_NEVER, 0, 1, M_T, 18, 1, 1e-4, 1e-4, NULL},
};
#define NROWS ((int)(sizeof TABLE / sizeof TABLE[0]))
_Static_assert(NROWS <= DM_EFFECTS_MAXROWS, "DM_EFFECTS_MAXROWS holds the table");

const dm_effect *dm_effects_table(int *count)
{
    *count = NROWS;
    return TABLE;
}

const dm_effect *dm_effects_find(const char *name)
{
    for (int i = 0; i < NROWS; i++)
        if (!strcmp(TABLE[i].name, name))
            return &TABLE[i];
    return NULL;
}

const dm_effect *dm_effects_find_key(const char *section, const char *key)
{
    for (int i = 0; i < NROWS; i++)
        if (TABLE[i].section && !strcmp(TABLE[i].section, section) && !strcmp(TABLE[i].key, key))
            return &TABLE[i];
    return NULL;
}

static int is_family(const dm_effect *e)
{
    return e->scope == DM_EFFECTS_EACH_CHAIN && e->nparam == 3;
}

const dm_effect *dm_effects_family(int f)
{
    assert(f >= 0 && f < 6);
    for (int i = 0, k = 0; i < NROWS; i++)
        if (is_family(&TABLE[i]) && k++ == f)
            return &TABLE[i];
    assert(!"the table holds six geometry families");
    return NULL;
}

static int is_union(const dm_effect *e) { return e->nparam == 6 * 3; }

const dm_effect *dm_effects_union(void)
{
    for (int i = 0; i < NROWS; i++)
        if (is_union(&TABLE[i]))
            return &TABLE[i];
    assert(!"the table holds geometry_errors");
    return NULL;
}

void dm_effects_key_list(char *buf, size_t n)
{
    assert(n > 0);
    buf[0] = '\0';
    for (int i = 0, k = 0; i < NROWS; i++)
        if (TABLE[i].section && !strcmp(TABLE[i].section, "effects"))
            snprintf(buf + strlen(buf), n - strlen(buf), "%s%s", k++ ? ", " : "", TABLE[i].key);
}

double dm_effects_param_scale(const dm_effect *e, int k)
{
    assert(k >= 0 && k < e->nparam);
    if (!e->linear)
        return 1.0 / log(10.0); /* a unit of log10 is ln 10 relative */
    return is_union(e) ? dm_effects_family(k / 3)->scale : e->scale;
}

void dm_effects_param_name(const dm_effect *e, int k, char *buf, size_t n)
{
    assert(k >= 0 && (k < e->nparam || k == 0) && n > 0); /* 0: a switch's name */
    if (is_union(e))
        snprintf(buf, n, "%s[%d]", dm_effects_family(k / 3)->name, k % 3);
    else if (e->nparam == 3)
        snprintf(buf, n, "%s[%d]", e->name, k);
    else
        snprintf(buf, n, "%s", e->name);
}

int dm_effects_apply(dm_robot *rb, const char *name, const double *v, dm_error *err)
{
    const dm_effect *e = dm_effects_find(name);
    if (!e) {
        char keys[600];
        dm_effects_key_list(keys, sizeof keys);
        return dm_fail(err, DM_EINVAL, "%s: [effects] %s: not a model extension (%s)",
                       rb->source, name, keys);
    }
    if (is_union(e)) { /* on a copy: unchanged on error */
        dm_robot changed = *rb;
        for (int f = 0; f < 6; f++) {
            int rc = dm_effects_apply(&changed, dm_effects_family(f)->name, v + 3 * f, err);
            if (rc)
                return rc;
        }
        *rb = changed;
        return DM_OK;
    }
    const double on[1] = {1};
    if (e->value == DM_EFFECTS_ONOFF) /* a switch: no parameter, v may be NULL */
        return dm_robot_set_number(rb, e->section, e->key, on, err);
    if (e->nparam == 1 && e->value == DM_EFFECTS_VEC3_NONNEG) { /* one stiffness, three axes */
        const double all3[3] = {v[0], v[0], v[0]};
        return dm_robot_set_number(rb, e->section, e->key, all3, err);
    }
    return dm_robot_set_number(rb, e->section, e->key, v, err);
}

/* Numbers of one [effects] row in dm_effects (the row's offset is in dm_robot). */
static const double *numbers_of(const dm_effects *fx, const dm_effect *e)
{
    size_t base = offsetof(dm_robot, effects);
    assert(e->section && !strcmp(e->section, "effects") && e->offset >= base &&
           e->offset - base < sizeof *fx && e->value != DM_EFFECTS_ONOFF);
    return (const double *)(const void *)((const char *)fx + (e->offset - base));
}

int dm_effects_is_set(const dm_effects *fx, const dm_effect *e)
{
    if (e->value == DM_EFFECTS_ONOFF)
        return fx->geometric_stiffness != 0;
    const double *v = numbers_of(fx, e);
    int n = e->value >= DM_EFFECTS_VEC3 ? 3 : 1;
    for (int i = 0; i < n; i++)
        if (v[i] != 0)
            return 1;
    return 0;
}

int dm_effects_geometry_errors(const dm_effects *fx)
{
    for (int i = 0; i < NROWS; i++)
        if (is_family(&TABLE[i]) && dm_effects_is_set(fx, &TABLE[i]))
            return 1;
    return dm_effects_clearance(fx);
}

int dm_effects_clearance(const dm_effects *e)
{
    return e->clearance_m > 0 || e->actuator_clearance_axial_m > 0 ||
           e->actuator_clearance_radial_m > 0;
}

int dm_effects_any(const dm_effects *fx)
{
    for (int i = 0; i < NROWS; i++)
        if (TABLE[i].section && !strcmp(TABLE[i].section, "effects") &&
            dm_effects_is_set(fx, &TABLE[i]))
            return 1;
    return 0;
}

int dm_effects_base_compliant(const dm_effects *e, int i)
{
    assert(i >= 0 && i < 3);
    for (int k = 0; k < 3; k++)
        if (e->base_stiffness_n_per_m[i][k] > 0)
            return 1;
    return 0;
}

/* ---- specs ----------------------------------------------------------------------- */

static int is_number_start(char c)
{
    return (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.';
}

/* One value of effect s (its nv-th), from text t. */
static int spec_value(const char *spec, dm_effects_spec *s, int nv, const char *t, dm_error *err)
{
    const dm_effect *e = s->effect;
    char *end;
    double v = strtod(t, &end);
    if (end == t || *end || !isfinite(v))
        return dm_fail(err, DM_EINVAL, "effects '%s': %s: '%s' is not a number", spec, e->name, t);
    if (!e->linear && !(v > 0))
        return dm_fail(err, DM_EINVAL, "effects '%s': %s takes a magnitude > 0, not '%s'", spec,
                       e->name, t);
    for (int k = nv; k < DM_EFFECTS_MAXV; k++) /* one value stands for all */
        s->value[k] = v;
    return DM_OK;
}

/* Start effect s from token `tok` (NAME, NAME=V or NAME=on); *nv: values given. */
static int spec_start(const char *spec, char *tok, dm_effects_spec *s, int *nv, dm_error *err)
{
    char *eq = strchr(tok, '=');
    if (eq)
        *eq = '\0';
    const dm_effect *e = dm_effects_find(tok);
    if (!e) {
        char keys[600];
        dm_effects_key_list(keys, sizeof keys);
        return dm_fail(err, DM_EINVAL,
                       "effects '%s': '%s' is not a candidate effect (see deltamap diagnose "
                       "--help) and not a model extension (%s)", spec, tok, keys);
    }
    s->effect = e;
    for (int k = 0; k < DM_EFFECTS_MAXV; k++)
        s->value[k] = e->nparam ? e->typical : 1;
    *nv = 0;
    if (!eq)
        return DM_OK;
    if (!e->nparam) {
        if (strcmp(eq + 1, "on"))
            return dm_fail(err, DM_EINVAL, "effects '%s': %s is a switch: %s or %s=on, not '%s'",
                           spec, e->name, e->name, e->name, eq + 1);
        return DM_OK;
    }
    *nv = 1;
    return spec_value(spec, s, 0, eq + 1, err);
}

static int spec_count_ok(const char *spec, const dm_effects_spec *s, int nv, dm_error *err)
{
    if (nv > 1 && nv != s->effect->nparam)
        return dm_fail(err, DM_EINVAL, "effects '%s': %s takes 1 or %d values, not %d", spec,
                       s->effect->name, s->effect->nparam, nv);
    return DM_OK;
}

int dm_effects_parse_spec(const char *spec, dm_effects_spec *out, int max, int *count,
                          dm_error *err)
{
    char buf[1024], *save = NULL;
    if (strlen(spec) >= sizeof buf)
        return dm_fail(err, DM_EINVAL, "effects '%.40s...': longer than %zu characters", spec,
                       sizeof buf - 1);
    snprintf(buf, sizeof buf, "%s", spec);
    int n = *count, nv = 0, rc = DM_OK;
    for (char *tok = strtok_r(buf, ",", &save); tok && !rc; tok = strtok_r(NULL, ",", &save)) {
        tok += strspn(tok, " \t");
        if (is_number_start(*tok)) { /* a further value of the effect before */
            if (n == *count || nv == 0 || nv >= out[n - 1].effect->nparam)
                return dm_fail(err, DM_EINVAL, "effects '%s': '%s' is not a value of an effect",
                               spec, tok);
            rc = spec_value(spec, &out[n - 1], nv++, tok, err);
            continue;
        }
        if (n > *count && (rc = spec_count_ok(spec, &out[n - 1], nv, err)))
            break;
        if (n == max)
            return dm_fail(err, DM_EINVAL, "effects '%s': at most %d effects", spec, max);
        rc = spec_start(spec, tok, &out[n], &nv, err);
        for (int k = *count; k < n && !rc; k++)
            if (out[k].effect == out[n].effect)
                rc = dm_fail(err, DM_EINVAL, "effects '%s': %s named twice", spec,
                             out[n].effect->name);
        n++;
    }
    if (!rc && n > *count)
        rc = spec_count_ok(spec, &out[n - 1], nv, err);
    if (!rc && n == *count)
        rc = dm_fail(err, DM_EINVAL, "effects '%s': name at least one effect", spec);
    if (!rc)
        *count = n;
    return rc;
}

int dm_effects_apply_spec(dm_robot *rb, const char *spec, dm_error *err)
{
    dm_effects_spec s[DM_EFFECTS_MAXROWS];
    int n = 0, rc = dm_effects_parse_spec(spec, s, DM_EFFECTS_MAXROWS, &n, err);
    dm_robot changed = *rb;
    for (int i = 0; i < n && !rc; i++)
        rc = dm_effects_apply(&changed, s[i].effect->name, s[i].value, err);
    if (!rc)
        *rb = changed;
    return rc;
}
