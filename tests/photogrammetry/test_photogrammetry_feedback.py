"""Feedback of structure from motion (issue 30): progress that moves, and a reason one can
act on for each image the mapper left out.

- the messages ``<stage>: <done> of <total> <unit>, about <time> left``: the estimate is the
  remaining items at the mean rate so far (exact arithmetic checked);
- :class:`progress.Stages` never reports a fraction below one reported before;
- :func:`diagnose.reason` on constructed links: each kind (too little texture, no matches,
  matched only with unregistered images, too few inlier matches to the model, degenerate
  geometry — homography or one partner —, matches agreeing on no pose) with its counts;
- :func:`progress.in_chunks` does every item once, in order, in pieces sized from the rate;
- eight templeRing views at 320 px (0.3 s of matching): the progress events are monotone,
  count images and pairs up to the totals, the pair total is the number of rows COLMAP wrote
  (read with sqlite3 afterwards, not through pycolmap), and each unregistered image's reason
  names its partners with the inlier counts the database holds for those pairs.
"""

from __future__ import annotations

import re
import sqlite3

import numpy as np
import pytest

from camcmm_plugins.photogrammetry import diagnose, progress
from camcmm_plugins.photogrammetry.diagnose import Link, Links, Mapper
from helpers.paths import SHARED_DATA

TEMPLE = SHARED_DATA / "middlebury_mvs_templering"


def test_step_text_counts_and_estimates_the_time_left():
    assert progress.step_text("matching", 0, 232, "pairs") == "matching: 0 of 232 pairs"
    # 58 pairs in 20 s: 174 left at 2.9 pairs/s = 60 s
    assert progress.step_text("matching", 58, 232, "pairs", 20.0) == "matching: 58 of 232 pairs, about 60 s left"
    # 10 of 47 images in 4 s: 37 more take 14.8 s
    assert progress.step_text("features", 10, 47, "images", 4.0) == "features: 10 of 47 images, about 15 s left"
    assert progress.step_text("features", 3, 47, "images", 1.0) == "features: 3 of 47 images"  # too early to say
    assert progress.step_text("features", 47, 47, "images", 9.0) == "features: 47 of 47 images"
    assert progress.step_text("matching", 500, 1081, "pairs", 150.0).endswith("about 2 min 54 s left")
    assert progress.parse_step("matching: 58 of 232 pairs, about 60 s left") == ("matching", 58, 232, "pairs")
    assert progress.parse_step("final bundle adjustment") is None


def test_stages_never_report_a_smaller_fraction():
    import pycolmap

    seen: list[float] = []
    st = progress.Stages(pycolmap, lambda f, m: seen.append(f), None)
    st.report("extract", 0.5, "features: 5 of 10 images")
    st.report("extract", 0.2, "features: late message of another thread")
    assert seen == [0.125, 0.125]  # 0.5 of the stage's 0.25, kept
    st.run("extract", "features", lambda: None)
    st.report("match", 0.5, "matching: 5 of 10 pairs")
    assert seen[-1] == pytest.approx(0.25 + 0.5 * 0.4)


def test_in_chunks_does_every_item_once_in_order_in_growing_pieces():
    import time

    import pycolmap

    seen, pieces = [], []
    st = progress.Stages(pycolmap, lambda f, m: seen.append((f, m)), None)

    def work(piece, first):
        pieces.append((list(piece), first))
        time.sleep(0.002 * len(piece))  # 500 items/s: 0.1 s holds 50

    items = list(range(203))
    progress.in_chunks(st, "match", "matching", "pairs", items, work, first=8, start=0.05, target_s=0.1)
    assert [i for p, _ in pieces for i in p] == items and [f for _, f in pieces] == [True] + [False] * (len(pieces) - 1)
    assert len(pieces[0][0]) == 8 and max(len(p) for p, _ in pieces) > 20  # sized from the rate
    steps = [progress.parse_step(m) for _, m in seen]
    assert steps[0] == ("matching", 0, 203, "pairs") and steps[-1] == ("matching", 203, 203, "pairs")
    assert [s[1] for s in steps] == sorted(s[1] for s in steps) and len(steps) == len(pieces) + 1
    assert seen[0][0] == pytest.approx(0.05 * 0.4) and seen[-1][0] == pytest.approx(0.4)


# -- reasons of constructed cases ----------------------------------------------------------------
LIMITS = Mapper(min_inliers=30, min_ratio=0.25, min_pair=15)


def _reason(n_features, links, on_points):
    return diagnose.reason(n_features, Links(links, on_points), LIMITS)


def test_reason_too_little_texture_and_no_matches():
    kind, text = _reason(40, [], 0)
    assert kind == "texture" and text.startswith("only 40 SIFT features (< 100)") and "speckle" in text
    kind, text = _reason(900, [Link("b.png", 0, "DEGENERATE", True)], 0)
    assert kind == "no matches" and "exhaustive" in text


def test_reason_matched_only_with_unregistered_images():
    kind, text = _reason(900, [Link("g.png", 120, "CALIBRATED", False), Link("h.png", 80, "UNCALIBRATED", False)], 0)
    assert kind == "not linked" and "(g.png, h.png)" in text and "views between" in text


def test_reason_too_few_inlier_matches_names_the_counts_and_the_minimum():
    links = [Link("a.png", 22, "UNCALIBRATED", True), Link("b.png", 9, "UNCALIBRATED", True)]
    kind, text = _reason(900, links, 12)
    assert kind == "too few"
    assert text.startswith(
        "too few inlier matches to the registered images: 31 with 2 registered images (a.png 22, b.png 9), "
        "12 of them on points of the model where the mapper needs 30; try: "
    )
    assert "overlap" in text and "sequential or exhaustive" in text
    assert _reason(900, links, 30)[0] != "too few"  # 30 is enough


def test_reason_degenerate_geometry_homography_or_one_partner():
    planar = [Link("a.png", 300, "PLANAR", True), Link("b.png", 200, "PANORAMIC", True)]
    kind, text = _reason(900, planar, 250)
    assert kind == "degenerate" and "a.png, b.png fit a homography" in text and "baseline" in text
    # one usable partner (the other pair has fewer than 15 inlier matches: the mapper does not use it)
    one = [Link("a.png", 300, "CALIBRATED", True), Link("b.png", 14, "CALIBRATED", True)]
    kind, text = _reason(900, one, 200)
    assert kind == "degenerate" and "only one registered image (a.png, 300 inlier matches)" in text
    # one homography pair beside a general one is not degenerate
    assert _reason(900, [planar[0], Link("c.png", 90, "CALIBRATED", True)], 250)[0] == "inconsistent"


def test_reason_matches_that_agree_on_no_pose():
    links = [Link("a.png", 200, "CALIBRATED", True), Link("b.png", 150, "UNCALIBRATED", True)]
    kind, text = _reason(900, links, 160)
    assert kind == "inconsistent" and "its 160 matches on points of the model (2 registered images: " in text
    assert "needs 30 and 25% of them" in text and "; try: " in text


# -- a real series ---------------------------------------------------------------------------------
def _pair_inliers(db) -> dict[tuple[int, int], int]:
    """Verified matches per image-id pair, read from COLMAP's tables with sqlite3
    (pair_id = id1 * 2147483647 + id2, COLMAP's database.cc)."""
    con = sqlite3.connect(str(db))
    try:
        rows = con.execute("SELECT pair_id, rows FROM two_view_geometries").fetchall()
        names = dict(con.execute("SELECT image_id, name FROM images").fetchall())
    finally:
        con.close()
    out = {}
    for pid, n in rows:
        a, b = divmod(int(pid), 2147483647)
        out[(names[a], names[b])] = out[(names[b], names[a])] = int(n)
    return out


@pytest.fixture(scope="module")
def eight_views(tmp_path_factory):
    """Eight templeRing views at 320 px, sparse (the browser test's series): the result,
    the progress events and the work folder (the database kept)."""
    import cv2

    from camcmm_plugins.photogrammetry.sfm import reconstruct_sparse

    files = sorted(TEMPLE.glob("templeR00*.png"))[:8]
    if len(files) < 8:
        pytest.skip("the templeRing images are absent")
    work = tmp_path_factory.mktemp("sfm8")
    events: list[tuple[float, str]] = []
    images = [cv2.imread(str(f))[:, :, ::-1] for f in files]
    out = reconstruct_sparse(
        images, [f.name for f in files], max_image_size=320, progress=lambda f, m: events.append((f, m)), workdir=work
    )
    return out, events, work


def test_progress_moves_monotone_and_counts_to_the_totals(eight_views):
    out, events, work = eight_views
    fractions = [f for f, _ in events]
    assert all(b >= a for a, b in zip(fractions, fractions[1:])) and fractions[-1] >= 0.95
    steps = [progress.parse_step(m) for _, m in events]
    by = {k: [(s[1], s[2]) for s in steps if s and s[0] == k] for k in ("features", "matching", "mapping")}
    assert by["features"][0] == (0, 8) and by["features"][-1] == (8, 8)
    # every pair COLMAP tried has a row; the count reported reaches that number
    con = sqlite3.connect(str(work / "database.db"))
    try:
        n_rows = con.execute("SELECT COUNT(*) FROM two_view_geometries").fetchone()[0]
    finally:
        con.close()
    assert n_rows == out.options["pairs_listed"] == 28  # 8 views, 8 partners each: every pair
    assert by["matching"][0] == (0, 28) and by["matching"][-1] == (28, 28)
    registered = [d for d, _ in by["mapping"]]
    assert registered == sorted(registered) and by["mapping"][-1] == (len(out.views), 8)
    for k in by.values():
        done = [d for d, _ in k]
        assert done == sorted(done)
    # in stage order
    stage_of = [s[0] for s in steps if s]
    assert stage_of.index("matching") > max(i for i, s in enumerate(stage_of) if s == "features")


def test_each_unregistered_image_has_a_reason_with_the_databases_counts(eight_views):
    out, _, work = eight_views
    missing = [r for r in out.images if not r["registered"]]
    assert missing, "the series registers fully now: pick one that leaves images out"
    registered = {r["image"] for r in out.images if r["registered"]}
    files = {f.name.split("_", 1)[1]: f.name for f in (work / "images").iterdir()}
    inliers = _pair_inliers(work / "database.db")
    for row in missing:
        assert row["kind"] in diagnose.TRY and "; try: " in row["reason"], row
        # the partners named with their counts are the database's pairs of this image
        for name, n in re.findall(r"(templeR\d+\.png) (\d+)", row["reason"]):
            assert name in registered and inliers[(files[row["image"]], files[name])] == int(n)
        if row["kind"] == "not linked":  # its verified partners are all unregistered
            partners = [b for (a, b), n in inliers.items() if a == files[row["image"]] and n > 0]
            assert partners and not {p.split("_", 1)[1] for p in partners} & registered
    warning = next(w for w in out.warnings if "not registered" in w)
    assert warning.startswith(f"{len(missing)} of 8 images not registered: ")
    assert all(r["image"] in warning for r in missing)
    assert np.isfinite(out.reprojection_rms_px)
