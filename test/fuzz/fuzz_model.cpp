// libFuzzer target: any bytes as a model document (infer_upload.h's read_model, the real
// ArduinoJson, the firmware's network shape). A document read as a model must carry the
// checksum of what was read and only finite floats; a refused one names a reason.
#include <stddef.h>
#include <stdint.h>

#include "infer_console.h"
#include "infer_model.h"
#include "infer_upload.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  typedef infer::model::Net Net;
  static infer::ModelSlot<Net> slot;
  static infer::ArenaAllocator<infer::kUploadArena> arena;
  infer::RangeReader in(reinterpret_cast<const char*>(data), size);
  infer::ModelError why = {nullptr, nullptr};
  if (infer::read_model<Net>(in, &arena, slot, &why)) {
    if (hpddo::model_checksum(slot.model) != slot.crc) __builtin_trap();
    for (uint16_t k = 0; k < Net::kW0Count; ++k)
      if (!hpddo::is_finite(slot.w0[k])) __builtin_trap();
  } else if (!why.code || !why.detail) {
    __builtin_trap();
  }
  if (arena.live() != 0) __builtin_trap();  // every block given back: the next upload starts empty
  return 0;
}
