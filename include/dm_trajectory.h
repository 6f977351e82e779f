/* dm_trajectory — nominal platform motions P(t), v(t), a(t) (m, m/s, m/s^2).
 *
 * Kinds: circles in any plane (centre, radius, angular rate), point-to-point
 * moves with a motion law, the industry pick-and-place cycle (25 mm up,
 * 305 mm across, 25 mm down), and samples t,x,y,z from a CSV file (natural
 * cubic spline through the samples). The three papers' trajectories are
 * named presets (docs/model.md §7). A trajectory is a read-only value once made. */
#ifndef DM_TRAJECTORY_H
#define DM_TRAJECTORY_H

#include "dm_error.h"
#include "dm_robot.h"

typedef enum {
    DM_LAW_CYCLOIDAL = 0,  /* s = tau - sin(2 pi tau)/(2 pi) */
    DM_LAW_TRAPEZOIDAL,    /* trapezoidal velocity, thirds: accelerate, cruise, brake */
    DM_LAW_POLY7,          /* 4-5-6-7 polynomial: jerk-limited, zero jerk at the ends */
    DM_LAW_BANGBANG        /* +a for half the time, -a for the other half */
} dm_motion_law;

typedef enum { DM_PATH_CIRCLE, DM_PATH_SEGMENTS, DM_PATH_SAMPLES } dm_path_kind;

#define DM_TRAJ_MAXSEG 8

typedef struct dm_segment {
    double t0_s, duration_s;
    double from_m[3], to_m[3];
    dm_motion_law law;
} dm_segment;

typedef struct dm_trajectory {
    char name[96];
    dm_path_kind kind;
    double duration_s;
    /* circle: P = centre + radius (cos phi u + sin phi w), phi = phase + rate t */
    double centre_m[3], radius_m, rate_rad_s, phase_rad, u[3], w[3];
    /* segments: rest-to-rest moves one after another */
    int nseg;
    dm_segment seg[DM_TRAJ_MAXSEG];
    /* samples: natural cubic spline per coordinate */
    int nsamp;
    double *t_s, *xyz_m, *m2; /* m2: spline second derivatives, 3 per sample */
} dm_trajectory;

/* Make a trajectory from a spec:
 *   preset name: chen2018, zheng2017, han2011, han2011-vertical (radius 0.05),
 *                han2011-vertical-printed (radius 0.24, leaves the workspace)
 *   circle:centre=X,Y,Z;radius=R;rate=W;duration=T[;plane=xy|yz|xz][;phase=DEG]
 *   p2p:from=X,Y,Z;to=X,Y,Z;duration=T[;law=cycloidal|trapezoidal|poly7|bangbang]
 *   pick:start=X,Y,Z;duration=T[;law=...][;axis=x|y]   (25 up, 305 across, 25 down)
 *   FILE.csv   columns t,x,y,z (found by name), '#' comments
 * `robot` supplies the home pose for defaults (may be NULL). */
int dm_traj_make(const char *spec, const dm_robot *robot, dm_trajectory *traj, dm_error *err);
void dm_traj_free(dm_trajectory *traj);

/* A trajectory through samples t (s, strictly increasing from 0) and
 * positions xyz (3 per sample, m): natural cubic spline. Copies the data. */
int dm_traj_from_samples(const double *t, const double *xyz, int n, const char *name,
                         dm_trajectory *traj, dm_error *err);

/* Position, velocity, acceleration at time t (clamped to [0, duration]). */
void dm_traj_eval(const dm_trajectory *traj, double t, double P[3], double v[3], double a[3]);

/* Normalised motion law: s(tau), s'(tau), s''(tau) for tau in [0, 1]. */
void dm_motion_law_eval(dm_motion_law law, double tau, double *s, double *ds, double *dds);

/* Check every sample time t = 0, dt, ..., duration for reachability; on
 * failure DM_EUNREACHABLE naming the first unreachable time and pose. */
int dm_traj_check_reachable(const dm_trajectory *traj, const dm_robot *robot, double dt_s,
                            dm_error *err);

#endif
