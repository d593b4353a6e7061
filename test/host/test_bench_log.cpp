#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "bench_log.h"

namespace {

std::string write_tmp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

std::string error_of(const std::string& name, const std::string& text) {
  try {
    hpddo_host::read_bench_log(write_tmp(name, text));
  } catch (const hpddo_host::LogError& e) {
    return e.what();
  }
  return "";
}

const char* kGood =
    "# condition=sweep\n# sample_rate_hz=2\n"
    "i_A,t_s,extra,duty,v_V,temp_C,rpm_ref\n"
    "0.003,0.0,x,0.000,0.012,31.7,0.0\n"
    "0.214,0.5,y,0.200,2.391,,41.2\n";

}  // namespace

TEST(BenchLog, ReadsColumnsInAnyOrderWithExtrasAndEmptyOptionals) {
  const auto log = hpddo_host::read_bench_log(write_tmp("good.csv", kGood));
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log.condition(), "sweep");
  EXPECT_EQ(log.meta.at("sample_rate_hz"), "2");
  EXPECT_DOUBLE_EQ(log.v_V[1], 2.391);
  EXPECT_DOUBLE_EQ(log.i_A[1], 0.214);
  EXPECT_DOUBLE_EQ(log.rpm_ref[1], 41.2);
  EXPECT_TRUE(std::isnan(log.temp_C[1]));
  EXPECT_FALSE(log.has_seq);
  EXPECT_EQ(log.seq[1], 1);
}

TEST(BenchLog, NamesFileLineAndFault) {
  const std::string head = "# condition=x\nt_s,duty,v_V,i_A\n0.0,0.1,1.0,0.1\n";
  EXPECT_NE(error_of("a.csv", "t_s,duty,v_V\n0,0,1\n").find("a.csv:1: missing required column(s): i_A"),
            std::string::npos);
  EXPECT_NE(error_of("b.csv", head + "0.5,0.1,abc,0.1\n").find("b.csv:4: non-numeric or non-finite value in "
                                                               "required column v_V"),
            std::string::npos);
  EXPECT_NE(error_of("c.csv", head + "0.5,0.1,nan,0.1\n").find("c.csv:4: non-numeric or non-finite"),
            std::string::npos);
  EXPECT_NE(error_of("d.csv", head + "0.0,0.1,1.0,0.1\n").find("d.csv:4: t_s not strictly increasing"),
            std::string::npos);
  EXPECT_NE(error_of("e.csv", head + "0.5,1.5,1.0,0.1\n").find("e.csv:4: duty outside 0..1"), std::string::npos);
  EXPECT_NE(error_of("f.csv", head + "0.5,0.1,1.0\n").find("f.csv:4: expected 4 fields, found 3"),
            std::string::npos);
  EXPECT_NE(error_of("g.csv", "").find("g.csv:0: empty file"), std::string::npos);
  EXPECT_NE(error_of("h.csv", "# a=b\nt_s,duty,v_V,i_A\n").find("h.csv:2: header with no rows"), std::string::npos);
  EXPECT_NE(error_of("i.csv", "# just a comment\n").find("i.csv:1: metadata line without key=value"),
            std::string::npos);
}

TEST(BenchLog, MissingFileIsAnError) {
  EXPECT_THROW(hpddo_host::read_bench_log("/nonexistent/x.csv"), hpddo_host::LogError);
}
