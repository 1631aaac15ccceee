"""The `irt` command line: exit codes, compiler-style diagnostics on stderr, never a bare traceback.

Exit codes (irtlang/cli.py): 0 ok, 1 run-time failure, 2 input errors, 3 missing capability, 70 internal error.
Most tests run the real command in a subprocess (`python -m irtlang.cli`); the internal-error and
missing-capability paths patch the code in-process (and once in a subprocess) to provoke them.
"""
from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import textwrap

import pytest

import irtlang
from irtlang import cli

GOOD = "UNITS MM\nd = 1200\nSEED 42\nPRINT 'spacing = {d} mm'\nWAVELENGTHS 450 550 650 NM\nCOATING al REFLECT 0.91\n"
BAD = "x = y + 1\nSURFACE\n  PLANE Z 5 deg\nOBJECT a\n"
TRACE_SCRIPT = "PRINT 'before'\nGRID RECT Z 0 -1 1 -1 1 3 3\nSOURCE DIRECTION 0 0 1\nTRACE\nPRINT 'after'\n"


def irt(*args, cwd=None, timeout=120):
    return subprocess.run([sys.executable, "-m", "irtlang.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout)


@pytest.fixture
def scripts(tmp_path):
    (tmp_path / "good.inr").write_text(GOOD)
    (tmp_path / "bad.inr").write_text(BAD)
    (tmp_path / "syntax.inr").write_text("PRINT 'a'\nSHIFT Z (1 + 2\nx = y\n")
    return tmp_path


# ---------------------------------------------------------------- irt check
def test_check_ok(scripts):
    r = irt("check", "good.inr", cwd=scripts)
    assert r.returncode == 0, r.stderr
    assert r.stdout == "good.inr: ok\n"
    assert r.stderr == ""


def test_check_errors_exit_2_with_carets_and_no_traceback(scripts):
    r = irt("check", "bad.inr", cwd=scripts)
    assert r.returncode == 2
    assert r.stdout == ""
    assert r.stderr == ("bad.inr:1:5: error: undefined variable 'y'\n"
                        "    1 | x = y + 1\n"
                        "      |     ^\n"
                        "bad.inr:3:11: error: expected a length, got 5 deg\n"
                        "    3 |   PLANE Z 5 deg\n"
                        "      |           ^^^^^\n"
                        "2 errors\n")
    assert "Traceback" not in r.stderr


def test_check_syntax_error(scripts):
    r = irt("check", "syntax.inr", cwd=scripts)
    assert r.returncode == 2
    assert r.stderr.splitlines() == ["syntax.inr:2:9: error: unterminated parenthesis: '(' is never closed",
                                     "    2 | SHIFT Z (1 + 2",
                                     "      |         ^",
                                     "hint: add the missing ')'",
                                     "1 error"]


def test_check_several_files(scripts):
    r = irt("check", "good.inr", "bad.inr", "syntax.inr", "good.inr", cwd=scripts)
    assert r.returncode == 2
    assert r.stdout == "good.inr: ok\ngood.inr: ok\n"
    assert "bad.inr:1:5: error: undefined variable 'y'" in r.stderr
    assert "syntax.inr:2:9: error: unterminated parenthesis" in r.stderr
    assert r.stderr.count("error:") == 3
    assert "Traceback" not in r.stderr
    r = irt("check", "good.inr", "good.inr", cwd=scripts)
    assert r.returncode == 0


def test_check_a_nonexistent_file(scripts):
    r = irt("check", "nope.inr", cwd=scripts)
    assert r.returncode == 2
    assert r.stderr == "nope.inr: error: no such file: nope.inr\n1 error\n"


def test_check_a_folder(scripts):
    (scripts / "dir.inr").mkdir()
    r = irt("check", "dir.inr", cwd=scripts)
    assert r.returncode == 2
    assert r.stderr.startswith("dir.inr: error: dir.inr is a folder, not a script\n")


def test_check_a_file_with_nul_bytes(scripts):
    (scripts / "bin.inr").write_bytes(b"PRINT 1\n\x00\xff\x00\x12binary junk")
    r = irt("check", "bin.inr", cwd=scripts)
    assert r.returncode == 2
    # issue 21: the NUL is reported at its line and column; nothing after it is shown
    assert r.stderr == ("bin.inr:2:1: error: a NUL byte (\\0) here: bin.inr is not a text script\n"
                        "    2 | \n      | ^\n1 error\n")


def test_check_a_file_that_is_not_utf8(scripts):
    (scripts / "latin1.inr").write_bytes(b"x = 1\nPRINT 'caf\xe9'\n")
    r = irt("check", "latin1.inr", cwd=scripts)
    assert r.returncode == 2
    lines = r.stderr.splitlines()
    assert lines[0] == "latin1.inr:2:11: error: latin1.inr is not a UTF-8 text file (byte 0xe9 at offset 16)"
    assert lines[-1] == "1 error"
    assert "Traceback" not in r.stderr


def test_check_an_include_of_a_binary_file(scripts):
    (scripts / "bin.dat").write_bytes(b"\x00" * 10)
    (scripts / "inc.inr").write_text("x = 1\nINCLUDE 'bin.dat'\n")
    r = irt("check", "inc.inr", cwd=scripts)
    assert r.returncode == 2
    # issue 21: INCLUDE reads scripts only, and never quotes another kind of file
    assert r.stderr.splitlines()[0] == "inc.inr:2:9: error: INCLUDE reads irtlang scripts (*.inr); 'bin.dat' is not one"


@pytest.mark.parametrize("where", ["before", "after"])
def test_debug_flag_is_accepted_and_changes_nothing_for_input_errors(scripts, where):
    args = ["--debug", "check", "bad.inr"] if where == "before" else ["check", "--debug", "bad.inr"]
    r = irt(*args, cwd=scripts)
    assert r.returncode == 2
    assert "bad.inr:1:5: error: undefined variable 'y'" in r.stderr
    assert "Traceback" not in r.stderr


def test_version():
    r = irt("--version")
    assert r.returncode == 0
    assert r.stdout.strip() == f"irt (irtlang) {irtlang.__version__}"


def test_no_command_prints_help_and_exits_2():
    r = irt()
    assert r.returncode == 2
    assert "usage: irt" in r.stdout


# ---------------------------------------------------------------- irt run
def test_run_without_trace_writes_the_manifest(scripts):
    out = scripts / "out dir"
    r = irt("run", "good.inr", "--out", out, cwd=scripts)
    assert r.returncode == 0, r.stderr
    assert "spacing = 1200 mm" in r.stdout
    man = json.loads((out / "manifest.json").read_text())
    assert man["irtlang_version"] == irtlang.__version__
    assert man["script_sha256"] == hashlib.sha256(GOOD.encode()).hexdigest()
    assert man["seed"] == 42
    assert [f["path"] for f in man["files"]] == ["results.nc"]   # results.nc: in every run folder
    assert man["status"] == "complete"
    assert man["script"] == "good.inr"


def test_run_with_input_errors_exits_2_and_writes_nothing(scripts):
    out = scripts / "o"
    r = irt("run", "bad.inr", "--out", out, cwd=scripts)
    assert r.returncode == 2
    assert "bad.inr:3:11: error: expected a length, got 5 deg" in r.stderr
    assert "Traceback" not in r.stderr
    assert not out.exists()


def test_run_a_nonexistent_file(scripts):
    r = irt("run", "nope.inr", cwd=scripts)
    assert r.returncode == 2
    assert r.stderr == "nope.inr: error: no such file: nope.inr\n1 error\n"


def test_run_stops_on_a_missing_capability_and_keeps_the_manifest(tmp_path, monkeypatch, capsys):
    """A step this build cannot execute: exit 3, a located message naming what is missing, a manifest."""
    from irtlang import engine

    def no_tracer(self, step, interp):
        raise engine.MissingCapability(step.span, "TRACE", "the non-sequential tracer")

    monkeypatch.setattr(engine.Engine, "do_trace", no_tracer)
    script = tmp_path / "t.inr"
    script.write_text(TRACE_SCRIPT)
    code = cli.main(["run", str(script), "--out", str(tmp_path / "out")])
    cap = capsys.readouterr()
    assert code == 3
    assert cap.out.splitlines()[0] == "before"
    assert "after" not in cap.out                                   # the run stops at TRACE
    assert cap.err.splitlines()[0] == (
        f"{script}:4:1: error: TRACE needs the non-sequential tracer, which this version of irtlang "
        f"(v{irtlang.__version__}) does not have yet; the run stops here")
    man = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert man["status"] == "stopped: TRACE needs the non-sequential tracer"
    assert man["script_sha256"] == hashlib.sha256(TRACE_SCRIPT.encode()).hexdigest()
    assert [f["path"] for f in man["files"]] == ["results.nc"]   # results.nc: in every run folder


# ---------------------------------------------------------------- internal errors
def _boom(*args, **kwargs):
    raise ZeroDivisionError("simulated bug")


def test_internal_error_asks_for_a_bug_report(tmp_path, monkeypatch, capsys):
    from irtlang.lang import interp

    monkeypatch.setattr(interp.Interpreter, "exec_command", _boom)
    (tmp_path / "s.inr").write_text("PRINT 1\n")
    code = cli.main(["check", str(tmp_path / "s.inr")])
    err = capsys.readouterr().err
    assert code == 70
    assert err.startswith("irt: internal error: ZeroDivisionError: simulated bug\n")
    assert f"This is a bug in irtlang {irtlang.__version__}. Please report it at {cli.BUG_URL}" in err
    assert f"irt --debug check {tmp_path / 's.inr'}" in err
    assert "Traceback" not in err


def test_internal_error_with_debug_shows_the_traceback(tmp_path, monkeypatch, capsys):
    from irtlang.lang import interp

    monkeypatch.setattr(interp.Interpreter, "exec_command", _boom)
    (tmp_path / "s.inr").write_text("PRINT 1\n")
    code = cli.main(["--debug", "check", str(tmp_path / "s.inr")])
    err = capsys.readouterr().err
    assert code == 70
    assert "Traceback (most recent call last)" in err and "ZeroDivisionError: simulated bug" in err


def test_internal_error_in_run_keeps_a_manifest(tmp_path, monkeypatch, capsys):
    from irtlang import engine

    monkeypatch.setattr(engine.Engine, "do_trace", _boom)
    (tmp_path / "t.inr").write_text(TRACE_SCRIPT)
    code = cli.main(["run", str(tmp_path / "t.inr"), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 70 and "irt: internal error: ZeroDivisionError: simulated bug" in err
    man = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert man["status"] == "internal error: ZeroDivisionError: simulated bug"


def test_internal_error_in_a_subprocess_has_no_traceback(tmp_path):
    (tmp_path / "s.inr").write_text("PRINT 1\n")
    code = textwrap.dedent("""
        import sys
        from irtlang.lang import interp
        def boom(*a, **k):
            raise KeyError("simulated")
        interp.Interpreter.exec_command = boom
        from irtlang.cli import main
        sys.exit(main(["check", "s.inr"]))
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert r.returncode == 70
    assert r.stderr.startswith("irt: internal error: KeyError: 'simulated'\n")
    assert "Traceback" not in r.stderr
