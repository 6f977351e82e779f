/* dm_vtk — VTK XML files for ParaView (docs/shapes.md): an unstructured
 * grid of line cells (.vtu, ASCII, every number with 17 significant
 * digits so it reads back as the same double) and a time-series
 * collection of such files (.pvd). Written through dm_file_out: a file
 * appears whole or not at all, and a missing directory is refused before
 * anything is written. The format: VTK's "VTK File Formats" (XML
 * UnstructuredGrid, version 0.1, cell type 3 = VTK_LINE). */
#ifndef DM_VTK_H
#define DM_VTK_H

#include "dm_error.h"

/* A named array: ncomp numbers per tuple, ntuples tuples (point data:
 * one per point; field data: any count). */
typedef struct dm_vtk_array {
    const char *name;
    int ncomp;
    long ntuples;
    const double *v;
} dm_vtk_array;

typedef struct dm_vtk_lines {
    int npoints;
    const double *xyz;       /* 3 per point */
    int nlines;
    const int *line;         /* 2 point indices per line */
    const int *line_tag;     /* per line (may be NULL): cell data named tag_name */
    const char *tag_name;
    int npoint_data;
    const dm_vtk_array *point_data;
    int nfield_data;
    const dm_vtk_array *field_data;
} dm_vtk_lines;

/* The grid as PATH (a .vtu). DM_EIO naming the path on failure. */
int dm_vtk_write_lines(const char *path, const dm_vtk_lines *grid, dm_error *err);

/* A .pvd collection: n datasets, file[i] (relative to the .pvd's
 * directory) at time t[i] (s). */
int dm_vtk_write_pvd(const char *path, int n, const double *t, const char *const *file,
                     dm_error *err);

/* DM_EIO naming path unless the directory path would be written into
 * exists. */
int dm_vtk_check_dir(const char *path, dm_error *err);

#endif
