// Cycle-exact cost of the observer on the ATmega328P (run in simavr by cycles_sim.c):
// one full Observer::step per golden row of models/default, float, fixed point int16
// (-DHPDDO_BENCH_FIXED) or int8 (-DHPDDO_BENCH_INT8), then each stage alone. Every timed region is framed by two
// writes to GPIOR0 (1: start, 2: stop) with its stage id in GPIOR1; the harness reads
// the cycle counter at each write. Each step's estimate is checked against the golden
// row (1e-4 relative, golden.h's rule); the number of misses goes to GPIOR2 at the end.
//
// -DHPDDO_BENCH_SIZE: one step on volatile inputs and nothing else, for avr-size.
// -DHPDDO_BENCH_EMLEARN: emlearn's predict on the same network (the peer), inputs z of
// the golden rows; the generated model comes from the build folder (bench/avr.py).
#include <avr/io.h>
#include <stdint.h>

#if defined(HPDDO_BENCH_EMLEARN)
#include "hpddo_emlearn_model.h"
#include "golden_default.h"
namespace g = hpddo_golden_default;
#else
// The observer built as uno_acq builds it: with the dynamic family only where the model
// names it (models/default does not), Observer<Net, dynamics_named(kDynamics)>.
#include "hpddo/dynamics.h"
HPDDO_DYNAMICS_DEFAULT(hpddo_model_default)
HPDDO_DYNAMICS_DEFAULT(hpddo_model_default_q)
HPDDO_DYNAMICS_DEFAULT(hpddo_model_default_q8)
#include "model_default_q.h"
#include "model_default_q8.h"
#include "model_tiny.h"  // every effect term on and a thermal node: their cost
#if defined(HPDDO_BENCH_INT8)  // the int8 model (model_default_q8.h)
#define HPDDO_BENCH_INTEGER 1
#include "golden_default_q8.h"
namespace m = hpddo_model_default_q8;
namespace g = hpddo_golden_default_q8;
#elif defined(HPDDO_BENCH_FIXED)
#define HPDDO_BENCH_INTEGER 1
#include "golden_default_q.h"
namespace m = hpddo_model_default_q;
namespace g = hpddo_golden_default_q;
#else
#include "golden_default.h"
namespace m = hpddo_model_default;
namespace g = hpddo_golden_default;
#endif
using Obs = hpddo::Observer<m::Net, hpddo::dynamics_named(m::kDynamics)>;
#endif

enum Stage : uint8_t {
  kStageStep = 1, kStagePrepare, kStageResidual, kStageFinish, kStagePhysics, kStageEnvelope, kStageGate,
  kStageThermal, kStageScaler, kStagePeer, kStagePhysicsAll, kStageThermalOn, kStageGateHinted,
};

#define BARRIER() __asm__ __volatile__("" ::: "memory")
static inline void start(uint8_t stage) {
  GPIOR1 = stage;
  BARRIER();
  GPIOR0 = 1;
  BARRIER();
}
static inline void stop() {
  BARRIER();
  GPIOR0 = 2;
  BARRIER();
}

volatile float g_sink;
volatile uint8_t g_sink8;

__attribute__((unused)) static bool close(float got, float want) {
  if (want != want) return got != got;
  const float scale = (want > 1.0f || want < -1.0f) ? (want < 0 ? -want : want) : 1.0f;
  const float d = got - want;
  return (d < 0 ? -d : d) <= 1e-4f * scale;
}

#if defined(HPDDO_BENCH_SIZE) && defined(HPDDO_BENCH_EMLEARN)
volatile float g_z = 0.1f;
int main() {
  for (;;) {
    const float z[5] = {g_z, g_z, g_z, g_z, g_z};
    g_sink = hpddo_emlearn_predict(z);
  }
}
#elif defined(HPDDO_BENCH_SIZE)
volatile float g_v = 9.0f, g_i = 0.9f, g_t = 36.0f;
int main() {
  Obs obs(m::kModel);
  for (;;) {
    hpddo::Sample s = {g_v, g_i, g_t, 0.01f, 1, true};
    g_sink = obs.step(s).rpm;
  }
}
#elif defined(HPDDO_BENCH_EMLEARN)
int main() {
  uint8_t bad = 0;
  for (uint16_t r = 0; r < g::kCount; ++r) {
    const float want = g::at(r, g::kCol_mlp_rpm);
    if (want != want) continue;  // the network did not run on this row
    float z[5];
    for (uint8_t j = 0; j < 5; ++j) z[j] = g::at(r, static_cast<uint8_t>(g::kCol_z0 + j));
    start(kStagePeer);
    const float y = hpddo_emlearn_predict(z);
    stop();
    // emlearn prints its weights with 6 decimals: about 1e-3 RPM from the float model.
    const float d = y - want;
    if ((d < 0 ? -d : d) > 0.05f) ++bad;
    g_sink = y;
  }
  GPIOR2 = bad;
  GPIOR0 = 3;
  for (;;) {
  }
}
#else
int main() {
  uint8_t bad = 0;
  {
    Obs obs(m::kModel);
    for (uint16_t r = 0; r < g::kCount; ++r) {
      const hpddo::Sample s = g::sample(r);
      start(kStageStep);
      const hpddo::Estimate e = obs.step(s);
      stop();
      if (!close(e.rpm, g::at(r, g::kCol_rpm)) || e.status != static_cast<uint8_t>(g::at(r, g::kCol_status))) {
        if (bad < 255) ++bad;
      }
      g_sink = e.rpm;
    }
  }
  {  // The stages of step(), in order, over the same stream.
    Obs obs(m::kModel);
    for (uint16_t r = 0; r < g::kCount; ++r) {
      const hpddo::Sample s = g::sample(r);
      start(kStagePrepare);
      const Obs::Prepared p = obs.prepare(s);
      stop();
      float res = 0.0f;
      if (p.use_network) {
        start(kStageResidual);
        res = obs.residual(p);
        stop();
      }
      start(kStageFinish);
      const hpddo::Estimate e = obs.finish(p, res);
      stop();
      g_sink = e.rpm;
    }
  }
  // The pieces of prepare() and residual() alone, on the golden rows' features.
  const hpddo::PhysicsParams& pp = m::kModel.physics;
  hpddo::ThermalEstimator th;
  hpddo::ThermalEstimator th_on;
  const hpddo::PhysicsParams& all = hpddo_model_tiny::kModel.physics;
  // The reciprocals the observer computes once (physics.h): the stages time the step's physics.
  const hpddo::PhysicsConst pk = hpddo::physics_const(pp);
  const hpddo::PhysicsConst all_k = hpddo::physics_const(all);
  uint8_t gate_first = 0;
  for (uint16_t r = 0; r < g::kCount; ++r) {
    float x[5];
    for (uint8_t j = 0; j < 5; ++j) x[j] = g::at(r, static_cast<uint8_t>(g::kCol_x0 + j));
    if (x[0] != x[0]) continue;
    hpddo::PhysicsInput in;
    in.v_V = g::at(r, g::kCol_v_V);
    in.i_A = g::at(r, g::kCol_i_A);
    in.di_dt_A_per_s = 0.0f;
    in.temp_C = g::at(r, g::kCol_temp_used_C);
    in.magnet_C = in.temp_C;
    float rpm = 0.0f;
    start(kStagePhysics);
    const bool ok = hpddo::physics_rpm(pp, pk, in, &rpm);
    stop();
    start(kStageThermal);
    th.step(pp, in.i_A, 0.5f, 31.0f);
    stop();
    float rpm_all = 0.0f;
    start(kStagePhysicsAll);
    const bool ok_all = hpddo::physics_rpm(all, all_k, in, &rpm_all);
    stop();
    start(kStageThermalOn);
    th_on.step(all, in.i_A, 0.5f, 31.0f);
    stop();
    start(kStageEnvelope);
    const bool inside = m::kModel.envelope.contains(x);
    stop();
    start(kStageGate);
    const float w = m::kModel.gate.weight(x);
    stop();
    // As in the step: the search starts at the previous row's nearest prototype.
    start(kStageGateHinted);
    const float w_hinted = m::kModel.gate.weight(x, &gate_first);
    stop();
    if (w_hinted != w && bad < 255) ++bad;
    float z[5] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
#if !defined(HPDDO_BENCH_INTEGER)  // the fixed-point network has the scaler folded into layer 0
    start(kStageScaler);
    m::kModel.scaler.transform(x, z);
    stop();
#endif
    g_sink = rpm + w + z[0] + th.rise_K() + rpm_all + th_on.rise_K();
    g_sink8 = static_cast<uint8_t>(ok + inside + ok_all);
  }
#if defined(HPDDO_BENCH_INTEGER)
  // The integer network on the board against the integer reference, bit for bit.
  for (uint16_t r = 0; r < g::kCount; ++r) {
    float x[5];
    for (uint8_t j = 0; j < 5; ++j) x[j] = g::at(r, static_cast<uint8_t>(g::kCol_x0 + j));
    int16_t xq[5];
    m::Net::quantise(m::kModel.weights, x, xq);
    if (m::Net::forward_acc(m::kModel.weights, xq) != g::int_at(r, g::kInt_acc) && bad < 255) ++bad;
  }
#endif
  GPIOR2 = bad;
  GPIOR0 = 3;  // done
  for (;;) {
  }
}
#endif
