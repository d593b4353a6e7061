// Host tests of the acquisition board's pure logic (uno_acq/acq_*.h).
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "acq_command.h"
#include "acq_format.h"
#include "acq_link.h"
#include "acq_onewire.h"
#include "acq_protocol.h"
#include "acq_window.h"

namespace {

std::string row_text(const acq::LogRow& r) {
  char buf[acq::kLineMax];
  acq::LineWriter w(buf, sizeof buf);
  acq::format_row(w, r);
  EXPECT_FALSE(w.overflow());
  return w.c_str();
}

acq::LogRow example_row() {
  acq::LogRow r;
  r.elapsed_samples = 3;
  r.period_us = 500000;
  r.duty_q = 8000;
  r.v_V = 9.61249f;
  r.i_A = -0.0123f;
  r.rpm = 181.255f;
  r.has_temp = true;
  r.temp_c16 = 40 * 16 + 1;
  r.load = 2;
  r.seq = 70001;
  return r;
}

}  // namespace

TEST(Format, RowFollowsTheBenchLogColumns) {
  EXPECT_STREQ(acq::kLogHeader, "t_s,duty,v_V,i_A,rpm_ref,temp_C,load,seq");
  EXPECT_EQ(row_text(example_row()), "1.500000,0.8000,9.6125,-0.0123,181.26,40.0625,2,70001");
}

TEST(Format, EstimateColumnsFollowTheRow) {
  EXPECT_STREQ(acq::kLogHeaderEstimate, ",rpm_est,est_status");
  char buf[acq::kLineMax];
  acq::LineWriter w(buf, sizeof buf);
  acq::format_row(w, example_row());
  acq::format_estimate(w, 183.004f, 4);
  EXPECT_FALSE(w.overflow());
  EXPECT_STREQ(w.c_str(), "1.500000,0.8000,9.6125,-0.0123,181.26,40.0625,2,70001,183.00,4");
}

TEST(Format, EmptyCellsForAbsentSpeedAndTemperature) {
  acq::LogRow r = example_row();
  r.rpm = hpddo::absent();
  r.has_temp = false;
  r.temp_c16 = -10 * 16;
  EXPECT_EQ(row_text(r), "1.500000,0.8000,9.6125,-0.0123,,,2,70001");
  r.has_temp = true;
  EXPECT_EQ(row_text(r).substr(0, 44), "1.500000,0.8000,9.6125,-0.0123,,-10.0000,2,7");
}

TEST(Format, TimeIsExactForLongRecordingsAndOddPeriods) {
  acq::LogRow r = example_row();
  r.elapsed_samples = 3600u * 100u * 5u;  // five hours at 100 Hz
  r.period_us = 10000;
  EXPECT_EQ(row_text(r).substr(0, 15), "18000.000000,0.");
  r.elapsed_samples = 7;
  r.period_us = 142857;  // 7 Hz
  EXPECT_EQ(row_text(r).substr(0, 9), "0.999999,");
}

TEST(Format, WriterNeverOverflows) {
  char buf[8];
  acq::LineWriter w(buf, sizeof buf);
  w.str("0123456789");
  EXPECT_TRUE(w.overflow());
  EXPECT_EQ(std::strlen(buf), 7u);
  char b2[32];
  acq::LineWriter c(b2, sizeof b2);
  c.compact(2.0f);
  c.put(' ');
  c.compact(0.5f);
  c.put(' ');
  c.compact(7.142857f);
  c.put(' ');
  c.i32(-2147483647 - 1);
  EXPECT_STREQ(b2, "2 0.5 7.1429 -2147483648");
}

TEST(Window, MeansAddHalfAnLsbAndApplyTheGains) {
  acq::WindowSums w = {};
  w.n_v = w.n_i = 4000;
  w.sum_v = 409u * 4000u;  // A0 at code 409: 2.0 V at the pin
  w.sum_i = 82u * 4000u;
  w.enc_counts = 302;
  w.period_us = 500000;
  const acq::Measurement m = acq::measure(w, acq::kCalibration, acq::kEncoderCountsPerRev);
  EXPECT_NEAR(m.v_V, (409.5f * 5.0f / 1024.0f) * 3.0f, 1e-5f);
  EXPECT_NEAR(m.i_A, (82.5f * 5.0f / 1024.0f) / 0.5f, 1e-5f);
  EXPECT_NEAR(m.rpm, 302.0f / (44.0f * 4.4f) * 120.0f, 1e-3f);  // 11 pulses x4 per motor rev, 1:4.4
  w.n_v = 0;
  EXPECT_TRUE(std::isnan(acq::measure(w, acq::kCalibration, acq::kEncoderCountsPerRev).v_V));
}

TEST(Window, PwmTimingAndWholePeriodWindows) {
  acq::PwmTiming t;
  ASSERT_TRUE(acq::pwm_timing(1000, &t));
  EXPECT_EQ(t.prescale, 1);
  EXPECT_EQ(t.top, 15999);
  EXPECT_EQ(acq::periods_per_window(t, 2.0f), 500);
  EXPECT_EQ(acq::periods_per_window(t, 100.0f), 10);
  EXPECT_EQ(acq::window_us(t, 500), 500000u);
  EXPECT_EQ(acq::pwm_compare(t, 8000), 12800);
  ASSERT_TRUE(acq::pwm_timing(100, &t));
  EXPECT_EQ(t.prescale, 8);
  EXPECT_EQ(t.top, 19999);
  EXPECT_FALSE(acq::pwm_timing(20, &t));
  ASSERT_TRUE(acq::pwm_timing(20000, &t));
  EXPECT_EQ(acq::periods_per_window(t, 0.0f), 0);
  EXPECT_EQ(acq::periods_per_window(t, 0.1f), 0);  // over 65535 periods
  EXPECT_EQ(acq::periods_per_window(t, 50000.0f), 1);
}

TEST(Window, FrameCarriesTheRoundedMeansAndSeq) {
  acq::WindowSums w = {};
  w.seq = 0x12345;
  w.period_us = 10000;
  w.duty_q = 8000;
  acq::Measurement m = {9.6125f, -0.8124f, 181.26f};
  const hpddo::SampleFrame f = acq::make_frame(w, m, true, 641);
  EXPECT_EQ(f.seq, 0x2345);
  EXPECT_EQ(f.v_mV, 9613);  // 9612.5 rounds away from zero (float: within 1 mV)
  EXPECT_EQ(f.i_mA, -812);
  EXPECT_EQ(f.rpm_x10, 1813);
  EXPECT_EQ(f.duty, 204);
  EXPECT_EQ(f.temp_c16, 641);
  EXPECT_EQ(f.flags, hpddo::kFrameFlagTemp | hpddo::kFrameFlagRpm);
  EXPECT_EQ(f.period_us, 10000u);
}

TEST(Window, QuadratureCountsBothDirectionsAndIgnoresGlitches) {
  const uint8_t fwd[] = {0, 1, 3, 2, 0, 1};
  int32_t n = 0;
  for (size_t k = 1; k < sizeof fwd; ++k) n += acq::quadrature_step(fwd[k - 1], fwd[k]);
  EXPECT_EQ(n, 5);
  n = 0;
  for (size_t k = sizeof fwd - 1; k > 0; --k) n += acq::quadrature_step(fwd[k], fwd[k - 1]);
  EXPECT_EQ(n, -5);
  EXPECT_EQ(acq::quadrature_step(0, 3), 0);  // both channels at once: unknown direction
  EXPECT_EQ(acq::quadrature_step(2, 2), 0);
}

TEST(Protocol, SweepLoadAndLongFollowThePaper) {
  acq::ProtocolPlan sweep(acq::kProtoSweep, 3, 0);
  EXPECT_EQ(sweep.total(), 33u);
  std::vector<int> duties;
  acq::Setpoint sp;
  for (uint32_t k = 0; k < sweep.total(); k += 3) {
    ASSERT_TRUE(sweep.at(k, &sp));
    EXPECT_EQ(sp.load, 0);
    duties.push_back(sp.duty_q);
  }
  EXPECT_EQ(duties, (std::vector<int>{0, 2000, 4000, 6000, 8000, 10000, 8000, 6000, 4000, 2000, 0}));
  EXPECT_FALSE(sweep.at(33, &sp));

  acq::ProtocolPlan load(acq::kProtoLoad, 2, 0);
  std::vector<int> loads;
  for (uint32_t k = 0; k < load.total(); ++k) {
    ASSERT_TRUE(load.at(k, &sp));
    EXPECT_EQ(sp.duty_q, 8000);
    loads.push_back(sp.load);
  }
  EXPECT_EQ(loads, (std::vector<int>{0, 0, 1, 1, 2, 2, 0, 0, 2, 2, 1, 1, 0, 0, 1, 1, 2, 2, 1, 1, 0, 0, 2, 2}));
  EXPECT_EQ(acq::step_seconds(acq::kProtoSweep, 0.0f), 30.0f);  // the bench's (tools/hpddo/bench.py)
  EXPECT_EQ(acq::step_seconds(acq::kProtoLoad, 0.0f), 25.0f);
  EXPECT_EQ(acq::step_seconds(acq::kProtoLoad, 0.05f), 0.05f);

  acq::ProtocolPlan lng(acq::kProtoLong, 1, 7200);
  EXPECT_EQ(lng.total(), 7200u);
  ASSERT_TRUE(lng.at(7199, &sp));
  EXPECT_EQ(sp.duty_q, 8000);
  EXPECT_EQ(sp.load, 2);
  EXPECT_EQ(acq::samples_for(20.0f, 2.0f), 40u);
  EXPECT_EQ(acq::samples_for(0.001f, 2.0f), 1u);
}

TEST(Command, ParsesEveryCommandAndRefusesTheRest) {
  EXPECT_EQ(acq::parse_command("run sweep").kind, acq::kCmdRun);
  EXPECT_EQ(acq::parse_command("run long\r\n").protocol, acq::kProtoLong);
  EXPECT_EQ(acq::parse_command("run fast").kind, acq::kCmdBad);
  acq::Command c = acq::parse_command("  duty   0.75 ");
  EXPECT_EQ(c.kind, acq::kCmdDuty);
  EXPECT_FLOAT_EQ(c.value, 0.75f);
  EXPECT_EQ(acq::parse_command("duty 1.5").kind, acq::kCmdBad);
  EXPECT_EQ(acq::parse_command("load 2").kind, acq::kCmdLoad);
  EXPECT_EQ(acq::parse_command("load 3").kind, acq::kCmdBad);
  EXPECT_EQ(acq::parse_command("rate 100").kind, acq::kCmdRate);
  EXPECT_EQ(acq::parse_command("rate 1e3").kind, acq::kCmdBad);
  EXPECT_EQ(acq::parse_command("pwm 20000").kind, acq::kCmdPwm);
  EXPECT_EQ(acq::parse_command("hold .5").kind, acq::kCmdHold);
  EXPECT_EQ(acq::parse_command("long 7200").kind, acq::kCmdLong);
  EXPECT_EQ(acq::parse_command("coast 1").kind, acq::kCmdCoast);
  EXPECT_EQ(acq::parse_command("coast 0").value, 0.0f);
  EXPECT_EQ(acq::parse_command("coast 2").kind, acq::kCmdBad);
  EXPECT_EQ(acq::parse_command("coast").kind, acq::kCmdBad);
  EXPECT_EQ(acq::parse_command("stop").kind, acq::kCmdStop);
  EXPECT_EQ(acq::parse_command("status").kind, acq::kCmdStatus);
  EXPECT_EQ(acq::parse_command("").kind, acq::kCmdNone);
  EXPECT_EQ(acq::parse_command("duty 0.5 0.6").kind, acq::kCmdBad);
  c = acq::parse_command("rec");
  EXPECT_EQ(c.kind, acq::kCmdRec);
  EXPECT_STREQ(c.word, "manual");
  c = acq::parse_command("rec warm-up_2");
  EXPECT_STREQ(c.word, "warm-up_2");
  EXPECT_EQ(acq::parse_command("rec a,b").kind, acq::kCmdBad);
  EXPECT_EQ(acq::parse_command("rec abcdefghijklmnopq").kind, acq::kCmdBad);
}

TEST(Command, LineBufferDropsOverlongLines) {
  acq::LineBuffer<8> lb;
  const char* in = "0123456789\nstop\r\n";
  std::vector<std::string> lines;
  for (const char* p = in; *p; ++p)
    if (lb.push(*p)) {
      lines.push_back(lb.line());
      lb.clear();
    }
  EXPECT_EQ(lines, (std::vector<std::string>{"stop"}));
}

TEST(Link, ShifterSends8N1LsbFirstAndIdlesHigh) {
  acq::TxQueue<8> q;
  acq::BitShifter sh;
  EXPECT_EQ(sh.next(q), 1);
  const uint8_t bytes[] = {0xA5, 0x01};
  ASSERT_TRUE(q.push(bytes, 2));
  std::vector<int> bits;
  for (int k = 0; k < 22; ++k) bits.push_back(sh.next(q));
  const std::vector<int> want = {0, 1, 0, 1, 0, 0, 1, 0, 1, 1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1};
  EXPECT_EQ(bits, want);
  EXPECT_FALSE(sh.busy());
  EXPECT_TRUE(q.empty());
}

TEST(Link, QueueIsAllOrNothing) {
  acq::TxQueue<32> q;
  uint8_t frame[21] = {};
  EXPECT_TRUE(q.push(frame, 21));
  EXPECT_FALSE(q.push(frame, 21));
  EXPECT_EQ(q.dropped(), 1);
  uint8_t b;
  for (int k = 0; k < 21; ++k) ASSERT_TRUE(q.pop(&b));
  EXPECT_FALSE(q.pop(&b));
  for (int k = 0; k < 40; ++k) {  // wraps the indices many times
    ASSERT_TRUE(q.push(frame, 11));
    for (int j = 0; j < 11; ++j) ASSERT_TRUE(q.pop(&b));
  }
  EXPECT_TRUE(q.empty());
}

TEST(OneWire, Crc8AndScratchpad) {
  // Datasheet-style scratchpad: +25.0625 C = 0x0191.
  uint8_t pad[9] = {0x91, 0x01, 0x4B, 0x46, 0x7F, 0xFF, 0x0F, 0x10, 0};
  pad[8] = acq::crc8_maxim(pad, 8);
  int16_t t = 0;
  ASSERT_TRUE(acq::ds18b20_decode(pad, &t));
  EXPECT_EQ(t, 0x0191);
  const uint8_t rom[8] = {0x28, 0xFF, 0x4C, 0x8D, 0x61, 0x16, 0x04, 0};
  EXPECT_EQ(acq::crc8_maxim(rom, 0), 0);
  const uint8_t check[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  EXPECT_EQ(acq::crc8_maxim(check, 9), 0xA1);  // CRC-8/MAXIM check value
  pad[2] ^= 1;
  EXPECT_FALSE(acq::ds18b20_decode(pad, &t));
  uint8_t ones[9];
  std::memset(ones, 0xFF, 9);
  EXPECT_FALSE(acq::ds18b20_decode(ones, &t));
  uint8_t zeros[9] = {};
  EXPECT_FALSE(acq::ds18b20_decode(zeros, &t));
}

TEST(OneWire, ScheduleConvertsReadsAndAges) {
  acq::TempSchedule s;
  EXPECT_EQ(s.poll(0), acq::TempSchedule::kStartConversion);
  s.started(10, true);
  EXPECT_EQ(s.poll(500), acq::TempSchedule::kIdle);
  EXPECT_EQ(s.poll(810), acq::TempSchedule::kReadScratchpad);
  s.read(820, true, 500);
  int16_t t = 0;
  ASSERT_TRUE(s.current(900, &t));
  EXPECT_EQ(t, 500);
  EXPECT_EQ(s.poll(900), acq::TempSchedule::kIdle);
  EXPECT_EQ(s.poll(1010), acq::TempSchedule::kStartConversion);
  s.started(1010, false);  // sensor gone
  EXPECT_FALSE(s.current(4000, &t));
}
