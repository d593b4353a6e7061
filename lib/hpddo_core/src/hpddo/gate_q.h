// The novelty gate (gate.h) in integers, for the fixed-point model: the same prototypes,
// thresholds and rule in units of 2^-kGateFrac of the gate's scaled space. The integer
// reference and the rule of every constant are in tools/hpddo/model/quant.py (quantise_gate,
// gate_weight_int), which computes the golden vectors:
//
//   gq_j  = sat16(round(g_j 2^e_j))                   the network's input quantisation
//   zq_j  = clip(((gq_j - cq_j) m_j + 2^(S_j-1)) >> S_j, -kGateZMax, kGateZMax)
//   acc_k = sum_j (zq_j - pq_kj)^2                    int32, cannot overflow
//   best  = min(r_out_q, acc_k ...)                   a prototype's sum stops once acc >= best
//   w     = 0 unless best < r_out_q; 1 if best <= r_in_q; else float(r_out_q - best) * fade
//
// A NaN or infinite g_j gives w = 0.
#ifndef HPDDO_GATE_Q_H
#define HPDDO_GATE_Q_H

#include <stdint.h>

#include "crc.h"
#include "gate.h"
#include "mlp_q.h"
#include "platform.h"

#if !HPDDO_GATE_EARLY_EXIT && defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace hpddo {

/// Fraction bits of the integer gate's scaled space (quant.GATE_FRAC).
static const uint8_t kGateFrac = 10;
/// Largest |zq| and |pq| (quant.GATE_ZMAX): 5 squared differences fit int32.
static const int16_t kGateZMax = 8191;

#if !HPDDO_GATE_EARLY_EXIT && defined(__SSE2__)
namespace detail {

/// The hosts' smallest sum of squares over the prototypes (x86-64 has SSE2 always): one
/// prototype's kDims <= 8 differences in one register, squared and summed in pairs by
/// PMADDWD, then across. Exact: |zq - pq| <= 2 kGateZMax fits int16, every sum int32.
template <uint8_t kDims, uint8_t kProtos>
inline int32_t min_distance_sse2(const int16_t (&z)[kDims], const int16_t* protos, int32_t best) {
  // kDims <= 5 (GateQ's static_assert): one register of 8 lanes holds a prototype.
  int16_t zz[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  int16_t keep[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  for (uint8_t j = 0; j < kDims; ++j) {
    zz[j] = z[j];
    keep[j] = -1;
  }
  const __m128i vz = _mm_loadu_si128(reinterpret_cast<const __m128i*>(zz));
  const __m128i mask = _mm_loadu_si128(reinterpret_cast<const __m128i*>(keep));
  const uint16_t n = static_cast<uint16_t>(kProtos * kDims);
  for (uint16_t k = 0; k < kProtos; ++k) {
    const uint16_t at = static_cast<uint16_t>(k * kDims);
    const int16_t* p = protos + at;
    __m128i vp;
    if (at + 8u <= n) {
      vp = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));  // the lanes past kDims are masked
    } else {  // the last rows: no read past the array
      int16_t t[8] = {0, 0, 0, 0, 0, 0, 0, 0};
      for (uint8_t j = 0; j < kDims; ++j) t[j] = p[j];
      vp = _mm_loadu_si128(reinterpret_cast<const __m128i*>(t));
    }
    const __m128i d = _mm_and_si128(_mm_sub_epi16(vz, vp), mask);
    __m128i sq = _mm_madd_epi16(d, d);
    sq = _mm_add_epi32(sq, _mm_shuffle_epi32(sq, _MM_SHUFFLE(1, 0, 3, 2)));
    sq = _mm_add_epi32(sq, _mm_shuffle_epi32(sq, _MM_SHUFFLE(2, 3, 0, 1)));
    const int32_t acc = _mm_cvtsi128_si32(sq);
    best = acc < best ? acc : best;
  }
  return best;
}

}  // namespace detail
#endif

/// Distance-to-prototypes gate in integers, kDims inputs, kProtos prototypes in flash.
template <uint8_t kDims, uint8_t kProtos>
struct GateQ {
  static_assert(kDims > 0 && kDims <= 5, "hpddo::GateQ: 1 to 5 inputs (the int32 sum holds 5 squares)");
  static_assert(kProtos > 0, "hpddo::GateQ: a gate needs at least one prototype (kProtos > 0)");

  const int8_t* in_exp;       ///< kDims input exponents e_j (the network's)
  const int16_t* centre;      ///< kDims cq_j = round(centre_j 2^e_j)
  const int8_t* shift;        ///< kDims S_j
  const int16_t* mult;        ///< kDims m_j (m_j / 2^S_j ~ 2^kGateFrac / (scale_j 2^e_j))
  const int16_t* prototypes;  ///< kProtos x kDims, round(p 2^kGateFrac), row-major
  int32_t r_in_q;             ///< round(r_in_sq 2^(2 kGateFrac))
  int32_t r_out_q;            ///< round(r_out_sq 2^(2 kGateFrac)) > r_in_q
  float fade;                 ///< 1 / (r_out_q - r_in_q)
  uint8_t sort_dim;           ///< the prototypes are in ascending order of this coordinate

  /// The weight of the residual for input g, in [0, 1]; 0 for a NaN or infinite g_j.
  float weight(const float (&g)[kDims]) const {
    uint8_t first = 0;
    return weight(g, &first);
  }

  /// The same; prototypes visited from *first on, which receives the nearest (gate.h).
  float weight(const float (&g)[kDims], uint8_t* first) const {
    int16_t gq[kDims];
    return weight(g, first, gq);
  }

  /// The same, and gq receives the quantised inputs sat16(round(g_j 2^e_j)), the
  /// network's where in_exp is the network's (the generated models): the observer hands
  /// them on to the network instead of quantising twice. Complete where the weight is
  /// above 0 (a NaN or infinite g_j stops early, with weight 0).
  float weight(const float (&g)[kDims], uint8_t* first, int16_t (&gq)[kDims]) const {
    int16_t z[kDims];
    for (uint8_t j = 0; j < kDims; ++j) {
      if (!is_finite(g[j])) return 0.0f;
      gq[j] = detail::quantise_input(g[j], flash_int8(in_exp + j));
      const uint8_t s = static_cast<uint8_t>(flash_int8(shift + j));
      const int32_t diff = static_cast<int32_t>(gq[j]) - flash_int16(centre + j);
      const int16_t mj = flash_int16(mult + j);
      // A 16 x 16-bit product where the difference fits int16 (the usual case), else 32-bit.
      int32_t t = diff == static_cast<int16_t>(diff) ? detail::mac16(0, static_cast<int16_t>(diff), mj)
                                                      : diff * mj;
      // (t + 2^(s-1)) >> s as ((t >> (s-1)) + 1) >> 1, the same integer (floors of floors):
      // no 2^(s-1) to build, a loop of s turns on the AVR.
      if (s > 0) t = (detail::shift_right(t, static_cast<uint8_t>(s - 1)) + 1) >> 1;
      z[j] = static_cast<int16_t>(t > kGateZMax ? kGateZMax : t < -kGateZMax ? -kGateZMax : t);
    }
    int32_t best = r_out_q;
#if !HPDDO_GATE_EARLY_EXIT && defined(__SSE2__)
    best = detail::min_distance_sse2<kDims, kProtos>(z, prototypes, best);
    (void)first;  // the hint serves the early exits only: left as it is
#elif !HPDDO_GATE_EARLY_EXIT
    // Every sum in full, then the minimum (gate.h); the sums cannot overflow.
    best = detail::min_sq_distance<int32_t, kDims, kProtos>(z, prototypes, best);
    (void)first;  // the hint serves the early exits only: left as it is
#else
    // The prototypes are stored in ascending order of their coordinate sort_dim (quant.py):
    // the search starts at the previous nearest (*first), then walks up the order until
    // that coordinate's difference alone reaches best (every later one differs more still),
    // and down the same way. A prototype whose difference there alone reaches best is
    // passed over after one 16 x 16-bit square.
    const uint8_t sd = sort_dim < kDims ? sort_dim : 0;
    const uint8_t k0 = *first < kProtos ? *first : 0;
    const int16_t zs = z[sd];
    const int16_t* p = prototypes + static_cast<uint16_t>(k0) * kDims;
    for (uint8_t k = k0; k < kProtos; ++k, p += kDims) {  // k0, then up
      const int16_t d = static_cast<int16_t>(zs - flash_int16(p + sd));
      if (detail::mac16(0, d, d) >= best) {
        if (d < 0) break;  // this one and every later one
        continue;
      }
      if (nearer(z, p, &best)) *first = k;
    }
    p = prototypes + static_cast<uint16_t>(k0) * kDims;
    for (uint8_t k = k0; k > 0;) {  // down
      --k;
      p -= kDims;
      const int16_t d = static_cast<int16_t>(zs - flash_int16(p + sd));
      if (detail::mac16(0, d, d) >= best) {
        if (d > 0) break;  // this one and every earlier one
        continue;
      }
      if (nearer(z, p, &best)) *first = k;
    }
#endif
    if (!(best < r_out_q)) return 0.0f;
    if (best <= r_in_q) return 1.0f;
    return static_cast<float>(r_out_q - best) * fade;
  }

  /// Whether prototype p is nearer than *best: its sum of squares, stopped once it reaches
  /// *best; *best receives it where it is below.
  static bool nearer(const int16_t (&z)[kDims], const int16_t* p, int32_t* best) {
    int32_t acc = 0;
    uint8_t j = 0;
    for (; j < kDims && acc < *best; ++j) {
      const int16_t d = static_cast<int16_t>(z[j] - flash_int16(p + j));
      acc = detail::mac16(acc, d, d);
    }
    if (j == kDims && acc < *best) {
      *best = acc;
      return true;
    }
    return false;
  }

  /// CRC-32 update over the stored gate, in quant.gate_bytes()'s order.
  uint32_t crc(uint32_t c) const {
    c = detail::crc_flash_bytes(c, centre, static_cast<uint16_t>(2u * kDims));
    c = detail::crc_flash_bytes(c, shift, kDims);
    c = detail::crc_flash_bytes(c, mult, static_cast<uint16_t>(2u * kDims));
    c = detail::crc_flash_bytes(c, prototypes, static_cast<uint16_t>(2u * kDims * kProtos));
    const int32_t r[2] = {r_in_q, r_out_q};
    c = crc32_update(c, reinterpret_cast<const uint8_t*>(r), 8);  // RAM, little-endian on every target
    uint8_t f[4];
    __builtin_memcpy(f, &fade, 4);
    c = crc32_update(c, f, 4);
    return crc32_update(c, &sort_dim, 1);
  }
};

}  // namespace hpddo

#endif  // HPDDO_GATE_Q_H
