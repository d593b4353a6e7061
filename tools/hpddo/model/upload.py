"""A trained model to a running ESP8266 without reflashing (`hpddo upload`).

The model goes as one JSON document (esp_infer/infer_upload.h gives its form: every
float as the uint32 of its IEEE-754 bits, so the board holds the trained float32 values
exactly), sent over the serial line in chunks of one command line each, every chunk
acknowledged before the next:

    {"cmd":"upload","bytes":N,"crc32":C}        -> {"event":"upload",...}
    {"cmd":"chunk","seq":K,"data":"<text>"}     -> {"event":"chunk","seq":K,...}
    {"cmd":"commit"}                            -> {"event":"commit","model":"uploaded",...}

The board checks the byte count and CRC-32, the document's format, parameter layout,
network shape and model checksum, stores it in LittleFS and only then puts it in force;
anything else is an {"event":"error",...} line, which this module raises as an
UploadError with the board's reason, the model in force unchanged. Telemetry lines
arriving meanwhile are skipped.
"""
from __future__ import annotations

import json
import pathlib
import time
import zlib

import numpy as np

from .. import schema
from ..logs.errors import InputError
from . import export

#: The document version the firmware reads (infer::kModelFormat).
FORMAT = 1
#: The board's serial speed (infer::kHostBaud).
BAUD = 460800
#: Longest command line the board reads (infer::kCommandMax); the board says it again.
MAX_LINE = 512


class UploadError(InputError):
    """An upload the board refused or that could not finish; the model in force unchanged."""


def _bits(values) -> list[int]:
    return [int(b) for b in np.asarray(values, "<f4").ravel().view("<u4")]


def document(model) -> bytes:
    """The model document of a ModelData (hpddo.model.observer_ref), compact JSON, ASCII."""
    p = model.physics
    physics = _bits([float(getattr(p, f)) for f in schema.FLOAT_FIELDS]) + [int(p.effects)]
    arrays = export.network_arrays(model)  # kW0, kB0, kW1, kB1[, kW2, kB2]
    g, lim = model.gate, model.limits
    doc = {"hpddo_model": FORMAT, "layout": schema.layout_crc(),
           "shape": [5, *model.hidden, 1], "physics": physics,
           "scaler_mean": _bits(model.scaler_mean), "scaler_scale": _bits(model.scaler_scale)}
    for name, a in arrays:
        doc[name[1:].lower()] = _bits(a)
    doc.update({"env_lo": _bits(model.env_lo), "env_hi": _bits(model.env_hi),
                "gate_centre": _bits(g.centre), "gate_scale": _bits(g.scale),
                "gate_prototypes": _bits(g.prototypes), "gate_r": _bits([g.r_in_sq, g.r_out_sq]),
                "clamp_rpm": _bits([model.clamp_rpm])[0],
                "limits": _bits([lim.v_max_V, lim.i_max_A, lim.temp_min_C, lim.temp_max_C]),
                "crc": export.model_checksum(model)})
    if model.dynamics_named:  # the dynamic family (infer_upload.h: "dynamics", before the crc it is covered by)
        crc = doc.pop("crc")
        doc.update(dynamics=_bits(export.dynamics_floats(model)), crc=crc)
    return json.dumps(doc, separators=(",", ":")).encode("ascii")


def chunk_lines(doc: bytes, max_line: int = MAX_LINE) -> list[bytes]:
    """The chunk commands of doc, each line (newline excluded) at most max_line bytes."""
    text = doc.decode("ascii")
    lines, start, seq = [], 0, 0
    while start < len(text):
        head = f'{{"cmd":"chunk","seq":{seq},"data":'
        room = max_line - len(head) - 1  # the closing brace
        end = start
        size = 2  # the quotes
        while end < len(text):
            step = len(json.dumps(text[end])) - 2
            if size + step > room:
                break
            size += step
            end += 1
        if end == start:
            raise ValueError(f"max_line {max_line} leaves no room for a chunk")
        lines.append((head + json.dumps(text[start:end]) + "}").encode("ascii"))
        start, seq = end, seq + 1
    return lines


def find_model(model_dir: pathlib.Path) -> pathlib.Path:
    """The one float model header model_<name>.h of a model folder (hpddo train's --out)."""
    model_dir = pathlib.Path(model_dir)
    if not model_dir.is_dir():
        raise UploadError(f"{model_dir}: no such folder")
    found = sorted(p for p in model_dir.glob("model_*.h") if not p.name.endswith(("_q.h", "_q8.h")))  # not the integer ones
    if len(found) != 1:
        names = ", ".join(p.name for p in found) or "none"
        raise UploadError(f"{model_dir}: needs exactly one model_<name>.h (found: {names})")
    return found[0]


def read_model(model_dir: pathlib.Path):
    """The ModelData of a model folder's header (its checksum checked)."""
    path = find_model(model_dir)
    try:
        return export.read_model_header(path.read_text())
    except (ValueError, KeyError, AttributeError) as exc:
        raise UploadError(f"{path}: not a model header hpddo wrote ({exc})") from None


class Link:
    """Command lines to the board and its reply lines back, over an open port (anything
    with write() and readline(), a serial.Serial with a read timeout)."""

    def __init__(self, port, timeout_s: float = 3.0, log=None):
        self.port, self.timeout_s, self.log = port, timeout_s, log

    def ask(self, line: bytes, event: str) -> dict:
        """Sends a command line; returns the board's reply with that event, skipping telemetry
        and other lines; an error line or no reply within timeout_s raises UploadError."""
        self.port.write(line + b"\n")
        self.port.flush()
        deadline = time.monotonic() + self.timeout_s
        while time.monotonic() < deadline:
            raw = self.port.readline()
            if not raw:
                continue
            try:
                msg = json.loads(raw.decode("utf-8", "replace"))
            except ValueError:
                continue
            if not isinstance(msg, dict):
                continue
            if msg.get("event") == "error":
                reason = f" ({msg['reason']})" if "reason" in msg else ""
                raise UploadError(f"the board refused it: {msg.get('error')}{reason}: {msg.get('detail', '')}; "
                                  f"the model in force is unchanged")
            if msg.get("event") == event:
                return msg
        raise UploadError(f"no reply to {event} within {self.timeout_s:g} s: is the inference board on this port "
                          f"(at {BAUD} baud)? the model in force is unchanged")


def send(port, doc: bytes, timeout_s: float = 3.0, log=print) -> dict:
    """Sends a model document over an open port; the board's commit reply (with the
    upload's time and size added), or UploadError. First asks the board's status, up to
    three times a second apart: a board that opening the port reset is booting meanwhile."""
    t0 = time.monotonic()
    for attempt in range(3):
        try:
            status = Link(port, 1.0).ask(b'{"cmd":"status"}', "status")
            break
        except UploadError:
            if attempt == 2:
                raise
    if status.get("fs") == "unmounted":  # (a firmware before the member: no "fs", go on)
        raise UploadError('the board\'s file system did not mount ("fs":"unmounted" in its ready line and '
                          'status): nothing uploaded, its flash left as it is, the compiled model in force; '
                          '{"cmd":"format"} on the port erases the file system (a stored model with it), '
                          'then upload again (docs/esp8266.md)')
    link = Link(port, timeout_s)
    crc = zlib.crc32(doc) & 0xFFFFFFFF
    ready = link.ask(json.dumps({"cmd": "upload", "bytes": len(doc), "crc32": crc},
                                separators=(",", ":")).encode(), "upload")
    lines = chunk_lines(doc, int(ready.get("max_line", MAX_LINE)))
    for k, line in enumerate(lines):
        ack = link.ask(line, "chunk")
        if ack.get("seq") != k:
            raise UploadError(f"chunk {k} acknowledged as {ack.get('seq')}: the model in force is unchanged")
    done = link.ask(b'{"cmd":"commit"}', "commit")
    done["seconds"] = time.monotonic() - t0
    done["bytes"] = len(doc)
    done["chunks"] = len(lines)
    if log:
        log(f"uploaded {len(doc)} bytes in {len(lines)} chunks, {done['seconds']:.2f} s: model crc "
            f"0x{done.get('model_crc', 0):08x} in force")
    return done
