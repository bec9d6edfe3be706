"""Reading and writing motion files; the format is chosen by the file suffix.

=================  ==========================================================================
suffix             format
=================  ==========================================================================
``.bvh``           Biovision hierarchy (text), one clip          -- ``specs/formats/bvh.md``
``.npz``           numpy archive, one clip                       -- ``specs/formats/npz.md``
``.h5``/``.hdf5``  HDF5, one clip or a database of named clips   -- ``specs/formats/hdf5.md``
``.gltf``/``.glb`` glTF 2.0, a skeleton and its named animations   -- ``specs/formats/gltf.md``
``.fbx``           FBX 7.x (binary or ASCII), read only; extra ``fbx`` -- ``specs/formats/fbx.md``
``.npz`` (AMASS)   AMASS / SMPL-H parameters, read only, with a body model -- ``specs/formats/amass.md``
=================  ==========================================================================

Every write is atomic: the file is written under a temporary name in the same directory and renamed at the
end, so a failure never leaves a partial file behind.

NPZ and HDF5 files hold either a :class:`~motionrep.Motion` or a representation's features
(:class:`FeatureClip`, written by :func:`write_features`); :func:`read` decodes features through the registered
representation, :func:`read_features` returns them as stored.  An HDF5 file is a database of named clips
(:func:`write_database`, :func:`list_clips`, :func:`read_clips`); a file written by :func:`write` is a database
with one clip, named after the file's stem.  BVH and NPZ files hold one clip, named after the file's stem.  A glTF
file holds one skeleton and one or more animations; each animation is a clip, named by the animation's name
(:func:`write` writes one, named after the file's stem).  glTF stores float32 values: a round trip through it
agrees within float32 rounding, not bit for bit.  An FBX file (read only, through the ``ufbx`` package of the
``fbx`` extra) holds one skeleton and one or more anim stacks, each a clip named by the stack.  An ``.npz`` file
with AMASS's keys (``poses``, ``trans``, ``betas``...) is an AMASS clip, read with an SMPL-H body model
(``body_model=``, or the environment variable ``MOTIONREP_SMPLH_MODEL``).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

from .. import formats
from ..model._pose import Motion
from ..errors import naming
from ..errors import (BVHFormatError, FBXFormatError, FormatError, GLTFFormatError, HDF5FormatError, NPZFormatError,
                      ValidationError)
from ._atomic import atomic_path
from ._bvh import format_bvh, parse_bvh, read_bvh, write_bvh
from ._features import FeatureClip, features_from_motion, motion_from_features

# The other formats' modules are imported when first used: h5py, pygltflib and zipfile cost start-up time that
# a BVH-only command (``motionrep info walk.bvh``) should not pay.
_LAZY = {
    "iter_hdf5_clips": "_hdf5", "list_hdf5_clips": "_hdf5", "read_hdf5": "_hdf5", "read_hdf5_clip": "_hdf5",
    "write_database": "_hdf5", "write_hdf5": "_hdf5", "write_hdf5_features": "_hdf5",
    "gltf_bytes": "_gltf", "iter_gltf_clips": "_gltf", "list_gltf_clips": "_gltf", "read_gltf": "_gltf",
    "read_gltf_clip": "_gltf", "write_gltf": "_gltf", "gltf_scale": "_gltf",
    "read_fbx": "_fbx", "read_fbx_clip": "_fbx", "list_fbx_clips": "_fbx", "iter_fbx_clips": "_fbx",
    "read_npz": "_npz", "read_npz_clip": "_npz", "write_npz": "_npz", "write_npz_features": "_npz",
}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


__all__ = [
    "read",
    "write",
    "read_features",
    "write_features",
    "read_stored",
    "list_clips",
    "read_clips",
    "write_database",
    "format_of",
    "SUFFIXES",
    "FeatureClip",
    "features_from_motion",
    "motion_from_features",
    "read_bvh",
    "write_bvh",
    "parse_bvh",
    "format_bvh",
    "read_npz",
    "write_npz",
    "read_hdf5",
    "write_hdf5",
    "read_gltf",
    "write_gltf",
    "gltf_bytes",
    "gltf_scale",
    "read_fbx",
    "atomic_path",
]

#: Known suffixes and the format each selects (the motion formats of :data:`motionrep.formats.FORMATS`).
SUFFIXES: dict[str, str] = {s: f.name for s, f in formats.BY_SUFFIX.items() if f.motion}

_ERRORS: dict[str, type[FormatError]] = {"bvh": BVHFormatError, "npz": NPZFormatError, "hdf5": HDF5FormatError,
                                         "gltf": GLTFFormatError, "fbx": FBXFormatError}


def format_of(path: str | os.PathLike[str]) -> str:
    """The format (``"bvh"``, ``"npz"``, ``"hdf5"``, ``"gltf"`` or ``"fbx"``) selected by ``path``'s suffix.

    Raises:
        FormatError: for an unknown suffix.
    """
    suffix = Path(path).suffix.lower()
    try:
        return SUFFIXES[suffix]
    except KeyError:
        raise FormatError(f"unknown file type {suffix or '(no suffix)'!r}; use one of "
                          + ", ".join(SUFFIXES), path) from None


def _no_clip(fmt: str, path, clip: str | None) -> None:
    if clip is not None:
        raise naming(_ERRORS[fmt](f"a {fmt.upper()} file holds one clip; clip= applies to HDF5 databases and "
                                  "glTF files", path), "clip=")


def read_stored(path: str | os.PathLike[str], clip: str | None = None,
                body_model: str | os.PathLike[str] | None = None) -> tuple[str, Motion | FeatureClip]:
    """Read one clip as stored, without decoding features.

    Args:
        path: a ``.bvh``, ``.npz``, ``.h5``, ``.hdf5``, ``.gltf``, ``.glb`` or ``.fbx`` file.
        clip: for an HDF5 database, the clip to read (only that clip is read), for a glTF file the animation, for
            an FBX file the anim stack; may be omitted when the file holds exactly one clip.
        body_model: for an AMASS ``.npz`` clip, its SMPL-H body model file (default: the file the environment
            variable ``MOTIONREP_SMPLH_MODEL`` names); ignored for other files.

    Returns:
        ``(name, clip)``: the clip's name (for BVH and NPZ, the file's stem) and a :class:`~motionrep.Motion` or,
        for a features file, a :class:`FeatureClip`.

    Raises:
        FormatError: (a subclass naming the file, and the line for BVH or the clip for HDF5) if the file is
            missing or malformed, or the clip is not found.
    """
    fmt = format_of(path)
    if fmt == "hdf5":
        from ._hdf5 import read_hdf5_clip

        return read_hdf5_clip(path, clip)
    if fmt == "gltf":
        from ._gltf import read_gltf_clip

        return read_gltf_clip(path, clip)
    if fmt == "fbx":
        from ._fbx import read_fbx_clip

        return read_fbx_clip(path, clip)
    _no_clip(fmt, path, clip)
    if fmt == "bvh":
        return Path(path).stem, read_bvh(path)
    from ._npz import read_npz_clip

    return Path(path).stem, read_npz_clip(path, body_model)


def read(path: str | os.PathLike[str], clip: str | None = None,
         body_model: str | os.PathLike[str] | None = None) -> Motion:
    """Read one motion from ``path`` (format from the suffix).

    A features file is decoded through the registered representation it names
    (``get_representation(name).from_features(features, skeleton, fps)``).

    Args:
        path: a ``.bvh``, ``.npz``, ``.h5``, ``.hdf5``, ``.gltf``, ``.glb`` or ``.fbx`` file.
        clip: for an HDF5 database, the name of the clip to read (only that clip is read), for a glTF file the
            animation's name, for an FBX file the anim stack's; may be omitted when the file holds exactly one.
        body_model: for an AMASS ``.npz`` clip (told by its keys), the SMPL-H body model ``.npz`` to pose it with
            (default: the file the environment variable ``MOTIONREP_SMPLH_MODEL`` names).

    Raises:
        FormatError: (a subclass naming the file, and the line for BVH or the clip for HDF5) if the file is
            missing or malformed, the clip is not found or not named in a database of several clips (the
            message lists them), or the features were written by another version of their representation
            (the message names both versions).
        UnknownPluginError: if a features file names a representation that is not installed.
    """
    fmt = format_of(path)
    name, item = read_stored(path, clip, body_model)
    if isinstance(item, FeatureClip):
        return motion_from_features(item, path, clip_name=name if fmt == "hdf5" else None)
    return item


def write(motion: Motion, path: str | os.PathLike[str], **options) -> None:
    """Write ``motion`` to ``path`` atomically (format from the suffix).

    Args:
        motion: the clip.
        path: target file; an existing file is replaced only once the new one is complete.
        **options: format options: BVH ``decimals`` (default 6); NPZ ``compress`` (default True: deflated); HDF5 ``clip``,
            the clip's name (default: the file's stem); glTF ``clip`` (the animation's name), ``scale`` (metres
            per file unit) and ``up`` (``"y"``, ``"z"`` or ``"auto"``), see :func:`write_gltf`.

    Raises:
        FormatError: for an unknown suffix.
        ValidationError: if ``motion`` is not a Motion or cannot be written in this format without loss.
    """
    if not isinstance(motion, Motion):
        hint = "; use write_features for a FeatureClip" if isinstance(motion, FeatureClip) else ""
        raise ValidationError(f"write needs a Motion, got {type(motion).__name__}{hint}")
    fmt = format_of(path)
    if fmt == "fbx":
        raise FBXFormatError("motionrep reads FBX but does not write it (no maintained Python library writes FBX "
                             "animation); write .glb or .bvh", path)
    if fmt == "bvh":
        write_bvh(motion, path, **options)
    elif fmt == "npz":
        from ._npz import write_npz

        write_npz(motion, path, **options)
    elif fmt == "gltf":
        from ._gltf import write_gltf

        write_gltf(motion, path, **options)
    else:
        from ._hdf5 import write_hdf5

        write_hdf5(motion, path, **options)


def read_features(path: str | os.PathLike[str], clip: str | None = None) -> FeatureClip:
    """Read a representation's features as stored (NPZ or HDF5), without decoding them.

    Raises:
        FormatError: (naming the file and clip) if the file is malformed or holds a motion rather than features.
    """
    fmt = format_of(path)
    name, item = read_stored(path, clip)
    if not isinstance(item, FeatureClip):
        where = f"clip {name!r} " if fmt == "hdf5" else ""
        raise _ERRORS[fmt](f"{where}holds a motion, not a representation's features; read it with read()", path)
    return item


def write_features(features: FeatureClip, path: str | os.PathLike[str], **options) -> None:
    """Write a representation's features to an NPZ or HDF5 file atomically (format from the suffix).

    Args:
        features: the :class:`FeatureClip`: features with the skeleton, fps and representation name and version.
        path: a ``.npz``, ``.h5`` or ``.hdf5`` file.
        **options: NPZ ``compress`` (default True: deflated); HDF5 ``clip`` (the clip's name, default the file's stem).

    Raises:
        FormatError: for a ``.bvh`` or unknown suffix.
    """
    fmt = format_of(path)
    if fmt in ("bvh", "gltf", "fbx"):
        raise _ERRORS[fmt](f"{fmt.upper()} files hold motions, not features; write features to .npz or .h5", path)
    if fmt == "npz":
        from ._npz import write_npz_features

        write_npz_features(features, path, **options)
    else:
        from ._hdf5 import write_hdf5_features

        write_hdf5_features(features, path, **options)


def list_clips(path: str | os.PathLike[str]) -> list[str]:
    """Names of the clips in ``path``: an HDF5 database's clip names in stored order (no clip data is read), a
    glTF file's animation names; for a BVH or NPZ file, the one clip's name, the file's stem (the file is not
    read).

    Raises:
        FormatError: for an unknown suffix, or an HDF5 file that is missing or not a motionrep file.
    """
    fmt = format_of(path)
    if fmt == "hdf5":
        from ._hdf5 import list_hdf5_clips

        return list_hdf5_clips(path)
    if fmt == "gltf":
        from ._gltf import list_gltf_clips

        return list_gltf_clips(path)
    if fmt == "fbx":
        from ._fbx import list_fbx_clips

        return list_fbx_clips(path)
    return [Path(path).stem]


def read_clips(path: str | os.PathLike[str]) -> Iterator[tuple[str, Motion]]:
    """Yield ``(name, motion)`` for every clip in ``path``, lazily, one clip read at a time.

    Features clips are decoded through their representation.  For BVH and NPZ files, one pair named after the
    file's stem.

    Raises:
        FormatError: as iteration reaches an invalid file or clip.
    """
    fmt = format_of(path)
    if fmt == "hdf5":
        from ._hdf5 import iter_hdf5_clips

        yield from iter_hdf5_clips(path, decode=True)
    elif fmt == "gltf":
        from ._gltf import iter_gltf_clips

        yield from iter_gltf_clips(path)
    elif fmt == "fbx":
        from ._fbx import iter_fbx_clips

        yield from iter_fbx_clips(path)
    else:
        yield Path(path).stem, read(path)
