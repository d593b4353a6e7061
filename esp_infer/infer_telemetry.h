// The values of one telemetry line of the inference board, and the step that
// produces them. The sketch measures the time and writes the JSON; this
// header decides what goes in it, so the host tests see the same values.
//
//   {"seq":412,"rpm":181.3,"rpm_m2":175.2,"residual":6.1,"confidence":1,"status":"ok",
//    "us":812,"rpm_ref":180.4,"v":9.612,"i":0.812,"gaps":0,"lost":0,"crc_errors":0}
#ifndef HPDDO_INFER_TELEMETRY_H
#define HPDDO_INFER_TELEMETRY_H

#include <stdint.h>

#include "hpddo/observer.h"
#include "infer_link.h"

namespace infer {

/// One line of telemetry.
struct Telemetry {
  uint16_t seq;
  float rpm;            ///< final estimate n_M3, RPM
  float rpm_m2;         ///< physics model alone, RPM
  float residual_rpm;   ///< learned correction applied, RPM
  float confidence;     ///< weight of the learned correction, 0..1 (the novelty gate's)
  hpddo::Status status;
  uint32_t infer_us;    ///< measured time of Observer::step, us
  float rpm_ref;        ///< encoder speed from the frame, comparison only (NaN: none)
  float v_V;
  float i_A;
  uint32_t gaps;
  uint32_t lost;
  uint32_t crc_errors;
};

/// Runs the observer on one frame, restarting its lags first when the frame
/// followed a gap the link saw. now_us() is a clock in microseconds (the
/// sketch passes micros); the time of the observer step goes into infer_us.
template <class Net, class Clock>
Telemetry infer_step(hpddo::Observer<Net>& obs, const hpddo::SampleFrame& f, const LinkReceiver& link,
                     Clock now_us) {
  const hpddo::Sample s = sample_from_frame(f);
  if (link.new_segment()) obs.restart_lags();
  const uint32_t t0 = now_us();
  const hpddo::Estimate e = obs.step(s);
  const uint32_t t1 = now_us();
  Telemetry t;
  t.seq = f.seq;
  t.rpm = e.rpm;
  t.rpm_m2 = e.rpm_m2;
  t.residual_rpm = e.residual_rpm;
  t.confidence = e.confidence;
  t.status = e.status;
  t.infer_us = t1 - t0;
  t.rpm_ref = frame_rpm_ref(f);
  t.v_V = s.v_V;
  t.i_A = s.i_A;
  t.gaps = link.gaps();
  t.lost = link.lost();
  t.crc_errors = link.crc_errors();
  return t;
}

}  // namespace infer

#endif  // HPDDO_INFER_TELEMETRY_H
