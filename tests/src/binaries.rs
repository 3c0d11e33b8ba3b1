//! Binaries of the workspace that system tests run as a user would.

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::OnceLock;

use crate::firmware::repo_root;

/// The `fuzzy-send` binary, built once (the test profile: the libraries
/// it links are already built for the tests).
pub fn fuzzy_send() -> PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let out = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
            .args([
                "build",
                "--profile",
                "test",
                "-p",
                "sender",
                "--bin",
                "fuzzy-send",
            ])
            .arg("--message-format=json-render-diagnostics")
            .current_dir(repo_root())
            .stderr(Stdio::inherit())
            .output()
            .expect("run cargo to build fuzzy-send");
        assert!(out.status.success(), "building fuzzy-send failed");
        let text = String::from_utf8_lossy(&out.stdout);
        text.lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|v| v["reason"] == "compiler-artifact" && v["target"]["name"] == "fuzzy-send")
            .find_map(|v| v["executable"].as_str().map(PathBuf::from))
            .expect("cargo reported the fuzzy-send executable")
    })
    .clone()
}
