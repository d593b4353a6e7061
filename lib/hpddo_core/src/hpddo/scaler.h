// StandardScaler: z_j = (x_j - mean_j) / scale_j, statistics fitted on the
// training rows only (tools/hpddo/model/network.py) and stored in flash by the model
// exporter.
#ifndef HPDDO_SCALER_H
#define HPDDO_SCALER_H

#include <stdint.h>

#include "platform.h"

namespace hpddo {

/// Feature standardisation with kN features; mean and scale point to flash.
template <uint8_t kN>
struct Scaler {
  static_assert(kN > 0, "hpddo::Scaler: standardising needs at least one feature (kN > 0)");

  const float* mean;   ///< kN feature means, in the features' own units
  const float* scale;  ///< kN standard deviations (never zero: a constant feature keeps 1)

  /// Writes the standardised features z from the raw features x.
  void transform(const float (&x)[kN], float (&z)[kN]) const {
    for (uint8_t j = 0; j < kN; ++j) {
      z[j] = (x[j] - flash_float(mean + j)) / flash_float(scale + j);
    }
  }
};

}  // namespace hpddo

#endif  // HPDDO_SCALER_H
