"""A progress display on stdout for time loops and adaptive loops (log messages and errors go to stderr)."""

from __future__ import annotations

import sys
import time


class Progress:
    """``Progress(total, label)``; ``update(done, text)``; ``close()``. On a terminal one line is redrawn;
    otherwise a line is printed at every 10 % so logs stay short. ``enabled=False`` prints nothing."""

    def __init__(self, total: float, label: str, enabled: bool = True, stream=None):
        self.total = max(float(total), 1e-300)
        self.label = label
        self.enabled = enabled
        self.stream = stream or sys.stdout
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.perf_counter()
        self._next_decile = 0.1

    def update(self, done: float, text: str = "") -> None:
        if not self.enabled:
            return
        frac = min(max(done / self.total, 0.0), 1.0)
        elapsed = time.perf_counter() - self.start
        bar = "#" * int(30 * frac) + "-" * (30 - int(30 * frac))
        line = f"{self.label} [{bar}] {100 * frac:5.1f}% {elapsed:6.1f}s {text}"
        if self.tty:
            self.stream.write("\r" + line[:150].ljust(150))
            self.stream.flush()
        elif frac + 1e-12 >= self._next_decile or frac >= 1.0:
            self.stream.write(line + "\n")
            self.stream.flush()
            while self._next_decile <= frac + 1e-12:
                self._next_decile += 0.1

    def close(self) -> None:
        if self.enabled and self.tty:
            self.stream.write("\n")
            self.stream.flush()
