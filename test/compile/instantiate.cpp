// Instantiates every template of the core with the fixture models (float and fixed point), so that
// each compiler sees all of the code, not just the declarations.
#ifdef HPDDO_WITH_ARDUINO_H
#include <Arduino.h>
#elif defined(HPDDO_WITH_ARDUINO_MACROS)
#include "arduino_macros.h"
#endif
#include "hpddo_core.h"
#include "model_tiny.h"
#include "model_tiny1.h"
#include "model_tiny1_q.h"
#include "model_tiny_q.h"

template <class Net>
static float run(const hpddo::Model<Net>& model, float v_V, float i_A) {
  hpddo::Observer<Net> obs(model);
  hpddo::Sample s = {v_V, i_A, hpddo::absent(), 0.5f, 1, true};
  const hpddo::Estimate e = obs.step(s);
  return e.rpm + static_cast<float>(hpddo::model_checksum(model) & 1u);
}

// A novelty gate over the five features and the temperature (gate.h), 2 prototypes.
HPDDO_FLASH static const float kGateCentre[6] = {6.0f, 0.5f, 150.0f, 0.5f, 150.0f, 40.0f};
HPDDO_FLASH static const float kGateScale[6] = {3.0f, 0.3f, 80.0f, 0.3f, 80.0f, 10.0f};
HPDDO_FLASH static const float kGateProtos[12] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f,
                                                  1.0f, 1.0f, 1.0f, 1.0f, 1.0f, -1.0f};
static const hpddo::Gate<6, 2> kGate = {kGateCentre, kGateScale, kGateProtos, 0.25f, 1.0f};

float hpddo_instantiate(float v_V, float i_A, uint8_t in_byte) {
  hpddo::FrameDecoder dec;
  hpddo::SampleFrame f;
  float extra = dec.push(in_byte, &f) ? hpddo::frame_v_V(f) : 0.0f;
  uint8_t buf[hpddo::kFrameSize];
  hpddo::encode_frame(f, buf);
  const float g[6] = {v_V, i_A, 150.0f, i_A, 150.0f, 40.0f};
  return run(hpddo_model_tiny::kModel, v_V, i_A) + run(hpddo_model_tiny1::kModel, v_V, i_A) +
         run(hpddo_model_tiny_q::kModel, v_V, i_A) + run(hpddo_model_tiny1_q::kModel, v_V, i_A) + extra +
         static_cast<float>(buf[3]) + kGate.weight(g);
}
