/* dm_robot — the description of a Delta robot (docs/model.md §1, §2, §6, §7).
 *
 * A robot comes from an INI file parsed with libinih, or from a built-in
 * preset (chen2018, zheng2017, han2011) whose text is the same INI format
 * shipped in robots/. All values are SI (m, kg, Pa, N/m, N*m/rad);
 * angles in files are degrees, stored here in radians.
 *
 * A dm_robot is a plain value: after loading it is read-only and may be
 * shared between threads. */
#ifndef DM_ROBOT_H
#define DM_ROBOT_H

#include <stdio.h>

#include "dm_effects.h"
#include "dm_error.h"

typedef enum {
    DM_SECTION_RECT = 0,   /* b along local y, h along local z */
    DM_SECTION_SQUARE,     /* side a */
    DM_SECTION_CIRCLE,     /* diameter D */
    DM_SECTION_TUBE        /* outer D, inner d */
} dm_section_shape;

/* Geometric properties of a cross-section (m^2, m^4). */
typedef struct dm_section {
    double area_m2;
    double iy_m4;   /* second moment about local y (bending in x-z) */
    double iz_m4;   /* second moment about local z (bending in x-y) */
    double ip_m4;   /* polar moment Iy + Iz (torsional inertia) */
    double j_m4;    /* torsion constant (torsional stiffness) */
} dm_section;

/* One straight member type (the arms or the rods): shape, dimensions,
 * material, and the derived section. */
typedef struct dm_member {
    dm_section_shape shape;
    double b_m, h_m;          /* rect width (local y) and height (local z) */
    double diameter_m;        /* circle / tube outer diameter, square side */
    double inner_diameter_m;  /* tube */
    double youngs_pa;
    double shear_pa;
    double density_kgm3;
    dm_section section;       /* derived by dm_robot_finish */
} dm_member;

#define DM_NAME_LEN 64
#define DM_SOURCE_LEN 512

typedef struct dm_robot {
    char name[DM_NAME_LEN];
    char source[DM_SOURCE_LEN];     /* file path or "preset:NAME" */

    /* [geometry] */
    double base_radius_m;           /* R */
    double platform_radius_m;       /* r */
    double arm_length_m;            /* la */
    double rod_length_m;            /* lb */
    double rod_half_spacing_m;      /* d */
    double theta0_rad;
    int elbow_in;                   /* 0 = elbow-out (default) */

    dm_member arm, rod;             /* [arm], [rod] */

    /* [platform] */
    double platform_mass_kg;
    double platform_inertia_kgm2[3];/* diag about P; default thin disc */

    double gravity_ms2[3];          /* [environment] */
    double rayleigh_alpha;          /* [damping] alpha (1/s) */
    double rayleigh_beta;           /* [damping] beta (s) */
    int na, nb;                     /* [mesh] elements per arm / rod */

    double home_m[3];               /* [workspace] centre pose */
    double singular_cond;           /* [workspace] near-singular threshold */

    dm_effects effects;             /* [effects] */
} dm_robot;

/* Names of the built-in presets, NULL-terminated. */
const char *const *dm_robot_preset_names(void);

/* Load a preset by name or, if `spec` is not a preset name, a robot file. */
int dm_robot_load(const char *spec, dm_robot *robot, dm_error *err);

/* Parse robot INI text; `source` names it in error messages. */
int dm_robot_parse_string(const char *text, const char *source,
                          dm_robot *robot, dm_error *err);
int dm_robot_parse_file(const char *path, dm_robot *robot, dm_error *err);

/* Write a robot as INI text that dm_robot_parse_* reads back exactly
 * (numbers with 17 significant digits). */
int dm_robot_write(const dm_robot *robot, FILE *out);

/* Change one value, "SECTION.KEY=VALUE" with the keys of the robot file
 * (e.g. "arm.side=0.025", "damping.beta=1e-4"), validated like a file;
 * derived values (sections, shear modulus) follow. A key of [effects] or
 * [damping] is read as the file's reader reads it and set by
 * dm_robot_set_number: the two setters agree, base_stiffness included
 * (dm_effects.h). On error the robot is unchanged and the message names
 * the assignment and key. */
int dm_robot_set(dm_robot *robot, const char *assignment, dm_error *err);

/* Set the numbers of one key of [effects] or [damping] in place, typed:
 * v holds 1 number (3 for a vector key; on/off keys take 0 or 1; degree
 * keys take degrees), validated as the robot file's reader would (one
 * validator serves the reader, this and dm_robot_set, which sets these
 * keys through this). The path of the fits' every evaluation: no text, no
 * allocation. Keys other values derive from (members, geometry, platform)
 * are refused: change them with dm_robot_set. base_stiffness sets every
 * chain (the rule in dm_effects.h). On error the robot is unchanged. */
int dm_robot_set_number(dm_robot *robot, const char *section, const char *key, const double *v,
                        dm_error *err);

/* Section properties of a member (docs/model.md §2). */
int dm_section_compute(const dm_member *member, dm_section *out, dm_error *err);

#endif
