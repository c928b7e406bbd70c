"""The progress bar of a fit on a terminal."""

from __future__ import annotations

import sys


class Progress:
    """A progress bar on stderr when it is a terminal (tqdm), silent otherwise."""

    def __init__(self, stage: str, total: int, enabled: bool | None = None):
        enabled = sys.stderr.isatty() if enabled is None else enabled
        self.bar = None
        if enabled:
            from tqdm import tqdm

            self.bar = tqdm(total=total, desc=f"fit {stage}", unit="gen", file=sys.stderr, leave=False)

    def __call__(self, message: str) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(message.split(":")[0])
            if message.startswith("global"):
                self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
