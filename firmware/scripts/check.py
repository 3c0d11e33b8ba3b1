#!/usr/bin/env python3
"""Firmware checks for CI, against committed baselines in firmware/baseline/.

    check.py size   [--bless]  flash/RAM of the release image: budgets and +10 %;
                               the board image (--features board): budgets
    check.py cost   [--bless]  instructions per point / tick in QEMU -icount: +10 %
    check.py panic  [--bless]  no reachable panic in the release image

`--bless` rewrites the baseline with the figures just measured (review the
diff like any golden file). Budgets: flash <= 128 KiB, static RAM <= 32 KiB
(checked, fail: the image must fit a 256 KiB STM32F401 with room for
settings), <= 2000 instructions per scheduled
point and <= 8400 per tick interrupt (reported; a figure over its budget
is printed as OVER BUDGET but only growth fails, so that the known excess
of the scheduler, tracked in fuzzy-core, does not block every change).
Run from anywhere; builds must exist (scripts/test.sh builds them).
"""
import os
import re
import subprocess
import sys

FW = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROOT = os.path.dirname(FW)
REL = os.path.join(FW, "target", "thumbv7em-none-eabihf", "release")
BASE = os.path.join(FW, "baseline")
GROWTH = 1.10
FLASH_BUDGET = 128 * 1024
RAM_BUDGET = 32 * 1024
# Budgets per scheduled point (the scheduler alone) and per tick
# interrupt (which only takes a setpoint from the ring); the planner's
# per-tick generation runs in the background and has no per-call budget.
COST_BUDGET = {"sched_mean": 2000, "isr_worst": 8400}
COST_KEYS = ["sched_mean", "sched_worst", "push_mean", "push_worst", "gen_mean", "gen_worst",
             "isr_mean", "isr_worst", "override_worst",
             "plan_mean", "plan_worst", "step_batch_mean", "step_batch_worst", "step_per_step"]
# From the `cost steps3x` line (three axes at 150/120/105 kHz), prefixed.
STEPS3X_KEYS = ["batch_mean", "batch_worst", "per_step", "engine_permille"]
QEMU_TIMEOUT_S = 300


def out_dir(profile):
    """Where cargo puts the images of a profile."""
    return os.path.join(FW, "target", "thumbv7em-none-eabihf", profile)


def llvm_tool(name):
    sysroot = subprocess.check_output(["rustc", "--print", "sysroot"], text=True).strip()
    host = re.search(r"host: (\S+)", subprocess.check_output(["rustc", "-vV"], text=True)).group(1)
    path = os.path.join(sysroot, "lib", "rustlib", host, "bin", name)
    if not os.path.exists(path):
        sys.exit(f"{name} not found: rustup component add llvm-tools")
    return path


def read_kv(path):
    out = {}
    if os.path.exists(path):
        for line in open(path):
            line = line.split("#", 1)[0].strip()
            if "=" in line:
                k, v = line.split("=", 1)
                out[k.strip()] = int(v.strip())
    return out


def write_kv(path, kv, header):
    with open(path, "w") as f:
        f.write(header)
        for k, v in kv.items():
            f.write(f"{k} = {v}\n")


def compare(name, now, base, budgets):
    failed = False
    for k, v in now.items():
        b = base.get(k)
        note = ""
        if k in budgets and v > budgets[k]:
            note = f"  OVER BUDGET ({budgets[k]})"
        if b is None:
            print(f"  {k:<24} {v:>8}   (no baseline){note}")
            continue
        grow = v > b * GROWTH
        failed |= grow
        pct = (v - b) * 100.0 / b if b else 0.0
        print(f"  {k:<24} {v:>8}   baseline {b:>8} ({pct:+.1f} %){'  GREW > 10 %' if grow else ''}{note}")
    if failed:
        print(f"{name}: a figure grew by more than 10 % over firmware/baseline/ (re-bless only if intended)")
    return failed


def size(bless):
    elf = os.path.join(REL, "fuzzy-firmware")
    out = subprocess.check_output([llvm_tool("llvm-size"), elf], text=True).split("\n")[1].split()
    text, data, bss = int(out[0]), int(out[1]), int(out[2])
    now = {"text": text, "data": data, "bss": bss, "flash": text + data, "ram": data + bss}
    path = os.path.join(BASE, "size.txt")
    print(f"firmware size: text {text}, data {data}, bss {bss} bytes: flash {text + data} (budget {FLASH_BUDGET}), static RAM {data + bss} (budget {RAM_BUDGET})")
    if bless:
        write_kv(path, now, "# llvm-size of the release image (bytes); scripts/check.py size --bless\n")
        return 0
    failed = compare("size", now, read_kv(path), {})
    if text + data > FLASH_BUDGET or data + bss > RAM_BUDGET:
        print("size: OVER BUDGET")
        failed = True
    failed |= board_size()
    return 1 if failed else 0


def board_size():
    """The images users flash (feature `board`: defmt over RTT, clock
    set-up; feature `usb`: the link over USB CDC-ACM) against the budgets
    too; then the default image is rebuilt."""
    env = dict(os.environ)
    env.pop("CARGO_TARGET_DIR", None)
    over = False
    try:
        for feat, profile in [("board", "release"), ("usb", "small")]:
            subprocess.run(["cargo", "build", "--profile", profile, "-q", "--no-default-features", "--features", feat],
                           cwd=FW, env=env, check=True)
            out = subprocess.check_output([llvm_tool("llvm-size"), os.path.join(out_dir(profile), "fuzzy-firmware")],
                                          text=True).split("\n")[1].split()
            text, data, bss = int(out[0]), int(out[1]), int(out[2])
            o = text + data > FLASH_BUDGET or data + bss > RAM_BUDGET
            over |= o
            print(f"{feat} image (--profile {profile} --features {feat}): flash {text + data}, static RAM {data + bss}{'  OVER BUDGET' if o else ''}")
    finally:
        subprocess.run(["cargo", "build", "--release", "-q"], cwd=FW, env=env, check=True)
    return over


def cost(bless):
    elf = os.path.join(REL, "cost")
    cmd = ["timeout", "-k", "5", str(QEMU_TIMEOUT_S), "qemu-system-arm", "-cpu", "cortex-m4",
           "-machine", "netduinoplus2", "-display", "none", "-monitor", "none",
           "-semihosting-config", "enable=on,target=native", "-serial", "null",
           "-icount", "shift=0", "-kernel", elf]
    res = subprocess.run(cmd, capture_output=True, text=True)
    print(res.stdout, end="")
    if res.returncode != 0:
        print(f"cost: QEMU exited with {res.returncode} (124: timeout)\n{res.stderr}")
        return 1
    m = re.search(r"^cost all (.*)$", res.stdout, re.M)
    if not m:
        print("cost: no summary line")
        return 1
    kv = dict(x.split("=") for x in m.group(1).split())
    now = {k: int(kv[k]) for k in COST_KEYS}
    m3 = re.search(r"^cost steps3x (.*)$", res.stdout, re.M)
    if not m3:
        print("cost: no steps3x line")
        return 1
    kv3 = dict(x.split("=") for x in m3.group(1).split())
    now.update({"steps3x_" + k: int(kv3[k]) for k in STEPS3X_KEYS})
    st = re.search(r"stack_bytes=(\d+)", res.stdout)
    path = os.path.join(BASE, "cost.txt")
    print("cost (instructions, QEMU -icount shift=0):")
    if bless:
        write_kv(path, now, "# instructions (QEMU -icount shift=0) from src/bin/cost.rs; scripts/check.py cost --bless\n")
        return 0
    failed = compare("cost", now, read_kv(path), COST_BUDGET)
    if st:
        print(f"  benchmark stack high-water mark: {st.group(1)} bytes")
    return 1 if failed else 0


def panic(bless):
    """The images users run: the QEMU image, the board image (--features
    board, defmt over RTT) and the USB one (--profile small --features usb), each against
    its own list."""
    failed = panic_image(bless, [], "panic-sites.txt", "release image")
    failed |= panic_image(bless, ["--no-default-features", "--features", "board"],
                          "panic-sites-board.txt", "board image (--features board)")
    failed |= panic_image(bless, ["--no-default-features", "--features", "usb"],
                          "panic-sites-usb.txt", "USB image (--profile small --features usb)", "small")
    return 1 if failed else 0


def panic_image(bless, features, baseline, label, profile="release"):
    """Link the image with a panic handler that cannot link (feature
    panic-never). If that fails, list every call into a core panic function
    in the normal image with its source location, and compare with
    firmware/baseline/<baseline> (file and panic kind): sites in that list
    are known and reported; any other fails."""
    env = dict(os.environ)
    env.pop("CARGO_TARGET_DIR", None)
    flags = list(features)
    if "--features" in flags:
        i = flags.index("--features") + 1
        flags[i] += ",panic-never"
    else:
        flags += ["--features", "panic-never"]
    res = subprocess.run(["cargo", "build", "--profile", profile, "--bin", "fuzzy-firmware"] + flags,
                         cwd=FW, env=env, capture_output=True, text=True)
    if res.returncode != 0:
        # The normal image of the same features, for the site listing.
        subprocess.run(["cargo", "build", "--profile", profile, "-q", "--bin", "fuzzy-firmware"] + list(features),
                       cwd=FW, env=env, check=True)
    path = os.path.join(BASE, baseline)
    known = [l.strip() for l in open(path) if l.strip() and not l.startswith("#")] if os.path.exists(path) else []
    try:
        return panic_sites(bless, res, path, known, label, out_dir(profile))
    finally:
        # Back to the default image (only the firmware crate itself rebuilds).
        subprocess.run(["cargo", "build", "--release", "-q"], cwd=FW, env=env, check=True)


def panic_sites(bless, res, path, known, label, out):
    if res.returncode == 0:
        print(f"panic-never: the {label} links without a panic handler: no reachable panic")
        if known:
            print(f"  {len(known)} entries in firmware/baseline/{os.path.basename(path)} are no longer needed: remove them")
        return 0
    if "panic path survived" not in res.stderr:
        print(res.stderr)
        return 1
    elf = os.path.join(out, "fuzzy-firmware")
    dis = subprocess.check_output([llvm_tool("llvm-objdump"), "-d", "-l", "--no-show-raw-insn", "-C", elf], text=True)
    call = re.compile(r"^\s*[0-9a-f]+:\s+bl?(?:\.w)?\s+0x[0-9a-f]+ <(core::panicking::[^>]*|core::result::unwrap_failed|core::option::expect_failed|core::slice::index::[^>]*fail[^>]*)>")
    sites = set()
    func, src = "", None
    for line in dis.split("\n"):
        m = re.match(r"^[0-9a-f]+ <(.*)>:$", line)
        if m:
            func, src = m.group(1), None
            continue
        if line.startswith("; /"):
            loc = line[2:].strip()
            # The last source line outside the standard library (and not
            # compiler-generated) before the call names the site.
            if "/rustc/" not in loc and not loc.endswith(":0"):
                src = loc
            continue
        m = call.match(line)
        if not m or func.startswith("core::"):
            continue
        # Prefer the inline chain at the call (addr2line); fall back on the
        # last source line before it.
        addr = line.split(":")[0].strip()
        frames = subprocess.check_output(["addr2line", "-i", "-e", elf, "0x" + addr], text=True).split()
        site = next((f for f in frames if "/rustc/" not in f and not f.endswith((":?", ":0"))), src)
        if site is None:
            # No source line of ours (an outlined standard-library function):
            # name the function instead of dropping the site.
            # (The linker's outlined pieces are numbered per link: the
            # number is dropped.)
            name = re.sub(r"^OUTLINED_FUNCTION_\d+$", "OUTLINED_FUNCTION", re.sub(r"::h[0-9a-f]{16}$", "", func))
            site = "fn " + name + ":0"
        site = site.split(" :")[0].replace(ROOT + "/", "") if site.startswith("fn ") else site.split(" ")[0].replace(ROOT + "/", "")
        site = re.sub(r"^.*/registry/src/[^/]+/", "", site)
        # Keyed by file and panic kind, not line, so that edits elsewhere
        # in the file do not move a known site into "new".
        sites.add(f"{site.rsplit(':', 1)[0]}  {m.group(1).split('::')[-1]}")
    new = sorted(s for s in sites if s not in known)
    print(f"panic-never: the {label} still has reachable panic paths:")
    for s in sorted(sites):
        print(f"  {'NEW ' if s in new else 'known'} {s}")
    if bless:
        with open(path, "w") as f:
            f.write("# Known panic sites in the release image (file:line  panic fn), see firmware/README.md.\n")
            f.write("# scripts/check.py panic fails on any site not listed here.\n")
            for s in sorted(sites):
                f.write(s + "\n")
        return 0
    if new:
        print(f"panic-never: NEW panic paths in the {label} (not in firmware/baseline/{os.path.basename(path)}): fix them")
        return 1
    print(f"panic-never: {label} NOT PROVEN: {len(sites)} known sites, all in firmware/baseline/{os.path.basename(path)}")
    return 0


if __name__ == "__main__":
    if len(sys.argv) < 2 or sys.argv[1] not in ("size", "cost", "panic"):
        sys.exit(__doc__)
    sys.exit({"size": size, "cost": cost, "panic": panic}[sys.argv[1]]("--bless" in sys.argv[2:]))
