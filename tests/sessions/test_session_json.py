"""A session's text (compact for autosaves, indented for saves) keeps each
record's text: it is the whole encoding's text exactly, records that are new
or replaced are encoded again, and infinities read back as infinities."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

from sessions.format.json_text import _MARKER, _RECORD_TEXTS, _plain, dumps
from sessions.runner import run_session
from sessions.store import load_session, parse_session

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def _full(model, compact: bool = True) -> str:
    """The text as the whole session encoded at once (independent of the kept texts; an
    empty hand history left out, as a session without one saves)."""
    text = json.dumps(
        _plain(
            model.model_dump(mode="python", exclude_none=False, exclude=set() if model.earlier else {"earlier"}),
            _MARKER,
        ),
        sort_keys=True,
        indent=None if compact else 2,
        allow_nan=False,
    )
    return text.replace(json.dumps(_MARKER + "+"), "1e999").replace(json.dumps(_MARKER + "-"), "-1e999") + "\n"


def test_the_text_is_the_whole_encoding_and_keeps_the_records_texts(tmp_path):
    shutil.copy(EXAMPLES / "coebra_lag_lead.json", tmp_path / "s.json")
    session = load_session(tmp_path / "s.json")
    run_session(session, iterations=4, autosave=False)
    model = session.model
    measures = [dict(m, value=-math.inf) for m in model.records[1]["measures"]]
    model.records[1] = dict(model.records[1], objective=math.inf, measures=measures, reason="1e999 as text")
    first = dumps(model, compact=True)
    assert first == _full(model)
    assert [_RECORD_TEXTS[id(r)][0] for r in model.records] == model.records  # each record's text is kept
    kept = {id(r): _RECORD_TEXTS[id(r)][1][True] for r in model.records}
    model.records[2] = dict(model.records[2], objective=-1.5)  # replaced, never changed in place
    again = dumps(model, compact=True)
    assert again == _full(model) and again != first
    assert _RECORD_TEXTS[id(model.records[0])][1][True] is kept[id(model.records[0])]  # not encoded again
    read = parse_session(again, "s.json", tmp_path).model.records
    assert read[1]["objective"] == math.inf and read[1]["measures"][0]["value"] == -math.inf
    assert read[1]["reason"] == "1e999 as text" and read[2]["objective"] == -1.5
    assert dumps(model) == _full(model, compact=False) and dumps(model) == _full(model, compact=False)
    model.records.clear()
    assert dumps(model) == _full(model, compact=False) and dumps(model, compact=True) == _full(model)
