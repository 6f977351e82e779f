/* dm_plan — the experiment that can tell, designed before it is run.
 *
 * Given candidate effects of dm_diagnose at assumed magnitudes, pick the N
 * poses of a modal or static survey (or, for a tracker run, one path of a
 * small family of circles and moves) that make their parameters
 * identifiable: D-optimal, maximising log det F with F = J'J / sigma^2
 * the Fisher information and J the sensitivities of the predictions to
 * the parameters in scaled units (relative for springs, masses and
 * damping; the candidate's scale for geometry errors). The determinant is
 * the product of the information along each parameter and of the squared
 * sines of the angles between their sensitivity vectors, so it rewards
 * separating effects that look alike as well as seeing each.
 *
 * Candidates: poses drawn uniformly (seeded) from the reachable part of a
 * region with cond(J) <= the robot's singular_condition (default region:
 * the box `synth` draws from, home +- 0.3 la in x and y, +- 0.15 la in z),
 * or the points of a grid; for static surveys each with one of seven
 * force directions (x, y, z and four diagonals). Greedy selection, then
 * exchanges until no swap raises the determinant; distinct candidates;
 * deterministic for a seed and independent of the thread count. */
#ifndef DM_PLAN_H
#define DM_PLAN_H

#include <stdint.h>
#include <stdio.h>

#include "dm_diagnose.h"
#include "dm_measure.h"
#include "dm_nuisance.h"
#include "dm_progress.h"
#include "dm_robot.h"

#define DM_PLAN_MAXEFF 6

typedef struct dm_plan_effect {
    const dm_effect *cand;
    double value[DM_DIAG_MAXV]; /* the assumed magnitude (per chain for three parameters) */
} dm_plan_effect;

typedef struct dm_plan_opts {
    dm_data_kind kind;
    int npose;                  /* poses; tracker: samples at 1 ms */
    double noise;               /* Hz or m (0: 0.02 Hz, 50 nm, 2 um) */
    const char *region;         /* grid (dm_grid_parse) of candidate poses, or NULL */
    uint64_t seed;
    int na, nb;                 /* mesh (0: the robot's) */
    int modes;                  /* modal: ranks 1..modes (default 6) */
    double force_n;             /* static: magnitude of the added force (default 50 N) */
    int ncandidates;            /* poses drawn without a grid (default 256) */
    int threads;                /* 0: OpenMP's default; the result does not depend on it */
    int force_long;             /* run even when estimated beyond DM_WORK_LIMIT
                                   (else refused before the predictions) */
    /* tracker: the run as a lab records it (dm_nuisance.h), 0: none; 1: '# frame:'
     * (the frame, the reflector offset and the clock offset are fitted with
     * every model); 2: also the clock rate. The effects are then planned for
     * what the run determines beyond the nuisances: their information is the
     * Schur complement of the nuisances' block (the sensitivities projected
     * orthogonal to the nuisances' design), and dm_plan_result.confound says
     * which of an effect's combinations the nuisances take. */
    int nuisance;
    int frame_tracker;          /* with nuisance: the template says '# frame: tracker' */
    const char *path;           /* tracker: assess this path (a trajectory spec) instead of
                                   choosing one from the family; NULL: the family */
    /* progress (dm_progress.h), NULL: none. Stages: "sensitivities" (a
     * survey: its pose analyses, p + 1 per candidate pose; a tracker run:
     * its predictions, p + 1 per path of the family), a survey's "choosing
     * poses" (the greedy scans over the candidates, one per pose) and
     * "exchanging poses" (one stage per exchange pass, a scan per pose),
     * then "assessment" (predictions of the design: the baseline, p + 1
     * sensitivities and, per effect, up to 32 for its detectable
     * magnitude). */
    dm_progress_fn progress;
    void *progress_user;
} dm_plan_opts;

typedef struct dm_plan_pair {
    int a, b;                   /* effects */
    double angle_deg;           /* smallest angle between their sensitivity spans */
    double sigma;               /* 1-sigma of their least determined joint combination */
    int alike;                  /* that combination is not determined: they stay look-alikes */
} dm_plan_pair;

/* An effect against a tracker run's nuisances: its combination (unit
 * vector over its parameters, scaled units) that the nuisances leave least
 * determined, that combination's 1-sigma alone and beyond the nuisances,
 * and the nuisance combination that mimics it (coefficients on the
 * nuisances' design columns scaled to unit norm, the largest 1 in size). */
typedef struct dm_plan_confound {
    int effect;
    double combo[DM_DIAG_MAXV];
    double sigma_alone, sigma;  /* scaled units, as dm_plan_pair.sigma */
    double lost_percent;        /* of the combination's information taken by the nuisances */
    double like[DM_NUISANCE_MAX];
    int alike;                  /* not determined beyond the nuisances, though alone it is */
} dm_plan_confound;

typedef struct dm_plan_result {
    dm_dataset design;          /* the planned samples (values 0, sigma = noise) */
    char path[256];             /* tracker: the chosen path */
    int ncandidates;            /* candidate poses (or paths) that qualified */
    int neffect, nparam;
    dm_plan_effect effect[DM_PLAN_MAXEFF];
    double noise;
    double logdet, logdet_random;       /* planned; median over random designs */
    double sigma[DM_DIAG_MAXP];         /* expected 1-sigma per parameter, its unit */
    double sigma_random[DM_DIAG_MAXP];  /* the same for random candidates (median over draws) */
    /* per effect: the smallest magnitude the planned experiment sees at 5
     * sigma, alone against the robot file (springs: the largest stiffness;
     * geometry errors: the size along the assumed direction; damping: the
     * relative change; a switch: how many sigmas it moves the data) */
    double detect[DM_PLAN_MAXEFF];
    int npair;
    dm_plan_pair pair[DM_PLAN_MAXEFF * (DM_PLAN_MAXEFF - 1) / 2];
    int nnuisance;              /* tracker nuisances marginalised (0: none) */
    int nconfound;              /* per effect with parameters, when nnuisance */
    dm_plan_confound confound[DM_PLAN_MAXEFF];
} dm_plan_result;

/* Parse an effect spec, "NAME[=V[,V,V]],NAME..." (dm_effects_parse_spec:
 * values default to each effect's typical magnitude). Unknown names,
 * effects that are no diagnosis candidate and effects the kind of data
 * cannot see are errors. */
int dm_plan_parse_effects(const char *spec, dm_data_kind kind, dm_plan_effect *effects,
                          int *count, dm_error *err);

int dm_plan(const dm_robot *robot, const dm_plan_effect *effects, int neffect,
            const dm_plan_opts *opts, dm_plan_result *out, dm_error *err);
void dm_plan_free(dm_plan_result *result);

/* The comparison: opts->npose random candidates of the plan's region
 * (static: each with a direction drawn uniformly on the sphere; tracker: a
 * random member of the path family), as a dataset like a plan's design. */
int dm_plan_random(const dm_robot *robot, const dm_plan_opts *opts, uint64_t seed,
                   dm_dataset *out, dm_error *err);

/* Synthetic measurements at the samples of a design (or a template read
 * by dm_dataset_read_template): the robot's predictions (its effects
 * applied) plus Gaussian noise of standard deviation `noise`, which
 * becomes every sample's sigma (0: the design's own sigma). Deterministic
 * for a seed. */
int dm_plan_observe(const dm_robot *robot, const dm_dataset *design, double noise, uint64_t seed,
                    int na, int nb, dm_dataset *out, dm_error *err);

/* The design as a measurement template in the format of docs/measured-data.md, the
 * measured values empty. */
int dm_plan_write_template(const dm_plan_result *result, const char *robot_name, FILE *out);

#endif
