// Instantiates every template of the core with both fixture models, so that
// each compiler sees all of the code, not just the declarations.
#ifdef HPDDO_WITH_ARDUINO_H
#include <Arduino.h>
#elif defined(HPDDO_WITH_ARDUINO_MACROS)
#include "arduino_macros.h"
#endif
#include "hpddo_core.h"
#include "model_tiny.h"
#include "model_tiny1.h"

template <class Net>
static float run(const hpddo::Model<Net>& model, float v_V, float i_A) {
  hpddo::Observer<Net> obs(model);
  hpddo::Sample s = {v_V, i_A, hpddo::absent(), 0.5f, 1, true};
  const hpddo::Estimate e = obs.step(s);
  return e.rpm + static_cast<float>(hpddo::model_checksum(model) & 1u);
}

float hpddo_instantiate(float v_V, float i_A, uint8_t in_byte) {
  hpddo::FrameDecoder dec;
  hpddo::SampleFrame f;
  float extra = dec.push(in_byte, &f) ? hpddo::frame_v_V(f) : 0.0f;
  uint8_t buf[hpddo::kFrameSize];
  hpddo::encode_frame(f, buf);
  return run(hpddo_model_tiny::kModel, v_V, i_A) + run(hpddo_model_tiny1::kModel, v_V, i_A) + extra +
         static_cast<float>(buf[3]);
}
