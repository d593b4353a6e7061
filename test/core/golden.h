// The tolerance of the golden-vector tests; the rows are read through each generated
// golden header's own at() and sample().
#ifndef HPDDO_TEST_GOLDEN_H
#define HPDDO_TEST_GOLDEN_H

#include <cmath>
#include <cstring>
#include <stdint.h>

#include "hpddo_core.h"

namespace golden {

/// |got - want| within 1e-4 relative to max(|want|, 1): the tolerance of every stage.
inline bool close(float got, float want) {
  if (std::isnan(want)) return std::isnan(got);
  const float scale = std::fabs(want) > 1.0f ? std::fabs(want) : 1.0f;
  return std::fabs(got - want) <= 1e-4f * scale;
}

/// The bits of a float, for tests that compare to the bit (golden rows stored as bits).
inline uint32_t bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

/// The float with these bits.
inline float from_bits(uint32_t b) {
  float f;
  std::memcpy(&f, &b, sizeof f);
  return f;
}

}  // namespace golden

#endif
