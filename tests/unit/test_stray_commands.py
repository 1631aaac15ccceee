"""Bad input and edge cases of the issue-20 commands (STATS PATHS, PST, SPOTS DIAGRAM, APPEND, FOCUS variables),
CONSIDER ONLY before TRACE, and LOAD RAYS of a file without the newer datasets: compiler-style diagnostics with
exit 2, run-time failures with exit 1, never a traceback (exit 70).  No trace runs here."""
import numpy as np
import pytest

from analysis.rayfile import write_rays_v1
from irtlang.cli import main


def _run(tmp_path, text, capsys, cmd="run"):
    f = tmp_path / "s.inr"
    f.write_text(text)
    argv = [cmd, str(f)] + (["--out", str(tmp_path / "out")] if cmd == "run" else [])
    code = main(argv)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


@pytest.mark.parametrize("text,message", [
    ("STATS LEDGER TOP 3\n", "TOP applies to STATS PATHS"),
    ("STATS PATHS TOP 0\n", "TOP"),
    ("APPEND 'x.txt' 1\n", "APPEND writes .csv tables"),
    ("APPEND 'x.csv'\n", "APPEND needs at least one value"),
    ("PST 'p.csv' ANGLES 0 10 3\n", "PST needs ON"),
    ("SURFACE\n  PLANE Z 0 RECT 1 1\nOBJECT det\nPST 'p.txt' ON det ANGLES 0 10 3\n", "PST writes a .csv"),
    ("SPOTS DIAGRAM 'x.csv'\n", "SPOTS DIAGRAM writes a .png"),
    ("SPOTS POSITION ABOUT CHIEF\n", "ABOUT applies to SPOTS DIAGRAM"),
    ("SPOTS DIAGRAM 's.png' THROUGH 1 1\n", "THROUGH needs at least 2 steps"),
])
def test_bad_input_is_a_diagnostic(tmp_path, capsys, text, message):
    code, out, err = _run(tmp_path, text, capsys, "check")
    assert code == 2, out + err
    assert message in err and "s.inr:" in err and "^" in err


def test_check_sets_the_result_variables(tmp_path, capsys):
    text = ("SURFACE\n  PLANE Z 10 DISK 5\nOBJECT det\n  DETECTOR PIXELS 4\nGRID DISK Z 0 5 RAYS 10\n"
            "SOURCE FIELD 0 0\nTRACE\nCONSIDER ONLY det\nSTATS\nSTATS PATHS\nSPOTS POSITION\nFOCUS\n"
            "SPECTRUM OF det\nPST ON det ANGLES 0 10 3\n"
            "PRINT '{STATS_FLUX} {STATS_FLUX_SE} {STATS_RAYS} {PATHS_TOP_FLUX} {PATHS_COUNT} {PATHS_TOP} {SPOTS_RMS}'\n"
            "PRINT '{SPOTS_GEO} {FOCUS_Z} {FOCUS_EFL} {FOCUS_BFL} {FOCUS_FNUM} {FOCUS_MAG} {SPECTRUM_FLUX} {PST_LAST}'\n"
            "APPEND 't.csv' STATS_FLUX FOCUS_Z PST_MAX\n")
    code, out, err = _run(tmp_path, text, capsys, "check")
    assert code == 0, out + err


def test_consider_only_before_trace_warns(tmp_path, capsys):
    text = ("SURFACE\n  PLANE Z 10 DISK 5\nOBJECT det\nSURFACE\n  PLANE Z 5 DISK 5\nOBJECT stop\n"
            "CONSIDER ONLY det\nGRID DISK Z 0 5 RAYS 10\nSOURCE DIRECTION 0 0 1\nTRACE\n")
    code, out, err = _run(tmp_path, text, capsys, "check")
    assert code == 0
    assert "warning: CONSIDER ONLY is in force: this TRACE sees only det; stop takes no part in it" in err
    assert "s.inr:7:1: note: CONSIDER ONLY given here" in err
    code, out, err = _run(tmp_path, text.replace("CONSIDER ONLY det\n", ""), capsys, "check")
    assert "warning" not in err


def _old_file(path):
    """A ray file as irtlang wrote it before the ledger, event kinds and start points were added."""
    n = 4
    write_rays_v1(path, wavelengths_nm=[550.0], objects=["M2", "det"], position=np.zeros((n, 3)),
                  direction=np.tile([0.0, 0.0, 1.0], (n, 1)), flux=np.full(n, 0.25), object=np.full(n, 1),
                  events=np.full(n, 2), history=np.array([[0, 1]] * n), rays_traced=n)


def test_load_rays_names_and_missing_ledger(tmp_path, capsys):
    _old_file(tmp_path / "old.h5")
    code, out, err = _run(tmp_path, "LOAD RAYS 'old.h5'\nCONSIDER ONLY det\nSELECT HIT(M2)\nSTATS\n"
                          "STATS PATHS 'p.csv'\nSTATS LEDGER\n", capsys)
    assert code == 1, out + err
    assert "LOAD RAYS: 4 rays on 2 objects (M2, det)" in out and "does not hold" in out
    assert "STATS: 4 rays selected, flux 1 W" in out
    assert "M2 > det" in out and "'?'" in out
    assert "STATS LEDGER: this ray file holds no ledger" in err
    assert "internal error" not in err


def test_analysis_without_a_trace_is_a_runtime_error(tmp_path, capsys):
    text = "SURFACE\n  PLANE Z 10 RECT 1 1\nOBJECT det\n  DETECTOR PIXELS 2\nPST ON det ANGLES 0 10 3\n"
    code, out, err = _run(tmp_path, text, capsys)
    assert code == 1 and "PST has no source to sweep" in err and "internal error" not in err


def test_path_table_synthetic():
    """Grouping, sorting, `other`, truncated histories and the per-source-ray standard error, on records made by
    hand: two source rays split into records that share their start point count as two contributions."""
    from irtlang.optics.stray import path_table

    H = 3
    R, T, S, A = 1, 2, 3, 4
    hist = np.array([[0 * 8 + S, 1 * 8 + A, -1],          # a > b
                     [0 * 8 + S, 1 * 8 + A, -1],          # a > b (the same source ray: start (0, 0))
                     [0 * 8 + R, 0 * 8 + R, 0 * 8 + R],   # a a a ... (+2 events): truncated
                     [-2, 1 * 8 + A, -1]])                # (volume) > b
    rec = {"history": hist, "events": np.array([2, 2, 5, 2]), "flux": np.array([1.0, 2.0, 0.5, 0.25]),
           "source": np.zeros(4, np.int32), "line": np.zeros(4, np.int32),
           "start": np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])}
    rows, other, total, total_se, n = path_table(rec, np.ones(4, bool), ["a", "b"], n_traced=10, top=2)
    assert n == 3 and total == 3.75
    assert [(r[0], r[1], r[2]) for r in rows] == [("a > b", "scatter > absorb", 3.0),
                                                  ("a > a > a > ... (+2 events)", "reflect > reflect > reflect > ...", 0.5)]
    assert other[0] == "other (1 paths)" and other[2] == 0.25
    # a > b: one source ray carrying 3 W out of 10: s1 = 3, s2 = 9 -> sqrt((0.9 - 0.09) * 100 / 9) = 3
    assert rows[0][3] == pytest.approx(3.0)
    rows, other, total, _, _ = path_table(rec, np.ones(4, bool), ["a", "b"], n_traced=10)
    assert other is None and [r[0] for r in rows][-1] == "(volume) > b"
