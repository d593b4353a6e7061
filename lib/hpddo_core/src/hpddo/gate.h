// Novelty gate of the residual: a weight w in [0, 1] that is 1 where the input lies
// near the training data and fades to 0 away from it, so that
//
//   n_M3 = n_M2 + w * clamp(MLP(scale(x)))
//
// keeps the learned correction where the network saw data and falls back to the
// physics where it did not (a per-feature box, envelope.h, cannot tell: a point inside
// every feature's range can still be far from every training row). w is also the
// estimate's confidence. Fitted by tools/hpddo/model/gate.py (fit(); the rule of the
// thresholds is stated there and in docs/gate.md).
//
// The input g (kDims values) is scaled by the gate's own centre and scale, and its
// squared Euclidean distance to the nearest of kProtos prototypes (in the scaled
// space, flash) decides:
//
//   d2 <= r_in_sq             -> w = 1
//   r_in_sq < d2 < r_out_sq   -> w = (r_out_sq - d2) / (r_out_sq - r_in_sq)
//   d2 >= r_out_sq            -> w = 0        (and w = 0 for any NaN or infinite g_j)
//
// Arithmetic order (the contract with tools/hpddo/model/gate.py weight(), which computes
// the golden vectors; float32 throughout):
//   z_j  = (g_j - centre_j) / scale_j                         j = 0 .. kDims-1
//   acc  = 0; for j = 0 .. kDims-1: diff = z_j - p_kj; acc = acc + diff * diff
//   best = r_out_sq; for k = 0 .. kProtos-1: if acc_k < best, best = acc_k
//   w    = 0 unless best < r_out_sq; 1 if best <= r_in_sq; else the fade above.
// The sum over j of a prototype stops once acc >= best: acc only grows (each term is
// non-negative), so that prototype could not have become best, and w is unchanged.
#ifndef HPDDO_GATE_H
#define HPDDO_GATE_H

#include <stdint.h>

#include "platform.h"

namespace hpddo {
namespace detail {

#if !HPDDO_GATE_EARLY_EXIT  // the boards search with early exits (platform.h); so does avr-gcc 5, without the pragma
/// min(best, the smallest over the kProtos prototypes (row-major in flash) of the sum over j of
/// (z_j - p_kj)^2), every sum in full and in the same order of terms, then a vector minimum:
/// the search without early exits, for the float gate (Acc float) and the integer gate (Acc
/// int32_t, z and the prototypes int16_t: the sums cannot overflow).
template <typename Acc, uint8_t kDims, uint8_t kProtos, typename Z, typename P>
Acc min_sq_distance(const Z (&z)[kDims], const P* prototypes, Acc best) {
  Acc d2[kProtos];
  for (uint8_t k = 0; k < kProtos; ++k) {
    const P* p = prototypes + static_cast<uint32_t>(k) * kDims;
    Acc acc = 0;
#pragma GCC unroll 8
    for (uint8_t j = 0; j < kDims; ++j) {
      const Acc diff = static_cast<Acc>(z[j]) - static_cast<Acc>(flash_read(p + j));
      acc = acc + diff * diff;
    }
    d2[k] = acc;
  }
  for (uint8_t k = 0; k < kProtos; ++k) best = d2[k] < best ? d2[k] : best;  // a vector min
  return best;
}
#endif

}  // namespace detail

/// Distance-to-prototypes gate over kDims inputs and kProtos prototypes in flash.
template <uint8_t kDims, uint8_t kProtos>
struct Gate {
  static_assert(kDims > 0, "hpddo::Gate: a gate needs at least one input dimension (kDims > 0)");
  static_assert(kProtos > 0, "hpddo::Gate: a gate needs at least one prototype (kProtos > 0)");

  static const uint8_t kInputs = kDims;
  static const uint8_t kPrototypes = kProtos;
  /// Floats the gate keeps in flash: centre, scale and the prototypes.
  /// (At most 2 * 255 + 255 * 255 = 65535: always a uint16_t; computed in 32 bits, as on
  /// the AVR int is 16 bits.)
  static const uint16_t kFlashFloats =
      static_cast<uint16_t>(2u * static_cast<uint32_t>(kDims) + static_cast<uint32_t>(kDims) * kProtos);

  const float* centre;      ///< kDims, in the units of g (training mean)
  const float* scale;       ///< kDims, in the units of g (training standard deviation; never 0)
  const float* prototypes;  ///< kProtos x kDims, row-major, in the scaled space
  float r_in_sq;            ///< squared scaled distance up to which w = 1
  float r_out_sq;           ///< squared scaled distance from which w = 0 (> r_in_sq)

  /// The weight of the residual for input g, in [0, 1]; 0 for a NaN or infinite g_j.
  float weight(const float (&g)[kDims]) const {
    uint8_t first = 0;
    return weight(g, &first);
  }

  /// The same weight; the prototypes are visited from *first on (cyclically), and *first
  /// receives the nearest one found. The result does not depend on *first (best is the
  /// minimum over all prototypes, each sum in the same order); the time does: started
  /// at the nearest prototype of the previous sample, the others mostly stop after a
  /// term or two (the observer keeps that hint).
  float weight(const float (&g)[kDims], uint8_t* first) const {
    float z[kDims];
    for (uint8_t j = 0; j < kDims; ++j) {
      if (!is_finite(g[j])) return 0.0f;
      z[j] = (g[j] - flash_float(centre + j)) / flash_float(scale + j);
    }
    float best = r_out_sq;
#if !HPDDO_GATE_EARLY_EXIT
    // Every sum in full (the same order of terms), then the minimum: a sum that the
    // early exit would stop is at least best in full too (the terms are not negative).
    best = detail::min_sq_distance<float, kDims, kProtos>(z, prototypes, best);
    (void)first;  // the hint serves the early exits only: left as it is
#else
    uint8_t k = *first < kProtos ? *first : 0;
    for (uint8_t n = 0; n < kProtos; ++n, k = static_cast<uint8_t>(k + 1u == kProtos ? 0u : k + 1u)) {
      const float* p = prototypes + static_cast<uint32_t>(k) * kDims;
      float acc = 0.0f;
      uint8_t j = 0;
      for (; j < kDims && acc < best; ++j) {
        const float diff = z[j] - flash_float(p + j);
        acc = acc + diff * diff;
      }
      if (j == kDims && acc < best) {
        best = acc;
        *first = k;
      }
    }
#endif
    if (!(best < r_out_sq)) return 0.0f;
    if (best <= r_in_sq) return 1.0f;
    return (r_out_sq - best) / (r_out_sq - r_in_sq);
  }
};

// Definitions of the constants, for uses that bind them to a reference (C++11).
template <uint8_t kDims, uint8_t kProtos>
const uint8_t Gate<kDims, kProtos>::kInputs;
template <uint8_t kDims, uint8_t kProtos>
const uint8_t Gate<kDims, kProtos>::kPrototypes;
template <uint8_t kDims, uint8_t kProtos>
const uint16_t Gate<kDims, kProtos>::kFlashFloats;

}  // namespace hpddo

#endif  // HPDDO_GATE_H
