"""The user's settings: a TOML file in the user's config directory.

``$LOOPCRAFT_CONFIG``, else ``$XDG_CONFIG_HOME/loopcraft/config.toml``, else
``~/.config/loopcraft/config.toml``.  Every key is optional:

    theme = "textual-light"     # any Textual theme; textual-dark and textual-light ship
    unit = "hz"                 # the frequency unit of new sessions: "rad/s" or "hz"
    recent_limit = 10           # how many recent sessions the start screen lists
    plots = "image"             # "text" (the default), or images where the terminal shows them
                                #   (sixel, kitty; in tmux: set -g allow-passthrough on)

    [keys]                      # binding id = "key[,key...]" (`loopcraft config` lists the ids)
    "app.step" = "s,j"
    "plant.edit" = "e,enter"

A file that does not read is reported (with its line and column) and the
defaults are used; it is never rewritten by the app.
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

SAMPLE = __doc__.split("Every key is optional:\n\n", 1)[1].split("\n\nA file", 1)[0]
UNITS = ("rad/s", "hz")
PLOTS = ("text", "image")


@dataclass(frozen=True)
class Config:
    """The settings in effect (defaults where the file says nothing)."""

    theme: str = "textual-dark"
    unit: str = "rad/s"
    recent_limit: int = 10
    keys: dict[str, str] = field(default_factory=dict)
    plots: str = "text"


class ConfigError(ValueError):
    """A config file that does not read; the message names the file and where."""


def config_path() -> Path:
    """Where the config file is (it need not exist)."""
    explicit = os.environ.get("LOOPCRAFT_CONFIG")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "loopcraft" / "config.toml"


def load_config(path: Path | None = None, themes: set[str] | None = None) -> Config:
    """The settings of ``path`` (default `config_path`); a `ConfigError` says what is
    wrong and where; a missing file gives the defaults.  ``themes``: the known theme names."""
    path = config_path() if path is None else path
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return Config()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    return _checked(path, data, themes)


def _checked(path: Path, data: dict, themes: set[str] | None) -> Config:
    known = {"theme", "unit", "recent_limit", "keys", "plots"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ConfigError(f"{path}: unknown key {unknown[0]!r}; keys are {', '.join(sorted(known))}")
    theme = data.get("theme", Config.theme)
    if not isinstance(theme, str) or (themes is not None and theme not in themes):
        listed = f"; themes: {', '.join(sorted(themes))}" if themes else ""
        raise ConfigError(f"{path}: theme: unknown theme {theme!r}{listed}")
    unit = data.get("unit", Config.unit)
    if unit not in UNITS:
        raise ConfigError(f"{path}: unit: {unit!r} is not one of {', '.join(UNITS)}")
    limit = data.get("recent_limit", Config.recent_limit)
    if not isinstance(limit, int) or isinstance(limit, bool) or not 0 <= limit <= 100:
        raise ConfigError(f"{path}: recent_limit: a whole number from 0 to 100, not {limit!r}")
    keys = data.get("keys", {})
    if not isinstance(keys, dict) or not all(
        isinstance(k, str) and isinstance(v, str) and v.strip() for k, v in keys.items()
    ):
        raise ConfigError(f'{path}: [keys]: each entry is "binding.id" = "key[,key...]"')
    plots = data.get("plots", Config.plots)
    if plots not in PLOTS:
        raise ConfigError(f"{path}: plots: {plots!r} is not one of {', '.join(PLOTS)}")
    return Config(theme, unit, limit, dict(keys), plots)


def unknown_binding_ids(config: Config, ids: set[str]) -> list[str]:
    """The [keys] entries that name no binding."""
    return sorted(set(config.keys) - ids)
