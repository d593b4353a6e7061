// Lines to the host's UART without waiting for it. The ESP8266 core's Serial.write() spins
// while the UART's 128-byte transmit FIFO is full: a 110-byte telemetry line at 460800 baud
// held the loop about 2.4 ms, a quarter of the CPU at 100 lines/s, and link bytes waited
// meanwhile. Here a line goes whole into a fixed ring (line(), no heap) and pump(), called from
// loop(), hands the UART only what its FIFO has room for (availableForWrite()), so no write
// ever waits. A line that does not fit the ring is dropped whole, never cut, and counted
// (lines_dropped(): the status reply's "tx_dropped"); once the ring has room again, one line
// {"event":"tx_dropped","lines":N} (N: the total so far) says so in the stream itself.
// Tested on the host with a fake port whose FIFO is small (test/firmware/test_infer.cpp, InferTx.*).
#ifndef HPDDO_INFER_TX_H
#define HPDDO_INFER_TX_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "infer_console.h"

namespace infer {

/// The ring's size, bytes: four widest replies (kReplyMax), or about 44 ms of the line at
/// 460800 baud, longer than the board's longest pause (a model's parse, 8.5 ms).
static const size_t kTxRing = 2048;

template <size_t N>
class TxQueue final : public LineSink {
 public:
  TxQueue() : head_(0), size_(0), peak_(0), dropped_(0), reported_(0) {}

  /// Queues one whole line, or drops it (counted) when the ring has no room for all of it.
  void line(const char* text, size_t n) override {
    if (n > N - size_) {
      ++dropped_;
      return;
    }
    put(text, n);
  }

  /// Hands the port as many queued bytes as it takes without waiting; Port has
  /// int availableForWrite() and size_t write(const uint8_t*, size_t) (HardwareSerial).
  template <class Port>
  void pump(Port& port) {
    note_drops();
    while (size_ > 0) {
      const int room = port.availableForWrite();
      if (room <= 0) return;
      size_t n = size_ < static_cast<size_t>(room) ? size_ : static_cast<size_t>(room);
      const size_t tail = (head_ + N - size_) % N;  // the oldest byte
      if (n > N - tail) n = N - tail;                  // up to the ring's end this time
      const size_t sent = port.write(buf_ + tail, n);
      size_ -= sent < n ? sent : n;
      if (sent < n) return;
    }
  }

  uint32_t lines_dropped() const override { return dropped_; }
  size_t queued() const { return size_; }  ///< bytes waiting
  size_t peak() const { return peak_; }    ///< most bytes ever waiting

 private:
  void put(const char* text, size_t n) {
    for (size_t k = 0; k < n; ++k) {
      buf_[head_] = static_cast<uint8_t>(text[k]);
      head_ = (head_ + 1) % N;
    }
    size_ += n;
    if (size_ > peak_) peak_ = size_;
  }

  /// After drops, one line with their total once it fits (itself never counted as dropped).
  void note_drops() {
    if (dropped_ == reported_) return;
    char text[48];
    const int n = snprintf(text, sizeof text, "{\"event\":\"tx_dropped\",\"lines\":%lu}\n",
                           static_cast<unsigned long>(dropped_));
    if (n <= 0 || static_cast<size_t>(n) >= sizeof text || static_cast<size_t>(n) > N - size_) return;
    put(text, static_cast<size_t>(n));
    reported_ = dropped_;
  }

  uint8_t buf_[N];
  size_t head_;  ///< where the next byte goes
  size_t size_;  ///< bytes queued, ending just before head_
  size_t peak_;
  uint32_t dropped_;
  uint32_t reported_;  ///< dropped_ when the last tx_dropped line was queued
};

}  // namespace infer

#endif  // HPDDO_INFER_TX_H
