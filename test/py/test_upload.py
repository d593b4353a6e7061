"""`hpddo upload`: a trained model to the running ESP8266 without reflashing, proven against
the host build of the board's logic (build/host/esp_host: infer::App with ArduinoJson
7.2.0 from ../shared/vendor, a folder as its LittleFS, a pseudo-terminal as its USB
serial). test/fixtures/upload_default.json is the default model's document as this module
writes it (`hpddo.model.upload.document`), read by the C++ tests (test/firmware/test_infer_json.cpp,
InferUpload.*) and the fuzzer (firmware.fuzz.model); it is regenerated and compared here."""
import dataclasses
import json
import os
import pathlib
import subprocess
import zlib

import numpy as np
import pytest

from conftest import ROOT
from hpddo import schema
from hpddo.model import export, fixtures, upload
from hpddo.cli import upload as upload_cli

DEFAULT = ROOT / "models" / "default"
FIXTURE = ROOT / "test" / "fixtures" / "upload_default.json"
VENDOR = pathlib.Path(os.environ.get("HPDDO_VENDOR_DIR", ROOT.parent / "shared" / "vendor"))


def test_the_fixture_is_the_document_of_the_default_model():
    doc = upload.document(upload.read_model(DEFAULT))
    assert FIXTURE.read_bytes() == doc
    d = json.loads(doc)
    assert d["crc"] == int(open(DEFAULT / "model_default.h").read().split("kChecksum = 0x")[1][:8], 16)
    assert d["layout"] == schema.layout_crc() and d["shape"] == [5, 16, 8, 1]


def test_chunk_lines_fit_the_boards_line_and_give_the_document_back():
    doc = FIXTURE.read_bytes()
    for max_line in (64, 200, upload.MAX_LINE):
        lines = upload.chunk_lines(doc, max_line)
        assert all(len(line) <= max_line for line in lines)
        msgs = [json.loads(line) for line in lines]
        assert [m["seq"] for m in msgs] == list(range(len(lines)))
        assert "".join(m["data"] for m in msgs).encode() == doc


def test_a_folder_without_one_model_header_is_refused(tmp_path):
    with pytest.raises(upload.UploadError, match="needs exactly one model_<name>.h"):
        upload.read_model(tmp_path)
    with pytest.raises(upload.UploadError, match="no such folder"):
        upload.read_model(tmp_path / "missing")


def esp_host() -> pathlib.Path:
    """The host build of the board's logic; skipped (failed under CI=true) without ArduinoJson."""
    build = pathlib.Path(os.environ.get("HPDDO_BUILD_DIR", ROOT / "build"))
    exe = build / "host" / "esp_host"
    if not (VENDOR / "ArduinoJson-7.2.0" / "src" / "ArduinoJson.h").is_file():
        reason = f"ArduinoJson 7.2.0 not found in {VENDOR} (set HPDDO_VENDOR_DIR): esp_host is not built"
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI=true: {reason}")
        pytest.skip(reason)
    if not exe.is_file():
        pytest.fail(f"{exe} not found: build it first (cmake --build {build} --target esp_host), or set HPDDO_BUILD_DIR")
    return exe


class Board:
    """esp_host serving a pseudo-terminal, its files in store."""

    def __init__(self, store: pathlib.Path, *args: str):
        self.store = store
        self.proc = subprocess.Popen([str(esp_host()), "--store", str(store), "--pty", *args], stdout=subprocess.PIPE,
                                     text=True)
        line = self.proc.stdout.readline()
        assert line.startswith("pty "), line
        self.port = line.split()[1]

    def close(self):
        self.proc.terminate()
        self.proc.wait(timeout=10)

    def golden_check(self, csv: pathlib.Path) -> subprocess.CompletedProcess:
        """A board started again over the same files (a reset): the model in force over a golden CSV."""
        return subprocess.run([str(esp_host()), "--store", str(self.store), "--golden-csv", str(csv)],
                              capture_output=True, text=True, timeout=60)


@pytest.fixture
def board(tmp_path):
    b = Board(tmp_path / "littlefs")
    yield b
    b.close()


def test_upload_puts_the_default_model_in_force_bit_for_bit_over_a_reset(board, capsys):
    assert upload_cli.main(["--port", board.port, str(DEFAULT)]) == 0
    out = capsys.readouterr().out
    assert "in force" in out, out
    assert (board.store / "model.json").read_bytes() == FIXTURE.read_bytes()
    assert not (board.store / "model.new").exists()
    res = board.golden_check(DEFAULT / "golden_default.csv")
    assert res.returncode == 0, res.stdout + res.stderr
    crc = int(open(DEFAULT / "model_default.h").read().split("kChecksum = 0x")[1][:8], 16)  # the layout's
    assert f"model uploaded (crc 0x{crc:08x}), 77 rows, 0 differ bitwise" in res.stdout, res.stdout
    # What the upload puts on the serial line, at the board's 460800 baud (8N1: 10 bits a byte).
    doc = FIXTURE.read_bytes()
    lines = upload.chunk_lines(doc)
    sent = sum(len(line) + 1 for line in lines) + 60
    print(f"upload of the default model: {len(doc)} bytes of document, {len(lines)} chunk lines, {sent} bytes sent: "
          f"{sent * 10 / upload.BAUD:.3f} s on the wire at {upload.BAUD} baud, plus one reply per line")


def model_with_effects():
    """The default model with thermal_ra and brush_drop switched on (physics a diagnosis would
    add; the network as it is): another model of the same network shape."""
    m = upload.read_model(DEFAULT)
    bits = schema.EFFECT_BITS
    p = dataclasses.replace(m.physics, ra_tc_per_K=float(np.float32(0.00393)), brush_V=float(np.float32(0.4)),
                            effects=bits["thermal_ra"][0] | bits["brush_drop"][0])
    return dataclasses.replace(m, physics=p)


def golden_inputs(csv: pathlib.Path):
    rows = np.genfromtxt(csv, delimiter=",", names=True)
    return [(float(r["v_V"]), float(r["i_A"]), None if np.isnan(r["temp_C"]) else float(r["temp_C"]), float(r["dt_s"]),
             int(r["seq"]) if r["has_seq"] else None) for r in rows]


def test_a_model_with_new_effects_reaches_the_board_without_a_rebuild(board, tmp_path):
    model = model_with_effects()
    folder = tmp_path / "with_effects"
    folder.mkdir()
    (folder / "model_effects.h").write_text(export.model_header(model, "effects", {"command": "test_upload.py"}))
    golden = export.golden_rows(model, golden_inputs(DEFAULT / "golden_default.csv"))
    (tmp_path / "golden_effects.csv").write_text(export.golden_csv(golden))
    default_rpm = np.genfromtxt(DEFAULT / "golden_default.csv", delimiter=",", names=True)["rpm"]
    assert np.nanmax(np.abs(golden[:, export.GOLDEN_INPUTS.__len__() + export.GOLDEN_STAGES.index("rpm")]
                            - default_rpm)) > 1.0  # the effects change the estimates
    assert upload_cli.main(["--port", board.port, str(folder)]) == 0
    res = board.golden_check(tmp_path / "golden_effects.csv")
    assert res.returncode == 0, res.stdout + res.stderr
    assert f"model uploaded (crc 0x{export.model_checksum(model):08x}), 77 rows, 0 differ bitwise" in res.stdout


# The dynamic family (issue 21, item 8): a model that names it, a shaft slow enough against the golden
# rows' 0.5 s period that the observer filters (tau 1 s; at 20 ms it would follow the back-EMF speed).
DYNAMICS = fixtures.DYNAMICS_SHAFT  # the shaft of test/fixtures/dynamics, which the UNO is built with


def model_with_dynamics():
    from hpddo.model import dynamics_ref
    return dataclasses.replace(upload.read_model(DEFAULT), dynamics=dynamics_ref.dynamics_params(**DYNAMICS))


def test_the_dynamic_family_goes_into_the_header_and_the_document_and_comes_back():
    model = model_with_dynamics()
    header = export.model_header(model, "dyn", {"command": "test_upload.py"})
    plain = export.model_header(upload.read_model(DEFAULT), "dyn", {"command": "test_upload.py"})
    assert "kDynamics" in header and "kDynamics" not in plain
    assert header.startswith(plain[:plain.index("#ifndef")].replace(
        f"0x{export.model_checksum(upload.read_model(DEFAULT)):08x}", f"0x{export.model_checksum(model):08x}"))
    back = export.read_model_header(header)  # its checksum checked: it covers the family
    assert back.dynamics == model.dynamics
    assert export.model_checksum(model) != export.model_checksum(upload.read_model(DEFAULT))
    doc = json.loads(upload.document(model))
    want = [int(b) for b in np.array([DYNAMICS[d.field] for d in schema.DYNAMICS], "<f4").view("<u4")]
    assert doc["dynamics"] == want and doc["crc"] == export.model_checksum(model)
    assert "dynamics" not in json.loads(FIXTURE.read_bytes())  # a model without it: the document as before


def test_a_model_with_the_dynamic_family_reaches_the_board_bit_for_bit(board, tmp_path):
    model = model_with_dynamics()
    folder = tmp_path / "with_dynamics"
    folder.mkdir()
    (folder / "model_dyn.h").write_text(export.model_header(model, "dyn", {"command": "test_upload.py"}))
    golden = export.golden_rows(model, golden_inputs(DEFAULT / "golden_default.csv"))
    (tmp_path / "golden_dyn.csv").write_text(export.golden_csv(golden))
    col = len(export.GOLDEN_INPUTS) + export.GOLDEN_STAGES.index("rpm_m2")
    default_m2 = np.genfromtxt(DEFAULT / "golden_default.csv", delimiter=",", names=True)["rpm_m2"]
    diff = np.abs(golden[:, col] - default_m2.astype(np.float32))
    assert np.nanmax(diff) > 1.0  # the family filters the back-EMF speed where it changes
    assert diff[0] == 0.0  # and starts settled on it
    assert upload_cli.main(["--port", board.port, str(folder)]) == 0
    res = board.golden_check(tmp_path / "golden_dyn.csv")
    assert res.returncode == 0, res.stdout + res.stderr
    assert f"model uploaded (crc 0x{export.model_checksum(model):08x}), 77 rows, 0 differ bitwise" in res.stdout


def test_a_model_trained_with_new_effects_reaches_the_running_board(board, tmp_path):
    """The mission's loop on the (host-built) board: hpddo train with the effects the
    diagnosis names, hpddo upload, and the board runs it: its golden vectors bit for bit."""
    from hpddo.cli import train as train_cli
    out = tmp_path / "with_effects"
    data = ROOT / "data" / "default"
    assert train_cli.main([str(data / "sweep.csv"), str(data / "load.csv"), str(data / "long.csv"),
                           "--effects", "thermal_ra,brush_drop,magnet_thermal", "--out", str(out), "--quiet"]) == 0
    assert upload_cli.main(["--port", board.port, str(out)]) == 0
    crc = export.model_checksum(upload.read_model(out))
    res = board.golden_check(out / "golden_default.csv")
    assert res.returncode == 0, res.stdout + res.stderr
    assert f"model uploaded (crc 0x{crc:08x}), 77 rows, 0 differ bitwise" in res.stdout, res.stdout


def test_a_shape_the_firmware_was_not_built_for_is_refused_with_the_command_to_rebuild(board, tmp_path, capsys):
    m = upload.read_model(DEFAULT)
    rng = np.random.default_rng(25)
    sizes = (5, 32, 16, 1)  # hpddo train --hidden 32,16
    layers = [(rng.normal(0, 0.3, (o, i)).astype(np.float32), rng.normal(0, 0.1, o).astype(np.float32))
              for i, o in zip(sizes[:-1], sizes[1:])]
    folder = tmp_path / "wide"
    folder.mkdir()
    (folder / "model_wide.h").write_text(export.model_header(dataclasses.replace(m, layers=layers), "wide",
                                                             {"command": "test_upload.py"}))
    assert upload_cli.main(["--port", board.port, str(folder)]) == 1
    err = capsys.readouterr().err
    assert "model_refused (shape)" in err and "pio run -e esp8266" in err and "unchanged" in err, err
    assert not (board.store / "model.json").exists() and not (board.store / "model.new").exists()
    res = board.golden_check(DEFAULT / "golden_default.csv")
    assert "model compiled" in res.stdout and res.returncode == 0, res.stdout


def test_an_upload_cut_short_leaves_the_model_in_force(board):
    """The host stops after a few chunks (a pulled cable): the board drops the upload after
    kUploadIdle_ms and says so; the stored model is the one before."""
    import serial
    assert upload_cli.main(["--port", board.port, str(DEFAULT)]) == 0
    before = (board.store / "model.json").read_bytes()
    doc = upload.document(model_with_effects())
    with serial.Serial(board.port, upload.BAUD, timeout=0.2, exclusive=True) as port:
        link = upload.Link(port, timeout_s=3.0)
        link.ask(json.dumps({"cmd": "upload", "bytes": len(doc), "crc32": zlib.crc32(doc)}).encode(), "upload")
        for line in upload.chunk_lines(doc)[:3]:
            link.ask(line, "chunk")
        with pytest.raises(upload.UploadError, match="upload_timeout"):
            upload.Link(port, timeout_s=8.0).ask(b'{"cmd":"status"}', "never")
        status = link.ask(b'{"cmd":"status"}', "status")
    crc = int(open(DEFAULT / "model_default.h").read().split("kChecksum = 0x")[1][:8], 16)  # the one before
    assert status["model"] == "uploaded" and status["model_crc"] == crc and status["uploading"] is False
    assert (board.store / "model.json").read_bytes() == before
    assert not (board.store / "model.new").exists()


def test_a_file_system_that_does_not_mount_is_reported_kept_and_formatted_only_when_asked(tmp_path, capsys):
    """esp_host's store playing a LittleFS that does not mount, a model stored in it: the ready
    line and the status say "fs":"unmounted", the compiled model runs, hpddo upload says why it
    does not upload and the stored file stays; the format command erases it and uploads work."""
    import serial
    store = tmp_path / "littlefs"
    store.mkdir()
    (store / "model.json").write_bytes(FIXTURE.read_bytes())
    # the board on stdin/stdout: its whole output from start-up (a port's opening discards what it held)
    res = subprocess.run([str(esp_host()), "--store", str(store), "--fs-unmountable"], input='{"cmd":"status"}\n',
                         capture_output=True, text=True, timeout=60)
    ready, status = (json.loads(line) for line in res.stdout.splitlines())
    assert ready["event"] == "ready" and ready["fs"] == "unmounted" and ready["model"] == "compiled", ready
    assert status["fs"] == "unmounted" and status["model"] == "compiled", status
    b = Board(store, "--fs-unmountable")
    try:
        assert upload_cli.main(["--port", b.port, str(DEFAULT)]) == 1
        err = capsys.readouterr().err
        assert "file system did not mount" in err and '{"cmd":"format"}' in err and err.count("\n") == 1, err
        assert (store / "model.json").read_bytes() == FIXTURE.read_bytes()
        with serial.Serial(b.port, upload.BAUD, timeout=2.0, exclusive=True) as port:
            assert upload.Link(port).ask(b'{"cmd":"format"}', "format")["fs"] == "mounted"
        assert not (store / "model.json").exists()
        assert upload_cli.main(["--port", b.port, str(DEFAULT)]) == 0
        assert (store / "model.json").read_bytes() == FIXTURE.read_bytes()
    finally:
        b.close()
