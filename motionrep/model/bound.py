"""The requested bound on the L-infinity joint error (``--max-error``): a percentage of the character height or
a distance in file units, parsed one way, and said one way in every report (:meth:`MaxError.read_as`).

The text of a bound is parsed in one place, :func:`parse_max_error`, at the door: the command line's options and
the public functions that take a string (:meth:`motionrep.pipeline.compress.Pipeline.build`).  From there on a
:class:`MaxError` travels (to worker processes and Dask workers too, pickled as it is), and a compressed clip
stores its bound structured (:class:`StoredBound`: the kind, the value and the distance in file units it
resolved to), so nothing reads the bound back from text except the reader of version-1 ``.mrc`` files.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..errors import ParameterError, naming

__all__ = ["MaxError", "StoredBound", "parse_max_error", "BOUND_KINDS"]

#: The kinds of a stored bound (:attr:`StoredBound.kind`).
BOUND_KINDS = ("percent", "distance", "none")


@dataclass(frozen=True)
class MaxError:
    """A requested L-infinity bound: a percentage of the character height, or a distance in file units."""

    value: float
    percent: bool

    def bound(self, height: float) -> float:
        """The bound in file units for a character of ``height``.

        Raises:
            ParameterError: for a percentage of a character whose height is 0.
        """
        if not self.percent:
            return self.value
        if height <= 0:
            raise naming(ParameterError("the character height is 0, so a bound in % of it means nothing; give "
                                        "max_error as a distance in file units"), "max_error")
        return self.value / 100.0 * height

    def read_as(self, height: float, units: str | None) -> str:
        """How this bound was read, in the one phrase every report uses: ``2% of height 152 = 3.04 cm``, or
        ``1.5 cm = 0.99% of height (read as a distance in file units; write 1.5% for a percentage)``.

        Raises:
            ParameterError: for a percentage of a character whose height is 0.
        """
        unit = units or "file units"
        bound = self.bound(height)
        if self.percent:
            return f"{self} of height {height:.4g} = {bound:.4g} {unit}"
        pct = f" = {100 * bound / height:.3g}% of height" if height > 0 else ""
        return f"{bound:.4g} {unit}{pct} (read as a distance in file units; write {self}% for a percentage)"

    @property
    def kind(self) -> str:
        """``"percent"`` (of the character height) or ``"distance"`` (in file units)."""
        return "percent" if self.percent else "distance"

    def __str__(self) -> str:
        """The bound as ``--max-error`` takes it (``2%``, ``1.5``), every digit kept: it parses back to this very
        bound (the shortest text that does, as ``repr`` of a float, without a trailing ``.0``)."""
        text = repr(float(self.value))
        if text.endswith(".0"):
            text = text[:-2]
        return f"{text}%" if self.percent else text


@dataclass(frozen=True)
class StoredBound:
    """The bound a clip was compressed within, as its ``.mrc`` container states it (``specs/container.md``).

    Attributes:
        asked: the requested bound, or None when the clip was compressed without one (``--max-error none``).
        distance: the bound in file units it resolved to for this clip (None without a bound).
    """

    asked: MaxError | None
    distance: float | None

    @property
    def kind(self) -> str:
        """``"percent"``, ``"distance"`` or ``"none"`` (:data:`BOUND_KINDS`)."""
        return "none" if self.asked is None else self.asked.kind

    def read_as(self, height: float, units: str | None) -> str | None:
        """:meth:`MaxError.read_as` of the requested bound (None without one)."""
        return None if self.asked is None else self.asked.read_as(height, units)

    def as_json(self) -> dict[str, object]:
        """``{"kind": "percent", "value": 2.0, "distance": 3.04}``; ``{"kind": "none", "value": null, "distance":
        null}`` without a bound."""
        return {"kind": self.kind, "value": None if self.asked is None else float(self.asked.value),
                "distance": None if self.distance is None else float(self.distance)}

    @classmethod
    def from_json(cls, obj: object) -> "StoredBound":
        """The bound :meth:`as_json` wrote, from untrusted JSON.

        Raises:
            ValueError: naming the key that is not what :meth:`as_json` writes.
        """
        if not isinstance(obj, dict):
            raise ValueError("must be an object with 'kind', 'value' and 'distance'")
        kind = obj.get("kind")
        if kind not in BOUND_KINDS:
            raise ValueError(f"'kind' is {str(kind)[:40]!r}, not one of {', '.join(BOUND_KINDS)}")
        numbers = {}
        for key in ("value", "distance"):
            v = obj.get(key)
            if kind == "none":
                if v is not None:
                    raise ValueError(f"'{key}' must be null for a bound of kind 'none'")
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0 or \
                    (key == "value" and v == 0):
                raise ValueError(f"'{key}' must be a finite number {'> 0' if key == 'value' else '>= 0'}, got "
                                 f"{str(v)[:40]}")
            numbers[key] = float(v)
        if kind == "none":
            return cls(None, None)
        return cls(MaxError(numbers["value"], kind == "percent"), numbers["distance"])


_MAX_ERROR_RE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(%?)\s*$")


def parse_max_error(value: str | float | MaxError | None) -> MaxError | None:
    """Parse ``"2%"`` (percent of character height), ``"3.5"`` (file units), ``"none"`` or None (no bound).

    Raises:
        ParameterError: for anything else, or a bound that is not > 0.
    """
    if value is None or isinstance(value, MaxError):
        return value
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        number, percent = float(value), False
    else:
        text = str(value)
        if text.strip().lower() in ("none", "off", ""):
            return None
        m = _MAX_ERROR_RE.match(text)
        if not m:
            raise naming(ParameterError(f"invalid max_error {text!r}: give a percentage of the character height "
                                        "('2%'), a distance in file units ('1.5'), or 'none'"), "max_error")
        number, percent = float(m.group(1)), bool(m.group(2))
    if not math.isfinite(number) or number <= 0:
        raise naming(ParameterError(f"max_error must be > 0, got {value!r}"), "max_error")
    return MaxError(number, percent)
