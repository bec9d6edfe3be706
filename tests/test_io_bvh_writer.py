"""The BVH writer's two paths for frame values, numpy (``_format_shortest``) and compiled (``motionrep.io._shortest``),
write the very same bytes: on hostile values (every magnitude, ties, powers of two and ten and their neighbours,
signed zeros, subnormals) and on every real clip, with the file's own angles and with angles computed from its
rotations (17-digit values)."""

from __future__ import annotations

import numpy as np
import pytest

from helpers import real_params
from motionrep import Motion
from motionrep.errors import ValidationError
from motionrep.io import read
from motionrep.io import _bvh
from motionrep.io._bvh import _format_shortest, channel_values
from motionrep.io._shortest import format_shortest


def _hostile(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = 20000
    bits = rng.integers(0, 2 ** 64, size=n, dtype=np.uint64).view(np.float64)
    parts = [bits[np.isfinite(bits)], rng.uniform(-400, 400, n), rng.normal(size=n) * 10.0 ** rng.integers(-8, 19, n),
             rng.uniform(0.00099, 0.0011, n), rng.integers(-2 ** 53, 2 ** 53, n) / 10.0 ** rng.integers(0, 20, n)]
    parts += [np.round(rng.uniform(-400, 400, 500), k) for k in range(18)]
    for k in range(-12, 19):
        for base in (10.0 ** k, 2.0 ** (3 * k)):
            parts.append(base * (1 + np.arange(-40, 41) * 2.0 ** -52))
    parts.append(np.array([0.0, -0.0, 5e-324, 2.2250738585072014e-308, 1e-4, 1e-3, 2.0 ** 52, 2.0 ** 52 + 0.5, 2.0 ** 53,
                           1.7976931348623157e308, 0.1, 0.3, 1 / 3, 123456789012345.6, 4503599627370495.5]))
    v = np.concatenate(parts)
    return np.concatenate([v, -v])


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("columns", [1, 7])
def test_compiled_and_numpy_writers_agree_on_hostile_values(seed, columns):
    v = _hostile(seed)
    v = v[:v.size // columns * columns].reshape(-1, columns)
    assert format_shortest(v) == _format_shortest(v)


def test_compiled_writer_is_shortest_repr_where_numpy_defers_to_it():
    # values with no fixed-point form of at most 17 decimals: the kernel computes repr's digits itself
    v = np.array([[1 / 3, -2 / 3, 0.1 + 0.2, 0.0012345678901234567, 123456.78901234567, 4503599627370495.5]])
    assert format_shortest(v) == (" ".join(map(repr, v[0].tolist())) + "\n").encode()


def test_the_writer_takes_the_compiled_path_for_large_clips(monkeypatch):
    v = np.random.default_rng(3).uniform(-180, 180, (50, 4))
    calls = []
    monkeypatch.setattr(_bvh, "COMPILED_WRITE_VALUES", 100)
    import motionrep.io._shortest as shortest

    real = shortest.format_shortest
    monkeypatch.setattr(shortest, "format_shortest", lambda x: calls.append(x.shape) or real(x))
    assert _bvh._shortest_text(v) == _format_shortest(v) and calls == [(50, 4)]


@pytest.mark.parametrize("path", real_params())
def test_compiled_and_numpy_writers_agree_on_every_real_clip(path):
    m = read(path)
    computed = Motion(m.skeleton, m.fps, m.root_translation, m.rotations, m.joint_translations)
    for motion in (m, computed):
        try:
            values = channel_values(motion)
        except ValidationError:  # rotations its channel layout cannot hold: not written at all
            continue
        if values.shape[1]:
            assert format_shortest(values) == _format_shortest(values)
