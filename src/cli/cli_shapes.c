/* modes --json's shapes: the numbers of dm_shape_set, printed. */
#include "cli_shapes.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "dm_vtk.h"

static const char *const COMPONENTS[6] = {"u_m", "v_m", "w_m", "tx_rad", "ty_rad", "tz_rad"};

/* nrow rows of ncol numbers, each times `scale`. */
static json_t *json_rows(const double *v, int nrow, int ncol, double scale)
{
    json_t *a = json_array();
    for (int r = 0; r < nrow; r++) {
        json_t *row = json_array();
        for (int c = 0; c < ncol; c++)
            json_array_append_new(row, json_real(scale * v[(size_t)ncol * r + c]));
        json_array_append_new(a, row);
    }
    return a;
}

static json_t *mesh_json(const dm_shape_set *set)
{
    const dm_shape_mesh *mesh = set->mesh;
    json_t *m = json_object(), *lines = json_array(), *kinds = json_array(), *comp = json_array();
    for (int l = 0; l < mesh->nlines; l++) {
        json_array_append_new(lines, json_pack("[ii]", mesh->line[2 * l], mesh->line[2 * l + 1]));
        json_array_append_new(kinds, json_string(dm_line_kind_name(mesh->line_kind[l])));
    }
    for (int c = 0; c < 6; c++)
        json_array_append_new(comp, json_string(COMPONENTS[c]));
    json_object_set_new(m, "nodes_m", json_rows(mesh->xyz_m, mesh->nnodes, 3, 1.0));
    json_object_set_new(m, "platform_node", json_integer(dm_shape_platform_node(mesh)));
    json_object_set_new(m, "lines", lines);
    json_object_set_new(m, "line_kinds", kinds);
    json_object_set_new(m, "components", comp);
    json_object_set_new(m, "scaled_max_m", json_real(set->max_m));
    return m;
}

/* A shape (6 per node) as "shape", "shape_scaled" and "shape_scale" of o. */
static void shape_json(json_t *o, const dm_shape_mesh *mesh, const double *d, double scale)
{
    json_object_set_new(o, "shape", json_rows(d, mesh->nnodes, 6, 1.0));
    json_object_set_new(o, "shape_scaled", json_rows(d, mesh->nnodes, 6, scale));
    json_object_set_new(o, "shape_scale", json_real(scale));
}

void dm_cli_shapes_json(json_t *o, json_t *modes, const dm_shape_set *set)
{
    size_t per = 6 * (size_t)set->mesh->nnodes;
    json_object_set_new(o, "shape_mesh", mesh_json(set));
    for (int j = 0; j < set->k; j++)
        shape_json(json_array_get(modes, j), set->mesh, set->mode + per * j, set->mode_scale[j]);
    json_t *st = json_object();
    shape_json(st, set->mesh, set->deflection, set->deflection_scale);
    json_object_set_new(o, "static_deflection", st);
}

/* ---- VTK ------------------------------------------------------------------- */

static int mode_arrays(const dm_shape_set *set, double *buf, dm_vtk_array *pd, char (*name)[48])
{
    int nn = set->mesh->nnodes, a = 0;
    size_t per = 6 * (size_t)nn;
    for (int j = 0; j <= set->k; j++, a += 2) {
        const double *d = j < set->k ? set->mode + per * j : set->deflection;
        double f = j < set->k ? set->mode_scale[j] : 1.0; /* the deflection in m */
        double *tr = buf + per * j, *rot = tr + 3 * (size_t)nn;
        dm_shape_split(set->mesh, d, f, tr, rot);
        if (j < set->k) {
            snprintf(name[a], sizeof name[a], "mode_%d", j + 1);
            snprintf(name[a + 1], sizeof name[a + 1], "mode_%d_rotation", j + 1);
        } else {
            snprintf(name[a], sizeof name[a], "static_deflection");
            snprintf(name[a + 1], sizeof name[a + 1], "static_deflection_rotation");
        }
        pd[a] = (dm_vtk_array){name[a], 3, nn, tr};
        pd[a + 1] = (dm_vtk_array){name[a + 1], 3, nn, rot};
    }
    return a;
}

int dm_cli_modes_vtk(const char *path, const dm_shape_set *set, const double *platform_share,
                     const double *freq_hz, dm_error *err)
{
    const dm_shape_mesh *mesh = set->mesh;
    int na = 2 * (set->k + 1);
    double *buf = malloc(6 * (size_t)mesh->nnodes * (set->k + 1) * sizeof *buf);
    dm_vtk_array *pd = malloc((size_t)na * sizeof *pd);
    char (*name)[48] = malloc((size_t)na * sizeof *name);
    int rc;
    if (!buf || !pd || !name)
        rc = dm_fail(err, DM_ENOMEM, "out of memory (%s)", path);
    else {
        int npd = mode_arrays(set, buf, pd, name);
        const dm_vtk_array fd[] = {
            {"frequencies_hz", 1, set->k, freq_hz},
            {"platform_share", 1, set->k, platform_share},
            {"mode_scale", 1, set->k, set->mode_scale},
            {"static_scale", 1, 1, &set->deflection_scale},
            {"scaled_max_m", 1, 1, &set->max_m}};
        dm_vtk_lines g = {mesh->nnodes, mesh->xyz_m, mesh->nlines, mesh->line, mesh->line_kind,
                          "kind", npd, pd, 5, fd};
        rc = dm_vtk_write_lines(path, &g, err);
    }
    free(buf);
    free(pd);
    free(name);
    return rc;
}

int dm_cli_traj_vtk_check(const dm_cli_traj_vtk *v, dm_error *err)
{
    struct stat st;
    if (stat(v->dir, &st) || !S_ISDIR(st.st_mode))
        return dm_fail(err, DM_EIO, "--vtk %s: no such directory (make it first)", v->dir);
    return DM_OK;
}

static int traj_vtk_alloc(dm_cli_traj_vtk *v, const dm_model *model, dm_error *err)
{
    if (!(v->mesh = dm_shape_mesh_alloc(model, err)))
        return err->code;
    size_t nn = (size_t)v->mesh->nnodes;
    v->d = malloc(6 * nn * sizeof *v->d);
    v->xyz = malloc(3 * nn * sizeof *v->xyz);
    v->trans = malloc(3 * nn * sizeof *v->trans);
    v->rot = malloc(3 * nn * sizeof *v->rot);
    if (!v->d || !v->xyz || !v->trans || !v->rot)
        return dm_fail(err, DM_ENOMEM, "out of memory (--vtk)");
    return DM_OK;
}

/* Room for one more frame's time and file name. */
static int traj_vtk_grow(dm_cli_traj_vtk *v, dm_error *err)
{
    if (v->n < v->cap)
        return DM_OK;
    long cap = v->cap ? 2 * v->cap : 64;
    double *t = realloc(v->t, cap * sizeof *t);
    if (t)
        v->t = t;
    char **file = t ? realloc(v->file, cap * sizeof *file) : NULL;
    if (!file)
        return dm_fail(err, DM_ENOMEM, "out of memory (--vtk)");
    v->file = file;
    v->cap = cap;
    return DM_OK;
}

int dm_cli_traj_vtk_frame(dm_cli_traj_vtk *v, const dm_integ_sample *s, dm_error *err)
{
    if (v->seen++ % v->every)
        return DM_OK;
    if (!s->model || !s->x)
        return dm_fail(err, DM_EINVAL, "--vtk: this run keeps no state of the robot to draw "
                       "(--rigid, or --integrator closed-form without the reference: use "
                       "cvode or full)");
    int rc = v->mesh ? DM_OK : traj_vtk_alloc(v, s->model, err);
    if (!rc)
        rc = traj_vtk_grow(v, err);
    if (rc)
        return rc;
    dm_shape_mesh_update(v->mesh, s->model);
    dm_shape_displace(v->mesh, s->x, v->d);
    dm_shape_deformed(v->mesh, v->d, v->magnify, v->xyz);
    dm_shape_split(v->mesh, v->d, 1.0, v->trans, v->rot);
    char name[64], path[1200];
    snprintf(name, sizeof name, "frame_%06ld.vtu", v->seen - 1);
    snprintf(path, sizeof path, "%s/%s", v->dir, name);
    const dm_shape_mesh *m = v->mesh;
    const dm_vtk_array pd[] = {{"displacement", 3, m->nnodes, v->trans},
                               {"rotation", 3, m->nnodes, v->rot}};
    const dm_vtk_array fd[] = {{"time_s", 1, 1, &s->t_s},
                               {"magnification", 1, 1, &v->magnify},
                               {"platform_error", 6, 1, s->error}};
    dm_vtk_lines g = {m->nnodes, v->xyz, m->nlines, m->line, m->line_kind, "kind", 2, pd, 3, fd};
    if ((rc = dm_vtk_write_lines(path, &g, err)))
        return rc;
    if (!(v->file[v->n] = strdup(name)))
        return dm_fail(err, DM_ENOMEM, "out of memory (--vtk)");
    v->t[v->n++] = s->t_s;
    return DM_OK;
}

int dm_cli_traj_vtk_finish(dm_cli_traj_vtk *v, int ok, dm_error *err)
{
    int rc = DM_OK;
    char path[1200];
    if (ok) {
        snprintf(path, sizeof path, "%s/trajectory.pvd", v->dir);
        rc = dm_vtk_write_pvd(path, (int)v->n, v->t, (const char *const *)v->file, err);
    }
    for (long i = 0; i < v->n; i++) {
        if (!ok || rc) {
            snprintf(path, sizeof path, "%s/%s", v->dir, v->file[i]);
            remove(path);
        }
        free(v->file[i]);
    }
    free(v->file);
    free(v->t);
    free(v->d);
    free(v->xyz);
    free(v->trans);
    free(v->rot);
    dm_shape_mesh_free(v->mesh);
    return rc;
}
