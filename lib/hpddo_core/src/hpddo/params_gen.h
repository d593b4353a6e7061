// GENERATED parameter schema: DO NOT EDIT. Regenerate with the command below.
// command: cd tools && ../.venv/bin/python -m hpddo.regenerate --write
// source: tools/hpddo/schema.py
// generator: hpddo.schema 1
// layout: crc32 0x432e337e (kParamsSchema)
// checksum: crc32 0x93a80e5d of the text below this banner
#ifndef HPDDO_PARAMS_GEN_H
#define HPDDO_PARAMS_GEN_H

#include <stdint.h>

namespace hpddo {

/// CRC-32 of the parameter layout (field names, types and order, effect bits). A model
/// header asserts that it was written for this layout.
static const uint32_t kParamsSchema = 0x432e337eu;

/// Bit of each effect in PhysicsParams::effects, for reporting and telemetry.
enum Effect : uint16_t {
  kEffectThermalRa = 1u << 0,           ///< thermal_ra: copper resistance rises with T
  kEffectMagnetThermal = 1u << 1,       ///< magnet_thermal: magnet flux falls with T
  kEffectBrushDrop = 1u << 2,           ///< brush_drop: brush-commutator contact drop
  kEffectSaturation = 1u << 3,          ///< saturation: armature reaction, Ke falls with |i|
  kEffectCurrentOffset = 1u << 4,       ///< current_offset: offset of the current channel
  kEffectVGain = 1u << 5,               ///< v_gain: gain error of the voltage channel
  kEffectInductance = 1u << 6,          ///< inductance: la di/dt, visible at high rates
  kEffectVOffset = 1u << 7,             ///< v_offset: offset of the voltage channel
  kEffectCurrentOffsetDrift = 1u << 8,  ///< current_offset_drift: current offset drifting with the case temperature
};

/// Every effect bit of the library.
static const uint16_t kEffectsAll = 0x01ffu;

/// The material constant of an effect (what a fitted coefficient is checked against; the
/// board's ripple counter turns Ra into a winding temperature with copper's).
static const float kMaterialThermalRa = 0.00393f;     ///< thermal_ra: copper, 1/K
static const float kMaterialMagnetThermal = -0.002f;  ///< magnet_thermal: magnets, 1/K

/// Lumped parameters of one motor-drivetrain assembly, all in SI units, speed
/// at the output shaft. Effect coefficients at zero switch their effect off.
/// Constructor-free: a model header initialises it in field order.
struct PhysicsParams {
  float ra_ohm;               ///< armature resistance at t_ref_C, ohm
  float ke_vs_per_rad;        ///< back-EMF constant at t_ref_C and zero current, V s/rad
  float t_ref_C;              ///< temperature at which ra_ohm and ke_vs_per_rad hold, C
  float ra_tc_per_K;          ///< thermal_ra: relative change of Ra per kelvin (copper +0.00393), 1/K
  float ke_tc_per_K;          ///< magnet_thermal: relative change of Ke per kelvin (ferrite ~ -0.002), 1/K
  float brush_V;              ///< brush_drop: total brush contact drop at full conduction, V
  float ke_sat_per_A;         ///< saturation: relative fall of Ke per ampere of |i|, 1/A
  float i_offset_A;           ///< current_offset: reading minus true current, A
  float v_gain;               ///< v_gain: reading / true voltage - 1, dimensionless
  float la_H;                 ///< inductance: armature inductance, H
  float v_offset_V;           ///< v_offset: reading minus true voltage, V
  float i_offset_tc_A_per_K;  ///< current_offset_drift: change of the current channel's offset per kelvin of the case above t_ref_C, A/K
  float brush_knee_A;         ///< brush_drop shape: current scale over which the brush drop builds up (half of it at the knee for order 1), A
  float brush_order;          ///< brush_drop shape: how sharply the brush drop levels off: 1 i/(|i|+knee), 2 i/sqrt(i^2+knee^2), the blend between, dimensionless
  float ke_sat_quad;          ///< saturation shape: share of the armature reaction that grows with i^2 (per 1 A) instead of |i|, dimensionless
  float th_r_K_per_W;         ///< thermal state: winding-to-ambient resistance (0: no estimate), K/W
  float th_tau_s;             ///< thermal state: time constant, s
  float t_amb_C;              ///< thermal state: ambient temperature, C
  uint16_t effects;           ///< Effect bits that are on (informative; zero coefficients are off)
};

/// Number of PhysicsParams fields, the effect bits included.
static const uint8_t kPhysicsParamCount = 19;

/// Calls f(p.field) for every PhysicsParams field in the schema's order, the order of
/// the struct, of a model header's initialiser and of model_checksum(): each float
/// coefficient, then the effect bits (uint16_t). Params is PhysicsParams or const
/// PhysicsParams; F has operator() for float and uint16_t (or their references).
template <class Params, class F>
inline void for_each_param(Params& p, F& f) {
  f(p.ra_ohm);
  f(p.ke_vs_per_rad);
  f(p.t_ref_C);
  f(p.ra_tc_per_K);
  f(p.ke_tc_per_K);
  f(p.brush_V);
  f(p.ke_sat_per_A);
  f(p.i_offset_A);
  f(p.v_gain);
  f(p.la_H);
  f(p.v_offset_V);
  f(p.i_offset_tc_A_per_K);
  f(p.brush_knee_A);
  f(p.brush_order);
  f(p.ke_sat_quad);
  f(p.th_r_K_per_W);
  f(p.th_tau_s);
  f(p.t_amb_C);
  f(p.effects);
}

/// The dynamic family (inertia and friction at the output shaft, with the inductance effect
/// la_H of PhysicsParams): Kt i = J dw/dt + B w + Tc sgn(w) + T_load, Kt = Ke. Computed on the
/// boards when named (j_kgm2 > 0; dynamics.h), its own struct so that PhysicsParams and
/// kParamsSchema do not change. Constructor-free, initialised in field order.
struct DynamicsParams {
  float j_kgm2;         ///< inertia of the shaft and all it drives, at the output shaft (0: the family is off), kg m^2
  float b_nms_per_rad;  ///< viscous friction at the output shaft (bearings, gearbox oil, a coupled machine's), N m s/rad
  float tc_nm;          ///< Coulomb friction at the output shaft (brushes, gear mesh, seals): a torque against the motion, N m
  float tau_obs_s;      ///< the observer's time constant: how fast the back-EMF speed pulls the mechanical model back (a filter's setting, not the motor's), s
};

/// Number of DynamicsParams fields.
static const uint8_t kDynamicsParamCount = 4;

}  // namespace hpddo

#endif  // HPDDO_PARAMS_GEN_H
