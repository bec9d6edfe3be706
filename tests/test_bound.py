"""The bound (``--max-error``) parsed once: one parser, called only at the doors; a :class:`MaxError` crosses process
boundaries as it is; its text keeps every digit."""

from __future__ import annotations

import pickle
import re
from pathlib import Path

import pytest

from motionrep.model.bound import MaxError, StoredBound, parse_max_error

LIBRARY = Path(__file__).resolve().parent.parent / "motionrep"


def test_the_text_of_a_bound_parses_back_to_it():
    for text in ("2%", "1.5", "0.123456789", "1234567.5%", "1e-05", "3"):
        parsed = parse_max_error(text)
        assert parse_max_error(str(parsed)) == parsed
    assert str(parse_max_error("2%")) == "2%" and str(parse_max_error("1.50")) == "1.5"


def test_a_pipeline_crosses_a_process_boundary_without_parsing_its_bound(monkeypatch):
    """A worker (pickle, as the process pool and Dask do) gets the MaxError itself: never its text again."""
    from motionrep.model import bound
    from motionrep.pipeline.compress import Pipeline

    pipeline = Pipeline.build("svd", max_error="0.123456789")
    data = pickle.dumps(pipeline)

    def refuse(value):
        if isinstance(value, str):
            raise AssertionError(f"the bound's text {value!r} was parsed again")
        return value

    monkeypatch.setattr(bound, "parse_max_error", refuse)
    import motionrep.pipeline.compress as compress

    monkeypatch.setattr(compress, "parse_max_error", refuse)
    again = pickle.loads(data)
    assert again.max_error == pipeline.max_error == MaxError(0.123456789, False)  # every digit


def test_one_parse_of_the_bound_text_in_the_library():
    """The parser is called at the door only: ``Pipeline.build`` (a Python caller's string), and the reader of
    version-1 ``.mrc`` files (their bound is text).  The command line parses its options there too."""
    calls = []
    for path in sorted(LIBRARY.rglob("*.py")):
        if "cli" in path.relative_to(LIBRARY).parts or path.name == "bound.py":
            continue
        for line in path.read_text().splitlines():
            if re.search(r"\bparse_max_error\(", line):
                calls.append(str(path.relative_to(LIBRARY)))
    assert sorted(calls) == ["io/container.py", "pipeline/compress.py"], calls


def test_stored_bound_json_round_trip():
    for stored in (StoredBound(MaxError(2.0, True), 3.04), StoredBound(MaxError(1.5, False), 1.5),
                   StoredBound(None, None)):
        assert StoredBound.from_json(stored.as_json()) == stored
    assert StoredBound(None, None).kind == "none" and StoredBound(None, None).read_as(1.0, None) is None
    with pytest.raises(ValueError, match="'kind'"):
        StoredBound.from_json({"kind": "furlongs", "value": 1, "distance": 1})
