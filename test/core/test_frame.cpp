#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "hpddo/frame.h"

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
