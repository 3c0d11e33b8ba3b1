//! The planner's tick stream on the simulated machines.
//!
//! The planner emits one commanded position per interpolation period,
//! already acceleration- and jerk-limited: it *is* the control's
//! interpolator and its acc/dec **before** interpolation. What a control
//! does **after** interpolation (between the interpolator and the servos)
//! stays. So on each machine:
//!
//! | machine | the other methods (feeds per block) | fuzzy + planner (tick stream) |
//! |---|---|---|
//! | FANUC-like, conventional | interpolation → linear acc/dec 1622 (64 ms) | ticks → linear acc/dec 1622 (64 ms) |
//! | FANUC-like, high accuracy | corner rule 1783, acc/dec 1660, bell 1772 → interpolation → acc/dec 1769 (11 ms) | ticks → acc/dec 1769 (11 ms); 1783/1660/1772 are replaced by the planner (planning the planned stream again would treat every tick as a block) |
//! | X-Y servo | interpolation → linear acc/dec (64 ms) → servo | ticks → linear acc/dec (64 ms) → servo |
//!
//! The after-interpolation filter of the conventional mode is a 64 ms moving
//! average of every axis: on a jerk-limited stream it adds nothing the
//! planner has not already limited (it cannot raise a peak acceleration),
//! but it still cuts curves (`≈ v²T²κ/24`) and delays the end by `T`,
//! exactly as for the other methods: the comparison isolates what the
//! planner changes in the commanded stream. That is how a planner outside
//! the control (a PC streaming 1 ms positions) meets an unchanged FANUC; a
//! planner inside the control is the high-accuracy row (FANUC itself
//! switches from 1622 to the short 1769 when acc/dec before interpolation
//! is on).
//!
//! **Limits.** The `[planner]` limits describe the simulated machine. The
//! defaults agree with it: per-axis acceleration 2000 mm/s² = parameter
//! 1660 (and the chord-error method's `A`), δ = 1 µm = the chord-error
//! method's and the G-code reader's tolerance, tick = interpolation period
//! (enforced). [`limit_notes`] lists where the planner's limits exceed the
//! machine's: 1660 on the FANUC-like machine; on the X-Y servo, the
//! acceleration its current limit allows, `(K_t·I_max − F_c)/J` through the
//! lead.

use crate::config::SimConfig;
use crate::experiments::dat_phuc2024::fanuc::FanucMode;
use crate::machine::accdec::{self, AccDecKind};
use crate::machine::{MachineConfig, Motion};

/// The machine following `commanded` (positions every `ts_s` from `t = 0`,
/// the last one where the tool ends).
pub fn follow(machine: &MachineConfig, commanded: Vec<[f64; 3]>, ts_s: f64) -> Motion {
    let actual = match machine {
        MachineConfig::Fanuc(f) => {
            let t_ms = match f.mode {
                FanucMode::Conventional => f.p1622_time_constant_ms,
                FanucMode::HighAccuracy => f.p1769_time_constant_ms,
            };
            accdec::filter(f.after_interpolation, &commanded, ts_s, t_ms / 1000.0)
        }
        MachineConfig::ServoXy(s) => {
            if s.accdec_time_constant_ms > 0.0 {
                let r = accdec::filter(
                    AccDecKind::Linear,
                    &commanded,
                    ts_s,
                    s.accdec_time_constant_ms / 1000.0,
                );
                s.track(&r, ts_s)
            } else {
                s.track(&commanded, ts_s)
            }
        }
    };
    Motion::padded(ts_s, commanded, actual)
}

/// Per-axis acceleration the simulated machine allows, mm/s² (`None`: no
/// such limit in the model).
pub fn machine_accel_mm_per_s2(machine: &MachineConfig) -> Option<[f64; 3]> {
    match machine {
        MachineConfig::Fanuc(f) => Some(f.p1660_max_acceleration_mm_per_s2),
        MachineConfig::ServoXy(s) => {
            let mm_per_rad = s.lead_mm / std::f64::consts::TAU;
            let axis = |a: &crate::experiments::cho::servo_xy::AxisParams| {
                let torque = a.torque_constant_n_m_per_a * s.current_limit_a - a.coulomb_n_m;
                (torque / a.inertia_kg_m2 * mm_per_rad).max(0.0)
            };
            // Z uses Y's parameters (servo_xy module docs).
            Some([axis(&s.x), axis(&s.y), axis(&s.y)])
        }
    }
}

/// Where the planner's limits exceed the simulated machine's (empty when
/// consistent).
pub fn limit_notes(config: &SimConfig) -> Vec<String> {
    let mut notes = Vec::new();
    let p = &config.planner;
    if let Some(a) = machine_accel_mm_per_s2(&config.machine) {
        let what = match config.machine {
            MachineConfig::Fanuc(_) => "parameter 1660",
            MachineConfig::ServoXy(_) => "the servo's current-limited acceleration",
        };
        for (k, axis) in ["X", "Y", "Z"].iter().enumerate() {
            let planned = p.axis_accel_max_mm_per_s2[k] as f64;
            if planned > a[k] + 1e-9 {
                notes.push(format!(
                    "planner.axis_accel_max_mm_per_s2 {axis} = {planned} mm/s² exceeds {what} ({:.0} mm/s²)",
                    a[k]
                ));
            }
        }
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiments::dat_phuc2024::fanuc::FanucConfig;

    #[test]
    fn the_defaults_agree_with_the_fanuc_machine_and_not_with_the_servo() {
        assert!(limit_notes(&SimConfig::default()).is_empty());
        let servo = SimConfig {
            machine: MachineConfig::ServoXy(Default::default()),
            ..Default::default()
        };
        let a = machine_accel_mm_per_s2(&servo.machine).unwrap();
        // (1.2054·10 − 0.2)/0.0103 rad/s² × 10/2π mm/rad.
        assert!((a[0] - 1831.7).abs() < 1.0, "{a:?}");
        assert_eq!(limit_notes(&servo).len(), 3);
    }

    #[test]
    fn a_stream_through_linear_acc_dec_arrives_t_later() {
        let commanded: Vec<[f64; 3]> = (0..=100).map(|k| [k as f64 * 0.01, 0.0, 0.0]).collect();
        let m = follow(
            &MachineConfig::Fanuc(FanucConfig::default()),
            commanded,
            0.001,
        );
        assert_eq!(m.actual.len(), 101 + 63);
        assert_eq!(m.commanded.len(), m.actual.len());
        assert_eq!(*m.actual.last().unwrap(), [1.0, 0.0, 0.0]);
        let hi = MachineConfig::Fanuc(FanucConfig {
            mode: FanucMode::HighAccuracy,
            ..Default::default()
        });
        let m = follow(
            &hi,
            (0..=100).map(|k| [k as f64, 0.0, 0.0]).collect(),
            0.001,
        );
        assert_eq!(m.actual.len(), 101 + 10);
    }
}
