"""Progress bars that stay readable in a log file.

tqdm redraws a bar every 0.1 s. On a terminal that is one line; written to a file (``nohup``, a cluster job, CI)
every redraw is kept, and a 10,000-step training leaves about a megabyte of bars. When standard error is not a
terminal, the commands redraw at most every 30 s instead. tqdm reads its ``TQDM_*`` settings from the environment
when it is first imported, so this runs before any command imports it, and worker processes inherit it.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping

LOG_INTERVAL_S = 30


def slow_bars_in_logs(environ: MutableMapping[str, str] | None = None, *, is_terminal: bool) -> bool:
    """Set ``TQDM_MININTERVAL`` for a log-file run unless the user set it; True when it was set here."""
    environ = os.environ if environ is None else environ
    if is_terminal or "TQDM_MININTERVAL" in environ:
        return False
    environ["TQDM_MININTERVAL"] = str(LOG_INTERVAL_S)
    return True
