"""Height-map files (issue 17): the instruments' files read as their headers state them
and as SurfaceTopography reads them, X3P and SDF round trips, refusals naming the file,
``camcmm info`` on a height map."""

from __future__ import annotations

import re
import zipfile

import numpy as np
import pytest

from camcmm import api
from camcmm.errors import InputError, ParameterError
from camcmm.io import info

CSI = "csi_height_maps_surfalize"

#: file -> (grid nx x ny, size in mm, height unit) as SOURCE.txt and the headers state them
REAL = {
    "test_1.dat": ((640, 480), (0.703, 0.527), "m"),
    "test_1.opd": ((736, 480), (1.203, 0.915), "mm"),
    "test_2.opd": ((736, 480), (1.203, 0.915), "mm"),
    "test_1.plu": ((768, 576), (0.255, 0.191), "um"),
}


def _st_heights_mm(path):
    """SurfaceTopography's own reading, taken to camcmm's [row = y, column = x] in mm."""
    from SurfaceTopography import read_topography

    t = read_topography(str(path))
    k = api.to_mm_factor(t.unit)
    h = np.ma.filled(np.ma.asarray(t.heights(), dtype=np.float64), np.nan).T * k
    (nx, ny), (sx, sy) = t.nb_grid_pts, t.physical_sizes
    return h, sx * k / nx, sy * k / ny


@pytest.mark.slow
@pytest.mark.parametrize("fname", sorted(REAL))
def test_real_files_read_as_stated(shared_data, fname):
    path = shared_data / CSI / fname
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    (nx, ny), (w, h), unit = REAL[fname]
    m = api.read(path)
    assert isinstance(m, api.HeightMap)
    assert m.shape == (ny, nx) and m.source_unit == unit and m.name == fname
    # SOURCE.txt gives the sizes to 3 decimals of a mm
    np.testing.assert_allclose(m.size_mm, (w, h), atol=6e-4)
    ref, dx, dy = _st_heights_mm(path)
    np.testing.assert_array_equal(np.isnan(m.heights), np.isnan(ref))
    np.testing.assert_allclose(m.heights, ref, rtol=1e-15, atol=0, equal_nan=True)
    assert (m.dx, m.dy) == pytest.approx((dx, dy), rel=1e-15)
    # a CSI height map of a part spans micrometres, not millimetres: the unit is applied
    assert 1e-4 < np.nanmax(m.heights) - np.nanmin(m.heights) < 0.1
    assert m.meta["format"]


@pytest.mark.slow
def test_zygo_file_keeps_intensity_and_instrument(shared_data):
    path = shared_data / CSI / "test_1.dat"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    m = api.read(path)
    assert m.intensity is not None and m.intensity.shape == m.shape
    # an 8-bit camera's counts (ac_range 255 in the header), not heights
    assert 0 <= np.nanmin(m.intensity) < np.nanmax(m.intensity) <= 255
    assert m.meta["instrument"]["vendor"] == "Zygo"
    assert m.meta["raw_metadata"]["wavelength_in"] == pytest.approx(570e-9, rel=1e-6)
    # the lateral step the header states (lateral_res, metres)
    assert m.dx == pytest.approx(m.meta["raw_metadata"]["lateral_res"] * 1000, rel=1e-12)


@pytest.mark.slow
def test_wyko_file_masks_its_undefined_points(shared_data):
    path = shared_data / CSI / "test_1.opd"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    m = api.read(path)
    assert 0 < m.shape[0] * m.shape[1] - m.n_valid < 0.01 * m.heights.size
    assert m.points().shape == (m.n_valid, 3) and np.isfinite(m.points()).all()


def _map(nan=True, origin=(0.25, -1.5)):
    rng = np.random.default_rng(7)
    h = rng.normal(scale=0.002, size=(37, 53)) + np.linspace(0, 0.01, 53)
    if nan:
        h[3, 4:9] = np.nan
    return api.HeightMap(h, 0.0013, 0.0017, origin=origin, name="map", meta={"instrument": {"model": "NewView"}})


FORMATS = [(".x3p", True), (".sdf", True), (".sdf", False)]


@pytest.mark.parametrize("ext, binary", FORMATS)
def test_round_trip_is_exact(tmp_path, ext, binary):
    m = _map(origin=(0.0, 0.0))
    path = tmp_path / f"m{ext}"
    api.write(m, path, binary=binary)
    back = api.read(path)
    np.testing.assert_array_equal(back.heights, m.heights)  # NaN where NaN, bit for bit elsewhere
    assert back.source_unit == "m"
    if ext == ".sdf" and binary:  # float64 metres in the binary header: one unit in the last place
        assert (back.dx, back.dy) == pytest.approx((m.dx, m.dy), rel=3e-16)
    else:
        assert (back.dx, back.dy) == (m.dx, m.dy)


@pytest.mark.slow
@pytest.mark.parametrize("ext, binary", FORMATS)
def test_surfacetopography_reads_our_files_the_same(tmp_path, ext, binary):
    m = _map(origin=(0.0, 0.0))
    path = tmp_path / f"m{ext}"
    api.write(m, path, binary=binary)
    ref, dx, dy = _st_heights_mm(path)
    np.testing.assert_array_equal(np.isnan(ref), ~m.valid)
    np.testing.assert_allclose(ref, m.heights, rtol=1e-15, atol=1e-18, equal_nan=True)
    assert (dx, dy) == pytest.approx((m.dx, m.dy), rel=1e-15)


def test_x3p_keeps_origin_and_instrument_and_is_the_standard_layout(tmp_path):
    m = _map()
    path = tmp_path / "m.x3p"
    api.write(m, path)
    back = api.read(path)
    assert back.origin == m.origin
    assert back.meta["instrument"]["model"] == "NewView"
    with zipfile.ZipFile(path) as zf:
        assert {"main.xml", "bindata/data.bin", "md5checksum.hex"} <= set(zf.namelist())
        xml = zf.read("main.xml").decode()
        assert "<SizeX>53</SizeX>" in xml and "<SizeY>37</SizeY>" in xml and "<FeatureType>SUR</FeatureType>" in xml
        # 1.3 um written in metres
        assert float(re.search(r"<CX>.*?<Increment>([^<]+)</Increment>", xml, re.S)[1]) == 1.3e-6


def test_x3p_validity_bitmap_and_integer_heights_are_read(tmp_path):
    """An X3P as instruments write it: 16-bit heights with increment and offset, invalid
    points in valid.bin (least-significant bit first)."""
    nx, ny = 5, 3
    raw = np.arange(nx * ny, dtype="<u2").reshape(ny, nx)
    valid = np.ones(nx * ny, bool)
    valid[[2, 9]] = False
    xml = f"""<?xml version="1.0"?><p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2">
<Record1><Revision>ISO5436 - 2000</Revision><FeatureType>SUR</FeatureType><Axes>
<CX><AxisType>I</AxisType><DataType>D</DataType><Increment>2e-6</Increment><Offset>0</Offset></CX>
<CY><AxisType>I</AxisType><DataType>D</DataType><Increment>3e-6</Increment><Offset>0</Offset></CY>
<CZ><AxisType>A</AxisType><DataType>I</DataType><Increment>1e-9</Increment><Offset>5e-6</Offset></CZ>
</Axes></Record1><Record3><MatrixDimension><SizeX>{nx}</SizeX><SizeY>{ny}</SizeY><SizeZ>1</SizeZ>
</MatrixDimension><DataLink><PointDataLink>bindata/data.bin</PointDataLink>
<ValidPointsLink>bindata/valid.bin</ValidPointsLink></DataLink></Record3></p:ISO5436_2>"""
    path = tmp_path / "int.x3p"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("main.xml", xml)
        zf.writestr("bindata/data.bin", raw.tobytes())
        zf.writestr("bindata/valid.bin", np.packbits(valid, bitorder="little").tobytes())
    m = api.read(path)
    assert m.shape == (3, 5) and (m.dx, m.dy) == (0.002, 0.003)
    expect = raw * 1e-6 + 5e-3  # mm: 1 nm per count above 5 um
    expect = np.where(valid.reshape(ny, nx), expect, np.nan)
    np.testing.assert_allclose(m.heights, expect, rtol=1e-14, equal_nan=True)
    # older openGPS versions mark invalid float points with +inf instead of NaN
    z = np.arange(nx * ny, dtype="<f8").reshape(ny, nx) * 1e-6
    z[1, 3] = np.inf
    path = tmp_path / "inf.x3p"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr(
            "main.xml",
            xml.replace(
                "<DataType>I</DataType><Increment>1e-9</Increment><Offset>5e-6</Offset>", "<DataType>D</DataType>"
            ).replace("<ValidPointsLink>bindata/valid.bin</ValidPointsLink>", ""),
        )
        zf.writestr("bindata/data.bin", z.tobytes())
    m = api.read(path)
    assert np.flatnonzero(~m.valid).tolist() == [1 * nx + 3]
    np.testing.assert_allclose(m.heights[0], z[0] * 1000)


def _garble(path, offset, data):
    b = bytearray(path.read_bytes())
    b[offset : offset + len(data)] = data
    path.write_bytes(bytes(b))


def test_bad_files_are_refused_in_one_line_naming_the_file(tmp_path):
    good = tmp_path / "good.x3p"
    api.write(_map(), good)
    cases = []
    p = tmp_path / "flipped.x3p"  # a bit flipped in the stored data: the MD5 catches it
    with zipfile.ZipFile(good) as zin, zipfile.ZipFile(p, "w") as zout:
        for item in zin.namelist():
            data = bytearray(zin.read(item))
            if item == "bindata/data.bin":
                data[100] ^= 1
            zout.writestr(item, bytes(data))
    cases.append((p, "do not match their MD5 checksum"))
    p = tmp_path / "notzip.x3p"
    p.write_bytes(b"this is not a zip at all")
    cases.append((p, "not a zip archive"))
    p = tmp_path / "short.sdf"
    api.write(_map(), p)
    p.write_bytes(p.read_bytes()[:500])
    cases.append((p, "SDF data are cut short"))
    p = tmp_path / "words.sdf"
    api.write(_map(), p, binary=False)
    p.write_bytes(p.read_bytes().replace(b"Xscale      = ", b"Xscale      = one"))
    cases.append((p, "SDF header value is not a number"))
    p = tmp_path / "magic.sdf"
    p.write_bytes(b"cISO-1.0" + bytes(200))
    cases.append((p, "not an ISO 25178-71 SDF file"))
    for path, reason in cases:
        with pytest.raises(InputError) as exc:
            api.read(path)
        msg = str(exc.value)
        assert msg.startswith(f"{path.name}: ") and reason in msg and "\n" not in msg, msg


def _gwy(path, xy_unit, z_unit):
    """A Gwyddion file written with SurfaceTopography's own GWY serialiser, units as given."""
    from SurfaceTopography.IO.GWY import _gwy_write_object

    def unit(u):
        return ("o", ("GwySIUnit", {"unitstr": ("s", u)}))

    h = np.arange(12.0).reshape(3, 4)
    field = {
        "xres": ("i", 4),
        "yres": ("i", 3),
        "xreal": ("d", 4.0),
        "yreal": ("d", 6.0),
        "xoff": ("d", 0.0),
        "yoff": ("d", 0.0),
        "si_unit_xy": unit(xy_unit),
        "si_unit_z": unit(z_unit),
        "data": ("D", h.astype("<f8").ravel()),
    }
    with open(path, "wb") as f:
        f.write(b"GWYP")
        _gwy_write_object(
            f, "GwyContainer", {"/0/data/title": ("s", "Height"), "/0/data": ("o", ("GwyDataField", field))}
        )


@pytest.mark.slow
def test_units_of_an_instrument_file(tmp_path):
    p = tmp_path / "scan.gwy"
    _gwy(p, "µm", "nm")
    m = api.read(p)
    # steps 4 um / 4 and 6 um / 3; heights in nm scaled to the lateral um, then to mm
    assert (m.dx, m.dy) == pytest.approx((1e-3, 2e-3), rel=1e-15) and m.source_unit == "um"
    np.testing.assert_allclose(m.heights, np.arange(12.0).reshape(3, 4) * 1e-6, rtol=1e-12)
    # an unknown lateral unit: SurfaceTopography 1.25 says so, 1.27 finds no length channel
    for xy, z, reason in (
        ("m", "V", "holds no height channel"),
        ("furlong", "m", "(Unknown unit 'furlong'|holds no height channel)"),
    ):
        _gwy(p, xy, z)
        with pytest.raises(InputError, match=rf"^scan\.gwy: .*{reason}"):
            api.read(p)
    p = tmp_path / "zygo.dat"  # the MetroPro magic, then nothing of a header
    p.write_bytes(b"\x88\x1b\x03\x6f" + bytes(100))
    with pytest.raises(InputError, match=r"^zygo\.dat: not a readable Zygo MetroPro DAT file \(.*\)$"):
        api.read(p)
    p = tmp_path / "scan.gwy"
    with pytest.raises(ParameterError, match="unknown length unit 'parsec'"):
        api.read(p, unit="parsec")


def test_a_stated_unit_rescales_steps_and_heights(tmp_path):
    path = tmp_path / "m.x3p"
    api.write(_map(), path)
    m = api.read(path, unit="um")  # the caller knows the file was written in um, not m
    ref = api.read(path)
    np.testing.assert_allclose(m.heights, ref.heights * 1e-6, equal_nan=True)  # um vs m
    assert m.dx == pytest.approx(ref.dx * 1e-6) and m.source_unit == "um"


def test_writing_a_heightmap_in_a_cloud_or_instrument_format_is_refused(tmp_path):
    with pytest.raises(InputError, match=r"m.ply: PLY cannot hold a heightmap; write it as one of .x3p, .sdf"):
        api.write(_map(), tmp_path / "m.ply")
    with pytest.raises(InputError, match=r"m.opd: camcmm reads Wyko/Bruker OPD but does not write it; .* .x3p, .sdf"):
        api.write(_map(), tmp_path / "m.opd")
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_info_cli_json_on_a_written_x3p(tmp_path, capfd):
    from helpers.cli import main_json  # in-process (the CLI's main): only the output counts

    path = tmp_path / "m.x3p"
    m = _map()
    api.write(m, path)
    d = main_json(capfd, "info", path, "--json")
    assert d["kind"] == "heightmap" and d["format"] == "X3P"
    assert d["grid"] == [53, 37] and d["steps_mm"] == [0.0013, 0.0017]
    assert d["size_mm"] == pytest.approx([53 * 0.0013, 37 * 0.0017])
    assert d["height_range_mm"] == pytest.approx([np.nanmin(m.heights), np.nanmax(m.heights)])
    assert d["valid_fraction"] == pytest.approx(1 - 5 / (53 * 37))
    assert d["source_unit"] == "m" and d["instrument"] == "NewView" and d["warnings"] == []
    assert info(path)["origin_mm"] == [0.25, -1.5]
