/* dm_grid — the grids of poses a sweep covers.
 *
 * Cartesian "x=A:B:N,y=A:B:N,z=A:B:N" or cylindrical
 * "r=A:B:N,phi=A:B:N,z=A:B:N" (phi in degrees); an axis given as one value
 * "z=-0.5" is fixed. Units m. N points from A to B inclusive. */
#ifndef DM_GRID_H
#define DM_GRID_H

#include <stddef.h>

#include "dm_error.h"

typedef enum { DM_GRID_CARTESIAN = 0, DM_GRID_CYLINDRICAL = 1 } dm_grid_kind;

typedef struct dm_grid_axis {
    char name[8];
    double from, to;
    int count;
} dm_grid_axis;

typedef struct dm_grid {
    dm_grid_kind kind;
    dm_grid_axis axis[3]; /* x, y, z or r, phi, z */
} dm_grid;

#define DM_GRID_MAX_POINTS 100000000L

int dm_grid_parse(const char *spec, dm_grid *grid, dm_error *err);
double dm_grid_value(const dm_grid_axis *axis, int i);
void dm_grid_position(const dm_grid *grid, const int idx[3], double P[3]);
long dm_grid_points(const dm_grid *grid);
/* Canonical text of a grid (round-trips through dm_grid_parse). */
void dm_grid_format(const dm_grid *grid, char *out, size_t len);

#endif
