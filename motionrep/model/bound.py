"""The requested bound on the L-infinity joint error (``--max-error``): a percentage of the character height or
a distance in file units, parsed one way, and said one way in every report (:meth:`MaxError.read_as`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..errors import ParameterError, naming

__all__ = ["MaxError", "parse_max_error"]


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

    def __str__(self) -> str:
        return f"{self.value:g}%" if self.percent else f"{self.value:g}"


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
