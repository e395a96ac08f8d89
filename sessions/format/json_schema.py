"""Write the JSON Schema of the session format: python -m sessions.format.json_schema [FILE]."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from sessions.format.schema import SessionModel

SCHEMA_FILE = Path(__file__).with_name("session.schema.json")


def schema_text() -> str:
    return json.dumps(SessionModel.model_json_schema(), indent=2, sort_keys=True) + "\n"


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else SCHEMA_FILE
    target.write_text(schema_text())
    print(f"wrote {target}")
