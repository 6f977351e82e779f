/* The map store's schema: one definition of each stored array, its
 * attributes, the sweep's fingerprint, the coordinate arrays (see
 * sweep_impl.h, docs/store.md). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sweep_impl.h"

static const char *const EXTRA_DIM[] = {"", "mode", "component", "axis", "move"};

const dm_sweep_array dm_sweep_arrays[N_DATA] = {
    {"status", DM_DTYPE_UINT8, X_NONE, "1", "0 ok, 1 unreachable, 2 near-singular, 3 solver failure, 255 not computed"},
    {"frequencies_hz", DM_DTYPE_FLOAT64, X_MODE, "Hz", "natural frequencies, ascending"},
    {"frequencies_tracked_hz", DM_DTYPE_FLOAT64, X_MODE, "Hz", "frequencies of mode families followed by MAC"},
    {"static_error", DM_DTYPE_FLOAT64, X_COMPONENT, "m, rad", "platform error under gravity: dx, dy, dz (m), ex, ey, ez (rad)"},
    {"compliance_max", DM_DTYPE_FLOAT64, X_NONE, "m/N", "largest translational compliance at P"},
    {"compliance_direction", DM_DTYPE_FLOAT64, X_AXIS, "1", "direction of the largest compliance"},
    {"stiffness_min", DM_DTYPE_FLOAT64, X_NONE, "N/m", "smallest translational stiffness at P (1/compliance_max)"},
    {"singularity", DM_DTYPE_FLOAT64, X_NONE, "1", "condition number of the kinematic Jacobian"},
    {"move_peak_m", DM_DTYPE_FLOAT64, X_MOVE, "m", "standard move: peak |Delta - Delta_static| during the move"},
    {"move_residual_m", DM_DTYPE_FLOAT64, X_MOVE, "m", "standard move: residual vibration amplitude after it"},
    {"move_settling_s", DM_DTYPE_FLOAT64, X_MOVE, "s", "standard move: settling time after it (inf: never)"},
    {"coupling_index_log10", DM_DTYPE_FLOAT64, X_NONE, "1", "Zheng's coupling index: log10 det K (depends on mesh and DOF units)"},
    {"coupling_index_change_log10", DM_DTYPE_FLOAT64, X_NONE, "1", "coupling index minus the nominal robot's (no effects) at the same pose and mesh; 0 without effects"},
    /* the tolerance Monte Carlo's (only with it) */
    {"error_mean_m", DM_DTYPE_FLOAT64, X_NONE, "m", "tolerance Monte Carlo: mean platform |error|"},
    {"error_p95_m", DM_DTYPE_FLOAT64, X_NONE, "m", "tolerance Monte Carlo: 95th percentile of the platform |error|"},
    {"error_max_m", DM_DTYPE_FLOAT64, X_NONE, "m", "tolerance Monte Carlo: largest platform |error| sampled"},
    {"dominant_source", DM_DTYPE_INT32, X_NONE, "1", "tolerance contributing most to the error's spread (linearised); -1 none"},
    {"p_exceed_spec", DM_DTYPE_FLOAT64, X_NONE, "1", "tolerance Monte Carlo: share of samples with |error| > spec"},
};

static int extra_len(int x, int k)
{
    return x == X_MODE ? k : x == X_COMPONENT ? 6 : x == X_AXIS ? 3 : x == X_MOVE ? 3 : 1;
}


static json_t *attrs(const char *units, const char *long_name)
{
    return json_pack("{s:s, s:s}", "units", units, "long_name", long_name);
}

/* The Monte Carlo's settings: in the fingerprint and the maps' attributes. */
static json_t *tolerance_settings(const sweep_ctx *c)
{
    const dm_tolerance_spec *t = &c->tol;
    json_t *bands = json_object();
    for (int k = 0; k < DM_TOL_NGEOM; k++) /* as --tol takes them: m, and degrees for *_deg */
        json_object_set_new(bands, dm_tolerance_class_name(k),
                            json_real(k == DM_TOL_THETA || k == DM_TOL_ALPHA0
                                          ? t->tol[k] * 180 / M_PI : t->tol[k]));
    return json_pack("{s:I, s:I, s:f, s:s, s:o}", "samples", (json_int_t)t->samples, "seed",
                     (json_int_t)t->seed, "spec_m", t->spec_m, "distribution",
                     t->dist == DM_TOL_UNIFORM ? "uniform" : "normal", "tolerances", bands);
}

static json_t *fingerprint(const sweep_ctx *c)
{
    char *ini = NULL, grid[512];
    size_t len = 0;
    FILE *mem = open_memstream(&ini, &len);
    dm_robot_write(c->rb, mem);
    fclose(mem);
    dm_grid_format(c->grid, grid, sizeof grid);
    const dm_move_opts *m = &c->o.move;
    json_t *f = json_pack("{s:s, s:s, s:s, s:i, s:[ii], s:[iii], s:b, s:{s:f, s:f, s:f, s:f, s:b}}",
                          "version", DM_SWEEP_VERSION, "robot_ini", ini, "grid", grid, "modes",
                          c->k, "mesh", c->na, c->nb, "tile", c->tile[0], c->tile[1], c->tile[2],
                          "dynamic", c->o.dynamic, "move", "amax_ms2", m->amax_ms2, "tau_s",
                          m->tau_s, "tol_m", m->tol_m, "window_s", m->window_s, "quasi_static",
                          m->quasi_static);
    free(ini);
    if (c->o.tolerance) /* absent otherwise: stores without the maps keep their fingerprint */
        json_object_set_new(f, "tolerance", tolerance_settings(c));
    return f;
}

void dm_sweep_schema_define(sweep_ctx *c, const char *path)
{
    dm_store *st = &c->store;
    const dm_grid *g = c->grid;
    memset(st, 0, sizeof *st);
    snprintf(st->path, sizeof st->path, "%s", path);
    const char *dims[4] = {g->axis[0].name, g->axis[1].name, g->axis[2].name, ""};
    for (int a = 0; a < c->ndata; a++) {
        const dm_sweep_array *d = &dm_sweep_arrays[a];
        int64_t shape[4];
        int chunk[4], nd = 3 + (d->extra != X_NONE);
        for (int i = 0; i < 3; i++) {
            shape[i] = g->axis[i].count;
            chunk[i] = c->tile[i];
        }
        shape[3] = chunk[3] = extra_len(d->extra, c->k);
        dims[3] = EXTRA_DIM[d->extra];
        json_t *at = attrs(d->units, d->long_name);
        if (a == A_STATUS)
            json_object_set_new(at, "flag_meanings",
                                json_string("ok unreachable near_singular solver_failure"));
        if (a >= N_CORE)
            json_object_set_new(at, "tolerance", tolerance_settings(c));
        if (a == A_DOMINANT) {
            /* code -> name: source_names[code] (a JSON list), and the CF
             * convention's flag_values / flag_meanings, for xarray users */
            json_t *names = json_array(), *values = json_array();
            char meanings[512] = "none";
            json_array_append_new(values, json_integer(-1));
            for (int k = 0; k < DM_TOL_NCLASS; k++) {
                json_array_append_new(names, json_string(dm_tolerance_class_name(k)));
                json_array_append_new(values, json_integer(k));
                size_t used = strlen(meanings);
                snprintf(meanings + used, sizeof meanings - used, " %s", dm_tolerance_class_name(k));
            }
            json_object_set_new(at, "source_names", names);
            json_object_set_new(at, "flag_values", values);
            json_object_set_new(at, "flag_meanings", json_string(meanings));
        }
        dm_store_add_array(st, d->name, d->dtype, nd, shape, chunk, dims, at);
    }
    static const char *const unit_of[2][3] = {{"m", "m", "m"}, {"m", "degree", "m"}};
    for (int i = 0; i < 3; i++) {
        int64_t shape[1] = {g->axis[i].count};
        int chunk[1] = {g->axis[i].count};
        const char *dn[1] = {g->axis[i].name};
        dm_store_add_array(st, g->axis[i].name, DM_DTYPE_FLOAT64, 1, shape, chunk, dn,
                  attrs(unit_of[g->kind][i], "grid coordinate"));
    }
    static const char *const xnames[4] = {"mode", "component", "axis", "move"};
    const int xlen[4] = {c->k, 6, 3, 3};
    static const char *const labels[4] = {"mode rank, 1 = lowest", "dx dy dz ex ey ez",
                                          "x y z", "X Y Z"};
    for (int i = 0; i < 4; i++) {
        int64_t shape[1] = {xlen[i]};
        int chunk[1] = {xlen[i]};
        const char *dn[1] = {xnames[i]};
        json_t *at = attrs("1", labels[i]);
        dm_store_add_array(st, xnames[i], DM_DTYPE_INT32, 1, shape, chunk, dn, at);
    }
    json_t *names = json_array();
    for (int a = 0; a < st->narr; a++)
        json_array_append_new(names, json_string(st->arr[a].name));
    char grid[512];
    dm_grid_format(g, grid, sizeof grid);
    json_t *dm = json_pack("{s:s, s:s, s:s, s:s, s:o, s:o}", "tool", DM_SWEEP_VERSION, "robot",
                           c->rb->name, "grid", grid, "grid_kind",
                           g->kind ? "cylindrical" : "cartesian", "arrays", names, "fingerprint",
                           fingerprint(c));
    dm_store_seal_record(dm);
    st->group_attributes = json_pack("{s:s, s:o}", "title", "deltamap workspace maps", "deltamap", dm);
}

/* The values of coordinate or label array a (c->ndata and after) into
 * out, dm_store_chunk_elems() of them: the grid's positions, or the
 * indices of an extra dimension (modes from 1 = lowest, the rest from 0). */
void dm_sweep_schema_coordinate(const sweep_ctx *c, int a, void *out)
{
    int i = a - c->ndata;
    if (i < 3) {
        const dm_grid_axis *ax = &c->grid->axis[i];
        for (int j = 0; j < ax->count; j++)
            ((double *)out)[j] = dm_grid_value(ax, j);
        return;
    }
    size_t n = dm_store_chunk_elems(&c->store, a);
    for (size_t j = 0; j < n; j++)
        ((int32_t *)out)[j] = (int32_t)j + (i == 3);
}

int dm_sweep_schema_write_coordinates_one(const sweep_ctx *c, int a, dm_error *err)
{
    const int64_t zero[1] = {0};
    void *v = malloc(dm_store_chunk_elems(&c->store, a) * dm_dtype_size(c->store.arr[a].dtype));
    if (!v)
        return dm_fail(err, DM_ENOMEM, "out of memory");
    dm_sweep_schema_coordinate(c, a, v);
    int rc = dm_store_write_chunk(&c->store, a, zero, v, err);
    free(v);
    return rc;
}

int dm_sweep_schema_write_coordinates(const sweep_ctx *c, dm_error *err)
{
    int rc = DM_OK;
    for (int a = c->ndata; a < c->ndata + N_AXES_LABELS && !rc; a++)
        rc = dm_sweep_schema_write_coordinates_one(c, a, err);
    return rc;
}
