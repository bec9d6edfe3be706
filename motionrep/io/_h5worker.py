"""The HDF5 side of motionrep's readers: every h5py call a read makes, with the checks that keep a hostile file
from reaching outside itself.

This module imports only numpy, h5py and the standard library, so that it can run on its own in a worker process
(``python _h5worker.py``; see :mod:`motionrep.io._h5read`, which runs it under a watchdog).  A :class:`Session`
opens files and answers small requests -- attributes, members of a group, a dataset's description, a dataset's
data -- and refuses, before reading anything:

- soft links and external links (``/clips/x -> /etc/...`` or another file), on every path it follows;
- datasets whose raw data is stored outside the file (external storage) or assembled from other files (virtual
  datasets);
- datasets with a filter other than deflate, shuffle, Fletcher-32 and LZF (HDF5 would load other filters as
  plugins from the environment);
- datatypes that are neither numbers nor strings (references, compounds, opaque, variable-length sequences);
- datasets larger than the caller allows.

A refusal raises :class:`Refused` with a message; anything h5py raises is left to the caller, who names the file.
"""

from __future__ import annotations

import contextlib
import math
import os
import pickle
import struct
import sys
from collections.abc import Iterator
from typing import Any

import numpy as np

__all__ = ["Session", "Refused", "ALLOWED_FILTERS", "serve"]

h5py: Any = None  # the module, imported by the first Session (see _load_h5py)


def _load_h5py() -> None:
    """Import h5py for this module.  The worker and an in-process session need it; a process that only forwards
    requests to a worker (:mod:`motionrep.io._h5read` imports :class:`Refused` from here) does not, and is spared
    its start-up (h5py's import costs about as much as numpy's)."""
    global h5py
    if h5py is None:
        import h5py as module

        h5py = module

#: HDF5 filters a motionrep file may use: deflate (gzip), shuffle, Fletcher-32 checksum, LZF (built into h5py).
ALLOWED_FILTERS = {1: "deflate", 2: "shuffle", 3: "fletcher32", 32000: "lzf"}
_KINDS = "biuf"  # numeric dtype kinds read as arrays


class Refused(Exception):
    """The file asks for something motionrep never does for a file (follow a link, read another file...)."""


def _no_plugins() -> None:
    """Never load HDF5 filter plugins named by a file (they are shared libraries found through the environment)."""
    try:
        h5py.h5pl.set_loading_state(0)
    except Exception:  # pragma: no cover - h5py built without the plugin interface
        pass


class Session:
    """Open HDF5 files by integer handle, and the requests a reader makes of them."""

    def __init__(self) -> None:
        _load_h5py()
        self.files: dict[int, h5py.File] = {}
        self.next_id = 1
        _no_plugins()

    # ---- files -----------------------------------------------------------------------------------------------
    def open(self, path: str) -> int:
        f = h5py.File(path, "r")
        fid = self.next_id
        self.next_id += 1
        self.files[fid] = f
        return fid

    def close(self, fid: int) -> None:
        f = self.files.pop(fid, None)
        if f is not None:
            f.close()

    def close_all(self) -> None:
        for fid in list(self.files):
            try:
                self.close(fid)
            except Exception:
                pass

    # ---- navigation (hard links only) ------------------------------------------------------------------------
    def _object(self, fid: int, path: str) -> Any:
        """The object at ``path`` (``""`` is the root), reached through hard links only."""
        obj = self.files[fid]
        where = ""
        for part in [p for p in path.split("/") if p]:
            if not isinstance(obj, h5py.Group):
                raise Refused(f"'/{where}' is not a group")
            link = obj.get(part, getlink=True)
            where = f"{where}/{part}" if where else part
            if link is None:
                raise KeyError(f"'/{where}' does not exist")
            _check_link(link, where)
            obj = obj[part]
        return obj

    def members(self, fid: int, group: str) -> list[tuple[str, str]]:
        """``(name, kind)`` of each member of ``group`` in stored order, links not followed; kind is ``"group"``,
        ``"dataset"``, ``"soft link"``, ``"external link"`` or ``"other"``."""
        g = self._object(fid, group)
        if not isinstance(g, h5py.Group):
            raise Refused(f"'/{group}' is not a group")
        out = []
        for name in g:
            link = g.get(name, getlink=True)
            if isinstance(link, h5py.SoftLink):
                kind = "soft link"
            elif isinstance(link, h5py.ExternalLink):
                kind = "external link"
            else:
                cls = g.get(name, getclass=True)
                kind = "group" if cls is h5py.Group else "dataset" if cls is h5py.Dataset else "other"
            out.append((name, kind))
        return out

    # ---- attributes ------------------------------------------------------------------------------------------
    def attrs(self, fid: int, path: str) -> dict[str, Any]:
        """Every attribute of the object at ``path``: numbers, strings (``str``; ``bytes`` if not UTF-8) and small
        arrays of them; an attribute of another type maps to ``Ellipsis``."""
        obj = self._object(fid, path)
        out: dict[str, Any] = {}
        for name in obj.attrs:
            attr_id = h5py.h5a.open(obj.id, name.encode("utf-8"))
            dtype = attr_id.dtype
            if not (dtype.kind in _KINDS or h5py.check_string_dtype(dtype) is not None):
                out[name] = Ellipsis
                continue
            # an attribute is small, but a damaged variable-length string's heap size is read whole, as a dataset's
            with address_space(2 * self.files[fid].id.get_filesize() + _HEADROOM):
                value = obj.attrs[name]
            if isinstance(value, np.ndarray) and value.dtype.kind == "O":
                value = [v.decode("utf-8", "surrogateescape") if isinstance(v, bytes) else str(v)
                         for v in value.ravel().tolist()]
            out[name] = value
        return out

    # ---- datasets --------------------------------------------------------------------------------------------
    def _dataset(self, fid: int, path: str) -> h5py.Dataset:
        ds = self._object(fid, path)
        if not isinstance(ds, h5py.Dataset):
            raise Refused(f"'/{path}' is not a dataset")
        _check_storage(ds, path)
        return ds

    def describe(self, fid: int, path: str) -> dict[str, Any]:
        """``shape``, ``dtype`` (a numpy dtype; for strings ``"string"``), ``itemsize`` (bytes per element as
        read; 0 for variable-length strings) and ``filters`` (names) of a dataset, without reading its data."""
        ds = self._dataset(fid, path)
        info = h5py.check_string_dtype(ds.dtype)
        if info is not None:
            dtype: Any = "string"
            itemsize = 0 if info.length is None else int(info.length)
        elif ds.dtype.kind in _KINDS and ds.dtype.fields is None and ds.dtype.subdtype is None:
            dtype, itemsize = np.dtype(ds.dtype), int(ds.dtype.itemsize)
        else:
            raise Refused(f"dataset '/{path}' has an unsupported datatype ({ds.dtype})")
        return {"shape": tuple(int(n) for n in ds.shape) if ds.shape is not None else None, "dtype": dtype,
                "itemsize": itemsize, "filters": _filters(ds)}

    def read(self, fid: int, path: str, max_bytes: int) -> Any:
        """A dataset's data: a numpy array, or for strings a list of ``str`` (``bytes`` where not UTF-8).

        Refuses a dataset whose data (declared shape x item size) exceeds ``max_bytes`` before reading it.
        """
        desc = self.describe(fid, path)
        ds = self.files[fid][path]
        shape = desc["shape"]
        if shape is None:
            raise Refused(f"dataset '/{path}' has no data space")
        count = math.prod(shape)
        size = count * (desc["itemsize"] or 16)
        if size > max_bytes:
            raise Refused(f"dataset '/{path}' declares shape {shape}: {size} bytes, more than the {max_bytes} "
                          "allowed")
        if ds.chunks is not None and count:
            expected = math.prod(-(-n // c) for n, c in zip(shape, ds.chunks))
            if ds.id.get_num_chunks() != expected:  # a damaged chunk index reads fill values, silently
                raise Refused(f"dataset '/{path}' has {ds.id.get_num_chunks()} of its {expected} chunks: the file "
                              "is damaged")
        with address_space(4 * size + 2 * self.files[fid].id.get_filesize() + _HEADROOM):
            return self._read_data(ds, desc["dtype"] == "string")

    @staticmethod
    def _read_data(ds: h5py.Dataset, strings: bool) -> Any:
        if strings:
            raw = ds[()]
            items = raw.ravel().tolist() if isinstance(raw, np.ndarray) else [raw]
            out = []
            for v in items:
                if isinstance(v, bytes):
                    try:
                        v = v.decode("utf-8")
                    except UnicodeDecodeError:
                        pass
                out.append(v)
            return out
        return ds[()]


#: What one dataset read may add to the reader's address space beyond its data and the file (library buffers).
_HEADROOM = 64 << 20


@contextlib.contextmanager
def address_space(extra: int) -> Iterator[None]:
    """Let this process's address space grow by at most ``extra`` bytes while the block runs (``RLIMIT_AS``;
    Linux, elsewhere nothing): a damaged size inside the file (a global heap collection's, read whole for
    variable-length strings) then fails an allocation in the HDF5 library instead of taking gigabytes."""
    try:
        import resource

        with open("/proc/self/statm", "rb") as fh:
            used = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    except (ImportError, OSError, ValueError):
        yield
        return
    cap = used + int(extra)
    for bound in (soft, hard):
        if bound != resource.RLIM_INFINITY:
            cap = min(cap, bound)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def _check_link(link: Any, where: str) -> None:
    if isinstance(link, h5py.SoftLink):
        raise Refused(f"'/{where}' is a soft link (to {link.path!r}); motionrep follows no links in a file")
    if isinstance(link, h5py.ExternalLink):
        raise Refused(f"'/{where}' is an external link (to {link.filename!r}); motionrep reads only the file "
                      "itself")
    if not isinstance(link, h5py.HardLink):
        raise Refused(f"'/{where}' is a link of an unknown kind")


def _check_storage(ds: h5py.Dataset, path: str) -> None:
    if ds.is_virtual:
        raise Refused(f"dataset '/{path}' is a virtual dataset (its data would come from other files); motionrep "
                      "reads only data stored in the file itself")
    plist = ds.id.get_create_plist()
    if plist.get_external_count() > 0:
        name = plist.get_external(0)[0]
        raise Refused(f"dataset '/{path}' keeps its data in an external file ({name.decode('utf-8', 'replace')!r});"
                      " motionrep reads only data stored in the file itself")
    for fid_ in _filter_ids(plist):
        if fid_ not in ALLOWED_FILTERS:
            raise Refused(f"dataset '/{path}' uses HDF5 filter {fid_}; motionrep reads only "
                          + ", ".join(ALLOWED_FILTERS.values()))


def _filter_ids(plist: Any) -> list[int]:
    return [int(plist.get_filter(i)[0]) for i in range(plist.get_nfilters())]


def _filters(ds: h5py.Dataset) -> list[str]:
    return [ALLOWED_FILTERS.get(i, str(i)) for i in _filter_ids(ds.id.get_create_plist())]


# ---------------------------------------------------------------------------------------------------------------
# the worker process: length-prefixed pickles over its stdin and stdout
# ---------------------------------------------------------------------------------------------------------------
_HEAD = struct.Struct("<Q")


def _read_exactly(fd: int, n: int) -> bytes | None:
    chunks = []
    while n:
        b = os.read(fd, min(n, 1 << 20))
        if not b:
            return None
        chunks.append(b)
        n -= len(b)
    return b"".join(chunks)


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        view = view[n:]


def _die_with_parent() -> None:
    """On Linux, ask to be killed when the parent dies (a spinning HDF5 call would otherwise outlive it)."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            import signal

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
        except Exception:  # pragma: no cover
            pass


def serve(inp: int, out: int) -> None:
    """Answer requests ``(method, args)`` read from ``inp`` with ``("ok", value)``, ``("refused", message)`` or
    ``("error", type name, message)`` written to ``out``, until ``inp`` closes."""
    session = Session()
    _write_all(out, _HEAD.pack(0))  # ready
    while True:
        head = _read_exactly(inp, _HEAD.size)
        if head is None:
            break
        body = _read_exactly(inp, _HEAD.unpack(head)[0])
        if body is None:
            break
        method, args = pickle.loads(body)
        try:
            reply: tuple = ("ok", getattr(session, method)(*args))
        except Refused as exc:
            reply = ("refused", str(exc))
        except MemoryError:
            reply = ("error", "MemoryError", "not enough memory")
        except Exception as exc:
            reply = ("error", type(exc).__name__, str(exc))
        try:
            data = pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:
            data = pickle.dumps(("error", type(exc).__name__, f"cannot send the result: {exc}"))
        _write_all(out, _HEAD.pack(len(data)) + data)
    session.close_all()


def _main() -> None:  # pragma: no cover - runs in the worker process
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle; it then ends this process
    _die_with_parent()
    out = os.dup(1)
    os.dup2(2, 1)  # stray prints (HDF5 diagnostics) must not reach the protocol pipe
    serve(0, out)


if __name__ == "__main__":  # pragma: no cover
    _main()
