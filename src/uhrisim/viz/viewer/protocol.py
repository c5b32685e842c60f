"""Wire protocol of the web viewer: commands from the page, JSON encoding of frames.

Everything here is pure (no sockets, no threads) so it can be unit-tested directly.

Page → server messages (JSON text over the websocket)::

    {"type": "command", "kind": "pause"|"resume"|"speed"|"step"|"post"|"select",
     "agent": str|null, "name": str|null, "value": float|str|null}
    {"type": "seek", "t": float}            # replay only: jump to time t (s)

Server → page messages::

    {"type": "hello", "mode": "live"|"replay", "scene": {...}, "buttons": [...],
     "max_fps": float, "history": {agent: [[t, north, east, depth], ...]},
     "replay": {"t_start": float, "t_end": float} | null}
    {"type": "frame", "seq": int, ...the published frame without "sonar"...}
    {"type": "sonar", "seq": int, "agent": str, "sensor": str, "t": float,
     "fan_png_b64": str, "fov_deg": float, "max_range": float,
     "marks": [{"id": int, "kind": "diver"|"track"|"tentative", "range": m,
                "bearing_deg": deg (> 0 starboard)}, ...]}   # sonar perception tracks
    {"type": "camera", "seq": int, "agent": str, "sensor": str, "t": float,
     "png_b64": str}

Units and frames as in docs/conventions.md and docs/viewer.md: positions NED metres,
headings compass degrees.
"""

from __future__ import annotations

import base64
import json
import logging
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from uhrisim.core.errors import ConfigError

log = logging.getLogger(__name__)

CommandKind = Literal["pause", "resume", "speed", "step", "post", "select"]
COMMAND_KINDS: frozenset[str] = frozenset({"pause", "resume", "speed", "step", "post", "select"})

#: Speed factors offered by the page; ``math.inf`` means "as fast as possible".
SPEED_CHOICES: tuple[float, ...] = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, math.inf)


@dataclass(frozen=True)
class Command:
    """A user action coming from the page, to be applied by the simulation loop.

    kind:
        ``"pause"`` / ``"resume"``: stop / restart simulation time.
        ``"step"``: while paused, advance by ``value`` ticks (default 1; ``value`` is None
        when the page did not say).
        ``"speed"``: set the real-time factor to ``value`` (float > 0; ``math.inf`` means
        run as fast as possible).
        ``"post"``: post variable ``name`` = ``value`` (str) into the community ``agent``
        (a scenario button, like pMarineViewer's).
        ``"select"``: the user selected agent ``agent`` on the map (e.g. to choose whose
        sonar is shown).
    """

    kind: CommandKind
    agent: str | None = None
    name: str | None = None
    value: float | str | None = None


def _opt_str(msg: dict[str, Any], key: str, where: str) -> str | None:
    v = msg.get(key)
    if v is None:
        return None
    if not isinstance(v, str) or not v or len(v) > 256:
        raise ConfigError(f"{key!r} must be a non-empty string of at most 256 chars", where)
    return v


def parse_command(msg: Any) -> Command:
    """Validate one decoded page message of type ``"command"`` into a :class:`Command`.

    Raises ConfigError (with ``where="viewer command"``) on anything malformed; the server
    logs and drops such messages, it never lets them reach the simulation.
    """
    where = "viewer command"
    if not isinstance(msg, dict):
        raise ConfigError("message must be a JSON object", where)
    kind = msg.get("kind")
    if kind not in COMMAND_KINDS:
        raise ConfigError(f"unknown command kind {kind!r}", where)
    agent = _opt_str(msg, "agent", where)
    name = _opt_str(msg, "name", where)
    raw = msg.get("value")
    value: float | str | None
    if kind == "speed":
        if raw == "max" or raw == "inf":
            value = math.inf
        else:
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise ConfigError(
                    f"speed value must be a number or 'max', got {raw!r}", where
                ) from None
            if not value > 0.0:
                raise ConfigError(f"speed value must be > 0, got {value}", where)
    elif kind == "step":
        if raw is None:
            value = None
        else:
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise ConfigError(
                    f"step value must be a number of ticks, got {raw!r}", where
                ) from None
            if not (math.isfinite(value) and value >= 1 and value == int(value)):
                raise ConfigError(f"step value must be a whole number >= 1, got {raw!r}", where)
    elif kind == "post":
        if agent is None or name is None:
            raise ConfigError("post needs 'agent' and 'name'", where)
        if raw is None:
            raise ConfigError("post needs a 'value'", where)
        if isinstance(raw, bool):
            value = "true" if raw else "false"
        elif isinstance(raw, (int, float)):
            value = float(raw)
        elif isinstance(raw, str) and len(raw) <= 4096:
            value = raw
        else:
            raise ConfigError("post value must be a string or a number", where)
    elif kind == "select":
        if agent is None:
            raise ConfigError("select needs 'agent'", where)
        value = None
    else:  # pause / resume
        value = None
    return Command(kind=kind, agent=agent, name=name, value=value)


def validate_buttons(buttons: list[dict[str, Any]]) -> list[dict[str, str]]:
    """Check scenario buttons ``[{"label", "agent", "var", "value"}]``; return clean copies."""
    out: list[dict[str, str]] = []
    for i, b in enumerate(buttons):
        where = f"viewer buttons[{i}]"
        if not isinstance(b, dict):
            raise ConfigError("button must be a mapping", where)
        missing = [k for k in ("label", "agent", "var", "value") if k not in b]
        if missing:
            raise ConfigError(f"button lacks {', '.join(missing)}", where)
        out.append({k: str(b[k]) for k in ("label", "agent", "var", "value")})
    return out


def _default(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (tuple, set, frozenset)):
        return list(o)
    raise TypeError(f"cannot encode {type(o).__name__} in a viewer frame")


def _sanitize(o: Any) -> Any:
    """Replace non-finite floats (which JSON.parse rejects) by None, recursively."""
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _sanitize(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_sanitize(v) for v in o]
    if isinstance(o, np.ndarray):
        return _sanitize(o.tolist())
    if isinstance(o, np.generic):
        return _sanitize(o.item())
    return o


def encode_json(obj: Any) -> str:
    """JSON text the browser can parse: numpy scalars/arrays become lists, NaN/inf → null."""
    text = json.dumps(obj, default=_default, separators=(",", ":"))
    if "NaN" in text or "Infinity" in text:
        text = json.dumps(_sanitize(obj), default=_default, separators=(",", ":"))
    return text


def encode_png_b64(image: np.ndarray, max_px: int | None = None) -> str:
    """Base64 PNG of an 8-bit image (H×W grey, H×W×3 RGB or H×W×4 RGBA).

    ``max_px``: if the image's larger side exceeds it, it is first shrunk (area
    averaging, aspect kept) so that side is ``max_px`` pixels — a display copy.
    """
    import cv2

    img = np.asarray(image)
    if max_px is not None and max(img.shape[:2]) > max_px:
        k = max_px / max(img.shape[:2])
        size = (max(1, round(img.shape[1] * k)), max(1, round(img.shape[0] * k)))
        img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
    if img.dtype != np.uint8:
        if np.issubdtype(img.dtype, np.floating):
            img = np.clip(np.nan_to_num(img) * 255.0, 0, 255).astype(np.uint8)
        else:
            img = np.clip(img, 0, 255).astype(np.uint8)
    if img.ndim == 3 and img.shape[2] == 3:
        img = img[:, :, ::-1]  # RGB → BGR for OpenCV
    elif img.ndim == 3 and img.shape[2] == 4:
        img = img[:, :, [2, 1, 0, 3]]
    elif img.ndim != 2:
        raise ConfigError(f"sonar fan image must be HxW or HxWx3/4, got shape {img.shape}",
                          "viewer frame sonar")
    # fast deflate with run-length matching: ~2x faster than the default on speckle
    params = [cv2.IMWRITE_PNG_COMPRESSION, 1, cv2.IMWRITE_PNG_STRATEGY,
              cv2.IMWRITE_PNG_STRATEGY_RLE]
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(img), params)
    if not ok:  # pragma: no cover - OpenCV fails only on invalid input
        raise ConfigError("PNG encoding failed", "viewer frame sonar")
    return base64.b64encode(buf.tobytes()).decode("ascii")
