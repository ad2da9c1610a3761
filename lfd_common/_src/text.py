"""What people read while a run goes on and after it: progress bars and markdown tables."""
from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from typing import Any

from tqdm.auto import tqdm

PROGRESS_OFF_ENV = "LFD_NO_PROGRESS"


def progress(iterable: Iterable | None = None, desc: str = "", total: int | None = None, **kwargs) -> tqdm:
    """A tqdm progress bar on stderr for a long loop.

    Args:
        iterable: what to iterate over (None for a bar updated by hand).
        desc: the bar's label.
        total: the number of items, when `iterable` has no length.
        **kwargs: passed to `tqdm`.

    Returns:
        The bar (iterate over it); silent when the environment variable `LFD_NO_PROGRESS` is set to
        anything but "".
    """
    return tqdm(iterable, desc=desc, total=total, disable=bool(os.environ.get(PROGRESS_OFF_ENV)),
                dynamic_ncols=True, **kwargs)


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """A GitHub-flavoured markdown table.

    Args:
        header: the column titles.
        rows: the rows, one value per column; floats are shown with 4 significant digits.

    Returns:
        The table, lines joined by newlines (no trailing newline).
    """
    def cell(v: Any) -> str:
        return f"{v:.4g}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return "\n".join(lines)
