"""A progress bar for long files: reading a trajectory table, replaying it in fast time."""

from __future__ import annotations

import sys


def progress_bar(enabled: bool | None, label: str, total: float):
    """A rich progress bar on stderr (enabled None: only when stderr is a terminal), or None."""
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        return None, None
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeRemainingColumn

    bar = Progress(TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(), TimeRemainingColumn(),
                   console=Console(stderr=True))
    bar.start()
    return bar, bar.add_task(label, total=total)
