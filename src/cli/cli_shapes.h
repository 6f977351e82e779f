/* Private to the command line: the shapes of dm_shape printed as JSON
 * (modes --json) and written as VTK (modes --vtk). */
#ifndef DM_CLI_SHAPES_H
#define DM_CLI_SHAPES_H

#include <jansson.h>

#include "dm_shape.h"

/* Into the modes --json object o: "shape_mesh" (nodes, lines, their kinds,
 * the components' names and the stated maximum), each entry of `modes`
 * (one per mode, in order) its "shape", "shape_scaled" and "shape_scale",
 * and "static_deflection" likewise. */
void dm_cli_shapes_json(json_t *o, json_t *modes, const dm_shape_set *set);

/* modes --vtk PATH: the robot at the pose as line cells (cell data
 * "kind": 0 arm, 1 rod, 2 short bar, 3 platform), per mode j the point
 * vectors "mode_j" and "mode_j_rotation" (the scaled shape), the static
 * deflection's "static_deflection" and "static_deflection_rotation" (m,
 * rad); field data "frequencies_hz", "platform_share", "mode_scale",
 * "static_scale", "scaled_max_m". */
int dm_cli_modes_vtk(const char *path, const dm_shape_set *set, const double *platform_share,
                     const double *freq_hz, dm_error *err);

/* trajectory --vtk DIR: every `every`-th sample as DIR/frame_NNNNNN.vtu,
 * the robot at the step's frozen pose with its nodes moved by the
 * displacement magnified `magnify` times (point data "displacement" and
 * "rotation" unmagnified, m and rad; field data "time_s",
 * "magnification", "platform_error"), and DIR/trajectory.pvd listing them
 * with their times. */
#include "dm_integrate.h"
typedef struct dm_cli_traj_vtk {
    const char *dir;
    int every;
    double magnify;
    long seen, n, cap;
    dm_shape_mesh *mesh;
    double *d, *xyz, *trans, *rot; /* a frame's numbers */
    double *t;
    char **file;
} dm_cli_traj_vtk;

/* Refuses a DIR that is not an existing directory (nothing written). */
int dm_cli_traj_vtk_check(const dm_cli_traj_vtk *v, dm_error *err);
int dm_cli_traj_vtk_frame(dm_cli_traj_vtk *v, const dm_integ_sample *s, dm_error *err);
/* The .pvd when ok, else every frame written is removed; frees. */
int dm_cli_traj_vtk_finish(dm_cli_traj_vtk *v, int ok, dm_error *err);

#endif
