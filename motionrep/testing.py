"""The conformance suite for representation and codec plugins: :func:`check_representation`, :func:`check_codec`.

A plugin's own tests call these, e.g.::

    from motionrep.testing import check_representation, check_codec

    def test_my_representation_conforms():
        check_representation(MyRepresentation())

    def test_my_codec_conforms():
        check_codec(MyCodec())

Each check raises AssertionError (explicitly, so ``python -O`` does not strip it) with a message naming the
plugin, the clip and what failed.  Codecs are measured through :class:`ConformanceContext`, the encode context
of the core (``motionrep compress``), so a codec is judged here exactly as in production.  The clips come from
:mod:`motionrep.model.synthetic`.  Runtime code never imports this module.
"""

from __future__ import annotations

import io
import json
import sys
from typing import Any, Iterable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from .defaults import DEFAULT_REPRESENTATION
from .model._pose import Motion
from .plugin.codec import Codec, Payload, codec_problems
from .errors import BoundNotMetError, MotionrepError, ParameterError
from .pipeline.evaluate import MotionContext
from .model.kinematics import character_height, global_positions
from .model.ops import resample
from .plugin.representation import Representation, representation_problems
from .model.synthetic import SIX_ORDERS, humanoid_skeleton, odd_skeleton, spinning_motion, synthetic_motion

__all__ = [
    "conformance_motions",
    "upsample_motion",
    "check_representation",
    "check_torch_path",
    "check_codec",
    "ConformanceContext",
]


def _fail(message: str) -> None:
    raise AssertionError(message)


def conformance_motions() -> list[Motion]:
    """The clips :func:`check_representation` uses by default (all small, deterministic).

    A humanoid in one rotation order, a humanoid whose joints cycle through the six Tait-Bryan orders,
    :func:`odd_skeleton` (1- and 2-axis joints, a joint without rotation channels, position channels on
    non-root joints, a root without position channels), :func:`spinning_motion` on the humanoid and on the odd
    skeleton, and a one-frame clip.
    """
    mixed = humanoid_skeleton(tuple(SIX_ORDERS[j % 6] for j in range(15)))
    odd = synthetic_motion(odd_skeleton(), frames=40, fps=25.0, seed=3)
    odd = odd.replace(root_translation=np.broadcast_to(odd.skeleton.offsets[0], (40, 3)))  # no position channels
    return [
        synthetic_motion(frames=60, seed=0),
        synthetic_motion(mixed, frames=50, seed=2),
        odd,
        spinning_motion(),
        spinning_motion(odd_skeleton(), frames=60, seed=4),
        synthetic_motion(frames=1, seed=5),
    ]


def upsample_motion(motion: Motion, factor: int) -> Motion:
    """``motion`` with ``factor - 1`` frames inserted between each pair of frames (:func:`motionrep.model.ops.resample`
    at ``factor`` times the frame rate): frame ``i`` of the input is frame ``i * factor`` of the output."""
    F = motion.num_frames
    if F < 2 or factor < 2:
        return motion
    return resample(motion, motion.fps * factor, (F - 1) * factor + 1)


def _label(i: int, motion: Motion) -> str:
    return f"clip {i} ({motion!r}, {motion.skeleton!r})"


def _scale(motion: Motion) -> float:
    h = character_height(motion.skeleton)
    return h if h > 0 else 1.0


def _expect_validation_error(call, what: str) -> None:
    try:
        call()
    except MotionrepError as exc:
        if "\n" in str(exc) or not str(exc):
            _fail(f"{what}: the error message must be one non-empty line, got {str(exc)!r}")
        return
    except Exception as exc:  # noqa: BLE001 - reporting what was raised instead
        _fail(f"{what}: expected a motionrep ValidationError, got {type(exc).__name__}: {exc}")
    _fail(f"{what}: expected a motionrep ValidationError, nothing was raised")


def check_representation(rep: Representation, motions: Iterable[Motion] | None = None, *,
                         tolerance: float = 1e-6, refine: int = 8) -> None:
    """Check that ``rep`` honours the :class:`~motionrep.plugin.representation.Representation` contract.

    For every clip (default :func:`conformance_motions`):

    * ``width`` equals the number of ``feature_names``, which are unique non-empty strings;
    * ``to_features`` gives finite ``(F, D)`` float64, the same on every call, and the same when the input's
      quaternions are negated at random (features depend on the pose, not on quaternion signs);
    * ``weights`` gives finite, non-negative ``(D,)`` float64;
    * ``from_features(to_features(m))`` has the same skeleton, fps and frame count, and reproduces the FK
      positions of every joint and end site, and the translations of joints with position channels, within
      ``tolerance`` times the character height;
    * features are continuous: on the clip upsampled ``refine`` times (:func:`upsample_motion`), no column
      jumps between frames by more than half its largest jump on the original clip (a continuous encoding
      shrinks its steps with the time step; a sign flip or wrap keeps its size);
    * features perturbed as a lossy codec would still decode to a valid Motion;
    * with a pose plan, the encode context (``frame_errors``, ``feature_edits``) measures such features through it
      as through ``from_features`` (within ``tolerance`` times the character height);
    * features of the wrong width, of the wrong rank, or with NaN raise a one-line
      :class:`~motionrep.errors.ValidationError`.

    Raises:
        AssertionError: naming the representation, the clip and the failed property.
    """
    who = f"representation {getattr(rep, 'name', rep)!r}"
    for problem in representation_problems(rep):
        _fail(f"{who}: {problem}")
    clips = list(conformance_motions() if motions is None else motions)
    if not clips:
        _fail(f"{who}: no clips to check")
    rng = np.random.default_rng(0)
    for i, m in enumerate(clips):
        where = f"{who}, {_label(i, m)}"
        sk, F = m.skeleton, m.num_frames
        D = rep.width(sk)
        names = rep.feature_names(sk)
        if not isinstance(D, (int, np.integer)) or D < 1:
            _fail(f"{where}: width must be a positive integer, got {D!r}")
        if len(names) != D or len(set(names)) != D or not all(isinstance(n, str) and n for n in names):
            _fail(f"{where}: feature_names must be {D} unique non-empty strings, got {len(names)} "
                  f"({len(set(names))} distinct)")
        feats = rep.to_features(m)
        if not isinstance(feats, np.ndarray) or feats.dtype != np.float64 or feats.shape != (F, D):
            _fail(f"{where}: to_features must return float64 ({F}, {D}), got "
                  f"{getattr(feats, 'dtype', type(feats))} {getattr(feats, 'shape', '')}")
        if not np.all(np.isfinite(feats)):
            _fail(f"{where}: to_features returned NaN or infinity")
        if not np.array_equal(rep.to_features(m), feats):
            _fail(f"{where}: to_features is not deterministic")
        scale = _scale(m)
        fscale = 1e-9 * (1.0 + np.abs(feats).max(axis=0))
        signs = np.where(rng.random(m.rotations.shape[:2]) < 0.5, -1.0, 1.0)
        flipped = rep.to_features(m.replace(rotations=m.rotations * signs[..., None], euler_branch=m.euler_branch))
        bad = np.abs(flipped - feats) > fscale
        if bad.any():
            f, c = np.argwhere(bad)[0]
            _fail(f"{where}: features depend on quaternion signs: column {names[c]!r} at frame {f} is "
                  f"{feats[f, c]!r} but {flipped[f, c]!r} once some input quaternions are negated")
        w = rep.weights(m)
        if not isinstance(w, np.ndarray) or w.dtype != np.float64 or w.shape != (D,):
            _fail(f"{where}: weights must return float64 ({D},), got {getattr(w, 'dtype', type(w))} "
                  f"{getattr(w, 'shape', '')}")
        if not np.all(np.isfinite(w)) or np.any(w < 0):
            _fail(f"{where}: weights must be finite and >= 0")
        decoded = rep.from_features(feats, sk, m.fps)
        if not isinstance(decoded, Motion):
            _fail(f"{where}: from_features must return a Motion, got {type(decoded).__name__}")
        if decoded.skeleton != sk or decoded.fps != m.fps or decoded.num_frames != F:
            _fail(f"{where}: from_features changed the skeleton, fps or frame count")
        err = np.linalg.norm(global_positions(decoded) - global_positions(m), axis=-1)
        if err.max() > tolerance * scale:
            f, p = np.unravel_index(int(err.argmax()), err.shape)
            _fail(f"{where}: round trip moves point {p} at frame {f} by {err.max():.3g} file units, more than "
                  f"{tolerance:g} x the character height ({scale:.6g})")
        if m.joint_translations.size:
            terr = np.abs(decoded.joint_translations - m.joint_translations).max()
            if terr > tolerance * scale:
                _fail(f"{where}: round trip changes joint translations by {terr:.3g}")
        if F >= 2:
            _check_continuity(rep, m, feats, names, refine, where)
        noise = rng.normal(size=feats.shape) * 1e-3 * (1.0 + np.abs(feats).max(axis=0))
        try:
            lossy = rep.from_features(feats + noise, sk, m.fps)
        except Exception as exc:  # noqa: BLE001
            _fail(f"{where}: slightly perturbed features (as from a lossy codec) failed to decode: "
                  f"{type(exc).__name__}: {exc}")
        if not isinstance(lossy, Motion) or lossy.num_frames != F:
            _fail(f"{where}: perturbed features did not decode to a {F}-frame Motion")
        if rep.pose_plan(sk) is not None:  # the encode context measures through the plan (and edits by it)
            planned, through = ConformanceContext(m, rep, None, None), ConformanceContext(m, rep, None, None)
            through._plan = None  # the Motion path: from_features, then FK
            gap = np.abs(planned.frame_errors(feats + noise) - through.frame_errors(feats + noise)).max()
            if not gap <= tolerance * scale:
                _fail(f"{where}: the pose plan decodes features otherwise than from_features (frame errors "
                      f"differ by {gap:.3g})")
        _expect_validation_error(lambda: rep.from_features(np.zeros((F, D + 1)), sk, m.fps),
                                 f"{where}: features of width {D + 1}")
        _expect_validation_error(lambda: rep.from_features(np.zeros(D), sk, m.fps), f"{where}: 1-D features")
        nan = feats.copy()
        nan[0, 0] = np.nan
        _expect_validation_error(lambda: rep.from_features(nan, sk, m.fps), f"{where}: features with NaN")
    if rep.torch_path() is not None and _have_torch():
        check_torch_path(rep, clips)


def _have_torch() -> bool:
    import importlib.util

    return importlib.util.find_spec("torch") is not None and importlib.util.find_spec("roma") is not None


def check_torch_path(rep: Representation, motions: Iterable[Motion] | None = None, *,
                     tolerance: float = 1e-10) -> None:
    """Check a representation's torch path (:meth:`~motionrep.plugin.representation.Representation.torch_path`)
    against its numpy path, in float64 (:func:`check_representation` runs it when torch is installed):

    * its encoding equals ``to_features`` within ``tolerance`` times ``1 + |column|``, and its decoding
      equals ``decode_poses`` (rotations as decoded, within ``tolerance``; translations within ``tolerance``
      times the character height), on features and on features perturbed as a codec would;
    * decoding keeps leading batch dimensions (two copies stacked decode to the same poses);
    * gradients of the FK positions of the decoded poses with respect to the features are finite, and
      ``torch.autograd.gradcheck`` passes on two frames of the first clip.

    Raises:
        AssertionError: naming the representation, the clip and what failed (ImportError without torch).
    """
    import torch

    from .plugin.representation import empty_poses
    from .torch import decode_features, encode_features, global_positions

    who = f"representation {getattr(rep, 'name', rep)!r}"
    rng = np.random.default_rng(1)
    for i, m in enumerate(conformance_motions() if motions is None else motions):
        where = f"{who}, {_label(i, m)}, torch path"
        sk = m.skeleton
        feats = rep.to_features(m)
        enc = encode_features(rep, m).detach().numpy()
        bad = np.abs(enc - feats) > tolerance * (1.0 + np.abs(feats))
        if enc.shape != feats.shape or bad.any():
            _fail(f"{where}: encoding differs from to_features (largest difference "
                  f"{np.abs(enc - feats).max() if enc.shape == feats.shape else enc.shape})")
        scale = max(_scale(m), 1e-300)
        for label, f in (("features", feats),
                         ("perturbed features", feats + rng.normal(size=feats.shape) * 1e-3 * (1 + np.abs(feats)))):
            poses = empty_poses(sk, f.shape[0])
            rep.decode_poses(f, sk, poses)
            root, rot, jt = decode_features(rep, torch.tensor(f), sk)
            # the numpy decoders' rotations are unit to rounding (world-rotation plans included: each world
            # rotation is its own normalised real part), so they are compared as decoded, not renormalised
            errors = (np.abs(rot.numpy() - poses.rotations).max(initial=0.0),
                      np.abs(root.numpy() - poses.root_translation).max(initial=0.0) / scale,
                      np.abs(jt.numpy() - poses.joint_translations).max(initial=0.0) / scale)
            if max(errors) > tolerance:
                _fail(f"{where}: decoding {label} differs from decode_poses (rotations {errors[0]:.3g}, root "
                      f"{errors[1]:.3g} and joint translations {errors[2]:.3g} x height)")
        batch = decode_features(rep, torch.tensor(np.stack([feats, feats])), sk)[1]
        if batch.shape != (2, feats.shape[0], sk.num_joints, 4) or \
                not torch.allclose(batch[1], batch[0], rtol=0, atol=1e-12):
            _fail(f"{where}: decoding (2, F, D) features did not give (2, F, J, 4) rotations, the same twice")
        x = torch.tensor(feats, requires_grad=True)
        pos = global_positions(sk, *decode_features(rep, x, sk))
        (grad,) = torch.autograd.grad((pos * pos).sum(), x)
        if not torch.isfinite(grad).all():
            _fail(f"{where}: the gradient of FK positions with respect to the features is not finite")
        if i == 0:
            small = torch.tensor(feats[:2], requires_grad=True)
            ok = torch.autograd.gradcheck(lambda t: global_positions(sk, *decode_features(rep, t, sk)), (small,),
                                          eps=1e-6, atol=1e-5, raise_exception=False, fast_mode=True)
            if not ok:
                _fail(f"{where}: torch.autograd.gradcheck of FK positions of decoded features failed")


def _check_continuity(rep: Representation, motion: Motion, feats: NDArray, names: Sequence[str], refine: int,
                      where: str) -> None:
    fine = rep.to_features(upsample_motion(motion, refine))
    coarse_jump = np.abs(np.diff(feats, axis=0)).max(axis=0)
    fine_jump = np.abs(np.diff(fine, axis=0))
    floor = 1e-9 * (1.0 + np.abs(feats).max(axis=0))
    bad = fine_jump > 0.5 * coarse_jump + floor
    if bad.any():
        f, c = np.argwhere(bad)[0]
        _fail(f"{where}: column {names[c]!r} is not continuous: on the clip upsampled {refine}x it jumps by "
              f"{fine_jump[f, c]:.6g} between frames {f} and {f + 1}, while its largest jump between the "
              f"original frames is {coarse_jump[c]:.6g} (a sign flip or wrap-around?)")


class ConformanceContext(MotionContext):
    """The :class:`~motionrep.plugin.codec.EncodeContext` the conformance suite encodes with: the core's own context
    (:class:`motionrep.pipeline.evaluate.MotionContext`: decode through the representation, FK, the shared L-infinity
    :class:`~motionrep.pipeline.evaluate.ErrorReport`), which also records every progress report.

    Args:
        motion, representation, codec, params, bound, seed: as for :class:`~motionrep.pipeline.evaluate.MotionContext`.

    Attributes:
        progress_log: every :meth:`progress` call, as ``(stage, fields)``.
    """

    def __init__(self, motion: Motion, representation: Representation, codec: Codec, params: Any,
                 bound: float | None = None, seed: int = 0):
        self.progress_log: list[tuple[str, dict[str, Any]]] = []
        super().__init__(motion, representation, codec, params, bound, seed,
                         progress=lambda stage, fields: self.progress_log.append((stage, dict(fields))))


def _payload_arrays(codec: Codec, payload: Payload, where: str) -> dict[str, NDArray]:
    if not isinstance(payload, Payload):
        _fail(f"{where}: encode must return a motionrep.plugin.codec.Payload, got {type(payload).__name__}")
    arrays = dict(payload.arrays)
    if not arrays:
        _fail(f"{where}: the payload stores no arrays")
    for key, a in arrays.items():
        if not isinstance(key, str) or not key:
            _fail(f"{where}: payload array names must be non-empty strings, got {key!r}")
        if not isinstance(a, np.ndarray) or a.dtype.kind not in "biuf":
            _fail(f"{where}: payload array {key!r} must be a numeric numpy array, got "
                  f"{getattr(a, 'dtype', type(a))}")
    try:
        stored = json.loads(json.dumps(dict(payload.info)))
    except (TypeError, ValueError) as exc:
        _fail(f"{where}: payload info must be JSON-serialisable: {exc}")
    try:
        codec.check_info(stored)
    except Exception as exc:  # noqa: BLE001 - any failure is the finding
        _fail(f"{where}: check_info refuses the codec's own outcome {stored}: {type(exc).__name__}: {exc}"[:500])
    return arrays


def check_codec(codec: Codec, motions: Iterable[Motion] | None = None,
                representation: Representation | str = DEFAULT_REPRESENTATION, *,
                params: Mapping[str, Any] | None = None, bound_fraction: float | None = 0.05,
                bound_params: Mapping[str, Any] | None = None, seed: int = 0) -> list[dict[str, Any]]:
    """Check that ``codec`` honours the :class:`~motionrep.plugin.codec.Codec` contract.

    * ``name``, ``format_version`` and ``Params`` are valid; every parameter has a default and a help text;
      ``parse_params({})`` works and an unknown parameter raises :class:`~motionrep.errors.ParameterError`.
    * For every clip (default: one small :func:`synthetic_motion`) of at least ``codec.min_frames`` frames,
      encoded from ``representation`` with ``params`` and no bound: ``encode`` returns a
      :class:`~motionrep.plugin.codec.Payload` of named numeric arrays with JSON-serialisable ``info`` that the codec's own ``check_info`` accepts once read back from JSON; the
      same seed gives the same arrays, byte for byte; ``decode`` gives finite ``(T, D)`` float64 at any times in
      [0, 1] (also one time, and a subset gives the same rows); the arrays survive a save to ``.npz`` and back;
      ``decode`` does not import torch.
    * With ``bound_fraction`` (times the character height) as the bound, ``encode`` either returns a payload
      whose error, measured by FK, is within the bound, or raises
      :class:`~motionrep.errors.BoundNotMetError` reporting a best error above it.

    Args:
        codec: the codec instance.
        motions: clips to encode.
        representation: a Representation or the name of a registered one.
        params: codec parameters for the encode without a bound (strings allowed, as from the command line).
        bound_fraction: the bound for the bounded encode, as a fraction of the character height; None skips it.
        bound_params: codec parameters for the bounded encode (default: ``params``), e.g. without the fixed
            size that ``params`` needs when there is no bound.
        seed: the seed handed to the codec.

    Returns:
        One dict per clip: ``num_parameters``, ``max_error`` (unbounded encode) and ``bounded_error`` (None if
        skipped or the bound was not met).

    Raises:
        AssertionError: naming the codec, the clip and the failed property.
    """
    who = f"codec {getattr(codec, 'name', codec)!r}"
    for problem in codec_problems(codec, complete=True):
        _fail(f"{who}: {problem}")
    try:
        codec.parse_params({})
    except Exception as exc:  # noqa: BLE001
        _fail(f"{who}: parse_params({{}}) failed: {type(exc).__name__}: {exc}")
    try:
        codec.parse_params({"no_such_parameter_xyz": "1"})
    except ParameterError:
        pass
    else:
        _fail(f"{who}: an unknown parameter must raise ParameterError")
    if isinstance(representation, str):
        from .plugin.registry import get_representation

        representation = get_representation(representation)
    p = codec.parse_params(dict(params or {}))
    bp = p if bound_params is None else codec.parse_params(dict(bound_params))
    clips = list([synthetic_motion(frames=48, seed=7)] if motions is None else motions)
    results = []
    for i, m in enumerate(clips):
        where = f"{who}, {_label(i, m)}"
        if m.num_frames < codec.min_frames:  # the core refuses such a clip before the codec sees it
            continue
        feats = representation.to_features(m)
        w = representation.weights(m)
        F, D = feats.shape
        ctx = ConformanceContext(m, representation, codec, p, None, seed)
        payload = codec.encode(feats.copy(), w.copy(), ctx)
        arrays = _payload_arrays(codec, payload, where)
        again = _payload_arrays(codec, codec.encode(feats.copy(), w.copy(),
                                                    ConformanceContext(m, representation, codec, p, None, seed)),
                                where)
        if sorted(again) != sorted(arrays) or any(
                again[k].dtype != arrays[k].dtype or again[k].tobytes() != arrays[k].tobytes() for k in arrays):
            _fail(f"{where}: encoding twice with seed {seed} gave different payloads")
        torch_before = "torch" in sys.modules
        out = codec.decode(payload, ctx.times)
        if not torch_before and "torch" in sys.modules:
            _fail(f"{where}: decode imported torch (decoding must work without it)")
        if not isinstance(out, np.ndarray) or out.dtype != np.float64 or out.shape != (F, D):
            _fail(f"{where}: decode must return float64 ({F}, {D}), got {getattr(out, 'dtype', type(out))} "
                  f"{getattr(out, 'shape', '')}")
        if not np.all(np.isfinite(out)):
            _fail(f"{where}: decode returned NaN or infinity")
        sub = codec.decode(payload, ctx.times[::2])
        if sub.shape != (len(ctx.times[::2]), D) or not np.allclose(sub, out[::2], rtol=1e-9, atol=1e-9):
            _fail(f"{where}: decoding a subset of the times must give the same rows")
        one = codec.decode(payload, np.array([0.5]))
        if one.shape != (1, D) or not np.all(np.isfinite(one)):
            _fail(f"{where}: decoding at one time must give finite (1, {D}) features")
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        buf.seek(0)
        with np.load(buf) as loaded:
            stored = Payload({k: loaded[k] for k in loaded.files}, dict(payload.info), payload.version)
        if not np.array_equal(codec.decode(stored, ctx.times), out):
            _fail(f"{where}: the payload decodes differently after a save to .npz and back")
        result: dict[str, Any] = {"num_parameters": payload.num_parameters,
                                   "max_error": ctx.evaluate(out).max_error, "bounded_error": None}
        if bound_fraction is not None:
            bound = bound_fraction * _scale(m)
            bctx = ConformanceContext(m, representation, codec, bp, bound, seed)
            try:
                bounded = codec.encode(feats.copy(), w.copy(), bctx)
            except BoundNotMetError as exc:
                if exc.best_error is not None and not exc.best_error > bound:
                    _fail(f"{where}: BoundNotMetError reports a best error {exc.best_error:.6g} within the bound "
                          f"{bound:.6g}")
            else:
                _payload_arrays(codec, bounded, where)
                reached = bctx.evaluate_payload(bounded).max_error
                if reached > bound * (1 + 1e-9):
                    _fail(f"{where}: with bound {bound:.6g} the payload's error is {reached:.6g}")
                result["bounded_error"] = reached
        results.append(result)
    return results
