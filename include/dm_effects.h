/* dm_effects — the model extensions (docs/model.md §6), declared once.
 *
 * One table row per effect: the robot-file key that holds it, where its
 * numbers sit in dm_robot, what the key takes, its unit, whether it is one
 * chain's, and what the diagnosis needs of it (search range, the data kinds
 * that can see it, scale, a typical magnitude). The robot file's [effects]
 * keys (reader, writer, the text and typed setters of dm_robot.h),
 * dm_effects_any, the diagnosis' candidates (dm_diagnose.h) and the effect
 * specs of plan and synth all derive from this table: an effect added here
 * is read, written, fingerprinted, set and fitted (tests/test_effects.c
 * walks the table and checks each of these).
 *
 * The rule for the compliant base, the one key with a global and per-chain
 * forms: in a robot file, `base_stiffness` is the value of every chain
 * without its own `base_stiffness_i` (the file is a declaration: key order
 * does not matter). An assignment — `--set effects.base_stiffness=…`,
 * dm_robot_set, dm_robot_set_number, dm_effects_apply — changes the robot
 * as it stands: `base_stiffness` sets all three chains (replacing any
 * per-chain values), `base_stiffness_i` sets chain i; of two assignments
 * the later wins where they overlap. */
#ifndef DM_EFFECTS_H
#define DM_EFFECTS_H

#include <stddef.h>

#include "dm_error.h"

struct dm_robot;

/* The robot's model extensions (docs/model.md §6); all off (zero) in the
 * baseline. Rayleigh damping is in dm_robot itself ([damping]). */
typedef struct dm_effects {
    double actuator_stiffness_nm_per_rad; /* 0 = clamped arm root */
    double joint_stiffness_n_per_m;       /* 0 = rigid rod-end joints */
    double payload_kg;
    double payload_offset_m[3];           /* platform axes */
    double elbow_mass_kg;                 /* at each elbow */
    double base_stiffness_n_per_m[3][3];  /* [chain][X,Y,Z]; 0 = rigid */
    int geometric_stiffness;              /* 0/1 */
    /* geometry errors per chain (Zheng table 1): the real robot differs from
     * the nominal one its controller assumes */
    double err_arm_length_m[3], err_rod_length_m[3];
    double err_base_radius_m[3], err_platform_radius_m[3];
    double err_theta_rad[3], err_alpha0_rad[3];
    double clearance_m;                   /* radial clearance of each rod-end ball joint */
    /* clearance of each actuator's revolute joint: the arm slides along its
     * axis (axial) and across it (radial) the way the joint is loaded */
    double actuator_clearance_axial_m, actuator_clearance_radial_m;
} dm_effects;

/* What a key takes (the robot file's reader and both setters check it). */
typedef enum {
    DM_EFFECTS_POSITIVE,    /* one number > 0 */
    DM_EFFECTS_NONNEG,      /* one number >= 0 */
    DM_EFFECTS_ONOFF,       /* on | off (typed: 1 | 0) */
    DM_EFFECTS_VEC3,        /* three finite numbers */
    DM_EFFECTS_VEC3_NONNEG, /* three numbers >= 0 */
    DM_EFFECTS_VEC3_DEG,    /* three numbers in degrees, stored in radians */
    DM_EFFECTS_NO_KEY       /* no key of its own (geometry_errors: six keys at once) */
} dm_effects_value;

/* Whose the effect is. */
typedef enum {
    DM_EFFECTS_ROBOT,      /* the robot's, or each joint's alike */
    DM_EFFECTS_EACH_CHAIN, /* three numbers, chain by chain (geometry errors) */
    DM_EFFECTS_ALL_CHAINS, /* one setting given to every chain (base_stiffness) */
    DM_EFFECTS_ONE_CHAIN   /* one chain's variant (base_stiffness_i): see chain */
} dm_effects_scope;

/* When the robot file's writer writes the key. */
typedef enum {
    DM_EFFECTS_WRITE_NONZERO,  /* when any of its numbers is not 0 */
    DM_EFFECTS_WRITE_ALWAYS,   /* always (geometric_stiffness = on|off) */
    DM_EFFECTS_WRITE_WITH_PREVIOUS, /* when it or the row before is not 0 (payload_offset) */
    DM_EFFECTS_WRITE_NEVER     /* never: other rows carry it (base_stiffness) */
} dm_effects_write;

/* Data kinds that can see an effect, one bit per dm_data_kind (dm_measure.h
 * checks that they agree). */
#define DM_EFFECTS_MODAL 1u
#define DM_EFFECTS_STATIC 2u
#define DM_EFFECTS_TRACKER 4u

#define DM_EFFECTS_MAXV 18 /* parameters of one effect (geometry_errors: 6 families x 3) */
#define DM_EFFECTS_MAXROWS 32

/* One effect. A diagnosis candidate when `kinds` is not 0. */
typedef struct dm_effect {
    const char *name;         /* as specs and the diagnosis name it */
    const char *section;      /* its robot-file key: [section] key; NULL: none */
    const char *key;
    size_t offset;            /* of the key's first number in dm_robot */
    dm_effects_value value;
    const char *unit;
    dm_effects_scope scope;
    int chain;                /* DM_EFFECTS_ONE_CHAIN: which */
    dm_effects_write write;
    double lo, hi;            /* log10 search range (lo == hi: a switch) */
    unsigned kinds;           /* DM_EFFECTS_* bits of the data that can see it; 0: no candidate */
    int nparam;               /* 0 (a switch), 1, 3 (one per chain) or 18 (geometry_errors) */
    int linear;               /* parameters fitted as they are (may be negative), from 0 */
    double scale;             /* linear: the size of an error worth knowing (unit); the
                                 data's power to see them is judged in these units */
    double typical;           /* a plausible magnitude (a spec's default) */
    const char *global;       /* a per-chain variant: the global effect it is one chain of */
} dm_effect;

/* The table, in the order the robot file's writer writes the keys. */
const dm_effect *dm_effects_table(int *count);

/* The effect of this name, or NULL. */
const dm_effect *dm_effects_find(const char *name);

/* The effect stored under robot-file key [section] key, or NULL. */
const dm_effect *dm_effects_find_key(const char *section, const char *key);

/* Family f (0..5) of the geometry errors (error_arm_length ...
 * error_alpha0_deg, in table order): the families of geometry_errors. */
const dm_effect *dm_effects_family(int f);

/* geometry_errors: the six families at once. */
const dm_effect *dm_effects_union(void);

/* "actuator_stiffness, joint_stiffness, ...": every [effects] key, for the
 * message an unknown one gets. */
void dm_effects_key_list(char *buf, size_t n);

/* Scale of parameter k of effect e in its fitted units (log10 for springs
 * and masses: 1/ln 10, i.e. relative; linear: e->scale, or the family's
 * for geometry_errors). */
double dm_effects_param_scale(const dm_effect *e, int k);

/* "error_base_radius[1]" for parameter k of e (chains 0..2), or e's name. */
void dm_effects_param_name(const dm_effect *e, int k, char *buf, size_t n);

/* Apply effect `name` with its parameters v[nparam] (ignored for switches)
 * to a robot, typed and in place (no text, no allocation): an effect of
 * one stiffness (base_stiffness*) gives it to all three axes; the rule of
 * base_stiffness against base_stiffness_i is the header's. Validated as
 * the robot file's reader would; on error the robot is unchanged. */
int dm_effects_apply(struct dm_robot *robot, const char *name, const double *v, dm_error *err);

/* Is the robot's [effects] row e set (any of its numbers not 0)? */
int dm_effects_is_set(const dm_effects *effects, const dm_effect *e);

/* Does the robot have any geometry error (then the real pose differs from
 * the commanded one)? */
int dm_effects_geometry_errors(const dm_effects *effects);

/* Has the robot any joint clearance (a dead band that flips with the load)? */
int dm_effects_clearance(const dm_effects *effects);

/* Is any effect switched on (else the robot is the baseline)? */
int dm_effects_any(const dm_effects *effects);

/* Does chain i sit on a compliant base (its arm root gets three
 * translations tied to ground by springs)? Chains without springs stay rigid. */
int dm_effects_base_compliant(const dm_effects *effects, int chain);

/* ---- effect specs: what plan --effects and synth --effect take ----------------
 *
 * A comma-separated list of effects, each NAME, NAME=V or NAME=V1,...,Vn
 * (n = the effect's nparam; one value stands for all n), a switch NAME or
 * NAME=on. Without a value an effect gets its typical magnitude. Springs
 * and masses (fitted in log10) take values > 0; every value is checked as
 * the robot file's reader checks the key. */
typedef struct dm_effects_spec {
    const dm_effect *effect;
    double value[DM_EFFECTS_MAXV];
} dm_effects_spec;

/* Parse `spec` into at most max effects (appended at out[*count]; *count
 * grows). On error *count is unchanged and the message quotes the spec. */
int dm_effects_parse_spec(const char *spec, dm_effects_spec *out, int max, int *count,
                          dm_error *err);

/* Parse `spec` and apply its effects to the robot (unchanged on error). */
int dm_effects_apply_spec(struct dm_robot *robot, const char *spec, dm_error *err);

#endif
