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


def test_run_prints_frequencies_in_the_sessions_unit_and_cip_says_db_and_deg(tmp_path, capsys):
    import shutil
    from pathlib import Path

    examples = Path(__file__).resolve().parent.parent / "sessions" / "examples"
    for name in ("cip_launch_vehicle.json", "cip_launch_vehicle.csv", "report003_lag_lead.json"):
        shutil.copy2(examples / name, tmp_path / name)
    assert main(["run", str(tmp_path / "cip_launch_vehicle.json"), "--iterations", "1"]) == 0
    out = capsys.readouterr().out
    assert "freq hz" in out.splitlines()[1]
    assert main(["run", str(tmp_path / "report003_lag_lead.json"), "--iterations", "1"]) == 0
    capsys.readouterr()
    assert main(["report", str(tmp_path / "report003_lag_lead.json")]) == 0
    report = capsys.readouterr().out
    assert "GAIN MARGIN NO.   1 =" in report and " DB " in report and "PHASE MARGIN NO." in report and " DEG " in report
