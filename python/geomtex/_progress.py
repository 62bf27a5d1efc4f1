"""Progress shown to a person: a tqdm bar where someone watches (a terminal, a Jupyter kernel),
a few plain lines where the output goes to a log or a pipe, so a log gets one line per stage
(or per tenth of a job) instead of hundreds of carriage-return redraws.

The line form is written here because tqdm has no newline mode: on a non-terminal it still
redraws with a carriage return on every refresh.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

#: Share of a typical conversion's time per stage (measured on the bunny), for the bar.
STAGE_SPAN = {
    "geometry": (0, 2), "partition": (2, 75), "repair": (75, 77), "overlap": (77, 79),
    "frame": (79, 80), "resolution": (80, 90), "raster": (90, 96), "dilate": (96, 99), "done": (100, 100),
}


def watched(stream: TextIO | None = None) -> bool:
    """Whether a person watches the output live: a terminal, or a Jupyter kernel (tqdm.auto
    draws a widget there)."""
    stream = sys.stderr if stream is None else stream
    if "ipykernel" in sys.modules:
        return True
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


class Lines:
    """tqdm's calls used here (update, set_description, set_postfix_str, close), written as a
    line at each tenth of the total and at the end."""

    def __init__(self, total: int, desc: str, unit: str, stream: TextIO | None = None) -> None:
        self.total, self.desc, self.unit, self.n = total, desc, unit, 0
        self.stream = sys.stderr if stream is None else stream
        self.start, self.postfix, self._tenth = time.perf_counter(), "", 0
        self._say(f"{desc}: {total} {unit}s")

    def _say(self, text: str) -> None:
        print(text, file=self.stream, flush=True)

    def update(self, n: int = 1) -> None:
        self.n += n
        tenth = 10 * self.n // max(self.total, 1)
        if tenth > self._tenth and self.n < self.total:
            self._tenth = tenth
            self._say(f"{self.desc}: {self.n}/{self.total} {self.unit}s")

    def set_description(self, desc: str, refresh: bool = True) -> None:
        self.desc = desc

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        if text != self.postfix:
            self.postfix = text
            self._say(f"{self.desc}: {text}")

    def close(self) -> None:
        self._say(f"{self.desc}: {self.n}/{self.total} {self.unit}s in {time.perf_counter() - self.start:.1f} s")


def bar(total: int, desc: str, unit: str) -> Any:
    """A tqdm.auto bar where someone watches, else `Lines`."""
    if not watched():
        return Lines(total, desc, unit)
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit=unit)


class Stages:
    """`convert`'s progress callback(stage, fraction): a percent bar over the stages where someone
    watches (redrawn at most every 0.1 s, tqdm's own pace), else one line as each stage starts
    and one at the end."""

    def __init__(self, desc: str = "geomtex", stream: TextIO | None = None) -> None:
        self.desc, self.stage, self.start = desc, "", time.perf_counter()
        self.stream = sys.stderr if stream is None else stream
        self.bar: Any = None
        if watched(self.stream):
            from tqdm.auto import tqdm

            self.bar = tqdm(total=100, desc=desc, unit="%", leave=False, file=self.stream)

    def __call__(self, stage: str, fraction: float) -> None:
        if self.bar is None:
            if stage != self.stage and stage != "done":
                print(f"{self.desc}: {stage}", file=self.stream, flush=True)
            self.stage = stage
            return
        start, end = STAGE_SPAN.get(stage, (self.bar.n, self.bar.n))
        if stage != self.stage:
            self.stage = stage
            self.bar.set_description(f"{self.desc} {stage}", refresh=False)
        step = round(start + (end - start) * fraction) - self.bar.n
        if step > 0:
            self.bar.update(step)  # tqdm redraws at its own pace (mininterval), not on every call

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        else:
            print(f"{self.desc}: done in {time.perf_counter() - self.start:.1f} s", file=self.stream, flush=True)
