// The novelty gate (gate.h) in integers, for the fixed-point model: the same prototypes,
// thresholds and rule in units of 2^-kGateFrac of the gate's scaled space. The integer
// reference and the rule of every constant are in tools/hpddo/quant.py (quantise_gate,
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
#include "mlp_q.h"
#include "platform.h"

namespace hpddo {

/// Fraction bits of the integer gate's scaled space (quant.GATE_FRAC).
static const uint8_t kGateFrac = 10;
/// Largest |zq| and |pq| (quant.GATE_ZMAX): 5 squared differences fit int32.
static const int16_t kGateZMax = 8191;

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

  /// The weight of the residual for input g, in [0, 1]; 0 for a NaN or infinite g_j.
  float weight(const float (&g)[kDims]) const {
    uint8_t first = 0;
    return weight(g, &first);
  }

  /// The same; prototypes visited from *first on, which receives the nearest (gate.h).
  float weight(const float (&g)[kDims], uint8_t* first) const {
    int16_t z[kDims];
    for (uint8_t j = 0; j < kDims; ++j) {
      if (!is_finite(g[j])) return 0.0f;
      const int16_t gq = detail::quantise_input(g[j], flash_int8(in_exp + j));
      const uint8_t s = static_cast<uint8_t>(flash_int8(shift + j));
      int32_t t = static_cast<int32_t>(static_cast<int32_t>(gq) - flash_int16(centre + j)) * flash_int16(mult + j);
      if (s > 0) t = (t + (static_cast<int32_t>(1) << (s - 1))) >> s;
      z[j] = static_cast<int16_t>(t > kGateZMax ? kGateZMax : t < -kGateZMax ? -kGateZMax : t);
    }
    int32_t best = r_out_q;
    uint8_t k = *first < kProtos ? *first : 0;
    for (uint8_t n = 0; n < kProtos; ++n, k = static_cast<uint8_t>(k + 1u == kProtos ? 0u : k + 1u)) {
      const int16_t* p = prototypes + static_cast<uint16_t>(k) * kDims;
      int32_t acc = 0;
      uint8_t j = 0;
      for (; j < kDims && acc < best; ++j) {
        const int16_t d = static_cast<int16_t>(z[j] - flash_int16(p + j));
        acc = detail::mac16(acc, d, d);
      }
      if (j == kDims && acc < best) {
        best = acc;
        *first = k;
      }
    }
    if (!(best < r_out_q)) return 0.0f;
    if (best <= r_in_q) return 1.0f;
    return static_cast<float>(r_out_q - best) * fade;
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
    return crc32_update(c, f, 4);
  }
};

}  // namespace hpddo

#endif  // HPDDO_GATE_Q_H
