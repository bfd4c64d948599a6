"""A progress display for long work: a tqdm bar on a terminal (when tqdm is installed), a one-line
counter without it, one line per 10 % in a log when asked for, and nothing otherwise (CI logs)."""

from __future__ import annotations

import sys
import time

__all__ = ["Progress"]


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class Progress:
    """Counts ``total`` units of work.

    Args:
        total: units to do.
        progress: ``True`` always show (lines in a non-terminal), ``False`` never, ``None`` only
            on a terminal.
        label: what is counted, shown first (``"sweep"``, ``"simulate"``).
        unit: the unit's short name (``"pt"``, ``"s"``).
    """

    def __init__(self, total: float, progress: bool | None, label: str = "work", unit: str = "it") -> None:
        self.total, self.done, self.failed = total, 0, 0
        self.label, self.unit = label, unit
        self.start = time.perf_counter()
        self.stream = sys.stderr
        tty = _isatty(self.stream)
        self.mode, self.bar, self.tenths = None, None, 0
        if progress is False or (progress is None and not tty):
            return
        self.mode = "counter" if tty else "lines"
        if tty and total > 0:
            try:
                from tqdm import tqdm
            except ImportError:
                pass
            else:
                self.mode = "tqdm"
                self.bar = tqdm(total=total, desc=label, unit=unit, file=self.stream, dynamic_ncols=True)

    @property
    def enabled(self) -> bool:
        return self.mode is not None

    def note(self, text: str) -> None:
        """A line of its own (when the display is on)."""
        if self.enabled:
            print(text, file=self.stream, flush=True)

    def update(self, amount: float = 1, failed: bool = False) -> None:
        self.done += amount
        self.failed += bool(failed)
        if self.mode == "tqdm":
            self.bar.update(amount)
            if self.failed:
                self.bar.set_postfix(failed=self.failed, refresh=False)
        elif self.mode == "counter":
            failures = f", {self.failed} failed" if self.failed else ""
            self.stream.write(f"\r{self.label}: {self.done:g}/{self.total:g} {self.unit}{failures}")
            self.stream.flush()
        elif self.mode == "lines":
            tenths = int(10 * self.done / self.total)
            if tenths > self.tenths:
                self.tenths = tenths
                failures = f", {self.failed} failed" if self.failed else ""
                share = 100 * self.done / self.total
                self.note(
                    f"{self.label}: {self.done:g}/{self.total:g} {self.unit} ({share:.0f}%){failures}, "
                    f"{time.perf_counter() - self.start:.1f} s"
                )

    def close(self) -> None:
        if self.mode == "tqdm" and self.bar is not None:
            self.bar.close()
        elif self.mode == "counter" and self.done:
            self.stream.write("\n")
            self.stream.flush()
