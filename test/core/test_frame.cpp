#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "hpddo/frame.h"
#include "link_montecarlo.h"

namespace {

hpddo::SampleFrame example(uint16_t seq) {
  hpddo::SampleFrame f;
  f.seq = seq;
  f.flags = hpddo::kFrameFlagTemp | hpddo::kFrameFlagRpm;
  f.duty = 204;
  f.v_mV = 9612;
  f.i_mA = -812;
  f.temp_c16 = 40 * 16 + 1;
  f.rpm_x10 = 1812;
  f.period_us = 500000;
  return f;
}

void expect_same(const hpddo::SampleFrame& a, const hpddo::SampleFrame& b) {
  EXPECT_EQ(a.seq, b.seq);
  EXPECT_EQ(a.flags, b.flags);
  EXPECT_EQ(a.duty, b.duty);
  EXPECT_EQ(a.v_mV, b.v_mV);
  EXPECT_EQ(a.i_mA, b.i_mA);
  EXPECT_EQ(a.temp_c16, b.temp_c16);
  EXPECT_EQ(a.rpm_x10, b.rpm_x10);
  EXPECT_EQ(a.period_us, b.period_us);
}

std::vector<hpddo::SampleFrame> feed(hpddo::FrameDecoder& dec, const std::vector<uint8_t>& bytes) {
  std::vector<hpddo::SampleFrame> out;
  hpddo::SampleFrame f;
  for (uint8_t b : bytes)
    if (dec.push(b, &f)) out.push_back(f);
  return out;
}

void append(std::vector<uint8_t>& v, const hpddo::SampleFrame& f) {
  uint8_t buf[hpddo::kFrameSize];
  hpddo::encode_frame(f, buf);
  v.insert(v.end(), buf, buf + hpddo::kFrameSize);
}

}  // namespace

TEST(Frame, LayoutIsLittleEndianWithCrcOverLengthAndPayload) {
  uint8_t buf[hpddo::kFrameSize];
  hpddo::encode_frame(example(0x1234), buf);
  EXPECT_EQ(hpddo::kFrameSize, 21);
  EXPECT_EQ(buf[0], 0xA5);
  EXPECT_EQ(buf[1], 0x5A);
  EXPECT_EQ(buf[2], 16);
  EXPECT_EQ(buf[3], 0x34);
  EXPECT_EQ(buf[4], 0x12);
  EXPECT_EQ(buf[7] | (buf[8] << 8), 9612);
  const uint16_t crc = hpddo::crc16(buf + 2, 17);
  EXPECT_EQ(buf[19], crc & 0xFF);
  EXPECT_EQ(buf[20], crc >> 8);
}

TEST(Frame, RoundTripAndUnits) {
  std::vector<uint8_t> bytes;
  append(bytes, example(7));
  hpddo::FrameDecoder dec;
  const auto got = feed(dec, bytes);
  ASSERT_EQ(got.size(), 1u);
  expect_same(got[0], example(7));
  EXPECT_FLOAT_EQ(hpddo::frame_v_V(got[0]), 9.612f);
  EXPECT_FLOAT_EQ(hpddo::frame_i_A(got[0]), -0.812f);
  EXPECT_FLOAT_EQ(hpddo::frame_temp_C(got[0]), 40.0625f);
  EXPECT_FLOAT_EQ(hpddo::frame_dt_s(got[0]), 0.5f);
  hpddo::SampleFrame no_temp = example(1);
  no_temp.flags = 0;
  EXPECT_TRUE(std::isnan(hpddo::frame_temp_C(no_temp)));
}

TEST(Frame, SaturateRound) {
  EXPECT_EQ(hpddo::saturate_round(2.5f, -10, 10), 3);
  EXPECT_EQ(hpddo::saturate_round(-2.5f, -10, 10), -3);
  EXPECT_EQ(hpddo::saturate_round(1e9f, -10, 10), 10);
  EXPECT_EQ(hpddo::saturate_round(NAN, -10, 10), -10);
}

TEST(Frame, ResynchronisesAfterGarbageAndCorruptFrames) {
  std::vector<uint8_t> bytes = {0x00, 0xA5, 0xA5, 0x5A, 0x03, 0xFF};
  append(bytes, example(1));
  std::vector<uint8_t> broken;
  append(broken, example(2));
  broken[9] ^= 0x40;  // damaged payload
  bytes.insert(bytes.end(), broken.begin(), broken.begin() + 14);
  append(bytes, example(3));  // starts inside the truncated damaged one
  append(bytes, example(4));
  hpddo::FrameDecoder dec;
  const auto got = feed(dec, bytes);
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0].seq, 1);
  EXPECT_EQ(got[1].seq, 3);
  EXPECT_EQ(got[2].seq, 4);
  EXPECT_GE(dec.crc_errors(), 1u);
  EXPECT_EQ(dec.frames(), 3u);
}

TEST(Frame, EverySingleBitErrorIsCaught) {
  std::vector<uint8_t> good;
  append(good, example(9));
  for (size_t bit = 0; bit < good.size() * 8; ++bit) {
    std::vector<uint8_t> bytes = good;
    bytes[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    append(bytes, example(10));
    hpddo::FrameDecoder dec;
    const auto got = feed(dec, bytes);
    ASSERT_EQ(got.size(), 1u) << "bit " << bit;
    EXPECT_EQ(got[0].seq, 10) << "bit " << bit;
  }
}

TEST(Frame, RandomNoiseYieldsNoFrames) {
  std::mt19937 rng(12345);
  std::vector<uint8_t> noise(200000);
  for (auto& b : noise) b = static_cast<uint8_t>(rng());
  hpddo::FrameDecoder dec;
  EXPECT_EQ(feed(dec, noise).size(), 0u);
  std::vector<uint8_t> after;
  append(after, example(5));
  const auto got = feed(dec, after);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].seq, 5);
}

namespace {

/// Random frames as the acquisition board sends them (2 Hz, channel values in range).
std::vector<hpddo::SampleFrame> board_frames(uint32_t seed, int n) {
  std::mt19937 rng(seed);
  std::vector<hpddo::SampleFrame> out;
  for (int k = 0; k < n; ++k) {
    hpddo::SampleFrame f = example(static_cast<uint16_t>(k));
    f.v_mV = static_cast<uint16_t>(rng() % 14000u);
    f.i_mA = static_cast<int16_t>(static_cast<int>(rng() % 3300u) - 300);
    f.temp_c16 = static_cast<int16_t>(320 + static_cast<int>(rng() % 640u));
    f.rpm_x10 = static_cast<int16_t>(rng() % 30000u);
    f.duty = static_cast<uint8_t>(rng());
    out.push_back(f);
  }
  return out;
}

}  // namespace

TEST(Frame, TruncatedFrameNeverCostsTheNextGoodFrame) {
  // A frame that lost its last 1-3 bytes completes on the next frame's sync bytes; when
  // its CRC happens to match (its lost CRC byte was 0xA5), the next frame kept them.
  const std::vector<hpddo::SampleFrame> frames = board_frames(77u, 30000);
  int matched_by_next_sync = 0;
  for (size_t k = 0; k + 2 < frames.size(); k += 3) {
    for (size_t cut = 1; cut <= 3; ++cut) {
      std::vector<uint8_t> bytes;
      append(bytes, frames[k]);
      matched_by_next_sync += bytes[20] == hpddo::kFrameSync0 && cut == 1;
      bytes.resize(bytes.size() - cut);
      append(bytes, frames[k + 1]);
      append(bytes, frames[k + 2]);
      hpddo::FrameDecoder dec;
      const auto got = feed(dec, bytes);
      ASSERT_GE(got.size(), 2u) << "frame " << k << " cut " << cut;
      EXPECT_EQ(got[got.size() - 2].seq, frames[k + 1].seq) << "frame " << k << " cut " << cut;
      EXPECT_EQ(got.back().seq, frames[k + 2].seq) << "frame " << k << " cut " << cut;
    }
  }
  EXPECT_GT(matched_by_next_sync, 10);  // the case the fix is for was exercised
}

TEST(Frame, AnyDroppedByteNeverCostsTheNextGoodFrame) {
  const std::vector<hpddo::SampleFrame> frames = board_frames(78u, 3000);
  for (size_t k = 0; k + 1 < frames.size(); k += 2) {
    for (size_t drop = 0; drop < hpddo::kFrameSize; ++drop) {
      std::vector<uint8_t> bytes;
      append(bytes, frames[k]);
      bytes.erase(bytes.begin() + static_cast<long>(drop));
      append(bytes, frames[k + 1]);
      hpddo::FrameDecoder dec;
      const auto got = feed(dec, bytes);
      ASSERT_FALSE(got.empty()) << "frame " << k << " drop " << drop;
      EXPECT_EQ(got.back().seq, frames[k + 1].seq) << "frame " << k << " drop " << drop;
      EXPECT_EQ(got.back().v_mV, frames[k + 1].v_mV);
    }
  }
}

TEST(Frame, CrcValidButImpossibleFramesAreRejectedAndTheNextSurvives) {
  // Each of these carries a valid CRC, but no acquisition board can send it.
  std::vector<hpddo::SampleFrame> bad;
  hpddo::SampleFrame f = example(20);
  f.flags = 0x07;  // unknown flag bit
  bad.push_back(f);
  f = example(21);
  f.period_us = 990000000u;  // 990 s: the probe's false accept
  bad.push_back(f);
  f = example(22);
  f.period_us = 0;
  bad.push_back(f);
  f = example(23);
  f.period_us = 100;  // 10 kHz: faster than the board's 1 kHz
  bad.push_back(f);
  f = example(24);
  f.flags = hpddo::kFrameFlagRpm;  // temperature absent, yet a value in its field
  bad.push_back(f);
  for (const hpddo::SampleFrame& b : bad) {
    std::vector<uint8_t> bytes;
    append(bytes, b);
    append(bytes, example(30));
    hpddo::FrameDecoder dec;
    const auto got = feed(dec, bytes);
    ASSERT_EQ(got.size(), 1u) << "seq " << b.seq;
    EXPECT_EQ(got[0].seq, 30);
  }
}

TEST(Frame, ChannelLimitsComeFromTheModelsInputLimits) {
  const hpddo::InputLimits lim = {40.0f, 10.0f, -55.0f, 125.0f};
  std::vector<hpddo::SampleFrame> bad;
  hpddo::SampleFrame f = example(40);
  f.v_mV = 40001;  // beyond the voltage channel
  bad.push_back(f);
  f = example(41);
  f.i_mA = 10001;
  bad.push_back(f);
  f = example(42);
  f.i_mA = -10001;
  bad.push_back(f);
  f = example(43);
  f.temp_c16 = 126 * 16;  // beyond the DS18B20's range
  bad.push_back(f);
  f = example(44);
  f.temp_c16 = -56 * 16;
  bad.push_back(f);
  for (const hpddo::SampleFrame& b : bad) {
    EXPECT_TRUE(hpddo::frame_plausible(b, nullptr)) << "seq " << b.seq;  // only the limits refuse it
    EXPECT_FALSE(hpddo::frame_plausible(b, &lim)) << "seq " << b.seq;
    std::vector<uint8_t> bytes;
    append(bytes, b);
    append(bytes, example(50));
    hpddo::FrameDecoder dec(&lim);
    const auto got = feed(dec, bytes);
    ASSERT_EQ(got.size(), 1u) << "seq " << b.seq;
    EXPECT_EQ(got[0].seq, 50);
    EXPECT_EQ(dec.rejected(), 1u);
  }
  hpddo::SampleFrame edge = example(60);
  edge.v_mV = 40000;
  edge.i_mA = -10000;
  edge.temp_c16 = 125 * 16;
  edge.period_us = hpddo::kFramePeriodMax_us;
  EXPECT_TRUE(hpddo::frame_plausible(edge, &lim));
  edge.period_us = hpddo::kFramePeriodMin_us;
  EXPECT_TRUE(hpddo::frame_plausible(edge, &lim));
}

TEST(Frame, PeriodRangeCoversEveryWindowTheBoardCanMake) {
  // Windows are whole PWM periods (31 Hz..100 kHz) nearest to 1/rate, rate 0.5..1000 Hz:
  // at least two thirds of the fastest window, at most 2 s plus half a 31 Hz period.
  EXPECT_LE(hpddo::kFramePeriodMin_us, 666u);
  EXPECT_GE(hpddo::kFramePeriodMax_us, 2016130u);
  EXPECT_GE(hpddo::kFramePeriodMin_us, 100u);
  EXPECT_LE(hpddo::kFramePeriodMax_us, 10000000u);
}

TEST(Frame, MonteCarloDamagedFramesCostNoGoodFrame) {
  // Bounded run of the figure in docs/firmware.md (fixed seed): every undamaged frame
  // is decoded, and false accepts stay rare (CRC-16 alone: about 6 per million).
  const hpddo::InputLimits lim = {40.0f, 10.0f, -55.0f, 125.0f};
  const linkmc::Result r = linkmc::run(200000, 20261121u, &lim);
  EXPECT_EQ(r.good_lost, 0u);
  EXPECT_LE(r.false_accepts, 2u);
  EXPECT_GT(r.decoded, r.sent - r.damaged);
}
