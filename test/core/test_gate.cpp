// hpddo::Gate: weight 1 near a prototype, 0 beyond r_out, the linear fade in d2
// between, 0 for NaN and infinities, monotone away from the data, and the early stop
// of the sum equal to the full minimum. Built plain and over the host flash fake
// (core.flash_fake.gate). test/py/test_gate.py holds it to tools/hpddo/model/gate.py.
#include <math.h>

#include <gtest/gtest.h>

#include "hpddo_core.h"

namespace {

// Two dimensions in units of their own (a volt-like and an RPM-like one), three
// prototypes in the scaled space; r_in = 0.5, r_out = 1 (scaled units).
HPDDO_FLASH const float kCentre[2] = {1.0f, 10.0f};
HPDDO_FLASH const float kScale[2] = {2.0f, 5.0f};
HPDDO_FLASH const float kProtos[6] = {0.0f, 0.0f, 3.0f, 0.0f, 0.0f, -2.0f};
const hpddo::Gate<2, 3> kGate = {kCentre, kScale, kProtos, 0.25f, 1.0f};

float w2(float a, float b) {
  const float g[2] = {a, b};
  return kGate.weight(g);
}

/// The gate's arithmetic without the early stop: every prototype's full sum.
template <uint8_t kD, uint8_t kP>
float reference_weight(const hpddo::Gate<kD, kP>& gate, const float (&g)[kD]) {
  float z[kD];
  for (uint8_t j = 0; j < kD; ++j) {
    if (!hpddo::is_finite(g[j])) return 0.0f;
    z[j] = (g[j] - hpddo::flash_float(gate.centre + j)) / hpddo::flash_float(gate.scale + j);
  }
  float best = gate.r_out_sq;
  for (uint8_t k = 0; k < kP; ++k) {
    float acc = 0.0f;
    for (uint8_t j = 0; j < kD; ++j) {
      const float diff = z[j] - hpddo::flash_float(gate.prototypes + k * kD + j);
      acc = acc + diff * diff;
    }
    if (acc < best) best = acc;
  }
  if (!(best < gate.r_out_sq)) return 0.0f;
  if (best <= gate.r_in_sq) return 1.0f;
  return (gate.r_out_sq - best) / (gate.r_out_sq - gate.r_in_sq);
}

}  // namespace

TEST(Gate, SizesAndFlashFloats) {
  EXPECT_EQ((hpddo::Gate<2, 3>::kInputs), 2);
  EXPECT_EQ((hpddo::Gate<2, 3>::kPrototypes), 3);
  EXPECT_EQ((hpddo::Gate<2, 3>::kFlashFloats), 10);
  EXPECT_EQ((hpddo::Gate<6, 32>::kFlashFloats), 204);
  EXPECT_EQ((hpddo::Gate<255, 255>::kFlashFloats), 65535);  // the largest still fits uint16_t
}

TEST(Gate, OneAtEveryPrototype) {
  // g = centre + scale * p for each prototype p
  EXPECT_EQ(w2(1.0f, 10.0f), 1.0f);
  EXPECT_EQ(w2(7.0f, 10.0f), 1.0f);
  EXPECT_EQ(w2(1.0f, 0.0f), 1.0f);
}

TEST(Gate, OneWithinRin) {
  EXPECT_EQ(w2(1.0f + 2.0f * 0.5f, 10.0f), 1.0f);  // d2 = 0.25 = r_in_sq: still 1
  EXPECT_EQ(w2(1.0f, 10.0f - 5.0f * 0.3f), 1.0f);
}

TEST(Gate, LinearFadeInSquaredDistance) {
  // z = (0.75, 0): d2 = 0.5625, w = (1 - 0.5625) / 0.75
  EXPECT_FLOAT_EQ(w2(2.5f, 10.0f), (1.0f - 0.5625f) / 0.75f);
  // z = (3, -0.9) near the second prototype: d2 = 0.81
  const float d2 = 0.9f * 0.9f;
  EXPECT_NEAR(w2(7.0f, 10.0f - 4.5f), (1.0f - d2) / 0.75f, 1e-6f);
}

TEST(Gate, ZeroFromRout) {
  EXPECT_EQ(w2(1.0f + 2.0f * 1.0f, 10.0f), 0.0f);   // d2 = 1 = r_out_sq
  EXPECT_EQ(w2(1.0f + 2.0f * 1.5f, 10.0f), 0.0f);   // midway between two prototypes
  EXPECT_EQ(w2(1.0e6f, 10.0f), 0.0f);
  EXPECT_EQ(w2(-3.0e38f, 3.0e38f), 0.0f);           // scaled distance overflows to inf
}

TEST(Gate, ZeroForNanAndInfinities) {
  EXPECT_EQ(w2(hpddo::absent(), 10.0f), 0.0f);
  EXPECT_EQ(w2(1.0f, hpddo::absent()), 0.0f);
  EXPECT_EQ(w2(INFINITY, 10.0f), 0.0f);
  EXPECT_EQ(w2(1.0f, -INFINITY), 0.0f);
}

TEST(Gate, MonotoneAwayFromThePrototypes) {
  // Along rays from the first prototype that meet no other one first.
  const float dirs[3][2] = {{-1.0f, 0.0f}, {0.0f, 1.0f}, {-0.6f, 0.8f}};
  for (const auto& d : dirs) {
    float prev = 1.0f;
    for (int s = 0; s <= 200; ++s) {
      const float t = 0.01f * static_cast<float>(s);  // scaled distance 0 .. 2
      const float w = w2(1.0f + 2.0f * t * d[0], 10.0f + 5.0f * t * d[1]);
      EXPECT_LE(w, prev) << t;
      EXPECT_GE(w, 0.0f);
      EXPECT_LE(w, 1.0f);
      prev = w;
    }
    EXPECT_EQ(prev, 0.0f);
  }
}

TEST(Gate, EarlyStopEqualsTheFullMinimum) {
  uint32_t s = 12345u;
  for (int n = 0; n < 20000; ++n) {
    float g[2];
    for (float& v : g) {
      s = s * 1664525u + 1013904223u;  // LCG: the same inputs on every host
      v = static_cast<float>(s >> 8) * (1.0f / 16777216.0f) * 24.0f - 8.0f;
    }
    g[1] = g[1] * 2.5f + 10.0f;
    const float w = kGate.weight(g);
    ASSERT_EQ(w, reference_weight(kGate, g)) << g[0] << " " << g[1];
    ASSERT_GE(w, 0.0f);
    ASSERT_LE(w, 1.0f);
  }
}

TEST(Gate, FirstPrototypeChangesNothingButTheOrder) {
  uint32_t s = 777u;
  uint8_t carried = 0;
  for (int n = 0; n < 5000; ++n) {
    float g[2];
    for (float& v : g) {
      s = s * 1664525u + 1013904223u;
      v = static_cast<float>(s >> 8) * (1.0f / 16777216.0f) * 24.0f - 8.0f;
    }
    g[1] = g[1] * 2.5f + 10.0f;
    const float want = reference_weight(kGate, g);
    for (uint8_t first = 0; first < 5; ++first) {  // 5: also a start beyond the prototypes
      uint8_t k = first;
      ASSERT_EQ(kGate.weight(g, &k), want) << "start " << int(first);
    }
    ASSERT_EQ(kGate.weight(g, &carried), want);  // the observer's use: the nearest carried on
  }
}

TEST(Gate, EqualThresholdsGiveAStep) {
  const hpddo::Gate<2, 3> step = {kCentre, kScale, kProtos, 0.25f, 0.25f};
  const float near_g[2] = {1.0f + 2.0f * 0.49f, 10.0f};
  const float far_g[2] = {1.0f + 2.0f * 0.51f, 10.0f};
  EXPECT_EQ(step.weight(near_g), 1.0f);
  EXPECT_EQ(step.weight(far_g), 0.0f);
}
