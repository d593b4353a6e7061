// The C++ bench log reader (host/bench_log.h) against docs/bench-log.md: the whole
// conformance corpus test/fixtures/logs (good logs accepted, bad logs refused with the
// expected line and fault keyword), the bundled recordings, and the values it reads.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "bench_log.h"

namespace {

namespace fs = std::filesystem;

const fs::path kLogs = HPDDO_LOGS_DIR;

std::string write_tmp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path, std::ios::binary) << text;
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

struct Expected {
  std::string file;
  size_t line;
  std::string fault;
};

std::vector<Expected> expected_faults() {
  std::ifstream in(kLogs / "bad" / "EXPECTED.tsv");
  std::vector<Expected> out;
  std::string row;
  std::getline(in, row);  // column names
  while (std::getline(in, row)) {
    std::istringstream cols(row);
    Expected e;
    std::string line;
    std::getline(cols, e.file, '\t');
    std::getline(cols, line, '\t');
    std::getline(cols, e.fault, '\t');
    e.line = std::stoul(line);
    out.push_back(e);
  }
  return out;
}

const char* kGood =
    "# condition=sweep\n# sample_rate_hz=2\n"
    "i_A,t_s,extra,duty,v_V,temp_C,rpm_ref\n"
    "0.003,0.0,x,0.000,0.012,31.7,0.0\n"
    "0.214,0.5,y,0.200,2.391,,41.2\n";

}  // namespace

TEST(BenchLogCorpus, AcceptsEveryGoodLog) {
  size_t n = 0;
  for (const auto& entry : fs::directory_iterator(kLogs / "good")) {
    if (entry.path().extension() != ".csv") continue;
    ++n;
    try {
      hpddo_host::read_bench_log(entry.path().string());
    } catch (const hpddo_host::LogError& e) {
      ADD_FAILURE() << "refused a good log: " << e.what();
    }
  }
  EXPECT_GE(n, 10u);
}

TEST(BenchLogCorpus, RefusesEveryBadLogWithItsLineAndFault) {
  const auto expected = expected_faults();
  ASSERT_GE(expected.size(), 40u);
  size_t csv = 0;
  for (const auto& entry : fs::directory_iterator(kLogs / "bad")) csv += entry.path().extension() == ".csv";
  EXPECT_EQ(csv, expected.size()) << "every bad log has one row in EXPECTED.tsv";
  for (const auto& e : expected) {
    const std::string path = (kLogs / "bad" / e.file).string();
    try {
      hpddo_host::read_bench_log(path);
      ADD_FAILURE() << e.file << ": accepted, expected line " << e.line << " " << e.fault;
    } catch (const hpddo_host::LogError& err) {
      EXPECT_EQ(err.line(), e.line) << err.what();
      EXPECT_EQ(err.fault(), e.fault) << err.what();
      EXPECT_NE(std::string(err.what()).find(e.file + ":" + std::to_string(e.line) + ": "), std::string::npos)
          << err.what();
    }
  }
}

TEST(BenchLogCorpus, AcceptsTheBundledRecordings) {
  const fs::path root = kLogs.parent_path().parent_path().parent_path();
  for (const char* rel : {"data/default/sweep.csv", "data/default/load.csv", "data/default/long.csv",
                          "test/fixtures/log_short.csv"}) {
    const auto log = hpddo_host::read_bench_log((root / rel).string());
    EXPECT_GT(log.size(), 100u) << rel;
    EXPECT_TRUE(log.has_seq) << rel;
    EXPECT_EQ(log.seq[0], 0) << rel;
  }
}

TEST(BenchLog, ReadsColumnsInAnyOrderWithExtrasAndEmptyOptionals) {
  const auto log = hpddo_host::read_bench_log(write_tmp("good.csv", kGood));
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log.condition(), "sweep");
  EXPECT_EQ(log.meta.at("sample_rate_hz"), "2");
  EXPECT_DOUBLE_EQ(log.v_V[1], 2.391);
  EXPECT_DOUBLE_EQ(log.i_A[1], 0.214);
  EXPECT_DOUBLE_EQ(log.rpm_ref[1], 41.2);
  EXPECT_TRUE(std::isnan(log.temp_C[1]));
  EXPECT_TRUE(log.has_rpm_ref && log.has_temp_C);
  EXPECT_FALSE(log.has_seq || log.has_load);
  EXPECT_EQ(log.seq[1], 1);
  EXPECT_EQ(log.lines[0], 4u);
  EXPECT_EQ(log.lines[1], 5u);
}

TEST(BenchLog, ReadsIntegersAsIntegersUpToTheirRange) {
  const auto log = hpddo_host::read_bench_log(
      write_tmp("ints.csv", "t_s,duty,v_V,i_A,load,seq\n0,0,0,0,255,9007199254740991\n1,0,0,0,007,00042\n"));
  EXPECT_EQ(log.load[0], 255);
  EXPECT_EQ(log.seq[0], 9007199254740991);
  EXPECT_EQ(log.load[1], 7);
  EXPECT_EQ(log.seq[1], 42);
  // seq of 2^63 and beyond is refused, never converted through a float
  EXPECT_NE(error_of("big.csv", "t_s,duty,v_V,i_A,seq\n0,0,0,0,9223372036854775808\n").find("big.csv:2: out of range"),
            std::string::npos);
}

TEST(BenchLog, NamesFileLineAndFault) {
  const std::string head = "# condition=x\nt_s,duty,v_V,i_A\n0.0,0.1,1.0,0.1\n";
  EXPECT_NE(error_of("a.csv", "t_s,duty,v_V\n0,0,1\n").find("a.csv:1: missing required column(s) i_A"),
            std::string::npos);
  EXPECT_NE(error_of("b.csv", head + "0.5,0.1,abc,0.1\n").find("b.csv:4: non-numeric value 'abc' in column v_V"),
            std::string::npos);
  EXPECT_NE(error_of("c.csv", head + "0.5,0.1,nan,0.1\n").find("c.csv:4: non-finite"), std::string::npos);
  EXPECT_NE(error_of("d.csv", head + "0.0,0.1,1.0,0.1\n").find("d.csv:4: t_s not increasing"), std::string::npos);
  EXPECT_NE(error_of("e.csv", head + "0.5,1.5,1.0,0.1\n").find("e.csv:4: duty outside 0..1"), std::string::npos);
  EXPECT_NE(error_of("f.csv", head + "0.5,0.1,1.0\n").find("f.csv:4: field count"), std::string::npos);
  EXPECT_NE(error_of("g.csv", "").find("g.csv:1: empty file"), std::string::npos);
  EXPECT_NE(error_of("h.csv", "# a=b\nt_s,duty,v_V,i_A\n").find("h.csv:2: header with no rows"), std::string::npos);
  EXPECT_NE(error_of("i.csv", "# just a comment\n").find("i.csv:1: malformed metadata"), std::string::npos);
}

TEST(BenchLog, MissingFileIsAnError) {
  try {
    hpddo_host::read_bench_log("/nonexistent/x.csv");
    ADD_FAILURE() << "no error";
  } catch (const hpddo_host::LogError& e) {
    EXPECT_EQ(e.line(), 0u);
    EXPECT_STREQ(e.what(), "/nonexistent/x.csv: cannot open");
  }
}

TEST(BenchLog, HoldsATemperatureReadingAsTheBoardDoes) {
  // a reading once a second at 4 Hz, one outside the sensor's range, and a gap longer than the board holds
  const std::string text =
      "# condition=x\nt_s,duty,v_V,i_A,temp_C\n"
      "0.00,0.1,1,0.1,\n0.25,0.1,1,0.1,30\n0.50,0.1,1,0.1,\n1.25,0.1,1,0.1,200\n2.75,0.1,1,0.1,\n"
      "2.80,0.1,1,0.1,\n3.00,0.1,1,0.1,31\n";
  const hpddo_host::BenchLog log = hpddo_host::read_bench_log(write_tmp("held.csv", text));
  const std::vector<double> t = hpddo_host::held_temperatures(log, -55.0, 125.0);
  ASSERT_EQ(t.size(), 7u);
  EXPECT_TRUE(std::isnan(t[0]));  // nothing read yet
  EXPECT_EQ(t[1], 30.0);
  EXPECT_EQ(t[2], 30.0);
  EXPECT_EQ(t[3], 30.0);          // outside the sensor's range: the last good reading, 1.0 s old
  EXPECT_EQ(t[4], 30.0);          // 2.5 s old: still held (hpddo::kTempMaxAge_ms)
  EXPECT_TRUE(std::isnan(t[5]));  // 2.55 s old: too old
  EXPECT_EQ(t[6], 31.0);
  EXPECT_TRUE(std::isnan(hpddo_host::read_bench_log(write_tmp("raw.csv", text)).temp_C[2]));  // the reader: as written
  const hpddo_host::BenchLog table = hpddo_host::read_bench_log(write_tmp("table.csv", "# kind=steady_state\n" + text));
  EXPECT_TRUE(std::isnan(hpddo_host::held_temperatures(table, -55.0, 125.0)[2]));  // a table's rows are points apart
}
