"""The tools' entry: `python -m hpddo SUBCOMMAND ...` and the `hpddo` command
(pyproject.toml, project.scripts: hpddo.__main__:main). Its first statement puts the stop
handler in place (hpddo.interrupt.arm), before the command line's code is imported, so a
Ctrl-C or SIGTERM at any moment from here gives one line and 130 or 143."""
from hpddo import interrupt as _interrupt

_interrupt.arm()

import sys  # noqa: E402 (after arm: everything below loads under the handler)

from hpddo.cli import main  # noqa: E402,F401 (the hpddo command's function)

if __name__ == "__main__":
    sys.exit(main())
