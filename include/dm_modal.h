/* dm_modal — natural frequencies and mass-normalised mode shapes
 * (docs/model.md §4–5): K phi = omega^2 M phi, Phi' M Phi = I, ascending.
 *
 * A dm_modal is a per-thread workspace sized for one model: allocate once,
 * solve at many poses with no allocation in between. */
#ifndef DM_MODAL_H
#define DM_MODAL_H

#include "dm_model.h"
#include "dm_error.h"

typedef enum {
    /* Default. Block subspace iteration with Rayleigh-Ritz on the
     * block-arrow Cholesky factor of K (the one statics use), warm-started
     * from the previous solve of the same workspace, converged on residual
     * norms and checked by a Sturm count; a dense cold start when there is
     * no previous solve or the check fails. Models of at most
     * DM_MODAL_DENSE_MAX DOF use DM_EIGEN_DENSE (measured faster there). */
    DM_EIGEN_PARTIAL = 0,
    /* All pairs by divide and conquer (dsygvd) on the dense matrices; the
     * reference. */
    DM_EIGEN_ALL = 1,
    /* The k lowest pairs on the dense matrices: Cholesky of M, dsygst,
     * dsyevr on the index range (up to 96 DOF dsterf for the eigenvalues
     * and dstein for k vectors), back-substitution; beyond max(20, n / 8)
     * pairs, where selecting them costs more, DM_EIGEN_ALL_ARROW's way. */
    DM_EIGEN_DENSE = 2,
    /* DM_EIGEN_PARTIAL's subspace iteration at any size (tests, bench). */
    DM_EIGEN_SUBSPACE = 3,
    /* All pairs like DM_EIGEN_ALL, reduced to standard form with the
     * block-arrow Cholesky factor of M (its solves visit the factor's
     * profile) instead of a dense one, then dsyevd: 0.71-0.74x dsygvd's
     * time at 210 DOF and 426. The trajectories' all-modes reference
     * keeps the same pairs factored instead (dm_spectrum); DM_EIGEN_ALL
     * stays the tests' oracle, independent of the block-arrow kernels. */
    DM_EIGEN_ALL_ARROW = 4
} dm_eigen_method;

/* DM_EIGEN_PARTIAL solves models up to this size densely (make bench). */
#define DM_MODAL_DENSE_MAX 60

typedef enum {
    DM_DIR_X = 0, DM_DIR_Y, DM_DIR_Z, DM_DIR_RX, DM_DIR_RY, DM_DIR_RZ
} dm_direction;

/* The most modes a pose's result holds where it is of fixed size: the
 * sweep's maps and its stores, synth's and plan's modal data, a measured
 * mode's rank (the solvers themselves have no such limit). */
#define DM_MAX_MODES 64
/* The same as text, for help and error messages: "64". */
#define DM_MAX_MODES_TEXT DM_MODAL_TEXT_(DM_MAX_MODES)
#define DM_MODAL_TEXT_(n) DM_MODAL_TEXT__(n)
#define DM_MODAL_TEXT__(n) #n

typedef struct dm_modal dm_modal;

typedef struct dm_modes {
    int n, k;
    double *omega_rad_s;     /* k */
    double *freq_hz;         /* k */
    double *phi;             /* n x k column-major, Phi' M Phi = I */
    const double *mphi;      /* n x k: M Phi, where the solver has it (the subspace
                                iteration's last products; else NULL) */
    double *platform_share;  /* k: share of the modal kinetic energy in the platform */
    int *direction;          /* k: dm_direction with the largest platform energy */
} dm_modes;

/* Relative residual ||x - theta K^-1 M x||_M (x M-normalised) at which a
 * Ritz pair counts as converged. To first order it bounds the relative
 * error of the eigenvalue, and squared over the relative gap to the rest
 * of the spectrum (Kato-Temple; for a cluster, the gap around it): 1e-8
 * leaves eigenvalues within ~1e-14 and invariant subspaces within ~1e-6
 * rad. */
#define DM_MODAL_CONVERGED 1e-8

/* Workspace for models of `model`'s size and up to kmax modes. */
dm_modal *dm_modal_alloc(const dm_model *model, int kmax, dm_eigen_method method,
                         dm_error *err);
void dm_modal_free(dm_modal *ws);

/* The k lowest modes of the model (its K and M are not modified). The
 * subspace methods need `factor`, the Cholesky factor of the same K
 * (dm_static_factor); the dense ones ignore it (may be NULL). The returned
 * dm_modes points into the workspace and is valid until the next solve. */
struct dm_static;
int dm_modal_solve(dm_modal *ws, const dm_model *model, const struct dm_static *factor, int k,
                   const dm_modes **modes, dm_error *err);

/* omega = sqrt(lambda) for k eigenvalues; DM_ENUMERIC naming the first
 * that is not positive (the structure is a mechanism). */
int dm_modal_omega(const double *lambda, int k, double *omega, dm_error *err);

/* The next solve starts cold (a sweep tile's first point: results must
 * not depend on which tile a thread did before). */
void dm_modal_forget(dm_modal *ws);

/* Poses come along a smooth path at equal steps (a trajectory's time
 * steps): each warm solve starts from the subspaces of the last three
 * solutions extrapolated (quadratic in the step) rather than from the
 * last alone, and needs fewer iterations; the results converge to the
 * same residuals either way. Calling it again (on or off) starts a new
 * path: do so where the steps stop being equal (a pause, a jump). */
void dm_modal_follow_path(dm_modal *ws, int on);

/* A Sturm count made ahead of a solve. Along a path the count that proves
 * a solve (dm_modal_stats.sigma) can be made before it, at a shift
 * predicted from the solves before, e.g. by another thread while the
 * solve before it runs (a trajectory's frames). dm_modal_count_ahead:
 * the number of eigenvalues of `model` below the shift predicted from
 * `shift`, the own shifts (dm_modal_stats.shift) of the solves two, three
 * and four steps before along a path of equal steps, with `ldl` the
 * caller's workspace (dm_arrow_ldl_init on the model's layout);
 * DM_ENUMERIC if no count could be made near it. dm_modal_offer_count:
 * the next solve, of that model, takes the count as its proof when it
 * lies at or above its own shift and equals the modes it found (no mode
 * can be missed below the lower shift either), and counts at its own
 * shift otherwise: the same decision either way, so the same results. */
typedef struct dm_modal_count {
    double sigma; /* rad^2/s^2 */
    int count;    /* eigenvalues below sigma */
} dm_modal_count;
int dm_modal_count_ahead(dm_arrow_ldl *ldl, const dm_model *model, const double shift[3],
                         dm_modal_count *out);
void dm_modal_offer_count(dm_modal *ws, const dm_modal_count *count);

/* Start the next solve from these ncol vectors (n x ncol, column-major)
 * instead of the previous solution (tests: a start that misses a mode must
 * be caught by the Sturm count). */
int dm_modal_set_start(dm_modal *ws, const double *X, int ncol, dm_error *err);

/* A seed: what a solve leaves behind to start another from (the subspace
 * and its Ritz values). A sweep starts each point from the seed of an
 * anchor near it, so a point's result does not depend on which points were
 * computed before it (or by which thread, or in which tile shape).
 * dm_modal_seed_size: bytes of a seed (0 for the dense methods);
 * dm_modal_seed_save: after a successful solve (returns 0 if there is
 * nothing to save); dm_modal_seed_load: the next solve starts from it. */
size_t dm_modal_seed_size(const dm_modal *ws);
int dm_modal_seed_save(const dm_modal *ws, void *seed);
void dm_modal_seed_load(dm_modal *ws, const void *seed);

/* Start the next solve between seeds: from `seed`, moved a fraction
 * frac[d] (0 < frac <= 1) of the way toward each of toward[0 .. count)
 * (seeds of poses one step away along different axes; a seed of another
 * subspace size is skipped), which the solve works out once it has the
 * model (see interpolate() in modal.c). */
#define DM_MODAL_TOWARD 3
void dm_modal_seed_load_toward(dm_modal *ws, const void *seed, const void *const toward[],
                               const double frac[], int count);

/* How a cold solve of the subspace method starts: from a block of
 * pseudo-random vectors (always the same) iterated to convergence, or
 * from the dense solver's lowest pairs; either way the Sturm count proves
 * the result, and a random start that fails falls back to the dense one.
 * DM_COLD_AUTO (the default) takes the random block above 96 DOF, where it
 * is measured faster, the dense solver below; the other two are for tests
 * and benchmarks. */
typedef enum { DM_COLD_AUTO, DM_COLD_RANDOM, DM_COLD_DENSE } dm_cold_start;
void dm_modal_set_cold_start(dm_modal *ws, dm_cold_start how);

/* How the last solve went. */
typedef struct dm_modal_stats {
    int iterations;     /* applications of K^-1 M (0: dense) */
    int rounds;         /* Rayleigh-Ritz projections */
    int warm;           /* started from a previous solution */
    int fallback;       /* the warm start failed (no convergence, or the
                           Sturm count found a mode it missed): cold */
    int random;         /* cold, and from the random block (else dense) */
    int subspace;       /* vectors iterated */
    int rebased;        /* filtered blocks made M-orthonormal before their
                           projection (they had collapsed) */
    int converged;      /* modes proven: the Sturm count below sigma */
    double sigma;       /* the Sturm shift (rad^2/s^2) */
    double shift;       /* its own shift, just above the last converged Ritz
                           value (sigma unless a count made ahead proved it) */
    int counted_ahead;  /* a count made ahead proved it */
    double residual;    /* largest relative residual of the converged modes */
} dm_modal_stats;
void dm_modal_last_stats(const dm_modal *ws, dm_modal_stats *stats);

/* Platform share and dominant direction of each mode of `model`. */
void dm_modal_platform_share(dm_modal *ws, const dm_model *model);

/* One mode's: phiP its 6 platform rows, MP the platform's 6 x 6 mass
 * (leading dimension ld); the share phiP' MP phiP, the direction whose
 * diagonal contribution is largest. */
void dm_modal_mode_platform_share(const double *MP, int ld, const double *phiP, double *share,
                                  int *direction);

const char *dm_direction_name(int direction);

/* Mode tracking by the modal assurance criterion, clusters as subspaces.
 * For each of the kr reference shapes ref (n x kr, families from a nearby
 * pose, same DOF numbering) find its mode among the first kc of `modes`.
 * Modes whose frequencies are closer than DM_TRACK_GAP (relative) form a
 * cluster: inside one the eigenvectors are an arbitrary basis that rounding
 * can rotate, so a family is matched to a cluster by the MAC with its
 * invariant subspace,
 *   MAC(ref, C) = sum_{j in C} (ref' M phi_j)^2 / (ref' M ref),
 * which no rotation changes; greedily by decreasing MAC, each cluster
 * taking as many families as it has modes; inside a cluster the families,
 * in index order, take its modes in ascending frequency. assign[f] = the
 * mode of family f (-1: none), mac[f] its MAC. shapes (n x kr, may be
 * NULL): each family's next reference, its shape projected on its cluster
 * (M-normalised). work needs 2 n kr + kr kc doubles. kr <= kc <=
 * DM_TRACK_MAX. */
#define DM_TRACK_MAX 64
#define DM_TRACK_GAP 1e-3
void dm_modal_track(const double *ref, int kr, const dm_modes *modes, int kc,
                    const dm_model *model, int *assign, double *mac, double *shapes,
                    double *work);

/* dm_modal_track's matching from the products it needs, in any
 * coordinates where M is known: a[j + kc f] = y_j' M ref_f (kc x kr),
 * norms2[f] = ref_f' M ref_f, the modes' frequencies (kc) and vectors
 * (vec: dim x kc, for the families' next references in shapes, dim x kr). */
void dm_modal_track_products(const double *a, const double *norms2, int kr, const double *freq_hz,
                             int kc, const double *vec, int dim, int *assign, double *mac,
                             double *shapes);

#endif
