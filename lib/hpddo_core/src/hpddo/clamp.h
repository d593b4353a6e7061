// Residual clamp: the learned correction is limited to +-bound, the 99th
// percentile of absolute training residuals, so that |n_M3 - n| never exceeds
// |n_M2 - n| + bound (paper, eq. 26).
#ifndef HPDDO_CLAMP_H
#define HPDDO_CLAMP_H

namespace hpddo {

/// Limits residual_rpm to [-bound_rpm, bound_rpm]; true when it had to.
inline bool clamp_residual(float bound_rpm, float* residual_rpm) {
  if (*residual_rpm > bound_rpm) {
    *residual_rpm = bound_rpm;
    return true;
  }
  if (*residual_rpm < -bound_rpm) {
    *residual_rpm = -bound_rpm;
    return true;
  }
  return false;
}

}  // namespace hpddo

#endif  // HPDDO_CLAMP_H
