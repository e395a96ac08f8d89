"""Garbled CSV tables: the text of a table next to a session, damaged one way."""

from __future__ import annotations

import random

CELLS = (
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e999",
    "-1e999",
    "",
    " ",
    "abc",
    "0",
    "-0",
    "-1",
    "1e-320",
    "0x10",
    "1,5",
    "1e308",
    "--1",
    "\x00",
    "\u00e9",
    "1e-300",
    "10" * 200,
)


def garble_csv(rng: random.Random, text: str) -> tuple[str | bytes, str]:
    """The damaged text (bytes when it is not valid UTF-8) and what was done."""
    lines = text.splitlines(keepends=True)
    header = next((i for i, line in enumerate(lines) if not line.startswith("#")), 0)
    data = list(range(header + 1, len(lines)))
    choice = rng.randrange(14)
    if choice == 0:
        return text[: rng.randrange(len(text) + 1)], "truncated"
    if choice == 1 and data:
        n = rng.choice(data)
        cells = lines[n].rstrip("\r\n").split(",")
        cells[rng.randrange(len(cells))] = rng.choice(CELLS)
        lines[n] = ",".join(cells) + "\n"
        return "".join(lines), f"cell on line {n + 1}"
    if choice == 2:
        return "".join(lines[:header] + lines[header + 1 :]), "no header"
    if choice == 3 and len(data) > 2:
        a, b = rng.sample(data, 2)
        lines[a], lines[b] = lines[b], lines[a]
        return "".join(lines), f"lines {a + 1} and {b + 1} swapped"
    if choice == 4 and data:
        n = rng.choice(data)
        lines.insert(n, lines[n])
        return "".join(lines), f"line {n + 1} twice"
    if choice == 5:
        return "", "empty"
    if choice == 6:
        return bytes(rng.randrange(256) for _ in range(rng.choice((1, 64, 4096)))), "binary"
    if choice == 7:
        return "".join(lines[: header + 1]), "header only"
    if choice == 8 and data:
        return "".join(lines[: header + 1] + [lines[data[0]]]), "one row"
    if choice == 9 and data:
        rows = [lines[rng.choice(data)] for _ in range(rng.choice((10_001, 20_000)))]
        return "".join(lines[: header + 1] + rows), f"{len(rows)} rows"
    if choice == 10 and data:
        n = rng.choice(data)
        lines[n] = lines[n].rstrip("\r\n") + ",extra,1\n"
        return "".join(lines), f"extra cells on line {n + 1}"
    if choice == 11:
        return text.replace(",", ";"), "semicolons"
    if choice == 12:
        return "\ufeff" + text.replace("\n", "\r\n"), "BOM and CRLF"
    if data:
        n = rng.choice(data)
        cells = lines[n].rstrip("\r\n").split(",")
        cells[0] = rng.choice(("0", "-1", "1e-300", "1e300"))
        lines[n] = ",".join(cells) + "\n"
        return "".join(lines), f"frequency on line {n + 1}"
    return text + "garbage", "trailing garbage"
