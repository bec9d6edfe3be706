"""The flat layout's module names keep answering from the wings (motionrep/_moved.py), with a warning."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from motionrep._moved import MOVED


def _run(code: str) -> str:
    return subprocess.run([sys.executable, "-W", "always::DeprecationWarning", "-c", textwrap.dedent(code)],
                          capture_output=True, text=True, check=True).stdout.strip()


def test_every_old_name_is_the_module_at_its_new_place():
    code = f"""
        import importlib, warnings
        moved = {MOVED!r}
        for old, new in moved.items():
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                a = importlib.import_module(old)
            b = importlib.import_module(new)
            assert a is b, old
            assert b.__spec__.name == new, (old, b.__spec__.name)
            assert any(new in str(w.message) and w.category is DeprecationWarning for w in caught), old
        print("ok")
    """
    assert _run(code) == "ok"


def test_old_names_of_a_package_and_its_submodules_and_of_the_batch_engine():
    code = """
        import warnings
        warnings.simplefilter("ignore")
        from motionrep.codec import Codec
        from motionrep.plugin.codec import Codec as Same
        import motionrep.render.scene as scene
        from motionrep.batch import run_batch
        from motionrep.batch.engine import run_batch as same_batch
        print(Codec is Same, scene.__name__, run_batch is same_batch)
    """
    assert _run(code) == "True motionrep.present.render.scene True"


def test_the_new_names_say_nothing():
    code = """
        import warnings
        warnings.simplefilter("error")
        import motionrep.pipeline.compress, motionrep.plugin.codec, motionrep.batch.engine, motionrep.present.render
        print("quiet")
    """
    assert _run(code) == "quiet"


def test_an_unknown_name_is_still_unknown():
    code = """
        try:
            import motionrep.no_such_module
        except ModuleNotFoundError:
            print("missing")
        import motionrep.batch
        print(hasattr(motionrep.batch, "no_such_name"))
    """
    assert _run(code) == "missing\nFalse"
