"""tools/capture.py against a fake serial port."""
import importlib.util
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("capture", ROOT / "tools" / "capture.py")
capture = importlib.util.module_from_spec(spec)
spec.loader.exec_module(capture)

from hpddo.benchlog import read_log  # noqa: E402

HEAD = ["! uno_acq 1 ready rate=2", "# condition=sweep", "# sample_rate_hz=2", "# motor=25GA371 1:4.4",
        "t_s,duty,v_V,i_A,rpm_ref,temp_C,load,seq"]


def rows(seqs):
    return [f"{k * 0.5:.6f},0.2000,2.{k:04d},0.2140,41.20,31.6875,0,{s}" for k, s in enumerate(seqs)]


class FakePort:
    def __init__(self, lines, interrupt_after=None):
        self.lines = [(l + "\n").encode() for l in lines]
        self.written = b""
        self.interrupt_after = interrupt_after
        self.n = 0

    def write(self, b):
        self.written += b

    def readline(self):
        if self.interrupt_after is not None and self.n >= self.interrupt_after:
            raise KeyboardInterrupt
        self.n += 1
        return self.lines.pop(0) if self.lines else b""


def test_valid_capture_is_a_valid_log(tmp_path):
    port = FakePort(HEAD + rows(range(10, 20)) + ["! end sweep overruns=0"])
    out = tmp_path / "sweep.csv"
    cap = capture.capture(port, out, "run sweep", progress=False, log=lambda *_: None)
    assert port.written == b"run sweep\n"
    log = read_log(out)
    assert len(log.df) == 10 and cap.rows == 10 and cap.lost == 0
    assert log.condition == "sweep" and log.sample_rate_hz == 2.0
    assert list(log.df["seq"]) == list(range(10, 20))
    assert not (tmp_path / "sweep.csv.partial").exists()


def test_interruption_leaves_no_final_file(tmp_path):
    port = FakePort(HEAD + rows(range(5)) + ["! end sweep"], interrupt_after=7)
    out = tmp_path / "sweep.csv"
    with pytest.raises(KeyboardInterrupt):
        capture.capture(port, out, progress=False, log=lambda *_: None)
    assert not out.exists()
    assert (tmp_path / "sweep.csv.partial").exists()


def test_seq_gaps_are_reported(tmp_path):
    port = FakePort(HEAD + rows([1, 2, 3, 7, 8, 10]))
    out = tmp_path / "gappy.csv"
    cap = capture.capture(port, out, rows=6, progress=False, log=lambda *_: None)
    assert cap.gaps == [(3, 3), (8, 1)]
    assert cap.lost == 4
    assert len(read_log(out).df) == 6


def test_no_rows_is_an_error_not_a_log(tmp_path):
    port = FakePort(HEAD)
    out = tmp_path / "empty.csv"
    with pytest.raises(capture.CaptureError):
        capture.capture(port, out, seconds=0.05, progress=False, log=lambda *_: None)
    assert not out.exists()
