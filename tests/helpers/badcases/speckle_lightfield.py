"""Bad inputs of ``camcmm speckle stability``, ``camcmm lightfield gradient|study`` and of
``camcmm info`` on the edge cases of the image reader's header parsing (issue 26).

Every image is decoded by camcmm's one reader (camcmm.io.image), which reads the size from
the header and refuses a bomb before decoding it, and refuses what it cannot size. The
light-field study is validated as one schema before any run is read: each problem one
line naming the file, the key path (``runs[0].focal_length_mm``) and the value.

Ids start with ``sl-``: ``sl-sp-`` speckle stability, ``sl-info-`` the reader through
``camcmm info``, ``sl-lg-`` lightfield gradient, ``sl-ls-`` lightfield study. The valid
building blocks are small (a 96 x 96 px speckle image, a 400-point cloud, a 64 x 48 px
depth map), so every case runs well under a second.
"""

from __future__ import annotations

import functools
import json
import struct

import numpy as np

from helpers.badinputs import Case, bmp, jpeg_header, ply_binary, png, tiff

W, H = 64, 48  # the light-field run's camera and depth map, px


@functools.cache
def speckle(shift: int = 0, size: int = 96, ext: str = ".png") -> bytes:
    """A blurred-noise 'speckle' image, shifted ``shift`` px to the right."""
    import cv2

    img = (np.random.default_rng(0).random((size, size)) * 255).astype(np.uint8)
    img = cv2.GaussianBlur(img, (3, 3), 0)
    return cv2.imencode(ext, np.roll(img, shift, axis=1))[1].tobytes()


def _jpeg_bomb(before_sof: bytes) -> bytes:
    """A 20000 x 20000 px JPEG header with an APP0 segment and ``before_sof`` between it and SOF0."""
    h = jpeg_header(20000, 20000)
    app0 = b"\xff\xe0" + struct.pack(">H", 16) + b"JFIF\0\x01\x01\0\0\x01\0\x01\0\0"
    return h[:2] + app0 + before_sof + h[2:]


def _tiff_no_size() -> bytes:
    """A TIFF whose directory lacks ImageWidth/ImageLength."""
    t = tiff(8, 8)
    return t.replace(struct.pack("<HHI", 256, 4, 1), struct.pack("<HHI", 300, 4, 1), 1)


@functools.cache
def _cloud() -> bytes:
    """400 points of a plane 300 mm in front of the camera (z = 0, camera at z = -300)."""
    g = np.random.default_rng(1).uniform(-20, 20, (400, 2))
    return ply_binary(np.column_stack([g, np.zeros(len(g))]))


def _views(**camera) -> bytes:
    cam = {"fx": 100.0, "fy": 100.0, "cx": 31.5, "cy": 23.5, "dist": [], "width": W, "height": H, **camera}
    return json.dumps(
        {"camera": cam, "views": [{"image": "v0.png", "R": np.eye(3).tolist(), "t": [0, 0, 300]}]}
    ).encode()


@functools.cache
def _depth() -> bytes:
    import cv2

    ramp = np.tile(np.linspace(1000, 60000, W), (H, 1)).astype(np.uint16)
    return cv2.imencode(".png", ramp)[1].tobytes()


def _run_files(prefix: str = "", depth: bytes | None = None, views: bytes | None = None) -> dict[str, bytes]:
    """One light-field run: cloud.ply, views.json, depth/v0.png + sidecar."""
    return {
        f"{prefix}cloud.ply": _cloud(),
        f"{prefix}views.json": _views() if views is None else views,
        f"{prefix}depth/v0.png": _depth() if depth is None else depth,
        f"{prefix}depth/v0.json": b'{"lambda_min": -6.0, "lambda_max": 9.0}',
    }


def _speckle_cases() -> list[Case]:
    out: list[Case] = []
    a, b = speckle(0), speckle(1)

    def sp(cid, images, files, names, extra=(), env=None):
        all_files = {"a.png": a, "b.png": b, **files}
        out.append(Case(f"sl-sp-{cid}", ("speckle", "stability", *images, *extra), all_files, names, env=env or {}))

    # decompression bombs: refused from the header, before a pixel is decoded
    sp("bomb-png", ("a.png", "bomb.png"), {"bomb.png": png(20000, 20000)}, ("bomb.png", "20000"))
    sp("bomb-png-first", ("bomb.png", "a.png"), {"bomb.png": png(20000, 20000)}, ("bomb.png",))
    sp("jpeg-byte-before-sof0", ("a.png", "j.jpg"), {"j.jpg": _jpeg_bomb(b"\x00")}, ("j.jpg", "20000"))
    sp("jpeg-junk-before-sof0", ("a.png", "j.jpg"), {"j.jpg": _jpeg_bomb(b"junk" * 25)}, ("j.jpg", "20000"))
    sp("jpeg-fill-before-sof0", ("a.png", "j.jpg"), {"j.jpg": _jpeg_bomb(b"\xff" * 7)}, ("j.jpg", "20000"))
    sp("jpeg-stuffed-before-sof0", ("a.png", "j.jpg"), {"j.jpg": _jpeg_bomb(b"\xff\x00\x01")}, ("j.jpg",))
    sp("png-65535", ("a.png", "h.png"), {"h.png": png(65535, 65535, idat=b"x")}, ("h.png", "65535"))
    sp(
        "png-65535-above-opencv",  # above OpenCV's own CV_IO_MAX_IMAGE_PIXELS: still one line
        ("a.png", "h.png"),
        {"h.png": png(65535, 65535, idat=b"x")},
        ("h.png",),
        env={"CAMCMM_MAX_IMAGE_PIXELS": "10000000000"},
    )
    sp("tiff-bomb", ("a.png", "t.tif"), {"t.tif": tiff(20000, 20000, body=b"")}, ("t.tif",))
    sp("bmp-bomb", ("a.png", "m.bmp"), {"m.bmp": bmp(20000, 20000, body=b"")}, ("m.bmp",))
    sp("bmp-negative-width", ("a.png", "m.bmp"), {"m.bmp": bmp(-64, 64, body=b"")}, ("m.bmp",))
    sp("png-zero", ("a.png", "z.png"), {"z.png": png(0, 0, idat=b"")}, ("z.png",))
    sp("cap-env", ("a.png", "b.png"), {}, ("a.png",), env={"CAMCMM_MAX_IMAGE_PIXELS": "100"})
    sp("cap-env-bad", ("a.png", "b.png"), {}, ("CAMCMM_MAX_IMAGE_PIXELS",), env={"CAMCMM_MAX_IMAGE_PIXELS": "lots"})
    # headers that cannot be sized: refused, not decoded
    sp("png-no-ihdr", ("a.png", "n.png"), {"n.png": b"\x89PNG\r\n\x1a\n" + b"rubbish" * 10}, ("n.png",))
    sp("jpeg-sos-before-sof", ("a.png", "s.jpg"), {"s.jpg": b"\xff\xd8\xff\xda\x00\x02" + b"\0" * 64}, ("s.jpg",))
    sp("jpeg-soi-only", ("a.png", "s.jpg"), {"s.jpg": b"\xff\xd8\xff"}, ("s.jpg",))
    sp("tiff-no-size", ("a.png", "t.tif"), {"t.tif": _tiff_no_size()}, ("t.tif",))
    sp("bmp-short-header", ("a.png", "m.bmp"), {"m.bmp": b"BM" + b"\0" * 12}, ("m.bmp",))
    # truncated and wrong content
    sp("truncated-png", ("a.png", "t.png"), {"t.png": b[: len(b) // 2]}, ("t.png",))
    sp("truncated-jpeg", ("a.png", "t.jpg"), {"t.jpg": speckle(0, ext=".jpg")[:400]}, ("t.jpg",))
    sp("png-named-jpg", ("a.png", "p.jpg"), {"p.jpg": b}, ("p.jpg",))
    sp("text-named-png", ("a.png", "x.png"), {"x.png": b"hello, not an image\n" * 20}, ("x.png",))
    sp("empty-png", ("a.png", "e.png"), {"e.png": b""}, ("e.png",))
    sp("text-file", ("a.png", "notes.txt"), {"notes.txt": b"hello\n"}, ("notes.txt",))
    sp("cloud-file", ("a.png", "c.ply"), {"c.ply": _cloud()}, ("c.ply",))
    sp("folder", ("a.png", "d.png"), {"d.png/": b""}, ("d.png",))
    sp("missing", ("a.png", "nothere.png"), {}, ("nothere.png",))
    sp("fifo", ("a.png", "f.png"), {"f.png": b"<fifo>"}, ("f.png",))
    sp("symlink-loop", ("a.png", "l.png"), {"l.png": b"->l.png"}, ("l.png",))
    # series that cannot be compared
    sp("mixed-sizes", ("a.png", "big.png"), {"big.png": speckle(0, size=128)}, ("big.png",))
    sp("one-image", ("a.png",), {}, ("a.png",))
    sp("tiny-image", ("a.png", "t.png"), {"t.png": speckle(0, size=8)}, ("t.png",))
    sp("flat-image", ("f.png", "a.png"), {"f.png": png(96, 96)}, ("f.png",))
    # limits
    for v in ("0", "-1", "nan", "inf", "abc", "1e400", "1e9"):
        sp(f"limit-{v}", ("a.png", "b.png"), {}, ("limit", v), extra=(f"--limit={v}",))
    for v in ("0", "-2", "nan"):
        sp(f"std-limit-{v}", ("a.png", "b.png"), {}, ("std_limit", "std-limit", v), extra=(f"--std-limit={v}",))
    # plot targets
    for cid, target, files in (
        ("txt", "p.txt", {}),
        ("folder", "d", {"d/": b""}),
        ("no-ext", "plot", {}),
        ("missing-parent", "no/where/p.png", {}),
        ("parent-is-file", "a.png/p.png", {}),
        ("fifo", "f.png", {"f.png": b"<fifo>"}),
        ("empty", "", {}),
    ):
        sp(f"plot-{cid}", ("a.png", "b.png"), files, (target or "--plot",), extra=(f"--plot={target}",))
    return out


def _info_cases() -> list[Case]:
    out: list[Case] = []

    def ic(cid, name, data, names=None):
        out.append(Case(f"sl-info-{cid}", ("info", name), {name: data}, names or (name,)))

    ic("jpeg-byte-before-sof0", "j.jpg", _jpeg_bomb(b"\x00"))
    ic("jpeg-junk-before-sof0", "j.jpg", _jpeg_bomb(b"\x12\x34\x56"))
    ic("jpeg-fill-before-sof0", "j.jpg", _jpeg_bomb(b"\xff\xff\xff"))
    ic("jpeg-height-zero", "z.jpg", jpeg_header(640, 0))
    ic("jpeg-no-sof", "n.jpg", b"\xff\xd8\xff\xd9")
    ic("jpeg-cut-in-sof", "c.jpg", jpeg_header(640, 480)[:8])
    ic("jpeg-bad-length", "l.jpg", b"\xff\xd8\xff\xe0\x00\x01" + b"\0" * 32)
    ic("png-65535", "h.png", png(65535, 65535, idat=b"x"))
    ic("png-cut-in-ihdr", "c.png", png(64, 48)[:20])
    ic("png-no-ihdr", "n.png", b"\x89PNG\r\n\x1a\n" + b"\0" * 40)
    ic("tiff-no-size", "t.tif", _tiff_no_size())
    ic("tiff-ifd-beyond-end", "t.tif", b"II*\0" + struct.pack("<I", 10**9) + b"\0" * 16)
    ic(
        "bigtiff-bomb",
        "b.tif",
        b"II+\0"
        + struct.pack("<HHQ", 8, 0, 16)
        + struct.pack("<Q", 2)
        + struct.pack("<HHQQ", 256, 16, 1, 10**6)
        + struct.pack("<HHQQ", 257, 16, 1, 10**6),
    )
    ic("bmp-zero-height", "z.bmp", bmp(64, 0, body=b""))
    ic("bmp-short", "s.bmp", b"BM\0\0")
    ic("unknown-header", "u.png", b"GIF89a" + b"\0" * 40)
    out.append(Case("sl-info-jpeg-stray-bytes-valid", ("info", "ok.jpg"), {"ok.jpg": _stray_jpeg()}, ("ok.jpg",)))
    return out


@functools.cache
def _stray_jpeg() -> bytes:
    """A valid JPEG with 3 stray bytes between two segments (libjpeg decodes it, warning)."""
    e = speckle(0, ext=".jpg")
    return e[:20] + b"abc" + e[20:]


def _gradient_cases() -> list[Case]:
    out: list[Case] = []
    base = ("lightfield", "gradient", "--cloud", "cloud.ply", "--views", "views.json", "--depth-maps", "depth")

    def gc(cid, extra, names, files=None, argv=base):
        out.append(Case(f"sl-lg-{cid}", (*argv, *extra), files or _run_files(), names))

    for opt, v in (
        ("band", "nan"),
        ("band", "-1"),
        ("band", "1e400"),
        ("band", "1000"),
        ("scale", "0"),
        ("scale", "-1"),
        ("scale", "nan"),
        ("scale", "inf"),
        ("sigma-lambda", "-1"),
        ("sigma-lambda", "nan"),
        ("region", "somewhere"),
        ("lambda-convention", "eq9"),
        ("depth-measure", "height"),
    ):
        gc(f"{opt}-{v}", (f"--{opt}={v}",), (opt, opt.replace("-", "_"), v))
    for cid, v in (("reversed", "5,1"), ("nan", "nan,1"), ("text", "a"), ("three", "1,2,3"), ("inf", "-inf,inf")):
        gc(f"lambda-range-{cid}", (f"--lambda-range={v}",), ("lambda range", v))
    gc("cloud-missing", (), ("nocloud.ply",), argv=(*base[:3], "nocloud.ply", *base[4:]))
    gc("views-missing", (), ("noviews.json",), argv=(*base[:5], "noviews.json", *base[6:]))
    gc("depth-missing", (), ("nodepth",), argv=(*base[:7], "nodepth"))
    gc("depth-is-file", (), ("views.json",), argv=(*base[:7], "views.json"))
    gc("depth-bomb", (), ("v0.png",), files=_run_files(depth=png(20000, 20000)))
    gc("depth-jpeg-bomb-as-png", (), ("v0.png",), files=_run_files(depth=_jpeg_bomb(b"\x00")))
    gc("depth-65535", (), ("v0.png",), files=_run_files(depth=png(65535, 65535, idat=b"x")))
    gc("depth-8bit", (), ("v0.png",), files=_run_files(depth=png(W, H)))
    gc("depth-above-map-limit", (), ("v0.png", "4000 x 2500"), files=_run_files(depth=png(4000, 2500)))
    gc("depth-truncated", (), ("v0.png",), files=_run_files(depth=_depth()[:100]))
    for cid, cam in (
        ("fx-negative", {"fx": -100.0}),
        ("fx-zero", {"fx": 0}),
        ("fx-nan", {"fx": float("nan")}),
        ("fx-text", {"fx": "abc"}),
        ("width-text", {"width": "abc"}),
        ("width-negative", {"width": -64}),
    ):
        gc(f"views-{cid}", (), ("views.json",), files=_run_files(views=_views(**cam)))
    rot = json.loads(_views())
    rot["views"][0]["R"] = [[2, 0, 0], [0, 1, 0], [0, 0, 1]]
    gc("views-r-not-rotation", (), ("views.json",), files=_run_files(views=json.dumps(rot).encode()))
    rot["views"][0]["R"] = np.eye(3).tolist()
    rot["views"][0]["t"] = [0, 0, float("inf")]
    gc("views-t-inf", (), ("views.json",), files=_run_files(views=json.dumps(rot).encode()))
    gc("views-not-json", (), ("views.json",), files=_run_files(views=b"{not json"))
    # the parameters the command has no option for, through `camcmm run`
    run = ("run", "lightfield.gradient", "cloud.ply", "views.json", "depth", "--json")
    for cid, v in (("text", '[["a",1],[2,3],[4,5]]'), ("nan", "[[NaN,1],[2,3],[4,5]]"), ("two", "[[1,2],[3,4]]")):
        gc(f"run-polygon-{cid}", ("--polygon", v), ("polygon",), argv=run)
    for opt, v in (("--tolerance", "0"), ("--tolerance", "nan"), ("--min-pixels", "0"), ("--scatter-points", "-1")):
        gc(f"run{opt}-{v}", (opt, v), (opt[2:].replace("-", "_"), v), argv=run)
    gc("views-empty", (), ("views.json",), files=_run_files(views=b'{"views": []}'))
    return out


def _study(runs=None, **top) -> bytes:
    import yaml

    if runs is None:
        runs = [
            {"set": "S1", "artefact": "A", "focal_length_mm": 30.0, "gradient_mm_per_lambda": 3.5},
            {"set": "S2", "artefact": "A", "focal_length_mm": 40.0, "gradient_mm_per_lambda": 5.0},
        ]
    return yaml.safe_dump({"name": "t", "runs": runs, **top}, sort_keys=False).encode()


def _study_cases() -> list[Case]:
    out: list[Case] = []

    def sc(cid, data, names, files=None, extra=(), name="study.yaml"):
        all_files = {name: data, **(files or {})}
        out.append(Case(f"sl-ls-{cid}", ("lightfield", "study", name, *extra), all_files, names))

    def run(**over):
        r = {"set": "S1", "artefact": "A", "focal_length_mm": 30.0, "gradient_mm_per_lambda": 3.5}
        r.update(over)
        return {k: v for k, v in r.items() if v is not None}

    def fileset(**over):
        r = {"set": "S1", "artefact": "A", "focal_length_mm": 30.0}
        r.update(cloud="cloud.ply", views="views.json", depth_maps="depth")
        r.update(over)
        return {k: v for k, v in r.items() if v is not None}

    second = {"set": "S2", "artefact": "A", "focal_length_mm": 40.0, "gradient_mm_per_lambda": 5.0}
    # the document's shape
    sc("list", b"- 1\n- 2\n", ("study.yaml",))
    sc("runs-missing", b"name: x\n", ("study.yaml", "runs"))
    sc("runs-empty", b"runs: []\n", ("study.yaml", "runs"))
    sc("runs-text", b"runs: everything\n", ("runs", "everything"))
    sc("run-text", _study(["just a run"]), ("runs[0]",))
    sc("run-no-set", _study([run(set=None)]), ("runs[0]",))
    sc("run-no-artefact", _study([run(artefact=None)]), ("runs[0]",))
    sc("set-list", _study([run(set=[1, 2])]), ("runs[0].set",))
    sc("set-empty", _study([run(set="  ")]), ("runs[0].set",))
    sc("set-bool", _study([run(set=True)]), ("runs[0].set",))
    sc("unknown-top-key", _study(predict_focal=45), ("predict_focal",))
    sc("unknown-run-key", _study([run(focal_lenght_mm=30.0)]), ("runs[0].focal_lenght_mm",))
    sc("name-mapping", _study(name={"a": 1}), ("name",))
    sc("yaml-syntax", b"runs: [\n", ("study.yaml",))
    sc("yaml-duplicate-key", b"runs: []\nruns: []\n", ("study.yaml", "runs"))
    sc("empty-file", b"", ("study.yaml",))
    sc(
        "json-nan",
        b'{"runs": [{"set": "S1", "artefact": "A", "gradient_mm_per_lambda": NaN}]}',
        ("runs[0]",),
        name="s.json",
    )
    # numbers
    for cid, v in (
        ("text", "abc"),
        ("nan", float("nan")),
        ("inf", float("inf")),
        ("negative", -30.0),
        ("zero", 0),
        ("list", [30]),
    ):
        sc(f"focal-{cid}", _study([run(focal_length_mm=v), second]), ("runs[0].focal_length_mm",))
    for cid, v in (("text", "abc"), ("nan", float("nan")), ("inf", float("-inf")), ("bool", True), ("null-like", {})):
        sc(f"gradient-{cid}", _study([run(gradient_mm_per_lambda=v), second]), ("runs[0].gradient_mm_per_lambda",))
    sc("pitch-negative", _study(pixel_pitch_um=-1.4), ("pixel_pitch_um",))
    sc("run-pitch-text", _study([run(pixel_pitch_um="x"), second]), ("runs[0].pixel_pitch_um",))
    sc("predict-zero", _study(predict_focal_mm=0), ("predict_focal_mm",))
    sc("predict-text", _study(predict_focal_mm="far"), ("predict_focal_mm",))
    sc("predict-option-negative", _study(), ("predict", "-1"), extra=("--predict-focal=-1",))
    sc("predict-option-nan", _study(), ("predict", "nan"), extra=("--predict-focal=nan",))
    # duplicates (the second used to replace the first in table 6.3)
    sc("duplicate-run", _study([run(), second, run(gradient_mm_per_lambda=9.9)]), ("runs[2]",))
    sc("duplicate-run-int-set", _study([run(set=1), run(set="1")]), ("runs[1]",))
    # truth
    sc("truth-text", _study(truth="3.5"), ("truth",))
    sc("truth-sets-text", _study(truth={"sets": "all"}), ("truth.sets",))
    sc("truth-set-no-gradient", _study(truth={"sets": [{"set": "S1"}]}), ("truth.sets[0]",))
    sc(
        "truth-set-unknown",
        _study(truth={"sets": [{"set": "S9", "gradient_mm_per_lambda": 3}]}),
        ("truth.sets[0].set",),
    )
    sc(
        "truth-gradient-nan",
        _study(truth={"sets": [{"set": "S1", "gradient_mm_per_lambda": float("nan")}]}),
        ("truth.sets[0]",),
    )
    sc(
        "truth-duplicate",
        _study(truth={"sets": [{"set": "S1", "gradient_mm_per_lambda": 3}] * 2}),
        ("truth.sets[1].set",),
    )
    # runs with files: paths and their content
    files = _run_files()
    sc("both-gradient-and-files", _study([fileset(gradient_mm_per_lambda=3.5)]), ("runs[0].cloud",), files)
    sc("files-partly", _study([fileset(views=None)]), ("runs[0]", "views"), files)
    sc("cloud-missing", _study([fileset(cloud="../x.ply")]), ("runs[0].cloud",), files)
    sc("cloud-folder", _study([fileset(cloud="depth")]), ("runs[0].cloud",), files)
    sc("cloud-number", _study([fileset(cloud=123)]), ("runs[0].cloud",), files)
    sc("cloud-empty", _study([fileset(cloud="")]), ("runs[0].cloud",), files)
    sc("cloud-etc-passwd", _study([fileset(cloud="/etc/passwd")]), ("passwd",), files)
    sc("depth-maps-file", _study([fileset(depth_maps="views.json")]), ("runs[0].depth_maps",), files)
    sc("views-missing", _study([fileset(views="nowhere/views.json")]), ("runs[0].views",), files)
    sc("lambda-range-text", _study([fileset(lambda_range="a")]), ("runs[0].lambda_range",), files)
    sc("lambda-range-reversed", _study([fileset(lambda_range=[5, 1])]), ("runs[0].lambda_range",), files)
    sc("lambda-range-short", _study([fileset(lambda_range=[1])]), ("runs[0].lambda_range",), files)
    sc("lambda-range-nan", _study([fileset(lambda_range="nan,1")]), ("runs[0].lambda_range",), files)
    sc("depth-bomb", _study([fileset()]), ("v0.png",), _run_files(depth=png(20000, 20000)))
    sc("depth-jpeg-bomb", _study([fileset()]), ("v0.png",), _run_files(depth=_jpeg_bomb(b"\x00")))
    sc("depth-above-map-limit", _study([fileset()]), ("v0.png",), _run_files(depth=png(4000, 2500)))
    sc("views-fx-negative", _study([fileset()]), ("views.json",), _run_files(views=_views(fx=-100.0)))
    out.append(Case("sl-ls-study-missing", ("lightfield", "study", "nostudy.yaml"), {}, ("nostudy.yaml",)))
    out.append(Case("sl-ls-study-folder", ("lightfield", "study", "sf.yaml"), {"sf.yaml/": b""}, ("sf.yaml",)))
    return out


def cases() -> list[Case]:
    return _speckle_cases() + _info_cases() + _gradient_cases() + _study_cases()
