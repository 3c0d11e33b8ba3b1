//! Njiri et al.'s control law: the force errors of section II.A in, the
//! FRPO of the controller turned into a feed override (absolute or
//! incremental, module docs), and the per-revolution peak window.

use super::data::NjiriController;
use crate::fuzzy::FuzzyInference;
use crate::units::Fx;

/// A force in newtons, Q16.16 (±32767 N, resolution 15 µN).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ForceN(pub Fx);

impl ForceN {
    /// From newtons as `f64` (saturating; NaN gives 0).
    pub fn from_f64(v: f64) -> Self {
        if v.is_nan() {
            return ForceN(Fx::ZERO);
        }
        ForceN(Fx::saturating_from_num(v))
    }

    /// The value in newtons.
    pub fn to_f64(self) -> f64 {
        self.0.to_num()
    }
}

/// A feed override in percent of the programmed feed, Q16.16.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct OverridePct(pub Fx);

impl OverridePct {
    /// 100 %: the programmed feed.
    pub const PROGRAMMED: OverridePct = OverridePct(Fx::lit("100"));
    /// The lower end of the FRPO range, 0 %.
    pub const MIN: OverridePct = OverridePct(Fx::ZERO);
    /// The upper end of the FRPO range, 150 %.
    pub const MAX: OverridePct = OverridePct(Fx::lit("150"));

    /// The value in percent.
    pub fn to_f64(self) -> f64 {
        self.0.to_num()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ForceN {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=f32} N", self.0.to_num::<f32>())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for OverridePct {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=f32} %", self.0.to_num::<f32>())
    }
}

/// How the controller's FRPO becomes the feed override (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OverrideLaw {
    /// The paper's sentence taken literally: override = FRPO.
    Absolute,
    /// Velocity form: `override += gain · (FRPO − 100 %)`, clamped to
    /// 0-150 %.
    Incremental {
        /// Fraction of the FRPO's departure from 100 % applied per step,
        /// in `(0, 1]`.
        gain: Fx,
    },
}

/// Settings of [`ForceOverride`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OverrideConfig {
    /// Reference peak forces `[F_x, F_y]` (section III.A: 120 N and 40 N).
    pub reference: [ForceN; 2],
    /// How FRPO drives the override.
    pub law: OverrideLaw,
    /// The override before the first step (and after [`ForceOverride::reset`]).
    pub initial: OverridePct,
}

impl OverrideConfig {
    /// The paper's references, the incremental law with gain 0.05, starting
    /// at the programmed feed.
    pub const PAPER: OverrideConfig = OverrideConfig {
        reference: [ForceN(Fx::lit("120")), ForceN(Fx::lit("40"))],
        law: OverrideLaw::Incremental {
            gain: Fx::lit("0.05"),
        },
        initial: OverridePct::PROGRAMMED,
    };

    /// Check the settings.
    pub fn validate(&self) -> Result<(), OverrideError> {
        if self.reference.iter().any(|r| r.0 <= Fx::ZERO) {
            return Err(OverrideError::BadReference);
        }
        if let OverrideLaw::Incremental { gain } = self.law {
            if gain <= Fx::ZERO || gain > Fx::ONE {
                return Err(OverrideError::BadGain);
            }
        }
        if self.initial < OverridePct::MIN || self.initial > OverridePct::MAX {
            return Err(OverrideError::BadInitial);
        }
        Ok(())
    }
}

impl Default for OverrideConfig {
    fn default() -> Self {
        Self::PAPER
    }
}

/// Why an [`OverrideConfig`] is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum OverrideError {
    /// A reference force is not positive.
    BadReference,
    /// The incremental gain is outside `(0, 1]`.
    BadGain,
    /// The initial override is outside 0-150 %.
    BadInitial,
}

impl core::fmt::Display for OverrideError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            OverrideError::BadReference => "reference peak forces must be positive",
            OverrideError::BadGain => "incremental gain must be in (0, 1]",
            OverrideError::BadInitial => "initial override must be within 0-150 %",
        })
    }
}

/// What one step saw and decided (for logs and plots).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepTrace {
    /// Controller inputs ΔX, Δ²X, ΔY, Δ²Y in N, before clamping to ±1.5 N.
    pub inputs: [Fx; 4],
    /// The controller's crisp output (FRPO), %.
    pub frpo: OverridePct,
    /// The override after this step, %.
    pub override_pct: OverridePct,
}

/// The closed-loop override: feed it the peak forces of each revolution,
/// apply the returned override to the programmed feed. `no_std`, no
/// allocation, no panics. It holds its controller's scratch: the centroid's
/// samples on [`CONTROLLER`](super::CONTROLLER), the consequents' strengths on
/// [`COMPACT`](super::COMPACT).
#[derive(Clone, Debug)]
pub struct ForceOverride<'c, C: FuzzyInference<4> = NjiriController> {
    controller: &'c C,
    config: OverrideConfig,
    scratch: C::Scratch,
    previous_error: Option<[Fx; 2]>,
    override_pct: OverridePct,
    last: StepTrace,
}

impl<'c, C: FuzzyInference<4>> ForceOverride<'c, C> {
    /// A controller with `config` (checked) on `controller` (normally
    /// [`CONTROLLER`](super::CONTROLLER), or [`COMPACT`](super::COMPACT) in a firmware).
    pub fn new(controller: &'c C, config: OverrideConfig) -> Result<Self, OverrideError> {
        config.validate()?;
        Ok(ForceOverride {
            controller,
            config,
            scratch: C::Scratch::default(),
            previous_error: None,
            override_pct: config.initial,
            last: StepTrace::default(),
        })
    }

    /// The settings.
    pub fn config(&self) -> &OverrideConfig {
        &self.config
    }

    /// The current override, %.
    pub fn override_pct(&self) -> OverridePct {
        self.override_pct
    }

    /// What the last step saw and decided.
    pub fn last_step(&self) -> StepTrace {
        self.last
    }

    /// Forget the history: the next step has Δ² = 0 and the override is the
    /// initial one again.
    pub fn reset(&mut self) {
        self.previous_error = None;
        self.override_pct = self.config.initial;
        self.last = StepTrace::default();
    }

    /// One sampling interval: `peak` = measured peak forces `[F_x, F_y]` of
    /// the last revolution (magnitudes, N). Returns the override to apply, %
    /// (always within 0-150 %).
    pub fn step(&mut self, peak: [ForceN; 2]) -> OverridePct {
        let r = self.config.reference;
        // Section II.A: ΔX = F_Xref − F_X, Δ²X = ΔX(k+1) − ΔX(k).
        let e = [
            r[0].0.saturating_sub(peak[0].0),
            r[1].0.saturating_sub(peak[1].0),
        ];
        let de = match self.previous_error {
            Some(p) => [e[0].saturating_sub(p[0]), e[1].saturating_sub(p[1])],
            None => [Fx::ZERO; 2],
        };
        self.previous_error = Some(e);
        let inputs = [e[0], de[0], e[1], de[1]];
        let frpo = self
            .controller
            .infer(&mut self.scratch, inputs)
            .output
            .clamp(OverridePct::MIN.0, OverridePct::MAX.0);
        let next = match self.config.law {
            OverrideLaw::Absolute => frpo,
            OverrideLaw::Incremental { gain } => {
                let change = gain.saturating_mul(frpo - OverridePct::PROGRAMMED.0);
                self.override_pct.0.saturating_add(change)
            }
        }
        .clamp(OverridePct::MIN.0, OverridePct::MAX.0);
        self.override_pct = OverridePct(next);
        self.last = StepTrace {
            inputs,
            frpo: OverridePct(frpo),
            override_pct: self.override_pct,
        };
        self.override_pct
    }
}

/// Peak force magnitudes over a window of raw samples (one spindle
/// revolution): what [`ForceOverride::step`] takes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PeakWindow {
    peak: [Fx; 2],
    samples: u32,
}

impl PeakWindow {
    /// An empty window.
    pub const fn new() -> Self {
        PeakWindow {
            peak: [Fx::ZERO; 2],
            samples: 0,
        }
    }

    /// Add one sample `[F_x, F_y]` (signed, N).
    pub fn push(&mut self, f: [ForceN; 2]) {
        for (p, v) in self.peak.iter_mut().zip(f) {
            *p = (*p).max(v.0.saturating_abs());
        }
        self.samples = self.samples.saturating_add(1);
    }

    /// Number of samples since the last [`Self::take`].
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// The peak magnitudes and an empty window; `None` if no sample came.
    pub fn take(&mut self) -> Option<[ForceN; 2]> {
        let out = (self.samples > 0).then_some([ForceN(self.peak[0]), ForceN(self.peak[1])]);
        *self = PeakWindow::new();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::super::data::{COMPACT, CONTROLLER};
    use super::*;

    fn step_all(c: &mut ForceOverride<'_>, fx: f64, fy: f64) -> f64 {
        c.step([ForceN::from_f64(fx), ForceN::from_f64(fy)])
            .to_f64()
    }

    #[test]
    fn incremental_law_reduces_on_excess_and_holds_at_reference() {
        let mut c = ForceOverride::new(&CONTROLLER, OverrideConfig::PAPER).unwrap();
        assert_eq!(step_all(&mut c, 120.0, 40.0), 100.0);
        assert_eq!(step_all(&mut c, 120.0, 40.0), 100.0);
        let o = step_all(&mut c, 150.0, 50.0);
        assert!(o < 96.0, "{o}");
        let t = c.last_step();
        assert_eq!(t.inputs[0], Fx::from_num(-30));
        assert_eq!(t.inputs[1], Fx::from_num(-30));
        // Far below: increases, but never beyond 150 %.
        for _ in 0..200 {
            step_all(&mut c, 10.0, 5.0);
        }
        assert_eq!(c.override_pct(), OverridePct::MAX);
        c.reset();
        assert_eq!(c.override_pct(), OverridePct::PROGRAMMED);
    }

    /// The override loop on the firmware's compact controller steps through
    /// the same values as on [`CONTROLLER`].
    #[test]
    fn compact_controller_gives_the_same_override() {
        let mut big = ForceOverride::new(&CONTROLLER, OverrideConfig::PAPER).unwrap();
        let mut small = ForceOverride::new(&COMPACT, OverrideConfig::PAPER).unwrap();
        assert!(core::mem::size_of_val(&small) < 100);
        for k in 0..300 {
            let f = [
                ForceN::from_f64(100.0 + (k % 37) as f64 * 1.3),
                ForceN::from_f64(35.0 + (k % 11) as f64 * 0.9),
            ];
            assert_eq!(big.step(f), small.step(f), "step {k}");
        }
    }

    #[test]
    fn absolute_law_is_the_frpo() {
        let cfg = OverrideConfig {
            law: OverrideLaw::Absolute,
            ..OverrideConfig::PAPER
        };
        let mut c = ForceOverride::new(&CONTROLLER, cfg).unwrap();
        // First step (Δ² = 0): ΔX, ΔY Ne, Δ²X, Δ²Y Ze: NM.
        let o = step_all(&mut c, 125.0, 45.0);
        assert_eq!(o, c.last_step().frpo.to_f64());
        assert!(o > 30.0 && o < 80.0, "{o}");
        // Rising further: all Ne, NS.
        assert!(step_all(&mut c, 135.0, 55.0) < 15.0);
    }

    #[test]
    fn bad_settings_are_refused() {
        let p = OverrideConfig::PAPER;
        let bad = [
            OverrideConfig {
                reference: [ForceN(Fx::ZERO), ForceN(Fx::ONE)],
                ..p
            },
            OverrideConfig {
                law: OverrideLaw::Incremental { gain: Fx::ZERO },
                ..p
            },
            OverrideConfig {
                law: OverrideLaw::Incremental {
                    gain: Fx::from_num(2),
                },
                ..p
            },
            OverrideConfig {
                initial: OverridePct(Fx::from_num(151)),
                ..p
            },
        ];
        for b in bad {
            assert!(ForceOverride::new(&CONTROLLER, b).is_err(), "{b:?}");
        }
    }

    #[test]
    fn peak_window() {
        let mut w = PeakWindow::new();
        assert_eq!(w.take(), None);
        for (x, y) in [(10.0, -3.0), (-120.5, 2.0), (60.0, 41.0)] {
            w.push([ForceN::from_f64(x), ForceN::from_f64(y)]);
        }
        assert_eq!(w.samples(), 3);
        assert_eq!(
            w.take(),
            Some([ForceN::from_f64(120.5), ForceN::from_f64(41.0)])
        );
        assert_eq!(w.samples(), 0);
        w.push([ForceN(Fx::MIN), ForceN(Fx::ZERO)]);
        assert_eq!(w.take().unwrap()[0].0, Fx::MAX);
    }
}
