//! Programs of hours under a memory cap: `host-sim plan` and
//! `fuzzy-send send --sim` keep no record that grows with the motion's
//! duration.
//!
//! The program is a 10 × 10 mm square at F100 repeated by an O-word loop
//! (24 s a lap): 100 hours of motion in a few lines. Each binary runs
//! under `ulimit -v` of 1 GiB (address space, so a growing record fails
//! where its allocation would) in the release build, built once:
//!
//! - `plan` refuses the 100-hour program up front (more ticks than
//!   `max_plan_ticks`, a bound on its running time), runs a 3-hour one to
//!   the end, and with the bound raised runs the 100-hour one with a
//!   resident size that stays flat (sampled, then stopped: the whole run
//!   takes minutes);
//! - the sender's `--sim` (at most 1000 × real time) runs a 1-hour program
//!   to the end, and the 100-hour one with a flat resident size (sampled,
//!   then stopped).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

use system_tests::firmware::repo_root;

/// One run at a time: the flat-memory checks sample a running process.
static SLOT: Mutex<()> = Mutex::new(());

/// Address space each run may use, KiB.
const CAP_KIB: u64 = 1 << 20;

/// Growth of the resident size allowed between the samples, KiB (a record
/// of positions or ticks grows by more than that each second).
const FLAT_KIB: u64 = 8 << 10;

/// The release binaries `host-sim` and `fuzzy-send`, built once.
fn release_bins() -> &'static (PathBuf, PathBuf) {
    static BINS: OnceLock<(PathBuf, PathBuf)> = OnceLock::new();
    BINS.get_or_init(|| {
        let out = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
            .args([
                "build",
                "--release",
                "-p",
                "host-sim",
                "-p",
                "sender",
                "--bins",
            ])
            .arg("--message-format=json-render-diagnostics")
            .current_dir(repo_root())
            .stderr(Stdio::inherit())
            .output()
            .expect("run cargo to build host-sim and fuzzy-send");
        assert!(out.status.success(), "release build failed");
        let text = String::from_utf8_lossy(&out.stdout);
        let exe = |name: &str| {
            text.lines()
                .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
                .filter(|v| v["reason"] == "compiler-artifact" && v["target"]["name"] == name)
                .find_map(|v| v["executable"].as_str().map(PathBuf::from))
                .unwrap_or_else(|| panic!("cargo reported no {name} executable"))
        };
        (exe("host-sim"), exe("fuzzy-send"))
    })
}

/// A folder for this test's files.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("long-runs-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The square repeated for `laps` laps (24 s each at F100), written to
/// `dir/name.ngc`.
fn square_loop(dir: &Path, name: &str, laps: u32) -> PathBuf {
    let p = dir.join(format!("{name}.ngc"));
    let text = format!(
        "G21 G90 G17\nG0 X0 Y0 Z0\nG1 F100\no100 repeat [{laps}]\nG1 X10 Y0\nG1 X10 Y10\nG1 X0 Y10\nG1 X0 Y0\no100 endrepeat\nM2\n"
    );
    std::fs::write(&p, text).unwrap();
    p
}

/// Laps of 24 s in `hours`.
fn laps(hours: u32) -> u32 {
    hours * 150
}

/// `exe args…` under the address-space cap (bash's `ulimit -v`, then
/// `exec`: the child's pid is the program's).
fn capped(exe: &Path, args: &[&str]) -> Child {
    let mut script = format!("ulimit -v {CAP_KIB} && exec '{}'", exe.display());
    for a in args {
        script.push_str(&format!(" '{a}'"));
    }
    Command::new("bash")
        .args(["-c", &script])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start bash")
}

/// Wait for `child` at most `limit`; its exit status (`None`: killed by a
/// signal), stdout and stderr. A run past the limit is killed and fails.
fn finish(mut child: Child, limit: Duration) -> (Option<i32>, String, String) {
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > limit {
            let _ = child.kill();
            panic!("still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The resident size of process `pid`, KiB.
fn rss_kib(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or_else(|| panic!("no VmRSS for {pid} (exited?)"))
}

/// Run `child` for a while, sampling its resident size after `settle`
/// and again `span` later; then stop it. It must still be running, and
/// have grown by at most [`FLAT_KIB`].
fn stays_flat(mut child: Child, what: &str, settle: Duration, span: Duration) {
    std::thread::sleep(settle);
    let running = |c: &mut Child| c.try_wait().unwrap().is_none();
    assert!(running(&mut child), "{what}: ended early");
    let a = rss_kib(child.id());
    std::thread::sleep(span);
    assert!(running(&mut child), "{what}: ended early");
    let b = rss_kib(child.id());
    let _ = child.kill();
    let _ = child.wait();
    eprintln!("{what}: resident {a} KiB, {span:?} later {b} KiB");
    assert!(
        b <= a + FLAT_KIB,
        "{what}: resident size grew from {a} to {b} KiB in {span:?}"
    );
}

#[test]
fn plan_refuses_a_100_hour_program_up_front() {
    let _slot = SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let (host_sim, _) = release_bins();
    let d = dir("plan-100h");
    let prog = square_loop(&d, "square_100h", laps(100));
    let out = d.join("out");
    let t0 = Instant::now();
    let child = capped(
        host_sim,
        &[
            "plan",
            prog.to_str().unwrap(),
            "--feeds",
            "programmed",
            "--no-plots",
            "--out-dir",
            out.to_str().unwrap(),
        ],
    );
    let (code, _, err) = finish(child, Duration::from_secs(60));
    eprintln!("{err}");
    assert_eq!(code, Some(1), "an error exit, not a signal: {err}");
    assert!(
        err.contains("max_plan_ticks") && err.contains("100.0 h") && err.contains("--config"),
        "{err}"
    );
    assert!(t0.elapsed() < Duration::from_secs(30), "{:?}", t0.elapsed());
}

#[test]
fn plan_runs_a_3_hour_program_to_the_end_under_the_cap() {
    let _slot = SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let (host_sim, _) = release_bins();
    let d = dir("plan-3h");
    let prog = square_loop(&d, "square_3h", laps(3));
    let out = d.join("out");
    let child = capped(
        host_sim,
        &[
            "plan",
            prog.to_str().unwrap(),
            "--feeds",
            "programmed",
            "--no-plots",
            "--out-dir",
            out.to_str().unwrap(),
        ],
    );
    let (code, text, err) = finish(child, Duration::from_secs(300));
    assert_eq!(code, Some(0), "{err}");
    // 450 laps of 24 s, and a stop at each corner.
    let t: f64 = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("cycle time"))
        .and_then(|v| v.trim().trim_end_matches('s').trim().parse().ok())
        .unwrap_or_else(|| panic!("no cycle time in {text}"));
    assert!((10_800.0..11_000.0).contains(&t), "{t}");
    assert!(text.contains("within limits: yes"), "{text}");
    // The ticks CSV is the bounded record's: every 128th tick and the last.
    assert!(text.contains("holds every 128th and the last"), "{text}");
    let rows = std::fs::read_to_string(out.join("square_3h_plan_ticks.csv"))
        .unwrap()
        .lines()
        .count();
    assert!(rows < host_sim::planner::trace::TRACE_BUCKETS + 3, "{rows}");
}

#[test]
fn plan_of_100_hours_with_the_bound_raised_keeps_its_memory_flat() {
    let _slot = SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let (host_sim, _) = release_bins();
    let d = dir("plan-100h-raised");
    let prog = square_loop(&d, "square_100h", laps(100));
    let config = d.join("long.toml");
    std::fs::write(&config, "max_plan_ticks = 400000000\n").unwrap();
    let out = d.join("out");
    let child = capped(
        host_sim,
        &[
            "plan",
            prog.to_str().unwrap(),
            "--config",
            config.to_str().unwrap(),
            "--feeds",
            "programmed",
            "--no-plots",
            "--out-dir",
            out.to_str().unwrap(),
        ],
    );
    stays_flat(
        child,
        "host-sim plan, 100 h",
        Duration::from_secs(3),
        Duration::from_secs(12),
    );
}

#[test]
fn sender_sim_runs_a_1_hour_program_to_the_end_under_the_cap() {
    let _slot = SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let (_, send) = release_bins();
    let d = dir("sim-1h");
    let prog = square_loop(&d, "square_1h", laps(1));
    let child = capped(send, &["--sim=1000", "send", prog.to_str().unwrap()]);
    let (code, _, err) = finish(child, Duration::from_secs(300));
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("done: 601 points"), "{err}");
    assert!(err.contains("ended at X0.000 Y0.000 Z0.000"), "{err}");
}

#[test]
fn sender_sim_of_100_hours_keeps_its_memory_flat() {
    let _slot = SLOT.lock().unwrap_or_else(|e| e.into_inner());
    let (_, send) = release_bins();
    let d = dir("sim-100h");
    let prog = square_loop(&d, "square_100h", laps(100));
    let child = capped(send, &["--sim=1000", "send", prog.to_str().unwrap()]);
    stays_flat(
        child,
        "fuzzy-send --sim=1000, 100 h",
        Duration::from_secs(3),
        Duration::from_secs(12),
    );
}
