/* dm_kinematics — rigid-body kinematics of the Delta robot (docs/model.md §1).
 *
 * Base frame O-XYZ at the centre of the fixed platform, Z up. Chain i has
 * radial unit e_i, actuator axis t_i; arm angle alpha_i > 0 points the arm
 * below the base plane. The platform translates only. Units: m, rad, s. */
#ifndef DM_KINEMATICS_H
#define DM_KINEMATICS_H

#include "dm_error.h"
#include "dm_robot.h"

/* The rigid configuration of the robot at one platform position. */
typedef struct dm_pose {
    double P[3];          /* platform centre */
    double alpha[3];      /* arm angles, rad */
    double e[3][3];       /* radial unit per chain */
    double t[3][3];       /* actuator axis per chain */
    double A[3][3];       /* arm root (actuator joint) */
    double B[3][3];       /* elbow (arm end) */
    double C[3][3];       /* platform attachment centre P + r e_i */
    double cond;          /* 2-norm condition number of J (alpha_dot = J P_dot) */
    double offset[3];     /* real - commanded platform position (geometry errors), m */
} dm_pose;

/* Inverse kinematics with the robot's elbow branch; DM_EUNREACHABLE (and a
 * message naming the chain) when |kappa| > rho for some chain. Also fills
 * the singularity measure pose->cond. */
int dm_kin_inverse(const dm_robot *robot, const double P[3], dm_pose *pose, dm_error *err);

/* Forward kinematics: the platform positions (0, 1 or 2) reached with arm
 * angles alpha. Solutions are ordered by ascending z. Returns their count. */
int dm_kin_forward(const dm_robot *robot, const double alpha[3], double P[2][3]);

/* The configuration the real robot takes when commanded to P: its
 * controller solves the nominal inverse kinematics, the real arms (with the
 * geometry errors of the robot's [effects]: lengths, radii, mounting angle,
 * actuator offset per chain) turn to those angles (+ offset), and the
 * platform goes where the real geometry closes (forward kinematics, the
 * solution nearest P). pose->offset = real - commanded position. Without
 * geometry errors this is dm_kin_inverse. */
int dm_kin_pose(const dm_robot *robot, const double P[3], dm_pose *pose, dm_error *err);

/* The same under a net force W (N) on the platform (its weight, inertia,
 * an added force). With joint clearance c each rod's effective length is
 * lb + 2c in tension and lb - 2c in compression, the rod forces following
 * from the platform's equilibrium (rods as two-force members); with
 * actuator-joint clearance each arm slides by c_axial along its axis and by
 * c_radial across it, the way the rods' pull on it points. dm_kin_pose
 * uses the weight of the platform and payload. */
int dm_kin_pose_loaded(const dm_robot *robot, const double P[3], const double W[3],
                       dm_pose *pose, dm_error *err);

/* A joint-clearance state given explicitly, per chain: the extra effective
 * rod length dlb (m; the parallelogram's rods together) and the shift of
 * the whole arm by its revolute joint's play (m, base frame). */
typedef struct dm_kin_play {
    double dlb[3];
    double shift[3][3];
} dm_kin_play;

/* The real configuration commanded to P (as dm_kin_pose) with this
 * clearance state instead of the one the load opens; the robot's own
 * clearance values are not used. Always closes the real chains, so with
 * no errors and zero play the offset is round-off, not exactly 0. */
int dm_kin_pose_play(const dm_robot *robot, const double P[3], const dm_kin_play *play,
                     dm_pose *pose, dm_error *err);

/* Net force on the platform (N): (platform + payload mass) (g - a) + F.
 * a or F may be NULL (zero). */
void dm_kin_platform_force(const dm_robot *robot, const double a[3], const double F[3],
                           double W[3]);

/* Where the robot's geometry errors and clearances put the real platform
 * relative to the commanded position P while it accelerates at a under
 * the external force F (a, F may be NULL: zero): the offset of
 * dm_kin_pose_loaded under dm_kin_platform_force's net force, what a
 * trajectory adds to the elastic error. Returns 1 with it, or 0 with
 * offset zero where the robot has neither or that pose is not found. */
int dm_kin_real_offset(const dm_robot *robot, const double P[3], const double a[3],
                       const double F[3], double offset[3]);

/* Jacobian J (row-major 3x3) with alpha_dot = J * P_dot. Returns
 * DM_ENUMERIC at a serial singularity (an arm's motion does not change its
 * rod length). */
int dm_kin_jacobian(const dm_robot *robot, const dm_pose *pose, double J[9], dm_error *err);

/* Arm rates for platform velocity v (m/s). */
int dm_kin_rates(const dm_robot *robot, const dm_pose *pose, const double v[3],
                 double alpha_dot[3], dm_error *err);

/* Arm accelerations for platform velocity v and acceleration a, including
 * the velocity (centripetal) terms. */
int dm_kin_accelerations(const dm_robot *robot, const dm_pose *pose, const double v[3],
                         const double a[3], double alpha_ddot[3], dm_error *err);

/* Rigid-body motion of the links, for inertial loads (docs/model.md §3). */
typedef struct dm_link_motion {
    double alpha_dot[3], alpha_ddot[3];
    double vB[3][3], aB[3][3];       /* elbow velocity / acceleration */
    double vP[3], aP[3];             /* platform */
    double rod_omega[3][3];          /* rod angular velocity per chain */
    double rod_alpha[3][3];          /* rod angular acceleration per chain */
    double arm_alpha[3][3];          /* arm angular acceleration per chain (about t_i) */
} dm_link_motion;

/* The accelerations of m (alpha_dot, alpha_ddot, aP, aB, rod_alpha,
 * arm_alpha) from
 * given arm rates and accelerations and platform acceleration, nothing
 * solved (dm_loads' rigid motions); the velocities are left as they are. */
void dm_kin_link_accelerations(const dm_pose *pose, const double alpha_dot[3],
                               const double alpha_ddot[3], const double aP[3],
                               dm_link_motion *motion);

int dm_kin_link_motion(const dm_robot *robot, const dm_pose *pose, const double v[3],
                       const double a[3], dm_link_motion *motion, dm_error *err);

#endif
