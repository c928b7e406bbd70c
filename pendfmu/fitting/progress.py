"""The progress bars of a fit on a terminal: the global search's generations, then each
counted phase (the bootstrap's refits) with the time it has left."""

from __future__ import annotations

import sys
from collections.abc import Callable


class Progress:
    """A progress bar on stderr when it is a terminal (tqdm), silent otherwise."""

    def __init__(self, stage: str, total: int, enabled: bool | None = None):
        self.stage = stage
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.bar = self._bar(f"fit {stage}", total, "gen")

    def _bar(self, description: str, total: int, unit: str):
        if not self.enabled:
            return None
        from tqdm import tqdm

        return tqdm(total=total, desc=description, unit=unit, file=sys.stderr, leave=False)

    def phase(self, name: str, total: int, unit: str) -> Callable[[], None]:
        """A bar of its own for a phase of `total` counted steps (the bootstrap's refits):
        tqdm shows how many are done and, from their pace, the time left. Returns the
        call that counts one step."""
        self.close()
        self.bar = self._bar(f"fit {self.stage}: {name}", total, unit)
        bar = self.bar
        return (lambda: bar.update(1)) if bar is not None else (lambda: None)

    def __call__(self, message: str) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(message.split(":")[0])
            if message.startswith("global"):
                self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
