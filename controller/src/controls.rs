//! Feed hold, resume, feed override and force samples: what the link asks
//! of the motion outside the path's order, and Njiri et al.'s force loop
//! that turns force samples into an override.

use fuzzy_core::njiri::{self, ForceN, ForceOverride, NjiriCompact, OverrideConfig, OverrideError};
use fuzzy_core::units::Fx;

/// Feed hold, resume and override requests and force samples from the
/// link, taken by the background at its next pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Controls {
    /// `Some(true)`: hold; `Some(false)`: resume.
    pub hold: Option<bool>,
    /// New feed override, percent (already range-checked).
    pub override_percent: Option<u16>,
    /// New spindle speed override, percent (already range-checked).
    pub spindle_percent: Option<u16>,
    /// Peak forces `[F_x, F_y]` of the last revolution (non-negative,
    /// checked); a sample not yet taken is replaced by the next one.
    pub force: Option<[ForceN; 2]>,
}

/// Njiri et al.'s force-feedback override (`fuzzy_core::njiri`) as the
/// controller runs it: the paper's settings ([`OverrideConfig::PAPER`]) on
/// the compact controller ([`njiri::COMPACT`], same outputs as the host's),
/// one step per force sample; its output replaces the feed override.
/// Under 100 bytes.
pub struct ForceLoop(ForceOverride<'static, NjiriCompact>);

impl ForceLoop {
    /// At 100 %, no history.
    pub fn new() -> Result<Self, OverrideError> {
        ForceOverride::new(&njiri::COMPACT, OverrideConfig::PAPER).map(ForceLoop)
    }

    /// If `c` carries a force sample, step the controller and put its
    /// override, rounded to a percent and at least
    /// [`link::OVERRIDE_MIN_PERCENT`], in `c.override_percent` (it wins
    /// over a manual override taken in the same pass).
    pub fn apply(&mut self, c: &mut Controls) {
        if let Some(peak) = c.force.take() {
            let pct = self.0.step(peak).0.to_bits();
            // 0-150 % in Q16.16: rounded, within the planner's range.
            let p = ((pct.max(0) as u32 + 0x8000) >> 16) as u16;
            c.override_percent =
                Some(p.clamp(link::OVERRIDE_MIN_PERCENT, link::OVERRIDE_MAX_PERCENT));
        }
    }
}

/// A force sample from the link's raw fields (newtons, Q16.16 bits), if
/// both are magnitudes (non-negative).
pub fn force_from_link(fx_n_q16: i32, fy_n_q16: i32) -> Option<[ForceN; 2]> {
    (fx_n_q16 >= 0 && fy_n_q16 >= 0).then(|| {
        [
            ForceN(Fx::from_bits(fx_n_q16)),
            ForceN(Fx::from_bits(fy_n_q16)),
        ]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(fx: f64, fy: f64) -> Controls {
        Controls {
            force: force_from_link((fx * 65536.0) as i32, (fy * 65536.0) as i32),
            ..Controls::default()
        }
    }

    #[test]
    fn forces_above_the_references_lower_the_override_at_them_it_holds() {
        let mut l = ForceLoop::new().unwrap();
        let mut c = sample(120.0, 40.0);
        l.apply(&mut c);
        assert_eq!(c.override_percent, Some(100));
        assert_eq!(c.force, None, "the sample is used up");
        let mut last = 100;
        for _ in 0..5 {
            let mut c = sample(150.0, 50.0);
            l.apply(&mut c);
            let p = c.override_percent.unwrap();
            assert!(p < last, "{last} -> {p}");
            last = p;
        }
    }

    #[test]
    fn a_manual_override_passes_when_no_sample_came() {
        let mut l = ForceLoop::new().unwrap();
        let mut c = Controls {
            override_percent: Some(70),
            ..Controls::default()
        };
        l.apply(&mut c);
        assert_eq!(c.override_percent, Some(70));
    }

    #[test]
    fn negative_forces_are_refused() {
        assert!(force_from_link(-1, 0).is_none());
        assert!(force_from_link(0, i32::MIN).is_none());
        assert!(force_from_link(0, 0).is_some());
    }
}
