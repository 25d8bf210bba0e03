"""A minimal progress bar on stderr; silent when stderr is not a terminal (CI logs, make)."""

from __future__ import annotations

import sys
import time


class ProgressBar:
    def __init__(
        self,
        total: int,
        description: str = "",
        stream=None,
        enabled=None,
        width: int = 30,
    ):
        self.total = max(int(total), 0)
        self.description = description
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = enabled
        self.width = width
        self.done = 0
        self.started = time.monotonic()

    def update(self, n: int = 1) -> None:
        self.done += n
        if not self.enabled or self.total == 0:
            return
        fraction = min(self.done / self.total, 1.0)
        filled = int(round(fraction * self.width))
        elapsed = time.monotonic() - self.started
        self.stream.write(
            f"\r{self.description} [{'#' * filled}{'.' * (self.width - filled)}] "
            f"{self.done}/{self.total} {elapsed:6.1f} s"
        )
        self.stream.flush()

    def close(self) -> None:
        if self.enabled and self.total:
            self.stream.write("\n")
            self.stream.flush()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
