"""Bad inputs of ``camcmm photogrammetry import|reconstruct`` and ``camcmm run
photogrammetry.scale`` (issue 26): COLMAP text and binary models, Metashape camera XML,
image series and scale specs. Ids start with ``pg-``.

The building blocks (:func:`colmap_text`, :func:`colmap_binary`, :func:`metashape_xml`)
write a small valid model of two cameras, three images and three points; each case
changes one field (NaN, inf, 0, negative, huge, not a number, missing, repeated) or the
file's shape (cut short, trailing bytes, counts beyond the file, wrong magic). The
tests in tests/photogrammetry/test_photogrammetry_trust.py use the same blocks and check
the exact refusals; here the harness's verdict (one line naming the value, or exit 0
with a warning) is what is held.
"""

from __future__ import annotations

import functools
import struct

from helpers.badinputs import Case, jpeg_header, png

# -- COLMAP --------------------------------------------------------------------------------
#: (id, model, width, height, params) of the valid model's cameras
CAMERAS = [
    (1, "PINHOLE", 640, 480, [500.0, 505.0, 320.5, 240.5]),
    (2, "OPENCV", 800, 600, [600.0, 602.0, 400.0, 300.0, 0.01, -0.002, 0.0005, -0.0003]),
]
#: (id, q (w x y z), t, camera id, name) of its images
IMAGES = [
    (1, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 10.0], 1, "view_01.png"),
    (2, [0.70710678, 0.0, 0.70710678, 0.0], [0.0, 0.0, 10.0], 1, "view_02.png"),
    (3, [0.5, 0.5, 0.5, 0.5], [1.0, -2.0, 9.0], 2, "view_03.png"),
]
#: (id, xyz, rgb, error px, track [(image id, point2D index)]) of its points
POINTS = [
    (1, [0.0, 0.0, 0.0], [255, 0, 0], 0.5, [(1, 0)]),
    (2, [1.0, 2.0, 3.0], [10, 20, 30], 0.25, [(1, 1), (2, 0)]),
    (3, [-1.5, 0.5, 2.0], [0, 128, 255], 1.0, []),
]
MODEL_IDS = {"SIMPLE_PINHOLE": 0, "PINHOLE": 1, "SIMPLE_RADIAL": 2, "RADIAL": 3, "OPENCV": 4, "FULL_OPENCV": 6}


def _v(x) -> str:
    return x if isinstance(x, str) else repr(float(x)) if isinstance(x, float) else str(x)


def colmap_text(cameras=None, images=None, points=None, folder: str = "m") -> dict[str, bytes]:
    """A text model in ``folder``: each table a list of rows (as :data:`CAMERAS` ...; any
    field may be a string written as it is) or a whole file as bytes."""

    def table(rows, line):
        return rows if isinstance(rows, bytes) else "".join(line(r) for r in rows).encode()

    cams = table(
        CAMERAS if cameras is None else cameras,
        lambda c: " ".join(_v(x) for x in (*c[:4], *c[4])) + "\n",
    )
    ims = table(
        IMAGES if images is None else images,
        lambda i: " ".join(_v(x) for x in (i[0], *i[1], *i[2], i[3], i[4])) + "\n\n",
    )
    pts = table(
        POINTS if points is None else points,
        lambda p: " ".join(_v(x) for x in (p[0], *p[1], *p[2], p[3], *(v for t in p[4] for v in t))) + "\n",
    )
    return {f"{folder}/cameras.txt": cams, f"{folder}/images.txt": ims, f"{folder}/points3D.txt": pts}


def cameras_bin(cameras=None, count=None) -> bytes:
    cams = CAMERAS if cameras is None else cameras
    out = struct.pack("<Q", len(cams) if count is None else count)
    for cid, model, w, h, params in cams:
        mid = MODEL_IDS.get(model, model) if isinstance(model, str) else model
        out += struct.pack("<iiQQ", cid, mid, w, h) + struct.pack(f"<{len(params)}d", *params)
    return out


def images_bin(images=None, count=None, n2d=None) -> bytes:
    ims = IMAGES if images is None else images
    out = struct.pack("<Q", len(ims) if count is None else count)
    for iid, q, t, cid, name in ims:
        raw = name if isinstance(name, bytes) else name.encode() + b"\0"
        n = 1 if n2d is None else n2d
        out += struct.pack("<I7dI", iid, *q, *t, cid) + raw + struct.pack("<Q", n)
        out += struct.pack("<ddq", 10.5, 20.5, -1) * min(n, 1)
    return out


def points_bin(points=None, count=None, track=None) -> bytes:
    pts = POINTS if points is None else points
    out = struct.pack("<Q", len(pts) if count is None else count)
    for pid, xyz, rgb, err, tr in pts:
        n = len(tr) if track is None else track
        out += struct.pack("<Q3d3BdQ", pid, *xyz, *rgb, err, n) + b"".join(struct.pack("<ii", *t) for t in tr)
    return out


def colmap_binary(cameras=None, images=None, points=None, folder: str = "m") -> dict[str, bytes]:
    """A binary model in ``folder``: each file from :func:`cameras_bin` ... or bytes."""
    c = cameras if isinstance(cameras, bytes) else cameras_bin(cameras)
    i = images if isinstance(images, bytes) else images_bin(images)
    p = points if isinstance(points, bytes) else points_bin(points)
    return {f"{folder}/cameras.bin": c, f"{folder}/images.bin": i, f"{folder}/points3D.bin": p}


def with_camera(k: int = 0, **change) -> list:
    """:data:`CAMERAS` with camera ``k`` changed: id, model, w, h, or p0..p7 (a parameter)."""
    rows = [list(c[:4]) + [list(c[4])] for c in CAMERAS]
    for key, v in change.items():
        if key.startswith("p"):
            rows[k][4][int(key[1:])] = v
        else:
            rows[k][("id", "model", "w", "h").index(key)] = v
    return [tuple(r) for r in rows]


def with_image(k: int = 0, **change) -> list:
    """:data:`IMAGES` with image ``k`` changed: id, q, t, cam, name."""
    rows = [list(i) for i in IMAGES]
    for key, v in change.items():
        rows[k][("id", "q", "t", "cam", "name").index(key)] = v
    return [tuple(r) for r in rows]


def with_point(k: int = 0, **change) -> list:
    """:data:`POINTS` with point ``k`` changed: id, xyz, rgb, err."""
    rows = [list(p) for p in POINTS]
    for key, v in change.items():
        rows[k][("id", "xyz", "rgb", "err").index(key)] = v
    return [tuple(r) for r in rows]


# -- Metashape -------------------------------------------------------------------------------
def metashape_xml(
    width="640", height="480", f="<f>500</f>", cx="<cx>1.5</cx>", extra="", transform=None, chunk_extra=""
) -> bytes:
    """A camera XML of one sensor and two aligned cameras; each argument replaces a
    piece as text (None leaves the element out)."""
    t1 = "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1" if transform is None else transform
    t2 = "1 0 0 1 0 1 0 0 0 0 1 0 0 0 0 1"
    res = "" if width is None and height is None else "<resolution"
    if res:
        res += "".join(f' {k}="{v}"' for k, v in (("width", width), ("height", height)) if v is not None) + "/>"
    return (
        "<document><chunk><sensors><sensor id='0' label='cam' type='frame'>"
        f"<calibration type='frame' class='adjusted'>{res}{f or ''}{cx or ''}<cy>-2</cy>{extra}</calibration>"
        "</sensor></sensors><cameras>"
        f"<camera id='0' sensor_id='0' label='a.jpg'><transform>{t1}</transform></camera>"
        f"<camera id='1' sensor_id='0' label='b.jpg'><transform>{t2}</transform></camera>"
        f"</cameras>{chunk_extra}</chunk></document>"
    ).encode()


@functools.cache
def _bomb() -> bytes:
    return png(20000, 20000)


def _import_cases() -> list[Case]:
    cases: list[Case] = []

    def ic(cid, files, names, path="m"):
        cases.append(Case(f"pg-{cid}", ("photogrammetry", "import", path, "--json"), files, names))

    # COLMAP, both formats: the same checks (cameras)
    for fmt, model in (("txt", colmap_text), ("bin", colmap_binary)):
        for v, name in ((float("nan"), "nan"), (float("inf"), "inf"), (0.0, "0"), (-500.0, "-500")):
            ic(f"{fmt}-cam-fx-{name}", model(cameras=with_camera(0, p0=v)), (name,))
        ic(f"{fmt}-cam-cx-far", model(cameras=with_camera(0, p2=1e9)), ("1e+09",))
        ic(f"{fmt}-cam-fy-neg", model(cameras=with_camera(1, p1=-602.0)), ("-602",))
        ic(f"{fmt}-cam-cy-nan", model(cameras=with_camera(0, p3=float("nan"))), ("nan",))
        ic(f"{fmt}-cam-k1-inf", model(cameras=with_camera(1, p4=float("inf"))), ("inf",))
        ic(f"{fmt}-cam-width-0", model(cameras=with_camera(0, w=0)), ("width",))
        ic(f"{fmt}-cam-height-0", model(cameras=with_camera(0, h=0)), ("height",))
        ic(f"{fmt}-cam-size-0x0", model(cameras=with_camera(0, w=0, h=0)), ("0 x 0",))
        ic(f"{fmt}-cam-width-huge", model(cameras=with_camera(0, w=2**40)), ("1.09951e+12", "width"))
        ic(f"{fmt}-cam-dup-id", model(cameras=with_camera(1, id=1)), ("camera id 1",))
        ic(f"{fmt}-img-q-nan", model(images=with_image(1, q=[float("nan"), 0.0, 0.0, 0.0])), ("nan",))
        ic(f"{fmt}-img-q-zero", model(images=with_image(1, q=[0.0, 0.0, 0.0, 0.0])), ("quaternion",))
        ic(f"{fmt}-img-q-inf", model(images=with_image(0, q=[float("inf"), 0.0, 0.0, 1.0])), ("inf",))
        ic(f"{fmt}-img-t-inf", model(images=with_image(2, t=[0.0, float("inf"), 0.0])), ("inf",))
        ic(f"{fmt}-img-t-nan", model(images=with_image(2, t=[float("nan"), 0.0, 0.0])), ("nan",))
        ic(f"{fmt}-img-camera-unknown", model(images=with_image(0, cam=9)), ("camera 9",))
        ic(f"{fmt}-img-dup-id", model(images=with_image(2, id=1)), ("image id 1",))
        ic(f"{fmt}-pt-xyz-nan", model(points=with_point(1, xyz=[float("nan"), 0.0, 0.0])), ("nan",))
        ic(f"{fmt}-pt-xyz-inf", model(points=with_point(1, xyz=[0.0, float("-inf"), 0.0])), ("-inf",))
        ic(f"{fmt}-pt-err-nan", model(points=with_point(0, err=float("nan"))), ("nan",))
        ic(f"{fmt}-pt-dup-id", model(points=with_point(2, id=2)), ("point id 2",))

    # text only: fields that are not numbers, missing, colours beyond a byte, encodings
    t = colmap_text
    ic("txt-cam-width-neg", t(cameras=with_camera(0, w=-640)), ("-640",))
    ic("txt-cam-width-1e30", t(cameras=with_camera(0, w="1e30")), ("1e+30",))
    ic("txt-cam-width-abc", t(cameras=with_camera(0, w="abc")), ("'abc'",))
    ic("txt-cam-width-frac", t(cameras=with_camera(0, w="640.5")), ("640.5",))
    ic("txt-cam-fx-abc", t(cameras=with_camera(0, p0="abc")), ("'abc'",))
    ic("txt-cam-id-abc", t(cameras=with_camera(0, id="x1")), ("'x1'",))
    ic("txt-cam-model-unknown", t(cameras=with_camera(0, model="WEIRD")), ("WEIRD",))
    ic("txt-cam-params-few", t(cameras=b"1 PINHOLE 640 480 500 505 320.5\n"), ("PINHOLE",))
    ic("txt-cam-params-many", t(cameras=b"1 PINHOLE 640 480 500 505 320.5 240 7\n"), ("PINHOLE",))
    ic("txt-cam-missing", t(cameras=b"1 PINHOLE 640\n"), ("cameras.txt",))
    ic("txt-cam-not-utf8", t(cameras=b"\xff\xfe 1 PINHOLE\n"), ("cameras.txt",))
    ic("txt-img-q-abc", t(images=with_image(0, q=["one", 0.0, 0.0, 0.0])), ("'one'",))
    ic("txt-img-truncated", t(images=b"1 1 0 0 0 0 0 10\n\n"), ("images.txt",))
    ic("txt-img-name-missing", t(images=b"1 1 0 0 0 0 0 10 1\n\n"), ("images.txt",))
    ic("txt-cam-height-abc", t(cameras=with_camera(0, h="tall")), ("'tall'",))
    ic("txt-img-id-abc", t(images=with_image(0, id="1.5")), ("'1.5'",))
    ic("txt-pt-rgb-300", t(points=with_point(0, rgb=[300, 0, 0])), ("300",))
    ic("txt-pt-rgb-neg", t(points=with_point(0, rgb=[-1, 0, 0])), ("-1",))
    ic("txt-pt-err-abc", t(points=with_point(0, err="bad")), ("'bad'",))
    ic("txt-pt-truncated", t(points=b"1 0 0 0 255 0\n"), ("points3D.txt",))
    ic("txt-empty-model", t(cameras=b"", images=b"", points=b""), ())  # exit 0: no image, a warning

    # binary only: what text cannot say (unsigned sizes, counts, cut files, magic)
    b = colmap_binary
    ic("bin-cam-width-neg", b(cameras=with_camera(0, w=2**64 - 640)), ("1.84467e+19",))
    ic("bin-cam-model-id-99", b(cameras=with_camera(0, model=99)), ("99",))
    ic("bin-cam-model-id-neg", b(cameras=with_camera(0, model=-1)), ("-1",))
    ic("bin-cam-count-huge", b(cameras=cameras_bin(count=2**60)), ("1152921504606846976",))
    ic("bin-cam-count-extra", b(cameras=cameras_bin(count=3)), ("cameras.bin",))
    ic("bin-cam-count-short", b(cameras=cameras_bin(count=1)), ("cameras.bin",))
    ic("bin-cam-cut-10", b(cameras=cameras_bin()[:-10]), ("cameras.bin",))
    ic("bin-cam-trailing", b(cameras=cameras_bin() + b"\0" * 7), ("cameras.bin",))
    ic("bin-cam-empty", b(cameras=b""), ("cameras.bin",))
    ic("bin-cam-text-magic", b(cameras=b"# Camera list\n1 PINHOLE 640 480 500 505 320 240\n"), ("cameras.bin",))
    ic("bin-img-count-huge", b(images=images_bin(count=2**62)), ("4611686018427387904",))
    ic("bin-img-n2d-huge", b(images=images_bin(n2d=2**61)), ("2305843009213693952",))
    ic("bin-img-name-unterminated", b(images=images_bin()[:-40] + b"x" * 10), ("images.bin",))
    ic("bin-img-name-not-utf8", b(images=images_bin(with_image(0, name=b"\xff\xfe.png\0"))), ("images.bin",))
    ic("bin-img-name-empty", b(images=images_bin(with_image(0, name=""))), ("image 1",))
    ic("bin-img-cut", b(images=images_bin()[:-5]), ("images.bin",))
    ic("bin-pt-count-huge", b(points=points_bin(count=2**58)), ("288230376151711744",))
    ic("bin-pt-track-huge", b(points=points_bin(track=2**60)), ("1152921504606846976",))
    ic("bin-empty-model", b(cameras=cameras_bin([]), images=images_bin([]), points=points_bin([])), ())
    ic("bin-pt-none", b(points=points_bin([])), ())  # a model without points: read, warned arbitrary scale
    ic("bin-pt-cut", b(points=points_bin()[:-3]), ("points3D.bin",))
    ic("bin-pt-trailing", b(points=points_bin() + b"\1"), ("points3D.bin",))
    ic(
        "bin-junk-all",
        {"m/cameras.bin": b"\x07" * 50, "m/images.bin": b"\x07" * 50, "m/points3D.bin": b""},
        ("cameras.bin",),
    )

    # Metashape camera XML: every numeric attribute and element
    m = metashape_xml

    def mc(cid, data, names):
        ic(f"ms-{cid}", {"c.xml": data}, names, path="c.xml")

    mc("f-neg", m(f="<f>-7000</f>"), ("-7000",))
    mc("f-zero", m(f="<f>0</f>"), ("0",))
    mc("f-nan", m(f="<f>nan</f>"), ("nan",))
    mc("f-inf", m(f="<f>inf</f>"), ("inf",))
    mc("f-abc", m(f="<f>abc</f>"), ("<f>",))
    mc("f-missing", m(f=None), ("<f", "<fx>"))
    mc("f-two", m(f="<f>500 600</f>"), ("<f>",))
    mc("width-abc", m(width="abc"), ("'abc'",))
    mc("width-neg", m(width="-6000", height="0"), ("-6000",))
    mc("width-zero", m(width="0"), ("width",))
    mc("height-zero", m(height="0"), ("height",))
    mc("size-zero", m(width="0", height="0"), ("0 x 0",))
    mc("width-1e30", m(width="1e30"), ("'1e30'",))
    mc("width-huge", m(width="99999999999"), ("1e+11",))
    mc("width-missing", m(width=None), ("width",))
    mc("resolution-missing", m(width=None, height=None), ("resolution",))
    mc("cx-nan", m(cx="<cx>nan</cx>"), ("nan",))
    mc("cx-far", m(cx="<cx>1e9</cx>"), ("1e+09",))
    mc("k1-abc", m(extra="<k1>x</k1>"), ("<k1>",))
    mc("b1-neg", m(extra="<b1>-600</b1>"), ("-100",))
    mc("transform-nan", m(transform="nan 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"), ("nan",))
    mc("transform-short", m(transform="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0"), ("transform",))
    mc("transform-not-rigid", m(transform="2 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"), ("transform",))
    mc(
        "chunk-scale-neg",
        m(chunk_extra="<transform><rotation>1 0 0 0 1 0 0 0 1</rotation><scale>-1</scale></transform>"),
        ("scale", "transform"),
    )
    mc("not-xml", b"<document><chunk", ("c.xml",))
    entities = "".join(f'<!ENTITY {chr(98 + i)} "{("&" + chr(97 + i) + ";") * 10}">' for i in range(8))
    mc(
        "entity-bomb",  # 10^9 characters from 0.4 kB: expat's amplification limit refuses it
        f'<?xml version="1.0"?><!DOCTYPE d [<!ENTITY a "aaaaaaaaaa">{entities}]>'
        '<document><chunk><sensors><sensor id="0" label="&i;"/></sensors></chunk></document>'.encode(),
        ("c.xml",),
    )
    mc("no-chunk", b"<document><x/></document>", ("chunk",))
    mc("not-utf8", b"\xff\xfe<document/>", ("c.xml",))
    ic("ms-cloud-bad-xml-beside", {"c.txt": b"0 0 0\n1 1 1\n2 2 2\n", "c.xml": m(f="<f>-1</f>")}, ("-1",), "c.txt")
    ic("missing-path", {}, ("nothing",), "nothing")
    ic("not-a-model-folder", {"m/": b""}, ("m",))
    return cases


def _reconstruct_cases() -> list[Case]:
    cases: list[Case] = []
    three = {f"s/i{k}.png": png(16, 12) for k in range(3)}

    def rc(cid, args, names, files=None):
        cases.append(
            Case(
                f"pg-rec-{cid}",
                ("photogrammetry", "reconstruct", *args, "--json"),
                three if files is None else files,
                names,
            )
        )

    rc("no-images", ("e",), ("e",), {"e/": b""})
    rc("missing-folder", ("gone",), ("gone",), {})
    rc("too-many", ("s",), ("401", "400"), {f"s/i{k:03d}.png": png(4, 4) for k in range(401)})
    rc("not-images", ("s",), ("i0.png", "i1.png", "i2.png"), {f"s/i{k}.png": b"not an image" for k in range(3)})
    rc("text-as-image", ("a.png", "b.png"), ("a.png",), {"a.png": b"hello", "b.png": png(8, 8)})
    rc("bomb", ("s",), ("b.png", "20000"), dict(three, **{"s/b.png": _bomb()}))
    rc("jpeg-header-bomb", ("s",), ("j.jpg", "60000"), dict(three, **{"s/j.jpg": jpeg_header(60000, 60000)}))
    rc("one-image", ("a.png",), ("1 image", "a.png", "image"), {"a.png": png(8, 8)})
    for spec, names in (
        ("spheres:-1", ("-1",)),
        ("spheres:abc", ("abc",)),
        ("spheres:nan", ("nan",)),
        ("spheres:inf", ("inf",)),
        ("spheres:1,2,3,4,5,6,7,8,9,10,11", ("10",)),
        ("bar:0", ("0",)),
        ("bar:1,2", ("bar",)),
        ("bar:5@-1", ("-1",)),
        ("bar:5@abc", ("abc",)),
        ("cube:5", ("cube",)),
        ("lengths:", ("lengths",)),
        ("lengths:gone.yaml", ("gone.yaml",)),
    ):
        rc(f"scale-{spec.replace(':', '-').replace(',', '_').replace('@', 'u')[:24]}", ("s", "--scale", spec), names)
    for name, data, names in (
        ("csv-bad", b"from,to,length\n1,2\n", ("line 2",)),
        ("csv-nan", b"1,2,nan\n", ("nan",)),
        ("csv-self", b"1,1,5\n", ("itself",)),
        ("yaml-bad", b"lengths: 5\n", ("lengths",)),
        ("yaml-neg", b"lengths: [5, -7, 9]\n", ("-7",)),
    ):
        ext = ".csv" if name.startswith("csv") else ".yaml"
        rc(
            f"lengths-{name}",
            ("s", "--scale", f"lengths:L{ext}"),
            (*names, f"L{ext}"),
            dict(three, **{f"L{ext}": data}),
        )
    for opt, val in (
        ("--max-image-size", "10"),
        ("--max-image-size", "abc"),
        ("--max-image-size", "-1"),
        ("--dense-max-image-size", "-5"),
        ("--matching", "random"),
        ("--mapper", "glomap"),
        ("--overlap", "0"),
        ("--camera-model", "FISHEYE9"),
        ("--turntable-angles", "abc"),
        ("--turntable-angles", "1,2"),
        ("--turntable-window", "-1"),
        ("--turntable-window", "nan"),
    ):
        rc(f"opt-{opt[2:]}-{val}", ("s", opt, val), (val, opt[2:].replace("-", "_")))
    rc("calibration-missing", ("s", "--calibration", "cal.yaml"), ("cal.yaml",))
    rc("calibration-junk", ("s", "--calibration", "cal.yaml"), ("cal.yaml",), dict(three, **{"cal.yaml": b"\0\1junk"}))
    return cases


def _scale_cases() -> list[Case]:
    """``camcmm run photogrammetry.scale CLOUD --scale SPEC``."""
    cloud = {"c.xyz": b"".join(f"{k} {k % 7} {k % 3}\n".encode() for k in range(50))}
    cases = []
    for cid, spec, names, extra in (
        ("spheres-neg", "spheres:-2", ("-2",), {}),
        ("bar-nan", "bar:nan", ("nan",), {}),
        ("lengths-missing", "lengths:none.csv", ("none.csv",), {}),
        ("lengths-folder", "lengths:d", ("'d'",), {"d/": b""}),
        ("lengths-too-many", "lengths:L.csv", ("64",), {"L.csv": b"".join(b"1,2,5\n" for _ in range(70))}),
        ("lengths-gap", "lengths:L.csv", ("L.csv",), {"L.csv": b"1,3,5\n"}),
        ("no-spheres", "bar:100", ("bar", "sphere", "spheres"), {}),
    ):
        cases.append(
            Case(
                f"pg-scale-{cid}",
                ("run", "photogrammetry.scale", "c.xyz", "--scale", spec, "--json"),
                {**cloud, **extra},
                names,
            )
        )
    return cases


def cases() -> list[Case]:
    return _import_cases() + _reconstruct_cases() + _scale_cases()
