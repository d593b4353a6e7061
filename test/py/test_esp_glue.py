"""The ESP8266 sketch's glue (esp_infer.cpp) is compiled only under PlatformIO (ArduinoJson
comes from its registry), so these checks read its source: the JSON document is sized for
exactly the members it writes, and every telemetry value reaches the line."""
import re

from conftest import ROOT

GLUE = (ROOT / "esp_infer" / "esp_infer.cpp").read_text()
TELEMETRY = (ROOT / "esp_infer" / "infer_telemetry.h").read_text()


def test_the_document_is_sized_for_the_members_it_writes():
    members = re.findall(r'doc\["(\w+)"\]', GLUE)
    assert len(members) == len(set(members))
    declared = int(re.search(r"kTelemetryMembers = (\d+);", GLUE).group(1))
    assert declared == len(members)
    assert "JSON_OBJECT_SIZE(kTelemetryMembers)" in GLUE and "doc.overflowed()" in GLUE


def test_every_telemetry_field_reaches_the_line():
    struct = TELEMETRY[TELEMETRY.index("struct Telemetry"):TELEMETRY.index("};", TELEMETRY.index("struct Telemetry"))]
    fields = re.findall(r"^\s+[\w:]+\s+(\w+);", struct, re.M)
    for f in fields:
        assert f"t.{f}" in GLUE, f"Telemetry::{f} is not written to the JSON line"
