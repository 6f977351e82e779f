/* Shared by the member-basis tests (test_members, test_boundary): the
 * effect set that changes members and boundary but not with the pose, a
 * robot loaded with assignments, random reachable poses near home. */
#ifndef DM_MEMBERS_FIXTURES_H
#define DM_MEMBERS_FIXTURES_H

#include "dm_kinematics.h"
#include "dm_rng.h"
#include "dm_robot.h"

/* Every effect that changes the members' matrices or the boundary but not
 * with the pose (geometric stiffness is tested apart). */
static const char *const ALL_EFFECTS[] = {
    "effects.actuator_stiffness=2000",     "effects.joint_stiffness=1e6",
    "effects.base_stiffness=2e5,3e5,5e5",  "effects.elbow_mass=0.3",
    "effects.payload_mass=1.5",            "effects.payload_offset=0.03,-0.02,-0.05",
    "effects.error_arm_length=0.001,-0.002,0", NULL};

static inline void load(dm_robot *rb, const char *preset, const char *const *sets)
{
    dm_error err;
    assert_int_equal(dm_robot_load(preset, rb, NULL), 0);
    for (int k = 0; sets && sets[k]; k++) {
        int rc = dm_robot_set(rb, sets[k], &err);
        if (rc)
            print_error("%s: %s\n", sets[k], err.msg);
        assert_int_equal(rc, 0);
    }
}

/* A reachable pose within 8 cm (x, y) and 4 cm (z) of home, drawn from rng. */
static inline void random_pose(const dm_robot *rb, dm_rng *rng, dm_pose *pose)
{
    for (int tries = 0; tries < 100; tries++) {
        double P[3];
        for (int k = 0; k < 3; k++)
            P[k] = rb->home_m[k] + (k < 2 ? 0.08 : 0.04) * (2 * dm_rng_uniform(rng) - 1);
        if (!dm_kin_pose(rb, P, pose, NULL))
            return;
    }
    fail_msg("no reachable pose near home");
}

#endif
