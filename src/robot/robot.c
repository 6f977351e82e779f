/* Robot description files: INI parsed with libinih, validated key by key.
 *
 * Parsing is table driven: every accepted [section] key has one row saying
 * where it goes, how it is read and whether it is required. The handler
 * records the line of every key so that checks made after parsing (a
 * missing dimension, a tube whose bore exceeds its diameter) still name the
 * file, line and key. */
#include "dm_robot.h"

#include <assert.h>
#include <errno.h>
#include <float.h>
#include <stdarg.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include <ini.h>

typedef enum {
    KEY_POSITIVE,   /* double > 0 */
    KEY_NONNEG,     /* double >= 0 */
    KEY_REAL,       /* any finite double */
    KEY_DEGREES,    /* finite double in degrees, stored in radians */
    KEY_COUNT,      /* integer >= 1 */
    KEY_VEC3,       /* three finite doubles "a, b, c" */
    KEY_VEC3_NONNEG,/* three doubles >= 0 */
    KEY_VEC3_DEG,   /* three doubles in degrees, stored in radians */
    KEY_SHAPE,      /* rect | square | circle | tube */
    KEY_ONOFF,      /* on | off */
    KEY_ELBOW,      /* out | in */
    KEY_NAME        /* free text */
} key_kind;

typedef struct {
    const char *section;
    const char *key;
    key_kind kind;
    size_t offset;
    int required;
    const char *unit;
} key_spec;

#define R_OFF(field) offsetof(dm_robot, field)

static const key_spec KEYS[] = {
    {"robot", "name", KEY_NAME, R_OFF(name), 0, ""},
    {"geometry", "base_radius", KEY_POSITIVE, R_OFF(base_radius_m), 1, "m"},
    {"geometry", "platform_radius", KEY_POSITIVE, R_OFF(platform_radius_m), 1, "m"},
    {"geometry", "arm_length", KEY_POSITIVE, R_OFF(arm_length_m), 1, "m"},
    {"geometry", "rod_length", KEY_POSITIVE, R_OFF(rod_length_m), 1, "m"},
    {"geometry", "rod_half_spacing", KEY_POSITIVE, R_OFF(rod_half_spacing_m), 1, "m"},
    {"geometry", "theta0_deg", KEY_DEGREES, R_OFF(theta0_rad), 0, "deg"},
    {"geometry", "elbow", KEY_ELBOW, R_OFF(elbow_in), 0, ""},
#define MEMBER_KEYS(sec, m)                                                        \
    {sec, "shape", KEY_SHAPE, R_OFF(m.shape), 1, ""},                              \
    {sec, "width", KEY_POSITIVE, R_OFF(m.b_m), 0, "m"},                            \
    {sec, "height", KEY_POSITIVE, R_OFF(m.h_m), 0, "m"},                           \
    {sec, "side", KEY_POSITIVE, R_OFF(m.diameter_m), 0, "m"},                      \
    {sec, "diameter", KEY_POSITIVE, R_OFF(m.diameter_m), 0, "m"},                  \
    {sec, "inner_diameter", KEY_POSITIVE, R_OFF(m.inner_diameter_m), 0, "m"},      \
    {sec, "youngs_modulus", KEY_POSITIVE, R_OFF(m.youngs_pa), 1, "Pa"},            \
    {sec, "shear_modulus", KEY_POSITIVE, R_OFF(m.shear_pa), 0, "Pa"},              \
    {sec, "poisson_ratio", KEY_REAL, 0, 0, ""},                                    \
    {sec, "density", KEY_POSITIVE, R_OFF(m.density_kgm3), 1, "kg/m^3"}
    MEMBER_KEYS("arm", arm),
    MEMBER_KEYS("rod", rod),
    {"platform", "mass", KEY_POSITIVE, R_OFF(platform_mass_kg), 1, "kg"},
    {"platform", "inertia", KEY_VEC3_NONNEG, R_OFF(platform_inertia_kgm2), 0, "kg*m^2"},
    {"environment", "gravity", KEY_VEC3, R_OFF(gravity_ms2), 0, "m/s^2"},
    {"damping", "alpha", KEY_NONNEG, R_OFF(rayleigh_alpha), 0, "1/s"},
    {"damping", "beta", KEY_NONNEG, R_OFF(rayleigh_beta), 0, "s"},
    {"mesh", "na", KEY_COUNT, R_OFF(na), 0, ""},
    {"mesh", "nb", KEY_COUNT, R_OFF(nb), 0, ""},
    {"workspace", "home", KEY_VEC3, R_OFF(home_m), 0, "m"},
    {"workspace", "singular_condition", KEY_POSITIVE, R_OFF(singular_cond), 0, ""},
    {"effects", "actuator_stiffness", KEY_POSITIVE, R_OFF(effects.actuator_stiffness_nm_per_rad), 0, "N*m/rad"},
    {"effects", "joint_stiffness", KEY_POSITIVE, R_OFF(effects.joint_stiffness_n_per_m), 0, "N/m"},
    {"effects", "payload_mass", KEY_POSITIVE, R_OFF(effects.payload_kg), 0, "kg"},
    {"effects", "payload_offset", KEY_VEC3, R_OFF(effects.payload_offset_m), 0, "m"},
    {"effects", "elbow_mass", KEY_POSITIVE, R_OFF(effects.elbow_mass_kg), 0, "kg"},
    {"effects", "base_stiffness", KEY_VEC3_NONNEG, 0, 0, "N/m"},
    {"effects", "base_stiffness_0", KEY_VEC3_NONNEG, R_OFF(effects.base_stiffness_n_per_m[0]), 0, "N/m"},
    {"effects", "base_stiffness_1", KEY_VEC3_NONNEG, R_OFF(effects.base_stiffness_n_per_m[1]), 0, "N/m"},
    {"effects", "base_stiffness_2", KEY_VEC3_NONNEG, R_OFF(effects.base_stiffness_n_per_m[2]), 0, "N/m"},
    {"effects", "geometric_stiffness", KEY_ONOFF, R_OFF(effects.geometric_stiffness), 0, ""},
    {"effects", "clearance", KEY_POSITIVE, R_OFF(effects.clearance_m), 0, "m"},
    {"effects", "actuator_clearance_axial", KEY_POSITIVE, R_OFF(effects.actuator_clearance_axial_m), 0, "m"},
    {"effects", "actuator_clearance_radial", KEY_POSITIVE, R_OFF(effects.actuator_clearance_radial_m), 0, "m"},
    {"effects", "error_arm_length", KEY_VEC3, R_OFF(effects.err_arm_length_m), 0, "m"},
    {"effects", "error_rod_length", KEY_VEC3, R_OFF(effects.err_rod_length_m), 0, "m"},
    {"effects", "error_base_radius", KEY_VEC3, R_OFF(effects.err_base_radius_m), 0, "m"},
    {"effects", "error_platform_radius", KEY_VEC3, R_OFF(effects.err_platform_radius_m), 0, "m"},
    {"effects", "error_theta_deg", KEY_VEC3_DEG, R_OFF(effects.err_theta_rad), 0, "deg"},
    {"effects", "error_alpha0_deg", KEY_VEC3_DEG, R_OFF(effects.err_alpha0_rad), 0, "deg"},
};
#define NKEYS (sizeof KEYS / sizeof KEYS[0])

/* What an unknown [effects] key is told. */
static const char NOT_AN_EFFECT[] =
    "not a model extension (actuator_stiffness, joint_stiffness, payload_mass, "
    "payload_offset, elbow_mass, base_stiffness[_0|_1|_2], geometric_stiffness, clearance, "
    "actuator_clearance_axial, actuator_clearance_radial, error_arm_length, "
    "error_rod_length, error_base_radius, error_platform_radius, error_theta_deg, "
    "error_alpha0_deg)";

/* Sections whose unknown keys get a more specific message. */
static const char *const RESERVED_SECTIONS[] = {"effects", NULL};

typedef struct {
    dm_robot *robot;
    const char *source;
    int line;              /* line being parsed (counted by our reader) */
    int key_line[NKEYS];   /* line where each key was set, 0 = absent */
    double poisson[2];     /* arm, rod */
    double base_global[3]; /* [effects] base_stiffness, for chains without their own */
    dm_error *err;
} parse_state;

static int parse_double(const char *s, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    while (*end == ' ' || *end == '\t')
        end++;
    /* subnormals are refused whatever their spelling (0x1p-1074 reads without
     * ERANGE, its decimal form 4.94e-324 with): the written file must read back */
    if (end == s || *end != '\0' || errno == ERANGE || !isfinite(v) ||
        (v != 0 && fabs(v) < DBL_MIN))
        return -1;
    *out = v;
    return 0;
}

static int parse_vec3(const char *s, double out[3])
{
    char buf[256];
    if (strlen(s) >= sizeof buf)
        return -1;
    strcpy(buf, s);
    char *save = NULL, *tok = strtok_r(buf, ",", &save);
    for (int i = 0; i < 3; i++) {
        if (!tok || parse_double(tok + strspn(tok, " \t"), &out[i]))
            return -1;
        tok = strtok_r(NULL, ",", &save);
    }
    return tok ? -1 : 0;
}

/* Record "FILE:LINE: [section] key: what" and return 0 (inih's "stop"). */
static int key_error(parse_state *st, int line, const char *section,
                     const char *key, const char *fmt, ...)
    __attribute__((format(printf, 5, 6)));

static int key_error(parse_state *st, int line, const char *section,
                     const char *key, const char *fmt, ...)
{
    char what[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    dm_fail(st->err, DM_EINVAL, "%s:%d: [%s] %s: %s", st->source, line,
            section, key, what);
    return 0;
}

static int is_vec3(key_kind k)
{
    return k == KEY_VEC3 || k == KEY_VEC3_NONNEG || k == KEY_VEC3_DEG;
}

static int store_value(parse_state *st, const key_spec *ks, const char *value)
{
    assert(ks->offset + (ks->kind == KEY_NAME ? DM_NAME_LEN
                         : is_vec3(ks->kind)   ? 3 * sizeof(double)
                                               : sizeof(double)) <=
           sizeof *st->robot);
    char *dst = (char *)st->robot + ks->offset;
    double v = 0, v3[3];
    switch (ks->kind) {
    case KEY_NAME:
        if (strlen(value) >= DM_NAME_LEN || !*value)
            return key_error(st, st->line, ks->section, ks->key,
                             "name must be 1 to 63 characters, got '%s'", value);
        if (strchr(value, ';')) /* written as "name = a ;b" it would read back as "a" */
            return key_error(st, st->line, ks->section, ks->key,
                             "'%s': a name cannot hold ';' (it starts a comment)", value);
        strcpy(dst, value);
        return 1;
    case KEY_SHAPE: {
        static const char *const shapes[] = {"rect", "square", "circle", "tube"};
        for (int i = 0; i < 4; i++)
            if (!strcmp(value, shapes[i])) {
                *(dm_section_shape *)dst = (dm_section_shape)i;
                return 1;
            }
        return key_error(st, st->line, ks->section, ks->key,
                         "'%s' is not a section shape (rect, square, circle, tube)", value);
    }
    case KEY_ONOFF:
        if (strcmp(value, "on") && strcmp(value, "off"))
            return key_error(st, st->line, ks->section, ks->key, "'%s' is not on or off", value);
        *(int *)dst = !strcmp(value, "on");
        return 1;
    case KEY_ELBOW:
        if (strcmp(value, "out") && strcmp(value, "in"))
            return key_error(st, st->line, ks->section, ks->key,
                             "'%s' is not an elbow branch (out, in)", value);
        *(int *)dst = !strcmp(value, "in");
        return 1;
    case KEY_COUNT: {
        char *end;
        long n = strtol(value, &end, 10);
        if (end == value || *end || n < 1 || n > 64)
            return key_error(st, st->line, ks->section, ks->key,
                             "'%s' is not a whole number from 1 to 64", value);
        *(int *)dst = (int)n;
        return 1;
    }
    case KEY_VEC3:
    case KEY_VEC3_NONNEG:
    case KEY_VEC3_DEG:
        if (parse_vec3(value, v3))
            return key_error(st, st->line, ks->section, ks->key,
                             "'%s' is not three numbers 'a, b, c'", value);
        if (ks->kind == KEY_VEC3_NONNEG && (v3[0] < 0 || v3[1] < 0 || v3[2] < 0))
            return key_error(st, st->line, ks->section, ks->key,
                             "'%s' has a negative component", value);
        for (int k = 0; k < 3 && ks->kind == KEY_VEC3_DEG; k++)
            v3[k] *= M_PI / 180.0;
        memcpy(!strcmp(ks->key, "base_stiffness") ? (char *)st->base_global : dst, v3, sizeof v3);
        return 1;
    default:
        break;
    }
    if (parse_double(value, &v))
        return key_error(st, st->line, ks->section, ks->key, "'%s' is not a number in range",
                         value);
    if (ks->kind == KEY_POSITIVE && !(v > 0))
        return key_error(st, st->line, ks->section, ks->key, "must be > 0, got %s", value);
    if (ks->kind == KEY_NONNEG && v < 0)
        return key_error(st, st->line, ks->section, ks->key, "must be >= 0, got %s", value);
    if (ks->kind == KEY_DEGREES)
        v *= M_PI / 180.0;
    if (!strcmp(ks->key, "poisson_ratio")) {
        if (!(v > -1.0 && v < 0.5))
            return key_error(st, st->line, ks->section, ks->key,
                             "must lie in (-1, 0.5), got %s", value);
        st->poisson[!strcmp(ks->section, "rod")] = v;
        return 1;
    }
    *(double *)dst = v;
    return 1;
}

static int handler(void *user, const char *section, const char *name, const char *value)
{
    parse_state *st = user;
    if (st->err && st->err->code)
        return 0; /* report only the first error */
    for (size_t i = 0; i < NKEYS; i++) {
        if (strcmp(KEYS[i].section, section) || strcmp(KEYS[i].key, name))
            continue;
        if (st->key_line[i])
            return key_error(st, st->line, section, name,
                             "given twice (first on line %d)", st->key_line[i]);
        st->key_line[i] = st->line;
        return store_value(st, &KEYS[i], value);
    }
    for (int r = 0; RESERVED_SECTIONS[r]; r++)
        if (!strcmp(section, RESERVED_SECTIONS[r]))
            return key_error(st, st->line, section, name,
                             "%s", NOT_AN_EFFECT);
    int known_section = 0;
    for (size_t i = 0; i < NKEYS; i++)
        known_section |= !strcmp(KEYS[i].section, section);
    if (!known_section)
        return key_error(st, st->line, section, name,
                         "unknown section [%s]", section);
    return key_error(st, st->line, section, name, "unknown key");
}

/* ---- reading ------------------------------------------------------------ */

/* inih reads through this callback one line at a time; counting the
 * newlines it hands out gives the line number of the key being parsed. */
typedef struct {
    const char *pos;
    int lines_done;
    parse_state *st;
} line_reader;

static char *read_line(char *buf, int size, void *stream)
{
    assert(size > 1);
    line_reader *rd = stream;
    if (!*rd->pos)
        return NULL;
    int n = 0;
    while (n < size - 1 && rd->pos[n] && rd->pos[n] != '\n')
        n++;
    if (n < size - 1 && rd->pos[n] == '\n')
        n++;
    memcpy(buf, rd->pos, (size_t)n);
    buf[n] = '\0';
    rd->pos += n;
    rd->st->line = rd->lines_done + 1;
    if (n > 0 && buf[n - 1] == '\n')
        rd->lines_done++;
    return buf;
}

static void set_defaults(dm_robot *robot)
{
    memset(robot, 0, sizeof *robot);
    robot->gravity_ms2[2] = -9.80665;
    robot->na = 4; /* converges f1..f6 to 0.1 % (docs/model.md §2, docs/convergence) */
    robot->nb = 4;
    robot->singular_cond = 100.0;
}

static int key_index(const char *section, const char *key)
{
    for (size_t i = 0; i < NKEYS; i++)
        if (!strcmp(KEYS[i].section, section) && !strcmp(KEYS[i].key, key))
            return (int)i;
    return -1;
}

static int line_of(const parse_state *st, const char *section, const char *key)
{
    int i = key_index(section, key);
    return i < 0 ? 0 : st->key_line[i];
}

/* Which dimension keys each shape takes. */
static int shape_uses(dm_section_shape shape, const char *key)
{
    switch (shape) {
    case DM_SECTION_RECT: return !strcmp(key, "width") || !strcmp(key, "height");
    case DM_SECTION_SQUARE: return !strcmp(key, "side");
    case DM_SECTION_CIRCLE: return !strcmp(key, "diameter");
    case DM_SECTION_TUBE:
        return !strcmp(key, "diameter") || !strcmp(key, "inner_diameter");
    }
    return 0;
}

static int finish_member(parse_state *st, const char *sec, dm_member *m, double poisson)
{
    static const char *const dims[] = {"width", "height", "side", "diameter", "inner_diameter"};
    int shape_line = line_of(st, sec, "shape");
    for (int k = 0; k < 5; k++) { /* misplaced keys first: the likelier mistake */
        int line = line_of(st, sec, dims[k]);
        if (line && !shape_uses(m->shape, dims[k]))
            return !key_error(st, line, sec, dims[k], "does not apply to this section shape");
    }
    for (int k = 0; k < 5; k++)
        if (!line_of(st, sec, dims[k]) && shape_uses(m->shape, dims[k]))
            return !key_error(st, shape_line, sec, dims[k],
                              "required by this section shape but missing");
    if (m->shape == DM_SECTION_TUBE && !(m->inner_diameter_m < m->diameter_m))
        return !key_error(st, line_of(st, sec, "inner_diameter"), sec, "inner_diameter",
                          "must be smaller than diameter (%g m)", m->diameter_m);
    int g_line = line_of(st, sec, "shear_modulus"), nu_line = line_of(st, sec, "poisson_ratio");
    if (g_line && nu_line)
        return !key_error(st, nu_line, sec, "poisson_ratio",
                          "give shear_modulus or poisson_ratio, not both (shear_modulus on line %d)",
                          g_line);
    if (!g_line && !nu_line)
        return !key_error(st, shape_line, sec, "poisson_ratio",
                          "missing: give poisson_ratio or shear_modulus");
    if (!g_line)
        m->shear_pa = m->youngs_pa / (2.0 * (1.0 + poisson));
    return dm_section_compute(m, &m->section, st->err);
}

int dm_effects_geometry_errors(const dm_effects *e)
{
    for (int i = 0; i < 3; i++)
        if (e->err_arm_length_m[i] || e->err_rod_length_m[i] || e->err_base_radius_m[i] ||
            e->err_platform_radius_m[i] || e->err_theta_rad[i] || e->err_alpha0_rad[i])
            return 1;
    return dm_effects_clearance(e);
}

int dm_effects_clearance(const dm_effects *e)
{
    return e->clearance_m > 0 || e->actuator_clearance_axial_m > 0 ||
           e->actuator_clearance_radial_m > 0;
}

int dm_effects_any(const dm_effects *e)
{
    int any = e->actuator_stiffness_nm_per_rad || e->joint_stiffness_n_per_m || e->payload_kg ||
              e->elbow_mass_kg || e->geometric_stiffness || dm_effects_geometry_errors(e);
    for (int i = 0; i < 3; i++)
        any |= dm_effects_base_compliant(e, i) || e->payload_offset_m[i] != 0;
    return any;
}

int dm_effects_base_compliant(const dm_effects *e, int i)
{
    assert(i >= 0 && i < 3);
    for (int k = 0; k < 3; k++)
        if (e->base_stiffness_n_per_m[i][k] > 0)
            return 1;
    return 0;
}

/* A chain's base springs are set on all three axes or on none (rigid):
 * one free translation would make the robot a mechanism. */
static int check_effects(parse_state *st)
{
    dm_effects *e = &st->robot->effects;
    for (int i = 0; i < 3 && line_of(st, "effects", "base_stiffness"); i++) {
        char key[32]; /* the global value fills chains without their own */
        snprintf(key, sizeof key, "base_stiffness_%d", i);
        if (!line_of(st, "effects", key))
            memcpy(e->base_stiffness_n_per_m[i], st->base_global, sizeof st->base_global);
    }
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3 && dm_effects_base_compliant(e, i); k++)
            if (!(e->base_stiffness_n_per_m[i][k] > 0)) {
                char key[32];
                int line = line_of(st, "effects", "base_stiffness");
                snprintf(key, sizeof key, "base_stiffness_%d", i);
                if (line_of(st, "effects", key))
                    line = line_of(st, "effects", key);
                else
                    snprintf(key, sizeof key, "base_stiffness");
                return dm_fail(st->err, DM_EINVAL,
                               "%s:%d: [effects] %s: chain %d has no spring along %c; "
                               "a compliant base needs kX, kY, kZ > 0 (or all 0: rigid)",
                               st->source, line, key, i, "XYZ"[k]);
            }
    return DM_OK;
}

static int check_required(parse_state *st)
{
    for (size_t i = 0; i < NKEYS; i++)
        if (KEYS[i].required && !st->key_line[i])
            return dm_fail(st->err, DM_EINVAL, "%s: [%s] %s: required key missing (%s)",
                           st->source, KEYS[i].section, KEYS[i].key,
                           *KEYS[i].unit ? KEYS[i].unit : "see docs/robot-file.md");
    return DM_OK;
}

/* Derived defaults and whole-robot checks, once every key is read. */
static int finish_robot(parse_state *st)
{
    dm_robot *rb = st->robot;
    int rc = check_required(st);
    if (rc)
        return rc;
    if (finish_member(st, "arm", &rb->arm, st->poisson[0]) ||
        finish_member(st, "rod", &rb->rod, st->poisson[1]) || check_effects(st))
        return DM_EINVAL;
    double offset = fabs(rb->base_radius_m - rb->platform_radius_m);
    if (offset >= rb->arm_length_m + rb->rod_length_m)
        return dm_fail(st->err, DM_EINVAL,
                       "%s:%d: [geometry] rod_length: the robot can reach nothing: "
                       "arm_length + rod_length (%g m) must exceed |base_radius - "
                       "platform_radius| (%g m)",
                       st->source, line_of(st, "geometry", "rod_length"),
                       rb->arm_length_m + rb->rod_length_m, offset);
    if (!line_of(st, "platform", "inertia")) {
        double r = rb->platform_radius_m, m = rb->platform_mass_kg;
        rb->platform_inertia_kgm2[0] = m * r * r / 4; /* thin disc */
        rb->platform_inertia_kgm2[1] = m * r * r / 4;
        rb->platform_inertia_kgm2[2] = m * r * r / 2;
    }
    if (!line_of(st, "workspace", "home")) {
        /* On the axis, below the base, where |Q|^2 = la^2 + lb^2. */
        double la = rb->arm_length_m, lb = rb->rod_length_m;
        double z2 = la * la + lb * lb - offset * offset;
        rb->home_m[2] = -sqrt(z2 > 0 ? z2 : 0.25 * (la + lb) * (la + lb));
    }
    if (!rb->name[0])
        snprintf(rb->name, DM_NAME_LEN, "unnamed");
    return DM_OK;
}

int dm_robot_parse_string(const char *text, const char *source, dm_robot *robot,
                          dm_error *err)
{
    dm_error local;
    if (!err)
        err = &local;
    dm_error_clear(err);
    set_defaults(robot);
    snprintf(robot->source, DM_SOURCE_LEN, "%s", source);
    parse_state st = {.robot = robot, .source = source, .err = err};
    line_reader rd = {.pos = text, .st = &st};
    int bad_line = ini_parse_stream(read_line, &rd, handler, &st);
    if (err->code)
        return err->code;
    if (bad_line)
        return dm_fail(err, DM_EINVAL, "%s:%d: not an INI line (expected [section] or key = value)",
                       source, bad_line);
    return finish_robot(&st);
}

int dm_robot_parse_file(const char *path, dm_robot *robot, dm_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return dm_fail(err, DM_EIO, "%s: cannot open robot file: %s", path, strerror(errno));
    char *text = NULL;
    size_t len = 0, cap = 0, got;
    char chunk[4096];
    while ((got = fread(chunk, 1, sizeof chunk, f)) > 0) {
        if (len + got + 1 > cap) {
            cap = 2 * (len + got + 1);
            char *grown = realloc(text, cap);
            if (!grown) {
                free(text);
                fclose(f);
                return dm_fail(err, DM_ENOMEM, "%s: out of memory reading robot file", path);
            }
            text = grown;
        }
        memcpy(text + len, chunk, got);
        len += got;
    }
    int read_failed = ferror(f);
    fclose(f);
    if (read_failed) {
        free(text);
        return dm_fail(err, DM_EIO, "%s: read error", path);
    }
    if (memchr(text ? text : "", '\0', len)) {
        free(text);
        return dm_fail(err, DM_EINVAL, "%s: not a text file (contains NUL bytes)", path);
    }
    int rc = dm_robot_parse_string(text ? (text[len] = '\0', text) : "", path, robot, err);
    free(text);
    return rc;
}

/* ---- presets -------------------------------------------------------------- */

/* Generated at build time from robots/NAME.ini (see Makefile): the shipped
 * example files are the single source of the presets. */
extern const char *const dm_preset_names_table[];
extern const char *const dm_preset_texts_table[];

const char *const *dm_robot_preset_names(void) { return dm_preset_names_table; }

int dm_robot_load(const char *spec, dm_robot *robot, dm_error *err)
{
    for (int i = 0; dm_preset_names_table[i]; i++) {
        if (strcmp(spec, dm_preset_names_table[i]))
            continue;
        char source[DM_SOURCE_LEN];
        snprintf(source, sizeof source, "robots/%s.ini (built-in preset)", spec);
        return dm_robot_parse_string(dm_preset_texts_table[i], source, robot, err);
    }
    if (!strchr(spec, '/') && !strchr(spec, '.')) {
        FILE *probe = fopen(spec, "r");
        if (!probe) {
            char names[256] = "";
            for (int i = 0; dm_preset_names_table[i]; i++)
                snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s",
                         i ? ", " : "", dm_preset_names_table[i]);
            return dm_fail(err, DM_EINVAL, "'%s' is neither a preset (%s) nor a robot file",
                           spec, names);
        }
        fclose(probe);
    }
    return dm_robot_parse_file(spec, robot, err);
}

/* ---- sections ------------------------------------------------------------ */

static void rect_section(double b, double h, dm_section *s)
{
    double lo = b < h ? b : h, hi = b < h ? h : b, q = lo / hi;
    s->area_m2 = b * h;
    s->iy_m4 = b * h * h * h / 12.0;
    s->iz_m4 = h * b * b * b / 12.0;
    s->ip_m4 = s->iy_m4 + s->iz_m4;
    s->j_m4 = hi * lo * lo * lo * (1.0 / 3.0 - 0.21 * q * (1.0 - q * q * q * q / 12.0));
}

static void tube_section(double D, double d, dm_section *s)
{
    double D2 = D * D, d2 = d * d;
    s->area_m2 = M_PI * (D2 - d2) / 4.0;
    s->iy_m4 = s->iz_m4 = M_PI * (D2 * D2 - d2 * d2) / 64.0;
    s->ip_m4 = s->j_m4 = s->iy_m4 + s->iz_m4;
}

int dm_section_compute(const dm_member *m, dm_section *out, dm_error *err)
{
    switch (m->shape) {
    case DM_SECTION_RECT: rect_section(m->b_m, m->h_m, out); break;
    case DM_SECTION_SQUARE: rect_section(m->diameter_m, m->diameter_m, out); break;
    case DM_SECTION_CIRCLE: tube_section(m->diameter_m, 0.0, out); break;
    case DM_SECTION_TUBE: tube_section(m->diameter_m, m->inner_diameter_m, out); break;
    default: return dm_fail(err, DM_EINVAL, "unknown section shape %d", (int)m->shape);
    }
    if (!(out->area_m2 > 0 && out->iy_m4 > 0 && out->iz_m4 > 0 && out->j_m4 > 0))
        return dm_fail(err, DM_EINVAL, "section has no area or stiffness");
    return DM_OK;
}

/* ---- writing ------------------------------------------------------------- */

/* Degrees that the parser (v * (M_PI / 180.0)) turns back into exactly
 * these radians: rad * 180 / pi may miss by an ulp, which every write and
 * read would add (and dm_robot_set writes and reads). The nearest such
 * double, if one lies within 16 ulps (every parsed value has one). */
static double degrees_of(double rad)
{
    double d = rad * 180.0 / M_PI, lo = d, hi = d;
    for (int i = 0; i < 16 && d * (M_PI / 180.0) != rad; i++) {
        lo = nextafter(lo, -INFINITY);
        hi = nextafter(hi, INFINITY);
        if (lo * (M_PI / 180.0) == rad)
            return lo;
        if (hi * (M_PI / 180.0) == rad)
            return hi;
    }
    return d;
}

static void write_member(FILE *out, const char *sec, const dm_member *m)
{
    static const char *const shapes[] = {"rect", "square", "circle", "tube"};
    fprintf(out, "\n[%s]\nshape = %s\n", sec, shapes[m->shape]);
    switch (m->shape) {
    case DM_SECTION_RECT:
        fprintf(out, "width = %.17g\nheight = %.17g\n", m->b_m, m->h_m);
        break;
    case DM_SECTION_SQUARE: fprintf(out, "side = %.17g\n", m->diameter_m); break;
    case DM_SECTION_CIRCLE: fprintf(out, "diameter = %.17g\n", m->diameter_m); break;
    case DM_SECTION_TUBE:
        fprintf(out, "diameter = %.17g\ninner_diameter = %.17g\n", m->diameter_m,
                m->inner_diameter_m);
        break;
    }
    fprintf(out, "youngs_modulus = %.17g\nshear_modulus = %.17g\ndensity = %.17g\n",
            m->youngs_pa, m->shear_pa, m->density_kgm3);
}

static void write_effects(FILE *out, const dm_effects *e)
{
    fprintf(out, "\n[effects]\n");
    if (e->actuator_stiffness_nm_per_rad > 0)
        fprintf(out, "actuator_stiffness = %.17g\n", e->actuator_stiffness_nm_per_rad);
    if (e->joint_stiffness_n_per_m > 0)
        fprintf(out, "joint_stiffness = %.17g\n", e->joint_stiffness_n_per_m);
    if (e->payload_kg > 0) {
        const double *o = e->payload_offset_m;
        fprintf(out, "payload_mass = %.17g\npayload_offset = %.17g, %.17g, %.17g\n", e->payload_kg,
                o[0], o[1], o[2]);
    }
    if (e->elbow_mass_kg > 0)
        fprintf(out, "elbow_mass = %.17g\n", e->elbow_mass_kg);
    for (int i = 0; i < 3; i++) {
        const double *k = e->base_stiffness_n_per_m[i];
        if (dm_effects_base_compliant(e, i))
            fprintf(out, "base_stiffness_%d = %.17g, %.17g, %.17g\n", i, k[0], k[1], k[2]);
    }
    fprintf(out, "geometric_stiffness = %s\n", e->geometric_stiffness ? "on" : "off");
    if (e->clearance_m > 0)
        fprintf(out, "clearance = %.17g\n", e->clearance_m);
    if (e->actuator_clearance_axial_m > 0)
        fprintf(out, "actuator_clearance_axial = %.17g\n", e->actuator_clearance_axial_m);
    if (e->actuator_clearance_radial_m > 0)
        fprintf(out, "actuator_clearance_radial = %.17g\n", e->actuator_clearance_radial_m);
    const struct {
        const char *key;
        const double *v;
        int degrees;
    } errs[] = {{"error_arm_length", e->err_arm_length_m, 0},
                {"error_rod_length", e->err_rod_length_m, 0},
                {"error_base_radius", e->err_base_radius_m, 0},
                {"error_platform_radius", e->err_platform_radius_m, 0},
                {"error_theta_deg", e->err_theta_rad, 1},
                {"error_alpha0_deg", e->err_alpha0_rad, 1}};
    for (int k = 0; k < 6; k++) {
        double v[3];
        for (int i = 0; i < 3; i++)
            v[i] = errs[k].degrees ? degrees_of(errs[k].v[i]) : errs[k].v[i];
        if (v[0] || v[1] || v[2])
            fprintf(out, "%s = %.17g, %.17g, %.17g\n", errs[k].key, v[0], v[1], v[2]);
    }
}

int dm_robot_write(const dm_robot *rb, FILE *out)
{
    fprintf(out, "[robot]\nname = %s\n", rb->name);
    fprintf(out, "\n[geometry]\nbase_radius = %.17g\nplatform_radius = %.17g\n"
                 "arm_length = %.17g\nrod_length = %.17g\nrod_half_spacing = %.17g\n"
                 "theta0_deg = %.17g\nelbow = %s\n",
            rb->base_radius_m, rb->platform_radius_m, rb->arm_length_m, rb->rod_length_m,
            rb->rod_half_spacing_m, degrees_of(rb->theta0_rad), rb->elbow_in ? "in" : "out");
    write_member(out, "arm", &rb->arm);
    write_member(out, "rod", &rb->rod);
    const double *J = rb->platform_inertia_kgm2, *g = rb->gravity_ms2, *h = rb->home_m;
    fprintf(out, "\n[platform]\nmass = %.17g\ninertia = %.17g, %.17g, %.17g\n",
            rb->platform_mass_kg, J[0], J[1], J[2]);
    fprintf(out, "\n[environment]\ngravity = %.17g, %.17g, %.17g\n", g[0], g[1], g[2]);
    fprintf(out, "\n[damping]\nalpha = %.17g\nbeta = %.17g\n", rb->rayleigh_alpha,
            rb->rayleigh_beta);
    fprintf(out, "\n[mesh]\nna = %d\nnb = %d\n", rb->na, rb->nb);
    fprintf(out, "\n[workspace]\nhome = %.17g, %.17g, %.17g\nsingular_condition = %.17g\n",
            h[0], h[1], h[2], rb->singular_cond);
    write_effects(out, &rb->effects);
    return ferror(out) ? DM_EIO : DM_OK;
}

/* ---- overrides ------------------------------------------------------------ */

/* Rewrite the robot's INI text with `key = value` in [section] (replacing
 * the key if present, else adding it) and parse the result, so an override
 * is validated exactly like a file. */
static int edit_text(const char *text, const char *section, const char *key, const char *value,
                     char **out)
{
    size_t cap = strlen(text) + strlen(section) + strlen(key) + strlen(value) + 64;
    char *res = malloc(cap), cur[64] = "";
    if (!res)
        return DM_ENOMEM;
    res[0] = '\0';
    int placed = 0, drop_g = !strcmp(key, "poisson_ratio"), drop_nu = !strcmp(key, "shear_modulus");
    for (const char *p = text; *p;) {
        const char *nl = strchr(p, '\n');
        size_t len = nl ? (size_t)(nl - p + 1) : strlen(p);
        char line[512];
        snprintf(line, sizeof line, "%.*s", (int)(len < 511 ? len : 511), p);
        if (line[0] == '[') {
            if (!placed && !strcmp(cur, section)) {
                sprintf(res + strlen(res), "%s = %s\n", key, value);
                placed = 1;
            }
            sscanf(line, "[%63[^]]", cur);
        }
        size_t kl = strcspn(line, " =");
        int in_sec = !strcmp(cur, section);
        int same = in_sec && kl == strlen(key) && !strncmp(line, key, kl);
        int dropped = in_sec && ((drop_g && !strncmp(line, "shear_modulus", 13)) ||
                                 (drop_nu && !strncmp(line, "poisson_ratio", 13)));
        if (same && !placed) {
            sprintf(res + strlen(res), "%s = %s\n", key, value);
            placed = 1;
        } else if (!same && !dropped) {
            strncat(res, p, len);
        }
        p += len;
    }
    if (!placed)
        sprintf(res + strlen(res), "%s[%s]\n%s = %s\n", strcmp(cur, section) ? "\n" : "", section,
                key, value);
    *out = res;
    return DM_OK;
}

int dm_robot_set(dm_robot *robot, const char *assignment, dm_error *err)
{
    char section[64], key[64], value[256];
    if (sscanf(assignment, "%63[^.=].%63[^=]=%255s", section, key, value) != 3)
        return dm_fail(err, DM_EINVAL, "'%s' is not SECTION.KEY=VALUE (e.g. arm.side=0.025)",
                       assignment);
    char *text = NULL, *edited = NULL;
    size_t len = 0;
    FILE *mem = open_memstream(&text, &len);
    if (!mem)
        return dm_fail(err, DM_ENOMEM, "out of memory");
    dm_robot_write(robot, mem);
    if (fclose(mem) || !text) {
        free(text);
        return dm_fail(err, DM_ENOMEM, "out of memory");
    }
    int rc = edit_text(text, section, key, value, &edited);
    free(text);
    if (rc)
        return dm_fail(err, rc, "out of memory");
    char source[DM_SOURCE_LEN];
    snprintf(source, sizeof source, "%.400s with %.100s", robot->source, assignment);
    dm_robot changed;
    rc = dm_robot_parse_string(edited, source, &changed, err);
    free(edited);
    if (!rc) {
        snprintf(changed.source, DM_SOURCE_LEN, "%s", robot->source);
        *robot = changed;
    }
    return rc;
}

/* ---- typed values -------------------------------------------------------------- */

static const key_spec *find_key(const char *section, const char *key)
{
    for (size_t i = 0; i < NKEYS; i++)
        if (!strcmp(KEYS[i].section, section) && !strcmp(KEYS[i].key, key))
            return &KEYS[i];
    return NULL;
}

/* Keys whose value no derived value depends on: set in place. */
static int settable(const key_spec *ks)
{
    return !strcmp(ks->section, "effects") || !strcmp(ks->section, "damping");
}

/* What the robot file's reader requires of the key's numbers. */
static const char *value_problem(const key_spec *ks, const double *v, int n)
{
    for (int i = 0; i < n; i++) {
        if (!isfinite(v[i]) || (v[i] != 0 && fabs(v[i]) < DBL_MIN))
            return "not a number in range";
        if (ks->kind == KEY_POSITIVE && !(v[i] > 0))
            return "must be > 0";
        if ((ks->kind == KEY_NONNEG || ks->kind == KEY_VEC3_NONNEG) && v[i] < 0)
            return "must be >= 0";
        if (ks->kind == KEY_ONOFF && v[i] != 0 && v[i] != 1)
            return "must be 0 (off) or 1 (on)";
    }
    return NULL;
}

int dm_robot_set_number(dm_robot *robot, const char *section, const char *key, const double *v,
                        dm_error *err)
{
    const key_spec *ks = find_key(section, key);
    if (!ks && !strcmp(section, "effects"))
        return dm_fail(err, DM_EINVAL, "%s: [effects] %s: %s", robot->source, key, NOT_AN_EFFECT);
    if (!ks)
        return dm_fail(err, DM_EINVAL, "%s: [%s] %s: no such key of a robot file",
                       robot->source, section, key);
    if (!settable(ks))
        return dm_fail(err, DM_EINVAL,
                       "[%s] %s: other values derive from it; change it with dm_robot_set",
                       section, key);
    int n = is_vec3(ks->kind) ? 3 : 1;
    const char *problem = value_problem(ks, v, n);
    if (problem)
        return dm_fail(err, DM_EINVAL, "%s: [%s] %s: %s, got %.17g", robot->source, section,
                       key, problem, v[0]);
    dm_robot changed = *robot; /* a copy, unchanged on error */
    double scale = ks->kind == KEY_VEC3_DEG || ks->kind == KEY_DEGREES ? M_PI / 180.0 : 1.0;
    assert(ks->offset + n * sizeof(double) <= sizeof changed);
    char *dst = (char *)&changed + ks->offset;
    if (!strcmp(key, "base_stiffness")) /* the global value: every chain's */
        for (int i = 0; i < 3; i++)
            memcpy(changed.effects.base_stiffness_n_per_m[i], v, sizeof(double) * 3);
    else if (ks->kind == KEY_ONOFF)
        *(int *)dst = v[0] != 0;
    else
        for (int i = 0; i < n; i++)
            ((double *)dst)[i] = v[i] * scale;
    /* as the reader: a chain's base springs on all three axes or none */
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3 && dm_effects_base_compliant(&changed.effects, i); k++)
            if (!(changed.effects.base_stiffness_n_per_m[i][k] > 0))
                return dm_fail(err, DM_EINVAL,
                               "%s: [effects] %s: chain %d has no spring along %c; a "
                               "compliant base needs kX, kY, kZ > 0 (or all 0: rigid)",
                               robot->source, key, i, "XYZ"[k]);
    *robot = changed;
    return DM_OK;
}
