"""The text files a user writes (campaign and model TOML), read with a size limit.

Parsing TOML takes time in proportion to the file's size; a multi-GB file
(a generated list gone wrong) would take hours before its first error, so a file over
:data:`MAX_TEXT_BYTES` is refused unread.
"""
from __future__ import annotations

from pathlib import Path

from .errors import UserError

MAX_TEXT_BYTES = 4 * 2**20  # 4 MiB: a campaign lists tests, a model its nodes and elements, not data


def read_input_text(path: Path, what: str, error: type[UserError] = UserError) -> str:
    """UTF-8 text of ``path`` (``what``: "campaign file", "model file"); raises
    ``error`` naming the file when it cannot be read, is over
    :data:`MAX_TEXT_BYTES` or is not UTF-8."""
    try:
        with path.open("rb") as f:
            data = f.read(MAX_TEXT_BYTES + 1)
    except OSError as err:
        raise error(f"cannot read {what}: {err.strerror}", field=str(path)) from None
    if len(data) > MAX_TEXT_BYTES:
        raise error(f"{what} of {path.stat().st_size} bytes, over the limit of {MAX_TEXT_BYTES} (4 MiB): a "
                    f"{what} describes a set-up, not data", field=path.name)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise error(f"{what} is not UTF-8 text (byte {err.start}: {data[err.start:err.start + 1]!r})",
                    field=path.name) from None
