"""The tools' entry: `python -m hpddo SUBCOMMAND ...` and the `hpddo` command
(pyproject.toml, project.scripts: hpddo.__main__:main). Its first statement puts the stop
handler in place (hpddo.interrupt.arm), before the command line's code is imported, so a
Ctrl-C or SIGTERM at any moment from here gives one line and 130 or 143.

Python's cyclic garbage collector stays off while the command line's code is imported
(numpy, scipy, pandas, statsmodels: hundreds of collections over objects that live as long as
the process), and those objects are then moved out of its reach (gc.freeze) when the command
starts its work (hpddo.cli.run turns it on again). The process ends as soon as its command
has: the interpreter's teardown would otherwise collect everything numpy, scipy, pandas,
statsmodels and matplotlib leave (0.4-0.5 s of every command on the 2-core machine,
docs/performance-diagnosis.md); it is moved out of the collector's reach first. The command
has written and closed its files by then (outdir.staged, write_text_atomic), and the exit
handlers run as before."""
from hpddo import interrupt as _interrupt

_interrupt.arm()

import gc  # noqa: E402 (after arm: everything below loads under the handler)

gc.disable()  # (until hpddo.cli.run starts the command's work)

import sys  # noqa: E402

from hpddo.cli import main as _command  # noqa: E402


def main(argv=None) -> int:
    """The hpddo command (hpddo.cli.main), its exit status returned to an exiting process."""
    status = _command(argv)
    gc.freeze()  # (this process exits now: nothing it holds needs collecting)
    return status


if __name__ == "__main__":
    sys.exit(main())
