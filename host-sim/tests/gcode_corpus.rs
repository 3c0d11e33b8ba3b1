//! Reads every G-code program under the directories named by
//! `HOST_SIM_GCODE_CORPUS` (separated by `:`) with `host-sim toolpath`, one
//! process per program with a time bound, and reports each one as read,
//! read without motion, refused (the error's file:line and feature), crashed
//! (a panic, an abort, a signal) or hung (past the bound); then the counts
//! per directory. Programs of public projects are not committed here: point
//! the variable at a checkout (e.g. LinuxCNC's `nc_files/`). Skipped with a
//! note when the variable is unset.
//!
//! ```text
//! HOST_SIM_GCODE_CORPUS=/tmp/corpus/linuxcnc:/tmp/corpus/cam \
//!   cargo test --release -p host-sim --test gcode_corpus -- --nocapture
//! ```
//!
//! `HOST_SIM_GCODE_CONFIG=FILE` passes a TOML configuration (e.g. the tool
//! table and subroutine directories of the machine the programs were
//! written for) to every run.
//!
//! Refusals whose message says `needs live machine state` (probing, inputs
//! read while running, user M-codes and remaps) are counted apart: they are
//! outside what a reader without a machine can do. The test fails only on a
//! crash or a hang.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const TIME_BOUND: Duration = Duration::from_secs(60);
const EXTENSIONS: [&str; 6] = ["nc", "ngc", "gcode", "tap", "cnc", "g"];

#[derive(Debug, Clone, PartialEq)]
enum Outcome {
    Read,
    NoMotion,
    NeedsMachine(String),
    Refused(String),
    Crashed(String),
    Hung,
}

fn programs(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = rd.flatten().map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            programs(&p, out);
        } else if p
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .is_some_and(|e| EXTENSIONS.contains(&e.as_str()))
        {
            out.push(p);
        }
    }
}

fn run(program: &Path) -> Outcome {
    let err_path = std::env::temp_dir().join(format!(
        "host-sim-corpus-{}-{}.err",
        std::process::id(),
        program
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().replace(' ', "_"))
    ));
    let Ok(err_file) = std::fs::File::create(&err_path) else {
        return Outcome::Crashed("cannot create a temporary file".into());
    };
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_host-sim"));
    cmd.arg("toolpath").arg(program);
    if let Ok(c) = std::env::var("HOST_SIM_GCODE_CONFIG") {
        cmd.arg("--config").arg(c);
    }
    let child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(err_file)
        .spawn();
    let Ok(mut child) = child else {
        return Outcome::Crashed("cannot start host-sim".into());
    };
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break Some(s),
            Ok(None) if start.elapsed() > TIME_BOUND => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(5)),
            Err(_) => break None,
        }
    };
    let stderr = std::fs::read_to_string(&err_path).unwrap_or_default();
    let _ = std::fs::remove_file(&err_path);
    let Some(status) = status else {
        return Outcome::Hung;
    };
    let msg = stderr.lines().next().unwrap_or("").to_string();
    if status.success() {
        Outcome::Read
    } else if status.code() == Some(1) && msg.starts_with("error:") {
        if msg.contains("fewer than two distinct points") {
            Outcome::NoMotion
        } else if msg.contains("needs live machine state") {
            Outcome::NeedsMachine(msg)
        } else {
            Outcome::Refused(msg)
        }
    } else {
        Outcome::Crashed(format!("{status}: {}", stderr.trim()))
    }
}

#[test]
fn public_programs_are_read_or_refused_clearly() {
    let Ok(dirs) = std::env::var("HOST_SIM_GCODE_CORPUS") else {
        eprintln!("SKIPPED: set HOST_SIM_GCODE_CORPUS=DIR[:DIR…] to read a corpus");
        return;
    };
    let mut bad = Vec::new();
    for dir in dirs.split(':').filter(|d| !d.is_empty()) {
        let mut files = Vec::new();
        programs(Path::new(dir), &mut files);
        let mut counts = [0usize; 6];
        for f in &files {
            let o = run(f);
            let shown = f.strip_prefix(dir).unwrap_or(f).display().to_string();
            let (k, note) = match &o {
                Outcome::Read => (0, "read".to_string()),
                Outcome::NoMotion => (1, "read, no motion".to_string()),
                Outcome::NeedsMachine(m) => (2, format!("needs machine: {m}")),
                Outcome::Refused(m) => (3, format!("refused: {m}")),
                Outcome::Crashed(m) => (4, format!("CRASHED: {m}")),
                Outcome::Hung => (5, format!("HUNG past {} s", TIME_BOUND.as_secs())),
            };
            counts[k] += 1;
            println!("{shown}\t{note}");
            if k >= 4 {
                bad.push(format!("{}: {note}", f.display()));
            }
        }
        let n = files.len();
        let pct = |k: usize| 100.0 * k as f64 / n.max(1) as f64;
        let machine_free = n - counts[2];
        println!(
            "== {dir}: {n} programs: {} read ({:.1} %), {} read without motion, {} need live machine state, {} refused, {} crashed, {} hung; read (with or without motion) of the {machine_free} that need no live machine state: {:.1} %",
            counts[0],
            pct(counts[0]),
            counts[1],
            counts[2],
            counts[3],
            counts[4],
            counts[5],
            100.0 * (counts[0] + counts[1]) as f64 / machine_free.max(1) as f64,
        );
    }
    assert!(bad.is_empty(), "crashes or hangs:\n{}", bad.join("\n"));
}
