"""A command whose reader closes the pipe early (``... | head``) stops quietly, as other Unix tools do."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

CLOSED_PIPE_STATUS = 141  # 128 + SIGPIPE, what a shell reports for a tool the pipe's reader cut off


@contextmanager
def quiet_on_closed_pipe() -> Iterator[None]:
    """Turn a BrokenPipeError into exit status 141 without a traceback. Stdout then goes to /dev/null, so that
    Python's own flush at exit does not raise again. Anything written to files before stays written."""
    try:
        yield
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        raise SystemExit(CLOSED_PIPE_STATUS) from None
