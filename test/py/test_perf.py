"""The committed benchmark figures (docs/figures/bench_observer.json) and the table in
docs/performance.md are one measurement: the table is perf.table() of the figures. And
the measurement itself was sound: no step off its golden row on the AVR."""
import json

import pytest

from conftest import ROOT
from hpddo.studies import perf

pytestmark = pytest.mark.slow  # runs tools for seconds to minutes: not in scripts/test.sh --quick


def test_committed_table_is_the_table_of_the_committed_figures():
    fig = json.loads(perf.FIGURES.read_text())
    doc = perf.DOC.read_text()
    block = doc[doc.index(perf.BEGIN):doc.index(perf.END)]
    assert perf.table(fig) in block
    assert f"`{perf.COMMAND}`" in block


def test_committed_measurement_had_no_golden_miss_and_a_peer():
    fig = json.loads(perf.FIGURES.read_text())
    assert fig["avr"]["float"]["golden_misses"] == 0
    assert fig["avr"]["fixed"]["golden_misses"] == 0
    assert fig["avr"]["int8"]["golden_misses"] == 0
    assert fig["avr"]["peer"]["status"] == "run"
    steps = fig["avr"]["fixed"]["stages"]["step"]
    assert steps["n"] >= 70 and steps["median"] <= steps["max"]


def test_committed_lx106_counts_had_no_golden_miss():
    fig = json.loads(perf.FIGURES.read_text())["lx106"]
    assert fig["status"] == "run"
    for kind in ("float_16_8", "fixed_16_8", "int8_16_8"):
        assert fig[kind]["golden_misses"] == 0
        assert abs(fig[kind]["counts_per_instruction"] - 40.96) < 1e-9  # -icount shift=10 at the sim's 40 MHz
    assert fig["fixed_128_64"]["step"]["median"] < fig["float_128_64"]["step"]["median"]


def test_lx106_step_in_qemu_matches_the_goldens(tmp_path):
    """The lx106 harness itself, where QEMU and GCC's sources are installed (scripts/bootstrap.sh
    --tests installs them): the fixed-point (16, 8) step on every
    golden row in QEMU, no miss, and the same instruction counts as committed (QEMU's
    instruction counting is exact)."""
    import glob
    import shutil

    import pytest
    if not (shutil.which("qemu-system-xtensa") and glob.glob(perf.GCC_SOURCE_GLOB) and shutil.which(perf.LX_CXX)):
        pytest.skip("qemu-system-misc, gcc-12-source or the lx106 GCC not installed (scripts/bootstrap.sh --tests installs them)")
    libsoft = perf._lx106_libgcc(tmp_path)
    inc = perf.bench_model_h("model_default_q", "golden_default_q")
    got = perf._lx106_run(tmp_path, "fixed_16_8", inc, [ROOT / "models" / "default"], libsoft)
    assert got["golden_misses"] == 0
    committed = json.loads(perf.FIGURES.read_text())["lx106"]["fixed_16_8"]["step"]
    assert got["step"] == committed


def test_committed_telemetry_line_and_upload_parse_on_the_lx106():
    """The ArduinoJson telemetry line within its goal (40,000 instructions), and the default
    model's document accepted by the board's parser on the lx106 (hpddo bench --observer)."""
    tl = json.loads(perf.FIGURES.read_text())["lx106"]["telemetry_line"]
    assert tl["status"] == "run" and tl["line"]["n"] >= 70
    assert tl["line"]["max"] <= perf.GOAL_LX106_LINE
    assert tl["bytes"]["max"] <= 240  # infer::kJsonMaxLine
    assert tl["upload_parse"]["accepted"] is True
    assert tl["upload_parse"]["arena_peak_B"] < tl["upload_parse"]["arena_capacity_B"]


def test_lx106_line_in_qemu_gives_the_committed_counts(tmp_path):
    """The telemetry line and the upload parse on the lx106, where QEMU and GCC's sources are
    installed: the same exact instruction counts as committed, the document accepted."""
    import glob
    import shutil

    import pytest
    if not (shutil.which("qemu-system-xtensa") and glob.glob(perf.GCC_SOURCE_GLOB) and shutil.which(perf.LX_CXX)):
        pytest.skip("qemu-system-misc, gcc-12-source or the lx106 GCC not installed (scripts/bootstrap.sh --tests installs them)")
    got = perf.lx106_line(tmp_path, perf._lx106_libgcc(tmp_path))
    if got["status"] != "run":
        pytest.skip(got["status"])
    committed = json.loads(perf.FIGURES.read_text())["lx106"]["telemetry_line"]
    assert got["line"] == committed["line"] and got["upload_parse"] == committed["upload_parse"]


def test_committed_upload_of_the_default_model_within_its_goal():
    """hpddo upload of the default model to the host-built board at an emulated 460800 baud."""
    up = json.loads(perf.FIGURES.read_text())["esp_upload"]
    assert up["status"] == "run" and up["baud"] == 460800 and up["seconds"]["n"] >= 3
    assert up["seconds"]["max"] <= perf.GOAL_UPLOAD_S


def test_committed_uno_loop_checked_every_estimate():
    """The UNO's main loop figures come from a run whose estimates all matched the reference."""
    u = json.loads(perf.FIGURES.read_text())["uno_loop"]
    assert u["status"] == "run"
    assert u["checked"] and "estimates within" in u["checked"][0]
    assert u["window"]["n"] >= 250 and u["observer"]["median"] < u["window"]["median"]
