//! The machine commands against the whole controller on the host
//! (`controller::sim::VirtualDevice` behind `sender::sim`): the `$`
//! settings read, written (checked by the controller, stored) and listed
//! with the controller's own table; homing against simulated limit
//! switches, its failure alarm and its refusal while disabled; and the
//! `fuzzy-send` binary's `settings`, `home`, `estop`, `unlock`, `status`
//! and `jog` on `--sim`, with their exit codes.

use std::process::Command;
use std::time::Duration;

use controller::config::{Config, SETTINGS};
use controller::sim::SimSwitch;
use link::{AlarmCode, StoreResult};
use sender::exit::Exit;
use sender::machine::HomeResult;
use sender::record::Recorder;
use sender::sim::{self, SimHandle};
use sender::stream::Session;

const T: Duration = Duration::from_secs(3);

fn session(h: &SimHandle) -> Session {
    let s = h.connect().unwrap();
    Session::new(
        Box::new(s.try_clone().unwrap()),
        Box::new(s),
        Recorder::none(),
    )
}

fn mm(x: f64) -> i64 {
    (x * 4294967296.0).round() as i64
}

#[test]
fn settings_are_listed_read_written_and_checked_by_the_controller() {
    let h = sim::start(4.0).unwrap();
    let mut s = session(&h);
    let all = s.settings(T).unwrap();
    assert_eq!(all.len(), SETTINGS.len());
    for (info, v) in &all {
        assert_eq!(Config::DEFAULT.by_id(info.id), Ok(*v), "${}", info.id);
    }
    // Written, stored, read back.
    assert_eq!(
        s.get_setting(120, T).unwrap(),
        Config::DEFAULT.by_id(120).unwrap()
    );
    assert_eq!(
        s.set_setting(120, 750, T).unwrap(),
        Some(StoreResult::Saved)
    );
    assert_eq!(s.get_setting(120, T).unwrap(), 750);
    // In range alone, refused with the others ($31 ≥ $30): nothing changed.
    let e = s.set_setting(31, 1000, T).unwrap_err();
    assert_eq!(e.exit, Exit::Controller);
    assert!(e.message.contains("OutOfRange"), "{e}");
    assert_eq!(s.get_setting(31, T).unwrap(), 0);
    let e = s.get_setting(1, T).unwrap_err();
    assert!(e.message.contains("UnknownSetting"), "{e}");
    // A new connection (the sender run again) reads what was written.
    let mut s2 = session(&h);
    assert_eq!(s2.get_setting(120, T).unwrap(), 750);
}

/// Limit switches at X 3 mm, Y 5 mm, Z 2 mm (max ends, 100 steps/mm), as
/// the controller's own homing test: `home` waits for `Homed`, the tool
/// at −pull-off on every axis.
#[test]
fn homing_finds_the_simulated_switches() {
    let h = sim::start_with(20.0, |d| {
        for (axis, at_mm) in [(0, 3.0), (1, 5.0), (2, 2.0)] {
            d.switches.push(SimSwitch {
                axis,
                max: true,
                at_steps: (at_mm * 100.0) as i64,
            });
        }
    })
    .unwrap();
    let mut s = session(&h);
    // Disabled ($22 = 0): refused, and the message says how to enable it.
    let e = s.home(0, T, Duration::from_secs(10)).unwrap_err();
    assert_eq!(e.exit, Exit::Controller);
    assert!(e.message.contains("$22"), "{e}");
    s.set_setting(22, 1, T).unwrap();
    s.set_setting(26, 2, T).unwrap();
    let r = s.home(0, T, Duration::from_secs(60)).unwrap();
    assert_eq!(
        r,
        HomeResult::Homed {
            axes: 7,
            pos_mm: [mm(-1.0); 3]
        }
    );
    assert_eq!(s.machine_within(T).unwrap().homed, 7);
}

#[test]
fn a_failed_homing_cycle_is_its_alarm() {
    let h = sim::start(20.0).unwrap();
    let mut s = session(&h);
    for (id, v) in [(22, 1), (44, 1), (45, 0), (130, 5_000), (25, 3000)] {
        s.set_setting(id, v, T).unwrap();
    }
    let r = s.home(0, T, Duration::from_secs(60)).unwrap();
    let HomeResult::Alarm { code, pos_mm } = r else {
        panic!("{r:?}")
    };
    assert_eq!(code, AlarmCode::HomingNoSwitch { axis: 0 });
    assert_eq!(pos_mm[0], mm(7.5), "searched 1.5 × the travel");
    s.unlock(T).unwrap();
}

/// The binary, as a user runs it.
fn fuzzy_send(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_fuzzy-send"))
        .arg("--sim=10")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_binarys_machine_commands_and_their_exit_codes() {
    // `settings`: every setting as Grbl's `$$`.
    let (code, out, err) = fuzzy_send(&["settings"]);
    assert_eq!(code, Some(0), "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), SETTINGS.len(), "{out}");
    assert!(
        lines.contains(&"$100=100.000 (X steps/mm, steps/mm)"),
        "{out}"
    );
    assert!(lines.iter().all(|l| l.starts_with('$') && l.contains('=')));
    let (code, out, _) = fuzzy_send(&["settings", "get", "$22"]);
    assert_eq!(code, Some(0));
    assert!(out.starts_with("$22=0 (homing"), "{out}");
    let (code, out, err) = fuzzy_send(&["settings", "set", "120", "750"]);
    assert_eq!(code, Some(0), "{err}");
    let was = controller::config::Config::DEFAULT.by_id(120).unwrap();
    assert!(
        out.starts_with(&format!("$120 = 750 mm/s² (was {was}; ")),
        "{out}"
    );
    assert!(err.contains("saved to flash"), "{err}");
    // Checked before connecting: exit 2. An unquoted `$100` arrives as
    // `00`: refused, with the quoting hint, not taken as `$0`.
    let (code, _, err) = fuzzy_send(&["settings", "set", "00", "5"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("'$100'"), "{err}");
    let (code, _, err) = fuzzy_send(&["settings", "set", "110", "0"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("range"), "{err}");
    let (code, _, err) = fuzzy_send(&["settings", "set", "100", "80.0001"]);
    assert_eq!(code, Some(2), "{err}");
    // Refused by the controller: exit 5.
    let (code, _, err) = fuzzy_send(&["settings", "set", "31", "1000"]);
    assert_eq!(code, Some(5), "{err}");
    assert!(err.contains("must stay below $30"), "{err}");
    // The tick rate, written as it runs: in force, no reset pending.
    let (code, _, err) = fuzzy_send(&["settings", "set", "200", "1000"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("in force") && !err.contains("reset"), "{err}");
    let (code, _, err) = fuzzy_send(&["settings", "set", "200", "2000"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("takes effect at the next reset"), "{err}");
    let (code, _, err) = fuzzy_send(&["home"]);
    assert_eq!(code, Some(5), "{err}");
    assert!(err.contains("$22=0"), "{err}");
    // `estop`: the alarm, exit 7.
    let (code, _, err) = fuzzy_send(&["estop"]);
    assert_eq!(code, Some(7), "{err}");
    assert!(err.contains("ALARM: e-stop from the host"), "{err}");
    // Each --sim run is a fresh controller: `unlock` finds no alarm.
    let (code, _, err) = fuzzy_send(&["unlock"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("not in alarm"), "{err}");
    let (code, out, _) = fuzzy_send(&["status"]);
    assert_eq!(code, Some(0));
    assert!(
        out.contains("state: Idle") && out.contains("alarm: none"),
        "{out}"
    );
    // `jog`: words checked before connecting (exit 2), then run (exit 0).
    for bad in [
        &["X5"][..],
        &["F100"],
        &["X5", "F100", "M3"],
        &["X5", "F-1"],
    ] {
        let mut args = vec!["jog"];
        args.extend_from_slice(bad);
        let (code, _, err) = fuzzy_send(&args);
        assert_eq!(code, Some(2), "{bad:?}: {err}");
    }
    let (code, _, err) = fuzzy_send(&["jog", "--log", "X-2", "Y-1", "F1200"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("sending jog: 2 points, 2.2 mm"), "{err}");
}

/// A TCP port that accepts and never answers (as QEMU's port does for a
/// second client while the first holds it): link lost, exit 4, and the
/// message speaks of a busy port, not of power and baud rates.
#[test]
fn a_silent_tcp_port_is_said_to_be_busy() {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap().to_string();
    let held = std::thread::spawn(move || l.accept().map(|c| c.0));
    let out = Command::new(env!("CARGO_BIN_EXE_fuzzy-send"))
        .args(["status", "--tcp", &addr, "--link-timeout", "1"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(4), "{err}");
    assert!(err.contains("busy") && !err.contains("baud"), "{err}");
    drop(held.join());
}
