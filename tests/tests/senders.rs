//! Real Grbl senders against `fuzzy-send serve --sim`: cncjs (its server
//! headless, through the pty) and bCNC (its sender classes, over TCP); and
//! cncjs again through `fuzzy-send serve` against the firmware in QEMU.
//! Run by `tests/senders/run.sh`; what each checks is listed in
//! `sender/README.md`.
//!
//! They are installed from npm and PyPI into `target/senders/`, so these
//! tests run only with `FUZZY_REQUIRE_SENDERS=1` (set by `scripts/test.sh`,
//! whose set-up installs node, npm, python3-venv and python3-tk).

use std::path::PathBuf;
use std::process::{Command, Output};
use std::sync::OnceLock;

use system_tests::firmware::{firmware_elf, qemu_available, repo_root};

fn enabled() -> bool {
    let on = std::env::var("FUZZY_REQUIRE_SENDERS").as_deref() == Ok("1");
    if !on {
        eprintln!("skipped: FUZZY_REQUIRE_SENDERS=1 runs the real senders");
    }
    on
}

/// `run.sh ARGS` within 15 minutes (installing included).
fn run_sh(args: &[&str], bin: Option<&PathBuf>) -> Output {
    let mut c = Command::new("timeout");
    c.arg("900")
        .arg(repo_root().join("tests/senders/run.sh"))
        .args(args);
    if let Some(b) = bin {
        c.env("FUZZY_SEND", b);
    }
    if args.contains(&"cncjs-qemu") {
        c.env("FUZZY_FIRMWARE", firmware_elf());
    }
    c.output().expect("run tests/senders/run.sh")
}

/// Installed once, and the binary built once, for both tests.
fn ready() -> &'static PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let out = run_sh(&["--install"], None);
        assert!(
            out.status.success(),
            "installing the senders failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        system_tests::binaries::fuzzy_send()
    })
}

/// `run.sh WHICH`, whose script ends with `[sender] PASS`.
fn check(which: &str, sender: &str) {
    if !enabled() {
        return;
    }
    let out = run_sh(&[which], Some(ready()));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{text}");
    assert!(
        out.status.success(),
        "{which} against fuzzy-send serve:\n{text}"
    );
    assert!(text.contains(&format!("[{sender}] PASS")), "{text}");
}

#[test]
fn cncjs_drives_the_grbl_front_through_the_pty() {
    check("cncjs", "cncjs");
}

#[test]
fn bcnc_drives_the_grbl_front_over_tcp() {
    check("bcnc", "bcnc");
}

#[test]
fn cncjs_drives_the_qemu_firmware_through_the_front() {
    if !qemu_available() {
        return;
    }
    check("cncjs-qemu", "cncjs");
}
