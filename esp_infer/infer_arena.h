// A fixed arena for ArduinoJson's documents on the ESP8266: no heap. ArduinoJson 7
// allocates its slot pools and strings through an Allocator; this one hands out blocks
// from a buffer it owns (N bytes, 8-aligned), gives the last block back when it is freed
// or shrunk, and starts again from the beginning once every block is freed (one
// document per line or command, destroyed before the next). A request that does not fit
// returns null: ArduinoJson then reports the document overflowed, and the caller says so.
#ifndef HPDDO_INFER_ARENA_H
#define HPDDO_INFER_ARENA_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <ArduinoJson.h>

namespace infer {

template <size_t N>
class ArenaAllocator : public ArduinoJson::Allocator {
 public:
  ArenaAllocator() : top_(0), live_(0), peak_(0) {}

  void* allocate(size_t size) override {
    const size_t need = kHeader + round_up(size);
    if (need < size || need > N - top_) return nullptr;
    Header h = {top_, top_ + need, size};
    memcpy(buf_ + top_, &h, sizeof h);
    void* p = buf_ + top_ + kHeader;
    top_ = h.end;
    if (top_ > peak_) peak_ = top_;
    ++live_;
    return p;
  }

  void deallocate(void* ptr) override {
    if (!ptr) return;
    const Header h = header(ptr);
    if (h.end == top_) top_ = h.start;  // the last block
    if (--live_ == 0) top_ = 0;
  }

  void* reallocate(void* ptr, size_t size) override {
    if (!ptr) return allocate(size);
    Header h = header(ptr);
    if (h.end == top_) {  // the last block: grows or shrinks in place
      const size_t need = kHeader + round_up(size);
      if (need < size || need > N - h.start) return nullptr;
      h.end = top_ = h.start + need;
      if (top_ > peak_) peak_ = top_;
    } else if (size > h.end - h.start - kHeader) {  // does not fit its room: moves
      void* q = allocate(size);
      if (!q) return nullptr;
      memcpy(q, ptr, h.size);
      deallocate(ptr);
      return q;
    }
    h.size = size;  // a block inside keeps its room
    memcpy(static_cast<uint8_t*>(ptr) - kHeader, &h, sizeof h);
    return ptr;
  }

  /// Most bytes in use at once since construction (headers and alignment included).
  size_t peak() const { return peak_; }
  /// Blocks handed out and not freed.
  size_t live() const { return live_; }
  static size_t capacity() { return N; }

 private:
  struct Header {
    size_t start;  ///< offset of the header in buf_
    size_t end;    ///< offset after the block's room
    size_t size;   ///< bytes asked for
  };
  static const size_t kAlign = 8;
  static const size_t kHeader = (sizeof(Header) + kAlign - 1) / kAlign * kAlign;
  static size_t round_up(size_t n) { return (n + kAlign - 1) / kAlign * kAlign; }
  Header header(void* ptr) const {
    Header h;
    memcpy(&h, static_cast<uint8_t*>(ptr) - kHeader, sizeof h);
    return h;
  }

  alignas(8) uint8_t buf_[N];
  size_t top_;
  size_t live_;
  size_t peak_;
};

}  // namespace infer

#endif  // HPDDO_INFER_ARENA_H
