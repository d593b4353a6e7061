// Fixed-size dense ReLU network with a linear scalar output, the residual
// learner of M3. Sizes are template parameters; weights stay in flash and are
// laid out row-major per layer, W[out][in] (the transpose of coefs_ in
// tools/hpddo/model/network.py, which keeps scikit-learn's W[in][out]), biases
// b[out]. kH2 == 0 means one hidden layer.
#ifndef HPDDO_MLP_H
#define HPDDO_MLP_H

#include <stdint.h>

#include "platform.h"

namespace hpddo {

/// out = act(W in + b) for one dense layer; W is kOut x kIn row-major in flash.
template <uint16_t kIn, uint16_t kOut, bool kRelu>
inline void dense(const float* w, const float* b, const float* in, float* out) {
  static_assert(kIn > 0, "hpddo::dense: a layer needs at least one input (kIn > 0)");
  static_assert(kOut > 0, "hpddo::dense: a layer needs at least one output (kOut > 0)");
  for (uint16_t o = 0; o < kOut; ++o) {
    float acc = flash_float(b + o);
    const float* row = w + static_cast<uint32_t>(o) * kIn;
    for (uint16_t k = 0; k < kIn; ++k) acc += flash_float(row + k) * in[k];
    out[o] = (kRelu && !(acc > 0.0f)) ? 0.0f : acc;
  }
}

/// Pointers to the flash arrays of one network.
struct MlpWeights {
  const float* w0;  ///< kH1 x kIn
  const float* b0;  ///< kH1
  const float* w1;  ///< kH2 x kH1 (or 1 x kH1 when kH2 == 0)
  const float* b1;  ///< kH2 (or 1)
  const float* w2;  ///< 1 x kH2 (unused when kH2 == 0)
  const float* b2;  ///< 1 (unused when kH2 == 0)
};

namespace detail {
/// The shape checks both forms of Mlp inherit: inputs and a first hidden layer,
/// and a parameter count that fits kParamCount (uint16_t; 65535 floats are 256 kB,
/// more than the flash of the ATmega328P and a quarter of the ESP8266's program
/// space). Mlp<255, 255, 255> has 130816 parameters, Mlp<255, 255, 0> 65536.
template <uint8_t kIn, uint8_t kH1, uint8_t kH2>
struct MlpShape {
  static_assert(kIn > 0, "hpddo::Mlp: the network needs at least one input (kIn > 0)");
  static_assert(kH1 > 0, "hpddo::Mlp: the first hidden layer needs at least one neuron (kH1 > 0)");
  static const uint32_t kParams = static_cast<uint32_t>(kIn) * kH1 + kH1 +
                                  (kH2 ? static_cast<uint32_t>(kH1) * kH2 + kH2 + kH2 : static_cast<uint32_t>(kH1)) + 1u;
  static_assert(kParams <= 0xFFFFu, "hpddo::Mlp: more than 65535 parameters do not fit kParamCount (uint16_t)");
};

/// What both forms of Mlp (Net) share beside their forward(): the observer's residual.
template <class Net, uint8_t kIn>
struct MlpResidual {
  /// The observer's residual for raw features x, RPM: scaler, then Net::forward().
  template <class Scaler>
  static float residual(const Scaler& scaler, const MlpWeights& w, const float (&x)[kIn]) {
    float z[kIn];
    scaler.transform(x, z);
    return Net::forward(w, z);
  }
};
}  // namespace detail

/// Two hidden layers: kIn -> kH1 (ReLU) -> kH2 (ReLU) -> 1 (linear).
template <uint8_t kIn, uint8_t kH1, uint8_t kH2>
struct Mlp : private detail::MlpShape<kIn, kH1, kH2>, public detail::MlpResidual<Mlp<kIn, kH1, kH2>, kIn> {
  static const uint8_t kInputs = kIn;
  static const uint8_t kHidden1 = kH1;
  static const uint8_t kHidden2 = kH2;
  static const uint16_t kW0Count = static_cast<uint16_t>(static_cast<uint32_t>(kIn) * kH1);
  static const uint16_t kW1Count = static_cast<uint16_t>(static_cast<uint32_t>(kH1) * kH2);
  static const uint16_t kW2Count = kH2;
  static const uint16_t kParamCount =
      static_cast<uint16_t>(kW0Count + kH1 + kW1Count + kH2 + kW2Count + 1);

  typedef MlpWeights Weights;

  /// Network output for standardised inputs z.
  static float forward(const MlpWeights& w, const float (&z)[kIn]) {
    float h1[kH1];
    float h2[kH2];
    float y[1];
    dense<kIn, kH1, true>(w.w0, w.b0, z, h1);
    dense<kH1, kH2, true>(w.w1, w.b1, h1, h2);
    dense<kH2, 1, false>(w.w2, w.b2, h2, y);
    return y[0];
  }
};

/// One hidden layer: kIn -> kH1 (ReLU) -> 1 (linear); w1/b1 hold the output.
template <uint8_t kIn, uint8_t kH1>
struct Mlp<kIn, kH1, 0> : private detail::MlpShape<kIn, kH1, 0>, public detail::MlpResidual<Mlp<kIn, kH1, 0>, kIn> {
  static const uint8_t kInputs = kIn;
  static const uint8_t kHidden1 = kH1;
  static const uint8_t kHidden2 = 0;
  static const uint16_t kW0Count = static_cast<uint16_t>(static_cast<uint32_t>(kIn) * kH1);
  static const uint16_t kW1Count = kH1;
  static const uint16_t kW2Count = 0;
  static const uint16_t kParamCount = static_cast<uint16_t>(kW0Count + kH1 + kW1Count + 1);

  typedef MlpWeights Weights;

  /// Network output for standardised inputs z.
  static float forward(const MlpWeights& w, const float (&z)[kIn]) {
    float h1[kH1];
    float y[1];
    dense<kIn, kH1, true>(w.w0, w.b0, z, h1);
    dense<kH1, 1, false>(w.w1, w.b1, h1, y);
    return y[0];
  }
};

}  // namespace hpddo

#endif  // HPDDO_MLP_H
