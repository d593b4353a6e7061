// The plain motor of the core's unit tests: the bundled bench's M2 rounded (4.5 ohm,
// 0.406 V s/rad), every effect off. Tests add the effect they exercise.
#ifndef HPDDO_TEST_MOTOR_H
#define HPDDO_TEST_MOTOR_H

#include "hpddo/physics.h"

namespace motor {

/// Ra and Ke of the test motor, identified at t_ref_C; every other field its default.
inline hpddo::PhysicsParams plain(float t_ref_C) {
  hpddo::PhysicsParams p = hpddo::PhysicsParams();
  p.ra_ohm = 4.5f;
  p.ke_vs_per_rad = 0.406f;
  p.t_ref_C = t_ref_C;
  return p;
}

}  // namespace motor

#endif
