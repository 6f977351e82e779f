/* VTK XML writers: UnstructuredGrid of lines, PVD collections. */
#include "dm_vtk.h"

#include <assert.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "dm_file.h"

int dm_vtk_check_dir(const char *path, dm_error *err)
{
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (!slash)
        return DM_OK; /* the current directory */
    if (slash == dir)
        slash[1] = '\0';
    else
        *slash = '\0';
    struct stat st;
    if (stat(dir, &st) || !S_ISDIR(st.st_mode))
        return dm_fail(err, DM_EIO, "%s: cannot write: directory %s does not exist", path, dir);
    return DM_OK;
}

static void write_array(FILE *f, const dm_vtk_array *a, const char *indent)
{
    assert(a->ncomp >= 1);
    fprintf(f, "%s<DataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"%d\" "
               "NumberOfTuples=\"%ld\" format=\"ascii\">\n%s ",
            indent, a->name, a->ncomp, a->ntuples, indent);
    for (long i = 0; i < a->ntuples * a->ncomp; i++)
        fprintf(f, " %.17g", a->v[i]);
    fprintf(f, "\n%s</DataArray>\n", indent);
}

static void write_cells(FILE *f, const dm_vtk_lines *g)
{
    fprintf(f, "      <Cells>\n        <DataArray type=\"Int32\" Name=\"connectivity\" "
               "format=\"ascii\">\n         ");
    for (int l = 0; l < 2 * g->nlines; l++)
        fprintf(f, " %d", g->line[l]);
    fprintf(f, "\n        </DataArray>\n        <DataArray type=\"Int32\" Name=\"offsets\" "
               "format=\"ascii\">\n         ");
    for (int l = 0; l < g->nlines; l++)
        fprintf(f, " %d", 2 * (l + 1));
    fprintf(f, "\n        </DataArray>\n        <DataArray type=\"UInt8\" Name=\"types\" "
               "format=\"ascii\">\n         ");
    for (int l = 0; l < g->nlines; l++)
        fprintf(f, " 3");
    fprintf(f, "\n        </DataArray>\n      </Cells>\n");
}

static void write_grid(FILE *f, const dm_vtk_lines *g)
{
    fprintf(f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" "
               "byte_order=\"LittleEndian\">\n  <UnstructuredGrid>\n");
    if (g->nfield_data) {
        fprintf(f, "    <FieldData>\n");
        for (int a = 0; a < g->nfield_data; a++)
            write_array(f, &g->field_data[a], "      ");
        fprintf(f, "    </FieldData>\n");
    }
    fprintf(f, "    <Piece NumberOfPoints=\"%d\" NumberOfCells=\"%d\">\n", g->npoints, g->nlines);
    fprintf(f, "      <Points>\n");
    write_array(f, &(dm_vtk_array){"Points", 3, g->npoints, g->xyz}, "        ");
    fprintf(f, "      </Points>\n");
    write_cells(f, g);
    if (g->line_tag) {
        fprintf(f, "      <CellData Scalars=\"%s\">\n        <DataArray type=\"Int32\" "
                   "Name=\"%s\" format=\"ascii\">\n         ", g->tag_name, g->tag_name);
        for (int l = 0; l < g->nlines; l++)
            fprintf(f, " %d", g->line_tag[l]);
        fprintf(f, "\n        </DataArray>\n      </CellData>\n");
    }
    if (g->npoint_data) {
        fprintf(f, "      <PointData>\n");
        for (int a = 0; a < g->npoint_data; a++)
            write_array(f, &g->point_data[a], "        ");
        fprintf(f, "      </PointData>\n");
    }
    fprintf(f, "    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
}

/* The output's temporary, once its directory is known to exist. */
static int open_out(const char *path, dm_file_out *out, dm_error *err)
{
    int rc = dm_vtk_check_dir(path, err);
    return rc ? rc : dm_file_out_open(out, path, err);
}

int dm_vtk_write_lines(const char *path, const dm_vtk_lines *g, dm_error *err)
{
    dm_file_out out;
    int rc = open_out(path, &out, err);
    if (rc)
        return rc;
    write_grid(out.f, g);
    return dm_file_out_commit(&out, err);
}

int dm_vtk_write_pvd(const char *path, int n, const double *t, const char *const *file,
                     dm_error *err)
{
    dm_file_out out;
    int rc = open_out(path, &out, err);
    if (rc)
        return rc;
    fprintf(out.f, "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" "
                   "byte_order=\"LittleEndian\">\n  <Collection>\n");
    for (int i = 0; i < n; i++)
        fprintf(out.f, "    <DataSet timestep=\"%.17g\" group=\"\" part=\"0\" file=\"%s\"/>\n",
                t[i], file[i]);
    fprintf(out.f, "  </Collection>\n</VTKFile>\n");
    return dm_file_out_commit(&out, err);
}
