"""`animate`: every PNG of a folder, sorted by name, into an animated GIF or MP4."""

import json

import numpy as np
import pytest
from PIL import Image

from analysis import AnalysisError, animate_folder
from analysis.cli import main

COLOURS = {"frame_02.png": (0, 0, 255), "frame_00.png": (255, 0, 0), "frame_01.png": (0, 255, 0)}


def _frames(folder, colours=COLOURS, size=(24, 16), mode="RGB"):
    folder.mkdir(exist_ok=True)
    for name, rgb in colours.items():                      # written out of name order
        img = np.zeros((size[1], size[0], 3), np.uint8)
        img[:] = rgb
        img[:4, :4] = 255                                   # a white corner marks the orientation
        im = Image.fromarray(img)
        (im.convert(mode) if mode != "RGB" else im).save(folder / name)
    return folder


def test_gif_has_every_frame_in_name_order(tmp_path, capsys):
    folder = _frames(tmp_path / "frames")
    (folder / "readme.txt").write_text("ignored")
    out = tmp_path / "earth.gif"
    assert main(["animate", str(folder), "-o", str(out), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["frames"] == 3 and res["first"] == "frame_00.png" and res["last"] == "frame_02.png"
    assert (res["width_px"], res["height_px"], res["fps"]) == (24, 16, 4.0)
    with Image.open(out) as gif:
        assert gif.n_frames == 3 and gif.size == (24, 16)
        seen = []
        for k in range(3):
            gif.seek(k)
            assert gif.info["duration"] == 250             # 4 frames per second
            rgb = np.asarray(gif.convert("RGB"))
            seen.append(tuple(int(c) for c in rgb[10, 12]))
            assert tuple(rgb[0, 0]) == (255, 255, 255)
    assert seen == [(255, 0, 0), (0, 255, 0), (0, 0, 255)]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["earth.gif", "frames"]      # no temporary file left


def test_rgba_frames_and_fps(tmp_path):
    folder = _frames(tmp_path / "frames", mode="RGBA")
    res = animate_folder(folder, tmp_path / "a.gif", fps=10)
    assert res["duration_s"] == pytest.approx(0.3)
    with Image.open(tmp_path / "a.gif") as gif:
        assert gif.n_frames == 3 and gif.info["duration"] == 100


def test_mp4_by_extension(tmp_path):
    cv2 = pytest.importorskip("cv2")
    folder = _frames(tmp_path / "frames", size=(32, 16))
    out = tmp_path / "earth.mp4"
    animate_folder(folder, out, fps=4)
    cap = cv2.VideoCapture(str(out))
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame[8, 20, ::-1].astype(int))       # BGR -> RGB, away from the white corner
    cap.release()
    assert len(frames) == 3
    for got, want in zip(frames, [(255, 0, 0), (0, 255, 0), (0, 0, 255)]):
        assert np.abs(got - np.array(want)).max() < 40      # lossy codec


@pytest.mark.parametrize("case, message", [
    ("empty", "holds no PNG frame"),
    ("sizes", "every frame must have the same size"),
    ("extension", "use .gif or .mp4"),
    ("notpng", "not a PNG image"),
])
def test_bad_frames_are_clear_errors(tmp_path, capsys, case, message):
    folder = tmp_path / "frames"
    folder.mkdir()
    out = tmp_path / ("earth.avi" if case == "extension" else "earth.gif")
    if case == "empty":
        (folder / "a.txt").write_text("no frames here")
    else:
        _frames(folder)
    if case == "sizes":
        _frames(folder, {"frame_03.png": (9, 9, 9)}, size=(25, 16))
    elif case == "notpng":
        (folder / "frame_09.png").write_text("not an image")
    with pytest.raises(AnalysisError, match=message.replace(".", r"\.")):
        animate_folder(folder, out)
    assert main(["animate", str(folder), "-o", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_analyze_animate_in_a_script(tmp_path, capsys):
    from irtlang.cli import main as irt

    _frames(tmp_path / "rgb")
    script = tmp_path / "anim.inr"
    script.write_text("ANALYZE ANIMATE 'rgb' OUTPUT 'earth.gif' FPS 2\n")
    assert irt(["run", str(script), "--out", str(tmp_path / "out")]) == 0
    assert "frames: 3" in capsys.readouterr().out
    with Image.open(tmp_path / "out" / "earth.gif") as gif:
        assert gif.n_frames == 3 and gif.info["duration"] == 500
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert "earth.gif" in json.dumps(manifest)
