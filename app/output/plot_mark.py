"""The mark scripts/plot_results.py puts in its PNGs (a tEXt chunk), so that a run into the
folder removes the pictures of an earlier run's results and nothing else: a user's own
pictures (no mark) stay."""

from __future__ import annotations

import struct
from pathlib import Path

KEY = "Source"
VALUE = "scripts/plot_results.py (removed by the next run into this folder)"
METADATA = {KEY: VALUE}
"""`savefig(..., metadata=METADATA)` (PNG)."""

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_HEAD_BYTES = 65536  # the text chunks come before the image data (matplotlib, Pillow)


def is_marked(path: Path) -> bool:
    """Whether the PNG at `path` has the mark (reads its chunks up to the image data)."""
    try:
        with open(path, "rb") as fh:
            data = fh.read(_HEAD_BYTES)
    except OSError:
        return False
    if not data.startswith(_SIGNATURE):
        return False
    want = KEY.encode() + b"\x00" + VALUE.encode()
    i = len(_SIGNATURE)
    while i + 8 <= len(data):
        (n,) = struct.unpack(">I", data[i:i + 4])
        kind = data[i + 4:i + 8]
        if kind == b"IDAT" or kind == b"IEND":
            return False
        if kind == b"tEXt" and data[i + 8:i + 8 + n] == want:
            return True
        i += 12 + n
    return False


def is_marked_png(path: Path) -> bool:
    """Whether `path` is a PNG with the mark (an earlier run's picture, to remove)."""
    return path.suffix == ".png" and is_marked(path)
