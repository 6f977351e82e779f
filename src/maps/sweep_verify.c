/* Checking a map store against the sweep it records (see sweep_impl.h,
 * docs/store.md "Integrity and resume"): every file a sweep derives from
 * its command — the group's and the arrays' metadata, the coordinate and
 * label chunks — is compared byte for byte with what this sweep writes,
 * since a file that parses can still say something else (a chunk_shape
 * edited, a unit replaced) and a reader would trust it. The data chunks
 * are checked by their checksums (sweep_census.c). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dm_robot.h"
#include "dm_trajstore.h"
#include "sweep_impl.h"

/* ---- the files a sweep derives ----------------------------------------------- */

typedef struct {
    const sweep_ctx *c;
    int repair;
    dm_sweep_damage_fn report;
    void *user;
    long found, repaired, chunks; /* chunks: of found, chunk files left as they are */
} check_run;

/* One file: its expected bytes, compared; reported, and rewritten when
 * repairing (a = -1: the group's metadata, never rewritten here). */
static int check_one(check_run *r, int a, int chunk, const void *want, size_t n, dm_error *err)
{
    char path[1200], why[300];
    const int64_t zero[1] = {0};
    if (chunk)
        dm_store_chunk_path(&r->c->store, a, zero, path, sizeof path);
    else
        dm_store_metadata_path(&r->c->store, a, path, sizeof path);
    int differs, rc = dm_store_compare_file(path, want, n, chunk, why, sizeof why, &differs, err);
    if (rc || !differs)
        return rc;
    r->found++;
    int fixed = 0;
    if (r->repair && a >= 0) {
        int rc = chunk ? dm_sweep_schema_write_coordinates_one(r->c, a, err)
                       : dm_store_write_metadata_file(&r->c->store, a, err);
        if (rc)
            return rc;
        fixed = 1;
        r->repaired++;
    }
    r->chunks += chunk && !fixed;
    if (r->report)
        r->report(r->user, path, why, fixed);
    return DM_OK;
}

int dm_sweep_schema_check(const sweep_ctx *c, int repair, dm_sweep_damage_fn report, void *user,
                          long *found, long *repaired, long *chunks, dm_error *err)
{
    check_run r = {c, repair, report, user, 0, 0, 0};
    int rc = DM_OK;
    for (int a = 0; a < c->store.narr && !rc; a++) {
        size_t n;
        char *text = dm_store_metadata_text(&c->store, a, &n);
        rc = text ? check_one(&r, a, 0, text, n, err) : dm_fail(err, DM_ENOMEM, "out of memory");
        free(text);
        if (rc || a < c->ndata)
            continue;
        void *v = malloc(dm_store_chunk_elems(&c->store, a) * dm_dtype_size(c->store.arr[a].dtype));
        unsigned char *bytes = NULL;
        if (v) {
            dm_sweep_schema_coordinate(c, a, v);
            bytes = dm_store_encode_chunk(&c->store, a, v, &n);
        }
        rc = bytes ? check_one(&r, a, 1, bytes, n, err) : dm_fail(err, DM_ENOMEM, "out of memory");
        free(v);
        free(bytes);
    }
    *found = r.found;
    if (repaired)
        *repaired = r.repaired;
    if (chunks)
        *chunks = r.chunks;
    return rc;
}

int dm_sweep_schema_check_group(const sweep_ctx *c, char *why, size_t len, dm_error *err)
{
    char path[1200];
    size_t n;
    int differs;
    char *text = dm_store_metadata_text(&c->store, -1, &n);
    if (!text)
        return dm_fail(err, DM_ENOMEM, "out of memory");
    dm_store_metadata_path(&c->store, -1, path, sizeof path);
    int rc = dm_store_compare_file(path, text, n, 0, why, len, &differs, err);
    free(text);
    if (!differs)
        why[0] = '\0';
    return rc;
}

/* ---- a store's own recorded sweep (deltamap info) ------------------------------ */

/* A band in degrees as recorded, back in radians: the double whose
 * degrees print as recorded (a neighbour of deg * pi / 180 at most a few
 * ulps away; tolerance_settings writes rad * 180 / pi). */
static double band_radians(double deg)
{
    double r = deg * M_PI / 180, lo = r, hi = r;
    for (int i = 0; i < 8; i++, lo = nextafter(lo, -INFINITY), hi = nextafter(hi, INFINITY)) {
        if (lo * 180 / M_PI == deg)
            return lo;
        if (hi * 180 / M_PI == deg)
            return hi;
    }
    return r;
}

static int whole_in(json_t *v, int lo, int hi, int *out)
{
    if (!json_is_integer(v) || json_integer_value(v) < lo || json_integer_value(v) > hi)
        return 0;
    *out = (int)json_integer_value(v);
    return 1;
}

/* The Monte Carlo's settings from the fingerprint's "tolerance". */
static int tolerance_from(json_t *t, dm_tolerance_spec *tol)
{
    dm_tolerance_spec_default(tol);
    json_t *bands = json_object_get(t, "tolerances");
    const char *dist = json_string_value(json_object_get(t, "distribution"));
    if (!json_is_integer(json_object_get(t, "samples")) || !json_is_integer(json_object_get(t, "seed")) ||
        !json_is_number(json_object_get(t, "spec_m")) || !dist || !json_is_object(bands))
        return 0;
    tol->samples = (long)json_integer_value(json_object_get(t, "samples"));
    tol->seed = (uint64_t)json_integer_value(json_object_get(t, "seed"));
    tol->spec_m = json_number_value(json_object_get(t, "spec_m"));
    tol->dist = !strcmp(dist, "normal") ? DM_TOL_NORMAL : DM_TOL_UNIFORM;
    for (int k = 0; k < DM_TOL_NGEOM; k++) {
        double v = json_number_value(json_object_get(bands, dm_tolerance_class_name(k)));
        tol->tol[k] = k == DM_TOL_THETA || k == DM_TOL_ALPHA0 ? band_radians(v) : v;
    }
    return 1;
}

/* The sweep a fingerprint records, as a context whose schema is defined
 * at path: 1 when its fingerprint is the recorded one again (so every file
 * the sweep derives can be compared), 0 when it is not one this version
 * makes. rb and g hold the robot and grid the context points to. */
static int sweep_from(json_t *fp, const char *path, sweep_ctx *c, dm_robot *rb, dm_grid *g)
{
    const char *ini = json_string_value(json_object_get(fp, "robot_ini"));
    const char *grid = json_string_value(json_object_get(fp, "grid"));
    json_t *mesh = json_object_get(fp, "mesh"), *tile = json_object_get(fp, "tile");
    json_t *move = json_object_get(fp, "move"), *tol = json_object_get(fp, "tolerance");
    dm_error e;
    memset(c, 0, sizeof *c);
    dm_sweep_opts_default(&c->o);
    if (!ini || !grid || dm_robot_parse_string(ini, "the store's fingerprint", rb, &e) ||
        dm_grid_parse(grid, g, &e) || !whole_in(json_object_get(fp, "modes"), 1, DM_MAX_MODES, &c->k) ||
        !whole_in(json_array_get(mesh, 0), 1, 64, &c->na) ||
        !whole_in(json_array_get(mesh, 1), 1, 64, &c->nb) ||
        !json_is_boolean(json_object_get(fp, "dynamic")) || !json_is_object(move) ||
        (tol && !tolerance_from(tol, &c->tol)))
        return 0;
    for (int d = 0; d < 3; d++)
        if (!whole_in(json_array_get(tile, (size_t)d), 1, g->axis[d].count, &c->tile[d]))
            return 0;
    c->rb = rb;
    c->grid = g;
    c->o.dynamic = json_is_true(json_object_get(fp, "dynamic"));
    c->o.move.amax_ms2 = json_number_value(json_object_get(move, "amax_ms2"));
    c->o.move.tau_s = json_number_value(json_object_get(move, "tau_s"));
    c->o.move.tol_m = json_number_value(json_object_get(move, "tol_m"));
    c->o.move.window_s = json_number_value(json_object_get(move, "window_s"));
    c->o.move.quasi_static = json_is_true(json_object_get(move, "quasi_static"));
    c->o.tolerance = tol != NULL;
    const char *method = json_string_value(json_object_get(fp, "method"));
    c->o.members = method && !strcmp(method, "members"); /* else the fingerprints differ */
    c->ndata = dm_sweep_ndata(tol != NULL, c->tol.spec_m);
    dm_sweep_schema_define(c, path);
    json_t *again = json_object_get(json_object_get(c->store.group_attributes, "deltamap"),
                                    "fingerprint");
    if (json_equal(again, fp))
        return 1;
    dm_store_release(&c->store);
    return 0;
}

/* A store read as its metadata says (another version's, or one whose
 * sweep cannot be rebuilt): the one-dimensional arrays' chunks (the
 * coordinates and labels; the data arrays' are the census's) by their
 * checksums. */
static int check_axes(dm_sweep_check *chk, dm_sweep_damage_fn report, void *user, dm_error *err)
{
    for (int a = 0; a < chk->store.narr; a++) {
        const dm_array_spec *s = &chk->store.arr[a];
        if (s->ndim != 1)
            continue;
        void *buf = malloc(dm_store_chunk_elems(&chk->store, a) * dm_dtype_size(s->dtype));
        if (!buf)
            return dm_fail(err, DM_ENOMEM, "out of memory");
        for (int64_t c = 0; c * s->chunk[0] < s->shape[0]; c++) {
            int missing;
            dm_error e;
            if (dm_store_read_chunk(&chk->store, a, &c, buf, &missing, &e)) {
                chk->problems++;
                chk->chunk_problems++;
                if (report)
                    report(user, e.msg, missing ? "missing" : "corrupt", 0);
            }
        }
        free(buf);
    }
    return DM_OK;
}

int dm_sweep_check_open(const char *path, int repair, dm_sweep_damage_fn report, void *user,
                        dm_sweep_check *chk, dm_error *err)
{
    json_t *attrs = NULL;
    memset(chk, 0, sizeof *chk);
    int rc = dm_store_read_group(path, &attrs, err);
    if (rc)
        return rc;
    if (dm_trajstore_is(attrs)) {
        rc = dm_trajstore_check(path, attrs, repair, report, user, chk, err);
        json_decref(attrs);
        return rc;
    }
    json_t *fp = json_object_get(json_object_get(attrs, "deltamap"), "fingerprint");
    const char *tool = json_string_value(json_object_get(json_object_get(attrs, "deltamap"), "tool"));
    const char *version = json_string_value(json_object_get(fp, "version"));
    snprintf(chk->made_by, sizeof chk->made_by, "%s", tool ? tool : version ? version : "");
    chk->other_version = version && strcmp(version, DM_SWEEP_VERSION);
    int sealed = dm_store_record_sealed(json_object_get(attrs, "deltamap"));
    sweep_ctx *c = calloc(1, sizeof *c);
    dm_robot *rb = malloc(sizeof *rb);
    dm_grid *g = malloc(sizeof *g);
    if (!c || !rb || !g)
        rc = dm_fail(err, DM_ENOMEM, "out of memory");
    else if (fp && !chk->other_version && sealed && sweep_from(fp, path, c, rb, g)) {
        char why[500], file[1100];
        long found, repaired, chunks;
        chk->verified = 1;
        if (!(rc = dm_sweep_schema_check_group(c, why, sizeof why, err)) && why[0]) {
            chk->problems++;
            snprintf(file, sizeof file, "%s/zarr.json", path);
            /* it names the sweep: never rewritten */
            snprintf(why + strlen(why), sizeof why - strlen(why), "; it names the sweep, so it "
                     "is not rewritten, and the sweep command refuses the store (--replace "
                     "replaces it)");
            if (report)
                report(user, file, why, 0);
        }
        if (!rc && !(rc = dm_sweep_schema_check(c, repair, report, user, &found, &repaired, &chunks,
                                                err))) {
            chk->problems += found;
            chk->repaired = repaired;
            chk->chunk_problems = chunks;
        }
        chk->store = c->store; /* the layout the chunks are read by: the sweep's own */
    } else {
        if (!chk->other_version) { /* no sweep this version makes: the files say what they are */
            char file[1100];
            snprintf(file, sizeof file, "%s/zarr.json", path);
            chk->problems++;
            if (report)
                report(user, file, !sealed ? "attributes.deltamap fails its checksum (crc32c): "
                                             "the sweep it records cannot be trusted, nothing is "
                                             "checked or repaired against it"
                                   : fp ? "its fingerprint is not one of a sweep this version makes"
                                        : "records no sweep (attributes.deltamap.fingerprint)", 0);
        }
        rc = dm_store_read_metadata(path, &chk->store, err);
        if (!rc)
            rc = check_axes(chk, report, user, err);
    }
    json_decref(attrs);
    free(c);
    free(rb);
    free(g);
    if (rc)
        dm_store_release(&chk->store);
    return rc;
}

void dm_sweep_check_close(dm_sweep_check *chk)
{
    dm_store_release(&chk->store);
}
