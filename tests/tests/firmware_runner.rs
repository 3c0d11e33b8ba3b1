//! The firmware's cargo runner (`firmware/scripts/qemu-run.sh`) as
//! `cargo run` calls it, with a stand-in `qemu-system-arm` first on the
//! `PATH` that records its arguments and whether it runs under `timeout`:
//! no QEMU runs. USART1 goes to the loopback address by default, so that
//! no other machine reaches the simulated motion; the firmware runs until
//! stopped, the images that end by themselves within a limit.

use std::path::{Path, PathBuf};
use std::process::Command;

use system_tests::firmware::repo_root;

/// A folder of its own for one test.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fuzzy-runner-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch folder");
    d
}

/// The arguments QEMU got when the runner ran an image named `image`,
/// with `env` set (and the runner's own variables unset otherwise).
fn qemu_args(dir: &Path, image: &str, env: &[(&str, &str)]) -> Vec<String> {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).expect("stub folder");
    let out = dir.join("args");
    let _ = std::fs::remove_file(&out);
    let _ = std::fs::remove_file(dir.join("args.parent"));
    let stub = bin.join("qemu-system-arm");
    std::fs::write(
        &stub,
        "#!/bin/sh\nfor a in \"$@\"; do printf '%s\\n' \"$a\"; done > \"$STUB_OUT\"\ncat /proc/$PPID/comm > \"$STUB_OUT.parent\"\n",
    )
    .expect("stub");
    let mut perm = std::fs::metadata(&stub).expect("stub").permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut perm, 0o755);
    std::fs::set_permissions(&stub, perm).expect("stub mode");
    let elf = dir.join(image);
    std::fs::write(&elf, b"").expect("image");
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut c = Command::new("bash");
    c.arg(repo_root().join("firmware/scripts/qemu-run.sh"))
        .arg(&elf)
        .env("PATH", path)
        .env("STUB_OUT", &out)
        .env_remove("FW_SERIAL")
        .env_remove("FW_TIMEOUT")
        .env_remove("FW_ICOUNT");
    for (k, v) in env {
        c.env(k, v);
    }
    // The exit status is the stand-in's (or defmt-print's): not the point.
    let _ = c.output().expect("run qemu-run.sh");
    std::fs::read_to_string(&out)
        .expect("the stand-in QEMU ran")
        .lines()
        .map(String::from)
        .collect()
}

/// Whether QEMU ran under `timeout` in the last [`qemu_args`] in `dir`.
fn under_timeout(dir: &Path) -> bool {
    let parent = std::fs::read_to_string(dir.join("args.parent")).expect("the stand-in's parent");
    parent.trim() == "timeout"
}

/// The value after `flag`.
fn after<'a>(args: &'a [String], flag: &str) -> Option<&'a str> {
    let k = args.iter().position(|a| a == flag)?;
    args.get(k + 1).map(String::as_str)
}

#[test]
fn usart1_listens_on_loopback_unless_told_otherwise() {
    let dir = scratch("serial");
    let args = qemu_args(&dir, "fuzzy-firmware", &[]);
    assert_eq!(
        after(&args, "-serial"),
        Some("tcp:127.0.0.1:7878,server=on,wait=off"),
        "{args:?}"
    );
    let args = qemu_args(
        &dir,
        "fuzzy-firmware",
        &[("FW_SERIAL", "unix:/tmp/x.sock,server=on")],
    );
    assert_eq!(after(&args, "-serial"), Some("unix:/tmp/x.sock,server=on"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_firmware_runs_until_stopped_and_benchmarks_within_a_limit() {
    let dir = scratch("timeout");
    qemu_args(&dir, "fuzzy-firmware", &[]);
    assert!(!under_timeout(&dir), "a user's `cargo run` has no limit");
    qemu_args(&dir, "fuzzy-firmware", &[("FW_TIMEOUT", "30")]);
    assert!(under_timeout(&dir), "FW_TIMEOUT sets one");
    for image in ["cost", "numerics_cost"] {
        qemu_args(&dir, image, &[]);
        assert!(under_timeout(&dir), "{image}: ends by itself, else fails");
        qemu_args(&dir, image, &[("FW_TIMEOUT", "0")]);
        assert!(!under_timeout(&dir), "{image}: FW_TIMEOUT=0 is none");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
