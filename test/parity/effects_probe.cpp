// effects_probe: evaluates hpddo_core's physics terms for the parameter sets and inputs
// given on stdin, for the Python/C++ parity test (test/py/test_effects_parity.py).
//
// stdin, one case per line:
//   P <every PhysicsParams field>            (new parameters, in the order of the generated
//                                            hpddo::for_each_param: the floats, then the
//                                            effect bits as an unsigned integer)
//   X v_V i_A di_dt winding_C magnet_C       -> prints physics_rpm (or "invalid")
//   T i_A dt_s ref_C                         -> prints the winding temperature after one step
//                                               above the reference ref_C
// stdout: one value per X or T line, %.9g.
#include <cstdio>
#include <cstring>

#include "hpddo/physics.h"
#include "hpddo/thermal.h"

namespace {

// for_each_param() visitor: reads every field of a P line.
struct ReadField {
  bool ok;
  void operator()(float& x) { ok = ok && std::scanf("%f", &x) == 1; }
  void operator()(uint16_t& bits) {
    unsigned u = 0;
    ok = ok && std::scanf("%u", &u) == 1;
    bits = static_cast<uint16_t>(u);
  }
};

}  // namespace

int main() {
  hpddo::PhysicsParams p = hpddo::PhysicsParams();
  hpddo::ThermalEstimator th;
  char tag[4];
  while (std::scanf("%3s", tag) == 1) {
    if (std::strcmp(tag, "P") == 0) {
      ReadField read = {true};
      hpddo::for_each_param(p, read);
      if (!read.ok) return 2;
      th.reset();
    } else if (std::strcmp(tag, "X") == 0) {
      hpddo::PhysicsInput in;
      if (std::scanf("%f %f %f %f %f", &in.v_V, &in.i_A, &in.di_dt_A_per_s, &in.temp_C, &in.magnet_C) != 5) return 2;
      float n = 0.0f;
      if (hpddo::physics_rpm(p, in, &n)) std::printf("%.9g\n", static_cast<double>(n));
      else std::printf("invalid\n");
    } else if (std::strcmp(tag, "T") == 0) {
      float i = 0.0f, dt = 0.0f, ref = 0.0f;
      if (std::scanf("%f %f %f", &i, &dt, &ref) != 3) return 2;
      th.step(p, i, dt, ref);
      std::printf("%.9g\n", static_cast<double>(th.temp_C(ref)));
    } else {
      return 2;
    }
  }
  return 0;
}
