// A deployed model: physics parameters, scaler, network, envelope, novelty gate and clamp.
// Generated headers (tools/gen_weights.py) define one `Model<Net>` each, with
// the arrays in flash and a CRC-32 over them that a test recomputes.
#ifndef HPDDO_MODEL_H
#define HPDDO_MODEL_H

#include <stdint.h>

#include "crc.h"
#include "envelope.h"
#include "gate.h"
#include "gate_q.h"
#include "limits.h"
#include "mlp.h"
#include "mlp_q.h"
#include "physics.h"
#include "scaler.h"

namespace hpddo {

/// Number of residual features: [v_V, i_A, n_M2, i_A(t-1), n_M2(t-1)].
static const uint8_t kFeatureCount = 5;

/// Indices of the residual features.
enum Feature : uint8_t { kFeatV = 0, kFeatI = 1, kFeatM2 = 2, kFeatILag = 3, kFeatM2Lag = 4 };

/// Prototypes of the novelty gate (gate.h) over the residual features: 32 cover the
/// training rows of a few recordings (docs/gate.md: 16 let unseen operating points
/// through, 64 gain nothing measurable and double the cost). 680 bytes of flash.
static const uint8_t kGatePrototypes = 32;

/// The novelty gate of a model: distance of the features to training prototypes.
typedef Gate<kFeatureCount, kGatePrototypes> FeatureGate;

/// The same gate in integers, the fixed-point model's (gate_q.h).
typedef GateQ<kFeatureCount, kGatePrototypes> FeatureGateQ;

/// The gate type of a model with network Net: float, or integer beside a fixed-point network.
template <class Net>
struct ModelGate {
  typedef FeatureGate type;
};
template <uint8_t kIn, uint8_t kH1, uint8_t kH2, class WH, uint8_t kR0, uint8_t kR1, class W0>
struct ModelGate<MlpQ<kIn, kH1, kH2, WH, kR0, kR1, W0> > {
  typedef FeatureGateQ type;
};

/// Everything the observer needs, for a network type Net (an Mlp<...>).
template <class Net>
struct Model {
  PhysicsParams physics;            ///< M2 with its effect terms
  Scaler<kFeatureCount> scaler;     ///< standardisation of the features
  typename Net::Weights weights;    ///< residual network, in flash (MlpWeights or MlpQWeights)
  Envelope<kFeatureCount> envelope; ///< training range of the features
  typename ModelGate<Net>::type gate;  ///< nearness of the features to the training rows
  float clamp_rpm;                  ///< residual bound, RPM
  InputLimits limits;               ///< fault limits of the readings
};

namespace detail {
inline uint32_t crc_float(uint32_t crc, float f) {
  uint32_t u = 0;
  __builtin_memcpy(&u, &f, sizeof u);
  const uint8_t b[4] = {static_cast<uint8_t>(u), static_cast<uint8_t>(u >> 8),
                        static_cast<uint8_t>(u >> 16), static_cast<uint8_t>(u >> 24)};
  return crc32_update(crc, b, 4);
}
inline uint32_t crc_flash(uint32_t crc, const float* p, uint16_t n) {
  for (uint16_t k = 0; k < n; ++k) crc = crc_float(crc, flash_float(p + k));
  return crc;
}
/// The float network's layers, float32 little-endian, w0 b0 w1 b1 [w2 b2].
template <class Net>
uint32_t crc_network(uint32_t crc, const MlpWeights& w) {
  crc = crc_flash(crc, w.w0, Net::kW0Count);
  crc = crc_flash(crc, w.b0, Net::kHidden1);
  crc = crc_flash(crc, w.w1, Net::kW1Count);
  crc = crc_flash(crc, w.b1, Net::kHidden2 ? Net::kHidden2 : 1);
  if (Net::kHidden2) {
    crc = crc_flash(crc, w.w2, Net::kW2Count);
    crc = crc_flash(crc, w.b2, 1);
  }
  return crc;
}
/// The fixed-point network's bytes (MlpQ::crc_weights, quant.weight_bytes()'s order).
template <class Net, class WH, class W0>
uint32_t crc_network(uint32_t crc, const MlpQWeights<WH, W0>& w) {
  return Net::crc_weights(crc, w);
}
/// The float gate: centre, scale, prototypes, r_in_sq, r_out_sq.
inline uint32_t crc_gate(uint32_t crc, const FeatureGate& g) {
  crc = crc_flash(crc, g.centre, kFeatureCount);
  crc = crc_flash(crc, g.scale, kFeatureCount);
  crc = crc_flash(crc, g.prototypes, static_cast<uint16_t>(kFeatureCount) * kGatePrototypes);
  crc = crc_float(crc, g.r_in_sq);
  return crc_float(crc, g.r_out_sq);
}
/// The integer gate: its bytes (GateQ::crc, quant.gate_bytes()'s order).
inline uint32_t crc_gate(uint32_t crc, const FeatureGateQ& g) { return g.crc(crc); }
/// for_each_param() visitor: every physics field into the CRC, the effect bits as a float.
struct CrcParams {
  uint32_t crc;
  void operator()(float f) { crc = crc_float(crc, f); }
  void operator()(uint16_t bits) { crc = crc_float(crc, static_cast<float>(bits)); }
};
}  // namespace detail

/// CRC-32 over the float32 little-endian bytes of everything a model stores and
/// the board uses, in the exporter's order: every physics field in the schema's
/// order (for_each_param(), generated from tools/hpddo/schema.py), the effect
/// bits (the header's kEffects) as a float, scaler, network layers (a fixed-point
/// network: its bytes, MlpQ::crc_weights), envelope, gate (an integer gate: its bytes),
/// gate (centre, scale, prototypes, r_in_sq, r_out_sq), clamp and limits. A
/// generated header's kChecksum must equal it.
template <class Net>
uint32_t model_checksum(const Model<Net>& m) {
  detail::CrcParams phys = {0xFFFFFFFFu};
  for_each_param(m.physics, phys);
  uint32_t crc = phys.crc;
  crc = detail::crc_flash(crc, m.scaler.mean, kFeatureCount);
  crc = detail::crc_flash(crc, m.scaler.scale, kFeatureCount);
  crc = detail::crc_network<Net>(crc, m.weights);
  crc = detail::crc_flash(crc, m.envelope.lo, kFeatureCount);
  crc = detail::crc_flash(crc, m.envelope.hi, kFeatureCount);
  crc = detail::crc_gate(crc, m.gate);
  const float tail[] = {m.clamp_rpm, m.limits.v_max_V, m.limits.i_max_A, m.limits.temp_min_C,
                        m.limits.temp_max_C};
  for (uint8_t k = 0; k < sizeof tail / sizeof tail[0]; ++k) crc = detail::crc_float(crc, tail[k]);
  return crc ^ 0xFFFFFFFFu;
}

}  // namespace hpddo

#endif  // HPDDO_MODEL_H
