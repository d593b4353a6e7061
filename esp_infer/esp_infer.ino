// hpddo inference board (ESP8266, NodeMCU). The sketch lives in esp_infer.cpp,
// next to this file, so that the Arduino IDE and PlatformIO build the same
// source; see docs/firmware.md.
