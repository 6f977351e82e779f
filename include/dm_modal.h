/* dm_modal — natural frequencies and mass-normalised mode shapes
 * (MODEL.md §4–5): K phi = omega^2 M phi, Phi' M Phi = I, ascending.
 *
 * A dm_modal is a per-thread workspace sized for one model: allocate once,
 * solve at many poses with no allocation in between. */
#ifndef DM_MODAL_H
#define DM_MODAL_H

#include "dm_assembly.h"
#include "dm_error.h"

typedef enum {
    /* Cholesky of M, reduction to standard form (dsygst), the k lowest
     * pairs only (dsyevr range 'I'; up to 96 DOF dsterf for the eigenvalues
     * and dstein for k vectors), back-substitution. Default: measured
     * fastest for k << n (see make bench). */
    DM_EIGEN_PARTIAL = 0,
    /* All pairs by divide and conquer (dsygvd); the reference. */
    DM_EIGEN_ALL = 1
} dm_eigen_method;

typedef enum {
    DM_DIR_X = 0, DM_DIR_Y, DM_DIR_Z, DM_DIR_RX, DM_DIR_RY, DM_DIR_RZ
} dm_direction;

typedef struct dm_modal dm_modal;

typedef struct dm_modes {
    int n, k;
    double *omega_rad_s;     /* k */
    double *freq_hz;         /* k */
    double *phi;             /* n x k column-major, Phi' M Phi = I */
    double *platform_share;  /* k: share of the modal kinetic energy in the platform */
    int *direction;          /* k: dm_direction with the largest platform energy */
} dm_modes;

/* Workspace for n-DOF models and up to kmax modes. */
dm_modal *dm_modal_alloc(int n, int kmax, dm_eigen_method method, dm_error *err);
void dm_modal_free(dm_modal *ws);

/* The k lowest modes of (K, M); K and M are not modified. The returned
 * dm_modes points into the workspace and is valid until the next solve. */
int dm_modal_solve(dm_modal *ws, const double *K, const double *M, int k,
                   const dm_modes **modes, dm_error *err);

/* Platform share and dominant direction of each mode of `model`. */
void dm_modal_platform_share(dm_modal *ws, const dm_model *model);

const char *dm_direction_name(int direction);

/* Mode tracking by the modal assurance criterion. For each of the kr
 * reference shapes ref (n x kr, from a nearby pose, same DOF numbering)
 * find the mode of `modes` (its first kc) that matches best, each mode used
 * at most once, greedily by decreasing MAC:
 *   MAC(a, b) = (a' M b)^2 / ((a' M a)(b' M b)), M = this pose's mass matrix.
 * assign[i] = index of the mode for reference i, mac[i] its MAC. work needs
 * n*kc + kr*kc doubles. */
void dm_modal_mac_match(const double *ref, int kr, const dm_modes *modes, int kc,
                        const double *M, int n, int *assign, double *mac, double *work);

#endif
