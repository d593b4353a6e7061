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


#: what each pinned release of PlatformIO's espressif8266 platform asks for, from its platform.json
#: ("framework-arduinoespressif8266": "~3.30102.0" in v4.2.0 and v4.2.1)
PLATFORM_FRAMEWORK = {"4.2.0": "3.30102.0", "4.2.1": "3.30102.0"}


def _vendor():
    """../shared/vendor's README, or a skip saying why (a failure with CI=true, as ctest's)."""
    import os

    import pytest

    readme = ROOT.parent / "shared" / "vendor" / "README.md"
    if not readme.is_file():
        why = f"the vendored libraries' README is not at {readme}"
        if os.environ.get("CI") == "true":
            pytest.fail(why)
        pytest.skip(why)
    return readme.parent, readme.read_text()


def _ini_value(section: str, key: str) -> str:
    body = INI[INI.index(f"[{section}]"):]
    body = body[:body.index("\n[", 1)] if "\n[" in body[1:] else body
    m = re.search(rf"^{key}\s*=\s*(.+)$", body, re.M)
    assert m, f"{key} missing in [{section}]"
    return m.group(1).strip()


def test_platformio_pins_the_vendored_core_and_arduinojson():
    """Users build against the ESP8266 core and the ArduinoJson the compile check and the host
    tests use: the platform and its framework package pinned exactly, the framework's version
    the vendored core's release, ArduinoJson's the vendored headers' version macro."""
    vendor, readme = _vendor()
    core = re.search(r"^\| `esp8266-arduino/` \| esp8266/Arduino \| (\d+)\.(\d+)\.(\d+)[-\w]* ", readme, re.M)
    assert core, "the core's version row in the vendor README"
    x, y, z = map(int, core.groups())
    platform = _ini_value("env:esp8266", "platform")
    m = re.fullmatch(r"platformio/espressif8266@(\d+\.\d+\.\d+)", platform)
    assert m, f"platform not pinned to one release: {platform!r}"
    assert m.group(1) in PLATFORM_FRAMEWORK, f"espressif8266 {m.group(1)}: which core it bundles is not known here"
    framework = _ini_value("env:esp8266", "platform_packages")
    f = re.fullmatch(r"platformio/framework-arduinoespressif8266@(\d+)\.(\d+)\.(\d+)", framework)
    assert f, f"the framework package not pinned exactly: {framework!r}"
    assert int(f.group(2)) == x * 10000 + y * 100 + z, (framework, core.group(0))
    assert ".".join(f.groups()) == PLATFORM_FRAMEWORK[m.group(1)], "the platform bundles another framework"
    version_hpp = (vendor / "ArduinoJson-7.2.0" / "src" / "ArduinoJson" / "version.hpp").read_text()
    aj = re.search(r'#define ARDUINOJSON_VERSION "([\d.]+)"', version_hpp).group(1)
    assert f"| `ArduinoJson-{aj}/src` | bblanchon/ArduinoJson | tag v{aj} |" in readme
    for env in ("env:esp8266", "env:native"):
        assert _ini_value(env, "lib_deps") == f"bblanchon/ArduinoJson@{aj}", env


def test_littlefs_is_mounted_without_formatting_and_serial_is_never_waited_for():
    """The core's LittleFSConfig formats by default (autoFormat true): LittleFS.begin() then wipes
    a file system that does not mount, the stored model with it. The glue turns that off and lets
    infer::App mount through the store (the result in the ready line); and its lines go to USB
    only through infer_tx.h's ring, pumped with what the UART's FIFO takes (no Serial.write that spins)."""
    vendor, _ = _vendor()
    lfs = (vendor / "esp8266-arduino" / "libraries" / "LittleFS" / "src" / "LittleFS.h").read_text()
    assert "LittleFSConfig(bool autoFormat = true)" in lfs and "if (!_cfg._autoFormat || !format())" in lfs
    code = "\n".join(line for line in GLUE.splitlines() if not line.lstrip().startswith("//"))
    mount = code[code.index("bool mount() override"):]
    mount = mount[:mount.index("}")]
    assert mount.index("LittleFS.setConfig(LittleFSConfig(false));") < mount.index("return LittleFS.begin();"), mount
    assert code.count("LittleFS.begin()") == 2 and "format() override { return LittleFS.format() && LittleFS.begin(); }" in code
    assert "g_app.begin(g_out);" in code
    assert "Serial.write" not in code and "Serial.print" not in code
    assert "infer::TxQueue<infer::kTxRing> g_out;" in code and "g_out.pump(Serial);" in code
