//! Njiri, Ikua & Nyakoe's force-feedback feed override in a closed loop
//! (section III.B, Figures 12-13): fuzzy-core's controller
//! ([`fuzzy_core::njiri`], the firmware's code) sets the feed override once
//! per spindle revolution from the peak forces of the last revolution; the
//! machine applies it through its acc/dec; a ball-end milling force model
//! ([`force_model`]) turns the feed per tooth and the depth of cut into the
//! next revolution's peak forces.
//!
//! ```text
//!  F_ref ─► ΔX, Δ²X, ΔY, Δ²Y ─► fuzzy FRPO ─► override law ─► feed = 30 mm/min × override
//!    ▲                                                               │ linear acc/dec (64 ms)
//!    └──────── peak F_x, F_y of the revolution ◄── force model ◄── feed per tooth, depth
//! ```
//!
//! The experiment: programmed feed 30 mm/min (0.1 mm/tooth at 300 min⁻¹,
//! one flute), reference peaks F_x = 120 N, F_y = 40 N, radial depth of cut
//! stepped from 1.0 to 1.5 mm where the tool is after 1 s (Fig. 12: "after
//! 1 second"). The paper measures the override settling at about 78 %
//! (23.4 mm/min) with the peak force held at about 120 N.
//!
//! Timing: the controller runs at the end of each revolution (0.2 s) on
//! that revolution's peaks and its override takes effect from the next one
//! (LabVIEW → CNC: one sample of delay); the feed follows the commanded
//! feed through FANUC's linear acc/dec after interpolation (a moving average
//! over parameter 1622, 64 ms, as [`crate::machine::accdec`]), simulated
//! every 1 ms. Every 1 ms the force model gives the force at the current
//! spindle angle for the current feed per tooth (axis speed × tooth
//! period) and depth; [`fuzzy_core::njiri::PeakWindow`] (the firmware's
//! code) collects the revolution's peaks, as it would from a dynamometer.
//!
//! Not here: the firmware side (the force arriving over the link and the
//! override applied by the firmware's motion loop), which is the firmware's.

pub mod command;
pub mod force_model;

use anyhow::{ensure, Result};
use fuzzy_core::njiri::{
    ForceN, ForceOverride, OverrideConfig, OverrideLaw, PeakWindow, CONTROLLER,
};
use fuzzy_core::units::Fx;

use force_model::ForceModel;

/// The experiment's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Experiment {
    /// The cutting-force model (calibrated).
    pub model: ForceModel,
    /// The controller's settings (references, override law).
    pub control: OverrideConfig,
    /// Whether the controller is on (off: Fig. 12, constant feed).
    pub controlled: bool,
    /// Programmed feed, mm/min (paper: 30).
    pub programmed_feed_mm_per_min: f64,
    /// Spindle speed, min⁻¹ (Table II: 300).
    pub spindle_rpm: f64,
    /// Depth of cut before the step, mm (1.0).
    pub depth_before_mm: f64,
    /// Depth of cut after the step, mm (1.5).
    pub depth_after_mm: f64,
    /// Where the depth steps: the position reached after this time at the
    /// programmed feed, s (1).
    pub step_after_s: f64,
    /// Simulated time, s.
    pub duration_s: f64,
    /// Linear acc/dec after interpolation (FANUC 1622), ms.
    pub accdec_ms: f64,
    /// Peak-to-peak measurement noise added to each peak force, N
    /// (deterministic pseudo-random; 0 = none).
    pub noise_n: f64,
}

impl Experiment {
    /// Section III.B with the paper's numbers and this crate's choices.
    pub fn paper() -> Result<Self> {
        Ok(Experiment {
            model: ForceModel::paper(),
            control: OverrideConfig::PAPER,
            controlled: true,
            programmed_feed_mm_per_min: 30.0,
            spindle_rpm: 300.0,
            depth_before_mm: 1.0,
            depth_after_mm: 1.5,
            step_after_s: 1.0,
            duration_s: 20.0,
            accdec_ms: 64.0,
            noise_n: 0.0,
        })
    }

    /// Check the settings.
    pub fn validate(&self) -> Result<()> {
        self.model.validate()?;
        self.control
            .validate()
            .map_err(|e| anyhow::anyhow!("controller: {e}"))?;
        let pos = |v: f64| v.is_finite() && v > 0.0;
        ensure!(
            pos(self.programmed_feed_mm_per_min) && self.programmed_feed_mm_per_min <= 1e5,
            "programmed feed must be in (0, 1e5] mm/min"
        );
        ensure!(
            pos(self.spindle_rpm) && self.spindle_rpm <= 1e5,
            "spindle speed must be in (0, 1e5] min⁻¹"
        );
        ensure!(
            [self.depth_before_mm, self.depth_after_mm]
                .iter()
                .all(|d| d.is_finite() && *d >= 0.0 && *d <= self.model.ball_radius_mm),
            "depths of cut must be within [0, ball radius]"
        );
        ensure!(
            self.step_after_s.is_finite() && self.step_after_s >= 0.0,
            "step time must be ≥ 0 s"
        );
        ensure!(
            pos(self.duration_s) && self.duration_s <= 3600.0,
            "duration must be in (0, 3600] s"
        );
        ensure!(
            self.accdec_ms.is_finite() && (0.0..=10_000.0).contains(&self.accdec_ms),
            "acc/dec time constant must be in [0, 10000] ms"
        );
        ensure!(
            self.noise_n.is_finite() && self.noise_n >= 0.0,
            "noise must be ≥ 0 N"
        );
        Ok(())
    }
}

/// One spindle revolution of the closed loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Revolution {
    /// Time at the end of the revolution, s.
    pub t_s: f64,
    /// Tool position along the feed at the end, mm.
    pub x_mm: f64,
    /// Depth of cut during the revolution, mm.
    pub depth_mm: f64,
    /// Mean feed during the revolution, mm/min.
    pub feed_mm_per_min: f64,
    /// Peak |F_x|, |F_y| measured, N.
    pub peak_n: [f64; 2],
    /// The controller's FRPO, %.
    pub frpo_pct: f64,
    /// The override commanded for the next revolution, %.
    pub override_pct: f64,
}

/// A run and its summary.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// Every revolution.
    pub revolutions: Vec<Revolution>,
    /// Summary of the last quarter of the run (after the step).
    pub settled: Settled,
    /// Peaks of the last revolution before the step.
    pub before_step: Option<Revolution>,
}

/// Means and spreads over the settled part of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settled {
    /// From this time on, s.
    pub from_s: f64,
    /// Mean override, %.
    pub override_pct: f64,
    /// Smallest and largest override, %.
    pub override_range_pct: (f64, f64),
    /// Mean feed, mm/min.
    pub feed_mm_per_min: f64,
    /// Mean peak F_x, F_y, N.
    pub peak_n: [f64; 2],
    /// Largest peak F_x, F_y, N.
    pub peak_max_n: [f64; 2],
    /// First time after the step from which the override stays within 1 %
    /// (of full scale) of its final mean, s (`None`: never).
    pub settling_time_s: Option<f64>,
}

/// A small deterministic noise source (xorshift), uniform in ±`amp`/2.
struct Noise {
    state: u64,
    amp: f64,
}

impl Noise {
    fn next(&mut self) -> f64 {
        if self.amp == 0.0 {
            return 0.0;
        }
        self.state ^= self.state << 13;
        self.state ^= self.state >> 7;
        self.state ^= self.state << 17;
        ((self.state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * self.amp
    }
}

/// Run the experiment.
pub fn run(exp: &Experiment) -> Result<Outcome> {
    exp.validate()?;
    let mut ctrl = ForceOverride::new(&CONTROLLER, exp.control)
        .map_err(|e| anyhow::anyhow!("controller: {e}"))?;
    let ts = 0.001;
    let rev_s = 60.0 / exp.spindle_rpm;
    let steps_per_rev = ((rev_s / ts).round() as usize).max(1);
    let n_avg = ((exp.accdec_ms / 1000.0 / ts).round() as usize).max(1);
    let x_step = exp.programmed_feed_mm_per_min / 60.0 * exp.step_after_s;
    let revs = (exp.duration_s / rev_s).ceil() as usize;
    // Linear acc/dec: the axis velocity is the moving average of the
    // commanded velocity over n_avg samples (running sum).
    let mut window = vec![exp.programmed_feed_mm_per_min / 60.0; n_avg];
    let mut sum: f64 = window.iter().sum();
    let mut head = 0;
    let mut noise = Noise {
        state: 0x9E37_79B9_7F4A_7C15,
        amp: exp.noise_n,
    };
    let mut peaks = PeakWindow::new();
    let tooth_s = rev_s / exp.model.flutes as f64;
    let omega = 2.0 * std::f64::consts::PI / rev_s;
    let mut override_pct = exp.control.initial.to_f64();
    let (mut x, mut t) = (0.0f64, 0.0f64);
    let mut out = Vec::with_capacity(revs);
    for _ in 0..revs {
        let commanded = exp.programmed_feed_mm_per_min / 60.0
            * if exp.controlled {
                override_pct / 100.0
            } else {
                1.0
            };
        let x0 = x;
        let mut depth = exp.depth_before_mm;
        for _ in 0..steps_per_rev {
            sum += commanded - window[head];
            window[head] = commanded;
            head = (head + 1) % n_avg;
            let v = sum / n_avg as f64; // mm/s
            x += v * ts;
            t += ts;
            // The deeper cut once the tool has reached the step.
            if x >= x_step {
                depth = exp.depth_after_mm;
            }
            let f_t = v * tooth_s;
            let (fx, fy) = exp.model.sample(omega * t, f_t, depth);
            peaks.push([ForceN::from_f64(fx), ForceN::from_f64(fy)]);
        }
        let feed_per_rev = x - x0;
        let p = peaks
            .take()
            .map_or([0.0; 2], |p| [p[0].to_f64(), p[1].to_f64()]);
        let peak = [
            (p[0] + noise.next()).max(0.0),
            (p[1] + noise.next()).max(0.0),
        ];
        let (frpo, next) = if exp.controlled {
            let o = ctrl.step([ForceN::from_f64(peak[0]), ForceN::from_f64(peak[1])]);
            (ctrl.last_step().frpo.to_f64(), o.to_f64())
        } else {
            (100.0, 100.0)
        };
        override_pct = next;
        out.push(Revolution {
            t_s: t,
            x_mm: x,
            depth_mm: depth,
            feed_mm_per_min: feed_per_rev / rev_s * 60.0,
            peak_n: peak,
            frpo_pct: frpo,
            override_pct: next,
        });
    }
    let before_step = out
        .iter()
        .take_while(|r| r.depth_mm == exp.depth_before_mm)
        .last()
        .copied();
    let settled = summarise(&out, exp.duration_s * 0.75, exp.step_after_s);
    Ok(Outcome {
        revolutions: out,
        settled,
        before_step,
    })
}

fn summarise(revs: &[Revolution], from_s: f64, step_s: f64) -> Settled {
    let tail: Vec<&Revolution> = revs.iter().filter(|r| r.t_s >= from_s).collect();
    let n = tail.len().max(1) as f64;
    let mean = |f: &dyn Fn(&Revolution) -> f64| tail.iter().map(|r| f(r)).sum::<f64>() / n;
    let max = |f: &dyn Fn(&Revolution) -> f64| tail.iter().map(|r| f(r)).fold(0.0, f64::max);
    let o = mean(&|r| r.override_pct);
    let lo = tail
        .iter()
        .map(|r| r.override_pct)
        .fold(f64::INFINITY, f64::min);
    let hi = max(&|r| r.override_pct);
    // Settling: the last revolution outside ±1 % of the mean (150 % scale).
    let band = 1.5;
    let last_out = revs.iter().rposition(|r| (r.override_pct - o).abs() > band);
    let settling_time_s = match last_out {
        None => Some(0.0),
        Some(i) if i + 1 < revs.len() => Some((revs[i + 1].t_s - step_s).max(0.0)),
        Some(_) => None,
    };
    Settled {
        from_s,
        override_pct: o,
        override_range_pct: (lo, hi),
        feed_mm_per_min: mean(&|r| r.feed_mm_per_min),
        peak_n: [mean(&|r| r.peak_n[0]), mean(&|r| r.peak_n[1])],
        peak_max_n: [max(&|r| r.peak_n[0]), max(&|r| r.peak_n[1])],
        settling_time_s,
    }
}

/// The override law from its command-line name and gain.
pub fn law(absolute: bool, gain: f64) -> Result<OverrideLaw> {
    if absolute {
        return Ok(OverrideLaw::Absolute);
    }
    ensure!(
        gain.is_finite() && gain > 0.0 && gain <= 1.0,
        "gain must be in (0, 1]"
    );
    Ok(OverrideLaw::Incremental {
        gain: Fx::from_num(gain),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn without_control_the_step_raises_the_force() {
        let exp = Experiment {
            controlled: false,
            duration_s: 3.0,
            ..Experiment::paper().unwrap()
        };
        let o = run(&exp).unwrap();
        let before = o.before_step.unwrap();
        assert!((before.peak_n[0] - 120.0).abs() < 0.5, "{before:?}");
        assert!((before.peak_n[1] - 40.0).abs() < 0.5, "{before:?}");
        let last = o.revolutions.last().unwrap();
        assert!(last.peak_n[0] > 130.0, "{last:?}");
        assert!((last.feed_mm_per_min - 30.0).abs() < 1e-9);
    }

    #[test]
    fn paper_experiment_settles_near_78_percent_holding_the_force() {
        let o = run(&Experiment::paper().unwrap()).unwrap();
        let s = o.settled;
        assert!((s.override_pct - 78.0).abs() < 3.0, "{s:?}");
        assert!(
            s.override_range_pct.1 - s.override_range_pct.0 < 3.0,
            "{s:?}"
        );
        assert!((s.peak_n[0] - 120.0).abs() < 2.0, "{s:?}");
        assert!((s.peak_n[1] - 40.0).abs() < 1.0, "{s:?}");
        assert!(s.settling_time_s.is_some_and(|t| t < 10.0), "{s:?}");
        // Before the step the loop sits at the programmed feed.
        let b = o.before_step.unwrap();
        assert!((b.override_pct - 100.0).abs() < 1.0, "{b:?}");
    }

    #[test]
    fn absolute_law_does_not_settle() {
        let exp = Experiment {
            control: OverrideConfig {
                law: OverrideLaw::Absolute,
                ..OverrideConfig::PAPER
            },
            ..Experiment::paper().unwrap()
        };
        let s = run(&exp).unwrap().settled;
        assert!(
            s.override_range_pct.1 - s.override_range_pct.0 > 20.0,
            "{s:?}"
        );
    }
}
