//! Step/direction outputs for three axes on `embedded-hal` pins: the motion
//! code hands over position setpoints and never touches the chip.
//!
//! Each tick the setpoint (I32F32 mm) becomes a whole step count
//! (`floor(mm × steps/mm)`); the difference is emitted as pulses, direction
//! first. Pulses are emitted back to back in the tick (a burst of at most
//! [`MAX_STEPS_PER_TICK`] per axis; more are carried to the next tick and
//! counted in [`Axes::lag_events`]). That suits QEMU and drivers with short
//! minimum pulse widths; a board whose drivers need microsecond pulses
//! spread over the tick should drive step pins from a timer (a new
//! [`StepOutput`] in its board file).

use embedded_hal::digital::OutputPin;
use fuzzy_core::units::Point3Mm;

use crate::settings::MAX_STEPS_PER_TICK;

/// Something that can take a position setpoint per tick.
pub trait StepOutput {
    /// Move to `pos` (mm).
    fn update(&mut self, pos: Point3Mm);
}

/// One axis: step and direction pins and its position in steps.
pub struct Axis<S, D> {
    step: S,
    dir: D,
    steps: i64,
    /// The direction the DIR pin is set to; `None` until the first step,
    /// which sets it whatever the pin's level at reset.
    forward: Option<bool>,
}

/// Three axes with the same steps/mm.
pub struct Axes<S, D> {
    axes: [Axis<S, D>; 3],
    steps_per_mm: i64,
    lag_events: u32,
}

impl<S: OutputPin, D: OutputPin> Axes<S, D> {
    /// Axes X, Y, Z at `start` (mm), `steps_per_mm`.
    pub fn new(pins: [(S, D); 3], steps_per_mm: u32, start: Point3Mm) -> Self {
        let spm = steps_per_mm as i64;
        let b = start.to_bits();
        let mut i = 0;
        let axes = pins.map(|(step, dir)| {
            let steps = Self::to_steps(b[i.min(2)], spm);
            i += 1;
            Axis {
                step,
                dir,
                steps,
                forward: None,
            }
        });
        Axes {
            axes,
            steps_per_mm: spm,
            lag_events: 0,
        }
    }

    /// `floor(mm × steps/mm)` for I32F32 bits (no overflow within ±2^31
    /// mm and 2^31 steps/mm: the product is done in 128 bits).
    fn to_steps(bits: i64, spm: i64) -> i64 {
        ((bits as i128 * spm as i128) >> 32) as i64
    }

    /// Ticks on which an axis had more steps than one burst may hold.
    pub fn lag_events(&self) -> u32 {
        self.lag_events
    }

    /// Each axis's position, steps.
    pub fn steps(&self) -> [i64; 3] {
        [self.axes[0].steps, self.axes[1].steps, self.axes[2].steps]
    }
}

impl<S: OutputPin, D: OutputPin> StepOutput for Axes<S, D> {
    fn update(&mut self, pos: Point3Mm) {
        let spm = self.steps_per_mm;
        let mut lagged = false;
        for (axis, bits) in self.axes.iter_mut().zip(pos.to_bits()) {
            let want = Self::to_steps(bits, spm);
            let diff = want - axis.steps;
            if diff == 0 {
                continue;
            }
            let forward = diff > 0;
            if axis.forward != Some(forward) {
                // Pin errors cannot be reported from a tick: the board's
                // pins are infallible (`Infallible`), others are ignored.
                let _ = if forward {
                    axis.dir.set_high()
                } else {
                    axis.dir.set_low()
                };
                axis.forward = Some(forward);
            }
            let mut n = diff.unsigned_abs();
            if n > MAX_STEPS_PER_TICK as u64 {
                n = MAX_STEPS_PER_TICK as u64;
                lagged = true;
            }
            for _ in 0..n {
                let _ = axis.step.set_high();
                let _ = axis.step.set_low();
            }
            axis.steps += if forward { n as i64 } else { -(n as i64) };
        }
        if lagged {
            self.lag_events = self.lag_events.wrapping_add(1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::convert::Infallible;
    use std::cell::RefCell;
    use std::rc::Rc;

    /// Pin edges in order: (axis, pin, level), pin 0 = step, 1 = dir.
    type Log = Rc<RefCell<Vec<(usize, u8, bool)>>>;

    struct Rec {
        log: Log,
        axis: usize,
        pin: u8,
    }

    impl embedded_hal::digital::ErrorType for Rec {
        type Error = Infallible;
    }

    impl OutputPin for Rec {
        fn set_low(&mut self) -> Result<(), Infallible> {
            self.log.borrow_mut().push((self.axis, self.pin, false));
            Ok(())
        }
        fn set_high(&mut self) -> Result<(), Infallible> {
            self.log.borrow_mut().push((self.axis, self.pin, true));
            Ok(())
        }
    }

    fn axes(log: &Log, spm: u32) -> Axes<Rec, Rec> {
        let pins = [0, 1, 2].map(|axis| {
            let pin = |pin| Rec {
                log: log.clone(),
                axis,
                pin,
            };
            (pin(0), pin(1))
        });
        Axes::new(pins, spm, Point3Mm::ORIGIN)
    }

    /// The position each axis's pulses say it is at, counting a rising
    /// step edge as a step in the direction the DIR pin then shows
    /// (unknown DIR: a failure).
    fn replay(log: &Log) -> [i64; 3] {
        let mut dir: [Option<bool>; 3] = [None; 3];
        let mut at = [0i64; 3];
        for &(axis, pin, level) in log.borrow().iter() {
            match (pin, level) {
                (1, l) => dir[axis] = Some(l),
                (0, true) => {
                    let d = dir[axis].expect("a step before DIR was ever set");
                    at[axis] += if d { 1 } else { -1 };
                }
                _ => {}
            }
        }
        at
    }

    fn mm(x: f64, y: f64, z: f64) -> Point3Mm {
        Point3Mm::from_f64(x, y, z).unwrap()
    }

    #[test]
    fn the_first_move_of_each_axis_sets_dir_before_stepping() {
        for (first, want) in [(10.0, 1000), (-10.0, -1000)] {
            let log = Log::default();
            let mut a = axes(&log, 100);
            // 10 mm at 100 steps/mm in 0.5 mm moves (within a tick's burst).
            for k in 1..=20 {
                let x = first * k as f64 / 20.0;
                a.update(mm(x, -x, x / 2.0));
            }
            assert_eq!(replay(&log), [want, -want, want / 2]);
            assert_eq!(a.steps(), [want, -want, want / 2]);
        }
    }

    #[test]
    fn back_and_forth_ends_where_commanded() {
        let log = Log::default();
        let mut a = axes(&log, 100);
        let mut x = 0.0f64;
        for target in [10.0, -10.0, 10.0, 2.5] {
            while (x - target).abs() > 1e-9 {
                x += (target - x).clamp(-0.5, 0.5);
                a.update(mm(x, 0.0, 0.0));
            }
        }
        assert_eq!(replay(&log)[0], 250);
        assert_eq!(a.steps()[0], 250);
        assert_eq!(a.lag_events(), 0);
    }

    #[test]
    fn steps_beyond_a_burst_are_carried_and_counted() {
        let log = Log::default();
        let mut a = axes(&log, 1000);
        // 1 mm = 1000 steps in one tick: 64 now, the rest on later ticks.
        a.update(mm(1.0, 0.0, 0.0));
        assert_eq!(a.steps()[0], MAX_STEPS_PER_TICK as i64);
        assert_eq!(a.lag_events(), 1);
        for _ in 0..20 {
            a.update(mm(1.0, 0.0, 0.0));
        }
        assert_eq!(a.steps()[0], 1000);
        assert_eq!(replay(&log)[0], 1000);
    }
}
