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

use crate::config::MAX_STEPS_PER_TICK;

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
    forward: bool,
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
                forward: true,
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
            if forward != axis.forward {
                // Pin errors cannot be reported from a tick: the board's
                // pins are infallible (`Infallible`), others are ignored.
                let _ = if forward {
                    axis.dir.set_high()
                } else {
                    axis.dir.set_low()
                };
                axis.forward = forward;
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
