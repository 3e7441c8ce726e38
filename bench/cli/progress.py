"""Progress of long commands: a tqdm bar on stderr when stdout is a
terminal, else nothing but the command's own one-line-per-stage output (CI
logs stay short)."""
from __future__ import annotations

import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from tqdm import tqdm


def interactive() -> bool:
    """Whether stdout is a terminal (bars are drawn on stderr)."""
    return sys.stdout.isatty()


def bar(total: int | None, unit: str, desc: str = "") -> tqdm:
    """A progress bar on stderr (``total`` None: a counter)."""
    from tqdm import tqdm
    return tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, dynamic_ncols=True, leave=False,
                smoothing=0)  # average rate: the callers set the count directly
