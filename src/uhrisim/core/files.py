"""Reading the user's text files (scenarios, behavior and mission files) safely, and
writing the run's own files whole.

Only a regular file is opened, and only when it is not larger than a bound: a FIFO would
block the ``open`` for ever, ``/dev/zero`` never ends, a folder or a device is no text.
A file another process may read while it is written (a run's ``metrics.json``, which a
restarted sweep reads to skip finished runs) is written beside and renamed into place.
"""

from __future__ import annotations

import stat
from pathlib import Path

from uhrisim.core.errors import AssetError

__all__ = ["MAX_TEXT_BYTES", "NotATextFileError", "read_text_file", "regular_file_text",
           "write_text_whole"]

#: Largest text file read (bytes): far above any scenario, behavior or mission file.
MAX_TEXT_BYTES = 16 * 1024 * 1024

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


class NotATextFileError(OSError):
    """A path that is not a regular file of a readable size; ``strerror`` says why."""

    def __str__(self) -> str:
        return str(self.strerror)


def regular_file_text(path: str | Path, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of the regular file ``path`` of at most ``max_bytes``. Raises what
    ``Path.read_text`` raises (FileNotFoundError, OSError, UnicodeDecodeError), and
    :class:`NotATextFileError` (an OSError) for anything but such a file, before opening
    it."""
    p = Path(path)
    mode = p.stat().st_mode
    if not stat.S_ISREG(mode):
        what = next((name for test, name in _KINDS if test(mode)), "not a regular file")
        raise NotATextFileError(0, f"{what}, not a file to read")
    with p.open("rb") as f:
        data = f.read(max_bytes + 1)  # a file that grows while read is still bounded
    if len(data) > max_bytes:
        raise NotATextFileError(0, f"larger than {max_bytes // (1024 * 1024)} MiB")
    return data.decode("utf-8")


def read_text_file(path: str | Path, kind: str) -> str:
    """The UTF-8 text of ``path`` (:func:`regular_file_text`); a missing, unreadable,
    irregular, too large or binary file is an AssetError naming the path and ``kind``
    (e.g. "behavior file")."""
    p = Path(path)
    try:
        return regular_file_text(p)
    except OSError as e:
        raise AssetError(f"{p}: cannot read {kind} ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise AssetError(f"{p}: not a text file ({e.reason} at byte {e.start})") from None


def write_text_whole(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole: into ``.NAME.part`` beside it, then
    renamed over it, so that a reader, or a kill mid-write, finds the old file or the new
    one and never a part. On an error (a full disk) the part is removed and the error
    raised. Returns ``path``."""
    target = Path(path)
    part = target.with_name(f".{target.name}.part")
    try:
        part.write_text(text, encoding="utf-8")
        part.replace(target)
    except BaseException:
        part.unlink(missing_ok=True)
        raise
    return target
