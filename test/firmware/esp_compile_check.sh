#!/usr/bin/env bash
# COMPILE ONLY (-c, no link, nothing runs): every translation unit of the ESP8266 sketch
# (esp_infer/*.cpp, the Arduino glue included) against the real ESP8266 Arduino core
# (esp8266/Arduino 3.1.2, NodeMCU 1.0 at 80 MHz: platform.txt's flags) and its libraries
# (SoftwareSerial, LittleFS) and ArduinoJson, from ../shared/vendor. The compiler is Debian's
# xtensa-lx106-elf-g++ (gcc 12) with the C++ headers of libstdc++-arm-none-eabi-dev and the
# vendor's newlib shims, not the users' toolchain (gcc 10.3 + newlib): this proves the glue
# against the core's APIs; the link and the board are PlatformIO's (`pio run -e esp8266`).
# usage: esp_compile_check.sh ROOT VENDOR OUT [model defines as NAME=VALUE...]
set -euo pipefail
root=$1 vendor=$2 out=$3
shift 3
E=$vendor/esp8266-arduino
cxx_inc=$(ls -d /usr/include/newlib/c++/*/ 2>/dev/null | sort -V | tail -1)
if [[ -z $cxx_inc ]]; then
  echo "no C++ headers for the lx106 build (/usr/include/newlib/c++): install libstdc++-arm-none-eabi-dev (scripts/bootstrap.sh)" >&2
  exit 1
fi
mkdir -p "$out/core"
: > "$out/core/build.opt"
defs=()
for d in "$@"; do defs+=("-D$d"); done
flags=(-D__ets__ -DICACHE_FLASH -U__STRICT_ANSI__ -D_GNU_SOURCE -DESP8266 -Os "@$out/core/build.opt"
  -I"$E/tools/sdk/include" -I"$E/tools/sdk/lwip2/include" -I"$out/core"
  -c -g -free -fipa-pta -Werror=return-type -mlongcalls -mtext-section-literals -fno-rtti -falign-functions=4
  -std=gnu++17 -ffunction-sections -fdata-sections -fno-exceptions
  -DMMU_IRAM_SIZE=0x8000 -DMMU_ICACHE_SIZE=0x8000 -DFP_IN_IROM -DNONOSDK22x_190703=1 -DF_CPU=80000000L
  -DLWIP_OPEN_SRC -DARDUINO=10819 -DARDUINO_ESP8266_NODEMCU_ESP12E -DARDUINO_ARCH_ESP8266
  '-DARDUINO_BOARD="ESP8266_NODEMCU_ESP12E"' '-DARDUINO_BOARD_ID="nodemcuv2"' -DFLASHMODE_DIO
  -I"$E/cores/esp8266" -I"$E/variants/nodemcu" -I"$E/libraries/SoftwareSerial/src" -I"$E/libraries/LittleFS/src"
  -I"$E/libraries/LittleFS/lib/littlefs" -I"$vendor/ArduinoJson-7.2.0/src"
  -I"$root/lib/hpddo_core/src" -I"$root/esp_infer" -I"$root/models/default" "${defs[@]}"
  -isystem "$cxx_inc" -isystem "$cxx_inc/arm-none-eabi" -isystem "$vendor/newlib-xtensa-shims"
  -include xtensa/config/core-isa.h -include string.h -include sys/string.h -include stdio.h -include sys/stdio.h)
echo "compile only (-c, no link) against esp8266/Arduino in $E, with $(xtensa-lx106-elf-g++ --version | head -1):"
for src in "$root"/esp_infer/*.cpp; do
  obj=$out/$(basename "$src").o
  xtensa-lx106-elf-g++ "${flags[@]}" "$src" -o "$obj"
  echo "  $(basename "$src"): compiled (object only, not linked)"
done
