/* dm_store — the map store: a Zarr v3 group on disk (docs/store.md).
 *
 * One array per quantity, each with `dimension_names`, `units` and a
 * regular chunk grid; chunks are files `NAME/c/i/j/k...` encoded with the
 * `bytes` codec (little-endian) followed by `crc32c` (4-byte checksum of
 * the bytes, appended little-endian). Metadata (`zarr.json`) is written
 * with jansson. Every file is written to a temporary name and renamed, so
 * a killed writer leaves either the old file or the new one, never half.
 * Temporary names carry the writer's host and PID (PATH.tmp.HOST.PID):
 * any number of processes, on any hosts, may write one store, and one
 * removes only the temporaries of writers that are gone.
 *
 * A dm_store handle is shared read-only by threads after creation; chunk
 * writes to distinct chunks are independent (no shared mutable state). */
#ifndef DM_STORE_H
#define DM_STORE_H

#include <stddef.h>
#include <stdint.h>

#include <jansson.h>

#include "dm_error.h"

#define DM_STORE_MAXDIM 5
#define DM_STORE_MAXARR 32
/* Limits on metadata read from disk: a chunk of at most 1 GiB (a sweep's
 * largest, a 1e6-point tile of 64 frequencies, is 512 MB), extents up to
 * 2^40. */
#define DM_STORE_MAX_CHUNK_BYTES (1LL << 30)
#define DM_STORE_MAX_EXTENT (1LL << 40)

typedef enum { DM_DTYPE_FLOAT64 = 0, DM_DTYPE_UINT8, DM_DTYPE_INT32 } dm_dtype;

typedef struct dm_array_spec {
    char name[48];
    dm_dtype dtype;
    int ndim;
    int64_t shape[DM_STORE_MAXDIM];
    int chunk[DM_STORE_MAXDIM];
    char dims[DM_STORE_MAXDIM][16];
    json_t *attributes;   /* owned by the spec list; units, long_name, ... */
} dm_array_spec;

typedef struct dm_store {
    char path[1024];
    int narr;
    dm_array_spec arr[DM_STORE_MAXARR];
    json_t *group_attributes;
} dm_store;

/* CRC-32C (Castagnoli), as the Zarr crc32c codec uses. */
uint32_t dm_crc32c(const void *data, size_t n);

size_t dm_dtype_size(dm_dtype t);

/* Write the group and array metadata (replacing what is there). */
int dm_store_write_metadata(const dm_store *store, dm_error *err);

/* Array a's metadata file (a = -1: the group's), the exact text
 * dm_store_write_metadata writes into it (*len bytes and a terminator;
 * caller frees; NULL: out of memory), and writing that one file
 * atomically. */
void dm_store_metadata_path(const dm_store *store, int a, char *out, size_t len);
char *dm_store_metadata_text(const dm_store *store, int a, size_t *len);
int dm_store_write_metadata_file(const dm_store *store, int a, dm_error *err);

/* Append an array to a store's layout (before dm_store_write_metadata):
 * ndim dimensions named dims[] of extent shape[] in chunks of chunk[];
 * attributes (units, long_name, ...) are owned by the store from now on.
 * The one way arrays are defined, by sweeps and trajectory runs alike. */
void dm_store_add_array(dm_store *store, const char *name, dm_dtype type, int ndim,
                        const int64_t *shape, const int *chunk, const char *const *dims,
                        json_t *attributes);

/* Read a store's metadata (for info/resume). Every field is checked:
 * known data_type, 1..DM_STORE_MAXDIM dimensions, whole extents, chunks of
 * at least one element per dimension and at most DM_STORE_MAX_CHUNK_BYTES,
 * array names that are one plain path component; DM_EINVAL names the file
 * and field otherwise (DM_EIO: missing or not JSON). Caller frees with
 * dm_store_release. */
int dm_store_read_metadata(const char *path, dm_store *store, dm_error *err);
void dm_store_release(dm_store *store);

/* The group's attributes alone (its zarr.json; NULL when it has none);
 * DM_EIO: missing or not JSON. Caller decrefs. */
int dm_store_read_group(const char *path, json_t **attributes, dm_error *err);

/* Chunk file of array a at chunk coordinates c[]. */
void dm_store_chunk_path(const dm_store *store, int a, const int64_t *c, char *out, size_t len);

/* Number of elements in one (full-size) chunk of array a. */
size_t dm_store_chunk_elems(const dm_store *store, int a);

/* Write one chunk atomically: data holds dm_store_chunk_elems() elements
 * in C order, native little-endian. The array's directory must exist (the
 * store's metadata written): a store removed under a writer is not
 * recreated piecemeal. */
int dm_store_write_chunk(const dm_store *store, int a, const int64_t *c, const void *data,
                         dm_error *err);

/* The bytes of a chunk file holding data (dm_store_chunk_elems()
 * elements): the elements, then their CRC-32C (caller frees; NULL: out of
 * memory). */
unsigned char *dm_store_encode_chunk(const dm_store *store, int a, const void *data, size_t *len);

/* The group's record of what made the store (attributes.deltamap: the
 * sweep's fingerprint, or a trajectory run's description) is what every
 * other file is checked against, so it carries its own checksum: seal
 * adds "crc32c", the CRC-32C of the record's canonical text (compact,
 * keys sorted) without it; sealed says whether it holds (a value edited in
 * the record would otherwise make every file it describes look damaged,
 * and a repair rewrite them to match). */
void dm_store_seal_record(json_t *record);
int dm_store_record_sealed(json_t *record);

/* The file at path against the bytes want[0..n-1] it should hold (a
 * metadata file, or a chunk file when chunk): *differs, and why in words
 * ("missing", "field 'shape[2]' is not what deltamap writes for this store", "not JSON
 * (...)", "too short (...)", "checksum mismatch (corrupt chunk)", "values
 * are not those deltamap writes ..."). Fails only for memory. */
int dm_store_compare_file(const char *path, const void *want, size_t n, int chunk, char *why,
                          size_t len, int *differs, dm_error *err);

/* Read and verify one chunk. Returns DM_OK, or DM_EIO with a message when
 * the file is missing, has the wrong size or fails its checksum; *missing
 * tells the first case apart. */
int dm_store_read_chunk(const dm_store *store, int a, const int64_t *c, void *data,
                        int *missing, dm_error *err);

/* Remove what dead writers left beside one chunk file (its temporaries). */
void dm_store_clean_chunk(const dm_store *store, int a, const int64_t *c);

#endif
