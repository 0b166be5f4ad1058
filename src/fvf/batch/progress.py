"""The progress display of a batch on stderr: done / total, skipped, failed, ETA.

A tqdm bar when tqdm is installed and stderr is a terminal; otherwise a plain line,
rewritten in place on a terminal and printed at most every :data:`PLAIN_INTERVAL` seconds
(and at the end) when stderr goes to a file or a pipe.
"""

from __future__ import annotations

import sys
import time
from typing import IO, Any

__all__ = ["Progress", "PLAIN_INTERVAL"]

#: Seconds between two plain progress lines when stderr is not a terminal.
PLAIN_INTERVAL = 5.0


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


class Progress:
    """Counts of a running batch, shown on ``file`` (default stderr).

    Parameters
    ----------
    total : int
        Jobs in the batch.
    enabled : bool
        Show anything at all.
    file : text stream, optional
    """

    def __init__(self, total: int, enabled: bool = True, file: IO[str] | None = None):
        self.total, self.enabled = total, enabled
        self.file = file if file is not None else sys.stderr
        self.done = self.failed = self.skipped = 0
        self.computed_seconds = 0.0
        self.start = time.perf_counter()
        self._last = 0.0
        self._bar = None
        tty = bool(getattr(self.file, "isatty", lambda: False)())
        self._tty = tty
        if enabled and tty:
            try:
                from tqdm import tqdm
            except ImportError:
                pass
            else:
                self._bar = tqdm(total=total, file=self.file, unit="job", desc="fvf batch")

    def note(self, text: str) -> None:
        """Print one line (e.g. the dashboard address) without breaking the bar."""
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.write(text, file=self.file)
        else:
            print(text, file=self.file, flush=True)

    def eta(self) -> float | None:
        """Seconds left, from the pace of the jobs finished so far (None before the first)."""
        if self.done == 0:
            return None
        elapsed = time.perf_counter() - self.start
        return elapsed / self.done * (self.total - self.done)

    def line(self) -> str:
        """The plain progress line."""
        eta = self.eta()
        return (
            f"fvf batch: {self.done}/{self.total} done ({self.skipped} skipped, "
            f"{self.failed} failed), {_clock(time.perf_counter() - self.start)} elapsed"
            + ("" if eta is None else f", ETA {_clock(eta)}")
        )

    def update(self, row: dict[str, Any]) -> None:
        """Count one finished job (its summary row)."""
        self.done += 1
        self.failed += row.get("status") == "failed"
        self.skipped += row.get("status") == "skipped"
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.set_postfix(failed=self.failed, skipped=self.skipped, refresh=False)
            self._bar.update(1)
            return
        now = time.perf_counter()
        if self._tty:
            print("\r" + self.line(), end="", file=self.file, flush=True)
        elif now - self._last >= PLAIN_INTERVAL or self.done == self.total:
            print(self.line(), file=self.file, flush=True)
            self._last = now

    def close(self) -> None:
        """End the display (a final newline on a terminal)."""
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.close()
        elif self._tty:
            print(file=self.file, flush=True)
