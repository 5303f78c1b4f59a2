"""Height-map readers against hostile and damaged headers (issue 26): zip and XML bombs
refused before they inflate, header fields that scale the data (increments, Zscale,
MetroPro's wavelength) refused when they would give a silently wrong map, and the
valid files the refusals are tested against read to the right numbers.

The files come from the bad-input family (tests/helpers/badcases/heightmaps.py).
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from camcmm.errors import CamcmmError
from camcmm.io import read
from helpers.badcases.heightmaps import (
    BILLION_LAUGHS,
    NX,
    NY,
    Z,
    metropro,
    patch_size,
    sdf_ascii,
    sdf_binary,
    x3p,
    x3p_xml,
    zipped,
)


def _refused(tmp_path, name: str, data: bytes, *words: str) -> str:
    p = tmp_path / name
    p.write_bytes(data)
    with pytest.raises(CamcmmError) as err:
        read(p)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(name)
    for w in words:
        assert w in msg, msg
    return msg


# -- the valid files: the right numbers ------------------------------------------------------
def test_valid_x3p_reads_heights_steps_and_offsets_in_mm(tmp_path):
    p = tmp_path / "ok.x3p"
    p.write_bytes(x3p(zoff="2e-3", xoff="-1e-3"))
    hm = read(p)
    assert hm.shape == (NY, NX)
    assert hm.dx == hm.dy == 0.01  # 1e-5 m
    assert hm.origin == (-1.0, 0.0)
    # z = value * 1e-6 m + 2e-3 m, in mm
    np.testing.assert_allclose(hm.heights.ravel(), Z * 1e-3 + 2.0, rtol=0, atol=1e-15)


def test_valid_x3p_integer_data_scaled_by_the_increment(tmp_path):
    p = tmp_path / "int.x3p"
    p.write_bytes(x3p(data=np.arange(NX * NY, dtype="<u2").tobytes(), dtype="I", zinc="2e-9"))
    np.testing.assert_allclose(read(p).heights.ravel(), np.arange(NX * NY) * 2e-6, rtol=1e-15)


def test_valid_sdf_binary_and_ascii_and_metropro(tmp_path):
    for name, data in (("b.sdf", sdf_binary()), ("a.sdf", sdf_ascii())):
        p = tmp_path / name
        p.write_bytes(data)
        hm = read(p)
        assert (hm.dx, hm.dy) == (0.01, 0.01)
        np.testing.assert_allclose(hm.heights.ravel(), Z * 1e-3, rtol=1e-15)
    p = tmp_path / "m.dat"
    p.write_bytes(metropro())
    hm = read(p)
    # count * intf 0.5 * obliquity 1 * wavelength 6.33e-7 m (float32) / 32768, in mm
    k = 0.5 * float(np.float32(6.33e-7)) / 32768 * 1000
    np.testing.assert_allclose(hm.heights.ravel(), np.arange(NX * NY) * 100 * k, rtol=1e-6)
    assert hm.dx == pytest.approx(1e-3, rel=1e-6)


# -- bombs --------------------------------------------------------------------------------------
def test_zip_bomb_member_refused_before_it_inflates(tmp_path):
    """256 MB of zeros in a 0.26 MB file, for an 8 x 6 grid: the old reader inflated the
    whole member (558 MB traced); refused now from the declared sizes, nothing read."""
    bomb = zipped({"main.xml": x3p_xml(md5=None), "bindata/data.bin": b"\0" * (256 << 20)}, level=9)
    assert len(bomb) < 300_000
    p = tmp_path / "bomb.x3p"
    p.write_bytes(bomb)
    del bomb
    tracemalloc.start()
    try:
        with pytest.raises(CamcmmError, match="declares 268435456 bytes; the grid needs 384"):
            read(p)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 << 20


def test_member_bigger_than_its_grid_refused_before_reading(tmp_path):
    bomb = zipped({"main.xml": x3p_xml(md5=None), "bindata/data.bin": b"\0" * (16 << 20)}, level=9)
    _refused(tmp_path, "big.x3p", bomb, "declares 16777216 bytes; the grid needs 384")


def test_member_lying_about_its_size_stops_at_the_grid(tmp_path):
    bomb = zipped({"main.xml": x3p_xml(md5=None), "bindata/data.bin": b"\0" * (16 << 20)}, level=9)
    _refused(tmp_path, "lie.x3p", patch_size(bomb, "bindata/data.bin", NX * NY * 8), "bindata/data.bin")


def test_reading_a_valid_map_holds_about_twice_the_grid(tmp_path):
    """The raw data and their float64 heights and a chunk of the zip member (1 MB)
    besides, nothing more (the old reader: 3.3 times the grid)."""
    z = np.random.default_rng(0).normal(size=(1000, 1500))
    p = tmp_path / "v.x3p"
    p.write_bytes(x3p(data=z.astype("<f8").tobytes(), nx=1500, ny=1000))
    tracemalloc.start()
    try:
        hm = read(p)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_array_equal(hm.heights, z * 1e-3)
    assert peak < 2.4 * z.nbytes


@pytest.mark.parametrize(
    "xml",
    [
        BILLION_LAUGHS,
        BILLION_LAUGHS.replace(b'<?xml version="1.0"?>', b"").decode().encode("utf-16"),
        b'<?xml version="1.0"?><!DOCTYPE a [<!ENTITY e SYSTEM "file:///etc/passwd">]><a>&e;</a>',
    ],
    ids=["billion-laughs", "utf16", "external-entity"],
)
def test_xml_entities_refused(tmp_path, xml):
    _refused(tmp_path, "x.x3p", x3p(xml=xml), "DTD or entities")


def test_xml_too_big_refused_before_reading(tmp_path):
    _refused(tmp_path, "big.x3p", patch_size(x3p(), "main.xml", 10 << 20), "main.xml declares 10485760 bytes")


def test_grid_beyond_the_memory_limit_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("CAMCMM_MAX_MEMORY_MB", "20")
    data = zipped({"main.xml": x3p_xml(nx=2048, ny=1024, xinc="1e-8", yinc="1e-8", md5=None)})
    _refused(tmp_path, "g.x3p", data, "2048 x 1024", "memory")


# -- header fields that scale the data -------------------------------------------------------
@pytest.mark.parametrize(
    ("kw", "words"),
    [
        ({"zinc": "0"}, ("CZ Increment",)),
        ({"zinc": "-1e-6"}, ("CZ Increment",)),
        ({"zinc": "NaN"}, ("CZ Increment",)),
        ({"zinc": "1e300"}, ("implausible",)),
        ({"xinc": "0"}, ("dx",)),
        ({"xinc": "1e300"}, ("8e+303 mm", "5000 mm")),
        ({"yinc": "1e-30"}, ("dy", "below")),
        ({"xoff": "1e300"}, ("origin",)),
    ],
)
def test_x3p_scaling_fields_refused(tmp_path, kw, words):
    _refused(tmp_path, "f.x3p", x3p(**kw), *words)


@pytest.mark.parametrize(
    ("data", "words"),
    [
        (sdf_binary(zs=0.0), ("Zscale",)),
        (sdf_binary(xs=1e300), ("Xscale", "5000 mm")),
        (sdf_binary(xs=-1e-5), ("dx",)),
        (sdf_ascii(zs="0"), ("Zscale",)),
        (sdf_binary() + b"\0" * 16, ("400 bytes", "need 384", "16 trailing bytes")),
        (sdf_ascii(values="1 " * (NX * NY) + "\n" + "7 " * 100000), ("trailing",)),
    ],
    ids=["zs0", "xs1e300", "xsneg", "ascii-zs0", "trailing", "ascii-trailing"],
)
def test_sdf_scaling_fields_and_trailing_bytes_refused(tmp_path, data, words):
    _refused(tmp_path, "s.sdf", data, *words)


@pytest.mark.parametrize(
    ("kw", "words"),
    [
        ({"wavelength": 0.0}, ("wavelength_in 0.0", "height scale factor")),
        ({"intf": 0.0}, ("intf_scale_factor 0.0",)),
        ({"lateral": 0.0}, ("lateral resolution",)),
        ({"lateral": 1e30}, ("5000 mm",)),
    ],
)
def test_metropro_scaling_fields_refused(tmp_path, kw, words):
    _refused(tmp_path, "m.dat", metropro(**kw), *words)


def test_member_inflating_like_a_bomb_refused_even_when_the_grid_fits(tmp_path):
    """8192 x 8192 float64 heights declared honestly (512 MB, within the memory limit)
    from 35 compressed bytes: no measurement deflates so; refused before inflating."""
    honest = zipped(
        {"main.xml": x3p_xml(nx=8192, ny=8192, xinc="1e-7", yinc="1e-7", md5=None), "bindata/data.bin": b"\0"}
    )
    _refused(tmp_path, "r.x3p", patch_size(honest, "bindata/data.bin", 8192 * 8192 * 8), "zip bomb", ":1")


@pytest.mark.parametrize("ext", [".plux", ".zon", ".vk6"])
def test_vendor_zip_bomb_refused_before_surface_topography_reads_it(tmp_path, ext):
    bomb = patch_size(zipped({"data.bin": b"\0" * 4096, "index.xml": b"<a/>"}), "data.bin", 3 << 30)
    _refused(tmp_path, f"b{ext}", bomb, "'data.bin' inflates", "zip bomb")


def test_ascii_sdf_read_line_by_line_keeps_bad_points_and_values_across_lines(tmp_path):
    words = [repr(float(v)) for v in Z]
    words[3] = "BAD"
    p = tmp_path / "a.sdf"
    p.write_bytes(sdf_ascii(values=" ".join(words[:5]) + "\n" + "\n".join(words[5:]) + "\n"))
    h = read(p).heights.ravel()
    assert np.isnan(h[3]) and np.isnan(h).sum() == 1
    np.testing.assert_allclose(np.delete(h, 3), np.delete(Z, 3) * 1e-3, rtol=1e-15)
    _refused(tmp_path, "m.sdf", sdf_ascii(values="1 " * (NX * NY + 1)), "more than 48 values")


def test_camcmm_members_refused_in_one_line(tmp_path):
    _refused(tmp_path, "d.x3p", x3p(members={"camcmm/meta.json": b"[" * 200000}), "meta.json is not JSON")
    short = x3p(members={"camcmm/intensity.bin": b"\0" * 16})
    _refused(tmp_path, "i.x3p", short, "declares 16 bytes; the grid needs 384")
