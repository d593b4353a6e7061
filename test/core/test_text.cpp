// hpddo::TextWriter: decimal text into a bounded buffer, NUL-terminated, overflow
// remembered and nothing written past the end.
#include <gtest/gtest.h>

#include <stdio.h>
#include <string.h>

#include "hpddo/text.h"

TEST(Text, IntegersAndFixedPointToTheLastDigit) {
  char buf[96];
  hpddo::TextWriter w(buf, sizeof buf);
  w.u32(0u);
  w.put(',');
  w.u32(4294967295u);
  w.put(',');
  w.i32(-2147483647 - 1);
  w.put(',');
  w.fixed(-5, 3);
  w.put(',');
  w.fixed(123456, 4);
  w.put(',');
  w.fixed(7, 0);
  w.put(',');
  w.digits(42u, 100000u);
  EXPECT_STREQ(buf, "0,4294967295,-2147483648,-0.005,12.3456,7,00042");
  EXPECT_EQ(w.length(), strlen(buf));
  EXPECT_FALSE(w.overflow());
}

TEST(Text, OverflowDropsTheRestAndNeverWritesPastTheEnd) {
  char buf[8];
  memset(buf, 'x', sizeof buf);
  hpddo::TextWriter w(buf, 6);
  w.str("hpddo-text");
  EXPECT_TRUE(w.overflow());
  EXPECT_STREQ(buf, "hpddo");
  EXPECT_EQ(w.length(), 5u);
  EXPECT_EQ(buf[6], 'x');
  EXPECT_EQ(buf[7], 'x');
  hpddo::TextWriter none(buf, 0);  // no room at all: nothing written, overflow said
  none.put('a');
  EXPECT_TRUE(none.overflow());
  EXPECT_EQ(buf[0], 'h');
}

TEST(Text, PowersOfTen) {
  EXPECT_EQ(hpddo::TextWriter::pow10(0), 1u);
  EXPECT_EQ(hpddo::TextWriter::pow10(9), 1000000000u);
}

// The digit loops divide by ten with a product below 65536 (TextWriter::div10): the same
// text as printf's for every value at the edges and across the range.
TEST(Text, DigitsAndFixedPointAgreeWithPrintf) {
  const int32_t edges[] = {0, 1, -1, 9, 10, 99, 100, 65535, 65536, 65539, 81919, 81920, 99999, 100000, 123456789,
                           2147483647, -2147483647 - 1, -65536, -100000};
  uint32_t v = 1u;
  for (int k = 0; k < 4000; ++k, v = v * 1664525u + 1013904223u) {
    for (int e = 0; e < 20; ++e) {
      const int32_t x = e < 19 ? edges[e] : static_cast<int32_t>(v >> (k % 31));
      for (uint8_t dec = 0; dec <= 9; ++dec) {
        char buf[40], want[40];
        hpddo::TextWriter w(buf, sizeof buf);
        w.fixed(x, dec);
        const int64_t mag = x < 0 ? -static_cast<int64_t>(x) : x;
        const int64_t p = static_cast<int64_t>(hpddo::TextWriter::pow10(dec));
        if (dec)
          snprintf(want, sizeof want, "%s%lld.%0*lld", x < 0 ? "-" : "", static_cast<long long>(mag / p), dec,
                   static_cast<long long>(mag % p));
        else
          snprintf(want, sizeof want, "%s%lld", x < 0 ? "-" : "", static_cast<long long>(mag));
        ASSERT_STREQ(buf, want) << x << " with " << int(dec) << " decimals";
      }
      char buf[40], want[40];
      hpddo::TextWriter w(buf, sizeof buf);
      const uint32_t u = static_cast<uint32_t>(x);
      w.u32(u);
      w.put(',');
      w.digits(u % 1000000u, 1000000u);
      snprintf(want, sizeof want, "%lu,%06lu", static_cast<unsigned long>(u), static_cast<unsigned long>(u % 1000000u));
      ASSERT_STREQ(buf, want);
    }
  }
}
