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

#endif
