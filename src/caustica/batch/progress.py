"""The command line's progress display of a batch, under :mod:`caustica.progress`'s policy: a tqdm bar
(frames per second, ETA) on a terminal, else a plain line each tenth of the frames (or every few seconds)
and one at the end; nothing when quiet."""
from __future__ import annotations

from ..progress import progress


class ProgressDisplay:
    """A ``progress`` callback for :func:`caustica.batch.job.run_job` that writes to ``stream`` (default stderr)."""

    def __init__(self, stream=None):
        self.stream = stream
        self.bar = None
        self.state = None

    def __call__(self, state) -> None:
        self.state = state
        if self.bar is None:
            self.bar = progress(state.total, "batch", unit="frame", enabled=True, stream=self.stream,
                                initial=state.skipped, leave=True, delay=0.0, line=self._line)
        self.bar.update(1)
        if state.failed:
            self.bar.set_postfix_str(f"failed={state.failed}")

    def _line(self) -> str:
        state = self.state
        eta = f", ETA {state.eta_s:.0f} s" if state.eta_s is not None else ""
        failed = f", {state.failed} failed" if state.failed else ""
        return f"frame {state.done + state.failed}/{state.total} ({state.rate:.2f} frames/s{eta}{failed})"

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
