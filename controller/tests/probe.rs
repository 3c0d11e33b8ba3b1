//! Probing on the host (`controller::sim`, the firmware's own code, driven
//! over its link): G38.2-.5 against a simulated surface, the trip latched
//! within one step (plus a tick's travel) of where the steps crossed it,
//! the move never past its target, Grbl's failures as alarms, and the
//! safety inputs winning over a probe.

use controller::config::Key;
use controller::probe::PROBE;
use controller::settings::TICK_HZ;
use controller::sim::{HeightMap, ProbeSurface, SimSwitch, VirtualDevice};
use link::client::Client;
use link::{AlarmCode, DeviceMsg, FrameReader, HostMsg, Motion, Status, FRAME_MAX};
use proptest::prelude::*;

const MM: f64 = 4294967296.0;
/// The default steps/mm (`controller::settings::STEPS_PER_MM`).
const STEP_MM: f64 = 0.01;

fn mm(x: f64) -> i64 {
    (x * MM).round() as i64
}

fn of(bits: [i64; 3]) -> [f64; 3] {
    bits.map(|b| b as f64 / MM)
}

struct Bench {
    dev: VirtualDevice,
    client: Client,
    reader: FrameReader,
    inbox: Vec<DeviceMsg>,
    ticks: u32,
}

impl Bench {
    fn new(surface: Option<ProbeSurface>) -> Bench {
        let mut dev = VirtualDevice::new().unwrap();
        dev.probe = surface;
        let mut b = Bench {
            dev,
            client: Client::new(),
            reader: FrameReader::new(),
            inbox: Vec::new(),
            ticks: 0,
        };
        b.deliver();
        b
    }

    fn deliver(&mut self) {
        for byte in self.dev.transmit() {
            if let Some(m) = self.reader.push::<DeviceMsg>(byte) {
                let m = m.expect("the device's frames decode");
                self.client.on_message(&m);
                self.inbox.push(m);
            }
        }
    }

    fn send(&mut self, m: &HostMsg) {
        let mut out = [0u8; FRAME_MAX];
        let n = link::encode(m, &mut out).unwrap();
        self.dev.receive(&out[..n]);
        self.deliver();
    }

    fn status(&mut self) -> Status {
        self.send(&HostMsg::StatusQuery);
        match self.inbox.last() {
            Some(DeviceMsg::Status(s)) => *s,
            other => panic!("no status: {other:?}"),
        }
    }

    fn tick(&mut self) {
        while let Some(m) = self.client.poll_transmit() {
            let mut out = [0u8; FRAME_MAX];
            let n = link::encode(&m, &mut out).unwrap();
            self.dev.receive(&out[..n]);
        }
        // A host asks for the status now and then (else the link's
        // silence holds the motion, `$209`).
        if self.ticks % 100 == 0 {
            self.send(&HostMsg::StatusQuery);
        }
        self.ticks += 1;
        self.dev.run_tick();
        self.deliver();
    }

    /// A straight move to `to` (mm) at 3000 mm/min, ended.
    fn move_to(&mut self, to: [f64; 3]) {
        self.client.start_path(3000i64 << 32, 60i64 << 32);
        self.client.point(to.map(mm), None);
        self.client.end_path();
        self.until(200_000, |b| {
            let s = b.status();
            s.motion == Motion::Idle && s.pos_mm == to.map(mm)
        });
    }

    fn probe(&mut self, to: [f64; 3], feed: f64, toward: bool, error_if_missed: bool) -> u32 {
        self.client
            .probe(to.map(mm), mm(feed), toward, error_if_missed)
    }

    /// Run until `done` (checked every tick), at most `max` ticks; the
    /// ticks run.
    fn until(&mut self, max: u32, mut done: impl FnMut(&mut Bench) -> bool) -> u32 {
        for t in 0..max {
            if done(self) {
                return t;
            }
            self.tick();
        }
        panic!("not done after {max} ticks: {:?}", self.status());
    }

    /// Run until the probe's report or an alarm.
    fn outcome(&mut self, max: u32) -> DeviceMsg {
        let n = self.inbox.len();
        let mut got = None;
        self.until(max, |b| {
            got = b.inbox[n..]
                .iter()
                .find(|m| matches!(m, DeviceMsg::Probed { .. } | DeviceMsg::Alarm { .. }))
                .copied();
            got.is_some()
        });
        got.unwrap()
    }
}

/// Where the tool rests once the report came: the status at rest.
fn rest(b: &mut Bench) -> [f64; 3] {
    b.until(1000, |b| b.status().motion != Motion::Running);
    of(b.status().pos_mm)
}

/// Toward a plane at `h` from z = 0 at `feed`: the trip within one step
/// plus one tick's travel of the plane, the tool at rest past it by the
/// ring's ticks and the deceleration, never past the target.
fn probe_plane(h: f64, feed: f64, target: f64) {
    let mut b = Bench::new(Some(ProbeSurface::plane(h)));
    let seq = b.probe([0.0, 0.0, target], feed, true, true);
    let got = b.outcome(2_000_000);
    let DeviceMsg::Probed {
        seq: s,
        pos_mm,
        tripped,
    } = got
    else {
        panic!("{got:?}")
    };
    assert_eq!((s, tripped), (seq, true));
    let p = of(pos_mm);
    let tick_mm = feed / 60.0 / TICK_HZ as f64;
    let err = p[2] - h;
    assert!(
        err.abs() <= STEP_MM + tick_mm + 1e-9,
        "F{feed} plane {h}: latched {} ({err:+.6} mm)",
        p[2]
    );
    assert_eq!((p[0], p[1]), (0.0, 0.0));
    let r = rest(&mut b);
    assert!(r[2] >= target, "never past the target: {r:?}");
    let over = h - r[2];
    // The ring's ticks, the debounce and the step pipeline at the feed,
    // then the stop at the tangential acceleration with its jerk ramps.
    let v = feed / 60.0;
    let a = b.client.hello().unwrap().accel_mm_per_s2 as f64;
    let j = controller::settings::JERK_MM_PER_S3 as f64;
    let ticks = controller::settings::SETPOINT_RING as f64 + 3.0 + 5.0;
    let bound = ticks * tick_mm + v * v / (2.0 * a) + v * a / j;
    assert!(
        (-STEP_MM..=bound).contains(&over),
        "F{feed}: {over} mm past the plane (bound {bound})"
    );
    // The planner took the abort (the rest of the move dropped): idle.
    assert_eq!(b.status().motion, Motion::Idle);
}

#[test]
fn a_probe_toward_a_plane_latches_the_crossing() {
    probe_plane(-3.25, 100.0, -10.0);
    probe_plane(-0.4, 1000.0, -2.0);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// Random planes and feeds.
    #[test]
    fn the_trip_is_within_one_step_and_a_tick_of_the_plane(
        h in -1.5f64..-0.05,
        feed in 20.0f64..1200.0,
    ) {
        probe_plane(h, feed, h - 1.0);
    }
}

#[test]
fn a_probe_already_tripped_raises_alarm_4() {
    let mut b = Bench::new(Some(ProbeSurface::plane(1.0)));
    b.tick();
    b.tick();
    b.tick();
    b.tick();
    b.send(&HostMsg::MachineQuery);
    let Some(DeviceMsg::Machine(m)) = b.inbox.last().copied() else {
        panic!()
    };
    assert_eq!(m.inputs & PROBE, PROBE, "the probe shows in the inputs");
    b.probe([0.0, 0.0, -5.0], 100.0, true, true);
    let got = b.outcome(10_000);
    assert!(
        matches!(got, DeviceMsg::Alarm { code: AlarmCode::ProbeFailInitial, pos_mm, .. } if pos_mm == [0; 3]),
        "{got:?}"
    );
    assert!(
        b.dev.axes.positions.iter().all(|p| p.to_bits() == [0; 3]),
        "no motion"
    );
}

#[test]
fn a_probe_that_never_trips_alarms_for_g38_2_and_reports_for_g38_3() {
    let mut b = Bench::new(Some(ProbeSurface::plane(-20.0)));
    b.probe([0.0, 0.0, -2.0], 600.0, true, true);
    let got = b.outcome(100_000);
    let DeviceMsg::Alarm { code, pos_mm, .. } = got else {
        panic!("{got:?}")
    };
    assert_eq!(code, AlarmCode::ProbeFailContact);
    assert_eq!(of(pos_mm)[2], -2.0, "at the target");
    assert!(!b
        .inbox
        .iter()
        .any(|m| matches!(m, DeviceMsg::Probed { .. })));
    let mut b = Bench::new(Some(ProbeSurface::plane(-20.0)));
    let seq = b.probe([0.0, 0.0, -2.0], 600.0, true, false);
    let got = b.outcome(100_000);
    assert_eq!(
        got,
        DeviceMsg::Probed {
            seq,
            pos_mm: [0, 0, mm(-2.0)],
            tripped: false
        }
    );
    let lowest = b
        .dev
        .axes
        .positions
        .iter()
        .map(|p| of(p.to_bits())[2])
        .fold(f64::MAX, f64::min);
    assert_eq!(lowest, -2.0, "never past the target");
    assert_eq!(b.status().motion, Motion::Idle);
}

/// G38.4 from inside the surface: trips where the tool leaves it.
#[test]
fn a_probe_away_trips_where_the_input_clears() {
    let mut b = Bench::new(Some(ProbeSurface::plane(0.5)));
    let seq = b.probe([0.0, 0.0, 3.0], 200.0, false, true);
    let got = b.outcome(100_000);
    let DeviceMsg::Probed {
        seq: s,
        pos_mm,
        tripped,
    } = got
    else {
        panic!("{got:?}")
    };
    assert_eq!((s, tripped), (seq, true));
    let z = of(pos_mm)[2];
    let tick_mm = 200.0 / 60.0 / TICK_HZ as f64;
    assert!((z - 0.5).abs() <= STEP_MM + tick_mm, "latched {z}");
}

/// A height map: the trip at the bilinear height under the tool.
#[test]
fn a_height_map_drives_the_probe_bilinearly() {
    let map = HeightMap {
        origin_mm: [0.0, 0.0],
        step_mm: [10.0, 10.0],
        nx: 2,
        z_mm: vec![-1.0, -2.0, -3.0, -4.0],
    };
    let surface = ProbeSurface {
        z_mm: 0.0,
        map: Some(map),
    };
    assert_eq!(surface.height(5.0, 5.0), -2.5);
    assert_eq!(surface.height(10.0, 0.0), -2.0);
    assert_eq!(surface.height(20.0, 0.0), 0.0, "the plane outside the map");
    let mut b = Bench::new(Some(surface));
    b.move_to([2.5, 7.5, 0.0]);
    b.probe([2.5, 7.5, -6.0], 150.0, true, true);
    let DeviceMsg::Probed { pos_mm, .. } = b.outcome(200_000) else {
        panic!()
    };
    // Bilinear at u = 0.25, v = 0.75.
    let want = -(0.75 * 0.25 + 2.0 * 0.25 * 0.25 + 3.0 * 0.75 * 0.75 + 4.0 * 0.25 * 0.75);
    let z = of(pos_mm)[2];
    assert!((z - want).abs() <= STEP_MM + 0.003, "{z} vs {want}");
}

/// The e-stop during a probe: its alarm, the probe dropped; after the
/// unlock the next probe runs from where the tool stopped.
#[test]
fn safety_inputs_win_over_a_probe() {
    let mut b = Bench::new(Some(ProbeSurface::plane(-3.0)));
    b.probe([0.0, 0.0, -5.0], 300.0, true, true);
    b.until(100_000, |b| of(b.status().pos_mm)[2] < -1.0);
    b.dev.estop = true;
    let got = b.outcome(1000);
    assert!(
        matches!(
            got,
            DeviceMsg::Alarm {
                code: AlarmCode::EStopInput,
                ..
            }
        ),
        "{got:?}"
    );
    b.dev.estop = false;
    for _ in 0..20 {
        b.tick();
    }
    let s = b.status();
    b.client.resync(&s);
    b.send(&HostMsg::Unlock);
    for _ in 0..20 {
        b.tick();
    }
    assert_eq!(b.status().motion, Motion::Idle);
    assert!(!b
        .inbox
        .iter()
        .any(|m| matches!(m, DeviceMsg::Probed { .. })));
    let seq = b.probe([0.0, 0.0, -5.0], 300.0, true, true);
    let got = b.outcome(100_000);
    assert!(
        matches!(got, DeviceMsg::Probed { seq: s, tripped: true, .. } if s == seq),
        "{got:?}"
    );

    // A limit switch (hard limits on) on the way wins over the probe.
    let mut b = Bench::new(Some(ProbeSurface::plane(-3.0)));
    b.send(&HostMsg::SetSetting {
        id: controller::config::SETTINGS[Key::HardLimits as usize].id,
        value: 1,
    });
    for _ in 0..5 {
        b.tick();
    }
    b.dev.switches.push(SimSwitch {
        axis: 2,
        max: false,
        at_steps: -100,
    });
    b.probe([0.0, 0.0, -5.0], 300.0, true, true);
    let got = b.outcome(100_000);
    assert!(
        matches!(
            got,
            DeviceMsg::Alarm {
                code: AlarmCode::HardLimit {
                    axis: 2,
                    max: false
                },
                ..
            }
        ),
        "{got:?}"
    );
}

/// `$6` inverts the probe input: the simulated probe is a switch whose
/// electrical level follows the polarity, so it trips at the same plane.
#[test]
fn the_probe_polarity_is_a_setting() {
    let mut c = controller::config::Config::DEFAULT;
    assert_eq!(c.input_invert() & PROBE, 0);
    c.set(6, 1).unwrap();
    assert_eq!(c.input_invert() & PROBE, PROBE);
    let mut b = Bench::new(Some(ProbeSurface::plane(-0.5)));
    b.send(&HostMsg::SetSetting { id: 6, value: 1 });
    for _ in 0..10 {
        b.tick();
    }
    b.probe([0.0, 0.0, -1.0], 100.0, true, true);
    let got = b.outcome(100_000);
    let DeviceMsg::Probed {
        pos_mm,
        tripped: true,
        ..
    } = got
    else {
        panic!("{got:?}")
    };
    assert!((of(pos_mm)[2] + 0.5).abs() <= STEP_MM + 0.002);
}
