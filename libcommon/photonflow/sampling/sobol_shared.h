/*
 * sampling/sobol_shared.h — the first PF_SOBOL_DIMS dimensions of Sobol's sequence with
 * Owen scrambling, shared by the C++ host and the OpenCL kernels (so both backends draw the same
 * numbers).
 *
 * Sobol's sequence in base 2. Point i of dimension d has 32 fraction bits:
 *   x_d(i) = XOR over the set bits k of i of V_d[k]
 * with V_d the generator matrix of column vectors ("direction numbers", Bratley & Fox 1988,
 * eq. 2 with Gray code left out). Dimension 0 is the radical inverse in base 2 (V_0[k] = 2^(31−k)).
 * Dimension d ≥ 1 comes from a primitive polynomial of degree s with coefficients a and initial
 * numbers m_1..m_s, published by Joe and Kuo (2008, "Constructing Sobol sequences with better
 * two-dimensional projections", SIAM J. Sci. Comput. 30, 2635–2654; file new-joe-kuo-6.21201,
 * rows d = 2..16, which are dimensions 1..15 here):
 *   V[k] = m_{k+1} · 2^(31−k)                                   for k < s
 *   V[k] = V[k−s] ⊕ (V[k−s] >> s) ⊕ ⊕_{j=1}^{s−1} a_j V[k−j]    for k ≥ s   (Joe & Kuo eq. 2.3)
 * The table below is that recurrence evaluated once (tests/sampling/sobol_shared_test.cpp recomputes it from the
 * published m_i and checks it, and checks the net property it implies).
 *
 * Owen scrambling (a nested uniform scramble: every elementary interval is permuted as a whole)
 * keeps each dimension's stratification and makes every point uniform on [0, 1), so an estimate
 * from scrambled points is unbiased; Burley (2020, "Practical hash-based Owen scrambling")
 * gives the hash-based form used here (pf_owen_scramble).
 *
 * All arithmetic is 32-bit unsigned (exact and equal in C++ and OpenCL C).
 */
#ifndef PHOTONFLOW_SAMPLING_SOBOL_SHARED_H
#define PHOTONFLOW_SAMPLING_SOBOL_SHARED_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/foundations/shared_types.h"

#ifdef __OPENCL_VERSION__
#define PF_CONSTANT_TABLE __constant
#else
#define PF_CONSTANT_TABLE static const
#endif
#define PF_CONSTANT PF_CONSTANT_TABLE

/* Generator matrices V_d[k], d < PF_SOBOL_DIMS, k < 32 (row d·32 + k). */
#define PF_SOBOL_DIMS 16
PF_CONSTANT pf_uint pf_sobol_matrix[PF_SOBOL_DIMS * 32] = {
    /*  0 */ 0x80000000U, 0x40000000U, 0x20000000U, 0x10000000U, 0x08000000U, 0x04000000U, 0x02000000U, 0x01000000U,
           0x00800000U, 0x00400000U, 0x00200000U, 0x00100000U, 0x00080000U, 0x00040000U, 0x00020000U, 0x00010000U,
           0x00008000U, 0x00004000U, 0x00002000U, 0x00001000U, 0x00000800U, 0x00000400U, 0x00000200U, 0x00000100U,
           0x00000080U, 0x00000040U, 0x00000020U, 0x00000010U, 0x00000008U, 0x00000004U, 0x00000002U, 0x00000001U,
    /*  1 */ 0x80000000U, 0xc0000000U, 0xa0000000U, 0xf0000000U, 0x88000000U, 0xcc000000U, 0xaa000000U, 0xff000000U,
           0x80800000U, 0xc0c00000U, 0xa0a00000U, 0xf0f00000U, 0x88880000U, 0xcccc0000U, 0xaaaa0000U, 0xffff0000U,
           0x80008000U, 0xc000c000U, 0xa000a000U, 0xf000f000U, 0x88008800U, 0xcc00cc00U, 0xaa00aa00U, 0xff00ff00U,
           0x80808080U, 0xc0c0c0c0U, 0xa0a0a0a0U, 0xf0f0f0f0U, 0x88888888U, 0xccccccccU, 0xaaaaaaaaU, 0xffffffffU,
    /*  2 */ 0x80000000U, 0xc0000000U, 0x60000000U, 0x90000000U, 0xe8000000U, 0x5c000000U, 0x8e000000U, 0xc5000000U,
           0x68800000U, 0x9cc00000U, 0xee600000U, 0x55900000U, 0x80680000U, 0xc09c0000U, 0x60ee0000U, 0x90550000U,
           0xe8808000U, 0x5cc0c000U, 0x8e606000U, 0xc5909000U, 0x6868e800U, 0x9c9c5c00U, 0xeeee8e00U, 0x5555c500U,
           0x8000e880U, 0xc0005cc0U, 0x60008e60U, 0x9000c590U, 0xe8006868U, 0x5c009c9cU, 0x8e00eeeeU, 0xc5005555U,
    /*  3 */ 0x80000000U, 0xc0000000U, 0x20000000U, 0x50000000U, 0xf8000000U, 0x74000000U, 0xa2000000U, 0x93000000U,
           0xd8800000U, 0x25400000U, 0x59e00000U, 0xe6d00000U, 0x78080000U, 0xb40c0000U, 0x82020000U, 0xc3050000U,
           0x208f8000U, 0x51474000U, 0xfbea2000U, 0x75d93000U, 0xa0858800U, 0x914e5400U, 0xdbe79e00U, 0x25db6d00U,
           0x58800080U, 0xe54000c0U, 0x79e00020U, 0xb6d00050U, 0x800800f8U, 0xc00c0074U, 0x200200a2U, 0x50050093U,
    /*  4 */ 0x80000000U, 0x40000000U, 0x20000000U, 0xb0000000U, 0xf8000000U, 0xdc000000U, 0x7a000000U, 0x9d000000U,
           0x5a800000U, 0x2fc00000U, 0xa1600000U, 0xf0b00000U, 0xda880000U, 0x6fc40000U, 0x81620000U, 0x40bb0000U,
           0x22878000U, 0xb3c9c000U, 0xfb65a000U, 0xddb2d000U, 0x78022800U, 0x9c0b3c00U, 0x5a0fb600U, 0x2d0ddb00U,
           0xa2878080U, 0xf3c9c040U, 0xdb65a020U, 0x6db2d0b0U, 0x800228f8U, 0x400b3cdcU, 0x200fb67aU, 0xb00ddb9dU,
    /*  5 */ 0x80000000U, 0x40000000U, 0x60000000U, 0x30000000U, 0xc8000000U, 0x24000000U, 0x56000000U, 0xfb000000U,
           0xe0800000U, 0x70400000U, 0xa8600000U, 0x14300000U, 0x9ec80000U, 0xdf240000U, 0xb6d60000U, 0x8bbb0000U,
           0x48008000U, 0x64004000U, 0x36006000U, 0xcb003000U, 0x2880c800U, 0x54402400U, 0xfe605600U, 0xef30fb00U,
           0x7e48e080U, 0xaf647040U, 0x1eb6a860U, 0x9f8b1430U, 0xd6c81ec8U, 0xbb249f24U, 0x80d6d6d6U, 0x40bbbbbbU,
    /*  6 */ 0x80000000U, 0xc0000000U, 0xa0000000U, 0xd0000000U, 0x58000000U, 0x94000000U, 0x3e000000U, 0xe3000000U,
           0xbe800000U, 0x23c00000U, 0x1e200000U, 0xf3100000U, 0x46780000U, 0x67840000U, 0x78460000U, 0x84670000U,
           0xc6788000U, 0xa784c000U, 0xd846a000U, 0x5467d000U, 0x9e78d800U, 0x33845400U, 0xe6469e00U, 0xb7673300U,
           0x20f86680U, 0x104477c0U, 0xf8668020U, 0x4477c010U, 0x668020f8U, 0x77c01044U, 0x8020f866U, 0xc0104477U,
    /*  7 */ 0x80000000U, 0x40000000U, 0xa0000000U, 0x50000000U, 0x88000000U, 0x24000000U, 0x12000000U, 0x2d000000U,
           0x76800000U, 0x9e400000U, 0x08200000U, 0x64100000U, 0xb2280000U, 0x7d140000U, 0xfea20000U, 0xba490000U,
           0x1a248000U, 0x491b4000U, 0xc4b5a000U, 0xe3739000U, 0xf6800800U, 0xde400400U, 0xa8200a00U, 0x34100500U,
           0x3a280880U, 0x59140240U, 0xeca20120U, 0x974902d0U, 0x6ca48768U, 0xd75b49e4U, 0xcc95a082U, 0x87639641U,
    /*  8 */ 0x80000000U, 0x40000000U, 0xa0000000U, 0x50000000U, 0x28000000U, 0xd4000000U, 0x6a000000U, 0x71000000U,
           0x38800000U, 0x58400000U, 0xea200000U, 0x31100000U, 0x98a80000U, 0x08540000U, 0xc22a0000U, 0xe5250000U,
           0xf2b28000U, 0x79484000U, 0xfaa42000U, 0xbd731000U, 0x18a80800U, 0x48540400U, 0x622a0a00U, 0xb5250500U,
           0xdab28280U, 0xad484d40U, 0x90a426a0U, 0xcc731710U, 0x20280b88U, 0x10140184U, 0x880a04a2U, 0x84350611U,
    /*  9 */ 0x80000000U, 0x40000000U, 0xe0000000U, 0xb0000000U, 0x98000000U, 0x94000000U, 0x8a000000U, 0x5b000000U,
           0x33800000U, 0xd9c00000U, 0x72200000U, 0x3f100000U, 0xc1b80000U, 0xa6ec0000U, 0x53860000U, 0x29f50000U,
           0x0a3a8000U, 0x1b2ac000U, 0xd392e000U, 0x69ff7000U, 0xea380800U, 0xab2c0400U, 0x4ba60e00U, 0xfde50b00U,
           0x60028980U, 0xf006c940U, 0x7834e8a0U, 0x241a75b0U, 0x123a8b38U, 0xcf2ac99cU, 0xb992e922U, 0x82ff78f1U,
    /* 10 */ 0x80000000U, 0x40000000U, 0xa0000000U, 0x10000000U, 0x08000000U, 0x6c000000U, 0x9e000000U, 0x23000000U,
           0x57800000U, 0xadc00000U, 0x7fa00000U, 0x91d00000U, 0x49880000U, 0xced40000U, 0x880a0000U, 0x2c0f0000U,
           0x3e0d8000U, 0x3317c000U, 0x5fb06000U, 0xc1f8b000U, 0xe18d8800U, 0xb2d7c400U, 0x1e106a00U, 0x6328b100U,
           0xf7858880U, 0xbdc3c2c0U, 0x77ba63e0U, 0xfdf7b330U, 0xd7800df8U, 0xedc0081cU, 0xdfa0041aU, 0x81d00a2dU,
    /* 11 */ 0x80000000U, 0x40000000U, 0x20000000U, 0x30000000U, 0x58000000U, 0xac000000U, 0x96000000U, 0x2b000000U,
           0xd4800000U, 0x09400000U, 0xe2a00000U, 0x52500000U, 0x4e280000U, 0xc71c0000U, 0x629e0000U, 0x12670000U,
           0x6e138000U, 0xf731c000U, 0x3a98a000U, 0xbe449000U, 0xf83b8800U, 0xdc2dc400U, 0xee06a200U, 0xb7239300U,
           0x1aa80d80U, 0x8e5c0ec0U, 0xa03e0b60U, 0x703701b0U, 0x783b88c8U, 0x9c2dca54U, 0xce06a74aU, 0x87239795U,
    /* 12 */ 0x80000000U, 0xc0000000U, 0xa0000000U, 0x50000000U, 0xf8000000U, 0x8c000000U, 0xe2000000U, 0x33000000U,
           0x0f800000U, 0x21400000U, 0x95a00000U, 0x5e700000U, 0xd8080000U, 0x1c240000U, 0xba160000U, 0xef370000U,
           0x15868000U, 0x9e6fc000U, 0x781b6000U, 0x4c349000U, 0x420e8800U, 0x630bcc00U, 0xf7ad6a00U, 0xad739500U,
           0x77800780U, 0x6d4004c0U, 0xd7a00420U, 0x3d700630U, 0x2f880f78U, 0xb1640ad4U, 0xcdb6077aU, 0x824706d7U,
    /* 13 */ 0x80000000U, 0xc0000000U, 0x60000000U, 0x90000000U, 0x38000000U, 0xc4000000U, 0x42000000U, 0xa3000000U,
           0xf1800000U, 0xaa400000U, 0xfce00000U, 0x85100000U, 0xe0080000U, 0x500c0000U, 0x58060000U, 0x54090000U,
           0x7a038000U, 0x670c4000U, 0xb3842000U, 0x094a3000U, 0x0d6f1800U, 0x2f5aa400U, 0x1ce7ce00U, 0xd5145100U,
           0xb8000080U, 0x040000c0U, 0x22000060U, 0x33000090U, 0xc9800038U, 0x6e4000c4U, 0xbee00042U, 0x261000a3U,
    /* 14 */ 0x80000000U, 0x40000000U, 0x20000000U, 0xf0000000U, 0xa8000000U, 0x54000000U, 0x9a000000U, 0x9d000000U,
           0x1e800000U, 0x5cc00000U, 0x7d200000U, 0x8d100000U, 0x24880000U, 0x71c40000U, 0xeba20000U, 0x75df0000U,
           0x6ba28000U, 0x35d14000U, 0x4ba3a000U, 0xc5d2d000U, 0xe3a16800U, 0x91db8c00U, 0x79aef200U, 0x0cdf4100U,
           0x672a8080U, 0x50154040U, 0x1a01a020U, 0xdd0dd0f0U, 0x3e83e8a8U, 0xaccacc54U, 0xd52d529aU, 0xd91d919dU,
    /* 15 */ 0x80000000U, 0xc0000000U, 0x20000000U, 0xd0000000U, 0xd8000000U, 0xc4000000U, 0x46000000U, 0x85000000U,
           0xa5800000U, 0x76c00000U, 0xada00000U, 0x6ab00000U, 0x2da80000U, 0xaabc0000U, 0x0daa0000U, 0x7ab10000U,
           0xd5a78000U, 0xbebd4000U, 0x93a3e000U, 0x3bb51000U, 0x3629b800U, 0x4d727c00U, 0x9b836200U, 0x27c4d700U,
           0xb629b880U, 0x8d727cc0U, 0xbb836220U, 0xf7c4d7d0U, 0x6e29b858U, 0x49727c04U, 0xfd836266U, 0x72c4d755U,
};
#undef PF_CONSTANT

/* Bits of x in reverse order: bits within nibbles, nibbles within bytes, then the bytes (the host
 * reverses the bytes with one bswap; the same bits either way). */
PF_INLINE pf_uint pf_reverse_bits32(pf_uint x) {
  x = ((x >> 1) & 0x55555555U) | ((x & 0x55555555U) << 1);
  x = ((x >> 2) & 0x33333333U) | ((x & 0x33333333U) << 2);
  x = ((x >> 4) & 0x0f0f0f0fU) | ((x & 0x0f0f0f0fU) << 4);
#ifdef __OPENCL_VERSION__
  x = ((x >> 8) & 0x00ff00ffU) | ((x & 0x00ff00ffU) << 8);
  return (x >> 16) | (x << 16);
#else
  return __builtin_bswap32(x);
#endif
}

/* Point i of Sobol dimension d (d < PF_SOBOL_DIMS) as 32 fraction bits: the XOR of the columns
 * of the set bits of i (dimension 0 in closed form, the bit reversal). The host visits only the
 * set bits (count-trailing-zeros); the kernels test every bit up to the highest; the XOR is the
 * same in any order, so both give the same bits. */
PF_INLINE pf_uint pf_sobol_bits(pf_uint d, pf_uint i) {
  if (d == 0U) return pf_reverse_bits32(i);
  pf_uint r = 0U;
#ifdef __OPENCL_VERSION__
  for (pf_uint k = d * 32U; i != 0U; i >>= 1, ++k)
    if (i & 1U) r ^= pf_sobol_matrix[k];
#else
  for (const pf_uint* m = pf_sobol_matrix + d * 32U; i != 0U; i &= i - 1U)
    r ^= m[__builtin_ctz(i)];
#endif
  return r;
}

/* Burley's hash-based Owen scramble of fraction bits x (bit 31 = the most significant digit):
 * reversed, each bit is flipped by a hash of the bits below it (which, reversed back, are the
 * digits above it) — a nested uniform scramble, a permutation of every elementary interval. */
PF_INLINE pf_uint pf_owen_scramble(pf_uint x, pf_uint seed) {
  x = pf_reverse_bits32(x);
  x += seed;
  x ^= x * 0x6c50b47cU;
  x ^= x * 0xb82f1e52U;
  x ^= x * 0xc7afe638U;
  x ^= x * 0x8d22f6e6U;
  return pf_reverse_bits32(x);
}

#endif /* PHOTONFLOW_SAMPLING_SOBOL_SHARED_H */
