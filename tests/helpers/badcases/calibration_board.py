"""Bad board checks (issue 30): ``camcmm run calibration.board-check IMAGE --board SPEC``,
the Calibration page's look for the board in the first image, with a wrong board spec
(no size, a size of 0, a marker larger than its square, an unknown kind), no board
given, an image that is missing, junk or a decompression bomb, and an image without the
board (exit 0 with an explicit warning). Ids start with ``calboard-``."""

from __future__ import annotations

from helpers.badinputs import Case, _encoded, _junk, chessboard_png, png_bomb


def cases() -> list[Case]:
    board = {"b.png": chessboard_png()}  # 9 x 6 inner corners
    out: list[Case] = []

    def rc(cid: str, image: str, args: tuple[str, ...], names: tuple[str, ...], files=None) -> None:
        out.append(
            Case(f"calboard-{cid}", ("run", "calibration.board-check", image, *args, "--json"),
                 board if files is None else files, names)
        )  # fmt: skip

    for spec in ("chessboard:9x6", "chessboard:9x6:0", "charuco:5x5:20:30", "dots:9x6:25", "chessboard:9x6:nan"):
        rc(f"spec-{spec.replace(':', '-')}", "b.png", ("--board", spec), ("board", spec))
    rc("no-board", "b.png", (), ("board",))
    rc("missing-image", "gone.png", ("--board", "chessboard:9x6:20"), ("gone.png",), {})
    rc("junk-image", "j.png", ("--board", "chessboard:9x6:20"), ("j.png",), {"j.png": _junk(3000)})
    rc("bomb-image", "bomb.png", ("--board", "chessboard:9x6:20"), ("bomb.png",), {"bomb.png": png_bomb()})
    # an image without the board: the check answers (found 0) and warns, it does not fail
    rc("not-found", "blank.png", ("--board", "chessboard:9x6:20"), ("blank.png",),
       {"blank.png": _encoded(".png", (240, 320))})  # fmt: skip
    return out
