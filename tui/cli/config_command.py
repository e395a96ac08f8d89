"""`loopcraft config`: where the user's config file is, what it holds, and the
ids of every key binding it can rebind (tui.config)."""

from __future__ import annotations

import argparse

from tui.cli.common import CliError


def cmd_config(args: argparse.Namespace) -> int:
    """Print the config's path and settings in effect; --sample: a sample file; --keys: the binding ids."""
    from tui.config import SAMPLE, ConfigError, config_path, load_config

    if args.sample:
        print(SAMPLE)
        return 0
    from textual.theme import BUILTIN_THEMES

    path = config_path()
    try:
        config = load_config(path, themes=set(BUILTIN_THEMES))
    except ConfigError as exc:
        raise CliError(str(exc)) from None
    print(f"config file: {path} ({'found' if path.exists() else 'not found: the defaults are used'})")
    print(f"theme = {config.theme!r}\nunit = {config.unit!r}\nrecent_limit = {config.recent_limit}")
    for binding_id, keys in sorted(config.keys.items()):
        print(f"keys.{binding_id} = {keys!r}")
    if args.keys:
        import tui.app  # noqa: F401 - defines (and so identifies) every binding
        from tui.keys import binding_table

        print("\nbinding id                          keys              what it does")
        for binding_id, keys, what in binding_table():
            shown = config.keys.get(binding_id, keys)
            print(f"{binding_id:<35} {shown:<17} {what}")
    return 0


def add_parser(sub) -> None:
    p = sub.add_parser(
        "config",
        help="where the config file is and what it holds (theme, unit, keys)",
        description="The user's settings: a TOML file (LOOPCRAFT_CONFIG, else "
        "$XDG_CONFIG_HOME/loopcraft/config.toml, else ~/.config/loopcraft/config.toml).",
    )
    p.add_argument("--keys", action="store_true", help="also list every key binding's id, keys and action")
    p.add_argument("--sample", action="store_true", help="print a sample config file")
    p.set_defaults(handler=cmd_config)
