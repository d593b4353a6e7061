// The fixed-point network (mlp_q.h) against the integer reference of tools/hpddo/model/quant.py:
// quantised inputs, output accumulator and residual bit for bit; the whole observer
// with it within the golden tolerance (its physics is float, as in the float goldens).
#include <cmath>
#include <cstring>
#include <limits>

#include <gtest/gtest.h>

#include "golden.h"
#include "golden_tiny1_q.h"
#include "golden_tiny_q.h"
#include "golden_tiny1_q8.h"
#include "golden_tiny_q8.h"
#include "model_tiny1_q.h"
#include "model_tiny1_q8.h"
#include "model_tiny_q.h"
#include "model_tiny_q8.h"
#if defined(HPDDO_HAVE_DEFAULT_MODEL)
#include "golden_default_q.h"
#include "model_default_q.h"
#endif
#if defined(HPDDO_HAVE_DEFAULT_MODEL_Q8)
#include "golden_default_q8.h"
#include "model_default_q8.h"
#endif

namespace {

using golden::bits;

// Columns are the same in every fixed-point golden table.
using namespace hpddo_golden_tiny_q;

template <class Net>
void check_network(const hpddo::Model<Net>& model, uint16_t count, float (*at)(uint16_t, uint8_t),
                   int32_t (*int_at)(uint16_t, uint8_t)) {
  for (uint16_t r = 0; r < count; ++r) {
    float x[5];
    for (uint8_t j = 0; j < 5; ++j) x[j] = at(r, static_cast<uint8_t>(kCol_x0 + j));
    int16_t xq[5];
    Net::quantise(model.weights, x, xq);
    for (uint8_t j = 0; j < 5; ++j) {
      ASSERT_EQ(xq[j], int_at(r, static_cast<uint8_t>(kInt_xq0 + j))) << "row " << r << " feature " << int(j);
    }
    ASSERT_EQ(Net::forward_acc(model.weights, xq), int_at(r, kInt_acc)) << "row " << r;
    ASSERT_EQ(bits(Net::forward_raw(model.weights, x)), bits(at(r, kCol_mlp_rpm))) << "row " << r;
  }
}

template <class Net>
void check_observer(const hpddo::Model<Net>& model, uint16_t count, float (*at)(uint16_t, uint8_t),
                    hpddo::Sample (*sample)(uint16_t)) {
  hpddo::Observer<Net> obs(model);
  int statuses[5] = {0, 0, 0, 0, 0};
  for (uint16_t r = 0; r < count; ++r) {
    const hpddo::Estimate e = obs.step(sample(r));
    EXPECT_EQ(static_cast<int>(e.status), static_cast<int>(at(r, kCol_status))) << "row " << r;
    EXPECT_TRUE(golden::close(e.rpm_m2, at(r, kCol_rpm_m2))) << "row " << r;
    EXPECT_TRUE(golden::close(e.residual_rpm, at(r, kCol_residual_rpm))) << "row " << r << " " << e.residual_rpm;
    EXPECT_TRUE(golden::close(e.rpm, at(r, kCol_rpm))) << "row " << r << " rpm " << e.rpm;
    EXPECT_TRUE(golden::close(e.confidence, at(r, kCol_confidence))) << "row " << r;
    ++statuses[e.status];
  }
  EXPECT_GT(statuses[hpddo::kStatusOk] + statuses[hpddo::kStatusClamped] + statuses[hpddo::kStatusGated], 0);
}

TEST(MlpQ, TinyNetworkMatchesIntegerReferenceBitForBit) {
  check_network(hpddo_model_tiny_q::kModel, hpddo_golden_tiny_q::kCount, hpddo_golden_tiny_q::at,
                hpddo_golden_tiny_q::int_at);
}

TEST(MlpQ, OneHiddenLayerMatchesIntegerReferenceBitForBit) {
  check_network(hpddo_model_tiny1_q::kModel, hpddo_golden_tiny1_q::kCount, hpddo_golden_tiny1_q::at,
                hpddo_golden_tiny1_q::int_at);
}

TEST(MlpQ, ObserverWithFixedPointNetworkMatchesReference) {
  check_observer(hpddo_model_tiny_q::kModel, hpddo_golden_tiny_q::kCount, hpddo_golden_tiny_q::at,
                 hpddo_golden_tiny_q::sample);
  check_observer(hpddo_model_tiny1_q::kModel, hpddo_golden_tiny1_q::kCount, hpddo_golden_tiny1_q::at,
                 hpddo_golden_tiny1_q::sample);
}

TEST(MlpQ, ChecksumMatchesGeneratedHeader) {
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_tiny_q::kModel), hpddo_model_tiny_q::kChecksum);
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_tiny1_q::kModel), hpddo_model_tiny1_q::kChecksum);
  EXPECT_NE(hpddo_model_tiny_q::kChecksum, hpddo_model_tiny::kChecksum);
}

// The int8 networks (layer 0 int8, the hidden layer int8 where there is one; mlp_q.h's mac8).
TEST(MlpQ8, TinyNetworksMatchIntegerReferenceBitForBit) {
  check_network(hpddo_model_tiny_q8::kModel, hpddo_golden_tiny_q8::kCount, hpddo_golden_tiny_q8::at,
                hpddo_golden_tiny_q8::int_at);
  check_network(hpddo_model_tiny1_q8::kModel, hpddo_golden_tiny1_q8::kCount, hpddo_golden_tiny1_q8::at,
                hpddo_golden_tiny1_q8::int_at);
}

TEST(MlpQ8, ObserverWithInt8NetworkMatchesReference) {
  check_observer(hpddo_model_tiny_q8::kModel, hpddo_golden_tiny_q8::kCount, hpddo_golden_tiny_q8::at,
                 hpddo_golden_tiny_q8::sample);
  check_observer(hpddo_model_tiny1_q8::kModel, hpddo_golden_tiny1_q8::kCount, hpddo_golden_tiny1_q8::at,
                 hpddo_golden_tiny1_q8::sample);
}

TEST(MlpQ8, ChecksumMatchesGeneratedHeader) {
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_tiny_q8::kModel), hpddo_model_tiny_q8::kChecksum);
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_tiny1_q8::kModel), hpddo_model_tiny1_q8::kChecksum);
  EXPECT_NE(hpddo_model_tiny_q8::kChecksum, hpddo_model_tiny_q::kChecksum);
}

TEST(MlpQ8, Mac8IsTheProductForEverySignAndByte) {
  const int16_t as[] = {0, 1, -1, 127, -128, 255, 256, -256, 32767, -32767, -32768, 12345, -12345, 0x00FF, 0x7F80};
  // near the int32 limits, as far as the sum stays in range (|w a| <= 2^22): mac8 adds within
  // quant.py's bounds, and an overflowing sum would be undefined in the reference too
  const int32_t accs[] = {0, 1, -1, 0x7F000000, -0x7F000000, 0x00FFFFFF, -0x01000000};
  for (int w = -128; w <= 127; ++w) {
    for (int16_t a : as) {
      for (int32_t acc : accs) {
        EXPECT_EQ(hpddo::detail::mac8(acc, static_cast<int8_t>(w), a), acc + w * static_cast<int32_t>(a));
      }
    }
  }
}

#if defined(HPDDO_HAVE_DEFAULT_MODEL_Q8)
TEST(MlpQ8, DefaultModelMatchesIntegerReference) {
  check_network(hpddo_model_default_q8::kModel, hpddo_golden_default_q8::kCount, hpddo_golden_default_q8::at,
                hpddo_golden_default_q8::int_at);
  check_observer(hpddo_model_default_q8::kModel, hpddo_golden_default_q8::kCount, hpddo_golden_default_q8::at,
                 hpddo_golden_default_q8::sample);
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_default_q8::kModel), hpddo_model_default_q8::kChecksum);
}
#endif

#if defined(HPDDO_HAVE_DEFAULT_MODEL)
TEST(MlpQ, DefaultModelMatchesIntegerReference) {
  check_network(hpddo_model_default_q::kModel, hpddo_golden_default_q::kCount, hpddo_golden_default_q::at,
                hpddo_golden_default_q::int_at);
  check_observer(hpddo_model_default_q::kModel, hpddo_golden_default_q::kCount, hpddo_golden_default_q::at,
                 hpddo_golden_default_q::sample);
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_default_q::kModel), hpddo_model_default_q::kChecksum);
}
#endif

TEST(MlpQ, InputQuantisationRoundsHalvesAwayFromZeroAndSaturates) {
  using hpddo::detail::quantise_input;
  EXPECT_EQ(quantise_input(0.0f, 4), 0);
  EXPECT_EQ(quantise_input(-0.0f, 4), 0);
  EXPECT_EQ(quantise_input(2.5f, 0), 3);
  EXPECT_EQ(quantise_input(-2.5f, 0), -3);
  EXPECT_EQ(quantise_input(2.49999976f, 0), 2);
  EXPECT_EQ(quantise_input(0.5f, 0), 1);
  EXPECT_EQ(quantise_input(0.49999997f, 0), 0);
  EXPECT_EQ(quantise_input(1.25f, 2), 5);
  EXPECT_EQ(quantise_input(-9.0f, 11), -18432);
  EXPECT_EQ(quantise_input(16.0f, 11), 32767);
  EXPECT_EQ(quantise_input(-16.0f, 11), -32767);
  EXPECT_EQ(quantise_input(1e30f, 0), 32767);
  EXPECT_EQ(quantise_input(std::numeric_limits<float>::infinity(), 0), 32767);
  EXPECT_EQ(quantise_input(-std::numeric_limits<float>::infinity(), 0), -32767);
  EXPECT_EQ(quantise_input(std::numeric_limits<float>::quiet_NaN(), 3), 0);
  EXPECT_EQ(quantise_input(std::numeric_limits<float>::denorm_min(), 60), 0);
  EXPECT_EQ(quantise_input(3.0f, -1), 2);   // 1.5 -> 2
  EXPECT_EQ(quantise_input(100.0f, -8), 0); // 0.39
}

}  // namespace

TEST(MlpQ, ShiftRightByBytesIsTheShift) {
  const int32_t values[] = {0, 1, -1, 12345, -12345, 0x7FFFFFFF, -0x7FFFFFFF - 1, 0x12345678, -0x12345678};
  for (int32_t v : values) {
    for (uint8_t s = 0; s < 32; ++s) {
      EXPECT_EQ(hpddo::detail::shift_right(v, s), v >> s) << v << " >> " << int(s);
      const uint32_t u = static_cast<uint32_t>(v);
      EXPECT_EQ(hpddo::detail::shift_right(u, s), u >> s) << u << " >> " << int(s);
    }
  }
}
