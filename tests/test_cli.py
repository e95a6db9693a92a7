"""The command line's one error policy (lab.cli.main): exit code 2 for bad input, 1 for a
runtime or hardware failure, no traceback unless --debug, unexpected errors unchanged."""

import errno
import subprocess
import sys

import pytest

from lab import cli
from lab.cli import main
from lab.errors import EXIT_INPUT, EXIT_RUNTIME, InputError, LabError, LabRuntimeError
from lab.rig import RigError


def test_error_classes():
    assert issubclass(InputError, ValueError) and InputError.exit_code == EXIT_INPUT == 2
    assert issubclass(LabRuntimeError, RuntimeError) and LabRuntimeError.exit_code == EXIT_RUNTIME == 1
    assert issubclass(RigError, LabRuntimeError) and issubclass(RigError, LabError)


@pytest.mark.parametrize(
    "argv, words",
    [
        (["simulate", "--robot", "no-such-robot", "--out", "{tmp}/o.csv"], "unknown robot 'no-such-robot'"),
        (["train", "{tmp}/missing.csv", "--out", "{tmp}/m.npz"], "dataset not found"),
        (["train", "{tmp}", "--out", "{tmp}/m.npz"], "{tmp}"),  # a directory as the data
        (
            ["track", "--model", "{tmp}/none.npz", "--trajectory", "circle", "--out", "{tmp}/r.json"],
            "model file not found",
        ),
        (
            [
                "track",
                "--soft-ik",
                "--rig",
                "warp",
                "--trajectory",
                "circle",
                "--n-rings",
                "1",
                "--n-axial",
                "6",
                "--out",
                "{tmp}/r.json",
            ],
            "unknown rig 'warp'",
        ),
        (
            ["capture", "--rig", "twin:{tmp}/none.toml", "--grid", "2", "--out", "{tmp}/c.csv", "--no-progress"],
            "defects file not found",
        ),
    ],
)
def test_bad_input_exits_2_without_traceback(argv, words, tmp_path, capsys):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "error: " in err and words.replace("{tmp}", str(tmp_path)) in err
    assert "Traceback" not in err


def _failing_command(exc):
    def run(args):
        raise exc

    return run


@pytest.mark.parametrize(
    "exc, code",
    [
        (RigError("servo 2 stopped answering"), 1),
        (LabRuntimeError("solver failed"), 1),
        (InputError("field robot.length_m must be positive"), 2),
        (FileNotFoundError(errno.ENOENT, "No such file or directory", "x.csv"), 2),
        (PermissionError(errno.EACCES, "Permission denied", "/ro/out.csv"), 2),
        (IsADirectoryError(errno.EISDIR, "Is a directory", "out"), 2),
        (OSError(errno.ENOSPC, "No space left on device", "out.csv"), 1),
    ],
)
def test_exit_code_follows_the_error(exc, code, monkeypatch, capsys):
    monkeypatch.setattr(cli.train, "run", _failing_command(exc))
    assert main(["train", "d.csv", "--out", "m.npz"]) == code
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "Traceback" not in err
    if isinstance(exc, OSError):
        assert exc.filename in err and exc.strerror in err


@pytest.mark.parametrize("where", ["before", "after"])
def test_debug_shows_the_traceback(where, monkeypatch, capsys):
    monkeypatch.setattr(cli.train, "run", _failing_command(RigError("servo 2 stopped answering")))
    argv = (
        ["--debug", "train", "d.csv", "--out", "m.npz"]
        if where == "before"
        else ["train", "d.csv", "--out", "m.npz", "--debug"]
    )
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and "RigError: servo 2 stopped answering" in err and "error: servo 2" in err


def test_unexpected_errors_keep_their_traceback(monkeypatch):
    monkeypatch.setattr(cli.train, "run", _failing_command(ZeroDivisionError("a bug")))
    with pytest.raises(ZeroDivisionError):
        main(["train", "d.csv", "--out", "m.npz"])


def test_python_m_lab_exit_code_and_message(tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "lab", "train", str(tmp_path / "none.csv"), "--out", str(tmp_path / "m.npz")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2 and "dataset not found" in r.stderr and "Traceback" not in r.stderr


def test_the_command_line_starts_without_the_heavy_libraries():
    # every command imports all of lab.cli: scipy.stats (~0.4 s), torch and numba wait for the
    # code that uses them (each `python -m lab` process, each test that starts one, pays this)
    probe = "import sys, lab.cli, lab.jobs\nprint(sorted({'scipy.stats', 'torch', 'numba'} & set(sys.modules)))"
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, check=True)
    assert r.stdout.strip() == "[]", r.stdout + r.stderr


def test_every_command_has_its_module():
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert (
        set(sub.choices)
        == set(cli.COMMANDS)
        == {
            "simulate",
            "train",
            "splits",
            "track",
            "capture",
            "defects",
            "transfer",
            "transfer-curve",
            "data-curve",
            "calibrate",
            "fit-dynamics",
            "import-data",
            "inspect",
            "compare",
        }
    )
    for name, module in cli.COMMANDS.items():
        assert (
            module.__name__ == f"lab.cli.{name.replace('-', '_')}"
            and callable(module.add_parser)
            and callable(module.run)
        )


@pytest.mark.parametrize("sig, code", [("SIGTERM", 143), ("SIGHUP", 129)])
def test_sigterm_and_sighup_stop_like_ctrl_c(sig, code, monkeypatch, capsys):
    import os
    import signal
    import time

    cleaned = []

    def run(args):
        try:
            os.kill(os.getpid(), getattr(signal, sig))
            time.sleep(5)  # the signal arrives here
        finally:
            cleaned.append(True)  # what a rig's close() (torque off) does
        return 0

    before = signal.getsignal(signal.SIGTERM)
    monkeypatch.setattr(cli.train, "run", run)
    assert main(["train", "d.csv", "--out", "m.npz"]) == code
    err = capsys.readouterr().err
    assert cleaned == [True] and f"interrupted by {sig}" in err and "Traceback" not in err
    assert signal.getsignal(signal.SIGTERM) is before  # handlers restored
