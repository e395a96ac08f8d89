"""Every numeric option of every subcommand is bounded (`tui.cli.options`): out of its
bounds, NaN or infinite it is refused naming the option, exit status 2, before any
work (``analyze --points -5``, ``--wmin 0``, ``--points 100000000`` reached numpy)."""

from __future__ import annotations

import argparse

import pytest

from tui.cli import build_parser, main
from tui.cli.options import BOUNDS

TF = ["--tf", "1/(s+1)"]
REFUSED = [
    (["analyze", *TF, "--points", "-5"], "--points"),
    (["analyze", *TF, "--points", "100000000"], "--points"),
    (["analyze", *TF, "--wmin", "0"], "--wmin"),
    (["analyze", *TF, "--wmin", "nan"], "--wmin"),
    (["analyze", *TF, "--wmax", "inf"], "--wmax"),
    (["analyze", *TF, "--wmin", "10", "--wmax", "1"], "--wmin"),
    (["analyze", *TF, "--delay", "-1"], "--delay"),
    (["analyze", *TF, "--skew", "nan"], "--skew"),
    (["analyze", *TF, "--gain", "inf"], "--gain"),
    (["analyze", *TF, "--locus", "gain", "--locus-points", "1"], "--locus-points"),
    (["analyze", *TF, "--locus", "gain", "--locus-range", "1", "nan"], "--locus-range"),
    (["analyze", *TF, "--locus", "gain", "--locus-range", "2", "1"], "--locus-range"),
    (["run", "S.json", "--iterations", "-1"], "--iterations"),
    (["run", "S.json", "--time-limit", "nan"], "--time-limit"),
    (["report", "S.json", "--iteration", "-3"], "--iteration"),
    (["export", "S.json", "--to", "json", "--iteration", "-1"], "--iteration"),
    (["compare", "S.json", "--iterations", "-1", "2"], "--iterations"),
    (["tradeoff", "S.json", "--penalty", "q2", "--values", "1", "inf"], "--values"),
    (["sweep", "S.json", "--starts", "0"], "--starts"),
    (["sweep", "S.json", "--starts", "2", "--spread", "0.5"], "--spread"),
    (["sweep", "S.json", "--tolerance", "K=+-1%", "--samples", "10000000"], "--samples"),
    (["sweep", "S.json", "--starts", "2", "--seed", "-1"], "--seed"),
    (["sweep", "S.json", "--starts", "2", "--workers", "0"], "--workers"),
    (["sweep", "S.json", "--starts", "2", "--connect-timeout", "-1"], "--connect-timeout"),
]


@pytest.mark.parametrize(("argv", "option"), REFUSED, ids=[" ".join(a[:1] + a[-2:]) for a, _ in REFUSED])
def test_a_numeric_option_out_of_bounds_is_refused_by_name(argv, option, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"error: {option}" in err and "Traceback" not in err and len(err.splitlines()) == 1


def test_every_numeric_option_has_bounds():
    """A new int or float option without an entry in BOUNDS fails here."""
    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    for name, sub in commands.items():
        numeric = {a.dest for a in sub._actions if a.type in (int, float)}
        assert numeric <= set(BOUNDS.get(name, {})), f"{name}: {sorted(numeric - set(BOUNDS.get(name, {})))}"


def test_options_within_bounds_still_work(capsys):
    assert main(["analyze", *TF, "--points", "50", "--wmin", "0.01", "--wmax", "100"]) == 0


def test_a_tolerance_study_takes_a_million_samples_and_no_more():
    """Issue 53, section 3: a study of 1 000 000 samples keeps its distributions, not its
    runs (peak memory 227 MB on the lag-lead, docs/benchmarks.md), so `--samples` goes to a
    million; a multi-start sweep keeps every run and stays at 100 000 starts."""
    from tui.cli.common import CliError
    from tui.cli.options import check_options

    parser = build_parser()
    study = ["sweep", "S.json", "--tolerance", "K=+-1%", "--samples"]
    check_options(parser.parse_args([*study, "1000000"]))
    with pytest.raises(CliError, match=r"--samples: 1000001 is not in 1\.\.1000000"):
        check_options(parser.parse_args([*study, "1000001"]))
    with pytest.raises(CliError, match=r"--starts: 100001 is not in 1\.\.100000"):
        check_options(parser.parse_args(["sweep", "S.json", "--starts", "100001"]))
