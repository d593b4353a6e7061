// Unity tests of the acquisition logic, on the UNO (pio test -e uno) and on
// the desk (pio test -e native). The full host suite is test/firmware/test_acq.cpp.
#include <string.h>
#include <unity.h>

#include "acq_format.h"
#include "acq_protocol.h"
#include "acq_window.h"

void setUp() {}
void tearDown() {}

static void test_row_format() {
  acq::LogRow r = {3, 500000, 8000, 9.61249f, -0.0123f, 181.255f, true, 641, 2, 70001};
  char buf[acq::kLineMax];
  acq::LineWriter w(buf, sizeof buf);
  acq::format_row(w, r);
  TEST_ASSERT_EQUAL_STRING("1.500000,0.8000,9.6125,-0.0123,181.26,40.0625,2,70001", buf);
}

static void test_window_means() {
  acq::WindowSums s;
  memset(&s, 0, sizeof s);
  s.n_v = s.n_i = 4000;
  s.sum_v = 409UL * 4000UL;
  s.sum_i = 82UL * 4000UL;
  s.enc_counts = 302;
  s.period_us = 500000;
  const acq::Measurement m = acq::measure(s, acq::kCalibration, 400);
  TEST_ASSERT_FLOAT_WITHIN(1e-4f, 409.5f * 5.0f / 1024.0f * 3.0f, m.v_V);
  TEST_ASSERT_FLOAT_WITHIN(1e-4f, 82.5f * 5.0f / 1024.0f / 0.5f, m.i_A);
  TEST_ASSERT_FLOAT_WITHIN(1e-3f, 90.6f, m.rpm);
}

static void test_sweep() {
  acq::ProtocolPlan p(acq::kProtoSweep, 2, 0);
  acq::Setpoint sp;
  TEST_ASSERT_EQUAL_UINT32(22, p.total());
  TEST_ASSERT_TRUE(p.at(10, &sp));
  TEST_ASSERT_EQUAL_UINT16(10000, sp.duty_q);
  TEST_ASSERT_TRUE(p.at(21, &sp));
  TEST_ASSERT_EQUAL_UINT16(0, sp.duty_q);
  TEST_ASSERT_FALSE(p.at(22, &sp));
}

static int run() {
  UNITY_BEGIN();
  RUN_TEST(test_row_format);
  RUN_TEST(test_window_means);
  RUN_TEST(test_sweep);
  return UNITY_END();
}

#include "../unity_main.h"
