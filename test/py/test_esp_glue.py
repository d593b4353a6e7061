"""The ESP8266 sketch's glue (esp_infer.cpp) is compiled against the real core only in
ctest (firmware.esp.glue_compile_only, compile only) and linked only under PlatformIO, so
these checks read its source: every JSON it writes goes through ArduinoJson (infer_line.h's
LineWriter, whose lines the host tests compare byte for byte with
test/fixtures/telemetry_lines.txt) at infer_line.h's baud, every telemetry value reaches the
line, and PlatformIO's lib_deps names the ArduinoJson the tests build against."""
import hashlib
import re

from conftest import ROOT

GLUE = (ROOT / "esp_infer" / "esp_infer.cpp").read_text()
APP = (ROOT / "esp_infer" / "infer_app.h").read_text()
TELEMETRY = (ROOT / "esp_infer" / "infer_telemetry.h").read_text()
LINE = (ROOT / "esp_infer" / "infer_line.h").read_text()
INI = (ROOT / "platformio.ini").read_text()


def test_the_line_is_written_by_the_tested_writer_at_its_baud():
    assert "infer::App<infer::model::Net> g_app(" in GLUE and "g_app.link_byte(" in GLUE
    assert "Serial.begin(infer::kHostBaud)" in GLUE
    assert "line_.write(" in APP and "char line[kJsonMaxLine + 1]" in APP
    assert not (ROOT / "esp_infer" / "infer_json.h").exists(), "the hand-written writer is gone"
    baud = int(re.search(r"kHostBaud = (\d+);", LINE).group(1))
    esp = INI[INI.index("[env:esp8266]"):]
    assert f"monitor_speed = {baud}" in esp


def test_every_telemetry_field_reaches_the_line():
    struct = TELEMETRY[TELEMETRY.index("struct Telemetry"):TELEMETRY.index("};", TELEMETRY.index("struct Telemetry"))]
    fields = re.findall(r"^\s+[\w:]+\s+(\w+);", struct, re.M)
    body = LINE[LINE.index("size_t write(const Telemetry& t"):]
    for f in fields:
        assert f"t.{f}" in body, f"Telemetry::{f} is not written to the JSON line"


def test_platformio_names_the_arduinojson_the_tests_build_against():
    esp = INI[INI.index("[env:esp8266]"):]
    esp = esp[:esp.index("\n[", 1)] if "\n[" in esp[1:] else esp
    assert re.search(r"lib_deps\s*=\s*bblanchon/ArduinoJson\s*@\s*7\.2\.0", esp), esp
    native = INI[INI.index("[env:native]"):]
    assert re.search(r"lib_deps\s*=\s*bblanchon/ArduinoJson\s*@\s*7\.2\.0", native), native


def test_the_reference_lines_are_the_captured_ones():
    text = (ROOT / "test" / "fixtures" / "telemetry_lines.txt").read_text()
    want = re.search(r"^# body_sha256=([0-9a-f]{64})$", text, re.M).group(1)
    body = "".join(line + "\n" for line in text.splitlines() if not line.startswith("#"))
    assert hashlib.sha256(body.encode()).hexdigest() == want
    assert len(body.splitlines()) == 4078


def test_nothing_listens_on_wifi():
    """Uploads go over the serial line only: the sketch links no network library (the core
    then keeps the radio off at boot) and never asks for the radio at boot."""
    code = "\n".join(line for line in GLUE.splitlines() if not line.lstrip().startswith("//"))
    for lib in ("ESP8266WiFi", "ESP8266WebServer", "WiFiUdp", "ESP8266mDNS", "ArduinoOTA", "WiFiServer"):
        assert lib not in code, lib
    assert "enableWiFiAtBootTime" not in code
    for header in (ROOT / "esp_infer").glob("*.h"):
        assert "WiFi" not in header.read_text().replace("Wi-Fi", ""), header.name


def test_every_argument_a_command_reads_passes_the_parsers_filter():
    """infer_console.h's filter keeps only kCommandKeys: an argument infer_app.h reads but the
    filter drops would never arrive."""
    console = (ROOT / "esp_infer" / "infer_console.h").read_text()
    keys = set(re.findall(r'"(\w+)"', re.search(r"kCommandKeys\[\] = \{([^}]*)\}", console).group(1)))
    used = set(re.findall(r'args\["(\w+)"\]', APP))
    assert used and used <= keys, used - keys
