"""Bad height maps (issue 26): ``camcmm info`` on X3P, SDF (binary and ASCII), MetroPro
``.dat`` and the other instrument extensions, and ``camcmm fuse csi`` with each option
wrong. Ids start with ``hm-``.

The files are built here: a valid one first (:func:`x3p`, :func:`sdf_binary`,
:func:`sdf_ascii`, :func:`metropro`), then each field corrupted: increments 0, negative,
NaN, 1e300; sizes that do not match the data; members too big; zip bombs (a member that
is small compressed and huge inflated, declared honestly or not); an XML bomb; missing
members; a wrong checksum, data type, trailing bytes, a cut file. A bomb must be refused
before it is inflated.
"""

from __future__ import annotations

import hashlib
import io
import struct
import zipfile
import zlib

import numpy as np

from helpers.badinputs import Case, _junk, _sphere, _tetra, ply_binary, png, stl_binary

NX, NY = 8, 6
#: the grid: heights in µm (X3P z increment 1e-6 m), a gentle slope so every value differs
Z = (np.arange(NX * NY, dtype=np.float64).reshape(NY, NX) * 0.25).ravel()
BILLION_LAUGHS = (
    b'<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
    + b"".join(
        f'<!ENTITY lol{i} "{("&lol" + (str(i - 1) if i > 1 else "") + ";") * 10}">'.encode() for i in range(1, 10)
    )
    + b']>\n<p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2"><Record1>&lol9;</Record1></p:ISO5436_2>'
)


def x3p_xml(
    nx=NX,
    ny=NY,
    nz=1,
    dtype="D",
    xinc="1.0E-5",
    yinc="1.0E-5",
    zinc="1.0E-6",
    xoff="0",
    zoff="0",
    feature="SUR",
    axis_x="I",
    link="bindata/data.bin",
    md5: str | None = "",
    valid: str | None = None,
) -> bytes:
    """main.xml of an X3P file; ``md5=""`` computes nothing (the caller fills it in)."""
    md5_el = f"<MD5ChecksumPointData>{md5}</MD5ChecksumPointData>" if md5 else ""
    valid_el = f"<ValidPointsLink>{valid}</ValidPointsLink>" if valid else ""
    link_el = f"<PointDataLink>{link}</PointDataLink>" if link else ""
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2">'
        f"<Record1><Revision>ISO5436 - 2000</Revision><FeatureType>{feature}</FeatureType><Axes>"
        f"<CX><AxisType>{axis_x}</AxisType><DataType>D</DataType><Increment>{xinc}</Increment>"
        f"<Offset>{xoff}</Offset></CX>"
        f"<CY><AxisType>I</AxisType><DataType>D</DataType><Increment>{yinc}</Increment><Offset>0</Offset></CY>"
        f"<CZ><AxisType>A</AxisType><DataType>{dtype}</DataType><Increment>{zinc}</Increment>"
        f"<Offset>{zoff}</Offset></CZ>"
        "</Axes></Record1><Record2><Date>2026-11-29</Date><Instrument><Manufacturer>test</Manufacturer>"
        "</Instrument><Comment>hm-</Comment></Record2>"
        f"<Record3><MatrixDimension><SizeX>{nx}</SizeX><SizeY>{ny}</SizeY><SizeZ>{nz}</SizeZ></MatrixDimension>"
        f"<DataLink>{link_el}{md5_el}{valid_el}</DataLink></Record3></p:ISO5436_2>"
    ).encode()


def zipped(members: dict[str, bytes], level: int = 1) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=level) as zf:
        for k, v in members.items():
            zf.writestr(k, v)
    return buf.getvalue()


def x3p(data: bytes | None = None, members: dict[str, bytes] | None = None, xml: bytes | None = None, **kw) -> bytes:
    """A valid X3P file (float64 heights :data:`Z`, with their MD5), or one with the
    given main.xml fields, data or extra/replacing members."""
    data = Z.astype("<f8").tobytes() if data is None else data
    if "md5" not in kw:
        kw["md5"] = hashlib.md5(data).hexdigest().upper()
    out = {"main.xml": x3p_xml(**kw) if xml is None else xml, "bindata/data.bin": data}
    out.update(members or {})
    return zipped({k: v for k, v in out.items() if v is not None})


def patch_size(blob: bytes, member: str, size: int) -> bytes:
    """The zip with ``member``'s declared (uncompressed) size set to ``size`` in its local
    and central headers: a zip that lies about what its member inflates to."""
    b = bytearray(blob)
    name = member.encode()
    for sig, off_name, off_size in ((b"PK\x03\x04", 30, 22), (b"PK\x01\x02", 46, 24)):
        i = b.find(sig)
        while i >= 0:
            if b[i + off_name : i + off_name + len(name)] == name:
                struct.pack_into("<I", b, i + off_size, size)
            i = b.find(sig, i + 4)
    return bytes(b)


def sdf_binary(nx=NX, ny=NY, xs=1e-5, ys=1e-5, zs=1e-6, dtype=7, comp=0, data: bytes | None = None) -> bytes:
    head = struct.pack(
        "<8s10s12s12sHHddddBBB", b"bISO-1.0", b"hm", b"291120261200", b"291120261200", nx, ny, xs, ys, zs, -1.0,
        comp, dtype, 0,
    )  # fmt: skip
    if data is None:
        data = Z.astype({5: "<i2", 6: "<i4"}.get(dtype, "<f8")).tobytes()
    return head + data


def sdf_ascii(nx=NX, ny=NY, xs="1e-5", ys="1e-5", zs="1e-6", dtype="7", values: str | None = None, extra="") -> bytes:
    head = (
        f"aISO-1.0\nManufacID = hm\nNumPoints = {nx}\nNumProfiles = {ny}\nXscale = {xs}\nYscale = {ys}\n"
        f"Zscale = {zs}\nZresolution = -1\nCompression = 0\nDataType = {dtype}\nCheckType = 0\n{extra}*\n"
    )
    if values is None:
        values = "\n".join(" ".join(repr(float(v)) for v in row) for row in Z.reshape(NY, NX)) + "\n"
    return (head + values + "*\n").encode()


def metropro(nx=NX, ny=NY, wavelength=6.33e-7, intf=0.5, obliq=1.0, lateral=1e-6, phase_res=1, sign=0,
             header_size=834, magic=b"\x88\x1b\x03\x70", data: bytes | None = None) -> bytes:  # fmt: skip
    """A Zygo MetroPro .dat (header format 1, 834 bytes, big-endian; Zygo's MetroPro
    Reference Guide): phase counts int32, height = count * intf * obliquity * wavelength
    / phase resolution (32768 for phase_res 1)."""
    h = bytearray(834)
    h[0:4] = magic
    struct.pack_into(">HI", h, 4, 1, header_size)
    struct.pack_into(">HHI", h, 68, nx, ny, (4 * nx * ny) & 0xFFFFFFFF)  # cn_org_width, cn_org_height, cn_n_bytes
    struct.pack_into(">ff", h, 164, intf, wavelength)  # intf_scale_factor, wavelength_in (m)
    struct.pack_into(">f", h, 176, obliq)  # obliquity_factor
    struct.pack_into(">f", h, 184, lateral)  # lateral_res (m)
    struct.pack_into(">h", h, 218, phase_res)
    struct.pack_into(">h", h, 232, sign)
    if data is None:
        data = (np.arange(nx * ny) * 100).astype(">i4").tobytes()
    return bytes(h) + data


def _zeros_deflated(n: int) -> bytes:
    return zlib.compress(b"\0" * n, 9)


def cases() -> list[Case]:
    out: list[Case] = []

    def info(cid, name, data, names=None, timeout=20.0, env=None):
        out.append(Case(f"hm-{cid}", ("info", name), {name: data}, names or (name,), timeout, env or {}))

    # -- X3P: a valid file, then each field wrong ---------------------------------------
    good = x3p()
    for field, values in (
        ("xinc", ("0", "-1e-5", "NaN", "1e300", "inf", "abc", "1e-30")),
        ("zinc", ("0", "-1e-6", "NaN", "1e300", "1e-40")),
    ):
        for v in values:
            tag = v.replace("-", "neg").replace(".", "p")
            info(f"x3p-{field}-{tag}", f"{field}_{tag}.x3p", x3p(**{field: v}))
    info("x3p-yinc-1e300", "yinc.x3p", x3p(yinc="1e300"))
    info("x3p-xoff-1e300", "xoff.x3p", x3p(xoff="1e300"))
    info("x3p-zoff-1e300", "zoff.x3p", x3p(zoff="1e300"))
    info("x3p-decimal-overflow", "decover.x3p", x3p(xinc="1e999999999"))
    info("x3p-size-mismatch", "sizes.x3p", x3p(nx=NX + 1))
    info("x3p-size-zero", "size0.x3p", x3p(nx=0))
    info("x3p-size-negative", "sizeneg.x3p", x3p(ny="-6"))
    info("x3p-size-unicode-digit", "sizeuni.x3p", x3p(nx="\u00b2"))
    info("x3p-size-layers", "layers.x3p", x3p(nz=2))
    info("x3p-data-short", "short.x3p", x3p(data=Z.astype("<f8").tobytes()[:-8]))
    info("x3p-data-long", "long.x3p", x3p(data=Z.astype("<f8").tobytes() + b"\0" * 8))
    info("x3p-member-far-too-big", "toobig.x3p", x3p(data=b"\0" * (10 << 20), md5=None))
    info("x3p-dtype-wrong", "dtype.x3p", x3p(dtype="Q"))
    info("x3p-dtype-int-size", "dtypei.x3p", x3p(dtype="I"))  # 2 bytes a value: the data hold 8
    info("x3p-md5-wrong", "md5.x3p", x3p(md5="0" * 32))
    info("x3p-no-main-xml", "nomain.x3p", zipped({"bindata/data.bin": Z.tobytes()}))
    info("x3p-no-data-member", "nodata.x3p", x3p(data=None, members={"bindata/data.bin": None}))
    info("x3p-no-link", "nolink.x3p", x3p(link=""))
    info("x3p-link-dir-escape", "escape.x3p", x3p(link="../../etc/passwd"))
    info("x3p-valid-missing", "validmiss.x3p", x3p(valid="bindata/valid.bin"))
    info("x3p-valid-short", "validshort.x3p", x3p(valid="v.bin", members={"v.bin": b"\xff"}))
    info("x3p-valid-huge", "validhuge.x3p", x3p(valid="v.bin", members={"v.bin": b"\xff" * (1 << 20)}))
    info("x3p-not-surface", "profile.x3p", x3p(feature="PRF"))
    info("x3p-absolute-axes", "absolute.x3p", x3p(axis_x="A"))
    info("x3p-xml-bad", "badxml.x3p", x3p(xml=b"<p:ISO5436_2><Record1>"))
    info("x3p-xml-encoding", "enc.x3p", x3p(xml=x3p_xml().replace(b"UTF-8", b"UTZ-8")))
    info("x3p-xml-no-records", "norec.x3p", x3p(xml=b"<a><b>1</b></a>"))
    info("x3p-xml-billion-laughs", "laughs.x3p", x3p(xml=BILLION_LAUGHS))
    info(
        "x3p-xml-external-entity",
        "xxe.x3p",
        x3p(xml=b'<?xml version="1.0"?><!DOCTYPE a [<!ENTITY e SYSTEM "file:///etc/passwd">]><a>&e;</a>'),
    )
    info(
        "x3p-xml-utf16-doctype",
        "utf16.x3p",
        x3p(xml=BILLION_LAUGHS.replace(b'<?xml version="1.0"?>', b"").decode().encode("utf-16")),
    )
    info("x3p-xml-5mb", "bigxml.x3p", x3p(xml=b"<a>" + b" " * (5 << 20) + b"</a>"))
    info("x3p-xml-declared-3gb", "xmlclaims.x3p", patch_size(good, "main.xml", 3 << 30))
    info("x3p-xml-deep", "deep.x3p", x3p(xml=b"<a>" * 50000 + b"</a>" * 50000))
    info("x3p-xml-child-in-leaf", "child.x3p", x3p(xinc="<v>1</v>"))
    # zip bombs: a member that inflates far beyond the grid, declared honestly or not
    bomb = zipped({"main.xml": x3p_xml(md5=None), "bindata/data.bin": b"\0" * (16 << 20)}, level=9)
    info("x3p-bomb-declared", "bomb.x3p", bomb)
    info("x3p-bomb-lying-size", "bomblie.x3p", patch_size(bomb, "bindata/data.bin", NX * NY * 8))
    info("x3p-data-declared-3gb", "claims.x3p", patch_size(good, "bindata/data.bin", 3 << 30))
    big_grid = zipped(
        {"main.xml": x3p_xml(nx=60000, ny=60000, xinc="1e-8", yinc="1e-8", md5=None), "bindata/data.bin": b"\0" * 64}
    )
    info("x3p-grid-60000sq", "grid.x3p", big_grid)
    info(
        "x3p-grid-honest-bomb",
        "honest.x3p",
        zipped(
            {
                "main.xml": x3p_xml(nx=2048, ny=2048, xinc="1e-8", yinc="1e-8", md5=None),
                "bindata/data.bin": b"\0" * (2048 * 2048 * 8),
            },
            level=9,
        ),
        env={"CAMCMM_MAX_MEMORY_MB": "20"},
    )
    # a grid honestly declared, 512 MB of zeros in a few kB: within the memory limit, but no
    # measurement deflates 1000:1 (the declared size patched: building it would take seconds)
    honest = zipped(
        {"main.xml": x3p_xml(nx=8192, ny=8192, xinc="1e-7", yinc="1e-7", md5=None), "bindata/data.bin": b"\0" * 4096}
    )
    info("x3p-bomb-ratio", "ratio.x3p", patch_size(honest, "bindata/data.bin", 8192 * 8192 * 8))
    for ext in (".plux", ".zon", ".vk6"):
        vendor_bomb = patch_size(zipped({"data.bin": b"\0" * 4096, "index.xml": b"<a/>"}), "data.bin", 3 << 30)
        info(f"{ext[1:]}-zip-bomb", f"bomb{ext}", vendor_bomb)
        info(f"{ext[1:]}-zip-junk-members", f"members{ext}", zipped({"a.txt": b"hello", "b.bin": _junk(512)}))
    info("x3p-meta-huge", "meta.x3p", x3p(members={"camcmm/meta.json": b" " * (5 << 20)}))
    info("x3p-meta-not-json", "metajson.x3p", x3p(members={"camcmm/meta.json": b"{nope"}))
    info("x3p-meta-deep-json", "metadeep.x3p", x3p(members={"camcmm/meta.json": b"[" * 200000}))
    info("x3p-intensity-short", "inten.x3p", x3p(members={"camcmm/intensity.bin": b"\0" * 16}))
    info("x3p-not-zip", "notzip.x3p", _junk(4096))
    info("x3p-truncated-zip", "cut.x3p", good[: len(good) // 2])
    info("x3p-empty", "empty.x3p", b"")
    info("x3p-encrypted-flag", "crypt.x3p", _flag_encrypted(good))
    info("x3p-bad-crc", "crc.x3p", _bad_crc(good, "bindata/data.bin"))

    # -- SDF ------------------------------------------------------------------------------
    for tag, kw in (("xs0", {"xs": 0.0}), ("xsneg", {"xs": -1e-5}), ("xsnan", {"xs": float("nan")}),
                    ("xs1e300", {"xs": 1e300}), ("zs0", {"zs": 0.0}), ("zsnan", {"zs": float("nan")}),
                    ("zs1e300", {"zs": 1e300}), ("ys-tiny", {"ys": 1e-300}), ("dtype9", {"dtype": 9}),
                    ("comp1", {"comp": 1}), ("nx0", {"nx": 0})):  # fmt: skip
        info(f"sdf-bin-{tag}", f"{tag}.sdf", sdf_binary(**kw))
    info("sdf-bin-trailing", "trail.sdf", sdf_binary() + b"\0" * 16)
    info("sdf-bin-short", "shortd.sdf", sdf_binary()[:-9])
    info("sdf-bin-header-cut", "headcut.sdf", sdf_binary()[:40])
    info("sdf-bin-int16-wrong-size", "i16.sdf", sdf_binary(dtype=5, data=Z.astype("<f8").tobytes()))
    info("sdf-bin-grid-65535sq", "huge.sdf", sdf_binary(nx=65535, ny=65535, xs=1e-9, ys=1e-9))
    for tag, kw in (("xs0", {"xs": "0"}), ("zs0", {"zs": "0"}), ("zsneg", {"zs": "-1e-6"}), ("xsnan", {"xs": "nan"}),
                    ("xs1e300", {"xs": "1e300"}), ("xs-overflow", {"xs": "1e999999999999"}), ("nx-word", {"nx": "ten"}),
                    ("nx-neg", {"nx": "-8"}), ("dtype-word", {"dtype": "x"})):  # fmt: skip
        info(f"sdf-asc-{tag}", f"a{tag}.sdf", sdf_ascii(**kw))
    info("sdf-asc-missing-key", "amiss.sdf", sdf_ascii().replace(b"Zscale", b"Qscale"))
    info("sdf-asc-too-few", "afew.sdf", sdf_ascii(values="1 2 3\n"))
    info("sdf-asc-too-many", "amany.sdf", sdf_ascii(values="1 " * (NX * NY + 5) + "\n"))
    info("sdf-asc-word", "aword.sdf", sdf_ascii(values=" ".join(["1"] * (NX * NY - 1) + ["x"]) + "\n"))
    info("sdf-asc-inf", "ainf.sdf", sdf_ascii(values=" ".join(["1"] * (NX * NY - 1) + ["inf"]) + "\n"))
    info("sdf-asc-trailing-mb", "atrail.sdf", sdf_ascii(values=" ".join(["1"] * (NX * NY)) + "\n" + "7 " * 300000))
    info("sdf-asc-no-star", "astar.sdf", b"aISO-1.0\nNumPoints = 8\n")
    info("sdf-not-sdf", "junk.sdf", _junk(2048))

    # -- MetroPro and the other instrument formats ------------------------------------------
    for tag, kw in (("wavelength0", {"wavelength": 0.0}), ("wavelength-nan", {"wavelength": float("nan")}),
                    ("intf0", {"intf": 0.0}), ("obliq0", {"obliq": 0.0}), ("lateral0", {"lateral": 0.0}),
                    ("lateral-1e30", {"lateral": 1e30}), ("wavelength-1e30", {"wavelength": 1e30}),
                    ("phase-res-7", {"phase_res": 7}), ("header-size", {"header_size": 999}),
                    ("bad-magic", {"magic": b"MPRO"})):  # fmt: skip
        info(f"dat-{tag}", f"{tag}.dat", metropro(**kw))
    info("dat-data-short", "dshort.dat", metropro()[:-10])
    info("dat-grid-huge", "dhuge.dat", metropro(nx=65535, ny=65535, data=b"\0" * 64))
    for ext in (".datx", ".opd", ".plu", ".sur", ".gwy", ".vk4", ".al3d", ".zmg"):
        info(f"{ext[1:]}-junk", f"j{ext}", _junk(3000, 7))
        info(f"{ext[1:]}-empty", f"e{ext}", b"")

    # -- camcmm fuse csi -----------------------------------------------------------------------
    cloud = ply_binary(_sphere(300))

    def fuse(cid, args, files, names):
        out.append(Case(f"hm-fuse-{cid}", ("fuse", "csi", *args), files, names, 30.0))

    base = {"c.ply": cloud, "m.x3p": good}
    fuse("cloud-is-map", ("--cloud", "m.x3p", "--csi", "m.x3p"), base, ("m.x3p",))
    fuse("cloud-missing", ("--cloud", "nope.ply", "--csi", "m.x3p"), base, ("nope.ply",))
    fuse("csi-missing", ("--cloud", "c.ply", "--csi", "nope.x3p"), base, ("nope.x3p",))
    fuse("csi-is-cloud", ("--cloud", "c.ply", "--csi", "c.ply"), base, ("c.ply",))
    kinds = {**base, "i.png": png(32, 32), "t.stl": stl_binary(_tetra()[0][_tetra()[1]]), "s.sdf": sdf_binary()}
    fuse("cloud-is-image", ("--cloud", "i.png", "--csi", "m.x3p"), kinds, ("i.png",))
    fuse("cloud-is-mesh", ("--cloud", "t.stl", "--csi", "m.x3p"), kinds, ("t.stl",))
    fuse("cloud-is-sdf", ("--cloud", "s.sdf", "--csi", "m.x3p"), kinds, ("s.sdf",))
    fuse("csi-is-image", ("--cloud", "c.ply", "--csi", "i.png"), kinds, ("i.png",))
    fuse("csi-is-mesh", ("--cloud", "c.ply", "--csi", "t.stl"), kinds, ("t.stl",))
    fuse("csi-second-bad", ("--cloud", "c.ply", "--csi", "m.x3p", "--csi", "i.png"), kinds, ("i.png",))
    nan_map = x3p(data=np.full(NX * NY, np.nan).tobytes())
    fuse("csi-all-invalid", ("--cloud", "c.ply", "--csi", "n.x3p"), {**base, "n.x3p": nan_map}, ("n.x3p",))
    fuse("csi-wrong-unit", ("--cloud", "c.ply", "--csi", "m.x3p"), base, ("m.x3p",))
    fuse("csi-bomb", ("--cloud", "c.ply", "--csi", "b.x3p"), {**base, "b.x3p": bomb}, ("b.x3p",))
    fuse(
        "csi-wavelength0",
        ("--cloud", "c.ply", "--csi", "w.dat"),
        {**base, "w.dat": metropro(wavelength=0.0)},
        ("w.dat",),
    )
    fuse("csi-folder", ("--cloud", "c.ply", "--csi", "d/"), {**base, "d/": b""}, ("d",))
    fuse("datum-missing", ("--cloud", "c.ply", "--csi", "m.x3p", "--datum", "no.json"), base, ("no.json",))
    fuse(
        "datum-bad",
        ("--cloud", "c.ply", "--csi", "m.x3p", "--datum", "d.json"),
        {**base, "d.json": b'{"point": [0, 0]}'},
        ("d.json",),
    )
    fuse("datum-zero-normal", ("--cloud", "c.ply", "--csi", "m.x3p", "--datum", "d.json"),
         {**base, "d.json": b'{"point": [0, 0, 0], "normal": [0, 0, 0]}'}, ("d.json",))  # fmt: skip
    for opt, v in (("--sigma-px", "-1"), ("--sigma-px", "nan"), ("--ransac-px", "0"), ("--grid", "3"),
                   ("--min-inliers", "2"), ("--ratio", "5"), ("--icp-iterations", "0"), ("--icp-max-distance", "-1"),
                   ("--max-points", "1e30"), ("--seed", "-1"), ("--reject", "magic"), ("--grey", "blue")):  # fmt: skip
        fuse(f"{opt[2:]}-{v}", ("--cloud", "c.ply", "--csi", "m.x3p", opt, v), base, (opt, v))
    return out


def _flag_encrypted(blob: bytes) -> bytes:
    """The zip with every member flagged encrypted (general-purpose bit 0)."""
    b = bytearray(blob)
    for sig, off in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):
        i = b.find(sig)
        while i >= 0:
            b[i + off] |= 1
            i = b.find(sig, i + 4)
    return bytes(b)


def _bad_crc(blob: bytes, member: str) -> bytes:
    """The zip with ``member``'s CRC-32 wrong in both headers."""
    b = bytearray(blob)
    name = member.encode()
    for sig, off_name, off_crc in ((b"PK\x03\x04", 30, 14), (b"PK\x01\x02", 46, 16)):
        i = b.find(sig)
        while i >= 0:
            if b[i + off_name : i + off_name + len(name)] == name:
                b[i + off_crc] ^= 0xFF
            i = b.find(sig, i + 4)
    return bytes(b)
