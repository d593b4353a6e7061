// The ESP8266 inference board's logic (infer::App: link, observer, telemetry, commands,
// model upload) built for the host, with the compiled default model, ArduinoJson 7 and a
// folder as its LittleFS. What the sketch does with Serial, SoftwareSerial and LittleFS,
// this does with a pseudo-terminal (or stdin/stdout), a bench log and a folder, so the
// host tools (`hpddo upload`) can be tested against it without a board.
//
//   esp_host --store DIR [--fs-unmountable] [--pty] [--baud N] [--frames LOG.csv [--rate HZ] [--on-signal]]
//            [--golden-csv FILE]
//
//   --store DIR       the board's files (model.json, model.new); created if missing
//   --fs-unmountable  the store plays a LittleFS that does not mount: its files are kept and
//                     none is read or written, until the format command erases them
//   --pty             serve the host side on a new pseudo-terminal: prints "pty PATH" on
//                     stdout, then runs until killed (SIGTERM, SIGINT)
//   (no --pty)        host bytes from stdin, lines to stdout, until stdin ends
//   --baud N          the serial line's speed emulated: each byte read or written takes
//                     10 / N s (8N1), as on the board's UART (default: as fast as the pipe)
//   --frames LOG.csv  the UNO's frames made from the rows of a bench log (t_s, v_V, i_A,
//                     and temp_C, rpm_ref, seq where present), one every 1/HZ s (default
//                     the log's own spacing), as the link would deliver them
//   --on-signal       the frames wait for SIGUSR1 (the UNO starting a recording) and each
//                     SIGUSR1 plays them again from the first, the board running on (its
//                     model in force, uploaded or not, kept): a bench run played twice
//   --golden-csv F    after start-up (the stored model in force, if any), steps the model
//                     in force over the rows of a golden CSV (hpddo.model.export.golden_csv) and
//                     compares: rpm, rpm_m2, residual_rpm, confidence and status bit for
//                     bit; prints the count of rows that differ; exit 0 only when none
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "bench_log.h"
#include "infer_app.h"
#include "model_default.h"

namespace {

typedef infer::App<hpddo_model_default::Net> App;

/// infer::Store over a folder: "/model.json" is DIR/model.json.
class DirStore final : public infer::Store {
 public:
  DirStore(const std::string& dir, bool unmountable) : dir_(dir), unmountable_(unmountable) {}
  bool mount() override { return mounted_ = !unmountable_; }
  bool format() override {
    std::remove(full(infer::kModelPath).c_str());
    std::remove(full(infer::kModelNewPath).c_str());
    unmountable_ = false;
    return mounted_ = true;
  }
  bool begin_write(const char* path) override {
    end_write();
    if (!mounted_) return false;
    w_ = std::fopen(full(path).c_str(), "wb");
    return w_ != nullptr;
  }
  bool append(const uint8_t* data, size_t n) override { return w_ && std::fwrite(data, 1, n, w_) == n; }
  bool end_write() override {
    if (!w_) return false;
    const bool ok = std::fflush(w_) == 0 && fsync(fileno(w_)) == 0;
    std::fclose(w_);
    w_ = nullptr;
    return ok;
  }
  bool open_read(const char* path) override {
    close_read();
    if (!mounted_) return false;
    r_ = std::fopen(full(path).c_str(), "rb");
    return r_ != nullptr;
  }
  int read() override { return r_ ? std::fgetc(r_) : -1; }
  size_t read_bytes(char* out, size_t n) override { return r_ ? std::fread(out, 1, n, r_) : 0; }
  void close_read() override {
    if (r_) std::fclose(r_);
    r_ = nullptr;
  }
  bool rename(const char* from, const char* to) override {
    return mounted_ && std::rename(full(from).c_str(), full(to).c_str()) == 0;
  }
  bool remove(const char* path) override { return mounted_ && std::remove(full(path).c_str()) == 0; }
  bool exists(const char* path) override { return mounted_ && access(full(path).c_str(), F_OK) == 0; }

 private:
  std::string full(const char* path) const { return dir_ + path; }
  std::string dir_;
  bool unmountable_;
  bool mounted_ = false;
  FILE* w_ = nullptr;
  FILE* r_ = nullptr;
};

/// The emulated line speed, baud (0: none).
double g_baud = 0;

/// Waits the time n bytes take on the emulated line.
void line_time(size_t n) {
  if (g_baud > 0) usleep(static_cast<useconds_t>(static_cast<double>(n) * 10.0 / g_baud * 1e6));
}

/// Lines to a file descriptor, whole (the pty or stdout), at the emulated line speed.
class FdSink final : public infer::LineSink {
 public:
  explicit FdSink(int fd) : fd_(fd) {}
  void line(const char* text, size_t n) override {
    line_time(n);
    while (n) {
      const ssize_t k = ::write(fd_, text, n);
      if (k < 0 && errno == EINTR) continue;
      if (k < 0 && errno == EAGAIN) {
        pollfd p = {fd_, POLLOUT, 0};
        ::poll(&p, 1, 100);
        continue;
      }
      if (k <= 0) return;  // the other side is gone: the board's UART would drop it too
      text += k;
      n -= static_cast<size_t>(k);
    }
  }

 private:
  int fd_;
};

volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
volatile sig_atomic_t g_play = 0;  // SIGUSR1s received (--on-signal)
void on_play(int) { g_play = g_play + 1; }

uint32_t millis_now() {
  using namespace std::chrono;
  static const steady_clock::time_point t0 = steady_clock::now();
  return static_cast<uint32_t>(duration_cast<milliseconds>(steady_clock::now() - t0).count());
}
uint32_t micros_now() {
  using namespace std::chrono;
  static const steady_clock::time_point t0 = steady_clock::now();
  return static_cast<uint32_t>(duration_cast<microseconds>(steady_clock::now() - t0).count());
}

/// The frames of a bench log's rows, with the time each is due (s from the start).
struct TimedFrame {
  double t_s;
  uint8_t bytes[hpddo::kFrameSize];
};

std::vector<TimedFrame> frames_of_log(const std::string& path, double rate_hz) {
  // the temperatures as the acquisition board sends them: its last reading repeated until it is too old
  const hpddo_host::BenchLog log = hpddo_host::as_observed(hpddo_host::read_bench_log(path),
                                                           hpddo_model_default::kModel.limits.temp_min_C,
                                                           hpddo_model_default::kModel.limits.temp_max_C);
  std::vector<TimedFrame> out;
  const size_t n = log.size();
  for (size_t k = 0; k < n; ++k) {
    hpddo::SampleFrame f;
    std::memset(&f, 0, sizeof f);
    f.seq = static_cast<uint16_t>(log.seq[k]);
    f.duty = static_cast<uint8_t>(hpddo::saturate_round(static_cast<float>(log.duty[k]) * 255.0f, 0, 255));
    f.v_mV = static_cast<uint16_t>(hpddo::saturate_round(static_cast<float>(log.v_V[k]) * 1000.0f, 0, 65535));
    f.i_mA = static_cast<int16_t>(hpddo::saturate_round(static_cast<float>(log.i_A[k]) * 1000.0f, -32768, 32767));
    if (!std::isnan(log.temp_C[k])) {
      f.flags |= hpddo::kFrameFlagTemp;
      f.temp_c16 = static_cast<int16_t>(hpddo::saturate_round(static_cast<float>(log.temp_C[k]) * 16.0f, -32768, 32767));
    }
    if (!std::isnan(log.rpm_ref[k])) {
      f.flags |= hpddo::kFrameFlagRpm;
      f.rpm_x10 = static_cast<int16_t>(hpddo::saturate_round(static_cast<float>(log.rpm_ref[k]) * 10.0f, -32768, 32767));
    }
    const double dt = k + 1 < n ? log.t_s[k + 1] - log.t_s[k] : (k ? log.t_s[k] - log.t_s[k - 1] : 0.5);
    f.period_us = static_cast<uint32_t>(std::lround((rate_hz > 0 ? 1.0 / rate_hz : dt) * 1e6));
    TimedFrame tf;
    tf.t_s = rate_hz > 0 ? static_cast<double>(k) / rate_hz : log.t_s[k] - log.t_s[0];
    hpddo::encode_frame(f, tf.bytes);
    out.push_back(tf);
  }
  return out;
}

/// Steps the model in force over a golden CSV's rows; the rows that differ bitwise.
int golden_check(App& app, const std::string& path) {
  std::ifstream in(path);
  std::string header;
  if (!in || !std::getline(in, header)) {
    std::fprintf(stderr, "esp_host: cannot read %s\n", path.c_str());
    return -1;
  }
  std::vector<std::string> cols;
  std::stringstream hs(header);
  for (std::string c; std::getline(hs, c, ',');) cols.push_back(c);
  auto col = [&cols](const char* name) {
    for (size_t k = 0; k < cols.size(); ++k)
      if (cols[k] == name) return static_cast<int>(k);
    return -1;
  };
  const int cv = col("v_V"), ci = col("i_A"), ct = col("temp_C"), cd = col("dt_s"), cs = col("seq"),
            ch = col("has_seq"), crpm = col("rpm"), cm2 = col("rpm_m2"), cres = col("residual_rpm"),
            cconf = col("confidence"), cst = col("status");
  if (cv < 0 || crpm < 0 || cst < 0 || cconf < 0) {
    std::fprintf(stderr, "esp_host: %s is not a golden CSV\n", path.c_str());
    return -1;
  }
  hpddo::Observer<hpddo_model_default::Net> obs(app.model(), app.dynamics());
  int rows = 0, differ = 0;
  for (std::string line; std::getline(in, line);) {
    std::vector<float> v;
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) v.push_back(std::strtof(c.c_str(), nullptr));
    hpddo::Sample s;
    s.v_V = v[cv];
    s.i_A = v[ci];
    s.temp_C = v[ct];
    s.dt_s = v[cd];
    s.seq = static_cast<uint16_t>(v[cs]);
    s.has_seq = v[ch] != 0.0f;
    const hpddo::Estimate e = obs.step(s);
    auto same = [](float got, float want) {
      return (std::isnan(got) && std::isnan(want)) || std::memcmp(&got, &want, sizeof got) == 0;
    };
    const bool ok = same(e.rpm, v[crpm]) && same(e.rpm_m2, v[cm2]) && same(e.residual_rpm, v[cres]) &&
                    same(e.confidence, v[cconf]) && static_cast<float>(e.status) == v[cst];
    if (!ok && ++differ <= 5)
      std::printf("row %d differs: rpm %.9g (golden %.9g), status %d (golden %g)\n", rows, static_cast<double>(e.rpm),
                  static_cast<double>(v[crpm]), static_cast<int>(e.status), static_cast<double>(v[cst]));
    ++rows;
  }
  std::printf("golden check: model %s (crc 0x%08x), %d rows, %d differ bitwise\n", app.uploaded() ? "uploaded" : "compiled",
              app.model_crc(), rows, differ);
  return rows > 0 ? differ : -1;
}

}  // namespace

int main(int argc, char** argv) {
  std::string store_dir, frames_path, golden_path;
  bool use_pty = false, on_play_signal = false, unmountable = false;
  double rate_hz = 0;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--store" && k + 1 < argc) {
      store_dir = argv[++k];
    } else if (a == "--fs-unmountable") {
      unmountable = true;
    } else if (a == "--pty") {
      use_pty = true;
    } else if (a == "--frames" && k + 1 < argc) {
      frames_path = argv[++k];
    } else if (a == "--baud" && k + 1 < argc) {
      g_baud = std::atof(argv[++k]);
    } else if (a == "--rate" && k + 1 < argc) {
      rate_hz = std::atof(argv[++k]);
    } else if (a == "--on-signal") {
      on_play_signal = true;
    } else if (a == "--golden-csv" && k + 1 < argc) {
      golden_path = argv[++k];
    } else {
      std::fprintf(stderr,
                   "usage: esp_host --store DIR [--fs-unmountable] [--pty] [--baud N] [--frames LOG.csv [--rate HZ] [--on-signal]] "
                   "[--golden-csv FILE]\n");
      return 2;
    }
  }
  if (store_dir.empty()) {
    std::fprintf(stderr, "esp_host: --store DIR is required\n");
    return 2;
  }
  mkdir(store_dir.c_str(), 0777);
  static DirStore store(store_dir, unmountable);
  static App app(hpddo_model_default::kModel, hpddo_model_default::kChecksum, store);

  if (!golden_path.empty()) {
    FdSink err(2);
    app.begin(err);
    const int differ = golden_check(app, golden_path);
    return differ == 0 ? 0 : 1;
  }

  std::vector<TimedFrame> frames;
  if (!frames_path.empty()) {
    try {
      frames = frames_of_log(frames_path, rate_hz);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "esp_host: %s\n", e.what());
      return 1;
    }
  }

  int in_fd = 0, out_fd = 1, slave = -1;
  if (use_pty) {
    const int master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0) {
      std::perror("esp_host: pty");
      return 1;
    }
    const char* name = ptsname(master);
    slave = open(name, O_RDWR | O_NOCTTY);  // kept open: the pty outlives each client
    termios t;
    tcgetattr(slave, &t);
    cfmakeraw(&t);
    tcsetattr(slave, TCSANOW, &t);
    fcntl(master, F_SETFL, O_NONBLOCK);
    in_fd = out_fd = master;
    std::printf("pty %s\n", name);
    std::fflush(stdout);
  }
  signal(SIGTERM, on_signal);
  signal(SIGINT, on_signal);
  signal(SIGUSR1, on_play);
  FdSink out(out_fd);
  app.begin(out);
  uint32_t start_ms = millis_now();
  size_t next_frame = on_play_signal ? frames.size() : 0;  // with --on-signal: none until SIGUSR1
  sig_atomic_t played = 0;
  uint8_t buf[512];
  while (!g_stop) {
    if (on_play_signal && g_play != played) {  // (again) from the first frame, from now
      played = g_play;
      start_ms = millis_now();
      next_frame = 0;
    }
    // Frames due by now, as the link delivers them.
    const double now_s = (millis_now() - start_ms) / 1000.0;
    while (next_frame < frames.size() && frames[next_frame].t_s <= now_s) {
      for (uint8_t b : frames[next_frame].bytes) app.link_byte(b, millis_now(), micros_now, out);
      ++next_frame;
    }
    pollfd p = {in_fd, POLLIN, 0};
    const int wait_ms = next_frame < frames.size()
                            ? static_cast<int>(std::max(0.0, (frames[next_frame].t_s - now_s) * 1000.0))
                            : 50;
    const int r = ::poll(&p, 1, std::min(wait_ms, 50));
    if (r > 0 && (p.revents & (POLLIN | POLLHUP | POLLERR))) {
      const ssize_t n = ::read(in_fd, buf, g_baud > 0 ? 64 : sizeof buf);
      if (n > 0) {
        line_time(static_cast<size_t>(n));
        for (ssize_t k = 0; k < n; ++k) app.host_byte(buf[k], millis_now(), out);
      } else if (n == 0 && !use_pty) {
        break;  // stdin ended
      } else if (n < 0 && errno != EAGAIN && errno != EINTR && errno != EIO) {
        break;
      } else if (use_pty && (p.revents & POLLHUP)) {
        usleep(10000);  // no client on the pty right now
      }
    }
    app.poll(millis_now(), out);
  }
  if (slave >= 0) close(slave);
  return 0;
}
