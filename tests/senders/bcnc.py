"""bCNC (from PyPI) driving `fuzzy-send serve` headless over TCP.

    python bcnc.py --url socket://127.0.0.1:PORT

bCNC's own `Sender` (its serial thread, character counting against 128
bytes) and its `GRBL1` controller class, without its Tk window: the few
methods the window supplies are stubbed, and a job is queued as bCNC's
Run button queues it (`bmain.Application.run`: `GCode.compile` into the
queue, then a WAIT for Idle). bCNC reads the machine through its status
parser (`CNC.vars`), which is what is checked.
"""

import argparse
import os
import sys
import tempfile
import time
from queue import Empty

import bCNC

HERE = os.path.dirname(bCNC.__file__)
sys.path[:0] = [HERE, os.path.join(HERE, "lib"), os.path.join(HERE, "controllers")]

import Helpers  # noqa: E402,F401  (installs gettext's _ for the rest)
import Utils  # noqa: E402

Utils.loadConfiguration()

import Sender  # noqa: E402
from CNC import CNC, WAIT  # noqa: E402


def log(*a):
    print("[bcnc]", *a, flush=True)


class Headless(Sender.Sender):
    """What bCNC's window adds to its Sender, as no-ops."""

    def disable(self):
        pass

    def enable(self):
        pass

    def busy(self):
        pass

    def notBusy(self):
        pass

    def event_generate(self, *a, **k):
        pass

    def acceptKey(self, *a):
        return True


def until(what, timeout, pred, app):
    t0 = time.time()
    while True:
        drain(app)
        v = pred()
        if v:
            return v
        if time.time() - t0 > timeout:
            raise RuntimeError(f"timed out waiting for {what}; state {CNC.vars['state']} "
                               f"MPos {mpos()}")
        time.sleep(0.02)


ERRORS = []
PLANE = None
STEP = 0.01


def drain(app):
    """The log bCNC's window would show; errors kept."""
    while True:
        try:
            kind, msg = app.log.get_nowait()
        except Empty:
            return
        if kind == Sender.Sender.MSG_ERROR:
            ERRORS.append(msg)


def mpos():
    return "{:.3f},{:.3f},{:.3f}".format(CNC.vars["mx"], CNC.vars["my"], CNC.vars["mz"])


def run_job(app, name, gcode, during=None):
    """Load and run a program as bCNC's Run button does; wait for its end
    (`during` acts while it runs)."""
    path = os.path.join(tempfile.mkdtemp(), name)
    with open(path, "w") as f:
        f.write(gcode)
    app.gcode.load(path)
    app.running = True
    app._runLines = sys.maxsize
    app._gcount = 0
    paths = app.gcode.compile(app.queue, lambda: False)
    app._runLines = len(paths) + 1
    app.queue.put((WAIT,))
    t0 = time.time()
    if during:
        during()
    until(f"{name} to end", 120, lambda: app._gcount >= app._runLines, app)
    app.runEnded()
    log(f"{name}: {len(paths)} lines, every one answered, in {time.time() - t0:.1f} s")


def settled(app, what):
    """Idle, with the same position over a few reports."""
    last = [None, 0]

    def still():
        p = (CNC.vars["state"], mpos())
        if p != last[0]:
            last[0], last[1] = p, time.time()
        return p[0] == "Idle" and time.time() - last[1] > 0.5

    until(what, 60, still, app)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    ap.add_argument("--plane", help="the simulated stock: Z,SX,SY (machine coordinates)")
    ap.add_argument("--step", type=float, default=0.01, help="the axes' step, mm")
    a = ap.parse_args()
    url = a.url
    global PLANE, STEP
    PLANE = tuple(float(v) for v in a.plane.split(",")) if a.plane else None
    STEP = a.step

    app = Headless()
    app.open(url, 115200)
    log(f"opened {url}")
    # bCNC flushes its input a second after opening (the welcome of an
    # Arduino reset by DTR); over TCP there is no reset, so it keeps the
    # controller it starts with, GRBL1.
    if app.controller != "GRBL1":
        raise RuntimeError(f"controller {app.controller}")
    settled(app, "a first status")
    log(f"connected: {CNC.vars['state']} at {mpos()}")

    steps = []

    def step(f):
        steps.append(f)
        return f

    @step
    def a_job():
        run_job(app, "square.nc", "\n".join([
            "G21 G90 G94",
            "G0 X0 Y0 Z1",
            "M3 S1000",
            "G4 P0.2",
            "G1 Z-0.5 F300",
            "G1 X10 F1000",
            "G1 Y10",
            "G2 X0 Y10 I-5 J0",
            "G1 Y0",
            "G0 Z1",
            "M5",
            "G0 X1.5 Y-2.25",
        ]) + "\n")
        settled(app, "the job at rest")
        if mpos() != "1.500,-2.250,1.000":
            raise RuntimeError(f"the end: MPos {mpos()}, want 1.500,-2.250,1.000")
        log(f"the end: MPos {mpos()}")

    @step
    def feed_hold_and_resume():
        def hold():
            until("motion", 10, lambda: CNC.vars["state"] == "Run" and CNC.vars["mx"] > 2, app)
            app.feedHold()
            until("Hold:0", 5, lambda: CNC.vars["state"] == "Hold:0", app)
            at = mpos()
            t = time.time()
            until("a second held", 5, lambda: time.time() - t > 1, app)
            if mpos() != at or CNC.vars["state"] != "Hold:0":
                raise RuntimeError(f"moved while held: {at} then {mpos()}")
            log(f"held at {at}")
            app.resume()

        lines = ["G21 G90 G1 F1000"] + [f"X{2 if i % 2 else 30} Y{i - 2.25}" for i in range(6)]
        run_job(app, "zigzag.nc", "\n".join(lines + ["G0 X1.5 Y-2.25"]) + "\n", hold)
        settled(app, "the job at rest")
        if mpos() != "1.500,-2.250,1.000":
            raise RuntimeError(f"the end: MPos {mpos()}, want 1.500,-2.250,1.000")
        log(f"the end: MPos {mpos()}")

    @step
    def feed_override():
        # bCNC's override slider: 0x91 written as a character.
        CNC.vars["_OvFeed"] = 110
        CNC.vars["_OvChanged"] = True
        until("Ov:110", 5, lambda: CNC.vars["OvFeed"] == 110, app)
        CNC.vars["_OvFeed"] = 100
        CNC.vars["_OvChanged"] = True
        until("Ov:100", 5, lambda: CNC.vars["OvFeed"] == 100, app)

    @step
    def a_jog():
        # bCNC's jog buttons: `$J=G91 X2 F100000` (the feed clamped to the
        # machine's maximum, as Grbl does).
        app.mcontrol.jog("X2")
        until("the jog", 40, lambda: mpos() != "1.500,-2.250,1.000", app)
        settled(app, "the jog at rest")
        if mpos() != "3.500,-2.250,1.000":
            raise RuntimeError(f"after the jog: MPos {mpos()}, want 3.500,-2.250,1.000")
        log(f"after the jog: MPos {mpos()}")

    @step
    def work_zero():
        app.sendGCode("G10 L20 P1 X0 Y0")
        app.sendGCode("$#")
        until("[G54:] from $#", 30, lambda: CNC.vars.get("G54") == ["3.500", "-2.250", "0.000"], app)
        until("WCO in a status report", 30, lambda: (CNC.vars["wcox"], CNC.vars["wcoy"]) == (3.5, -2.25), app)
        # bCNC computes WPos from the WCO it had when MPos came (WCO comes
        # after MPos in a report): the next report has it.
        until("WPos 0,0", 15, lambda: (CNC.vars["wx"], CNC.vars["wy"]) == (0.0, 0.0), app)
        log(f"G54 {CNC.vars['G54']}; WPos {CNC.vars['wx']},{CNC.vars['wy']},{CNC.vars['wz']}")

    @step
    def autolevel_scan():
        # bCNC's Probe page, Autolevel: a 3 x 3 grid over 8 x 4 mm scanned
        # with G38.2 (`Probe.scan`, run as its Scan button runs it), each
        # [PRB:] parsed into its height matrix (work coordinates). The
        # simulated stock is the tilted plane the serve was started with.
        if PLANE is None:
            return
        probe = app.gcode.probe
        probe.xmin, probe.xmax, probe.xn = 0.0, 8.0, 3
        probe.ymin, probe.ymax, probe.yn = 0.0, 4.0, 3
        probe.zmin, probe.zmax = -6.0, 1.0
        probe.xstep()
        probe.ystep()
        CNC.vars["prbfeed"] = 200.0
        CNC.vars["safe"] = 1.0
        lines = probe.scan()
        app.running = True
        app._runLines = sys.maxsize
        app._gcount = 0
        n = 1
        for line in CNC.compile(lines):
            if line is not None:
                app.queue.put(line + "\n" if isinstance(line, str) else line)
                n += 1
        app._runLines = n
        app.queue.put((WAIT,))
        t0 = time.time()
        until("the scan to end", 120, lambda: app._gcount >= app._runLines, app)
        app.runEnded()
        settled(app, "the scan at rest")
        wco = (CNC.vars["wcox"], CNC.vars["wcoy"], CNC.vars["wcoz"])
        z0, sx, sy = PLANE
        worst = 0.0
        for j in range(probe.yn):
            for i in range(probe.xn):
                mx = probe.xmin + i * probe._xstep + wco[0]
                my = probe.ymin + j * probe._ystep + wco[1]
                want = z0 + sx * mx + sy * my - wco[2]
                got = probe.matrix[j][i]
                worst = max(worst, abs(got - want))
                if abs(got - want) > STEP + 1e-9:
                    raise RuntimeError(f"height ({i},{j}): {got}, the stock is at {want:.4f}")
        log(f"{probe.xn} x {probe.yn} heights in {time.time() - t0:.1f} s, "
            f"each within {worst:.4f} mm of the stock; matrix {probe.matrix}")

    for f in steps:
        t0 = time.time()
        log(f"-- {f.__name__}")
        f()
        drain(app)
        if ERRORS:
            raise RuntimeError(f"{f.__name__}: bCNC logged {ERRORS}")
        log(f"ok: {f.__name__} ({time.time() - t0:.1f} s)")

    app.thread = None
    app.serial.close()
    log("PASS")


if __name__ == "__main__":
    try:
        main()
    except Exception as e:  # noqa: BLE001
        print(f"[bcnc] FAIL: {e}", flush=True)
        os._exit(1)
    os._exit(0)
