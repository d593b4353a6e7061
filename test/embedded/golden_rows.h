// The observer suites' shared check: an observer stepped through a golden vector's rows
// (written by the exporter, the same files the host tests read) gives each row's speed
// within 1e-4 relative (1e-4 RPM below 1 RPM), its status, and the novelty gate's weight.
// Gold is the golden header's namespace as a type-free set of functions: at(row, col),
// sample(row), passed in with its column indices.
#ifndef HPDDO_TEST_EMBEDDED_GOLDEN_ROWS_H
#define HPDDO_TEST_EMBEDDED_GOLDEN_ROWS_H

#include <unity.h>

#include "hpddo_core.h"

struct GoldenColumns {
  uint16_t count;
  uint8_t rpm, status, confidence;
};

template <class Observer>
void check_golden_rows(Observer* obs, const GoldenColumns& col, float (*at)(uint16_t, uint8_t),
                       hpddo::Sample (*sample)(uint16_t)) {
  for (uint16_t r = 0; r < col.count; ++r) {
    const hpddo::Estimate e = obs->step(sample(r));
    const float want = at(r, col.rpm);
    const float mag = want < 0.0f ? -want : want;
    TEST_ASSERT_FLOAT_WITHIN(1e-4f * (mag > 1.0f ? mag : 1.0f), want, e.rpm);
    TEST_ASSERT_EQUAL_INT(static_cast<int>(at(r, col.status)), static_cast<int>(e.status));
    TEST_ASSERT_FLOAT_WITHIN(1e-4f, at(r, col.confidence), e.confidence);  // the novelty gate's weight
  }
}

#endif  // HPDDO_TEST_EMBEDDED_GOLDEN_ROWS_H
