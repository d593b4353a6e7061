"""The ESP8266 sketch's glue (esp_infer.cpp) is compiled only under PlatformIO (the ESP8266
Arduino core comes from its registry), so these checks read its source: the line is
written by infer_json.h's format_json (fixed decimals, a bounded length: its host tests
prove the budget) at infer_json.h's baud, and every telemetry value reaches the line."""
import re

from conftest import ROOT

GLUE = (ROOT / "esp_infer" / "esp_infer.cpp").read_text()
TELEMETRY = (ROOT / "esp_infer" / "infer_telemetry.h").read_text()
JSON = (ROOT / "esp_infer" / "infer_json.h").read_text()


def test_the_line_is_formatted_by_the_tested_writer_at_its_baud():
    assert "infer::format_json(" in GLUE and "Serial.begin(infer::kHostBaud)" in GLUE
    assert "char line[infer::kJsonMaxLine + 1]" in GLUE
    assert "#include <ArduinoJson.h>" not in GLUE and "serializeJson" not in GLUE
    baud = int(re.search(r"kHostBaud = (\d+);", JSON).group(1))
    ini = (ROOT / "platformio.ini").read_text()
    esp = ini[ini.index("[env:esp8266]"):]
    assert f"monitor_speed = {baud}" in esp


def test_every_telemetry_field_reaches_the_line():
    struct = TELEMETRY[TELEMETRY.index("struct Telemetry"):TELEMETRY.index("};", TELEMETRY.index("struct Telemetry"))]
    fields = re.findall(r"^\s+[\w:]+\s+(\w+);", struct, re.M)
    body = JSON[JSON.index("inline size_t format_json"):]
    for f in fields:
        assert f"t.{f}" in body, f"Telemetry::{f} is not written to the JSON line"
