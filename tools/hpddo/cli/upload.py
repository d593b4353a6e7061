"""Sends a trained model to the running ESP8266 inference board, without reflashing.

    hpddo upload --port /dev/ttyUSB0 mymodel        (the --out folder of hpddo train)

The model (physics parameters and effects, scaler, network, gate, clamp, envelope, limits
and its checksum) goes over the serial line as one JSON document in acknowledged chunks.
The board checks the bytes' count and CRC-32, the document's format, the physics
parameter layout, the network shape against the one it was built for and the model's
checksum, stores it in LittleFS and only then switches to it; it keeps it over a reset.
An interrupted or refused upload leaves the model in force running: the board's reason is
printed (a network shape the firmware was not built for: rebuild it with the model's
header, docs/esp8266.md). Nothing listens on the board's Wi-Fi: serial only.

Exit status: 0 model in force, 1 refused or failed (one line "hpddo upload: ...").
"""
from __future__ import annotations

import argparse

from ..model import upload
from . import options

try:
    import serial  # pyserial
except ImportError:  # pragma: no cover
    serial = None


def parser(prog: str = "hpddo upload") -> argparse.ArgumentParser:
    """The command line options."""
    p = options.new_parser(prog, __doc__)
    p.add_argument("--port", required=True, help="serial port of the ESP8266, e.g. /dev/ttyUSB0 or COM4")
    p.add_argument("--baud", type=options.positive_int, default=upload.BAUD,
                   help=f"baud rate of the port (default {upload.BAUD}, the board's)")
    p.add_argument("--timeout", type=options.positive_float, default=3.0, metavar="S",
                   help="seconds to wait for each of the board's replies (default 3)")
    p.add_argument("model_dir", metavar="MODEL_DIR", help="folder holding model_<name>.h (hpddo train's --out)")
    return p


def run(a: argparse.Namespace) -> int:
    """Reads the model, opens the port exclusively, sends; 0 when the board runs the model."""
    model = upload.read_model(a.model_dir)
    doc = upload.document(model)
    if serial is None:  # pragma: no cover
        raise upload.UploadError("pyserial is not installed (pip install pyserial)")
    try:
        # DTR and RTS held off: the NodeMCU's auto-reset circuit then leaves the board running.
        port = serial.Serial(None, a.baud, timeout=0.2, exclusive=True)
        port.port = a.port
        port.dtr = False
        port.rts = False
        port.open()
    except (serial.SerialException, OSError) as exc:
        raise upload.UploadError(f"cannot open {a.port}: {exc}") from None
    try:
        with port:
            upload.send(port, doc, timeout_s=a.timeout)
    except (serial.SerialException, OSError) as exc:
        raise upload.UploadError(f"lost {a.port} during the upload: {exc}; the model in force is unchanged") from None
    return 0


def main(argv=None) -> int:
    """`hpddo upload ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("upload", argv)
