//! The step engine: what a hardware timer's compare interrupt runs. Each
//! call hands out the next batch of pin edges and the time they are due;
//! the caller writes them when the timer reaches that time and says when
//! it did ([`StepEngine::done`]), then asks for the next batch.
//!
//! Each axis's step position follows its commanded position: the commanded
//! position (whole steps, [`super::plan`]) changes at exact crossing times
//! given by the tick plans, one window (tick) each; the engine emits a
//! rising step edge at each crossing (up to `early` before it, to share an
//! interrupt with nearby edges), a falling edge a pulse width later, and
//! keeps every minimum: pulse width, low time (equal to the pulse width),
//! direction setup before a rising edge, DIR changed only while the step
//! pin is inactive. A step the minimums hold back (a rate above
//! `1 / (2 · pulse)`, or a reversal right after a step) is carried, never
//! dropped: the axis owes it and emits it as soon as the minimums allow.
//! At every window end the shortfall is measured; a window ending short is
//! lag ([`StepReport`]).
//!
//! DIR is set as early as it is known: after the falling edge of the last
//! step one way, if the next crossing (this window's, or the next
//! window's, which the engine already holds) goes the other way, and at
//! power-up before the first step whatever the pin's level at reset.
//!
//! Windows are the engine's own clock: window `k + 1` starts exactly
//! `T` counts after window `k`, and at each window start the engine takes
//! the plan the tick queued, and the following one as lookahead. The tick
//! must queue plan `k + 1` before window `k` starts: the firmware starts
//! the first window 1.5 ticks after the first tick, so a tick may be up to
//! half a tick late. A window without a plan holds (counted,
//! `late_windows`); a plan whose start is not where the previous one ended
//! (a plan lost at the hand-over, or a jump beyond
//! [`super::plan::MAX_STEPS_PER_TICK`]) moves the commanded position
//! there, and the difference is lag.
//!
//! With the reversal filter on ([`super::config::StepConfig::reversal_filter_ns`]),
//! a step whose next crossing is a step back within the filter time is
//! dropped together with it (Klipper's `stepcompress_append`
//! rolls back the pending step on a direction change within
//! `SDS_FILTER_TIME`, `klippy/chelper/stepcompress.c`; here the engine
//! holds the next window's plan, so it sees the pair before emitting).

use super::config::Timing;
use super::plan::AxisPlan;
use super::queue::PlanRx;
use super::report::{StepReport, StepShared};

/// Pin levels to change: bit `i` is axis `i`'s step pin, bit `3 + i` its
/// direction pin (X, Y, Z = 0, 1, 2), electrical levels (polarity applied).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Edges {
    /// Pins to drive high.
    pub set: u8,
    /// Pins to drive low.
    pub clear: u8,
}

impl Edges {
    /// No change.
    pub const NONE: Edges = Edges { set: 0, clear: 0 };

    /// Whether nothing changes.
    pub const fn is_empty(&self) -> bool {
        self.set == 0 && self.clear == 0
    }

    #[inline(always)]
    const fn of(bit: u8, high: bool) -> Edges {
        if high {
            Edges { set: bit, clear: 0 }
        } else {
            Edges { set: 0, clear: bit }
        }
    }

    fn level(&mut self, bit: u8, high: bool) {
        if high {
            self.set |= bit;
        } else {
            self.clear |= bit;
        }
    }
}

/// The next batch: its edges and the timer count they are due at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Due {
    /// Timer count (wrapping).
    pub at: u32,
    /// What to write then.
    pub edges: Edges,
}

/// `a` is after `b` (wrapping counts, within ±2^31).
#[inline(always)]
fn after(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

/// The later of `a` and `b`.
#[inline(always)]
fn later(a: u32, b: u32) -> u32 {
    if after(a, b) {
        a
    } else {
        b
    }
}

/// How far ahead an idle axis's event is put (kept fresh by every window
/// change), counts.
const IDLE: u32 = 1 << 30;

/// `x − now`, 0 if `x` is not after `now`.
#[inline(always)]
fn until(x: u32, now: u32) -> u32 {
    let d = x.wrapping_sub(now) as i32;
    if d < 0 {
        0
    } else {
        d as u32
    }
}

/// An axis's crossings in one window, stepped one by one.
#[derive(Clone, Copy, Debug, Default)]
struct Crossings {
    left: u32,
    forward: bool,
    /// `forward` as a step: +1 or −1.
    step: i64,
    /// The next crossing's time: its exact time rounded up (absolute
    /// counts; the engine never emits one before its window's first
    /// count).
    at: u32,
    /// How far `at` was rounded up, in units of `1 / dq` counts.
    short: u64,
    interval: u32,
    interval_rem: u64,
    dq: u64,
}

impl Crossings {
    fn of(p: &AxisPlan, base: u32) -> Self {
        Crossings {
            left: p.steps,
            forward: p.forward,
            step: if p.forward { 1 } else { -1 },
            at: base.wrapping_add(p.first),
            short: p.first_short,
            interval: p.interval,
            interval_rem: p.interval_rem,
            dq: p.dq,
        }
    }

    /// `o`'s crossings, field by field (a whole-struct copy of this size
    /// becomes a `memcpy` call).
    #[inline(always)]
    fn set(&mut self, o: &Crossings) {
        self.left = o.left;
        self.forward = o.forward;
        self.step = o.step;
        self.at = o.at;
        self.short = o.short;
        self.interval = o.interval;
        self.interval_rem = o.interval_rem;
        self.dq = o.dq;
    }

    /// Past the next crossing.
    #[inline(always)]
    fn advance(&mut self) {
        self.left = self.left.saturating_sub(1);
        self.at = self.at.wrapping_add(self.interval);
        if self.short >= self.interval_rem {
            self.short -= self.interval_rem;
        } else {
            self.short = self
                .short
                .wrapping_add(self.dq)
                .wrapping_sub(self.interval_rem);
            self.at = self.at.wrapping_add(1);
        }
    }

    /// The step of a crossing (only while `left > 0`).
    #[inline(always)]
    fn sign(&self) -> i64 {
        self.step
    }
}

/// What an axis wants next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Want {
    /// Nothing until the plans change.
    Nothing,
    /// A step owed (its crossing already past), this way (`true`:
    /// forward).
    Owed(bool),
    /// The next crossing: direction, time, and whether it is in the next
    /// window.
    Cross(bool, u32, bool),
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
enum Kind {
    /// Nothing to do until the plans change.
    #[default]
    Idle,
    /// End the pulse.
    Fall,
    /// End the pulse and set DIR (`true`: forward).
    FallDir(bool),
    /// Set DIR.
    Dir(bool),
    /// A step for the next crossing, this window's.
    Rise,
    /// A step for the next crossing, the next window's (this one's are
    /// done; a batch late past the window's end may hold it together with
    /// the window change).
    RiseNext,
    /// A step owed (a crossing already past).
    RiseOwed,
}

/// An axis's next pin event: what, when at the earliest and at the latest,
/// and its edges.
#[derive(Clone, Copy, Debug, Default)]
struct Event {
    kind: Kind,
    edges: Edges,
    earliest: u32,
    latest: u32,
}

impl Event {
    /// The end of a pulse: at `f` at the earliest, and by a pulse width
    /// later (to share a batch) unless the next step needs it by `bound`.
    #[inline(always)]
    fn fall(kind: Kind, edges: Edges, f: u32, pulse: u32, bound: u32) -> Event {
        Event {
            kind,
            edges,
            earliest: f,
            latest: later(f, earlier(f.wrapping_add(pulse), bound)),
        }
    }

    /// A step for the crossing at `c`: not before `ready` (the minimums),
    /// `early` before `c` or its window's first count; at `c` at the latest
    /// (or as soon as it may, if later).
    #[inline(always)]
    fn rise(kind: Kind, edges: Edges, c: u32, ready: u32, early: u32, window_start: u32) -> Event {
        let earliest = later(
            ready,
            later(c.wrapping_sub(early), window_start.wrapping_add(1)),
        );
        Event {
            kind,
            edges,
            earliest,
            latest: later(c, earliest),
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Axis {
    /// Steps emitted (rising edges, signed by DIR).
    pos: i64,
    /// Steps owed: the commanded position as of the last crossing passed,
    /// minus `pos`.
    owed: i64,
    /// The DIR pin's direction (`None`: not driven since reset).
    dir: Option<bool>,
    /// The step pin is active.
    high: bool,
    /// When the active pulse may end.
    fall_at: u32,
    /// Earliest next rising edge (low time, direction setup).
    rise_ok: u32,
    /// This window's crossings.
    cur: Crossings,
    /// The next window's crossings (none unless the engine holds its plan).
    nxt: Crossings,
    /// The next plan's start, whole steps.
    nxt_start: i64,
    /// What the reversal filter took from the next window in advance.
    nxt_consumed: i64,
}

/// The earlier of `a` and `b`.
#[inline(always)]
fn earlier(a: u32, b: u32) -> u32 {
    if after(a, b) {
        b
    } else {
        a
    }
}

impl Axis {
    /// This window's crossings.
    #[inline(always)]
    fn cur(&self) -> &Crossings {
        &self.cur
    }

    #[inline(always)]
    fn cur_mut(&mut self) -> &mut Crossings {
        &mut self.cur
    }

    /// The next window's crossings.
    #[inline(always)]
    fn nxt(&self) -> &Crossings {
        &self.nxt
    }

    #[inline(always)]
    fn nxt_mut(&mut self) -> &mut Crossings {
        &mut self.nxt
    }

    /// What the axis wants next; the reversal filter drops pairs on the
    /// way (counted in `filtered`).
    #[inline(always)]
    fn want(&mut self, filter: u32, have_next: bool, filtered: &mut u32) -> Want {
        if self.owed != 0 {
            return Want::Owed(self.owed > 0);
        }
        loop {
            if self.cur().left > 0 {
                let c = self.cur().at;
                if filter > 0
                    && self.cur().left == 1
                    && have_next
                    && self.nxt().left > 0
                    && self.nxt().forward != self.cur().forward
                    && self.nxt().at.wrapping_sub(c) < filter
                {
                    self.cur_mut().advance();
                    self.nxt_consumed += self.nxt().sign();
                    self.nxt_mut().advance();
                    *filtered = filtered.wrapping_add(1);
                    continue;
                }
                return Want::Cross(self.cur().forward, c, false);
            }
            if have_next && self.nxt().left > 0 {
                return Want::Cross(self.nxt().forward, self.nxt().at, true);
            }
            return Want::Nothing;
        }
    }

    /// The next event of axis `i` (bit `1 << i`), `now` the time of the
    /// last write, `end` the running window's end. The common case first:
    /// nothing owed, the next crossing in this window and the way DIR
    /// points, and no reversal filter to consult (only the last crossing of
    /// a window can start a pair).
    #[inline(always)]
    fn event(
        &mut self,
        bit: u8,
        tm: &Timing,
        now: u32,
        end: u32,
        have_next: bool,
        filtered: &mut u32,
    ) -> Event {
        let c = self.cur().at;
        if self.owed == 0
            && self.cur().left > 0
            && self.dir == Some(self.cur().forward)
            && (tm.filter == 0 || self.cur().left > 1)
        {
            let step_on = tm.invert_step & bit == 0;
            return if self.high {
                let bound = c.wrapping_sub(tm.early).wrapping_sub(tm.low);
                Event::fall(
                    Kind::Fall,
                    Edges::of(bit, !step_on),
                    self.fall_at,
                    tm.pulse,
                    bound,
                )
            } else {
                Event::rise(
                    Kind::Rise,
                    Edges::of(bit, step_on),
                    c,
                    later(self.rise_ok, now),
                    tm.early,
                    end.wrapping_sub(tm.window),
                )
            };
        }
        self.event_general(bit, tm, now, end, have_next, filtered)
    }

    /// [`Self::event`] in every case.
    #[inline(never)]
    fn event_general(
        &mut self,
        bit: u8,
        tm: &Timing,
        now: u32,
        end: u32,
        have_next: bool,
        filtered: &mut u32,
    ) -> Event {
        let want = self.want(tm.filter, have_next, filtered);
        let step_on = tm.invert_step & bit == 0;
        let dir_pin = bit << 3;
        let dir_high = |d: bool| d != (tm.invert_dir & bit != 0);
        let mut edges = Edges::NONE;
        if self.high {
            // The pulse ends at `fall_at`, or up to a pulse width later to
            // share a batch, as long as the next step is not held up.
            let f = self.fall_at;
            edges.level(bit, !step_on);
            let (kind, bound) = match want {
                Want::Cross(d, c, _) if self.dir == Some(d) => {
                    (Kind::Fall, c.wrapping_sub(tm.early).wrapping_sub(tm.low))
                }
                Want::Cross(d, c, _) => {
                    edges.level(dir_pin, dir_high(d));
                    let hold = if tm.setup > tm.low { tm.setup } else { tm.low };
                    (
                        Kind::FallDir(d),
                        c.wrapping_sub(tm.early).wrapping_sub(hold),
                    )
                }
                Want::Owed(d) if self.dir != Some(d) => {
                    edges.level(dir_pin, dir_high(d));
                    (Kind::FallDir(d), f)
                }
                Want::Owed(_) => (Kind::Fall, f),
                Want::Nothing => (Kind::Fall, f.wrapping_add(tm.pulse)),
            };
            return Event::fall(kind, edges, f, tm.pulse, bound);
        }
        let (d, cross) = match want {
            Want::Nothing => return Event::default(),
            Want::Owed(d) => (d, None),
            Want::Cross(d, c, next) => (d, Some((c, next))),
        };
        if self.dir != Some(d) {
            // DIR now (any batch takes it), at the latest `setup` before
            // the step.
            edges.level(dir_pin, dir_high(d));
            let latest = match cross {
                Some((c, _)) => later(now, c.wrapping_sub(tm.early).wrapping_sub(tm.setup)),
                None => now,
            };
            return Event {
                kind: Kind::Dir(d),
                edges,
                earliest: now,
                latest,
            };
        }
        edges.level(bit, step_on);
        let ready = later(self.rise_ok, now);
        match cross {
            None => Event {
                kind: Kind::RiseOwed,
                edges,
                earliest: ready,
                latest: ready,
            },
            Some((c, next_window)) => {
                // Never before its own window: a step belongs to the tick
                // whose end it precedes.
                let (kind, window_start) = if next_window {
                    (Kind::RiseNext, end)
                } else {
                    (Kind::Rise, end.wrapping_sub(tm.window))
                };
                Event::rise(kind, edges, c, ready, tm.early, window_start)
            }
        }
    }

    /// `kind` was written at `t`.
    #[inline(always)]
    fn apply(&mut self, kind: Kind, tm: &Timing, t: u32) {
        match kind {
            Kind::Idle => {}
            Kind::Fall => {
                self.high = false;
                self.rise_ok = later(self.rise_ok, t.wrapping_add(tm.low));
            }
            Kind::FallDir(d) => {
                self.high = false;
                self.dir = Some(d);
                let hold = if tm.setup > tm.low { tm.setup } else { tm.low };
                self.rise_ok = later(self.rise_ok, t.wrapping_add(hold));
            }
            Kind::Dir(d) => {
                self.dir = Some(d);
                self.rise_ok = later(self.rise_ok, t.wrapping_add(tm.setup));
            }
            Kind::Rise => {
                self.high = true;
                self.fall_at = t.wrapping_add(tm.pulse);
                self.pos += self.cur().sign();
                self.cur_mut().advance();
            }
            Kind::RiseNext => {
                self.high = true;
                self.fall_at = t.wrapping_add(tm.pulse);
                let s = self.nxt().sign();
                self.pos += s;
                self.nxt_consumed += s;
                self.nxt_mut().advance();
            }
            Kind::RiseOwed => {
                self.high = true;
                self.fall_at = t.wrapping_add(tm.pulse);
                let s = if self.dir == Some(true) { 1 } else { -1 };
                self.pos += s;
                self.owed -= s;
            }
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Batch {
    at: u32,
    edges: Edges,
    /// Axes whose event is in the batch.
    axes: u8,
    rollover: bool,
}

/// The step engine (module docs).
pub struct StepEngine<'a> {
    t: Timing,
    plans: PlanRx<'a>,
    shared: &'a StepShared,
    axes: [Axis; 3],
    /// Each axis's next event (an idle one far ahead).
    events: [Event; 3],
    /// End of the window running (start of the next), counts.
    window_end: u32,
    /// The next window's plan is in `Axis::nxt`.
    have_next: bool,
    /// When the last batch was written.
    now: u32,
    pending: Batch,
    pending_valid: bool,
    report: StepReport,
    /// Stopped by the tick ([`Self::poll_halt`]): plans are dropped.
    halted: bool,
    /// Per axis, the edges of a step's rise and of its fall.
    rise_edges: [Edges; 3],
    fall_edges: [Edges; 3],
    /// `early + low`: a falling edge's latest time before the next
    /// crossing.
    early_low: u32,
    /// Plans taken from the queue (wrapping; for cost figures and models).
    plans_taken: u32,
}

impl<'a> StepEngine<'a> {
    /// At `start` (whole steps per axis), DIR unknown, the step pins
    /// inactive; the first window starts at `first_window` (timer counts),
    /// nothing moves before.
    pub fn new(
        timing: Timing,
        plans: PlanRx<'a>,
        shared: &'a StepShared,
        start: [i64; 3],
        first_window: u32,
    ) -> Self {
        let now = first_window.wrapping_sub(timing.window);
        let axes = start.map(|s| Axis {
            pos: s,
            rise_ok: now,
            fall_at: now,
            nxt_start: s,
            ..Axis::default()
        });
        StepEngine {
            t: timing,
            plans,
            shared,
            axes,
            events: [Event {
                earliest: now.wrapping_add(IDLE),
                latest: now.wrapping_add(IDLE),
                ..Event::default()
            }; 3],
            window_end: first_window,
            have_next: false,
            now,
            pending: Batch::default(),
            pending_valid: false,
            report: StepReport::default(),
            halted: false,
            rise_edges: [0, 1, 2].map(|i| Edges::of(1 << i, timing.invert_step & 1 << i == 0)),
            fall_edges: [0, 1, 2].map(|i| Edges::of(1 << i, timing.invert_step & 1 << i != 0)),
            early_low: timing.early.wrapping_add(timing.low),
            plans_taken: 0,
        }
    }

    /// Take a stop or a resume the tick asked for ([`StepShared`]); call
    /// before writing a batch. A stop drops every crossing and step owed
    /// and every plan queued, now: only the pulses already started end
    /// (keeping their width), the axes stand where they are, and that
    /// position is published; until the tick resumes, plans are dropped.
    /// Returns whether the batch from [`Self::due`] changed (ask again).
    pub fn poll_halt(&mut self) -> bool {
        match self.shared.halt_request() {
            Some(seq) if !self.halted => {
                self.halted = true;
                for a in self.axes.iter_mut() {
                    a.owed = 0;
                    a.cur = Crossings::default();
                    a.nxt = Crossings::default();
                    a.nxt_consumed = 0;
                    a.nxt_start = a.pos;
                }
                self.have_next = false;
                self.drain();
                self.pending_valid = false;
                self.refresh_mask(0b111);
                self.shared.ack_halt(seq, self.position());
                true
            }
            None if self.halted => {
                self.halted = false;
                false
            }
            _ => false,
        }
    }

    /// Whether the engine is stopped ([`Self::poll_halt`]).
    pub fn halted(&self) -> bool {
        self.halted
    }

    fn drain(&mut self) {
        while self.plans.ready() {
            self.plans.pop();
        }
    }

    /// The levels the step pins rest at (set once at start-up).
    pub fn idle_edges(&self) -> Edges {
        Edges {
            set: self.t.invert_step & 0b111,
            clear: !self.t.invert_step & 0b111,
        }
    }

    /// The settings in counts.
    pub fn timing(&self) -> &Timing {
        &self.t
    }

    /// Steps emitted per axis.
    pub fn position(&self) -> [i64; 3] {
        self.axes.map(|a| a.pos)
    }

    /// End of the window running, timer counts.
    pub fn window_end(&self) -> u32 {
        self.window_end
    }

    /// The figures so far.
    pub fn report(&self) -> StepReport {
        self.report
    }

    /// The next batch (computed once, then the same until [`Self::done`]).
    pub fn due(&mut self) -> Due {
        if !self.pending_valid {
            self.plan_batch();
            self.pending_valid = true;
        }
        Due {
            at: self.pending.at,
            edges: self.pending.edges,
        }
    }

    /// The batch from [`Self::due`] was written at timer count `t` (its
    /// due time or later: a reading taken after the write keeps every
    /// minimum).
    pub fn done(&mut self, t: u32) {
        if !self.pending_valid {
            return;
        }
        self.pending_valid = false;
        let b = self.pending;
        let t = later(t, b.at);
        self.now = t;
        if b.axes & 1 != 0 {
            self.step_axis::<0>(t);
        }
        if b.axes & 2 != 0 {
            self.step_axis::<1>(t);
        }
        if b.axes & 4 != 0 {
            self.step_axis::<2>(t);
        }
        // A window stepped with the next plan here changes when there is
        // time to spare ([`Self::plan_batch`]).
        if b.rollover && !(self.have_next && self.window_stepped()) {
            self.rollover();
        }
    }

    /// Axis `I`'s event was written at `t`: apply it, work out the next.
    /// The two transitions of steady stepping (a step's rising edge, and
    /// its falling edge, with the next crossing in this window and the way
    /// DIR points, nothing owed, no reversal filter to consult) are worked
    /// out here, in place; every other case goes the general way
    /// ([`Self::next_event`]).
    #[inline(always)]
    fn step_axis<const I: usize>(&mut self, t: u32) {
        let tm = &self.t;
        let ev = &mut self.events[I];
        let a = &mut self.axes[I];
        let kind = ev.kind;
        match kind {
            Kind::Rise => {
                a.high = true;
                let f = t.wrapping_add(tm.pulse);
                a.fall_at = f;
                a.pos += a.cur.sign();
                a.cur.advance();
                let c = &a.cur;
                if c.left > 0 && (tm.filter == 0 || c.left > 1) && a.dir == Some(c.forward) {
                    let bound = c.at.wrapping_sub(self.early_low);
                    *ev = Event::fall(Kind::Fall, self.fall_edges[I], f, tm.pulse, bound);
                    return;
                }
            }
            Kind::Fall => {
                a.high = false;
                let ok = later(a.rise_ok, t.wrapping_add(tm.low));
                a.rise_ok = ok;
                let c = &a.cur;
                if a.owed == 0
                    && c.left > 0
                    && (tm.filter == 0 || c.left > 1)
                    && a.dir == Some(c.forward)
                {
                    *ev = Event::rise(
                        Kind::Rise,
                        self.rise_edges[I],
                        c.at,
                        later(ok, t),
                        tm.early,
                        self.window_end.wrapping_sub(tm.window),
                    );
                    return;
                }
            }
            _ => a.apply(kind, tm, t),
        }
        self.next_event::<I>(kind, t);
    }

    /// Axis `I`'s next event after `kind` was written at `t` (and applied),
    /// in every case.
    #[inline(never)]
    fn next_event<const I: usize>(&mut self, kind: Kind, t: u32) {
        let (end, have_next) = (self.window_end, self.have_next);
        let a = &mut self.axes[I];
        let tm = &self.t;
        let bit = 1u8 << I;
        let step_on = tm.invert_step & bit == 0;
        // The next crossing, this window's or (none left) the next's; with
        // the reversal filter on, a window's last crossing goes the general
        // way.
        let plain = tm.filter == 0 || a.cur().left > 1;
        let next = if a.cur().left > 0 {
            Some((a.cur().at, a.cur().forward, false))
        } else if have_next && a.nxt().left > 0 {
            Some((a.nxt().at, a.nxt().forward, true))
        } else {
            None
        };
        let e = match (kind, next) {
            (Kind::Rise | Kind::RiseNext, Some((c, fwd, _))) if plain && a.dir == Some(fwd) => {
                let bound = c.wrapping_sub(tm.early).wrapping_sub(tm.low);
                Event::fall(
                    Kind::Fall,
                    Edges::of(bit, !step_on),
                    a.fall_at,
                    tm.pulse,
                    bound,
                )
            }
            (Kind::Fall, Some((c, fwd, next_window)))
                if plain && a.owed == 0 && a.dir == Some(fwd) =>
            {
                let (kind, window_start) = if next_window {
                    (Kind::RiseNext, end)
                } else {
                    (Kind::Rise, end.wrapping_sub(tm.window))
                };
                let edges = Edges::of(bit, step_on);
                Event::rise(kind, edges, c, later(a.rise_ok, t), tm.early, window_start)
            }
            _ => a.event(bit, tm, t, end, have_next, &mut self.report.filtered_pairs),
        };
        self.set_event::<I>(e);
    }

    /// Work axis `I`'s next event out anew.
    fn refresh<const I: usize>(&mut self) {
        let (now, end, have_next) = (self.now, self.window_end, self.have_next);
        let e = self.axes[I].event(
            1 << I,
            &self.t,
            now,
            end,
            have_next,
            &mut self.report.filtered_pairs,
        );
        self.set_event::<I>(e);
    }

    /// [`Self::refresh`] for the axes in `mask`.
    fn refresh_mask(&mut self, mask: u8) {
        if mask & 1 != 0 {
            self.refresh::<0>();
        }
        if mask & 2 != 0 {
            self.refresh::<1>();
        }
        if mask & 4 != 0 {
            self.refresh::<2>();
        }
    }

    #[inline(always)]
    fn set_event<const I: usize>(&mut self, mut e: Event) {
        if e.kind == Kind::Idle {
            e.earliest = self.now.wrapping_add(IDLE);
            e.latest = e.earliest;
        }
        self.events[I] = e;
    }

    /// New step settings `timing` (the same window length) at `start`
    /// (whole steps per axis): the engine built anew on its queue, its
    /// figures kept, DIR unknown again (set before the next step; the step
    /// pins' rest levels are [`Self::idle_edges`], for the caller to write).
    /// For a machine at rest: a step owed or planned is dropped, and so
    /// are the plans queued, with their windows: the next window is the
    /// one of the plan the tick queues next.
    pub fn reconfigure(&mut self, timing: Timing, start: [i64; 3]) {
        let mut first = self.window_end;
        if self.have_next {
            first = first.wrapping_add(self.t.window);
        }
        while self.plans.ready() {
            self.plans.pop();
            first = first.wrapping_add(self.t.window);
        }
        let held = self.plans.handle();
        let plans = core::mem::replace(&mut self.plans, held);
        let (report, taken) = (self.report, self.plans_taken);
        *self = Self::new(timing, plans, self.shared, start, first);
        self.report = report;
        self.plans_taken = taken;
    }

    /// Software stepping: every batch due up to `limit` written through
    /// `out` (edges, time) at its due time.
    pub fn run_until(&mut self, limit: u32, mut out: impl FnMut(Edges, u32)) {
        loop {
            let d = self.due();
            if after(d.at, limit) {
                return;
            }
            out(d.edges, d.at);
            self.done(d.at);
        }
    }

    /// Take the next window's plan if the tick has queued it, and update
    /// the axes whose next event may look at it (one crossing or none left
    /// in this window).
    fn pull(&mut self) -> bool {
        if self.halted {
            self.drain();
            return false;
        }
        if self.have_next || !self.plans.ready() {
            return false;
        }
        let base = self.window_end;
        let mask =
            self.take_axis::<0>(base) | self.take_axis::<1>(base) | self.take_axis::<2>(base);
        self.plans.pop();
        self.plans_taken = self.plans_taken.wrapping_add(1);
        self.have_next = true;
        self.refresh_mask(mask);
        true
    }

    /// Axis `I` of the plan at the queue's head as the next window's
    /// crossings (the window starting at `base`); its bit if its next
    /// event may look at them (one crossing or none left in this window).
    #[inline(always)]
    fn take_axis<const I: usize>(&mut self, base: u32) -> u8 {
        let p = self.plans.axis::<I>();
        let a = &mut self.axes[I];
        a.nxt.set(&Crossings::of(&p, base));
        a.nxt_start = p.start;
        a.nxt_consumed = 0;
        ((a.cur.left <= 1) as u8) << I
    }

    /// The window ends: the next plan's crossings become the running ones
    /// (their events, already worked out with them as lookahead, stand),
    /// and the shortfall is measured.
    fn rollover(&mut self) {
        // Stopped, a window without a plan is no late tick.
        let late = !self.have_next && !self.pull() && !self.halted;
        let moved =
            self.roll_axis::<0>(late) | self.roll_axis::<1>(late) | self.roll_axis::<2>(late);
        let lag = self.axes[0]
            .owed
            .unsigned_abs()
            .max(self.axes[1].owed.unsigned_abs())
            .max(self.axes[2].owed.unsigned_abs());
        self.have_next = false;
        let r = &mut self.report;
        if late {
            r.late_windows = r.late_windows.wrapping_add(1);
        }
        let lag = lag.min(u32::MAX as u64) as u32;
        if lag > 0 {
            r.lag_ticks = r.lag_ticks.wrapping_add(1);
            r.lag_max_steps = r.lag_max_steps.max(lag);
        }
        r.lag_now_steps = lag;
        self.window_end = self.window_end.wrapping_add(self.t.window);
        self.shared.publish(&self.report);
        // Axes whose position moved (owed steps, a gap) or that ran without
        // lookahead work out anew; idle ones only have their far-off time
        // renewed (their event was worked out with this window's plan as
        // lookahead).
        let far = self.now.wrapping_add(IDLE);
        for e in self.events.iter_mut() {
            if e.kind == Kind::Idle {
                e.earliest = far;
                e.latest = far;
            }
        }
        let refresh = if late { 0b111 } else { moved };
        if refresh != 0 {
            self.refresh_mask(refresh);
        }
    }

    /// Axis `I` into the next window; its bit if its position moved.
    #[inline(always)]
    fn roll_axis<const I: usize>(&mut self, late: bool) -> u8 {
        let now = self.now;
        let a = &mut self.axes[I];
        // Crossings of the ending window not yet stepped are owed.
        let mut moved = false;
        while a.cur().left > 0 {
            a.owed += a.cur().sign();
            a.cur_mut().advance();
            moved = true;
        }
        if late {
            *a.cur_mut() = Crossings::default();
        } else {
            // Where the plan starts is the commanded position: a gap (a plan
            // lost or capped) is moved over and shows as lag.
            let expected = a.pos + a.owed - a.nxt_consumed;
            if expected != a.nxt_start {
                a.owed += a.nxt_start - expected;
                moved = true;
            }
            let n = a.nxt;
            a.cur.set(&n);
            a.nxt.left = 0;
            a.nxt_consumed = 0;
            // A step waiting for the next window's crossing now waits for
            // this window's.
            if self.events[I].kind == Kind::RiseNext {
                self.events[I].kind = Kind::Rise;
            }
        }
        // Keep the minimums' times within reach of wrapping compares.
        a.rise_ok = later(a.rise_ok, now);
        (moved as u8) << I
    }

    /// Everything of the running window is stepped: no crossing left and
    /// nothing owed (its end count can no longer change).
    pub fn window_stepped(&self) -> bool {
        let [a0, a1, a2] = &self.axes;
        a0.cur.left | a1.cur.left | a2.cur.left == 0 && a0.owed | a1.owed | a2.owed == 0
    }

    /// Plans taken from the queue so far (wrapping).
    pub fn plans_taken(&self) -> u32 {
        self.plans_taken
    }

    /// Time to spare before the axes' next edges, counts from `now`: the
    /// least of each axis's latest time less the batches before it (one
    /// per axis due earlier, [`Timing::batch`]), 0 if past.
    #[inline(always)]
    fn slack(&self, now: u32) -> u32 {
        let [e0, e1, e2] = &self.events;
        let (mut a, mut b, mut c) = (
            until(e0.latest, now),
            until(e1.latest, now),
            until(e2.latest, now),
        );
        if a > b {
            core::mem::swap(&mut a, &mut b);
        }
        if b > c {
            core::mem::swap(&mut b, &mut c);
        }
        if a > b {
            core::mem::swap(&mut a, &mut b);
        }
        let batch = self.t.batch;
        a.min(b.saturating_sub(batch))
            .min(c.saturating_sub(2 * batch))
    }

    fn plan_batch(&mut self) {
        // Once every crossing of the running window is stepped (nothing owed)
        // and the next plan is here, nothing can change the count at the
        // window's end any more: the window change may come at any moment
        // from then until a quarter of the next window, and it comes when
        // the timer has time to spare before the next edge, so that it never
        // holds a step up. Until then the next window's steps go out on its
        // plan held as lookahead (`RiseNext`).
        let now = self.now;
        let mut defer = 0;
        let mut rolled = false;
        if self.have_next && self.window_stepped() && until(self.window_end, now) < self.t.window {
            let grace = self.t.window / 4;
            let deadline = self.window_end.wrapping_add(grace);
            if self.slack(now) >= self.t.window_slack || !after(deadline, now) {
                self.rollover();
                rolled = true;
            } else {
                defer = grace;
            }
        }
        self.compute_batch(defer);
        // The next plan is taken when the timer has a moment to spare (or
        // half a window before it is needed), so that its copy never holds
        // up a step; right after a window change only with time for both.
        if !self.have_next && self.plans.ready() {
            let now = self.now;
            let need = if rolled {
                self.t.pull_slack + self.t.window_slack
            } else {
                self.t.pull_slack
            };
            let spare = self.slack(now) >= need;
            let needed = until(self.window_end, now) < self.t.window / 2;
            if (spare || needed) && self.pull() {
                self.compute_batch(0);
            }
        }
    }

    /// The next batch; `defer`: counts past the window's end its change
    /// may wait (the window stepped, the next plan held).
    #[inline(always)]
    fn compute_batch(&mut self, defer: u32) {
        let now = self.now;
        // Signed counts from now (every time kept within ±2^31 of it);
        // `wait` is the least of them, at least 0.
        let ahead = |x: u32| x.wrapping_sub(now) as i32;
        let to_end = ahead(self.window_end.wrapping_add(defer));
        let half = (self.t.window / 2) as i32;
        // Without lookahead (start-up, or a late tick) look again in half a
        // tick rather than at the window's end.
        let (cap, rollover_ok) = if !self.have_next && to_end > half {
            (half, false)
        } else {
            (to_end, true)
        };
        let [e0, e1, e2] = &self.events;
        let wait = cap
            .min(ahead(e0.latest))
            .min(ahead(e1.latest))
            .min(ahead(e2.latest))
            .max(0);
        let mut b = Batch {
            at: now.wrapping_add(wait as u32),
            rollover: rollover_ok && to_end <= wait,
            ..Batch::default()
        };
        let due = |e: &Event| ahead(e.earliest) <= wait;
        if due(e0) {
            b.axes |= 1;
            b.edges.set |= e0.edges.set;
            b.edges.clear |= e0.edges.clear;
        }
        if due(e1) {
            b.axes |= 2;
            b.edges.set |= e1.edges.set;
            b.edges.clear |= e1.edges.clear;
        }
        if due(e2) {
            b.axes |= 4;
            b.edges.set |= e2.edges.set;
            b.edges.clear |= e2.edges.clear;
        }
        self.pending = b;
    }
}
