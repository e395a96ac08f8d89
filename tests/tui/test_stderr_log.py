"""Issue 54: while the workbench runs, standard error (a worker process's, a logging
handler made before the app, Dask's tracebacks) goes to the log file the help names,
never over the screen; Textual keeps the terminal on `sys.__stderr__`."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

from tui.stderr_log import log_path, log_path_text, stderr_to_log


def test_standard_error_goes_to_the_log_and_the_terminal_stays_textuals(tmp_path, capfd):
    stream = os.fdopen(2, "w", buffering=1, closefd=False)  # the process's standard error, as at import
    handler = logging.StreamHandler(stream)  # as distributed makes its own before the app runs
    logger = logging.getLogger("loopcraft-test-stale-handler")
    logger.addHandler(handler)
    try:
        screen_before = sys.__stderr__
        with stderr_to_log(tmp_path / "app.log") as path:
            subprocess.run([sys.executable, "-c", "import sys; sys.stderr.write('worker: heartbeat failed\\n')"])
            logger.error("distributed.comm.tcp: retry_operation")
            os.write(2, b"a C library's line\n")
            sys.__stderr__.write("drawn by Textual\n")
            sys.__stderr__.flush()
            assert sys.__stderr__ is not screen_before
        assert sys.__stderr__ is screen_before
    finally:
        logger.removeHandler(handler)
    logged = path.read_text()
    assert "worker: heartbeat failed" in logged and "retry_operation" in logged and "a C library's line" in logged
    assert "drawn by Textual" not in logged
    assert "drawn by Textual" in capfd.readouterr().err  # the terminal's descriptor, as before
    os.write(2, b"after the app\n")
    assert "after the app" in capfd.readouterr().err and "after the app" not in path.read_text()


def test_the_log_lives_in_the_apps_folder_and_the_help_names_it(tmp_path, monkeypatch):
    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    assert log_path() == tmp_path / "home" / "loopcraft.log" and log_path_text() == "$LOOPCRAFT_HOME/loopcraft.log"
    monkeypatch.delenv("LOOPCRAFT_HOME")
    assert (
        log_path() == Path.home() / ".loopcraft" / "loopcraft.log" and log_path_text() == "~/.loopcraft/loopcraft.log"
    )


def test_a_failing_study_is_a_message_and_the_keys_come_back(workdir, monkeypatch):
    """A study whose cluster fails (here: the sweep raises in its worker, with Dask's kind of
    log line on standard error) says so in a notification; nothing is printed over the
    screen by the app, and the session's keys act again."""
    import asyncio

    from tests.tui.test_app import settle
    from tui.app import LoopcraftApp
    from tui.state.sweep_desk import SweepDesk

    def failing(self, text, progress=None, cancelled=lambda: False):
        logging.getLogger("distributed.comm.tcp").error("heartbeat ... retry_operation")
        raise OSError("Timed out trying to connect to tcp://127.0.0.1:9 after 1 s")

    monkeypatch.setattr(SweepDesk, "run", failing)

    async def scenario() -> None:
        app = LoopcraftApp(workdir / "report003_lag_lead.json")
        async with app.run_test(size=(120, 40)) as pilot:
            await settle(app, pilot)
            await pilot.press("w")
            await pilot.pause()
            app.screen.query_one("#value").value = "tolerance K=+-10% samples 4"
            await pilot.press("enter")
            await settle(app, pilot)
            titles = [n.title for n in app._notifications]
            assert "sweep failed" in titles and not app.busy
            assert app.screen.query_one("#tabs").active == "sweep"

    asyncio.run(scenario())
