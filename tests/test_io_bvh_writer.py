"""The BVH writer's frame values (``motionrep.io._shortest``, compiled C): each value as the shortest fixed-point
decimal of at most 17 decimals that reads back to the same double, else as ``repr`` writes it.  Checked against that
rule written out in plain Python (``reference``: the same IEEE operations, so the same bytes on any CPU) on hostile
values (every magnitude, ties, powers of two and ten and their neighbours, signed zeros, subnormals, random bit
patterns) and on every real clip, with the file's own angles and with angles computed from its rotations (17-digit
values); and every value written reads back as the very same double."""

from __future__ import annotations

import math

import numpy as np
import pytest

from helpers import real_params
from motionrep import Motion
from motionrep.errors import ValidationError
from motionrep.io import read
from motionrep.io._bvh import channel_values
from motionrep.io._numbers import parse_numbers
from motionrep.io._shortest import format_shortest


def reference_value(v: float) -> str:
    """The fewest decimals ``k`` (0-17) with ``m = round(|v| 10**k) < 2**53`` and ``m / 10**k == |v|`` (one correctly
    rounded division of exact doubles), written in fixed point (``-`` for a negative value, ``-0`` too); else
    ``repr``."""
    a = abs(v)
    small = min(a, 2.0 ** 53)
    for k in range(18):
        p = 10.0 ** k
        cand = float(round(small * p))  # round half to even, as rint
        if cand < 2.0 ** 53 and cand / p == a:
            whole, frac = divmod(int(cand), 10 ** k)
            sign = "-" if math.copysign(1.0, v) < 0 else ""
            return sign + str(whole) + ("." + str(frac).zfill(k) if k else "")
    return repr(v)


def reference(values: np.ndarray) -> bytes:
    return "".join(" ".join(map(reference_value, row)) + "\n" for row in values.tolist()).encode()


def _hostile(seed: int, n: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    bits = rng.integers(0, 2 ** 64, size=n, dtype=np.uint64).view(np.float64)
    parts = [bits[np.isfinite(bits)], rng.uniform(-400, 400, n), rng.normal(size=n) * 10.0 ** rng.integers(-8, 19, n),
             rng.uniform(0.00099, 0.0011, n), rng.integers(-2 ** 53, 2 ** 53, n) / 10.0 ** rng.integers(0, 20, n)]
    parts += [np.round(rng.uniform(-400, 400, n // 40), k) for k in range(18)]
    for k in range(-12, 19):
        for base in (10.0 ** k, 2.0 ** (3 * k)):
            parts.append(base * (1 + np.arange(-20, 21) * 2.0 ** -52))
    parts.append(np.array([0.0, -0.0, 5e-324, 2.2250738585072014e-308, 1e-4, 1e-3, 2.0 ** 52, 2.0 ** 52 + 0.5, 2.0 ** 53,
                           1.7976931348623157e308, 0.1, 0.3, 1 / 3, 123456789012345.6, 4503599627370495.5]))
    v = np.concatenate(parts)
    return np.concatenate([v, -v])


def reads_back(text: bytes, values: np.ndarray) -> bool:
    back, bad = parse_numbers(text)
    return bad is None and back.view(np.uint64).tolist() == values.ravel().view(np.uint64).tolist()


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("columns", [1, 7])
def test_hostile_values(seed, columns):
    v = _hostile(seed, 2000)
    v = v[:v.size // columns * columns].reshape(-1, columns)
    text = format_shortest(v)
    assert text == reference(v)
    assert reads_back(text, v)


@pytest.mark.slow
def test_many_hostile_values():
    v = _hostile(7, 40000).reshape(-1, 2)
    text = format_shortest(v)
    assert text == reference(v) and reads_back(text, v)


def test_values_with_no_short_decimal_are_repr():
    # values with no fixed-point form of at most 17 decimals: the kernel computes repr's digits itself
    v = np.array([[1 / 3, -2 / 3, 0.1 + 0.2, 0.0012345678901234567, 123456.78901234567, 4503599627370495.5]])
    assert format_shortest(v) == (" ".join(map(repr, v[0].tolist())) + "\n").encode()
    # more values left to Python's repr than the first pass records (a second pass), spliced in their places
    many = np.tile([[1.2345e20, 0.5, -7e-30]], (3000, 1))
    assert format_shortest(many) == reference(many)


@pytest.mark.parametrize("path", real_params())
def test_every_real_clip(path):
    """Both the file's own angles and angles computed from the rotations (17-digit values): every value reads back;
    the first and last 50 frames byte for byte against the reference."""
    m = read(path)
    computed = Motion(m.skeleton, m.fps, m.root_translation, m.rotations, m.joint_translations)
    for motion in (m, computed):
        try:
            values = channel_values(motion)
        except ValidationError:  # rotations its channel layout cannot hold: not written at all
            continue
        if not values.shape[1]:
            continue
        text = format_shortest(values)
        assert reads_back(text, values)
        lines = text.splitlines(keepends=True)
        assert b"".join(lines[:50] + lines[-50:]) == reference(np.concatenate([values[:50], values[-50:]]))
