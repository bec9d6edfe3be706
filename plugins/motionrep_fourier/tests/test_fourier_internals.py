"""The Fourier plugin's own machinery: the network and its warm start, the L-BFGS optimiser, the frequency
choice, and the windowed payload (version 2).  The codecs' behaviour through the core is tested in
``tests/test_codecs.py``."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from motionrep.pipeline.compress import compress_motion, decompress
from motionrep.errors import BoundNotMetError, ParameterError
from motionrep.pipeline.evaluate import max_joint_error
from motionrep.model.synthetic import chain_skeleton, synthetic_motion

FAST_FOURIER = {"iters": 200}


def edges_of(container) -> list[int]:
    """The window edges of a Fourier payload (quantised or float), ``[0, F - 1]`` for one network."""
    from motionrep_fourier._packed import unpack as unpack_data

    arrays = container.arrays
    if "data" in arrays:
        return unpack_data(arrays["data"])[0].tolist()
    return arrays["edges"].tolist() if "edges" in arrays else [0, container.num_frames - 1]


# ---------------------------------------------------------------------------------------------------------------
# Fourier codecs: the network, warm start, frequency choice
# ---------------------------------------------------------------------------------------------------------------
def test_warm_start_growth_leaves_the_function_unchanged():
    from motionrep_fourier._trainnet import grow as _grow, initial_net as _initial

    gen = np.random.default_rng(3)
    net = _initial(gen, 5, 10, 7)
    x = gen.random((40, 5), dtype=np.float32)
    before = net.forward(x)
    grown = _grow(net, gen)
    assert (grown.inputs, grown.hidden) == (7, 14)
    x_new = np.concatenate([x, gen.random((40, 2), dtype=np.float32) * 2 - 1], axis=1)  # any new inputs
    # The new inputs enter through zero weights and the new hidden units through zero output weights, so the
    # function is unchanged in exact arithmetic. In float32 the wider matrix products may be summed in another
    # order by the CPU's BLAS kernel (seen: one ulp apart on AMD EPYC, bit-identical on Intel), so the outputs
    # are compared within a few float32 ulps of values of order 1, not bit for bit.
    np.testing.assert_allclose(grown.forward(x_new), before, rtol=0, atol=4 * np.finfo(np.float32).eps)


@pytest.mark.parametrize("decay", [None, 1e-2])
def test_variable_projection_loss_and_gradient(decay):
    """The loss of the first two layers with the output layer solved by ridge least squares, plus the weight decay
    of every layer's weights (not the biases): its gradient matches central differences (float64 network), and
    the solved output layer is the least-squares one."""
    from motionrep_fourier._trainnet import RIDGE, Net as _Net, grow as _grow, initial_net as _initial

    gen = np.random.default_rng(4)
    grown = _grow(_initial(gen, 3, 6, 5), gen)
    decay = RIDGE if decay is None else decay
    net = _Net(grown.inputs, grown.hidden, grown.width, grown.theta, dtype=np.float64, decay=decay)
    x, z = gen.random((25, 5)), gen.random((25, 5))
    theta = net.theta[:net.nonlinear_size].astype(np.float64)
    value, grad = net.loss_and_grad(x, z, theta)
    step = 1e-6
    numeric = np.array([(net.loss_and_grad(x, z, theta + step * e)[0] - net.loss_and_grad(x, z, theta - step * e)[0])
                        / (2 * step) for e in np.eye(theta.size)])
    np.testing.assert_allclose(grad, numeric, rtol=1e-5, atol=1e-9)
    full = net.weights_at(x, z, theta)
    out = net.forward(x, full)
    W0, _, W1, _, W2, _ = net.views(full)
    hidden = np.sum(W0 ** 2) + np.sum(W1 ** 2)
    assert value == pytest.approx(np.mean((out - z) ** 2) + decay * (hidden + np.sum(W2 ** 2)), rel=1e-12)
    # no other output layer does better on the same hidden activations
    for _ in range(5):
        other = full.copy()
        other[net.nonlinear_size:] += 1e-3 * gen.standard_normal(other.size - net.nonlinear_size)
        W2o = net.views(other)[4]
        assert np.mean((net.forward(x, other) - z) ** 2) + decay * (hidden + np.sum(W2o ** 2)) > value
    assert _grow(net, gen).decay == decay


def _two_loop_direction(g, pairs):
    """The classic L-BFGS two-loop recursion (Nocedal and Wright, algorithm 7.4), the reference for the compact
    form: ``-H g`` with ``H0 = (s.y / y.y) I`` from the newest pair."""
    q, alphas = -g.copy(), []
    for s, y in reversed(pairs):
        a = (s @ q) / (s @ y)
        q -= a * y
        alphas.append(a)
    s, y = pairs[-1]
    q *= (s @ y) / (y @ y)
    for (s, y), a in zip(pairs, reversed(alphas)):
        q += (a - (y @ q) / (s @ y)) * s
    return q


def test_lbfgs_compact_direction_is_the_two_loop_recursion_and_converges():
    from motionrep_fourier._lbfgs import LBFGS as _LBFGS

    rng = np.random.default_rng(0)
    n = 40
    A = rng.normal(size=(n, n))
    H = A @ A.T + 0.1 * np.eye(n)  # condition number ~ 1e3
    optimizer = _LBFGS(lambda x: (0.5 * x @ H @ x, H @ x), rng.normal(size=n), history=5)
    optimizer.run(12)  # the memory is full and has wrapped around
    m = optimizer.m
    pairs = [(optimizer._SY[i].astype(np.float64), optimizer._SY[m + i].astype(np.float64))
             for i in optimizer._o]
    assert len(pairs) == 5
    reference = _two_loop_direction(optimizer.g, pairs)
    assert np.allclose(optimizer._direction(), reference, rtol=1e-5, atol=1e-6 * np.abs(reference).max())
    f0 = optimizer.f
    optimizer.run(500)
    assert optimizer.f < 1e-12 * f0
    assert optimizer.evaluations < 1.3 * 512  # step 1 is accepted almost always: about one evaluation per step


def test_line_search_steps_through_the_float32_noise_of_the_loss():
    """Near a minimum the loss values carry rounding noise larger than the possible decrease; the line search
    must still move to where the slope flattens instead of declaring convergence (the gradient is accurate)."""
    from motionrep_fourier._lbfgs import LBFGS as _LBFGS

    rng = np.random.default_rng(1)
    scales = np.geomspace(1.0, 1e4, 20)  # very uneven curvature

    def noisy(x):
        value = 1.0 + 0.5 * np.sum(scales * x ** 2)
        return value * (1.0 + 3e-6 * rng.uniform(-1, 1)), scales * x  # float32-like noise on the value only

    x0 = 1e-3 / np.sqrt(scales)  # every term of the loss is already below its noise
    optimizer = _LBFGS(noisy, x0)
    optimizer.run(60)
    assert not optimizer.converged  # a line search that trusts the values alone stops at once, about 0.5 here
    assert np.linalg.norm(scales * optimizer.x) < 0.1 * np.linalg.norm(scales * x0)


def test_training_uses_one_blas_thread_and_no_torch(chain_motion):
    """Training is numpy on one BLAS thread (restored afterwards): the result cannot depend on the core count,
    and torch is not needed (nor imported) to encode or decode."""
    from threadpoolctl import threadpool_info

    before = [(p["internal_api"], p["num_threads"]) for p in threadpool_info()]
    compress_motion(chain_motion, "naive-fourier", max_error=None, params={"k": 1, "iters": 25})
    assert [(p["internal_api"], p["num_threads"]) for p in threadpool_info()] == before
    code = ("import sys; from motionrep.model.synthetic import chain_skeleton, synthetic_motion; "
            "from motionrep.pipeline.compress import compress_motion; "
            "m = synthetic_motion(chain_skeleton(3), frames=48, fps=30, seed=1, cycles=2, amplitude_deg=20); "
            "compress_motion(m, 'adaptive-fourier', max_error=None, params={'k': 1, 'iters': 25}); "
            "assert 'torch' not in sys.modules, 'torch imported'")
    subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)


def test_adaptive_frequency_is_the_dct_peak_of_the_first_component():
    from motionrep_fourier._train import next_adaptive_frequency

    N = 200
    t = np.arange(N)
    # DCT-II index k is cos(pi k (n + 1/2) / N): k / 2 cycles over the clip
    strong = np.cos(np.pi * 7 * (t + 0.5) / N)  # 3.5 cycles
    weak = 0.3 * np.cos(np.pi * 12 * (t + 0.5) / N)  # 6 cycles
    residual = np.stack([strong + weak, 0.5 * (strong + weak), np.zeros(N)], axis=1)
    weights = np.array([1.0, 1.0, 5.0])
    assert next_adaptive_frequency(residual, weights, []) == 3.5
    assert next_adaptive_frequency(residual, weights, [3.5]) == 6.0
    assert next_adaptive_frequency(np.zeros((N, 3)), weights, []) is None


def test_network_decodes_at_any_time_continuously():
    from motionrep_fourier._network import fourier_features, network_forward

    x = fourier_features([0.0, 0.5], [1.0, 2.5])
    assert np.allclose(x, [[0, 0, 1, 0, 1], [0.5, 0, -1, np.sin(2.5 * np.pi), np.cos(2.5 * np.pi)]], atol=1e-12)
    rng = np.random.default_rng(0)
    arrays = {"omega": np.array([1.0, 3.0], np.float32), "W0": rng.normal(size=(10, 5)), "b0": rng.normal(size=10),
              "W1": rng.normal(size=(10, 10)), "b1": rng.normal(size=10), "W2": rng.normal(size=(4, 10)),
              "b2": rng.normal(size=4)}
    t = np.linspace(0, 1, 1001)
    y = network_forward(arrays, t)
    assert y.shape == (1001, 4)
    y_near = network_forward(arrays, t + 1e-7)  # continuous in t: nearby times give nearby features
    assert np.max(np.abs(y_near - y)) < 1e-4 < np.max(np.abs(np.diff(y, axis=0)))
    with pytest.raises(ValueError, match="shape"):
        network_forward(dict(arrays, W1=np.zeros((3, 3))), t)


def test_network_is_eq_2_in_float32_and_a_time_decodes_alike_in_any_batch():
    """The compiled float32 forward pass is the plain formula of eq. 2 (float64, weights as stored) to float32
    rounding, for any count of times around the block size; a time gives the same bits alone, in any batch and
    at any position (fixed summation order, no BLAS), so what the core measures is what a runtime gets."""
    from motionrep_fourier._network import ROWS, Network, fourier_features, network_forward

    rng = np.random.default_rng(3)
    arrays = {"omega": np.array([0.5, 2.0, 7.5], np.float32), "W0": rng.normal(size=(14, 7)).astype(np.float32),
              "b0": rng.normal(size=14).astype(np.float32), "W1": rng.normal(size=(14, 14)).astype(np.float32),
              "b1": rng.normal(size=14).astype(np.float32), "W2": rng.normal(size=(5, 14)).astype(np.float16),
              "b2": rng.normal(size=5).astype(np.float32)}
    a = {k: np.asarray(v, dtype=np.float64) for k, v in arrays.items()}

    def plain(t):
        h = fourier_features(t, a["omega"]) @ a["W0"].T + a["b0"]
        h = np.where(h > 0, h, np.expm1(np.minimum(h, 0)))
        h = h @ a["W1"].T + a["b1"]
        h = np.where(h > 0, h, np.expm1(np.minimum(h, 0)))
        return h @ a["W2"].T + a["b2"]

    net = Network(arrays)
    for count in (1, 2, ROWS - 1, ROWS, ROWS + 1, 2 * ROWS + 7):
        t = rng.uniform(size=count)
        y = network_forward(arrays, t)
        assert y.shape == (count, 5) and y.dtype == np.float64
        ref = plain(t)
        assert np.max(np.abs(y - ref)) < 1e-5 * max(1.0, np.max(np.abs(ref)))  # float32 rounding
        assert np.array_equal(network_forward(arrays, t), y)  # deterministic
        ones = np.concatenate([net(t[i:i + 1]) for i in range(count)])
        assert np.array_equal(ones, y.astype(np.float32))  # alone = in a batch, bit for bit
        assert np.array_equal(net(t[1:]), ones[1:])  # another position in the block


def test_decoder_elu_is_expm1_to_float32_rounding():
    from motionrep_fourier._network import elu

    z = np.concatenate([[-1e3, -30.0, -17.0, -3.0, -1e-30, -0.0, 0.0, 1e-30, 2.5],
                        -np.logspace(-8, 1.5, 2000)]).astype(np.float32)
    e = elu(z)
    assert e.dtype == np.float32
    positive = z >= 0
    assert np.array_equal(e[positive], z[positive])
    exact = np.expm1(z[~positive].astype(np.float64))
    assert np.all(np.abs(e[~positive] - exact) <= 4 * np.spacing(np.abs(exact).astype(np.float32)))


# ---------------------------------------------------------------------------------------------------------------
# Fourier codecs in windows (payload version 2)
# ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("frames, window", [(2, 8), (9, 8), (10, 8), (48, 16), (100, 8), (101, 33), (1000, 125)])
def test_window_edges_cover_the_clip_in_equal_windows(frames, window):
    from motionrep_fourier._windows import window_edges

    edges = window_edges(frames, window)
    steps = np.diff(edges)
    assert edges[0] == 0 and edges[-1] == frames - 1 and np.all(steps >= 1) and np.all(steps <= max(window, 1))
    assert edges.size - 1 == max(1, -(-(frames - 1) // window))
    assert steps.max() - steps.min() <= 1
    assert window_edges(frames, 0).tolist() == [0, frames - 1]


@pytest.fixture(scope="module")
def windowed(chain_motion):
    """Windows with float32 weights: the version-2 windowed layout (still written by dtype=float32)."""
    return compress_motion(chain_motion, "adaptive-fourier", max_error="3%",
                           params={"window": 16, "dtype": "float32", **FAST_FOURIER})


def test_windows_meet_the_bound_each_with_its_own_network(windowed, chain_motion):
    r, c = windowed, windowed.container
    assert c.codec_version == 4 and c.info["windows"] == 3 and len(c.info["K"]) == 3
    assert c.arrays["edges"].tolist() == [0, 16, 31, 47]
    assert r.report.max_error <= r.bound and r.report.max_error_percent <= 3.0
    # every stored number counts: the window table, frequencies, weights, output biases
    D = r.figures.feature_width
    per_window = [K + 2 * (2 * K + 1) * (2 * K + 1) + 2 * 2 * (2 * K + 1) + (2 * (2 * K + 1)) ** 2
                  + D * 2 * (2 * K + 1) + D for K in c.info["K"]]
    assert c.num_parameters == 4 + 3 + sum(per_window)
    # the core measured the payload decoded from the bytes: the same error as decoding the file again
    assert max_joint_error(chain_motion, decompress(r.data)).max_error == r.report.max_error


def test_windowed_decoding_follows_each_window_and_is_deterministic(windowed):
    from motionrep_fourier._network import network_forward
    from motionrep_fourier._windows import split_windows, windows_forward

    arrays = windowed.container.arrays
    edges, windows = split_windows(arrays)
    F = int(edges[-1]) + 1
    t = np.linspace(0, 1, 1001)
    y = windows_forward(arrays, t)
    assert np.array_equal(windows_forward(arrays, t), y)
    x = t * (F - 1)
    for s, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        inside = (x >= a) & (x < b) if s < len(windows) - 1 else (x >= a)
        np.testing.assert_array_equal(y[inside], network_forward(windows[s], (x[inside] - a) / (b - a)))
    # a window's own network at the shared boundary frame is within the bound too: both were measured there
    assert np.isfinite(y).all()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_windowed_times_in_any_order_decode_alike_grouped_or_alone(windowed, dtype):
    """The kernel groups the times of a call by window (GROUP at a time, then ROWS at a time): random, unsorted,
    repeated and out-of-range times, shared boundary frames and counts around GROUP and ROWS decode to the same
    bits in one call as one at a time (the single-time path) and as the same times sorted, in float32 (payload
    versions >= 3) and float64 (versions 1 and 2), so grouping changes no measured value."""
    from motionrep_fourier._network import GROUP, ROWS
    from motionrep_fourier._windows import Windows, split_windows

    arrays = windowed.container.arrays
    edges, _ = split_windows(arrays)
    F = int(edges[-1]) + 1
    net = Windows(arrays, dtype=dtype)
    rng = np.random.default_rng(11)
    boundaries = edges / (F - 1)
    special = np.concatenate([boundaries, np.nextafter(boundaries, -1), np.nextafter(boundaries, 2), [-0.25, 1.5]])
    for count in (1, 2, ROWS + 1, 3 * ROWS + 5, GROUP - 1, GROUP + 3 * ROWS + 1):
        t = rng.uniform(-0.05, 1.05, count)
        t[rng.integers(0, count, count // 3)] = t[0]  # duplicates
        t[:min(count, special.size)] = special[:count]
        rng.shuffle(t)
        y = net(t)
        assert y.shape == (count, net.width) and np.isfinite(y).all()
        alone = np.concatenate([net(t[i:i + 1]) for i in range(count)])
        assert np.array_equal(y, alone)
        order = np.argsort(t, kind="stable")
        assert np.array_equal(net(t[order]), y[order])
    # one time of a window among many of another: the single-time path inside a batch
    t = np.concatenate([np.full(ROWS + 1, 0.9), [0.05], np.full(7, 0.9)])
    assert np.array_equal(net(t), np.concatenate([net(t[i:i + 1]) for i in range(t.size)]))


def test_windowed_payload_checks_its_layout(windowed):
    from motionrep_fourier._windows import windows_forward

    arrays = dict(windowed.container.arrays)
    for name, bad in [("weights", arrays["weights"][:-1]), ("k", arrays["k"] + 1),
                      ("edges", arrays["edges"][::-1].copy()), ("b2", arrays["b2"][:2])]:
        with pytest.raises(ValueError, match="windowed payload"):
            windows_forward({**arrays, name: bad}, [0.5])


# jobs=2 is the fast smoke test of the window workers; three processes only in the slow run
@pytest.mark.parametrize("jobs", [1, 2, pytest.param(3, marks=pytest.mark.slow)])
def test_windowed_files_are_byte_identical_for_a_seed_and_any_number_of_processes(jobs, windowed, chain_motion):
    again = compress_motion(chain_motion, "adaptive-fourier", max_error="3%",
                            params={"window": 16, "dtype": "float32", "jobs": jobs, **FAST_FOURIER})
    a, b = again.container, windowed.container
    assert a.info == b.info and a.arrays.keys() == b.arrays.keys()
    assert all(a.arrays[k].tobytes() == b.arrays[k].tobytes() for k in a.arrays)  # the payload, bit for bit
    assert again.evaluations == windowed.evaluations  # the workers' evaluations are counted too
    if jobs == 1:  # the parameters are stored too: the same parameters give the same file
        assert compress_motion(chain_motion, "adaptive-fourier", max_error="3%",
                               params={"window": 16, "dtype": "float32", "jobs": 1, **FAST_FOURIER}).data == again.data


def test_forked_window_workers_split_and_fail_like_one_process(chain_motion):
    """Splitting and failing in worker processes: the same error (the earliest window that cannot be split)."""
    messages = []
    for jobs in (1, 2):
        with pytest.raises(BoundNotMetError, match=r"\(window of frames 0-8\)") as info:
            compress_motion(chain_motion, "naive-fourier", max_error="0.01%",
                            params={"window": 16, "max_k": 0, "iters": 50, "jobs": jobs})
        messages.append(str(info.value))
    assert messages[0] == messages[1]


def test_worker_count(monkeypatch):
    import threading

    from motionrep_fourier import _workers
    from motionrep_fourier._workers import worker_count

    with monkeypatch.context() as m:  # as in a process of one thread, whatever daemon threads earlier tests left
        m.setattr(_workers.threading, "active_count", lambda: 1)  # (a Dask client leaves its offload thread)
        assert worker_count(4, 2) == 2 and worker_count(1, 9) == 1 and worker_count(3, 9) == 3
        assert 1 <= worker_count(0, 100) <= os.cpu_count()
    # never forked from a process with other threads running (a threaded scheduler)

    seen, release = [], threading.Event()
    thread = threading.Thread(target=release.wait)
    thread.start()
    try:
        seen.append(worker_count(4, 9))
    finally:
        release.set()
        thread.join()
    assert seen == [1]


@pytest.mark.parametrize("version", [1, 2])
def test_version_1_and_2_payloads_decode_in_float64_as_they_were_measured(version, chain_motion, windowed):
    """Files written before quantisation (payload version 2: float weights, one network or windows) and before
    windows (version 1, the same arrays as one network of version 2) were measured in float64 when they were
    written: they decode in float64 (the plain formula of eq. 2, to float64 rounding), through the codec, the
    runtime decoder and decompress alike; versions 3 and 4 decode the same arrays in float32."""
    import dataclasses

    import motionrep
    from motionrep.plugin.codec import Payload
    from motionrep.io.container import pack, unpack
    from motionrep.plugin.registry import get_codec, get_representation
    from motionrep_fourier._network import fourier_features
    from motionrep_fourier._windows import split_windows

    def plain(a, t):
        a = {k: np.asarray(v, dtype=np.float64) for k, v in a.items()}
        h = fourier_features(t, a["omega"]) @ a["W0"].T + a["b0"]
        h = np.where(h > 0, h, np.expm1(np.minimum(h, 0)))
        h = h @ a["W1"].T + a["b1"]
        h = np.where(h > 0, h, np.expm1(np.minimum(h, 0)))
        return h @ a["W2"].T + a["b2"]

    r = compress_motion(chain_motion, "naive-fourier", max_error=None, params={"k": 2, "iters": 50,
                                                                               "dtype": "float32"})
    assert r.container.codec_version == 4 and "edges" not in r.container.arrays
    t = np.linspace(0.0, 1.0, 301)
    for result in (r, windowed) if version == 2 else (r,):
        old = unpack(pack(dataclasses.replace(result.container, codec_version=version)))
        assert old.codec_version == version
        codec = get_codec(old.codec)
        v_old = codec.decode(Payload(old.arrays, old.info, version=version), t)
        v3 = codec.decode(Payload(old.arrays, old.info, version=3), t)
        if "edges" in old.arrays:
            edges, windows = split_windows(old.arrays)
            F = int(edges[-1]) + 1
            s = np.searchsorted(edges[1:-1], t * (F - 1), side="right")
            reference = np.concatenate([plain(windows[s[i]], [(t[i] * (F - 1) - edges[s[i]])
                                                              / (edges[s[i] + 1] - edges[s[i]])])
                                        for i in range(t.size)])
        else:
            reference = plain(old.arrays, t)
        scale = np.abs(reference).max()
        # float64 sums in another order than numpy's (BLAS differs by machine): float64 rounding, not bit for bit
        np.testing.assert_allclose(v_old, reference, rtol=0, atol=1e-12 * scale)
        assert np.abs(v3 - reference).max() > 1e-9 * scale  # float32: not what version 1 and 2 files measured
        # the runtime decoder and decompress decode the old version in float64 too
        rep = get_representation(old.representation, version=old.representation_version)
        clip = motionrep.open(pack(old))
        seconds = np.linspace(0.0, clip.duration, 37)
        u = clip.normalized_times(seconds)
        expected = rep.from_features(codec.decode(Payload(old.arrays, old.info, version=version), u),
                                     old.skeleton, old.fps)
        np.testing.assert_array_equal(clip.poses(seconds).rotations, expected.rotations)
        frames = np.arange(old.num_frames) / (old.num_frames - 1)
        expected = rep.from_features(codec.decode(Payload(old.arrays, old.info, version=version), frames),
                                     old.skeleton, old.fps)
        np.testing.assert_array_equal(decompress(pack(old)).rotations, expected.rotations)


def test_windows_measure_the_same_with_or_without_evaluate_frames(chain_motion):
    """A context without ``evaluate_frames`` (the method is new) is measured on the whole clip instead."""
    from motionrep.plugin.registry import get_codec, get_representation
    from motionrep.testing import ConformanceContext

    codec, rep = get_codec("adaptive-fourier"), get_representation("root-quat-axis-angle")
    params = codec.parse_params({"window": 16, "iters": 100, "k": 1, "jobs": 1})
    f, w = rep.to_features(chain_motion), rep.weights(chain_motion)

    class Older:  # every attribute of the context but evaluate_frames
        def __init__(self, ctx):
            self.ctx, self.calls = ctx, 0
            self.params, self.bound, self.seed, self.times = ctx.params, ctx.bound, ctx.seed, ctx.times

        def evaluate(self, features):
            self.calls += 1
            assert np.asarray(features).shape == f.shape
            return self.ctx.evaluate(features)

        def evaluate_payload(self, payload):
            return self.ctx.evaluate_payload(payload)

        def progress(self, stage, **fields):
            pass

    def context():
        return ConformanceContext(chain_motion, rep, codec, params, 1e9, 0)

    older = Older(context())
    a, b = codec.encode(f, w, context()), codec.encode(f, w, older)
    assert older.calls > 0
    assert a.info == b.info and all(np.array_equal(a.arrays[k], b.arrays[k]) for k in a.arrays)


@pytest.fixture(scope="module")
def long_motion():
    return synthetic_motion(chain_skeleton(3), frames=601, fps=60, seed=3, cycles=9, amplitude_deg=20)


def test_window_unset_codes_a_short_clip_as_one_network(chain_motion):
    r = compress_motion(chain_motion, "adaptive-fourier", max_error="3%", params=FAST_FOURIER)
    assert edges_of(r.container) == [0, 47] and r.container.params["window"] is None
    assert r.report.max_error <= r.bound


def test_window_unset_codes_a_long_clip_in_windows_split_where_they_need_more(long_motion, monkeypatch):
    import motionrep_fourier._codecs as codecs

    r = compress_motion(long_motion, "adaptive-fourier", max_error="3%", params=FAST_FOURIER)
    edges = np.array(edges_of(r.container))
    assert edges[0] == 0 and edges[-1] == 600 and np.diff(edges).max() <= codecs.AUTO_LONGEST
    assert max(r.container.info["K"]) <= codecs.AUTO_MAX_K and r.report.max_error <= r.bound
    # a window longer than AUTO_WINDOW that needs more than AUTO_MAX_K frequencies is split in two
    monkeypatch.setattr(codecs, "AUTO_MAX_K", 0)
    events = []
    r = compress_motion(long_motion, "adaptive-fourier", max_error="3%", params=FAST_FOURIER,
                        progress=lambda stage, fields: events.append((stage, fields.get("window"))))
    assert ("split", "0-200") in events
    assert np.diff(edges_of(r.container)).max() <= codecs.AUTO_WINDOW and r.report.max_error <= r.bound


@pytest.mark.parametrize("window", [1, 7, -8, 2.5])
def test_window_parameter_is_validated(window, chain_motion):
    with pytest.raises(ParameterError, match="window"):
        compress_motion(chain_motion, "adaptive-fourier", params={"window": window})


def test_a_window_that_misses_the_bound_is_split_then_named(chain_motion):
    # 0-16 misses, so do its halves 0-8 and 8-16; 0-8 spans fewer than 2 x MIN_SPLIT steps: its error is final
    with pytest.raises(BoundNotMetError, match=r"\(window of frames 0-8\).*max_k=0"):
        compress_motion(chain_motion, "naive-fourier", max_error="0.01%",
                        params={"window": 16, "max_k": 0, "iters": 50})


def test_windows_that_miss_the_bound_are_split_until_they_meet_it(chain_motion, monkeypatch):
    import motionrep_fourier._train as train
    from motionrep_fourier._codecs import MIN_SPLIT

    real_fit, tried = train.fit, []

    def fit(features, weights, context, **kw):  # a network "cannot" cover more than 12 frame steps
        tried.append(features.shape[0] - 1)
        if features.shape[0] - 1 > 12:
            raise BoundNotMetError("too long", 1.0, 0.5)
        return real_fit(features, weights, context, **kw)

    monkeypatch.setattr(train, "fit", fit)
    events = []
    r = compress_motion(chain_motion, "naive-fourier", max_error="50%", params={"window": 24, "iters": 50, "jobs": 1},
                        progress=lambda stage, fields: events.append((stage, fields.get("window"))))
    # 47 steps: windows 0-24 and 24-47; each misses, and is split at its middle frame
    assert edges_of(r.container) == [0, 12, 24, 35, 47]
    assert tried == [24, 12, 12, 23, 11, 12] and MIN_SPLIT == 8
    assert [w for stage, w in events if stage == "split"] == ["0-24", "24-47"]
    assert max_joint_error(chain_motion, decompress(r.data)).max_error <= r.bound


# ---------------------------------------------------------------------------------------------------------------
# Quantised payload (versions 3 and 4)
# ---------------------------------------------------------------------------------------------------------------
def _random_networks(rng, Ks, D):
    from motionrep_fourier._packed import QuantizedNetwork

    out = []
    for K in Ks:
        h = 2 * (2 * K + 1)
        layers = (rng.integers(-300, 300, (h, 2 * K + 2)), rng.integers(-40, 40, (h, h + 1)),
                  rng.integers(-5000, 5000, (D, h + 1)))
        columns = (np.append(rng.integers(0, 30, h), 0), np.append(rng.integers(0, 30, h), 0))
        out.append(QuantizedNetwork(rng.integers(1, 200, K), rng.integers(-90, -40, 3), layers, columns))
    return out


def test_quantised_payload_round_trips_and_dequantises_the_same_way():
    from motionrep_fourier._packed import dequantized, pack, unpack

    rng = np.random.default_rng(7)
    networks = _random_networks(rng, [0, 3, 1, 5], 7)
    scale = rng.integers(-20, 20, 7)
    data = pack([0, 10, 25, 26, 60], scale, networks)
    assert data.dtype == np.uint8
    edges, scale2, back = unpack(data)
    assert edges.tolist() == [0, 10, 25, 26, 60] and scale2.tolist() == scale.tolist()
    for a, b in zip(networks, back):
        assert a.omega2.tolist() == b.omega2.tolist() and a.steps.tolist() == b.steps.tolist()
        assert all(np.array_equal(x, y) for x, y in zip(a.layers, b.layers))
        assert all(np.array_equal(x, y) for x, y in zip(a.columns, b.columns))
        da, db = dequantized(a, scale), dequantized(b, scale)
        assert all(da[k].tobytes() == db[k].tobytes() for k in da)
        assert da["W2"].dtype == np.float32 and da["omega"].tolist() == (a.omega2 / 2).tolist()
    assert np.array_equal(pack([0, 10, 25, 26, 60], scale, networks), data)  # the same bytes every time


def test_quantised_payload_versions_3_and_4_hold_the_same_integers():
    """Version 4 codes the integers of version 3 under per-row (or per-column) models where that is smaller:
    both read back to the same networks, and version 4 is smaller when the output layer's rows differ in
    magnitude (features of different ranges, a feature that never moves), within a few bytes otherwise."""
    from motionrep.errors import PayloadError
    from motionrep_fourier._packed import VERSION, pack, unpack

    assert VERSION == 4
    rng = np.random.default_rng(9)
    networks = _random_networks(rng, [3, 1], 40)
    for n in networks:  # rows of the output layer of very different magnitudes, six of them zero
        n.layers[2][:] = n.layers[2] // (1 << rng.integers(0, 12, (40, 1)))
        n.layers[2][3:9] = 0
    scale = rng.integers(-20, 20, 40)
    data3, data4 = pack([0, 20, 40], scale, networks, 3), pack([0, 20, 40], scale, networks)
    for data, version in ((data3, 3), (data4, 4)):
        edges, scale2, back = unpack(data, version)
        assert edges.tolist() == [0, 20, 40] and scale2.tolist() == scale.tolist()
        for a, b in zip(networks, back):
            assert all(np.array_equal(x, y) for x, y in zip(a.layers, b.layers))
            assert all(np.array_equal(x, y) for x, y in zip(a.columns, b.columns))
            assert a.omega2.tolist() == b.omega2.tolist() and a.steps.tolist() == b.steps.tolist()
    assert data4.size < 0.92 * data3.size
    plain = _random_networks(rng, [2], 5)  # rows alike: one model per layer, as version 3
    assert pack([0, 9], scale[:5], plain).size <= pack([0, 9], scale[:5], plain, 3).size + 8
    with pytest.raises(PayloadError, match="version"):
        unpack(data4, 2)


def test_version_3_quantised_files_decode_as_they_were_written(chain_motion):
    """A file of payload version 3 (the same integers, coded under one model per layer) decodes through the
    codec, the runtime decoder and decompress to exactly what the version-4 file of the same networks does."""
    import dataclasses

    import motionrep
    from motionrep.io.container import pack, unpack
    from motionrep_fourier._packed import pack as pack_data, unpack as unpack_data

    r = compress_motion(chain_motion, "adaptive-fourier", max_error="3%", params={"window": 16, **FAST_FOURIER})
    c = r.container
    assert c.codec_version == 4 and c.info["windows"] == 3
    edges, scale, networks = unpack_data(c.arrays["data"])
    old_data = pack_data(edges, scale, networks, 3)
    assert not np.array_equal(old_data, c.arrays["data"])
    old = unpack(pack(dataclasses.replace(c, codec_version=3, arrays={"data": old_data})))
    assert old.codec_version == 3
    new, previous = decompress(r.data), decompress(pack(old))
    np.testing.assert_array_equal(previous.rotations, new.rotations)
    np.testing.assert_array_equal(previous.root_translation, new.root_translation)
    assert max_joint_error(chain_motion, previous).max_error <= r.bound
    seconds = np.linspace(0.0, motionrep.open(r.data).duration, 29)
    np.testing.assert_array_equal(motionrep.open(pack(old)).poses(seconds).rotations,
                                  motionrep.open(r.data).poses(seconds).rotations)


def test_damaged_quantised_payloads_are_refused_not_decoded_wrongly():
    from motionrep.plugin.coding import IntegerEncoder
    from motionrep.errors import PayloadError
    from motionrep_fourier._packed import pack, unpack

    rng = np.random.default_rng(8)
    data = pack([0, 30], rng.integers(-5, 5, 6), _random_networks(rng, [2], 6))
    for bad in (data[:-4], data[:len(data) // 2 // 4 * 4], np.concatenate([data, np.zeros(8, np.uint8)]),
                data[:-3]):
        with pytest.raises(PayloadError):
            unpack(bad)
    # sizes beyond what the data can hold are refused before anything is allocated
    enc = IntegerEncoder()
    enc.encode_raw([60000], 16)
    enc.encode_raw([(1 << 24) - 1], 24)
    with pytest.raises(PayloadError, match="invalid width"):
        unpack(np.frombuffer(enc.to_bytes(), np.uint8))


def test_quantised_windows_meet_the_bound_and_decode_once(chain_motion, monkeypatch):
    import motionrep_fourier._codecs as codecs
    from motionrep.plugin.registry import get_codec

    r = compress_motion(chain_motion, "adaptive-fourier", max_error="3%", params={"window": 16, **FAST_FOURIER})
    c = r.container
    assert c.codec_version == 4 and list(c.arrays) == ["data"] and c.info["windows"] == 3
    assert edges_of(c) == [0, 16, 31, 47] and len(c.info["steps"]) == 3
    assert r.report.max_error <= r.bound
    assert max_joint_error(chain_motion, decompress(r.data)).max_error == r.report.max_error
    # the payload is range-decoded and dequantised once, when the decoder is prepared, not per call
    calls = []
    real = codecs.unpack
    monkeypatch.setattr(codecs, "unpack", lambda *args: calls.append(1) or real(*args))
    from motionrep.plugin.codec import Payload

    decoder = get_codec("adaptive-fourier").decoder(Payload(c.arrays))
    first = decoder(np.linspace(0, 1, 97))
    for _ in range(3):
        assert np.array_equal(decoder(np.linspace(0, 1, 97)), first)
    assert len(calls) == 1


def test_quantised_payload_is_a_fraction_of_the_float_one(chain_motion):
    opts = dict(max_error="2%", params={**FAST_FOURIER, "window": 0})
    q = compress_motion(chain_motion, "adaptive-fourier", **opts)
    f = compress_motion(chain_motion, "adaptive-fourier", max_error="2%",
                        params={**FAST_FOURIER, "window": 0, "dtype": "float32"})
    assert q.report.max_error <= q.bound and f.report.max_error <= f.bound
    nbytes = lambda r: sum(a.nbytes for a in r.container.arrays.values())  # noqa: E731
    assert nbytes(q) < 0.5 * nbytes(f)


def test_quantised_without_a_bound_rounds_finely(chain_motion):
    """With k and no bound the steps give an output error of RMS about 1e-3 of the targets' (NOISE)."""
    q = compress_motion(chain_motion, "naive-fourier", max_error=None, params={"k": 2, "iters": 100})
    f = compress_motion(chain_motion, "naive-fourier", max_error=None, params={"k": 2, "iters": 100,
                                                                              "dtype": "float32"})
    assert q.container.info["K"] == f.container.info["K"] == 2
    a, b = decompress(q.data), decompress(f.data)
    # the same training; the rounding moves joints by far less than the network's own error
    assert max_joint_error(b, a).max_error < 0.05 * f.report.max_error + 1e-9


def test_rounding_compensates_each_column_on_the_inputs():
    """``_quantise.rounded`` (GPTQ): on correlated inputs the layer's output moves far less than with each
    weight rounded to its nearest multiple, every integer stays within a few steps of its weight, and columns
    of inputs that are never non-zero are rounded to the nearest, as nothing can compensate them."""
    from motionrep_fourier._quantise import rounded

    rng = np.random.default_rng(3)
    N, n, m = 400, 12, 30
    mix = rng.normal(size=(n, n))
    inputsT = np.vstack([(rng.normal(size=(N, n)) @ mix).T[:-2], np.zeros((1, N)), np.ones((1, N))])
    A = rng.normal(size=(m, n))
    steps = np.full(n, 0.05)
    steps[3] = 0.2  # per-column steps
    Q = rounded(A, inputsT, steps)
    nearest = np.rint(A / steps)
    error = lambda q: float(np.sum(((A - q * steps) @ inputsT) ** 2))  # noqa: E731
    assert error(Q) < 0.5 * error(nearest)
    assert np.max(np.abs(Q - nearest)) <= 8
    assert np.array_equal(Q[:, -2], nearest[:, -2])
    assert np.array_equal(rounded(A, inputsT, steps), Q)  # deterministic


def test_weight_decay_follows_the_bound_in_normalised_units():
    """The decay is the same share of the loss at the bound for any units (bound and RMS scaled together), four
    times smaller at half the bound, and the floor ``RIDGE`` without a bound or at a bound far below the motion."""
    from motionrep_fourier._train import DECAY, clip_scale, weight_decay
    from motionrep_fourier._trainnet import RIDGE

    assert weight_decay(0.5, 2.0) == pytest.approx(DECAY * 0.0625)
    assert weight_decay(50.0, 200.0) == pytest.approx(weight_decay(0.5, 2.0))
    assert weight_decay(0.25, 2.0) == pytest.approx(weight_decay(0.5, 2.0) / 4)
    assert weight_decay(None, 2.0) == RIDGE and weight_decay(1e-6, 2.0) == RIDGE
    rng = np.random.default_rng(2)
    Y, w = rng.normal(size=(50, 4)) * [1.0, 2.0, 0.0, 3.0], np.array([1.0, 0.5, 2.0, 1.0])
    scale = clip_scale(Y, w)
    assert scale.rms == pytest.approx(np.sqrt(np.mean(((Y - Y.mean(axis=0)) * w) ** 2)))
    assert clip_scale(np.zeros((5, 4)), w).rms == 1.0  # a clip that never moves


def test_a_stage_far_from_the_bound_ends_early(chain_motion):
    """A stage whose measured error is above FAR times the bound ends at its first measurement after FAR_ITERS
    iterations (measurements come at least every EVAL_EVERY chunks); the stages near the bound train on (to their
    plateau or ``iters``)."""
    from motionrep_fourier._train import CHUNK, EVAL_EVERY, FAR, FAR_ITERS

    stages: dict[int, tuple[int, float]] = {}

    def progress(stage, fields):
        if stage == "train" and "error" in fields:
            stages[fields["K"]] = (fields["iteration"], fields["error"])

    r = compress_motion(chain_motion, "naive-fourier", max_error="0.3%", params={"window": 0, "iters": 1000},
                        progress=progress)
    far = [K for K, (_, error) in stages.items() if error > FAR * r.bound and K < r.container.info["K"]]
    assert far and all(FAR_ITERS <= stages[K][0] <= FAR_ITERS + EVAL_EVERY * CHUNK for K in far)
    assert any(iterations > FAR_ITERS for iterations, error in stages.values() if error <= FAR * r.bound)


def test_an_uninitialised_compiled_decoder_refuses_to_sample():
    """A ``_cfourier.Decoder`` never initialised (or whose initialisation failed) raises, never calls through an
    empty sampler."""
    from motionrep_fourier import _cfourier

    empty = _cfourier.Decoder.__new__(_cfourier.Decoder)
    with pytest.raises(ValueError, match="not initialised"):
        empty.sampler
    with pytest.raises(ValueError, match="not initialised"):
        _cfourier.sample(np.zeros(2), np.zeros((3, 2)), empty)
