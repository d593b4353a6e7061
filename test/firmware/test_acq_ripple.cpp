// Host tests of the ripple mode's pure logic (uno_acq/acq_ripple.h, issue 23): timing, the
// trigger at the middle of the on-time, the burst length against the window and the line,
// the chunk encoding and its base64 line. The board side is proven in simavr
// (check_uno_ripple.py, firmware.uno.sim_ripple*), whose bursts the host decodes with
// tools/hpddo/logs/ripple_link.py.
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <cmath>

#include "acq_coast.h"
#include "acq_ripple.h"
#include "acq_ripple_count.h"
#include "hpddo/crc.h"

namespace {

TEST(AcqRipple, TimingAtTheSampleRates) {
  acq::RippleTiming rt;
  ASSERT_TRUE(acq::ripple_timing(10000, &rt));
  EXPECT_EQ(rt.pwm.prescale, 1);
  EXPECT_EQ(rt.pwm.top, 1599);
  EXPECT_EQ(rt.adps, 5);          // 500 kHz ADC clock: 432 cycles, 27 % of the period
  EXPECT_EQ(rt.conv_cycles, 432);
  EXPECT_EQ(rt.sh_cycles, 67);    // 2 ADC clocks + 3 cycles
  EXPECT_EQ(rt.stop_periods, 3);  // a free-running conversion (1664 cycles) ends within 2 periods
  ASSERT_TRUE(acq::ripple_timing(8000, &rt));
  EXPECT_EQ(rt.adps, 5);
  ASSERT_TRUE(acq::ripple_timing(20000, &rt));
  EXPECT_EQ(rt.pwm.top, 799);
  EXPECT_EQ(rt.adps, 4);  // 1 MHz: 216 cycles of 800
  EXPECT_LE(rt.conv_cycles * 10u, 800u * 3u);
  EXPECT_FALSE(acq::ripple_timing(7999, &rt));
  EXPECT_FALSE(acq::ripple_timing(20001, &rt));
}

TEST(AcqRipple, TriggerAtTheMiddleOfTheOnTime) {
  acq::RippleTiming rt;
  ASSERT_TRUE(acq::ripple_timing(10000, &rt));
  for (uint16_t duty_q = 1000; duty_q < 10000; duty_q = static_cast<uint16_t>(duty_q + 500)) {
    const uint16_t ocr1a = acq::pwm_compare(rt.pwm, duty_q);
    const uint16_t ocr1b = acq::ripple_trigger(rt.pwm, ocr1a, duty_q, rt.sh_cycles);
    // the compare match comes OCR1B + 1 ticks after the period's start, the sample-and-hold
    // sh_cycles later: the middle of the ocr1a + 1 ticks of on-time within a cycle
    const double sh_at = ocr1b + 1.0 + rt.sh_cycles;
    EXPECT_NEAR(sh_at, (ocr1a + 1) / 2.0, 1.0) << duty_q;
    // the conversion and its interrupt end within the period
    EXPECT_LT(ocr1b + 1u + rt.conv_cycles, 1600u * 8u / 10u) << duty_q;
  }
  EXPECT_EQ(acq::ripple_trigger(rt.pwm, 1280, 8000, rt.sh_cycles), 573);
  EXPECT_EQ(acq::ripple_trigger(rt.pwm, 0, 0, rt.sh_cycles), 733);        // off: the period's middle
  EXPECT_EQ(acq::ripple_trigger(rt.pwm, 1600, 10000, rt.sh_cycles), 733);  // always on
  EXPECT_EQ(acq::ripple_trigger(rt.pwm, 80, 500, rt.sh_cycles), 0);        // 5 %: as early as it goes
}

TEST(AcqRipple, BurstFitsTheWindowAndTheLine) {
  acq::RippleTiming rt;
  ASSERT_TRUE(acq::ripple_timing(10000, &rt));
  EXPECT_EQ(acq::ripple_burst_samples(rt, 5000, 500000), 3968);  // 2 Hz: 0.397 s of the 0.5 s
  EXPECT_EQ(acq::ripple_burst_samples(rt, 1000, 500000), 768);   // 10 Hz
  EXPECT_EQ(acq::ripple_burst_samples(rt, 100, 500000), 64);     // 100 Hz: 2 chunks
  EXPECT_EQ(acq::ripple_burst_samples(rt, 30, 500000), 0);       // not one chunk
  // at 115200 baud a 10 kHz burst needs 25625 characters/s of 11520: none
  EXPECT_EQ(acq::ripple_burst_samples(rt, 5000, 115200), 0);
  ASSERT_TRUE(acq::ripple_timing(16000, &rt));  // 41000 characters/s > 80 % of 50000
  EXPECT_EQ(acq::ripple_burst_samples(rt, 8000, 500000), 0);
  ASSERT_TRUE(acq::ripple_timing(12000, &rt));
  EXPECT_GT(acq::ripple_burst_samples(rt, 6000, 500000), 0);
  EXPECT_EQ(acq::ripple_burst_chars(32), acq::kRippleLineMax);
  EXPECT_EQ(acq::kRippleLineMax, 82);
}

TEST(AcqRipple, ChunkLayoutPackingAndCrc) {
  std::vector<uint16_t> codes;
  for (int k = 0; k < 32; ++k) codes.push_back(static_cast<uint16_t>((k * 97 + 5) & 0x3FF));
  codes[3] = 1023;
  codes[4] = 0;
  acq::RippleChunk c;
  c.seq = 0x12345678u;
  c.first = 64;
  c.total = 3968;
  c.start_period = 1032;
  c.phase_cycles = 641;
  c.n = 32;
  c.codes = codes.data();
  uint8_t out[acq::kRippleChunkMax];
  const uint8_t len = acq::encode_ripple_chunk(c, out);
  ASSERT_EQ(len, acq::kRippleChunkMax);
  EXPECT_EQ(out[0], 0xA5);
  EXPECT_EQ(out[1], 0x5B);
  EXPECT_EQ(out[2], len - 5);
  EXPECT_EQ(out[3] | out[4] << 8 | out[5] << 16 | static_cast<uint32_t>(out[6]) << 24, 0x12345678u);
  EXPECT_EQ(out[7] | out[8] << 8, 64);
  EXPECT_EQ(out[9] | out[10] << 8, 3968);
  EXPECT_EQ(out[11] | out[12] << 8, 1032);
  EXPECT_EQ(out[13] | out[14] << 8, 641);
  EXPECT_EQ(out[15], 32);
  for (int k = 0; k < 32; ++k) {  // unpack LSB first
    uint32_t v = 0;
    for (int b = 0; b < 10; ++b) {
      const int bit = 10 * k + b;
      v |= static_cast<uint32_t>((out[acq::kRippleHead + bit / 8] >> (bit % 8)) & 1u) << b;
    }
    EXPECT_EQ(v, codes[k]) << k;
  }
  EXPECT_EQ(out[len - 2] | out[len - 1] << 8, hpddo::crc16(out + 2, len - 4u));
  // a short last chunk
  c.n = 5;
  EXPECT_EQ(acq::encode_ripple_chunk(c, out), acq::kRippleHead + 7 + 2);
  EXPECT_EQ(out[2], acq::kRippleHead - 3 + 7);
}

// The coast probe (acq_coast.h, issue 33 item 7): its length, how often, where it fits, its channels
// and its chunk. The board side is proven in simavr (check_uno_coast.py, firmware.uno.sim_coast_*).
TEST(AcqCoast, ProbeIsFourMillisecondsOfPairsAtEveryRate) {
  for (uint32_t hz = acq::kRippleHzMin; hz <= acq::kRippleHzMax; hz += 500) {
    acq::RippleTiming rt;
    ASSERT_TRUE(acq::ripple_timing(hz, &rt)) << hz;
    const uint16_t period = static_cast<uint16_t>(rt.pwm.top + 1u);
    const uint16_t n = acq::coast_samples(period);
    EXPECT_EQ(n % 2u, 0u) << hz;  // a current and a voltage sample a pair
    const double probe_us = 1e6 * n * period / acq::kCpuHz;
    EXPECT_NEAR(probe_us, acq::kCoastProbeUs, 1e6 * period / acq::kCpuHz) << hz;  // within a pair's period
  }
  EXPECT_EQ(acq::coast_samples(1600), 40);  // 10 kHz: 20 pairs
  EXPECT_EQ(acq::coast_samples(2000), 32);  // 8 kHz
  EXPECT_EQ(acq::coast_samples(800), 80);   // 20 kHz
  EXPECT_EQ(acq::coast_samples(40000), 4);  // at least 2 pairs
}

TEST(AcqCoast, ProbeEveryPeriodInWholeWindows) {
  EXPECT_EQ(acq::coast_every_windows(1600, 5000), 3);   // 2 Hz windows: 1.5 s
  EXPECT_EQ(acq::coast_every_windows(1600, 1000), 15);  // 10 Hz
  EXPECT_EQ(acq::coast_every_windows(1600, 100), 150);  // 100 Hz
  EXPECT_EQ(acq::coast_every_windows(1600, 60000), 2);  // 6 s windows: at least every other one
  for (uint16_t wp = 100; wp < 20000; wp = static_cast<uint16_t>(wp * 3 / 2)) {
    const double window_s = wp * 1600.0 / acq::kCpuHz;
    const uint16_t n = acq::coast_every_windows(1600, wp);
    if (n > 2) {
      EXPECT_LE(std::fabs(n * window_s - acq::kCoastPeriodMs / 1000.0), window_s / 2 + 1e-9) << wp;
    }
  }
}

TEST(AcqCoast, ProbeTakesTheBurstsPlaceAndAlternatesCurrentFirst) {
  acq::RippleTiming rt;
  ASSERT_TRUE(acq::ripple_timing(10000, &rt));
  const uint16_t n = acq::coast_samples(1600);
  EXPECT_TRUE(acq::coast_fits(acq::ripple_burst_samples(rt, 5000, acq::kRippleHostBaud), n));   // 2 Hz
  EXPECT_TRUE(acq::coast_fits(acq::ripple_burst_samples(rt, 1000, acq::kRippleHostBaud), n));   // 10 Hz
  EXPECT_TRUE(acq::coast_fits(acq::ripple_burst_samples(rt, 100, acq::kRippleHostBaud), n));    // 100 Hz: 64
  EXPECT_FALSE(acq::coast_fits(acq::ripple_burst_samples(rt, 30, acq::kRippleHostBaud), n));    // no burst
  EXPECT_FALSE(acq::coast_fits(40, 40));  // the drive must be back before the window's last period
  for (uint16_t k = 0; k < n; ++k)
    EXPECT_EQ(acq::coast_channel(k), k % 2 ? acq::kAdcChannelV : acq::kAdcChannelI) << k;
}

TEST(AcqCoast, ChunkIsTheRippleLayoutWithItsOwnSync) {
  std::vector<uint16_t> codes;
  for (int k = 0; k < 8; ++k) codes.push_back(static_cast<uint16_t>(k % 2 ? 600 - k : 60 >> k));
  acq::RippleChunk c;
  c.seq = 17;
  c.first = 32;
  c.total = 40;
  c.start_period = 1032;
  c.phase_cycles = 641;
  c.n = 8;
  c.codes = codes.data();
  uint8_t burst[acq::kRippleChunkMax], probe[acq::kRippleChunkMax];
  const uint8_t len = acq::encode_ripple_chunk(c, burst);
  ASSERT_EQ(acq::encode_ripple_chunk(c, probe, acq::kCoastSync1), len);
  EXPECT_EQ(probe[1], 0x5C);
  EXPECT_EQ(burst[1], acq::kRippleSync1);
  EXPECT_EQ(std::memcmp(burst + 2, probe + 2, len - 2u), 0);  // the CRC does not cover the sync
}

TEST(AcqRipple, Base64LineAsRfc4648) {
  char line[acq::kRippleLineMax];
  const uint8_t man[] = {'M', 'a', 'n', 'M', 'a'};
  const uint8_t n = acq::ripple_line(man, 5, line);
  EXPECT_EQ(std::string(line, n), "~TWFuTWE=\n");
  EXPECT_EQ(std::string(line, acq::ripple_line(man, 1, line)), "~TQ==\n");
  uint8_t frame[acq::kRippleChunkMax] = {};
  EXPECT_EQ(acq::ripple_line(frame, acq::kRippleChunkMax, line), acq::kRippleLineMax);
}

TEST(AcqRipple, RingKeepsOrderAndRefusesWhenFull) {
  acq::SampleRing<8> r;
  for (uint16_t k = 0; k < 8; ++k) EXPECT_TRUE(r.push(k));
  EXPECT_FALSE(r.push(99));
  EXPECT_EQ(r.peak(), 8);
  uint16_t out[8];
  r.pop(out, 5);
  for (uint16_t k = 0; k < 5; ++k) EXPECT_EQ(out[k], k);
  for (uint16_t k = 0; k < 5; ++k) EXPECT_TRUE(r.push(static_cast<uint16_t>(100 + k)));
  EXPECT_EQ(r.size(), 8);
  r.pop(out, 8);
  EXPECT_EQ(out[0], 5);
  EXPECT_EQ(out[3], 100);
  EXPECT_EQ(out[7], 104);
}

// The counter on a sampled sine of known frequency (plus a mean and a sub-harmonic at f/2)
// counts it: cycles from rise to rise over the PWM periods they took.
TEST(AcqRippleCount, CountsTheLineOfAKnownFrequency) {
  const float fs = 10000.0f;
  for (float f : {30.0f, 79.0f, 110.0f}) {
    acq::RippleCounter c;
    acq::ripple_counter_reset(&c);
    const uint8_t k = acq::ripple_lp_shift(f, 0.5f * fs);  // filtered at the decimated 5 kHz
    acq::ripple_counter_begin(&c, k, static_cast<uint16_t>(fs / f + 0.5f), 0, true);
    for (int n = 0; n < 20000; ++n) {
      const double t = n / static_cast<double>(fs);
      const double fd = static_cast<double>(f);
      const double x = 100.0 + 6.0 * std::sin(2 * M_PI * fd * t) + 1.5 * std::sin(M_PI * fd * t + 0.3);
      acq::ripple_counter_sample(&c, static_cast<uint16_t>(x + 0.5));
    }
    float got = 0.0f;
    ASSERT_TRUE(acq::ripple_counter_hz(c.cyc, c.span, fs, &got)) << f;
    EXPECT_NEAR(got, f, 0.002f * f) << "k " << int(k);
    EXPECT_TRUE(acq::ripple_count_confident(got, f * 1.1f));
    EXPECT_FALSE(acq::ripple_count_confident(got / 2.0f, f));  // the octave below is refused
  }
  EXPECT_EQ(acq::ripple_lp_shift(79.0f, 10000.0f), 3);   // 2^3: a corner near 2 f
  EXPECT_EQ(acq::ripple_lp_shift(30.0f, 10000.0f), 5);
  EXPECT_EQ(acq::ripple_lp_shift(0.0f, 10000.0f), 5);
}

// Across gaps shorter than a ripple period (100 Hz windows: 64 of 100 periods), a crossing in
// a gap is bridged by the expected period: the count is the line's.
TEST(AcqRippleCount, CountsAcrossGapsShorterThanAPeriod) {
  const float fs = 10000.0f, f = 79.0f;
  acq::RippleCounter c;
  acq::ripple_counter_reset(&c);
  const uint8_t k = acq::ripple_lp_shift(f, 0.5f * fs);
  long period = 0;
  float cyc = 0.0f, span = 0.0f;
  for (int w = 0; w < 300; ++w) {
    acq::ripple_counter_begin(&c, k, static_cast<uint16_t>(fs / f + 0.5f), 36, w == 0);
    period += 36;
    for (int j = 0; j < 64; ++j, ++period) {
      const double x = 100.0 + 6.0 * std::sin(2 * M_PI * static_cast<double>(f) * static_cast<double>(period) / 10000.0);
      acq::ripple_counter_sample(&c, static_cast<uint16_t>(x + 0.5));
    }
    cyc += c.cyc;
    span += c.span;
    c.cyc = c.span = 0;
  }
  float got = 0.0f;
  ASSERT_TRUE(acq::ripple_counter_hz(cyc, span, fs, &got));
  EXPECT_NEAR(got, f, 0.003f * f);
  EXPECT_GT(cyc, 200.0f);  // most of the 237 cycles of the 3 s
}

// After a gap the count bridges, a burst that holds kRippleMinCycles expected periods (counted
// alone) lets the band's high-pass settle, 2^(k+2) filtered codes, before a crossing counts; a
// shorter one (100 Hz windows) needs its first crossing to bridge the gap; a gap longer than the
// count bridges settles 4 x 2^(k+2) as before. (ripple/board.py begin, the same rule.)
TEST(AcqRippleCount, ALongBurstSettlesItsHighPassAfterAGap) {
  acq::RippleCounter c;
  acq::ripple_counter_reset(&c);
  const uint8_t k = 3;
  acq::ripple_counter_begin(&c, k, 127, 0, true, 768);
  c.settle = 0;
  acq::ripple_counter_begin(&c, k, 127, 232, false, 768);  // 10 Hz windows: 768 >= 5 x 127
  EXPECT_EQ(c.settle, 1u << (k + 2));
  c.settle = 0;
  acq::ripple_counter_begin(&c, k, 127, 36, false, 64);  // 100 Hz windows: a burst under a period
  EXPECT_EQ(c.settle, 0u);
  acq::ripple_counter_begin(&c, k, 127, 400, false, 768);  // beyond 2.5 expected periods
  EXPECT_EQ(c.settle, 4u << (k + 2));
}

// Ra from exact inputs: the calibrated Ke, then the copper's rise through Ra(T).
TEST(AcqRippleCount, RaAndTemperatureFromExactInputs) {
  hpddo::PhysicsParams p = {};
  p.ra_ohm = 4.5f;
  p.ke_vs_per_rad = 0.4f;
  p.t_ref_C = 30.0f;
  acq::RippleRa r;
  acq::ripple_ra_reset(&r);
  const float ke = 0.4f, w = 12.0f, i = 0.9f, dt = 0.5f;
  for (int n = 0; n < 2; ++n)  // one second of cold windows calibrates Ke
    EXPECT_EQ(acq::ripple_ra_step(p, ke * w + i * 4.5f, i, w * hpddo::kRpmPerRadS, dt, &r), n == 1);
  EXPECT_NEAR(r.ke_cal, ke, 1e-5f);
  const float ra_hot = 4.5f * (1.0f + hpddo::kMaterialThermalRa * 10.0f);  // 10 K warmer
  for (int n = 0; n < 400; ++n) acq::ripple_ra_step(p, ke * w + i * ra_hot, i, w * hpddo::kRpmPerRadS, dt, &r);
  EXPECT_NEAR(r.ra_ohm, ra_hot, 1e-3f);
  EXPECT_NEAR(r.tw_C, 40.0f, 0.05f);
  const float before = r.ra_ohm;  // a glitch of V is left out
  acq::ripple_ra_step(p, ke * w + i * ra_hot + 2.0f, i, w * hpddo::kRpmPerRadS, dt, &r);
  EXPECT_EQ(r.ra_ohm, before);
  EXPECT_FLOAT_EQ(hpddo::kMaterialThermalRa, 0.00393f);  // copper's, generated from the schema
}

}  // namespace

// The window whose prior sets a burst's band: the one before at 2 and 10 Hz windows (the burst
// opens 1032 and 232 periods after the close), the one before that at 100 Hz (36 periods,
// while the main loop may still work on the window before). board.band_lag agrees
// (test/py/test_ripple_count.py).
TEST(AcqRippleCount, BandLagFollowsTheBurstsLead) {
  acq::RippleTiming rt;
  ASSERT_TRUE(acq::ripple_timing(10000, &rt));
  const uint32_t period = acq::pwm_period_cycles(rt.pwm);
  for (const auto& c : {std::make_pair(5000, 1), std::make_pair(1000, 1), std::make_pair(100, 2)}) {
    const uint16_t window = static_cast<uint16_t>(c.first);
    const uint16_t n = acq::ripple_burst_samples(rt, window, acq::kRippleHostBaud);
    EXPECT_EQ(acq::ripple_band_lag(static_cast<uint16_t>(window - n), period), c.second) << window;
  }
}
