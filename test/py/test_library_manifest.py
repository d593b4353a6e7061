"""lib/hpddo_core is a library for both IDEs: PlatformIO's library.json and the Arduino
IDE's library.properties (1.5 format) exist, are complete, agree on name and version and
name the umbrella header, which includes every header of the core."""
import json
import pathlib
import re

LIB = pathlib.Path(__file__).resolve().parents[2] / "lib" / "hpddo_core"
UMBRELLA = "hpddo_core.h"
SEMVER = re.compile(r"^\d+\.\d+\.\d+(-[0-9A-Za-z.-]+)?$")
# https://arduino.github.io/arduino-cli/latest/library-specification/
ARDUINO_REQUIRED = ("name", "version", "author", "maintainer", "sentence", "paragraph", "category", "url",
                    "architectures")
ARDUINO_CATEGORIES = {"Display", "Communication", "Signal Input/Output", "Sensors", "Device Control", "Timing",
                      "Data Storage", "Data Processing", "Other"}


def library_json():
    return json.loads((LIB / "library.json").read_text(encoding="utf-8"))


def library_properties():
    props = {}
    for number, line in enumerate((LIB / "library.properties").read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        key, sep, value = line.partition("=")
        assert sep, f"library.properties:{number}: not key=value: {line!r}"
        assert key not in props, f"library.properties:{number}: {key} twice"
        props[key] = value
    return props


def as_list(value):
    return [value] if isinstance(value, str) else list(value)


def test_both_manifests_exist():
    assert (LIB / "library.json").is_file()
    assert (LIB / "library.properties").is_file()
    assert (LIB / "src" / UMBRELLA).is_file()


def test_library_json_is_complete_for_platformio():
    m = library_json()
    for key in ("name", "version", "description", "frameworks", "platforms", "headers"):
        assert m.get(key), f"library.json has no {key}"
    assert re.fullmatch(r"[a-z0-9]+([_-][a-z0-9]+)*", m["name"]) and len(m["name"]) <= 50
    assert SEMVER.match(m["version"])
    assert len(m["description"]) <= 255
    # The core includes no framework header: the native env (pio test -e native) uses it too.
    assert as_list(m["frameworks"]) == ["*"]
    assert {"atmelavr", "espressif8266", "native"} <= set(as_list(m["platforms"]))
    assert UMBRELLA in as_list(m["headers"])
    include_dir = m.get("build", {}).get("includeDir", "include")
    assert (LIB / include_dir / UMBRELLA).is_file(), f"includeDir {include_dir} does not hold {UMBRELLA}"


def test_library_properties_is_complete_for_the_arduino_ide():
    p = library_properties()
    missing = [key for key in ARDUINO_REQUIRED if not p.get(key)]
    assert not missing, f"library.properties lacks {missing}"
    assert SEMVER.match(p["version"])
    assert p["category"] in ARDUINO_CATEGORIES
    assert {"avr", "esp8266"} <= {a.strip() for a in p["architectures"].split(",")}
    assert [h.strip() for h in p["includes"].split(",")] == [UMBRELLA]
    # 1.5 format: the sources sit in src/ (recursive), no utility/ folder.
    assert (LIB / "src").is_dir() and not (LIB / "utility").exists()


def test_manifests_agree_on_name_version_and_header():
    m, p = library_json(), library_properties()
    assert m["name"] == p["name"]
    assert m["version"] == p["version"]
    assert UMBRELLA in as_list(m["headers"]) and p["includes"] == UMBRELLA


def test_umbrella_header_reaches_every_core_header():
    """Every header of the core is included by the umbrella, directly or through another."""
    src = LIB / "src"
    reached, todo = set(), [UMBRELLA]
    while todo:
        path = src / todo.pop()
        for name in re.findall(r'#include "([^"]+\.h)"', path.read_text(encoding="utf-8")):
            rel = str((path.parent / name).resolve().relative_to(src.resolve()))
            if rel not in reached:
                reached.add(rel)
                todo.append(rel)
    headers = {f"hpddo/{h.name}" for h in (src / "hpddo").glob("*.h")}
    assert headers - reached == set(), f"{UMBRELLA} does not reach {sorted(headers - reached)}"
