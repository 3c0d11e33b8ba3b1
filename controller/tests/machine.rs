//! The machine around the motion on the host (`controller::sim`, the
//! firmware's own code, driven over its link by `link::client::Client`):
//! alarms (e-stop input and message mid-move, hard and soft limits, link
//! loss, unlock), homing against simulated switches on the simulated axes,
//! settings over the link and in their flash store, and spindle/coolant
//! commands synchronised with the path.

use controller::config::Config;
use controller::sim::{SimSwitch, VirtualDevice};
use controller::store;
use fuzzy_core::units::Point3Mm;
use link::client::Client;
use link::{
    AlarmCode, DeviceMsg, ErrorCode, FrameReader, HostMsg, MachineCmd, MachineStatus, Motion,
    PlanEvent, SpindleDir, Status, StoreResult, FRAME_MAX,
};

/// A device, a host session and everything the device said.
struct Bench {
    dev: VirtualDevice,
    client: Client,
    reader: FrameReader,
    inbox: Vec<DeviceMsg>,
}

fn frame(m: &HostMsg) -> Vec<u8> {
    let mut out = [0u8; FRAME_MAX];
    let n = link::encode(m, &mut out).unwrap();
    out[..n].to_vec()
}

const MM: f64 = 4294967296.0;

fn mm(x: f64) -> i64 {
    (x * MM).round() as i64
}

fn x_of(p: Point3Mm) -> f64 {
    p.to_bits()[0] as f64 / MM
}

impl Bench {
    fn new() -> Bench {
        Self::on(VirtualDevice::new().unwrap())
    }

    fn on(dev: VirtualDevice) -> Bench {
        let mut b = Bench {
            dev,
            client: Client::new(),
            reader: FrameReader::new(),
            inbox: Vec::new(),
        };
        b.deliver();
        assert!(b.client.hello().is_some(), "hello at reset");
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
        self.dev.receive(&frame(m));
        self.deliver();
    }

    fn transmit(&mut self) {
        while let Some(m) = self.client.poll_transmit() {
            self.dev.receive(&frame(&m));
        }
    }

    fn status(&mut self) -> Status {
        self.send(&HostMsg::StatusQuery);
        match self.inbox.last() {
            Some(DeviceMsg::Status(s)) => *s,
            other => panic!("no status: {other:?}"),
        }
    }

    fn machine(&mut self) -> MachineStatus {
        self.send(&HostMsg::MachineQuery);
        match self.inbox.last() {
            Some(DeviceMsg::Machine(s)) => *s,
            other => panic!("no machine status: {other:?}"),
        }
    }

    /// The reply to one message: what the device sent after it.
    fn ask(&mut self, m: &HostMsg) -> Vec<DeviceMsg> {
        let n = self.inbox.len();
        self.send(m);
        self.inbox[n..].to_vec()
    }

    fn set(&mut self, id: u16, value: i64) -> DeviceMsg {
        let r = self.ask(&HostMsg::SetSetting { id, value });
        assert_eq!(r.len(), 1, "{r:?}");
        r[0]
    }

    fn run(&mut self, ticks: u32) {
        for _ in 0..ticks {
            self.transmit();
            self.dev.run_tick();
            self.deliver();
        }
    }

    /// Run until `done` holds for the status (checked every 10 ticks).
    fn run_until(&mut self, max_ticks: u32, mut done: impl FnMut(&Status) -> bool) -> Status {
        let mut t = 0;
        loop {
            let s = self.status();
            if done(&s) {
                return s;
            }
            assert!(t < max_ticks, "not done after {t} ticks: {s:?}");
            self.run(10);
            t += 10;
        }
    }

    fn errors(&self) -> Vec<ErrorCode> {
        self.inbox
            .iter()
            .filter_map(|m| match *m {
                DeviceMsg::Error { code, .. } => Some(code),
                _ => None,
            })
            .collect()
    }

    fn alarms(&self) -> Vec<(AlarmCode, [i64; 3])> {
        self.inbox
            .iter()
            .filter_map(|m| match *m {
                DeviceMsg::Alarm { code, pos_mm, .. } => Some((code, pos_mm)),
                _ => None,
            })
            .collect()
    }

    /// A path (F_max 3000 mm/min) through `pts` (x, y, z in mm), ended.
    fn path(&mut self, pts: &[[f64; 3]]) {
        self.client.start_path(3000i64 << 32, 60i64 << 32);
        for p in pts {
            self.client.point(p.map(mm), None);
        }
        self.client.end_path();
    }

    /// Continue the session where the device is (dropping what the
    /// client still holds).
    fn resync(&mut self) {
        let s = self.status();
        self.client.resync(&s);
    }

    fn positions(&self) -> usize {
        self.dev.axes.positions.len()
    }
}

fn line_x(from: f64, to: f64, step: f64) -> Vec<[f64; 3]> {
    let n = ((to - from) / step).abs().round() as usize;
    (1..=n)
        .map(|i| [from + (to - from) * i as f64 / n as f64, 0.0, 0.0])
        .collect()
}

fn feed(s: &Status) -> f64 {
    s.feed_mm_per_min as f64 / MM
}

/// An e-stop at full feed: nothing reaches the axes from the tick that saw
/// it, the drivers are released, everything queued is dropped and path
/// commands are refused until an unlock, which the still-pressed e-stop
/// refuses; released and unlocked, a new path runs from where the tool
/// stopped.
#[test]
fn an_e_stop_input_mid_move_stops_the_output_at_that_tick_until_unlocked() {
    let mut b = Bench::new();
    b.path(&line_x(0.0, 100.0, 0.5));
    b.run_until(20_000, |s| feed(s) >= 2997.0);
    let sent = b.positions();
    let last = *b.dev.axes.positions.last().unwrap();
    b.dev.estop = true;
    b.dev.tick();
    assert_eq!(
        b.positions(),
        sent,
        "no position after the tick that saw it"
    );
    let stopped_steps = b.dev.steps();
    assert!(!b.dev.drivers_enabled, "drivers released");
    b.run(500);
    assert_eq!(b.positions(), sent, "nothing more while in alarm");
    assert_eq!(b.dev.steps(), stopped_steps, "no step after that tick");
    assert_eq!(b.dev.axes.pin_steps(), stopped_steps);
    let s = b.status();
    assert_eq!(s.motion, Motion::Alarm);
    // Where the steps stopped: behind the last setpoint by the step
    // pipeline (1.5 ticks, 0.05 mm a tick at 3000 mm/min), with no ramp.
    let stop = Point3Mm::from_bits(s.pos_mm[0], s.pos_mm[1], s.pos_mm[2]);
    let behind = x_of(last) - x_of(stop);
    assert!((0.05..0.15).contains(&behind), "{behind} mm behind");
    assert_eq!((x_of(stop) * 100.0).floor() as i64, stopped_steps[0]);
    assert_eq!(feed(&s), 0.0);
    assert_eq!(b.alarms(), vec![(AlarmCode::EStopInput, stop.to_bits())]);
    let last = stop;
    let m = b.machine();
    assert_eq!((m.alarm, m.alarms), (Some(AlarmCode::EStopInput), 1));
    assert!(
        b.inbox.iter().any(|m| matches!(m, DeviceMsg::Planned {
            event: PlanEvent::Reset { pos_mm }, ..
        } if *pos_mm == last.to_bits())),
        "the planner rebuilt at the stop, reported"
    );
    assert!(b.client.all_acked(), "the client dropped what was queued");
    // Refused while in alarm.
    b.path(&[[0.0, 5.0, 0.0]]);
    b.run(5);
    assert!(b.errors().contains(&ErrorCode::Alarm));
    assert_eq!(
        b.ask(&HostMsg::Unlock),
        vec![DeviceMsg::Error {
            code: ErrorCode::InputActive,
            expected_seq: b.status().next_seq
        }]
    );
    // Released and unlocked: a new path from where the tool stopped.
    b.dev.estop = false;
    b.run(10);
    let next_seq = b.status().next_seq;
    b.resync();
    assert_eq!(b.client.send_next(), next_seq);
    assert!(matches!(
        b.ask(&HostMsg::Unlock)[..],
        [DeviceMsg::Ack { .. }]
    ));
    b.run(5);
    assert_eq!(b.status().motion, Motion::Idle);
    assert!(b.dev.drivers_enabled);
    b.path(&[[x_of(last), 5.0, 0.0]]);
    let goal = [mm(x_of(last)), mm(5.0), 0];
    let end = b.run_until(20_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    assert_eq!(end.pos_mm, goal);
    // The motion after the unlock starts at the stop: no jump.
    let after = &b.dev.axes.positions[sent..];
    assert!(after
        .windows(2)
        .all(|w| (x_of(w[1]) - x_of(w[0])).abs() < 1e-9));
    assert_eq!(after[0].to_bits()[0], last.to_bits()[0]);
}

#[test]
fn an_e_stop_message_stops_the_output_at_the_next_tick() {
    let mut b = Bench::new();
    b.path(&line_x(0.0, 100.0, 0.5));
    b.run_until(20_000, |s| feed(s) >= 2997.0);
    let sent = b.positions();
    assert!(matches!(
        b.ask(&HostMsg::EStop)[..],
        [DeviceMsg::Ack { .. }]
    ));
    b.run(200);
    assert_eq!(
        b.positions(),
        sent,
        "the tick after the message sent nothing"
    );
    assert_eq!(b.alarms().len(), 1);
    assert_eq!(b.alarms()[0].0, AlarmCode::EStopLink);
    assert_eq!(b.status().motion, Motion::Alarm);
    // Grbl's $X: unlock, and the machine takes paths again.
    b.send(&HostMsg::Unlock);
    b.run(5);
    let s = b.status();
    assert_eq!(s.motion, Motion::Idle);
    b.path(&line_x(
        x_of(*b.dev.axes.positions.last().unwrap()),
        0.0,
        0.5,
    ));
    b.run_until(40_000, |s| s.motion == Motion::Idle && s.pos_mm == [0; 3]);
}

/// Hard limits on, a switch at X = 10 mm (1000 steps): the path to 20 mm
/// stops at the switch within the debounce, with the switch's code.
#[test]
fn a_hard_limit_switch_raises_an_alarm_after_the_debounce() {
    let mut b = Bench::new();
    assert!(matches!(
        b.set(21, 1),
        DeviceMsg::Setting { id: 21, value: 1 }
    ));
    b.dev.switches.push(SimSwitch {
        axis: 0,
        max: true,
        at_steps: 1000,
    });
    b.path(&line_x(0.0, 20.0, 0.5));
    b.run_until(20_000, |s| s.motion == Motion::Alarm);
    let (code, pos) = b.alarms()[0];
    assert_eq!(code, AlarmCode::HardLimit { axis: 0, max: true });
    let x = pos[0] as f64 / MM;
    // 3 samples of debounce at up to 3000 mm/min: 0.15 mm.
    assert!((10.0..10.2).contains(&x), "stopped at {x}");
    b.run(100);
    assert_eq!(b.status().pos_mm, pos);
    // Unlocked on the switch (edge-triggered, as Grbl's pin change), the
    // tool may be driven off it.
    b.send(&HostMsg::Unlock);
    b.resync();
    b.path(&[[5.0, 0.0, 0.0]]);
    let goal = [mm(5.0), 0, 0];
    b.run_until(20_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    assert_eq!(b.alarms().len(), 1);
}

/// Soft limits on: a point outside Grbl's machine space `[−travel, 0]` is
/// refused when it arrives, and nothing of its batch is accepted.
#[test]
fn soft_limits_refuse_points_outside_the_travel_on_arrival() {
    let mut b = Bench::new();
    b.set(20, 1);
    b.set(130, 50_000);
    let next = b.status().next_seq;
    b.send(&HostMsg::Point {
        seq: next,
        pos_mm: [mm(1.0), 0, 0],
        feed_cap_mm_per_min: None,
    });
    assert_eq!(b.errors(), vec![ErrorCode::OutOfTravel]);
    let mut batch = link::PointBatch::new();
    for x in [-1.0, -2.0, -60.0] {
        batch.push(link::BatchPoint {
            pos_mm: [link::batch::to_grid(mm(x)), 0, 0],
            feed_cap_mm_per_min: None,
        });
    }
    b.send(&HostMsg::Points { seq: next, batch });
    assert_eq!(b.errors().last(), Some(&ErrorCode::OutOfTravel));
    assert_eq!(b.status().next_seq, next, "nothing of the batch accepted");
    b.path(&line_x(0.0, -49.0, 0.5));
    let goal = [mm(-49.0), 0, 0];
    b.run_until(40_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    assert_eq!(b.alarms(), vec![]);
}

/// Settings change at rest only (refused while moving). With soft limits
/// switched on while the tool is outside the travel (not homed, say), it
/// may come back in, as Grbl allows; points further out are refused.
#[test]
fn soft_limits_let_a_tool_outside_the_travel_come_back_in() {
    let mut b = Bench::new();
    b.path(&line_x(0.0, -30.0, 0.5));
    b.run_until(40_000, |s| {
        s.motion == Motion::Idle && s.pos_mm[0] == mm(-30.0)
    });
    // Moving: settings refused.
    b.path(&line_x(-30.0, -60.0, 0.5));
    b.run_until(20_000, |s| s.motion == Motion::Running);
    assert!(matches!(
        b.set(20, 1),
        DeviceMsg::Error {
            code: ErrorCode::Busy,
            ..
        }
    ));
    b.run_until(40_000, |s| {
        s.motion == Motion::Idle && s.pos_mm[0] == mm(-60.0)
    });
    b.set(130, 40_000);
    b.set(20, 1);
    b.run(50);
    assert!(b.alarms().is_empty(), "at rest outside: no violation");
    b.path(&[[-70.0, 0.0, 0.0]]);
    b.run(5);
    assert!(b.errors().contains(&ErrorCode::OutOfTravel));
    // Back in with one move to a point inside (points outside are refused
    // whichever way they lead).
    b.resync();
    b.path(&[[-35.0, 0.0, 0.0]]);
    let goal = [mm(-35.0), 0, 0];
    b.run_until(40_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    assert!(b.alarms().is_empty(), "{:?}", b.alarms());
}

/// Link loss: a path left open that runs out stops under control
/// (underrun); after the timeout of silence it becomes an alarm.
#[test]
fn a_silent_link_with_a_starved_path_raises_an_alarm_after_the_stop() {
    let mut b = Bench::new();
    b.set(206, 300);
    b.client.start_path(3000i64 << 32, 60i64 << 32);
    for p in line_x(0.0, 40.0, 0.5) {
        b.client.point(p.map(mm), None);
    }
    let stop = b.run_until(20_000, |s| s.motion == Motion::Starved && feed(s) == 0.0);
    // Polled (frames arrive): no alarm however long.
    for _ in 0..100 {
        b.run(10);
        b.status();
    }
    assert!(b.alarms().is_empty());
    // Silent.
    b.run(350);
    assert_eq!(b.alarms().len(), 1);
    assert_eq!(b.alarms()[0], (AlarmCode::LinkLoss, stop.pos_mm));
}

/// A link that falls silent while the tool moves (the host gone, its path
/// queued): a feed hold after `$209`, the tool at rest on the path well
/// short of its end, then the link-loss alarm after `$206` where it
/// rests. Polled, the same path runs to its end.
#[test]
fn a_link_silent_while_moving_holds_the_motion_then_raises_the_alarm() {
    let end = [mm(80.0), 0, 0];
    let pts = line_x(0.0, 80.0, 1.0);
    let mut b = Bench::new();
    b.path(&pts);
    b.run_until(60_000, |s| s.motion == Motion::Idle && s.pos_mm == end);
    assert!(b.alarms().is_empty(), "polled: no hold, no alarm");

    let mut b = Bench::new();
    b.set(206, 300);
    b.path(&pts);
    b.run_until(5_000, |s| s.motion == Motion::Running && feed(s) > 2000.0);
    // Silent from here: everything was sent within the credit.
    b.run(1005);
    let held = b.status();
    b.run(300);
    assert!(b.alarms().is_empty(), "{:?}", b.alarms());
    let rest = b.status();
    assert_eq!(rest.motion, Motion::Held, "{rest:?}");
    assert_eq!(feed(&rest), 0.0);
    let x = rest.pos_mm[0] as f64 / MM;
    assert!(x < 70.0, "stopped well short of the end: X{x}");
    assert!(feed(&held) > 0.0, "it was still moving: {held:?}");
    // Silent on at rest: the alarm, where the tool rests.
    b.run(250);
    assert!(b.alarms().is_empty(), "{:?}", b.alarms());
    b.run(100);
    let alarms = b.alarms();
    assert_eq!(alarms.len(), 1, "{alarms:?}");
    let (code, at) = alarms[0];
    assert_eq!(code, AlarmCode::LinkLoss);
    // Where the step output stopped: the rest position to the step.
    let off_mm = (at[0] - rest.pos_mm[0]).abs() as f64 / MM;
    assert!(off_mm <= 0.01 + 1e-9, "{at:?} {rest:?}");
    assert_eq!(b.status().motion, Motion::Alarm);

    // A host heard again before the alarm resumes the path as from any
    // hold.
    let mut b = Bench::new();
    b.path(&pts);
    b.run_until(5_000, |s| s.motion == Motion::Running && feed(s) > 2000.0);
    b.run(1100);
    assert_eq!(b.status().motion, Motion::Held);
    b.send(&HostMsg::Resume);
    b.run_until(60_000, |s| s.motion == Motion::Idle && s.pos_mm == end);
    assert!(b.alarms().is_empty());
}

/// The homing cycle against switches on the simulated axes (X max at 3
/// mm, Y max at 5 mm, Z max at 2 mm of the step output's coordinates,
/// 100 steps/mm): motion is refused before it when homing is required;
/// Z first, then X and Y (the default passes); each axis ends one pull-off
/// from its switch, within a few locate-feed ticks, at machine coordinate
/// −pull-off; then paths run in the new coordinates.
#[test]
fn homing_finds_the_switches_and_sets_the_machine_coordinates() {
    let mut b = Bench::new();
    b.set(22, 1);
    b.set(26, 2);
    for (axis, at_mm) in [(0, 3.0), (1, 5.0), (2, 2.0)] {
        b.dev.switches.push(SimSwitch {
            axis,
            max: true,
            at_steps: (at_mm * 100.0) as i64,
        });
    }
    b.path(&[[-1.0, 0.0, 0.0]]);
    b.run(5);
    assert!(b.errors().contains(&ErrorCode::NotHomed));
    b.resync();
    assert!(matches!(
        b.ask(&HostMsg::Home { axes: 0 })[..],
        [DeviceMsg::Ack { .. }]
    ));
    b.run(5);
    assert_eq!(b.status().motion, Motion::Homing);
    let s = b.run_until(200_000, |s| s.motion != Motion::Homing);
    assert_eq!(s.motion, Motion::Idle, "{:?}", b.alarms());
    let homed = b.inbox.iter().find_map(|m| match *m {
        DeviceMsg::Homed { axes, pos_mm } => Some((axes, pos_mm)),
        _ => None,
    });
    let (axes, pos) = homed.expect("a Homed report");
    assert_eq!(axes, 7);
    assert_eq!(pos, [mm(-1.0); 3], "−pull-off on every axis");
    assert_eq!(s.pos_mm, pos);
    assert_eq!(b.machine().homed, 7);
    // Where the step output is: one pull-off from each switch (the locate
    // at 25 mm/min with 2 samples of debounce overshoots by < 1 µm, then
    // at most a step of the 0.01 mm resolution).
    let phys = *b.dev.axes.positions.last().unwrap();
    for (a, at) in [3.0, 5.0, 2.0].into_iter().enumerate() {
        let p = phys.to_bits()[a] as f64 / MM;
        assert!((p - (at - 1.0)).abs() < 0.011, "axis {a} at {p}");
    }
    // Z homed first, then X, then Y: the order the positions moved in.
    let moved: Vec<usize> = b
        .dev
        .axes
        .positions
        .windows(2)
        .filter_map(|w| (0..3).find(|&a| w[0].to_bits()[a] != w[1].to_bits()[a]))
        .fold(Vec::new(), |mut v, a| {
            if v.last() != Some(&a) {
                v.push(a);
            }
            v
        });
    assert_eq!(moved, vec![2, 0, 1], "pass order Z, then X, Y");
    // Paths now run in machine coordinates; 0 is the switch.
    b.resync();
    b.path(&[[-10.0, -20.0, -1.0]]);
    let goal = [mm(-10.0), mm(-20.0), mm(-1.0)];
    b.run_until(40_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    let phys = b.dev.axes.positions.last().unwrap().to_bits();
    assert!((phys[0] as f64 / MM - (3.0 - 10.0)).abs() < 0.011);
    assert!((phys[1] as f64 / MM - (5.0 - 20.0)).abs() < 0.011);
    // The step engine made every move, homing's too: its count and the
    // pins' are the commanded position's, nothing owed.
    b.run(3);
    let want = phys.map(|x| ((x as i128 * 100) >> 32) as i64);
    assert_eq!(b.dev.steps(), want);
    assert_eq!(b.dev.axes.pin_steps(), want);
    assert_eq!(b.dev.exec().steps.fault(), None);
}

#[test]
fn homing_without_a_switch_or_off_a_stuck_switch_fails_with_its_alarm() {
    let mut b = Bench::new();
    b.set(22, 1);
    b.set(44, 1); // X only
    b.set(45, 0);
    b.set(130, 5_000); // 5 mm travel: a 7.5 mm search
    b.set(25, 3000);
    b.send(&HostMsg::Home { axes: 0 });
    b.run_until(100_000, |s| s.motion == Motion::Alarm);
    assert_eq!(b.alarms()[0].0, AlarmCode::HomingNoSwitch { axis: 0 });
    let x = b.alarms()[0].1[0] as f64 / MM;
    assert!((x - 7.5).abs() < 1e-6, "searched 1.5 × the travel: {x}");
    // A switch that stays closed whatever the pull-off.
    let mut b = Bench::new();
    b.set(22, 1);
    b.set(44, 1);
    b.set(45, 0);
    b.dev.switches.push(SimSwitch {
        axis: 0,
        max: true,
        at_steps: -1_000_000,
    });
    b.send(&HostMsg::Home { axes: 0 });
    b.run_until(100_000, |s| s.motion == Motion::Alarm);
    assert_eq!(b.alarms()[0].0, AlarmCode::HomingPullOff { axis: 0 });
}

/// Settings over the link: read, written (stored, the planner rebuilt),
/// refused out of range or unknown (nothing changed), and read back from
/// the flash after a reset; a corrupted store gives the defaults and says
/// so.
#[test]
fn settings_round_trip_over_the_link_and_through_a_reset() {
    let mut b = Bench::new();
    assert!(b.inbox.contains(&DeviceMsg::Stored(StoreResult::Empty)));
    assert_eq!(
        b.ask(&HostMsg::GetSetting { id: 120 }),
        vec![DeviceMsg::Setting {
            id: 120,
            value: 2000
        }]
    );
    assert!(matches!(
        b.set(120, 0),
        DeviceMsg::Error {
            code: ErrorCode::OutOfRange,
            ..
        }
    ));
    assert!(matches!(
        b.set(999, 1),
        DeviceMsg::Error {
            code: ErrorCode::UnknownSetting,
            ..
        }
    ));
    assert_eq!(
        b.set(120, 800),
        DeviceMsg::Setting {
            id: 120,
            value: 800
        }
    );
    b.set(100, 80_000);
    b.run(5);
    assert!(b.inbox.contains(&DeviceMsg::Stored(StoreResult::Saved)));
    assert!(b.inbox.iter().any(|m| matches!(
        m,
        DeviceMsg::Planned {
            event: PlanEvent::Reset { .. },
            ..
        }
    )));
    assert!(
        !b.machine().restart_needed,
        "steps/mm apply at rest, without a reset"
    );
    // The planner took the new acceleration: 800 mm/s² per axis, half of
    // it tangential.
    let accel = b
        .dev
        .background()
        .planning()
        .motion()
        .accel_limit_mm_s2()
        .to_num::<f64>();
    assert!((accel - 400.0).abs() < 0.01, "{accel}");
    // A reset reads them back.
    let flash = b.dev.machine.flash.clone();
    let mut c = Bench::on(VirtualDevice::with_flash(flash.clone()).unwrap());
    assert!(c.inbox.contains(&DeviceMsg::Stored(StoreResult::Loaded)));
    assert_eq!(
        c.ask(&HostMsg::GetSetting { id: 100 }),
        vec![DeviceMsg::Setting {
            id: 100,
            value: 80_000
        }]
    );
    assert_eq!(c.client.hello().unwrap().accel_mm_per_s2, 400);
    // Corrupted: the defaults, reported.
    let mut bad = flash;
    bad.words[5] ^= 0x100;
    let mut d = Bench::on(VirtualDevice::with_flash(bad).unwrap());
    assert!(d.inbox.contains(&DeviceMsg::Stored(StoreResult::Corrupt)));
    assert_eq!(
        d.ask(&HostMsg::GetSetting { id: 120 }),
        vec![DeviceMsg::Setting {
            id: 120,
            value: 2000
        }]
    );
    assert_eq!(d.machine().store, StoreResult::Corrupt);
    // Storage itself: what the device wrote is one record.
    let (cfg, r, _) = store::load(&c.dev.machine.flash);
    assert_eq!(r, StoreResult::Loaded);
    assert_eq!(cfg.by_id(120), Ok(800));
    assert_ne!(cfg, Config::DEFAULT);
}

/// M3 S1000 between two paths, M5 after the second: each takes effect with
/// the tool at rest at the end of the path before it (reported with that
/// path's last index), the motion waits the spin-up delay after M3, and
/// the outputs follow (PWM duty from the speed range).
#[test]
fn spindle_commands_take_effect_at_their_point_of_the_path() {
    let mut b = Bench::new();
    b.set(207, 250);
    let a = line_x(0.0, 10.0, 0.5);
    let bb = line_x(10.0, 20.0, 0.5);
    b.client.start_path(3000i64 << 32, 60i64 << 32);
    for p in &a {
        b.client.point(p.map(mm), None);
    }
    let m3 = b.client.machine(MachineCmd::Spindle {
        dir: SpindleDir::Cw,
        speed_rpm: 1000,
    });
    for p in &bb {
        b.client.point(p.map(mm), None);
    }
    let m5 = b.client.machine(MachineCmd::Spindle {
        dir: SpindleDir::Off,
        speed_rpm: 0,
    });
    b.client.end_path();
    let goal = [mm(20.0), 0, 0];
    b.run_until(40_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    b.run(50);
    let applied: Vec<(u32, MachineCmd, u32)> = b
        .inbox
        .iter()
        .filter_map(|m| match *m {
            DeviceMsg::Applied {
                seq, cmd, point, ..
            } => Some((seq, cmd, point)),
            _ => None,
        })
        .collect();
    assert_eq!(applied.len(), 2, "{applied:?}");

    assert_eq!(
        (applied[0].0, applied[0].2),
        (m3, a.len() as u32),
        "M3 after the last point of the first path"
    );
    assert_eq!((applied[1].0, applied[1].2), (m5, bb.len() as u32));
    // The outputs changed with the tool at rest at the ends.
    let outs = &b.dev.machine.outputs;
    assert_eq!(outs.len(), 2, "{outs:?}");
    let at = |k: usize| x_of(b.dev.axes.positions[k - 1]);
    assert_eq!(at(outs[0].0), 10.0);
    assert!(outs[0].1.spindle_on && outs[0].1.duty_q16 == u16::MAX);
    assert_eq!(at(outs[1].0), 20.0);
    assert!(!outs[1].1.spindle_on);
    // After M3, 250 ms (ticks) without motion before the second path.
    let after = &b.dev.axes.positions[outs[0].0..];
    let still = after.iter().take_while(|p| x_of(**p) == 10.0).count();
    assert!(still >= 250, "moved after {still} ticks");
    // Before M5 the tool had stopped at 20 mm (no motion after it).
    assert!(b.dev.axes.positions[outs[1].0..]
        .iter()
        .all(|p| x_of(*p) == 20.0));
}

/// A dwell (G4 P0.3) between two paths: the tool at rest at the end of the
/// first for 300 ms (ticks) before the second starts; a dwell over an hour
/// is refused (`OutOfRange`) and nothing changes.
#[test]
fn a_dwell_holds_the_tool_at_its_point() {
    let mut b = Bench::new();
    let a = line_x(0.0, 10.0, 0.5);
    let bb = line_x(10.0, 20.0, 0.5);
    b.client.start_path(3000i64 << 32, 60i64 << 32);
    for p in &a {
        b.client.point(p.map(mm), None);
    }
    let dwell = b.client.machine(MachineCmd::Dwell { ms: 300 });
    for p in &bb {
        b.client.point(p.map(mm), None);
    }
    b.client.end_path();
    let goal = [mm(20.0), 0, 0];
    b.run_until(40_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    let applied: Vec<(u32, u32)> = b
        .inbox
        .iter()
        .filter_map(|m| match *m {
            DeviceMsg::Applied { seq, point, .. } => Some((seq, point)),
            _ => None,
        })
        .collect();
    assert_eq!(applied, vec![(dwell, a.len() as u32)]);
    let pos = &b.dev.axes.positions;
    let first = pos.iter().position(|p| x_of(*p) == 10.0).unwrap();
    let still = pos[first..]
        .iter()
        .take_while(|p| x_of(**p) == 10.0)
        .count();
    assert!(still >= 300, "moved after {still} ticks");
    assert!(still < 300 + 100, "held {still} ticks");

    let before = b.inbox.len();
    b.client.machine(MachineCmd::Dwell {
        ms: link::DWELL_MAX_MS + 1,
    });
    b.run(50);
    assert!(
        b.inbox[before..].iter().any(|m| matches!(
            m,
            DeviceMsg::Error {
                code: link::ErrorCode::OutOfRange,
                ..
            }
        )),
        "{:?}",
        &b.inbox[before..]
    );
}

/// A reset by the watchdog (the firmware's start-up trips this alarm when
/// the chip says so): the controller starts in the alarm state, reports it,
/// and takes paths only after an unlock.
#[test]
fn a_watchdog_reset_starts_in_the_alarm_state() {
    let mut b = Bench::new();
    b.dev.latch().trip(AlarmCode::Watchdog);
    b.run(5);
    assert_eq!(b.alarms(), vec![(AlarmCode::Watchdog, [0; 3])]);
    assert_eq!(b.status().motion, Motion::Alarm);
    assert!(!b.dev.drivers_enabled);
    b.send(&HostMsg::Unlock);
    b.path(&[[1.0, 0.0, 0.0]]);
    let goal = [mm(1.0), 0, 0];
    b.run_until(20_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
}

/// Step settings written at rest apply to the next motion without a reset:
/// X at 80 steps/mm instead of 100 and its step pin inverted, the second
/// millimetre takes 80 steps on the pins (read with the new polarity),
/// no step lost, lagging or late in the change, and no reset asked for.
#[test]
fn step_settings_written_at_rest_apply_to_the_next_motion() {
    let mut b = Bench::new();
    let goal = |x: f64| move |s: &Status| s.motion == Motion::Idle && s.pos_mm == [mm(x), 0, 0];
    b.path(&line_x(0.0, 1.0, 0.5));
    b.run_until(20_000, goal(1.0));
    b.run(10);
    assert_eq!(b.dev.axes.pin_steps()[0], 100, "1 mm at 100 steps/mm");
    assert_eq!(
        b.set(100, 80_000),
        DeviceMsg::Setting {
            id: 100,
            value: 80_000
        }
    );
    assert_eq!(b.set(2, 0b001), DeviceMsg::Setting { id: 2, value: 1 });
    b.run(10);
    assert!(!b.dev.step_settings_pending(), "applied at rest");
    assert!(!b.machine().restart_needed);
    assert_eq!(b.dev.steps()[0], 80, "1 mm is 80 steps now");
    b.resync();
    b.path(&line_x(1.0, 2.0, 0.5));
    b.run_until(20_000, goal(2.0));
    b.run(10);
    assert_eq!(b.dev.axes.pin_steps()[0], 180, "the second mm in 80 steps");
    assert_eq!(b.dev.steps()[0], 160);
    let s = b.status();
    assert_eq!(
        (s.step_lag_ticks, s.step_late_ticks),
        (0, 0),
        "nothing carried or late"
    );
    assert!(b.alarms().is_empty());
}

/// A setting written while the tool moves is refused (`Busy`) and changes
/// nothing: the path runs at the old steps/mm and the value reads back
/// unchanged; with the spindle on, a write at rest is refused
/// (`OutputsOn`: a flash erase would stall the controller with the
/// spindle running) until M5.
#[test]
fn settings_written_while_moving_or_with_the_spindle_on_are_refused() {
    let mut b = Bench::new();
    b.path(&line_x(0.0, 20.0, 0.5));
    b.run_until(20_000, |s| feed(s) >= 2997.0);
    for (id, value) in [(100, 80_000), (0, 4_000), (120, 800)] {
        assert!(
            matches!(
                b.set(id, value),
                DeviceMsg::Error {
                    code: ErrorCode::Busy,
                    ..
                }
            ),
            "${id} while moving"
        );
    }
    b.run_until(40_000, |s| {
        s.motion == Motion::Idle && s.pos_mm == [mm(20.0), 0, 0]
    });
    b.run(10);
    assert!(!b.dev.step_settings_pending());
    assert_eq!(b.dev.axes.pin_steps()[0], 2000, "20 mm at 100 steps/mm");
    assert_eq!(
        b.ask(&HostMsg::GetSetting { id: 100 }),
        vec![DeviceMsg::Setting {
            id: 100,
            value: 100_000
        }]
    );
    assert!(!b
        .inbox
        .iter()
        .any(|m| matches!(m, DeviceMsg::Stored(StoreResult::Saved))));

    b.set(207, 0);
    b.resync();
    b.client.start_path(3000i64 << 32, 60i64 << 32);
    b.client.machine(MachineCmd::Spindle {
        dir: SpindleDir::Cw,
        speed_rpm: 1000,
    });
    b.client.machine(MachineCmd::Coolant {
        flood: false,
        mist: true,
    });
    b.client.end_path();
    b.run(100);
    assert!(b.dev.machine.outputs.last().unwrap().1.spindle_on);
    assert!(matches!(
        b.set(120, 800),
        DeviceMsg::Error {
            code: ErrorCode::OutputsOn,
            ..
        }
    ));
    b.resync();
    b.client.start_path(3000i64 << 32, 60i64 << 32);
    b.client.machine(MachineCmd::Spindle {
        dir: SpindleDir::Off,
        speed_rpm: 0,
    });
    b.client.end_path();
    b.run(100);
    assert!(
        matches!(
            b.set(120, 800),
            DeviceMsg::Error {
                code: ErrorCode::OutputsOn,
                ..
            }
        ),
        "the mist coolant is still on"
    );
    b.resync();
    b.client.start_path(3000i64 << 32, 60i64 << 32);
    b.client.machine(MachineCmd::Coolant {
        flood: false,
        mist: false,
    });
    b.client.end_path();
    b.run(100);
    assert_eq!(
        b.set(120, 800),
        DeviceMsg::Setting {
            id: 120,
            value: 800
        }
    );
}

/// In an alarm a write waits for the alarm to be carried out (the tick
/// stopped, the spindle off: `Busy` before), then is taken; step settings
/// written in the alarm apply after the unlock, before the next motion.
#[test]
fn settings_in_an_alarm_are_taken_once_it_is_carried_out() {
    let mut b = Bench::new();
    b.path(&line_x(0.0, 100.0, 0.5));
    b.run_until(20_000, |s| feed(s) >= 2997.0);
    b.send(&HostMsg::EStop);
    assert!(matches!(
        b.set(100, 50_000),
        DeviceMsg::Error {
            code: ErrorCode::Busy,
            ..
        }
    ));
    b.run(5);
    assert_eq!(b.alarms().len(), 1);
    assert_eq!(
        b.set(100, 50_000),
        DeviceMsg::Setting {
            id: 100,
            value: 50_000
        }
    );
    b.run(5);
    assert!(b.dev.step_settings_pending(), "not in the alarm");
    b.send(&HostMsg::Unlock);
    b.run(10);
    assert!(!b.dev.step_settings_pending(), "after the unlock, at rest");
    let from = x_of(*b.dev.axes.positions.last().unwrap());
    let pins = b.dev.axes.pin_steps()[0];
    b.resync();
    b.path(&line_x(from, from - 2.0, 0.5));
    let goal = [mm(from - 2.0), 0, 0];
    b.run_until(40_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    b.run(10);
    assert_eq!(pins - b.dev.axes.pin_steps()[0], 100, "2 mm at 50 steps/mm");
}

/// The tick rate applies at the next reset: stored and reported as
/// needing one, while the planner and the tick keep the rate they
/// started with.
#[test]
fn the_tick_rate_applies_at_the_next_reset() {
    let mut b = Bench::new();
    b.set(200, 2000);
    b.run(5);
    assert!(b.machine().restart_needed);
    assert_eq!(b.dev.background().config().tick_hz(), 1000);
    assert_eq!(
        b.ask(&HostMsg::GetSetting { id: 200 }),
        vec![DeviceMsg::Setting {
            id: 200,
            value: 2000
        }]
    );
    let flash = b.dev.machine.flash.clone();
    // Written back to the rate running: no reset needed any more.
    b.set(200, 1000);
    b.run(5);
    assert!(!b.machine().restart_needed);
    b.set(200, 1000);
    b.run(5);
    assert!(!b.machine().restart_needed, "the same value again");
    let c = Bench::on(VirtualDevice::with_flash(flash).unwrap());
    assert_eq!(c.client.hello().unwrap().tick_hz, 2000);
}

/// Distance from `p` to the polyline `poly`, mm.
fn off_polyline(poly: &[[f64; 3]], p: [f64; 3]) -> f64 {
    poly.windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let ab: Vec<f64> = (0..3).map(|k| b[k] - a[k]).collect();
            let ap: Vec<f64> = (0..3).map(|k| p[k] - a[k]).collect();
            let l2: f64 = ab.iter().map(|x| x * x).sum();
            let t = if l2 > 0.0 {
                (ap.iter().zip(&ab).map(|(x, y)| x * y).sum::<f64>() / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (0..3)
                .map(|k| (ap[k] - t * ab[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

/// A program switching its path control between paths (as the sender sends
/// `G64 P0.01`, `G61`, `G64`): zigzags with 90° corners, the first blended
/// within 10 µm (wider than the machine's 1 µm, so it cuts its corners by
/// more than that), the second on the path exactly with a stop at every
/// corner, the third within the machine's 1 µm again.
#[test]
fn a_programs_path_control_takes_effect_from_its_block_on() {
    let mut b = Bench::new();
    let zigzag = |y0: f64, rev: bool| -> Vec<[f64; 3]> {
        (0..=10)
            .map(|i| {
                let x = if rev { 10 - i } else { i } as f64;
                [x, y0 + (i % 2) as f64, 0.0]
            })
            .collect()
    };
    let (p1, p2, p3) = (zigzag(0.0, false), zigzag(3.0, true), zigzag(6.0, false));
    let control = |c| MachineCmd::PathControl(c);
    b.client
        .machine(control(link::PathControl::Tolerance { nm: 10_000 }));
    b.path(&p1[1..]);
    b.client.machine(control(link::PathControl::Exact));
    b.path(&p2);
    b.client.machine(control(link::PathControl::Blend));
    b.path(&p3);
    let goal = [mm(10.0), mm(6.0), 0];
    b.run_until(60_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    let all: Vec<[f64; 3]> = p1.iter().chain(&p2).chain(&p3).copied().collect();
    let pos: Vec<[f64; 3]> = b.dev.axes.positions.iter().map(|p| p.to_f64()).collect();
    let mut worst = [0.0f64; 3];
    for p in &pos {
        let band = if p[1] < 1.5 {
            0
        } else if p[1] < 4.5 {
            1
        } else {
            2
        };
        worst[band] = worst[band].max(off_polyline(&all, *p));
    }
    assert!(worst[0] <= 0.010 + 1e-9, "G64 P0.01: {} mm", worst[0]);
    assert!(
        worst[0] > 0.001,
        "G64 P0.01 blended no wider: {} mm",
        worst[0]
    );
    assert!(worst[1] <= 1e-9, "G61: {} mm off the path", worst[1]);
    assert!(worst[2] <= 0.001 + 1e-9, "G64: {} mm", worst[2]);
    // G61: every corner of the second zigzag is passed at the creep speed.
    for v in &p2[1..p2.len() - 1] {
        let k = (0..pos.len())
            .min_by(|&i, &j| {
                let d = |p: [f64; 3]| (p[0] - v[0]).hypot(p[1] - v[1]);
                d(pos[i]).total_cmp(&d(pos[j]))
            })
            .unwrap();
        let step = |i: usize| (pos[i + 1][0] - pos[i][0]).hypot(pos[i + 1][1] - pos[i][1]);
        assert!(
            step(k - 1).max(step(k)) < 1e-4,
            "G61 corner {v:?} passed at {} mm/tick",
            step(k)
        );
    }
    eprintln!(
        "path control: G64 P0.01 {:.2} µm, G61 {:.1e} mm, G64 {:.2} µm off the path",
        worst[0] * 1e3,
        worst[1],
        worst[2] * 1e3
    );
}
