"""The user's config: theme, unit, recent files and key bindings by id."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.config import SAMPLE, ConfigError, load_config
from tui.keys import binding_table


def test_every_binding_has_a_unique_id():
    ids = [row[0] for row in binding_table()]
    assert all(ids) and len(ids) == len(set(ids))


def test_the_sample_reads_and_bad_files_say_where(tmp_path):
    path = tmp_path / "config.toml"
    path.write_text(SAMPLE)
    config = load_config(path, themes={"textual-dark", "textual-light"})
    assert (config.theme, config.unit, config.recent_limit, config.plots) == ("textual-light", "hz", 10, "image")
    assert config.keys["app.step"] == "s,j"
    for text, message in [
        ("theme = \n", "line 1, column"),
        ("colour = 'red'\n", "unknown key 'colour'"),
        ("unit = 'Hz'\n", "unit"),
        ("recent_limit = -1\n", "recent_limit"),
        ("[keys]\n'app.step' = 3\n", "[keys]"),
        ("theme = 'neon'\n", "unknown theme"),
        ("plots = 'sixel'\n", "plots: 'sixel' is not one of text, image"),
    ]:
        path.write_text(text)
        with pytest.raises(ConfigError, match=None) as info:
            load_config(path, themes={"textual-dark"})
        assert message in str(info.value) and str(path) in str(info.value), (text, str(info.value))
    assert load_config(tmp_path / "missing.toml").theme == "textual-dark"


@synchronous
async def test_the_app_takes_the_theme_and_a_rebound_key(workdir, monkeypatch, tmp_path):
    config = tmp_path / "config.toml"
    config.write_text('theme = "textual-light"\n[keys]\n"app.step" = "j"\n')
    monkeypatch.setenv("LOOPCRAFT_CONFIG", str(config))
    app = LoopcraftApp(workdir / "coebra_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert app.theme == "textual-light"
        await pilot.press("j")
        await settle(app, pilot)
        assert app.bench.iteration == 1


@synchronous
async def test_a_bad_config_is_reported_and_the_app_still_opens(workdir, monkeypatch, tmp_path):
    config = tmp_path / "config.toml"
    config.write_text("theme = \n")
    monkeypatch.setenv("LOOPCRAFT_CONFIG", str(config))
    app = LoopcraftApp(workdir / "coebra_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert app.bench is not None
        assert any("line 1" in n.message for n in app._notifications)


def test_loopcraft_config_prints_where_and_what(tmp_path):
    config = tmp_path / "config.toml"
    config.write_text('unit = "hz"\n')
    env = {"LOOPCRAFT_CONFIG": str(config), "PATH": ""}
    out = subprocess.run(
        [sys.executable, "-m", "tui.cli", "config", "--keys"], capture_output=True, text=True, env=env, check=True
    ).stdout
    assert str(config) in out and "unit = 'hz'" in out and "app.step" in out
    config.write_text("unit = 3\n")
    bad = subprocess.run([sys.executable, "-m", "tui.cli", "config"], capture_output=True, text=True, env=env)
    assert bad.returncode == 2 and "unit" in bad.stderr and "Traceback" not in bad.stderr
