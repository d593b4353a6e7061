// The observer step: one sample (V, I, temperature where present) in, one
// speed estimate with its status out. Keeps the one-step lags of I and n_M2
// and a thermal state; resets the lags after invalid input or a seq gap.
//
//   n_M2  = physics model with effect terms (physics.h)
//   x     = [v, i, n_M2, i(t-1), n_M2(t-1)]   (lags = current values after a reset)
//   w     = gate.weight(x)                    nearness to the training rows (gate.h)
//   n_M3  = n_M2 + w * clamp(MLP(scale(x)))   inside the training envelope
//   n_M3  = n_M2                              outside it (fallback), or where w = 0
//
// w is the estimate's confidence in the learned correction: 1 near the training
// data, fading to 0 away from it (status "gated" where it is below 1), 0 where
// the network does not apply. The network is not evaluated where w = 0.
//
// Bounds (limits.h): a period outside [kPeriodMin_s, kPeriodMax_s] is no
// sample-to-sample step, so the sample starts a new segment (no di/dt; lags
// restart) but is used; an n_M2 beyond the model's speed range
// (speed_limit_rpm) is no speed, so the sample is invalid; the winding stays
// within [reference, kWindingMax_C] (thermal.h).
//
// The dynamic family (dynamics.h), where the model names it (its header's kDynamics, passed to
// the constructor): n_M2 above is the back-EMF speed, the measurement of DynamicsObserver, and
// its estimate takes n_M2's place in everything after (the features, rpm_m2, rpm). It restarts
// with the lags (a new segment). Not named: not called, the observer as before bit for bit.
// Observer<Net, false> compiles without it (the UNO's uno_acq with a model that does not name it,
// 1.8 KB of flash less): Observer<Net, dynamics_named(kDynamics)> decides from the model
// header itself (its kDynamics is a constant expression).
#ifndef HPDDO_OBSERVER_H
#define HPDDO_OBSERVER_H

#include <stdint.h>

#include "clamp.h"
#include "dynamics.h"
#include "model.h"
#include "physics.h"
#include "platform.h"
#include "thermal.h"

namespace hpddo {

/// What the observer did with a sample.
enum Status : uint8_t {
  kStatusOk = 0,        ///< physics plus the learned residual
  kStatusClamped = 1,   ///< residual limited to the clamp bound
  kStatusFallback = 2,  ///< outside the training envelope (per-feature box): physics alone
  kStatusInvalid = 3,   ///< reading not usable: estimate held, lags reset
  kStatusGated = 4,     ///< inside the box, away from the training rows: residual scaled by the confidence < 1 (0: physics alone)
};

/// Short lower-case name of a status, for logs and telemetry.
inline const char* status_name(Status s) {
  switch (s) {
    case kStatusOk: return "ok";
    case kStatusClamped: return "clamped";
    case kStatusFallback: return "fallback";
    case kStatusGated: return "gated";
    default: return "invalid";
  }
}

/// One sample: means over the sample period.
struct Sample {
  float v_V;      ///< terminal voltage, V
  float i_A;      ///< armature current, A
  float temp_C;   ///< case temperature, C; NaN where not read
  float dt_s;     ///< time since the previous sample, s
  uint16_t seq;   ///< sample counter of the acquisition board
  bool has_seq;   ///< false where the source carries no counter
};

/// One estimate. rpm is always finite.
struct Estimate {
  float rpm;           ///< output-shaft speed estimate, RPM
  float rpm_m2;        ///< physics model alone, RPM (held when invalid)
  float residual_rpm;  ///< learned correction applied, RPM
  float temp_C;        ///< winding temperature the thermal effects used, C
  float confidence;    ///< weight of the learned correction, 0..1 (the gate's; 0: physics alone)
  Status status;
};

namespace detail {

/// The gate's weight of the features x; a fixed-point model's integer gate also leaves the
/// quantised features in xq (gate_q.h), for its network.
template <class Gate>
inline float gate_weight(const Gate& gate, const float (&x)[kFeatureCount], uint8_t* first,
                         int16_t (&)[kFeatureCount]) {
  return gate.weight(x, first);
}
inline float gate_weight(const FeatureGateQ& gate, const float (&x)[kFeatureCount], uint8_t* first,
                         int16_t (&xq)[kFeatureCount]) {
  return gate.weight(x, first, xq);
}

/// The network's residual of features x, RPM: scaler and network.
template <class Net>
struct Residual {
  static float of(const Model<Net>& m, const float (&x)[kFeatureCount], const int16_t (&)[kFeatureCount]) {
    return Net::residual(m.scaler, m.weights, x);
  }
};
/// The fixed-point network takes the inputs the gate quantised (the same exponents: the
/// generated models share one array), else quantises them itself.
template <uint8_t kIn, uint8_t kH1, uint8_t kH2, class WH, uint8_t kR0, uint8_t kR1, class W0>
struct Residual<MlpQ<kIn, kH1, kH2, WH, kR0, kR1, W0> > {
  typedef MlpQ<kIn, kH1, kH2, WH, kR0, kR1, W0> Net;
  static float of(const Model<Net>& m, const float (&x)[kFeatureCount], const int16_t (&xq)[kFeatureCount]) {
    if (m.gate.in_exp == m.weights.in_exp) return Net::forward_q(m.weights, xq);
    return Net::residual(m.scaler, m.weights, x);
  }
};

}  // namespace detail

/// Per-sample observer over a Model; no heap, a few dozen bytes of state. kWithDynamics: whether
/// the dynamic family is compiled in (true, the default: it runs where the model names it; false:
/// never; derive it from the model header, Observer<Net, dynamics_named(kDynamics)>, so that a
/// model that names the family is never run without it).
template <class Net, bool kWithDynamics = true>
class Observer {
  static_assert(Net::kInputs == kFeatureCount,
                "hpddo::Observer: the network must take the kFeatureCount residual features (Mlp<5, H1, H2>)");

 public:
  /// Keeps a reference to model: pass one that outlives the observer (a generated kModel).
  /// dynamics: the model's dynamic family (its header's kDynamics; kDynamicsOff: none), kept
  /// by reference as the model. Starts in the state reset() leaves. constexpr (C++11: every
  /// member in the list, an empty body): a global observer of a generated model is
  /// constant-initialised, its state in the data image, no constructor code (the UNO's g_obs:
  /// 318 bytes of constructor code there before; docs/firmware.md).
  constexpr explicit Observer(const Model<Net>& model, const DynamicsParams& dynamics = kDynamicsOff)
      : model_(&model),
        physics_const_(physics_const(model.physics)),
        speed_limit_rpm_(speed_limit_rpm(model.physics, model.limits)),
        thermal_on_(ThermalEstimator::enabled(model.physics)),
        inductance_on_(model.physics.la_H != 0.0f),
        thermal_(),
        last_{0.0f, 0.0f, 0.0f, 0.0f, 0.0f, kStatusInvalid},  // reset()'s: Estimate(), status invalid
        dynamics_(&dynamics),
        dyn_() {}

  /// A temporary Model would leave the observer with a dangling reference.
  explicit Observer(const Model<Net>&& model) = delete;
  Observer(const Model<Net>& model, const DynamicsParams&& dynamics) = delete;

  /// Forgets the lags and the held estimate; the winding restarts at its reference (the
  /// state the constructor leaves: keep the two alike).
  void reset() {
    has_lag_ = false;
    has_seq_ = false;
    last_seq_ = 0;
    last_ = Estimate();
    last_.status = kStatusInvalid;
    thermal_.reset();
    gate_first_ = 0;
    seq_gaps_ = 0;
    period_breaks_ = 0;
    dyn_.reset();
  }

  /// Forgets the one-step lags only: the next sample starts a new segment, as
  /// after a seq gap (the thermal state and the held estimate stay).
  void restart_lags() { has_lag_ = false; }

  /// Number of seq gaps seen since reset().
  uint32_t seq_gaps() const { return seq_gaps_; }

  /// Number of usable samples since reset() whose period lay outside
  /// [kPeriodMin_s, kPeriodMax_s]; each started a new segment.
  uint32_t period_breaks() const { return period_breaks_; }

  /// Largest |n_M2| the model's limits allow, RPM; beyond it a sample is invalid.
  float speed_limit() const { return speed_limit_rpm_; }

  /// What the observer knows of a sample before the network runs (prepare()):
  /// the physics estimate, the network's inputs and whether the network applies.
  struct Prepared {
    Estimate physics;         ///< rpm = rpm_m2, status fallback; status invalid: no usable reading
    float x[kFeatureCount];   ///< the network's inputs [v, i, n_M2, i(t-1), n_M2(t-1)]
    int16_t xq[kFeatureCount];  ///< fixed-point model: x quantised by the gate, for the network (where use_network)
    float confidence;         ///< the gate's weight inside the envelope, else 0
    bool use_network;         ///< confidence > 0: the residual applies
  };

  /// Turns one sample into an estimate: prepare(), the network where it applies, finish().
  Estimate step(const Sample& s) {
    const Prepared p = prepare(s);
    return finish(p, p.use_network ? residual(p) : 0.0f);
  }

  /// The first half of step(): seq and period bookkeeping, thermal state, physics
  /// model and the lags, for one sample. Call finish() on every result, in order.
  Prepared prepare(const Sample& s) {
    Prepared out;
    out.use_network = false;
    out.confidence = 0.0f;
    out.physics = Estimate();
    out.physics.status = kStatusInvalid;
    for (uint8_t j = 0; j < kFeatureCount; ++j) {
      out.x[j] = 0.0f;
      out.xq[j] = 0;
    }
    const PhysicsParams& p = model_->physics;
    if (s.has_seq) {
      if (has_seq_ && s.seq != static_cast<uint16_t>(last_seq_ + 1u)) {
        ++seq_gaps_;
        has_lag_ = false;
      }
      has_seq_ = true;
      last_seq_ = s.seq;
    }
    if (!reading_valid(s)) {
      has_lag_ = false;
      return out;
    }

    const float dt_s = s.dt_s;
    if (!within(dt_s, kPeriodMin_s, kPeriodMax_s)) {  // order-key compares (platform.h): exact, cheap
      ++period_breaks_;
      has_lag_ = false;
    }
    const bool temp_read = is_finite(s.temp_C) && within(s.temp_C, model_->limits.temp_min_C, model_->limits.temp_max_C);
    const float ref_C = temp_read ? s.temp_C : p.t_amb_C;
    if (thermal_on_) thermal_.step(p, true_current_A(p, s.i_A), dt_s, ref_C);  // off: it would not move
    PhysicsInput in;
    in.v_V = s.v_V;
    in.i_A = s.i_A;
    // di/dt only where the inductance term uses it (la_H = 0: no division).
    in.di_dt_A_per_s = has_lag_ && inductance_on_ ? (s.i_A - i_lag_A_) / dt_s : 0.0f;
    // The copper follows the winding (estimated above the case reading, or above the
    // ambient); the magnets sit on the case: its reading, else the only thermal state.
    in.temp_C = thermal_on_ ? thermal_.temp_C(ref_C) : (temp_read ? s.temp_C : p.t_ref_C);
    in.magnet_C = temp_read ? s.temp_C : in.temp_C;
    float m2 = 0.0f;
    if (!physics_rpm(p, physics_const_, in, &m2) || !within(m2, -speed_limit_rpm_, speed_limit_rpm_)) {
      has_lag_ = false;
      return out;
    }
    if (kWithDynamics && dynamics_named(*dynamics_)) {  // the dynamic family: n_M2 is its measurement (dynamics.h)
      if (!has_lag_) dyn_.reset();
      m2 = dyn_.step(p.ke_vs_per_rad, *dynamics_, true_current_A(p, s.i_A), m2, dt_s);
    }

    out.x[kFeatV] = s.v_V;
    out.x[kFeatI] = s.i_A;
    out.x[kFeatM2] = m2;
    out.x[kFeatILag] = has_lag_ ? i_lag_A_ : s.i_A;
    out.x[kFeatM2Lag] = has_lag_ ? m2_lag_rpm_ : m2;
    i_lag_A_ = s.i_A;
    m2_lag_rpm_ = m2;
    has_lag_ = true;

    out.physics.rpm = m2;
    out.physics.rpm_m2 = m2;
    out.physics.temp_C = in.temp_C;
    out.physics.residual_rpm = 0.0f;
    out.physics.status = kStatusFallback;
    if (model_->envelope.contains(out.x)) {
      out.confidence = detail::gate_weight(model_->gate, out.x, &gate_first_, out.xq);
      if (!above_zero(out.confidence)) out.physics.status = kStatusGated;  // inside the box, far from the rows
    }
    out.use_network = above_zero(out.confidence);
    return out;
  }

  /// The network's residual for a prepared sample, RPM, unclamped (scaler and MLP; a
  /// fixed-point network has the scaler folded into its first layer).
  float residual(const Prepared& p) const { return detail::Residual<Net>::of(*model_, p.x, p.xq); }

  /// The second half of step(): the estimate of a prepared sample, given the
  /// network's residual (ignored where the network does not apply; a non-finite
  /// one leaves physics alone): clamped, then scaled by the confidence. Call once
  /// per prepare(), in the same order: an invalid sample holds the estimate of
  /// the sample finished before it.
  Estimate finish(const Prepared& p, float residual_rpm) {
    if (p.physics.status == kStatusInvalid) {
      Estimate e = last_;
      e.residual_rpm = 0.0f;
      e.confidence = 0.0f;
      e.status = kStatusInvalid;
      return e;
    }
    Estimate e = p.physics;
    if (p.use_network && is_finite(residual_rpm)) {
      const bool clamped = clamp_residual(model_->clamp_rpm, &residual_rpm);
      e.status = p.confidence < 1.0f ? kStatusGated : clamped ? kStatusClamped : kStatusOk;
      e.residual_rpm = p.confidence * residual_rpm;
      e.confidence = p.confidence;
    }
    e.rpm = e.rpm_m2 + e.residual_rpm;
    last_ = e;
    return e;
  }

 private:
  bool reading_valid(const Sample& s) const {
    const InputLimits& lim = model_->limits;
    // The floats' order keys (platform.h): the float compares' results at a fifth of the
    // cycles on the AVR; a key above 0 is a float above 0 (-0's key is 0).
    return is_finite(s.v_V) && is_finite(s.i_A) && within(s.v_V, -lim.v_max_V, lim.v_max_V) &&
           within(s.i_A, -lim.i_max_A, lim.i_max_A) && order_key(s.dt_s) > 0 && is_finite(s.dt_s);
  }

  const Model<Net>* model_;  ///< a pointer, not a reference: an observer can be assigned (a new model in force)
  PhysicsConst physics_const_;  ///< the model's reciprocals: no division per step (physics.h)
  float speed_limit_rpm_;
  bool thermal_on_;     ///< the model's thermal node is on (ThermalEstimator::enabled), once per model
  bool inductance_on_;  ///< the model's inductance term is on (la_H != 0): di/dt is needed
  ThermalEstimator thermal_;
  Estimate last_;
  float i_lag_A_ = 0.0f;
  float m2_lag_rpm_ = 0.0f;
  uint16_t last_seq_ = 0;
  uint8_t gate_first_ = 0;  ///< the gate's nearest prototype at the previous sample: tried first
  bool has_lag_ = false;
  bool has_seq_ = false;
  uint32_t seq_gaps_ = 0;
  uint32_t period_breaks_ = 0;
  const DynamicsParams* dynamics_;  ///< the model's dynamic family (kDynamicsOff: none)
  DynamicsObserver dyn_;            ///< its state, where named
};

}  // namespace hpddo

#endif  // HPDDO_OBSERVER_H
