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
#include "model_tiny1_q.h"
#include "model_tiny_q.h"
#if defined(HPDDO_HAVE_DEFAULT_MODEL)
#include "golden_default_q.h"
#include "model_default_q.h"
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

namespace {

// The square-root bound of the integer gate's board path (gate_q.h): |d| > b must imply
// d^2 >= x, that is (b + 1)^2 >= x, for every best the gate can hold (0 < x < 2^31).
void expect_sqrt_bound(uint32_t x) {
  const uint32_t b = hpddo::detail::sqrt_bound(x);
  const uint64_t next = static_cast<uint64_t>(b + 1u) * (b + 1u);
  EXPECT_GE(next, x) << "x = " << x << ", b = " << b;
  // and useful: within a few units of the root, not a blanket bound
  EXPECT_LE(static_cast<double>(b), std::sqrt(static_cast<double>(x)) * 1.02 + 2.0) << "x = " << x;
}

}  // namespace

TEST(GateQ, SquareRootBoundNeverPassesOverANearerPrototype) {
  for (uint32_t x = 1; x <= 300000u; ++x) expect_sqrt_bound(x);
  uint32_t x = 300001u;
  while (x < 0x7FFFFFFFu - x / 1000u) {
    expect_sqrt_bound(x);
    expect_sqrt_bound(x - 1u);
    x += x / 1000u + 1u;
  }
  expect_sqrt_bound(0x7FFFFFFFu);
}

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
