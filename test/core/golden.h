// The tolerance of the golden-vector tests; the rows are read through each generated
// golden header's own at() and sample().
#ifndef HPDDO_TEST_GOLDEN_H
#define HPDDO_TEST_GOLDEN_H

#include <cmath>

#include "hpddo_core.h"

namespace golden {

/// |got - want| within 1e-4 relative to max(|want|, 1): the tolerance of every stage.
inline bool close(float got, float want) {
  if (std::isnan(want)) return std::isnan(got);
  const float scale = std::fabs(want) > 1.0f ? std::fabs(want) : 1.0f;
  return std::fabs(got - want) <= 1e-4f * scale;
}

}  // namespace golden

#endif
