// infer::Store in memory, for the host tests and fuzzers of the inference board: files
// are strings; a fault can be injected on the n-th append (fail_append_at), on rename, or on
// the mount (mount_fails: a damaged file system, which only format() makes usable, emptied).
// As LittleFS, every file call fails until mount() or format() succeeded.
#ifndef HPDDO_TEST_MEM_STORE_H
#define HPDDO_TEST_MEM_STORE_H

#include <map>
#include <string>

#include "infer_upload.h"

class MemStore final : public infer::Store {
 public:
  std::map<std::string, std::string> files;
  long fail_append_at = -1;  ///< the append (counted from 0, see appends()) that fails; -1: none
  bool fail_rename = false;
  bool mount_fails = false;
  bool mounted = false;
  int formats = 0;  ///< format() calls

  bool mount() override { return mounted = !mount_fails; }
  bool format() override {
    ++formats;
    files.clear();
    mount_fails = false;
    return mounted = true;
  }
  bool begin_write(const char* path) override {
    if (!mounted) return false;
    writing_ = path;
    files[writing_].clear();
    return true;
  }
  bool append(const uint8_t* data, size_t n) override {
    if (appends_++ == fail_append_at || writing_.empty()) return false;
    files[writing_].append(reinterpret_cast<const char*>(data), n);
    return true;
  }
  bool end_write() override {
    writing_.clear();
    return true;
  }
  bool open_read(const char* path) override {
    if (!mounted) return false;
    auto it = files.find(path);
    if (it == files.end()) return false;
    reading_ = it->second;
    pos_ = 0;
    return true;
  }
  int read() override { return pos_ < reading_.size() ? static_cast<unsigned char>(reading_[pos_++]) : -1; }
  size_t read_bytes(char* out, size_t n) override {
    size_t k = 0;
    while (k < n && pos_ < reading_.size()) out[k++] = reading_[pos_++];
    return k;
  }
  void close_read() override { reading_.clear(); }
  bool rename(const char* from, const char* to) override {
    auto it = files.find(from);
    if (!mounted || fail_rename || it == files.end()) return false;
    files[to] = it->second;
    files.erase(from);
    return true;
  }
  bool remove(const char* path) override { return mounted && files.erase(path) > 0; }
  bool exists(const char* path) override { return mounted && files.count(path) > 0; }
  long appends() const { return appends_; }

 private:
  std::string writing_;
  std::string reading_;
  size_t pos_ = 0;
  long appends_ = 0;
};

#endif  // HPDDO_TEST_MEM_STORE_H
