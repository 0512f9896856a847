/*
 * build_grid.cl — photon orderings built on the device for the accelerated gathers
 * (cl_gather.h; thesis ch. 7.3):
 *
 *   per-mesh uniform grid (thesis eq. 7.1), as the CPU's photon_grid.h builds it:
 *     grid_bounds    per-mesh bounds and counts: a work-group reduces in local memory, then one
 *                    atomic_min/atomic_max per mesh on order-preserving ints (grid_shared.h);
 *     (host)         the headers from the bounds: photon_grid.h's mesh_grid_header, shared code;
 *     key_grid_bin   each photon's global bin = first_bin(mesh) + eq. 7.1 offset, counted with
 *                    atomic_inc ("photons scattered into bins with atomic counters"), whose old
 *                    value is the photon's rank in its bin;
 *     scan_*         exclusive prefix sum of the counts → the bin-start table cell_start;
 *     scatter_keys   each photon to cell_start[bin] + rank (a separate kernel);
 *     sort_ranges    each bin's photon indices ascending (a shell sort per bin; bins hold few
 *                    photons), which makes the scatter's arbitrary order deterministic — the
 *                    result is the CPU's stable counting sort, byte for byte;
 *     permute        photons[i] = input[order[i]].
 *   per-mesh arrays ("photon sorting", Table 7.3): a stable counting sort by mesh in chunks of
 *     PF_CHUNK photons (mesh_chunk_count, one exclusive scan over the mesh-major count matrix,
 *     mesh_chunk_scatter), deterministic without atomics; mesh_start[m] .. mesh_start[m+1].
 *   hashed grid (`hash-grid`): key_hash_cell gives each photon its table slot (grid_shared.h),
 *     then the same count / scan / scatter / sort kernels as the per-mesh grid, and
 *     permute_photons_keys, which writes the sorted photons as the gather reads them: keys
 *     (position, mesh, direct flag) in blocks of four photons and a 24-byte payload (direction,
 *     flux) per photon.
 */
#pragma OPENCL FP_CONTRACT OFF
#include "photonflow/foundations/shared_types.h"
#include "photonflow/stages/grid_shared.h"

#define PF_CHUNK 256
#define PF_SCAN_ITEMS 16 /* entries per work-item of scan_blocks (kScanItems in cl_scan_sort.cpp) */

/* bounds[8·m + 0..2] = ordered lo, 3..5 = ordered hi, 6 = count (host initialises lo to INT_MAX,
 * hi to INT_MIN, count to 0). Meshes mesh_first .. mesh_first + span − 1 only; `lb` holds 7·span
 * ints of local memory. */
__kernel void grid_bounds(__global const pf_photon* ph, int n, int mesh_first, int span,
                          __global int* bounds, __local int* lb) {
  const int lid = (int)get_local_id(0), L = (int)get_local_size(0);
  for (int k = lid; k < 7 * span; k += L) {
    const int f = k % 7;
    lb[k] = f < 3 ? INT_MAX : (f < 6 ? INT_MIN : 0);
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  const int i = (int)get_global_id(0);
  if (i < n) {
    const int m = ph[i].mesh - mesh_first;
    if (m >= 0 && m < span) {
      for (int a = 0; a < 3; ++a) {
        const int o = pf_float_ordered(ph[i].position[a]);
        atomic_min(&lb[7 * m + a], o);
        atomic_max(&lb[7 * m + 3 + a], o);
      }
      atomic_inc(&lb[7 * m + 6]);
    }
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int k = lid; k < 7 * span; k += L) {
    const int m = k / 7, f = k % 7;
    if (lb[7 * m + 6] == 0) continue; /* no photon of this mesh in this work-group */
    __global int* b = &bounds[8 * (mesh_first + m) + f];
    if (f < 3) atomic_min(b, lb[k]);
    else if (f < 6) atomic_max(b, lb[k]);
    else atomic_add(b, lb[k]);
  }
}

/* key[i] = global bin of photon i (first_bin + eq. 7.1 offset); counts[key]++. */
__kernel void key_grid_bin(__global const pf_photon* ph, int n, __global const pf_mesh_grid* mg,
                           __global int* key, __global int* rank, __global int* counts) {
  const int i = (int)get_global_id(0);
  if (i >= n) return;
  __global const pf_mesh_grid* g = &mg[ph[i].mesh];
  const int k = g->first_bin + pf_grid_bin(g, ph[i].position[0], ph[i].position[1],
                                           ph[i].position[2]);
  key[i] = k;
  rank[i] = atomic_inc(&counts[k]);
}

/* key[i] = table slot of photon i's cell in the hashed grid (grid_shared.h); counts[key]++. */
__kernel void key_hash_cell(__global const pf_photon* ph, int n, float ox, float oy, float oz,
                            float cell, int nx, int ny, int nz, uint mask, __global int* key,
                            __global int* rank, __global int* counts) {
  const int i = (int)get_global_id(0);
  if (i >= n) return;
  const int cx = pf_grid_coord(ph[i].position[0], ox, cell, nx);
  const int cy = pf_grid_coord(ph[i].position[1], oy, cell, ny);
  const int cz = pf_grid_coord(ph[i].position[2], oz, cell, nz);
  const int k = (int)pf_hash_slot(cx, cy, cz, (uint)nx, (uint)ny, mask);
  key[i] = k;
  rank[i] = atomic_inc(&counts[k]);
}

/* order[start[key[i]] + rank[i]] = i: each photon to the place its counter gave it (rank = the
 * count before its atomic_inc, a distinct slot of its range in whatever order the atomics ran). */
__kernel void scatter_keys(__global const int* key, __global const int* rank, int n,
                           __global const int* start, __global int* order) {
  const int i = (int)get_global_id(0);
  if (i >= n) return;
  order[start[key[i]] + rank[i]] = i;
}

/* Range r = order[start[r] .. start[r+1]) (the last range ends at `total`) sorted ascending:
 * shell sort with the gaps 701, 301, 132, 57, 23, 10, 4, 1 (Ciura 2001). */
__kernel void sort_ranges(__global const int* start, int ranges, int total,
                          __global int* order) {
  const int r = (int)get_global_id(0);
  if (r >= ranges) return;
  const int begin = start[r], end = r + 1 < ranges ? start[r + 1] : total;
  const int n = end - begin;
  if (n < 2) return;
  __global int* a = &order[begin];
  const int gaps[8] = {701, 301, 132, 57, 23, 10, 4, 1};
  for (int gi = 0; gi < 8; ++gi) {
    const int gap = gaps[gi];
    for (int i = gap; i < n; ++i) {
      const int x = a[i];
      int j = i;
      while (j >= gap && a[j - gap] > x) {
        a[j] = a[j - gap];
        j -= gap;
      }
      a[j] = x;
    }
  }
}

/* out[i] = in[order[i]]. */
__kernel void permute_photons(__global const pf_photon* in, __global const int* order, int n,
                              __global pf_photon* out) {
  const int i = (int)get_global_id(0);
  if (i >= n) return;
  out[i] = in[order[i]];
}

/* The same permutation into the hashed grid's two arrays (hash_grid.h): lane i % 4 of key block
 * i / 4 = position and pf_photon_hash_key, payload[i] = direction and flux,
 * of photon order[i]. Work-items n .. 4·ceil(n / 4) − 1 zero the last block's unused lanes. */
__kernel void permute_photons_keys(__global const pf_photon* in, __global const int* order, int n,
                                   __global pf_photon_keys4* keys,
                                   __global pf_photon_payload* payload) {
  const int i = (int)get_global_id(0);
  if (i >= (n + 3) / 4 * 4) return;
  __global pf_photon_keys4* b = &keys[i / 4];
  const int l = i % 4;
  if (i >= n) {
    b->x[l] = b->y[l] = b->z[l] = 0.0f;
    b->key[l] = 0;
    return;
  }
  __global const pf_photon* p = &in[order[i]];
  b->x[l] = p->position[0];
  b->y[l] = p->position[1];
  b->z[l] = p->position[2];
  b->key[l] = pf_photon_hash_key(p->mesh, p->flags);
  for (int a = 0; a < 3; ++a) {
    payload[i].dir[a] = p->dir[a];
    payload[i].flux[a] = p->flux[a];
  }
}

/* ---- stable counting sort by mesh, in chunks ------------------------------------------------- */

/* counts[m·chunks + c] = photons of mesh m in chunk c (photons c·PF_CHUNK ..); one work-item per
 * chunk, so no atomics. counts must be zero on entry. */
__kernel void mesh_chunk_count(__global const pf_photon* ph, int n, int chunks,
                               __global int* counts) {
  const int c = (int)get_global_id(0);
  if (c >= chunks) return;
  const int end = min(n, (c + 1) * PF_CHUNK);
  for (int i = c * PF_CHUNK; i < end; ++i) counts[ph[i].mesh * chunks + c] += 1;
}

/* mesh_start[m] = offsets[m·chunks] (the scanned counts), mesh_start[mesh_count] = n. */
__kernel void mesh_starts(__global const int* offsets, int chunks, int mesh_count, int n,
                          __global int* mesh_start) {
  const int m = (int)get_global_id(0);
  if (m > mesh_count) return;
  mesh_start[m] = m < mesh_count ? offsets[m * chunks] : n;
}

/* Chunk c writes its photons, in index order, from the cursors offsets[m·chunks + c]. */
__kernel void mesh_chunk_scatter(__global const pf_photon* ph, int n, int chunks,
                                 __global int* offsets, __global int* order) {
  const int c = (int)get_global_id(0);
  if (c >= chunks) return;
  const int end = min(n, (c + 1) * PF_CHUNK);
  for (int i = c * PF_CHUNK; i < end; ++i) order[offsets[ph[i].mesh * chunks + c]++] = i;
}

/* ---- exclusive prefix sum ----------------------------------------------------------------- */

/* In place over data[0 .. n): each work-group scans PF_SCAN_ITEMS·L entries (PF_SCAN_ITEMS
 * consecutive ones per work-item, then a Hillis–Steele scan of the L partial sums in local memory)
 * and writes its total to block_sums[group]; scan_add then adds the scanned block sums. */
__kernel void scan_blocks(__global int* data, int n, __global int* block_sums, __local int* tmp) {
  const int lid = (int)get_local_id(0), L = (int)get_local_size(0);
  const int base = ((int)get_group_id(0) * L + lid) * PF_SCAN_ITEMS;
  int v[PF_SCAN_ITEMS];
  int s = 0;
  for (int j = 0; j < PF_SCAN_ITEMS; ++j) {
    v[j] = base + j < n ? data[base + j] : 0;
    s += v[j];
  }
  tmp[lid] = s;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int off = 1; off < L; off <<= 1) {
    const int t = lid >= off ? tmp[lid - off] : 0;
    barrier(CLK_LOCAL_MEM_FENCE);
    tmp[lid] += t;
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  int run = tmp[lid] - s; /* exclusive prefix of this work-item's entries */
  for (int j = 0; j < PF_SCAN_ITEMS; ++j) {
    if (base + j < n) data[base + j] = run;
    run += v[j];
  }
  if (lid == L - 1) block_sums[get_group_id(0)] = tmp[L - 1];
}

__kernel void scan_add(__global int* data, int n, __global const int* block_offsets) {
  const int i = (int)get_global_id(0);
  if (i >= n) return;
  data[i] += block_offsets[i / (PF_SCAN_ITEMS * (int)get_local_size(0))];
}
