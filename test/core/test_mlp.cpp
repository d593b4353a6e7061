#include <gtest/gtest.h>

#include "golden.h"
#include "golden_tiny.h"
#include "golden_tiny1.h"
#include "model_tiny.h"
#include "model_tiny1.h"

TEST(Mlp, ShapesAndParameterCounts) {
  EXPECT_EQ((+hpddo::Mlp<5, 16, 8>::kParamCount), 241);  // the paper's 0.9 kB network
  EXPECT_EQ((+hpddo::Mlp<5, 128, 64>::kParamCount), 9089);
  EXPECT_EQ((+hpddo::Mlp<5, 8, 0>::kParamCount), 57);
}

TEST(Mlp, HandComputedTwoByTwo) {
  // h = relu(W0 x + b0) = relu([1 -1; 2 0.5] [1 2] + [0 1]) = relu([-1, 4]) = [0, 4]
  // g = relu(W1 h + b1) = relu([3 0.25] [0 4] - 0.5) = [0.5];  y = 2 * 0.5 + 0.1 = 1.1
  HPDDO_FLASH static const float w0[4] = {1.0f, -1.0f, 2.0f, 0.5f};
  HPDDO_FLASH static const float b0[2] = {0.0f, 1.0f};
  HPDDO_FLASH static const float w1[2] = {3.0f, 0.25f};
  HPDDO_FLASH static const float b1[1] = {-0.5f};
  HPDDO_FLASH static const float w2[1] = {2.0f};
  HPDDO_FLASH static const float b2[1] = {0.1f};
  const hpddo::MlpWeights w = {w0, b0, w1, b1, w2, b2};
  const float z[2] = {1.0f, 2.0f};
  EXPECT_FLOAT_EQ((hpddo::Mlp<2, 2, 1>::forward(w, z)), 1.1f);
  // One hidden layer: y = [3 0.25] [0 4] - 0.5 = 0.5
  EXPECT_FLOAT_EQ((hpddo::Mlp<2, 2, 0>::forward(w, z)), 0.5f);
}

template <class Net>
static int check_golden(const hpddo::Model<Net>& m, int count, float (*at)(uint16_t, uint8_t), int col_z0,
                        int col_out) {
  int checked = 0;
  for (int r = 0; r < count; ++r) {
    const float want = at(static_cast<uint16_t>(r), static_cast<uint8_t>(col_out));
    if (std::isnan(want)) continue;
    float z[5];
    for (int j = 0; j < 5; ++j) z[j] = at(static_cast<uint16_t>(r), static_cast<uint8_t>(col_z0 + j));
    const float got = Net::forward(m.weights, z);
    EXPECT_TRUE(golden::close(got, want)) << "row " << r << " got " << got << " want " << want;
    ++checked;
  }
  return checked;
}

TEST(Mlp, TwoHiddenLayersMatchGolden) {
  using namespace hpddo_golden_tiny;
  EXPECT_GT(check_golden(hpddo_model_tiny::kModel, kCount, at, kCol_z0, kCol_mlp_rpm), 20);  // rows where the network runs
}

TEST(Mlp, OneHiddenLayerMatchesGolden) {
  using namespace hpddo_golden_tiny1;
  EXPECT_GT(check_golden(hpddo_model_tiny1::kModel, kCount, at, kCol_z0, kCol_mlp_rpm), 20);  // rows where the network runs
}
