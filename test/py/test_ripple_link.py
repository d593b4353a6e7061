"""The UNO's ripple bursts on the USB serial (hpddo.logs.ripple_link, issue 23 item 2): the
chunk lines decode by the layout of uno_acq/acq_ripple.h, damaged ones are refused, the
assembler keeps only whole bursts, and hpddo capture writes them as the <condition>.ripple.csv
that hpddo ripple reads. (The board's own encoder against this decoder: the simavr test
firmware.uno.sim_ripple, test/firmware/check_uno_ripple.py.)"""
import base64
import binascii
import struct

import numpy as np
import pytest

from hpddo.cli import capture
from hpddo.logs import ripple, ripple_link
from hpddo.logs.benchlog import read_log


def chunk_bytes(seq, first, total, start_period, phase, codes):
    """A chunk by the layout documented in uno_acq/acq_ripple.h."""
    n = len(codes)
    bits = sum(int(c) << (10 * k) for k, c in enumerate(codes))
    packed = bits.to_bytes((10 * n + 7) // 8, "little")
    body = struct.pack("<BIHHHHB", 13 + len(packed), seq, first, total, start_period, phase, n) + packed
    crc = binascii.crc_hqx(body, 0xFFFF)
    return b"\xa5\x5b" + body + struct.pack("<H", crc)


def line(*args):
    return "~" + base64.b64encode(chunk_bytes(*args)).decode()


def test_a_chunk_decodes_to_its_fields_and_codes():
    codes = [0, 1023, 5, 512, 77] + list(range(100, 127))
    c = ripple_link.decode_line(line(70000, 32, 768, 232, 641, codes) + "\n")
    assert (c.seq, c.first, c.total, c.start_period, c.phase_cycles) == (70000, 32, 768, 232, 641)
    assert list(c.codes) == codes
    assert len(line(1, 0, 32, 0, 0, codes)) + 1 == 82  # kRippleLineMax with its newline


@pytest.mark.parametrize("damage, fault", [
    (lambda b: b[:20] + bytes([b[20] ^ 4]) + b[21:], "CRC"),
    (lambda b: b[:-1], "length"),
    (lambda b: b"\xa5\x5a" + b[2:], "header"),
])
def test_damaged_chunks_are_refused(damage, fault):
    raw = damage(chunk_bytes(3, 0, 64, 10, 641, list(range(32))))
    with pytest.raises(ripple_link.ChunkError, match=fault):
        ripple_link.decode_line("~" + base64.b64encode(raw).decode())
    with pytest.raises(ripple_link.ChunkError, match="base64"):
        ripple_link.decode_line("~@@@@")


def test_only_whole_bursts_are_kept():
    a = ripple_link.Assembler()
    codes = np.arange(80) % 1024
    for first in (64, 0, 32):  # out of order
        assert a.feed(line(7, first, 80, 920, 641, codes[first:first + 32].tolist()))
    assert a.feed(line(7, 0, 80, 920, 641, codes[:32].tolist()))  # a repeat
    a.feed(line(8, 0, 80, 920, 641, codes[:32].tolist()))  # seq 8 misses two chunks
    assert not a.feed("~" + base64.b64encode(b"\xa5\x5b\x00").decode())
    whole, incomplete = a.bursts()
    assert [b.seq for b in whole] == [7] and incomplete == [8]
    assert whole[0].codes.tolist() == codes.tolist() and whole[0].start_period == 920
    assert a.duplicates == 1 and a.bad == 1


HEAD = ["! uno_acq 1 ready rate=10 pwm=10000", "# condition=ripple", "# sample_rate_hz=10", "# pwm_hz=10000",
        "# shunt_ohm=0.5", "# adc_ref_V=5", "# ripple_hz=10000", "# ripple_n=64", "# shunt_gain=1",
        "t_s,duty,v_V,i_A,rpm_ref,temp_C,load,seq"]


def test_capture_writes_the_bursts_beside_the_log(tmp_path):
    rng = np.random.default_rng(23)
    bursts = {s: rng.integers(0, 400, 64) for s in (5, 6, 7)}
    stream = list(HEAD)
    for k, s in enumerate((5, 6, 7)):
        stream.append(f"{k * 0.1:.6f},0.8000,9.6,0.5,150.0,,0,{s}")
        for first in (0, 32):
            chunk = line(s, first, 64, 936, 641, bursts[s][first:first + 32].tolist())
            if s == 6 and first == 32:
                chunk = chunk[:40] + ("A" if chunk[40] != "A" else "B") + chunk[41:]  # damaged on the line
            stream.append(chunk)
    stream.append("! end stopped overruns=0")
    out = tmp_path / "ripple.csv"
    said = []
    cap = capture.capture(FakePort(stream), out, "rec ripple", progress=False, log=said.append)
    assert cap.rows == 3 and len(read_log(out).df) == 3  # the chunk lines are not rows
    b = ripple.read(tmp_path / "ripple.ripple.csv")
    assert b.seq.tolist() == [5, 7]  # seq 6 lost a chunk on the line: left out, counted
    assert b.sample_hz == 10000 and b.a_per_code == pytest.approx(5 / 1024 / 0.5)
    assert b.codes[1].tolist() == bursts[7].tolist()
    assert b.t_s[0] == pytest.approx(0.0 + (936 * 1600 + 641) / 16e6)
    assert any("1 incomplete" in s and "1 damaged" in s for s in said)


class FakePort:
    def __init__(self, lines):
        self.lines = [(l + "\n").encode() for l in lines]
        self.written = b""

    def write(self, b):
        self.written += b

    def readline(self):
        return self.lines.pop(0) if self.lines else b""
