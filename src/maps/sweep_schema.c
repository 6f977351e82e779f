/* The map store's schema: one definition of each stored array, its
 * attributes, the sweep's fingerprint, the coordinate arrays (see
 * sweep_impl.h, docs/store.md). */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sweep_impl.h"

/* The fourth dimensions (X_*): name, its label array's long_name, length
 * (the mode dimension's is the sweep's k). */
static const struct {
    const char *name, *labels;
    int len;
} EXTRA_DIM[] = {
    [X_NONE] = {"", "", 1},
    [X_MODE] = {"mode", "mode rank, 1 = lowest", 0},
    [X_COMPONENT] = {"component", "dx dy dz ex ey ez", 6},
    [X_AXIS] = {"axis", "x y z", 3},
    [X_MOVE] = {"move", "X Y Z", 3},
};

static void status_flags(json_t *at)
{
    json_object_set_new(at, "flag_meanings", json_string("ok unreachable near_singular solver_failure"));
}

/* code -> name: source_names[code] (a JSON list), and the CF convention's
 * flag_values / flag_meanings, for xarray users */
static void source_flags(json_t *at)
{
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

/* the point result's field f: offset and size */
#define FIELD(f) offsetof(dm_point_result, f), sizeof(((dm_point_result *)0)->f)

const dm_sweep_array dm_sweep_arrays[] = {
    {"status", DM_DTYPE_UINT8, X_NONE, G_CORE, "1",
     "0 ok, 1 unreachable, 2 near-singular, 3 solver failure, 255 not computed", status_flags,
     FIELD(status), DM_POINT_NOT_COMPUTED},
    {"frequencies_hz", DM_DTYPE_FLOAT64, X_MODE, G_CORE, "Hz", "natural frequencies, ascending",
     NULL, FIELD(freq_hz), NAN},
    {"frequencies_tracked_hz", DM_DTYPE_FLOAT64, X_MODE, G_CORE, "Hz",
     "frequencies of mode families followed by MAC", NULL, FIELD(tracked_hz), NAN},
    {"static_error", DM_DTYPE_FLOAT64, X_COMPONENT, G_CORE, "m, rad",
     "platform error under gravity: dx, dy, dz (m), ex, ey, ez (rad)", NULL, FIELD(static_error),
     NAN},
    {"compliance_max", DM_DTYPE_FLOAT64, X_NONE, G_CORE, "m/N",
     "largest translational compliance at P", NULL, FIELD(compliance_max), NAN},
    {"compliance_direction", DM_DTYPE_FLOAT64, X_AXIS, G_CORE, "1",
     "direction of the largest compliance", NULL, FIELD(compliance_dir), NAN},
    {"stiffness_min", DM_DTYPE_FLOAT64, X_NONE, G_CORE, "N/m",
     "smallest translational stiffness at P (1/compliance_max)", NULL, FIELD(stiffness_min), NAN},
    {"singularity", DM_DTYPE_FLOAT64, X_NONE, G_CORE, "1",
     "condition number of the kinematic Jacobian", NULL, FIELD(singularity), NAN},
    {"move_peak_m", DM_DTYPE_FLOAT64, X_MOVE, G_CORE, "m",
     "standard move: peak |Delta - Delta_static| during the move", NULL, FIELD(move_peak), NAN},
    {"move_residual_m", DM_DTYPE_FLOAT64, X_MOVE, G_CORE, "m",
     "standard move: residual vibration amplitude after it", NULL, FIELD(move_residual), NAN},
    {"move_settling_s", DM_DTYPE_FLOAT64, X_MOVE, G_CORE, "s",
     "standard move: settling time after it (inf: never)", NULL, FIELD(move_settling), NAN},
    {"coupling_index_log10", DM_DTYPE_FLOAT64, X_NONE, G_CORE, "1",
     "Zheng's coupling index: log10 det K (depends on mesh and DOF units)", NULL,
     FIELD(coupling_index_log10), NAN},
    {"coupling_index_change_log10", DM_DTYPE_FLOAT64, X_NONE, G_CORE, "1",
     "coupling index minus the nominal robot's (no effects) at the same pose and mesh; 0 "
     "without effects",
     NULL, FIELD(coupling_change_log10), NAN},
    {"error_mean_m", DM_DTYPE_FLOAT64, X_NONE, G_TOLERANCE, "m",
     "tolerance Monte Carlo: mean platform |error|", NULL, FIELD(error_mean_m), NAN},
    {"error_p95_m", DM_DTYPE_FLOAT64, X_NONE, G_TOLERANCE, "m",
     "tolerance Monte Carlo: 95th percentile of the platform |error|", NULL, FIELD(error_p95_m),
     NAN},
    {"error_max_m", DM_DTYPE_FLOAT64, X_NONE, G_TOLERANCE, "m",
     "tolerance Monte Carlo: largest platform |error| sampled", NULL, FIELD(error_max_m), NAN},
    {"dominant_source", DM_DTYPE_INT32, X_NONE, G_TOLERANCE, "1",
     "tolerance contributing most to the error's spread (linearised); -1 none", source_flags,
     FIELD(dominant_source), -1},
    {"p_exceed_spec", DM_DTYPE_FLOAT64, X_NONE, G_SPEC, "1",
     "tolerance Monte Carlo: share of samples with |error| > spec", NULL, FIELD(p_exceed_spec),
     NAN},
};
const int dm_sweep_narrays = sizeof dm_sweep_arrays / sizeof dm_sweep_arrays[0];

int dm_sweep_ndata(int tolerance, double spec_m)
{
    int last = !tolerance ? G_CORE : spec_m > 0 ? G_SPEC : G_TOLERANCE, n = 0;
    while (n < dm_sweep_narrays && dm_sweep_arrays[n].group <= last)
        n++;
    return n;
}

int dm_sweep_extra_len(int extra, int k)
{
    return extra == X_MODE ? k : EXTRA_DIM[extra].len;
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
    if (c->o.members) /* likewise: the full model's stores keep theirs */
        json_object_set_new(f, "method", json_string("members"));
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
        shape[3] = chunk[3] = dm_sweep_extra_len(d->extra, c->k);
        dims[3] = EXTRA_DIM[d->extra].name;
        json_t *at = attrs(d->units, d->long_name);
        if (d->group >= G_TOLERANCE)
            json_object_set_new(at, "tolerance", tolerance_settings(c));
        if (d->cf_attributes)
            d->cf_attributes(at);
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
    for (int x = X_MODE; x <= X_MOVE; x++) {
        int len = dm_sweep_extra_len(x, c->k);
        int64_t shape[1] = {len};
        int chunk[1] = {len};
        const char *dn[1] = {EXTRA_DIM[x].name};
        dm_store_add_array(st, EXTRA_DIM[x].name, DM_DTYPE_INT32, 1, shape, chunk, dn,
                           attrs("1", EXTRA_DIM[x].labels));
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
    int first = i - 3 + X_MODE == X_MODE; /* label arrays in X_* order */
    size_t n = dm_store_chunk_elems(&c->store, a);
    for (size_t j = 0; j < n; j++)
        ((int32_t *)out)[j] = (int32_t)j + first;
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
