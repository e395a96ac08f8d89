"""The app's own arguments: --example is in the help, and --help never starts the app."""

from __future__ import annotations

from tui.cli import main


def test_help_lists_example_and_help_after_example_prints_help(capsys, monkeypatch):
    import tui.cli as cli
    monkeypatch.setattr(cli, "run_app", lambda *a, **k: (_ for _ in ()).throw(AssertionError("the app started")))
    for argv in (["--help"], ["--example", "coebra_lag_lead", "--help"], ["x.json", "-h"]):
        try:
            main(argv)
        except SystemExit as exc:
            assert exc.code == 0
        out = capsys.readouterr().out
        assert "--example NAME" in out and "coebra_lag_lead" in out, argv


def test_a_bare_example_option_names_the_examples(capsys):
    assert main(["--example"]) == 2
    assert "report003_lag_lead" in capsys.readouterr().err
    assert main(["x.json", "extra"]) == 2
