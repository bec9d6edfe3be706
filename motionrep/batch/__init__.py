"""The batch wing: many clips at once, on a local pool or a Dask cluster.

The engine, where work runs (executors), where results are written and resumed (store, checksum), and the
totals at the end."""


def __getattr__(name: str):
    """The names of the former module ``motionrep.batch`` (``run_batch``, ``compress_clips``...), answered from
    :mod:`motionrep.batch.engine` with a :class:`DeprecationWarning` (motionrep/_moved.py has the other moves)."""
    import importlib
    import warnings

    engine = importlib.import_module(f"{__name__}.engine")
    if name.startswith("__") or not hasattr(engine, name):
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(f"motionrep.batch.{name} is now motionrep.batch.engine.{name}: import it from there",
                  DeprecationWarning, stacklevel=2)
    return getattr(engine, name)
