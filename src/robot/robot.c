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

/* The kinds an effect's key takes are the effect table's (dm_effects.h). */
typedef enum {
    KEY_POSITIVE = DM_EFFECTS_POSITIVE,       /* double > 0 */
    KEY_NONNEG = DM_EFFECTS_NONNEG,           /* double >= 0 */
    KEY_ONOFF = DM_EFFECTS_ONOFF,             /* on | off */
    KEY_VEC3 = DM_EFFECTS_VEC3,               /* three finite doubles "a, b, c" */
    KEY_VEC3_NONNEG = DM_EFFECTS_VEC3_NONNEG, /* three doubles >= 0 */
    KEY_VEC3_DEG = DM_EFFECTS_VEC3_DEG,       /* three doubles in degrees, stored in radians */
    KEY_REAL = DM_EFFECTS_NO_KEY + 1,         /* any finite double */
    KEY_DEGREES,    /* finite double in degrees, stored in radians */
    KEY_COUNT,      /* integer >= 1 */
    KEY_SHAPE,      /* rect | square | circle | tube */
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
    {"mesh", "na", KEY_COUNT, R_OFF(na), 0, ""},
    {"mesh", "nb", KEY_COUNT, R_OFF(nb), 0, ""},
    {"workspace", "home", KEY_VEC3, R_OFF(home_m), 0, "m"},
    {"workspace", "singular_condition", KEY_POSITIVE, R_OFF(singular_cond), 0, ""},
};
#define NKEYS (sizeof KEYS / sizeof KEYS[0])
/* Every key of the file: KEYS, then the effect table's rows (those with a
 * key: [effects] and [damping]). */
#define NALL (NKEYS + DM_EFFECTS_MAXROWS)

/* Key i of NALL into *ks; 0 when i is no key (a row without one, or past
 * the table's end). */
static int key_at(size_t i, key_spec *ks)
{
    if (i < NKEYS) {
        *ks = KEYS[i];
        return 1;
    }
    int n;
    const dm_effect *tab = dm_effects_table(&n);
    if (i - NKEYS >= (size_t)n || !tab[i - NKEYS].section)
        return 0;
    const dm_effect *e = &tab[i - NKEYS];
    *ks = (key_spec){e->section, e->key, (key_kind)e->value, e->offset, 0, e->unit};
    return 1;
}

/* Is it the key whose value every chain gets (base_stiffness)? */
static int every_chain(const key_spec *ks)
{
    const dm_effect *e = dm_effects_find_key(ks->section, ks->key);
    return e && e->scope == DM_EFFECTS_ALL_CHAINS;
}

/* What an unknown [effects] key is told: "not a model extension (...)". */
static void not_an_effect(char *buf, size_t n)
{
    char keys[600];
    dm_effects_key_list(keys, sizeof keys);
    snprintf(buf, n, "not a model extension (%s)", keys);
}

/* Sections whose unknown keys get a more specific message. */
static const char *const RESERVED_SECTIONS[] = {"effects", NULL};

typedef struct {
    dm_robot *robot;
    const char *source;
    int line;              /* line being parsed (counted by our reader) */
    int key_line[NALL];    /* line where each key was set, 0 = absent */
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
    char what[768];
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

/* The numbers a numeric key's text holds, or what is wrong with its form
 * (the robot file's reader and dm_robot_set read values through this). */
static const char *text_numbers(const key_spec *ks, const char *text, double v[3])
{
    if (ks->kind == KEY_ONOFF) {
        if (strcmp(text, "on") && strcmp(text, "off"))
            return "is not on or off";
        v[0] = !strcmp(text, "on");
        return NULL;
    }
    if (is_vec3(ks->kind))
        return parse_vec3(text, v) ? "is not three numbers 'a, b, c'" : NULL;
    return parse_double(text, v) ? "is not a number in range" : NULL;
}

/* What the robot file requires of a numeric key's numbers: the one check
 * of the reader and both setters. */
static const char *value_problem(const key_spec *ks, const double *v, int n, int *bad)
{
    for (int i = 0; i < n; i++) {
        *bad = i;
        if (!isfinite(v[i]) || (v[i] != 0 && fabs(v[i]) < DBL_MIN))
            return "not a number in range";
        if (ks->kind == KEY_POSITIVE && !(v[i] > 0))
            return "must be > 0";
        if (ks->kind == KEY_NONNEG && v[i] < 0)
            return "must be >= 0";
        if (ks->kind == KEY_VEC3_NONNEG && v[i] < 0)
            return "has a negative component";
        if (ks->kind == KEY_ONOFF && v[i] != 0 && v[i] != 1)
            return "must be 0 (off) or 1 (on)";
    }
    return NULL;
}

/* Store a numeric key's checked numbers (degrees as radians, on/off as an int). */
static void put_numbers(dm_robot *rb, const key_spec *ks, const double *v, int n)
{
    assert(ks->offset + (size_t)n * sizeof(double) <= sizeof *rb);
    char *dst = (char *)rb + ks->offset;
    double scale = ks->kind == KEY_VEC3_DEG || ks->kind == KEY_DEGREES ? M_PI / 180.0 : 1.0;
    if (ks->kind == KEY_ONOFF)
        *(int *)dst = v[0] != 0;
    else
        for (int i = 0; i < n; i++)
            ((double *)dst)[i] = v[i] * scale;
}

/* The keys that are not numbers. */
static int store_word(parse_state *st, const key_spec *ks, const char *value)
{
    char *dst = (char *)st->robot + ks->offset;
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
    case KEY_ELBOW:
        if (strcmp(value, "out") && strcmp(value, "in"))
            return key_error(st, st->line, ks->section, ks->key,
                             "'%s' is not an elbow branch (out, in)", value);
        *(int *)dst = !strcmp(value, "in");
        return 1;
    default: { /* KEY_COUNT */
        assert(ks->kind == KEY_COUNT);
        char *end;
        long n = strtol(value, &end, 10);
        if (end == value || *end || n < 1 || n > 64)
            return key_error(st, st->line, ks->section, ks->key,
                             "'%s' is not a whole number from 1 to 64", value);
        *(int *)dst = (int)n;
        return 1;
    }
    }
}

static int store_value(parse_state *st, const key_spec *ks, const char *value)
{
    if (ks->kind >= KEY_COUNT)
        return store_word(st, ks, value);
    double v[3];
    int n = is_vec3(ks->kind) ? 3 : 1;
    const char *problem = text_numbers(ks, value, v);
    if (problem)
        return key_error(st, st->line, ks->section, ks->key, "'%s' %s", value, problem);
    int bad;
    if ((problem = value_problem(ks, v, n, &bad)))
        return key_error(st, st->line, ks->section, ks->key, "%s, got %s", problem, value);
    if (!strcmp(ks->key, "poisson_ratio")) {
        if (!(v[0] > -1.0 && v[0] < 0.5))
            return key_error(st, st->line, ks->section, ks->key,
                             "must lie in (-1, 0.5), got %s", value);
        st->poisson[!strcmp(ks->section, "rod")] = v[0];
        return 1;
    }
    if (every_chain(ks)) /* given to the chains without their own once all is read */
        memcpy(st->base_global, v, sizeof st->base_global);
    else
        put_numbers(st->robot, ks, v, n);
    return 1;
}

static int handler(void *user, const char *section, const char *name, const char *value)
{
    parse_state *st = user;
    if (st->err && st->err->code)
        return 0; /* report only the first error */
    key_spec ks;
    for (size_t i = 0; i < NALL; i++) {
        if (!key_at(i, &ks) || strcmp(ks.section, section) || strcmp(ks.key, name))
            continue;
        if (st->key_line[i])
            return key_error(st, st->line, section, name,
                             "given twice (first on line %d)", st->key_line[i]);
        st->key_line[i] = st->line;
        return store_value(st, &ks, value);
    }
    char why[700];
    not_an_effect(why, sizeof why);
    for (int r = 0; RESERVED_SECTIONS[r]; r++)
        if (!strcmp(section, RESERVED_SECTIONS[r]))
            return key_error(st, st->line, section, name, "%s", why);
    int known_section = 0;
    for (size_t i = 0; i < NALL; i++)
        known_section |= key_at(i, &ks) && !strcmp(ks.section, section);
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
    key_spec ks;
    for (size_t i = 0; i < NALL; i++)
        if (key_at(i, &ks) && !strcmp(ks.section, section) && !strcmp(ks.key, key))
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
    for (size_t i = 0; i < NKEYS; i++) /* the effect table's keys are never required */
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

/* [effects] from the effect table, in its order, each key when its row
 * says (dm_effects_write). */
static void write_effects(FILE *out, const dm_robot *rb)
{
    int n;
    const dm_effect *tab = dm_effects_table(&n);
    fprintf(out, "\n[effects]\n");
    for (int i = 0; i < n; i++) {
        const dm_effect *e = &tab[i];
        if (!e->section || strcmp(e->section, "effects") || e->write == DM_EFFECTS_WRITE_NEVER)
            continue;
        int set = dm_effects_is_set(&rb->effects, e);
        if (e->write == DM_EFFECTS_WRITE_WITH_PREVIOUS && i > 0)
            set |= dm_effects_is_set(&rb->effects, &tab[i - 1]);
        if (!set && e->write != DM_EFFECTS_WRITE_ALWAYS)
            continue;
        const char *at = (const char *)rb + e->offset;
        if (e->value == DM_EFFECTS_ONOFF) {
            fprintf(out, "%s = %s\n", e->key, *(const int *)(const void *)at ? "on" : "off");
            continue;
        }
        const double *v = (const double *)(const void *)at;
        fprintf(out, "%s = ", e->key);
        for (int k = 0; k < (e->value >= DM_EFFECTS_VEC3 ? 3 : 1); k++)
            fprintf(out, "%s%.17g", k ? ", " : "",
                    e->value == DM_EFFECTS_VEC3_DEG ? degrees_of(v[k]) : v[k]);
        fprintf(out, "\n");
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
    write_effects(out, rb);
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

/* Keys whose value no derived value depends on: set in place, typed. */
static int settable(const key_spec *ks)
{
    return !strcmp(ks->section, "effects") || !strcmp(ks->section, "damping");
}

/* A settable key's text, read as the file's reader reads it, set by the
 * typed setter: one path, one check, for both setters. */
static int set_from_text(dm_robot *robot, const key_spec *ks, const char *assignment,
                         const char *value, dm_error *err)
{
    double v[3];
    const char *problem = text_numbers(ks, value, v);
    if (problem)
        return dm_fail(err, DM_EINVAL, "%s with %s: [%s] %s: '%s' %s", robot->source, assignment,
                       ks->section, ks->key, value, problem);
    return dm_robot_set_number(robot, ks->section, ks->key, v, err);
}

int dm_robot_set(dm_robot *robot, const char *assignment, dm_error *err)
{
    char section[64], key[64], value[256];
    if (sscanf(assignment, "%63[^.=].%63[^=]=%255s", section, key, value) != 3)
        return dm_fail(err, DM_EINVAL, "'%s' is not SECTION.KEY=VALUE (e.g. arm.side=0.025)",
                       assignment);
    key_spec ks;
    int i = key_index(section, key);
    if (i >= 0 && key_at((size_t)i, &ks) && settable(&ks))
        return set_from_text(robot, &ks, assignment, value, err);
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

/* As the reader: a chain's base springs on all three axes or none. */
static int check_base_springs(const dm_robot *rb, const char *key, dm_error *err)
{
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3 && dm_effects_base_compliant(&rb->effects, i); k++)
            if (!(rb->effects.base_stiffness_n_per_m[i][k] > 0))
                return dm_fail(err, DM_EINVAL,
                               "%s: [effects] %s: chain %d has no spring along %c; a "
                               "compliant base needs kX, kY, kZ > 0 (or all 0: rigid)",
                               rb->source, key, i, "XYZ"[k]);
    return DM_OK;
}

int dm_robot_set_number(dm_robot *robot, const char *section, const char *key, const double *v,
                        dm_error *err)
{
    key_spec ks;
    int i = key_index(section, key);
    if (i < 0 && !strcmp(section, "effects")) {
        char why[700];
        not_an_effect(why, sizeof why);
        return dm_fail(err, DM_EINVAL, "%s: [effects] %s: %s", robot->source, key, why);
    }
    if (i < 0 || !key_at((size_t)i, &ks))
        return dm_fail(err, DM_EINVAL, "%s: [%s] %s: no such key of a robot file",
                       robot->source, section, key);
    if (!settable(&ks))
        return dm_fail(err, DM_EINVAL,
                       "[%s] %s: other values derive from it; change it with dm_robot_set",
                       section, key);
    int n = is_vec3(ks.kind) ? 3 : 1;
    int bad;
    const char *problem = value_problem(&ks, v, n, &bad);
    if (problem)
        return dm_fail(err, DM_EINVAL, "%s: [%s] %s: %s, got %.17g", robot->source, section,
                       key, problem, v[bad]);
    dm_robot changed = *robot; /* a copy, unchanged on error */
    if (every_chain(&ks)) /* base_stiffness: every chain's (the rule in dm_effects.h) */
        for (int c = 0; c < 3; c++)
            memcpy(changed.effects.base_stiffness_n_per_m[c], v, sizeof(double) * 3);
    else
        put_numbers(&changed, &ks, v, n);
    int rc = check_base_springs(&changed, key, err);
    if (!rc)
        *robot = changed;
    return rc;
}
