"""hpddo capture (tools/capture.py) against a fake serial port."""
import pytest

from hpddo.logs.benchlog import read_log
from hpddo.cli import capture

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


# ---------------------------------------------------------------- issue 9: reliability

import errno  # noqa: E402

import serial  # noqa: E402  (pyserial: its exception types are what a real port raises)

HEAD_NO_SEQ = ["# condition=manual", "# sample_rate_hz=2", "t_s,duty,v_V,i_A"]


def plain_rows(n, start=0):
    return [f"{k * 0.5:.6f},0.2000,2.{k:04d},0.2140" for k in range(start, start + n)]


def quiet(*_):
    pass


def test_protocol_end_is_marked_complete_before_the_header(tmp_path):
    port = FakePort(HEAD + rows(range(4)) + ["! end sweep overruns=0"])
    out = tmp_path / "sweep.csv"
    capture.capture(port, out, progress=False, log=quiet, warn=quiet)
    log = read_log(out)
    assert log.meta["complete"] == "true" and log.meta["garbled_rows"] == "0"
    assert "cut" not in log.meta and log.meta["condition"] == "sweep"
    assert out.read_text().splitlines()[0] == "# complete=true"


def test_cut_by_rows_is_marked_incomplete(tmp_path):
    port = FakePort(HEAD + rows(range(10)) + ["! end sweep"])
    out = tmp_path / "cut.csv"
    cap = capture.capture(port, out, rows=5, progress=False, log=quiet, warn=quiet)
    log = read_log(out)
    assert len(log.df) == 5 and not cap.complete
    assert log.meta["complete"] == "false" and log.meta["cut"] == "--rows 5"


def test_cut_by_seconds_is_marked_incomplete(tmp_path):
    port = FakePort(HEAD + rows(range(3)))  # then silence: the port times out
    out = tmp_path / "cut.csv"
    capture.capture(port, out, seconds=0.05, progress=False, log=quiet, warn=quiet)
    log = read_log(out)
    assert log.meta["complete"] == "false" and log.meta["cut"] == "--seconds 0.05"
    assert len(log.df) == 3


def test_garbled_rows_without_seq_are_counted_not_written(tmp_path):
    good = plain_rows(8)
    stream = HEAD_NO_SEQ + good[:2] + [
        "1.000000,0.2000,2.0",            # lost bytes: too few fields
        "1.000000,0.2000,2.0x00,0.2140",  # not a number
        "0.250000,0.2000,2.0000,0.2140",  # t_s goes back
        "1.000000,1.5000,2.0000,0.2140",  # duty outside 0..1
        "1.000000,0.2000,nan,0.2140",     # not finite
    ] + good[2:] + ["! end manual"]
    warnings = []
    out = tmp_path / "garbled.csv"
    cap = capture.capture(FakePort(stream), out, progress=False, log=quiet, warn=warnings.append)
    log = read_log(out)
    assert len(log.df) == 8 and cap.rows == 8
    assert list(log.df["t_s"]) == [k * 0.5 for k in range(8)]
    assert [line for line, _, _ in cap.garbled] == [6, 7, 8, 9, 10]  # stream lines, 1-based
    assert log.meta["garbled_rows"] == "5" and log.meta["complete"] == "false"
    assert len(warnings) == 5 and "line 6" in warnings[0] and "fields" in warnings[0]


def test_garbled_metadata_line_is_not_written(tmp_path):
    stream = ["# condition=sweep", "# samp\ufffdle rate=2", "t_s,duty,v_V,i_A"] + plain_rows(3) + ["! end"]
    out = tmp_path / "meta.csv"
    cap = capture.capture(FakePort(stream), out, progress=False, log=quiet, warn=quiet)
    assert read_log(out).meta["garbled_rows"] == "1" and len(cap.garbled) == 1


def test_line_split_by_a_read_timeout_is_joined(tmp_path):
    port = FakePort(HEAD_NO_SEQ + plain_rows(3) + ["! end"])
    row = port.lines[4]
    port.lines[4:5] = [row[:9], row[9:]]  # pyserial's readline returns what came before its timeout
    out = tmp_path / "split.csv"
    cap = capture.capture(port, out, progress=False, log=quiet, warn=quiet)
    assert cap.rows == 3 and not cap.garbled and len(read_log(out).df) == 3


class UnpluggedPort(FakePort):
    port = "/dev/ttyACM7"

    def __init__(self, lines, fail_after):
        super().__init__(lines)
        self.fail_after = fail_after

    def readline(self):
        if self.n >= self.fail_after:
            raise serial.SerialException("device reports readiness to read but returned no data "
                                         "(device disconnected or multiple access on port?)")
        return super().readline()


def test_unplugged_port_is_a_clear_error(tmp_path):
    port = UnpluggedPort(HEAD + rows(range(5)), fail_after=7)
    out = tmp_path / "sweep.csv"
    with pytest.raises(capture.PortError) as exc:
        capture.capture(port, out, progress=False, log=quiet, warn=quiet)
    msg = str(exc.value)
    assert "/dev/ttyACM7" in msg and "disconnected" in msg and "sweep.csv.partial" in msg
    assert "\n" not in msg
    assert not out.exists() and (tmp_path / "sweep.csv.partial").exists()


def test_os_error_on_read_is_a_port_error(tmp_path):
    class EioPort(UnpluggedPort):
        def readline(self):
            if self.n >= self.fail_after:
                raise OSError(errno.EIO, "Input/output error")
            return super().readline()

    with pytest.raises(capture.PortError, match="Input/output error"):
        capture.capture(EioPort(HEAD, fail_after=2), tmp_path / "x.csv", progress=False, log=quiet, warn=quiet)
    assert not (tmp_path / "x.csv").exists()


class FullDiskFile:
    """A file whose write fails with ENOSPC once more than `room` characters were written."""

    def __init__(self, f, room):
        self.f, self.room = f, room

    def write(self, s):
        self.room -= len(s)
        if self.room < 0:
            raise OSError(errno.ENOSPC, "No space left on device")
        return self.f.write(s)

    def __getattr__(self, name):
        return getattr(self.f, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.f.close()


def full_disk(monkeypatch, name_suffix, room=0):
    """Makes capture's open() hand out a FullDiskFile for files whose name ends with name_suffix."""
    real_open = open

    def fake_open(path, mode="r", *args, **kw):
        f = real_open(path, mode, *args, **kw)
        if str(path).endswith(name_suffix) and ("w" in mode or "a" in mode):
            return FullDiskFile(f, room)
        return f

    monkeypatch.setattr(capture, "open", fake_open, raising=False)


def test_disk_full_while_recording_is_a_clear_error(tmp_path, monkeypatch):
    full_disk(monkeypatch, ".partial", room=300)
    out = tmp_path / "sweep.csv"
    with pytest.raises(capture.OutputError) as exc:
        capture.capture(FakePort(HEAD + rows(range(20)) + ["! end"]), out, progress=False,
                        log=quiet, warn=quiet)
    msg = str(exc.value)
    assert "sweep.csv.partial" in msg and "No space left on device" in msg and "\n" not in msg
    assert not out.exists()


def test_disk_full_while_writing_the_final_log_leaves_no_final_file(tmp_path, monkeypatch):
    full_disk(monkeypatch, ".tmp", room=10)
    out = tmp_path / "sweep.csv"
    with pytest.raises(capture.OutputError, match="No space left on device"):
        capture.capture(FakePort(HEAD + rows(range(5)) + ["! end"]), out, progress=False,
                        log=quiet, warn=quiet)
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.csv.partial"]
    assert len(read_log(tmp_path / "sweep.csv.partial").df) == 5  # the rows stay readable


# ---------------------------------------------------------------- the command line


class FakeSerial(FakePort):
    """A pyserial Serial stand-in for main(): context manager, reset_input_buffer, close."""

    def __init__(self, lines, interrupt_after=None, fail_after=None):
        super().__init__(lines, interrupt_after)
        self.fail_after = fail_after
        self.port = "/dev/ttyFAKE0"
        self.closed = False

    def readline(self):
        if self.fail_after is not None and self.n >= self.fail_after:
            raise serial.SerialException("read failed: [Errno 5] Input/output error")
        return super().readline()

    def reset_input_buffer(self):
        pass

    def close(self):
        self.closed = True

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def run_main(monkeypatch, fake, *args, sleep=None):
    monkeypatch.setattr(serial, "Serial", lambda *a, **k: fake)
    monkeypatch.setattr(capture.time, "sleep", sleep or (lambda s: None))
    return capture.main(["--port", "/dev/ttyFAKE0", "--quiet", *args])


def test_main_interrupt_during_the_port_open_wait(tmp_path, monkeypatch, capsys):
    def interrupted(_):
        raise KeyboardInterrupt

    out = tmp_path / "sweep.csv"
    code = run_main(monkeypatch, FakeSerial(HEAD), "--run", "sweep", "-o", str(out), sleep=interrupted)
    err = capsys.readouterr().err.strip()
    assert code == 130 and "/dev/ttyFAKE0" in err and "interrupted" in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_main_cannot_open_port(tmp_path, monkeypatch, capsys):
    def no_port(*a, **k):
        raise serial.SerialException("[Errno 2] could not open port /dev/ttyFAKE0: No such file or directory")

    monkeypatch.setattr(serial, "Serial", no_port)
    code = capture.main(["--port", "/dev/ttyFAKE0", "--run", "sweep", "-o", str(tmp_path / "s.csv")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and "/dev/ttyFAKE0" in err and "\n" not in err


def test_main_unplugged_port(tmp_path, monkeypatch, capsys):
    out = tmp_path / "sweep.csv"
    fake = FakeSerial(HEAD + rows(range(5)), fail_after=7)
    code = run_main(monkeypatch, fake, "--run", "sweep", "-o", str(out))
    err = capsys.readouterr().err.strip()
    assert code == 1 and "/dev/ttyFAKE0" in err and "sweep.csv.partial" in err and "\n" not in err
    assert not out.exists() and fake.closed


def test_main_disk_full(tmp_path, monkeypatch, capsys):
    full_disk(monkeypatch, ".partial", room=200)
    out = tmp_path / "sweep.csv"
    code = run_main(monkeypatch, FakeSerial(HEAD + rows(range(20)) + ["! end"]), "--run", "sweep", "-o", str(out))
    err = capsys.readouterr().err.strip()
    assert code == 1 and "No space left on device" in err and "sweep.csv.partial" in err and "\n" not in err
    assert not out.exists()


def test_main_interrupt_while_recording_stops_the_board(tmp_path, monkeypatch, capsys):
    out = tmp_path / "sweep.csv"
    fake = FakeSerial(HEAD + rows(range(5)) + ["! end"], interrupt_after=7)
    code = run_main(monkeypatch, fake, "--run", "sweep", "-o", str(out))
    err = capsys.readouterr().err.strip()
    assert code == 130 and "sweep.csv.partial" in err and "\n" not in err
    assert fake.written.endswith(b"stop\n") and not out.exists()


def test_main_reports_a_cut_on_stderr(tmp_path, monkeypatch, capsys):
    out = tmp_path / "warmup.csv"
    code = run_main(monkeypatch, FakeSerial(HEAD + rows(range(10))), "--rec", "warmup", "--rows", "4",
                    "-o", str(out))
    err = capsys.readouterr().err
    assert code == 0 and "complete=false" in err and "--rows 4" in err
    assert read_log(out).meta["cut"] == "--rows 4"


def test_main_garbled_rows_exit_3(tmp_path, monkeypatch, capsys):
    out = tmp_path / "sweep.csv"
    stream = HEAD + rows(range(3)) + ["0.1,garbage"] + ["! end sweep"]
    code = run_main(monkeypatch, FakeSerial(stream), "--run", "sweep", "-o", str(out))
    err = capsys.readouterr().err
    assert code == 3 and "1 garbled row" in err and "complete=false" in err
    assert read_log(out).meta["garbled_rows"] == "1"


def test_garbled_header_fails_naming_the_partial(tmp_path):
    stream = ["# condition=sweep", "t_s,du\ufffd,v_V,i_A"] + plain_rows(3)
    out = tmp_path / "hdr.csv"
    with pytest.raises(capture.CaptureError, match=r"garbled header at stream line 2.*hdr\.csv\.partial"):
        capture.capture(FakePort(stream), out, seconds=0.05, progress=False, log=quiet, warn=quiet)
    assert not out.exists()


def test_a_flood_of_garbled_rows_is_counted_and_shown_only_in_part(tmp_path):
    stream = HEAD_NO_SEQ + plain_rows(1) + ["x,y"] * 50 + plain_rows(2, start=1) + ["! end"]
    warnings = []
    cap = capture.capture(FakePort(stream), tmp_path / "f.csv", progress=False, log=quiet,
                          warn=warnings.append)
    assert len(cap.garbled) == 50 and cap.rows == 3
    assert len(warnings) == capture.MAX_GARBLED_SHOWN + 1 and "not shown" in warnings[-1]
    assert read_log(tmp_path / "f.csv").meta["garbled_rows"] == "50"


def test_main_opens_the_port_exclusively_and_closes_it(tmp_path, monkeypatch):
    fake = FakeSerial(HEAD + rows([0, 1, 2]) + ["! end done"])
    opened = []

    def open_port(*a, **k):
        opened.append(k)
        return fake

    monkeypatch.setattr(serial, "Serial", open_port)
    monkeypatch.setattr(capture.time, "sleep", lambda s: None)
    assert capture.main(["--port", "/dev/ttyFAKE0", "--quiet", "--run", "sweep", "-o", str(tmp_path / "s.csv")]) == 0
    assert opened == [{"timeout": 1.0, "exclusive": True}] and fake.closed
