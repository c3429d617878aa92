"""The command line's progress display: a tqdm bar (frames per second, ETA) on a terminal, else a
plain line at most once a second and one at the end."""
from __future__ import annotations

import sys
import time

PLAIN_INTERVAL_S = 1.0


class ProgressDisplay:
    """A ``progress`` callback for :func:`caustica.batch.job.run_job` that writes to ``stream``."""

    def __init__(self, stream=None):
        self.stream = sys.stderr if stream is None else stream
        self.bar = None
        self._last = 0.0
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def __call__(self, state) -> None:
        if self._tty:
            self._update_bar(state)
            return
        now = time.monotonic()
        if now - self._last >= PLAIN_INTERVAL_S or state.done + state.failed >= state.total:
            self._last = now
            eta = f", ETA {state.eta_s:.0f} s" if state.eta_s is not None else ""
            failed = f", {state.failed} failed" if state.failed else ""
            print(f"frame {state.done + state.failed}/{state.total} ({state.rate:.2f} frames/s{eta}{failed})",
                  file=self.stream, flush=True)

    def _update_bar(self, state) -> None:
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=state.total, initial=state.skipped, unit="frame", file=self.stream,
                            dynamic_ncols=True, desc="batch")
        self.bar.update(1)
        if state.failed:
            self.bar.set_postfix(failed=state.failed, refresh=False)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
