// Host tests of the inference board's logic (esp_infer/infer_*.h) with the
// model the firmware is built with and its golden vectors.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "infer_link.h"
#include "infer_model.h"
#include "infer_telemetry.h"

#include HPDDO_GOLDEN_HEADER

namespace {

namespace gold = ::HPDDO_GOLDEN_NS;
typedef infer::model::Net Net;

float g(int r, int c) { return gold::at(static_cast<uint16_t>(r), static_cast<uint8_t>(c)); }

hpddo::SampleFrame frame_of(uint16_t seq, float v, float i, float temp, float dt, float rpm) {
  hpddo::SampleFrame f;
  f.seq = seq;
  f.flags = hpddo::kFrameFlagRpm;
  f.duty = 200;
  f.v_mV = static_cast<uint16_t>(hpddo::saturate_round(v * 1000.0f, 0, 65535));
  f.i_mA = static_cast<int16_t>(hpddo::saturate_round(i * 1000.0f, -32768, 32767));
  f.temp_c16 = 0;
  if (!std::isnan(temp)) {
    f.flags |= hpddo::kFrameFlagTemp;
    f.temp_c16 = static_cast<int16_t>(hpddo::saturate_round(temp * 16.0f, -32768, 32767));
  }
  f.rpm_x10 = static_cast<int16_t>(hpddo::saturate_round(rpm * 10.0f, -32768, 32767));
  f.period_us = static_cast<uint32_t>(dt * 1e6f + 0.5f);
  return f;
}

void append(std::vector<uint8_t>& v, const hpddo::SampleFrame& f) {
  uint8_t buf[hpddo::kFrameSize];
  hpddo::encode_frame(f, buf);
  v.insert(v.end(), buf, buf + hpddo::kFrameSize);
}

struct FakeClock {
  uint32_t* t;
  uint32_t operator()() const { return *t += 250; }
};

bool same(const hpddo::Estimate& a, const hpddo::Estimate& b) {
  return a.status == b.status && a.rpm == b.rpm && a.rpm_m2 == b.rpm_m2 && a.residual_rpm == b.residual_rpm;
}

}  // namespace

TEST(InferModel, ChecksumOfTheSelectedModel) {
  EXPECT_EQ(hpddo::model_checksum(infer::model::kModel), infer::model::kChecksum);
}

TEST(InferModel, GoldenVectorsThroughTheSelectedModel) {
  hpddo::Observer<Net> obs(infer::model::kModel);
  for (int r = 0; r < gold::kCount; ++r) {
    const hpddo::Sample s = gold::sample(static_cast<uint16_t>(r));
    const hpddo::Estimate e = obs.step(s);
    const float want = g(r, gold::kCol_rpm);
    EXPECT_NEAR(e.rpm, want, 1e-4f * std::fmax(std::fabs(want), 1.0f)) << "row " << r;
    EXPECT_EQ(static_cast<int>(e.status), static_cast<int>(g(r, gold::kCol_status))) << "row " << r;
  }
}

TEST(InferLink, FramePathEqualsTheObserverOnTheSameSamples) {
  hpddo::Observer<Net> direct(infer::model::kModel);
  hpddo::Observer<Net> via(infer::model::kModel);
  infer::LinkReceiver rx;
  uint32_t clock = 0;
  int checked = 0;
  for (int r = 0; r < gold::kCount; ++r) {
    // Rows a frame can carry: seq, finite readings, a period of the board's range.
    const float dt = g(r, gold::kCol_dt_s);
    if (g(r, gold::kCol_has_seq) == 0.0f || !hpddo::is_finite(g(r, gold::kCol_v_V)) ||
        !hpddo::is_finite(g(r, gold::kCol_i_A)) || !(dt >= 1e-6f * static_cast<float>(hpddo::kFramePeriodMin_us)) ||
        !(dt <= 1e-6f * static_cast<float>(hpddo::kFramePeriodMax_us)))
      continue;
    const hpddo::SampleFrame f = frame_of(static_cast<uint16_t>(g(r, gold::kCol_seq)), g(r, gold::kCol_v_V),
                                          g(r, gold::kCol_i_A), g(r, gold::kCol_temp_C), g(r, gold::kCol_dt_s), 0);
    std::vector<uint8_t> bytes;
    append(bytes, f);
    hpddo::SampleFrame got;
    bool done = false;
    for (uint8_t b : bytes) done = rx.push(b, &got);
    ASSERT_TRUE(done);
    const infer::Telemetry t = infer::infer_step(via, got, rx, FakeClock{&clock});
    const hpddo::Estimate e = direct.step(infer::sample_from_frame(f));
    EXPECT_EQ(t.rpm, e.rpm);
    EXPECT_EQ(t.rpm_m2, e.rpm_m2);
    EXPECT_EQ(t.residual_rpm, e.residual_rpm);
    EXPECT_EQ(t.confidence, e.confidence);
    EXPECT_EQ(t.status, e.status);
    EXPECT_EQ(t.infer_us, 250u);
    EXPECT_NEAR(t.v_V, g(r, gold::kCol_v_V), 0.0005f);
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

TEST(InferLink, EncoderSpeedNeverReachesTheObserver) {
  hpddo::Observer<Net> a(infer::model::kModel);
  hpddo::Observer<Net> b(infer::model::kModel);
  infer::LinkReceiver rx;
  uint32_t clock = 0;
  for (uint16_t k = 0; k < 20; ++k) {
    const hpddo::SampleFrame fa = frame_of(k, 6.0f + 0.2f * k, 0.4f, 35.0f, 0.5f, 100.0f);
    const hpddo::SampleFrame fb = frame_of(k, 6.0f + 0.2f * k, 0.4f, 35.0f, 0.5f, -3000.0f);
    const infer::Telemetry ta = infer::infer_step(a, fa, rx, FakeClock{&clock});
    const infer::Telemetry tb = infer::infer_step(b, fb, rx, FakeClock{&clock});
    EXPECT_EQ(ta.rpm, tb.rpm);
    EXPECT_EQ(ta.residual_rpm, tb.residual_rpm);
    EXPECT_FLOAT_EQ(ta.rpm_ref, 100.0f);
    EXPECT_FLOAT_EQ(tb.rpm_ref, -3000.0f);
  }
  hpddo::SampleFrame none = frame_of(0, 1, 1, NAN, 0.5f, 0);
  none.flags = 0;
  EXPECT_TRUE(std::isnan(infer::frame_rpm_ref(none)));
}

TEST(InferLink, SeqGapIsCountedAndResetsTheLags) {
  std::vector<uint8_t> bytes;
  for (uint16_t s = 100; s < 105; ++s) append(bytes, frame_of(s, 8.0f + 0.3f * s - 30.0f, 0.5f, NAN, 0.5f, 0));
  const hpddo::SampleFrame after = frame_of(110, 9.5f, 0.9f, NAN, 0.5f, 0);  // 105..109 lost
  bytes.push_back(0x00);  // plus some garbage before it
  bytes.push_back(0xA5);
  append(bytes, after);
  infer::LinkReceiver rx;
  hpddo::Observer<Net> obs(infer::model::kModel);
  std::vector<hpddo::Estimate> out;
  hpddo::SampleFrame f;
  for (uint8_t b : bytes)
    if (rx.push(b, &f)) out.push_back(obs.step(infer::sample_from_frame(f)));
  ASSERT_EQ(out.size(), 6u);
  EXPECT_EQ(rx.gaps(), 1u);
  EXPECT_EQ(rx.lost(), 5u);
  EXPECT_EQ(obs.seq_gaps(), 1u);
  // After the gap the observer behaves as on a first sample: lags = current values.
  hpddo::Observer<Net> fresh(infer::model::kModel);
  hpddo::Sample s = infer::sample_from_frame(after);
  s.has_seq = false;
  EXPECT_TRUE(same(out.back(), fresh.step(s)));
}

TEST(InferLink, SeqWrapIsNoGapAndCorruptFramesAreCounted) {
  std::vector<uint8_t> bytes;
  append(bytes, frame_of(65534, 5, 0.3f, NAN, 0.01f, 0));
  append(bytes, frame_of(65535, 5, 0.3f, NAN, 0.01f, 0));
  std::vector<uint8_t> bad;
  append(bad, frame_of(0, 5, 0.3f, NAN, 0.01f, 0));
  bad[8] ^= 0x10;
  bytes.insert(bytes.end(), bad.begin(), bad.end());
  append(bytes, frame_of(1, 5, 0.3f, NAN, 0.01f, 0));
  infer::LinkReceiver rx;
  hpddo::SampleFrame f;
  int n = 0;
  for (uint8_t b : bytes) n += rx.push(b, &f) ? 1 : 0;
  EXPECT_EQ(n, 3);
  EXPECT_EQ(rx.crc_errors(), 1u);
  EXPECT_EQ(rx.gaps(), 1u);  // 65535 -> 1: the damaged frame 0 is a lost sample
  EXPECT_EQ(rx.lost(), 1u);
}

TEST(InferLink, FramesBeyondTheModelsChannelsAreRejectedAndTheNextSurvives) {
  const hpddo::InputLimits& lim = infer::model::kModel.limits;
  std::vector<uint8_t> bytes;
  append(bytes, frame_of(1, lim.v_max_V + 0.5f, 0.5f, NAN, 0.5f, 0));   // beyond the voltage channel
  append(bytes, frame_of(2, 9.0f, -lim.i_max_A - 0.5f, NAN, 0.5f, 0));  // beyond the current channel
  append(bytes, frame_of(3, 9.0f, 0.5f, lim.temp_max_C + 1.0f, 0.5f, 0));  // beyond the sensor
  append(bytes, frame_of(4, 9.0f, 0.5f, NAN, 990.0f, 0));               // a period no window has
  append(bytes, frame_of(5, 9.0f, 0.5f, 40.0f, 0.5f, 0));
  infer::LinkReceiver rx(&lim);
  hpddo::SampleFrame f;
  std::vector<uint16_t> got;
  for (uint8_t b : bytes)
    if (rx.push(b, &f)) got.push_back(f.seq);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], 5);
  EXPECT_EQ(rx.rejected(), 4u);
}

TEST(InferLink, ASeqCycleLostIsSeenFromTheArrivalTimeAndRestartsTheLags) {
  // 65536 samples lost at 2 Hz: the next seq follows on 16 bits, nine hours later.
  infer::LinkReceiver rx;
  hpddo::Observer<Net> obs(infer::model::kModel);
  hpddo::SampleFrame f;
  uint32_t clock = 0;
  uint32_t now_ms = 1000;
  const auto send = [&](const hpddo::SampleFrame& fr) {
    std::vector<uint8_t> bytes;
    append(bytes, fr);
    bool done = false;
    for (uint8_t b : bytes) done = rx.push(b, now_ms, &f);
    EXPECT_TRUE(done);
    return infer::infer_step(obs, f, rx, FakeClock{&clock});
  };
  send(frame_of(7, 8.0f, 0.5f, 40.0f, 0.5f, 0));
  now_ms += 500;
  send(frame_of(8, 8.5f, 0.6f, 40.0f, 0.5f, 0));
  EXPECT_FALSE(rx.new_segment());
  EXPECT_EQ(rx.gaps(), 0u);
  now_ms += 65536u * 500u;
  const hpddo::SampleFrame after = frame_of(9, 9.5f, 1.2f, 40.0f, 0.5f, 0);
  const infer::Telemetry t = send(after);
  EXPECT_TRUE(rx.new_segment());
  EXPECT_EQ(rx.gaps(), 1u);
  EXPECT_GE(rx.lost(), 65536u);
  // Lags restarted: the estimate equals that of an observer at the start of a segment.
  hpddo::Observer<Net> ref(infer::model::kModel);
  ref.step(infer::sample_from_frame(frame_of(7, 8.0f, 0.5f, 40.0f, 0.5f, 0)));
  ref.step(infer::sample_from_frame(frame_of(8, 8.5f, 0.6f, 40.0f, 0.5f, 0)));
  ref.restart_lags();
  const hpddo::Estimate e = ref.step(infer::sample_from_frame(after));
  EXPECT_EQ(t.rpm, e.rpm);
  EXPECT_EQ(t.status, e.status);
  // Frames on time are no gap.
  now_ms += 520;
  send(frame_of(10, 9.5f, 1.2f, 40.0f, 0.5f, 0));
  EXPECT_FALSE(rx.new_segment());
}
