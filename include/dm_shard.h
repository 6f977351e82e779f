/* dm_shard — a fixed partition of a sweep's tiles among N processes.
 *
 * Tiles are numbered 0..T-1 in the store's chunk order (last spatial axis
 * fastest). Each run of N consecutive tiles gives exactly one tile to every
 * shard, so each shard holds T/N tiles (give or take one) spread evenly
 * over the whole grid: neighbouring tiles cost about the same (the edge of
 * the workspace, where points are unreachable and cheap, is shared by all
 * shards). Within run g the tiles are rotated by floor(frac(g phi) N), a
 * golden-ratio (Weyl) sequence, so that no shard gets the same place in
 * every run — with plain t mod N and N dividing a count of tiles along an
 * axis, one shard would get, say, the same z-slice throughout.
 *
 * The partition depends on integers only (tile number and N), never on
 * the robot or floating point: every process, on any machine, computes the
 * same one. docs/cluster.md compares it with block and modulo partitions. */
#ifndef DM_SHARD_H
#define DM_SHARD_H

/* The shard (0..count-1) that owns tile `tile` when the tiles are split
 * among `count` shards; count <= 1 gives 0. */
long dm_shard_of(long tile, long count);

#endif
