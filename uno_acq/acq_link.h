// Transmit side of the link to the ESP8266: a byte queue filled by the main
// loop and a bit shifter that the Timer2 compare interrupt advances once per
// bit. The shifter only decides the level of the next bit; the timer's
// compare-match output (OC2A) puts it on the pin, so the bit edges keep
// hardware timing whatever interrupt latency the other interrupts cause.
//
// 8N1, LSB first, idle high. At 38462 baud (Timer2 /8, 52 ticks a bit) a
// 21-byte frame takes 5.5 ms: the link carries up to 180 samples/s. The
// interrupt has a whole bit (26 us) to program the next level, which covers
// the longest chain of other interrupts ahead of it.
#ifndef HPDDO_ACQ_LINK_H
#define HPDDO_ACQ_LINK_H

#include <stdint.h>

namespace acq {

/// Single-producer single-consumer byte ring; N a power of two, at most 128.
/// The producer (main loop) writes head_, the consumer (interrupt) writes tail_;
/// single-byte indices are atomic on the AVR.
template <uint8_t N>
class TxQueue {
  static_assert(N && (N & (N - 1)) == 0 && N <= 128, "N must be a power of two <= 128");

 public:
  constexpr TxQueue() : buf_(), head_(0), tail_(0), dropped_(0) {}

  /// Queues all n bytes, or none (false) when they do not fit.
  bool push(const uint8_t* data, uint8_t n) {
    const uint8_t used = static_cast<uint8_t>(head_ - tail_);
    if (static_cast<uint16_t>(used) + n > N) {
      ++dropped_;
      return false;
    }
    uint8_t h = head_;
    for (uint8_t k = 0; k < n; ++k) buf_[static_cast<uint8_t>(h++) & (N - 1)] = data[k];
    head_ = h;
    return true;
  }
  bool empty() const { return head_ == tail_; }
  /// Takes the next byte; false when empty.
  bool pop(uint8_t* out) {
    if (head_ == tail_) return false;
    *out = buf_[tail_ & (N - 1)];
    tail_ = static_cast<uint8_t>(tail_ + 1);
    return true;
  }
  uint16_t dropped() const { return dropped_; }  ///< pushes refused for lack of room

 private:
  uint8_t buf_[N];
  volatile uint8_t head_;
  volatile uint8_t tail_;
  uint16_t dropped_;
};

/// Decides the line level of each bit slot of an 8N1 stream.
class BitShifter {
 public:
  constexpr BitShifter() : bits_(0), left_(0) {}

  /// Level (0 or 1) of the next bit slot, taking a byte from q when the
  /// previous one is done; 1 (idle) when there is nothing to send.
  template <class Queue>
  uint8_t next(Queue& q) {
    if (left_ == 0) {
      uint8_t b;
      if (!q.pop(&b)) return 1;
      bits_ = static_cast<uint16_t>((static_cast<uint16_t>(b) << 1) | 0x200u);  // start 0, data, stop 1
      left_ = 10;
    }
    const uint8_t level = static_cast<uint8_t>(bits_ & 1u);
    bits_ = static_cast<uint16_t>(bits_ >> 1);
    --left_;
    return level;
  }
  /// True between the start bit and the stop bit of a byte.
  bool busy() const { return left_ != 0; }

 private:
  uint16_t bits_;
  uint8_t left_;
};

}  // namespace acq

#endif  // HPDDO_ACQ_LINK_H
