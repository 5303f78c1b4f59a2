"""Bad CAD files (issue 27): ``camcmm info`` and ``camcmm inspect --nominal`` on STEP and IGES
files that are not what their extension says, are empty, hold no shape or are cut or
garbled. Ids start with ``cad-``. Each must be refused in one line naming the file (the
header is checked before OpenCascade parses anything)."""

from __future__ import annotations

from helpers.badinputs import Case, _junk, _sphere, _tetra, ply_binary, stl_binary

HEADER = (
    b"ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('camcmm test'),'2;1');\n"
    b"FILE_NAME('t.step','2026-01-01T00:00:00',(''),(''),'','','');\n"
    b"FILE_SCHEMA(('AUTOMOTIVE_DESIGN'));\nENDSEC;\n"
)
#: a STEP with data but no shape: a lone point
POINT_ONLY = HEADER + b"DATA;\n#1=CARTESIAN_POINT('',(0.,0.,0.));\nENDSEC;\nEND-ISO-10303-21;\n"
#: a face whose surface is missing (#9 is not defined)
DANGLING = (
    HEADER + b"DATA;\n#1=ADVANCED_FACE('',(#2),#9,.T.);\n#2=FACE_OUTER_BOUND('',#3,.T.);\nENDSEC;\nEND-ISO-10303-21;\n"
)


def cases() -> list[Case]:
    out: list[Case] = []
    v, f = _tetra()
    stl = stl_binary(v[f])
    cloud = {"scan.ply": ply_binary(_sphere(200))}

    def both(cid: str, name: str, data: bytes) -> None:
        out.append(Case(f"cad-info-{cid}", ("info", name), {name: data}, (name,), 20.0))
        out.append(
            Case(
                f"cad-inspect-{cid}",
                ("inspect", "scan.ply", "--nominal", name, "--json"),
                {**cloud, name: data},
                (name,),
                30.0,
            )
        )

    both("stl-as-step", "part.step", stl)
    both("empty-step", "part.stp", b"")
    both("blank-step", "part.step", b"\n\n   \n")
    both("header-only", "part.step", HEADER + b"DATA;\nENDSEC;\nEND-ISO-10303-21;\n")
    both("point-only", "part.step", POINT_ONLY)
    both("dangling-face", "part.step", DANGLING)
    both("cut-step", "part.step", HEADER[:60])
    both("junk-after-magic", "part.stp", b"ISO-10303-21;\n" + _junk(4000))
    both("junk-step", "part.stp", _junk(3000))
    both("text-iges", "part.iges", b"not an IGES file\n")
    both("junk-iges", "part.igs", _junk(2000, seed=3))
    both("short-iges", "part.igs", b"S" * 80 + b"\n")
    return out
