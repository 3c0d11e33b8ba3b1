//! What the operator asks for while a program runs: from keys (a
//! terminal), from a script of timed actions (tests, unattended runs), or
//! from Ctrl-C; and the operator's state those requests change (hold,
//! override, stop), which decides the message to send.

use std::time::Duration;

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use link::{HostMsg, OVERRIDE_MAX_PERCENT, OVERRIDE_MIN_PERCENT};

/// Override step of `+`/`-`, percent.
pub const OVERRIDE_STEP_PERCENT: u16 = 10;

/// An operator request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Hold if running, resume if held (space).
    ToggleHold,
    /// Feed hold.
    Hold,
    /// Release a feed hold.
    Resume,
    /// Override up one step (`+`).
    Faster,
    /// Override down one step (`-`).
    Slower,
    /// Override to this percent (clamped to 10-200).
    Override(u16),
    /// Controlled stop: the motion stops on the path, the rest of the
    /// program is dropped (Esc, Ctrl-C).
    Stop,
    /// Emergency stop (`!`): `HostMsg::EStop`, the controller's alarm
    /// state (the step output stops at the next tick with no
    /// deceleration, the drivers are released) until an unlock.
    EStop,
}

/// The action of a key press, if any (releases and repeats of a held key
/// are ignored; terminals without key-release reports send presses only).
pub fn from_key(k: &KeyEvent) -> Option<Action> {
    if k.kind == KeyEventKind::Release {
        return None;
    }
    let ctrl = k.modifiers.contains(KeyModifiers::CONTROL);
    match k.code {
        KeyCode::Char('c') | KeyCode::Char('C') if ctrl => Some(Action::Stop),
        KeyCode::Esc => Some(Action::Stop),
        KeyCode::Char(' ') => Some(Action::ToggleHold),
        KeyCode::Char('+') | KeyCode::Char('=') => Some(Action::Faster),
        KeyCode::Char('-') | KeyCode::Char('_') => Some(Action::Slower),
        KeyCode::Char('!') => Some(Action::EStop),
        _ => None,
    }
}

/// Why the run was stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopKind {
    /// Controlled stop (Esc, Ctrl-C, `stop`).
    Stop,
    /// Emergency stop (`!`, `estop`): the alarm state.
    EStop,
}

/// The operator's side of hold, override and stop: what was asked for,
/// and the message each request sends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Operator {
    /// A feed hold is asked for.
    pub hold: bool,
    /// The override asked for, percent.
    pub override_percent: u16,
    /// A stop was asked for.
    pub stop: Option<StopKind>,
}

/// What a request does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Effect {
    /// Send this immediate message.
    Send(HostMsg),
    /// Stop: abort the path (the caller sends `Client::abort()`).
    Stop(StopKind),
    /// A second stop while stopping (or any stop after an e-stop): leave
    /// without waiting for the controller's report.
    Leave,
    /// Nothing changes.
    None,
}

impl Operator {
    /// Starting from the controller's override.
    pub fn new(override_percent: u16) -> Self {
        Operator {
            hold: false,
            override_percent: override_percent.clamp(OVERRIDE_MIN_PERCENT, OVERRIDE_MAX_PERCENT),
            stop: None,
        }
    }

    /// Apply a request.
    pub fn apply(&mut self, a: Action) -> Effect {
        if let Some(kind) = self.stop {
            return match (kind, a) {
                // An e-stop during a controlled stop: the e-stop.
                (StopKind::Stop, Action::EStop) => {
                    self.stop = Some(StopKind::EStop);
                    Effect::Stop(StopKind::EStop)
                }
                (_, Action::Stop | Action::EStop) => Effect::Leave,
                _ => Effect::None,
            };
        }
        match a {
            Action::ToggleHold => self.set_hold(!self.hold),
            Action::Hold => self.set_hold(true),
            Action::Resume => self.set_hold(false),
            Action::Faster => {
                self.set_override(self.override_percent.saturating_add(OVERRIDE_STEP_PERCENT))
            }
            Action::Slower => {
                self.set_override(self.override_percent.saturating_sub(OVERRIDE_STEP_PERCENT))
            }
            Action::Override(p) => self.set_override(p),
            Action::Stop => {
                self.stop = Some(StopKind::Stop);
                Effect::Stop(StopKind::Stop)
            }
            Action::EStop => {
                self.stop = Some(StopKind::EStop);
                Effect::Stop(StopKind::EStop)
            }
        }
    }

    fn set_hold(&mut self, hold: bool) -> Effect {
        self.hold = hold;
        Effect::Send(if hold { HostMsg::Hold } else { HostMsg::Resume })
    }

    fn set_override(&mut self, p: u16) -> Effect {
        let p = p.clamp(OVERRIDE_MIN_PERCENT, OVERRIDE_MAX_PERCENT);
        if p == self.override_percent {
            return Effect::None;
        }
        self.override_percent = p;
        Effect::Send(HostMsg::Override { percent: p })
    }
}

/// When a scripted action fires.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Trigger {
    /// This long after streaming started.
    At(Duration),
    /// Once the controller reports this point (index in the path, from 1)
    /// reached.
    AtPoint(u32),
    /// This long after the previous action fired (or after the start).
    After(Duration),
}

/// One line of a script.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    /// When.
    pub trigger: Trigger,
    /// What.
    pub action: Action,
    /// Its line in the script, from 1.
    pub line: usize,
}

/// Timed operator actions, in order: each fires once its trigger holds
/// and every earlier one has fired.
///
/// ```text
/// # comments and blank lines are ignored
/// at 2.0 s: hold          # 2 s after streaming started
/// after 1 s: resume       # 1 s after the previous action
/// at point 800: override 50
/// at 5 s: override +10    # also: faster, slower, toggle
/// at 6 s: stop            # also: estop
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Script {
    steps: Vec<Step>,
    next: usize,
    last_fired: Duration,
}

fn parse_seconds(s: &str) -> Result<Duration, String> {
    let s = s.trim();
    let num = s
        .strip_suffix("ms")
        .map(|n| (n, 1e-3))
        .or_else(|| s.strip_suffix('s').map(|n| (n, 1.0)))
        .ok_or_else(|| format!("{s:?}: a time needs a unit (s or ms)"))?;
    let v: f64 = num
        .0
        .trim()
        .parse()
        .map_err(|_| format!("{:?} is not a number", num.0.trim()))?;
    if !(v.is_finite() && v >= 0.0 && v * num.1 < 1e6) {
        return Err(format!("{s:?}: out of range"));
    }
    Ok(Duration::from_secs_f64(v * num.1))
}

fn parse_action(s: &str) -> Result<Action, String> {
    let words: Vec<&str> = s.split_whitespace().collect();
    Ok(match words.as_slice() {
        ["hold"] => Action::Hold,
        ["resume"] => Action::Resume,
        ["toggle"] | ["space"] => Action::ToggleHold,
        ["faster"] | ["+"] => Action::Faster,
        ["slower"] | ["-"] => Action::Slower,
        ["stop"] => Action::Stop,
        ["estop"] | ["e-stop"] | ["!"] => Action::EStop,
        ["override", v] => {
            if let Some(d) = v.strip_prefix('+') {
                let d: u16 = d.parse().map_err(|_| format!("{v:?}: not a percent"))?;
                match d {
                    OVERRIDE_STEP_PERCENT => Action::Faster,
                    _ => return Err("override +N: only +10 (one key step)".into()),
                }
            } else if let Some(d) = v.strip_prefix('-') {
                let d: u16 = d.parse().map_err(|_| format!("{v:?}: not a percent"))?;
                match d {
                    OVERRIDE_STEP_PERCENT => Action::Slower,
                    _ => return Err("override -N: only -10 (one key step)".into()),
                }
            } else {
                let p: u16 = v
                    .trim_end_matches('%')
                    .parse()
                    .map_err(|_| format!("{v:?}: not a percent"))?;
                if !(OVERRIDE_MIN_PERCENT..=OVERRIDE_MAX_PERCENT).contains(&p) {
                    return Err(format!(
                        "override {p}: outside {OVERRIDE_MIN_PERCENT}-{OVERRIDE_MAX_PERCENT} %"
                    ));
                }
                Action::Override(p)
            }
        }
        _ => {
            return Err(format!(
            "{s:?}: unknown action (hold, resume, toggle, faster, slower, override N, stop, estop)"
        ))
        }
    })
}

impl Script {
    /// Parse a script; errors name the line.
    pub fn parse(text: &str) -> Result<Script, String> {
        let mut steps = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let s = raw.split('#').next().unwrap_or("").trim();
            if s.is_empty() {
                continue;
            }
            let err = |m: String| format!("line {line}: {m}");
            let (when, what) = s
                .split_once(':')
                .ok_or_else(|| err(format!("{s:?}: expected `at TIME: ACTION`")))?;
            let when = when.trim();
            let trigger = if let Some(n) = when.strip_prefix("at point") {
                let n: u32 = n
                    .trim()
                    .parse()
                    .map_err(|_| err(format!("{when:?}: expected `at point N`")))?;
                Trigger::AtPoint(n)
            } else if let Some(t) = when.strip_prefix("at") {
                Trigger::At(parse_seconds(t).map_err(err)?)
            } else if let Some(t) = when.strip_prefix("after") {
                Trigger::After(parse_seconds(t).map_err(err)?)
            } else {
                return Err(err(format!(
                    "{when:?}: expected `at T s`, `at point N` or `after T s`"
                )));
            };
            let action = parse_action(what.trim()).map_err(err)?;
            steps.push(Step {
                trigger,
                action,
                line,
            });
        }
        Ok(Script {
            steps,
            next: 0,
            last_fired: Duration::ZERO,
        })
    }

    /// The steps.
    pub fn steps(&self) -> &[Step] {
        &self.steps
    }

    /// Whether every step fired.
    pub fn is_done(&self) -> bool {
        self.next >= self.steps.len()
    }

    /// The actions due `elapsed` after streaming started, with the
    /// controller at `point_reached`.
    pub fn due(&mut self, elapsed: Duration, point_reached: u32) -> Vec<Action> {
        let mut out = Vec::new();
        while let Some(s) = self.steps.get(self.next) {
            let fire = match s.trigger {
                Trigger::At(t) => elapsed >= t,
                Trigger::AtPoint(n) => point_reached >= n,
                Trigger::After(d) => elapsed >= self.last_fired + d,
            };
            if !fire {
                break;
            }
            out.push(s.action);
            self.last_fired = elapsed;
            self.next += 1;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(code: KeyCode, m: KeyModifiers) -> KeyEvent {
        KeyEvent::new(code, m)
    }

    #[test]
    fn keys_map_to_actions() {
        let n = KeyModifiers::NONE;
        assert_eq!(
            from_key(&key(KeyCode::Char(' '), n)),
            Some(Action::ToggleHold)
        );
        assert_eq!(from_key(&key(KeyCode::Char('+'), n)), Some(Action::Faster));
        assert_eq!(
            from_key(&key(KeyCode::Char('+'), KeyModifiers::SHIFT)),
            Some(Action::Faster)
        );
        assert_eq!(from_key(&key(KeyCode::Char('-'), n)), Some(Action::Slower));
        assert_eq!(from_key(&key(KeyCode::Esc, n)), Some(Action::Stop));
        assert_eq!(
            from_key(&key(KeyCode::Char('c'), KeyModifiers::CONTROL)),
            Some(Action::Stop)
        );
        assert_eq!(from_key(&key(KeyCode::Char('c'), n)), None);
        assert_eq!(from_key(&key(KeyCode::Char('!'), n)), Some(Action::EStop));
        let mut release = key(KeyCode::Char(' '), n);
        release.kind = KeyEventKind::Release;
        assert_eq!(from_key(&release), None);
    }

    #[test]
    fn the_operator_toggles_hold_and_clamps_the_override() {
        let mut o = Operator::new(100);
        assert_eq!(o.apply(Action::ToggleHold), Effect::Send(HostMsg::Hold));
        assert_eq!(o.apply(Action::ToggleHold), Effect::Send(HostMsg::Resume));
        for _ in 0..9 {
            o.apply(Action::Faster);
        }
        assert_eq!(o.override_percent, 190);
        assert_eq!(
            o.apply(Action::Faster),
            Effect::Send(HostMsg::Override { percent: 200 })
        );
        assert_eq!(o.apply(Action::Faster), Effect::None, "at the top");
        assert_eq!(
            o.apply(Action::Override(5)),
            Effect::Send(HostMsg::Override { percent: 10 })
        );
        assert_eq!(o.apply(Action::Slower), Effect::None, "at the bottom");
        assert_eq!(
            Operator::new(0).override_percent,
            OVERRIDE_MIN_PERCENT,
            "a controller's 0 % (force loop) is clamped"
        );
    }

    #[test]
    fn a_stop_ends_every_other_request_and_a_second_one_leaves() {
        let mut o = Operator::new(100);
        assert_eq!(o.apply(Action::EStop), Effect::Stop(StopKind::EStop));
        assert_eq!(o.apply(Action::Hold), Effect::None);
        assert_eq!(o.apply(Action::Faster), Effect::None);
        assert_eq!(o.apply(Action::Stop), Effect::Leave);
        // An e-stop during a controlled stop goes through.
        let mut o = Operator::new(100);
        assert_eq!(o.apply(Action::Stop), Effect::Stop(StopKind::Stop));
        assert_eq!(o.apply(Action::EStop), Effect::Stop(StopKind::EStop));
        assert_eq!(o.apply(Action::EStop), Effect::Leave);
    }

    #[test]
    fn scripts_parse_and_fire_in_order() {
        let mut s = Script::parse(
            "# demo\nat 2.0 s: hold\n\nafter 500 ms: resume # comment\nat point 100: override 50\nat 1 s: override +10\nat 6s: stop\n",
        )
        .unwrap();
        assert_eq!(s.steps().len(), 5);
        assert_eq!(s.steps()[1].line, 4);
        let ms = Duration::from_millis;
        assert_eq!(s.due(ms(1000), 500), vec![]);
        assert_eq!(s.due(ms(2000), 0), vec![Action::Hold]);
        assert_eq!(s.due(ms(2400), 0), vec![]);
        assert_eq!(s.due(ms(2500), 0), vec![Action::Resume]);
        assert_eq!(s.due(ms(9000), 99), vec![], "waits for the point");
        // The point, then the overdue `at 1 s` and `at 6 s` at once.
        assert_eq!(
            s.due(ms(9000), 100),
            vec![Action::Override(50), Action::Faster, Action::Stop]
        );
        assert!(s.is_done());
    }

    #[test]
    fn script_errors_name_the_line() {
        for (text, want) in [
            ("at 1 s: hold\nat 2: resume\n", "line 2"),
            ("at 1 s hold\n", "line 1"),
            ("\n\nat 1 s: jump\n", "line 3"),
            ("at 1 s: override 500\n", "line 1"),
            ("at point x: hold\n", "line 1"),
            ("soon: hold\n", "line 1"),
            ("at 1 s: override +20\n", "line 1"),
        ] {
            let e = Script::parse(text).unwrap_err();
            assert!(e.starts_with(want), "{text:?}: {e}");
        }
    }
}
