"""The errors a user's input can cause, as one family the command-line tools report in
one line (the file, the line where there is one, the fault and what to do) instead of
a traceback. Anything else escaping a tool is a bug of hpddo."""
from __future__ import annotations

from .benchlog import BenchLogError


class InputError(ValueError):
    """Input that hpddo cannot use: the message says what is wrong and what to do."""


#: Caught by every command-line tool and reported as "tool: message", exit status 1.
USER_ERRORS = (InputError, BenchLogError)
