"""A session's JSON text: stable (sorted keys, shortest float repr), standard JSON
that reads back as it was (inf and -inf written as 1e999 and -1e999, nan as
"nan"), and for autosaves made again only where it changed.

An autosave writes the whole session every few seconds of a run; after 1000
iterations of a two-channel `cip` session that is some 10 MB, and encoding it
held the GIL for most of a second (the UI thread stalls meanwhile; a save
runs on it).  A record, once made, is never changed in place
(`sessions.store.write_autosave` copies the list of them, not them): its
texts are kept with it, and a session's text is the rest of the session
with the records' texts spliced in."""

from __future__ import annotations

import json
import math
import secrets
import threading
from typing import Any

from sessions.format.schema import SessionModel

_MARKER = "\0" + secrets.token_hex(8)  # stands in for an infinity (and the records) while encoding
_RECORD_TEXTS: dict[int, tuple[dict, dict[bool, str]]] = {}  # id -> (the record, kept alive: its id is
# not reused; its text by compactness)
_LOCK = threading.Lock()


def dumps(model: SessionModel, compact: bool = False) -> str:
    """Stable JSON: sorted keys, shortest float repr, two-space indent (``compact``: none,
    for autosaves); inf and -inf as 1e999 and -1e999, nan as "nan".  Each record's
    text is kept from the last time (the module docstring)."""
    skipped = {"records"} | (set() if model.earlier else {"earlier"})  # no hand history: the file as before it
    data = _plain(model.model_dump(mode="python", exclude_none=False, exclude=skipped), _MARKER)
    data["records"] = _MARKER + "records"
    text = _standard(json.dumps(data, indent=None if compact else 2, sort_keys=True, allow_nan=False))
    texts = _record_texts(model.records, compact)
    if compact:
        records = "[" + ", ".join(texts) + "]"
    else:  # json's layout of a list of objects one level in
        records = "[\n    " + ",\n    ".join(texts) + "\n  ]" if texts else "[]"
    return text.replace(json.dumps(data["records"]), records, 1) + "\n"


def _record_texts(records: list[dict], compact: bool) -> list[str]:
    """Each record's text (compact, or indented as two levels in), kept from the last
    call when it is the same record."""
    with _LOCK:
        kept, texts = {}, []
        for record in records:
            hit = _RECORD_TEXTS.get(id(record))
            forms = hit[1] if hit is not None and hit[0] is record else {}
            if compact not in forms:
                encoded = json.dumps(
                    _plain(record, _MARKER), indent=None if compact else 2, sort_keys=True, allow_nan=False
                )
                forms[compact] = _standard(encoded if compact else encoded.replace("\n", "\n    "))
            kept[id(record)] = (record, forms)
            texts.append(forms[compact])
        _RECORD_TEXTS.clear()
        _RECORD_TEXTS.update(kept)
    return texts


def _standard(text: str) -> str:
    """The infinities' stand-ins written as 1e999 and -1e999."""
    return text.replace(json.dumps(_MARKER + "+"), "1e999").replace(json.dumps(_MARKER + "-"), "-1e999")


def _plain(value: Any, marker: str) -> Any:
    """Plain JSON data; an infinity becomes ``marker`` and its sign (`dumps` writes it as 1e999)."""
    if isinstance(value, float):
        if math.isfinite(value):
            return value
        return "nan" if math.isnan(value) else marker + ("+" if value > 0 else "-")
    if isinstance(value, dict):
        return {str(k): _plain(v, marker) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v, marker) for v in value]
    if hasattr(value, "tolist"):
        return _plain(value.tolist(), marker)
    return value
