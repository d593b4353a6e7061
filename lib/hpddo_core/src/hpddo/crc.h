// Checksums: CRC-16/CCITT-FALSE for link frames, CRC-32 (IEEE 802.3) for
// model headers. Bitwise, table-free: a few hundred bytes of code on AVR.
#ifndef HPDDO_CRC_H
#define HPDDO_CRC_H

#include <stddef.h>
#include <stdint.h>

namespace hpddo {

/// Feeds one byte into a CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF).
inline uint16_t crc16_update(uint16_t crc, uint8_t byte) {
  crc = static_cast<uint16_t>(crc ^ static_cast<uint16_t>(byte << 8));
  for (uint8_t bit = 0; bit < 8; ++bit) {
    crc = (crc & 0x8000u) ? static_cast<uint16_t>((crc << 1) ^ 0x1021u)
                          : static_cast<uint16_t>(crc << 1);
  }
  return crc;
}

/// CRC-16/CCITT-FALSE of a buffer ("123456789" gives 0x29B1).
inline uint16_t crc16(const uint8_t* data, size_t len) {
  uint16_t crc = 0xFFFFu;
  for (size_t k = 0; k < len; ++k) crc = crc16_update(crc, data[k]);
  return crc;
}

/// Feeds bytes into a running CRC-32 (IEEE, reflected); start with 0xFFFFFFFF
/// and invert at the end, or use crc32().
inline uint32_t crc32_update(uint32_t crc, const uint8_t* data, size_t len) {
  for (size_t k = 0; k < len; ++k) {
    crc ^= data[k];
    for (uint8_t bit = 0; bit < 8; ++bit) {
      crc = (crc & 1u) ? (crc >> 1) ^ 0xEDB88320u : crc >> 1;
    }
  }
  return crc;
}

/// CRC-32 (IEEE) of a buffer ("123456789" gives 0xCBF43926).
inline uint32_t crc32(const uint8_t* data, size_t len) {
  return crc32_update(0xFFFFFFFFu, data, len) ^ 0xFFFFFFFFu;
}

}  // namespace hpddo

#endif  // HPDDO_CRC_H
