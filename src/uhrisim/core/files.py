"""Reading the user's text files (behavior, mission files) with one-line errors."""

from __future__ import annotations

from pathlib import Path

from uhrisim.core.errors import AssetError

__all__ = ["read_text_file"]


def read_text_file(path: str | Path, kind: str) -> str:
    """The UTF-8 text of ``path``; a missing, unreadable or binary file is an AssetError
    naming the path and ``kind`` (e.g. "behavior file")."""
    p = Path(path)
    try:
        return p.read_text(encoding="utf-8")
    except OSError as e:
        raise AssetError(f"{p}: cannot read {kind} ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise AssetError(f"{p}: not a text file ({e.reason} at byte {e.start})") from None
