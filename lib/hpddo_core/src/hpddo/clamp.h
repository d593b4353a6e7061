// Residual clamp: the learned correction is limited to +-bound, the 99th
// percentile of absolute training residuals, so that |n_M3 - n| never exceeds
// |n_M2 - n| + bound (paper, eq. 26).
#ifndef HPDDO_CLAMP_H
#define HPDDO_CLAMP_H

#include <stdint.h>

#include "platform.h"

namespace hpddo {

/// Limits residual_rpm to [-bound_rpm, bound_rpm]; true when it had to. The compares are
/// those of the floats' order keys (platform.h; key(-b) = -key(b)): the float compares'
/// results for any residual and bound that are not NaN.
inline bool clamp_residual(float bound_rpm, float* residual_rpm) {
  const int32_t r = order_key(*residual_rpm);
  const int32_t b = order_key(bound_rpm);
  if (r > b) {
    *residual_rpm = bound_rpm;
    return true;
  }
  if (r < -b) {
    *residual_rpm = -bound_rpm;
    return true;
  }
  return false;
}

}  // namespace hpddo

#endif  // HPDDO_CLAMP_H
