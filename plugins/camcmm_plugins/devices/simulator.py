"""A simulated Zaber-ASCII stage, and an interferometer watching it, in a separate process.

Run ``python -m camcmm_plugins.devices.simulator --pty --link /tmp/stage`` (or
``camcmm devices simulate-stage``). It opens a pseudo-terminal (or listens on
``--tcp HOST:PORT``, reached as ``socket://HOST:PORT``), prints ``STAGE <port>`` (and
``INTERFEROMETER <port>`` with ``--interferometer``) and ``READY`` on stdout, and
then answers the Zaber ASCII protocol (see :mod:`.zaber`) the way a real axis does:
moves take time at ``--speed``, positions are microsteps, ``WR`` until homed,
``RJ ... BADDATA`` outside the travel, ``RJ ... BADCOMMAND`` for unknown commands.

The interferometer endpoint speaks the line protocol of
:mod:`.interferometer` (``POS?`` -> ``POS <value> mm``) and reports the axis' TRUE
position: the commanded one times (1 + ``--scale-error`` ppm) plus a periodic
lead-screw error ``--periodic-um``, plus normal noise ``--noise-um``, relative to its
datum (``ZERO``). The stage's own read-back is the commanded position, as a stepper
stage's is, so the two differ as in a real scale run.

Faults, for tests, as commands on the stage port (simulator only)::

    /1 0 sim mute 2      no reply to the next 2 commands (time-outs)
    /1 0 sim garble 1    the next reply is garbled
    /1 0 sim garble 1 move   ... the next reply to a command starting with 'move'
    /1 0 sim delay 1.5   reply 1.5 s late from now on (0 ends it)
    /1 0 sim hang        never answer again (a hung controller)
    /1 0 sim exit        the process ends at once (a pulled cable / power loss)
    /1 0 sim exit 3      ... when the 3rd command from now arrives, unanswered (mid-move)
    /1 0 sim hang 3      ... likewise: the controller stops answering at the 3rd command
    /1 0 sim reset [3]   the controller resets (now, or at the 3rd command): axes stop,
                         positions count from 0 and have no reference (WR) until homed
    /1 0 sim stall       the next move never reaches its target (BUSY until ``stop``)
    /1 0 sim alerts 2    the next 2 replies come after an alert (``!``) and an info
                         (``#``) line
    /1 0 sim noise 2     the next 2 replies come among line noise: a truncated reply to
                         another message id, a line of junk bytes, and the remains of a
                         truncated alert in front of the reply on the same line

Every option is checked before anything is opened (:func:`check`; ``camcmm devices
simulate-stage``, ``python -m`` and :class:`SimulatorProcess` alike): a value the
simulator cannot serve is refused in one line naming the option and the value. Lines
on its ports never end it: bad data is answered ``RJ ... BADDATA``.

Killing the process (SIGKILL) is the other disconnection. Standard library only, so the
process starts in a fraction of a second.
"""

from __future__ import annotations

import argparse
import math
import os
import random
import select
import socket
import subprocess
import sys
import tempfile
import time
import tty
from pathlib import Path

VELOCITY_UNIT = 1.6384


MAX_DATA = 2**31 - 1  # positions and speeds are signed 32-bit numbers, as a device's
MAX_DELAY_S = 60.0  # longest reply delay ``sim delay`` sets
MAX_LINE = 4096  # a longer line without an end is dropped, as a device's input buffer overflows


def _data(text: str) -> int:
    """A command's integer data; ValueError (-> BADDATA) outside the 32-bit range."""
    if len(text) > 12:
        raise ValueError(text)
    v = int(text)
    if not -MAX_DATA <= v <= MAX_DATA:
        raise ValueError(text)
    return v


class SimAxis:
    def __init__(self, speed_steps: float, limits: tuple[int, int] | None):
        self.speed = float(speed_steps)  # microsteps/s
        self.limits = limits
        self.start = self.target = 0.0
        self.t0 = 0.0
        self.homed = False
        self.stall_next = self.stalled = False

    def pos(self) -> float:
        if self.stalled:  # held up (an obstruction, a slipping coupling): busy, not moving
            return self.start
        span = self.target - self.start
        moved = (time.monotonic() - self.t0) * self.speed
        return self.target if moved >= abs(span) else self.start + math.copysign(moved, span)

    def busy(self) -> bool:
        return self.pos() != self.target

    def move_to(self, target: float) -> None:
        self.start, self.target, self.t0 = self.pos(), float(target), time.monotonic()
        self.stalled, self.stall_next = self.stall_next and target != self.start, False

    def stop(self) -> None:
        p = self.pos()
        self.start = self.target = p
        self.stalled = False

    def reset(self) -> None:
        # a controller reset: the motion ends where it is and the count restarts at 0
        self.start = self.target = 0.0
        self.homed = self.stalled = self.stall_next = False


class ZaberSim:
    """The protocol state machine of one device with ``axes`` axes."""

    def __init__(
        self, address: int = 1, axes: int = 1, speed_steps: float = 2_000_000.0, limit_max: int | None = 4_200_000
    ):
        self.address = address
        lim = (0, int(limit_max)) if limit_max is not None else None
        self.axes = [SimAxis(speed_steps, lim) for _ in range(axes)]
        self.mute = 0
        self.garble = 0
        self.garble_only = ""
        self.alerts = 0
        self.noise = 0
        self.delay = 0.0
        self.hung = False
        self.at_command: dict[str, int] = {}  # fault -> commands until it strikes

    def handle(self, line: str) -> list[str]:
        text = line.strip()
        if not text.startswith("/"):
            return []
        body = text[1:]
        if ":" in body:  # checksum: drop the command if it does not match, as a device does
            body, _, cc = body.rpartition(":")
            if f"{(-sum(body.encode())) & 0xFF:02X}" != cc.upper():
                return []
        tokens = body.split()
        dev = int(tokens.pop(0)) if tokens and tokens[0].isdigit() else 0
        axis = int(tokens.pop(0)) if tokens and tokens[0].isdigit() else 0
        mid = tokens.pop(0) if tokens and tokens[0].isdigit() else None
        if dev not in (0, self.address):
            return []
        if tokens[:1] == ["sim"]:
            ok, data = self._sim(tokens[1:])
            return [self._reply(axis, mid, ok, data)]
        for fault in list(self.at_command):
            self.at_command[fault] -= 1
            if self.at_command[fault] <= 0:
                del self.at_command[fault]
                self._strike(fault)
        if self.hung:
            return []
        if self.mute > 0:  # the command is lost; line noise still comes
            self.mute -= 1
            return self._noisy([], axis, mid)
        if axis > len(self.axes):
            return [self._reply(axis, mid, False, "BADAXIS")]
        ok, data = self._command(axis, tokens)
        reply = self._reply(axis, mid, ok, data)
        if self.garble > 0 and " ".join(tokens).startswith(self.garble_only):
            self.garble -= 1
            reply = reply[: max(4, len(reply) // 2)] + "~#~"
        out = [reply]
        if self.alerts > 0:
            self.alerts -= 1
            out[:0] = [f"!{self.address:02d} {axis or 1} IDLE --", f"#{self.address:02d} {axis} 0 simulated info line"]
        return self._noisy(out, axis, mid)

    def _noisy(self, out: list[str], axis: int, mid: str | None) -> list[str]:
        if self.noise <= 0:
            return out
        self.noise -= 1
        other = f" {(int(mid) + 50) % 100}" if mid is not None else ""
        noise = [f"@{self.address:02d} {axis}{other} OK BU", "\x00\x7f~%&\x15 ="]
        return noise + out[:-1] + [f"!{self.address:02d} {axis or 1} ID" + out[-1]] if out else noise

    def _strike(self, fault: str) -> None:
        if fault == "exit":
            os._exit(3)
        elif fault == "hang":
            self.hung = True
        elif fault == "reset":
            for a in self.axes:
                a.reset()
            self.mute = self.garble = self.alerts = self.noise = 0

    def _sim(self, args: list[str]) -> tuple[bool, str]:
        what = args[0] if args else ""
        n = args[1] if len(args) > 1 else "1"
        count = int(n) if n.isdigit() and len(n) <= 9 else -1  # counts: 0 .. 999999999
        if what in ("mute", "garble", "alerts", "noise", "hang", "exit", "reset") and count < 0:
            return False, "BADDATA"
        if what == "mute":
            self.mute = count
        elif what == "garble":
            self.garble, self.garble_only = count, " ".join(args[2:])
        elif what == "alerts":
            self.alerts = count
        elif what == "noise":
            self.noise = count
        elif what == "delay":
            try:
                delay = float(n)
            except ValueError:
                return False, "BADDATA"
            if not 0.0 <= delay <= MAX_DELAY_S:  # also refuses nan
                return False, "BADDATA"
            self.delay = delay
        elif what == "stall":
            for a in self.axes:
                a.stall_next = True
        elif what in ("hang", "exit", "reset"):
            if len(args) > 1 and count > 0:
                self.at_command[what] = count
            else:
                self._strike(what)
        else:
            return False, "BADCOMMAND"
        return True, "0"

    def _reply(self, axis: int, mid: str | None, ok: bool, data: str) -> str:
        axes = self.axes if axis == 0 else [self.axes[axis - 1]] if axis <= len(self.axes) else []
        busy = any(a.busy() for a in axes)
        warn = "--" if all(a.homed for a in axes) else "WR"
        ident = f"{mid} " if mid is not None else ""
        return f"@{self.address:02d} {axis} {ident}{'OK' if ok else 'RJ'} {'BUSY' if busy else 'IDLE'} {warn} {data}"

    def _command(self, axis: int, t: list[str]) -> tuple[bool, str]:
        if not t:
            return True, "0"
        ax = self.axes[axis - 1] if axis else None
        cmd = " ".join(t[:2])
        try:
            if t[0] == "home" and len(t) == 1:
                for a in [ax] if ax else self.axes:
                    a.move_to(0)
                    a.homed = True
                return True, "0"
            if t[0] == "stop":
                for a in [ax] if ax else self.axes:
                    a.stop()
                return True, "0"
            if ax is None:
                return (
                    (True, "50081")
                    if cmd == "get device.id"
                    else (False, "BADAXIS" if t[0] in ("move", "get", "set") else "BADCOMMAND")
                )
            if cmd in ("move abs", "move rel") and len(t) == 3:
                target = _data(t[2]) + (round(ax.pos()) if t[1] == "rel" else 0)
                lo, hi = ax.limits or (-MAX_DATA, MAX_DATA)
                if not lo <= target <= hi:
                    return False, "BADDATA"
                ax.move_to(target)
                return True, "0"
            if cmd in ("move min", "move max") and ax.limits:
                ax.move_to(ax.limits[0 if t[1] == "min" else 1])
                return True, "0"
            if cmd in ("get pos", "get encoder.pos"):
                return True, str(int(round(ax.pos())))
            if cmd in ("get limit.min", "get limit.max") and ax.limits:
                return True, str(ax.limits[0 if t[1] == "limit.min" else 1])
            if cmd == "get maxspeed":
                return True, str(int(round(ax.speed * VELOCITY_UNIT)))
            if cmd == "set maxspeed" and len(t) == 3:
                v = _data(t[2])
                if v <= 0:
                    return False, "BADDATA"
                ax.speed = v / VELOCITY_UNIT
                return True, "0"
            if t == ["warnings"]:
                return True, "00" if ax.homed else "01 WR"
        except ValueError:
            return False, "BADDATA"
        return False, "BADCOMMAND"


class InterferometerSim:
    """Watches axis 1 of ``stage``: true position in mm, noise, datum (``ZERO``)."""

    def __init__(
        self,
        stage: ZaberSim,
        resolution: float,
        scale_ppm: float,
        periodic_um: float,
        period_mm: float,
        noise_um: float,
        seed: int,
    ):
        self.stage, self.resolution = stage, resolution
        self.scale, self.periodic, self.period = scale_ppm * 1e-6, periodic_um * 1e-3, period_mm
        self.noise = noise_um * 1e-3
        self.rng = random.Random(seed)
        self.datum = 0.0

    def truth(self) -> float:
        x = self.stage.axes[0].pos() * self.resolution
        return x * (1.0 + self.scale) + self.periodic * math.sin(2 * math.pi * x / self.period)

    def handle(self, line: str) -> list[str]:
        cmd = line.strip().upper()
        if not cmd:
            return []
        if cmd == "POS?":
            return [f"POS {self.truth() - self.datum + self.rng.gauss(0.0, self.noise):.7f} mm"]
        if cmd == "ZERO":
            self.datum = self.truth()
            return ["OK"]
        if cmd == "ID?":
            return ["ID camcmm simulated interferometer"]
        return [f"ERR unknown command {cmd[:20]}"]


class ConfigError(ValueError):
    """A simulator option that is out of range or cannot be used; ``str()`` is one line
    naming the option and its value."""


def _num(v: float) -> str:
    return str(v) if isinstance(v, int) else f"{v:g}"


def _opt(name: str) -> str:
    return "--" + name.replace("_", "-")


def parse_hostport(text: str, option: str = "--tcp") -> tuple[str, int]:
    """``HOST:PORT`` -> (host, port); an empty host is 127.0.0.1, port 0 a free one."""
    host, colon, port = str(text).rpartition(":")
    if not colon or not port.isdigit() or len(port) > 5 or int(port) > 65535:
        raise ConfigError(f"{option} {text!r}: expected HOST:PORT with a port from 0 (a free one) to 65535")
    if any(c.isspace() for c in host) or "/" in host:
        raise ConfigError(f"{option} {text!r}: {host!r} is not a host name or address")
    return host or "127.0.0.1", int(port)


def _check_link(path: str, option: str) -> None:
    p = Path(path)
    if p.is_symlink() or not p.exists():
        if not p.parent.is_dir():
            raise ConfigError(f"{option} {path}: the folder {p.parent} does not exist")
        return
    # never replace a user's file or folder by the link
    raise ConfigError(f"{option} {path}: exists and is not a link; give a new path")


#: option -> (integer?, lowest, highest, lowest excluded?, what it is); nan and inf are never accepted
LIMITS: dict[str, tuple[bool, float, float, bool, str]] = {
    "address": (True, 1, 99, False, "the device number on the daisy chain"),
    "axes": (True, 1, 9, False, "the number of axes"),
    "resolution": (False, 0.0, 1e6, True, "the size of one microstep in mm (or deg)"),
    "speed": (False, 0.0, 1e9, True, "the speed in mm/s (or deg/s)"),
    "travel": (False, 0.0, 1e9, True, "the travel in mm from 0"),
    "scale_error": (False, -1e6, 1e6, True, "the scale error in ppm"),
    "periodic_um": (False, 0.0, 1e6, False, "the periodic error's amplitude in um"),
    "period_mm": (False, 0.0, 1e9, True, "the periodic error's period in mm"),
    "noise_um": (False, 0.0, 1e6, False, "the interferometer noise in um (1 sigma)"),
    "seed": (True, 0, 2**32 - 1, False, "the noise seed"),
}


def check(args: argparse.Namespace) -> None:
    """Refuse a configuration the simulator cannot serve, before anything is opened:
    raises :class:`ConfigError` naming the option and its value. The same checks hold
    for ``camcmm devices simulate-stage``, ``python -m`` and :class:`SimulatorProcess`."""
    for name, (integer, lo, hi, lo_open, what) in LIMITS.items():
        v = getattr(args, name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and v != int(v)):
            raise ConfigError(f"{_opt(name)} {v!r}: {what} must be {'an integer' if integer else 'a number'}")
        if not (lo < v if lo_open else lo <= v) or not v <= hi:  # also refuses nan
            low = f"> {_num(lo)}" if lo_open else f">= {_num(lo)}"
            raise ConfigError(f"{_opt(name)} {_num(v)}: {what} must be {low} and <= {_num(hi)}")
    steps_per_s = args.speed / args.resolution * VELOCITY_UNIT
    if not 0.5 <= steps_per_s < MAX_DATA + 0.5:  # rounds to 1 .. MAX_DATA (inf is refused too)
        raise ConfigError(
            f"--speed {args.speed:g} with --resolution {args.resolution:g}: {steps_per_s:.6g} speed units "
            f"(microsteps/s x {VELOCITY_UNIT}); the device takes 1 to {MAX_DATA}"
        )
    if not args.rotary and not 0.5 <= args.travel / args.resolution < MAX_DATA + 0.5:
        raise ConfigError(
            f"--travel {args.travel:g} with --resolution {args.resolution:g}: "
            f"{args.travel / args.resolution:.6g} microsteps; the device counts 1 to {MAX_DATA}"
        )
    if args.tcp is not None:
        parse_hostport(args.tcp)
        if args.link:
            raise ConfigError(f"--link {args.link}: a link is for the pty; with --tcp the port is socket://HOST:PORT")
    elif args.link:
        _check_link(args.link, "--link")
    if not args.interferometer:
        for name in ("interferometer_link", "interferometer_tcp"):
            if getattr(args, name):
                raise ConfigError(f"{_opt(name)} {getattr(args, name)}: needs --interferometer")
        return
    if args.interferometer_tcp is not None:
        if args.tcp is None:
            raise ConfigError(f"--interferometer-tcp {args.interferometer_tcp}: needs --tcp (else it is on a pty)")
        parse_hostport(args.interferometer_tcp, "--interferometer-tcp")
    if args.interferometer_link:
        if args.tcp is not None:
            raise ConfigError(
                f"--interferometer-link {args.interferometer_link}: a link is for the pty; "
                "with --tcp use --interferometer-tcp"
            )
        _check_link(args.interferometer_link, "--interferometer-link")
        if args.link and os.path.abspath(args.link) == os.path.abspath(args.interferometer_link):
            raise ConfigError(f"--interferometer-link {args.interferometer_link}: the same path as --link")


class _Endpoint:
    """One byte stream (a pty master or a TCP listener with its client) and its handler.
    Opening failures are :class:`ConfigError` naming ``option`` and its value."""

    bugs = 0  # exceptions a handler raised (reported on stderr)

    def __init__(self, handler, link: str | None, tcp: str | None, option: str):
        self.handler, self.buf = handler, b""
        self.client: socket.socket | None = None
        self.fd = self.listener = self._slave = None
        if tcp is None:
            master, slave = os.openpty()
            tty.setraw(slave)  # no echo, no line editing: a serial line, not a terminal
            self.fd, self._slave = master, slave  # keep the slave open so that clients may come and go
            self.port = os.ttyname(slave)
            if link:
                tmp = f"{link}.{os.getpid()}.tmp"
                try:
                    os.symlink(self.port, tmp)
                    os.replace(tmp, link)
                except OSError as exc:
                    self.close()
                    raise ConfigError(f"{option} {link}: cannot make the link: {exc.strerror or exc}") from None
                self.port = link
        else:
            host, port = parse_hostport(tcp, option)
            self.listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            try:
                self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                self.listener.bind((host, port))
                self.listener.listen(1)
            except (OSError, OverflowError, UnicodeError) as exc:
                self.close()
                reason = getattr(exc, "strerror", None) or exc
                raise ConfigError(f"{option} {tcp}: cannot listen there: {reason}") from None
            h, p = self.listener.getsockname()
            self.port = f"socket://{h}:{p}"

    def close(self) -> None:
        for x in (self.client, self.listener):
            if x is not None:
                x.close()
        for fd in (self.fd, self._slave):
            if fd is not None:
                os.close(fd)
        self.client = self.listener = self.fd = self._slave = None

    def readables(self) -> list:
        return [x for x in (self.fd, self.listener, self.client) if x is not None]

    def on_ready(self, r, delay: float) -> None:
        if r is self.listener:
            if self.client is not None:
                self.client.close()
            self.client, _ = self.listener.accept()
            self.buf = b""
            return
        try:
            if r is self.fd:
                data = os.read(self.fd, 4096)
            else:
                assert self.client is not None  # r is the client's socket
                data = self.client.recv(4096)
        except OSError:
            data = b""
        if not data:
            if r is self.client:
                self.client.close()
                self.client = None
            return
        self.buf += data
        while True:
            cut = min((i for i in (self.buf.find(b"\n"), self.buf.find(b"\r")) if i >= 0), default=-1)
            if cut < 0:
                self.buf = self.buf[-MAX_LINE:] if len(self.buf) > MAX_LINE else self.buf
                break
            line, self.buf = self.buf[:cut], self.buf[cut + 1 :]
            try:
                out = self.handler(line[:MAX_LINE].decode("ascii", "replace"))
            except Exception as exc:  # a simulator bug: say so (a few times: stderr may be an undrained pipe),
                _Endpoint.bugs += 1  # keep serving as a device would
                if _Endpoint.bugs <= 10:
                    print(f"simulator: {type(exc).__name__}: {exc} on {line[:80]!r}", file=sys.stderr, flush=True)
                out = []
            if out and delay:
                time.sleep(delay)
            for reply in out:
                self.write((reply + "\r\n").encode("ascii", "replace"))

    def write(self, data: bytes) -> None:
        try:
            if self.fd is not None:
                os.write(self.fd, data)
            elif self.client is not None:
                self.client.sendall(data)
        except OSError:
            pass


class Simulator:
    """The stage (and interferometer) endpoints of ``args`` (the options of
    :func:`configure`), checked and opened; :class:`ConfigError` if they cannot be."""

    def __init__(self, args: argparse.Namespace):
        check(args)
        self.stage = ZaberSim(
            args.address,
            args.axes,
            args.speed / args.resolution,
            None if args.rotary else int(round(args.travel / args.resolution)),
        )
        self.endpoints = [_Endpoint(self.stage.handle, args.link, args.tcp, "--tcp" if args.tcp else "--link")]
        if args.interferometer:
            ifm = InterferometerSim(
                self.stage,
                args.resolution,
                args.scale_error,
                args.periodic_um,
                args.period_mm,
                args.noise_um,
                args.seed,
            )
            tcp = None if args.tcp is None else args.interferometer_tcp or parse_hostport(args.tcp)[0] + ":0"
            try:
                self.endpoints.append(
                    _Endpoint(
                        ifm.handle,
                        args.interferometer_link,
                        tcp,
                        "--interferometer-tcp" if tcp else "--interferometer-link",
                    )
                )
            except ConfigError:
                self.close()
                raise

    def announce(self) -> None:
        print(f"STAGE {self.endpoints[0].port}", flush=True)
        if len(self.endpoints) > 1:
            print(f"INTERFEROMETER {self.endpoints[1].port}", flush=True)
        print("READY", flush=True)

    def serve_forever(self) -> None:
        eps = self.endpoints
        while True:
            owners = {r: e for e in eps for r in e.readables()}
            ready, _, _ = select.select(list(owners), [], [], 0.5)
            for r in ready:
                owners[r].on_ready(r, self.stage.delay if owners[r] is eps[0] else 0.0)

    def close(self) -> None:
        for e in self.endpoints:
            e.close()


def serve(args: argparse.Namespace) -> None:
    """Check and open (:class:`ConfigError` if impossible), print the ports, serve until killed."""
    sim = Simulator(args)
    try:
        sim.announce()
        sim.serve_forever()
    finally:
        sim.close()


def configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("--tcp", metavar="HOST:PORT", help="listen on TCP (socket://HOST:PORT) instead of a pty")
    p.add_argument("--link", metavar="PATH", help="symlink to the pty, stable across restarts (a new path or a link)")
    p.add_argument("--address", type=int, default=1, help="device address, 1 to 99 (default 1)")
    p.add_argument("--axes", type=int, default=1, help="number of axes, 1 to 9 (default 1)")
    p.add_argument("--resolution", type=float, default=0.001, help="mm (or deg) per microstep, > 0 (default 0.001)")
    p.add_argument("--speed", type=float, default=200.0, help="speed in mm/s (or deg/s), > 0; default 200")
    p.add_argument("--travel", type=float, default=150.0, help="travel in mm from 0, > 0 (default 150)")
    p.add_argument("--rotary", action="store_true", help="no travel limits (a rotary axis)")
    p.add_argument("--interferometer", action="store_true", help="also serve an interferometer watching axis 1")
    p.add_argument("--interferometer-link", metavar="PATH", help="symlink to the interferometer's pty")
    p.add_argument("--interferometer-tcp", metavar="HOST:PORT", help="with --tcp: the interferometer's address")
    p.add_argument("--scale-error", type=float, default=0.0, help="true/commanded - 1 in ppm (-1e6 to 1e6)")
    p.add_argument("--periodic-um", type=float, default=0.0, help="periodic lead-screw error amplitude (um, >= 0)")
    p.add_argument("--period-mm", type=float, default=5.0, help="its period (mm, > 0)")
    p.add_argument("--noise-um", type=float, default=0.0, help="interferometer noise (um, 1 sigma, >= 0)")
    p.add_argument("--seed", type=int, default=0, help="noise seed, 0 to 2**32-1")


class _RaisingParser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        raise ConfigError(message)


class _OneLineParser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        print(f"{self.prog}: error: {message}", file=sys.stderr)  # one line, as camcmm's own errors
        raise SystemExit(2)


def parse(argv: list[str]) -> argparse.Namespace:
    """The simulator's options from ``argv``, checked: :class:`ConfigError` names the
    first one at fault (what the process would refuse, without starting it)."""
    p = _RaisingParser(prog="camcmm-stage-simulator", add_help=False)
    p.add_argument("--pty", action="store_true")
    configure(p)
    args = p.parse_args(argv)
    check(args)
    return args


class SimulatorProcess:
    """Start the simulator as a child process and read its ports. ``restart()`` starts
    it again on the same ports (pty links or TCP port), as a power-cycled device."""

    def __init__(
        self,
        *args: str,
        folder: str | os.PathLike | None = None,
        pty: bool = True,
        interferometer: bool = False,
        timeout: float = 20.0,
    ):
        self.folder = Path(folder or tempfile.mkdtemp(prefix="camcmm-sim-"))
        self.folder.mkdir(parents=True, exist_ok=True)
        self.args = [str(a) for a in args]
        if pty and "--tcp" not in self.args:
            self.args += ["--link", str(self.folder / "stage")]
            if interferometer:
                self.args += ["--interferometer-link", str(self.folder / "interferometer")]
        elif "--tcp" not in self.args:
            self.args += ["--tcp", "127.0.0.1:0"]
        if interferometer:
            self.args.append("--interferometer")
        parse(self.args)  # an impossible configuration is refused here, in one line, not by a child
        self.timeout = timeout
        self.proc: subprocess.Popen | None = None
        self.stage_port = self.interferometer_port = ""
        self.start()

    def start(self) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "camcmm_plugins.devices.simulator", *self.args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert self.proc.stdout is not None and self.proc.stderr is not None  # PIPEs
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                why = [x for x in self.proc.stderr.read()[-2000:].splitlines() if x.strip()]
                self.proc.wait()
                if self.proc.returncode == 2 and why:  # refused its configuration (e.g. a TCP port in use)
                    raise ConfigError(why[-1].strip().removeprefix("camcmm-stage-simulator: error: "))
                raise RuntimeError(
                    f"stage simulator ended (exit {self.proc.returncode}): {why[-1].strip() if why else 'no message'}"
                )
            word, _, rest = line.strip().partition(" ")
            if word == "STAGE":
                self.stage_port = rest
                if rest.startswith("socket://") and "--tcp" in self.args:
                    self.args[self.args.index("--tcp") + 1] = rest[len("socket://") :]
            elif word == "INTERFEROMETER":
                self.interferometer_port = rest
                if rest.startswith("socket://") and "--interferometer-tcp" not in self.args:
                    self.args += ["--interferometer-tcp", rest[len("socket://") :]]
            elif word == "READY":
                return
        raise RuntimeError("stage simulator did not start in time")

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
        if self.proc is not None:
            self.proc.wait()

    def restart(self) -> None:
        self.kill()
        self.start()

    stop = kill

    def __enter__(self) -> SimulatorProcess:
        return self

    def __exit__(self, *exc) -> None:
        self.kill()


def main(argv: list[str] | None = None) -> None:
    p = _OneLineParser(prog="camcmm-stage-simulator", description=__doc__.splitlines()[0])
    p.add_argument("--pty", action="store_true", help="serve on a pseudo-terminal (the default without --tcp)")
    configure(p)
    args = p.parse_args(argv)
    try:
        sim = Simulator(args)
    except ConfigError as exc:
        p.error(str(exc))
    try:
        sim.announce()
        sim.serve_forever()
    finally:
        sim.close()


if __name__ == "__main__":
    main()
