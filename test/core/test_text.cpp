// hpddo::TextWriter: decimal text into a bounded buffer, NUL-terminated, overflow
// remembered and nothing written past the end.
#include <gtest/gtest.h>

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
