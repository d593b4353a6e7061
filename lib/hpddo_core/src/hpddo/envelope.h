// Training envelope: the per-feature range seen in training, widened by 10 %
// of it on each side (tools/hpddo/model/train.py, ENVELOPE_MARGIN). Outside it the
// residual is an extrapolation, and the observer falls back to the physics model.
#ifndef HPDDO_ENVELOPE_H
#define HPDDO_ENVELOPE_H

#include <stdint.h>

#include "platform.h"

namespace hpddo {

/// Per-feature closed interval [lo, hi] in the features' own units (flash).
template <uint8_t kN>
struct Envelope {
  static_assert(kN > 0, "hpddo::Envelope: a training range needs at least one feature (kN > 0)");

  const float* lo;
  const float* hi;

  /// True when every feature lies inside its interval (NaN never does; the bounds are
  /// finite: the exporter writes no other). The compares are those of the floats' order
  /// keys (platform.h: within), the same result at a fifth of the cycles on the AVR.
  bool contains(const float (&x)[kN]) const {
    for (uint8_t j = 0; j < kN; ++j) {
      if (!within(x[j], flash_float(lo + j), flash_float(hi + j))) return false;
    }
    return true;
  }
};

}  // namespace hpddo

#endif  // HPDDO_ENVELOPE_H
