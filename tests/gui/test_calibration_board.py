"""The Calibration page's board form, headless: the form composes the board spec the CLI
and the saved files take and parses it back (round trip, against the calibration
plugin's own parser as the reference); the square size is required (no silent 25 mm);
the drawing shows as many points as the plugin's board has, with the size dimensioned;
and the board is looked for in the first image before calibrating (OpenCV's sample:
54 of 54 inner corners; a wrong count found nowhere, with what to check; a generated
ChArUco board: all of its corners).
"""

from __future__ import annotations

import asyncio
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("trame")
cv2 = pytest.importorskip("cv2")

from camcmm.errors import InputError  # noqa: E402
from camcmm.gui.pages.calibration import board as bf  # noqa: E402
from camcmm.gui.pages.calibration import boardsvg  # noqa: E402
from camcmm_plugins.calibration.boards import board_points, parse_board  # noqa: E402

DATA = Path(__file__).parents[1] / "data" / "opencv_stereo_chessboard"
SPECS = [
    "chessboard:9x6:25",
    "chessboard:13x12:30",
    "charuco:11x8:15:11:DICT_5X5_100",
    "charuco:5x7:40:30:DICT_4X4_50",
    "circles:7x6:20",
    "acircles:4x11:10",
    "chessboard:9x6:1.5875",
]


@pytest.mark.parametrize("spec", SPECS)
def test_parse_then_compose_gives_the_spec_back(spec):
    form = bf.parse(spec)
    assert form["unit"] == "mm"
    assert bf.compose(form) == spec
    # the plugin reads the composed spec as the form says (its parser is the reference)
    b = parse_board(bf.compose(form))
    assert (b.kind, b.cols, b.rows, b.square) == (form["kind"], form["cols"], form["rows"], form["square"])


def test_compose_converts_the_unit_and_parse_reads_it_back_in_mm():
    form = dict(bf.blank(), square="1", unit="in")
    spec = bf.compose(form)
    assert spec == "chessboard:9x6:25.4"
    back = bf.parse(spec)
    assert back["square"] == pytest.approx(25.4, abs=1e-12) and back["unit"] == "mm"
    charuco = dict(bf.blank(), kind="charuco", cols="11", rows="8", square="1.5", marker="1.1", unit="cm")
    assert bf.compose(charuco) == "charuco:11x8:15:11:DICT_5X5_100"
    assert parse_board(bf.compose(charuco)).marker == pytest.approx(11.0)
    # the spec short of the dictionary (the CLI's default) reads into the form with it
    assert bf.parse("charuco:11x8:15:11")["dictionary"] == "DICT_5X5_100"


def test_the_square_size_is_required_never_assumed():
    form = bf.blank()
    assert form["square"] == ""  # a new form has no size
    for square in ("", None, "  "):
        with pytest.raises(InputError, match="square size: enter it"):
            bf.compose(dict(form, square=square))
    with pytest.raises(InputError, match="circle spacing: enter it"):
        bf.compose(dict(form, kind="circles"))
    for bad, why in (("0", "positive"), ("-2", "positive"), ("abc", "not a number"), ("inf", "positive")):
        with pytest.raises(InputError, match=why):
            bf.compose(dict(form, square=bad))
    with pytest.raises(InputError, match="marker size: enter it"):
        bf.compose(dict(form, kind="charuco", square="15"))
    with pytest.raises(InputError, match="smaller than the square"):
        bf.compose(dict(form, kind="charuco", square="15", marker="15"))
    with pytest.raises(InputError, match="inner corners across"):
        bf.compose(dict(form, square="25", cols="8.5"))
    with pytest.raises(InputError, match="unknown kind"):
        bf.parse("dots:9x6:25")
    # the check on the first image runs before the size is entered: the scale does not
    # change which points are found
    assert bf.detection_spec(form) == "chessboard:9x6:1"
    assert bf.detection_spec(dict(form, kind="charuco", cols=11, rows=8)) == "charuco:11x8:1:0.75:DICT_5X5_100"


def _svg(form):
    root = ET.fromstring(boardsvg.svg(form))
    ns = "{http://www.w3.org/2000/svg}"
    dots = [c for c in root.iter(f"{ns}circle") if c.get("class") == "point"]
    size = next(t for t in root.iter(f"{ns}text") if t.get("class") == "size")
    texts = " ".join(t.text or "" for t in root.iter(f"{ns}text"))
    return root, dots, size.text, texts


@pytest.mark.parametrize("spec", SPECS[:6])
def test_the_drawing_has_the_boards_points_and_its_size(spec):
    form = bf.parse(spec)
    root, dots, size, texts = _svg(form)
    expected, what = board_points(parse_board(spec))  # the plugin's count of the board's points
    assert int(root.get("data-points")) == len(dots) == expected
    assert root.get("data-what") == what
    assert size.endswith(f"{form['square']:g} mm")
    assert f"{form['cols']} {bf.COUNTS[form['kind']]} across" in texts
    # the dots lie on the drawing's grid: a chessboard's on square corners (one square apart)
    xs = sorted({float(c.get("cx")) for c in dots})  # written to 0.01 px
    if form["kind"] in ("chessboard", "charuco", "circles"):
        assert len(xs) == (form["cols"] - 1 if form["kind"] == "charuco" else form["cols"])
        assert np.ptp(np.diff(xs)) <= 0.011


def test_the_drawing_says_the_size_is_missing_and_the_unit_entered():
    _, _, size, _ = _svg(bf.blank())
    assert size == "square size required"
    _, _, size, _ = _svg(dict(bf.blank(), square="1", unit="in"))
    assert size == "square size 1 in = 25.4 mm"
    assert boardsvg.data_url("<svg/>").startswith("data:image/svg+xml;base64,")


def test_describe_in_words():
    assert bf.describe("chessboard:9x6:25") == "chessboard, 9 × 6 inner corners, 25 mm squares"
    assert bf.describe("acircles:4x11:10") == "asymmetric circle grid, 4 × 11 circles, spacing 10 mm"
    assert "ChArUco board, 11 × 8 squares, 15 mm squares, 11 mm markers (5 × 5 bits, 100 markers)" == bf.describe(
        "charuco:11x8:15:11"
    )
    # every dictionary offered is one OpenCV has, named in words
    assert all(hasattr(cv2.aruco, d["value"]) and "DICT" not in d["title"] for d in bf.DICTIONARIES)


def test_board_check_counts_the_points_of_a_generated_charuco_board(tmp_path):
    from camcmm.host import default_host
    from camcmm.model import Image
    from camcmm.tasks import calibration as task

    b = parse_board("charuco:7x5:20:15:DICT_4X4_50")
    img = cv2.copyMakeBorder(b.charuco().generateImage((700, 500)), 40, 40, 40, 40, cv2.BORDER_CONSTANT, value=255)
    out = task.check_board(default_host(), Image(img, name="charuco.png"), b.spec)
    assert out["found"] and (out["count"], out["expected"]) == (24, 24)
    assert out["text"] == "found 24 of 24 inner corners on charuco.png"


@pytest.mark.skipif(not DATA.is_dir(), reason="tests/data/opencv_stereo_chessboard is missing")
def test_the_page_checks_the_board_on_the_first_image_and_requires_the_size(gui_app, tmp_path):
    server, session = gui_app(data_roots=[DATA])
    page = server.pages["calibration"]
    s = page.state
    assert s.cal_board == "" and "square size" in s.cal_board_error  # no silent 25 mm
    s.cal_source, s.cal_folder, s.cal_left_pattern = "folder", str(DATA), "left*"
    out = asyncio.run(page.check_board_async())  # before any size is entered
    assert out["text"] == "found 54 of 54 inner corners on left01.jpg" and out["state"] == "ok"
    assert s.cal_board_check["image"].startswith("data:image/jpeg;base64,")
    # Calibrate without the size: refused in one line naming it, nothing run
    assert asyncio.run(page.run_async()) is None
    assert s.cal_error.startswith("board square size: enter it") and "\n" not in s.cal_error
    assert session.page_error("calibration") == s.cal_error
    # the square counted instead of the inner corners: found nowhere, and what to check
    s.cal_board_cols, s.cal_board_rows = 10, 7
    out = asyncio.run(page.check_board_async())
    assert out["state"] == "missing" and out["text"].startswith("found 0 of 70 inner corners on left01.jpg: ")
    assert "one fewer than the squares" in out["text"]
    # the size entered: the spec composed, the refusal gone
    s.cal_board_cols, s.cal_board_rows, s.cal_board_square = 9, 6, "2.5"
    s.cal_board_unit = "cm"
    page.board_changed()
    assert s.cal_board == "chessboard:9x6:25" and s.cal_error == "" and session.page_error("calibration") == ""
    assert "25 mm squares" in s.cal_board_words
    # a stored board fills the form (the saved files keep the spec, in mm)
    page._set_request({"board": "charuco:11x8:15:11:DICT_5X5_100"})
    assert page.board_form() == {"kind": "charuco", "cols": 11, "rows": 8, "square": 15.0, "unit": "mm",
                                 "marker": 11.0, "dictionary": "DICT_5X5_100"}  # fmt: skip
    assert s.cal_board == "charuco:11x8:15:11:DICT_5X5_100"
    # no image chosen yet: said, not an error
    s.cal_folder = str(tmp_path)
    out = asyncio.run(page.check_board_async())
    assert out["text"].startswith("no image chosen yet") and out["state"] == ""
